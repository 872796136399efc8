//! [`VolumetricError`]: what can be wrong with a volumetric model, plan or line table,
//! naming the file and the key, or the row, column and line.

use std::path::{Path, PathBuf};

use crate::base::{ConfigError, FileError};
use crate::table::TableError;

/// What can be wrong with a volumetric input or output file.
#[derive(Debug, thiserror::Error)]
pub enum VolumetricError {
    #[error(transparent)]
    File(#[from] FileError),
    /// A TOML or JSON file that does not parse or does not validate; the location names
    /// the offending entry (`components.E_BX.poly`, `line[3].targets`…).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A line of a line table as a whole is wrong (too few targets, …).
    #[error("{path}: line `{line}` (first at row {row}, file line {file_line}): {problem}")]
    Line {
        path: PathBuf,
        line: String,
        row: usize,
        file_line: usize,
        problem: String,
    },
    /// A topology that is not a permutation of XYZ.
    #[error("topology `{0}` is not a permutation of XYZ (e.g. YXZ for a moving-bridge CMM)")]
    Topology(String),
    /// The lines cannot carry the fit at all (no degrees of freedom left, …).
    #[error("{file}: {message}")]
    Fit { file: String, message: String },
    #[error(transparent)]
    Table(#[from] TableError),
}

/// A problem of one key of a model or plan file (the shared [`ConfigError`] shape).
pub(crate) fn config_err(
    path: &Path,
    key: impl Into<String>,
    message: impl Into<String>,
) -> VolumetricError {
    ConfigError::key(path, key, message).into()
}
