//! One export, as one job: which table, which dialect, written or updated in place, one
//! line or both directions, and where the points go — decided here, once, from typed
//! settings; the command line parses its flags into an [`ExportJob`], calls [`run`] and
//! prints the [`Exported`] summary (as `sim::job` is for the diagnosis).
//!
//! | source | what is written | dialects |
//! |---|---|---|
//! | [`Source::Model`] | the model sampled along a line (forward values only) | every dialect, and the CSV line |
//! | [`Source::Session`] | a direction-dependent table from the session's ISO 230-2 means x̄↑, x̄↓ on one of its lines (no model; with a step, the means put on the step's points by the controllers' own linear rule) | those whose [`Limits::bidirectional`] holds (Siemens through its CEC tables) |
//! | [`Source::Existing`] | the table in use updated by the session's residual, in its own layout ([`super::update`]) | every dialect |
//! | [`Source::Modulo`] | a rotary axis' modulo table: from a rotary table, from both directions of a session, or the table in use updated ([`super::modulo`]) | [`modulo_dialects`](super::modulo::modulo_dialects) (two directions: LinuxCNC, Fagor 8055) |
//!
//! Where the points go ([`Placement`]): with `ends` a round grid of the step through the
//! reference position; without, a table that lists every position ([`Spacing::Listed`],
//! and the CSV line) ends on the range end, the others need a step that divides the
//! range ([`StepFit`]).

use errmap_drivers::SessionRow;

use super::modulo::{ModuloError, ModuloInput, ModuloSpec, ModuloTable, modulo_dialect};
use super::{
    At, ControllerTable, Dialect, ExportFormat, Residual, SettingsError, Spacing, TableSettings,
    UpdateError, UpdateSummary, read, update_table,
};
use crate::base::Axis;
use crate::export::bidirectional::{ChooseLineError, LineMeans, choose_line, direction_tables};
use crate::export::{
    Ends, ExportError, Extrapolation, LineSpec, Sampled, StepFit, regrid_measured, sample_line_fit,
};
use crate::interp::Interpolator;
use crate::session::iso_by_line;

/// What is written: a controller's table, or errmap's CSV line.
#[derive(Clone, Copy)]
pub enum Output {
    Table(&'static dyn Dialect),
    Csv,
}

impl Output {
    /// The name `--format` gives it.
    pub fn name(self) -> &'static str {
        match self {
            Output::Table(d) => d.name(),
            Output::Csv => "csv",
        }
    }

    /// Whether every position is listed (any step fits, the last interval shorter).
    fn lists_every_position(self) -> bool {
        match self {
            Output::Table(d) => d.limits().spacing == Spacing::Listed,
            Output::Csv => true,
        }
    }
}

impl std::fmt::Debug for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a table's points go when a step is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// A round grid through `reference_mm`, the ends clamped or extrapolated.
    pub ends: Option<Ends>,
    pub reference_mm: f64,
}

impl Placement {
    /// The placement rule for `output` ([`crate::export::step`]).
    pub fn fit(self, output: Output) -> StepFit {
        match self.ends {
            Some(ends) => StepFit::Grid {
                reference_mm: self.reference_mm,
                ends,
            },
            None if output.lists_every_position() => StepFit::LastShorter,
            None => StepFit::Divide,
        }
    }
}

/// Where the table's values come from.
pub enum Source<'a> {
    /// A fitted model along `line` (its step placed by [`Placement`]).
    Model {
        model: &'a dyn Interpolator,
        line: LineSpec,
        extrapolation: Extrapolation,
    },
    /// A session's per-direction means on the line `at` names; `step_mm` regrids them.
    Session {
        rows: &'a [SessionRow],
        at: &'a [(Axis, f64)],
        step_mm: Option<f64>,
    },
    /// The table in use (`bytes`) updated by the session's residual.
    Existing {
        bytes: &'a [u8],
        rows: &'a [SessionRow],
        bidirectional: bool,
    },
    /// A rotary axis' modulo table; `spec.dialect` is the output's.
    Modulo {
        spec: &'a ModuloSpec,
        input: ModuloInput<'a>,
    },
}

