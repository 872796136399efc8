//! The controllers: one file per controller dialect, each holding everything errmap
//! knows of that controller's compensation table — its writer (a pure renderer of a
//! [`Sampled`] line), its reader (the table read back, [`read`]), the per-dialect part of
//! the in-place update ([`update`]), and its limits, sign and unit ([`Limits`]), written
//! once and used by all three. The registry [`DIALECTS`] lists them; the command line's
//! `--format` values, their help and every message that lists dialects are made from it.
//!
//! | dialect | module | table | limit |
//! |---|---|---|---|
//! | LinuxCNC | [`linuxcnc`] | a `COMP_FILE` (type 0 or 1) | [`LINUXCNC_MAX_ENTRIES`] = 256 |
//! | Siemens 840D | [`siemens`] | a SINUMERIK 840D sl LEC/MSEC part program (`%_N_AX_EEC_INI`); direction-dependent: two CEC tables (`%_N_NC_CEC_INI`, K3 §4.4.4) | the axis' MD38000 (CEC: MD18342), a parameter |
//! | FANUC | [`fanuc`] | pitch error compensation: parameters 3620–3624 (3605#0, 3626, 3627 bidirectional) and increments per point | point numbers ≤ [`FANUC_MAX_POINT_NUMBER`], \|value\| ≤ a parameter |
//! | HEIDENHAIN | [`heidenhain`] | a TNC `.COM` nonlinear axis error compensation table | [`HEIDENHAIN_MAX_POINTS`] = 256, a parameter |
//! | ISG / TwinCAT | [`isg`] | a `kw.ssfk` leadscrew error compensation list, unilateral or bilateral | < P-COMP-00059 ([`ISG_DEFAULT_MAX_POINTS`] = 1500) |
//! | Fagor 8055 | [`fagor`] | a leadscrew table `AL<axis>` (one table, or both directions) | [`FAGOR_8055_MAX_POINTS`] (unverified) |
//! | Fagor 8065 | [`fagor`] | an axis file `<axis>.mp` holding the leadscrew table (UTF-16LE; BIDIR 1 with a reverse line) | [`FAGOR_8065_MAX_POINTS`] (unverified) |
//!
//! # Sign convention
//!
//! errmap's error is e = indicated − reference (µm, [`crate::table::ErrorPoint`]). The
//! compensation is c = −e ([`compensation_um`]): the amount that, added to the machine's
//! *indicated* (scale/encoder) position, gives the reference (true) position,
//! indicated + c = reference. How a controller applies a table decides which of c and
//! −c it stores ([`Sign`], in each dialect's [`Limits`]):
//!
//! * **Siemens LEC/MSEC corrects the actual (feedback) value**, so the table holds c, in
//!   mm (the controller's documentation is cited in [`siemens`]).
//! * **TwinCAT CNC (ISG) LSEC holds the position error actual − setpoint**, which is c,
//!   in 0.1 µm ([`isg`]).
//! * **FANUC pitch error compensation outputs pulses added to the motion**, so its
//!   increments are those of e, relative to the reference position ([`fanuc`]).
//! * **HEIDENHAIN**: the sign is not stated in the sources consulted; errmap writes c,
//!   ISO 230-2's deviation ([`heidenhain`]).
//! * **LinuxCNC adds its trim to the position command**, so the trim is −c = e; a type-0
//!   file lists the actual position N + c instead, which LinuxCNC turns into the same
//!   trim (the controller's source is cited in [`linuxcnc`]).
//! * **Fagor** stores real − theoretical = c, which the CNC subtracts ([`fagor`]).
//!
//! Both are first-order corrections: the table is looked up at the commanded (or
//! indicated) position rather than the corrected one, an error of order
//! e·(de/dx) — µm × µm/mm, i.e. nanometres for ordinary maps.
//!
//! # Where this stage sits
//!
//! It imports `export` (the sampled line, [`ExportError`], the CSV line and the grid,
//! which are not controller formats and stay there), `session` (the residual of an
//! update), `sim` (the test plans its [`program`]s run), `volumetric` (the component
//! tables a dialect's volumetric table holds), `table` and `base`; `import` uses it (a
//! controller table read into an error table, and the text decoding and [`At`] its
//! readers share), and the binary calls its [`job`] once per export.
//!
//! # Adding a dialect
//!
//! One new file here implementing [`Dialect`] (writer, reader, limits, sign, unit, and
//! where the controller has them its settings, part-program syntax and axis tables) and
//! one line in [`DIALECTS`]; see `CONTRIBUTING.md`. A rotary axis' modulo table is the
//! dialect's [`Dialect::modulo`] ([`modulo::ModuloSyntax`], in the dialect's file).

