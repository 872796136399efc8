//! One candidate effect against the current model: every variant of a kind fitted jointly
//! with the chosen terms, its BIC, rank and determinedness ([`Selector::evaluate`]); the
//! periodic candidates come from the periodogram (`nonlinear`) and must pass the support
//! check (`checks`). [`Selector::adopt`] turns the winner into a term.
//!
//! Called from `backward`, `summary` and the forward pass in `mod.rs`; calls `nonlinear`
//! and `checks`.

use crate::diagnose::effects::{self, Kind, Variant};
use crate::diagnose::engine::{Fit, bic};

use super::nonlinear::GOLDEN_ITERS;
use super::{Cand, Eval, Selector, Term, ids_of, nonlinear};

/// The periodogram is searched again when the residual's weighted RMS has fallen below
/// this fraction of the RMS it was last searched on.
const RESEARCH_FRACTION: f64 = 0.8;

/// Periodogram candidates weaker than this Δχ² (on the search subset) are not
/// evaluated: noise peaks of a scan over a few thousand frequencies reach about 15–20, and a
/// periodic term must reach `checks::MOVING_SUPPORT_CHI2` on the moving rows anyway.
const MIN_CANDIDATE_POWER: f64 = 10.0;

/// Most periodic terms in one model.
const MAX_PERIODIC: usize = 3;

impl Selector<'_> {
    /// Evaluates `kind` added to `terms`: every variant; returns the best determined
    /// full-rank one and the best of any kind (for notes and ambiguities).
    pub(super) fn evaluate(
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
                let periodic = self.periodic_evals(terms, resid, &ids, &base, nl);
                evals.extend(periodic);
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
        self.best_of(evals, strict)
    }
    /// The periodogram's candidates not yet in the model nor refused, each at its refined
    /// period, fitted; one that would enter must pass the support check on the moving rows.
    fn periodic_evals(
        &mut self,
        terms: &[Term],
        resid: &[f64],
        ids: &[usize],
        base: &Fit,
        nl: usize,
    ) -> Vec<Eval> {
        let kind = Kind::Periodic;
        let mut evals = Vec::new();
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
        let base_bic = self.model_bic(base, nl);
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
                    let p =
                        self.refine_period(resid, pc.period_um, pc.step_um, GOLDEN_ITERS, false);
                    self.periods[k].refined_um = Some(p);
                    p
                }
            };
            let [s, c] = effects::periodic_cols(&self.obs.x, p);
            let (s, c) = (self.engine.project(s), self.engine.project(c));
            let fit = self.engine.fit_with(ids, &[&s, &c]);
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
                e.undetermined = Some(why.to_string());
            }
            e.cand = Cand::Trial(vec![s, c]);
            evals.push(e);
        }
        evals
    }

    /// The best determined full-rank evaluation (determined even by the support check when
    /// `strict`) and the best of any, leaving out variants refused before.
    fn best_of(&self, evals: Vec<Eval>, strict: bool) -> (Option<Eval>, Option<Eval>) {
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
        let dof =
            (self.n() as f64 - fit.rank as f64 - 1.0 - self.engine.absorbed() as f64).max(1.0);
        let s2 = (fit.chi2 / dof).max(self.cfg.min_variance_factor);
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

    pub(super) fn adopt(&mut self, e: Eval) -> Term {
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

    pub(super) fn allowed(&self, kind: Kind, terms: &[Term]) -> bool {
        let same = terms.iter().filter(|t| t.kind == kind).count();
        match kind {
            Kind::Periodic => same < MAX_PERIODIC,
            _ => same == 0,
        }
    }
}
