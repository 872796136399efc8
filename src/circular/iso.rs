//! ISO 230-4 numbers of a circular test: G per direction, G(b), H, D and F, on the
//! nominal-arc samples only, unfiltered.
//!
//! The least-squares circle (LSC) of a set of points p_i is the centre c and radius ρ
//! minimising Σ(|p_i − c| − ρ)². It is found here by Gauss–Newton from the linear fit of
//! dr on (1, cos θ, sin θ) (which is itself within |c|²/R of it); deviations are
//! d_i = |p_i − c| − ρ. G is max d − min d about a run's own LSC, G(b) the same about one
//! LSC of both runs, D = (ρ_ccw + ρ_cw)/2 − R, F the extremes of raw dr (about the table
//! ball), H the largest |dr_ccw(θ) − dr_cw(θ)| at each sample of one run against the other
//! run interpolated in angle. Reference: ISO 230-4:2005, *Test code for machine tools —
//! Part 4: Circular tests for numerically controlled machine tools*; H is the 1996
//! edition's circular hysteresis (see `docs/circular-test.md` for what is our reading).

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use super::input::{CircularTest, Run, Sense, TestMeta};

/// The ISO 230-4 quantities, µm; `None` when the test lacks the direction they need.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Iso230_4 {
    #[serde(rename = "G_ccw_um")]
    pub g_ccw_um: Option<f64>,
    #[serde(rename = "G_cw_um")]
    pub g_cw_um: Option<f64>,
    #[serde(rename = "G_b_um")]
    pub g_b_um: Option<f64>,
    #[serde(rename = "H_um")]
    pub h_um: Option<f64>,
    #[serde(rename = "D_um")]
    pub d_um: Option<f64>,
    #[serde(rename = "F_max_um")]
    pub f_max_um: f64,
    #[serde(rename = "F_min_um")]
    pub f_min_um: f64,
}

/// A least-squares circle: centre (mm) and radius (mm), and the deviations (µm) of the
/// points it was fitted to, in their order.
#[derive(Debug, Clone, PartialEq)]
pub struct Lsc {
    pub centre_mm: [f64; 2],
    pub radius_mm: f64,
    pub d_um: Vec<f64>,
}

impl Lsc {
    /// max d − min d, µm.
    pub fn range_um(&self) -> f64 {
        let max = self.d_um.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = self.d_um.iter().copied().fold(f64::INFINITY, f64::min);
        max - min
    }

    /// rms of d, µm.
    pub fn rms_um(&self) -> f64 {
        (self.d_um.iter().map(|d| d * d).sum::<f64>() / self.d_um.len().max(1) as f64).sqrt()
    }
}

/// The nominal-arc samples of a run as (θ rad, dr µm).
pub fn nominal_samples(run: &Run, meta: &TestMeta) -> Vec<(f64, f64)> {
    run.nominal(meta)
        .into_iter()
        .map(|i| (run.angle_deg[i].to_radians(), run.dr_um[i]))
        .collect()
}

