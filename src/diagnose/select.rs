//! Model selection: forward selection by BIC, backward check and swap moves,
//! leave-one-run-out confirmation, final checks with restart, ambiguity.
//!
//! 1. **Forward.** Starting from the constant alone, every testable effect is fitted
//!    jointly with the effects already chosen, in each of its variants (x0 free or 0;
//!    θ0 and/or θ1; v the feed or the measured speed; the air columns of refraction; an
//!    exponential drift with τ profiled jointly with all other terms on a grid and by
//!    golden section, or a linear one; a periodic term at each periodogram candidate, its
//!    period refined by golden section). Only full-rank variants whose key parameters are
//!    determined and plausible compete (a periodic one must also pass
//!    [`Selector::periodic_support`]). The lowest BIC = n·ln(χ²/n) + k·ln n
//!    (k = independent columns + nonlinear parameters) enters when it lowers BIC by at
//!    least `min_delta_bic`; candidates within [`TIE_BIC`] of the best are a tie, settled
//!    by [`Kind::preference`]. After each step the nonlinear parameters are refined and
//!    every term's variant is chosen again given the others.
//! 2. **Backward and swap.** An effect whose removal costs less than `min_delta_bic`
//!    leaves; an effect that another testable one replaces with a BIC gain of at least
//!    `min_delta_bic` is swapped (the greedy path can settle on a worse explanation).
//! 3. **Cross-validation.** With the nonlinear parameters fixed, an effect whose removal
//!    does not raise the leave-one-run-out held-out error leaves.
//! 4. **Final checks.** The covariance at the optimum, (JᵀWJ)⁻¹·χ²/(n − p) with J
//!    including the derivatives by the nonlinear parameters, gives one-sigma uncertainties
//!    (delta method for amplitude, phase, x0). An effect with an undetermined key
//!    parameter (one-sigma above `max_relative_uncertainty` × |value|), an implausible
//!    one, or a periodic term without support is refused, its variant (or period)
//!    excluded, and the selection restarts.
//! 5. **Ambiguity.** Every found effect is replaced in turn by every other testable effect;
//!    a determined replacement within `ambiguity_delta_bic` of the chosen model is an
//!    ambiguity, stated with the measurement that would separate the two.

use std::collections::BTreeMap;

use super::DiagnoseConfig;
use super::data::Obs;
use super::effects::{self, Columns, Kind, Param, Variant};
use super::engine::{CONST, Engine, Fit, bic, pinv_sym, solve};
use super::spectral;

/// Candidates whose BIC is within this of the best are a tie (numerically or
/// statistically identical fits), settled by preference.
pub(crate) const TIE_BIC: f64 = 1.0;

/// The periodogram is searched again when the residual's weighted RMS has fallen below
/// this fraction of the RMS it was last searched on.
const RESEARCH_FRACTION: f64 = 0.8;

/// Longest period of the broad periodogram, as a fraction of the x range: a "period"
/// with fewer than 10 cycles over the axis is a smooth shape, not a periodic error.
const MAX_BROAD_FRACTION: f64 = 0.1;

/// The sampling pitch (mm) of which `period_mm` is a sub-multiple s/k (k = 1‥64, within
/// 1 %), if any.
fn lattice_alias(period_mm: f64, lattices: &[f64]) -> Option<f64> {
    lattices.iter().copied().find(|&s| {
        let k = (s / period_mm).round();
        (1.0..=64.0).contains(&k) && (s / k - period_mm).abs() <= 0.01 * period_mm
    })
}

/// Δχ² a periodic term must reach on the moving rows alone (independent phases), about
/// 5σ for two parameters.
const MOVING_SUPPORT_CHI2: f64 = 25.0;

/// Moving rows needed for the periodograms to use them alone.
const MIN_MOVING_FOR_SCAN: usize = 200;

/// Rounds of backward check and swap moves.
const MAX_SWAP_ROUNDS: usize = 3;

/// Restarts of the selection after a refused term.
const MAX_RESTARTS: usize = 4;

/// Periodogram candidates weaker than this Δχ² (on the search subset) are not
/// evaluated: noise peaks of a scan over a few thousand frequencies reach about 15–20, and a
/// periodic term must reach [`MOVING_SUPPORT_CHI2`] on the moving rows anyway.
const MIN_CANDIDATE_POWER: f64 = 10.0;

/// Parameters of two effects correlated beyond this (|ρ|) are reported as hard to
/// separate.
const CORRELATED: f64 = 0.95;

/// Most periodogram candidates kept across searches.
const MAX_PERIOD_CANDIDATES: usize = 10;

/// Most periodic terms in one model.
const MAX_PERIODIC: usize = 3;

/// Golden-section iterations for a period or a time constant (0.618¹² ≈ 0.3 % of the
/// bracket, one grid step).
const GOLDEN_ITERS: usize = 12;

/// Points of the τ grid of the drift search.
const TAU_GRID: usize = 16;

/// One selected effect.
#[derive(Debug, Clone)]
pub(crate) struct Term {
    pub kind: Kind,
    pub variant: Variant,
    pub cols: Vec<usize>,
}

/// A periodogram candidate.
#[derive(Debug, Clone)]
pub(crate) struct PeriodCand {
    pub period_um: f64,
    /// Δχ² of the peak on the search subset.
    pub power: f64,
    /// Where it came from, in words ("P/2 of the 20 µm grating", "broad scan").
    pub label: String,
    /// Grid step at this period, µm.
    pub step_um: f64,
    /// Refined period (on the search subset), once computed.
    pub refined_um: Option<f64>,
}

/// A spectral scan kept for the report.
#[derive(Debug, Clone, Default)]
pub(crate) struct Broad {
    pub period_mm: Vec<f64>,
    pub power: Vec<f64>,
}

#[derive(Clone)]
enum Cand {
    Reg(Vec<usize>),
    Trial(Vec<Vec<f64>>),
}

#[derive(Clone)]
struct Eval {
    kind: Kind,
    variant: Variant,
    cand: Cand,
    bic: f64,
    /// Number of the candidate's columns that are independent of the model's.
    rank_new: usize,
    full: bool,
    undetermined: Option<String>,
}

/// A found-vs-alternative ambiguity.
#[derive(Debug, Clone)]
pub(crate) struct Ambiguity {
    pub found: Kind,
    pub alt: Kind,
    /// BIC(model with alt instead of found) − BIC(model).
    pub delta_bic: f64,
}

/// Final fit of a term.
#[derive(Debug, Clone)]
pub(crate) struct FittedTerm {
    pub term: Term,
    pub params: Vec<Param>,
    pub contribution: Vec<f64>,
}

/// What a selection pass returns.
#[derive(Debug, Clone)]
pub(crate) struct Outcome {
    pub terms: Vec<FittedTerm>,
    /// Model prediction (constant + effects) per row, for the centred residual.
    pub model: Vec<f64>,
    /// Held-out prediction per row (leave-one-fold-out).
    pub cv_pred: Vec<f64>,
    pub ambiguities: Vec<Ambiguity>,
    /// Strongly correlated parameters of two found effects: (effect, parameter, effect,
    /// parameter, ρ).
    pub correlated: Vec<(Kind, &'static str, Kind, &'static str, f64)>,
    /// Effects that would improve the fit but whose parameters are not determined.
    pub refused: Vec<String>,
    pub design: Vec<String>,
    pub log: Vec<String>,
    pub periods: Vec<PeriodCand>,
    pub broad: Broad,
    /// Weighted RMS of the residual the periodogram was last searched on.
    pub searched_rms: f64,
    /// ΔBIC of every testable kind against the final model (adding it, or for a found
    /// one, removing it).
    pub scores: Vec<(Kind, f64)>,
}

