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
    /// A model document without a fit: not written by the identification (the CLI adds
    /// the command that writes one).
    #[error("{path}: fit: missing")]
    NoFit { path: PathBuf },
}

/// Why the lines cannot carry a fit; the caller names the line table.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Unfit {
    /// Least squares: no degree of freedom beyond the determined parameters.
    #[error(
        "{rows} targets on {lines} lines leave no degree of freedom for {rank} determined parameters and {lines} line constants; measure more targets or lower the degree"
    )]
    NoFreedom {
        rows: usize,
        lines: usize,
        rank: usize,
    },
    /// Penalised tables: no degree of freedom beyond the effective parameters.
    #[error(
        "{rows} targets on {lines} lines leave no degree of freedom for {edf:.1} effective parameters and {lines} line constants; measure more targets"
    )]
    NoFreedomPenalised { rows: usize, lines: usize, edf: f64 },
    /// The penalised normal equations could not be factorised.
    #[error("the penalised normal equations are singular")]
    Singular,
}

/// What an identified model cannot give because the lines did not determine it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Undetermined {
    /// The compensation tables need every component; these were not determined.
    #[error("the compensation needs {}, which the lines did not determine", .components.join(", "))]
    Compensation { components: Vec<String> },
    /// One component has no value at a position.
    #[error("{component} is not determined")]
    Component { component: String },
    /// The positioning error of an axis at a position.
    #[error(
        "the positioning error of {axis} at {at_mm} mm depends on components the lines did not determine"
    )]
    Positioning { axis: char, at_mm: f64 },
    /// The error vector needs the named components.
    #[error(
        "the error vector needs {missing}, which the lines did not determine (see `unidentified` in the model)"
    )]
    Vector { missing: String },
}

/// A component name that is not one of the 18 (`E_XX` … `E_CZ`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown component `{0}`")]
pub struct UnknownComponent(pub String);

/// A preset name of a volumetric plan that is not one of [`PRESETS`](super::simulate).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown preset `{name}` (presets: {})", .known.join(", "))]
pub struct UnknownPreset {
    pub name: String,
    pub known: Vec<&'static str>,
}

/// Why a component table in a model file cannot be used; the caller names the file and key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ComponentTableError {
    #[error("{positions} positions but {values} values")]
    Lengths { positions: usize, values: usize },
    #[error("a position is repeated")]
    Repeated,
    #[error("a table needs at least 2 positions")]
    TooFew,
    #[error("the positions must include 0 (components are zero at 0)")]
    NoZero,
    #[error("the value at 0 mm is {value}; components are zero at their reference position 0")]
    NotZeroAtZero { value: f64 },
    /// The interpolator refused the table (its own words).
    #[error("{0}")]
    Interpolation(String),
}

/// A problem of one key of a model or plan file (the shared [`ConfigError`] shape).
pub(crate) fn config_err(
    path: &Path,
    key: impl Into<String>,
    message: impl Into<String>,
) -> VolumetricError {
    ConfigError::key(path, key, message).into()
}
