//! Words about a rotary axis: the ISO 230-2 report in ″ and °, and the `table --json`
//! document (`docs/rotary.md` §2).

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::base::{FileOp, RotaryAxis, io_err};
use crate::session::rotary::{Closure, RotaryIso};

/// `summary` of `table --json` for a rotary session.
#[derive(Debug, Serialize)]
pub struct RotarySummaryJson {
    pub kind: &'static str,
    pub axis: RotaryAxis,
    pub source: String,
    pub targets: usize,
    pub dwell_rows: usize,
}

/// The one line of a rotary `table --json`.
#[derive(Debug, Serialize)]
pub struct RotaryLineJson<'a> {
    pub axis: RotaryAxis,
    pub iso230: &'a RotaryIso,
    pub closure: Option<&'a Closure>,
}

/// `errmap table --json` of a rotary session.
#[derive(Debug, Serialize)]
pub struct RotaryTableJson<'a> {
    pub summary: RotarySummaryJson,
    pub nodes: usize,
    pub lines: Vec<RotaryLineJson<'a>>,
    pub warnings: &'a [String],
}

/// The ISO 230-2 figures of a rotary axis as markdown: ″ and °.
pub fn rotary_iso_markdown(
    source: &str,
    axis: RotaryAxis,
    iso: &RotaryIso,
    closure: Option<&Closure>,
    warnings: &[String],
) -> String {
    let mut s = String::new();
    let deg = |a: f64| a / 3600.0;
    let _ = writeln!(s, "# ISO 230-2 positioning test of rotary axis {axis}\n");
    let _ = writeln!(
        s,
        "Source: `{source}`. Deviations x = −e (reference − indicated), in arcseconds (″) with \
         degrees (°) beside; 0° and 360° are evaluated as two targets.\n"
    );
    let _ = writeln!(s, "| figure | ″ | ° |\n|---|---:|---:|");
    let rows = [
        ("A (bidirectional accuracy)", iso.a_arcsec),
        ("A↑", iso.a_up_arcsec),
        ("A↓", iso.a_down_arcsec),
        ("E (systematic deviation)", iso.e_arcsec),
        ("E↑", iso.e_up_arcsec),
        ("E↓", iso.e_down_arcsec),
        ("M (mean bidirectional deviation)", iso.m_arcsec),
        ("R (bidirectional repeatability)", iso.r_arcsec),
        ("R↑", iso.r_up_arcsec),
        ("R↓", iso.r_down_arcsec),
        ("B (reversal)", iso.b_arcsec),
        ("B̄ (mean reversal)", iso.mean_reversal_arcsec),
    ];
    for (name, v) in rows {
        let _ = writeln!(s, "| {name} | {v:.2} | {:.6} |", deg(v));
    }
    let _ = writeln!(
        s,
        "\n| target | position ° | n↑ | n↓ | x̄↑ ″ | x̄↓ ″ | x̄ ″ | B ″ | s↑ ″ | s↓ ″ | R ″ |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for t in &iso.targets {
        let _ = writeln!(
            s,
            "| {} | {:.4} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            t.target,
            t.position_deg,
            t.n_up,
            t.n_down,
            t.mean_up_arcsec,
            t.mean_down_arcsec,
            t.mean_bidir_arcsec,
            t.reversal_arcsec,
            t.s_up_arcsec,
            t.s_down_arcsec,
            t.repeat_bidir_arcsec
        );
    }
    match closure {
        Some(c) => {
            let _ = writeln!(
                s,
                "\n## Closure (0° = 360°)\n\n| direction | x̄(360) − x̄(0) ″ | limit 2·max(s) ″ |\n\
                 |---|---:|---:|\n| ↑ | {:.2} | {:.2} |\n| ↓ | {:.2} | {:.2} |\n\nConsistent: {}.",
                c.diff_up_arcsec,
                c.limit_up_arcsec,
                c.diff_down_arcsec,
                c.limit_down_arcsec,
                if c.consistent { "yes" } else { "no" }
            );
        }
        None => {
            let _ = writeln!(s, "\nNo closure pair (the test has not both 0° and 360°).");
        }
    }
    for w in warnings {
        let _ = writeln!(s, "\n**Warning.** {w}");
    }
    s
}

