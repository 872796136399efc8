//! The rotary axis' diagnosis from the recording alone (`docs/rotary.md` §3): the dwell
//! rows explained by a free constant (the reference's zero, never reported) and the
//! effects of [`effects`], each kept only when significant at a 1 % family-wise
//! false-alarm rate and determined.
//!
//! **Unit of observation.** A dwell's samples share its positioning offset, so the fit is
//! made on dwell means (run, direction, target), one observation each, and σ̂² is the
//! scatter of the dwell means about the joint fit: a per-row σ would be √m too small.
//!
//! **Search.** Candidates: the harmonics N = 1 (`eccentricity`), 2 (`twice_per_rev`) and
//! 3 … ⌊m₀/2⌋ (`gear_periodic`, m₀ distinct targets in [0, 360)), `reversal`,
//! `scale_factor`, `thermal_drift` linear or exponential (τ scanned on a log grid): K
//! candidates. Forward: the candidate raising χ² = RSS/σ̂² the most is added while the
//! rise exceeds T = max(25, 2·ln(K/0.01)) (a Bonferroni bound: each of the K tests at
//! 0.01/K; 25, five sigma, as a floor); the exponential drift ranks 2·ln(12) below its
//! rise (the best of 12 scanned τ), so a drift linear within the noise is reported linear. Backward: an effect whose removal from the final
//! joint fit raises χ² by less than T is dropped (made redundant by a later one), then one
//! whose main parameter's one-sigma exceeds half its value (not determined).
//!
//! Cost: O(K²·D·p²) for D dwells and p columns; a revolution of 40 targets × 5 runs is
//! milliseconds.

pub mod effects;
mod fit;

use std::collections::BTreeMap;

pub use effects::{ARCSEC_PER_DEG_PPM, RotaryDrift, RotaryEffect, RotaryId};
use fit::{Candidate, Dwell, Fit, fit, predict};

use crate::base::{ParamName, Verdict};

/// One dwell row of a rotary session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotarySample {
    pub run: u32,
    pub direction: i8,
    pub target_deg: f64,
    /// Seconds since the session's first sample.
    pub t_s: f64,
    pub e_arcsec: f64,
}

/// One effect found.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryFinding {
    pub effect: RotaryEffect,
    /// One-sigma of each parameter (per_rev has none: 0).
    pub uncertainty: Vec<(ParamName, f64)>,
    pub where_: String,
    /// rms of the effect over the dwell rows, about its mean, ″.
    pub explains_arcsec: f64,
    /// Rise of χ² when it is removed from the final joint fit.
    pub delta_chi2: f64,
}

/// The diagnosis of a rotary recording.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryDiagnosis {
    pub verdict: Verdict,
    pub rms_before_arcsec: f64,
    pub rms_after_arcsec: f64,
    /// Each run held out in turn; `None` with one run.
    pub cv_rms_after_arcsec: Option<f64>,
    pub effects: Vec<RotaryFinding>,
    /// Candidates searched (K) and the χ² threshold T.
    pub candidates: usize,
    pub threshold_chi2: f64,
    pub dwells: usize,
}

/// Why a rotary recording cannot be diagnosed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RotaryDiagnoseError {
    #[error("{dwells} dwells: too few to fit a constant and test any effect (at least 4)")]
    TooFewDwells { dwells: usize },
}

/// Per dwell (run, direction, angle in µ°): its angle, Σt, Σe and its samples.
type DwellSums = BTreeMap<(u32, i8, i64), (f64, f64, f64, usize)>;

fn dwells_of(samples: &[RotarySample]) -> Vec<Dwell> {
    let mut m = DwellSums::new();
    for s in samples {
        let key = (s.run, s.direction, (s.target_deg * 1e6).round() as i64);
        let e = m.entry(key).or_insert((s.target_deg, 0.0, 0.0, 0));
        e.1 += s.t_s;
        e.2 += s.e_arcsec;
        e.3 += 1;
    }
    m.into_iter()
        .map(|((run, direction, _), (theta_deg, t, e, n))| Dwell {
            run,
            direction,
            theta_deg,
            t_s: t / n as f64,
            e_arcsec: e / n as f64,
        })
        .collect()
}

