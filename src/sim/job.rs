//! The diagnosis as one job: read (and thin) the recording, simulate it from a model or
//! read its simulated twin, choose the grating period, diagnose, and write the found
//! effects back into the model. `errmap diagnose` and the demo run this; they only add
//! the report on disk and the words on the terminal.
//!
//! Every decision is here, in one place a test can reach:
//! - the session file of a capture directory (`session.parquet`, then `session.csv`);
//! - bounded memory: at most `max_rows` rows, thinned uniformly in time, and the same
//!   samples of the simulation, with a design note saying so;
//! - the grating period: the flag, else the model's device, else the capture's
//!   `session.json`;
//! - a non-finite figure of the diagnosis is a bug, reported, never written.

use std::path::{Path, PathBuf};

use errmap_drivers::SessionRow;
use serde::Deserialize;

use crate::diagnose::{DiagnoseConfig, DiagnoseError, Diagnosis, diagnose, diagnose_recorded};
use crate::session;
use crate::table::TableError;

use super::{MachineModel, SimError, apply_found_effects, simulate_rows};

/// What a recording is diagnosed against.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Against {
    /// A simulated session of the same plan.
    Simulated(PathBuf),
    /// A machine model that simulates the recording's own moves.
    Model(PathBuf),
    /// Nothing: the static part is taken from the recording itself.
    Nothing,
}

/// One diagnosis to run.
#[derive(Debug, Clone)]
pub struct DiagnoseJob {
    /// The recorded session: a table, or a capture directory holding one.
    pub recorded: PathBuf,
    /// What it is diagnosed against.
    pub against: Against,
    /// The scale's grating period, µm (else from the model or the capture).
    pub grating_period_um: Option<f64>,
    /// The set-up's bound on the laser dead path, mm.
    pub max_dead_path_mm: Option<f64>,
    /// The most rows held; longer recordings are thinned uniformly in time.
    pub max_rows: usize,
}

/// What the job found.
#[derive(Debug)]
pub struct DiagnoseOutcome {
    /// The session table that was read.
    pub recorded_table: PathBuf,
    /// The rows diagnosed (thinned when the recording was longer than `max_rows`).
    pub recorded_rows: Vec<SessionRow>,
    /// The diagnosis (with a design note when the rows were thinned).
    pub diagnosis: Diagnosis,
    /// How the rows were thinned, when they were: the caller adds its
    /// [`Thinning::note`] to the diagnosis' design notes.
    pub thinning: Option<Thinning>,
    /// With a model: the model with the found effects written in, and a note per effect.
    pub updated: Option<(MachineModel, Vec<String>)>,
}

/// Why the job could not run.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{0}: no session.csv or session.parquet in this directory")]
    NoSession(PathBuf),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("{path}: diagnosis failed")]
    Diagnose {
        path: PathBuf,
        #[source]
        source: DiagnoseError,
    },
    #[error(
        "{path}: the diagnosis computed {name} = {value}; nothing written (a bug: please report it)"
    )]
    NonFinite {
        path: PathBuf,
        name: &'static str,
        value: f64,
    },
}

/// The session table of `p`: `p` itself, or the table inside a capture directory.
pub fn session_file(p: &Path) -> Result<PathBuf, JobError> {
    if p.is_dir() {
        return ["session.parquet", "session.csv"]
            .iter()
            .map(|name| p.join(name))
            .find(|f| f.is_file())
            .ok_or_else(|| JobError::NoSession(p.to_path_buf()));
    }
    Ok(p.to_path_buf())
}

/// The grating period in a capture directory's `session.json` (the board's hello), µm.
pub(crate) fn grating_from_capture(session: &Path) -> Option<f64> {
    #[derive(Deserialize)]
    struct Hello {
        grating_period_nm: f64,
    }
    #[derive(Deserialize)]
    struct SessionJson {
        hello: Hello,
    }
    let dir = if session.is_dir() {
        session
    } else {
        session.parent()?
    };
    let text = std::fs::read_to_string(dir.join("session.json")).ok()?;
    let s: SessionJson = serde_json::from_str(&text).ok()?;
    Some(s.hello.grating_period_nm / 1000.0)
}

/// A recording longer than the row budget, thinned uniformly in time.
#[derive(Debug, Clone, PartialEq)]
pub struct Thinning {
    /// The session table read.
    pub path: PathBuf,
    /// Its rows.
    pub total_rows: u64,
    /// The budget ([`DiagnoseJob::max_rows`]).
    pub max_rows: usize,
    /// Every `stride`-th device sample was kept.
    pub stride: i64,
    /// The rows diagnosed.
    pub kept_rows: usize,
}

