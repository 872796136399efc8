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
//!
//! # Part programs (test plans and volumetric campaigns, [`super::program`])
//!
//! Words used (SINUMERIK 840D sl / 828D Programming Manual "Fundamentals",
//! 6FC5398-1BP40-xBA0: "Dwell time (G4)", "Metric/inch dimensions (G70/G71)",
//! "Feedrate (G93, G94, G95, F…)", "Exact stop (G60)")
//!
//! * `G71` mm, `G90` absolute, `G94` feed in mm/min, `G60` exact stop (modal: every
//!   block ends at rest in the fine window, no velocity blending).
//! * `G1 X… F…` a feed move, F mm/min.
//! * `G4 F…` dwell, **F in seconds** (`G4 S…` would be spindle revolutions). G4 must be in
//!   a block of its own; the F in a G4 block applies only to the dwell, the programmed
//!   feed stays in force afterwards.
//! * `;` comments; `M30` ends the program.
//!
//! Positions are written with 3 decimals: the default input resolution MD10200
//! `INT_INCR_PER_MM` is 1000 (0.001 mm).

use std::fmt::Write as _;

use super::TableSetting;
use super::modulo::{
    MAX_TARGETS, ModuloError, ModuloRead, ModuloSpec, ModuloSyntax, ModuloTable, deg6,
};
use super::modulo_update as mu;
use super::program::{ProgramError, ProgramKind, ProgramSyntax, iso_move, seconds3};
use super::read::{At, Field, Parsed, check_point, field_at, num, point};
use super::text::Text;
use super::update::fixed;
use super::{
    AxisKind, AxisTables, Dialect, DialectOption, ExportFormat, Limits, OptionValue, SettingsError,
    Sign, Spacing, TableFormat, TableSettings, UpdateStyle, Value, ValueUnit,
};
use crate::base::Axis;
use crate::export::{ExportError, Sampled, fmt_mm, fmt_point};

/// How the limit messages name this controller's table.
pub const LABEL: &str = "the Siemens LEC table (MD38000 MM_ENC_COMP_MAX_POINTS)";

