//! The Beckhoff TwinCAT CNC (ISG kernel) leadscrew error compensation renderer
//! ([`render`]).
//!
//! # TwinCAT CNC leadscrew error compensation (LSEC, `kw.ssfk.*`)
//!
//! Source: Beckhoff Information System, TF5200 TwinCAT 3 CNC "Axis compensation"
//! (infosys.beckhoff.com, `tf5200_axis_compensation` and
//! `tf5200_axis_compensation_parameters`): "Leadscrew error compensation", "Overview",
//! P-COMP-00017 to P-COMP-00025, P-COMP-00059 and "Example of a compensation value
//! list"; and `axiscompensation` (the same function, "Characteristics").
//!
//! LSEC changes the position setpoint of the axis by a compensation value in the
//! position-control cycle (and takes it out of the actual value again, so the display
//! is not affected). The compensation values are "absolute position errors" at
//! interpolation points, **linearly interpolated** between them. The table lives in the
//! axis' compensation value list (an ASCII file of `name value` lines; `#` starts a
//! comment line): the header `kopf.log_achs_nr`, `kopf.log_achs_name`, and `kw.ssfk.*`:
//!
//! | entry | meaning |
//! |---|---|
//! | `unit` (P-COMP-00017) | 1: lengths in 0.1 µm (0: increments) |
//! | `interval` (P-COMP-00018) | distance of equidistant points; 0: each point's `setpoint` is given |
//! | `kw_startpos` (P-COMP-00019) | the position where the table starts |
//! | `kw_nr_max` (P-COMP-00020) | the number of entries; it must be smaller than `max_points` (P-COMP-00059, default 1500) |
//! | `bilateral` (P-COMP-00021) | 0: one table for both directions; 1: `pos` and `neg` per direction |
//! | `modulo` (P-COMP-00022) | 0: linear axis |
//! | `table[i].setpoint` (P-COMP-00025) | the position of point i |
//! | `table[i].pos`, `table[i].neg` (P-COMP-00023/24) | the compensation value moving in the + / − direction |
//!
//! errmap writes `unit` 1, `interval` 0 and every `setpoint`, so any spacing works
//! (positions rounded to 0.1 µm; the value at a position moved by ≤ 0.05 µm changes by
//! slope × 0.05 µm, picometres). Without a reverse line `bilateral` is 0 and `neg`
//! repeats `pos`. LSEC is switched on in the axis parameters by P-AXIS-00175
//! `lr_param.ssfk` = 1; for a bilateral table P-AXIS-00243 `lr_param.n_backlash_cyc`
//! spreads the jump at a reversal over that many cycles. Both directions use the same
//! interpolation points, and outside the table the value at its nearer end is kept
//! (TwinCAT NC "Axis compensation", leadscrew error compensation, Characteristics).
//!
//! # Sign convention
//!
//! The documentation's example computes the value as Δs = s_actual − s_setpoint (measured
//! 19856.5 µm for the programmed 19866.7 µm gives `pos` = −102 × 0.1 µm). With errmap's
//! e = indicated − reference, the setpoint is the indicated position and the measured
//! one the reference, so the table holds c = −e, in 0.1 µm.

use super::{Controller, ExportError, Sampled, compensation_um, fmt_point};

/// The default of P-COMP-00059 `kw.ssfk.max_points` (and the fixed maximum before CNC
/// build V3.1.3079.06).
pub const ISG_DEFAULT_MAX_POINTS: usize = 1500;

/// The axis the list belongs to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IsgAxis {
    /// `kopf.log_achs_nr`, the logical axis number.
    pub number: u32,
    /// `kopf.log_achs_name`.
    pub name: String,
    /// P-COMP-00059 of the axis: `kw_nr_max` must be smaller.
    pub max_points: usize,
}

/// A length in mm as an integer number of 0.1 µm.
fn tenths_um(mm: f64) -> Result<i64, ExportError> {
    let v = (mm * 1e4).round();
    if v.is_nan() || v.abs() >= i32::MAX as f64 {
        return Err(ExportError::ControllerLimit {
            controller: Controller::Isg,
            problem: format!("{mm} mm is beyond the SGN32 range of 0.1 µm entries"),
        });
    }
    Ok(v as i64)
}

/// The `kw.ssfk` compensation value list for `forward` (and `reverse`, errors measured
/// moving in the negative direction at the same positions: a bilateral table).
pub fn render(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    axis: &IsgAxis,
) -> Result<String, ExportError> {
    let rev = super::paired(forward, reverse)?;
    let name_ok = !axis.name.is_empty()
        && axis.name.len() <= 32
        && axis
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if !name_ok {
        return Err(ExportError::ControllerLimit {
            controller: Controller::Isg,
            problem: format!(
                "axis name `{}` must be 1–32 letters, digits, `_` or `-`",
                axis.name
            ),
        });
    }
    let n = forward.len();
    if n >= axis.max_points {
        // kw_nr_max < max_points: at most max_points − 1 entries.
        return Err(ExportError::TooManyEntries {
            controller: Controller::Isg,
            samples: n,
            padding: 0,
            limit: axis.max_points.saturating_sub(1),
            length_mm: forward.length_mm(),
        });
    }
    let mut setpoints = Vec::with_capacity(n);
    for (i, &x) in forward.positions_mm.iter().enumerate() {
        let t = tenths_um(x)?;
        if let Some(&prev) = setpoints.last()
            && t <= prev
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: prev as f64 * 1e-4,
                position_mm: t as f64 * 1e-4,
            });
        }
        setpoints.push(t);
    }
    let values = |s: &Sampled| -> Result<Vec<i64>, ExportError> {
        s.error_um
            .iter()
            .map(|&e| tenths_um(compensation_um(e) * 1e-3))
            .collect()
    };
    let pos = values(forward)?;
    let neg = values(rev)?;
    let bilateral = reverse.is_some();
    let key = |k: &str| format!("{k:<36}");
    let mut out = String::with_capacity(n * 140 + 600);
    out.push_str("# errmap leadscrew error compensation (LSEC)\n");
    out.push_str(&format!(
        "# line along {} at {}; {n} points, {} extrapolated\n",
        forward.axis,
        fmt_point(forward.at_mm),
        forward.extrapolated_count()
    ));
    out.push_str(
        "# values: position error actual - setpoint = c = -e (e = indicated - reference), 0.1 um\n",
    );
    out.push_str(&format!(
        "# activate with P-AXIS-00175 lr_param.ssfk = 1; needs P-COMP-00059 kw.ssfk.max_points > {n}\n"
    ));
    out.push_str(&format!("{}{}\n", key("kopf.log_achs_nr"), axis.number));
    out.push_str(&format!("{}{}\n", key("kopf.log_achs_name"), axis.name));
    out.push_str(&format!("{}0\n", key("kw.ssfk.interval")));
    out.push_str(&format!("{}{}\n", key("kw.ssfk.kw_startpos"), setpoints[0]));
    out.push_str(&format!("{}{n}\n", key("kw.ssfk.kw_nr_max")));
    out.push_str(&format!("{}1\n", key("kw.ssfk.unit")));
    out.push_str(&format!(
        "{}{}\n",
        key("kw.ssfk.bilateral"),
        u8::from(bilateral)
    ));
    out.push_str(&format!("{}0\n", key("kw.ssfk.modulo")));
    for (field, list) in [("setpoint", &setpoints), ("pos", &pos), ("neg", &neg)] {
        for (i, v) in list.iter().enumerate() {
            out.push_str(&format!(
                "{}{v}\n",
                key(&format!("kw.ssfk.table[{i}].{field}"))
            ));
        }
    }
    Ok(out)
}
