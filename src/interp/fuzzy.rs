//! The Gaussian-membership fuzzy interpolator (Agbegha, Guo and Bai 2011,
//! Section III, Eqs. 8–13).
//!
//! Each cell has 8 rules, one per corner ("if x is W, y is N and z is U then e is P₁" …).
//! Along each axis the input has two Gaussian-bell memberships, centred on the cell's low
//! and high node with width σ·h (h the cell size, σ a fraction of it):
//! μ_lo(u) = exp(−u²/2σ²), μ_hi(u) = exp(−(1−u)²/2σ²), u = (x − x_lo)/h.
//! Rules fire with the product of their three memberships, and the centre-of-gravity
//! output (Eq. 10) is the weighted mean of the 8 corner errors. Because the memberships
//! factor per axis, the normalised weight of the high node along one axis is
//!
//! w_hi(u) = μ_hi / (μ_lo + μ_hi) = 1 / (1 + exp(−(2u − 1)/(2σ²))),
//!
//! a logistic function of position with slope 1/σ² at the cell centre. σ → 0 gives the
//! nearest corner's error; σ → ∞ gives the mean of the 8 corners. The weights are
//! evaluated in this logistic form, so they stay in [0, 1] and finite far outside the
//! grid, where the end cell is used and the prediction tends to the nearest end node's
//! error (flagged as extrapolation).
//!
//! The paper does not publish the membership width. The default σ = 0.5 puts each bell's
//! one-sigma point at the cell centre, so the two bells cross at exp(−½) ≈ 0.61 there, the
//! shape drawn in the paper's Fig. 5a (bells spanning the ±10 mm half-cells of a 20 mm
//! cell). With σ = 0.5 the method smooths: at a node the far side still weighs
//! 1/(1 + e²) ≈ 0.12 per axis, so it does not pass through the node values. Cost: as
//! trilinear, plus one exponential per axis.

use super::{InterpError, Interpolator, Locator, eval_cells, locators};
use crate::table::Grid;

/// Default membership width as a fraction of the cell size.
pub const DEFAULT_SIGMA: f64 = 0.5;

/// Fuzzy interpolator over a grid.
#[derive(Debug, Clone)]
pub struct Fuzzy {
    grid: Grid,
    loc: [Locator; 3],
    /// 1/(2σ²), the logistic slope factor.
    k: f64,
}

/// Normalised weight of the high node at relative position `u`, for 1/(2σ²) = `k`.
#[inline]
pub fn high_weight(u: f64, k: f64) -> f64 {
    let z = (2.0 * u - 1.0) * k;
    // Numerically stable logistic: never exp of a large positive number.
    if z >= 0.0 {
        1.0 / (1.0 + (-z).exp())
    } else {
        let e = z.exp();
        e / (1.0 + e)
    }
}

impl Fuzzy {
    /// σ must be positive and finite.
    pub fn new(grid: &Grid, sigma: f64) -> Result<Self, InterpError> {
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(InterpError::BadSigma { sigma });
        }
        Ok(Self {
            grid: grid.clone(),
            loc: locators(grid),
            k: 1.0 / (2.0 * sigma * sigma),
        })
    }
}

impl Interpolator for Fuzzy {
    fn predict(&self, p: [f64; 3]) -> f64 {
        let k = self.k;
        eval_cells(&self.grid, &self.loc, p, |u| {
            let hi = high_weight(u, k);
            [1.0 - hi, hi]
        })
    }

    fn outside(&self, p: [f64; 3]) -> bool {
        self.grid.outside(p)
    }
}