/// The candidates searched for these dwells (`docs/rotary.md` §3).
fn candidates(dwells: &[Dwell]) -> Vec<Candidate> {
    let mut angles: Vec<i64> = dwells
        .iter()
        .filter(|w| w.theta_deg < 360.0 - 1e-6)
        .map(|w| (w.theta_deg * 1e6).round() as i64)
        .collect();
    angles.sort_unstable();
    angles.dedup();
    let n_max = (angles.len() / 2) as u32;
    let mut c: Vec<Candidate> = (1..=n_max.max(2)).map(Candidate::Harmonic).collect();
    c.extend([
        Candidate::Reversal,
        Candidate::Scale,
        Candidate::DriftLinear,
    ]);
    let span = dwells.iter().map(|w| w.t_s).fold(0.0, f64::max);
    if span > 0.0 {
        // τ from a twentieth of the session to three times it.
        for k in 0..12 {
            c.push(Candidate::DriftExp(
                span / 20.0 * 60f64.powf(f64::from(k) / 11.0),
            ));
        }
    }
    c
}

/// The number of candidates K: one per harmonic, reversal, scale, two drift forms.
fn family_size(c: &[Candidate]) -> usize {
    c.iter()
        .filter(|x| !matches!(x, Candidate::DriftExp(_)))
        .count()
        + 1
}

/// The χ² rise of `c` added to `set`, with σ̂² of the larger model.
fn rise(dwells: &[Dwell], set: &[Candidate], base_rss: f64, c: Candidate) -> Option<f64> {
    let mut with = set.to_vec();
    with.push(c);
    let f = fit(dwells, &with)?;
    Some((base_rss - f.rss) / f.sigma2.max(1e-300))
}

/// The χ² penalty of the exponential drift's scanned τ: its best of [`TAU_GRID`] trials
/// must beat the linear form by 2·ln(12) (a Bonferroni share), so a drift that is linear
/// within the noise is reported linear.
fn ranked(c: &(Candidate, f64)) -> f64 {
    match c.0 {
        Candidate::DriftExp(_) => c.1 - 2.0 * (TAU_GRID as f64).ln(),
        _ => c.1,
    }
}

/// Values of τ scanned for the exponential drift.
const TAU_GRID: u32 = 12;