/// The selection over one weighting of the data.
pub(crate) struct Selector<'a> {
    obs: &'a Obs,
    cfg: &'a DiagnoseConfig,
    engine: Engine,
    cols: Columns,
    kinds: Vec<Kind>,
    periods: Vec<PeriodCand>,
    broad: Broad,
    /// Weighted RMS of the residual the periodogram candidates were found on (None: not
    /// searched yet). The search is repeated when the residual has dropped below
    /// [`RESEARCH_FRACTION`] of it: a strong effect removed, weaker periods can show.
    searched_rms: Option<f64>,
    /// Row subset for the period searches.
    sub: Vec<usize>,
    /// Variants that failed the final checks in this pass (not proposed again).
    failed: Vec<(Kind, std::mem::Discriminant<Variant>)>,
    /// Periods of periodic terms that failed the final checks.
    failed_periods: Vec<f64>,
    /// Strongly correlated parameters of two found effects (last final fit).
    correlated: Vec<(Kind, &'static str, Kind, &'static str, f64)>,
    /// The τ grid of the drift search (ln τ) and its columns on the subset.
    tau_grid: Vec<(f64, Vec<f64>)>,
    log: Vec<String>,
    refused: Vec<String>,
}

fn ids_of(terms: &[Term]) -> Vec<usize> {
    let mut ids = vec![CONST];
    for t in terms {
        ids.extend_from_slice(&t.cols);
    }
    ids
}

fn nonlinear(terms: &[Term]) -> usize {
    terms.iter().map(|t| t.variant.nonlinear()).sum()
}

/// Golden-section minimisation of `f` on [lo, hi].
fn golden(mut lo: f64, mut hi: f64, iters: usize, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut a = hi - g * (hi - lo);
    let mut b = lo + g * (hi - lo);
    let (mut fa, mut fb) = (f(a), f(b));
    for _ in 0..iters {
        if fa <= fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - g * (hi - lo);
            fa = f(a);
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + g * (hi - lo);
            fb = f(b);
        }
    }
    if fa <= fb { (a, fa) } else { (b, fb) }
}

/// Weighted fit of `y` by a constant and `cols` on the rows `rows` (all rows: None).
fn small_fit(y: &[f64], w: &[f64], cols: &[&[f64]], rows: Option<&[usize]>) -> Fit {
    let k = cols.len() + 1;
    let mut g = vec![vec![0.0; k]; k];
    let mut gy = vec![0.0; k];
    let mut yy = 0.0;
    let mut row = vec![0.0; k];
    let mut add = |r: usize| {
        row[0] = 1.0;
        for (c, col) in cols.iter().enumerate() {
            row[c + 1] = col[r];
        }
        for a in 0..k {
            let wa = w[r] * row[a];
            gy[a] += wa * y[r];
            for b in a..k {
                g[a][b] += wa * row[b];
            }
        }
        yy += w[r] * y[r] * y[r];
    };
    match rows {
        Some(idx) => idx.iter().for_each(|&r| add(r)),
        None => (0..y.len()).for_each(add),
    }
    for a in 0..k {
        for b in 0..a {
            g[a][b] = g[b][a];
        }
    }
    solve(&g, &gy, yy)
}

/// χ² of a weighted fit of `y` by a constant and `cols` (all of length n).
fn small_chi2(y: &[f64], w: &[f64], cols: &[&[f64]]) -> f64 {
    let k = cols.len() + 1;
    let mut g = vec![vec![0.0; k]; k];
    let mut gy = vec![0.0; k];
    let mut yy = 0.0;
    let mut row = vec![0.0; k];
    for r in 0..y.len() {
        row[0] = 1.0;
        for (c, col) in cols.iter().enumerate() {
            row[c + 1] = col[r];
        }
        let wr = w[r];
        for a in 0..k {
            let wa = wr * row[a];
            gy[a] += wa * y[r];
            for b in a..k {
                g[a][b] += wa * row[b];
            }
        }
        yy += wr * y[r] * y[r];
    }
    for a in 0..k {
        for b in 0..a {
            g[a][b] = g[b][a];
        }
    }
    solve(&g, &gy, yy).chi2
}

impl<'a> Selector<'a> {
    pub fn new(
        obs: &'a Obs,
        cfg: &'a DiagnoseConfig,
        y: Vec<f64>,
        w: Vec<f64>,
        fold: Vec<usize>,
        nfolds: usize,
        spectrum: Option<(Vec<PeriodCand>, Broad, f64)>,
    ) -> Self {
        let mut engine = Engine::new(y, w, fold, nfolds);
        let cols = effects::register(&mut engine, obs, cfg.laser_wavelength_um);
        let kinds = effects::kinds(&cols);
        // Rows for the period search: the moving ones when there are enough (see
        // `spectral_search`), an evenly spaced subset of them.
        let moving: Vec<usize> = (0..obs.len()).filter(|&k| obs.moving[k]).collect();
        let period_rows: Vec<usize> = if moving.len() >= MIN_MOVING_FOR_SCAN {
            moving
        } else {
            (0..obs.len()).collect()
        };
        let sub: Vec<usize> = spectral::subset(period_rows.len(), cfg.spectral_max_rows.max(50))
            .into_iter()
            .map(|k| period_rows[k])
            .collect();
        let searched_rms = spectrum.as_ref().map(|s| s.2);
        let (periods, broad) = spectrum.map(|s| (s.0, s.1)).unwrap_or_default();
        Selector {
            obs,
            cfg,
            engine,
            cols,
            kinds,
            periods,
            broad,
            searched_rms,
            sub,
            failed: Vec::new(),
            failed_periods: Vec::new(),
            correlated: Vec::new(),
            tau_grid: Vec::new(),
            log: Vec::new(),
            refused: Vec::new(),
        }
    }

    pub fn untestable(&self) -> &[String] {
        &self.cols.untestable
    }

    fn n(&self) -> usize {
        self.engine.n()
    }

    fn model_bic(&self, fit: &Fit, nonlin: usize) -> f64 {
        bic(fit.chi2, self.n(), fit.rank + nonlin)
    }

    fn residual(&self, ids: &[usize], fit: &Fit) -> Vec<f64> {
        let pred = self.engine.predict(ids, &fit.coef);
        self.engine
            .y()
            .iter()
            .zip(&pred)
            .map(|(y, p)| y - p)
            .collect()
    }

    fn weighted_rms(&self, v: &[f64]) -> f64 {
        let w = self.engine.w();
        let sw: f64 = w.iter().sum();
        (v.iter().zip(w).map(|(r, w)| w * r * r).sum::<f64>() / sw.max(1e-300)).sqrt()
    }

    fn sub_of(&self, v: &[f64]) -> Vec<f64> {
        self.sub.iter().map(|&k| v[k]).collect()
    }

    // ---------------------------------------------------------------- spectral search

