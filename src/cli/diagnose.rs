//! The diagnosis subcommands: diagnose, and the concealed-case report. Glue only: the
//! work is in `errmap::diagnose`, `errmap::sim` and `errmap::report`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use errmap::session;

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
    use errmap::diagnose::{DiagnoseConfig, diagnose};
    use errmap::report::diagnosis::write_report;
    use errmap::sim::{MachineModel, apply_found_effects, simulate_rows};
    let rec_path = session_file(&a.recorded)?;
    let recorded = session::read_session(&rec_path)?;
    let (simulated, model) = match (&a.simulated, &a.model) {
        (Some(s), _) => (session::read_session(&session_file(s)?)?, None),
        (None, Some(m)) => {
            let model = MachineModel::read(m)?;
            (
                simulate_rows(&model, m, &recorded)?,
                Some((model, m.clone())),
            )
        }
        (None, None) => bail!("give --simulated SESSION or --model MODEL.toml"),
    };
    let grating = a
        .grating_period_um
        .or_else(|| {
            model
                .as_ref()
                .map(|(m, _)| f64::from(m.device.grating_period_nm) / 1000.0)
        })
        .or_else(|| grating_from_capture(&a.recorded));
    let config = DiagnoseConfig {
        grating_period_um: grating,
        model_dead_path_mm: model.as_ref().map(|(m, _)| m.laser.dead_path_mm.max(0.0)),
        ..DiagnoseConfig::default()
    };
    let d = diagnose(&recorded, &simulated, &config)
        .with_context(|| format!("{}: diagnosis failed", rec_path.display()))?;
    // Every report carries the session's environment.
    let environment = errmap::report::environment::environment_summary(&recorded);
    write_report(&d, &a.report, Some(&environment))?;
    if let Some((mut m, path)) = model {
        let notes = apply_found_effects(&mut m, &d.effects);
        let _ = &path;
        if let Some(map) = &mut m.error_map {
            map.table = relative_to(&map.table, &a.report);
        }
        let out = a.report.join("updated-model.toml");
        m.write(&out)?;
        eprintln!(
            "diagnose: updated model ({}) → {}",
            notes.join("; "),
            out.display()
        );
    }
    if a.json {
        println!("{}", serde_json::to_string(&d)?);
    } else {
        eprintln!(
            "diagnose: {} — RMS {:.4} µm before, {:.4} µm after ({:.4} µm cross-validated by run); report in {}",
            d.verdict,
            d.rms_before_um,
            d.rms_after_um,
            d.cv_rms_after_um,
            a.report.display()
        );
        for e in &d.effects {
            eprintln!(
                "  {}: {} — {}",
                e.id,
                serde_json::to_string(&e.params)?,
                e.where_
            );
        }
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
