//! What technicians already have, read into errmap's tables: laser vendors' exports and
//! spreadsheets become a **session table** (`session-table.md`: one dwell row per run,
//! direction and target reading), and the compensation table already in a controller,
//! read by its dialect in the controller stage (`crate::controller`, which also updates
//! it in place), becomes an **error table**.
//!
//! | reader | file | output |
//! |---|---|---|
//! | [`api`] | API XD laser `.pos`, "Linear Data Table" (inch or mm, uni- or bidirectional) | session rows |
//! | [`rtl`] | Renishaw Laser10/LaserXL linear `.rtl` (text sections) | session rows |
//! | [`csv`] | any table through a column map (delimiter, decimal comma, units, error sign) | session rows |
//! | [`tables`] | a controller table of any dialect (`crate::controller::DIALECTS`), read by the controller stage | an error table per table point |
//!
//! Detection ([`detect`]) is by content, never by file name (a controller table by its
//! dialect's `detect`); a Renishaw `.rtx` dynamic
//! capture is recognised and refused (it has no targets). Each format's provenance and what
//! is unverified against a genuine file is in `docs/import.md`.
//!
//! # Signs and units
//!
//! errmap's error is e = indicated − reference (µm); ISO 230-2's deviation is
//! x = reference − indicated = −e. Lengths are converted exactly (1 in = 25.4 mm),
//! temperatures (°C = (°F − 32)·5/9) and pressures (1 inHg = 33.8638866667 hPa,
//! 1 mmHg = 1.33322387415 hPa, 1 kPa = 10 hPa) with the constants of [`units`].
//!
//! # Errors
//!
//! Every refusal is an [`ImportError::Bad`] naming the file, the 1-based physical line and,
//! for CSV, the column: `FILE: line N, column C: what`. The readers return rows or an error
//! and write nothing; the caller writes the table whole or not at all.

mod api;
mod csv;
mod rtl;
mod tables;

use std::path::{Path, PathBuf};

use errmap_drivers::SessionRow;
use errmap_drivers::frame::Axis as WireAxis;
use serde::Serialize;

use crate::base::{Axis, NamesSettings, Setting};
use crate::table::TableError;

pub use crate::controller::At;
pub use csv::{
    Col, ColumnMap, CsvOptions, ErrorSign, ErrorUnit, LengthUnit, MapError, PressureUnit, TempUnit,
    data_lines,
};
pub use tables::write_error_table;

/// Exact unit conversions.
pub mod units {
    pub use crate::controller::MM_PER_INCH;
    /// Hectopascals per inch of mercury.
    pub const HPA_PER_INHG: f64 = 33.8638866667;
    /// Hectopascals per millimetre of mercury.
    pub const HPA_PER_MMHG: f64 = 1.33322387415;
    /// Hectopascals per kilopascal.
    pub const HPA_PER_KPA: f64 = 10.0;

    /// °F → °C.
    pub fn fahrenheit_to_c(f: f64) -> f64 {
        (f - 32.0) * 5.0 / 9.0
    }
}

/// The settings of the import stage that its messages name (`base::Setting`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImportSetting {
    /// A CSV's column map ([`ColumnMap`]).
    ColumnMap,
    /// What a CSV's error column holds ([`ErrorSign`]).
    ErrorSign,
    /// A CSV's field delimiter (`CsvOptions::delimiter`).
    Delimiter,
    /// `,` as a CSV's decimal mark (`CsvOptions::decimal_comma`).
    DecimalComma,
    /// The format a file is read as (`ImportOptions::format`; detected when not given).
    Format,
}

impl Setting for ImportSetting {
    fn words(self) -> &'static str {
        match self {
            ImportSetting::ColumnMap => "the column map",
            ImportSetting::ErrorSign => "the error sign",
            ImportSetting::Delimiter => "the delimiter",
            ImportSetting::DecimalComma => "the decimal-comma option",
            ImportSetting::Format => "the format",
        }
    }
}

/// `, column C` when a column is named.
fn column_text(column: &Option<String>) -> String {
    column
        .as_ref()
        .map(|c| format!(", column {c}"))
        .unwrap_or_default()
}