/// Siemens' settings: the LEC table's machine axis, the first of the two CEC tables.
static OPTIONS: [DialectOption; 2] = [
    DialectOption {
        name: "siemens-axis",
        help: "Siemens machine-axis name, e.g. X1",
        default: Some("X1"),
        parse: |s| {
            check_axis_name(s)?;
            Ok(OptionValue::Text(s.to_string()))
        },
    },
    DialectOption {
        name: "siemens-table",
        help: "Siemens --bidirectional: the first of the two CEC tables (positive direction; the \
               next one is the negative direction). The machine axis is AX<--axis-number>",
        default: Some("0"),
        parse: super::options::count,
    },
];

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
        return Err(super::too_many(LABEL, s, 2, max_points, false));
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
    let rev = crate::export::paired(forward, Some(reverse))?;
    let (step, step_txt) = table_step(forward, max_points)?;
    if axis_number == 0 {
        return Err(ExportError::BadAxisName { name: "AX0".into() });
    }
    let Some(second_table) = first_table.checked_add(1) else {
        return Err(ExportError::ControllerLimit {
            controller: LABEL,
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
                fmt_mm(VALUE.sign.of(e) * 1e-3)
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
/// The samples must be equidistant (as [`sample_line`](crate::export::sample_line) makes them). A zero point is
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
            fmt_mm(VALUE.sign.of(e) * 1e-3)
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

// ---------------------------------------------------------------------------------------
// Siemens

/// One equidistant Siemens table being read.
#[derive(Default)]
struct SiemensTable {
    /// N → (line, field, value).
    values: std::collections::BTreeMap<usize, (usize, Field, f64)>,
    step: Option<(usize, f64)>,
    min: Option<(usize, f64)>,
    max: Option<(usize, f64)>,
    direction: Option<(usize, i64)>,
    first_line: usize,
}

impl SiemensTable {
    /// (position mm, line, field, value) per point, checked.
    fn points(&self, what: &str, last_line: usize) -> Result<Vec<(f64, usize, Field, f64)>, At> {
        let need = |v: Option<(usize, f64)>, name: &str| {
            v.ok_or_else(|| At::new(last_line, format!("{what}: no {name}")))
        };
        let (sl, step) = need(self.step, "STEP")?;
        let (_, min) = need(self.min, "MIN")?;
        let (xl, max) = need(self.max, "MAX")?;
        if step <= 0.0 || max <= min {
            return Err(At::new(
                sl,
                format!("{what}: STEP {step} mm from {min} to {max} mm is not a table"),
            ));
        }
        let k = (max - min) / step;
        let count = k.round();
        if (k - count).abs() > 1e-6 * count.max(1.0) || count > 1e6 {
            return Err(At::new(
                xl,
                format!(
                    "{what}: MAX − MIN = {} mm is not a whole number of STEP {step} mm",
                    max - min
                ),
            ));
        }
        let count = count as usize + 1;
        if let Some((&n, &(l, ..))) = self.values.iter().find(|(n, _)| **n >= count) {
            return Err(At::new(
                l,
                format!("{what}: point {n} beyond the {count} points MIN…MAX by STEP"),
            ));
        }
        if self.values.len() != count {
            let missing = (0..count)
                .find(|n| !self.values.contains_key(n))
                .unwrap_or(0);
            return Err(At::new(
                xl,
                format!(
                    "{what}: {count} points from MIN to MAX by STEP but {} values (point {missing} is missing)",
                    self.values.len()
                ),
            ));
        }
        Ok(self
            .values
            .iter()
            .map(|(&n, &(l, f, v))| (min + n as f64 * step, l, f, v))
            .collect())
    }
}

/// The axis errmap's comment `; line along <axis> at …` names (Siemens programs).
fn line_axis(t: &str) -> Option<Axis> {
    let rest = t
        .strip_prefix(';')?
        .trim_start()
        .strip_prefix("line along ")?;
    rest.split_whitespace().next()?.parse().ok()
}

/// `NAME[args]=value` → (name, args, value offset in the line, value text).
fn siemens_assignment(l: &str) -> Option<(&str, Vec<&str>, usize, &str)> {
    let (lhs, value) = l.split_once('=')?;
    let (name, rest) = lhs.split_once('[')?;
    let args = rest.strip_suffix(']')?;
    Some((
        name.trim(),
        args.split(',').map(str::trim).collect(),
        lhs.len() + 1,
        value,
    ))
}

impl SiemensTable {
    /// Stores one entry of the table `key`: a point value when `point` (the point number's
    /// argument) is given, else the table parameter `base` (STEP, MIN, …), checked.
    fn take(
        &mut self,
        key: &str,
        line: usize,
        base: &str,
        point: Option<&str>,
        (f, vt): (Field, &str),
    ) -> Result<(), At> {
        match (base, point) {
            ("", Some(arg)) => {
                let n: usize = arg
                    .parse()
                    .map_err(|_| At::new(line, format!("point number `{}` is not a count", arg)))?;
                let v = num(line, "the value", vt)?;
                if self.values.insert(n, (line, f, v)).is_some() {
                    return Err(At::new(
                        line,
                        format!("point {n} of table {key} given twice"),
                    ));
                }
            }
            ("STEP", _) => self.step = Some((line, num(line, "STEP", vt)?)),
            ("MIN", _) => self.min = Some((line, num(line, "MIN", vt)?)),
            ("MAX", _) => self.max = Some((line, num(line, "MAX", vt)?)),
            ("DIRECTION", _) => {
                let d = num(line, "DIRECTION", vt)?;
                if ![-1.0, 0.0, 1.0].contains(&d) {
                    return Err(At::new(line, format!("DIRECTION {d} (−1, 0 or 1)")));
                }
                self.direction = Some((line, d as i64));
            }
            ("IS_MODULO", _) => {
                if num(line, "IS_MODULO", vt)? != 0.0 {
                    return Err(At::new(
                        line,
                        "a modulo (rotary) table: errmap reads linear axes",
                    ));
                }
            }
            ("MULT_BY_TABLE", _) => {
                if num(line, "MULT_BY_TABLE", vt)? != 0.0 {
                    return Err(At::new(
                        line,
                        "a table multiplied by another: not a leadscrew table",
                    ));
                }
            }
            ("INPUT_AXIS", _) | ("OUTPUT_AXIS", _) => {}
            (other, _) => return Err(At::new(line, format!("unknown table entry `{other}`"))),
        }
        Ok(())
    }
}

/// Which table and entry a Siemens assignment sets: (entry after the name's `_`, or ""
/// for a point value; the table's key; the argument holding the point number), refusing
/// names of the other program kind.
fn siemens_target<'l>(
    cec: bool,
    name: &'l str,
    args: &[&str],
    line: usize,
    t: &str,
) -> Result<(&'l str, String, Option<usize>), At> {
    Ok(match (cec, name) {
        (false, "$AA_ENC_COMP") if args.len() == 3 => {
            ("", format!("{},{}", args[0], args[2]), Some(1))
        }
        (false, n) if n.starts_with("$AA_ENC_COMP_") && args.len() == 2 => {
            (&n[13..], format!("{},{}", args[0], args[1]), None)
        }
        (true, "$AN_CEC") if args.len() == 2 => ("", args[0].to_string(), Some(1)),
        (true, n) if n.starts_with("$AN_CEC_") && args.len() == 1 => {
            (&n[8..], args[0].to_string(), None)
        }
        _ => {
            return Err(At::new(
                line,
                format!("`{t}`: not a line of this table program"),
            ));
        }
    })
}

/// A Siemens `%_N_AX_EEC_INI` (one LEC/MSEC table) or `%_N_NC_CEC_INI` (one CEC table
/// without direction, or two for the positive and negative directions).
pub fn read(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
    let cec = match first {
        "%_N_AX_EEC_INI" => false,
        "%_N_NC_CEC_INI" => true,
        _ => {
            return Err(At::new(
                1,
                "not a Siemens compensation program (`%_N_AX_EEC_INI` or `%_N_NC_CEC_INI`)",
            ));
        }
    };
    let mut tables: std::collections::BTreeMap<String, SiemensTable> = Default::default();
    let mut ended = false;
    let mut axis = None;
    for (i, &(off, l)) in lines.iter().enumerate().skip(1) {
        let line = i + 1;
        let t = l.trim();
        if ended && !t.is_empty() {
            return Err(At::new(line, "text after M17 (the end of the program)"));
        }
        if let Some(a) = line_axis(t) {
            axis = Some(a);
        }
        if t.is_empty() || t.starts_with(';') || t == "CHANDATA(1)" {
            continue;
        }
        if t == "M17" || t == "M30" {
            ended = true;
            continue;
        }
        let Some((name, args, voff, value)) = siemens_assignment(l) else {
            return Err(At::new(line, format!("`{t}` is not `$NAME[…]=value`")));
        };
        let (base, key, n_index) = siemens_target(cec, name, &args, line, t)?;
        let table = tables.entry(key.clone()).or_insert_with(|| SiemensTable {
            first_line: line,
            ..Default::default()
        });
        let vt = value.trim();
        let lead = value.len() - value.trim_start().len();
        let f = field_at(off + voff + lead, vt);
        table.take(&key, line, base, n_index.map(|k| args[k]), (f, vt))?;
    }
    let last = lines.len().max(1);
    if !ended {
        return Err(At::new(last, "no M17: the program is cut short"));
    }
    let mut parsed = siemens_points(&tables, cec, last)?;
    parsed.axis = axis;
    if parsed.points.len() < 2 {
        return Err(At::new(last, "a table needs two points"));
    }
    Ok(parsed)
}

/// The table points of the program's tables: one table (one column), or in a CEC program
/// two tables of directions 1 and −1 at the same points; anything else is refused.
fn siemens_points(
    tables: &std::collections::BTreeMap<String, SiemensTable>,
    cec: bool,
    last: usize,
) -> Result<Parsed, At> {
    let e = |v: f64| VALUE.error_um(v, 1.0);
    let mut parsed = Parsed::default();
    let list: Vec<(&String, &SiemensTable)> = tables.iter().collect();
    match list.as_slice() {
        [(name, t)] => {
            if t.direction.is_some_and(|d| d.1 != 0) {
                return Err(At::new(
                    t.direction.map_or(last, |d| d.0),
                    format!(
                        "table {name} acts in one direction only and its other-direction table is missing"
                    ),
                ));
            }
            for (p, l, f, v) in t.points(&format!("table {name}"), last)? {
                check_point(l, p, &[e(v)])?;
                parsed.points.push(point(l, p, e(v), e(v), v, v, f, f));
            }
            parsed.one_column = true;
        }
        [(na, a), (nb, b)] if cec => {
            let dir = |t: &SiemensTable| t.direction.map_or(0, |d| d.1);
            let (up, down) = match (dir(a), dir(b)) {
                (1, -1) => (a, b),
                (-1, 1) => (b, a),
                _ => {
                    return Err(At::new(
                        b.first_line,
                        format!("tables {na} and {nb}: two tables must be DIRECTION 1 and −1"),
                    ));
                }
            };
            let pu = up.points("the positive-direction table", last)?;
            let pd = down.points("the negative-direction table", last)?;
            if pu.len() != pd.len() || pu.iter().zip(&pd).any(|(x, y)| (x.0 - y.0).abs() > 1e-9) {
                return Err(At::new(
                    down.first_line,
                    "the two direction tables have different points (MIN, MAX, STEP)",
                ));
            }
            for (u, d) in pu.iter().zip(&pd) {
                check_point(u.1, u.0, &[e(u.3), e(d.3)])?;
                parsed
                    .points
                    .push(point(u.1, u.0, e(u.3), e(d.3), u.3, d.3, u.2, d.2));
            }
            parsed.bidirectional = true;
        }
        [] => return Err(At::new(last, "no table values")),
        _ => {
            return Err(At::new(
                list[1].1.first_line,
                format!(
                    "{} tables in one file: errmap reads one axis' table",
                    list.len()
                ),
            ));
        }
    }
    Ok(parsed)
}

// ---------------------------------------------------------------------------------------
// The dialect

/// SINUMERIK 840D sl LEC/MSEC and direction-dependent CEC programs ([`super::DIALECTS`]).
#[derive(Debug, Clone, Copy)]
pub struct Siemens;

/// The values: c in mm.
pub const VALUE: Value = Value {
    sign: Sign::Compensation,
    unit: ValueUnit::Length,
};

impl Dialect for Siemens {
    fn modulo(&self) -> Option<&dyn ModuloSyntax> {
        Some(self)
    }
    fn program(&self) -> Option<&dyn ProgramSyntax> {
        Some(self)
    }
    fn options(&self) -> &'static [DialectOption] {
        &OPTIONS
    }
    fn axis_tables(&self) -> Option<AxisTables> {
        Some(AxisTables {
            format: |axis| ExportFormat::Siemens {
                axis_name: format!("{}1", axis.upper()),
                max_points: SIEMENS_808D_MAX_POINTS,
            },
            extension: "spf",
            about: "A SINUMERIK 840D sl LEC/MSEC program for machine axes X1, Y1, Z1",
            summary: "SINUMERIK LEC/MSEC",
        })
    }
    fn name(&self) -> &'static str {
        "siemens"
    }
    fn controller(&self) -> &'static str {
        "Siemens 840D"
    }
    fn about(&self) -> &'static str {
        "Siemens 840D encoder/leadscrew compensation (a line)"
    }
    fn limits(&self) -> Limits {
        Limits {
            max_points: SIEMENS_808D_MAX_POINTS,
            spacing: Spacing::Equidistant,
            bidirectional: true,
            value: VALUE,
            axes: &[AxisKind::Linear],
        }
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![
            (
                TableSetting::MaxPoints,
                format!(
                    "MD38000 MM_ENC_COMP_MAX_POINTS (default {SIEMENS_808D_MAX_POINTS}, the 808D)"
                ),
            ),
            (
                TableSetting::AxisNumber,
                "the CEC tables' axis AX<n>".into(),
            ),
        ]
    }
    fn detect(&self, _bytes: &[u8], text: &Text) -> bool {
        let lines = text.lines();
        let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
        first == "%_N_AX_EEC_INI" || first == "%_N_NC_CEC_INI"
    }
    fn table_format(&self, _: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(TableFormat::Siemens)
    }
    fn read(&self, text: &Text, _: TableFormat) -> Result<Parsed, At> {
        read(text)
    }
    fn update_style(&self) -> UpdateStyle {
        // Written at 1e-6 mm with trailing zeros trimmed (`export`'s files).
        UpdateStyle {
            trimmed_decimals: Some(6),
            ..UpdateStyle::default()
        }
    }
    fn export_format(
        &self,
        s: &TableSettings,
        bidirectional: bool,
    ) -> Result<ExportFormat, SettingsError> {
        let max_points = s.max_points.unwrap_or(SIEMENS_808D_MAX_POINTS);
        // Siemens' direction-dependent compensation is a pair of CEC tables (K3 §4.4.4).
        Ok(if bidirectional {
            ExportFormat::SiemensCec {
                axis_number: s.axis_number(),
                first_table: s.options.count(OPTIONS[1].name).unwrap_or(0),
                max_points,
            }
        } else {
            ExportFormat::Siemens {
                axis_name: s.options.text(OPTIONS[0].name).unwrap_or("X1").to_string(),
                max_points,
            }
        })
    }
}