pub mod fagor;
pub mod fanuc;
pub mod heidenhain;
pub mod isg;
pub mod job;
pub mod linuxcnc;
pub mod modulo;
mod modulo_update;
mod options;
pub mod program;
mod read;
mod setting;
pub mod siemens;
pub(crate) mod text;
mod update;

use crate::export::{ExportError, Sampled};

pub use crate::export::compensation_um;
pub use fagor::{FAGOR_8055_MAX_POINTS, FAGOR_8065_MAX_POINTS, Fagor8055Spec};
pub use fanuc::{FANUC_MAX_POINT_NUMBER, FanucSpec, FanucTable};
pub use heidenhain::{HEIDENHAIN_MAX_POINTS, is_table_name};
pub use isg::{ISG_DEFAULT_MAX_POINTS, IsgAxis};
pub use linuxcnc::{CompType, LINUXCNC_MAX_ENTRIES};
pub use modulo_update::update_modulo;
pub use options::{DialectOption, DialectOptions, OptionError, OptionValue, dialect_options};
pub use read::{At, ControllerTable, Field, Parsed, TablePoint, read};
pub use setting::ControllerSetting;
pub use siemens::SIEMENS_808D_MAX_POINTS;
pub use update::{
    Digits, Editor, PointUpdate, Residual, UpdateError, UpdateStyle, UpdateSummary, Updated,
    update_table,
};

/// The refusal of a table of more entries than the controller takes: `samples` of
/// `s` plus `padding` entries the format adds, against `limit`, naming a step that fits
/// (and, where `any_step_fits`, a round one: the table lists every position).
pub(crate) fn too_many(
    controller: &'static str,
    s: &Sampled,
    padding: usize,
    limit: usize,
    any_step_fits: bool,
) -> ExportError {
    ExportError::TooManyEntries {
        controller,
        any_step_fits,
        samples: s.len(),
        padding,
        limit,
        length_mm: s.length_mm(),
    }
}

/// Millimetres per inch (exact by definition).
pub const MM_PER_INCH: f64 = 25.4;

/// Length unit of a file's positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LengthUnit {
    #[default]
    Mm,
    Inch,
}

impl LengthUnit {
    pub fn mm(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Inch => MM_PER_INCH,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::Inch => "inch",
        }
    }
}

