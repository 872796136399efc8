//! Fanuc (Series 0i/30i milling) ISO G-code for a test plan ([`render`]).
//!
//! # Words used (FANUC Series 0i-MODEL F Operator's Manual, B-64604EN, part II
//! "Programming": "Dwell (G04)", "Inch/metric conversion (G20, G21)", "Feed functions")
//!
//! * `%` opens and closes the file for transfer; `O….` is the program number
//!   ([`PROGRAM_NUMBER`], 1 … 9999; 8000 … 9999 are often edit-protected by parameter 3202).
//! * `G21` mm, `G90` absolute, `G94` feed per minute; `G01 X… F…` a feed move, F in mm/min.
//! * **Every coordinate is written with a decimal point.** Without one, a Fanuc reads the
//!   number in least input increments (IS-B: `X10` is 0.010 mm) unless pocket-calculator
//!   decimal input (parameter 3401#0 DPI) is set, so `X10.000` is the only unambiguous form.
//! * `G04 P…` dwell: **P is an integer number of milliseconds** (decimal point not
//!   permitted; 1 … 99 999 999, i.e. at most 99 999.999 s). `G04 X…` takes seconds with a
//!   decimal point, but X's reading depends on the same DPI parameter on some models and on
//!   G95 (revolutions), while an integer P in G94 is always ms — so errmap writes P, the
//!   dwell rounded to 1 ms. The same table of ranges is in Siemens' ISO-dialect manual for
//!   the 840D (SINUMERIK ISO Milling, 04.07, §3.3.1 "Dwell (G04)"), which mimics Fanuc.
//! * `( … )` comments (upper-case letters and digits are safe on every model); `M30` ends
//!   the program and rewinds.

use std::fmt::Write as _;

use super::{Dialect, IsoWords, ProgramError, header_lines, write_iso_body};
use crate::sim::testplan::TestPlan;

/// The program number written (`O0230`, after ISO 230).
pub const PROGRAM_NUMBER: u32 = 230;

/// The largest `G04 P` (ms).
pub const MAX_DWELL_MS: u64 = 99_999_999;

/// The program.
pub fn render(plan: &TestPlan) -> Result<String, ProgramError> {
    let dwell_s = plan.config.dwell_s;
    let dwell_ms = (dwell_s * 1000.0).round();
    if dwell_ms > MAX_DWELL_MS as f64 {
        return Err(ProgramError::DwellTooLong {
            dialect: Dialect::Fanuc,
            dwell_s,
            max_s: MAX_DWELL_MS as f64 / 1000.0,
        });
    }
    if dwell_ms < 1.0 {
        return Err(ProgramError::DwellTooShort {
            dialect: Dialect::Fanuc,
            dwell_s,
            min_s: 0.001,
        });
    }
    let dwell_ms = dwell_ms as u64;
    let mut s = String::new();
    let _ = writeln!(s, "%");
    let _ = writeln!(s, "O{PROGRAM_NUMBER:04} (ERRMAP ISO 230-2)");
    for line in header_lines(plan, Dialect::Fanuc) {
        let _ = writeln!(s, "({})", fanuc_comment(&line));
    }
    write_iso_body(
        &mut s,
        plan,
        &IsoWords {
            comment: &|c| format!("({})", fanuc_comment(c)),
            setup: "G21 G90 G94",
            linear: "G01",
            dwell: &|_| vec![format!("G04 P{dwell_ms}")],
            end: &["M30", "%"],
        },
    );
    Ok(s)
}

/// Upper case, ASCII letters, digits, spaces and `.,-+=:/` only (no parentheses).
pub(crate) fn fanuc_comment(text: &str) -> String {
    text.to_ascii_uppercase()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || " .,-+=:/".contains(c) {
                c
            } else {
                ' '
            }
        })
        .collect::<String>()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}
