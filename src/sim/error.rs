//! Errors of the simulator's files: the machine model, the plan, the concealed cases.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::table::TableError;

/// What can be wrong with a machine model, a plan or a simulation's output files.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },
    #[error(transparent)]
    Table(#[from] TableError),
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SimError + '_ {
    move |source| SimError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads a simulator TOML file (a machine model, a plan) into `T`: read once, unknown
/// keys refused where `T` says so, then every number checked against its physical range
/// ([`super::bounds`]).
pub(crate) fn read_toml<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, SimError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let value = toml::from_str(&text).map_err(|e| SimError::Config {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    super::bounds::check_numbers(path, &text)?;
    Ok(value)
}