/// Which controller table, and what the file does not say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    /// Fagor 8055 `AL<axis>`; the file states no unit.
    Fagor8055 { units: LengthUnit },
    /// Fagor 8065 `<axis>.mp` (mm unless told).
    Fagor8065 { units: LengthUnit },
    /// LinuxCNC `COMP_FILE` (mm unless told); its type is not in the file.
    LinuxCnc {
        comp_type: CompType,
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
    /// The dialect whose table this is: its reader and its update.
    pub fn dialect(self) -> &'static dyn Dialect {
        match self {
            TableFormat::Fagor8055 { .. } => &fagor::Fagor::Al8055,
            TableFormat::Fagor8065 { .. } => &fagor::Fagor::Mp8065,
            TableFormat::LinuxCnc { .. } => &linuxcnc::LinuxCnc,
            TableFormat::Siemens => &siemens::Siemens,
            TableFormat::Fanuc => &fanuc::Fanuc,
            TableFormat::Heidenhain => &heidenhain::Heidenhain,
            TableFormat::Isg => &isg::Isg,
        }
    }

    pub fn name(self) -> &'static str {
        self.dialect().name()
    }

    /// The sign and unit of the table's values (its dialect's [`Value`]).
    pub fn value(self) -> Value {
        self.dialect().limits().value
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

/// What to export: a controller table (a dialect and its settings), the CSV line or the
/// grid.
#[derive(Debug, Clone, PartialEq)]
pub enum ExportFormat {
    /// A LinuxCNC `COMP_FILE` for one joint.
    LinuxCnc { comp_type: CompType },
    /// A SINUMERIK 840D sl LEC/MSEC program for machine axis `axis_name` (e.g. `X1`),
    /// whose MD38000 `MM_ENC_COMP_MAX_POINTS` is `max_points`.
    Siemens {
        axis_name: String,
        max_points: usize,
    },
    /// SINUMERIK 840D sl direction-dependent leadscrew error compensation: two CEC tables
    /// from `first_table` on machine axis `AX<axis_number>`, each of at most
    /// `max_points` (MD18342); needs a reverse line.
    SiemensCec {
        axis_number: u32,
        first_table: usize,
        max_points: usize,
    },
    /// FANUC pitch error compensation (bidirectional with a reverse line).
    Fanuc { spec: FanucSpec },
    /// A HEIDENHAIN `.COM` table: the axis key (column name), the table's name and the
    /// entry limit.
    Heidenhain {
        axis_key: String,
        table_name: String,
        max_points: usize,
    },
    /// A TwinCAT CNC (ISG) `kw.ssfk` list (bilateral with a reverse line).
    Isg { axis: IsgAxis },
    /// A Fagor 8055 `AL<axis>` leadscrew table (both directions with a reverse line).
    Fagor8055 { spec: Fagor8055Spec },
    /// A Fagor 8065 `<axis>.mp` axis file holding the leadscrew table (both directions,
    /// BIDIR 1, with a reverse line); UTF-16LE ([`ExportFormat::render_bytes`]).
    Fagor8065 { spec: Fagor8055Spec },
    /// One line as `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`.
    Csv,
    /// A volumetric grid (CSV or Parquet by extension), see [`write_grid`].
    Grid,
}

impl ExportFormat {
    /// A short name for messages.
    pub fn name(&self) -> &'static str {
        match self {
            ExportFormat::LinuxCnc { .. } => "linuxcnc",
            ExportFormat::Siemens { .. } => "siemens",
            ExportFormat::SiemensCec { .. } => "siemens (direction-dependent, CEC)",
            ExportFormat::Fanuc { .. } => "fanuc",
            ExportFormat::Heidenhain { .. } => "heidenhain",
            ExportFormat::Isg { .. } => "isg",
            ExportFormat::Fagor8055 { .. } => "fagor-8055",
            ExportFormat::Fagor8065 { .. } => "fagor-8065",
            ExportFormat::Csv => "csv",
            ExportFormat::Grid => "grid",
        }
    }

    /// Whether the format has direction-dependent tables (a reverse line).
    pub fn bidirectional(&self) -> bool {
        matches!(
            self,
            ExportFormat::LinuxCnc { .. }
                | ExportFormat::SiemensCec { .. }
                | ExportFormat::Fanuc { .. }
                | ExportFormat::Isg { .. }
                | ExportFormat::Fagor8055 { .. }
                | ExportFormat::Fagor8065 { .. }
        )
    }

    /// Whether the format is written from one sampled line (all but [`ExportFormat::Grid`]).
    pub fn is_line(&self) -> bool {
        !matches!(self, ExportFormat::Grid)
    }

    /// Renders a sampled line. `reverse` (direction-dependent errors, same positions)
    /// is used by the formats with direction-dependent tables ([`Self::bidirectional`]);
    /// the other line formats refuse it.
    pub fn render_line(
        &self,
        forward: &Sampled,
        reverse: Option<&Sampled>,
    ) -> Result<String, ExportError> {
        match self {
            ExportFormat::LinuxCnc { comp_type } => linuxcnc::render(forward, *comp_type, reverse),
            ExportFormat::Siemens {
                axis_name,
                max_points,
            } => {
                self.forward_only(reverse)?;
                siemens::render(forward, axis_name, *max_points)
            }
            ExportFormat::SiemensCec {
                axis_number,
                first_table,
                max_points,
            } => {
                let Some(reverse) = reverse else {
                    return Err(ExportError::ReverseMismatch {
                        problem: "the direction-dependent Siemens tables need the reverse line"
                            .into(),
                    });
                };
                siemens::render_bidirectional(
                    forward,
                    reverse,
                    *axis_number,
                    *first_table,
                    *max_points,
                )
            }
            ExportFormat::Fanuc { spec } => fanuc::render(forward, reverse, spec),
            ExportFormat::Heidenhain {
                axis_key,
                table_name,
                max_points,
            } => {
                self.forward_only(reverse)?;
                heidenhain::render(forward, axis_key, table_name, *max_points)
            }
            ExportFormat::Isg { axis } => isg::render(forward, reverse, axis),
            ExportFormat::Fagor8055 { spec } => {
                fagor::render(fagor::Fagor::Al8055, forward, reverse, spec)
            }
            ExportFormat::Fagor8065 { spec } => {
                fagor::render(fagor::Fagor::Mp8065, forward, reverse, spec)
            }
            ExportFormat::Csv => {
                self.forward_only(reverse)?;
                forward.check()?;
                Ok(crate::export::csv(forward))
            }
            ExportFormat::Grid => Err(ExportError::GridNeedsVolume),
        }
    }

    /// Refuses a reverse line for a format without a direction-dependent table.
    fn forward_only(&self, reverse: Option<&Sampled>) -> Result<(), ExportError> {
        match reverse {
            Some(_) => Err(ExportError::ReverseUnsupported {
                format: self.name(),
                with: names_where(|d| d.limits().bidirectional, "or"),
            }),
            None => Ok(()),
        }
    }

    /// The file's bytes for a sampled line: [`Self::render_line`]'s text, UTF-8, except
    /// the Fagor 8065 axis file, which is UTF-16LE with its byte-order mark.
    pub fn render_bytes(
        &self,
        forward: &Sampled,
        reverse: Option<&Sampled>,
    ) -> Result<Vec<u8>, ExportError> {
        let text = self.render_line(forward, reverse)?;
        Ok(match self {
            ExportFormat::Fagor8065 { .. } => fagor::encode_8065(&text),
            _ => text.into_bytes(),
        })
    }
}

