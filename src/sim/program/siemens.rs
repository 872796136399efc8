//! SINUMERIK 840D sl (Siemens dialect) part program for a test plan ([`render`]).
//!
//! # Words used (SINUMERIK 840D sl / 828D Programming Manual "Fundamentals",
//! 6FC5398-1BP40-xBA0: "Dwell time (G4)", "Metric/inch dimensions (G70/G71)",
//! "Feedrate (G93, G94, G95, F…)", "Exact stop (G60)")
//!
//! * `G71` mm, `G90` absolute, `G94` feed in mm/min, `G60` exact stop (modal: every
//!   block ends at rest in the fine window, no velocity blending).
//! * `G1 X… F…` a feed move, F mm/min.
//! * `G4 F…` dwell, **F in seconds** (`G4 S…` would be spindle revolutions). G4 must be in
//!   a block of its own; the F in a G4 block applies only to the dwell, the programmed
//!   feed stays in force afterwards.
//! * `;` comments; `M30` ends the program.
//!
//! Positions are written with 3 decimals: the default input resolution MD10200
//! `INT_INCR_PER_MM` is 1000 (0.001 mm).

use std::fmt::Write as _;

use super::{Dialect, ProgramError, comment, feed_mm_min, header_lines, mm3, seconds3};
use crate::sim::testplan::{CycleStep, TestPlan};

/// The program (an `.MPF` main program).
pub fn render(plan: &TestPlan) -> Result<String, ProgramError> {
    let letter = plan.config.axis.upper();
    let mut s = String::new();
    for line in header_lines(plan, Dialect::Siemens) {
        let _ = writeln!(s, "; {line}");
    }
    let _ = writeln!(s, "G71 G90 G94 G60");
    let start = plan.start_point_mm();
    let _ = writeln!(
        s,
        "G1 X{} Y{} Z{} F{}",
        mm3(start[0]),
        mm3(start[1]),
        mm3(start[2]),
        feed_mm_min(plan.config.feed_mm_s)
    );
    for step in plan.cycle() {
        if let Some(c) = comment(plan, &step) {
            let _ = writeln!(s, "; {c}");
        }
        match step {
            CycleStep::RunStart { .. } => {}
            CycleStep::Approach { position_mm, .. } | CycleStep::Overrun { position_mm, .. } => {
                let _ = writeln!(s, "G1 {letter}{}", mm3(position_mm));
            }
            CycleStep::Dwell { dwell_s, .. } => {
                let _ = writeln!(s, "G4 F{}", seconds3(dwell_s));
            }
        }
    }
    let _ = writeln!(s, "M30");
    Ok(s)
}
