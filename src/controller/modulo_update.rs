//! The recalibration of a rotary axis: a modulo table already in use (`export --existing`),
//! corrected by a session measured with it active, written back in the file's own layout
//! (`docs/rotary.md`, "Updating a modulo table in use").
//!
//! The session's error is then the **residual** the table leaves. Each direction d's
//! residual r_d (the rotary error table's e, or e↑ = −x̄↑ and e↓ = −x̄↓ with
//! `--bidirectional`) is detrended by its own closure gap, as [`super::modulo`] does
//! (the gap is a ratio error the table cannot carry: reported), and the table's
//! compensation at each of its points q becomes
//!
//! c_new,d(q) = c_old,d(q) − (r′_d(q) − r̄′(R)),  r̄′(R) the mean of the directions' r′_d(R),
//!
//! so the reference position R keeps its correction (on average over the directions) and
//! the two ends, 0° and 360°, keep equal corrections. Without `--bidirectional` a
//! one-direction table stays one (Fagor's err− stays all 0); LinuxCNC's reverse column
//! gets the same change as its forward one.
//!
//! Every modulo rule is checked on the table read (refused, naming the line, when broken:
//! 0 and 360 first and last, equal end corrections, Siemens `IS_MODULO = 1`, `_MIN` 0,
//! `_MAX` 360, FANUC's increments summing to 0 and v₀ = v_last, the axis and the step) and
//! kept on the result, which is read back through the same checks. Only the values change:
//! each is rounded to the decimals its field was written with (at least 6 for the
//! ° tables, 4 for Fagor), a value whose text does not change keeps it, and everything
//! else is kept byte for byte — so a zero residual gives the file back unchanged.
//! FANUC: the absolute curve A_j = Σ_{1..j} v (detection units × magnification) gets
//! the change of E = −c, rounded as absolute values, and is differenced again, so a
//! revolution still sums to 0 exactly.

use super::modulo::{
    DirectionsSummary, MAX_TARGETS, ModuloDialect, ModuloError, ModuloSpec, ModuloTable,
    check_revolution, detrended, fanuc_increments, interp, linuxcnc_value,
};
use super::update::{Edit, apply, fixed};
use super::{ControllerSetting, Field};
use crate::base::NamesSettings;

/// A modulo table as read: its points and each direction's compensation, ″, and where
/// each value stands in the text.
struct Read {
    angles: Vec<f64>,
    lines: Vec<usize>,
    /// Each point's value field(s): moving + and (LinuxCNC, Fagor) moving −.
    up: Vec<Field>,
    down: Vec<Option<Field>>,
    c_up: Vec<f64>,
    c_down: Vec<f64>,
    /// A two-direction table (LinuxCNC forward ≠ reverse, Fagor err− not all 0).
    two: bool,
    /// The line that states the step (Siemens, FANUC), else the second point's.
    step_line: usize,
    fanuc: Option<FanucRead>,
}

/// FANUC's increments and the unit of one count, ″.
struct FanucRead {
    unit_arcsec: f64,
    increments: Vec<(Field, i64)>,
}

fn at(line: usize, problem: impl Into<String>) -> ModuloError {
    ModuloError::Existing {
        line,
        problem: problem.into(),
    }
}

fn mismatch(line: usize, mismatch: TableMismatch) -> ModuloError {
    ModuloError::Mismatch { line, mismatch }
}

/// A table in use that does not fit a setting of the update: the step or the axis it
/// was asked to have (`ModuloError::Mismatch`).
#[derive(Debug, Clone, PartialEq)]
pub enum TableMismatch {
    /// Its `points` are not every `step_deg`.
    Step { step_deg: f64, points: usize },
    /// A Siemens table for the axis `found`, not `expected`.
    SiemensAxis { found: String, expected: String },
    /// A HEIDENHAIN table without the column `key`.
    AxisName { key: String },
}

