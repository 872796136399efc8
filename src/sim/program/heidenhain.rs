//! HEIDENHAIN TNC conversational (Klartext) program for a test plan ([`render`]).
//!
//! # Syntax used (HEIDENHAIN TNC 640 User's Manual "Klartext Programming" and User's
//! Manual "Programming of Machining Cycles", cycle 9 DWELL TIME)
//!
//! * Every block is numbered from 0; block 0 is `BEGIN PGM name MM` (mm program), the last
//!   `END PGM name MM`. The name is letters, digits and `_` ([`PROGRAM_NAME`]).
//! * `L X+… Y+… Z+… R0 F…` a straight line in absolute coordinates, the sign always
//!   written, `R0` no radius compensation, F in mm/min (modal: written once).
//! * Cycle 9 **DWELL TIME** is two blocks, `CYCL DEF 9.0 DWELL TIME` and
//!   `CYCL DEF 9.1 DWELL t` with t in seconds, input range 0 … 3600 s in steps of
//!   0.001 s ([`MAX_DWELL_S`]). It is DEF-active: it runs where it is defined, no
//!   `CYCL CALL` needed.
//! * `;` comment blocks; `M30` ends the program.

use std::fmt::Write as _;

use super::{Dialect, ProgramError, comment, feed_mm_min, header_lines, mm3, seconds3};
use crate::sim::testplan::{CycleStep, TestPlan};

/// The program name written in `BEGIN PGM` / `END PGM`.
pub const PROGRAM_NAME: &str = "ERRMAP_ISO230";

/// Cycle 9's largest dwell, s.
pub const MAX_DWELL_S: f64 = 3600.0;

/// `v` mm with an explicit sign and 3 decimals.
fn signed(v: f64) -> String {
    let t = mm3(v);
    if t.starts_with('-') {
        t
    } else {
        format!("+{t}")
    }
}

/// The program.
pub fn render(plan: &TestPlan) -> Result<String, ProgramError> {
    let dwell_s = plan.config.dwell_s;
    if dwell_s > MAX_DWELL_S {
        return Err(ProgramError::DwellTooLong {
            dialect: Dialect::Heidenhain,
            dwell_s,
            max_s: MAX_DWELL_S,
        });
    }
    let letter = plan.config.axis.upper();
    let mut blocks: Vec<String> = Vec::new();
    blocks.push(format!("BEGIN PGM {PROGRAM_NAME} MM"));
    for line in header_lines(plan, Dialect::Heidenhain) {
        blocks.push(format!("; {line}"));
    }
    let start = plan.start_point_mm();
    blocks.push(format!(
        "L X{} Y{} Z{} R0 F{}",
        signed(start[0]),
        signed(start[1]),
        signed(start[2]),
        feed_mm_min(plan.config.feed_mm_s)
    ));
    for step in plan.cycle() {
        if let Some(c) = comment(plan, &step) {
            blocks.push(format!("; {c}"));
        }
        match step {
            CycleStep::RunStart { .. } => {}
            CycleStep::Approach { position_mm, .. } | CycleStep::Overrun { position_mm, .. } => {
                blocks.push(format!("L {letter}{} R0", signed(position_mm)));
            }
            CycleStep::Dwell { dwell_s, .. } => {
                blocks.push("CYCL DEF 9.0 DWELL TIME".into());
                blocks.push(format!("CYCL DEF 9.1 DWELL {}", seconds3(dwell_s)));
            }
        }
    }
    blocks.push("M30".into());
    blocks.push(format!("END PGM {PROGRAM_NAME} MM"));
    let mut s = String::new();
    for (i, b) in blocks.iter().enumerate() {
        let _ = writeln!(s, "{i} {b}");
    }
    Ok(s)
}