impl std::fmt::Debug for Source<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Model { line, .. } => write!(f, "Model({line:?})"),
            Source::Session { rows, .. } => write!(f, "Session({} rows)", rows.len()),
            Source::Existing { bytes, rows, .. } => {
                write!(f, "Existing({} bytes, {} rows)", bytes.len(), rows.len())
            }
            Source::Modulo { spec, .. } => write!(f, "Modulo({})", spec.dialect.name()),
        }
    }
}

/// One export.
#[derive(Debug)]
pub struct ExportJob<'a> {
    pub output: Output,
    pub settings: TableSettings,
    pub placement: Placement,
    pub source: Source<'a>,
}

/// What was written, for the caller's summary.
#[derive(Debug, Clone, PartialEq)]
pub enum Written {
    /// A line from a model: the samples, and a note on where the table goes (HEIDENHAIN).
    Line {
        sampled: Sampled,
        note: Option<String>,
    },
    /// Both directions from a session: the forward line and the mean reversal, µm.
    Directions {
        forward: Sampled,
        mean_reversal_um: f64,
    },
    /// A table updated in place.
    Updated(UpdateSummary),
    /// A rotary axis' modulo table (written, or updated in place).
    Modulo(Box<ModuloTable>),
}

/// The file's bytes and what they hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    pub bytes: Vec<u8>,
    /// The format's name for messages.
    pub format: &'static str,
    pub written: Written,
}

