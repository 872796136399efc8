//! errmap's own rotary simulator: an ISO 230-2 cycle in degrees run on an axis with
//! hidden rotary effects ([`RotaryEffect`]), read by an angle encoder against a rotary
//! reference. It writes the rotary session a capture would (`docs/rotary.md` §1).
//!
//! Per run, from `from − overrun`: every target ascending with a dwell at each, on to
//! `to + overrun`, every target descending, back to `from − overrun`; moves at
//! `feed_deg_s`. A dwell of `samples_per_dwell` samples `dwell_s` apart shares one
//! positioning offset (normal, `positioning_arcsec`); each sample adds white noise
//! (`noise_arcsec`). e = Σ r(θ, d, t) + offset + noise; indicated = θ + offset/3600
//! (the axis reads where it stopped); reference = indicated − e/3600.

use rand::SeedableRng;
use rand::rngs::StdRng;

use crate::base::{RotaryAxis, gaussian};
use crate::diagnose::rotary::RotaryEffect;
use crate::session::rotary::{RotaryRow, RotarySession};

/// An ISO 230-2 cycle on a rotary axis.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryCycle {
    /// Ascending, in [0, 360].
    pub targets_deg: Vec<f64>,
    pub runs: u32,
    pub overrun_deg: f64,
    pub dwell_s: f64,
    pub feed_deg_s: f64,
    pub samples_per_dwell: usize,
}

impl RotaryCycle {
    /// `n` equal steps over the revolution, 0 and 360 both, 5 runs, 5° overrun, 2 s
    /// dwells of 4 samples at 10 °/s.
    pub fn revolution(n: usize) -> Self {
        RotaryCycle {
            targets_deg: (0..=n).map(|k| 360.0 * k as f64 / n as f64).collect(),
            runs: 5,
            overrun_deg: 5.0,
            dwell_s: 2.0,
            feed_deg_s: 10.0,
            samples_per_dwell: 4,
        }
    }
}

/// The simulated axis: its hidden effects and its noise.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryAxisModel {
    pub axis: RotaryAxis,
    pub effects: Vec<RotaryEffect>,
    /// One offset per dwell, ″ (one-sigma).
    pub positioning_arcsec: f64,
    /// Per sample, ″ (one-sigma).
    pub noise_arcsec: f64,
    pub seed: u64,
}

/// Runs the cycle on the axis: the dwell rows of a rotary session.
pub fn simulate_rotary(model: &RotaryAxisModel, cycle: &RotaryCycle) -> RotarySession {
    let mut rng = StdRng::seed_from_u64(model.seed);
    let mut rows = Vec::new();
    let (Some(&from), Some(&to)) = (cycle.targets_deg.first(), cycle.targets_deg.last()) else {
        return RotarySession {
            axis: model.axis,
            rows,
        };
    };
    let mut t = 0.0;
    let mut at = from - cycle.overrun_deg;
    let feed = cycle.feed_deg_s.max(1e-6);
    let step_s = cycle.dwell_s / cycle.samples_per_dwell.max(1) as f64;
    for run in 1..=cycle.runs {
        let mut sample = 0i64;
        let up: Vec<(usize, f64)> = cycle.targets_deg.iter().copied().enumerate().collect();
        let mut passes = [(1i8, up.clone()), (-1i8, up)];
        passes[1].1.reverse();
        for (d, targets) in passes {
            for (idx, theta) in targets {
                t += (theta - at).abs() / feed;
                at = theta;
                let offset = model.positioning_arcsec * gaussian(&mut rng);
                for _ in 0..cycle.samples_per_dwell {
                    let r: f64 = model.effects.iter().map(|e| e.r_arcsec(theta, d, t)).sum();
                    let e = r + offset + model.noise_arcsec * gaussian(&mut rng);
                    let indicated = theta + offset / 3600.0;
                    rows.push(RotaryRow {
                        axis: model.axis.into(),
                        run,
                        sample,
                        t_s: t,
                        direction: d,
                        target: idx as i32,
                        target_deg: Some(theta),
                        indicated_deg: indicated,
                        reference_deg: indicated - e / 3600.0,
                        error_arcsec: e,
                        feed_deg_s: Some(cycle.feed_deg_s),
                        air_temp_c: None,
                        part_temp_c: None,
                        scale_temp_c: None,
                        flags: 0,
                    });
                    sample += 1;
                    t += step_s;
                }
            }
            let end = if d > 0 {
                to + cycle.overrun_deg
            } else {
                from - cycle.overrun_deg
            };
            t += (end - at).abs() / feed;
            at = end;
        }
    }
    RotarySession {
        axis: model.axis,
        rows,
    }
}
