//! Why an acceptance input was refused: each variant names the file and the row, key or
//! option, as `cli-contract.md` asks of exit 1.

use crate::base::{ConfigError, FileError};
use crate::table::TableError;
use crate::volumetric::VolumetricError;

/// Errors of the acceptance stage.
#[derive(Debug, thiserror::Error)]
pub enum AcceptanceError {
    /// A value the rule cannot judge with (a negative U, T_L > T_U, r < 0, …).
    #[error("{what}: {problem}")]
    Value { what: String, problem: String },
    /// A data row of a table (`FILE: row R (line R+1): problem`), a problem of the whole
    /// file (its columns, its design) or a key of a TOML file: the shared [`ConfigError`].
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// An MPE (or U) formula that does not parse.
    #[error(
        "{option} `{formula}`: {problem} (expected `A+L/K`, `min(A+L/K,B)` or `B`, A and B in µm, K > 0)"
    )]
    Formula {
        option: String,
        formula: String,
        problem: super::mpe::FormulaProblem,
    },
    /// The volumetric model cannot give what the plan needs.
    #[error("{}: {problem}", path.display())]
    Model {
        path: std::path::PathBuf,
        problem: String,
    },
    /// A setting of the probing test out of range or given nowhere, named with the SPHERE
    /// file it completes (the command line names the flag that sets it).
    #[error("{}: {setting}: {problem}", path.display())]
    Setting {
        path: std::path::PathBuf,
        setting: ProbingSetting,
        problem: SettingProblem,
    },
    /// A file that cannot be read (the shared [`FileError`] shape).
    #[error(transparent)]
    File(#[from] FileError),
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
        ConfigError::row(path, row, row + 1, column, problem).into()
    }

    pub(crate) fn file(path: &std::path::Path, problem: impl Into<String>) -> Self {
        ConfigError::file(path, problem).into()
    }

    pub(crate) fn key(
        path: &std::path::Path,
        key: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        ConfigError::key(path, key, problem).into()
    }
}

/// A setting of the probing test that the SPHERE file's `[mpe]` table or the caller's
/// options give; shown as its key in the SPHERE file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbingSetting {
    MpeForm,
    MpeSize,
    MpeLocation,
    GuardFraction,
}

impl ProbingSetting {
    /// The key in the SPHERE file (`guard_fraction` is the rule's).
    pub fn key(self) -> &'static str {
        match self {
            ProbingSetting::MpeForm => "mpe.form_um",
            ProbingSetting::MpeSize => "mpe.size_um",
            ProbingSetting::MpeLocation => "mpe.location_um",
            ProbingSetting::GuardFraction => "guard_fraction",
        }
    }
}

impl std::fmt::Display for ProbingSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

/// What is wrong with a [`ProbingSetting`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SettingProblem {
    /// An MPE that is not finite and positive.
    #[error("{0}: an MPE must be finite and > 0 µm")]
    NotPositive(f64),
    /// A guard-band fraction that is not finite and ≥ 0.
    #[error("r = {0} must be finite and ≥ 0")]
    Fraction(f64),
    /// An MPE given neither by the options nor in `[mpe]`.
    #[error("missing")]
    Missing,
}
