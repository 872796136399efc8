//! Part programs: a [`TestPlan`]'s standard test cycle, or a campaign of measured lines in
//! space ([`LinesProgram`], the volumetric plans), as blocks a controller executes. The
//! shape of both programs is written once here; each dialect's words — comments, moves,
//! dwell, stop, opening and closing blocks — are its [`ProgramSyntax`], in its own file
//! beside its compensation table, and [`Dialect::program`] hands it out. Like the table
//! writers these are pure renderers: a plan in, the program text out; the caller writes
//! the file.
//!
//! | dialect | module | units, positioning | feed | dwell | MARK output |
//! |---|---|---|---|---|---|
//! | LinuxCNC | [`linuxcnc`](super::linuxcnc) | `G21 G90` | `G1 … F` mm/min (`G94`) | `G4 P` s | `M64/M65 P n` around each dwell |
//! | Fanuc | [`fanuc`](super::fanuc) | `G21 G90` | `G01 … F` mm/min (`G94`) | `G04 P` ms (integer) | — |
//! | Siemens 840D | [`siemens`](super::siemens) | `G71 G90` | `G1 … F` mm/min (`G94`) | `G4 F` s | — |
//! | Heidenhain | [`heidenhain`](super::heidenhain) | `BEGIN PGM … MM` | `L … R0 F` mm/min | `CYCL DEF 9.0 DWELL TIME` s | — |
//!
//! # The test cycle ([`render`])
//!
//! Every program first moves all three axes to the start point P_1 − o on the line at the
//! test feed — the path there must be clear; the operator should position the machine
//! near it first — then runs the cycle with moves along the tested axis only, and ends at
//! P_1 − o. Positions are written to 0.001 mm (the plan's targets are rounded to it).
//! No dialect changes tool, spindle or coolant.
//!
//! # A campaign of lines ([`render_lines`])
//!
//! For every line: a comment naming it (targets, runs, the probe offset at which the
//! retroreflector is mounted), a move of all three axes to its first target at the feed,
//! and a **programmed stop** (`M0`; HEIDENHAIN `STOP`) so the operator aligns the laser
//! before pressing cycle start. Then each run visits the targets in order — a move of
//! all three axes to the target and the dwell there — and returns to the first target,
//! as `volumetric::simulate` times it. The stop is LinuxCNC's `M0` (pause,
//! `docs/src/gcode/m-code.adoc`), the ISO 6983 `M00`/`M0` of FANUC and the 840D
//! (Programming Manual "Fundamentals", M0 programmed stop), and the TNC's `STOP` block
//! (TNC 640 User's Manual, "Programming a program STOP").
//!
//! The moves between targets are straight feed moves of all three axes; the path between
//! lines (from the last target of one to the first of the next) must be clear — the
//! header says so.

use std::fmt::Write as _;

use super::{ControllerSetting, DIALECTS, Dialect, names_where};
use crate::base::{Direction, NamesSettings, Setting};
use crate::sim::{CycleStep, LinesProgram, RotaryPlan, TestPlan};

/// The largest coordinate every dialect writes with 3 decimals (Fanuc IS-B: 8 digits).
pub const MAX_COORDINATE_MM: f64 = 99_999.999;

/// Which program is written: the opening and closing blocks name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgramKind {
    /// The ISO 230-2 standard test cycle of a [`TestPlan`].
    TestCycle,
    /// A volumetric campaign of lines ([`LinesProgram`]).
    Lines,
}

impl ProgramKind {
    /// The program's title in upper case (FANUC's `O` block).
    pub fn title(self) -> &'static str {
        match self {
            ProgramKind::TestCycle => "ISO 230-2",
            ProgramKind::Lines => "VOLUMETRIC LINES",
        }
    }

    /// The program's name as a word (letters, digits, `_`: HEIDENHAIN's `BEGIN PGM`).
    pub fn word(self) -> &'static str {
        match self {
            ProgramKind::TestCycle => "ERRMAP_ISO230",
            ProgramKind::Lines => "ERRMAP_LINES",
        }
    }
}

