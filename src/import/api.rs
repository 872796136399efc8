//! API (Automated Precision Inc.) XD laser `.pos` export, "Linear Data Table".
//!
//! The layout, as it appears in real exports (a public repository of Fagor compensation
//! tools keeps two, `doug-co/laser_adjust`): a first line
//! `API X-D Laser Measurement Linear Data Table …`, a header of TAB-separated `Key: value`
//! pieces (a piece with no `:` is a further value of the key before it), a TAB-separated
//! readings block headed `Position LasRead LinearError Status AirTemp AirPress MatTemp
//! MatTemp2 MatTemp3` and closed by `DecimalPoints:`, then the vendor's own analysis
//! (compensation table, standard deviations, an ASME B5.54 summary).
//!
//! | quantity | from the file | errmap |
//! |---|---|---|
//! | target P | `Position`·k (k = 25.4 for `Unit: inch`, 1 for mm) | coordinate, `scale_mm` |
//! | error | `LinearError` (= laser − position, file unit) | e_um = −LinearError·k·1000 |
//! | reference | `Position + LinearError` | `laser_mm` = (Position + LinearError)·k |
//! | counting sign s | `LasRead = s·(Position + LinearError)` | checked per reading |
//! | air, material | `AirTemp` °F, `AirPress` inHg, `MatTemp…` °F (−1.00: no sensor), header `Humidity` % | °C, hPa, % |
//!
//! The laser's counting sign differs between exports of one machine (the real X export has
//! s = −1, its Y export s = +1, both headers say `Direction: 1`), so s is the sign most
//! readings satisfy within 2.5 units of the last printed decimal, and a reading that does
//! not satisfy it is refused: LasRead is the one column that ties the others together.
//! The direction of travel is taken from the order of the pass' positions, never from a
//! header flag. The analysis sections are a summary, not data: the compensation table is
//! checked against the readings' means and any disagreement becomes a warning.
//!
//! Unverified against a genuine file: `Bidirection` exports (read as pairs of passes) and
//! mm exports (°C and mmHg assumed; a warning says so).

use std::collections::HashMap;

use super::units::{HPA_PER_INHG, HPA_PER_MMHG, MM_PER_INCH, fahrenheit_to_c};
use super::{
    At, Env, ImportSummary, Imported, Reading, assemble, distinct_targets, summary_counts,
};
use crate::base::Axis;
use crate::controller::text::{Text, decimals, number};

/// The header's keys and their values (first value first), with the line of each key.
#[derive(Debug, Default)]
struct Header {
    values: HashMap<String, (usize, Vec<String>)>,
}

impl Header {
    fn push_line(&mut self, line_no: usize, line: &str) {
        let mut last: Option<String> = None;
        for piece in line.split('\t') {
            let p = piece.trim();
            let key_piece = p
                .split_once(':')
                .filter(|(k, _)| k.chars().next().is_some_and(char::is_alphabetic));
            if let Some((k, v)) = key_piece {
                let key = k.trim().to_string();
                let entry = self
                    .values
                    .entry(key.clone())
                    .or_insert((line_no, Vec::new()));
                if !v.trim().is_empty() {
                    entry.1.push(v.trim().to_string());
                }
                last = Some(key);
            } else if !p.is_empty()
                && let Some(k) = &last
                && let Some(e) = self.values.get_mut(k)
            {
                e.1.push(p.to_string());
            }
        }
    }

    fn first(&self, key: &str) -> Option<(usize, &str)> {
        self.values
            .get(key)
            .and_then(|(l, v)| v.first().map(|s| (*l, s.as_str())))
    }

    fn all(&self, key: &str) -> &[String] {
        self.values
            .get(key)
            .map(|(_, v)| v.as_slice())
            .unwrap_or(&[])
    }

    fn need(&self, key: &str, header_end: usize) -> Result<(usize, &str), At> {
        self.first(key).ok_or_else(|| {
            At::new(
                header_end,
                format!("the header has no `{key}:` (needed: Unit, IniPos, EndPos, RunNum, NumofPos, TestType)"),
            )
        })
    }

