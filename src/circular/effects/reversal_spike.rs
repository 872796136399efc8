//! `reversal_spike`: after each reversal at t_r the axis overshoots and settles,
//! e = −h·sgn v·exp(−(t − t_r)/τ) (before its first reversal the run starts from rest).
//!
//! Signature: A: h·exp(−Δt_A/τ)·|cos θ|; B: h·exp(−Δt_B/τ)·|sin θ| — outward for h > 0 on
//! the side the motion leaves each reversal, so mirrored between ccw and cw. τ is scanned
//! on a log grid between two sample intervals and a quarter of a quarter turn's time.

use std::f64::consts::PI;

use nalgebra::DMatrix;

use super::{Contribution, Family, MAX_TERM_UM, Motion, Sampling, Scan, Term, Wording};
use super::{positive, sd, within};
use crate::base::ParamName as P;
use crate::base::{EffectParamError, Params};
use crate::circular::signature::{Geometry, Point, Slot};

/// The longest decay a spike may have, ms.
const MAX_TAU_MS: f64 = 10_000.0;

/// A spike of height `h_um` after each reversal, decaying with `tau_ms`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReversalSpike {
    pub h_um: f64,
    pub tau_ms: f64,
}

impl Family for ReversalSpike {
    const NAME: &'static str = "reversal_spike";
    const PARAMS: &'static [P] = &[P::HUm, P::TauMs];

    fn scan(sampling: &Sampling) -> Option<Scan> {
        let omega = sampling.omega_rad_per_s;
        let dt_ms = sampling.dtheta_rad / omega * 1e3;
        let quarter_ms = (PI / 2.0) / omega * 1e3;
        let tau_ms = (2.0 * dt_ms, (quarter_ms / 4.0).max(4.0 * dt_ms));
        let (lo, hi) = (tau_ms.0.ln(), tau_ms.1.ln());
        Some(Scan {
            lo,
            hi,
            step: (hi - lo) / 40.0,
            reach: 2.0,
            // Few steps: scan on the joint fit (a spike and a backlash overlap).
            joint: true,
            stride: 1,
            start: (tau_ms.0 * tau_ms.1).sqrt(),
            to_nl: f64::exp,
            from_nl: f64::ln,
        })
    }

    fn columns(slot: Slot, nl: f64, p: &Point, _g: &Geometry) -> [f64; 2] {
        match slot {
            Slot::A => [(-p.dt_a_s * 1e3 / nl).exp() * p.cos_theta.abs(), 0.0],
            Slot::B | Slot::Plane => [(-p.dt_b_s * 1e3 / nl).exp() * p.sin_theta.abs(), 0.0],
        }
    }

    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError> {
        Ok(ReversalSpike {
            h_um: p.num(P::HUm)?,
            tau_ms: p.num(P::TauMs)?,
        })
    }

    fn from_fit(coef: &[f64], nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(P, f64)>) {
        (
            ReversalSpike {
                h_um: coef[0],
                tau_ms: nl,
            },
            vec![(P::HUm, sd(cov, 0)), (P::TauMs, sd(cov, 1))],
        )
    }
}

impl Term for ReversalSpike {
    fn params(&self) -> Vec<(P, f64)> {
        vec![(P::HUm, self.h_um), (P::TauMs, self.tau_ms)]
    }

    fn linear(&self) -> (f64, [f64; 2]) {
        (self.tau_ms, [self.h_um, 0.0])
    }

    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution {
        let (_, v, offset) = m.axis(slot);
        let own = match m.last_reversal(offset) {
            Some(tr) => -self.h_um * v * (-(m.t - tr) * 1e3 / self.tau_ms).exp(),
            None => 0.0,
        };
        Contribution::axes(slot, own, 0.0)
    }

    fn check(&self) -> Result<(), (P, String)> {
        within(P::HUm, self.h_um, MAX_TERM_UM, "µm")?;
        positive(P::TauMs, self.tau_ms, MAX_TAU_MS, "ms")
    }

    fn words(&self, w: &Wording) -> String {
        format!(
            "{} spikes of {:.2} µm as {} reverses ({}), on the side the motion leaves \
             each reversal (mirrored between ccw and cw)",
            if self.h_um >= 0.0 {
                "outward"
            } else {
                "inward"
            },
            self.h_um.abs(),
            w.name,
            w.reversals
        )
    }
}
