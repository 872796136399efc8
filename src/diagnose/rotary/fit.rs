//! The joint least-squares fit of the rotary diagnosis on dwell means: a constant and the
//! candidates' columns, each dwell one observation (its samples share the dwell's
//! positioning offset). σ̂² = RSS/(K − p) from the dwell residuals, the covariance
//! σ̂²·(XᵀX)⁻¹.

use nalgebra::{DMatrix, DVector};

use super::effects::{ARCSEC_PER_DEG_PPM, RotaryDrift, RotaryEffect};

/// One dwell (run, direction, target): its mean e and its covariates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Dwell {
    pub(super) run: u32,
    pub(super) direction: i8,
    pub(super) theta_deg: f64,
    /// Mean time of its samples since t0, s.
    pub(super) t_s: f64,
    pub(super) e_arcsec: f64,
}

/// A searched term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Candidate {
    Harmonic(u32),
    Reversal,
    Scale,
    DriftLinear,
    DriftExp(f64),
}

impl Candidate {
    /// The same id (one effect per id, per N for the harmonics).
    pub(super) fn same_slot(&self, other: &Candidate) -> bool {
        use Candidate::*;
        match (self, other) {
            (Harmonic(a), Harmonic(b)) => a == b,
            (DriftLinear | DriftExp(_), DriftLinear | DriftExp(_)) => true,
            _ => std::mem::discriminant(self) == std::mem::discriminant(other),
        }
    }

    pub(super) fn width(&self) -> usize {
        if matches!(self, Candidate::Harmonic(_)) {
            2
        } else {
            1
        }
    }

    /// The column values at (θ, d, t).
    pub(super) fn columns(&self, theta_deg: f64, d: i8, t_s: f64, out: &mut Vec<f64>) {
        match *self {
            Candidate::Harmonic(n) => {
                let a = (f64::from(n) * theta_deg).to_radians();
                out.push(a.sin());
                out.push(a.cos());
            }
            Candidate::Reversal => out.push(f64::from(d) / 2.0),
            Candidate::Scale => out.push(theta_deg * ARCSEC_PER_DEG_PPM),
            Candidate::DriftLinear => out.push(t_s),
            Candidate::DriftExp(tau) => out.push(1.0 - (-t_s / tau).exp()),
        }
    }

    /// The effect from its coefficients.
    pub(super) fn effect(&self, c: &[f64]) -> RotaryEffect {
        match *self {
            Candidate::Harmonic(n) => {
                let amplitude = c[0].hypot(c[1]);
                let phase = c[1].atan2(c[0]).to_degrees().rem_euclid(360.0);
                RotaryEffect::harmonic(n, amplitude, phase)
            }
            Candidate::Reversal => RotaryEffect::Reversal { b_arcsec: c[0] },
            Candidate::Scale => RotaryEffect::ScaleFactor { ppm: c[0] },
            Candidate::DriftLinear => RotaryEffect::ThermalDrift(RotaryDrift::Linear {
                rate_arcsec_per_s: c[0],
            }),
            Candidate::DriftExp(tau_s) => RotaryEffect::ThermalDrift(RotaryDrift::Exponential {
                amplitude_arcsec: c[0],
                tau_s,
            }),
        }
    }
}

/// A joint fit: coefficients (constant first), covariance, RSS, σ̂².
#[derive(Debug, Clone)]
pub(super) struct Fit {
    pub(super) coef: Vec<f64>,
    pub(super) cov: DMatrix<f64>,
    pub(super) rss: f64,
    pub(super) sigma2: f64,
}

/// The design matrix of `set` over `dwells` (a constant column first).
fn design(dwells: &[Dwell], set: &[Candidate]) -> DMatrix<f64> {
    let p = 1 + set.iter().map(Candidate::width).sum::<usize>();
    let mut x = DMatrix::zeros(dwells.len(), p);
    let mut row = Vec::with_capacity(p);
    for (k, w) in dwells.iter().enumerate() {
        row.clear();
        row.push(1.0);
        for c in set {
            c.columns(w.theta_deg, w.direction, w.t_s, &mut row);
        }
        for (j, v) in row.iter().enumerate() {
            x[(k, j)] = *v;
        }
    }
    x
}

/// Least squares of the dwell means on the constant and `set`; `None` when the columns
/// are not independent on these dwells (a harmonic aliased by the targets) or there are
/// no degrees of freedom left.
pub(super) fn fit(dwells: &[Dwell], set: &[Candidate]) -> Option<Fit> {
    let x = design(dwells, set);
    let (n, p) = x.shape();
    if n <= p {
        return None;
    }
    // Columns scaled to unit norm before inverting: θ in ° and t in s differ by orders.
    let scale: Vec<f64> = (0..p).map(|j| x.column(j).norm().max(1e-300)).collect();
    let mut xs = x.clone();
    for (j, s) in scale.iter().enumerate() {
        xs.column_mut(j).scale_mut(1.0 / s);
    }
    let y = DVector::from_iterator(n, dwells.iter().map(|w| w.e_arcsec));
    let xtx = xs.transpose() * &xs;
    let svd = xtx.clone().svd(false, false);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    if smin.is_nan() || smin <= smax * 1e-10 {
        return None;
    }
    let inv = xtx.try_inverse()?;
    let bs = &inv * (xs.transpose() * &y);
    let resid = &y - &xs * &bs;
    let rss = resid.norm_squared();
    let sigma2 = rss / (n - p) as f64;
    let coef: Vec<f64> = (0..p).map(|j| bs[j] / scale[j]).collect();
    let mut cov = inv * sigma2;
    for i in 0..p {
        for j in 0..p {
            cov[(i, j)] /= scale[i] * scale[j];
        }
    }
    Some(Fit {
        coef,
        cov,
        rss,
        sigma2,
    })
}

/// Predicted r of the fitted set (constant included) at (θ, d, t).
pub(super) fn predict(set: &[Candidate], coef: &[f64], theta_deg: f64, d: i8, t_s: f64) -> f64 {
    let mut row = vec![1.0];
    for c in set {
        c.columns(theta_deg, d, t_s, &mut row);
    }
    row.iter().zip(coef).map(|(a, b)| a * b).sum()
}
