//! The HEIDENHAIN TNC nonlinear axis error compensation renderer ([`render`]).
//!
//! # HEIDENHAIN nonlinear axis error compensation (`*.COM`, `*.CMA`)
//!
//! Sources: HEIDENHAIN Technical Manual MANUALplus 620, "Entering compensation values"
//! and "Assigning the compensation value tables to the axes" (pp. 716–718); HEIDENHAIN
//! TNC 407/415/425 Technical Manual (01.98), non-linear axis error compensation
//! (pp. 4-28 to 4-31) and PLC module 9095 (p. 622).
//!
//! A compensation value table (`*.COM`) holds, row by row, a compensation point in the
//! `AXISPOS` column (the position with respect to the machine datum) and the
//! compensation value in the column named after the compensated axis (the axis key of
//! `CfgAxes/axisList`); an optional `BACKLASH` column holds values measured in the
//! negative direction of traverse, which errmap does not write (the sources do not say
//! whether it holds the value or its difference from the positive one). A `*.CMA` table
//! (standard name `config.cma`) assigns the `.COM` tables to the axes, one column per
//! compensated axis, and the line marked `*` in its `ACTIVE` column is the active one;
//! errmap writes the `.COM` table and names the `.CMA` entry in its report. On the TNC
//! 407 family non-linear compensation is selected per axis by MP730 and a `.COM` table
//! has at most 256 entries (module 9095, error 3: "more than 256 entries") —
//! [`HEIDENHAIN_MAX_POINTS`], a parameter because later controls were not documented in
//! the sources consulted. The manuals' examples use equidistant points (5 mm on the
//! MANUALplus 620, a power of two of 0.1 µm on the TNC 407), so errmap writes
//! equidistant tables only.
//!
//! The file is HEIDENHAIN's table text: `BEGIN <name> MM`, a line of column names, one
//! line per row starting with its number `NR`, and `[END]`.
//!
//! # Sign convention
//!
//! The TNC 407 manual plots the table as the axis' "error" curve; the sign of that error
//! (actual − nominal or nominal − actual) is not stated in the sources consulted. errmap
//! writes ISO 230-2's deviation, actual − target = reference − indicated = c (mm), the
//! value a laser calibration reports and the same sign as the Siemens table. Check the
//! sign on the machine with one point before trusting the whole table. How the control
//! continues the compensation beyond the first and last points was not found either:
//! errmap adds no points.
//!
//! # Part programs (test plans and volumetric campaigns, [`super::program`])
//!
//! Syntax used (HEIDENHAIN TNC 640 User's Manual "Klartext Programming" and User's
//! Manual "Programming of Machining Cycles", cycle 9 DWELL TIME)
//!
//! * Every block is numbered from 0; block 0 is `BEGIN PGM name MM` (mm program), the last
//!   `END PGM name MM`. The name is letters, digits and `_` ([`ProgramKind::word`](super::program::ProgramKind::word)).
//! * `L X+… Y+… Z+… R0 F…` a straight line in absolute coordinates, the sign always
//!   written, `R0` no radius compensation, F in mm/min (modal: written once).
//! * Cycle 9 **DWELL TIME** is two blocks, `CYCL DEF 9.0 DWELL TIME` and
//!   `CYCL DEF 9.1 DWELL t` with t in seconds, input range 0 … 3600 s in steps of
//!   0.001 s ([`MAX_DWELL_S`]). It is DEF-active: it runs where it is defined, no
//!   `CYCL CALL` needed.
//! * `;` comment blocks; `M30` ends the program.

use std::fmt::Write as _;

use super::Field;
use super::TableSetting;
use super::modulo::{ModuloError, ModuloRead, ModuloSpec, ModuloSyntax, ModuloTable, deg6};
use super::modulo_update as mu;
use super::program::{ProgramError, ProgramKind, ProgramSyntax, seconds3, signed_mm3};
use super::read::{At, Parsed, check_point, field_at, num, point};
use super::text::Text;
use super::update::fixed;
use super::{
    AxisKind, Dialect, ExportFormat, Limits, SettingsError, Sign, Spacing, TableFormat,
    TableSettings, UpdateStyle, Value, ValueUnit,
};
use crate::base::Axis;
use crate::export::{ExportError, Sampled, fmt_mm};

