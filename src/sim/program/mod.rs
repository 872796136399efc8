//! Part programs that run a [`TestPlan`] on a machine: the standard test cycle of
//! [`testplan`](super::testplan) as blocks a controller executes.
//!
//! The programs live beside the plan in `sim` because they render a `TestPlan` (and
//! `export`, the compensation-table stage, may not import `sim`); like `export` they are
//! pure renderers: a plan in, the program text out, and the caller writes the file.
//!
//! | dialect | module | units, positioning | feed | dwell | MARK output |
//! |---|---|---|---|---|---|
//! | LinuxCNC | [`linuxcnc`] | `G21 G90` | `G1 … F` mm/min (`G94`) | `G4 P` s | `M64/M65 P n` around each dwell |
//! | Fanuc | [`fanuc`] | `G21 G90` | `G01 … F` mm/min (`G94`) | `G04 P` ms (integer) | — |
//! | Siemens 840D | [`siemens`] | `G71 G90` | `G1 … F` mm/min (`G94`) | `G4 F` s | — |
//! | Heidenhain | [`heidenhain`] | `BEGIN PGM … MM` | `L … R0 F` mm/min | `CYCL DEF 9.0 DWELL TIME` s | — |
//!
//! Every program first moves all three axes to the start point P_1 − o on the line at the
//! test feed — the path there must be clear; the operator should position the machine
//! near it first — then runs the cycle with moves along the tested axis only, and ends at
//! P_1 − o. Positions are written to 0.001 mm (the plan's targets are rounded to it).
//! No dialect changes tool, spindle or coolant.
//!
//! [`lines`] writes the same dialects for a campaign of lines in space (the volumetric
//! plans): three-axis moves to each target in order, a dwell there, and a programmed stop
//! before each line for the laser alignment.

pub mod fanuc;
pub mod heidenhain;
pub mod lines;
pub mod linuxcnc;
pub mod siemens;

use std::fmt;
use std::str::FromStr;

use super::testplan::{CycleStep, Direction, TestPlan};

/// The largest coordinate every dialect writes with 3 decimals (Fanuc IS-B: 8 digits).
pub const MAX_COORDINATE_MM: f64 = 99_999.999;

/// A controller's program dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dialect {
    LinuxCnc,
    Fanuc,
    Siemens,
    Heidenhain,
}

impl Dialect {
    pub const ALL: [Dialect; 4] = [
        Dialect::LinuxCnc,
        Dialect::Fanuc,
        Dialect::Siemens,
        Dialect::Heidenhain,
    ];

