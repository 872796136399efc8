//! A degree per component by leave-one-line-out cross-validation (`--degree auto-each`):
//! the same honest comparison the global `auto` makes ([`super::identify`]), one
//! component at a time.
//!
//! # Method
//!
//! The 18 bases are nested (a component of degree d uses the first columns of degree
//! d + 1; a straightness of degree 1 is the one of degree 2), so the design is built once
//! at the largest degree and every candidate is a choice of its columns. Starting from the
//! global CV choice D, coordinate descent: for each component in turn (E_XX … E_CZ, those
//! fixed by `--component-degree` excepted) every other degree 1…max is scored by the
//! leave-one-line-out sum of squares over the lines the start could predict; a candidate
//! must predict all of them and determine every component the start determines. A lower
//! degree is taken when its score stays within [`RAISE_GAIN`] (1 %) of the lowest score
//! any accepted choice reached, a higher one only when it lowers the current score by
//! more than 1 % — parameters that buy less are noise fitted, and the bound on the lowest
//! score keeps a run of "free" reductions from drifting. Sweeps repeat until nothing
//! changes (at most [`MAX_SWEEPS`]).
//!
//! # Cost
//!
//! One SVD of the design (rows × params) and one Cholesky per line for each candidate:
//! 18·(max − 1) candidates a sweep, i.e. about 50 global fits for max = 4 — the price of
//! the choice, which is why it is a separate mode rather than the default.

use serde::{Deserialize, Serialize};

use super::basis::Basis;
use super::identify::{
    CvScore, Design, IdentifyConfig, augment, cv_per_line, decompose, degrees, design,
    identified_flags,
};
use super::lines::LineTable;
use super::model::{Component, Topology};

/// Least relative drop of the CV sum of squares that justifies a higher degree.
pub(crate) const RAISE_GAIN: f64 = 0.01;
/// Most coordinate-descent sweeps over the 18 components.
pub(crate) const MAX_SWEEPS: usize = 3;

/// What the per-component search did (JSON `cv_each`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EachScore {
    /// CV RMS at the global degree the search started from, µm (weighted).
    pub start_cv_rms_um: f64,
    /// CV RMS at the chosen degrees, µm (weighted).
    pub cv_rms_um: f64,
    /// Candidates scored.
    pub evaluations: usize,
    pub sweeps: usize,
}

/// The columns of `full` (built at degree `max` for every component) that a basis of
/// degrees `degs` uses.
fn columns(full: &Basis, degs: &[usize]) -> Vec<usize> {
    let probe = Basis::new(full.topology(), full.range_mm, degs.to_vec());
    let mut cols = Vec::new();
    for c in 0..21 {
        let o = full.offset(c);
        cols.extend(o..o + probe.count(c));
    }
    cols
}

fn select(d: &Design, cols: &[usize]) -> Design {
    Design {
        a: d.a.select_columns(cols),
        e: d.e.clone(),
        line_rows: d.line_rows.clone(),
        sqrt_w: d.sqrt_w.clone(),
        scale: cols.iter().map(|&j| d.scale[j]).collect(),
    }
}