/// How the limit messages name this controller's table.
pub const LABEL: &str = "a HEIDENHAIN TNC compensation table (.COM)";

/// The TNC 407/415/425 limit on entries per `.COM` table.
pub const HEIDENHAIN_MAX_POINTS: usize = 256;

/// Whether `v` is a name a controller table may carry (a HEIDENHAIN table name or axis
/// key, an ISG axis name): 1–32 letters, digits, `_` or `.`, starting with a letter.
pub fn is_table_name(v: &str) -> bool {
    !v.is_empty()
        && v.len() <= 32
        && v.starts_with(|c: char| c.is_ascii_alphabetic())
        && v.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
}

/// A `.COM` table for axis `axis_key` (e.g. `X`), named `table_name` (e.g. `X.COM`), at
/// most `max_points` rows, values c in mm.
pub fn render(
    s: &Sampled,
    axis_key: &str,
    table_name: &str,
    max_points: usize,
) -> Result<String, ExportError> {
    let bad = |what: &str, v: &str| ExportError::ControllerLimit {
        controller: LABEL,
        problem: format!(
            "{what} `{v}` must be letters, digits, `_` or `.`, starting with a letter"
        ),
    };
    if !is_table_name(axis_key) {
        return Err(bad("the axis key", axis_key));
    }
    if !is_table_name(table_name) {
        return Err(bad("the table name", table_name));
    }
    s.check()?;
    s.uniform_step()?;
    let n = s.len();
    if n > max_points {
        return Err(super::too_many(LABEL, s, 0, max_points, false));
    }
    let mut out = String::with_capacity((n + 4) * 40);
    out.push_str(&format!("BEGIN {table_name} MM\n"));
    out.push_str(&format!("{:<6}{:<18}{axis_key}\n", "NR", "AXISPOS"));
    for (i, (&x, &e)) in s.positions_mm.iter().zip(&s.error_um).enumerate() {
        out.push_str(&format!(
            "{:<6}{:<18}{}\n",
            i,
            signed(x),
            signed(VALUE.sign.of(e) * 1e-3)
        ));
    }
    out.push_str("[END]\n");
    Ok(out)
}

/// A number in mm at the file resolution with an explicit sign, as TNC tables show them.
fn signed(v: f64) -> String {
    let t = fmt_mm(v);
    if t.starts_with('-') {
        t
    } else {
        format!("+{t}")
    }
}

/// One sentence for the export report: where the table goes.
pub fn assignment_note(s: &Sampled, axis_key: &str, table_name: &str) -> String {
    let fixed: Vec<String> = crate::table::Axis::ALL
        .iter()
        .filter(|&&a| a != s.axis)
        .map(|a| format!("{a} = {}", crate::export::fmt_fixed(s.at_mm[a.index()], 4)))
        .collect();
    format!(
        "enter {table_name} in the {axis_key} column of the active line of the .CMA table \
         ({axis_key} = F({axis_key}), measured along {} at {} mm)",
        s.axis,
        fixed.join(", ")
    )
}

// ---------------------------------------------------------------------------------------
// HEIDENHAIN