    /// Periodogram candidates on the current residual: narrow windows around the
    /// grating-tied periods and a broad scan of long periods (detrended by a cubic in x).
    fn spectral_search(&mut self, resid: &[f64], keep: &[f64]) {
        let cfg = self.cfg;
        let (lo, hi) = self
            .obs
            .x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let span = (hi - lo).max(1e-3);
        let mut cands: Vec<PeriodCand> = Vec::new();
        let n = self.obs.len();
        // Rows for a scan of `nf` frequencies: within the row·frequency budget.
        // The scans use the moving rows when there are enough: their positions are
        // independent draws of the phase, while all samples of a dwell share one (and
        // dwell targets on a round pitch put many periods in phase, so a sine would fit
        // the dwell-vs-moving offset at many frequencies).
        let moving: Vec<usize> = (0..n).filter(|&k| self.obs.moving[k]).collect();
        let base: Vec<usize> = if moving.len() >= MIN_MOVING_FOR_SCAN {
            moving
        } else {
            (0..n).collect()
        };
        let rows_for = |nf: usize| -> Vec<usize> {
            let by_budget = (cfg.spectral_budget / nf.max(1) as f64) as usize;
            spectral::subset(
                base.len(),
                by_budget.clamp(200, cfg.spectral_max_rows.max(200)),
            )
            .into_iter()
            .map(|k| base[k])
            .collect()
        };
        let pick = |idx: &[usize], v: &[f64]| -> Vec<f64> { idx.iter().map(|&k| v[k]).collect() };

        // Windows around grating-tied periods.
        let mut centres: Vec<(f64, String)> = Vec::new();
        let gratings: Vec<f64> = match cfg.grating_period_um {
            Some(p) => vec![p],
            None => super::COMMON_GRATINGS_UM.to_vec(),
        };
        for &p in &gratings {
            for (div, name) in [(1.0, "P"), (2.0, "P/2"), (4.0, "P/4")] {
                let c = p / div;
                if centres.iter().all(|(q, _)| (q - c).abs() > 1e-9 * c) {
                    centres.push((c, format!("{name} of the {p} µm grating")));
                }
            }
        }
        let plan: Vec<(f64, String, f64, f64, usize)> = centres
            .into_iter()
            .map(|(c, label)| {
                let fc = 1000.0 / c;
                let half = cfg.period_window_rel * fc;
                let mut df = 1.0 / (2.0 * span);
                let mut nf = (2.0 * half / df).ceil() as usize + 1;
                if nf > 4000 {
                    df = 2.0 * half / 3999.0;
                    nf = 4000;
                }
                (fc - half, label, df, fc, nf)
            })
            .collect();
        let total: usize = plan.iter().map(|p| p.4).sum();
        let idx = rows_for(total);
        let (x, w, r) = (
            pick(&idx, &self.obs.x),
            pick(&idx, self.engine.w()),
            pick(&idx, resid),
        );
        let mut window_peaks: Vec<PeriodCand> = Vec::new();
        for (f0, label, df, _fc, nf) in plan {
            let pw = spectral::scan(&x, &r, &w, f0, df, nf);
            if let Some(&k) = spectral::peaks(&pw, 1, 1).first() {
                let f = f0 + k as f64 * df;
                window_peaks.push(PeriodCand {
                    period_um: 1000.0 / f,
                    power: pw[k],
                    label,
                    step_um: 1000.0 * df / (f * f),
                    refined_um: None,
                });
            }
        }
        window_peaks.sort_by(|a, b| b.power.total_cmp(&a.power));
        cands.extend(window_peaks.into_iter().take(3));

        // Broad scan of long periods on the residual minus a cubic in x.
        let fmin = 1.0 / (MAX_BROAD_FRACTION * span);
        let fmax = 1.0 / cfg.broad_min_period_mm.max(1e-3);
        if fmax > fmin {
            // One point per resolution element; the golden-section refinement of a
            // candidate recovers the peak between two grid points.
            let mut df = 1.0 / span;
            let mut nf = ((fmax - fmin) / df).ceil() as usize + 1;
            if nf > 8000 {
                df = (fmax - fmin) / 7999.0;
                nf = 8000;
            }
            let idx = rows_for(nf);
            let (x, w, r) = (
                pick(&idx, &self.obs.x),
                pick(&idx, self.engine.w()),
                pick(&idx, resid),
            );
            let xc: Vec<f64> = x.iter().map(|v| (v - lo) / span * 2.0 - 1.0).collect();
            let detrended = detrend_cubic(&xc, &r, &w);
            let pw = spectral::scan(&x, &detrended, &w, fmin, df, nf);
            for k in spectral::peaks(&pw, 5, 2) {
                let f = fmin + k as f64 * df;
                cands.push(PeriodCand {
                    period_um: 1000.0 / f,
                    power: pw[k],
                    label: "broad periodogram".into(),
                    step_um: 1000.0 * df / (f * f),
                    refined_um: None,
                });
            }
            self.broad = Broad {
                period_mm: (0..nf).map(|k| 1.0 / (fmin + k as f64 * df)).collect(),
                power: pw,
            };
        }
        // The new search replaces the old candidates (it ran on a cleaner residual), except
        // those of the periodic terms already in the model (`keep`): their peaks are gone
        // from this residual, and a later pass with other weights needs them.
        let mut merged = cands;
        for old in std::mem::take(&mut self.periods) {
            let near = |p: f64, q: f64| (p - q).abs() <= 3.0 * old.step_um;
            if keep.iter().any(|&p| near(p, old.period_um)) {
                // It replaces a new peak at the same period (whose power was measured
                // with the term already removed).
                match merged.iter().position(|c| near(c.period_um, old.period_um)) {
                    Some(k) => merged[k] = old,
                    None => merged.insert(0, old),
                }
            }
        }
        merged.truncate(MAX_PERIOD_CANDIDATES);
        self.periods = merged;
    }

    /// Refines a period on `resid`: on the search subset, or on all rows (`full`).
    fn refine_period(&self, resid: &[f64], p: f64, step: f64, iters: usize, full: bool) -> f64 {
        let (x, w, r) = if full {
            // The last refinement, within half a grid step of the optimum: all rows, so
            // that the period is the optimum of the same χ² its uncertainty comes from.
            (self.obs.x.clone(), self.engine.w().to_vec(), resid.to_vec())
        } else {
            (
                self.sub_of(&self.obs.x),
                self.sub_of(self.engine.w()),
                self.sub_of(resid),
            )
        };
        let (best, _) = golden(p - step, p + step, iters, |q| {
            let [s, c] = effects::periodic_cols(&x, q);
            small_chi2(&r, &w, &[&s, &c])
        });
        if best > 0.0 && best <= self.max_period_um() {
            best
        } else {
            p
        }
    }

    /// The spacing of successive moving samples, mm, one per feed: feed × sample interval.
    /// Along a move at constant speed the samples sit on a lattice of this pitch, so the
    /// scale's counter quantisation — and anything else tied to the counter's grid — is
    /// in phase at every one of them; a periodogram shows that as peaks at the pitch and
    /// its sub-multiples.
    fn sampling_lattices_mm(&self) -> Vec<f64> {
        let o = self.obs;
        let mut by_feed: BTreeMap<i64, Vec<f64>> = BTreeMap::new();
        for seg in &o.moves {
            for w in seg.windows(2) {
                let (a, b) = (w[0], w[1]);
                let dx = (o.x[b] - o.x[a]).abs();
                if o.v_feed[b] > 0.0 && dx > 0.0 {
                    by_feed
                        .entry((o.v_feed[b] * 1000.0).round() as i64)
                        .or_default()
                        .push(dx);
                }
            }
        }
        by_feed
            .into_values()
            .filter(|v| v.len() >= 10)
            .map(|mut v| {
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            })
            .collect()
    }

    /// Why a found `dead_path` is not physical: with the model's own dead path D₀ known,
    /// D₀ + D more than two sigmas below zero.
    fn negative_dead_path(&self, f: &FittedTerm) -> Option<String> {
        let d0 = self.cfg.model_dead_path_mm?;
        if f.term.kind != Kind::DeadPath {
            return None;
        }
        let p = f.params.iter().find(|p| p.name == "dead_path_mm")?;
        (d0 + p.value < -2.0 * p.sigma).then(|| {
            format!(
                "dead_path_mm = {:.1} ± {:.1} on the model's {d0:.1} mm makes the dead path {:.1} mm: \
                 a length cannot be negative",
                p.value,
                p.sigma,
                d0 + p.value
            )
        })
    }