/// A dialect's part-program words. The program's shape ([`render`], [`render_lines`]) is
/// the same in every dialect; only these differ.
pub trait ProgramSyntax: Sync {
    /// The dialect's name (its [`Dialect::name`], what `--dialect` takes).
    fn name(&self) -> &'static str;
    /// The usual file extension.
    fn extension(&self) -> &'static str;
    /// A comment block holding `text`.
    fn comment(&self, text: &str) -> String;
    /// The blocks before the header comments.
    fn begin(&self, _kind: ProgramKind) -> Vec<String> {
        Vec::new()
    }
    /// The modal set-up block (units, absolute, feed per minute, exact stop), if any.
    fn setup(&self) -> Option<&'static str>;
    /// A feed move of the named axes (`("X", 10.0)`, mm), with the feed word (mm/min) on
    /// the first move only (modal).
    fn feed_move(&self, axes: &[(&str, f64)], feed: Option<&str>) -> String;
    /// The blocks of a dwell of `dwell_s`; refuses a dwell the control cannot write.
    fn dwell(&self, dwell_s: f64) -> Result<Vec<String>, ProgramError>;
    /// The programmed stop.
    fn stop(&self) -> &'static str;
    /// The closing blocks.
    fn end(&self, kind: ProgramKind) -> Vec<String>;
    /// Whether every block carries its number from 0 (HEIDENHAIN).
    fn numbered(&self) -> bool {
        false
    }
    /// How many digital outputs the program can switch around a dwell (MARKs for an
    /// acquisition board); `None`: the dialect writes none.
    fn mark_outputs(&self) -> Option<u32> {
        None
    }
    /// The block switching digital output `n` on or off (where [`Self::mark_outputs`]).
    fn output(&self, _n: u32, _on: bool) -> String {
        String::new()
    }
}

/// The dialects that write part programs, in the registry's order.
pub fn dialects() -> impl Iterator<Item = &'static dyn ProgramSyntax> {
    DIALECTS.iter().filter_map(|d| d.program())
}

/// The part-program dialect named `name` (case-insensitive), or why not.
pub fn dialect(name: &str) -> Result<&'static dyn ProgramSyntax, ParseDialectError> {
    super::dialect(name)
        .and_then(|d| d.program())
        .ok_or_else(|| ParseDialectError(name.to_string()))
}

/// The dialect `--dialect` takes when none is given (the registry's first that writes
/// programs).
pub fn default_dialect() -> &'static dyn ProgramSyntax {
    dialects().next().expect("a dialect writes part programs")
}