/// A refusal, naming the file, its line and (CSV) its column.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{path}: line {line}{}: {message}", column_text(column))]
    Bad {
        path: PathBuf,
        line: usize,
        column: Option<String>,
        message: String,
    },
    /// A refusal that a setting of the import would fix ([`ImportSetting`]).
    #[error("{}", self.render(&Setting::words))]
    Setting {
        path: PathBuf,
        line: usize,
        column: Option<String>,
        problem: ImportProblem,
    },
    /// The file cannot be read (the shared [`FileError`] shape).
    #[error(transparent)]
    File(#[from] crate::base::FileError),
    #[error(transparent)]
    Table(#[from] TableError),
}

impl NamesSettings for ImportError {
    type Setting = ImportSetting;
    fn render(&self, name: &dyn Fn(ImportSetting) -> &'static str) -> String {
        match self {
            ImportError::Setting {
                path,
                line,
                column,
                problem,
            } => format!(
                "{}: line {line}{}: {}",
                path.display(),
                column_text(column),
                problem.render(name)
            ),
            ImportError::Bad { .. } | ImportError::File(_) | ImportError::Table(_) => {
                self.to_string()
            }
        }
    }
}

/// A reader's refusal ([`At`], the controller stage's) with the path attached.
impl At {
    pub fn at(self, path: &Path) -> ImportError {
        ImportError::Bad {
            path: path.to_path_buf(),
            line: self.line,
            column: self.column,
            message: self.message,
        }
    }
}

/// A refusal of a file that a setting of the import would fix (the setting named as an
/// [`ImportSetting`]), at a line and maybe a column: `ImportError::Setting`.
#[derive(Debug, Clone, PartialEq)]
pub enum ImportProblem {
    /// The map names column #`number`; the header has `columns`.
    ColumnBeyond { number: usize, columns: usize },
    /// The map names a column the header (`header`, joined) does not have.
    ColumnMissing { name: String, header: String },
    /// The map has no target column.
    NoTarget,
    /// An error column and no sign for it.
    NoErrorSign,
    /// A one-column header holding `found`: an export with another delimiter (and
    /// decimal commas in its data, when `decimal_comma`).
    OtherDelimiter { found: char, decimal_comma: bool },
    /// A `.` in a cell read with decimal commas.
    PointWithComma { raw: String },
    /// A decimal comma in a cell read without them.
    CommaWithout { raw: String },
    /// No format told by content: the dialects told by content (`by_content`) and those
    /// that must be named (`by_name`), `or`-joined.
    Unrecognised { by_content: String, by_name: String },
    /// A controller table of the dialect `name` where a positioning test was asked for.
    ControllerTable { name: &'static str },
}

impl ImportProblem {
    /// The problem with every setting called by `name`.
    pub fn render(&self, name: &dyn Fn(ImportSetting) -> &'static str) -> String {
        use ImportSetting::{ColumnMap, DecimalComma, Delimiter, ErrorSign, Format};
        match self {
            ImportProblem::ColumnBeyond { number, columns } => format!(
                "{} names column #{number}, but the header has {columns} columns",
                name(ColumnMap)
            ),
            ImportProblem::ColumnMissing {
                name: column,
                header,
            } => format!(
                "{} names column `{column}`, which is not in the header ({header})",
                name(ColumnMap)
            ),
            ImportProblem::NoTarget => format!("{} has no target", name(ColumnMap)),
            ImportProblem::NoErrorSign => format!(
                "an error column needs {} (a sign is never guessed)",
                name(ErrorSign)
            ),
            ImportProblem::OtherDelimiter {
                found,
                decimal_comma,
            } => {
                let (held, value) = match found {
                    '\t' => ("TAB".to_string(), "tab".to_string()),
                    c => (format!("`{c}`"), format!("'{c}'")),
                };
                format!(
                    "the header is one column but holds {held}: this looks like a {}-separated \
                     export{}; read it with {} {value}{}",
                    if *found == ';' {
                        "`;` (European Excel)"
                    } else {
                        "differently"
                    },
                    if *decimal_comma {
                        " with decimal commas"
                    } else {
                        ""
                    },
                    name(Delimiter),
                    if *decimal_comma {
                        format!(" and {}", name(DecimalComma))
                    } else {
                        String::new()
                    },
                )
            }
            ImportProblem::PointWithComma { raw } => format!(
                "`{raw}` has a `.` but {} says `,` is the decimal mark",
                name(DecimalComma)
            ),
            ImportProblem::CommaWithout { raw } => format!(
                "`{raw}` has a decimal comma; read the file with {}",
                name(DecimalComma)
            ),
            ImportProblem::Unrecognised {
                by_content,
                by_name,
            } => format!(
                "not a recognised format (API XD .pos, Renishaw .rtl, or a {by_content} table); \
                 a spreadsheet or CSV needs {format} csv and {}, a table its content does not \
                 name {format} {by_name}",
                name(ColumnMap),
                format = name(Format),
            ),
            ImportProblem::ControllerTable { name: dialect } => format!(
                "a {dialect} compensation table, not a positioning test: read it with {} \
                 {dialect} into an error table",
                name(Format)
            ),
        }
    }
}

impl std::fmt::Display for ImportProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render(&Setting::words))
    }
}

