//! Presentation for every stage: words, tables and figures on disk. Nothing else in the
//! library imports this module; it imports any stage it reports on, and [`crate::plot`].
//!
//! | module | writes |
//! |---|---|
//! | `compare` | the comparison report (`report.md`, CSVs, figures) of `compare --report` |
//! | `concealed` | the concealed-case report and index (`reports/diagnosis/`) |
//! | `findings` | a comparison's findings in plain words |
//! | `json` | the `compare --json` document |
//! | `iso230` | the ISO 230-2 / VDI/DGQ 3441 section and deviation chart |
//! | [`certificate`] | the calibration certificate PDF (`errmap certificate`), with its statement of conformity when tolerances are given |
//! | `acceptance` | the ISO 10360-2 reports, measured and predicted (`acceptance iso10360`, `volumetric iso10360`) |
//! | `probing` | the ISO 10360-5 probing test's report and its map of the residuals on the sphere (`acceptance iso10360-5 --report`) |
//! | `uncertainty` | the measurement-uncertainty budget table and the standards note |
//! | `environment` | a session's air and material temperatures in words and a table |
//! | `diagnosis` | the diagnosis report (`diagnose --out`, `reports/diagnosis/`) |
//! | `experiment` | the fuzzy-interpolation simulation's report (`fuzzy-sim`) |
//! | `volumetric` | the volumetric identification report (`volumetric identify --report`) |
//! | `history` | the calibration history report (`history report --report`) |
//! | `md` | nothing itself: the Markdown writer the reports are written with |
//! | `finite` | the guard of every writer here: no NaN or ±inf leaves in Markdown or JSON |
//!
//! Every file is written through [`write_text`] or [`write_json`]: checked by `finite`,
//! then written whole or not at all (`table::write_atomically`).

use std::path::{Path, PathBuf};

use crate::base::io_err;
use crate::base::{FileError, FileOp};
use crate::plot::PlotError;
use crate::table::TableError;

mod acceptance;
mod artefact;
pub mod certificate;
mod circular;
mod compare;
mod concealed;
mod diagnosis;
mod environment;
mod experiment;
mod findings;
mod finite;
mod history;
mod iso230;
mod json;
mod md;
mod probing;
pub mod rotary;
mod uncertainty;
mod volumetric;

pub use acceptance::{write_iso10360_report, write_virtual_report};
pub use artefact::{write_evaluation_report, write_report as write_artefact_report};
pub use circular::{
    CCW_COLOUR, CW_COLOUR, chart as circular_chart, write_report as write_circular_report,
};
pub use compare::write_report as write_compare_report;
pub use concealed::write_concealed;
pub use diagnosis::{
    IsoEffect, append_iso_effect, iso_effect, write_report as write_diagnosis_report,
};
pub use environment::{environment_summary, environment_text};
pub use experiment::markdown as experiment_markdown;
pub use findings::group_by_reason;
pub use finite::check_json;
pub use history::ReportWriter as HistoryReportWriter;
pub use iso230::{
    decimals as iso230_decimals, markdown as iso230_markdown, plot as iso230_plot,
    write_session_report,
};
pub use json::{
    CompareJson, CompareJsonRow, DiagnoseJson, GB_T_17421_2, GridJson, MethodJson, RefusedJson,
    ReplayJson, TableJson, TableLineJson, TableUncertaintyJson, table_json,
};
pub use probing::write_probing_report;
pub use volumetric::write_report as write_volumetric_report;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Creating the directory or writing a file failed (the shared [`FileError`] shape).
    #[error(transparent)]
    File(#[from] FileError),
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
    /// A NaN or ±inf reached a writer (`finite`): a bug in errmap, not in the input.
    #[error(
        "{path}: {value} at {at}: a non-finite number reached the output, which is a bug in \
         errmap (the readers refuse such values); nothing was written, please report it"
    )]
    NonFinite {
        path: PathBuf,
        at: String,
        value: f64,
    },
}

/// Writes a Markdown (or other text) file: refused when it holds a formatted NaN or inf
/// ([`finite::check_markdown`]), else written whole or not at all.
pub fn write_text(path: &Path, text: &str) -> Result<(), ReportError> {
    finite::check_markdown(path, text)?;
    write_bytes(path, text.as_bytes())
}

/// The pretty JSON text of `value`, refused when a number in it is NaN or ±inf
/// ([`finite::check_json`]; serde_json would write `null`). `path` names the output in
/// the messages (`stdout` for a printed document).
pub fn json_text<T: serde::Serialize + ?Sized>(
    path: &Path,
    value: &T,
    pretty: bool,
) -> Result<String, ReportError> {
    finite::check_json(path, value)?;
    let text = if pretty {
        serde_json::to_string_pretty(value)
    } else {
        serde_json::to_string(value)
    };
    text.map_err(|e| ReportError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Writes `value` as pretty JSON (and a newline), checked like [`json_text`], whole or
/// not at all.
pub fn write_json<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), ReportError> {
    let text = json_text(path, value, true)? + "\n";
    write_bytes(path, text.as_bytes())
}

/// Writes bytes whole or not at all (`table::write_atomically`).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    use std::io::Write;
    crate::table::write_atomically::<ReportError>(path, |f| {
        f.write_all(bytes)
            .map_err(|e| io_err(path, FileOp::Write)(e).into())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_document_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().expect("tempdir");
        let md = dir.path().join("report.md");
        let json = dir.path().join("model.json");
        std::fs::write(&md, "old").expect("write");
        let e = write_text(&md, &format!("| rms | {:.3} |\n", f64::NAN)).expect_err("refused");
        let msg = e.to_string();
        assert!(
            msg.contains("report.md") && msg.contains("line 1") && msg.contains("bug"),
            "{msg}"
        );
        let e = write_json(&json, &[1.0, f64::INFINITY]).expect_err("refused");
        assert!(e.to_string().contains("model.json"), "{e}");
        assert_eq!(std::fs::read_to_string(&md).expect("read"), "old");
        let mut left: Vec<_> = std::fs::read_dir(dir.path())
            .expect("dir")
            .map(|e| e.expect("entry").file_name())
            .collect();
        left.sort();
        assert_eq!(left, ["report.md"], "nothing else written");
        write_text(&md, "| rms | 0.125 |\n").expect("finite");
        write_json(&json, &[0.5, -1.0]).expect("finite");
        assert_eq!(
            std::fs::read_to_string(&md).expect("read"),
            "| rms | 0.125 |\n"
        );
        let back: Vec<f64> =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("read")).expect("json");
        assert_eq!(back, [0.5, -1.0]);
    }
}