impl std::fmt::Debug for dyn ProgramSyntax {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::fmt::Display for dyn ProgramSyntax {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl PartialEq for dyn ProgramSyntax {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

/// A dialect name that writes no part program.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.render(&Setting::words))]
pub struct ParseDialectError(pub String);

impl NamesSettings for ParseDialectError {
    type Setting = ControllerSetting;
    fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        format!(
            "{}: `{}` is not {}",
            name(ControllerSetting::ProgramDialect),
            self.0,
            names_where(|d: &dyn Dialect| d.program().is_some(), "or")
        )
    }
}

/// Options beyond the plan.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ProgramOptions {
    /// A digital output switched on at each dwell and off after it, so that an acquisition
    /// board takes its MARKs from the controller (LinuxCNC only: `M64/M65 P n`).
    pub mark_output: Option<u32>,
}

/// Why a program cannot be written. A refusal of the mark output or the dwell names the
/// setting ([`ControllerSetting`]; [`NamesSettings::render`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramError {
    #[error("{}", self.render(&Setting::words))]
    MarkOutputUnsupported { dialect: &'static str },
    #[error("{}", self.render(&Setting::words))]
    MarkOutputRange {
        controller: &'static str,
        index: u32,
        max: u32,
    },
    #[error("{}", self.render(&Setting::words))]
    DwellTooLong {
        dialect: &'static str,
        dwell_s: f64,
        max_s: f64,
    },
    #[error("{}", self.render(&Setting::words))]
    DwellTooShort {
        dialect: &'static str,
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

impl NamesSettings for ProgramError {
    type Setting = ControllerSetting;
    fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        use ControllerSetting::{Dwell, MarkOutput};
        match self {
            ProgramError::MarkOutputUnsupported { dialect } => format!(
                "{}: the {dialect} program has no digital-output MARKs (only {}'s M64/M65)",
                name(MarkOutput),
                names_where(
                    |d: &dyn Dialect| d.program().is_some_and(|p| p.mark_outputs().is_some()),
                    "and"
                )
            ),
            ProgramError::MarkOutputRange {
                controller,
                index,
                max,
            } => format!(
                "{}: output {index} is beyond {controller}'s motion digital outputs 0…{max} \
                 (a default configuration has 4: motmod num_dio)",
                name(MarkOutput)
            ),
            ProgramError::DwellTooLong {
                dialect,
                dwell_s,
                max_s,
            } => format!(
                "{}: {dwell_s} s is beyond the {dialect} dwell limit of {max_s} s",
                name(Dwell)
            ),
            ProgramError::DwellTooShort {
                dialect,
                dwell_s,
                min_s,
            } => format!(
                "{}: {dwell_s} s is below the {dialect} dwell resolution of {min_s} s",
                name(Dwell)
            ),
            ProgramError::CoordinateTooLarge { .. } | ProgramError::EmptyCampaign => {
                self.to_string()
            }
        }
    }
}

/// The blocks written as lines, numbered from 0 where the dialect numbers them.
fn text(p: &dyn ProgramSyntax, blocks: &[String]) -> String {
    let mut s = String::new();
    for (i, b) in blocks.iter().enumerate() {
        if p.numbered() {
            let _ = writeln!(s, "{i} {b}");
        } else {
            let _ = writeln!(s, "{b}");
        }
    }
    s
}

/// The blocks of one dwell, with the MARK output switched around it.
fn dwell_blocks(
    p: &dyn ProgramSyntax,
    dwell_s: f64,
    mark: Option<u32>,
) -> Result<Vec<String>, ProgramError> {
    let dwell = p.dwell(dwell_s)?;
    Ok(match mark {
        Some(n) => std::iter::once(p.output(n, true))
            .chain(dwell)
            .chain(std::iter::once(p.output(n, false)))
            .collect(),
        None => dwell,
    })
}

/// The three axes at `p`.
fn xyz(p: [f64; 3]) -> [(&'static str, f64); 3] {
    [("X", p[0]), ("Y", p[1]), ("Z", p[2])]
}

/// The program for `plan` in dialect `p`.
pub fn render(
    plan: &TestPlan,
    p: &dyn ProgramSyntax,
    options: &ProgramOptions,
) -> Result<String, ProgramError> {
    let mark = options.mark_output;
    let Some(outputs) = (match mark {
        Some(_) => p.mark_outputs(),
        None => Some(0),
    }) else {
        return Err(ProgramError::MarkOutputUnsupported { dialect: p.name() });
    };
    check_coordinates(plan)?;
    if let Some(index) = mark
        && index >= outputs
    {
        return Err(ProgramError::MarkOutputRange {
            controller: super::dialect(p.name()).map_or("", |d| d.controller()),
            index,
            max: outputs - 1,
        });
    }
    let dwell = dwell_blocks(p, plan.config.dwell_s, mark)?;
    let c = &plan.config;
    let letter = c.axis.upper();
    let mut blocks = p.begin(ProgramKind::TestCycle);
    for line in header_lines(plan, p.name()) {
        blocks.push(p.comment(&line));
    }
    if let Some(n) = mark {
        blocks.push(p.comment(&format!(
            "digital output {n} is on while the axis dwells at a target"
        )));
    }
    blocks.extend(p.setup().map(String::from));
    let feed = feed_mm_min(c.feed_mm_s);
    blocks.push(p.feed_move(&xyz(plan.start_point_mm()), Some(&feed)));
    for step in plan.cycle() {
        if let Some(text) = comment(plan, &step) {
            blocks.push(p.comment(&text));
        }
        match step {
            CycleStep::RunStart { .. } => {}
            CycleStep::Approach { position_mm, .. } | CycleStep::Overrun { position_mm, .. } => {
                blocks.push(p.feed_move(&[(letter, position_mm)], None));
            }
            CycleStep::Dwell { .. } => blocks.extend(dwell.iter().cloned()),
        }
    }
    blocks.extend(p.end(ProgramKind::TestCycle));
    Ok(text(p, &blocks))
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

/// The program for the campaign `c` in dialect `p`. Refuses an empty campaign, a line
/// without targets or runs, non-finite or too large coordinates, and dwells the dialect
/// cannot write.
pub fn render_lines(c: &LinesProgram, p: &dyn ProgramSyntax) -> Result<String, ProgramError> {
    if c.lines.is_empty()
        || c.lines
            .iter()
            .any(|l| l.targets_mm.is_empty() || l.runs == 0)
    {
        return Err(ProgramError::EmptyCampaign);
    }
    if let Some(&value_mm) = c
        .lines
        .iter()
        .flat_map(|l| l.targets_mm.iter().flatten())
        .find(|v| !v.is_finite() || v.abs() > MAX_COORDINATE_MM)
    {
        return Err(ProgramError::CoordinateTooLarge { value_mm });
    }
    if !(c.feed_mm_s.is_finite() && c.feed_mm_s > 0.0 && c.dwell_s.is_finite() && c.dwell_s >= 0.0)
    {
        return Err(ProgramError::EmptyCampaign);
    }
    let dwell = p.dwell(c.dwell_s)?;
    let feed = feed_mm_min(c.feed_mm_s);
    let mut blocks = p.begin(ProgramKind::Lines);
    let visits: usize = c
        .lines
        .iter()
        .map(|l| l.targets_mm.len() * l.runs as usize)
        .sum();
    for h in [
        format!(
            "errmap volumetric campaign {}, {} dialect",
            c.title,
            p.name()
        ),
        format!(
            "{} lines, {visits} target visits, dwell {} s, feed {feed} mm/min",
            c.lines.len(),
            seconds3(c.dwell_s)
        ),
        "CHECK a clear path between lines: all three axes move together".into(),
        "the program stops before each line: align the laser, then cycle start".into(),
    ] {
        blocks.push(p.comment(&h));
    }
    blocks.extend(p.setup().map(String::from));
    let mut feed_written = false;
    for l in &c.lines {
        let n = l.targets_mm.len();
        blocks.push(p.comment(&format!(
            "line {}: {n} targets, {} run{}, probe offset {} {} {} mm",
            l.name,
            l.runs,
            if l.runs == 1 { "" } else { "s" },
            mm3(l.probe_mm[0]),
            mm3(l.probe_mm[1]),
            mm3(l.probe_mm[2])
        )));
        let first = l.targets_mm[0];
        blocks.push(p.feed_move(&xyz(first), (!feed_written).then_some(feed.as_str())));
        feed_written = true;
        blocks.push(p.stop().into());
        for run in 1..=l.runs {
            blocks.push(p.comment(&format!("run {run} of {}", l.runs)));
            for &t in &l.targets_mm {
                blocks.push(p.feed_move(&xyz(t), None));
                blocks.extend(dwell.iter().cloned());
            }
            blocks.push(p.feed_move(&xyz(first), None));
        }
    }
    blocks.extend(p.end(ProgramKind::Lines));
    Ok(text(p, &blocks))
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

/// `v` mm with an explicit sign and 3 decimals (HEIDENHAIN).
pub(crate) fn signed_mm3(v: f64) -> String {
    let t = mm3(v);
    if t.starts_with('-') {
        t
    } else {
        format!("+{t}")
    }
}

/// An ISO 6983 feed move: `linear` (`G1`, `G01`), each axis' word, the feed word.
pub(crate) fn iso_move(linear: &str, axes: &[(&str, f64)], feed: Option<&str>) -> String {
    let mut s = linear.to_string();
    for (letter, v) in axes {
        let _ = write!(s, " {letter}{}", mm3(*v));
    }
    if let Some(f) = feed {
        let _ = write!(s, " F{f}");
    }
    s
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
fn comment(plan: &TestPlan, step: &CycleStep) -> Option<String> {
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
fn header_lines(plan: &TestPlan, dialect: &str) -> Vec<String> {
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
fn other_letters(plan: &TestPlan) -> [&'static str; 2] {
    use crate::base::Axis;
    match plan.config.axis {
        Axis::X => ["Y", "Z"],
        Axis::Y => ["X", "Z"],
        Axis::Z => ["X", "Y"],
    }
}

/// The ISO 230-2 cycle of a rotary axis ([`RotaryPlan`], `docs/rotary.md` §5) in dialect
/// `p`: the header comments, the dialect's set-up, a move to from − overrun, then per run
/// every target ascending with a dwell, on to to + overrun, every target descending, back
/// to from − overrun. Moves of the rotary axis only, each with its feed word in °/min
/// (60 × the plan's °/s; the controls read F of a rotary-only move as degrees per minute
/// under G94 — an assumption for FANUC, Siemens and HEIDENHAIN, see `docs/rotary.md`).
/// Angles absolute and unwrapped (below 0, beyond 360) with 3 decimals.
pub fn render_rotary(plan: &RotaryPlan, p: &dyn ProgramSyntax) -> Result<String, ProgramError> {
    let c = &plan.config;
    let letter = c.axis.upper();
    let feed = feed_mm_min(c.feed_deg_s);
    let dwell = p.dwell(c.dwell_s)?;
    let mut blocks = p.begin(ProgramKind::TestCycle);
    let header = [
        format!(
            "errmap plan: ISO 230-2 cycle of rotary axis {letter}, {} targets from {} to {} deg, \
             {} runs, {} dialect",
            plan.targets_deg.len(),
            c.from_deg,
            c.to_deg,
            c.runs,
            p.name()
        ),
        format!(
            "overrun {} deg, dwell {} s, feed {feed} deg/min",
            c.overrun_deg, c.dwell_s
        ),
        "angles absolute and unwrapped, below 0 and beyond 360: the axis must count \
         continuously; a modulo axis needs the control's directional moves"
            .to_string(),
    ];
    blocks.extend(header.iter().map(|h| p.comment(h)));
    blocks.extend(p.setup().map(String::from));
    let start = c.from_deg - c.overrun_deg;
    blocks.push(p.feed_move(&[(letter, start)], Some(&feed)));
    for (kind, v) in plan.events() {
        if kind == 'M' {
            blocks.push(p.feed_move(&[(letter, v)], Some(&feed)));
        } else {
            blocks.extend(dwell.iter().cloned());
        }
    }
    blocks.extend(p.end(ProgramKind::TestCycle));
    Ok(text(p, &blocks))
}
