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
//! 6. **Every parameter.** A term selected in a reduced variant (x0 = 0, θ0 or θ1 alone,
//!    one air column of refraction) is refitted jointly with the others in its full
//!    variant, so every vocabulary parameter is reported with its one-sigma; the added
//!    ones are not held to the determinedness rule ("consistent with zero" is an answer,
//!    said in `where`). Selection, ΔBIC and ambiguities are those of the selected variants.
//!
//! **Files**, in call order (each calls only the ones below it; all share the types and
//! the small accessors of this file):
//!
//! | file | holds |
//! |---|---|
//! | `mod.rs` | the types, [`Selector::new`], the driver [`Selector::run`] (passes 1–3 in [`Selector::select_terms`], the restart after 4, the quantisation floor) |
//! | `backward` | step 2: backward removal, swap moves, variants revised given the others |
//! | `summary` | step 5 and the report's extras: ambiguities, design notes, every candidate's ΔBIC |
//! | `candidates` | one effect against the current model: its variants, BIC, rank, determinedness |
//! | `checks` | step 4: final fit with covariance, periodic support, undetermined or implausible parameters, the sampling lattices of the quantisation floor |
//! | `nonlinear` | periodogram search, refinement of a period and of a drift's τ (golden section) |
//!
//! `candidates` sits below `backward` and `summary`, and `checks` and `nonlinear` below
//! `candidates`, so no two files call each other.

mod backward;
mod candidates;
mod checks;
mod decide;
mod nonlinear;
mod summary;

use super::DiagnoseConfig;
use super::data::Obs;
use super::effects::{self, Columns, Kind, Param, Variant};
use super::engine::{CONST, Engine, Fit, bic};
use super::spectral;
pub(crate) use crate::base::centred_rms;

use checks::lattice_alias;
pub(crate) use decide::Decision;
use nonlinear::MIN_MOVING_FOR_SCAN;

/// Candidates whose BIC is within this of the best are a tie (numerically or
/// statistically identical fits), settled by preference.
pub(crate) const TIE_BIC: f64 = 1.0;

/// Rounds of backward check and swap moves.
const MAX_SWAP_ROUNDS: usize = 3;

/// Restarts of the selection after a refused term.
const MAX_RESTARTS: usize = 4;

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
    /// Why a vocabulary parameter was not fitted (for `where`).
    pub notes: Vec<String>,
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
    /// Choices between inseparable effects made on physical grounds.
    pub decisions: Vec<Decision>,
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
    /// `candidates::RESEARCH_FRACTION` of it: a strong effect removed, weaker periods can show.
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

impl<'a> Selector<'a> {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        obs: &'a Obs,
        cfg: &'a DiagnoseConfig,
        y: Vec<f64>,
        w: Vec<f64>,
        fold: Vec<usize>,
        nfolds: usize,
        spectrum: Option<(Vec<PeriodCand>, Broad, f64)>,
        static_map: Option<crate::diagnose::engine::MapGroups>,
    ) -> Self {
        let mapped = static_map.is_some();
        let mut engine = Engine::new(y, w, fold, nfolds, static_map);
        let mut cols = effects::register(&mut engine, obs, cfg.laser_wavelength_um);
        let mut kinds = effects::kinds(&cols);
        if mapped {
            // Functions of line, target and direction are the static map itself.
            kinds.retain(|k| !matches!(k, Kind::ScaleFactor | Kind::Reversal | Kind::Abbe(_)));
            cols.untestable.push(
                "scale_factor, reversal, abbe: part of the static map taken from the recording itself (the mean error per line, target and direction), so not tested"
                    .into(),
            );
        }
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

    pub(super) fn untestable(&self) -> &[String] {
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

    fn bic_of(&mut self, terms: &[Term]) -> f64 {
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        self.model_bic(&fit, nonlinear(terms))
    }

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

    /// Runs the whole selection: [`Self::select_terms`], then the final checks; a term
    /// that fails them is refused, its variant (or period) excluded, and the selection
    /// starts again without it, so a better explanation can take its place.
    /// Steps 1–4 with restarts: selects, fits and checks; a term failing the checks is
    /// refused and its variant (or period) excluded, and the selection starts again (at
    /// most `MAX_RESTARTS` times, then every failing term is dropped).
    fn select_with_restarts(&mut self) -> (Vec<Term>, Vec<FittedTerm>) {
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

        (terms, fitted)
    }

    /// Step 5: drops the effects too small to matter against the noise or the counter's
    /// quantisation, refitting the rest until nothing more is dropped.
    fn drop_small(&mut self, mut terms: Vec<Term>, mut fitted: Vec<FittedTerm>) -> Vec<Term> {
        let n = self.n();
        let cfg = self.cfg;
        // Too small to matter, repeated until nothing more is dropped (the effects
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
            let dof = (n as f64 - fit.rank as f64 - self.engine.absorbed() as f64).max(1.0);
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
                break;
            }
            self.refused.extend(small);
            terms = keep.iter().map(|f| f.term.clone()).collect();
            fitted = self.final_fit(&terms);
        }
        terms
    }

    /// Each row's leave-one-fold-out prediction by the terms `ids`.
    fn cv_predictions(&mut self, ids: &[usize]) -> Vec<f64> {
        let n = self.n();
        let cv = self.engine.cv(ids);
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
        cv_pred
    }

    pub(super) fn run(mut self) -> Outcome {
        let (mut terms, fitted) = self.select_with_restarts();

        // 5. Too small to matter.
        terms = self.drop_small(terms, fitted);

        // 6. Ambiguities, design notes, scores (on the selected variants).
        let mut ambiguities = self.ambiguities(&terms);
        let mut decisions = Vec::new();
        if let Some(d) = self.decide_dead_path(&mut terms, &ambiguities) {
            // Swapped by physics: the ambiguities are the new term's.
            if ambiguities.iter().all(|a| a.found != d.chosen) {
                ambiguities = self.ambiguities(&terms);
            }
            decisions.push(d);
        }
        let design = self.design_notes();
        let scores = self.scores(&terms);

        // 7. Every parameter of each found effect, fitted jointly.
        let (terms, fitted) = self.complete(&terms);

        let ids = ids_of(&terms);
        let fit = self.engine.fit(&ids);
        let model = self.engine.predict(&ids, &fit.coef);
        let cv_pred = self.cv_predictions(&ids);
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
            decisions,
        }
    }
}

/// A variant in words, for messages.
fn variant_words(v: &Variant) -> String {
    match v {
        Variant::Single => "as fitted".into(),
        Variant::ReversalLinear => "reversal linear in position".into(),
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
