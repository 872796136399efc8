//! The artefact stage's errors: files the OS refuses, files that hold something wrong
//! (naming the key or the row), and fits that cannot be made.

use std::path::PathBuf;

use crate::base::{ConfigError, FileError};

#[derive(Debug, thiserror::Error)]
pub enum ArtefactError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Volumetric(#[from] crate::volumetric::VolumetricError),
    #[error(transparent)]
    Undetermined(#[from] crate::volumetric::Undetermined),
    /// The output directory of `simulate` exists already (nothing recorded is replaced).
    #[error("{}: exists already; the simulated measurements go into a new directory", path.display())]
    Exists { path: PathBuf },
    /// A fit that the data cannot carry (too few features, a degenerate layout).
    #[error("{}: {message}", file.display())]
    Fit { file: PathBuf, message: String },
}
