//! The Siemens LEC/MSEC renderer ([`render`]).
//!
//! # Siemens 840D sl leadscrew / measuring-system error compensation
//!
//! SINUMERIK 840D sl Extended Functions, Function Manual K3 "Compensations",
//! §4.4.2 "Measuring system error compensation" (6FC5397-1BP40-3BA1, 03/2013): per
//! machine axis and measuring system e (0 = first encoder) the table is the system
//! variables `$AA_ENC_COMP[e,N,AXi]` (the value at interpolation point N, mm),
//! `$AA_ENC_COMP_STEP[e,AXi]` (the distance between points), `$AA_ENC_COMP_MIN[e,AXi]`
//! (the position of point 0), `$AA_ENC_COMP_MAX[e,AXi]` (the position of the last point)
//! and `$AA_ENC_COMP_IS_MODULO[e,AXi]`, loaded by an `%_N_AX_EEC_INI` program
//! (`CHANDATA(1)` … `M17`) while MD32700 `ENC_COMP_ENABLE` = 0. Points are equidistant,
//! so N_points = (MAX − MIN)/STEP + 1, and N_points must not exceed MD38000
//! `MM_ENC_COMP_MAX_POINTS` (0 ≤ N ≤ MD38000 − 1), which is configured per axis (the manual's example needs
//! ≥ 801; the SINUMERIK 808D allows up to 200, [`SIEMENS_808D_MAX_POINTS`]) — so the limit
//! is a parameter here. Between points the value is interpolated linearly; below MIN and
//! above MAX the first and last values stay active over the whole remaining travel,
//! which is why the manual asks for them to be 0 when the table does not cover the whole
//! traversing range. Tables are direction-independent (backlash is a separate function)
//! and this module writes linear axes only (`IS_MODULO = 0`).
//!
//! **How the first and last values are made 0.** The sampled line is written unchanged
//! and one extra point of value 0 is added one step before the first sample and one step
//! after the last (MIN = start − step, MAX = end + step). Inside the mapped range the
//! control applies exactly the compensation the model predicts; over the one step beyond
//! each end it ramps linearly to 0, and beyond that the axis is uncompensated, as it would
//! be without a table. The alternative — subtracting the straight line through the end
//! values — would also zero the ends, but it silently removes a scale error and an
//! offset from the compensation everywhere inside the range, which is not what a
//! commissioning engineer asks for. The two pads count against MD38000. Note also that
//! the 808D manual recommends a zero value at the reference point so that switching the
//! compensation on after referencing causes no jump; errmap's tables are absolute, so if
//! c ≠ 0 there the axis moves by c when the table is activated.
//!
//! # Direction-dependent compensation ([`render_bidirectional`])
//!
//! The 840D sl has no direction-dependent LEC/MSEC table; K3 §4.4.4 "Direction-dependent
//! leadscrew error compensation" (same manual, pp. 262–265) builds it from two sag
//! compensation (CEC) tables whose base axis and compensation axis are the same axis,
//! one applying only while the axis moves in the positive direction
//! (`$AN_CEC_DIRECTION[t] = 1`), the other only in the negative direction (`= -1`)
//! (§4.4.3, p. 249). A CEC table is `$AN_CEC[t,N]` with `$AN_CEC_INPUT_AXIS[t]`,
//! `$AN_CEC_OUTPUT_AXIS[t]` (`(AXn)`), `$AN_CEC_STEP[t]`, `$AN_CEC_MIN[t]`,
//! `$AN_CEC_MAX[t]`, `$AN_CEC_DIRECTION[t]`, `$AN_CEC_MULT_BY_TABLE[t]` and
//! `$AN_CEC_IS_MODULO[t]`, loaded by a `%_N_NC_CEC_INI` program while MD32710
//! `CEC_ENABLE` = 0; its size is MD18342 `MM_CEC_MAX_POINTS[t]` (the 828D: 8 tables of
//! 200 points, fixed). Values are linearly interpolated as in LEC; errmap pads each
//! table with a zero point one step beyond each end, as above. The axis' own LEC/MSEC
//! table must then be left empty (MD32700 = 0), or both would act. The sources consulted
//! do not state the sign of a CEC value in words; K3 presents §4.4.4 as the leadscrew
//! error compensation split by direction, so errmap writes c as in the LEC table —
//! check the sign on the machine with one point before trusting the tables.
//!
//! # Sign convention
//!
//! **Siemens LEC/MSEC corrects the actual (feedback) value.** The compensation value
//! modifies the axis' position actual value, so a positive value makes the axis move in
//! the negative direction (SINUMERIK 808D Function Manual 01/2017, "Leadscrew error
//! compensation"). The table therefore holds c, in mm.

