//! An ISO 230-2 positioning test along one axis: target positions with random offsets,
//! the standard test cycle, and the measurement-plan TOML the simulator reads
//! ([`PlanSpec`](super::PlanSpec)). Part programs for controllers are rendered from the
//! same [`TestPlan`] by [`program`](super::program).
//!
//! # Targets (ISO 230-2:2014, clause 5 "test conditions and test program")
//!
//! The m target positions cover the range `from … to` at a nominal interval
//! p = (to − from)/(m − 1). Given `--targets m` that is p; given `--interval q` instead,
//! m − 1 = ⌈(to − from)/q⌉ intervals, so p ≤ q and the targets still end at `to`.
//! ISO 230-2 asks for target positions spread so that periodic errors (a ball screw's
//! pitch, an encoder's signal period) are not sampled at the same phase everywhere, and
//! suggests P_i = (i − 1)·p + r with r a different random value at each target; the
//! commercial packages call it a "random offset". Here
//!
//! ```text
//! P_1 = from,   P_m = to,   P_i = from + (i − 1)·p + u_i·f·p   (1 < i < m)
//! ```
//!
//! with u_i uniform in [−1, 1] from a seeded generator (`StdRng`, reproducible for one
//! `rand` version) and f the `random_offset` fraction, 0 ≤ f < 0.5, so the targets stay
//! strictly increasing. The end targets stay at the range ends (f·p of freedom is allowed
//! there by the issue, but keeping them put means the error table spans exactly the range
//! asked for and a compensation table over it needs no extrapolation). Every target is
//! rounded to 1 µm (0.001 mm), the least input increment of the coarsest dialect written
//! (Fanuc IS-B), so the TOML and every part program hold the same numbers.
//!
//! # The standard test cycle (ISO 230-2:2014, clause 5, figure "standard test cycle")
//!
//! Our reading of the linear cycle: each of n runs approaches every target from below
//! going up, moves on past the last target by the overrun o, reverses, approaches every
//! target from above coming down, and moves on below the first target by o, so that the
//! next run approaches the first target from below again. At each target the axis stops
//! and dwells while the measurement is taken:
//!
//! ```text
//! start at P_1 − o
//! run j = 1…n:  P_1 ↑ dwell, P_2 ↑ dwell, … P_m ↑ dwell, P_m + o,
//!               P_m ↓ dwell, … P_1 ↓ dwell, P_1 − o
//! ```
//!
//! (the standard shows the overrun as the short loop at each end of the cycle; it does not
//! fix its length — it must be long enough for the reversal to be a real one, i.e. larger
//! than the axis' lost motion, and a few millimetres is usual). The overrun positions may
//! lie outside `from … to`: the user must check them against the travel limits.
//!
//! The simulated board of `errmap-drivers` reverses at the end targets without the
//! overrun; the plan file records `overrun_mm` for the part programs, and the board's
//! MARKs (targets, runs, directions) are the same either way.

use std::fmt::Write as _;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::base::Axis;

/// Targets are rounded to this (the least input increment of Fanuc IS-B), mm; the
/// rounding is done as k/1000.
pub(crate) const TARGET_RESOLUTION_MM: f64 = 1e-3;

/// errmap's cap on targets per line and on runs, so that a mistyped value cannot
/// produce a program of millions of blocks.
pub(crate) const MAX_TARGETS: usize = 10_000;
pub(crate) const MAX_RUNS: u32 = 1_000;

/// How the targets are spaced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Spacing {
    /// This many targets, ends included (≥ 2).
    Targets(usize),
    /// At most this interval, mm: ⌈range/interval⌉ equal intervals.
    Interval(f64),
}

/// What the test is: the validated inputs of [`TestPlan::generate`].
#[derive(Debug, Clone, PartialEq)]
pub struct TestPlanConfig {
    pub axis: Axis,
    pub from_mm: f64,
    pub to_mm: f64,
    pub spacing: Spacing,
    /// Runs, each up and down (ISO 230-2: 5).
    pub runs: u32,
    /// Travel past the end targets before each reversal, mm (> 0).
    pub overrun_mm: f64,
    /// Stop at each target, s (> 0).
    pub dwell_s: f64,
    /// Feed of every move, mm/s (> 0).
    pub feed_mm_s: f64,
    /// The two other coordinates of the line, mm, in axis order (Y, Z for X; X, Z for Y;
    /// X, Y for Z), as [`PlanSpec::lines_mm`](super::PlanSpec::lines_mm).
    pub line_mm: [f64; 2],
    /// Random offset of the inner targets as a fraction of the interval, 0 ≤ f < 0.5.
    pub random_offset: f64,
    pub seed: u64,
}