impl Thinning {
    /// The note for the diagnosis, the budget called `budget` (the CLI passes its flag).
    pub fn note(&self, budget: &str) -> String {
        format!(
            "{}: {} rows, more than {budget} {}: diagnosed on the device samples whose index is a multiple of {} ({} rows, uniformly in time)",
            self.path.display(),
            self.total_rows,
            self.max_rows,
            self.stride,
            self.kept_rows
        )
    }
}

impl DiagnoseJob {
    /// Runs the job: nothing is written.
    pub fn run(&self) -> Result<DiagnoseOutcome, JobError> {
        let rec_path = session_file(&self.recorded)?;
        let thinned = session::read_session_thinned(&rec_path, self.max_rows)?;
        let stride = thinned.stride;
        let recorded_rows = thinned.rows;
        let (simulated, model) = match &self.against {
            Against::Simulated(s) => (
                Some(session::read_session_every(&session_file(s)?, stride)?.0),
                None,
            ),
            Against::Model(m) => {
                let model = MachineModel::read(m)?;
                (Some(simulate_rows(&model, m, &recorded_rows)?), Some(model))
            }
            Against::Nothing => (None, None),
        };
        let grating = self
            .grating_period_um
            .or_else(|| {
                model
                    .as_ref()
                    .map(|m| f64::from(m.device.grating_period_nm) / 1000.0)
            })
            .or_else(|| grating_from_capture(&self.recorded));
        let config = DiagnoseConfig {
            grating_period_um: grating,
            model_dead_path_mm: model.as_ref().map(|m| m.laser.dead_path_mm.max(0.0)),
            max_dead_path_mm: self.max_dead_path_mm,
            ..DiagnoseConfig::default()
        };
        let d = match &simulated {
            Some(sim) => diagnose(&recorded_rows, sim, &config),
            None => diagnose_recorded(&recorded_rows, &config),
        }
        .map_err(|source| JobError::Diagnose {
            path: rec_path.clone(),
            source,
        })?;
        let thinning = (stride > 1).then(|| Thinning {
            path: rec_path.clone(),
            total_rows: thinned.total,
            max_rows: self.max_rows,
            stride,
            kept_rows: recorded_rows.len(),
        });
        if let Some((name, value)) = first_non_finite(&d) {
            return Err(JobError::NonFinite {
                path: rec_path,
                name,
                value,
            });
        }
        let updated = model.map(|mut m| {
            let notes = apply_found_effects(&mut m, &d.effects);
            (m, notes)
        });
        Ok(DiagnoseOutcome {
            recorded_table: rec_path,
            recorded_rows,
            diagnosis: d,
            thinning,
            updated,
        })
    }
}

/// The first figure of a diagnosis that is not finite (the inputs are checked at the
/// door, so this is a bug of the fit).
fn first_non_finite(d: &Diagnosis) -> Option<(&'static str, f64)> {
    let figures = [
        ("rms_before_um", d.rms_before_um),
        ("rms_after_um", d.rms_after_um),
        ("cv_rms_after_um", d.cv_rms_after_um),
        ("rms_before_centred_um", d.rms_before_centred_um),
        ("noise_sigma_um", d.noise_sigma_um),
    ];
    let effects = d.effects.iter().flat_map(|e| {
        std::iter::once(("explains_um", e.explains_um))
            .chain(e.uncertainty.values().map(|&u| ("uncertainty", u)))
    });
    figures
        .into_iter()
        .chain(effects)
        .find(|(_, v)| !v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capture_directory_without_a_table_is_named() {
        let dir = std::env::temp_dir().join(format!("errmap-job-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let e = session_file(&dir).expect_err("no table").to_string();
        assert!(e.contains("no session.csv or session.parquet"), "{e}");
        std::fs::write(dir.join("session.csv"), "x").expect("write");
        assert_eq!(session_file(&dir).expect("found"), dir.join("session.csv"));
        std::fs::write(dir.join("session.parquet"), "x").expect("write");
        assert_eq!(
            session_file(&dir).expect("found"),
            dir.join("session.parquet"),
            "Parquet first"
        );
        std::fs::write(
            dir.join("session.json"),
            r#"{"hello": {"grating_period_nm": 20000, "axis": "x"}, "raw": "r"}"#,
        )
        .expect("write");
        assert_eq!(grating_from_capture(&dir), Some(20.0));
        assert_eq!(grating_from_capture(&dir.join("session.csv")), Some(20.0));
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
