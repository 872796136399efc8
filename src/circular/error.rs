//! [`CircularError`]: what can be wrong with a circular test, a machine model for the
//! simulator or a volumetric model for the link, naming the file, line and column (or the
//! TOML key).

use std::path::{Path, PathBuf};

use crate::table::TableError;

/// Why a circular test (or a model) could not be read, or a result not made.
#[derive(Debug, thiserror::Error)]
pub enum CircularError {
    #[error("{path}: cannot read or write: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A cell or a row of the trace (line = file line, the header is line 1).
    #[error("{path}: line {line}: column {column}: {problem}")]
    Trace {
        path: PathBuf,
        line: usize,
        column: String,
        problem: String,
    },
    /// A TOML file that does not parse (line and column of the problem).
    #[error("{path}: line {line}: column {column}: {problem}")]
    Toml {
        path: PathBuf,
        line: usize,
        column: usize,
        problem: String,
    },
    /// A TOML key that is missing or has an invalid value.
    #[error("{path}: key {key}: {problem}")]
    Key {
        path: PathBuf,
        key: String,
        problem: String,
    },
    /// The trace as a whole (no rows, too many runs, ...).
    #[error("{path}: {problem}")]
    Test { path: PathBuf, problem: String },
    #[error(transparent)]
    Table(#[from] TableError),
    /// The volumetric model of the link could not be read or could not predict.
    #[error("{path}: {problem}")]
    Link { path: PathBuf, problem: String },
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> CircularError + '_ {
    move |source| CircularError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(crate) fn key_err(path: &Path, key: &str, problem: impl Into<String>) -> CircularError {
    CircularError::Key {
        path: path.to_path_buf(),
        key: key.to_string(),
        problem: problem.into(),
    }
}

/// Parses TOML text into `T`, a parse error (an unknown key included, where `T` denies
/// them) named by its line and column.
pub(crate) fn parse_toml<T: for<'de> serde::Deserialize<'de>>(
    path: &Path,
    text: &str,
) -> Result<T, CircularError> {
    toml::from_str(text).map_err(|e| {
        let (line, column) = match e.span() {
            Some(span) => line_column(text, span.start),
            None => (1, 1),
        };
        CircularError::Toml {
            path: path.to_path_buf(),
            line,
            column,
            problem: e.message().trim_end().to_string(),
        }
    })
}

/// 1-based line and column (in characters) of byte offset `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = text.get(..at).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before
        .rsplit('\n')
        .next()
        .map(|l| l.chars().count())
        .unwrap_or(0)
        + 1;
    (line, column)
}
