//! The Fagor 8055 leadscrew error compensation table `AL<axis>` ([`render_8055`]) and the
//! Fagor 8065 axis parameter file `<axis>.mp` holding the same table ([`render_8065`]).
//!
//! # Layout
//!
//! One line per point, CRLF, fields right-aligned in fixed widths, as the CNC stores the
//! table (the layout of real `ALX`/`ALY` files kept in the public `doug-co/laser_adjust`
//! repository):
//!
//! ```text
//!       P001          X    0.00000       EX    0.00000        EX    0.00000
//! ```
//!
//! `P<n>` (3 digits, from 1), the axis letter, the position, `E<axis>` and the error moving
//! in the positive direction, `E<axis>` and the error moving in the negative direction, in
//! the machine's unit: 4 decimals in mm, 5 in inch (the real files' inch resolution). The
//! positions must increase; between points the CNC interpolates linearly, and beyond the
//! last point it applies the last point's error. A table whose every negative-direction
//! error is 0 is one table for both directions.
//!
//! # Sign convention
//!
//! Fagor's manuals define the table's error as *real position − theoretical position* =
//! ISO 230-2's deviation x = −e, which the CNC subtracts; errmap writes the compensation
//! c = −e, the same number. The public `laser_adjust` tool adds an API laser's
//! LinearError (also x) to the table, which agrees. **Not checked on a machine** (see
//! `docs/import.md`): check one point after loading a table.
//!
//! Unverified limits: at most [`FAGOR_8055_MAX_POINTS`] points per axis (the usual
//! figure for the 8055's leadscrew tables); the manual's further rules (the error at the
//! reference point, the slope between points) are not enforced.

//! # Fagor 8065 `<axis>.mp` ([`render_8065`])
//!
//! The 8065 keeps the leadscrew table among the axis' parameters, in a UTF-16LE text file
//! with a byte-order mark and CRLF (the layout of real `X.mp`/`Y.mp` files from the same
//! repository): a first line `<A> AXIS` padded to 30 characters then `;3100`, the lines
//! `MM` `;0` and `MPVersionID` `;100` padded the same way, a column heading, and one line
//! per parameter, `2;` + the name padded to 50 + `;` + the value (padded to 20 and followed
//! by `;` and a comment when it has one). The table is `/LSCRWCOMP` (1, on),
//! `/LSCRWDATA/NPOINTS`, `/LSCRWDATA/BIDIR` (0: one table for both directions, 1: the
//! NEGERROR column is used), then `/LSCRWDATA/DATA/POSITION i`, `POSERROR i`, `NEGERROR i`
//! (i = 1…NPOINTS, each block in turn), 4 decimals in mm (5 in inch). Values: the same
//! error actual − theoretical = c as the 8055. errmap writes only this block: a partial
//! parameter file, whose other parameters the CNC keeps or defaults (not confirmed); on a
//! machine that already has an `<axis>.mp`, update that file instead (`export
//! --existing`), which keeps every other parameter byte for byte. The meaning of the
//! header numbers (3100, 0, 100) is copied from the real files, not from a manual.
//!
//! Interpolation (both controls, from the 8055 installation manual's description of the
//! table; the 8065's own manual was not found): linear between points, the positions
//! referred to machine zero and strictly increasing; a table whose every negative-direction
//! error is 0 (8065: BIDIR 0) applies the positive-direction errors both ways. What the
//! CNC applies beyond the first and last points is not stated in the sources found: keep
//! the table over the whole travel.

use std::fmt::Write as _;

use super::LengthUnit;
use super::TableSetting;
use super::modulo::{ModuloError, ModuloRead, ModuloSpec, ModuloSyntax, ModuloTable};
use super::modulo_update as mu;
use super::read::{At, Field, TablePoint, check_point};
use super::text::{Text, number};
use super::update::fixed;
use super::{
    AxisKind, Dialect, Digits, Editor, ExportFormat, Limits, Parsed, PointUpdate, SettingsError,
    Sign, Spacing, TableFormat, TableSettings, UpdateStyle, Value, ValueUnit,
};
use crate::base::Axis;
use crate::export::{ExportError, Sampled};

