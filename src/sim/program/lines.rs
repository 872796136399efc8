//! Part programs for a campaign of measured lines in space ([`render_lines`]): the
//! volumetric plans of `errmap volumetric` (laser lines along axes, face and body
//! diagonals), in the same four dialects as the test-plan programs.
//!
//! For every line: a comment naming it (targets, runs, the probe offset at which the
//! retroreflector is mounted), a move of all three axes to its first target at the feed,
//! and a **programmed stop** (`M0`; HEIDENHAIN `STOP`) so the operator aligns the laser
//! before pressing cycle start. Then each run visits the targets in order — a move of
//! all three axes to the target and the dwell there — and returns to the first target,
//! as `volumetric::simulate` times it. The words are those of the test-plan programs
//! (module docs of [`linuxcnc`](super::linuxcnc), [`fanuc`](super::fanuc),
//! [`siemens`](super::siemens), [`heidenhain`](super::heidenhain)); the stop is LinuxCNC's
//! `M0` (pause, `docs/src/gcode/m-code.adoc`), the ISO 6983 `M00`/`M0` of FANUC and the
//! 840D (Programming Manual "Fundamentals", M0 programmed stop), and the TNC's `STOP`
//! block (TNC 640 User's Manual, "Programming a program STOP").
//!
//! The moves between targets are straight feed moves of all three axes; the path between
//! lines (from the last target of one to the first of the next) must be clear — the
//! header says so.

use std::fmt::Write as _;

use super::{Dialect, MAX_COORDINATE_MM, ProgramError, feed_mm_min, mm3, seconds3};

/// One measured line: its targets in the order they are visited, and its runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramLine {
    pub name: String,
    pub targets_mm: Vec<[f64; 3]>,
    pub runs: u32,
    /// Where the retroreflector sits relative to the tool point, mm (for the comment).
    pub probe_mm: [f64; 3],
}

/// A campaign: its lines, the feed of every move and the dwell at every target.
#[derive(Debug, Clone, PartialEq)]
pub struct LinesProgram {
    pub title: String,
    pub lines: Vec<ProgramLine>,
    pub feed_mm_s: f64,
    pub dwell_s: f64,
}

/// What one dialect writes for each element of the program.
struct Words {
    comment: fn(&str) -> String,
    setup: &'static str,
    /// A three-axis move; the feed on the first move only (modal).
    move3: fn([f64; 3], Option<&str>) -> String,
    dwell: Box<dyn Fn(f64) -> Vec<String>>,
    stop: &'static str,
    begin: Vec<String>,
    end: Vec<String>,
}

fn signed(v: f64) -> String {
    let t = mm3(v);
    if t.starts_with('-') {
        t
    } else {
        format!("+{t}")
    }
}

fn iso_move(linear: &str, p: [f64; 3], feed: Option<&str>) -> String {
    let mut s = format!("{linear} X{} Y{} Z{}", mm3(p[0]), mm3(p[1]), mm3(p[2]));
    if let Some(f) = feed {
        let _ = write!(s, " F{f}");
    }
    s
}

fn words(dialect: Dialect, dwell_s: f64) -> Result<Words, ProgramError> {
    Ok(match dialect {
        Dialect::LinuxCnc => Words {
            comment: |c| format!("({})", c.replace(['(', ')'], "")),
            setup: "G21 G90 G94 G61",
            move3: |p, f| iso_move("G1", p, f),
            dwell: Box::new(|s| vec![format!("G4 P{}", seconds3(s))]),
            stop: "M0",
            begin: vec![],
            end: vec!["M2".into()],
        },
        Dialect::Fanuc => {
            let ms = (dwell_s * 1000.0).round();
            if ms > super::fanuc::MAX_DWELL_MS as f64 {
                return Err(ProgramError::DwellTooLong {
                    dialect,
                    dwell_s,
                    max_s: super::fanuc::MAX_DWELL_MS as f64 / 1000.0,
                });
            }
            if ms < 1.0 {
                return Err(ProgramError::DwellTooShort {
                    dialect,
                    dwell_s,
                    min_s: 0.001,
                });
            }
            Words {
                comment: |c| format!("({})", super::fanuc::fanuc_comment(c)),
                setup: "G21 G90 G94",
                move3: |p, f| iso_move("G01", p, f),
                dwell: Box::new(move |_| vec![format!("G04 P{}", ms as u64)]),
                stop: "M00",
                begin: vec![
                    "%".into(),
                    format!(
                        "O{:04} (ERRMAP VOLUMETRIC LINES)",
                        super::fanuc::PROGRAM_NUMBER
                    ),
                ],
                end: vec!["M30".into(), "%".into()],
            }
        }
        Dialect::Siemens => Words {
            comment: |c| format!("; {c}"),
            setup: "G71 G90 G94 G60",
            move3: |p, f| iso_move("G1", p, f),
            dwell: Box::new(|s| vec![format!("G4 F{}", seconds3(s))]),
            stop: "M0",
            begin: vec![],
            end: vec!["M30".into()],
        },
        Dialect::Heidenhain => {
            if dwell_s > super::heidenhain::MAX_DWELL_S {
                return Err(ProgramError::DwellTooLong {
                    dialect,
                    dwell_s,
                    max_s: super::heidenhain::MAX_DWELL_S,
                });
            }
            Words {
                comment: |c| format!("; {c}"),
                setup: "",
                move3: |p, f| {
                    let mut s =
                        format!("L X{} Y{} Z{} R0", signed(p[0]), signed(p[1]), signed(p[2]));
                    if let Some(f) = f {
                        let _ = write!(s, " F{f}");
                    }
                    s
                },
                dwell: Box::new(|s| {
                    vec![
                        "CYCL DEF 9.0 DWELL TIME".into(),
                        format!("CYCL DEF 9.1 DWELL {}", seconds3(s)),
                    ]
                }),
                stop: "STOP",
                begin: vec![format!("BEGIN PGM {} MM", PROGRAM_NAME)],
                end: vec!["M30".into(), format!("END PGM {} MM", PROGRAM_NAME)],
            }
        }
    })
}

