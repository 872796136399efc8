//! The error type of every chart function, [`PlotError`].

use std::path::PathBuf;

/// Why a chart could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A required input slice was empty (names the argument).
    #[error("nothing to plot: {0} is empty")]
    Empty(&'static str),
    /// A slice does not have the length the other arguments imply.
    #[error("length mismatch: {what} has {found} values, expected {expected}")]
    LengthMismatch {
        /// Which argument or series.
        what: String,
        /// Length implied by the other arguments.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// Every value was NaN or infinite.
    #[error("nothing to plot: no finite values")]
    NoFiniteValues,
    /// Any other unusable input (e.g. an output stem without a file name).
    #[error("invalid plot input: {0}")]
    Invalid(String),
    /// The output directory could not be created.
    #[error("cannot create directory {path}: {source}")]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The bundled fonts could not be registered with plotters.
    #[error("the bundled DejaVu fonts could not be registered with plotters")]
    Fonts,
    /// Drawing or writing an output file failed.
    #[error("drawing {path} failed: {source}")]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// What plotters or the file system reported.
        #[source]
        source: DrawFailure,
    },
}

/// What plotters or the file system reported while a figure was drawn or put in place;
/// [`PlotError::Draw`] names the file. Kept as text: plotters' errors are generic over
/// the drawing backend and borrow from it.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct DrawFailure {
    message: String,
}

impl DrawFailure {
    /// The report of a backend or of the file system.
    pub(crate) fn new(e: impl std::fmt::Display) -> Self {
        Self {
            message: e.to_string(),
        }
    }
}
