//! The residual's test against the noise, and where a residual that fails it sits.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::identify::{LineResidual, ResidualVerdict};
use crate::base::Effect;
use crate::base::Verdict;
use crate::diagnose::FoundEffect;

/// A line that carries part of a residual the test rejects (JSON `residual.carriers`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Carrier {
    pub line: String,
    /// Its share of the residual's sum of squares.
    pub share: f64,
    pub rms_um: f64,
    /// Where along the line the largest residual is, mm, and its value, µm.
    pub worst_s_mm: f64,
    pub worst_r_um: f64,
}

/// The lines carrying most of the residual (largest sum of squares first, until 80 % of
/// it or five lines).
pub(crate) fn carriers(res: &[LineResidual]) -> Vec<Carrier> {
    let total: f64 = res.iter().flat_map(|l| &l.r_um).map(|r| r * r).sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    let mut per: Vec<Carrier> = res
        .iter()
        .filter(|l| !l.r_um.is_empty())
        .map(|l| {
            let ss: f64 = l.r_um.iter().map(|r| r * r).sum();
            let (i, r) = l
                .r_um
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .map_or((0, 0.0), |(i, r)| (i, *r));
            Carrier {
                line: l.line.clone(),
                share: ss / total,
                rms_um: (ss / l.r_um.len() as f64).sqrt(),
                worst_s_mm: l.s_mm.get(i).copied().unwrap_or(0.0),
                worst_r_um: r,
            }
        })
        .collect();
    per.sort_by(|a, b| b.share.total_cmp(&a.share));
    let mut out = Vec::new();
    let mut acc = 0.0;
    for c in per {
        if acc >= 0.8 || out.len() >= 5 {
            break;
        }
        acc += c.share;
        out.push(c);
    }
    out
}

/// The residual against the noise. With `s_um` on every row: the weighted chi-square
/// with its degrees of freedom, Wilson–Hilferty z; without: the lag-1 autocorrelation
/// of the residuals along each line, z = ρ·√n (white noise gives z ≈ 0 or slightly
/// negative; a systematic residual a run of same-sign values). `missing_physics` when
/// z > 3.09 (one-sided p < 0.001), with an `unexplained` effect: `rms_um` the residual's
/// RMS, `explains_um` its part above the noise, RMS·√(1 − 1/σ₀²) when rows are weighted
/// (σ₀² = χ²/ν), the whole RMS otherwise; `tried` says which component models were
/// fitted before the residual was called unexplained, and the lines carrying it are named
/// ([`carriers`]).
pub(crate) fn residual_test(
    res: &[LineResidual],
    chi2: Option<(f64, f64)>,
    rms_um: f64,
    sigma0: f64,
    tried: &str,
) -> ResidualVerdict {
    let (test, z) = match chi2 {
        Some((c, dof)) => {
            let nu = dof;
            let h = 2.0 / (9.0 * nu);
            ("chi-square", ((c / nu).cbrt() - (1.0 - h)) / h.sqrt())
        }
        None => {
            let (mut num, mut den, mut n) = (0.0, 0.0, 0usize);
            for l in res {
                den += l.r_um.iter().map(|r| r * r).sum::<f64>();
                num += l.r_um.windows(2).map(|w| w[0] * w[1]).sum::<f64>();
                n += l.r_um.len().saturating_sub(1);
            }
            let rho = if den > 0.0 { num / den } else { 0.0 };
            ("lag-1 autocorrelation", rho * (n as f64).sqrt())
        }
    };
    let mut effects = Vec::new();
    let mut carried = Vec::new();
    if z > Z_MISSING {
        carried = carriers(res);
        let lines: Vec<String> = carried
            .iter()
            .map(|c| {
                format!(
                    "{} ({:.0} %, largest {:+.3} µm at s = {:.1} mm)",
                    c.line,
                    100.0 * c.share,
                    c.worst_r_um,
                    c.worst_s_mm
                )
            })
            .collect();
        let excess = if chi2.is_some() {
            rms_um * (1.0 - 1.0 / (sigma0 * sigma0)).max(0.0).sqrt()
        } else {
            rms_um
        };
        effects.push(FoundEffect {
            effect: Effect::Unexplained { rms_um },
            uncertainty: BTreeMap::new(),
            where_: format!(
                "the residual of the rigid-body fit fails the {test} test against the noise \
                 (z = {z:.1} > {Z_MISSING}) with every admissible component model ({tried}) and \
                 no drift or bad line explains it; most of it on {}; see the residual per line \
                 and against time in the report",
                lines.join(", ")
            ),
            explains_um: excess,
        });
    }
    ResidualVerdict {
        verdict: Verdict::from_found(z > Z_MISSING),
        effects,
        test: test.into(),
        z,
        carriers: carried,
    }
}

/// One-sided p < 0.001 of the residual test.
pub const Z_MISSING: f64 = 3.09;
