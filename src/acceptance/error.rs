//! Why an acceptance input was refused: each variant names the file and the row, key or
//! option, as `cli-contract.md` asks of exit 1.

use std::path::PathBuf;

use crate::table::TableError;
use crate::volumetric::VolumetricError;

/// Errors of the acceptance stage.
#[derive(Debug, thiserror::Error)]
pub enum AcceptanceError {
    /// A value the rule cannot judge with (a negative U, T_L > T_U, r < 0, …).
    #[error("{what}: {problem}")]
    Value { what: String, problem: String },
    /// A data row of a table: `FILE: row R (line R+1): problem`.
    #[error("{}: row {row} (line {}){}: {problem}", path.display(), row + 1, column.as_deref().map(|c| format!(", column `{c}`")).unwrap_or_default())]
    Row {
        path: PathBuf,
        row: usize,
        column: Option<String>,
        problem: String,
    },
    /// A problem of the whole file (its columns, its design).
    #[error("{}: {problem}", path.display())]
    File { path: PathBuf, problem: String },
    /// A key of a TOML file.
    #[error("{}: {key}: {problem}", path.display())]
    Key {
        path: PathBuf,
        key: String,
        problem: String,
    },
    /// An MPE (or U) formula that does not parse.
    #[error(
        "{option} `{formula}`: {problem} (expected `A+L/K`, `min(A+L/K,B)` or `B`, A and B in µm, K > 0)"
    )]
    Formula {
        option: String,
        formula: String,
        problem: String,
    },
    /// The volumetric model cannot give what the plan needs.
    #[error("{}: {problem}", path.display())]
    Model { path: PathBuf, problem: String },
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Volumetric(#[from] VolumetricError),
}

impl AcceptanceError {
    pub(crate) fn value(what: impl Into<String>, problem: impl Into<String>) -> Self {
        AcceptanceError::Value {
            what: what.into(),
            problem: problem.into(),
        }
    }

    pub(crate) fn row(
        path: &std::path::Path,
        row: usize,
        column: Option<&str>,
        problem: impl Into<String>,
    ) -> Self {
        AcceptanceError::Row {
            path: path.to_path_buf(),
            row,
            column: column.map(str::to_string),
            problem: problem.into(),
        }
    }

    pub(crate) fn file(path: &std::path::Path, problem: impl Into<String>) -> Self {
        AcceptanceError::File {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }

    pub(crate) fn key(
        path: &std::path::Path,
        key: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        AcceptanceError::Key {
            path: path.to_path_buf(),
            key: key.into(),
            problem: problem.into(),
        }
    }
}