// ---------------------------------------------------------------------------------------
// Part programs

impl ProgramSyntax for Siemens {
    fn name(&self) -> &'static str {
        Dialect::name(self)
    }
    fn extension(&self) -> &'static str {
        "mpf"
    }
    fn comment(&self, text: &str) -> String {
        format!("; {text}")
    }
    fn setup(&self) -> Option<&'static str> {
        Some("G71 G90 G94 G60")
    }
    fn feed_move(&self, axes: &[(&str, f64)], feed: Option<&str>) -> String {
        iso_move("G1", axes, feed)
    }
    fn dwell(&self, dwell_s: f64) -> Result<Vec<String>, ProgramError> {
        Ok(vec![format!("G4 F{}", seconds3(dwell_s))])
    }
    fn stop(&self) -> &'static str {
        "M0"
    }
    fn end(&self, _: ProgramKind) -> Vec<String> {
        vec!["M30".into()]
    }
}

// ---------------------------------------------------------------------------------------
// The modulo table of a rotary axis ([`super::modulo`])

/// `name[args]=value` of a Siemens line: the name, the arguments, the value's field.
fn modulo_assignment(body: &str, offset: usize) -> Option<(&str, Vec<&str>, Field, &str)> {
    let code = body.split(';').next()?.trim_end();
    let (lhs, rhs) = code.split_once('=')?;
    let (name, args) = lhs.trim().split_once('[')?;
    let args = args.strip_suffix(']')?.split(',').map(str::trim).collect();
    let v = rhs.trim();
    let start = offset + code.len() - rhs.trim_start().len();
    Some((name, args, mu::field(start, start + v.len(), v), v))
}

