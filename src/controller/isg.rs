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
//!
//! # Volumetric compensation: TwinCAT 3 CNC TF5280 / ISG `ISG_CSV` ([`render_volumetric`])
//!
//! What is sourced
//!
//! From the TF5280 documentation (Beckhoff Information System, `tf5280_volumetric_comp`;
//! the same pages in ISG's kernel documentation, isg-stuttgart.de `kernel-html`):
//!
//! * "ISG CSV format" (page 296429067): a header naming the columns — arguments and
//!   parameters — then one record per row; `//` starts a row comment; a line `#` is a
//!   "file break" after which a new header and its records follow. Component errors of
//!   the X axis have the header `X EXX EYX EZX EAX EBX ECX` (argument X, then the six
//!   ISO 230-1 component errors); the columns in the manual's examples are separated by
//!   blanks, as written here.
//! * "Units of measure" (page 296426379): parameter values in **millimetres** for
//!   offsets and **radians** for angles; the arguments X, Y, Z in millimetres.
//! * "Overview" (page 296386187): the model follows DIN ISO 230-1/-7 and ISO/TR 16907,
//!   serial kinematics with exactly three linear axes; only the tool position is
//!   compensated.
//! * "Workpiece axes" (page 296411019): `workpiece_axes`, default 0 = every axis on the
//!   tool side — errmap's model (workpiece on the base, the whole chain carries the
//!   tool). "Tool length" (page 296392971): by default the compensation is computed for
//!   tool length 0 — errmap's components are those of the tool reference point with probe
//!   offset 0, so no N0X/N0Y/N0Z is written.
//! * Configuration (pages 296390283, 1218769547): `file[j]` and `file_format[j] ISG_CSV`
//!   in the compensation list; axis assignment `X 1`, `Y 2`, `Z 3` by logical axis
//!   number (machine-specific — errmap does not write the list, only says what to set).
//!
//!
//! The tables come from `volumetric::component_tables`, which also says what is *not*
//! sourced (the squareness, folded into straightness) and how the file avoids it.

use super::TableSetting;
use super::read::{At, Field, Parsed, check_point, field_at, point};
use super::text::{Text, number};
use super::{
    AxisKind, Dialect, ExportFormat, Limits, SettingsError, Sign, Spacing, TableFormat,
    TableSettings, Value, ValueUnit,
};
use crate::base::Axis;
use crate::export::{ExportError, Sampled, fmt_point};
use crate::volumetric::{Component, ComponentTables};
use std::fmt::Write as _;

