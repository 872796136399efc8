//! `lateral_play`: when this axis reverses, the other one shifts by half the play,
//! e_other = +(p/2)·sgn v.
//!
//! Signature: A: −s·(p/2)·|sin θ|; B: +s·(p/2)·|cos θ| — it flips with the direction. With
//! one direction only it is 97 % correlated with `scale_mismatch` once the setup terms are
//! removed, and is left out of the fit.

use nalgebra::DMatrix;

use super::{Contribution, Family, MAX_TERM_UM, Motion, Term, Wording, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The play `p_um` the other axis shows when this one reverses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateralPlay {
    pub p_um: f64,
}

impl Family for LateralPlay {
    const NAME: &'static str = "lateral_play";
    const PARAMS: &'static [P] = &[P::PUm];
    const NEEDS_BOTH_DIRECTIONS: bool = true;

    fn columns(slot: Slot, _nl: f64, p: &Point, _g: &Geometry) -> [f64; 2] {
        match slot {
            Slot::A => [-p.s * 0.5 * p.sin_theta.abs(), 0.0],
            Slot::B | Slot::Plane => [p.s * 0.5 * p.cos_theta.abs(), 0.0],
        }
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(LateralPlay {
            p_um: p.num(P::PUm)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (LateralPlay { p_um: coef[0] }, vec![(P::PUm, sd(cov, 0))])
    }
}

impl Term for LateralPlay {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::PUm, self.p_um)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.p_um, 0.0])
    }

    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution {
        let (_, v, _) = m.axis(slot);
        Contribution::axes(slot, 0.0, (self.p_um / 2.0) * v)
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::PUm, self.p_um, MAX_TERM_UM, "µm")
    }

    fn words(&self, w: &Wording) -> String {
        format!(
            "{} shifts by {:.2} µm when {} reverses ({}); the step flips with the \
             direction of the run",
            w.other,
            self.p_um.abs() / 2.0,
            w.name,
            w.reversals
        )
    }
}
