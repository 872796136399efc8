//! A session reduced to its error table, ISO 230-2 statistics per line and their
//! uncertainty budgets: the job behind `errmap table` and the workbench's session page.
//! It reads the session table in batches (memory bounded by a batch and the dwell
//! accumulators) and writes nothing; the caller writes the table and says what happened.

use std::path::Path;

use crate::session::{
    self, AxisStats, EnvironmentStats, IsoError, ReductionError, ReductionSummary,
};
use crate::session::{Budget, StatUncertainty};
use crate::table::{ErrorTable, TableError};

/// Why a session could not be reduced.
#[derive(Debug, thiserror::Error)]
pub enum ReduceError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Reduction(#[from] ReductionError),
    #[error(transparent)]
    Uncertainty(#[from] session::UncertaintyError),
}

/// A session reduced to an error table, with ISO 230-2 statistics per line.
#[derive(Debug)]
pub struct Reduced {
    pub table: ErrorTable,
    pub summary: ReductionSummary,
    /// The lines with ISO 230-2 statistics, in line order.
    pub iso: Vec<((f64, f64), AxisStats)>,
    /// The lines without, and why.
    pub failed: Vec<((f64, f64), IsoError)>,
    /// The uncertainty budget of each line of `iso` (made with the [`BudgetInputs`]).
    pub budgets: Vec<Budget>,
    /// The expanded uncertainty of each line's figures (`budgets[k].expanded()`).
    pub expanded: Vec<StatUncertainty>,
    /// The air, material and humidity readings over the session.
    pub environment: EnvironmentStats,
    /// The capture's device description was found beside the table (its `session.json`).
    pub device_known: bool,
}

/// What a test's description (an info file) adds to the uncertainty budget: the budget's
/// configuration, the laser resolution it states, its drift check and the conditions it
/// declares for what no sensor recorded. The default adds nothing.
#[derive(Debug, Clone, Default)]
pub struct BudgetInputs {
    pub config: session::UncertaintyConfig,
    pub stated_laser_um: Option<f64>,
    pub drift_check: session::DriftCheck,
    pub declared: session::DeclaredConditions,
}

/// Reduces the session table at `path` (a table file; see `sim::session_file` for a
/// capture directory) with the default budget inputs.
pub fn reduce_session(path: &Path) -> Result<Reduced, ReduceError> {
    reduce_session_with(path, &BudgetInputs::default())
}

/// Reduces the session table at `path`, its budgets made with `inputs`.
pub fn reduce_session_with(path: &Path, inputs: &BudgetInputs) -> Result<Reduced, ReduceError> {
    let mut reducer = session::Reducer::new();
    let mut environment = EnvironmentStats::default();
    let mut recorded = session::RecordedResolution::default();
    let mut drift = session::DriftFinder::default();
    session::for_each_batch(path, session::BATCH_ROWS, &mut |rows| {
        for r in rows {
            reducer.push(r);
            environment.push(r);
            recorded.push(r.laser_mm);
            drift.push(r);
        }
        Ok(())
    })?;
    let (table, summary) = reducer.error_table(&path.display().to_string())?;
    let device = super::device_resolutions(path);
    let device_known = device.is_some();
    let sources = session::BudgetSources::choose(
        device,
        inputs.stated_laser_um,
        &recorded,
        &inputs.drift_check,
        &drift,
        &inputs.declared,
    );
    let (iso, failed) = reducer.iso_by_line();
    let budgets = iso
        .iter()
        .map(|(_, s)| {
            session::line_budget_with(&inputs.config, &environment, s, &sources).map(|(b, _)| b)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let expanded = budgets.iter().map(Budget::expanded).collect();
    Ok(Reduced {
        table,
        summary,
        iso,
        failed,
        budgets,
        expanded,
        environment,
        device_known,
    })
}
