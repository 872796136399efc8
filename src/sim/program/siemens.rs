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

use super::{Dialect, IsoWords, ProgramError, header_lines, seconds3, write_iso_body};
use crate::sim::testplan::TestPlan;

/// The program (an `.MPF` main program).
pub fn render(plan: &TestPlan) -> Result<String, ProgramError> {
    let mut s = String::new();
    for line in header_lines(plan, Dialect::Siemens) {
        let _ = writeln!(s, "; {line}");
    }
    write_iso_body(
        &mut s,
        plan,
        &IsoWords {
            comment: &|c| format!("; {c}"),
            setup: "G71 G90 G94 G60",
            linear: "G1",
            dwell: &|dwell_s| vec![format!("G4 F{}", seconds3(dwell_s))],
            end: &["M30"],
        },
    );
    Ok(s)
}