// ---------------------------------------------------------------------------------------
// The dialect registry

/// What a dialect's values hold: c = −e (the compensation) or e itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sign {
    /// The table holds c = −e ([`compensation_um`]).
    Compensation,
    /// The table holds e (LinuxCNC's trim; FANUC's increments).
    Error,
}

impl Sign {
    /// The stored quantity for an error `e` (or back: the sign is its own inverse).
    pub fn of(self, e: f64) -> f64 {
        match self {
            Sign::Compensation => compensation_um(e),
            Sign::Error => e,
        }
    }
}

/// The unit of a table's values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ValueUnit {
    /// The file's length unit (mm, or inch where the file or its user says so).
    Length,
    /// 0.1 µm (ISG `unit` 1).
    TenthMicrometre,
    /// Detection unit × magnification (FANUC), a setting of the control.
    Units,
}

/// The sign and the unit of a dialect's values, written once: the writer, the reader and
/// the update convert through it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Value {
    pub sign: Sign,
    pub unit: ValueUnit,
}

impl Value {
    /// The file's number for an error of `e_um` (µm), `k` mm per file length unit.
    /// (FANUC's increments are computed by its own module from `sign`.)
    pub fn file(self, e_um: f64, k: f64) -> f64 {
        let v = self.sign.of(e_um);
        match self.unit {
            ValueUnit::Length => v / (k * 1000.0),
            ValueUnit::TenthMicrometre => v * 10.0,
            ValueUnit::Units => v,
        }
    }

