//! [`CircularError`]: what can be wrong with a circular test, a machine model for the
//! simulator or a volumetric model for the link, naming the file, line and column (or the
//! TOML key).

use std::path::{Path, PathBuf};

use crate::base::{ConfigError, FileError};
use crate::table::TableError;

/// Why a circular test (or a model) could not be read, or a result not made.
#[derive(Debug, thiserror::Error)]
pub enum CircularError {
    /// A file that cannot be read or written (the trace, its TOML, a model).
    #[error(transparent)]
    File(#[from] FileError),
    /// A cell or a row of the trace (line = file line, the header is line 1).
    #[error("{path}: line {line}: column {column}: {problem}")]
    Trace {
        path: PathBuf,
        line: usize,
        column: String,
        problem: String,
    },
    /// A TOML file that does not parse (at a line and column) or a key that is missing or
    /// has an invalid value.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The trace as a whole (no rows, too many runs, ...).
    #[error("{path}: {problem}")]
    Test { path: PathBuf, problem: String },
    #[error(transparent)]
    Table(#[from] TableError),
    /// A simulated test that would have more samples than a test may have (refused before
    /// anything is allocated).
    #[error(
        "a simulated test of {samples:.3e} samples is more than the {max} a test may have \
         (raise the feed or lower the sample rate)"
    )]
    TooManySamples { samples: f64, max: usize },
    /// The volumetric model of the link could not be read or could not predict.
    #[error("{path}: {problem}")]
    Link {
        path: PathBuf,
        problem: super::link::LinkProblem,
    },
}

/// A TOML key that is missing or has an invalid value (the shared [`ConfigError`] shape).
pub(crate) fn key_err(path: &Path, key: &str, problem: impl Into<String>) -> CircularError {
    ConfigError::key(path, key, problem).into()
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
        ConfigError::position(path, line, column, e.message().trim_end()).into()
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