    fn need_number(&self, key: &str, header_end: usize) -> Result<f64, At> {
        let (line, v) = self.need(key, header_end)?;
        number(v).ok_or_else(|| At::new(line, format!("`{key}: {v}` is not a number")))
    }
}

/// One parsed row of the readings block.
struct Row {
    line: usize,
    position: f64,
    las_read: f64,
    las_decimals: usize,
    linear_error: f64,
    status: u8,
    env: [Option<f64>; 5],
}

/// The readings block's column line: every name, and where the three required columns are.
struct Columns<'a> {
    names: Vec<&'a str>,
    pos: usize,
    las: usize,
    err: usize,
}

impl<'a> Columns<'a> {
    /// Splits the column line and finds Position, LasRead and LinearError, which every
    /// reading needs; the others (Status, air and material) are optional.
    fn parse(line: &'a str, header_end: usize) -> Result<Columns<'a>, At> {
        let names: Vec<&str> = line.split('\t').map(str::trim).collect();
        let col = |name: &str| names.iter().position(|&c| c == name);
        let (Some(pos), Some(las), Some(err)) =
            (col("Position"), col("LasRead"), col("LinearError"))
        else {
            return Err(At::new(
                header_end,
                "the column line needs Position, LasRead and LinearError",
            ));
        };
        Ok(Columns {
            names,
            pos,
            las,
            err,
        })
    }

    /// The index of the column `name`, if the file has it.
    fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|&c| c == name)
    }
}

/// What the header says about the test: the unit, the travel range and how many readings
/// the block must hold; every later step checks against it.
struct Layout {
    inch: bool,
    /// mm per file unit.
    k: f64,
    ini: f64,
    end: f64,
    runs: usize,
    per_pass: usize,
    bidirectional: bool,
    expected: usize,
}

impl Layout {
    /// Reads Unit, IniPos, EndPos, RunNum, NumofPos and TestType, refusing values the
    /// reader cannot interpret (separate so `read` shows the steps, not the key checks).
    fn from_header(header: &Header, header_end: usize) -> Result<Layout, At> {
        let (unit_line, unit) = header.need("Unit", header_end)?;
        let inch = match unit.to_ascii_lowercase().as_str() {
            "inch" | "in" => true,
            "mm" => false,
            other => {
                return Err(At::new(
                    unit_line,
                    format!("unit `{other}` (expected inch or mm)"),
                ));
            }
        };
        let k = if inch { MM_PER_INCH } else { 1.0 };
        let ini = header.need_number("IniPos", header_end)?;
        let end = header.need_number("EndPos", header_end)?;
        let run_num = header.need_number("RunNum", header_end)?;
        let num_pos = header.need_number("NumofPos", header_end)?;
        let (tt_line, test_type) = header.need("TestType", header_end)?;
        let bidirectional = match test_type.to_ascii_lowercase().as_str() {
            "unidirection" | "unidirectional" => false,
            "bidirection" | "bidirectional" => true,
            other => {
                return Err(At::new(
                    tt_line,
                    format!("TestType `{other}` (expected Unidirection or Bidirection)"),
                ));
            }
        };
        let count_ok = |v: f64| v.fract() == 0.0 && (1.0..=100_000.0).contains(&v);
        if !count_ok(run_num) || !count_ok(num_pos) {
            return Err(At::new(
                header.first("RunNum").map(|l| l.0).unwrap_or(header_end),
                format!("RunNum {run_num} and NumofPos {num_pos} must be whole counts ≥ 1"),
            ));
        }
        let (runs, per_pass) = (run_num as usize, num_pos as usize);
        if per_pass < 2 {
            return Err(At::new(
                header.first("NumofPos").map(|l| l.0).unwrap_or(header_end),
                "NumofPos 1: a pass needs two targets to have a direction of travel",
            ));
        }
        let passes = runs * if bidirectional { 2 } else { 1 };
        Ok(Layout {
            inch,
            k,
            ini,
            end,
            runs,
            per_pass,
            bidirectional,
            expected: passes * per_pass,
        })
    }

