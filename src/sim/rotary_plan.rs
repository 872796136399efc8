//! The ISO 230-2 test plan of a rotary axis, in degrees (`docs/rotary.md` §5); its part
//! programs are `controller::program::render_rotary`.
//!
//! Targets from `from` to `to` (both included; 0 and 360 make the closure pair), inner ones
//! offset at random by up to `random_offset` of the interval and rounded to 0.001°. Per
//! run, from `from − overrun`: every target ascending with a dwell at each, on to
//! `to + overrun`, every target descending, on to `from − overrun`. Angles are absolute
//! and unwrapped (below 0 and beyond 360): the axis must count continuously.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::base::RotaryAxis;

/// What a rotary plan is made from.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryPlanConfig {
    pub axis: RotaryAxis,
    pub from_deg: f64,
    pub to_deg: f64,
    /// Number of targets (ends included), or the largest interval.
    pub targets: Option<usize>,
    pub interval_deg: Option<f64>,
    pub runs: u32,
    pub overrun_deg: f64,
    pub dwell_s: f64,
    pub feed_deg_s: f64,
    pub random_offset: f64,
    pub seed: u64,
}

/// A rotary test plan.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryPlan {
    pub config: RotaryPlanConfig,
    pub targets_deg: Vec<f64>,
}

/// A rotary plan's configuration that cannot make a plan: the field and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {problem}")]
pub struct RotaryPlanError {
    pub field: &'static str,
    pub problem: String,
}

fn bad(field: &'static str, problem: impl Into<String>) -> RotaryPlanError {
    RotaryPlanError {
        field,
        problem: problem.into(),
    }
}

/// The most targets a plan may have.
pub const MAX_PLAN_TARGETS: usize = 10_000;

impl RotaryPlan {
    pub fn generate(c: RotaryPlanConfig) -> Result<RotaryPlan, RotaryPlanError> {
        if !(0.0 <= c.from_deg && c.from_deg < c.to_deg && c.to_deg <= 360.0) {
            return Err(bad(
                "from/to",
                "0 ≤ from < to ≤ 360 is needed (errmap never wraps)",
            ));
        }
        let span = c.to_deg - c.from_deg;
        let m = match (c.targets, c.interval_deg) {
            (Some(m), _) => m,
            (None, Some(q)) if q > 0.0 => (span / q - 1e-9).ceil() as usize + 1,
            _ => return Err(bad("targets", "give a number of targets or an interval")),
        };
        if !(2..=MAX_PLAN_TARGETS).contains(&m) {
            return Err(bad(
                "targets",
                format!("{m}: between 2 and {MAX_PLAN_TARGETS}"),
            ));
        }
        if c.runs == 0 || c.runs > 1000 {
            return Err(bad("runs", format!("{}: between 1 and 1000", c.runs)));
        }
        if !(0.0..0.5).contains(&c.random_offset) {
            return Err(bad("random_offset", "in [0, 0.5)"));
        }
        for (field, v) in [
            ("overrun", c.overrun_deg),
            ("dwell_s", c.dwell_s),
            ("feed", c.feed_deg_s),
        ] {
            if !(0.0..=3600.0).contains(&v) {
                return Err(bad(field, format!("{v} is outside 0 … 3600")));
            }
        }
        if c.feed_deg_s <= 0.0 {
            return Err(bad("feed", "must be positive"));
        }
        let step = span / (m - 1) as f64;
        let mut rng = StdRng::seed_from_u64(c.seed);
        let targets_deg = (0..m)
            .map(|i| {
                let nominal = c.from_deg + step * i as f64;
                let off = if i == 0 || i == m - 1 || c.random_offset == 0.0 {
                    0.0
                } else {
                    rng.random_range(-c.random_offset..c.random_offset) * step
                };
                ((nominal + off) * 1000.0).round() / 1000.0 + 0.0
            })
            .collect();
        Ok(RotaryPlan {
            config: c,
            targets_deg,
        })
    }

    /// PLAN.toml.
    pub fn toml(&self) -> String {
        let c = &self.config;
        let t: Vec<String> = self.targets_deg.iter().map(|v| format!("{v}")).collect();
        format!(
            "# errmap plan: ISO 230-2 cycle of rotary axis {}, degrees\naxis = \"{}\"\n\
             targets_deg = [{}]\nruns = {}\noverrun_deg = {}\ndwell_s = {}\nfeed_deg_s = {}\n\
             seed = {}\n",
            c.axis,
            c.axis,
            t.join(", "),
            c.runs,
            c.overrun_deg,
            c.dwell_s,
            c.feed_deg_s,
            c.seed
        )
    }

    /// The cycle's events: ('M', angle) for a move, ('D', seconds) for a dwell.
    pub fn events(&self) -> Vec<(char, f64)> {
        let c = &self.config;
        let mut ev = Vec::new();
        for _ in 0..c.runs {
            for &t in &self.targets_deg {
                ev.push(('M', t));
                ev.push(('D', c.dwell_s));
            }
            ev.push(('M', c.to_deg + c.overrun_deg));
            for &t in self.targets_deg.iter().rev() {
                ev.push(('M', t));
                ev.push(('D', c.dwell_s));
            }
            ev.push(('M', c.from_deg - c.overrun_deg));
        }
        ev
    }
}
