//! Reading a controller table back: the shared shapes ([`ControllerTable`], [`TablePoint`],
//! [`Field`], a reader's refusal [`At`]) and the dispatch to each dialect's reader through
//! the registry's trait ([`read`], [`super::Dialect::read`]). Each reader gives the table points in errmap's sign (e = indicated −
//! reference, µm) and where each value sits in the text, so that [`super::update`]
//! rewrites the values and nothing else.
//!
//! These are the layouts errmap writes (and, for Fagor and LinuxCNC, the layouts of real
//! files), documented with their sources in each dialect's module; files written by a
//! controller or another tool may differ: they are refused at the line that does not fit,
//! never guessed.

use super::TableFormat;
use super::text::{Text, decimals, number};
use crate::base::Axis;

/// A reader's refusal before the path is attached.
#[derive(Debug, Clone, PartialEq)]
pub struct At {
    pub line: usize,
    pub column: Option<String>,
    pub message: String,
}

impl At {
    pub fn new(line: usize, message: impl Into<String>) -> At {
        At {
            line,
            column: None,
            message: message.into(),
        }
    }

    pub fn col(line: usize, column: &str, message: impl Into<String>) -> At {
        At {
            line,
            column: Some(column.to_string()),
            message: message.into(),
        }
    }
}

/// What a dialect's reader found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Parsed {
    /// The axis the file names (8055's letter, 8065's first line, errmap's comment in a
    /// Siemens or FANUC file, the HEIDENHAIN column, the ISG axis name); `None` when it
    /// names none (LinuxCNC). [`ControllerTable::assume_axis`] gives one to such a table.
    pub axis: Option<Axis>,
    pub points: Vec<TablePoint>,
    /// Whether the table has separate values for the two directions.
    pub bidirectional: bool,
    /// The field saying whether the table is direction-dependent (ISG `bilateral`, the
    /// 8065's `BIDIR`) and its comment (the 8065's `No`/`Yes`).
    pub bidir_value: Option<Field>,
    pub bidir_comment: Option<Field>,
    /// One value per point and no way to hold a second direction (Siemens LEC, a CEC
    /// table without direction, HEIDENHAIN, an ISG list without `neg`).
    pub one_column: bool,
    /// FANUC: the increments and where they sit.
    pub fanuc: Option<super::fanuc::FanucLayout>,
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

/// A controller table as read: its format, its text, and what its dialect's reader
/// found ([`Parsed`], whose fields it gives through `Deref`: `table.points`, …).
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerTable {
    pub format: TableFormat,
    pub text: Text,
    /// Whether `axis` was given by the caller rather than read from the file.
    pub axis_assumed: bool,
    pub read: Parsed,
}

impl std::ops::Deref for ControllerTable {
    type Target = Parsed;
    fn deref(&self) -> &Parsed {
        &self.read
    }
}

pub(crate) fn field_at(start: usize, token: &str) -> Field {
    Field {
        start,
        end: start + token.len(),
        decimals: decimals(token),
    }
}

/// A table point whose up and down values are `up` and `down` (file units `vu`, `vd`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn point(
    line: usize,
    position_mm: f64,
    e_up_um: f64,
    e_down_um: f64,
    vu: f64,
    vd: f64,
    up: Field,
    down: Field,
) -> TablePoint {
    TablePoint {
        line,
        position_mm,
        e_up_um,
        e_down_um,
        position_file: position_mm,
        up_file: vu,
        down_file: vd,
        up,
        down,
    }
}

pub(crate) fn check_point(line: usize, position_mm: f64, e: &[f64]) -> Result<(), At> {
    use crate::base::{ERROR_UM, POSITION_MM};
    POSITION_MM
        .check(position_mm)
        .map_err(|m| At::new(line, format!("position: {m}")))?;
    for &v in e {
        ERROR_UM
            .check(v)
            .map_err(|m| At::new(line, format!("error: {m}")))?;
    }
    Ok(())
}

pub(crate) fn num(line: usize, what: &str, t: &str) -> Result<f64, At> {
    number(t).ok_or_else(|| At::new(line, format!("{what} `{}` is not a number", t.trim())))
}

/// The byte ranges of the whitespace-separated tokens of `line` (offsets from `base`).
pub(crate) fn tokens(line: &str, base: usize) -> Vec<(usize, usize)> {
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

pub(crate) fn field(text: &str, (start, end): (usize, usize)) -> Field {
    Field {
        start,
        end,
        decimals: decimals(&text[start..end]),
    }
}

/// Reads a controller table from `bytes`: the text decoded, then read by `format`'s
/// dialect ([`super::Dialect::read`]).
pub fn read(bytes: &[u8], format: TableFormat) -> Result<ControllerTable, At> {
    let text = Text::decode(bytes).map_err(|(l, m)| At::new(l, m))?;
    let read = format.dialect().read(&text, format)?;
    Ok(ControllerTable {
        format,
        text,
        axis_assumed: false,
        read,
    })
}

pub(crate) fn increasing(points: &[TablePoint], line: usize, position: f64) -> Result<(), At> {
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

impl ControllerTable {
    /// The table's axis: the file's, else `axis` (a file that names none, as a LinuxCNC
    /// `COMP_FILE`, is the table of the axis its user says).
    pub fn assume_axis(mut self, axis: Axis) -> Self {
        if self.read.axis.is_none() {
            self.read.axis = Some(axis);
            self.axis_assumed = true;
        }
        self
    }
}