/// A refusal of the import stage's readers before the path is attached: the shared
/// [`At`], or an [`ImportProblem`] that names a setting.
#[derive(Debug, Clone, PartialEq)]
pub enum ImportRefusal {
    At(At),
    Setting {
        line: usize,
        column: Option<String>,
        problem: ImportProblem,
    },
}

impl From<At> for ImportRefusal {
    fn from(at: At) -> ImportRefusal {
        ImportRefusal::At(at)
    }
}

impl ImportRefusal {
    fn new(line: usize, problem: ImportProblem) -> ImportRefusal {
        ImportRefusal::Setting {
            line,
            column: None,
            problem,
        }
    }

    fn col(line: usize, column: &str, problem: ImportProblem) -> ImportRefusal {
        ImportRefusal::Setting {
            line,
            column: Some(column.to_string()),
            problem,
        }
    }

    /// The refusal with the path attached.
    pub fn at(self, path: &Path) -> ImportError {
        match self {
            ImportRefusal::At(at) => at.at(path),
            ImportRefusal::Setting {
                line,
                column,
                problem,
            } => ImportError::Setting {
                path: path.to_path_buf(),
                line,
                column,
                problem,
            },
        }
    }
}

/// The formats errmap reads: the positioning tests' and, by name, the controller
/// tables of the registry (`crate::controller::DIALECTS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    ApiXd,
    RenishawRtl,
    RenishawRtx,
    Csv,
    /// A controller table, by its dialect's name.
    Table(&'static str),
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::ApiXd => "api-xd",
            Format::RenishawRtl => "renishaw-rtl",
            Format::RenishawRtx => "renishaw-rtx",
            Format::Csv => "csv",
            Format::Table(name) => name,
        }
    }
}

/// The format of `bytes` by content (`import.md` §0), or the refusal at line 1. A CSV is
/// never guessed: it needs its format and column map given.
pub fn detect(bytes: &[u8]) -> Result<Format, ImportRefusal> {
    let text =
        crate::controller::text::Text::decode(bytes).map_err(|(line, m)| At::new(line, m))?;
    let lines = text.lines();
    let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
    if first.starts_with("API X-D Laser Measurement Linear Data Table") {
        return Ok(Format::ApiXd);
    }
    if first.starts_with("API Linear") {
        return Err(At::new(
            1,
            "an API laser analysis section only (no header, no readings, so no unit); import \
             the whole `.pos` export",
        )
        .into());
    }
    if first == "HEADER::" {
        let rtl = lines.iter().take(40).any(|(_, l)| {
            l.split_once(':').is_some_and(|(k, v)| {
                k.trim().eq_ignore_ascii_case("File type") && v.trim().eq_ignore_ascii_case("rtl")
            })
        });
        return Ok(if rtl {
            Format::RenishawRtl
        } else {
            Format::RenishawRtx
        });
    }
    if let Some(d) = crate::controller::detect(bytes) {
        return Ok(Format::Table(d.name()));
    }
    Err(ImportRefusal::new(
        1,
        ImportProblem::Unrecognised {
            by_content: crate::controller::names_where(|d| d.detects_by_content(), "or"),
            by_name: crate::controller::names_where(|d| !d.detects_by_content(), "or"),
        },
    ))
}