    /// The error (µm) a file's number `v` stands for (the inverse of [`Value::file`]).
    pub fn error_um(self, v: f64, k: f64) -> f64 {
        self.sign.of(match self.unit {
            ValueUnit::Length => v * k * 1000.0,
            ValueUnit::TenthMicrometre => v / 10.0,
            ValueUnit::Units => v,
        })
    }
}

/// How a table's points may be spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// One interval (Siemens MIN/STEP/MAX, FANUC's interval, HEIDENHAIN's manuals).
    Equidistant,
    /// Every position is listed, so the intervals may differ.
    Listed,
}

/// The kind of axis a table compensates. Rotary axes (modulo tables) are the rotary-axis
/// issue's: a `Rotary { modulo_deg }` variant goes here, and each dialect says whether
/// its table can be one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    Linear,
}

/// A dialect's limits: points, spacing, directions, values and the axis kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// The most points of a table (the default where the control makes it a parameter).
    pub max_points: usize,
    pub spacing: Spacing,
    /// Whether the table can hold a second direction (a reverse line).
    pub bidirectional: bool,
    pub value: Value,
    /// The axes the tables compensate.
    pub axes: &'static [AxisKind],
}

/// The settings a dialect's table needs beyond the line, typed; each dialect takes what
/// it uses (the command line's flags, parsed once).
#[derive(Debug, Clone, PartialEq)]
pub struct TableSettings {
    /// The compensated axis (errmap's).
    pub axis: crate::base::Axis,
    /// The controller's name of the axis (HEIDENHAIN key, ISG name, Fagor letter).
    pub axis_name: Option<String>,
    /// The controller's axis number (FANUC header, ISG, Siemens CEC `AX<n>`).
    pub axis_number: Option<u32>,
    /// A dialect's table size, where it is a parameter.
    pub max_points: Option<usize>,
    /// HEIDENHAIN's `.COM` table name.
    pub table_name: Option<String>,
    /// The file's length unit where the file does not state it.
    pub units: Option<LengthUnit>,
    /// LinuxCNC's `COMP_FILE_TYPE`.
    pub comp_type: Option<CompType>,
    /// The grid's reference position, mm (FANUC's reference point, parameter 3620).
    pub reference_mm: f64,
    /// The settings each dialect declares for itself ([`Dialect::options`]).
    pub options: DialectOptions,
}

impl TableSettings {
    /// The settings of a table along `axis` with nothing else given: the defaults of the
    /// command line's flags.
    pub fn new(axis: crate::base::Axis) -> Self {
        TableSettings {
            axis,
            axis_name: None,
            axis_number: None,
            max_points: None,
            table_name: None,
            units: None,
            comp_type: None,
            reference_mm: 0.0,
            options: DialectOptions::default(),
        }
    }

    /// The controller's axis name: given, else errmap's axis in upper case.
    pub fn axis_name(&self) -> String {
        self.axis_name
            .clone()
            .unwrap_or_else(|| self.axis.upper().to_string())
    }

    /// The controller's axis number: given, else 1, 2, 3 for x, y, z.
    pub fn axis_number(&self) -> u32 {
        self.axis_number.unwrap_or(self.axis.index() as u32 + 1)
    }
}

/// A setting of [`TableSettings`] that several dialects read, each as its controller calls
/// it ([`Dialect::reads`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableSetting {
    /// [`TableSettings::axis_name`].
    AxisName,
    /// [`TableSettings::axis_number`].
    AxisNumber,
    /// [`TableSettings::max_points`].
    MaxPoints,
    /// [`TableSettings::table_name`].
    TableName,
    /// [`TableSettings::units`].
    Units,
    /// [`TableSettings::comp_type`].
    CompType,
}