use super::{Controller, ExportError, Sampled, compensation_um, fmt_mm, fmt_point};

/// The SINUMERIK 808D's LEC table size (N = 0…199). On the 840D sl the limit is the
/// axis' MD38000 `MM_ENC_COMP_MAX_POINTS`, which must be read from the machine.
pub const SIEMENS_808D_MAX_POINTS: usize = 200;

/// A SINUMERIK machine-axis name: a letter, then letters, digits or `_`, at most 32.
pub fn check_axis_name(name: &str) -> Result<(), ExportError> {
    let ok = !name.is_empty()
        && name.len() <= 32
        && name.starts_with(|c: char| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(ExportError::BadAxisName {
            name: name.to_string(),
        })
    }
}

/// The comment naming the line and the sign of the values.
fn line_comment(s: &Sampled) -> String {
    format!(
        "; line along {} at {}; values c = -e in mm (e = indicated - reference)\n",
        s.axis,
        fmt_point(s.at_mm)
    )
}

/// The checked table geometry: the step as written, and the step.
fn table_step(s: &Sampled, max_points: usize) -> Result<(f64, String), ExportError> {
    s.check()?;
    let step = s.uniform_step()?;
    let step_txt = fmt_mm(step);
    let step_written: f64 = step_txt.parse().unwrap_or(0.0);
    if step_written <= 0.0 || (step_written - step).abs() > 1e-9 * step.max(1.0) {
        return Err(ExportError::StepNotRepresentable { step_mm: step });
    }
    let n = s.len();
    if n + 2 > max_points {
        return Err(ExportError::TooManyEntries {
            controller: Controller::Siemens,
            samples: n,
            padding: 2,
            limit: max_points,
            length_mm: s.length_mm(),
        });
    }
    Ok((step, step_txt))
}

/// A SINUMERIK 840D sl direction-dependent leadscrew error compensation program
/// (`%_N_NC_CEC_INI`, module docs): CEC table `first_table` for the positive direction
/// (`forward`, x̄↑) and `first_table + 1` for the negative one (`reverse`, x̄↓), base and
/// compensation axis `AX<axis_number>`, values c in mm, each padded with a zero point
/// one step beyond each end, so `s.len() + 2` points per table (MD18342).
pub fn render_bidirectional(
    forward: &Sampled,
    reverse: &Sampled,
    axis_number: u32,
    first_table: usize,
    max_points: usize,
) -> Result<String, ExportError> {
    let rev = super::paired(forward, Some(reverse))?;
    let (step, step_txt) = table_step(forward, max_points)?;
    if axis_number == 0 {
        return Err(ExportError::BadAxisName { name: "AX0".into() });
    }
    let Some(second_table) = first_table.checked_add(1) else {
        return Err(ExportError::ControllerLimit {
            controller: Controller::Siemens,
            problem: format!("CEC table index {first_table} leaves no room for its second table"),
        });
    };
    let n = forward.len();
    let ax = format!("AX{axis_number}");
    let mut out = String::with_capacity((2 * n + 40) * 32);
    out.push_str("%_N_NC_CEC_INI\n");
    out.push_str(&format!(
        "; errmap direction-dependent leadscrew error compensation for machine axis {ax} (K3 4.4.4)\n"
    ));
    out.push_str(&line_comment(forward));
    out.push_str(&format!(
        "; table {first_table}: positive direction (mean up), table {}: negative direction (mean down); \
         {n} samples from {} to {} mm plus a zero point one step beyond each end\n",
        second_table,
        fmt_mm(forward.positions_mm[0]),
        fmt_mm(forward.positions_mm[n - 1]),
    ));
    out.push_str(&format!(
        "; needs MD18342 MM_CEC_MAX_POINTS[{first_table}] and [{}] >= {}; load with MD32710 CEC_ENABLE = 0; \
         leave the axis' LEC/MSEC table off (MD32700 = 0)\n",
        second_table,
        n + 2
    ));
    out.push_str("CHANDATA(1)\n");
    for (t, s, direction) in [(first_table, forward, 1), (second_table, rev, -1)] {
        out.push_str(&format!("$AN_CEC[{t},0]=0.0\n"));
        for (i, &e) in s.error_um.iter().enumerate() {
            out.push_str(&format!(
                "$AN_CEC[{t},{}]={}\n",
                i + 1,
                fmt_mm(compensation_um(e) * 1e-3)
            ));
        }
        out.push_str(&format!("$AN_CEC[{t},{}]=0.0\n", n + 1));
        out.push_str(&format!("$AN_CEC_INPUT_AXIS[{t}]=({ax})\n"));
        out.push_str(&format!("$AN_CEC_OUTPUT_AXIS[{t}]=({ax})\n"));
        out.push_str(&format!("$AN_CEC_STEP[{t}]={step_txt}\n"));
        out.push_str(&format!(
            "$AN_CEC_MIN[{t}]={}\n",
            fmt_mm(s.positions_mm[0] - step)
        ));
        out.push_str(&format!(
            "$AN_CEC_MAX[{t}]={}\n",
            fmt_mm(s.positions_mm[n - 1] + step)
        ));
        out.push_str(&format!("$AN_CEC_DIRECTION[{t}]={direction}\n"));
        out.push_str(&format!("$AN_CEC_MULT_BY_TABLE[{t}]=0\n"));
        out.push_str(&format!("$AN_CEC_IS_MODULO[{t}]=0\n"));
    }
    out.push_str("M17\n");
    Ok(out)
}