/// SINUMERIK EEC with `$AA_ENC_COMP_IS_MODULO = 1`: equidistant, one value per point for
/// both directions; MD38000's default of 200 points assumed.
impl ModuloSyntax for Siemens {
    fn equidistant(&self) -> bool {
        true
    }
    fn default_max_points(&self) -> usize {
        200
    }
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
        let letter = spec.axis.upper();
        let mut s = String::new();
        let c = t.c_arcsec.clone();
        let ax = spec
            .siemens_axis
            .clone()
            .unwrap_or_else(|| format!("{letter}1"));
        let _ = writeln!(
            s,
            "; errmap: rotary axis {letter}, modulo encoder compensation (EEC), ″→°; \
             closure gap {:.3}″ left out (correct the ratio)",
            t.closure_gap_arcsec
        );
        let _ = writeln!(s, "CHANDATA(1)");
        for (i, c) in c.iter().enumerate() {
            let _ = writeln!(s, "$AA_ENC_COMP[0,{i},{ax}]={}", deg6(c / 3600.0));
        }
        let _ = writeln!(
            s,
            "$AA_ENC_COMP_STEP[0,{ax}]={}",
            deg6(t.step_deg.unwrap_or(0.0))
        );
        let _ = writeln!(s, "$AA_ENC_COMP_MIN[0,{ax}]=0.0");
        let _ = writeln!(s, "$AA_ENC_COMP_MAX[0,{ax}]=360.0");
        let _ = writeln!(s, "$AA_ENC_COMP_IS_MODULO[0,{ax}]=1");
        let _ = writeln!(s, "M17");
        Ok(t.written(s))
    }
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
        let ax = spec
            .siemens_axis
            .clone()
            .unwrap_or_else(|| format!("{}1", spec.axis.upper()));
        let mut t = ModuloRead::default();
        let mut points: Vec<(usize, usize, Field, f64)> = Vec::new();
        let (mut step, mut min, mut max, mut modulo) = (None, None, None, None);
        for (line, offset, body) in mu::lines(text) {
            let Some((name, args, f, v)) = modulo_assignment(body, offset) else {
                continue;
            };
            if !name.starts_with("$AA_ENC_COMP") {
                continue;
            }
            let axis = args.last().copied().unwrap_or("");
            if axis != ax {
                return Err(mu::mismatch(
                    line,
                    mu::TableMismatch::SiemensAxis {
                        found: axis.to_string(),
                        expected: ax,
                    },
                ));
            }
            let value = mu::number(line, v, name)?;
            match name {
                "$AA_ENC_COMP" => {
                    let i: usize = args
                        .get(1)
                        .and_then(|i| i.parse().ok())
                        .ok_or_else(|| mu::at(line, "the point index is not a whole number"))?;
                    points.push((i, line, f, value));
                }
                "$AA_ENC_COMP_STEP" => step = Some((line, value)),
                "$AA_ENC_COMP_MIN" => min = Some((line, value)),
                "$AA_ENC_COMP_MAX" => max = Some((line, value)),
                "$AA_ENC_COMP_IS_MODULO" => modulo = Some((line, value)),
                _ => {}
            }
        }
        let last = mu::lines(text).len();
        match modulo {
            Some((_, 1.0)) => {}
            Some((line, v)) => {
                return Err(mu::at(
                    line,
                    format!("$AA_ENC_COMP_IS_MODULO is {v}: not a modulo table"),
                ));
            }
            None => {
                return Err(mu::at(
                    last,
                    "no $AA_ENC_COMP_IS_MODULO=1: not a modulo table",
                ));
            }
        }
        for (name, got, want) in [("_MIN", min, 0.0), ("_MAX", max, 360.0)] {
            match got {
                Some((_, v)) if (v - want).abs() <= 1e-9 => {}
                Some((line, v)) => {
                    return Err(mu::at(
                        line,
                        format!("$AA_ENC_COMP{name} is {v}, not {want}"),
                    ));
                }
                None => return Err(mu::at(last, format!("no $AA_ENC_COMP{name}"))),
            }
        }
        let (step_line, s) = step.ok_or_else(|| mu::at(last, "no $AA_ENC_COMP_STEP"))?;
        if points.len() > MAX_TARGETS {
            return Err(mu::at(
                points[MAX_TARGETS].1,
                format!("more than {MAX_TARGETS} points"),
            ));
        }
        for (k, &(i, line, f, v)) in points.iter().enumerate() {
            if i != k {
                return Err(mu::at(
                    line,
                    format!("point {i} where point {k} was expected"),
                ));
            }
            t.angles.push(k as f64 * s);
            t.lines.push(line);
            t.up.push(f);
            t.down.push(None);
            t.c_up.push(v * 3600.0);
            t.c_down.push(v * 3600.0);
        }
        t.step_line = step_line;
        Ok(t)
    }
    fn encode(&self, _spec: &ModuloSpec, _q: f64, c: f64, field: Field, _old: &str) -> String {
        fixed(c / 3600.0, field.decimals.max(6))
    }
}