/// The dialects that read `setting`, each with its words for it, in the registry's order.
pub fn readers_of(setting: TableSetting) -> Vec<(&'static dyn Dialect, String)> {
    DIALECTS
        .iter()
        .filter_map(|d| {
            d.reads()
                .into_iter()
                .find(|(s, _)| *s == setting)
                .map(|(_, words)| (*d, words))
        })
        .collect()
}

/// What a dialect needs that its settings do not give.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsError {
    #[error("{what} states no unit: the unit (mm or inch) is required")]
    NoUnit { what: &'static str },
    #[error(
        "a LinuxCNC table does not state its COMP_FILE_TYPE: the type (actual or trim) is required"
    )]
    NoCompType,
}

/// One controller dialect: its names, limits, detection, and the formats its writer and
/// reader take. Each dialect's file implements it; [`DIALECTS`] lists them.
pub trait Dialect: Sync {
    /// The name `--format` takes and `import --json` prints.
    fn name(&self) -> &'static str;
    /// Other spellings accepted.
    fn aliases(&self) -> &'static [&'static str] {
        &[]
    }
    /// The controller as a user knows it (`Siemens 840D`).
    fn controller(&self) -> &'static str;
    /// One line for `--help`.
    fn about(&self) -> &'static str;
    fn limits(&self) -> Limits;
    /// The common settings ([`TableSetting`]) its tables read, each in the controller's
    /// words with its default where it has one; the help lists them from here.
    fn reads(&self) -> Vec<(TableSetting, String)> {
        Vec::new()
    }
    /// Whether `text` (decoded from `bytes`) is this dialect's table, by content (never
    /// by file name); `false` for a table that cannot be told by content (LinuxCNC).
    fn detect(&self, bytes: &[u8], text: &text::Text) -> bool;
    /// Whether [`Dialect::detect`] can tell the table at all.
    fn detects_by_content(&self) -> bool {
        true
    }
    /// The reader's format, with what the file does not say taken from `settings`.
    fn table_format(&self, settings: &TableSettings) -> Result<TableFormat, SettingsError>;
    /// The writer's format from `settings`; `bidirectional`: a reverse line is given.
    fn export_format(
        &self,
        settings: &TableSettings,
        bidirectional: bool,
    ) -> Result<ExportFormat, SettingsError>;
    /// The reader: the table in `text` (in `format`, this dialect's [`TableFormat`]),
    /// every point in errmap's sign with the [`Field`] where each value sits; refused at
    /// the line that does not fit. [`read`] dispatches here.
    fn read(&self, text: &text::Text, format: TableFormat) -> Result<Parsed, At>;
    /// How the common update writes this dialect's values.
    fn update_style(&self) -> UpdateStyle {
        UpdateStyle::default()
    }
    /// One point's new values in the common update. The default writes the dialect's [`Value`] of e + r in one column, or two
    /// (a second column that repeats the first keeps doing so); a dialect whose values
    /// are stored otherwise (LinuxCNC's actual positions, Fagor's reversal columns)
    /// overrides it.
    fn edit_point(&self, editor: &mut Editor, point: &PointUpdate) {
        update::edit_values(editor, point)
    }
    /// The in-place update of `table` by `residual` ([`update_table`] checks the axis and
    /// the directions first, then dispatches here). The default is the common update:
    /// every point through [`Dialect::edit_point`], in the file's own style, nothing
    /// else changed; a table that is not a list of values (FANUC's increments) overrides it.
    fn update(&self, table: &ControllerTable, residual: &Residual, bidirectional: bool) -> Updated {
        update::update_values(table, residual, bidirectional)
    }
    /// The dialect's part-program syntax for test plans and campaigns of lines, where
    /// errmap writes programs for this controller.
    fn program(&self) -> Option<&dyn program::ProgramSyntax> {
        None
    }
    /// The modulo table of a rotary axis ([`modulo`]), where this dialect writes one.
    fn modulo(&self) -> Option<&dyn modulo::ModuloSyntax> {
        None
    }
    /// The settings of this dialect's tables beyond [`TableSettings`]' common ones; the
    /// command line makes a flag of each.
    fn options(&self) -> &'static [DialectOption] {
        &[]
    }
    /// The 1-D tables of each axis' positioning error a volumetric model is written as
    /// (`volumetric export --axis-tables`), where this dialect writes them.
    fn axis_tables(&self) -> Option<AxisTables> {
        None
    }
    /// The controller's own volumetric compensation file (the 21 component tables), where
    /// it has one.
    fn volumetric(&self) -> Option<VolumetricTable> {
        None
    }
}