/// The least-squares circle of samples (θ rad, dr µm) on a nominal radius R (mm).
pub(crate) fn lsc(samples: &[(f64, f64)], radius_mm: f64) -> Lsc {
    let pts: Vec<[f64; 2]> = samples
        .iter()
        .map(|&(th, dr)| {
            let r = radius_mm + dr * 1e-3;
            [r * th.cos(), r * th.sin()]
        })
        .collect();
    // Start: the linear fit dr ≈ c0 + c1 cos θ + c2 sin θ (µm).
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for &(th, dr) in samples {
        let a = Vector3::new(1.0, th.cos(), th.sin());
        ata += a * a.transpose();
        atb += a * dr;
    }
    let c = ata.lu().solve(&atb).unwrap_or_else(Vector3::zeros);
    let (mut cx, mut cy, mut rho) = (c[1] * 1e-3, c[2] * 1e-3, radius_mm + c[0] * 1e-3);
    // Gauss–Newton on (cx, cy, ρ): r_i = |p_i − c| − ρ, ∂r/∂c = −(p − c)/|p − c|, ∂r/∂ρ = −1.
    for _ in 0..8 {
        let mut jtj = Matrix3::zeros();
        let mut jtr = Vector3::zeros();
        for p in &pts {
            let (dx, dy) = (p[0] - cx, p[1] - cy);
            let d = (dx * dx + dy * dy).sqrt();
            let j = Vector3::new(-dx / d, -dy / d, -1.0);
            jtj += j * j.transpose();
            jtr += j * (d - rho);
        }
        let Some(step) = jtj.lu().solve(&(-jtr)) else {
            break;
        };
        cx += step[0];
        cy += step[1];
        rho += step[2];
        if step.norm() < 1e-13 * radius_mm {
            break;
        }
    }
    let d_um = pts
        .iter()
        .map(|p| (((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt() - rho) * 1e3)
        .collect();
    Lsc {
        centre_mm: [cx, cy],
        radius_mm: rho,
        d_um,
    }
}

/// Linear interpolation of a run's nominal dr at angle θ (rad); `None` outside its range.
/// `sorted` is in increasing angle.
fn interpolate(sorted: &[(f64, f64)], theta: f64) -> Option<f64> {
    let (lo, hi) = (sorted.first()?.0, sorted.last()?.0);
    if theta < lo || theta > hi {
        return None;
    }
    let i = sorted.partition_point(|p| p.0 < theta);
    if i == 0 {
        return Some(sorted[0].1);
    }
    let (a, b) = (sorted[i - 1], sorted[i.min(sorted.len() - 1)]);
    let f = if b.0 > a.0 {
        (theta - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    Some(a.1 + f * (b.1 - a.1))
}

/// H: max |dr_ccw − dr_cw| at every nominal sample of each run, the other interpolated.
pub(crate) fn hysteresis_um(ccw: &[(f64, f64)], cw: &[(f64, f64)]) -> f64 {
    let mut sorted_cw = cw.to_vec();
    sorted_cw.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut sorted_ccw = ccw.to_vec();
    sorted_ccw.sort_by(|a, b| a.0.total_cmp(&b.0));
    let one = |from: &[(f64, f64)], other: &[(f64, f64)]| {
        from.iter()
            .filter_map(|&(th, dr)| interpolate(other, th).map(|o| (dr - o).abs()))
            .fold(0.0, f64::max)
    };
    one(&sorted_ccw, &sorted_cw).max(one(&sorted_cw, &sorted_ccw))
}

/// The ISO 230-4 quantities of a test.
pub fn evaluate(test: &CircularTest) -> Iso230_4 {
    let meta = &test.meta;
    let r = meta.radius_mm;
    let ccw = test.run(Sense::Ccw).map(|run| nominal_samples(run, meta));
    let cw = test.run(Sense::Cw).map(|run| nominal_samples(run, meta));
    let lsc_ccw = ccw.as_ref().map(|s| lsc(s, r));
    let lsc_cw = cw.as_ref().map(|s| lsc(s, r));
    let (g_b, h, d) = match (&ccw, &cw, &lsc_ccw, &lsc_cw) {
        (Some(a), Some(b), Some(la), Some(lb)) => {
            let all: Vec<(f64, f64)> = a.iter().chain(b.iter()).copied().collect();
            (
                Some(lsc(&all, r).range_um()),
                Some(hysteresis_um(a, b)),
                Some(((la.radius_mm + lb.radius_mm) / 2.0 - r) * 1e3),
            )
        }
        _ => (None, None, None),
    };
    let raw = ccw.iter().chain(cw.iter()).flatten().map(|p| p.1);
    let f_max = raw.clone().fold(f64::NEG_INFINITY, f64::max);
    let f_min = raw.fold(f64::INFINITY, f64::min);
    Iso230_4 {
        g_ccw_um: lsc_ccw.as_ref().map(Lsc::range_um),
        g_cw_um: lsc_cw.as_ref().map(Lsc::range_um),
        g_b_um: g_b,
        h_um: h,
        d_um: d,
        f_max_um: f_max,
        f_min_um: f_min,
    }
}

/// The LSC the contract's `rms_before_um` is about: one common circle of all runs.
pub(crate) fn common_lsc(test: &CircularTest) -> Lsc {
    let all: Vec<(f64, f64)> = test
        .runs
        .iter()
        .flat_map(|run| nominal_samples(run, &test.meta))
        .collect();
    lsc(&all, test.meta.radius_mm)
}