/// Forward selection then backward pruning (module docs).
fn select(dwells: &[Dwell], cands: &[Candidate], t: f64) -> Vec<Candidate> {
    let mut set: Vec<Candidate> = Vec::new();
    while let Some(base) = fit(dwells, &set) {
        let best = cands
            .iter()
            .filter(|c| !set.iter().any(|s| s.same_slot(c)))
            .filter_map(|&c| rise(dwells, &set, base.rss, c).map(|r| (c, r)))
            .max_by(|a, b| ranked(a).total_cmp(&ranked(b)));
        match best {
            Some((c, r)) if r > t => set.push(c),
            _ => break,
        }
    }
    while let Some(full) = fit(dwells, &set) {
        let weakest = (0..set.len())
            .map(|i| (i, removal_rise(dwells, &set, &full, i)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let undetermined = (0..set.len()).find(|&i| !determined(&set, &full, i));
        match (weakest, undetermined) {
            (Some((i, r)), _) if r <= t => {
                set.remove(i);
            }
            (_, Some(i)) => {
                set.remove(i);
            }
            _ => break,
        }
    }
    set
}

fn removal_rise(dwells: &[Dwell], set: &[Candidate], full: &Fit, i: usize) -> f64 {
    let mut without = set.to_vec();
    without.remove(i);
    fit(dwells, &without).map_or(f64::INFINITY, |f| {
        (f.rss - full.rss) / full.sigma2.max(1e-300)
    })
}

/// The offset of candidate `i`'s coefficients in the fit (after the constant).
fn offset(set: &[Candidate], i: usize) -> usize {
    1 + set[..i].iter().map(Candidate::width).sum::<usize>()
}

/// The main parameter and its one-sigma, and every parameter's one-sigma.
fn sigmas(set: &[Candidate], f: &Fit, i: usize) -> (f64, f64, Vec<f64>) {
    let o = offset(set, i);
    let v = |a: usize, b: usize| f.cov[(o + a, o + b)];
    match set[i] {
        Candidate::Harmonic(n) => {
            let (s, c) = (f.coef[o], f.coef[o + 1]);
            let a = s.hypot(c).max(1e-300);
            let g = [s / a, c / a];
            let h = [-c / (a * a), s / (a * a)];
            let q = |w: [f64; 2]| {
                (w[0] * w[0] * v(0, 0) + 2.0 * w[0] * w[1] * v(0, 1) + w[1] * w[1] * v(1, 1))
                    .max(0.0)
                    .sqrt()
            };
            let (sa, sp) = (q(g), q(h).to_degrees());
            // In the order of the effect's parameters (gear_periodic: per_rev between).
            let all = if n <= 2 {
                vec![sa, sp]
            } else {
                vec![sa, 0.0, sp]
            };
            (a, sa, all)
        }
        _ => {
            let s = v(0, 0).max(0.0).sqrt();
            (f.coef[o], s, vec![s])
        }
    }
}

fn determined(set: &[Candidate], f: &Fit, i: usize) -> bool {
    let (value, sigma, _) = sigmas(set, f, i);
    sigma <= 0.5 * value.abs()
}

/// Diagnoses a rotary recording's dwell rows; `closure_mismatch` adds the ratio advice
/// to a significant `scale_factor`.
pub fn diagnose_rotary(
    samples: &[RotarySample],
    closure_mismatch: bool,
) -> Result<RotaryDiagnosis, RotaryDiagnoseError> {
    let dwells = dwells_of(samples);
    if dwells.len() < 4 {
        return Err(RotaryDiagnoseError::TooFewDwells {
            dwells: dwells.len(),
        });
    }
    let cands = candidates(&dwells);
    let k = family_size(&cands);
    let t = 25f64.max(2.0 * (k as f64 / 0.01).ln());
    let set = select(&dwells, &cands, t);
    let full = fit(&dwells, &set).or_else(|| fit(&dwells, &[]));
    let rms = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    let e: Vec<f64> = samples.iter().map(|s| s.e_arcsec).collect();
    let rms_before_arcsec = rms(&e);
    let Some(full) = full else {
        return Err(RotaryDiagnoseError::TooFewDwells {
            dwells: dwells.len(),
        });
    };
    let resid = |set: &[Candidate], coef: &[f64], s: &RotarySample| {
        s.e_arcsec - predict(set, coef, s.target_deg, s.direction, s.t_s)
    };
    let after: Vec<f64> = samples.iter().map(|s| resid(&set, &full.coef, s)).collect();
    let rms_after_arcsec = (after.iter().map(|x| x * x).sum::<f64>() / after.len() as f64).sqrt();
    let cv_rms_after_arcsec = cross_validate(samples, &dwells, &set);
    let mut effects: Vec<RotaryFinding> = (0..set.len())
        .map(|i| {
            let o = offset(&set, i);
            let effect = set[i].effect(&full.coef[o..o + set[i].width()]);
            let (_, _, sig) = sigmas(&set, &full, i);
            let uncertainty = effect
                .params()
                .iter()
                .zip(sig.iter().chain(std::iter::repeat(&0.0)))
                .map(|((p, _), s)| (*p, *s))
                .collect();
            let r: Vec<f64> = samples
                .iter()
                .map(|s| effect.r_arcsec(s.target_deg, s.direction, s.t_s))
                .collect();
            RotaryFinding {
                effect,
                uncertainty,
                where_: effect.words(closure_mismatch),
                explains_arcsec: rms(&r),
                delta_chi2: removal_rise(&dwells, &set, &full, i),
            }
        })
        .collect();
    effects.sort_by(|a, b| b.explains_arcsec.total_cmp(&a.explains_arcsec));
    Ok(RotaryDiagnosis {
        verdict: Verdict::from_found(!effects.is_empty()),
        rms_before_arcsec,
        rms_after_arcsec,
        cv_rms_after_arcsec,
        effects,
        candidates: k,
        threshold_chi2: t,
        dwells: dwells.len(),
    })
}

/// rms of the rows of each run predicted by the fit of the other runs (same effects).
fn cross_validate(samples: &[RotarySample], dwells: &[Dwell], set: &[Candidate]) -> Option<f64> {
    let mut runs: Vec<u32> = dwells.iter().map(|w| w.run).collect();
    runs.sort_unstable();
    runs.dedup();
    if runs.len() < 2 {
        return None;
    }
    let (mut ss, mut n) = (0.0, 0usize);
    for run in runs {
        let train: Vec<Dwell> = dwells.iter().filter(|w| w.run != run).copied().collect();
        let f = fit(&train, set)?;
        for s in samples.iter().filter(|s| s.run == run) {
            let r = s.e_arcsec - predict(set, &f.coef, s.target_deg, s.direction, s.t_s);
            ss += r * r;
            n += 1;
        }
    }
    Some((ss / n.max(1) as f64).sqrt())
}