/// How the limit messages name this controller's table.
pub const LABEL: &str = "the Fagor leadscrew table (8055 AL<axis>, 8065 <axis>.mp)";

/// Points of an 8055 leadscrew table (unverified against the manual).
pub const FAGOR_8055_MAX_POINTS: usize = 255;

/// Points of an 8065 table accepted by errmap (the 8055i manual's NPOINTS limit, 1000;
/// the 8065's own limit was not found).
pub const FAGOR_8065_MAX_POINTS: usize = 1000;

/// What the table needs beyond the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fagor8055Spec {
    /// The axis letter the CNC uses (`X`, `Y`, `Z`, `U`, …).
    pub axis_letter: char,
    /// Whether the machine works in inch (the values are then in inch, 5 decimals).
    pub inch: bool,
}

/// The columns both controls write: positions and the two directions' values, as text
/// in the machine's unit (4 decimals in mm, 5 in inch).
struct Columns {
    letter: char,
    positions: Vec<String>,
    up: Vec<String>,
    /// 0 without a reverse line (one table for both directions).
    down: Vec<String>,
}

/// The checked columns of a table of at most `max_points` points.
fn columns(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &Fagor8055Spec,
    max_points: usize,
) -> Result<Columns, ExportError> {
    let rev = crate::export::paired(forward, reverse)?;
    let n = forward.len();
    if n > max_points {
        return Err(super::too_many(LABEL, forward, 0, max_points, false));
    }
    if !spec.axis_letter.is_ascii_alphabetic() {
        return Err(ExportError::ControllerLimit {
            controller: LABEL,
            problem: format!("`{}` is not an axis letter", spec.axis_letter),
        });
    }
    let (k, d) = if spec.inch {
        (LengthUnit::Inch.mm(), 5)
    } else {
        (1.0, 4)
    };
    let mut positions: Vec<String> = Vec::with_capacity(n);
    for i in 0..n {
        let pos = fixed(forward.positions_mm[i] / k, d);
        if let Some(p) = positions.last()
            && pos.parse::<f64>().unwrap_or(f64::NAN) <= p.parse::<f64>().unwrap_or(f64::NAN)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: forward.positions_mm[i - 1],
                position_mm: forward.positions_mm[i],
            });
        }
        positions.push(pos);
    }
    let value = |e_um: f64| fixed(VALUE.file(e_um, k), d);
    Ok(Columns {
        letter: spec.axis_letter.to_ascii_uppercase(),
        positions,
        up: forward.error_um.iter().map(|&e| value(e)).collect(),
        down: match reverse {
            Some(_) => rev.error_um.iter().map(|&e| value(e)).collect(),
            None => vec![fixed(0.0, d); n],
        },
    })
}

/// The table of `control` for a sampled line: the 8055's `AL<axis>` ([`text_8055`]) or
/// the text of the 8065's axis file ([`text_8065`]), each refused beyond its control's
/// points.
pub fn render(
    control: Fagor,
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &Fagor8055Spec,
) -> Result<String, ExportError> {
    Ok(match control {
        Fagor::Al8055 => text_8055(&columns(forward, reverse, spec, FAGOR_8055_MAX_POINTS)?),
        Fagor::Mp8065 => text_8065(
            &columns(forward, reverse, spec, FAGOR_8065_MAX_POINTS)?,
            reverse.is_some(),
        ),
    })
}

/// An `AL<axis>` table: per sample, the compensation c = −e moving + and (with a
/// reverse line) moving −; without one the negative-direction column is 0 (one table).
fn text_8055(c: &Columns) -> String {
    let a = c.letter;
    let mut out = String::with_capacity(c.positions.len() * 75);
    for (i, pos) in c.positions.iter().enumerate() {
        out.push_str(&format!(
            "{:>10}{a:>11}{pos:>11}{:>9}{:>11}{:>10}{:>11}\r\n",
            format!("P{:03}", i + 1),
            format!("E{a}"),
            c.up[i],
            format!("E{a}"),
            c.down[i],
        ));
    }
    out
}

/// One `2;<name>;<value>[;<comment>]` parameter line of an 8065 axis file.
fn param_8065(name: &str, value: &str, comment: Option<&str>) -> String {
    match comment {
        Some(c) => format!("2;{name:<50};{value:<20};{c}\r\n"),
        None => format!("2;{name:<50};{value}\r\n"),
    }
}