/// Chooses the degree of every component. `fixed[c]` are not searched; `start` is the
/// global degree to start from; `thermal` the scale-expansion column when fitted.
#[allow(clippy::too_many_arguments)]
pub(crate) fn choose_each(
    table: &LineTable,
    topology: Topology,
    range: [[f64; 2]; 3],
    sqrt_w: &[f64],
    thermal: Option<&[f64]>,
    start: Vec<usize>,
    fixed: &[bool],
    max: usize,
) -> (Vec<usize>, EachScore) {
    let top: Vec<usize> = start.iter().map(|&d| d.max(max)).collect();
    let full_basis = Basis::new(topology, range, top);
    let full = design(table, &full_basis, sqrt_w);
    // Per-line CV and identified flags of a choice of degrees.
    let eval = |degs: &[usize]| {
        let sub = select(&full, &columns(&full_basis, degs));
        let basis = Basis::new(topology, range, degs.to_vec());
        let flags = identified_flags(&basis, &decompose(&sub.a).null);
        let cv = match thermal.and_then(|c| augment(&sub, c)) {
            Some(aug) => cv_per_line(&aug),
            None => cv_per_line(&sub),
        };
        (cv, flags)
    };
    let (base_cv, base_flags) = eval(&start);
    let usable: Vec<usize> = (0..base_cv.len())
        .filter(|&l| base_cv[l].is_some())
        .collect();
    let score = |cv: &[Option<f64>]| -> Option<f64> { usable.iter().map(|&l| cv[l]).sum() };
    let rms = |ss: f64| {
        let n: usize = usable.iter().map(|&l| table.lines[l].targets.len()).sum();
        if n > 0 {
            (ss / n as f64).sqrt()
        } else {
            f64::NAN
        }
    };
    let start_ss = score(&base_cv).unwrap_or(f64::INFINITY);
    let mut best = start_ss;
    // The lowest score of any accepted choice: lower degrees may cost at most 1 % of it.
    let mut lowest = start_ss;
    let mut cur = start;
    let mut evaluations = 1;
    let mut sweeps = 0;
    while sweeps < MAX_SWEEPS {
        sweeps += 1;
        let mut changed = false;
        for c in (0..18).filter(|&c| !fixed[c]) {
            let straight = Component::from_index(c).is_straightness();
            for d in 1..=max {
                let same = if straight {
                    d.max(2) == cur[c].max(2)
                } else {
                    d == cur[c]
                };
                if same {
                    continue;
                }
                let mut cand = cur.clone();
                cand[c] = d;
                let (cv, flags) = eval(&cand);
                evaluations += 1;
                if base_flags.iter().zip(&flags).any(|(b, f)| *b && !f) {
                    continue;
                }
                let Some(ss) = score(&cv) else { continue };
                let better = if d < cur[c] {
                    ss <= lowest * (1.0 + RAISE_GAIN)
                } else {
                    ss < best * (1.0 - RAISE_GAIN)
                };
                if better {
                    best = ss;
                    lowest = lowest.min(ss);
                    cur = cand;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    (
        cur,
        EachScore {
            start_cv_rms_um: rms(start_ss),
            cv_rms_um: rms(best),
            evaluations,
            sweeps,
        },
    )
}

/// Degree by leave-one-line-out cross-validation: among the degrees that determine at
/// least the components degree 1 determines, the one with the lowest CV RMS (a degree
/// too high costs width of the σ bands, one too low a bias they do not show). Lines the others cannot predict at some degree are left out of
/// every degree's score, so the scores are over the same lines.
pub(crate) fn choose_degree(
    table: &LineTable,
    config: &IdentifyConfig,
    range: [[f64; 2]; 3],
    sqrt_w: &[f64],
    thermal: Option<&[f64]>,
    max: usize,
) -> (usize, Vec<CvScore>) {
    // (degree, identified count, identified flags, CV per line)
    type PerDegree = (usize, usize, Vec<bool>, Vec<Option<f64>>);
    let mut per: Vec<PerDegree> = Vec::new();
    for deg in 1..=max {
        let basis = Basis::new(config.topology, range, degrees(config, deg));
        let d = design(table, &basis, sqrt_w);
        let dec = decompose(&d.a);
        let flags = identified_flags(&basis, &dec.null);
        let count = flags.iter().filter(|f| **f).count();
        // With temperatures, each degree is scored with the scale-expansion column in.
        let cv = match thermal.and_then(|c| augment(&d, c)) {
            Some(aug) => cv_per_line(&aug),
            None => cv_per_line(&d),
        };
        per.push((deg, count, flags, cv));
    }
    let base = per[0].2.clone();
    let admissible: Vec<usize> = (0..per.len())
        .filter(|&i| base.iter().zip(&per[i].2).all(|(b, f)| !b || *f))
        .collect();
    let usable: Vec<usize> = (0..table.lines.len())
        .filter(|&l| admissible.iter().all(|&i| per[i].3[l].is_some()))
        .collect();
    let rows: usize = usable.iter().map(|&l| table.lines[l].targets.len()).sum();
    let scores: Vec<CvScore> = admissible
        .iter()
        .map(|&i| {
            let ss: f64 = usable.iter().map(|&l| per[i].3[l].unwrap_or(0.0)).sum();
            CvScore {
                degree: per[i].0,
                cv_rms_um: if rows > 0 {
                    (ss / rows as f64).sqrt()
                } else {
                    f64::NAN
                },
                identified: per[i].1,
            }
        })
        .collect();
    let best = scores
        .iter()
        .map(|s| s.cv_rms_um)
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    let chosen = scores
        .iter()
        .find(|s| s.cv_rms_um <= best)
        .map(|s| s.degree)
        .unwrap_or(2.min(max));
    (chosen, scores)
}