    /// "RunNum r × NumofPos n[ × 2 directions]", the count messages' explanation.
    fn counts(&self) -> String {
        format!(
            "RunNum {} × NumofPos {}{}",
            self.runs,
            self.per_pass,
            if self.bidirectional {
                " × 2 directions"
            } else {
                ""
            }
        )
    }

    /// A temperature in °C from the file's unit (°F in inch exports).
    fn temp(&self, v: f64) -> f64 {
        if self.inch { fahrenheit_to_c(v) } else { v }
    }
}

/// Reads an API XD `.pos` export (see the module docs).
pub(super) fn read(bytes: &[u8], axis_override: Option<Axis>) -> Result<Imported, At> {
    let text = Text::decode(bytes).map_err(|(l, m)| At::new(l, m))?;
    let lines = text.lines();
    check_title(&lines)?;
    let (header, ci) = read_header(&lines)?;
    let header_end = ci + 1;
    let columns = Columns::parse(lines[ci].1, header_end)?;
    let layout = Layout::from_header(&header, header_end)?;
    let (rows, closed_at) = read_rows(&lines, ci, &columns, &layout)?;
    let readings = to_readings(&rows, &layout, &header)?;
    let mut warnings = Vec::new();
    if !layout.inch
        && rows
            .iter()
            .any(|r| r.env[0].is_some() || r.env[1].is_some())
    {
        warnings.push(
            "a mm export: AirTemp read as °C and AirPress as mmHg (unverified against a genuine \
             mm file)"
                .to_string(),
        );
    }
    check_compensation_table(&lines, closed_at, &rows, layout.inch, &mut warnings);
    let (axis, at_mm, axis_warning) = placement(&header, axis_override, layout.k, &mut warnings);
    let dt_s = dwell_s(&header, readings.len())?;
    let machine = header
        .first("MachName")
        .or_else(|| header.first("MachID"))
        .map(|(_, v)| v.to_string());
    let rows_out = assemble(&readings, axis, at_mm, dt_s);
    let (runs_n, targets_n, directions) = summary_counts(&readings);
    Ok(Imported {
        summary: ImportSummary {
            format: "api-xd",
            rows: rows_out.len(),
            runs: Some(runs_n),
            targets: targets_n,
            directions,
            units_in: if layout.inch { "inch" } else { "mm" },
            axis: axis.upper(),
            machine,
            warnings,
            axis_warning,
        },
        rows: rows_out,
    })
}

/// The time between readings: the header's `Dwell` (s), 1 s without one. The readings'
/// times t = k·Dwell must stay inside the documented range of a time
/// (`base::TIME_S`, ±10⁹ s): a Dwell of 1e300 imported to times `table` then refused
/// (issue 40 item 6), so it is refused here, at its line.
fn dwell_s(header: &Header, readings: usize) -> Result<f64, At> {
    let Some((line, v)) = header.first("Dwell") else {
        return Ok(1.0);
    };
    // No number, or 0 (no dwell stated): one second, as before.
    let Some(d) = number(v).filter(|&d| d != 0.0) else {
        return Ok(1.0);
    };
    let span = d * readings.saturating_sub(1) as f64;
    let bound = crate::base::TIME_S;
    if !(d.is_finite() && d > 0.0 && bound.contains(span)) {
        return Err(At::new(
            line,
            format!(
                "Dwell {v} s: must be positive and keep the {readings} readings' times within                  {} s (the range of a time)",
                bound.hi
            ),
        ));
    }
    Ok(d)
}