/// Why a test plan cannot be made: the field of [`TestPlanConfig`] at fault and the
/// problem. Displayed with the config's field names; [`TestPlanError::render`] takes
/// other names for the fields (the command line's flags).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.render(PlanField::name))]
pub struct TestPlanError {
    pub field: PlanField,
    pub problem: PlanProblem,
}

/// A field of [`TestPlanConfig`] (the spacing's two kinds apart).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanField {
    FromMm,
    ToMm,
    Targets,
    Interval,
    Runs,
    RandomOffset,
    OverrunMm,
    DwellS,
    FeedMmS,
    LineMm,
}

impl PlanField {
    /// The field's name in [`TestPlanConfig`].
    pub fn name(self) -> &'static str {
        match self {
            PlanField::FromMm => "from_mm",
            PlanField::ToMm => "to_mm",
            PlanField::Targets => "targets",
            PlanField::Interval => "interval",
            PlanField::Runs => "runs",
            PlanField::RandomOffset => "random_offset",
            PlanField::OverrunMm => "overrun_mm",
            PlanField::DwellS => "dwell_s",
            PlanField::FeedMmS => "feed_mm_s",
            PlanField::LineMm => "line_mm",
        }
    }
}

/// What is wrong with a field's value.
#[derive(Debug, Clone, PartialEq)]
pub enum PlanProblem {
    /// `from_mm` is not below `to_mm`.
    EmptyRange { from_mm: f64, to_mm: f64 },
    /// The value refused, in words that name no other field.
    Refused(String),
}

impl TestPlanError {
    /// The message with every field called by `name`.
    pub fn render(&self, name: impl Fn(PlanField) -> &'static str) -> String {
        let problem = match &self.problem {
            PlanProblem::EmptyRange { from_mm, to_mm } => format!(
                "the range {from_mm} … {to_mm} mm is empty: {} must be less than {}",
                name(PlanField::FromMm),
                name(PlanField::ToMm)
            ),
            PlanProblem::Refused(message) => message.clone(),
        };
        format!("{}: {problem}", name(self.field))
    }
}

fn bad(field: PlanField, message: impl Into<String>) -> TestPlanError {
    TestPlanError {
        field,
        problem: PlanProblem::Refused(message.into()),
    }
}

pub(crate) use crate::base::Direction;

/// One step of the standard test cycle, after the move to [`TestPlan::start_point_mm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CycleStep {
    /// Run `run` (from 1) begins (the axis is at P_1 − o).
    RunStart { run: u32 },
    /// Move along the axis to target `target` (from 0), approaching in `direction`.
    Approach {
        run: u32,
        direction: Direction,
        target: usize,
        position_mm: f64,
    },
    /// Stop at the target just approached.
    Dwell {
        run: u32,
        direction: Direction,
        target: usize,
        dwell_s: f64,
    },
    /// Move past the end target by the overrun: after the last target going up
    /// (`direction` Up), after the first coming down (Down).
    Overrun {
        run: u32,
        direction: Direction,
        position_mm: f64,
    },
}

/// A generated ISO 230-2 test along one line.
#[derive(Debug, Clone, PartialEq)]
pub struct TestPlan {
    pub config: TestPlanConfig,
    /// Strictly increasing, rounded to [`TARGET_RESOLUTION_MM`].
    pub targets_mm: Vec<f64>,
    /// The nominal interval p, mm.
    pub interval_mm: f64,
}

fn round_target(x: f64) -> f64 {
    // k / 1000 (a correctly rounded division) is the f64 nearest to the decimal the files
    // hold, so the TOML and the programs read back to exactly these numbers.
    let r = (x * 1000.0).round() / 1000.0;
    if r == 0.0 { 0.0 } else { r }
}