    /// Longest period a periodic term may have, µm.
    fn max_period_um(&self) -> f64 {
        let (lo, hi) = self
            .obs
            .x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        1000.0 * MAX_BROAD_FRACTION * (hi - lo).max(1e-3) * 1.05
    }

    /// Whether a periodic term (columns `s`, `c`) is supported by the data the way a
    /// periodic scale error is, on `resid` (the residual without it):
    /// - on the moving rows alone, whose positions are independent draws of the phase
    ///   (rows of one dwell share their phase, so unmodelled structure at a few dwell
    ///   positions can mimic a short period): Δχ² ≥ [`MOVING_SUPPORT_CHI2`];
    /// - along the axis: its amplitude in each third of the x range agrees with the
    ///   whole (within 3σ or a factor of 2), as a scale's interpolation error does and a
    ///   local bump does not.
    fn periodic_support(&self, resid: &[f64], s: &[f64], c: &[f64]) -> Result<(), String> {
        let w = self.engine.w();
        let n = resid.len();
        let whole = small_fit(resid, w, &[s, c], None);
        let amp = whole.coef[1].hypot(whole.coef[2]);
        let moving: Vec<usize> = (0..n).filter(|&k| self.obs.moving[k]).collect();
        if moving.len() >= 50 {
            let base = small_fit(resid, w, &[], Some(&moving)).chi2;
            let with = small_fit(resid, w, &[s, c], Some(&moving));
            let dof = (moving.len() as f64 - 3.0).max(1.0);
            let s2 = (with.chi2 / dof).max(1e-300);
            let gain = (base - with.chi2) / s2;
            if gain < MOVING_SUPPORT_CHI2 {
                return Err(format!(
                    "not supported by the moving samples alone (Δχ² = {gain:.1} < {MOVING_SUPPORT_CHI2})"
                ));
            }
        }
        let (lo, hi) = self
            .obs
            .x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let third = (hi - lo) / 3.0;
        for part in 0..3 {
            let a = lo + part as f64 * third;
            let b = if part == 2 { hi + 1.0 } else { a + third };
            let rows: Vec<usize> = (0..n)
                .filter(|&k| self.obs.x[k] >= a && self.obs.x[k] < b)
                .collect();
            if rows.len() < 30 {
                continue;
            }
            let f = small_fit(resid, w, &[s, c], Some(&rows));
            let dof = (rows.len() as f64 - 3.0).max(1.0);
            let s2 = f.chi2 / dof;
            let (sc, cc) = (f.coef[1], f.coef[2]);
            let ap = sc.hypot(cc).max(1e-300);
            let var = ((sc / ap).powi(2) * f.cov[1][1]
                + 2.0 * (sc / ap) * (cc / ap) * f.cov[1][2]
                + (cc / ap).powi(2) * f.cov[2][2])
                * s2;
            let sd = var.max(0.0).sqrt();
            let tol = 3.0 * sd;
            if ap + tol < 0.5 * amp || ap - tol > 2.0 * amp {
                return Err(format!(
                    "its amplitude is not uniform along the axis ({ap:.4} ± {sd:.4} µm at {}–{} mm against {amp:.4} µm overall)",
                    super::fixed(a, 0),
                    super::fixed(b.min(hi), 0)
                ));
            }
        }
        Ok(())
    }

    /// Best τ of an exponential drift profiled jointly with the columns `base` (variable
    /// projection: every trial τ refits all linear parameters on all rows), on a grid of
    /// ln τ from span/50 to 3·span (columns cached), or around `around`, then golden
    /// section. O(n·k) per trial.
    fn profile_tau(&mut self, base: &[usize], around: Option<f64>) -> f64 {
        let t0 = self.obs.t0;
        let (lo, hi) = match around {
            Some(tau) => (tau.ln() - 0.4, tau.ln() + 0.4),
            None => {
                if self.tau_grid.is_empty() {
                    let span = self
                        .obs
                        .t
                        .iter()
                        .fold(0.0f64, |m, &v| m.max(v - t0))
                        .max(1e-6);
                    let (a, b) = ((span / 50.0).ln(), (span * 3.0).ln());
                    let m = TAU_GRID;
                    self.tau_grid = (0..m)
                        .map(|k| {
                            let g = a + (b - a) * k as f64 / (m - 1) as f64;
                            (g, effects::drift_col(&self.obs.t, t0, g.exp()))
                        })
                        .collect();
                }
                let grid = std::mem::take(&mut self.tau_grid);
                let vals: Vec<f64> = grid
                    .iter()
                    .map(|(_, col)| self.engine.fit_with(base, &[col]).chi2)
                    .collect();
                let k = (0..vals.len())
                    .min_by(|&i, &j| vals[i].total_cmp(&vals[j]))
                    .unwrap_or(0);
                let h = grid[1].0 - grid[0].0;
                let bracket = (grid[k].0 - h, grid[k].0 + h);
                self.tau_grid = grid;
                bracket
            }
        };
        let t = self.obs.t.clone();
        golden(lo, hi, GOLDEN_ITERS, |lt| {
            let col = effects::drift_col(&t, t0, lt.exp());
            self.engine.fit_with(base, &[&col]).chi2
        })
        .0
        .exp()
    }

    // ---------------------------------------------------------------- evaluation

    /// Evaluates `kind` added to `terms`: every variant; returns the best determined
    /// full-rank one and the best of any kind (for notes and ambiguities).
    fn evaluate(
        &mut self,
        terms: &[Term],
        kind: Kind,
        resid: &[f64],
        strict: bool,
    ) -> (Option<Eval>, Option<Eval>) {
        let ids = ids_of(terms);
        let base = self.engine.fit(&ids);
        let nl = nonlinear(terms);
        let mut evals: Vec<Eval> = Vec::new();
        for (variant, cols) in effects::static_variants(kind, &self.cols) {
            let mut all = ids.clone();
            all.extend_from_slice(&cols);
            let fit = self.engine.fit(&all);
            evals.push(self.make_eval(
                kind,
                variant,
                Cand::Reg(cols),
                &fit,
                base.rank,
                nl,
                ids.len(),
            ));
        }
        match kind {
            Kind::Periodic => {
                let selected: Vec<f64> = terms
                    .iter()
                    .filter_map(|t| match t.variant {
                        Variant::Periodic { period_um } => Some(period_um),
                        _ => None,
                    })
                    .collect();
                let rms = self.weighted_rms(resid);
                if self
                    .searched_rms
                    .is_none_or(|r| rms < RESEARCH_FRACTION * r)
                {
                    self.spectral_search(resid, &selected);
                    self.searched_rms = Some(rms);
                }
                let base_bic = self.model_bic(&base, nl);
                for k in 0..self.periods.len() {
                    let pc = self.periods[k].clone();
                    if pc.power < MIN_CANDIDATE_POWER
                        || selected
                            .iter()
                            .chain(&self.failed_periods)
                            .any(|&p| (p - pc.period_um).abs() < 3.0 * pc.step_um)
                    {
                        continue;
                    }
                    let p = match pc.refined_um {
                        Some(p) => p,
                        None => {
                            let p = self.refine_period(
                                resid,
                                pc.period_um,
                                pc.step_um,
                                GOLDEN_ITERS,
                                false,
                            );
                            self.periods[k].refined_um = Some(p);
                            p
                        }
                    };
                    let [s, c] = effects::periodic_cols(&self.obs.x, p);
                    let fit = self.engine.fit_with(&ids, &[&s, &c]);
                    let mut e = self.make_eval(
                        kind,
                        Variant::Periodic { period_um: p },
                        Cand::Trial(Vec::new()),
                        &fit,
                        base.rank,
                        nl,
                        ids.len(),
                    );
                    // The support check only matters for a candidate that would enter.
                    if e.undetermined.is_none()
                        && base_bic - e.bic >= self.cfg.min_delta_bic
                        && let Err(why) = self.periodic_support(resid, &s, &c)
                    {
                        e.undetermined = Some(why);
                    }
                    e.cand = Cand::Trial(vec![s, c]);
                    evals.push(e);
                }
            }
            Kind::ThermalDrift if self.cols.t_lin.is_some() => {
                let tau = self.profile_tau(&ids, None);
                let col = effects::drift_col(&self.obs.t, self.obs.t0, tau);
                let fit = self.engine.fit_with(&ids, &[&col]);
                evals.push(self.make_eval(
                    kind,
                    Variant::DriftExp { tau_s: tau },
                    Cand::Trial(vec![col]),
                    &fit,
                    base.rank,
                    nl,
                    ids.len(),
                ));
            }
            _ => {}
        }
        let mut best: Option<Eval> = None;
        let mut any: Option<Eval> = None;
        for e in evals {
            if e.rank_new == 0
                || self
                    .failed
                    .contains(&(e.kind, std::mem::discriminant(&e.variant)))
            {
                continue;
            }
            let ok = e.full && (!strict || e.undetermined.is_none());
            if ok && best.as_ref().is_none_or(|b| e.bic < b.bic) {
                best = Some(e.clone());
            }
            if any.as_ref().is_none_or(|b| e.bic < b.bic) {
                any = Some(e);
            }
        }
        (best, any)
    }