/// Which reader to use for a positioning test.
#[derive(Debug, Clone, PartialEq)]
pub enum SessionFormat {
    Auto,
    ApiXd,
    RenishawRtl,
    /// (Boxed: the column map is large beside the other variants.)
    Csv(Box<CsvOptions>),
}

/// How to import a positioning test.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    pub format: SessionFormat,
    /// Overrides the file's axis (csv: the axis; default x).
    pub axis: Option<Axis>,
}

/// What `import --json` prints (`import.md` §1).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportSummary {
    pub format: &'static str,
    pub rows: usize,
    /// Distinct runs (`null` for a controller table).
    pub runs: Option<usize>,
    pub targets: usize,
    /// Travel directions: 1 or 2.
    pub directions: usize,
    /// The file's length unit: `mm` or `inch`.
    pub units_in: &'static str,
    /// The axis letter, upper case.
    pub axis: &'static str,
    pub machine: Option<String>,
    pub warnings: Vec<String>,
    /// The index in `warnings` of the one saying that the file states no axis and X was
    /// taken (a caller names the setting that gives the axis: the command line's `--axis`).
    #[serde(skip)]
    pub axis_warning: Option<usize>,
}

/// A positioning test as session rows, with its summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    pub rows: Vec<SessionRow>,
    pub summary: ImportSummary,
}

/// Environment values of one reading, converted (°C, hPa, %).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Env {
    pub air_temp_c: Option<f64>,
    pub air_pressure_hpa: Option<f64>,
    pub air_rh_pct: Option<f64>,
    pub scale_temp_c: Option<f64>,
    pub part_temp_c: Option<f64>,
}

/// One reading of a positioning test, in errmap's units and signs, before the session's
/// bookkeeping (target rank, sample index, time) is added by [`assemble`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// ISO run j ≥ 1.
    pub run: u32,
    /// +1 / −1: the pass' direction of travel.
    pub direction: i8,
    /// Nominal target position P, mm.
    pub target_mm: f64,
    /// Indicated position, mm.
    pub scale_mm: f64,
    /// Reference position, mm.
    pub laser_mm: f64,
    /// e = indicated − reference, µm.
    pub error_um: f64,
    pub flags: u8,
    pub env: Env,
}

impl Reading {
    /// Refuses, at `line`, a value outside the session table's physical ranges
    /// ([`crate::base::limits`]), as `read_session` would on the written file.
    pub fn check(&self, line: usize) -> Result<(), At> {
        use crate::base::{ERROR_UM, HUMIDITY_PCT, POSITION_MM, PRESSURE_HPA, TEMPERATURE_C};
        let checks = [
            ("target position", POSITION_MM.check(self.target_mm)),
            ("indicated position", POSITION_MM.check(self.scale_mm)),
            ("reference position", POSITION_MM.check(self.laser_mm)),
            ("error", ERROR_UM.check(self.error_um)),
        ];
        let env = [
            ("air temperature", self.env.air_temp_c, TEMPERATURE_C),
            ("air pressure", self.env.air_pressure_hpa, PRESSURE_HPA),
            ("humidity", self.env.air_rh_pct, HUMIDITY_PCT),
            ("scale temperature", self.env.scale_temp_c, TEMPERATURE_C),
            ("part temperature", self.env.part_temp_c, TEMPERATURE_C),
        ];
        for (what, r) in checks.into_iter().chain(
            env.into_iter()
                .filter_map(|(w, v, b)| v.map(|v| (w, b.check(v)))),
        ) {
            if let Err(m) = r {
                return Err(At::new(line, format!("{what}: {m}")));
            }
        }
        Ok(())
    }
}

/// Two target positions within this are one target (1 nm).
pub const TARGET_TOL_MM: f64 = 1e-6;