/// Why an export cannot be made; each names its part of the job.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// A setting the dialect needs is missing.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The line cannot be sampled or rendered.
    #[error(transparent)]
    Line(ExportError),
    /// A session's table cannot be rendered in this format.
    #[error(transparent)]
    Table(ExportError),
    #[error(
        "{format} has no direction-dependent table (those that do: {with}); export the \
         bidirectional mean from the error table instead"
    )]
    NoReverse { format: &'static str, with: String },
    #[error("the session has no rows")]
    EmptySession,
    #[error(
        "{format} has no modulo table for a rotary axis ({})",
        super::modulo::modulo_names()
    )]
    NoModulo { format: &'static str },
    /// The modulo table cannot be made or updated.
    #[error(transparent)]
    Modulo(#[from] ModuloError),
    #[error("only a controller table is updated in place: {with}")]
    NotUpdatable { with: String },
    #[error(transparent)]
    ChooseLine(#[from] ChooseLineError),
    /// The table in use cannot be read.
    #[error("{0:?}")]
    Read(At),
    /// The session's residual cannot be formed.
    #[error(transparent)]
    Residual(UpdateError),
    /// The table cannot take the update.
    #[error(transparent)]
    Update(UpdateError),
}

/// Runs the job (module docs). Pure: no file is read or written.
pub fn run(job: &ExportJob<'_>) -> Result<Exported, JobError> {
    match &job.source {
        Source::Model {
            model,
            line,
            extrapolation,
        } => from_model(job, *model, line, *extrapolation),
        Source::Session { rows, at, step_mm } => from_session(job, rows, at, *step_mm),
        Source::Existing {
            bytes,
            rows,
            bidirectional,
        } => update(job, bytes, rows, *bidirectional),
        Source::Modulo { spec, input } => {
            let format = job.output.name();
            if modulo_dialect(format).map(|d| d.name()) != Some(spec.dialect.name()) {
                return Err(JobError::NoModulo { format });
            }
            let table = super::modulo::modulo(*input, spec)?;
            Ok(Exported {
                bytes: table.text.clone().into_bytes(),
                format: spec.dialect.name(),
                written: Written::Modulo(Box::new(table)),
            })
        }
    }
}

/// The library's format for the output.
fn format(job: &ExportJob<'_>, bidirectional: bool) -> Result<ExportFormat, SettingsError> {
    match job.output {
        Output::Table(d) => d.export_format(&job.settings, bidirectional),
        Output::Csv => Ok(ExportFormat::Csv),
    }
}

fn from_model(
    job: &ExportJob<'_>,
    model: &dyn Interpolator,
    line: &LineSpec,
    extrapolation: Extrapolation,
) -> Result<Exported, JobError> {
    let format = format(job, false)?;
    let fit = job.placement.fit(job.output);
    let sampled = sample_line_fit(model, line, fit, extrapolation).map_err(JobError::Line)?;
    let bytes = format
        .render_bytes(&sampled, None)
        .map_err(JobError::Line)?;
    let note = match &format {
        ExportFormat::Heidenhain {
            axis_key,
            table_name,
            ..
        } => Some(super::heidenhain::assignment_note(
            &sampled, axis_key, table_name,
        )),
        _ => None,
    };
    Ok(Exported {
        bytes,
        format: format.name(),
        written: Written::Line { sampled, note },
    })
}

fn from_session(
    job: &ExportJob<'_>,
    rows: &[SessionRow],
    at: &[(Axis, f64)],
    step_mm: Option<f64>,
) -> Result<Exported, JobError> {
    let format = format(job, true)?;
    if !format.bidirectional() {
        return Err(JobError::NoReverse {
            format: format.name(),
            with: super::names_where(|d| d.limits().bidirectional, "and"),
        });
    }
    let first = rows.first().ok_or(JobError::EmptySession)?;
    let axis = Axis::from(first.axis);
    let (lines, failed) = iso_by_line(rows);
    let means: Vec<LineMeans> = lines
        .iter()
        .map(|(at_mm, stats)| LineMeans {
            at_mm: *at_mm,
            positions_mm: stats.targets.iter().map(|t| t.position_mm).collect(),
            mean_up_um: stats.targets.iter().map(|t| t.mean_up_um).collect(),
            mean_down_um: stats.targets.iter().map(|t| t.mean_down_um).collect(),
        })
        .collect();
    let failed: Vec<String> = failed.iter().map(|(l, e)| format!("{l:?}: {e}")).collect();
    let i = choose_line(axis, &means, at, &failed)?;
    let stats = &lines[i].1;
    let (mut forward, mut reverse) = direction_tables(axis, &means[i]);
    if let Some(step) = step_mm {
        let fit = job.placement.fit(job.output);
        forward = regrid_measured(&forward, step, fit).map_err(JobError::Line)?;
        reverse = regrid_measured(&reverse, step, fit).map_err(JobError::Line)?;
    }
    let bytes = format
        .render_bytes(&forward, Some(&reverse))
        .map_err(JobError::Table)?;
    let mean_reversal_um = stats.targets.iter().map(|t| t.reversal_um).sum::<f64>()
        / stats.targets.len().max(1) as f64;
    Ok(Exported {
        bytes,
        format: format.name(),
        written: Written::Directions {
            forward,
            mean_reversal_um,
        },
    })
}

fn update(
    job: &ExportJob<'_>,
    bytes: &[u8],
    rows: &[SessionRow],
    bidirectional: bool,
) -> Result<Exported, JobError> {
    let Output::Table(d) = job.output else {
        return Err(JobError::NotUpdatable {
            with: super::names_where(|_| true, "or"),
        });
    };
    let format = d.table_format(&job.settings)?;
    let table: ControllerTable = read(bytes, format)
        .map_err(JobError::Read)?
        .assume_axis(job.settings.axis);
    let residual = Residual::from_session(rows, bidirectional).map_err(JobError::Residual)?;
    let updated = update_table(&table, &residual, bidirectional).map_err(JobError::Update)?;
    Ok(Exported {
        bytes: updated.bytes,
        format: d.name(),
        written: Written::Updated(updated.summary),
    })
}