    #[allow(clippy::too_many_arguments)]
    fn make_eval(
        &self,
        kind: Kind,
        variant: Variant,
        cand: Cand,
        fit: &Fit,
        base_rank: usize,
        nl: usize,
        k0: usize,
    ) -> Eval {
        let k = fit.coef.len() - k0;
        let rank_new = fit.rank.saturating_sub(base_rank);
        let full = (k0..fit.coef.len()).all(|i| fit.independent[i]);
        let bic = bic(fit.chi2, self.n(), fit.rank + nl + variant.nonlinear());
        let dof = (self.n() as f64 - fit.rank as f64 - 1.0).max(1.0);
        let s2 = fit.chi2 / dof;
        let mut th: Vec<f64> = (k0..k0 + k).map(|i| fit.coef[i]).collect();
        let mut cov: Vec<Vec<f64>> = (k0..k0 + k)
            .map(|i| (k0..k0 + k).map(|j| fit.cov[i][j] * s2).collect())
            .collect();
        if variant.nonlinear() > 0 {
            th.push(match variant {
                Variant::Periodic { period_um } => period_um,
                Variant::DriftExp { tau_s } => tau_s,
                _ => 0.0,
            });
            for row in &mut cov {
                row.push(0.0);
            }
            cov.push(vec![0.0; k + 1]);
        }
        let undetermined = if full {
            let ps = effects::params(kind, &variant, &th, &cov);
            effects::undetermined(&ps, self.cfg.max_relative_uncertainty).map(|p| {
                format!(
                    "{} = {:.4} ± {:.4} is not determined",
                    p.name, p.value, p.sigma
                )
            })
        } else {
            Some("its signature is not independent of the other effects on these data".into())
        };
        Eval {
            kind,
            variant,
            cand,
            bic,
            rank_new,
            full,
            undetermined,
        }
    }

    fn adopt(&mut self, e: Eval) -> Term {
        let cols = match e.cand {
            Cand::Reg(c) => c,
            Cand::Trial(v) => v.into_iter().map(|c| self.engine.add(c)).collect(),
        };
        Term {
            kind: e.kind,
            variant: e.variant,
            cols,
        }
    }

    /// Re-optimises every nonlinear parameter on its partial residual (the data minus the
    /// other terms), then the caller refits jointly.
    fn refine_nonlinear(&mut self, terms: &mut [Term], full: bool) {
        for i in 0..terms.len() {
            if terms[i].variant.nonlinear() == 0 {
                continue;
            }
            let ids = ids_of(terms);
            let fit = self.engine.fit(&ids);
            let own: Vec<usize> = terms[i].cols.clone();
            let mut others_ids = Vec::new();
            let mut others_coef = Vec::new();
            for (p, &id) in ids.iter().enumerate() {
                if id != CONST && !own.contains(&id) {
                    others_ids.push(id);
                    others_coef.push(fit.coef[p]);
                }
            }
            let pred = self.engine.predict(&others_ids, &others_coef);
            let partial: Vec<f64> = self
                .engine
                .y()
                .iter()
                .zip(&pred)
                .map(|(y, p)| y - p)
                .collect();
            let iters = if full { 2 * GOLDEN_ITERS } else { GOLDEN_ITERS };
            match terms[i].variant {
                Variant::Periodic { period_um } => {
                    let step = self
                        .periods
                        .iter()
                        .map(|p| p.step_um * (period_um / p.period_um).powi(2))
                        .fold(f64::INFINITY, f64::min);
                    let step = if step.is_finite() {
                        step
                    } else {
                        period_um * 1e-5
                    };
                    let p = self.refine_period(&partial, period_um, 0.5 * step, iters, full);
                    let [s, c] = effects::periodic_cols(&self.obs.x, p);
                    terms[i].cols = vec![self.engine.add(s), self.engine.add(c)];
                    terms[i].variant = Variant::Periodic { period_um: p };
                }
                Variant::DriftExp { tau_s } => {
                    let mut base = vec![CONST];
                    base.extend(others_ids.iter().copied());
                    let tau = self.profile_tau(&base, Some(tau_s));
                    let col = effects::drift_col(&self.obs.t, self.obs.t0, tau);
                    terms[i].cols = vec![self.engine.add(col)];
                    terms[i].variant = Variant::DriftExp { tau_s: tau };
                }
                _ => {}
            }
        }
    }

    /// Re-chooses the variant of every term given the others (a linear drift chosen
    /// first may be exponential once the others are in; x0, θ0/θ1, the speed used by the
    /// latch delay, the air columns of refraction likewise). Periodic terms keep theirs.
    fn revise_variants(&mut self, terms: &mut [Term]) {
        for i in 0..terms.len() {
            let kind = terms[i].kind;
            if kind == Kind::Periodic {
                continue;
            }
            let current = self.bic_of(terms);
            let mut rest = terms.to_vec();
            rest.remove(i);
            let ids = ids_of(&rest);
            let fit = self.engine.fit(&ids);
            let resid = self.residual(&ids, &fit);
            let (best, _) = self.evaluate(&rest, kind, &resid, true);
            if let Some(b) = best
                && b.variant != terms[i].variant
                && b.bic < current - 1e-6
            {
                self.log.push(format!(
                    "revise {}: {:?} → {:?} (BIC −{:.1})",
                    kind.label(self.obs),
                    terms[i].variant,
                    b.variant,
                    current - b.bic
                ));
                terms[i] = self.adopt(b);
            }
        }
    }

    fn bic_of(&mut self, terms: &[Term]) -> f64 {
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        self.model_bic(&fit, nonlinear(terms))
    }

    fn allowed(&self, kind: Kind, terms: &[Term]) -> bool {
        let same = terms.iter().filter(|t| t.kind == kind).count();
        match kind {
            Kind::Periodic => same < MAX_PERIODIC,
            _ => same == 0,
        }
    }

    // ---------------------------------------------------------------- the passes

