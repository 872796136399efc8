//! `errmap plan`: an ISO 230-2 test plan along one axis and its part program.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use errmap::base::Axis;
use errmap::controller::program::{self, ProgramOptions, ProgramSyntax};
use errmap::sim::{PlanField, Spacing, TestPlan, TestPlanConfig};

use super::values;

#[derive(Debug, Args)]
pub(crate) struct PlanArgs {
    /// The tested axis: x, y or z, or a rotary axis a, b or c (angles in degrees).
    #[arg(long, value_parser = values::any_axis())]
    pub axis: values::AnyAxis,
    /// First target, mm.
    #[arg(long, allow_negative_numbers = true, value_parser = values::coordinate)]
    pub from: f64,
    /// Last target, mm.
    #[arg(long, allow_negative_numbers = true, value_parser = values::coordinate)]
    pub to: f64,
    /// Number of targets, ends included (ISO 230-2: at least 5 per metre, 5 in all).
    #[arg(
        long,
        conflicts_with = "interval",
        required_unless_present = "interval"
    )]
    pub targets: Option<usize>,
    /// Largest interval between targets, mm (the range is split into equal intervals).
    #[arg(long, value_parser = values::length)]
    pub interval: Option<f64>,
    /// Runs, each up and down (ISO 230-2: 5).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Travel past the end targets before each reversal, mm.
    #[arg(long, default_value_t = 5.0, value_parser = values::non_negative_length)]
    pub overrun: f64,
    /// Stop at each target, s.
    #[arg(long, default_value_t = 2.0, value_parser = values::seconds)]
    pub dwell_s: f64,
    /// Feed of every move, mm/s (default 25).
    #[arg(long, value_parser = values::feed)]
    pub feed_mm_s: Option<f64>,
    /// Rotary axis: the angular feed of every move, °/s (default 10).
    #[arg(long, value_parser = values::feed)]
    pub feed_deg_s: Option<f64>,
    /// The line's fixed coordinates, e.g. `y=1,z=200` (mm; a missing one is 0).
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub at: values::LineAt,
    /// Random offset of the inner targets, as a fraction of the interval, in [0, 0.5).
    #[arg(long, default_value_t = 0.1, value_parser = values::offset_fraction)]
    pub random_offset: f64,
    /// Seed of the random offsets.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The measurement plan (TOML, as `errmap simulate --plan` reads).
    #[arg(long)]
    pub out: PathBuf,
    /// The part program to write.
    #[arg(long)]
    pub program: Option<PathBuf>,
    /// The controller whose part-program syntax --program uses.
    #[arg(long, default_value = program::default_dialect().name(), value_parser = values::dialect())]
    pub dialect: &'static dyn ProgramSyntax,
    // Its help names the dialects that switch outputs, from the registry.
    #[arg(long, help = mark_output_help())]
    pub mark_output: Option<u32>,
}

/// The line's two fixed coordinates from `--at`.
fn line_coordinates(axis: Axis, at: &values::LineAt) -> Result<[f64; 2]> {
    let mut p = [0.0; 3];
    for &(a, v) in &at.0 {
        if a == axis {
            return Err(super::guard::usage(format!(
                "--at: {a} is the tested axis; give the other two"
            )));
        }
        p[a.index()] = v;
    }
    let others: Vec<f64> = Axis::ALL
        .iter()
        .filter(|&&a| a != axis)
        .map(|a| p[a.index()])
        .collect();
    Ok([others[0], others[1]])
}

pub(crate) fn plan_cmd(a: PlanArgs) -> Result<()> {
    let axis = match a.axis {
        values::AnyAxis::Rotary(r) => return super::rotary::plan(&a, r),
        values::AnyAxis::Linear(axis) => axis,
    };
    if a.feed_deg_s.is_some() {
        return Err(super::guard::usage(
            "--feed-deg-s is for a rotary axis (--axis a|b|c); a linear axis takes --feed-mm-s",
        ));
    }
    let dialect = a.dialect;
    let mut outputs = vec![("--out", a.out.as_path())];
    outputs.extend(a.program.as_deref().map(|p| ("--program", p)));
    super::guard::refuse_aliases(&outputs, &[])?;
    let spacing = match (a.targets, a.interval) {
        (Some(m), None) => Spacing::Targets(m),
        (None, Some(q)) => Spacing::Interval(q),
        _ => return Err(super::guard::usage("give one of --targets and --interval")),
    };
    let plan = TestPlan::generate(TestPlanConfig {
        axis,
        from_mm: a.from,
        to_mm: a.to,
        spacing,
        runs: a.runs,
        overrun_mm: a.overrun,
        dwell_s: a.dwell_s,
        feed_mm_s: a.feed_mm_s.unwrap_or(25.0),
        line_mm: line_coordinates(axis, &a.at)?,
        random_offset: a.random_offset,
        seed: a.seed,
    })
    // Every field of the configuration is a flag, named in the error: a usage error.
    .map_err(|e| super::guard::usage(e.render(plan_flag)))?;
    let text = match &a.program {
        Some(_) => Some(program::render(
            &plan,
            dialect,
            &ProgramOptions {
                mark_output: a.mark_output,
            },
        )?),
        None if a.mark_output.is_some() => {
            return Err(super::guard::usage("--mark-output needs --program"));
        }
        None => None,
    };
    super::guard::write_file(&a.out, plan.toml().as_bytes())?;
    eprintln!(
        "plan: {} targets along {axis}, interval {:.3} mm, {} runs → {}",
        plan.targets_mm.len(),
        plan.interval_mm,
        a.runs,
        a.out.display()
    );
    if let (Some(path), Some(text)) = (&a.program, text) {
        super::guard::write_file(path, text.as_bytes())?;
        eprintln!("plan: {} program → {}", dialect.name(), path.display());
    }
    Ok(())
}

/// The `errmap plan` flag of each field of the test plan's configuration.
fn plan_flag(field: PlanField) -> &'static str {
    match field {
        PlanField::FromMm => "--from",
        PlanField::ToMm => "--to",
        PlanField::Targets => "--targets",
        PlanField::Interval => "--interval",
        PlanField::Runs => "--runs",
        PlanField::RandomOffset => "--random-offset",
        PlanField::OverrunMm => "--overrun",
        PlanField::DwellS => "--dwell-s",
        PlanField::FeedMmS => "--feed-mm-s",
        PlanField::LineMm => "--at",
    }
}

/// The help of `plan --mark-output`: the dialects whose programs switch a digital output
/// around each dwell, with their outputs and blocks (from the registry).
fn mark_output_help() -> String {
    let with: Vec<String> = program::dialects()
        .filter_map(|p| {
            let n = p.mark_outputs()?;
            Some(format!(
                "{}: outputs 0…{}, `{}` … `{}`",
                p.name(),
                n.saturating_sub(1),
                p.output(0, true),
                p.output(0, false)
            ))
        })
        .collect();
    format!(
        "Switch this digital output on at each dwell and off after it (a MARK for the \
         acquisition board), where the program's dialect can: {}",
        with.join("; ")
    )
}