/// A HEIDENHAIN `.COM` table: `BEGIN <name> MM|INCH`, a column line with `NR`, `AXISPOS`
/// and the compensated axis' column, one row per point, `[END]`.
pub fn read(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let first: Vec<&str> = lines
        .first()
        .map(|l| l.1.split_whitespace().collect())
        .unwrap_or_default();
    let k = match first.as_slice() {
        ["BEGIN", _, "MM"] | ["BEGIN", _] => 1.0,
        ["BEGIN", _, "INCH"] => super::MM_PER_INCH,
        _ => return Err(At::new(1, "not a HEIDENHAIN table (`BEGIN <name> MM`)")),
    };
    let header: Vec<&str> = lines
        .get(1)
        .map(|l| l.1.split_whitespace().collect())
        .unwrap_or_default();
    let (inr, ipos, ival) = heidenhain_columns(&header)?;
    let axis = header[ival].parse::<Axis>().ok();
    let mut parsed = Parsed {
        axis,
        one_column: true,
        ..Default::default()
    };
    let mut ended = false;
    for (i, &(off, l)) in lines.iter().enumerate().skip(2) {
        let line = i + 1;
        let t = l.trim();
        if t.is_empty() {
            continue;
        }
        if ended {
            return Err(At::new(line, "text after [END]"));
        }
        if t == "[END]" {
            ended = true;
            continue;
        }
        let toks = super::read::tokens(l, 0);
        if toks.len() != header.len() {
            return Err(At::new(
                line,
                format!(
                    "{} fields, the column line has {}",
                    toks.len(),
                    header.len()
                ),
            ));
        }
        let tok = |c: usize| &l[toks[c].0..toks[c].1];
        if tok(inr).parse::<u32>().is_err() {
            return Err(At::new(
                line,
                format!("NR `{}` is not a row number", tok(inr)),
            ));
        }
        let p = num(line, "AXISPOS", tok(ipos))? * k;
        let v = num(line, header[ival], tok(ival))?;
        let e = VALUE.error_um(v, k);
        check_point(line, p, &[e])?;
        if let Some(prev) = parsed.points.last()
            && p <= prev.position_mm
        {
            return Err(At::new(
                line,
                format!(
                    "AXISPOS {p} after {}: the points must increase",
                    prev.position_mm
                ),
            ));
        }
        let f = field_at(off + toks[ival].0, tok(ival));
        let mut pt = point(line, p, e, e, v, v, f, f);
        pt.position_file = p / k;
        parsed.points.push(pt);
    }
    if !ended {
        return Err(At::new(
            lines.len().max(1),
            "no [END]: the table is cut short",
        ));
    }
    if parsed.points.len() < 2 {
        return Err(At::new(lines.len().max(1), "a table needs two points"));
    }
    Ok(parsed)
}

/// The column line's NR, AXISPOS and single value column (indices), refusing a BACKLASH
/// column, whose meaning errmap's sources leave open, and more than one axis.
fn heidenhain_columns(header: &[&str]) -> Result<(usize, usize, usize), At> {
    if header.contains(&"BACKLASH") {
        return Err(At::new(
            2,
            "a BACKLASH column: whether it holds the negative-direction value or its difference \
             is not documented in the sources errmap follows",
        ));
    }
    let (Some(inr), Some(ipos)) = (
        header.iter().position(|&h| h == "NR"),
        header.iter().position(|&h| h == "AXISPOS"),
    ) else {
        return Err(At::new(2, "the column line needs NR and AXISPOS"));
    };
    let values: Vec<usize> = (0..header.len())
        .filter(|&i| i != inr && i != ipos)
        .collect();
    let [ival] = values.as_slice() else {
        return Err(At::new(
            2,
            format!(
                "{} value columns: errmap reads one compensated axis",
                values.len()
            ),
        ));
    };
    Ok((inr, ipos, *ival))
}

// ---------------------------------------------------------------------------------------
// The dialect

/// HEIDENHAIN TNC `.COM` tables ([`super::DIALECTS`]).
#[derive(Debug, Clone, Copy)]
pub struct Heidenhain;

/// The values: c in mm (or inch, as the table's first line says).
pub const VALUE: Value = Value {
    sign: Sign::Compensation,
    unit: ValueUnit::Length,
};