    /// Forward selection, nonlinear refinement, backward check, swap moves and
    /// cross-validation, from the constant alone.
    fn select_terms(&mut self) -> Vec<Term> {
        let n = self.n();
        let cfg = self.cfg;
        let fit0 = self.engine.fit(&[CONST]);

        // 1. Forward selection.
        let mut terms: Vec<Term> = Vec::new();
        let mut cur_bic = self.model_bic(&fit0, 0);
        self.log
            .push(format!("start: constant only, BIC {cur_bic:.1} (n = {n})"));
        while terms.len() < cfg.max_effects {
            let ids = ids_of(&terms);
            let fit = self.engine.fit(&ids);
            let resid = self.residual(&ids, &fit);
            let mut best: Vec<Eval> = Vec::new();
            let kinds = self.kinds.clone();
            for kind in kinds {
                if !self.allowed(kind, &terms) {
                    continue;
                }
                let (b, _) = self.evaluate(&terms, kind, &resid, true);
                if let Some(b) = b {
                    best.push(b);
                }
            }
            let Some(min) = best.iter().map(|e| e.bic).min_by(f64::total_cmp) else {
                break;
            };
            let chosen = best
                .into_iter()
                .filter(|e| e.bic <= min + TIE_BIC)
                .min_by_key(|e| e.kind.preference());
            let Some(chosen) = chosen else { break };
            let gain = cur_bic - chosen.bic;
            if gain < cfg.min_delta_bic {
                self.log.push(format!(
                    "stop: the best remaining candidate, {}, would change BIC by {:+.1} (an effect needs ≤ −{})",
                    chosen.kind.label(self.obs),
                    -gain,
                    cfg.min_delta_bic
                ));
                break;
            }
            self.log.push(format!(
                "add {} ({:?}): BIC −{gain:.1}",
                chosen.kind.label(self.obs),
                chosen.variant
            ));
            let term = self.adopt(chosen);
            terms.push(term);
            self.refine_nonlinear(&mut terms, false);
            self.revise_variants(&mut terms);
            cur_bic = self.bic_of(&terms);
        }

        // 2. Nonlinear parameters on all rows; backward check and swap moves until
        //    neither changes the model (an effect that entered while another was poorly
        //    fitted may have become redundant, or a better one may take its place).
        self.refine_nonlinear(&mut terms, true);
        for _ in 0..MAX_SWAP_ROUNDS {
            self.backward(&mut terms);
            if !self.swap(&mut terms) {
                break;
            }
            self.refine_nonlinear(&mut terms, true);
            self.revise_variants(&mut terms);
        }

        // 3. Cross-validation (nonlinear parameters fixed).
        if cfg.cv_confirm {
            loop {
                if terms.is_empty() {
                    break;
                }
                let full = self.engine.cv(&ids_of(&terms)).mse;
                let mut best: Option<(usize, f64)> = None;
                for i in 0..terms.len() {
                    let mut t = terms.clone();
                    t.remove(i);
                    let m = self.engine.cv(&ids_of(&t)).mse;
                    if best.is_none_or(|(_, b)| m < b) {
                        best = Some((i, m));
                    }
                }
                match best {
                    Some((i, m)) if m <= full => {
                        self.log.push(format!(
                            "cross-validation: remove {} (held-out error {:.5} without it ≤ {:.5} with it)",
                            terms[i].kind.label(self.obs),
                            m,
                            full
                        ));
                        terms.remove(i);
                    }
                    _ => break,
                }
            }
        }
        terms
    }

    /// Removes, one at a time, effects whose removal costs less than `min_delta_bic`.
    fn backward(&mut self, terms: &mut Vec<Term>) {
        while !terms.is_empty() {
            let full = self.bic_of(terms);
            let mut worst: Option<(usize, f64)> = None;
            for i in 0..terms.len() {
                let mut t = terms.clone();
                t.remove(i);
                let d = self.bic_of(&t) - full;
                if worst.is_none_or(|(_, w)| d < w) {
                    worst = Some((i, d));
                }
            }
            match worst {
                Some((i, d)) if d < self.cfg.min_delta_bic => {
                    self.log.push(format!(
                        "backward: remove {} (removal costs only {d:.1} BIC)",
                        terms[i].kind.label(self.obs)
                    ));
                    terms.remove(i);
                }
                _ => break,
            }
        }
    }

    /// Replaces one effect by another testable one when that lowers BIC by at least
    /// `min_delta_bic` (the greedy forward path can settle on a worse explanation).
    /// Periodic terms are neither swapped in nor out. Returns whether it swapped.
    fn swap(&mut self, terms: &mut [Term]) -> bool {
        let full = self.bic_of(terms);
        let kinds = self.kinds.clone();
        let mut best: Option<(usize, Eval)> = None;
        for i in 0..terms.len() {
            if terms[i].kind == Kind::Periodic {
                continue;
            }
            let mut rest = terms.to_vec();
            rest.remove(i);
            let ids = ids_of(&rest);
            let fit = self.engine.fit(&ids);
            let resid = self.residual(&ids, &fit);
            for &kind in &kinds {
                if kind == Kind::Periodic || terms.iter().any(|t| t.kind == kind) {
                    continue;
                }
                if let (Some(e), _) = self.evaluate(&rest, kind, &resid, true)
                    && e.bic < full - self.cfg.min_delta_bic
                    && best.as_ref().is_none_or(|(_, b)| e.bic < b.bic)
                {
                    best = Some((i, e));
                }
            }
        }
        match best {
            Some((i, e)) => {
                self.log.push(format!(
                    "swap: {} → {} ({:?}), BIC −{:.1}",
                    terms[i].kind.label(self.obs),
                    e.kind.label(self.obs),
                    e.variant,
                    full - e.bic
                ));
                terms[i] = self.adopt(e);
                true
            }
            None => false,
        }
    }

    /// The first reason not to report a selected term: a periodic term without support,
    /// an undetermined parameter, an implausible one.
    fn first_problem(&mut self, terms: &[Term], fitted: &[FittedTerm]) -> Option<(usize, String)> {
        let cfg = self.cfg;
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        let resid = self.residual(&ids, &fit);
        for (i, f) in fitted.iter().enumerate() {
            if f.term.kind == Kind::Periodic {
                let without: Vec<f64> = resid
                    .iter()
                    .zip(&f.contribution)
                    .map(|(r, c)| r + c)
                    .collect();
                let (s, c) = (
                    self.engine.col(f.term.cols[0]),
                    self.engine.col(f.term.cols[1]),
                );
                if let Err(why) = self.periodic_support(&without, s, c) {
                    return Some((i, why));
                }
            }
            let why = effects::undetermined(&f.params, cfg.max_relative_uncertainty)
                .map(|p| {
                    format!(
                        "{} = {:.4} ± {:.4} is not determined (one-sigma above {:.0} % of the value)",
                        p.name,
                        p.value,
                        p.sigma,
                        100.0 * cfg.max_relative_uncertainty
                    )
                })
                .or_else(|| effects::implausible(f.term.kind, &f.params, self.obs))
                .or_else(|| self.negative_dead_path(f));
            if let Some(w) = why {
                return Some((i, w));
            }
        }
        None
    }

