//! [`VolumetricError`]: what can be wrong with a volumetric model, plan or line table,
//! naming the file and the key, or the row, column and line.

use std::path::{Path, PathBuf};

use crate::table::TableError;

/// What can be wrong with a volumetric input or output file.
#[derive(Debug, thiserror::Error)]
pub enum VolumetricError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A TOML or JSON file that does not parse or does not validate; `key` names the
    /// offending entry (`components.E_BX.poly`, `line[3].targets`…).
    #[error("{path}: {key}: {message}")]
    Config {
        path: PathBuf,
        key: String,
        message: String,
    },
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

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> VolumetricError + '_ {
    move |source| VolumetricError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(crate) fn config_err(
    path: &Path,
    key: impl Into<String>,
    message: impl Into<String>,
) -> VolumetricError {
    VolumetricError::Config {
        path: path.to_path_buf(),
        key: key.into(),
        message: message.into(),
    }
}

/// Reads a TOML file into `T`; a parse error names the file and carries toml's own
/// line, column and key.
pub(crate) fn read_toml<T: for<'de> serde::Deserialize<'de>>(
    path: &Path,
) -> Result<T, VolumetricError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let value =
        toml::from_str(&text).map_err(|e| config_err(path, "file", e.to_string().trim_end()))?;
    // Every number within its key's physical range, as the simulator's files (issue 17:
    // a component coefficient of 1e308 came out as an inf error vector).
    crate::sim::bounds::check_numbers(path, &text).map_err(|e| match e {
        crate::sim::SimError::Config { message, .. } => match message.split_once(": ") {
            Some((key, problem)) => config_err(path, key, problem),
            None => config_err(path, "file", message),
        },
        other => config_err(path, "file", other.to_string()),
    })?;
    Ok(value)
}
