//! What the campaign itself did wrong: a drift of the readings in time, common to every
//! line, and a single line whose readings scale against the others. Both are named in
//! `cli-contract.md`'s vocabulary, with x replaced by the distance s along the line, and
//! fitted jointly with the 21 errors (and the scale's α when that was kept).
//!
//! # Terms
//!
//! - **`thermal_drift`** (linear form, `rate_um_per_s`): every reading gains ρ·t, with t
//!   the row's `t_s`. Each line's free constant absorbs the line's mean, so the design
//!   column is t centred per line: ρ is determined by the time each line takes, not by
//!   the hours between lines. Only when every row has `t_s`.
//! - **`scale_factor` of one line** (`ppm`, `where` naming the line): the line's readings
//!   gain k·s·1e−3 µm — a beam misaligned by θ reads −θ²/2 of the length (the cosine
//!   error), a wrong air compensation on that line a scale of either sign. The column is s
//!   on that line's rows (centred on the line) and 0 elsewhere; it is separable from the
//!   21 errors only when other lines measure the same combination of components (two
//!   lines along X at different offsets, say).
//!
//! # Selection
//!
//! Forward, one term at a time, from the fit so far: for each candidate column g, its
//! part g⊥ orthogonal to the design's range (weighted, centred, the SVD's U), the
//! estimate θ = g⊥·r / g⊥·g⊥ from the residual r, its variance σ₁²/g⊥·g⊥ with σ₁² the
//! residual variance after the term (one degree of freedom fewer), and t = |θ|/σ. This
//! is the exact t of the joint least-squares fit with that column, at the cost of a dot
//! product per candidate. A column with |g⊥| below [`SEPARABLE`]·|g| lies in the span of
//! the 21 errors and is not a candidate. The drift is kept when t > [`DRIFT_T`]
//! (two-sided p ≈ 0.001); a line when t exceeds the Bonferroni threshold for the number
//! of lines tested (family-wise p ≈ 0.001, [`line_threshold`]), so a rigid campaign of
//! sixty lines does not find one of them bad by chance, and only if, with it fitted, no
//! other line still passes the threshold: several lines that stand out are not one bad
//! line but something the lines share (a scale changing through the campaign), left to
//! the residual's test as `unexplained`. At most one line and [`MAX_TERMS`] terms. The
//! reported values and σ come from the final joint fit (covariance scaled by its
//! residual), as the 21 errors' do.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use super::identify::{Design, augment, centre_per_line, decompose};
use super::lines::LineTable;
use crate::base::ParamName;
use crate::base::{Drift, Effect};
use crate::diagnose::FoundEffect;

/// The t above which a common drift is kept (two-sided p ≈ 0.001).
pub(crate) const DRIFT_T: f64 = 3.29;
/// The family-wise two-sided p of the bad-line search.
pub(crate) const LINE_FAMILY_P: f64 = 0.001;
/// |g⊥|/|g| below which a term cannot be told from the 21 errors.
pub(crate) const SEPARABLE: f64 = 1e-6;
/// At most this many campaign terms.
pub(crate) const MAX_TERMS: usize = 3;

/// One campaign term and its column.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Term {
    /// ρ, µm/s, common to every line.
    Drift,
    /// k, ppm, of the line at this index.
    Line(usize),
}

/// A candidate: the term and its column (unweighted, centred per line).
struct Candidate {
    term: Term,
    col: Vec<f64>,
}

/// The t threshold for one of `n` lines at family-wise p [`LINE_FAMILY_P`] (Bonferroni,
/// two-sided): the standard normal quantile of 1 − p/(2n).
pub(crate) fn line_threshold(n: usize) -> f64 {
    normal_upper_quantile(LINE_FAMILY_P / (2.0 * n.max(1) as f64))
}

/// z with P(Z > z) = q for 0 < q < 0.5: the Abramowitz–Stegun 26.2.23 rational
/// approximation (|error| < 4.5e−4), enough for a threshold.
fn normal_upper_quantile(q: f64) -> f64 {
    let q = q.clamp(1e-300, 0.5);
    let t = (-2.0 * q.ln()).sqrt();
    t - (2.515517 + 0.802853 * t + 0.010328 * t * t)
        / (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t)
}

fn candidates(table: &LineTable, w: &[f64]) -> Vec<Candidate> {
    let mut out = Vec::new();
    let times: Option<Vec<f64>> = table
        .lines
        .iter()
        .flat_map(|l| &l.targets)
        .map(|t| t.t_s)
        .collect();
    if let Some(t) = times {
        out.push(Candidate {
            term: Term::Drift,
            col: centre_per_line(table, w, &t),
        });
    }
    let rows = table.targets();
    let mut r = 0;
    for (i, line) in table.lines.iter().enumerate() {
        let mut v = vec![0.0; rows];
        for (k, t) in line.targets.iter().enumerate() {
            v[r + k] = 1e-3 * line.s_mm(t);
        }
        let c = centre_per_line(table, w, &v);
        // Rows of other lines are 0 − 0: the centring leaves them 0.
        out.push(Candidate {
            term: Term::Line(i),
            col: c,
        });
        r += line.targets.len();
    }
    out
}