impl Dialect for Heidenhain {
    fn modulo(&self) -> Option<&dyn ModuloSyntax> {
        Some(self)
    }
    fn program(&self) -> Option<&dyn ProgramSyntax> {
        Some(self)
    }
    fn name(&self) -> &'static str {
        "heidenhain"
    }
    fn controller(&self) -> &'static str {
        "HEIDENHAIN"
    }
    fn about(&self) -> &'static str {
        "HEIDENHAIN TNC nonlinear axis error compensation table, .COM (a line)"
    }
    fn limits(&self) -> Limits {
        Limits {
            max_points: HEIDENHAIN_MAX_POINTS,
            spacing: Spacing::Equidistant,
            bidirectional: false,
            value: VALUE,
            axes: &[AxisKind::Linear],
        }
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![
            (TableSetting::AxisName, "the column (axis key)".into()),
            (
                TableSetting::MaxPoints,
                format!("entries per .COM (default {HEIDENHAIN_MAX_POINTS})"),
            ),
            (
                TableSetting::TableName,
                "the .COM table (default <axis name>.COM)".into(),
            ),
        ]
    }
    fn detect(&self, _bytes: &[u8], text: &Text) -> bool {
        let lines = text.lines();
        let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
        first.starts_with("BEGIN ") && lines.get(1).is_some_and(|l| l.1.contains("AXISPOS"))
    }
    fn table_format(&self, _: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(TableFormat::Heidenhain)
    }
    fn read(&self, text: &Text, _: TableFormat) -> Result<Parsed, At> {
        read(text)
    }
    fn update_style(&self) -> UpdateStyle {
        // Written at 1e-6 mm with trailing zeros trimmed, `+` on positive values.
        UpdateStyle {
            trimmed_decimals: Some(6),
            plus: true,
            ..UpdateStyle::default()
        }
    }
    fn export_format(&self, s: &TableSettings, _: bool) -> Result<ExportFormat, SettingsError> {
        let axis_key = s.axis_name();
        Ok(ExportFormat::Heidenhain {
            table_name: s
                .table_name
                .clone()
                .unwrap_or_else(|| format!("{axis_key}.COM")),
            axis_key,
            max_points: s.max_points.unwrap_or(HEIDENHAIN_MAX_POINTS),
        })
    }
}

// ---------------------------------------------------------------------------------------
// Part programs

/// Cycle 9's largest dwell, s.
pub const MAX_DWELL_S: f64 = 3600.0;

impl ProgramSyntax for Heidenhain {
    fn name(&self) -> &'static str {
        Dialect::name(self)
    }
    fn extension(&self) -> &'static str {
        "h"
    }
    fn comment(&self, text: &str) -> String {
        format!("; {text}")
    }
    fn begin(&self, kind: ProgramKind) -> Vec<String> {
        vec![format!("BEGIN PGM {} MM", kind.word())]
    }
    fn setup(&self) -> Option<&'static str> {
        None
    }
    fn feed_move(&self, axes: &[(&str, f64)], feed: Option<&str>) -> String {
        let mut s = "L".to_string();
        for (letter, v) in axes {
            s.push_str(&format!(" {letter}{}", signed_mm3(*v)));
        }
        s.push_str(" R0");
        if let Some(f) = feed {
            s.push_str(&format!(" F{f}"));
        }
        s
    }
    fn dwell(&self, dwell_s: f64) -> Result<Vec<String>, ProgramError> {
        if dwell_s > MAX_DWELL_S {
            return Err(ProgramError::DwellTooLong {
                dialect: ProgramSyntax::name(self),
                dwell_s,
                max_s: MAX_DWELL_S,
            });
        }
        Ok(vec![
            "CYCL DEF 9.0 DWELL TIME".into(),
            format!("CYCL DEF 9.1 DWELL {}", seconds3(dwell_s)),
        ])
    }
    fn stop(&self) -> &'static str {
        "STOP"
    }
    fn end(&self, kind: ProgramKind) -> Vec<String> {
        vec!["M30".into(), format!("END PGM {} MM", kind.word())]
    }
    fn numbered(&self) -> bool {
        true
    }
}

