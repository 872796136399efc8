//! The compensation table already in a controller, read back into errmap's sign: for each
//! table point the error e the table compensates moving up and down (µm, e = indicated −
//! reference), and where each value sits in the file, so that [`super::update`] can
//! rewrite the values and nothing else.
//!
//! | format | file | values | errmap |
//! |---|---|---|---|
//! | Fagor 8055 `AL<axis>` | lines `P<n> <A> <pos> E<A> <err+> E<A> <err−>` to the first blank line, positions strictly increasing, unit stated nowhere (`--units`) | Fagor error = actual − theoretical = x (the CNC subtracts it) | e_up = −err+·k·1000, e_down = −err−·k·1000; all err− = 0: one table for both directions |
//! | Fagor 8065 `<axis>.mp` | UTF-16LE with mark, CRLF, first line `<A> AXIS`; `/LSCRWDATA/NPOINTS`, `/BIDIR`, `/DATA/POSITION i`, `/POSERROR i`, `/NEGERROR i` | mm unless `--units inch`; same sign as 8055 | BIDIR 0: e_down = e_up |
//! | LinuxCNC `COMP_FILE` | `nominal forward reverse` per line | type 1 (trim): e = v·1000; type 0 (actual): e = (nominal − v)·1000 | forward → e_up, reverse → e_down |
//!
//! The Fagor sign follows the manuals' "error = real position − theoretical position" and
//! the public `laser_adjust` tool, which adds a laser's LinearError to the table; it has not
//! been checked on a machine (`docs/import.md`). The LinuxCNC rule is the inverse of
//! [`crate::export::linuxcnc`].

use std::path::Path;

use polars::prelude::{Column, DataFrame};
use serde::Serialize;

use super::csv::LengthUnit;
use super::text::{Text, decimals, number};
use super::{At, ImportSummary, snap};
use crate::base::Axis;
use crate::export::LinuxCncCompType;
use crate::table::{TableError, write_frame};

/// Which controller table, and what the file does not say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    /// Fagor 8055 `AL<axis>`; the file states no unit.
    Fagor8055 { units: LengthUnit },
    /// Fagor 8065 `<axis>.mp` (mm unless told).
    Fagor8065 { units: LengthUnit },
    /// LinuxCNC `COMP_FILE` (mm unless told); its type is not in the file.
    LinuxCnc {
        comp_type: LinuxCncCompType,
        units: LengthUnit,
    },
    /// Siemens 840D LEC/MSEC or direction-dependent CEC program (mm).
    Siemens,
    /// FANUC pitch error data as errmap writes them (its parameter comment).
    Fanuc,
    /// HEIDENHAIN `.COM` table (`MM`, or `INCH` in its first line).
    Heidenhain,
    /// TwinCAT CNC (ISG) `kw.ssfk` compensation value list (0.1 µm).
    Isg,
}

impl TableFormat {
    pub fn name(self) -> &'static str {
        match self {
            TableFormat::Fagor8055 { .. } => "fagor-8055",
            TableFormat::Fagor8065 { .. } => "fagor-8065",
            TableFormat::LinuxCnc { .. } => "linuxcnc",
            TableFormat::Siemens => "siemens",
            TableFormat::Fanuc => "fanuc",
            TableFormat::Heidenhain => "heidenhain",
            TableFormat::Isg => "isg",
        }
    }

    pub fn units(self) -> LengthUnit {
        match self {
            TableFormat::Fagor8055 { units }
            | TableFormat::Fagor8065 { units }
            | TableFormat::LinuxCnc { units, .. } => units,
            TableFormat::Siemens
            | TableFormat::Fanuc
            | TableFormat::Heidenhain
            | TableFormat::Isg => LengthUnit::Mm,
        }
    }
}

/// Where a number sits in the decoded text: byte range and the decimals written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    pub start: usize,
    pub end: usize,
    pub decimals: usize,
}

/// One table point.
#[derive(Debug, Clone, PartialEq)]
pub struct TablePoint {
    /// 1-based line of the point (8065: of its POSITION).
    pub line: usize,
    pub position_mm: f64,
    /// The error the table compensates moving +, errmap sign, µm.
    pub e_up_um: f64,
    /// The same moving −.
    pub e_down_um: f64,
    /// The position and the two values as written (file units).
    pub position_file: f64,
    pub up_file: f64,
    pub down_file: f64,
    pub up: Field,
    pub down: Field,
}

