//! The nonlinear parameters of the selection: the periodogram search for periodic
//! candidates ([`Selector::spectral_search`]), the refinement of a period and the profiled
//! time constant of an exponential drift (golden section), and their re-optimisation on the
//! partial residual after every step ([`Selector::refine_nonlinear`]).
//!
//! Called from `candidates` and from the passes in `mod.rs`; calls no other file of `select`.

use crate::base::golden;
use crate::diagnose::effects::{self, Variant};
use crate::diagnose::engine::{CONST, solve};
use crate::diagnose::spectral;

use super::checks::MOVING_SUPPORT_CHI2;
use super::{Broad, PeriodCand, Selector, Term, ids_of};

/// Longest period of the broad periodogram, as a fraction of the x range: a "period"
/// with fewer than 10 cycles over the axis is a smooth shape, not a periodic error.
const MAX_BROAD_FRACTION: f64 = 0.1;

/// Most frequencies of one broad scan (beyond, the grid coarsens).
const MAX_BROAD_FREQUENCIES: usize = 20_000;

/// The shortest period of the broad search, in grating periods: shorter periods are the
/// grating-tied windows' (P, P/2, P/4), or beyond what a scale's errors hold.
pub(super) const SHORT_BAND_GRATINGS: f64 = 4.0;

/// Family-wise false-alarm probability of the periodogram search per session: the
/// support a periodic term needs on the moving rows grows with the number of independent
/// frequencies searched (a Bonferroni bound), so a wider search does not find more noise.
const SEARCH_FALSE_ALARM: f64 = 0.01;

/// Moving rows needed for the periodograms to use them alone.
pub(super) const MIN_MOVING_FOR_SCAN: usize = 200;

/// Most periodogram candidates kept across searches.
const MAX_PERIOD_CANDIDATES: usize = 10;

/// Golden-section iterations for a period or a time constant (0.618¹² ≈ 0.3 % of the
/// bracket, one grid step).
pub(super) const GOLDEN_ITERS: usize = 12;

/// Points of the τ grid of the drift search.
const TAU_GRID: usize = 16;

/// The rows the periodograms scan. The scans use the moving rows when there are enough:
/// their positions are independent draws of the phase, while all samples of a dwell share
/// one (and dwell targets on a round pitch put many periods in phase, so a sine would fit
/// the dwell-vs-moving offset at many frequencies).
struct ScanRows {
    base: Vec<usize>,
}

impl ScanRows {
    /// The moving rows, or all rows when fewer than [`MIN_MOVING_FOR_SCAN`] move.
    fn of(sel: &Selector) -> ScanRows {
        let n = sel.obs.len();
        let moving: Vec<usize> = (0..n).filter(|&k| sel.obs.moving[k]).collect();
        let base: Vec<usize> = if moving.len() >= MIN_MOVING_FOR_SCAN {
            moving
        } else {
            (0..n).collect()
        };
        ScanRows { base }
    }

    /// Rows for a scan of `nf` frequencies: within the row·frequency budget.
    fn rows_for(&self, nf: usize, cfg: &crate::diagnose::DiagnoseConfig) -> Vec<usize> {
        let base = &self.base;
        let by_budget = (cfg.spectral_budget / nf.max(1) as f64) as usize;
        spectral::subset(
            base.len(),
            by_budget.clamp(200, cfg.spectral_max_rows.max(200)),
        )
        .into_iter()
        .map(|k| base[k])
        .collect()
    }
}

/// The values of `v` at the rows `idx`.
fn pick(idx: &[usize], v: &[f64]) -> Vec<f64> {
    idx.iter().map(|&k| v[k]).collect()
}