    /// The name `--dialect` takes.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::LinuxCnc => "linuxcnc",
            Dialect::Fanuc => "fanuc",
            Dialect::Siemens => "siemens",
            Dialect::Heidenhain => "heidenhain",
        }
    }

    /// The usual file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Dialect::LinuxCnc => "ngc",
            Dialect::Fanuc => "nc",
            Dialect::Siemens => "mpf",
            Dialect::Heidenhain => "h",
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A `--dialect` that is none of [`Dialect::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--dialect: `{0}` is not linuxcnc, fanuc, siemens or heidenhain")]
pub struct ParseDialectError(pub String);

impl FromStr for Dialect {
    type Err = ParseDialectError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Dialect::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| ParseDialectError(s.to_string()))
    }
}

/// Options beyond the plan.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ProgramOptions {
    /// A digital output switched on at each dwell and off after it, so that an acquisition
    /// board takes its MARKs from the controller (LinuxCNC only: `M64/M65 P n`).
    pub mark_output: Option<u32>,
}

/// Why a program cannot be written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramError {
    #[error(
        "--mark-output: the {dialect} program has no digital-output MARKs (only linuxcnc's M64/M65)"
    )]
    MarkOutputUnsupported { dialect: Dialect },
    #[error(
        "--mark-output: output {index} is beyond LinuxCNC's motion digital outputs 0…{max} \
         (a default configuration has 4: motmod num_dio)"
    )]
    MarkOutputRange { index: u32, max: u32 },
    #[error("--dwell-s: {dwell_s} s is beyond the {dialect} dwell limit of {max_s} s")]
    DwellTooLong {
        dialect: Dialect,
        dwell_s: f64,
        max_s: f64,
    },
    #[error("--dwell-s: {dwell_s} s is below the {dialect} dwell resolution of {min_s} s")]
    DwellTooShort {
        dialect: Dialect,
        dwell_s: f64,
        min_s: f64,
    },
    #[error(
        "coordinate {value_mm} mm (start, target or overrun) is beyond ±{MAX_COORDINATE_MM} mm, \
         the largest the programs write"
    )]
    CoordinateTooLarge { value_mm: f64 },
    #[error(
        "a lines program needs at least one line, every line targets and at least one run, \
         a positive feed and a non-negative dwell"
    )]
    EmptyCampaign,
}

/// The program for `plan` in `dialect`.
pub fn render(
    plan: &TestPlan,
    dialect: Dialect,
    options: &ProgramOptions,
) -> Result<String, ProgramError> {
    if options.mark_output.is_some() && dialect != Dialect::LinuxCnc {
        return Err(ProgramError::MarkOutputUnsupported { dialect });
    }
    check_coordinates(plan)?;
    match dialect {
        Dialect::LinuxCnc => linuxcnc::render(plan, options.mark_output),
        Dialect::Fanuc => fanuc::render(plan),
        Dialect::Siemens => siemens::render(plan),
        Dialect::Heidenhain => heidenhain::render(plan),
    }
}

fn check_coordinates(plan: &TestPlan) -> Result<(), ProgramError> {
    let start = plan.start_point_mm();
    let along = [plan.below_mm(), plan.above_mm()];
    match start
        .iter()
        .chain(&along)
        .find(|v| v.abs() > MAX_COORDINATE_MM)
    {
        Some(&value_mm) => Err(ProgramError::CoordinateTooLarge { value_mm }),
        None => Ok(()),
    }
}

/// `v` mm with 3 decimals, never `-0.000`.
pub(crate) fn mm3(v: f64) -> String {
    let s = format!("{v:.3}");
    if s.parse::<f64>() == Ok(0.0) {
        "0.000".into()
    } else {
        s
    }
}

/// A feed in mm/min from mm/s: an integer when it is one, else up to 3 decimals.
pub(crate) fn feed_mm_min(feed_mm_s: f64) -> String {
    let f = feed_mm_s * 60.0;
    let r = (f * 1000.0).round() / 1000.0;
    let mut s = format!("{r:.3}");
    while s.ends_with('0') {
        s.pop();
    }
    if s.ends_with('.') {
        s.pop();
    }
    s
}

/// A time in s with 3 decimals.
pub(crate) fn seconds3(v: f64) -> String {
    format!("{v:.3}")
}

/// A short description of a cycle step for the programs' comments, or `None`.
pub(crate) fn comment(plan: &TestPlan, step: &CycleStep) -> Option<String> {
    match *step {
        CycleStep::RunStart { run } => Some(format!("run {run} of {}", plan.config.runs)),
        CycleStep::Overrun { direction, .. } => Some(match direction {
            Direction::Up => "overrun above the last target, reversal".to_string(),
            Direction::Down => "overrun below the first target, reversal".to_string(),
        }),
        _ => None,
    }
}

/// The header lines every dialect writes as comments (without comment syntax).
pub(crate) fn header_lines(plan: &TestPlan, dialect: Dialect) -> Vec<String> {
    let c = &plan.config;
    let [a, b] = other_letters(plan);
    vec![
        format!(
            "errmap ISO 230-2 standard test cycle along {}, {} dialect",
            c.axis.upper(),
            dialect
        ),
        format!(
            "{} targets {} to {} mm, {} run{} up and down, dwell {} s",
            plan.targets_mm.len(),
            mm3(plan.targets_mm[0]),
            mm3(plan.targets_mm[plan.targets_mm.len() - 1]),
            c.runs,
            if c.runs == 1 { "" } else { "s" },
            seconds3(c.dwell_s)
        ),
        format!(
            "line {a}{} {b}{}; feed {} mm/min; seed {}",
            mm3(c.line_mm[0]),
            mm3(c.line_mm[1]),
            feed_mm_min(c.feed_mm_s),
            c.seed
        ),
        format!(
            "CHECK the travel {} to {} mm (overrun {} mm) and a clear path to the start point",
            mm3(plan.below_mm()),
            mm3(plan.above_mm()),
            mm3(c.overrun_mm)
        ),
    ]
}

/// The letters of the two fixed axes, in axis order.
pub(crate) fn other_letters(plan: &TestPlan) -> [&'static str; 2] {
    use crate::base::Axis;
    match plan.config.axis {
        Axis::X => ["Y", "Z"],
        Axis::Y => ["X", "Z"],
        Axis::Z => ["X", "Y"],
    }
}

/// The words in which the ISO 6983 (G-code) dialects — LinuxCNC, Fanuc, Siemens 840D —
/// differ; the program's shape is the same in all three ([`write_iso_body`]).
pub(crate) struct IsoWords<'a> {
    /// A comment line, e.g. `(text)` or `; text`.
    pub comment: &'a dyn Fn(&str) -> String,
    /// The modal set-up line (units, absolute, feed per minute, exact stop).
    pub setup: &'a str,
    /// The linear-move word, `G1` or `G01`.
    pub linear: &'a str,
    /// The lines of one dwell (with any output switched around it).
    pub dwell: &'a dyn Fn(f64) -> Vec<String>,
    /// The closing lines, e.g. `M2`, or `M30` and `%`.
    pub end: &'a [&'a str],
}

/// Writes the program's body after its header: the set-up line, the move to the start
/// point at the plan's feed, then every step of the test cycle with its comment, and the
/// closing lines.
pub(crate) fn write_iso_body(s: &mut String, plan: &TestPlan, words: &IsoWords) {
    use std::fmt::Write as _;
    let letter = plan.config.axis.upper();
    let _ = writeln!(s, "{}", words.setup);
    let start = plan.start_point_mm();
    let _ = writeln!(
        s,
        "{} X{} Y{} Z{} F{}",
        words.linear,
        mm3(start[0]),
        mm3(start[1]),
        mm3(start[2]),
        feed_mm_min(plan.config.feed_mm_s)
    );
    for step in plan.cycle() {
        if let Some(c) = comment(plan, &step) {
            let _ = writeln!(s, "{}", (words.comment)(&c));
        }
        match step {
            CycleStep::RunStart { .. } => {}
            CycleStep::Approach { position_mm, .. } | CycleStep::Overrun { position_mm, .. } => {
                let _ = writeln!(s, "{} {letter}{}", words.linear, mm3(position_mm));
            }
            CycleStep::Dwell { dwell_s, .. } => {
                for line in (words.dwell)(dwell_s) {
                    let _ = writeln!(s, "{line}");
                }
            }
        }
    }
    for line in words.end {
        let _ = writeln!(s, "{line}");
    }
}