    /// Runs the whole selection: [`Self::select_terms`], then the final checks; a term
    /// that fails them is refused, its variant (or period) excluded, and the selection
    /// starts again without it, so a better explanation can take its place.
    pub fn run(mut self) -> Outcome {
        let n = self.n();
        let cfg = self.cfg;
        let mut terms;
        let mut fitted;
        let mut restarts = 0;
        loop {
            terms = self.select_terms();
            fitted = self.final_fit(&terms);
            let Some((i, why)) = self.first_problem(&terms, &fitted) else {
                break;
            };
            let kind = terms[i].kind;
            self.refused.push(format!(
                "{} ({}) is not reported: {why}",
                kind.label(self.obs),
                variant_words(&terms[i].variant)
            ));
            match terms[i].variant {
                Variant::Periodic { period_um } => self.failed_periods.push(period_um),
                ref v => self.failed.push((kind, std::mem::discriminant(v))),
            }
            restarts += 1;
            if restarts > MAX_RESTARTS {
                // Give up refining: drop every failing term.
                while let Some((i, _)) = self.first_problem(&terms, &fitted) {
                    terms.remove(i);
                    fitted = self.final_fit(&terms);
                }
                break;
            }
            self.log
                .push("selection restarted without the refused variant".into());
        }

        // 5. Too small to matter, repeated until nothing more is dropped (the effects
        // left after a drop are refitted, and one may shrink below its floor).
        // Counter quantisation is uniform over a step q (standard uncertainty q/√12), and
        // with sampling locked to the counter's grid it is constant along a move and differs
        // between moves: N independent offsets, not one per row. An effect with k
        // parameters fitted to them picks up about (q/√12)·√(k/N) RMS by chance; the floor
        // is three times that, at most q/√12. (On a 0.1 µm counter clean sessions show
        // 0.008–0.018 µm of such structure with N = 36–48 moves; a real 0.12 µm drift over
        // the session is 0.027 µm.)
        let q_sigma = self.obs.quantum_um / 12f64.sqrt();
        let moves = self.obs.moves.len().max(1) as f64;
        let lattices = self.sampling_lattices_mm();
        loop {
            let ids = ids_of(&terms);
            let fit = self.engine.fit(&ids);
            let dof = (n as f64 - fit.rank as f64).max(1.0);
            let sigma_w = (fit.chi2 / dof).sqrt();
            let mean_w = self.engine.w().iter().sum::<f64>() / n as f64;
            let noise_rms = sigma_w / mean_w.sqrt();
            let mut keep = Vec::new();
            let mut small = Vec::new();
            for f in fitted {
                let rms = centred_rms(&f.contribution);
                // A period that divides the moving samples' pitch sees them all in one
                // phase within a move, like the quantisation error: it must exceed the
                // whole of one count's quantisation uncertainty (on a 0.1 µm counter such
                // peaks at 0.6 mm for a 2.4 mm pitch explain 0.014–0.023 µm RMS in
                // sessions without them).
                let alias = match f.term.variant {
                    Variant::Periodic { period_um } => lattice_alias(period_um / 1000.0, &lattices),
                    _ => None,
                };
                let k = f.params.len().max(1) as f64;
                let quantisation = if alias.is_some() {
                    q_sigma
                } else {
                    (3.0 * q_sigma * (k / moves).sqrt()).min(q_sigma)
                };
                if rms < cfg.min_effect_fraction_of_noise * noise_rms {
                    small.push(format!(
                        "{} is significant but explains only {rms:.4} µm RMS (< {} × noise {noise_rms:.4} µm): not reported",
                        f.term.kind.label(self.obs),
                        cfg.min_effect_fraction_of_noise
                    ));
                } else if rms < quantisation {
                    small.push(format!(
                        "{} is significant but explains only {rms:.4} µm RMS, less than {} \
                         ({:.4} µm counter step: {quantisation:.4} µm): not reported",
                        f.term.kind.label(self.obs),
                        if alias.is_some() {
                            "one count's quantisation uncertainty (its period divides the moving samples' pitch)"
                        } else {
                            "what counter quantisation fits by chance"
                        },
                        self.obs.quantum_um
                    ));
                } else {
                    keep.push(f);
                }
            }
            if small.is_empty() {
                fitted = keep;
                break;
            }
            self.refused.extend(small);
            terms = keep.iter().map(|f| f.term.clone()).collect();
            fitted = self.final_fit(&terms);
        }

        // 6. Ambiguities, design notes, scores.
        let ambiguities = self.ambiguities(&terms);
        let design = self.design_notes();
        let scores = self.scores(&terms);

        let ids = ids_of(&terms);
        let fit = self.engine.fit(&ids);
        let model = self.engine.predict(&ids, &fit.coef);
        let cv = self.engine.cv(&ids);
        let mut cv_pred = vec![0.0; n];
        let fold = self.engine.fold().to_vec();
        for (k, p) in cv_pred.iter_mut().enumerate() {
            let c = &cv.coefs[fold[k]];
            *p = ids
                .iter()
                .zip(c)
                .map(|(&id, &b)| b * self.engine.col(id)[k])
                .sum();
        }
        Outcome {
            terms: fitted,
            model,
            cv_pred,
            ambiguities,
            correlated: self.correlated.clone(),
            refused: self.refused.clone(),
            design,
            log: self.log.clone(),
            periods: self.periods.clone(),
            broad: self.broad.clone(),
            searched_rms: self.searched_rms.unwrap_or(f64::INFINITY),
            scores,
        }
    }

