//! The concealed-case report (`errmap report-concealed`, `reports/diagnosis/`): every case
//! diagnosed from its recorded and simulated sessions alone, and an index comparing what
//! was found with the hidden truth.

use super::md::Md;
use std::path::Path;

use super::ReportError;
use super::diagnosis::write_report;
use crate::base::EffectId;
use crate::base::FileOp;
use crate::base::io_err;
use crate::diagnose::{DiagnoseConfig, Verdict, diagnose};
use crate::session::read_session;
use crate::sim::ConcealedTruth;

/// What one case came to, for the caller's progress lines.
#[derive(Debug, Clone)]
pub struct CaseOutcome {
    pub name: String,
    pub verdict: Verdict,
    pub effects: Vec<EffectId>,
}

/// The hidden effects' parameters as the index shows them: ids sorted by name, as in
/// `truth.json`, each with its parameters by name (numbers as the JSON writes them).
fn hidden_params(truth: &ConcealedTruth) -> Vec<String> {
    let mut effects: Vec<_> = truth.effects.iter().collect();
    effects.sort_by_key(|e| e.id().as_str());
    effects
        .iter()
        .map(|e| {
            let ps: Vec<String> = e
                .params_by_name()
                .iter()
                .map(|(k, v)| match v.as_f64() {
                    Some(x) => format!("{k} {}", json_number(x)),
                    None => format!("{k} {v}"),
                })
                .collect();
            format!("`{}`: {}", e.id(), ps.join(", "))
        })
        .collect()
}

/// A number as the JSON of `truth.json` writes it (`3.0`, `0.004`), so that the index
/// reads like the truth files it quotes.
fn json_number(v: f64) -> String {
    serde_json::to_string(&v).unwrap_or_else(|_| v.to_string())
}

/// Diagnoses every case under `cases` (each with `recorded.parquet`, `simulated.parquet`
/// and `truth.json`) into `out/<case>/`, and writes `out/README.md`, the index.
pub fn write_concealed(cases: &Path, out: &Path) -> Result<Vec<CaseOutcome>, ReportError> {
    let mut names: Vec<String> = std::fs::read_dir(cases)
        .map_err(io_err(cases, FileOp::Read))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("recorded.parquet").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut index = Md::new();
    index
        .heading(1, "Diagnosis of the concealed-effect cases")
        .para(
            "Regenerate with `errmap report-concealed` \
             (cases from `errmap gen-concealed`). The diagnosis saw only `recorded.parquet` and \
             `simulated.parquet`; the hidden truth comes from `truth.json`.",
        )
        .table([
            "case",
            "hidden",
            "found",
            "parameters found (± 1σ)",
            "hidden parameters",
            "RMS before → after µm",
            "noise σ µm",
        ]);
    let mut outcomes = Vec::new();
    for name in &names {
        let dir = cases.join(name);
        let recorded = read_session(&dir.join("recorded.parquet"))?;
        let simulated = read_session(&dir.join("simulated.parquet"))?;
        let truth = ConcealedTruth::read(&dir.join("truth.json"))?;
        let d = diagnose(
            &recorded,
            &simulated,
            &DiagnoseConfig {
                grating_period_um: Some(20.0),
                ..DiagnoseConfig::default()
            },
        )
        .map_err(|source| ReportError::Diagnose {
            path: dir.clone(),
            source,
        })?;
        let report = out.join(name);
        write_report(&d, &report, None)?;
        let json_path = report.join("diagnosis.json");
        super::write_json(&json_path, &d)?;
        let found: Vec<String> = d.effects.iter().map(|e| format!("`{}`", e.id())).collect();
        let params: Vec<String> = d
            .effects
            .iter()
            .map(|e| {
                e.effect
                    .params_by_name()
                    .iter()
                    .map(|(k, v)| match (v.as_f64(), e.uncertainty.get(k)) {
                        (Some(x), Some(u)) => format!("{k} {x:.4} ± {u:.4}"),
                        _ => format!("{k} {v}"),
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect();
        let hidden = hidden_params(&truth);
        index.row([
            format!("[{name}]({name}/report.md)"),
            if hidden.is_empty() {
                "nothing".to_string()
            } else {
                let ids: Vec<&str> = truth.effects.iter().map(|e| e.id().as_str()).collect();
                serde_json::to_string(&ids).unwrap_or_default()
            },
            if found.is_empty() {
                format!("none ({})", d.verdict)
            } else {
                found.join(", ")
            },
            params.join("; "),
            hidden.join("; "),
            format!("{:.4} → {:.4}", d.rms_before_um, d.rms_after_um),
            json_number(truth.sizes.noise_um),
        ]);
        outcomes.push(CaseOutcome {
            name: name.clone(),
            verdict: d.verdict,
            effects: d.effects.iter().map(|e| e.id()).collect(),
        });
    }
    let index_path = out.join("README.md");
    super::write_text(&index_path, index.as_str())?;
    Ok(outcomes)
}