/// Refuses a file whose first line is not the Linear Data Table title, naming the API
/// analysis-only export apart because it is the likely mistake.
fn check_title(lines: &[(usize, &str)]) -> Result<(), At> {
    let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
    if first.starts_with("API X-D Laser Measurement Linear Data Table") {
        return Ok(());
    }
    Err(if first.starts_with("API Linear") {
        At::new(
            1,
            "an API laser analysis section only (no header, no readings, so no unit)",
        )
    } else {
        At::new(
            1,
            "not an API XD export (the first line is not `API X-D Laser Measurement Linear \
             Data Table`)",
        )
    })
}

/// Collects the header's `Key: value` pieces up to the readings' column line, and returns
/// them with that line's index (the header has no closing marker of its own).
fn read_header(lines: &[(usize, &str)]) -> Result<(Header, usize), At> {
    let mut header = Header::default();
    for (i, (_, l)) in lines.iter().enumerate().skip(1) {
        let fields: Vec<&str> = l.split('\t').map(str::trim).collect();
        if fields.first() == Some(&"Position") && fields.contains(&"LinearError") {
            return Ok((header, i));
        }
        header.push_line(i + 1, l);
    }
    Err(At::new(
        lines.len().max(1),
        "no readings: the `Position LasRead LinearError …` column line is missing",
    ))
}

/// Reads the readings block after the column line `ci` up to `DecimalPoints:`, checking
/// its count against the header; returns the rows and the closing line's number.
fn read_rows(
    lines: &[(usize, &str)],
    ci: usize,
    columns: &Columns,
    layout: &Layout,
) -> Result<(Vec<Row>, usize), At> {
    let expected = layout.expected;
    let mut rows: Vec<Row> = Vec::with_capacity(expected);
    for (i, (_, l)) in lines.iter().enumerate().skip(ci + 1) {
        let line = i + 1;
        if l.trim_start().starts_with("DecimalPoints:") {
            if rows.len() != expected {
                return Err(At::new(
                    line,
                    format!(
                        "{} readings, the header says {expected} ({})",
                        rows.len(),
                        layout.counts()
                    ),
                ));
            }
            return Ok((rows, line));
        }
        if rows.len() == expected {
            return Err(At::new(
                line,
                format!(
                    "more readings than the header's {expected} ({})",
                    layout.counts()
                ),
            ));
        }
        rows.push(parse_row(line, l, columns)?);
    }
    Err(At::new(
        lines.len(),
        format!(
            "the file ends inside the readings ({} of {expected}, no `DecimalPoints:` line): \
             truncated",
            rows.len()
        ),
    ))
}

/// Parses one TAB-separated reading into a `Row` (numbers only; the cross-checks between
/// columns and rows come later, once the counting sign is known).
fn parse_row(line: usize, l: &str, columns: &Columns) -> Result<Row, At> {
    let fields: Vec<&str> = l.split('\t').map(str::trim).collect();
    if fields.len() != columns.names.len() {
        return Err(At::new(
            line,
            format!(
                "a reading with {} fields, the column line has {} (a truncated or broken row)",
                fields.len(),
                columns.names.len()
            ),
        ));
    }
    let num = |c: usize| {
        number(fields[c]).ok_or_else(|| {
            At::new(
                line,
                format!("{} `{}` is not a number", columns.names[c], fields[c]),
            )
        })
    };
    let status = match columns.find("Status") {
        Some(c) => {
            let v = num(c)?;
            if v.fract() != 0.0 || !(0.0..=255.0).contains(&v) {
                return Err(At::new(
                    line,
                    format!("Status `{}` is not a laser status code", fields[c]),
                ));
            }
            v as u8
        }
        None => 0,
    };
    let opt = |name: &str| -> Result<Option<f64>, At> {
        match columns.find(name) {
            Some(c) => num(c).map(Some),
            None => Ok(None),
        }
    };
    Ok(Row {
        line,
        position: num(columns.pos)?,
        las_read: num(columns.las)?,
        las_decimals: decimals(fields[columns.las]),
        linear_error: num(columns.err)?,
        status,
        env: [
            opt("AirTemp")?,
            opt("AirPress")?,
            opt("MatTemp")?,
            opt("MatTemp2")?,
            opt("MatTemp3")?,
        ],
    })
}