/// How the limit messages name this controller's table.
pub const LABEL: &str =
    "the TwinCAT CNC (ISG) leadscrew error compensation table (P-COMP-00059 kw.ssfk.max_points)";

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
            controller: LABEL,
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
    let rev = crate::export::paired(forward, reverse)?;
    let name_ok = !axis.name.is_empty()
        && axis.name.len() <= 32
        && axis
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if !name_ok {
        return Err(ExportError::ControllerLimit {
            controller: LABEL,
            problem: format!(
                "axis name `{}` must be 1–32 letters, digits, `_` or `-`",
                axis.name
            ),
        });
    }
    let n = forward.len();
    if n >= axis.max_points {
        // kw_nr_max < max_points: at most max_points − 1 entries.
        return Err(super::too_many(
            LABEL,
            forward,
            0,
            axis.max_points.saturating_sub(1),
            false,
        ));
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
            .map(|&e| tenths_um(VALUE.sign.of(e) * 1e-3))
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

// ---------------------------------------------------------------------------------------
// ISG

/// An ISG list value: its line, where it sits and its text.
type IsgEntry = (usize, Field, String);

/// An ISG list's `name value` pairs by name, with the last line (for "missing" messages).
struct IsgKeys {
    keys: std::collections::HashMap<String, IsgEntry>,
    last: usize,
}

impl IsgKeys {
    /// Collects the `name value` lines (comments skipped), refusing a malformed line and a
    /// name given twice.
    fn read(lines: &[(usize, &str)]) -> Result<IsgKeys, At> {
        let mut keys: std::collections::HashMap<String, IsgEntry> = Default::default();
        for (i, &(off, l)) in lines.iter().enumerate() {
            let line = i + 1;
            let body = l.split("/*").next().unwrap_or("");
            let t = body.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let mut it = t.split_whitespace();
            let (Some(key), Some(value), None) = (it.next(), it.next(), it.next()) else {
                return Err(At::new(line, format!("`{t}` is not `name value`")));
            };
            let start = off + body.find(key).unwrap_or(0) + key.len();
            let vstart = start + l[start - off..].find(value).unwrap_or(0);
            if keys
                .insert(
                    key.to_string(),
                    (line, field_at(vstart, value), value.to_string()),
                )
                .is_some()
            {
                return Err(At::new(line, format!("{key} given twice")));
            }
        }
        Ok(IsgKeys {
            keys,
            last: lines.len().max(1),
        })
    }

    /// The whole-number value of `key`, if given.
    fn int(&self, key: &str) -> Result<Option<(usize, Field, i64)>, At> {
        match self.keys.get(key) {
            None => Ok(None),
            Some((l, f, v)) => {
                let x = number(v)
                    .filter(|x| x.fract() == 0.0 && x.abs() < 1e15)
                    .ok_or_else(|| At::new(*l, format!("{key} `{v}` is not a whole number")))?;
                Ok(Some((*l, *f, x as i64)))
            }
        }
    }

    /// The whole-number value of a key every leadscrew list has.
    fn need(&self, key: &str) -> Result<(usize, Field, i64), At> {
        self.int(key)?.ok_or_else(|| {
            At::new(
                self.last,
                format!("no {key}: not a leadscrew compensation list"),
            )
        })
    }

    /// Refuses a table entry beyond the `n` entries of kw_nr_max (the first one by line).
    fn check_entries(&self, n: usize) -> Result<(), At> {
        let beyond = self
            .keys
            .iter()
            .filter(|(key, _)| {
                key.strip_prefix("kw.ssfk.table[").is_some_and(|rest| {
                    rest.split(']')
                        .next()
                        .and_then(|s| s.parse::<usize>().ok())
                        .is_none_or(|i| i >= n)
                })
            })
            .min_by_key(|(_, (l, ..))| *l);
        if let Some((key, (l, ..))) = beyond {
            return Err(At::new(
                *l,
                format!("{key}: beyond the kw_nr_max {n} entries"),
            ));
        }
        Ok(())
    }
}

/// A TwinCAT CNC (ISG) compensation value list: `name value` lines (`#` comment lines,
/// `/* … */` after a value), `kw.ssfk.unit` 1 (0.1 µm), points from `interval` and
/// `kw_startpos` or each `table[i].setpoint`, `table[i].pos` (and `neg`).
pub fn read(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let keys = IsgKeys::read(&lines)?;
    let last = keys.last;
    let (ul, _, unit) = keys.need("kw.ssfk.unit")?;
    if unit != 1 {
        return Err(At::new(
            ul,
            format!(
                "kw.ssfk.unit {unit}: errmap reads lists in 0.1 µm (unit 1), not drive increments"
            ),
        ));
    }
    if let Some((l, _, m)) = keys.int("kw.ssfk.modulo")?
        && m != 0
    {
        return Err(At::new(l, "a modulo axis' list: errmap reads linear axes"));
    }
    let (nl, _, count) = keys.need("kw.ssfk.kw_nr_max")?;
    if !(2..=1_000_000).contains(&count) {
        return Err(At::new(
            nl,
            format!("kw_nr_max {count}: a table needs two points"),
        ));
    }
    let n = count as usize;
    let bil = keys.int("kw.ssfk.bilateral")?;
    let bilateral = match bil {
        None => false,
        Some((_, _, 0)) => false,
        Some((_, _, 1)) => true,
        Some((l, _, b)) => return Err(At::new(l, format!("bilateral {b} (0 or 1)"))),
    };
    let interval = keys.int("kw.ssfk.interval")?.map_or(0, |x| x.2);
    let start = keys.int("kw.ssfk.kw_startpos")?.map(|x| x.2);
    // Every table entry must be within kw_nr_max (the first one that is not is named).
    keys.check_entries(n)?;
    let has_neg = (0..n).all(|i| keys.keys.contains_key(&format!("kw.ssfk.table[{i}].neg")));
    if bilateral && !has_neg {
        return Err(At::new(
            last,
            "a bilateral list needs table[i].neg for every point",
        ));
    }
    let axis = keys
        .keys
        .get("kopf.log_achs_name")
        .and_then(|(_, _, v)| v.parse::<Axis>().ok());
    let mut parsed = Parsed {
        axis,
        bidirectional: bilateral,
        bidir_value: bil.map(|b| b.1),
        one_column: !has_neg,
        ..Default::default()
    };
    for i in 0..n {
        let at = |what: &str| -> Result<(usize, Field, i64), At> {
            keys.int(&format!("kw.ssfk.table[{i}].{what}"))?
                .ok_or_else(|| {
                    At::new(
                        nl,
                        format!("kw_nr_max {n} but kw.ssfk.table[{i}].{what} is missing"),
                    )
                })
        };
        let p01 = if interval == 0 {
            at("setpoint")?.2
        } else {
            let Some(s) = start else {
                return Err(At::new(last, "an interval without kw_startpos"));
            };
            s + i as i64 * interval
        };
        let (line, uf, u) = at("pos")?;
        let (df, d) = if has_neg {
            at("neg").map(|x| (x.1, x.2))?
        } else {
            (uf, u)
        };
        let p = p01 as f64 * 1e-4;
        let e = |v: i64| VALUE.error_um(v as f64, 1.0);
        let e_down = if bilateral { e(d) } else { e(u) };
        check_point(line, p, &[e(u), e(d)])?;
        if let Some(prev) = parsed.points.last()
            && p <= prev.position_mm
        {
            return Err(At::new(
                line,
                format!(
                    "point {i} at {p} mm after {} mm: the points must increase",
                    prev.position_mm
                ),
            ));
        }
        parsed
            .points
            .push(point(line, p, e(u), e_down, u as f64, d as f64, uf, df));
    }
    Ok(parsed)
}

// ---------------------------------------------------------------------------------------
// The dialect

/// TwinCAT CNC (ISG) `kw.ssfk` lists ([`super::DIALECTS`]).
#[derive(Debug, Clone, Copy)]
pub struct Isg;

/// The values: c in 0.1 µm.
pub const VALUE: Value = Value {
    sign: Sign::Compensation,
    unit: ValueUnit::TenthMicrometre,
};

impl Dialect for Isg {
    fn volumetric(&self) -> Option<super::VolumetricTable> {
        Some(super::VolumetricTable {
            render: render_volumetric,
            file_name: "volcomp_twincat.csv",
            summary: "TwinCAT 3 CNC (TF5280) ISG CSV component tables",
        })
    }
    fn name(&self) -> &'static str {
        "isg"
    }
    fn controller(&self) -> &'static str {
        "ISG/TwinCAT"
    }
    fn about(&self) -> &'static str {
        "Beckhoff TwinCAT CNC (ISG) leadscrew error compensation list, kw.ssfk (a line)"
    }
    fn limits(&self) -> Limits {
        Limits {
            max_points: ISG_DEFAULT_MAX_POINTS - 1,
            spacing: Spacing::Listed,
            bidirectional: true,
            value: VALUE,
            axes: &[AxisKind::Linear],
        }
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![
            (TableSetting::AxisName, "kopf.log_achs_name".into()),
            (TableSetting::AxisNumber, "kopf.log_achs_nr".into()),
            (
                TableSetting::MaxPoints,
                format!("P-COMP-00059 kw.ssfk.max_points (default {ISG_DEFAULT_MAX_POINTS})"),
            ),
        ]
    }
    fn detect(&self, _bytes: &[u8], text: &Text) -> bool {
        text.lines()
            .iter()
            .take(60)
            .any(|(_, l)| l.trim_start().starts_with("kw.ssfk."))
    }
    fn table_format(&self, _: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(TableFormat::Isg)
    }
    fn read(&self, text: &Text, _: TableFormat) -> Result<Parsed, At> {
        read(text)
    }
    fn export_format(&self, s: &TableSettings, _: bool) -> Result<ExportFormat, SettingsError> {
        Ok(ExportFormat::Isg {
            axis: IsgAxis {
                number: s.axis_number(),
                name: s.axis_name(),
                max_points: s.max_points.unwrap_or(ISG_DEFAULT_MAX_POINTS),
            },
        })
    }
}

