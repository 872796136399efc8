//! `scale_mismatch`: the two axes' scales differ, e = k·q·10⁻³ (k in ppm); `ppm` = k_A − k_B
//! (the mean of the two is the radius term, which a circular test cannot tell from the
//! bar's length).
//!
//! Signature: (R·10⁻³·ppm/2)·cos 2θ: an oval along the axes, the same in both directions.

use nalgebra::DMatrix;

use super::{Contribution, Family, Motion, Term, Wording, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The largest scale difference, ppm (1 %).
const MAX_PPM: f64 = 10_000.0;

/// The difference `ppm` of the two axes' scales (> 0: A reads longer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleMismatch {
    pub ppm: f64,
}

impl Family for ScaleMismatch {
    const NAME: &'static str = "scale_mismatch";
    const PARAMS: &'static [P] = &[P::Ppm];
    const SLOTS: &'static [Slot] = &[Slot::Plane];

    fn columns(_slot: Slot, _nl: f64, p: &Point, g: &Geometry) -> [f64; 2] {
        [g.radius_mm * 1e-3 * 0.5 * (2.0 * p.theta).cos(), 0.0]
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(ScaleMismatch {
            ppm: p.num(P::Ppm)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (ScaleMismatch { ppm: coef[0] }, vec![(P::Ppm, sd(cov, 0))])
    }
}

impl Term for ScaleMismatch {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::Ppm, self.ppm)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.ppm, 0.0])
    }

    /// Half the difference on each axis, in opposite senses.
    fn simulate(&self, _slot: Slot, m: &Motion) -> Contribution {
        Contribution {
            a_um: self.ppm / 2.0 * m.q_mm[0] * 1e-3,
            b_um: -(self.ppm / 2.0 * m.q_mm[1] * 1e-3),
            ..Contribution::default()
        }
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::Ppm, self.ppm, MAX_PPM, "ppm")
    }

    fn words(&self, w: &Wording) -> String {
        let (longer, shorter) = w.ordered(self.ppm);
        format!(
            "{longer} reads {:.2} ppm longer than {shorter}: an oval along the axes, the same \
             in both directions",
            self.ppm.abs()
        )
    }
}
