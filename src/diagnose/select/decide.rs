//! Deciding with physics between two effects these data cannot tell apart: a dead path
//! against a thermal drift ([`Selector::decide_dead_path`]). When the air changes
//! monotonically during the session, −D·(n(t) − n(t0)) is a smooth function of time and a
//! drift fits it as well; the fit alone would settle the tie by preference. A metrologist
//! asks instead whether the dead path the fit needs is a length the set-up's optics can
//! have: D_total = D_model + D between zero and the beam length from the interferometer
//! to the measurement's zero point (`DiagnoseConfig::max_dead_path_mm`; without it, the
//! axis travel, stated as an assumption), within two of its sigmas. A possible length
//! keeps `dead_path` (a measured covariate explains the residual); an impossible one
//! reports `thermal_drift`. Either way the basis is stated and the measurement that
//! separates them is written out as a plan (`effects::separation_plan`).
//!
//! Called from [`Selector::run`]; calls `candidates` and `checks`.

use crate::base::ParamName as P;
use crate::diagnose::effects::{self, Kind};
use crate::diagnose::words::fixed;

use super::{Ambiguity, Selector, Term, ids_of};

/// A choice between two inseparable effects made on physical grounds.
#[derive(Debug, Clone)]
pub(crate) struct Decision {
    /// The effect reported.
    pub chosen: Kind,
    /// The one it could not be told apart from.
    pub other: Kind,
    /// The basis of the choice, in words.
    pub basis: String,
    /// The measurement that separates them, as a plan file (TOML) the simulator and
    /// `errmap plan` read.
    pub plan_toml: String,
}

impl Selector<'_> {
    /// Decides between `dead_path` and `thermal_drift` when one was found and the other
    /// is an ambiguity; replaces the term when physics says the other. Returns the
    /// decision (None: no such ambiguity).
    pub(super) fn decide_dead_path(
        &mut self,
        terms: &mut [Term],
        ambiguities: &[Ambiguity],
    ) -> Option<Decision> {
        let i = terms
            .iter()
            .position(|t| matches!(t.kind, Kind::DeadPath | Kind::ThermalDrift))?;
        let found = terms[i].kind;
        let other = if found == Kind::DeadPath {
            Kind::ThermalDrift
        } else {
            Kind::DeadPath
        };
        ambiguities
            .iter()
            .find(|a| a.found == found && a.alt == other)?;
        let mut rest = terms.to_vec();
        rest.remove(i);
        let ids = ids_of(&rest);
        let fit = self.engine.fit(&ids);
        let resid = self.residual(&ids, &fit);
        // The dead-path explanation fitted jointly with the other terms.
        let dp_term = if found == Kind::DeadPath {
            terms[i].clone()
        } else {
            let (e, _) = self.evaluate(&rest, Kind::DeadPath, &resid, false);
            self.adopt(e?)
        };
        let mut dp_terms = rest.clone();
        dp_terms.insert(i, dp_term.clone());
        let fitted = self.final_fit(&dp_terms);
        let p = fitted[i].params.iter().find(|p| p.name == P::DeadPathMm)?;
        let (d, sd) = (p.value, p.sigma);
        let d0 = self.cfg.model_dead_path_mm.unwrap_or(0.0);
        let total = d0 + d;
        let (lo, hi) = crate::diagnose::words::range(&self.obs.x);
        let travel = hi - lo;
        let (bound, bound_words) = match self.cfg.max_dead_path_mm {
            Some(b) => (
                b,
                format!(
                    "the set-up's {} mm from the interferometer to the zero point",
                    fixed(b, 0)
                ),
            ),
            None => (
                travel,
                format!(
                    "the axis travel, {} mm (no set-up bound was given, so the interferometer is taken to be within one travel of the zero point)",
                    fixed(travel, 0)
                ),
            ),
        };
        let model_words = match self.cfg.model_dead_path_mm {
            Some(m) => format!(
                "the model's {} mm + the fitted {}",
                fixed(m, 0),
                fixed(d, 0)
            ),
            None => "the simulation is taken to have none".to_string(),
        };
        let head = format!(
            "dead_path and thermal_drift fit these data equally (the air changed monotonically, so −D·Δn(t) is a smooth function of time); decided by physics: the dead path the fit needs is {} ± {} mm ({model_words})",
            fixed(total, 0),
            fixed(sd, 0)
        );
        let chosen = if total < -2.0 * sd {
            let basis = format!(
                "{head}, a negative length: the residual is a drift of the machine, not a dead path"
            );
            (Kind::ThermalDrift, basis)
        } else if total > bound + 2.0 * sd {
            let basis = format!(
                "{head}, longer than {bound_words}: no beam of this set-up is that long, so the residual is a drift of the machine, not a dead path"
            );
            (Kind::ThermalDrift, basis)
        } else {
            let basis = format!(
                "{head}, a length between 0 and {bound_words}: possible for the optics, so the residual is reported as the dead path, which a measured covariate (the air) explains without a free function of time"
            );
            (Kind::DeadPath, basis)
        };
        let (kind, basis) = chosen;
        if kind != found {
            let term = if kind == Kind::DeadPath {
                Some(dp_term)
            } else {
                let (e, _) = self.evaluate(&rest, Kind::ThermalDrift, &resid, true);
                e.map(|e| self.adopt(e))
            };
            match term {
                Some(t) => {
                    self.log.push(format!(
                        "physics: {} → {} ({basis})",
                        found.label(self.obs),
                        kind.label(self.obs)
                    ));
                    terms[i] = t;
                }
                None => return None,
            }
        }
        Some(Decision {
            chosen: kind,
            other: if kind == Kind::DeadPath {
                Kind::ThermalDrift
            } else {
                Kind::DeadPath
            },
            basis,
            plan_toml: effects::separation_plan(self.obs, Kind::DeadPath, Kind::ThermalDrift)?,
        })
    }
}
