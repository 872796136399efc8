//! Presentation for every stage: words, tables and figures on disk. Nothing else in the
//! library imports this module; it imports any stage it reports on, and [`crate::plot`].
//!
//! | module | writes |
//! |---|---|
//! | [`compare`] | the comparison report (`report.md`, CSVs, figures) of `compare --report` |
//! | [`concealed`] | the concealed-case report and index (`reports/diagnosis/`) |
//! | [`findings`] | a comparison's findings in plain words |
//! | [`json`] | the `compare --json` document |
//! | [`iso230`] | the ISO 230-2 / VDI/DGQ 3441 section and deviation chart |
//! | [`certificate`] | the calibration certificate PDF (`errmap certificate`) |
//! | [`uncertainty`] | the measurement-uncertainty budget table and the standards note |
//! | [`environment`] | a session's air and material temperatures in words and a table |
//! | [`diagnosis`] | the diagnosis report (`diagnose --out`, `reports/diagnosis/`) |
//! | [`experiment`] | the seed-000 simulation's report (`fuzzy-sim`) |
//! | [`volumetric`] | the volumetric identification report (`volumetric identify --report`) |

use std::path::PathBuf;

use crate::plot::PlotError;
use crate::table::TableError;

pub mod certificate;
pub mod compare;
pub mod concealed;
pub mod diagnosis;
pub mod environment;
pub mod experiment;
pub mod findings;
pub mod iso230;
pub mod json;
pub mod uncertainty;
pub mod volumetric;

pub use compare::write_report;
pub use findings::group_by_reason;
pub use json::{CompareJson, CompareJsonRow, MethodJson, RefusedJson};

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Creating the directory or writing a file failed.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A table (CSV/Parquet) could not be written.
    #[error(transparent)]
    Table(#[from] TableError),
    /// A case could not be diagnosed.
    #[error("{path}: diagnosis failed: {source}")]
    Diagnose {
        path: PathBuf,
        #[source]
        source: crate::diagnose::DiagnoseError,
    },
    /// A case's truth or model file could not be read.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A JSON document could not be made.
    #[error("{path}: {message}")]
    Json { path: PathBuf, message: String },
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}
