//! Each effect's radial signature dr(θ) in a circular test, and the setup terms.
//!
//! A sample is seen through [`Point`]: its commanded angle θ (rad, unwrapped), the sense
//! s of its run (+1 ccw, −1 cw) and the times since the run last passed a reversal of
//! axis A (θ = kπ) and of axis B (θ = π/2 + kπ). To first order a bar reads
//! dr = e_A·cos θ + e_B·sin θ, with e_A, e_B the axis errors (actual − commanded, µm).
//! The signatures below follow from the physics of each effect in that one line; they are
//! what the diagnosis fits (linear in every parameter but the spike's τ and the cyclic
//! error's period, which are scanned); each is written in its effect's file
//! (`effects/<id>.rs`). The simulator (`simulate`) does not use them: it moves the axes
//! and measures the bar.
//!
//! | effect (slot) | dr(θ), µm |
//! |---|---|
//! | backlash A | s·(b/2)·sgn(sin θ)·cos θ |
//! | backlash B | −s·(b/2)·sgn(cos θ)·sin θ |
//! | reversal spike A | h·exp(−Δt_A/τ)·\|cos θ\| |
//! | reversal spike B | h·exp(−Δt_B/τ)·\|sin θ\| |
//! | lateral play A | −s·(p/2)·\|sin θ\| |
//! | lateral play B | +s·(p/2)·\|cos θ\| |
//! | cyclic error A | a·sin(2πR cos θ/P + φ)·cos θ |
//! | cyclic error B | a·sin(2πR sin θ/P + φ)·sin θ |
//! | straightness A | bow·sin³θ |
//! | straightness B | bow·cos³θ |
//! | servo mismatch | s·(v·dt/2)·sin 2θ (v in mm/s, dt in ms) |
//! | scale mismatch | (R·10⁻³·ppm/2)·cos 2θ |
//! | squareness | (R·10⁻³·α/2)·sin 2θ |
//! | setup | c0 + c1·cos θ + c2·sin θ |

use std::f64::consts::{FRAC_PI_2, PI};

use serde::{Serialize, Serializer};

use super::effects::CircularEffect;
use super::input::{Plane, Run, TestMeta};

/// What a circular effect acts on: the plane's first axis A, its second B, or the pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Slot {
    A,
    B,
    Plane,
}

impl Slot {
    /// The contract's `axis`: the axis letter (upper case) or the plane.
    pub fn label(self, plane: Plane) -> String {
        let (a, b) = plane.axes();
        match self {
            Slot::A => a.to_string().to_uppercase(),
            Slot::B => b.to_string().to_uppercase(),
            Slot::Plane => plane.as_str().to_string(),
        }
    }
}

/// A slot with the plane it lies in, serialised as its label.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisOrPlane {
    pub plane: Plane,
    pub slot: Slot,
}

impl Serialize for AxisOrPlane {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.slot.label(self.plane))
    }
}

/// What one sample contributes to the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Commanded angle, rad, and its cosine and sine (computed once).
    pub theta: f64,
    pub cos_theta: f64,
    pub sin_theta: f64,
    /// +1 ccw, −1 cw.
    pub s: f64,
    /// Seconds since the run last passed a reversal of A (θ = kπ) and of B (θ = π/2 + kπ).
    pub dt_a_s: f64,
    pub dt_b_s: f64,
}

/// The test's constants the signatures need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    pub radius_mm: f64,
    pub v_mm_per_s: f64,
}

impl Geometry {
    pub fn of(meta: &TestMeta) -> Geometry {
        Geometry {
            radius_mm: meta.radius_mm,
            v_mm_per_s: meta.v_mm_per_s(),
        }
    }
}

impl Point {
    /// The point at angle θ of a run of sense `s`, `dt_a_s` and `dt_b_s` after the last
    /// reversals of A and B.
    pub fn at(theta: f64, s: f64, dt_a_s: f64, dt_b_s: f64) -> Point {
        Point {
            theta,
            cos_theta: theta.cos(),
            sin_theta: theta.sin(),
            s,
            dt_a_s,
            dt_b_s,
        }
    }
}

/// The points of a run: θ in radians and the times since the last reversals, from `t_s`
/// when the run has it (the time at the reversal angle interpolated), else from the angle
/// and the feed.
pub fn points(run: &Run, meta: &TestMeta) -> Vec<Point> {
    let s = run.sense.s();
    let omega = meta.omega_rad_per_s();
    let theta: Vec<f64> = run.angle_deg.iter().map(|a| a.to_radians()).collect();
    let since = |th: f64, offset: f64| -> f64 {
        // Angle travelled since the last reversal at offset + kπ.
        let travelled = (s * (th - offset)).rem_euclid(PI);
        match &run.t_s {
            Some(t) => {
                let at = th - s * travelled;
                let first = theta[0];
                if (at - first) * s < 0.0 {
                    travelled / omega
                } else {
                    let t_here = interp(&theta, t, th, s);
                    let t_rev = interp(&theta, t, at, s);
                    (t_here - t_rev).max(0.0)
                }
            }
            None => travelled / omega,
        }
    };
    theta
        .iter()
        .map(|&th| Point::at(th, s, since(th, 0.0), since(th, FRAC_PI_2)))
        .collect()
}

/// Linear interpolation of `y` at `x` on monotonic `xs` (increasing when s > 0).
fn interp(xs: &[f64], y: &[f64], x: f64, s: f64) -> f64 {
    let n = xs.len();
    let key = |v: f64| v * s;
    let i = xs.partition_point(|&v| key(v) < key(x));
    if i == 0 {
        return y[0];
    }
    if i >= n {
        return y[n - 1];
    }
    let (x0, x1) = (xs[i - 1], xs[i]);
    let f = if x1 != x0 { (x - x0) / (x1 - x0) } else { 0.0 };
    y[i - 1] + f * (y[i] - y[i - 1])
}

/// The setup terms' columns at a point: 1, cos θ, sin θ.
pub(crate) fn setup_columns(p: &Point) -> [f64; 3] {
    [1.0, p.cos_theta, p.sin_theta]
}

/// The radial signature of an effect (with its parameters) on `slot` at a point, µm: its
/// linear columns ([`Family::columns`](super::effects::Family::columns)) times its
/// coefficients.
pub fn dr_um(effect: &CircularEffect, slot: Slot, p: &Point, g: &Geometry) -> f64 {
    let (nl, coef) = effect.term().linear();
    let col = (effect.id().kind().columns)(slot, nl, p, g);
    col[0] * coef[0] + col[1] * coef[1]
}