/// Whether a row satisfies LasRead = s·(Position + LinearError) within 2.5 units of
/// LasRead's last printed decimal.
fn fits(r: &Row, s: f64) -> bool {
    let tol = 2.5 * 10f64.powi(-(r.las_decimals as i32));
    (r.las_read - s * (r.position + r.linear_error)).abs() <= tol + 1e-12
}

/// Turns the rows into readings pass by pass: the counting sign most rows satisfy, the
/// direction from each pass' order, and every row checked against both and the range.
fn to_readings(rows: &[Row], layout: &Layout, header: &Header) -> Result<Vec<Reading>, At> {
    let plus = rows.iter().filter(|r| fits(r, 1.0)).count();
    let minus = rows.iter().filter(|r| fits(r, -1.0)).count();
    let s = if minus > plus { -1.0 } else { 1.0 };
    let (ini, end) = (layout.ini, layout.end);
    let (lo, hi) = (ini.min(end), ini.max(end));
    let range_tol = 1e-9 * (1.0 + hi.abs().max(lo.abs()));
    let mut readings = Vec::with_capacity(rows.len());
    let rh = header.first("Humidity").and_then(|(_, v)| number(v));
    for (p, pass) in rows.chunks(layout.per_pass).enumerate() {
        let direction: i8 = if pass[1].position > pass[0].position {
            1
        } else {
            -1
        };
        for (j, r) in pass.iter().enumerate() {
            if !fits(r, s) {
                return Err(At::new(
                    r.line,
                    format!(
                        "LasRead {} is not {}(Position + LinearError) = {} (the file's counting \
                         sign, from {} of {} readings): the columns disagree",
                        r.las_read,
                        if s < 0.0 { "−" } else { "" },
                        s * (r.position + r.linear_error),
                        plus.max(minus),
                        rows.len()
                    ),
                ));
            }
            if r.position < lo - range_tol || r.position > hi + range_tol {
                return Err(At::new(
                    r.line,
                    format!(
                        "Position {} is outside IniPos {ini} … EndPos {end}",
                        r.position
                    ),
                ));
            }
            if j > 0 && (r.position - pass[j - 1].position) * f64::from(direction) <= 0.0 {
                return Err(At::new(
                    r.line,
                    format!(
                        "Position {} breaks the order of pass {} (it moves {} from {})",
                        r.position,
                        p + 1,
                        if direction > 0 { "up" } else { "down" },
                        pass[0].position
                    ),
                ));
            }
            let run = if layout.bidirectional {
                p / 2 + 1
            } else {
                p + 1
            } as u32;
            let reading = to_reading(r, run, direction, layout, rh);
            reading.check(r.line)?;
            readings.push(reading);
        }
    }
    Ok(readings)
}

/// One checked row as a reading in mm and µm, with its air and material conditions in
/// °C and hPa (the unit conversions in one place).
fn to_reading(r: &Row, run: u32, direction: i8, layout: &Layout, rh: Option<f64>) -> Reading {
    let (inch, k) = (layout.inch, layout.k);
    let mats: Vec<f64> = r.env[2..]
        .iter()
        .flatten()
        .copied()
        .filter(|&v| v != -1.0)
        .collect();
    let part =
        (!mats.is_empty()).then(|| layout.temp(mats.iter().sum::<f64>() / mats.len() as f64));
    let env = Env {
        air_temp_c: r.env[0].map(|v| layout.temp(v)),
        air_pressure_hpa: r.env[1].map(|v| v * if inch { HPA_PER_INHG } else { HPA_PER_MMHG }),
        air_rh_pct: rh,
        scale_temp_c: None,
        part_temp_c: part,
    };
    let target_mm = r.position * k;
    Reading {
        run,
        direction,
        target_mm,
        scale_mm: target_mm,
        laser_mm: (r.position + r.linear_error) * k,
        error_um: -r.linear_error * k * 1000.0,
        flags: r.status,
        env,
    }
}