/// A dialect shows as its name.
impl std::fmt::Debug for dyn Dialect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Dialects are the same when their names are: the registry names each once.
impl PartialEq for dyn Dialect {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

/// A controller's volumetric compensation file: its writer, the file name the demo gives
/// it, and its words for the summary line.
#[derive(Debug, Clone, Copy)]
pub struct VolumetricTable {
    /// The file from a model's component tables and the name of its source.
    pub render: fn(&crate::volumetric::ComponentTables, &str) -> String,
    pub file_name: &'static str,
    /// The file's name in the summary line.
    pub summary: &'static str,
}

/// Every volumetric compensation file errmap writes, in the registry's order.
pub fn volumetric_tables() -> impl Iterator<Item = VolumetricTable> {
    DIALECTS.iter().filter_map(|d| d.volumetric())
}

/// How a dialect writes a volumetric model's positioning error of each axis as a 1-D
/// table: the table's format along an axis, the file's extension, and its words.
#[derive(Debug, Clone, Copy)]
pub struct AxisTables {
    /// The format of the table along `axis`.
    pub format: fn(crate::base::Axis) -> ExportFormat,
    pub extension: &'static str,
    /// One line for `--help`.
    pub about: &'static str,
    /// The tables' name in the summary line.
    pub summary: &'static str,
}

/// The registry: every controller dialect errmap writes, reads and updates, in the order
/// `--help` lists them. Adding a dialect: its file, and one line here.
pub static DIALECTS: &[&dyn Dialect] = &[
    &linuxcnc::LinuxCnc,
    &siemens::Siemens,
    &fanuc::Fanuc,
    &heidenhain::Heidenhain,
    &isg::Isg,
    &fagor::Fagor::Al8055,
    &fagor::Fagor::Mp8065,
];

/// The dialect named `name` (or one of its aliases), case-insensitive.
pub fn dialect(name: &str) -> Option<&'static dyn Dialect> {
    let n = name.trim();
    DIALECTS.iter().copied().find(|d| {
        d.name().eq_ignore_ascii_case(n) || d.aliases().iter().any(|a| a.eq_ignore_ascii_case(n))
    })
}

/// The dialects whose `pick` holds, by name: `a, b, c or d` (`conjunction` = "or"/"and").
pub fn names_where(pick: impl Fn(&dyn Dialect) -> bool, conjunction: &str) -> String {
    let names: Vec<&str> = DIALECTS
        .iter()
        .filter(|d| pick(**d))
        .map(|d| d.name())
        .collect();
    join_list(&names, conjunction)
}

/// `items` as a sentence lists them: `a, b, c or d` (`conjunction` = "or"/"and"); one item
/// alone, none empty.
pub fn join_list<S: AsRef<str>>(items: &[S], conjunction: &str) -> String {
    match items {
        [] => String::new(),
        [one] => one.as_ref().to_string(),
        [rest @ .., last] => {
            let rest: Vec<&str> = rest.iter().map(AsRef::as_ref).collect();
            format!("{} {conjunction} {}", rest.join(", "), last.as_ref())
        }
    }
}

/// The controller table `bytes` hold, by content, or `None`.
pub fn detect(bytes: &[u8]) -> Option<&'static dyn Dialect> {
    let text = text::Text::decode(bytes).ok()?;
    DIALECTS.iter().copied().find(|d| d.detect(bytes, &text))
}
