//! Measurement plan files (the simulated board's plan in TOML), simulating a whole stream
//! from a model and a plan, and test points with the simulated truth for a captured table.

use std::path::Path;

use errmap_drivers::frame::Axis as WireAxis;
use errmap_drivers::sim::{Faults, Plan, SimStream};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use super::error::SimError;
use super::physics::{MachineModel, PhysicsTruth, simulate_plan};
use crate::base::read_toml;
use crate::base::{Allowed, Axis, ConfigError};
use crate::table::ErrorTable;

/// A measurement plan file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlanSpec {
    /// "X", "Y" or "Z".
    pub axis: String,
    /// The two other coordinates of each line, mm.
    pub lines_mm: Vec<[f64; 2]>,
    pub targets_mm: Vec<f64>,
    #[serde(default = "default_runs")]
    pub runs: u32,
    #[serde(default = "default_feed")]
    pub feed_mm_s: f64,
    /// Further feeds, cycled by run (run 1 at `feed_mm_s`, run 2 at the first of these…).
    #[serde(default)]
    pub extra_feeds_mm_s: Vec<f64>,
    #[serde(default = "default_dwell")]
    pub dwell_s: f64,
    /// Travel past the end targets before each reversal, mm, for the part program
    /// (`errmap plan`); the simulated board reverses at the end targets. 0 when absent.
    #[serde(default)]
    pub overrun_mm: f64,
    #[serde(default = "default_rate")]
    pub sample_hz: f64,
    #[serde(default = "default_settle")]
    pub settle_s: f64,
    /// Acceleration of every move, mm/s².
    #[serde(default = "default_accel")]
    pub accel_mm_s2: f64,
    /// Seed of the controller's timing relative to the board's timer.
    #[serde(default)]
    pub seed: u64,
}

fn default_runs() -> u32 {
    5
}
fn default_feed() -> f64 {
    120.0
}
fn default_dwell() -> f64 {
    0.5
}
fn default_rate() -> f64 {
    50.0
}
fn default_settle() -> f64 {
    0.2
}
fn default_accel() -> f64 {
    2000.0
}

impl PlanSpec {
    /// Reads a plan file: unknown keys refused, every number finite and in its range
    /// ([`super::bounds`]).
    pub fn read(path: &Path) -> Result<Self, SimError> {
        read_toml(path, super::bounds::check_numbers)
    }

    pub fn plan(&self, path: &Path) -> Result<Plan, SimError> {
        let axis: Axis = self
            .axis
            .trim()
            .parse()
            .map_err(|e| ConfigError::key(path, "axis", format!("{e}")))?;
        let axis = WireAxis::from(axis);
        Allowed::NonNegative
            .check("overrun_mm", self.overrun_mm)
            .map_err(|e| ConfigError::file(path, e.to_string()))?;
        let plan = Plan {
            axis,
            lines_mm: self.lines_mm.clone(),
            targets_mm: self.targets_mm.clone(),
            runs: self.runs,
            feed_mm_s: self.feed_mm_s,
            extra_feeds_mm_s: self.extra_feeds_mm_s.clone(),
            dwell_s: self.dwell_s,
            sample_hz: self.sample_hz,
            settle_s: self.settle_s,
            accel_mm_s2: self.accel_mm_s2,
            seed: self.seed,
        };
        // The board's checks, with this file's name: ranges, order, the sample budget.
        errmap_drivers::sim::check_plan(&plan).map_err(|e| {
            ConfigError::file(
                path,
                match e {
                    errmap_drivers::sim::SimError::Plan(m)
                    | errmap_drivers::sim::SimError::Device(m) => m,
                },
            )
        })?;
        Ok(plan)
    }
}

/// Simulates a whole stream from a model and plan file (noise as the model says).
pub fn simulate_stream(
    model_path: &Path,
    plan_path: Option<&Path>,
    faults: &Faults,
) -> Result<(SimStream, PhysicsTruth), SimError> {
    let model = MachineModel::read(model_path)?;
    let plan = read_plan(plan_path)?;
    simulate_plan(&model, model_path, &plan, faults, true)
}

/// A plan file, or the built-in plan without one.
pub fn read_plan(plan_path: Option<&Path>) -> Result<Plan, SimError> {
    match plan_path {
        Some(p) => PlanSpec::read(p)?.plan(p),
        None => Ok(Plan::default()),
    }
}

/// Test points for a captured error table: `n` random positions inside its grid (seeded)
/// with the simulated truth's noiseless error, relative to the counters' origin (home on
/// the first line, where the plan's first sample is taken).
pub fn truth_test_points(
    truth: &PhysicsTruth,
    error_table: &Path,
    n: usize,
    seed: u64,
) -> Result<ErrorTable, SimError> {
    let grid = ErrorTable::read(error_table)?.grid()?;
    let home_line = [grid.ys[0], grid.zs[0]];
    let home = truth.map_um([0.0, home_line[0], home_line[1]]);
    let mut rng = StdRng::seed_from_u64(seed);
    let points = (0..n)
        .map(|_| {
            let p = [0, 1, 2].map(|a| {
                let v = grid.axis(a);
                rng.random_range(v[0]..=v[v.len() - 1])
            });
            crate::table::ErrorPoint::new(p[0], p[1], p[2], truth.map_um(p) - home)
        })
        .collect();
    Ok(ErrorTable::from_points(
        format!("simulated truth at {n} random points"),
        points,
    ))
}