/// Writes `report.md` of a rotary session into `dir` (created).
pub fn write_rotary_report(dir: &Path, markdown: &str) -> Result<(), crate::base::FileError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let p = dir.join("report.md");
    std::fs::write(&p, markdown).map_err(io_err(&p, FileOp::Write))
}

/// One effect of `diagnose --json` on a rotary session.
#[derive(Debug, Serialize)]
pub struct RotaryEffectJson {
    pub id: crate::diagnose::rotary::RotaryId,
    pub params: std::collections::BTreeMap<&'static str, f64>,
    pub uncertainty: std::collections::BTreeMap<&'static str, f64>,
    #[serde(rename = "where")]
    pub where_: String,
    pub explains_arcsec: f64,
    pub delta_chi2: f64,
}

/// `diagnose --recorded ROTARY --json` (`docs/rotary.md` §3).
#[derive(Debug, Serialize)]
pub struct RotaryDiagnosisJson {
    pub axis: RotaryAxis,
    pub verdict: &'static str,
    pub rms_before_arcsec: f64,
    pub rms_after_arcsec: f64,
    pub cv_rms_after_arcsec: Option<f64>,
    pub effects: Vec<RotaryEffectJson>,
    pub candidates: usize,
    pub threshold_chi2: f64,
    pub family_false_alarm_rate: f64,
    pub dwells: usize,
}

impl RotaryDiagnosisJson {
    pub fn new(axis: RotaryAxis, d: &crate::diagnose::rotary::RotaryDiagnosis) -> Self {
        RotaryDiagnosisJson {
            axis,
            verdict: d.verdict.as_circular_str(),
            rms_before_arcsec: d.rms_before_arcsec,
            rms_after_arcsec: d.rms_after_arcsec,
            cv_rms_after_arcsec: d.cv_rms_after_arcsec,
            effects: d
                .effects
                .iter()
                .map(|f| RotaryEffectJson {
                    id: f.effect.id(),
                    params: f
                        .effect
                        .params()
                        .iter()
                        .map(|(p, v)| (p.as_str(), *v))
                        .collect(),
                    uncertainty: f
                        .uncertainty
                        .iter()
                        .map(|(p, v)| (p.as_str(), *v))
                        .collect(),
                    where_: f.where_.clone(),
                    explains_arcsec: f.explains_arcsec,
                    delta_chi2: f.delta_chi2,
                })
                .collect(),
            candidates: d.candidates,
            threshold_chi2: d.threshold_chi2,
            family_false_alarm_rate: 0.01,
            dwells: d.dwells,
        }
    }

    /// The diagnosis as markdown.
    pub fn markdown(&self, source: &str) -> String {
        let mut s = format!(
            "# Rotary diagnosis of axis {}\n\nSource: `{source}`. Verdict: **{}**. rms before \
             {:.3}″, after {:.3}″ (runs held out: {}). {} dwells; {} candidates searched, kept \
             when removing one raises χ² by more than {:.1} (1 % family-wise) and its main \
             parameter's one-sigma is at most half its value.\n\n",
            self.axis,
            self.verdict,
            self.rms_before_arcsec,
            self.rms_after_arcsec,
            self.cv_rms_after_arcsec
                .map_or("n/a".to_string(), |v| format!("{v:.3}″")),
            self.dwells,
            self.candidates,
            self.threshold_chi2
        );
        if self.effects.is_empty() {
            s.push_str("No effect is significant: the axis is consistent with its noise.\n");
        }
        for e in &self.effects {
            let params: Vec<String> = e
                .params
                .iter()
                .map(|(k, v)| {
                    let u = e.uncertainty.get(k).copied().unwrap_or(0.0);
                    format!("{k} = {v:.4} ± {u:.4}")
                })
                .collect();
            let _ = writeln!(
                s,
                "- **{}** ({}; explains {:.3}″ rms, Δχ² {:.1}): {}",
                e.id.as_str(),
                params.join(", "),
                e.explains_arcsec,
                e.delta_chi2,
                e.where_
            );
        }
        s
    }
}