impl Selector<'_> {
    /// Periodogram candidates on the current residual: narrow windows around the
    /// grating-tied periods and broad scans of long and short periods (detrended by a
    /// cubic in x; see [`Selector::broad_bands`]).
    pub(super) fn spectral_search(&mut self, resid: &[f64], keep: &[f64]) {
        let (lo, span) = self.x_span();
        let mut cands: Vec<PeriodCand> = Vec::new();
        let scan = ScanRows::of(self);
        // Windows around grating-tied periods.
        cands.extend(self.grating_windows(&scan, span, resid));
        // Broad scans on the residual minus a cubic in x: long periods (0.5 mm – L/10),
        // then short ones (4 grating periods – 0.5 mm), each within its own row budget.
        let (broad_cands, broad) = self.broad_scans(&scan, lo, span, resid);
        cands.extend(broad_cands);
        if !broad.power.is_empty() {
            self.broad = broad;
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

    /// The best peak of a narrow window around each grating-tied period (P, P/2, P/4 of
    /// each grating), the three strongest.
    fn grating_windows(&self, scan: &ScanRows, span: f64, resid: &[f64]) -> Vec<PeriodCand> {
        let cfg = self.cfg;
        let mut centres: Vec<(f64, String)> = Vec::new();
        let gratings: Vec<f64> = match cfg.grating_period_um {
            Some(p) => vec![p],
            None => crate::diagnose::COMMON_GRATINGS_UM.to_vec(),
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
        let idx = scan.rows_for(total, cfg);
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
        window_peaks.into_iter().take(3).collect()
    }

    /// The peaks of the broad scans of [`Selector::broad_bands`] on the residual less a
    /// cubic in x, and the scans themselves (for the report's periodogram).
    fn broad_scans(
        &self,
        scan: &ScanRows,
        lo: f64,
        span: f64,
        resid: &[f64],
    ) -> (Vec<PeriodCand>, Broad) {
        let mut cands = Vec::new();
        let mut broad = Broad::default();
        for (fmin, fmax, oversample) in self.broad_bands(span) {
            // One point per resolution element (two in the short band, where a peak is
            // narrow against the band); the golden-section refinement of a candidate
            // recovers the peak between two grid points.
            let mut df = 1.0 / (oversample * span);
            let mut nf = ((fmax - fmin) / df).ceil() as usize + 1;
            if nf > MAX_BROAD_FREQUENCIES {
                df = (fmax - fmin) / (MAX_BROAD_FREQUENCIES - 1) as f64;
                nf = MAX_BROAD_FREQUENCIES;
            }
            let idx = scan.rows_for(nf, self.cfg);
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
            broad
                .period_mm
                .extend((0..nf).map(|k| 1.0 / (fmin + k as f64 * df)));
            broad.power.extend(pw);
        }
        (cands, broad)
    }

    /// The broad scans' frequency bands, cycles/mm, with their oversampling: long periods
    /// from [`DiagnoseConfig::broad_min_period_mm`] to a tenth of the x range, and short
    /// ones from [`SHORT_BAND_GRATINGS`] grating periods (the largest of
    /// [`crate::diagnose::COMMON_GRATINGS_UM`] when the grating is unknown) up to it.
    ///
    /// [`DiagnoseConfig::broad_min_period_mm`]: crate::diagnose::DiagnoseConfig::broad_min_period_mm
    pub(super) fn broad_bands(&self, span_mm: f64) -> Vec<(f64, f64, f64)> {
        let cfg = self.cfg;
        let fmin = 1.0 / (MAX_BROAD_FRACTION * span_mm);
        let fmid = 1.0 / cfg.broad_min_period_mm.max(1e-3);
        let grating_um = cfg.grating_period_um.unwrap_or_else(|| {
            crate::diagnose::COMMON_GRATINGS_UM
                .iter()
                .copied()
                .fold(0.0, f64::max)
        });
        let fmax = 1000.0 / (SHORT_BAND_GRATINGS * grating_um);
        let mut bands = Vec::new();
        if fmid > fmin {
            bands.push((fmin, fmid, 1.0));
        }
        if fmax > fmid.max(fmin) {
            bands.push((fmid.max(fmin), fmax, 2.0));
        }
        bands
    }

    /// The lowest position and the positions' span, mm (at least 1 µm).
    fn x_span(&self) -> (f64, f64) {
        let (lo, hi) = self
            .obs
            .x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        (lo, (hi - lo).max(1e-3))
    }

    /// Δχ² a periodic term must reach on the moving rows alone: about 5σ for two
    /// parameters (25), and more when the search looked at so many independent
    /// frequencies N that noise would reach 25 somewhere: 2·ln(N/α) with α =
    /// [`SEARCH_FALSE_ALARM`] (the χ² with two degrees of freedom exceeds c with
    /// probability e^(−c/2)).
    pub(super) fn moving_support_chi2(&self) -> f64 {
        let (_, span) = self.x_span();
        let independent: f64 = self
            .broad_bands(span)
            .iter()
            .map(|&(a, b, _)| (b - a) * span)
            .sum::<f64>()
            .max(1.0);
        (2.0 * (independent / SEARCH_FALSE_ALARM).ln()).max(MOVING_SUPPORT_CHI2)
    }

    /// Refines a period on `resid`: on the search subset, or on all rows (`full`).
    pub(super) fn refine_period(
        &self,
        resid: &[f64],
        p: f64,
        step: f64,
        iters: usize,
        full: bool,
    ) -> f64 {
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

    /// Best τ of an exponential drift profiled jointly with the columns `base` (variable
    /// projection: every trial τ refits all linear parameters on all rows), on a grid of
    /// ln τ from span/50 to 3·span (columns cached), or around `around`, then golden
    /// section. O(n·k) per trial.
    pub(super) fn profile_tau(&mut self, base: &[usize], around: Option<f64>) -> f64 {
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

    /// Re-optimises every nonlinear parameter on its partial residual (the data minus the
    /// other terms), then the caller refits jointly.
    pub(super) fn refine_nonlinear(&mut self, terms: &mut [Term], full: bool) {
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