/// The measured axis (the override, else TestAxis, else X with a warning), the other
/// axes' coordinates from AxesLoc, in mm, and the index of that warning.
fn placement(
    header: &Header,
    axis_override: Option<Axis>,
    k: f64,
    warnings: &mut Vec<String>,
) -> (Axis, [f64; 3], Option<usize>) {
    let letter = header
        .first("TestAxis")
        .map(|(_, v)| v.trim_matches(|c| c == '(' || c == ')').trim().to_string());
    let file_axis = letter.as_deref().and_then(|l| l.parse::<Axis>().ok());
    let (axis, axis_warning) = match (axis_override, file_axis) {
        (Some(a), _) => (a, None),
        (None, Some(a)) => (a, None),
        (None, None) => {
            warnings.push("the file states no axis (TestAxis): taken as X".into());
            (Axis::X, Some(warnings.len() - 1))
        }
    };
    let mut at_mm = [0.0; 3];
    for piece in header.all("AxesLoc") {
        if let Some((l, v)) = piece
            .trim()
            .strip_prefix('(')
            .and_then(|p| p.split_once(')'))
            && let (Ok(a), Some(v)) = (l.trim().parse::<Axis>(), number(v))
            && a != axis
        {
            at_mm[a.index()] = v * k;
        }
    }
    (axis, at_mm, axis_warning)
}

/// Cross-checks the vendor's "API Linear Error Compensation Table" against the readings:
/// every line `position<TAB>value` at a measured target, within 1e-5 in (1e-4 mm) of that
/// target's mean LinearError, and every target listed. Disagreements are warnings.
fn check_compensation_table(
    lines: &[(usize, &str)],
    from: usize,
    rows: &[Row],
    inch: bool,
    warnings: &mut Vec<String>,
) {
    let Some(start) = lines
        .iter()
        .skip(from)
        .position(|(_, l)| l.trim() == "API Linear Error Compensation Table")
        .map(|i| i + from)
    else {
        return;
    };
    let tol = if inch { 1e-5 } else { 1e-4 };
    let targets = distinct_targets(rows.iter().map(|r| r.position));
    let mean = |p: f64| {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| (r.position - p).abs() <= 1e-9)
            .map(|r| r.linear_error)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let mut seen = vec![false; targets.len()];
    // The line after the title is the column line (`Position  …Avg Error`).
    for (i, (_, l)) in lines.iter().enumerate().skip(start + 2) {
        let line = i + 1;
        if l.trim().is_empty() {
            break;
        }
        let fields: Vec<&str> = l.split('\t').map(str::trim).collect();
        let (Some(p), Some(v)) = (
            fields.first().and_then(|f| number(f)),
            fields.get(1).and_then(|f| number(f)),
        ) else {
            warnings.push(format!(
                "line {line}: the vendor's compensation table has `{}`, not position<TAB>value",
                l.trim()
            ));
            continue;
        };
        if fields.len() != 2 {
            warnings.push(format!(
                "line {line}: the vendor's compensation table has {} fields, not 2",
                fields.len()
            ));
        }
        match targets.iter().position(|&t| (t - p).abs() <= 1e-9) {
            None => warnings.push(format!(
                "line {line}: the vendor's compensation table lists {p}, which is not a measured \
                 target"
            )),
            Some(t) => {
                seen[t] = true;
                let m = mean(targets[t]);
                if (v - m).abs() > tol {
                    warnings.push(format!(
                        "line {line}: the vendor's compensation table gives {v} at {p}, the \
                         readings' mean LinearError is {m:.6}"
                    ));
                }
            }
        }
    }
    for (t, s) in targets.iter().zip(&seen) {
        if !s {
            warnings.push(format!(
                "line {}: the vendor's compensation table has no line for the target {t}",
                start + 1
            ));
        }
    }
}