/// The text of a Fagor 8065 `<axis>.mp` holding the leadscrew table (module docs), CRLF;
/// the file is this text in UTF-16LE with its byte-order mark ([`encode_8065`]).
/// `bidir` (a reverse line, same positions) sets BIDIR 1 and fills NEGERROR with its
/// compensation; without it BIDIR is 0 and NEGERROR 0.
fn text_8065(c: &Columns, bidir: bool) -> String {
    let n = c.positions.len();
    let mut t = String::with_capacity((3 * n + 10) * 80);
    t.push_str(&format!("{:<30};3100\r\n", format!("{} AXIS", c.letter)));
    t.push_str(&format!("{:<30};0\r\n", "MM"));
    t.push_str(&format!("{:<30};100\r\n", "MPVersionID"));
    t.push_str(&format!(
        " ;{:<50};{:<20};Comment;\r\n",
        "Parameter", "Value"
    ));
    t.push_str(&param_8065("/LSCRWCOMP", "1", Some("Yes")));
    t.push_str(&param_8065("/LSCRWDATA/NPOINTS", &n.to_string(), None));
    t.push_str(&param_8065(
        "/LSCRWDATA/BIDIR",
        if bidir { "1" } else { "0" },
        Some(if bidir { "Yes" } else { "No" }),
    ));
    for (block, list) in [
        ("POSITION", &c.positions),
        ("POSERROR", &c.up),
        ("NEGERROR", &c.down),
    ] {
        for (i, v) in list.iter().enumerate() {
            t.push_str(&param_8065(
                &format!("/LSCRWDATA/DATA/{block} {}", i + 1),
                v,
                None,
            ));
        }
    }
    t
}

/// An 8065 axis file's bytes: UTF-16LE after the byte-order mark FF FE.
pub fn encode_8065(text: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(2 + 2 * text.len());
    out.extend_from_slice(&[0xFF, 0xFE]);
    for u in text.encode_utf16() {
        out.extend_from_slice(&u.to_le_bytes());
    }
    out
}

// ---------------------------------------------------------------------------------------
// Reading

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

