//! The diagnosis subcommands: diagnose, and the concealed-case report. Glue only: the
//! work is in `errmap::diagnose`, `errmap::sim` and `errmap::report`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose, diagnose_recorded};
use errmap::report::diagnosis::{IsoEffect, append_iso_effect, iso_effect, write_report};
use errmap::session;
use errmap::sim::{MachineModel, apply_found_effects, simulate_rows};

use super::acquisition::session_file;
use super::args::DiagnoseArgs;

/// The grating period from a capture directory's session.json, if any, µm.
fn grating_from_capture(session: &Path) -> Option<f64> {
    let dir = if session.is_dir() {
        session
    } else {
        session.parent()?
    };
    let text = std::fs::read_to_string(dir.join("session.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["hello"]["grating_period_nm"]
        .as_f64()
        .map(|nm| nm / 1000.0)
}

pub fn diagnose_cmd(a: DiagnoseArgs) -> Result<()> {
    let against = match (&a.simulated, &a.model) {
        (Some(s), _) => Against::Simulated(s.clone()),
        (None, Some(m)) => Against::Model(m.clone()),
        (None, None) => Against::Nothing,
    };
    let (d, iso) = run_diagnosis_with(
        &a.recorded,
        &against,
        &a.report,
        a.grating_period_um,
        a.max_dead_path_mm,
        usize::try_from(a.max_rows).unwrap_or(usize::MAX),
    )?;
    if a.json {
        // Checked as typed numbers: in the `Value` below a NaN would already be `null`.
        errmap::report::finite::check_json(std::path::Path::new("stdout"), &d)?;
        let mut v = serde_json::to_value(&d)?;
        if let (Some(iso), Some(obj)) = (iso, v.as_object_mut()) {
            obj.insert("iso230".into(), serde_json::to_value(iso)?);
        }
        super::guard::print_json(&v)?;
    } else {
        print_summary(&d, &a.report)?;
    }
    Ok(())
}

/// What a recording is diagnosed against.
#[derive(Debug, Clone)]
pub enum Against {
    /// A simulated session of the same plan.
    Simulated(PathBuf),
    /// A machine model that simulates the recording's own moves.
    Model(PathBuf),
    /// Nothing: the static part is taken from the recording itself.
    Nothing,
}

/// Diagnoses a recorded session (table or capture directory) against a simulation and
/// writes the report into `report` (with `updated-model.toml` when diagnosed against a
/// model).
pub fn run_diagnosis(
    recorded: &Path,
    against: &Against,
    report: &Path,
    grating_period_um: Option<f64>,
) -> Result<Diagnosis> {
    Ok(run_diagnosis_with(
        recorded,
        against,
        report,
        grating_period_um,
        None,
        errmap::diagnose::MAX_ROWS,
    )?
    .0)
}

/// [`run_diagnosis`] with the set-up's dead-path bound and the most rows to hold (longer
/// recordings are thinned to it uniformly in time); with nothing to diagnose against,
/// also the ISO 230-2 figures with the found effects removed (written into the report).
pub fn run_diagnosis_with(
    recorded: &Path,
    against: &Against,
    report: &Path,
    grating_period_um: Option<f64>,
    max_dead_path_mm: Option<f64>,
    max_rows: usize,
) -> Result<(Diagnosis, Option<IsoEffect>)> {
    let rec_path = session_file(recorded)?;
    // Bounded memory whatever the session's length: at most MAX_ROWS rows, thinned
    // uniformly in time, and the same samples of the simulation.
    let thinned = session::read_session_thinned(&rec_path, max_rows)?;
    let stride = thinned.stride;
    let recorded_rows = thinned.rows;
    let (simulated, model) = match against {
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
    let grating = grating_period_um
        .or_else(|| {
            model
                .as_ref()
                .map(|m| f64::from(m.device.grating_period_nm) / 1000.0)
        })
        .or_else(|| grating_from_capture(recorded));
    let config = DiagnoseConfig {
        grating_period_um: grating,
        model_dead_path_mm: model.as_ref().map(|m| m.laser.dead_path_mm.max(0.0)),
        max_dead_path_mm,
        ..DiagnoseConfig::default()
    };
    let mut d = match &simulated {
        Some(sim) => diagnose(&recorded_rows, sim, &config),
        None => diagnose_recorded(&recorded_rows, &config),
    }
    .with_context(|| format!("{}: diagnosis failed", rec_path.display()))?;
    if stride > 1 {
        let note = format!(
            "{}: {} rows, more than --max-rows {max_rows}: diagnosed on the device samples whose index is a multiple of {stride} ({} rows, uniformly in time)",
            rec_path.display(),
            thinned.total,
            recorded_rows.len()
        );
        eprintln!("diagnose: {note}");
        d.design_notes.push(note);
    }
    let iso = simulated.is_none().then(|| iso_effect(&recorded_rows, &d));
    // The inputs are finite and in range: a non-finite figure is a bug, reported, and
    // neither the report nor the JSON (where it would read `null`) is written.
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
    if let Some((name, v)) = figures
        .into_iter()
        .chain(effects)
        .find(|(_, v)| !v.is_finite())
    {
        bail!(
            "{}: the diagnosis computed {name} = {v}; nothing written (a bug: please report it)",
            rec_path.display()
        );
    }
    // Every report carries the session's environment.
    let environment = errmap::report::environment::environment_summary(&recorded_rows);
    // A new report directory appears whole or not at all (guard::into_new_dir); the
    // temporary one is a sibling, so the model's relative table path is the same.
    let notes = super::guard::into_new_dir(report, |dir| {
        write_report(&d, dir, Some(&environment))?;
        if let Some(iso) = &iso {
            append_iso_effect(dir, iso)?;
        }
        let Some(mut m) = model else {
            return Ok(None);
        };
        let notes = apply_found_effects(&mut m, &d.effects);
        if let Some(map) = &mut m.error_map {
            map.table = relative_to(&map.table, report);
        }
        m.write(&dir.join("updated-model.toml"))?;
        Ok(Some(notes))
    })?;
    if let Some(notes) = notes {
        let what = if notes.is_empty() {
            "nothing found to add: the model as given".to_string()
        } else {
            notes.join("; ")
        };
        eprintln!(
            "diagnose: updated model ({what}) → {}",
            report.join("updated-model.toml").display()
        );
    }
    Ok((d, iso))
}

/// The diagnosis in a few lines on stderr.
pub fn print_summary(d: &Diagnosis, report: &Path) -> Result<()> {
    eprintln!(
        "diagnose: {} — RMS {:.4} µm before, {:.4} µm after ({:.4} µm cross-validated by run); report in {}",
        d.verdict,
        d.rms_before_um,
        d.rms_after_um,
        d.cv_rms_after_um,
        report.display()
    );
    for e in &d.effects {
        eprintln!(
            "  {}: {} — {}",
            e.id(),
            serde_json::to_string(&errmap::base::effect::ParamsMap(&e.effect))?,
            e.where_
        );
    }
    Ok(())
}

/// `path` (relative to the working directory, or absolute) as seen from directory `base`.
fn relative_to(path: &Path, base: &Path) -> PathBuf {
    let (Ok(p), Ok(b)) = (std::path::absolute(path), std::path::absolute(base)) else {
        return path.to_path_buf();
    };
    fn norm(x: &Path) -> Vec<std::path::Component<'_>> {
        let mut out = Vec::new();
        for c in x.components() {
            match c {
                std::path::Component::ParentDir => {
                    out.pop();
                }
                std::path::Component::CurDir => {}
                other => out.push(other),
            }
        }
        out
    }
    let (pc, bc) = (norm(&p), norm(&b));
    let common = pc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    let mut rel = PathBuf::new();
    for _ in common..bc.len() {
        rel.push("..");
    }
    for c in &pc[common..] {
        rel.push(c.as_os_str());
    }
    rel
}

/// Diagnoses every case under `cases` into `out/<case>/`, with an index comparing found
/// and hidden effects (`errmap report-concealed`).
pub fn report_concealed(cases: &Path, out: &Path) -> Result<()> {
    for c in errmap::report::concealed::write_concealed(cases, out)? {
        eprintln!(
            "report-concealed: {}: {} {:?}",
            c.name, c.verdict, c.effects
        );
    }
    Ok(())
}