/// A SINUMERIK 840D sl LEC/MSEC program (`%_N_AX_EEC_INI`) for machine axis
/// `axis_name`, measuring system 0, values c in mm.
///
/// The samples must be equidistant (as [`sample_line`](super::sample_line) makes them). A zero point is
/// added one step before the first and one after the last sample, so that the first and
/// last compensation values are 0 (see the module docs); the table then has
/// `s.len() + 2` points, which must not exceed `max_points` (the axis' MD38000).
pub fn render(s: &Sampled, axis_name: &str, max_points: usize) -> Result<String, ExportError> {
    check_axis_name(axis_name)?;
    let (step, step_txt) = table_step(s, max_points)?;
    let n = s.len();
    let min = s.positions_mm[0] - step;
    let max = s.positions_mm[n - 1] + step;
    let ax = axis_name;
    let mut out = String::with_capacity((n + 16) * 40);
    out.push_str("%_N_AX_EEC_INI\n");
    out.push_str(&format!(
        "; errmap leadscrew/measuring-system error compensation for machine axis {ax}\n"
    ));
    out.push_str(&line_comment(s));
    out.push_str(&format!(
        "; {n} samples from {} to {} mm plus a zero point one step beyond each end; \
         {} extrapolated\n",
        fmt_mm(s.positions_mm[0]),
        fmt_mm(s.positions_mm[n - 1]),
        s.extrapolated_count()
    ));
    out.push_str(&format!(
        "; needs MD38000 MM_ENC_COMP_MAX_POINTS >= {}; load with MD32700 ENC_COMP_ENABLE = 0\n",
        n + 2
    ));
    out.push_str("CHANDATA(1)\n");
    out.push_str(&format!("$AA_ENC_COMP[0,0,{ax}]=0.0\n"));
    for (i, &e) in s.error_um.iter().enumerate() {
        out.push_str(&format!(
            "$AA_ENC_COMP[0,{},{ax}]={}\n",
            i + 1,
            fmt_mm(compensation_um(e) * 1e-3)
        ));
    }
    out.push_str(&format!("$AA_ENC_COMP[0,{},{ax}]=0.0\n", n + 1));
    out.push_str(&format!("$AA_ENC_COMP_STEP[0,{ax}]={step_txt}\n"));
    out.push_str(&format!("$AA_ENC_COMP_MIN[0,{ax}]={}\n", fmt_mm(min)));
    out.push_str(&format!("$AA_ENC_COMP_MAX[0,{ax}]={}\n", fmt_mm(max)));
    out.push_str(&format!("$AA_ENC_COMP_IS_MODULO[0,{ax}]=0\n"));
    out.push_str("M17\n");
    Ok(out)
}
