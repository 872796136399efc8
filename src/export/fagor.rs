//! The Fagor 8055 leadscrew error compensation table `AL<axis>` ([`render_8055`]).
//!
//! # Layout
//!
//! One line per point, CRLF, fields right-aligned in fixed widths, as the CNC stores the
//! table (the layout of real `ALX`/`ALY` files kept in the public `doug-co/laser_adjust`
//! repository):
//!
//! ```text
//!       P001          X    0.00000       EX    0.00000        EX    0.00000
//! ```
//!
//! `P<n>` (3 digits, from 1), the axis letter, the position, `E<axis>` and the error moving
//! in the positive direction, `E<axis>` and the error moving in the negative direction, in
//! the machine's unit: 4 decimals in mm, 5 in inch (the real files' inch resolution). The
//! positions must increase; between points the CNC interpolates linearly, and beyond the
//! last point it applies the last point's error. A table whose every negative-direction
//! error is 0 is one table for both directions.
//!
//! # Sign convention
//!
//! Fagor's manuals define the table's error as *real position − theoretical position* =
//! ISO 230-2's deviation x = −e, which the CNC subtracts; errmap writes the compensation
//! c = −e, the same number. The public `laser_adjust` tool adds an API laser's
//! LinearError (also x) to the table, which agrees. **Not checked on a machine** (see
//! `docs/import.md`): check one point after loading a table.
//!
//! Unverified limits: at most [`FAGOR_8055_MAX_POINTS`] points per axis (the usual
//! figure for the 8055's leadscrew tables); the manual's further rules (the error at the
//! reference point, the slope between points) are not enforced.

use super::{Controller, ExportError, Sampled, compensation_um};

/// Points of an 8055 leadscrew table (unverified against the manual).
pub const FAGOR_8055_MAX_POINTS: usize = 255;

/// What the table needs beyond the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fagor8055Spec {
    /// The axis letter the CNC uses (`X`, `Y`, `Z`, `U`, …).
    pub axis_letter: char,
    /// Whether the machine works in inch (the values are then in inch, 5 decimals).
    pub inch: bool,
}

/// `v` with `d` decimals, no `-0`.
fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.parse::<f64>() == Ok(0.0) => rest.to_string(),
        _ => s,
    }
}

/// An `AL<axis>` table: per sample, the compensation c = −e moving + and (with `reverse`)
/// moving −; without `reverse` the negative-direction column is 0 (one table).
pub fn render_8055(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &Fagor8055Spec,
) -> Result<String, ExportError> {
    let rev = super::paired(forward, reverse)?;
    let n = forward.len();
    if n > FAGOR_8055_MAX_POINTS {
        return Err(ExportError::TooManyEntries {
            controller: Controller::Fagor,
            samples: n,
            padding: 0,
            limit: FAGOR_8055_MAX_POINTS,
            length_mm: forward.length_mm(),
        });
    }
    if !spec.axis_letter.is_ascii_alphabetic() {
        return Err(ExportError::ControllerLimit {
            controller: Controller::Fagor,
            problem: format!("`{}` is not an axis letter", spec.axis_letter),
        });
    }
    let a = spec.axis_letter.to_ascii_uppercase();
    let (k, d) = if spec.inch { (25.4, 5) } else { (1.0, 4) };
    let mut out = String::with_capacity(n * 75);
    let mut previous: Option<String> = None;
    for i in 0..n {
        let pos = fixed(forward.positions_mm[i] / k, d);
        if let Some(p) = &previous
            && pos.parse::<f64>().unwrap_or(f64::NAN) <= p.parse::<f64>().unwrap_or(f64::NAN)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: forward.positions_mm[i - 1],
                position_mm: forward.positions_mm[i],
            });
        }
        let up = fixed(compensation_um(forward.error_um[i]) / (k * 1000.0), d);
        let down = if reverse.is_some() {
            fixed(compensation_um(rev.error_um[i]) / (k * 1000.0), d)
        } else {
            fixed(0.0, d)
        };
        out.push_str(&format!(
            "{:>10}{a:>11}{pos:>11}{:>9}{up:>11}{:>10}{down:>11}\r\n",
            format!("P{:03}", i + 1),
            format!("E{a}"),
            format!("E{a}"),
        ));
        previous = Some(pos);
    }
    Ok(out)
}
