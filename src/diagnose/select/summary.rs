//! What the final model is compared with, for the report: every found effect replaced
//! by every other testable one ([`Selector::ambiguities`]), pairs of effects whose
//! signatures coincide on this data set ([`Selector::design_notes`]), and every testable
//! effect's ΔBIC against the final model ([`Selector::scores`]).
//!
//! Called from [`Selector::run`]; calls `candidates`.

use crate::diagnose::effects::{self, Kind};
use crate::diagnose::engine::CONST;

use super::{Ambiguity, Selector, Term, ids_of};

impl Selector<'_> {
    /// Every found effect replaced in turn by every other testable kind.
    pub(super) fn ambiguities(&mut self, terms: &[Term]) -> Vec<Ambiguity> {
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
    pub(super) fn design_notes(&mut self) -> Vec<String> {
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
                    effects::separation_advice(*ka, *kb, self.obs)
                ));
            }
        }
        out
    }

    /// ΔBIC of every testable kind against the final model.
    pub(super) fn scores(&mut self, terms: &[Term]) -> Vec<(Kind, f64)> {
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
