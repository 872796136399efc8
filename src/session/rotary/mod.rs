//! Rotary sessions (axis A, B or C): the table, its checks, ISO 230-2 in arcseconds with
//! the 0/360° closure check, and the rotary error table (`docs/rotary.md`).
//!
//! A rotary session row holds the axis' own reading (`indicated_deg`), the reference
//! instrument's angle (`reference_deg`) and `error_arcsec` = (indicated − reference)·3600,
//! the value every evaluation uses. Targets lie in [0, 360]; 0 and 360 are one physical
//! position, the **closure pair**, evaluated as two targets and compared with each other
//! ([`Closure`]). No angle is ever wrapped.
//!
//! The ISO 230-2 figures are the linear axis' (`session::axis_stats`, ISO 230-2:2014
//! clause 3, whose scope covers rotary axes alike), fed with degrees for millimetres and
//! arcseconds for micrometres: the formulas hold whatever the unit.

mod budget;
mod iso;
mod read;

pub use budget::{
    ASSUMED_REFERENCE_ACCURACY_ARCSEC, RotaryBudget, RotaryBudgetInputs, RotaryTerm, rotary_budget,
};
pub use iso::{
    Closure, RotaryIso, RotaryTable, RotaryTableRow, RotaryTargetStats, closure_warning,
    read_rotary_error_table, rotary_error_table, rotary_iso, write_rotary_error_table,
};
pub use read::{
    is_rotary, read_rotary_session, rotary_csv_header, rotary_csv_line, rotary_frame,
    write_rotary_session,
};

use std::path::PathBuf;

use crate::base::RotaryAxis;
use crate::table::TableError;

/// Two target angles closer than this (1 µ°) are the same nominal angle.
pub const ANGLE_TOL_DEG: f64 = 1e-6;

/// One latched sample of a rotary session: the capture's own row (as the linear session
/// holds the drivers' `SessionRow`); its `axis` is the wire's, and the session's
/// [`RotarySession::axis`] (every row's: the reader and the capture refuse a second one).
pub use errmap_drivers::rotary::RotaryRow;

/// A rotary session: its axis and its rows in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct RotarySession {
    pub axis: RotaryAxis,
    pub rows: Vec<RotaryRow>,
}

impl RotarySession {
    /// The dwell rows' distinct targets, ascending: (index, angle).
    pub fn targets(&self) -> Vec<(i32, f64)> {
        let mut v: Vec<(i32, f64)> = Vec::new();
        for r in self.rows.iter().filter(|r| r.is_dwell()) {
            if let Some(deg) = r.target_deg
                && !v.iter().any(|t| t.0 == r.target)
            {
                v.push((r.target, deg));
            }
        }
        v.sort_by(|a, b| a.1.total_cmp(&b.1));
        v
    }
}

/// A rotary session or table that cannot be read or breaks the contract.
#[derive(Debug, thiserror::Error)]
pub enum RotaryError {
    #[error(transparent)]
    Table(TableError),
    /// A cell, or a rule about one row: the file's physical line (header = 1).
    #[error("{path}: line {line}: column {column}: {problem}")]
    At {
        path: PathBuf,
        line: usize,
        column: String,
        problem: String,
    },
    #[error(transparent)]
    Io(#[from] crate::base::FileError),
    /// The session as a whole (no dwell rows, too few runs for a figure).
    #[error("{path}: {problem}")]
    Whole { path: PathBuf, problem: String },
}

impl RotaryError {
    fn at(path: &std::path::Path, line: usize, column: &str, problem: impl Into<String>) -> Self {
        RotaryError::At {
            path: path.to_path_buf(),
            line,
            column: column.to_string(),
            problem: problem.into(),
        }
    }
}

impl From<TableError> for RotaryError {
    /// A table reader's cell error in the rotary contract's words (line, column).
    fn from(e: TableError) -> Self {
        let (path, line, column, problem) = match e {
            TableError::NotNumeric {
                path,
                line,
                column,
                value,
                ..
            } => (path, line, column, format!("`{value}` is not a number")),
            TableError::EmptyCell {
                path, line, column, ..
            } => (path, line, column, "empty cell in a required column".into()),
            TableError::NonFinite {
                path,
                line,
                column,
                value,
                ..
            } => (
                path,
                line,
                column,
                format!("{value} is not a finite number"),
            ),
            TableError::BadValue {
                path,
                line,
                column,
                problem,
                ..
            } => (path, line, column, problem),
            other => return RotaryError::Table(other),
        };
        RotaryError::At {
            path,
            line,
            column,
            problem,
        }
    }
}