    /// Joint fit with the covariance of every term's parameters at the optimum.
    fn final_fit(&mut self, terms: &[Term]) -> Vec<FittedTerm> {
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        let n = self.n();
        // Jacobian columns: the linear ones, then one derivative per nonlinear term.
        let mut jac: Vec<Vec<f64>> = ids.iter().map(|&id| self.engine.col(id).to_vec()).collect();
        let mut nl_index: Vec<Option<usize>> = Vec::new();
        let mut offset = 1;
        for t in terms {
            let coef = &fit.coef[offset..offset + t.cols.len()];
            offset += t.cols.len();
            match effects::nonlinear_derivative(&t.variant, coef, self.obs) {
                Some(dcol) => {
                    nl_index.push(Some(jac.len()));
                    jac.push(dcol);
                }
                None => nl_index.push(None),
            }
        }
        let p = jac.len();
        let w = self.engine.w();
        let mut jtj = vec![vec![0.0; p]; p];
        for a in 0..p {
            for b in a..p {
                let (ja, jb) = (&jac[a], &jac[b]);
                let mut s = 0.0;
                for k in 0..n {
                    s += w[k] * ja[k] * jb[k];
                }
                jtj[a][b] = s;
                jtj[b][a] = s;
            }
        }
        let inv = pinv_sym(&jtj);
        let dof = (n as f64 - p as f64).max(1.0);
        let s2 = fit.chi2 / dof;
        // Parameters of different effects that the data hardly separate.
        let mut owner: Vec<Option<(usize, &'static str)>> = vec![None; p];
        let mut offset = 1;
        for (ti, t) in terms.iter().enumerate() {
            let names = effects::coef_names(t.kind, &t.variant);
            for (q, name) in names.iter().take(t.cols.len()).enumerate() {
                owner[offset + q] = Some((ti, name));
            }
            offset += t.cols.len();
            if let (Some(j), Some(name)) = (nl_index[ti], names.get(t.cols.len())) {
                owner[j] = Some((ti, name));
            }
        }
        self.correlated.clear();
        for a in 0..p {
            for b in a + 1..p {
                if let (Some((ta, na)), Some((tb, nb))) = (owner[a], owner[b])
                    && ta != tb
                {
                    let d = (inv[a][a] * inv[b][b]).sqrt();
                    let rho = if d > 0.0 { inv[a][b] / d } else { 0.0 };
                    if rho.abs() > CORRELATED
                        && self
                            .correlated
                            .iter()
                            .all(|c| (c.0, c.2) != (terms[ta].kind, terms[tb].kind))
                    {
                        self.correlated
                            .push((terms[ta].kind, na, terms[tb].kind, nb, rho));
                    }
                }
            }
        }
        let mut out = Vec::new();
        let mut offset = 1;
        for (ti, t) in terms.iter().enumerate() {
            let lin: Vec<usize> = (offset..offset + t.cols.len()).collect();
            offset += t.cols.len();
            let mut idx = lin.clone();
            let mut th: Vec<f64> = lin.iter().map(|&i| fit.coef[i]).collect();
            if let Some(j) = nl_index[ti] {
                idx.push(j);
                th.push(match t.variant {
                    Variant::Periodic { period_um } => period_um,
                    Variant::DriftExp { tau_s } => tau_s,
                    _ => 0.0,
                });
            }
            let cov: Vec<Vec<f64>> = idx
                .iter()
                .map(|&a| idx.iter().map(|&b| inv[a][b] * s2).collect())
                .collect();
            let params = effects::params(t.kind, &t.variant, &th, &cov);
            let coef: Vec<f64> = lin.iter().map(|&i| fit.coef[i]).collect();
            let contribution = self.engine.predict(&t.cols, &coef);
            out.push(FittedTerm {
                term: t.clone(),
                params,
                contribution,
            });
        }
        out
    }

    /// Every found effect replaced in turn by every other testable kind.
    fn ambiguities(&mut self, terms: &[Term]) -> Vec<Ambiguity> {
        let mut out = Vec::new();
        if terms.is_empty() {
            return out;
        }
        let full = self.bic_of(terms);
        let kinds = self.kinds.clone();
        for i in 0..terms.len() {
            let mut rest = terms.to_vec();
            let found = rest.remove(i);
            let ids = ids_of(&rest);
            let fit = self.engine.fit(&ids);
            let resid = self.residual(&ids, &fit);
            for &kind in &kinds {
                if kind == found.kind || terms.iter().any(|t| t.kind == kind) {
                    continue;
                }
                if kind == Kind::Periodic || found.kind == Kind::Periodic {
                    continue;
                }
                let (best, _) = self.evaluate(&rest, kind, &resid, true);
                if let Some(e) = best {
                    let d = e.bic - full;
                    if d < self.cfg.ambiguity_delta_bic {
                        out.push(Ambiguity {
                            found: found.kind,
                            alt: kind,
                            delta_bic: d,
                        });
                    }
                }
            }
        }
        out
    }

    /// Pairs of testable effects whose signatures coincide on this data set (independent
    /// of the residual): A's columns are explained (1 − R² < 1e−4) by B's and a constant.
    fn design_notes(&mut self) -> Vec<String> {
        let mut out = Vec::new();
        let primary: Vec<(Kind, Vec<usize>)> = self
            .kinds
            .iter()
            .filter_map(|&k| {
                effects::static_variants(k, &self.cols)
                    .into_iter()
                    .next()
                    .map(|(_, c)| (k, c))
            })
            .collect();
        let mut contained = |a: &[usize], b: &[usize]| -> bool {
            let mut base = vec![CONST];
            base.extend_from_slice(b);
            a.iter().all(|&c| {
                let tot = self.engine.unexplained(&[CONST], c);
                let res = self.engine.unexplained(&base, c);
                tot <= 0.0 || res <= 1e-4 * tot
            })
        };
        for (i, (ka, ca)) in primary.iter().enumerate() {
            for (j, (kb, cb)) in primary.iter().enumerate() {
                if i == j || !contained(ca, cb) {
                    continue;
                }
                let mutual = contained(cb, ca);
                if mutual && j < i {
                    continue; // said once, for the first of the pair
                }
                let (a, b) = (ka.label(self.obs), kb.label(self.obs));
                let what = if mutual {
                    format!("{a} and {b} are indistinguishable on these data (+ offset)")
                } else {
                    format!("{a} is indistinguishable from {b} (+ offset) on these data")
                };
                out.push(format!(
                    "{what}: {}",
                    super::separation_advice(*ka, *kb, self.obs)
                ));
            }
        }
        out
    }

    /// ΔBIC of every testable kind against the final model.
    fn scores(&mut self, terms: &[Term]) -> Vec<(Kind, f64)> {
        let full = self.bic_of(terms);
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        let resid = self.residual(&ids, &fit);
        let mut out = Vec::new();
        let kinds = self.kinds.clone();
        for kind in kinds {
            if let Some(i) = terms.iter().position(|t| t.kind == kind) {
                let mut t = terms.to_vec();
                t.remove(i);
                out.push((kind, self.bic_of(&t) - full));
            } else if self.allowed(kind, terms) {
                let (b, a) = self.evaluate(terms, kind, &resid, true);
                if let Some(a) = &a
                    && full - a.bic >= self.cfg.min_delta_bic
                    && b.as_ref()
                        .is_none_or(|b| full - b.bic < self.cfg.min_delta_bic)
                {
                    self.refused.push(format!(
                        "{} would lower BIC by {:.1} but is not reported: {}",
                        kind.label(self.obs),
                        full - a.bic,
                        a.undetermined
                            .as_deref()
                            .unwrap_or("its signature is not independent of the found effects")
                    ));
                }
                if let Some(e) = b.or(a) {
                    out.push((kind, e.bic - full));
                }
            }
        }
        out
    }
}

/// A variant in words, for messages.
fn variant_words(v: &Variant) -> String {
    match v {
        Variant::Single => "as fitted".into(),
        Variant::X0Fixed => "x0 = 0".into(),
        Variant::X0Free => "x0 free".into(),
        Variant::AbbeFull => "θ0 and θ1".into(),
        Variant::AbbeTheta0 => "θ0 only".into(),
        Variant::AbbeTheta1 => "θ1 only".into(),
        Variant::LatchFeed => "v = feed".into(),
        Variant::LatchMeasured => "v measured".into(),
        Variant::RefrBoth => "air temperature and pressure".into(),
        Variant::RefrT => "air temperature only".into(),
        Variant::RefrP => "air pressure only".into(),
        Variant::DriftExp { tau_s } => format!("exponential, τ = {tau_s:.0} s"),
        Variant::DriftLinear => "linear".into(),
        Variant::Periodic { period_um } => format!("period {period_um:.4} µm"),
    }
}

/// RMS about the mean.
pub(crate) fn centred_rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Residual minus its weighted cubic fit in `xc` (∈ [−1, 1]).
fn detrend_cubic(xc: &[f64], r: &[f64], w: &[f64]) -> Vec<f64> {
    let k = 4;
    let mut g = vec![vec![0.0; k]; k];
    let mut gy = vec![0.0; k];
    for i in 0..r.len() {
        let row = [1.0, xc[i], xc[i] * xc[i], xc[i] * xc[i] * xc[i]];
        for a in 0..k {
            gy[a] += w[i] * row[a] * r[i];
            for b in 0..k {
                g[a][b] += w[i] * row[a] * row[b];
            }
        }
    }
    let f = solve(&g, &gy, 0.0);
    (0..r.len())
        .map(|i| {
            let row = [1.0, xc[i], xc[i] * xc[i], xc[i] * xc[i] * xc[i]];
            r[i] - (0..k).map(|a| f.coef[a] * row[a]).sum::<f64>()
        })
        .collect()
}

#[cfg(test)]
mod lattice_tests {
    use super::lattice_alias;

    #[test]
    fn sub_multiples_of_the_sampling_pitch_are_aliases() {
        // 120 mm/s at 50 Hz: a 2.4 mm pitch; 60 mm/s: 1.2 mm.
        let pitches = [2.4, 1.2];
        assert_eq!(lattice_alias(0.6, &pitches), Some(2.4));
        assert_eq!(lattice_alias(0.599_97, &pitches), Some(2.4));
        assert_eq!(lattice_alias(1.2, &pitches), Some(2.4));
        assert_eq!(lattice_alias(0.7, &pitches), None);
        assert_eq!(lattice_alias(5.0, &pitches), None);
        assert_eq!(lattice_alias(0.6, &[]), None);
    }
}