/// What the terms' scores need of a fit of a design: its weighted residual r, its residual
/// degrees of freedom ν, and the map g ↦ (I − P)g with P the fit's hat matrix (the
/// orthogonal projector onto the design's range for least squares; tables at knots are
/// scored against their unpenalised least-squares fit, [`super::identify`]).
pub(crate) struct Residualiser<'a> {
    pub r: DVector<f64>,
    pub dof: f64,
    pub project: Project<'a>,
}

/// G ↦ (I − P)G, column by column: every candidate's column at once, so that the
/// products with the design are two matrix products instead of two matrix–vector products
/// per candidate (issue 40 item 10).
pub(crate) type Project<'a> = Box<dyn Fn(&DMatrix<f64>) -> DMatrix<f64> + 'a>;

/// How the 21 errors are fitted to a design (with `n_lines` constants).
pub(crate) type Fitter<'f> = dyn for<'a> Fn(&'a Design, usize) -> Option<Residualiser<'a>> + 'f;

/// The least-squares residualiser (polynomial bases): P = U Uᵀ from the design's SVD.
pub(crate) fn least_squares(d: &Design, n_lines: usize) -> Option<Residualiser<'_>> {
    let dec = decompose(&d.a);
    let rank = dec.sv_range.len();
    let rows = d.a.nrows();
    let ut_e = dec.u_range.transpose() * &d.e;
    let r = &d.e - &dec.u_range * ut_e;
    let u = dec.u_range;
    Some(Residualiser {
        r,
        dof: rows as f64 - rank as f64 - n_lines as f64,
        project: Box::new(move |g: &DMatrix<f64>| g - &u * u.tr_mul(g)),
    })
}

/// The t of each candidate column against the fit of design `d` (with `n_lines`
/// constants). For a column g: g⊥ = (I − P)g, θ = g·r / g·g⊥, the residual variance
/// after the term σ₁² = (χ² − θ·g·r)/(ν − 1), σ = σ₁/√(g·g⊥) — the exact joint fit's t for
/// least squares, and for a penalised fit the t of the unpenalised column with the
/// smoothing held.
fn scores<'a>(
    d: &Design,
    n_lines: usize,
    fitter: &Fitter<'_>,
    cols: impl ExactSizeIterator<Item = &'a [f64]>,
) -> Vec<Option<f64>> {
    let rows = d.a.nrows();
    let Some(fit) = fitter(d, n_lines) else {
        return vec![None; cols.len()];
    };
    if fit.dof <= 1.0 {
        return vec![None; cols.len()];
    }
    let chi2 = fit.r.norm_squared();
    let dof1 = fit.dof - 1.0;
    let k = cols.len();
    let mut g_all = DMatrix::zeros(rows, k);
    for (j, col) in cols.enumerate() {
        for (i, (a, b)) in col.iter().zip(&d.sqrt_w).enumerate() {
            g_all[(i, j)] = a * b;
        }
    }
    let gp_all = (fit.project)(&g_all);
    (0..k)
        .map(|j| {
            let g = g_all.column(j);
            let gn = g.norm();
            if !(gn > 0.0 && gn.is_finite()) {
                return None;
            }
            let gg = g.dot(&gp_all.column(j));
            if gg.is_nan() || gg <= 0.0 || gg.sqrt() < SEPARABLE * gn {
                return None;
            }
            let gr = g.dot(&fit.r);
            let theta = gr / gg;
            let s1 = ((chi2 - gr * gr / gg).max(0.0) / dof1).sqrt();
            let sigma = s1 / gg.sqrt();
            // σ = 0: the column takes up the whole residual. It is significant beyond any
            // bound when it explains something (θ ≠ 0, data without noise), and not at all
            // when there is nothing left to explain (a residual of exact zeros: θ = 0).
            Some(if sigma > 0.0 {
                theta.abs() / sigma
            } else if theta != 0.0 {
                f64::INFINITY
            } else {
                0.0
            })
        })
        .collect()
}

/// A chosen term: its column (to augment the design with) and its t at selection.
pub(crate) struct Chosen {
    pub term: Term,
    pub col: Vec<f64>,
    pub t: f64,
}