// ---------------------------------------------------------------------------------------
// The modulo table of a rotary axis ([`super::modulo`])

fn signed6(v: f64) -> String {
    let v = v + 0.0;
    if v >= 0.0 {
        format!("+{v:.6}")
    } else {
        format!("{v:.6}")
    }
}

/// A rotary `.COM` (`DEG`) table from 0 to 360°, equidistant.
impl ModuloSyntax for Heidenhain {
    fn equidistant(&self) -> bool {
        true
    }
    fn default_max_points(&self) -> usize {
        HEIDENHAIN_MAX_POINTS
    }
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
        let letter = spec.axis.upper();
        let mut s = String::new();
        let c = t.c_arcsec.clone();
        let key = spec.axis_name.clone().unwrap_or_else(|| letter.to_string());
        let _ = writeln!(s, "BEGIN {key}.COM DEG");
        let _ = writeln!(s, "{:<6}{:<18}{key}", "NR", "AXISPOS");
        for (i, (q, c)) in t.points_deg.iter().zip(&c).enumerate() {
            let _ = writeln!(
                s,
                "{:<6}{:<18}{}",
                i,
                format!("+{}", deg6(*q)),
                signed6(c / 3600.0)
            );
        }
        let _ = writeln!(s, "[END]");
        Ok(t.written(s))
    }
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
        let key = spec
            .axis_name
            .clone()
            .unwrap_or_else(|| spec.axis.upper().to_string());
        let all = mu::lines(text);
        let (_, _, begin) = all.first().copied().unwrap_or((1, 0, ""));
        let head: Vec<&str> = begin.split_whitespace().collect();
        if head.first() != Some(&"BEGIN") || !head.iter().any(|w| w.eq_ignore_ascii_case("DEG")) {
            return Err(mu::at(
                1,
                "not a rotary .COM table (its first line is `BEGIN <key>.COM DEG`)",
            ));
        }
        let mut column = None;
        let mut t = ModuloRead::default();
        for &(line, offset, body) in &all[1..] {
            let w = mu::words(body, offset);
            match w.first().map(|x| x.1) {
                None => continue,
                Some("[END]") => break,
                Some("NR") => {
                    column = Some(w.iter().position(|x| x.1 == key).ok_or_else(|| {
                        mu::mismatch(line, mu::TableMismatch::AxisName { key: key.clone() })
                    })?);
                    continue;
                }
                Some(_) => {}
            }
            let c = column.ok_or_else(|| mu::at(line, "a point before the `NR AXISPOS` header"))?;
            let (q, v) = match (w.get(1), w.get(c)) {
                (Some(q), Some(v)) => (mu::number(line, q.1, "AXISPOS")?, *v),
                _ => {
                    return Err(mu::at(
                        line,
                        format!("a row of `NR AXISPOS {key}` has three columns"),
                    ));
                }
            };
            let value = mu::number(line, v.1, &key)?;
            t.angles.push(q);
            t.lines.push(line);
            t.up.push(v.0);
            t.down.push(None);
            t.c_up.push(value * 3600.0);
            t.c_down.push(value * 3600.0);
        }
        t.step_line = t.lines.get(1).copied().unwrap_or(1);
        if let Some(s) = t.angles.get(1).copied() {
            if let Some(j) =
                (0..t.angles.len()).find(|&j| (t.angles[j] - j as f64 * s).abs() > 1e-6)
            {
                return Err(mu::at(
                    t.lines[j],
                    format!("the points are not equidistant (step {s}°)"),
                ));
            }
        }
        Ok(t)
    }
    fn encode(&self, _spec: &ModuloSpec, _q: f64, c: f64, field: Field, old: &str) -> String {
        let s = fixed(c / 3600.0, field.decimals.max(6));
        if old.starts_with('+') && !s.starts_with('-') {
            format!("+{s}")
        } else {
            s
        }
    }
}
