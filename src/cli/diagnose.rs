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
    std::fs::create_dir_all(&a.report)
        .with_context(|| format!("cannot create {}", a.report.display()))?;
    write_report(&d, &a.report)?;
    // Every report carries the session's environment.
    let md_path = a.report.join("report.md");
    if let Ok(mut md) = std::fs::read_to_string(&md_path) {
        md.push('\n');
        md.push_str(&session::environment_summary(&recorded));
        std::fs::write(&md_path, md)
            .with_context(|| format!("cannot write {}", md_path.display()))?;
    }
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

/// Diagnoses every case under `cases` (each with recorded.parquet, simulated.parquet and
/// truth.json) into `out/<case>/`, with an index comparing found and hidden effects.
pub fn report_concealed(cases: &Path, out: &Path) -> Result<()> {
    use errmap::diagnose::{DiagnoseConfig, diagnose};
    use errmap::report::diagnosis::write_report;
    let mut names: Vec<String> = std::fs::read_dir(cases)
        .with_context(|| format!("cannot read {}", cases.display()))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("recorded.parquet").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut index = String::from(
        "# Diagnosis of the concealed-effect cases\n\nRegenerate with `errmap report-concealed` \
         (cases from `errmap gen-concealed`). The diagnosis saw only `recorded.parquet` and \
         `simulated.parquet`; the hidden truth comes from `truth.json`.\n\n\
         | case | hidden | found | parameters found (± 1σ) | hidden parameters | RMS before → after µm | noise σ µm |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for name in &names {
        let dir = cases.join(name);
        let recorded = session::read_session(&dir.join("recorded.parquet"))?;
        let simulated = session::read_session(&dir.join("simulated.parquet"))?;
        let truth: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("truth.json"))
                .with_context(|| format!("{}", dir.display()))?,
        )?;
        let d = diagnose(
            &recorded,
            &simulated,
            &DiagnoseConfig {
                grating_period_um: Some(20.0),
                ..DiagnoseConfig::default()
            },
        )?;
        let report = out.join(name);
        std::fs::create_dir_all(&report)?;
        write_report(&d, &report)?;
        std::fs::write(
            report.join("diagnosis.json"),
            serde_json::to_string_pretty(&d)? + "\n",
        )?;
        let found: Vec<String> = d.effects.iter().map(|e| format!("`{}`", e.id)).collect();
        let params: Vec<String> = d
            .effects
            .iter()
            .map(|e| {
                e.params
                    .iter()
                    .map(|(k, v)| match (v.as_f64(), e.uncertainty.get(k)) {
                        (Some(x), Some(u)) => format!("{k} {x:.4} ± {u:.4}"),
                        _ => format!("{k} {v}"),
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect();
        let hidden: Vec<String> = truth["params"]
            .as_object()
            .map(|o| {
                o.iter()
                    .map(|(id, p)| {
                        let ps: Vec<String> = p
                            .as_object()
                            .map(|m| m.iter().map(|(k, v)| format!("{k} {v}")).collect())
                            .unwrap_or_default();
                        format!("`{id}`: {}", ps.join(", "))
                    })
                    .collect()
            })
            .unwrap_or_default();
        index.push_str(&format!(
            "| [{name}]({name}/report.md) | {} | {} | {} | {} | {:.4} → {:.4} | {} |\n",
            if hidden.is_empty() {
                "nothing".to_string()
            } else {
                truth["effects"].to_string()
            },
            if found.is_empty() {
                format!("none ({})", d.verdict)
            } else {
                found.join(", ")
            },
            params.join("; "),
            hidden.join("; "),
            d.rms_before_um,
            d.rms_after_um,
            truth["sizes"]["noise_um"]
        ));
        eprintln!(
            "report-concealed: {name}: {} {:?}",
            d.verdict,
            d.effects.iter().map(|e| &e.id).collect::<Vec<_>>()
        );
    }
    std::fs::write(out.join("README.md"), index)?;
    Ok(())
}