impl TableMismatch {
    /// The mismatch with the setting called by `name`.
    pub fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        match self {
            TableMismatch::Step { step_deg, points } => format!(
                "the table's points are not every {step_deg}° as {} says ({points} points)",
                name(ControllerSetting::Step)
            ),
            TableMismatch::SiemensAxis { found, expected } => format!(
                "the table is for axis {found}, not {expected} ({})",
                name(ControllerSetting::SiemensAxis)
            ),
            TableMismatch::AxisName { key } => format!(
                "no column {key} (the table is for another axis: {})",
                name(ControllerSetting::AxisName)
            ),
        }
    }
}

impl NamesSettings for ModuloError {
    type Setting = ControllerSetting;
    fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        match self {
            ModuloError::Mismatch { line, mismatch } => {
                format!("line {line}: {}", mismatch.render(name))
            }
            // The rest name no setting (a variant added to `modulo.rs` falls here).
            other => other.to_string(),
        }
    }
}

/// The whitespace-separated words of `line` (starting at byte `offset` of the text) with
/// their byte ranges in the text.
fn words(line: &str, offset: usize) -> Vec<(Field, &str)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, ch) in line
        .char_indices()
        .chain(std::iter::once((line.len(), ' ')))
    {
        match (ch.is_whitespace(), start) {
            (true, Some(s)) => {
                let w = &line[s..i];
                out.push((field(offset + s, offset + i, w), w));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    out
}

fn field(start: usize, end: usize, w: &str) -> Field {
    Field {
        start,
        end,
        decimals: w.split_once('.').map_or(0, |(_, d)| d.len()),
    }
}

fn number(line: usize, w: &str, what: &str) -> Result<f64, ModuloError> {
    w.trim_start_matches('+')
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| at(line, format!("{what} `{w}` is not a number")))
}

/// The text's lines with their 1-based numbers and byte offsets (line ends dropped).
fn lines(text: &str) -> Vec<(usize, usize, &str)> {
    let mut out = Vec::new();
    let mut offset = 0;
    for (k, l) in text.split_inclusive('\n').enumerate() {
        let body = l.trim_end_matches(['\n', '\r']);
        out.push((k + 1, offset, body));
        offset += l.len();
    }
    out
}

/// Reads the modulo table `text` of `spec`'s dialect and checks its rules.
fn read(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let mut t = match spec.dialect {
        ModuloDialect::LinuxCnc => read_linuxcnc(text, spec)?,
        ModuloDialect::Siemens => read_siemens(text, spec)?,
        ModuloDialect::Fanuc => read_fanuc(text, spec)?,
        ModuloDialect::Heidenhain => read_heidenhain(text, spec)?,
        ModuloDialect::Fagor8055 => read_fagor(text, spec)?,
    };
    check_read(&mut t, spec)?;
    Ok(t)
}

/// The rules every modulo table keeps: 0 first, 360 last, increasing, equal ends, the
/// step `--step` names, at most [`MAX_TARGETS`] points.
fn check_read(t: &mut Read, spec: &ModuloSpec) -> Result<(), ModuloError> {
    let n = t.angles.len();
    let last = *t.lines.last().unwrap_or(&1);
    if n < 2 {
        return Err(at(last, "fewer than two points: not a modulo table"));
    }
    if n > MAX_TARGETS {
        return Err(at(
            t.lines[MAX_TARGETS],
            format!("more than {MAX_TARGETS} points"),
        ));
    }
    if t.angles[0].abs() > 1e-9 {
        return Err(at(
            t.lines[0],
            format!("the first point is at {}°, not 0°", t.angles[0]),
        ));
    }
    if (t.angles[n - 1] - 360.0).abs() > 1e-9 {
        return Err(at(
            t.lines[n - 1],
            format!(
                "the last point is at {}°, not 360°: not a modulo table",
                t.angles[n - 1]
            ),
        ));
    }
    if let Some(k) = (1..n).find(|&k| t.angles[k] <= t.angles[k - 1]) {
        return Err(at(t.lines[k], "the angles do not increase"));
    }
    for (c, what) in [(&t.c_up, "moving +"), (&t.c_down, "moving −")] {
        if (c[0] - c[n - 1]).abs() > 1e-6 {
            return Err(at(
                t.lines[n - 1],
                format!(
                    "the corrections at 0° and 360° differ ({what}: {:.4}″ and {:.4}″): a \
                     modulo table has equal ends",
                    c[0],
                    c[n - 1]
                ),
            ));
        }
    }
    if let Some(s) = spec.step_deg {
        let k = (360.0 / s).round() as usize;
        let bad = (n != k + 1)
            .then_some(1)
            .or_else(|| (0..n).find(|&j| (t.angles[j] - j as f64 * s).abs() > 1e-6));
        if let Some(j) = bad {
            return Err(mismatch(
                if j == 1 { t.step_line } else { t.lines[j] },
                TableMismatch::Step {
                    step_deg: s,
                    points: n,
                },
            ));
        }
    }
    Ok(())
}

fn read_linuxcnc(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let mut t = empty();
    for (line, offset, body) in lines(text) {
        let w = words(body, offset);
        if w.is_empty() || w[0].1.starts_with('#') {
            continue;
        }
        if w.len() != 3 {
            return Err(at(
                line,
                "a LinuxCNC comp line is `nominal forward reverse`",
            ));
        }
        let q = number(line, w[0].1, "nominal")?;
        let decode = |v: f64| {
            if spec.trim {
                -v * 3600.0
            } else {
                (v - q) * 3600.0
            }
        };
        t.angles.push(q);
        t.lines.push(line);
        t.c_up.push(decode(number(line, w[1].1, "forward")?));
        t.c_down.push(decode(number(line, w[2].1, "reverse")?));
        t.up.push(w[1].0);
        t.down.push(Some(w[2].0));
    }
    t.two = t
        .c_up
        .iter()
        .zip(&t.c_down)
        .any(|(a, b)| (a - b).abs() > 1e-9);
    t.step_line = t.lines.get(1).copied().unwrap_or(1);
    Ok(t)
}

fn empty() -> Read {
    Read {
        angles: Vec::new(),
        lines: Vec::new(),
        up: Vec::new(),
        down: Vec::new(),
        c_up: Vec::new(),
        c_down: Vec::new(),
        two: false,
        step_line: 1,
        fanuc: None,
    }
}

/// `name[args]=value` of a Siemens line: the name, the arguments, the value's field.
fn siemens_assignment(body: &str, offset: usize) -> Option<(&str, Vec<&str>, Field, &str)> {
    let code = body.split(';').next()?.trim_end();
    let (lhs, rhs) = code.split_once('=')?;
    let (name, args) = lhs.trim().split_once('[')?;
    let args = args.strip_suffix(']')?.split(',').map(str::trim).collect();
    let v = rhs.trim();
    let start = offset + code.len() - rhs.trim_start().len();
    Some((name, args, field(start, start + v.len(), v), v))
}

fn read_siemens(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let ax = spec
        .siemens_axis
        .clone()
        .unwrap_or_else(|| format!("{}1", spec.axis.upper()));
    let mut t = empty();
    let mut points: Vec<(usize, usize, Field, f64)> = Vec::new();
    let (mut step, mut min, mut max, mut modulo) = (None, None, None, None);
    for (line, offset, body) in lines(text) {
        let Some((name, args, f, v)) = siemens_assignment(body, offset) else {
            continue;
        };
        if !name.starts_with("$AA_ENC_COMP") {
            continue;
        }
        let axis = args.last().copied().unwrap_or("");
        if axis != ax {
            return Err(mismatch(
                line,
                TableMismatch::SiemensAxis {
                    found: axis.to_string(),
                    expected: ax,
                },
            ));
        }
        let value = number(line, v, name)?;
        match name {
            "$AA_ENC_COMP" => {
                let i: usize = args
                    .get(1)
                    .and_then(|i| i.parse().ok())
                    .ok_or_else(|| at(line, "the point index is not a whole number"))?;
                points.push((i, line, f, value));
            }
            "$AA_ENC_COMP_STEP" => step = Some((line, value)),
            "$AA_ENC_COMP_MIN" => min = Some((line, value)),
            "$AA_ENC_COMP_MAX" => max = Some((line, value)),
            "$AA_ENC_COMP_IS_MODULO" => modulo = Some((line, value)),
            _ => {}
        }
    }
    let last = lines(text).len();
    match modulo {
        Some((_, 1.0)) => {}
        Some((line, v)) => {
            return Err(at(
                line,
                format!("$AA_ENC_COMP_IS_MODULO is {v}: not a modulo table"),
            ));
        }
        None => return Err(at(last, "no $AA_ENC_COMP_IS_MODULO=1: not a modulo table")),
    }
    for (name, got, want) in [("_MIN", min, 0.0), ("_MAX", max, 360.0)] {
        match got {
            Some((_, v)) if (v - want).abs() <= 1e-9 => {}
            Some((line, v)) => {
                return Err(at(line, format!("$AA_ENC_COMP{name} is {v}, not {want}")));
            }
            None => return Err(at(last, format!("no $AA_ENC_COMP{name}"))),
        }
    }
    let (step_line, s) = step.ok_or_else(|| at(last, "no $AA_ENC_COMP_STEP"))?;
    if points.len() > MAX_TARGETS {
        return Err(at(
            points[MAX_TARGETS].1,
            format!("more than {MAX_TARGETS} points"),
        ));
    }
    for (k, &(i, line, f, v)) in points.iter().enumerate() {
        if i != k {
            return Err(at(line, format!("point {i} where point {k} was expected")));
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

fn read_heidenhain(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let key = spec
        .axis_name
        .clone()
        .unwrap_or_else(|| spec.axis.upper().to_string());
    let all = lines(text);
    let (_, _, begin) = all.first().copied().unwrap_or((1, 0, ""));
    let head: Vec<&str> = begin.split_whitespace().collect();
    if head.first() != Some(&"BEGIN") || !head.iter().any(|w| w.eq_ignore_ascii_case("DEG")) {
        return Err(at(
            1,
            "not a rotary .COM table (its first line is `BEGIN <key>.COM DEG`)",
        ));
    }
    let mut column = None;
    let mut t = empty();
    for &(line, offset, body) in &all[1..] {
        let w = words(body, offset);
        match w.first().map(|x| x.1) {
            None => continue,
            Some("[END]") => break,
            Some("NR") => {
                column =
                    Some(w.iter().position(|x| x.1 == key).ok_or_else(|| {
                        mismatch(line, TableMismatch::AxisName { key: key.clone() })
                    })?);
                continue;
            }
            Some(_) => {}
        }
        let c = column.ok_or_else(|| at(line, "a point before the `NR AXISPOS` header"))?;
        let (q, v) = match (w.get(1), w.get(c)) {
            (Some(q), Some(v)) => (number(line, q.1, "AXISPOS")?, *v),
            _ => {
                return Err(at(
                    line,
                    format!("a row of `NR AXISPOS {key}` has three columns"),
                ));
            }
        };
        let value = number(line, v.1, &key)?;
        t.angles.push(q);
        t.lines.push(line);
        t.up.push(v.0);
        t.down.push(None);
        t.c_up.push(value * 3600.0);
        t.c_down.push(value * 3600.0);
    }
    t.step_line = t.lines.get(1).copied().unwrap_or(1);
    if let Some(s) = t.angles.get(1).copied() {
        if let Some(j) = (0..t.angles.len()).find(|&j| (t.angles[j] - j as f64 * s).abs() > 1e-6) {
            return Err(at(
                t.lines[j],
                format!("the points are not equidistant (step {s}°)"),
            ));
        }
    }
    Ok(t)
}

fn read_fagor(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let letter = spec.axis.upper().to_string();
    let e = format!("E{letter}");
    let mut t = empty();
    for (line, offset, body) in lines(text) {
        let w = words(body, offset);
        if w.is_empty() {
            continue;
        }
        if w.len() != 7 || !w[0].1.starts_with('P') {
            return Err(at(
                line,
                format!("a Fagor line is `P<n> {letter} <pos> {e} <err+> {e} <err−>`"),
            ));
        }
        if w[1].1 != letter || w[3].1 != e || w[5].1 != e {
            return Err(at(
                line,
                format!("the table is for axis {}, not {letter}", w[1].1),
            ));
        }
        t.angles.push(number(line, w[2].1, "position")?);
        t.lines.push(line);
        t.c_up.push(number(line, w[4].1, "err+")? * 3600.0);
        t.c_down.push(number(line, w[6].1, "err−")? * 3600.0);
        t.up.push(w[4].0);
        t.down.push(Some(w[6].0));
    }
    // err− all 0: one table for both directions (Fagor's rule).
    t.two = t.c_down.iter().any(|&c| c != 0.0);
    if !t.two {
        t.c_down = t.c_up.clone();
    }
    t.step_line = t.lines.get(1).copied().unwrap_or(1);
    Ok(t)
}

/// `key=value` pairs of FANUC's parameter comment.
fn fanuc_parameters(body: &str) -> Vec<(u32, &str)> {
    body.trim_matches(|c| c == '(' || c == ')')
        .split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .filter_map(|(k, v)| Some((k.parse().ok()?, v)))
        .collect()
}

fn read_fanuc(text: &str, spec: &ModuloSpec) -> Result<Read, ModuloError> {
    let mut params: Option<(usize, Vec<(u32, &str)>)> = None;
    let mut unit_deg = spec.detection_unit_deg;
    let mut increments: Vec<(usize, usize, Field, i64)> = Vec::new();
    for (line, offset, body) in lines(text) {
        if body.contains("3620=") {
            params = Some((line, fanuc_parameters(body)));
        } else if body.starts_with('(') {
            let words: Vec<&str> = body.split_whitespace().collect();
            if let Some(k) = words.iter().position(|w| *w == "axis") {
                let a = words.get(k + 1).map_or("", |w| w.trim_end_matches(','));
                if !a.eq_ignore_ascii_case(spec.axis.upper().to_string().as_str()) {
                    return Err(at(
                        line,
                        format!("the table is for axis {a}, not {}", spec.axis.upper()),
                    ));
                }
            }
            if let Some(k) = words.iter().position(|w| *w == "unit") {
                unit_deg = words
                    .get(k + 1)
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(unit_deg);
            }
        } else if let Some(rest) = body.strip_prefix('N') {
            let (n, v) = rest
                .split_once('P')
                .ok_or_else(|| at(line, "a FANUC line is `N<number>P<value>`"))?;
            let n: usize = n
                .parse()
                .map_err(|_| at(line, format!("`N{n}` is not a point number")))?;
            let value: i64 = v
                .parse()
                .map_err(|_| at(line, format!("`P{v}` is not a whole number")))?;
            let start = offset + body.len() - v.len();
            increments.push((n, line, field(start, start + v.len(), v), value));
        }
    }
    let (pline, params) =
        params.ok_or_else(|| at(1, "no parameter comment `(3620=… 3625=360)`"))?;
    let get = |k: u32| -> Result<f64, ModuloError> {
        params
            .iter()
            .find(|p| p.0 == k)
            .and_then(|p| p.1.parse().ok())
            .ok_or_else(|| at(pline, format!("parameter {k} is missing")))
    };
    let (p, magnification, step) = (get(3620)?, get(3623)?, get(3624)?);
    if get(3625)? != 360.0 {
        return Err(at(pline, "3625 is not 360: not a rotary axis' table"));
    }
    if get(3621)? != p || get(3622)? != p + increments.len().saturating_sub(1) as f64 {
        return Err(at(pline, "3621 and 3622 are not 3620 and 3620 + 360/3624"));
    }
    let unit_arcsec = unit_deg * 3600.0 * magnification.max(1.0);
    let mut t = empty();
    let mut sum = 0i64;
    for (j, &(n, line, f, v)) in increments.iter().enumerate() {
        if n != 10000 + p as usize + j {
            return Err(at(
                line,
                format!("point N{n} where N{} was expected", 10000 + p as usize + j),
            ));
        }
        if j > 0 {
            sum += v;
        }
        t.angles.push(j as f64 * step);
        t.lines.push(line);
        t.up.push(f);
        t.down.push(None);
        t.c_up.push(-(sum as f64) * unit_arcsec);
    }
    let last = t.lines.last().copied().unwrap_or(pline);
    if sum != 0 {
        return Err(at(
            last,
            format!("the increments of a revolution sum to {sum}, not 0"),
        ));
    }
    if increments.first().map(|i| i.3) != increments.last().map(|i| i.3) {
        return Err(at(
            t.lines[0],
            "the reference point's value differs from the last point's",
        ));
    }
    t.c_down = t.c_up.clone();
    t.step_line = pline;
    t.fanuc = Some(FanucRead {
        unit_arcsec,
        increments: increments.iter().map(|i| (i.2, i.3)).collect(),
    });
    Ok(t)
}

/// The value text of correction `c` ″ at `q` ° for `field` (the old text `old`).
fn encode(spec: &ModuloSpec, q: f64, c: f64, field: Field, old: &str) -> String {
    let dec = field.decimals.max(6);
    match spec.dialect {
        ModuloDialect::LinuxCnc => fixed(linuxcnc_value(q, c, spec.trim, dec), dec),
        ModuloDialect::Siemens => fixed(c / 3600.0, dec),
        ModuloDialect::Heidenhain => {
            let s = fixed(c / 3600.0, dec);
            if old.starts_with('+') && !s.starts_with('-') {
                format!("+{s}")
            } else {
                s
            }
        }
        ModuloDialect::Fagor8055 => fixed(c / 3600.0, field.decimals),
        // FANUC's increments are written by `fanuc_edits`.
        ModuloDialect::Fanuc => old.to_string(),
    }
}

/// Plans writing `new` over `field` unless it reads as the same number.
fn edit(edits: &mut Vec<Edit>, text: &str, field: Field, new: String, align: bool) {
    let old = &text[field.start..field.end];
    let same = |a: &str, b: &str| {
        a.trim_start_matches('+').parse::<f64>().ok()
            == b.trim_start_matches('+').parse::<f64>().ok()
    };
    if !same(old, &new) {
        edits.push(Edit {
            field,
            text: new,
            align,
        });
    }
}

/// FANUC: the absolute curve gets the change of E = −c (`delta` the change of c at each
/// point, ″), rounded, differenced again; v₀ = v_last.
fn fanuc_edits(f: &FanucRead, delta: &[f64], spec: &ModuloSpec) -> Result<Vec<Edit>, ModuloError> {
    let mut absolute = Vec::with_capacity(delta.len());
    let mut sum = 0i64;
    for (j, (inc, d)) in f.increments.iter().zip(delta).enumerate() {
        if j > 0 {
            sum += inc.1;
        }
        absolute.push(sum + (-d / f.unit_arcsec).round() as i64);
    }
    let v = fanuc_increments(&absolute, spec)?;
    Ok(f.increments
        .iter()
        .zip(&v)
        .filter(|(old, new)| old.1 != **new)
        .map(|(old, new)| Edit {
            field: old.0,
            text: new.to_string(),
            align: false,
        })
        .collect())
}

/// The modulo table in use (`bytes`) updated by the residual `series` measured with it
/// active: one series (both directions) or two (moving +, moving −); see the module docs.
pub fn update_modulo(
    bytes: &[u8],
    series: &[&[(f64, f64)]],
    spec: &ModuloSpec,
) -> Result<ModuloTable, ModuloError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        at(line, "not text (UTF-8 or ASCII)")
    })?;
    for s in series {
        check_revolution(s)?;
    }
    if series.len() == 2 && spec.dialect.equidistant() {
        return Err(ModuloError::OneDirection {
            format: spec.dialect.name(),
        });
    }
    let old = read(text, spec)?;
    let r = spec.reference_deg;
    if !old.angles.iter().any(|a| (a - r).abs() <= 1e-9) {
        return Err(ModuloError::Reference {
            reference_deg: r,
            hint: "one of the table's points".into(),
        });
    }
    let (v, gaps): (Vec<Vec<(f64, f64)>>, Vec<f64>) = series.iter().map(|s| detrended(s)).unzip();
    let datums: Vec<f64> = v.iter().map(|v| interp(v, r)).collect();
    let datum = datums.iter().sum::<f64>() / datums.len() as f64;
    let delta = |v: &[(f64, f64)]| -> Vec<f64> {
        old.angles
            .iter()
            .map(|&q| -(interp(v, q) - datum))
            .collect()
    };
    let (d_up, d_down) = (delta(&v[0]), delta(&v[v.len() - 1]));
    let two_out = series.len() == 2 || old.two;
    let mut edits = Vec::new();
    if let Some(f) = &old.fanuc {
        edits = fanuc_edits(f, &d_up, spec)?;
    } else {
        let align = matches!(
            spec.dialect,
            ModuloDialect::LinuxCnc | ModuloDialect::Fagor8055
        );
        for k in 0..old.angles.len() {
            let q = old.angles[k];
            let f = old.up[k];
            let new = encode(spec, q, old.c_up[k] + d_up[k], f, &text[f.start..f.end]);
            edit(&mut edits, text, f, new, align);
            if let Some(f) =
                old.down[k].filter(|_| two_out || spec.dialect == ModuloDialect::LinuxCnc)
            {
                let new = encode(spec, q, old.c_down[k] + d_down[k], f, &text[f.start..f.end]);
                edit(&mut edits, text, f, new, align);
            }
        }
    }
    let new_text = apply(text, edits);
    let new = read(&new_text, spec)?;
    summary(spec, &old, new, new_text, &v, &gaps, &datums)
}

/// What the update reports: the residual's closure gaps, the change at the points and
/// the residual left at the targets (the change interpolated between points).
fn summary(
    spec: &ModuloSpec,
    old: &Read,
    new: Read,
    text: String,
    v: &[Vec<(f64, f64)>],
    gaps: &[f64],
    datums: &[f64],
) -> Result<ModuloTable, ModuloError> {
    let datum = datums.iter().sum::<f64>() / datums.len() as f64;
    let change = |c_new: &[f64], c_old: &[f64]| -> Vec<(f64, f64)> {
        old.angles
            .iter()
            .zip(c_new.iter().zip(c_old))
            .map(|(&q, (a, b))| (q, a - b))
            .collect()
    };
    let changes = [
        change(&new.c_up, &old.c_up),
        change(&new.c_down, &old.c_down),
    ];
    let max_change = changes
        .iter()
        .flatten()
        .map(|c| c.1.abs())
        .fold(0.0, f64::max);
    let residuals: Vec<f64> = v
        .iter()
        .enumerate()
        .map(|(d, v)| {
            v.iter()
                .map(|&(q, e)| (e - datum + interp(&changes[d], q)).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let g = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let mut warnings = Vec::new();
    if g.abs() > 1e-9 {
        warnings.push(format!(
            "the residual's closure gap {g:.3}″ ({:.3} ppm) is left out of the table: a modulo \
             table cannot carry a ratio error; correct the ratio",
            g / 1.296
        ));
    }
    let directions = match (gaps, datums, residuals.as_slice()) {
        ([gu, gd], [du, dd], [ru, rd]) => Some(DirectionsSummary {
            closure_gap_up_arcsec: *gu,
            closure_gap_down_arcsec: *gd,
            datum_up_arcsec: *du,
            datum_down_arcsec: *dd,
            max_residual_up_arcsec: *ru,
            max_residual_down_arcsec: *rd,
        }),
        _ => None,
    };
    Ok(ModuloTable {
        text,
        format: spec.dialect.name(),
        axis: spec.axis,
        points: new.angles.len(),
        step_deg: spec.dialect.equidistant().then(|| new.angles[1]),
        reference_deg: spec.reference_deg,
        closure_gap_arcsec: g,
        ratio_ppm: g / 1.296,
        datum_offset_arcsec: datum,
        max_residual_arcsec: residuals.iter().copied().fold(0.0, f64::max),
        max_change_arcsec: Some(max_change),
        c_down_arcsec: (new.two || spec.dialect == ModuloDialect::LinuxCnc)
            .then(|| new.c_down.clone()),
        c_arcsec: new.c_up,
        points_deg: new.angles,
        directions,
        warnings,
    })
}
