//! LinuxCNC (RS274/NGC) G-code for a test plan ([`render`]).
//!
//! # Words used (LinuxCNC G-code reference, `docs/src/gcode/g-code.adoc` and `m-code.adoc`)
//!
//! * `G21` millimetres, `G90` absolute distances, `G94` units-per-minute feed, `G61` exact
//!   path (no blending: every programmed point is reached).
//! * `G1 X… Y… Z… F…` a feed move; `F` in mm/min under `G21 G94`, modal, so it is written
//!   once, on the first move.
//! * `G4 P…` dwell, **P in seconds** (a decimal number; a negative P is an error).
//! * `M64 P n` / `M65 P n` switch motion digital output n on / off *immediately* (as
//!   opposed to `M62/M63`, which change it with the next move). `n` is 0 … num_dio − 1,
//!   num_dio being motmod's parameter (4 by default, 64 at most: `EMCMOT_MAX_DIO` in
//!   `src/emc/motion/emcmotcfg.h`). LinuxCNC's task waits for the motion queue to drain
//!   before it issues an immediate output (`emcTaskCheckPreconditions` in
//!   `src/emc/task/emctaskmain.cc` returns `EMC_TASK_EXEC_WAITING_FOR_MOTION` for
//!   `EMC_MOTION_SET_DOUT` with `now`), so `M64` after a `G1` fires with the axis at rest
//!   on the target — a board wired to that output gets a rising edge at "target reached"
//!   and a falling edge at "target left", the same events as its MARK frames.
//! * `( … )` comments; `M2` ends the program.
//!
//! The program is checked against LinuxCNC's own interpreter (`rs274`, Debian package
//! `linuxcnc-uspace`) by `tests/it/testplan.rs` when that is installed:
//! `rs274 -g plan.ngc` prints the canonical moves (`STRAIGHT_FEED`, `DWELL`).

use std::fmt::Write as _;

use super::{IsoWords, ProgramError, header_lines, seconds3, write_iso_body};
use crate::sim::testplan::TestPlan;

/// LinuxCNC's largest number of motion digital outputs (`EMCMOT_MAX_DIO`).
pub const MAX_DIO: u32 = 64;

/// The program; `mark_output` toggles `M64/M65 P n` around every dwell.
pub fn render(plan: &TestPlan, mark_output: Option<u32>) -> Result<String, ProgramError> {
    if let Some(index) = mark_output
        && index >= MAX_DIO
    {
        return Err(ProgramError::MarkOutputRange {
            index,
            max: MAX_DIO - 1,
        });
    }
    let mut s = String::new();
    for line in header_lines(plan, super::Dialect::LinuxCnc) {
        let _ = writeln!(s, "({})", line.replace(['(', ')'], ""));
    }
    if let Some(n) = mark_output {
        let _ = writeln!(
            s,
            "(digital output {n} is on while the axis dwells at a target)"
        );
    }
    let dwell = |dwell_s: f64| -> Vec<String> {
        let g4 = format!("G4 P{}", seconds3(dwell_s));
        match mark_output {
            Some(n) => vec![format!("M64 P{n}"), g4, format!("M65 P{n}")],
            None => vec![g4],
        }
    };
    write_iso_body(
        &mut s,
        plan,
        &IsoWords {
            comment: &|c| format!("({c})"),
            setup: "G21 G90 G94 G61",
            linear: "G1",
            dwell: &dwell,
            end: &["M2"],
        },
    );
    Ok(s)
}
