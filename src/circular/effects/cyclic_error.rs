//! `cyclic_error`: a cyclic error of the axis' screw or scale, e = a·sin(2π·q/P + φ) with q
//! the axis position from the test centre.
//!
//! Signature: A: a·sin(2πR cos θ/P + φ)·cos θ; B: a·sin(2πR sin θ/P + φ)·sin θ. It is fitted
//! as two linear columns (coefficients a·cos φ and a·sin φ) for a period P scanned
//! uniformly in 1/P between max(2 mm, 8 × the travel per sample) and R/2; where the
//! samples are denser than eight per 2 mm the coarse scan averages them in bins of an
//! eighth of the shortest period (the refinement uses every sample).

use std::f64::consts::{PI, TAU};

use nalgebra::DMatrix;

use super::{Contribution, Family, MAX_TERM_UM, Motion, Sampling, Scan, Term, Wording};
use super::{positive, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The longest period a cyclic error may have, mm.
const MAX_PERIOD_MM: f64 = 10_000.0;

/// A cyclic error of amplitude `amplitude_um`, period `period_mm` of the axis' travel and
/// phase `phase_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CyclicError {
    pub amplitude_um: f64,
    pub period_mm: f64,
    pub phase_rad: f64,
}

impl Family for CyclicError {
    const NAME: &'static str = "cyclic_error";
    const PARAMS: &'static [P] = &[P::AmplitudeUm, P::PeriodMm, P::PhaseRad];
    const WIDTH: usize = 2;

    fn scan(sampling: &Sampling) -> Option<Scan> {
        let r = sampling.radius_mm;
        // At least eight samples a period: the shortest period searched, and how many
        // samples the coarse scan may average while keeping eight a period.
        let per_sample_mm = r * sampling.dtheta_rad;
        let p_min = (8.0 * per_sample_mm).max(2.0);
        let stride = (p_min / (8.0 * per_sample_mm)).floor();
        let p_max = (r / 2.0).max(p_min * 1.5);
        let (lo, hi) = (1.0 / p_max, 1.0 / p_min);
        Some(Scan {
            lo,
            hi,
            step: 0.3 / (TAU * r),
            reach: 1.0,
            joint: false,
            stride: if stride.is_finite() && stride >= 1.0 {
                stride as usize
            } else {
                1
            },
            start: 2.0 / (lo + hi),
            to_nl: |u| 1.0 / u,
            from_nl: |nl| 1.0 / nl,
        })
    }

    fn columns(slot: Slot, nl: f64, p: &Point, g: &Geometry) -> [f64; 2] {
        let q = match slot {
            Slot::A => p.cos_theta,
            Slot::B | Slot::Plane => p.sin_theta,
        };
        let u = TAU * g.radius_mm * q / nl;
        [u.sin() * q, u.cos() * q]
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(CyclicError {
            amplitude_um: p.num(P::AmplitudeUm)?,
            period_mm: p.num(P::PeriodMm)?,
            phase_rad: p.num(P::PhaseRad)?,
        })
    }

    /// The amplitude and phase from the pair of coefficients (x, y) = (a·cos φ, a·sin φ),
    /// their one-sigmas propagated through the covariance of the pair.
    fn from_fit(coef: &[f64], nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        let (x, y) = (coef[0], coef[1]);
        let a = x.hypot(y);
        let phase = y.atan2(x);
        let ga = [x / a, y / a];
        let gp = [-y / (a * a), x / (a * a)];
        let q = |g: [f64; 2]| {
            (g[0] * g[0] * cov[(0, 0)]
                + 2.0 * g[0] * g[1] * cov[(0, 1)]
                + g[1] * g[1] * cov[(1, 1)])
                .max(0.0)
                .sqrt()
        };
        (
            CyclicError {
                amplitude_um: a,
                period_mm: nl,
                phase_rad: phase,
            },
            vec![
                (P::AmplitudeUm, q(ga)),
                (P::PeriodMm, sd(cov, 2)),
                (P::PhaseRad, q(gp)),
            ],
        )
    }
}

impl Term for CyclicError {
    fn params(&self) -> Vec<(P, f64)> {
        vec![
            (P::AmplitudeUm, self.amplitude_um),
            (P::PeriodMm, self.period_mm),
            (P::PhaseRad, self.phase_rad),
        ]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (
            self.period_mm,
            [
                self.amplitude_um * self.phase_rad.cos(),
                self.amplitude_um * self.phase_rad.sin(),
            ],
        )
    }

    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution {
        let (q, _, _) = m.axis(slot);
        let own = self.amplitude_um * (2.0 * PI * q / self.period_mm + self.phase_rad).sin();
        Contribution::axes(slot, own, 0.0)
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::AmplitudeUm, self.amplitude_um, MAX_TERM_UM, "µm")?;
        positive(P::PeriodMm, self.period_mm, MAX_PERIOD_MM, "mm")?;
        within(P::PhaseRad, self.phase_rad, TAU, "rad")
    }

    fn words(&self, w: &Wording) -> String {
        format!(
            "{name} cycles with a period of {:.3} mm of its travel (screw or scale); \
             strongest where {name} moves fastest",
            self.period_mm,
            name = w.name
        )
    }
}
