//! `straightness`: the moving axis' path bows, e_other = bow·(1 − (q/R)²) (its linear part
//! is squareness, its constant the centring).
//!
//! Signature: A: bow·sin³θ ≡ −(bow/4)·sin 3θ; B: bow·cos³θ ≡ (bow/4)·cos 3θ, modulo the
//! setup terms: a three-lobed trace.

use nalgebra::DMatrix;

use super::{Contribution, Family, MAX_TERM_UM, Motion, Term, Wording, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The bow `bow_um` of the axis' path at its centre (> 0 towards +other axis, relative to
/// the chord over ±R).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Straightness {
    pub bow_um: f64,
}

impl Family for Straightness {
    const NAME: &'static str = "straightness";
    const PARAMS: &'static [P] = &[P::BowUm];

    fn columns(slot: Slot, _nl: f64, p: &Point, _g: &Geometry) -> [f64; 2] {
        match slot {
            Slot::A => [p.sin_theta.powi(3), 0.0],
            Slot::B | Slot::Plane => [p.cos_theta.powi(3), 0.0],
        }
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(Straightness {
            bow_um: p.num(P::BowUm)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (
            Straightness { bow_um: coef[0] },
            vec![(P::BowUm, sd(cov, 0))],
        )
    }
}

impl Term for Straightness {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::BowUm, self.bow_um)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.bow_um, 0.0])
    }

    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution {
        let (q, _, _) = m.axis(slot);
        Contribution::axes(slot, 0.0, self.bow_um * (1.0 - (q / m.radius_mm).powi(2)))
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::BowUm, self.bow_um, MAX_TERM_UM, "µm")
    }

    fn words(&self, w: &Wording) -> String {
        format!(
            "{}'s path bows {:.2} µm towards {}{} at mid-travel (a three-lobed trace)",
            w.name,
            self.bow_um.abs(),
            if self.bow_um >= 0.0 { "+" } else { "-" },
            w.other
        )
    }
}