/// A controller table as read (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerTable {
    pub format: TableFormat,
    pub text: Text,
    /// The axis the file names (8055's letter, 8065's first line, errmap's comment in a
    /// Siemens or FANUC file, the HEIDENHAIN column, the ISG axis name); `None` when it
    /// names none (LinuxCNC). [`ControllerTable::assume_axis`] gives one to such a table.
    pub axis: Option<Axis>,
    /// Whether `axis` was given by the caller rather than read from the file.
    pub axis_assumed: bool,
    pub points: Vec<TablePoint>,
    /// Whether the table has separate values for the two directions.
    pub bidirectional: bool,
    /// 8065: the `/LSCRWDATA/BIDIR` value and its comment (`No`/`Yes`), when present.
    pub bidir_value: Option<Field>,
    pub bidir_comment: Option<Field>,
    /// One value per point, no second direction possible (Siemens LEC, HEIDENHAIN, …).
    pub one_column: bool,
    /// FANUC: the increments and where they sit.
    pub fanuc: Option<super::dialects::FanucLayout>,
}

/// The byte ranges of the whitespace-separated tokens of `line` (offsets from `base`).
fn tokens(line: &str, base: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in line.char_indices() {
        if c.is_whitespace() {
            if let Some(s) = start.take() {
                out.push((base + s, base + i));
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    if let Some(s) = start {
        out.push((base + s, base + line.len()));
    }
    out
}

/// `<A> AXIS` (8065's first line before `;`) → the axis.
pub fn axis_heading(h: &str) -> Option<Axis> {
    let mut w = h.split_whitespace();
    let (Some(a), Some("AXIS"), None) = (w.next(), w.next(), w.next()) else {
        return None;
    };
    a.parse().ok()
}

/// A Fagor 8055 line `P<n> <A> <pos> E<A> <v> E<A> <v>`: (axis letter, position, err+,
/// err−), or `None` when the line is not one.
pub fn fagor_8055_line(line: &str) -> Option<(char, f64, f64, f64)> {
    let t: Vec<&str> = line.split_whitespace().collect();
    if t.len() != 7 {
        return None;
    }
    let p = t[0].strip_prefix('P')?;
    if p.is_empty() || !p.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let mut a = t[1].chars();
    let (Some(letter), None) = (a.next(), a.next()) else {
        return None;
    };
    let e = format!("E{letter}");
    if !letter.is_ascii_alphabetic() || t[3] != e || t[5] != e {
        return None;
    }
    Some((letter, number(t[2])?, number(t[4])?, number(t[6])?))
}

fn field(text: &str, (start, end): (usize, usize)) -> Field {
    Field {
        start,
        end,
        decimals: decimals(&text[start..end]),
    }
}

/// Reads a controller table from `bytes`.
pub fn read(bytes: &[u8], format: TableFormat) -> Result<ControllerTable, At> {
    let text = Text::decode(bytes).map_err(|(l, m)| At::new(l, m))?;
    let k = format.units().mm();
    let dialect = match format {
        TableFormat::Siemens => Some(super::dialects::read_siemens(&text)?),
        TableFormat::Fanuc => Some(super::dialects::read_fanuc(&text)?),
        TableFormat::Heidenhain => Some(super::dialects::read_heidenhain(&text)?),
        TableFormat::Isg => Some(super::dialects::read_isg(&text)?),
        _ => None,
    };
    if let Some(d) = dialect {
        return Ok(ControllerTable {
            format,
            text,
            axis: d.axis,
            axis_assumed: false,
            points: d.points,
            bidirectional: d.bidirectional,
            bidir_value: d.bidir_value,
            bidir_comment: None,
            one_column: d.one_column,
            fanuc: d.fanuc,
        });
    }
    let (axis, points, bidirectional, bidir_value, bidir_comment) = match format {
        TableFormat::Fagor8055 { .. } => {
            let (axis, points) = read_8055(&text, k)?;
            let bidir = points.iter().any(|p| p.down_file != 0.0);
            (Some(axis), points, bidir, None, None)
        }
        TableFormat::Fagor8065 { .. } => read_8065(&text, k)?,
        TableFormat::LinuxCnc { comp_type, .. } => {
            let points = read_linuxcnc(&text, k, comp_type)?;
            let bidir = points.iter().any(|p| p.e_up_um != p.e_down_um);
            (None, points, bidir, None, None)
        }
        _ => return Err(At::new(1, "not a table format")),
    };
    Ok(ControllerTable {
        format,
        text,
        axis,
        axis_assumed: false,
        points,
        bidirectional,
        bidir_value,
        bidir_comment,
        one_column: false,
        fanuc: None,
    })
}

/// Refuses, at `line`, a point outside errmap's physical ranges (positions ±10⁶ mm,
/// errors ±10⁶ µm).
fn in_range(line: usize, position_mm: f64, e_um: &[f64]) -> Result<(), At> {
    use crate::base::limits::{ERROR_UM, POSITION_MM};
    POSITION_MM
        .check(position_mm)
        .map_err(|m| At::new(line, format!("position: {m}")))?;
    for &e in e_um {
        ERROR_UM
            .check(e)
            .map_err(|m| At::new(line, format!("error: {m}")))?;
    }
    Ok(())
}

fn increasing(points: &[TablePoint], line: usize, position: f64) -> Result<(), At> {
    if let Some(prev) = points.last()
        && position <= prev.position_file
    {
        return Err(At::new(
            line,
            format!(
                "position {position} after {} (line {}): the points must increase",
                prev.position_file, prev.line
            ),
        ));
    }
    Ok(())
}

fn read_8055(text: &Text, k: f64) -> Result<(Axis, Vec<TablePoint>), At> {
    let mut points: Vec<TablePoint> = Vec::new();
    let mut letter: Option<char> = None;
    for (i, (off, l)) in text.lines().into_iter().enumerate() {
        let line = i + 1;
        if l.trim().is_empty() {
            break;
        }
        let Some((a, pos, up, down)) = fagor_8055_line(l) else {
            return Err(At::new(
                line,
                format!(
                    "`{}` is not `P<n> <axis> <position> E<axis> <error+> E<axis> <error−>`",
                    l.trim()
                ),
            ));
        };
        match letter {
            None => letter = Some(a),
            Some(b) if b != a => {
                return Err(At::new(line, format!("axis {a} in a table of axis {b}")));
            }
            _ => {}
        }
        increasing(&points, line, pos)?;
        in_range(line, pos * k, &[up * k * 1000.0, down * k * 1000.0])?;
        let t = tokens(l, off);
        points.push(TablePoint {
            line,
            position_mm: pos * k,
            e_up_um: -up * k * 1000.0,
            e_down_um: -down * k * 1000.0,
            position_file: pos,
            up_file: up,
            down_file: down,
            up: field(&text.text, t[4]),
            down: field(&text.text, t[6]),
        });
    }
    let Some(letter) = letter else {
        return Err(At::new(1, "no table points"));
    };
    let axis: Axis = letter.to_string().parse().map_err(|_| {
        At::new(
            1,
            format!("axis {letter}: errmap's tables are along X, Y or Z"),
        )
    })?;
    if points.len() < 2 {
        return Err(At::new(1, "one table point: a table needs two"));
    }
    // One table for both directions when every err− is 0.
    if points.iter().all(|p| p.down_file == 0.0) {
        for p in &mut points {
            p.e_down_um = p.e_up_um;
        }
    }
    Ok((axis, points))
}

type Read8065 = (
    Option<Axis>,
    Vec<TablePoint>,
    bool,
    Option<Field>,
    Option<Field>,
);

fn read_8065(text: &Text, k: f64) -> Result<Read8065, At> {
    let lines = text.lines();
    let first = lines.first().map(|l| l.1).unwrap_or("");
    let axis = axis_heading(first.split(';').next().unwrap_or("")).ok_or_else(|| {
        At::new(
            1,
            "the first line is not `<axis> AXIS` (a Fagor 8065 axis file)",
        )
    })?;
    // name → (line, value field, value text, comment field)
    let mut params: std::collections::HashMap<String, (usize, Field, String, Option<Field>)> =
        Default::default();
    for (i, &(off, l)) in lines.iter().enumerate().skip(1) {
        let parts: Vec<&str> = l.split(';').collect();
        if parts.len() < 3 {
            continue;
        }
        let name = parts[1].trim();
        if !name.starts_with("/LSCRWDATA/") {
            continue;
        }
        // Byte offset of the value part.
        let value_off = off + parts[0].len() + 1 + parts[1].len() + 1;
        let raw = parts[2];
        let lead = raw.len() - raw.trim_start().len();
        let vt = raw.trim();
        let vf = field(&text.text, (value_off + lead, value_off + lead + vt.len()));
        let comment = parts.get(3).map(|c| {
            let coff = value_off + raw.len() + 1;
            let lead = c.len() - c.trim_start().len();
            field(&text.text, (coff + lead, coff + lead + c.trim().len()))
        });
        if params
            .insert(name.to_string(), (i + 1, vf, vt.to_string(), comment))
            .is_some()
        {
            return Err(At::new(i + 1, format!("{name} appears twice")));
        }
    }
    let get = |name: &str| params.get(name);
    let Some((nl, _, nv, _)) = get("/LSCRWDATA/NPOINTS") else {
        return Err(At::new(
            lines.len().max(1),
            "no /LSCRWDATA/NPOINTS: the file holds no leadscrew table",
        ));
    };
    let n = number(nv)
        .filter(|v| v.fract() == 0.0 && (0.0..=100_000.0).contains(v))
        .ok_or_else(|| At::new(*nl, format!("NPOINTS `{nv}` is not a count")))?
        as usize;
    if n < 2 {
        return Err(At::new(
            *nl,
            format!("NPOINTS {n}: a table needs two points"),
        ));
    }
    let bidir = get("/LSCRWDATA/BIDIR");
    let bidirectional = match bidir {
        Some((l, _, v, _)) => match v.as_str() {
            "0" => false,
            "1" => true,
            other => return Err(At::new(*l, format!("BIDIR `{other}` (0 or 1)"))),
        },
        None => false,
    };
    let mut points: Vec<TablePoint> = Vec::with_capacity(n);
    for i in 1..=n {
        let fetch = |what: &str| -> Result<(usize, Field, f64), At> {
            let name = format!("/LSCRWDATA/DATA/{what} {i}");
            let (l, f, v, _) = get(&name)
                .ok_or_else(|| At::new(*nl, format!("NPOINTS {n} but {name} is missing")))?;
            let x =
                number(v).ok_or_else(|| At::new(*l, format!("{name} `{v}` is not a number")))?;
            Ok((*l, *f, x))
        };
        let (line, _, pos) = fetch("POSITION")?;
        let (_, up_f, up) = fetch("POSERROR")?;
        let (_, down_f, down) = fetch("NEGERROR")?;
        increasing(&points, line, pos)?;
        in_range(line, pos * k, &[up * k * 1000.0, down * k * 1000.0])?;
        let e_up = -up * k * 1000.0;
        points.push(TablePoint {
            line,
            position_mm: pos * k,
            e_up_um: e_up,
            e_down_um: if bidirectional {
                -down * k * 1000.0
            } else {
                e_up
            },
            position_file: pos,
            up_file: up,
            down_file: down,
            up: up_f,
            down: down_f,
        });
    }
    if let Some(extra) = params.keys().find(|name| {
        ["POSITION", "POSERROR", "NEGERROR"].iter().any(|w| {
            name.strip_prefix(&format!("/LSCRWDATA/DATA/{w} "))
                .and_then(|i| i.parse::<usize>().ok())
                .is_some_and(|i| i == 0 || i > n)
        })
    }) {
        let (l, ..) = params[extra];
        return Err(At::new(l, format!("{extra} beyond NPOINTS {n}")));
    }
    Ok((
        Some(axis),
        points,
        bidirectional,
        bidir.map(|b| b.1),
        bidir.and_then(|b| b.3),
    ))
}

fn read_linuxcnc(text: &Text, k: f64, comp: LinuxCncCompType) -> Result<Vec<TablePoint>, At> {
    let mut points: Vec<TablePoint> = Vec::new();
    for (i, (off, l)) in text.lines().into_iter().enumerate() {
        let line = i + 1;
        if l.trim().is_empty() {
            continue;
        }
        let t = tokens(l, off);
        let vals: Vec<Option<f64>> = t.iter().map(|&(s, e)| number(&text.text[s..e])).collect();
        let (3, Some(n), Some(f), Some(r)) = (
            vals.len(),
            vals.first().copied().flatten(),
            vals.get(1).copied().flatten(),
            vals.get(2).copied().flatten(),
        ) else {
            return Err(At::new(
                line,
                format!(
                    "`{}` is not `nominal forward reverse` (three numbers)",
                    l.trim()
                ),
            ));
        };
        increasing(&points, line, n)?;
        let e = |v: f64| match comp {
            LinuxCncCompType::Trim => v * k * 1000.0,
            LinuxCncCompType::ActualPosition => (n - v) * k * 1000.0,
        };
        in_range(line, n * k, &[e(f), e(r)])?;
        points.push(TablePoint {
            line,
            position_mm: n * k,
            e_up_um: e(f),
            e_down_um: e(r),
            position_file: n,
            up_file: f,
            down_file: r,
            up: field(&text.text, t[1]),
            down: field(&text.text, t[2]),
        });
    }
    if points.len() < 2 {
        return Err(At::new(
            text.lines().len().max(1),
            "fewer than two table points",
        ));
    }
    Ok(points)
}

/// One row of the error table written from a controller table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TableRow {
    pub point: usize,
    pub xyz_mm: [f64; 3],
    pub e_um: f64,
    pub e_up_um: f64,
    pub e_down_um: f64,
}

impl ControllerTable {
    /// The table's axis: the file's, else `axis` (a file that names none, as a LinuxCNC
    /// `COMP_FILE`, is the table of the axis its user says).
    pub fn assume_axis(mut self, axis: Axis) -> Self {
        if self.axis.is_none() {
            self.axis = Some(axis);
            self.axis_assumed = true;
        }
        self
    }

    /// The error table's rows along `axis`: one per point, in file order, e = mean of the
    /// two directions.
    pub fn rows(&self, axis: Axis) -> Vec<TableRow> {
        self.points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut xyz = [0.0; 3];
                xyz[axis.index()] = snap(p.position_mm);
                TableRow {
                    point: i + 1,
                    xyz_mm: xyz,
                    e_um: snap(0.5 * (p.e_up_um + p.e_down_um)),
                    e_up_um: snap(p.e_up_um),
                    e_down_um: snap(p.e_down_um),
                }
            })
            .collect()
    }

    /// `import --json`'s summary for this table.
    pub fn summary(&self, axis: Axis, warnings: Vec<String>) -> ImportSummary {
        ImportSummary {
            format: self.format.name(),
            rows: self.points.len(),
            runs: None,
            targets: self.points.len(),
            directions: if self.bidirectional { 2 } else { 1 },
            units_in: self.format.units().name(),
            axis: axis.upper(),
            machine: None,
            warnings,
        }
    }
}

/// Writes `point,x_mm,y_mm,z_mm,e_um,e_up_um,e_down_um` (CSV or Parquet by extension),
/// whole or not at all.
pub fn write_error_table(path: &Path, rows: &[TableRow]) -> Result<(), TableError> {
    let n = rows.len();
    let col = |name: &str, f: &dyn Fn(&TableRow) -> f64| {
        Column::new(name.into(), rows.iter().map(f).collect::<Vec<f64>>())
    };
    let cols = vec![
        Column::new(
            "point".into(),
            rows.iter().map(|r| r.point as i64).collect::<Vec<i64>>(),
        ),
        col("x_mm", &|r| r.xyz_mm[0]),
        col("y_mm", &|r| r.xyz_mm[1]),
        col("z_mm", &|r| r.xyz_mm[2]),
        col("e_um", &|r| r.e_um),
        col("e_up_um", &|r| r.e_up_um),
        col("e_down_um", &|r| r.e_down_um),
    ];
    let mut df = DataFrame::new(n, cols).map_err(|e| TableError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(path, &mut df)
}
