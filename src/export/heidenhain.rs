//! The HEIDENHAIN TNC nonlinear axis error compensation renderer ([`render`]).
//!
//! # HEIDENHAIN nonlinear axis error compensation (`*.COM`, `*.CMA`)
//!
//! Sources: HEIDENHAIN Technical Manual MANUALplus 620, "Entering compensation values"
//! and "Assigning the compensation value tables to the axes" (pp. 716–718); HEIDENHAIN
//! TNC 407/415/425 Technical Manual (01.98), non-linear axis error compensation
//! (pp. 4-28 to 4-31) and PLC module 9095 (p. 622).
//!
//! A compensation value table (`*.COM`) holds, row by row, a compensation point in the
//! `AXISPOS` column (the position with respect to the machine datum) and the
//! compensation value in the column named after the compensated axis (the axis key of
//! `CfgAxes/axisList`); an optional `BACKLASH` column holds values measured in the
//! negative direction of traverse, which errmap does not write (the sources do not say
//! whether it holds the value or its difference from the positive one). A `*.CMA` table
//! (standard name `config.cma`) assigns the `.COM` tables to the axes, one column per
//! compensated axis, and the line marked `*` in its `ACTIVE` column is the active one;
//! errmap writes the `.COM` table and names the `.CMA` entry in its report. On the TNC
//! 407 family non-linear compensation is selected per axis by MP730 and a `.COM` table
//! has at most 256 entries (module 9095, error 3: "more than 256 entries") —
//! [`HEIDENHAIN_MAX_POINTS`], a parameter because later controls were not documented in
//! the sources consulted. The manuals' examples use equidistant points (5 mm on the
//! MANUALplus 620, a power of two of 0.1 µm on the TNC 407), so errmap writes
//! equidistant tables only.
//!
//! The file is HEIDENHAIN's table text: `BEGIN <name> MM`, a line of column names, one
//! line per row starting with its number `NR`, and `[END]`.
//!
//! # Sign convention
//!
//! The TNC 407 manual plots the table as the axis' "error" curve; the sign of that error
//! (actual − nominal or nominal − actual) is not stated in the sources consulted. errmap
//! writes ISO 230-2's deviation, actual − target = reference − indicated = c (mm), the
//! value a laser calibration reports and the same sign as the Siemens table. Check the
//! sign on the machine with one point before trusting the whole table. How the control
//! continues the compensation beyond the first and last points was not found either:
//! errmap adds no points.

use super::{Controller, ExportError, Sampled, compensation_um, fmt_mm};

/// The TNC 407/415/425 limit on entries per `.COM` table.
pub const HEIDENHAIN_MAX_POINTS: usize = 256;

/// A `.COM` table for axis `axis_key` (e.g. `X`), named `table_name` (e.g. `X.COM`), at
/// most `max_points` rows, values c in mm.
pub fn render(
    s: &Sampled,
    axis_key: &str,
    table_name: &str,
    max_points: usize,
) -> Result<String, ExportError> {
    let bad = |what: &str, v: &str| ExportError::ControllerLimit {
        controller: Controller::Heidenhain,
        problem: format!(
            "{what} `{v}` must be letters, digits, `_` or `.`, starting with a letter"
        ),
    };
    let ok = |v: &str| {
        !v.is_empty()
            && v.len() <= 32
            && v.starts_with(|c: char| c.is_ascii_alphabetic())
            && v.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
    };
    if !ok(axis_key) {
        return Err(bad("the axis key", axis_key));
    }
    if !ok(table_name) {
        return Err(bad("the table name", table_name));
    }
    s.check()?;
    s.uniform_step()?;
    let n = s.len();
    if n > max_points {
        return Err(ExportError::TooManyEntries {
            controller: Controller::Heidenhain,
            samples: n,
            padding: 0,
            limit: max_points,
            length_mm: s.length_mm(),
        });
    }
    let mut out = String::with_capacity((n + 4) * 40);
    out.push_str(&format!("BEGIN {table_name} MM\n"));
    out.push_str(&format!("{:<6}{:<18}{axis_key}\n", "NR", "AXISPOS"));
    for (i, (&x, &e)) in s.positions_mm.iter().zip(&s.error_um).enumerate() {
        out.push_str(&format!(
            "{:<6}{:<18}{}\n",
            i,
            signed(x),
            signed(compensation_um(e) * 1e-3)
        ));
    }
    out.push_str("[END]\n");
    Ok(out)
}

/// A number in mm at the file resolution with an explicit sign, as TNC tables show them.
fn signed(v: f64) -> String {
    let t = fmt_mm(v);
    if t.starts_with('-') {
        t
    } else {
        format!("+{t}")
    }
}

/// One sentence for the export report: where the table goes.
pub fn assignment_note(s: &Sampled, axis_key: &str, table_name: &str) -> String {
    let fixed: Vec<String> = crate::table::Axis::ALL
        .iter()
        .filter(|&&a| a != s.axis)
        .map(|a| format!("{a} = {}", super::fmt_fixed(s.at_mm[a.index()], 4)))
        .collect();
    format!(
        "enter {table_name} in the {axis_key} column of the active line of the .CMA table \
         ({axis_key} = F({axis_key}), measured along {} at {} mm)",
        s.axis,
        fixed.join(", ")
    )
}