/// Session rows from readings in acquisition order: `target` = rank of the position in
/// ascending order, `sample` = index within the run, `t_s` = k·`dt_s`, the axis coordinate
/// = P and the other two from `at_mm`.
pub fn assemble(readings: &[Reading], axis: Axis, at_mm: [f64; 3], dt_s: f64) -> Vec<SessionRow> {
    let targets = distinct_targets(readings.iter().map(|r| r.target_mm));
    let mut next_sample: std::collections::BTreeMap<u32, i64> = Default::default();
    readings
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let rank = targets
                .iter()
                .position(|&p| (p - r.target_mm).abs() <= TARGET_TOL_MM)
                .unwrap_or(0);
            let sample = next_sample.entry(r.run).or_insert(0);
            let s = *sample;
            *sample += 1;
            let mut xyz = at_mm;
            xyz[axis.index()] = snap(targets[rank]);
            SessionRow {
                run: r.run,
                sample: s,
                t_s: k as f64 * dt_s,
                axis: wire(axis),
                direction: r.direction,
                feed_mm_s: None,
                target: rank as i32,
                x_mm: Some(xyz[0]),
                y_mm: Some(xyz[1]),
                z_mm: Some(xyz[2]),
                scale_mm: snap(r.scale_mm),
                laser_mm: snap(r.laser_mm),
                error_um: snap(r.error_um),
                air_temp_c: r.env.air_temp_c.map(snap),
                air_pressure_hpa: r.env.air_pressure_hpa.map(snap),
                air_rh_pct: r.env.air_rh_pct.map(snap),
                scale_temp_c: r.env.scale_temp_c.map(snap),
                part_temp_c: r.env.part_temp_c.map(snap),
                flags: r.flags,
            }
        })
        .collect()
}

/// `v` rounded to 1e-9 (of its unit) and without `-0`: unit conversions such as
/// 0.000047 in · 25 400 give 1.1937999999999998 µm in binary; the file meant 1.1938.
pub fn snap(v: f64) -> f64 {
    if v.abs() < 1e6 {
        (v * 1e9).round() / 1e9 + 0.0
    } else {
        v + 0.0
    }
}

/// The distinct positions, ascending, merged within [`TARGET_TOL_MM`].
pub fn distinct_targets(positions: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = positions.collect();
    v.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::with_capacity(v.len());
    for p in v {
        if out.last().is_none_or(|&q| (p - q).abs() > TARGET_TOL_MM) {
            out.push(p);
        }
    }
    out
}

/// The wire protocol's axis for a session row.
pub fn wire(axis: Axis) -> WireAxis {
    match axis {
        Axis::X => WireAxis::X,
        Axis::Y => WireAxis::Y,
        Axis::Z => WireAxis::Z,
    }
}

/// The summary's counts from readings.
pub(crate) fn summary_counts(readings: &[Reading]) -> (usize, usize, usize) {
    let mut runs: Vec<u32> = readings.iter().map(|r| r.run).collect();
    runs.sort_unstable();
    runs.dedup();
    let targets = distinct_targets(readings.iter().map(|r| r.target_mm)).len();
    let up = readings.iter().any(|r| r.direction > 0);
    let down = readings.iter().any(|r| r.direction < 0);
    (runs.len(), targets, usize::from(up) + usize::from(down))
}

/// Reads a positioning test from `bytes` (the contents of `path`, which only names the
/// file in messages) into session rows.
pub fn import_session(
    path: &Path,
    bytes: &[u8],
    options: &ImportOptions,
) -> Result<Imported, ImportError> {
    let format = match &options.format {
        SessionFormat::Auto => match detect(bytes).map_err(|e| e.at(path))? {
            Format::ApiXd => Format::ApiXd,
            Format::RenishawRtl => Format::RenishawRtl,
            Format::RenishawRtx => Format::RenishawRtx,
            Format::Table(name) => {
                return Err(
                    ImportRefusal::new(1, ImportProblem::ControllerTable { name }).at(path),
                );
            }
            other => return Err(At::new(1, format!("{} is not detected", other.name())).at(path)),
        },
        SessionFormat::ApiXd => Format::ApiXd,
        SessionFormat::RenishawRtl => Format::RenishawRtl,
        SessionFormat::Csv(_) => Format::Csv,
    };
    let result = match (format, &options.format) {
        (Format::ApiXd, _) => api::read(bytes, options.axis),
        (Format::RenishawRtl, _) => rtl::read(bytes, options.axis),
        (Format::RenishawRtx, _) => Err(rtl::refuse_rtx(bytes)),
        (Format::Csv, SessionFormat::Csv(o)) => {
            return csv::read(bytes, o, options.axis).map_err(|e| e.at(path));
        }
        _ => Err(At::new(1, "not a recognised format")),
    };
    result.map_err(|e| e.at(path))
}