impl TestPlanConfig {
    /// Checks every input; the error names the field.
    pub fn validate(&self) -> Result<(), TestPlanError> {
        let finite = |flag, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(bad(flag, format!("{v} is not a finite number")))
            }
        };
        finite(PlanField::FromMm, self.from_mm)?;
        finite(PlanField::ToMm, self.to_mm)?;
        if self.from_mm >= self.to_mm {
            return Err(TestPlanError {
                field: PlanField::ToMm,
                problem: PlanProblem::EmptyRange {
                    from_mm: self.from_mm,
                    to_mm: self.to_mm,
                },
            });
        }
        match self.spacing {
            Spacing::Targets(m) if !(2..=MAX_TARGETS).contains(&m) => {
                return Err(bad(
                    PlanField::Targets,
                    format!("{m} targets: between 2 and {MAX_TARGETS}, ends included"),
                ));
            }
            Spacing::Interval(q) if !(q.is_finite() && q > 0.0) => {
                return Err(bad(
                    PlanField::Interval,
                    format!("{q} mm must be a positive length"),
                ));
            }
            Spacing::Interval(q) if (self.to_mm - self.from_mm) / q >= MAX_TARGETS as f64 => {
                return Err(bad(
                    PlanField::Interval,
                    format!("{q} mm gives more than {MAX_TARGETS} targets"),
                ));
            }
            _ => {}
        }
        if !(1..=MAX_RUNS).contains(&self.runs) {
            return Err(bad(
                PlanField::Runs,
                format!("{} runs: between 1 and {MAX_RUNS}", self.runs),
            ));
        }
        if !(self.random_offset.is_finite() && (0.0..0.5).contains(&self.random_offset)) {
            return Err(bad(
                PlanField::RandomOffset,
                format!(
                    "{} is a fraction of the interval in [0, 0.5), so that the targets stay in order",
                    self.random_offset
                ),
            ));
        }
        for (flag, v, unit) in [
            (PlanField::OverrunMm, self.overrun_mm, "mm"),
            (PlanField::DwellS, self.dwell_s, "s"),
            (PlanField::FeedMmS, self.feed_mm_s, "mm/s"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(flag, format!("{v} {unit} must be positive and finite")));
            }
        }
        for v in self.line_mm {
            finite(PlanField::LineMm, v)?;
        }
        Ok(())
    }

    fn intervals(&self) -> usize {
        let length = self.to_mm - self.from_mm;
        match self.spacing {
            Spacing::Targets(m) => m - 1,
            // 1e-9 relative slack: an interval that divides the range typed in decimal
            // gives exactly that many intervals.
            Spacing::Interval(q) => ((length / q) * (1.0 - 1e-12) - 1e-9).ceil().max(1.0) as usize,
        }
    }
}

impl TestPlan {
    /// Validates `config` and draws the targets (see the module docs).
    pub fn generate(config: TestPlanConfig) -> Result<Self, TestPlanError> {
        config.validate()?;
        let k = config.intervals();
        let p = (config.to_mm - config.from_mm) / k as f64;
        if p < 10.0 * TARGET_RESOLUTION_MM {
            return Err(bad(
                match config.spacing {
                    Spacing::Targets(_) => PlanField::Targets,
                    Spacing::Interval(_) => PlanField::Interval,
                },
                format!(
                    "the interval {p} mm is below 0.01 mm; targets are written to {TARGET_RESOLUTION_MM} mm"
                ),
            ));
        }
        let mut rng = StdRng::seed_from_u64(config.seed);
        let mut targets_mm = Vec::with_capacity(k + 1);
        for i in 0..=k {
            let nominal = config.from_mm + i as f64 * p;
            let x = if i == 0 {
                config.from_mm
            } else if i == k {
                config.to_mm
            } else {
                let u: f64 = rng.random_range(-1.0..=1.0);
                nominal + u * config.random_offset * p
            };
            targets_mm.push(round_target(x));
        }
        // Rounding to 1 µm cannot reorder targets ≥ 0.01 mm · (1 − 2f) > 0 apart… except
        // when f is close to 0.5; check rather than assume.
        if let Some(w) = targets_mm.windows(2).find(|w| w[1] <= w[0]) {
            return Err(bad(
                PlanField::RandomOffset,
                format!(
                    "targets {} and {} mm are not in order after rounding to 1 µm; use a smaller fraction",
                    w[0], w[1]
                ),
            ));
        }
        Ok(TestPlan {
            config,
            targets_mm,
            interval_mm: p,
        })
    }

    /// The 3-D point at `position_mm` along the axis on the plan's line.
    pub fn point_mm(&self, position_mm: f64) -> [f64; 3] {
        let [a, b] = self.config.line_mm;
        match self.config.axis {
            Axis::X => [position_mm, a, b],
            Axis::Y => [a, position_mm, b],
            Axis::Z => [a, b, position_mm],
        }
    }

    /// Where the program starts: P_1 − o on the line.
    pub fn start_point_mm(&self) -> [f64; 3] {
        self.point_mm(self.below_mm())
    }

    /// P_1 − o, the turning point below the first target.
    pub fn below_mm(&self) -> f64 {
        round_target(self.targets_mm[0] - self.config.overrun_mm)
    }

    /// P_m + o, the turning point above the last target.
    pub fn above_mm(&self) -> f64 {
        round_target(self.targets_mm[self.targets_mm.len() - 1] + self.config.overrun_mm)
    }