/// Forward selection of campaign terms on top of design `d`; `w` the row weights.
/// Returns the chosen terms and, when there are any, the design augmented with their
/// columns in that order (for the joint fit).
pub(crate) fn select(
    table: &LineTable,
    w: &[f64],
    d: &Design,
    fitter: &Fitter<'_>,
) -> (Vec<Chosen>, Option<Design>) {
    let n_lines = table.lines.len();
    let mut cands = candidates(table, w);
    let line_t = line_threshold(n_lines);
    let mut chosen = Vec::new();
    let mut cur: Option<Design> = None;
    while chosen.len() < MAX_TERMS && !cands.is_empty() {
        let base = cur.as_ref().unwrap_or(d);
        let t = scores(
            base,
            n_lines,
            fitter,
            cands.iter().map(|c| c.col.as_slice()),
        );
        let best = t
            .iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let t = (*t)?;
                let need = match cands[i].term {
                    Term::Drift => DRIFT_T,
                    Term::Line(_) => line_t,
                };
                (t > need).then_some((i, t / need))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((i, _)) = best else { break };
        let c = cands.swap_remove(i);
        let Some(next) = augment(base, &c.col) else {
            break;
        };
        if matches!(c.term, Term::Line(_)) {
            // A single bad line: with it fitted, no other line may still stand out.
            // Several that do are not one bad line but something every line shares (a
            // scale changing through the campaign, say), left to the residual's test.
            let others: Vec<&[f64]> = cands
                .iter()
                .filter(|o| matches!(o.term, Term::Line(_)))
                .map(|o| o.col.as_slice())
                .collect();
            let still = scores(&next, n_lines, fitter, others.into_iter())
                .iter()
                .any(|t| t.is_some_and(|t| t > line_t));
            cands.retain(|o| !matches!(o.term, Term::Line(_)));
            if still {
                continue;
            }
        }
        chosen.push(Chosen {
            term: c.term,
            col: c.col,
            t: t[i].unwrap_or(0.0),
        });
        cur = Some(next);
    }
    (chosen, cur)
}

/// A term's t in words: one decimal, or what an infinite one means (data without noise
/// that the term explains exactly). Also the thermal test's.
pub(crate) fn t_words(t: f64) -> String {
    if t.is_finite() {
        format!("{t:.1}")
    } else {
        "unbounded (the term leaves no residual)".to_string()
    }
}

/// The effect of a chosen term, from its fitted value and σ (joint fit).
pub(crate) fn effect(table: &LineTable, c: &Chosen, value: f64, sigma: f64) -> FoundEffect {
    let contribution: Vec<f64> = c.col.iter().map(|g| value * g).collect();
    let explains_um = crate::base::rms(&contribution).unwrap_or(0.0);
    let mut uncertainty = BTreeMap::new();
    let (effect, where_) = match c.term {
        Term::Drift => {
            uncertainty.insert(ParamName::RateUmPerS, sigma);
            (
                Effect::ThermalDrift(Drift::Linear {
                    rate_um_per_s: value,
                }),
                format!(
                    "every line: the readings drift by {:.3} ± {:.3} µm/h during the campaign \
                     (t_s within each line; each line's constant absorbs the hours between \
                     lines), |ρ|/σ = {} > {DRIFT_T}; fitted jointly with the 21 errors, \
                     which are reported without it",
                    value * 3600.0,
                    sigma * 3600.0,
                    t_words(c.t)
                ),
            )
        }
        Term::Line(i) => {
            let line = &table.lines[i];
            uncertainty.insert(ParamName::Ppm, sigma);
            let cosine = if value < 0.0 {
                format!(
                    "a beam misaligned by about {:.2} mrad (cosine error), or ",
                    (2.0 * value.abs() * 1e-6).sqrt() * 1e3
                )
            } else {
                String::new()
            };
            (
                Effect::ScaleFactor { ppm: value },
                format!(
                    "line {} alone: its readings scale by {:.2} ± {:.2} ppm against the other \
                     lines ({cosine}a wrong air compensation on that line); |k|/σ = {} > \
                     {:.2} (Bonferroni over {} lines); fitted jointly with the 21 errors, which \
                     are reported without it; remeasure the line",
                    line.id,
                    value,
                    sigma,
                    t_words(c.t),
                    line_threshold(table.lines.len()),
                    table.lines.len()
                ),
            )
        }
    };
    FoundEffect {
        effect,
        uncertainty,
        where_,
        explains_um,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quantile against values from a normal table: z(0.025) = 1.960,
    /// z(0.0005) = 3.291, z(1e−5) = 4.265.
    #[test]
    fn normal_quantiles_match_the_table() {
        for (q, z) in [(0.025, 1.960), (0.0005, 3.291), (1e-5, 4.265)] {
            assert!((normal_upper_quantile(q) - z).abs() < 2e-3, "{q}");
        }
        // Sixty lines at family p 0.001: q = 8.3e−6, z ≈ 4.31.
        assert!((line_threshold(60) - 4.31).abs() < 0.01);
    }
}
