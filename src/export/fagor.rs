//! The Fagor 8055 leadscrew error compensation table `AL<axis>` ([`render_8055`]) and the
//! Fagor 8065 axis parameter file `<axis>.mp` holding the same table ([`render_8065`]).
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

//! # Fagor 8065 `<axis>.mp` ([`render_8065`])
//!
//! The 8065 keeps the leadscrew table among the axis' parameters, in a UTF-16LE text file
//! with a byte-order mark and CRLF (the layout of real `X.mp`/`Y.mp` files from the same
//! repository): a first line `<A> AXIS` padded to 30 characters then `;3100`, the lines
//! `MM` `;0` and `MPVersionID` `;100` padded the same way, a column heading, and one line
//! per parameter, `2;` + the name padded to 50 + `;` + the value (padded to 20 and followed
//! by `;` and a comment when it has one). The table is `/LSCRWCOMP` (1, on),
//! `/LSCRWDATA/NPOINTS`, `/LSCRWDATA/BIDIR` (0: one table for both directions, 1: the
//! NEGERROR column is used), then `/LSCRWDATA/DATA/POSITION i`, `POSERROR i`, `NEGERROR i`
//! (i = 1…NPOINTS, each block in turn), 4 decimals in mm (5 in inch). Values: the same
//! error actual − theoretical = c as the 8055. errmap writes only this block: a partial
//! parameter file, whose other parameters the CNC keeps or defaults (not confirmed); on a
//! machine that already has an `<axis>.mp`, update that file instead (`export
//! --existing`), which keeps every other parameter byte for byte. The meaning of the
//! header numbers (3100, 0, 100) is copied from the real files, not from a manual.
//!
//! Interpolation (both controls, from the 8055 installation manual's description of the
//! table; the 8065's own manual was not found): linear between points, the positions
//! referred to machine zero and strictly increasing; a table whose every negative-direction
//! error is 0 (8065: BIDIR 0) applies the positive-direction errors both ways. What the
//! CNC applies beyond the first and last points is not stated in the sources found: keep
//! the table over the whole travel.

use super::{Controller, ExportError, Sampled, compensation_um};

/// Points of an 8055 leadscrew table (unverified against the manual).
pub const FAGOR_8055_MAX_POINTS: usize = 255;

/// Points of an 8065 table accepted by errmap (the 8055i manual's NPOINTS limit, 1000;
/// the 8065's own limit was not found).
pub const FAGOR_8065_MAX_POINTS: usize = 1000;

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

/// One `2;<name>;<value>[;<comment>]` parameter line of an 8065 axis file.
fn param_8065(name: &str, value: &str, comment: Option<&str>) -> String {
    match comment {
        Some(c) => format!("2;{name:<50};{value:<20};{c}\r\n"),
        None => format!("2;{name:<50};{value}\r\n"),
    }
}

/// The text of a Fagor 8065 `<axis>.mp` holding the leadscrew table (module docs), CRLF;
/// the file is this text in UTF-16LE with its byte-order mark ([`encode_8065`]). `reverse` (same positions) sets BIDIR 1 and fills NEGERROR with
/// its compensation; without it BIDIR is 0 and NEGERROR 0.
pub fn render_8065(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &Fagor8055Spec,
) -> Result<String, ExportError> {
    let rev = super::paired(forward, reverse)?;
    let n = forward.len();
    if n > FAGOR_8065_MAX_POINTS {
        return Err(ExportError::TooManyEntries {
            controller: Controller::Fagor,
            samples: n,
            padding: 0,
            limit: FAGOR_8065_MAX_POINTS,
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
    let mut positions: Vec<String> = Vec::with_capacity(n);
    for i in 0..n {
        let pos = fixed(forward.positions_mm[i] / k, d);
        if let Some(p) = positions.last()
            && pos.parse::<f64>().unwrap_or(f64::NAN) <= p.parse::<f64>().unwrap_or(f64::NAN)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: forward.positions_mm[i - 1],
                position_mm: forward.positions_mm[i],
            });
        }
        positions.push(pos);
    }
    let value = |e_um: f64| fixed(compensation_um(e_um) / (k * 1000.0), d);
    let bidir = reverse.is_some();
    let mut t = String::with_capacity((3 * n + 10) * 80);
    t.push_str(&format!("{:<30};3100\r\n", format!("{a} AXIS")));
    t.push_str(&format!("{:<30};0\r\n", "MM"));
    t.push_str(&format!("{:<30};100\r\n", "MPVersionID"));
    t.push_str(&format!(
        " ;{:<50};{:<20};Comment;\r\n",
        "Parameter", "Value"
    ));
    t.push_str(&param_8065("/LSCRWCOMP", "1", Some("Yes")));
    t.push_str(&param_8065("/LSCRWDATA/NPOINTS", &n.to_string(), None));
    t.push_str(&param_8065(
        "/LSCRWDATA/BIDIR",
        if bidir { "1" } else { "0" },
        Some(if bidir { "Yes" } else { "No" }),
    ));
    for (i, p) in positions.iter().enumerate() {
        t.push_str(&param_8065(
            &format!("/LSCRWDATA/DATA/POSITION {}", i + 1),
            p,
            None,
        ));
    }
    for (i, &e) in forward.error_um.iter().enumerate() {
        t.push_str(&param_8065(
            &format!("/LSCRWDATA/DATA/POSERROR {}", i + 1),
            &value(e),
            None,
        ));
    }
    for i in 0..n {
        let v = if bidir {
            value(rev.error_um[i])
        } else {
            fixed(0.0, d)
        };
        t.push_str(&param_8065(
            &format!("/LSCRWDATA/DATA/NEGERROR {}", i + 1),
            &v,
            None,
        ));
    }
    Ok(t)
}

/// An 8065 axis file's bytes: UTF-16LE after the byte-order mark FF FE.
pub fn encode_8065(text: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(2 + 2 * text.len());
    out.extend_from_slice(&[0xFF, 0xFE]);
    for u in text.encode_utf16() {
        out.extend_from_slice(&u.to_le_bytes());
    }
    out
}