pub(crate) fn read_8055(text: &Text, k: f64) -> Result<(Axis, Vec<TablePoint>), At> {
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
        next_point(&points, line, pos, [up, down], k)?;
        let t = super::read::tokens(l, off);
        points.push(TablePoint {
            line,
            position_mm: pos * k,
            e_up_um: VALUE.error_um(up, k),
            e_down_um: VALUE.error_um(down, k),
            position_file: pos,
            up_file: up,
            down_file: down,
            up: super::read::field(&text.text, t[4]),
            down: super::read::field(&text.text, t[6]),
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

pub(crate) fn read_8065(text: &Text, k: f64) -> Result<Read8065, At> {
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
        let vf = super::read::field(&text.text, (value_off + lead, value_off + lead + vt.len()));
        let comment = parts.get(3).map(|c| {
            let coff = value_off + raw.len() + 1;
            let lead = c.len() - c.trim_start().len();
            super::read::field(&text.text, (coff + lead, coff + lead + c.trim().len()))
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
        next_point(&points, line, pos, [up, down], k)?;
        let e_up = VALUE.error_um(up, k);
        points.push(TablePoint {
            line,
            position_mm: pos * k,
            e_up_um: e_up,
            e_down_um: if bidirectional {
                VALUE.error_um(down, k)
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

// ---------------------------------------------------------------------------------------
// The dialect

/// A Fagor control's leadscrew table: the 8055's `AL<axis>` or the 8065's `<axis>.mp`
/// ([`super::DIALECTS`] holds one of each).
#[derive(Debug, Clone, Copy)]
pub enum Fagor {
    /// The 8055's `AL<axis>` table (the file states no unit).
    Al8055,
    /// The 8065's `<axis>.mp` axis file (mm unless told).
    Mp8065,
}

/// The values (both controls): real − theoretical = c, in the machine's length unit.
pub const VALUE: Value = Value {
    sign: Sign::Compensation,
    unit: ValueUnit::Length,
};

/// Both controls' limits but the points.
fn limits(max_points: usize) -> Limits {
    Limits {
        max_points,
        spacing: Spacing::Listed,
        bidirectional: true,
        value: VALUE,
        axes: &[AxisKind::Linear],
    }
}

/// The table's axis letter and unit: `--axis-name`'s first letter, else errmap's axis.
fn spec(s: &TableSettings) -> Fagor8055Spec {
    Fagor8055Spec {
        axis_letter: s
            .axis_name
            .as_deref()
            .and_then(|n| n.chars().next())
            .unwrap_or_else(|| s.axis.upper().chars().next().unwrap_or('X')),
        inch: s.units == Some(LengthUnit::Inch),
    }
}

impl Dialect for Fagor {
    /// The 8055's table only.
    fn modulo(&self) -> Option<&dyn ModuloSyntax> {
        matches!(self, Fagor::Al8055).then_some(self as &dyn ModuloSyntax)
    }
    fn name(&self) -> &'static str {
        match self {
            Fagor::Al8055 => "fagor-8055",
            Fagor::Mp8065 => "fagor-8065",
        }
    }
    fn aliases(&self) -> &'static [&'static str] {
        match self {
            Fagor::Al8055 => &["fagor8055"],
            Fagor::Mp8065 => &["fagor8065"],
        }
    }
    fn controller(&self) -> &'static str {
        match self {
            Fagor::Al8055 => "Fagor 8055",
            Fagor::Mp8065 => "Fagor 8065",
        }
    }
    fn about(&self) -> &'static str {
        match self {
            Fagor::Al8055 => "Fagor 8055 leadscrew table AL<axis> (needs --units)",
            Fagor::Mp8065 => {
                "Fagor 8065 axis file <axis>.mp holding the leadscrew table (UTF-16LE; mm unless --units inch); with --existing the machine's own file updated"
            }
        }
    }
    fn limits(&self) -> Limits {
        limits(match self {
            Fagor::Al8055 => FAGOR_8055_MAX_POINTS,
            Fagor::Mp8065 => FAGOR_8065_MAX_POINTS,
        })
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![
            (
                TableSetting::AxisName,
                "the axis letter (its first letter)".into(),
            ),
            (
                TableSetting::Units,
                match self {
                    Fagor::Al8055 => "required: the table states none",
                    Fagor::Mp8065 => "mm unless inch",
                }
                .into(),
            ),
        ]
    }
    fn detect(&self, bytes: &[u8], text: &Text) -> bool {
        let lines = text.lines();
        let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
        match self {
            Fagor::Al8055 => fagor_8055_line(first).is_some(),
            Fagor::Mp8065 => {
                bytes.starts_with(&[0xFF, 0xFE])
                    && first
                        .split(';')
                        .next()
                        .is_some_and(|h| axis_heading(h).is_some())
            }
        }
    }
    fn table_format(&self, s: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(match self {
            Fagor::Al8055 => TableFormat::Fagor8055 {
                units: s.units.ok_or(SettingsError::NoUnit {
                    what: "a Fagor 8055 table",
                })?,
            },
            Fagor::Mp8065 => TableFormat::Fagor8065 {
                units: s.units.unwrap_or_default(),
            },
        })
    }
    fn export_format(&self, s: &TableSettings, _: bool) -> Result<ExportFormat, SettingsError> {
        self.table_format(s)?;
        Ok(match self {
            Fagor::Al8055 => ExportFormat::Fagor8055 { spec: spec(s) },
            Fagor::Mp8065 => ExportFormat::Fagor8065 { spec: spec(s) },
        })
    }
    fn read(&self, text: &Text, format: TableFormat) -> Result<Parsed, At> {
        let k = format.units().mm();
        Ok(match self {
            Fagor::Al8055 => {
                let (axis, points) = read_8055(text, k)?;
                Parsed {
                    axis: Some(axis),
                    bidirectional: points.iter().any(|p| p.down_file != 0.0),
                    points,
                    ..Parsed::default()
                }
            }
            Fagor::Mp8065 => {
                let (axis, points, bidirectional, bidir_value, bidir_comment) = read_8065(text, k)?;
                Parsed {
                    axis,
                    points,
                    bidirectional,
                    bidir_value,
                    bidir_comment,
                    ..Parsed::default()
                }
            }
        })
    }
    fn update_style(&self) -> UpdateStyle {
        UpdateStyle::ALIGNED
    }
    /// err+ and err− in the file's unit, each at its own decimals: err+ − r⁺, and err−
    /// (err+ where the table was one for both directions) − r⁻ when there is a reverse.
    fn edit_point(&self, editor: &mut Editor, u: &PointUpdate) {
        let (p, k) = (u.point, editor.k());
        let own = |f: Field| Digits {
            decimals: f.decimals,
            trim: false,
        };
        editor.edit(
            p.up,
            p.up_file,
            p.up_file,
            p.up_file + VALUE.file(u.r_up, k),
            own(p.up),
        );
        if u.bidirectional || u.table.bidirectional {
            let base = if u.table.bidirectional {
                p.down_file
            } else {
                p.up_file
            };
            let r = if u.bidirectional { u.r_down } else { u.r_up };
            editor.edit(
                p.down,
                p.down_file,
                base,
                base + VALUE.file(r, k),
                own(p.down),
            );
        }
    }
}
/// A point's checks, as both Fagor readers make them: positions increasing, the position
/// and both errors (file units × `k`) within the table's limits.
fn next_point(
    points: &[TablePoint],
    line: usize,
    pos: f64,
    [up, down]: [f64; 2],
    k: f64,
) -> Result<(), At> {
    super::read::increasing(points, line, pos)?;
    check_point(
        line,
        pos * k,
        &[VALUE.error_um(up, k), VALUE.error_um(down, k)],
    )
}

// ---------------------------------------------------------------------------------------
// The modulo table of a rotary axis ([`super::modulo`])

/// The 8055's leadscrew table of a rotary axis (only [`Fagor::Al8055`] has one): the
/// targets listed, 0° and 360° first and last with the same error.
impl ModuloSyntax for Fagor {
    fn equidistant(&self) -> bool {
        false
    }
    fn default_max_points(&self) -> usize {
        FAGOR_8055_MAX_POINTS
    }
    fn direction_columns(&self) -> Option<&'static str> {
        Some("err−")
    }
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
        let letter = spec.axis.upper();
        let mut s = String::new();
        let (c, c_down) = (t.c_arcsec.clone(), t.c_down_arcsec.clone());
        let e = format!("E{letter}");
        for (i, (q, c)) in t.points_deg.iter().zip(&c).enumerate() {
            // err− 0 everywhere: the same table both ways (Fagor's rule).
            let minus = c_down
                .as_ref()
                .map_or_else(|| "0.0000".to_string(), |d| fixed(d[i] / 3600.0, 4));
            let _ = write!(
                s,
                "{:>10}{letter:>11}{:>11}{:>9}{:>11}{:>10}{:>11}\r\n",
                format!("P{:03}", i + 1),
                format!("{q:.4}"),
                e,
                fixed(c / 3600.0, 4),
                e,
                minus
            );
        }
        Ok(t.written(s))
    }
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
        let letter = spec.axis.upper().to_string();
        let e = format!("E{letter}");
        let mut t = ModuloRead::default();
        for (line, offset, body) in mu::lines(text) {
            let w = mu::words(body, offset);
            if w.is_empty() {
                continue;
            }
            if w.len() != 7 || !w[0].1.starts_with('P') {
                return Err(mu::at(
                    line,
                    format!("a Fagor line is `P<n> {letter} <pos> {e} <err+> {e} <err−>`"),
                ));
            }
            if w[1].1 != letter || w[3].1 != e || w[5].1 != e {
                return Err(mu::at(
                    line,
                    format!("the table is for axis {}, not {letter}", w[1].1),
                ));
            }
            t.angles.push(mu::number(line, w[2].1, "position")?);
            t.lines.push(line);
            t.c_up.push(mu::number(line, w[4].1, "err+")? * 3600.0);
            t.c_down.push(mu::number(line, w[6].1, "err−")? * 3600.0);
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
    fn encode(&self, _spec: &ModuloSpec, _q: f64, c: f64, field: Field, _old: &str) -> String {
        fixed(c / 3600.0, field.decimals)
    }
}