    /// The standard test cycle, run by run (module docs).
    pub fn cycle(&self) -> Vec<CycleStep> {
        let c = &self.config;
        let m = self.targets_mm.len();
        let mut steps = Vec::with_capacity(c.runs as usize * (4 * m + 3));
        for run in 1..=c.runs {
            steps.push(CycleStep::RunStart { run });
            for direction in [Direction::Up, Direction::Down] {
                let order: Vec<usize> = match direction {
                    Direction::Up => (0..m).collect(),
                    Direction::Down => (0..m).rev().collect(),
                };
                for target in order {
                    steps.push(CycleStep::Approach {
                        run,
                        direction,
                        target,
                        position_mm: self.targets_mm[target],
                    });
                    steps.push(CycleStep::Dwell {
                        run,
                        direction,
                        target,
                        dwell_s: c.dwell_s,
                    });
                }
                steps.push(CycleStep::Overrun {
                    run,
                    direction,
                    position_mm: match direction {
                        Direction::Up => self.above_mm(),
                        Direction::Down => self.below_mm(),
                    },
                });
            }
        }
        steps
    }

    /// The measurement-plan TOML that [`PlanSpec::read`](super::PlanSpec::read) reads, with
    /// a comment header recording how the targets were drawn.
    pub fn toml(&self) -> String {
        let c = &self.config;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# errmap plan: ISO 230-2 standard test cycle along {}, {} targets {} … {} mm",
            c.axis.upper(),
            self.targets_mm.len(),
            toml_f64(c.from_mm),
            toml_f64(c.to_mm)
        );
        let _ = writeln!(
            s,
            "# nominal interval {} mm, inner targets offset randomly within ±{} of it (seed {}),",
            toml_f64(round_target(self.interval_mm)),
            toml_f64(c.random_offset),
            c.seed
        );
        let _ = writeln!(
            s,
            "# {} run{} up and down, overrun {} mm past the end targets ({} … {} mm).\n",
            c.runs,
            if c.runs == 1 { "" } else { "s" },
            toml_f64(c.overrun_mm),
            toml_f64(self.below_mm()),
            toml_f64(self.above_mm())
        );
        let _ = writeln!(s, "axis = \"{}\"", c.axis.upper());
        let _ = writeln!(
            s,
            "lines_mm = [[{}, {}]]",
            toml_f64(c.line_mm[0]),
            toml_f64(c.line_mm[1])
        );
        let targets: Vec<String> = self.targets_mm.iter().map(|&t| toml_f64(t)).collect();
        let _ = writeln!(s, "targets_mm = [{}]", targets.join(", "));
        let _ = writeln!(s, "runs = {}", c.runs);
        let _ = writeln!(s, "feed_mm_s = {}", toml_f64(c.feed_mm_s));
        let _ = writeln!(s, "dwell_s = {}", toml_f64(c.dwell_s));
        let _ = writeln!(s, "overrun_mm = {}", toml_f64(c.overrun_mm));
        let _ = writeln!(
            s,
            "seed = {}  # the simulator's controller timing (the same seed as the targets')",
            c.seed
        );
        s
    }
}

/// A float as TOML writes it: shortest round-trip digits, always with a `.`.
fn toml_f64(v: f64) -> String {
    let v = if v == 0.0 { 0.0 } else { v };
    let s = format!("{v}");
    if s.contains(['.', 'e', 'i', 'N']) {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> TestPlanConfig {
        TestPlanConfig {
            axis: Axis::X,
            from_mm: 0.0,
            to_mm: 800.0,
            spacing: Spacing::Targets(21),
            runs: 5,
            overrun_mm: 5.0,
            dwell_s: 2.0,
            feed_mm_s: 25.0,
            line_mm: [1.0, 200.0],
            random_offset: 0.1,
            seed: 7,
        }
    }

    #[test]
    fn interval_mode_rounds_the_interval_down_to_fit_the_range() {
        let c = TestPlanConfig {
            spacing: Spacing::Interval(40.0),
            ..config()
        };
        assert_eq!(c.intervals(), 20);
        let c = TestPlanConfig {
            spacing: Spacing::Interval(30.0),
            ..config()
        };
        // 800 / 30 = 26.7 → 27 intervals of 29.63 mm.
        assert_eq!(c.intervals(), 27);
    }

    #[test]
    fn toml_floats_always_have_a_point() {
        assert_eq!(toml_f64(5.0), "5.0");
        assert_eq!(toml_f64(-0.0), "0.0");
        assert_eq!(toml_f64(41.234), "41.234");
    }
}
