//! Moves on a chosen model: every term's variant chosen again given the others
//! ([`Selector::revise_variants`]), backward removal of an effect that costs less than
//! `min_delta_bic` ([`Selector::backward`]), and the swap of one effect for a better one
//! ([`Selector::swap`]).
//!
//! Called from the forward pass in `mod.rs`; calls `candidates`.

use crate::diagnose::effects::Kind;

use super::{Eval, Selector, Term, ids_of};

impl Selector<'_> {
    /// Re-chooses the variant of every term given the others (a linear drift chosen
    /// first may be exponential once the others are in; x0, θ0/θ1, the speed used by the
    /// latch delay, the air columns of refraction likewise). Periodic terms keep theirs.
    pub(super) fn revise_variants(&mut self, terms: &mut [Term]) {
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

    /// Removes, one at a time, effects whose removal costs less than `min_delta_bic`.
    pub(super) fn backward(&mut self, terms: &mut Vec<Term>) {
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
    pub(super) fn swap(&mut self, terms: &mut [Term]) -> bool {
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
}
