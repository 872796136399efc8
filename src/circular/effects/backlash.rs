//! `backlash`: the axis lags half its lost motion behind the motion, e = −(b/2)·sgn v, the
//! switch at each reversal (θ = kπ for A, π/2 + kπ for B).
//!
//! Signature: A: s·(b/2)·sgn(sin θ)·cos θ; B: −s·(b/2)·sgn(cos θ)·sin θ — a step of b
//! outward at each reversal, in both directions. `b_um` < 0 is an over-compensation.

use nalgebra::DMatrix;

use super::{Contribution, Family, MAX_TERM_UM, Motion, Term, Wording, sd, sgn, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// Lost motion of one axis, µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backlash {
    pub b_um: f64,
}

impl Family for Backlash {
    const NAME: &'static str = "backlash";
    const PARAMS: &'static [P] = &[P::BUm];

    fn columns(slot: Slot, _nl: f64, p: &Point, _g: &Geometry) -> [f64; 2] {
        let (c, s_) = (p.cos_theta, p.sin_theta);
        match slot {
            Slot::A => [p.s * 0.5 * sgn(s_) * c, 0.0],
            Slot::B | Slot::Plane => [-p.s * 0.5 * sgn(c) * s_, 0.0],
        }
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(Backlash {
            b_um: p.num(P::BUm)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (Backlash { b_um: coef[0] }, vec![(P::BUm, sd(cov, 0))])
    }
}

impl Term for Backlash {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::BUm, self.b_um)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.b_um, 0.0])
    }

    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution {
        let (_, v, _) = m.axis(slot);
        Contribution::axes(slot, -(self.b_um / 2.0) * v, 0.0)
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::BUm, self.b_um, MAX_TERM_UM, "µm")
    }

    fn words(&self, w: &Wording) -> String {
        let b_um = self.b_um;
        format!(
            "{} lags {:.2} µm behind its motion: a step of {:.2} µm {} at its reversals \
             ({}), in both directions",
            w.name,
            b_um.abs() / 2.0,
            b_um.abs(),
            if b_um >= 0.0 {
                "outward"
            } else {
                "inward (over-compensated)"
            },
            w.reversals
        )
    }
}
