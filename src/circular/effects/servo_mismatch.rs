//! `servo_mismatch`: axis A lags its command by τ_A, B by τ_B; `dt_ms` = τ_A − τ_B.
//!
//! Signature: s·(v·dt/2)·sin 2θ (v in mm/s, dt in ms): an oval along 45°/135° that turns
//! over between ccw and cw. With one direction only it is the same sin 2θ term as
//! `squareness`, which then carries all of it: it is left out of the fit.

use nalgebra::DMatrix;

use super::{Contribution, Family, Motion, Term, Wording, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The largest lag difference a servo mismatch may have, ms.
const MAX_DT_MS: f64 = 1000.0;

/// The difference `dt_ms` of the two axes' servo lags (> 0: A lags more).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoMismatch {
    pub dt_ms: f64,
}

impl Family for ServoMismatch {
    const NAME: &'static str = "servo_mismatch";
    const PARAMS: &'static [P] = &[P::DtMs];
    const SLOTS: &'static [Slot] = &[Slot::Plane];
    const NEEDS_BOTH_DIRECTIONS: bool = true;

    fn columns(_slot: Slot, _nl: f64, p: &Point, g: &Geometry) -> [f64; 2] {
        [p.s * g.v_mm_per_s * 0.5 * (2.0 * p.theta).sin(), 0.0]
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(ServoMismatch {
            dt_ms: p.num(P::DtMs)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (
            ServoMismatch { dt_ms: coef[0] },
            vec![(P::DtMs, sd(cov, 0))],
        )
    }
}

impl Term for ServoMismatch {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::DtMs, self.dt_ms)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.dt_ms, 0.0])
    }

    /// Half the difference on each axis, in opposite senses.
    fn simulate(&self, _slot: Slot, _m: &Motion) -> Contribution {
        Contribution {
            lag_a_ms: self.dt_ms / 2.0,
            lag_b_ms: -(self.dt_ms / 2.0),
            ..Contribution::default()
        }
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::DtMs, self.dt_ms, MAX_DT_MS, "ms")
    }

    fn words(&self, w: &Wording) -> String {
        let (more, less) = w.ordered(self.dt_ms);
        format!(
            "{more} lags {:.3} ms more than {less}: an oval along 45°/135° that turns over \
             between ccw and cw",
            self.dt_ms.abs()
        )
    }
}
