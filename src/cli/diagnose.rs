//! The diagnosis subcommands: diagnose, and the concealed-case report. Glue only: the
//! work is in `errmap::diagnose`, `errmap::sim` and `errmap::report`.

use std::path::{Path, PathBuf};

use anyhow::Result;
use errmap::diagnose::Diagnosis;
use errmap::report::{IsoEffect, append_iso_effect, iso_effect, write_diagnosis_report};
pub(crate) use errmap::sim::Against;
use errmap::sim::DiagnoseJob;

use super::args::DiagnoseArgs;

pub(crate) fn diagnose_cmd(a: DiagnoseArgs) -> Result<()> {
    if super::rotary::is_rotary_session(&a.recorded)? {
        return super::rotary::diagnose(&a);
    }
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
        super::guard::print_json(&errmap::report::DiagnoseJson {
            diagnosis: &d,
            iso230: iso.as_ref(),
        })?;
    } else {
        print_summary(&d, &a.report)?;
    }
    Ok(())
}

/// Diagnoses a recorded session (table or capture directory) against a simulation and
/// writes the report into `report` (with `updated-model.toml` when diagnosed against a
/// model).
pub(crate) fn run_diagnosis(
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
/// The work is [`DiagnoseJob::run`]; this writes its report and says what it did.
pub(crate) fn run_diagnosis_with(
    recorded: &Path,
    against: &Against,
    report: &Path,
    grating_period_um: Option<f64>,
    max_dead_path_mm: Option<f64>,
    max_rows: usize,
) -> Result<(Diagnosis, Option<IsoEffect>)> {
    let mut inputs: Vec<(&str, &Path)> = vec![("--recorded", recorded)];
    match against {
        Against::Simulated(p) => inputs.push(("--simulated", p)),
        Against::Model(p) => inputs.push(("--model", p)),
        Against::Nothing => {}
    }
    super::guard::refuse_aliases(&[("--report", report)], &inputs)?;
    let job = DiagnoseJob {
        recorded: recorded.to_path_buf(),
        against: against.clone(),
        grating_period_um,
        max_dead_path_mm,
        max_rows,
    };
    let out = job.run()?;
    let mut d = out.diagnosis;
    if let Some(t) = &out.thinning {
        let note = t.note("--max-rows");
        eprintln!("diagnose: {note}");
        d.design_notes.push(note);
    }
    let iso = matches!(against, Against::Nothing).then(|| iso_effect(&out.recorded_rows, &d));
    // Every report carries the session's environment.
    let environment = errmap::report::environment_summary(&out.recorded_rows);
    // A new report directory appears whole or not at all (guard::into_new_dir); the
    // temporary one is a sibling, so the model's relative table path is the same.
    let notes = super::guard::into_new_dir(report, |dir| {
        write_diagnosis_report(&d, dir, Some(&environment))?;
        if let Some(iso) = &iso {
            append_iso_effect(dir, iso)?;
        }
        let Some((mut m, notes)) = out.updated else {
            return Ok(None);
        };
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
pub(crate) fn print_summary(d: &Diagnosis, report: &Path) -> Result<()> {
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
            serde_json::to_string(&errmap::base::ParamsMap(&e.effect))?,
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
pub(crate) fn report_concealed(cases: &Path, out: &Path) -> Result<()> {
    for c in errmap::report::write_concealed(cases, out)? {
        eprintln!(
            "report-concealed: {}: {} {:?}",
            c.name, c.verdict, c.effects
        );
    }
    Ok(())
}
