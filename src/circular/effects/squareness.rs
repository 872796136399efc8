//! `squareness`: +B actually runs along (α, 1), e_A = α·q_B·10⁻³; `urad` = α, > 0 when the
//! angle between +A and +B is less than 90°.
//!
//! Signature: (R·10⁻³·α/2)·sin 2θ: an oval along 45°/135°, the same in both directions.
//! With one direction only it carries the whole sin 2θ term, `servo_mismatch`'s included.

use nalgebra::DMatrix;

use super::{Contribution, Family, Motion, Term, Wording, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The largest squareness, µrad (about 0.6°).
const MAX_URAD: f64 = 10_000.0;

/// The squareness `urad` of the plane's two axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Squareness {
    pub urad: f64,
}

impl Family for Squareness {
    const NAME: &'static str = "squareness";
    const PARAMS: &'static [P] = &[P::Urad];
    const SLOTS: &'static [Slot] = &[Slot::Plane];

    fn columns(_slot: Slot, _nl: f64, p: &Point, g: &Geometry) -> [f64; 2] {
        [g.radius_mm * 1e-3 * 0.5 * (2.0 * p.theta).sin(), 0.0]
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(Squareness {
            urad: p.num(P::Urad)?,
        })
    }

    fn from_fit(coef: &[f64], _nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (Squareness { urad: coef[0] }, vec![(P::Urad, sd(cov, 0))])
    }
}

impl Term for Squareness {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::Urad, self.urad)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (0.0, [self.urad, 0.0])
    }

    fn simulate(&self, _slot: Slot, m: &Motion) -> Contribution {
        Contribution {
            a_um: self.urad * m.q_mm[1] * 1e-3,
            ..Contribution::default()
        }
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::Urad, self.urad, MAX_URAD, "µrad")
    }

    fn words(&self, w: &Wording) -> String {
        let base = format!(
            "the angle between +{} and +{} is {} than 90° by {:.2} µrad: an oval along \
             45°/135°",
            w.a(),
            w.b(),
            if self.urad >= 0.0 { "less" } else { "more" },
            self.urad.abs()
        );
        if w.both {
            format!("{base}, the same in both directions")
        } else {
            format!(
                "{base}; one direction only, so it may be servo_mismatch instead (the same \
                 sin 2θ term)"
            )
        }
    }
}