/// The ISG CSV parameter file (TwinCAT 3 CNC TF5280): three blocks separated by file
/// breaks, `X EXX EYX EZX EAX EBX ECX` and the same for Y and Z, in mm and rad.
pub fn render_volumetric(t: &ComponentTables, source: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// errmap volumetric compensation, ISG CSV (TwinCAT 3 CNC TF5280, file_format ISG_CSV)"
    );
    let _ = writeln!(s, "// identified from: {source}");
    let _ = writeln!(
        s,
        "// component errors per ISO 230-1 (actual - nominal): translations in mm, rotations in rad, \
         arguments in mm"
    );
    let _ = writeln!(
        s,
        "// kinematic chain from the workpiece (base) to the tool: {} - all axes on the tool side \
         (workpiece_axes 0); tool length 0",
        t.topology
    );
    let _ = writeln!(
        s,
        "// squareness folded into the straightness of Y and Z (E_XY, E_XZ, E_YZ): no position-error \
         parameter is written"
    );
    for (k, ax) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        if k > 0 {
            let _ = writeln!(s, "#");
        }
        let sig: Vec<String> = (0..6)
            .map(|kind| {
                let c = Component { axis: k, kind };
                format!("{} {:.3} {}", c.name(), t.max_sigma[k][kind], c.unit())
            })
            .collect();
        let _ = writeln!(s, "// largest one-sigma: {}", sig.join(", "));
        let mut header = format!("{ax:<12}");
        for kind in ['X', 'Y', 'Z', 'A', 'B', 'C'] {
            let _ = write!(header, " {:>18}", format!("E{kind}{ax}"));
        }
        let _ = writeln!(s, "{}", header.trim_end());
        for (a, row) in t.positions_mm[k].iter().zip(&t.values[k]) {
            let mut line = format!("{a:<12.4}");
            for (kind, v) in row.iter().enumerate() {
                let written = if kind < 3 { v * 1e-3 } else { v * 1e-6 };
                let _ = write!(line, " {written:>18.12}");
            }
            let _ = writeln!(s, "{line}");
        }
    }
    s
}