/// The HEIDENHAIN program name of a lines program.
pub const PROGRAM_NAME: &str = "ERRMAP_LINES";

/// The program for `p` in `dialect`. Refuses an empty campaign, a line without targets
/// or runs, non-finite or too large coordinates, and dwells the dialect cannot write.
pub fn render_lines(p: &LinesProgram, dialect: Dialect) -> Result<String, ProgramError> {
    if p.lines.is_empty()
        || p.lines
            .iter()
            .any(|l| l.targets_mm.is_empty() || l.runs == 0)
    {
        return Err(ProgramError::EmptyCampaign);
    }
    if let Some(&value_mm) = p
        .lines
        .iter()
        .flat_map(|l| l.targets_mm.iter().flatten())
        .find(|v| !v.is_finite() || v.abs() > MAX_COORDINATE_MM)
    {
        return Err(ProgramError::CoordinateTooLarge { value_mm });
    }
    if !(p.feed_mm_s.is_finite() && p.feed_mm_s > 0.0 && p.dwell_s.is_finite() && p.dwell_s >= 0.0)
    {
        return Err(ProgramError::EmptyCampaign);
    }
    let w = words(dialect, p.dwell_s)?;
    let feed = feed_mm_min(p.feed_mm_s);
    let mut blocks: Vec<String> = w.begin.clone();
    let visits: usize = p
        .lines
        .iter()
        .map(|l| l.targets_mm.len() * l.runs as usize)
        .sum();
    for h in [
        format!("errmap volumetric campaign {}, {dialect} dialect", p.title),
        format!(
            "{} lines, {visits} target visits, dwell {} s, feed {feed} mm/min",
            p.lines.len(),
            seconds3(p.dwell_s)
        ),
        "CHECK a clear path between lines: all three axes move together".into(),
        "the program stops before each line: align the laser, then cycle start".into(),
    ] {
        blocks.push((w.comment)(&h));
    }
    if !w.setup.is_empty() {
        blocks.push(w.setup.into());
    }
    let mut feed_written = false;
    for l in &p.lines {
        let n = l.targets_mm.len();
        blocks.push((w.comment)(&format!(
            "line {}: {n} targets, {} run{}, probe offset {} {} {} mm",
            l.name,
            l.runs,
            if l.runs == 1 { "" } else { "s" },
            mm3(l.probe_mm[0]),
            mm3(l.probe_mm[1]),
            mm3(l.probe_mm[2])
        )));
        let first = l.targets_mm[0];
        blocks.push((w.move3)(first, (!feed_written).then_some(feed.as_str())));
        feed_written = true;
        blocks.push(w.stop.into());
        for run in 1..=l.runs {
            blocks.push((w.comment)(&format!("run {run} of {}", l.runs)));
            for &t in &l.targets_mm {
                blocks.push((w.move3)(t, None));
                blocks.extend((w.dwell)(p.dwell_s));
            }
            blocks.push((w.move3)(first, None));
        }
    }
    blocks.extend(w.end);
    let mut s = String::new();
    for (i, b) in blocks.iter().enumerate() {
        if dialect == Dialect::Heidenhain {
            let _ = writeln!(s, "{i} {b}");
        } else {
            let _ = writeln!(s, "{b}");
        }
    }
    Ok(s)
}
