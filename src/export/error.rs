//! Why an export fails: [`ExportError`] (a controller's table limit names a step that
//! fits; the controller is named by its dialect's label, `src/controller/`), and the
//! [`MappedBox`] named when extrapolation is refused.

use std::fmt;

use super::{ExportSetting, fmt_fixed, fmt_mm, fmt_point};
use crate::base::{NamesSettings, Setting};
use crate::interp::Interpolator;
use crate::table::{Axis, TableError};

/// The mapped volume as far as `Interpolator::outside` reveals it: for each axis the
/// extent of the inside segment through one inside point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedBox {
    pub lo_mm: [f64; 3],
    pub hi_mm: [f64; 3],
}

impl MappedBox {
    /// Finds the box around `inside` by doubling outwards, then bisecting, along each
    /// axis (≈ 100 `outside` calls per face). `None` if `inside` is outside. A face the
    /// search does not reach within 1e9 mm is reported as ±∞.
    pub fn around(model: &dyn Interpolator, inside: [f64; 3]) -> Option<Self> {
        if model.outside(inside) {
            return None;
        }
        let mut lo_mm = [0.0; 3];
        let mut hi_mm = [0.0; 3];
        for a in 0..3 {
            lo_mm[a] = edge(model, inside, a, -1.0);
            hi_mm[a] = edge(model, inside, a, 1.0);
        }
        Some(Self { lo_mm, hi_mm })
    }
}

impl fmt::Display for MappedBox {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (a, axis) in Axis::ALL.iter().enumerate() {
            if a > 0 {
                f.write_str(", ")?;
            }
            write!(
                f,
                "{axis} {}–{} mm",
                fmt_fixed(self.lo_mm[a], 4),
                fmt_fixed(self.hi_mm[a], 4)
            )?;
        }
        Ok(())
    }
}

/// The last inside coordinate along axis `a` from `p` in direction `dir`.
fn edge(model: &dyn Interpolator, p: [f64; 3], a: usize, dir: f64) -> f64 {
    let x0 = p[a];
    let is_out = |x: f64| {
        let mut q = p;
        q[a] = x;
        model.outside(q)
    };
    let mut inside = x0;
    let mut d = 1.0;
    let mut outside = loop {
        let x = x0 + dir * d;
        if is_out(x) {
            break x;
        }
        inside = x;
        d *= 2.0;
        if d > 1e9 {
            return dir * f64::INFINITY;
        }
    };
    for _ in 0..200 {
        let mid = 0.5 * (inside + outside);
        if mid == inside || mid == outside {
            break;
        }
        if is_out(mid) {
            outside = mid;
        } else {
            inside = mid;
        }
    }
    inside
}

/// Why a table cannot be exported. A refusal that a setting would fix names it as an
/// [`ExportSetting`] ([`NamesSettings::render`]).
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("step {step_mm} mm must be a positive, finite length")]
    BadStep { step_mm: f64 },
    #[error("coordinate {value} mm along {axis} is not a finite number")]
    NonFiniteCoordinate { axis: Axis, value: f64 },
    #[error(
        "the range along {axis} from {start_mm} mm to {end_mm} mm is empty: the end must be greater than the start"
    )]
    EmptyRange {
        axis: Axis,
        start_mm: f64,
        end_mm: f64,
    },
    #[error("{}", self.render(&Setting::words))]
    StepDoesNotDivide {
        axis: Axis,
        length_mm: f64,
        step_mm: f64,
        fitting_step_mm: f64,
    },
    #[error("{points} sample points exceed errmap's cap of {limit}; use a coarser step")]
    TooManyPoints { points: u128, limit: usize },
    #[error("{}", too_many_message(controller, *any_step_fits, *samples, *padding, *limit, *length_mm))]
    TooManyEntries {
        /// The dialect's label (e.g. `controller::fanuc::LABEL`).
        controller: &'static str,
        /// The table lists every position, so any round step of at least the minimum fits
        /// (the last interval shorter): the message names one.
        any_step_fits: bool,
        /// Sampled positions.
        samples: usize,
        /// Entries the format adds (Siemens: 2 zero end points).
        padding: usize,
        limit: usize,
        length_mm: f64,
    },
    #[error("{}", outside_message(*outside, *total, *first_mm, mapped.as_ref()))]
    OutsideMappedRange {
        outside: usize,
        total: usize,
        first_mm: [f64; 3],
        mapped: Option<MappedBox>,
    },
    #[error("the model predicts {value} µm at {point}, which is not a finite number", point = fmt_point(*position_mm))]
    NonFinitePrediction { position_mm: [f64; 3], value: f64 },
    #[error(
        "sampled line has {positions} positions, {errors} errors and {flags} extrapolation flags"
    )]
    LengthMismatch {
        positions: usize,
        errors: usize,
        flags: usize,
    },
    #[error("a compensation table needs at least 2 samples, got {count}")]
    TooFewSamples { count: usize },
    #[error("sample {index}: position {position_mm} mm or error {error_um} µm is not finite")]
    NonFiniteSample {
        index: usize,
        position_mm: f64,
        error_um: f64,
    },
    #[error(
        "sample {index}: position {position_mm} mm does not increase on {previous_mm} mm \
         (at the file's 1e-6 mm resolution)"
    )]
    NotIncreasing {
        index: usize,
        previous_mm: f64,
        position_mm: f64,
    },
    #[error(
        "sample {index}: gap {gap_mm} mm differs from the table step {step_mm} mm; this format's tables have one interval (its `Spacing` is equidistant)"
    )]
    NotEquidistant {
        index: usize,
        step_mm: f64,
        gap_mm: f64,
    },
    #[error(
        "the table step {step_mm} mm is not a whole number of 1e-6 mm, so MIN, MAX and STEP \
         would not describe the points exactly; choose a step with at most 6 decimals"
    )]
    StepNotRepresentable { step_mm: f64 },
    #[error("reverse line does not match the forward line: {problem}")]
    ReverseMismatch { problem: String },
    #[error(
        "the {format} format has no direction-dependent table; export the forward errors \
         and configure backlash separately, or use a format that has one ({with})"
    )]
    ReverseUnsupported {
        format: &'static str,
        /// The formats that have one, by name.
        with: String,
    },
    #[error(
        "`{name}` is not a machine axis name (letters, digits and `_`, starting with a letter, at most 32 characters, e.g. X1)"
    )]
    BadAxisName { name: String },
    /// The reference position a FANUC table counts its points from is not one of them
    /// (`outside`: beyond the table's range).
    #[error("{}", self.render(&Setting::words))]
    ReferenceOffGrid {
        /// The dialect's label.
        controller: &'static str,
        reference_mm: f64,
        outside: bool,
        first_mm: f64,
        last_mm: f64,
        step_mm: f64,
    },
    #[error("{controller}: {problem}")]
    ControllerLimit {
        /// The dialect's label.
        controller: &'static str,
        problem: String,
    },
    #[error("the grid format samples a volume: call write_grid, not render_line")]
    GridNeedsVolume,
    #[error(transparent)]
    Table(#[from] TableError),
}

impl NamesSettings for ExportError {
    type Setting = ExportSetting;
    fn render(&self, name: &dyn Fn(ExportSetting) -> &'static str) -> String {
        match self {
            ExportError::StepDoesNotDivide {
                axis,
                length_mm,
                step_mm,
                fitting_step_mm,
            } => format!(
                "step {step_mm} mm does not divide the {} mm range along {axis} into whole \
                 intervals; the nearest finer step that does is {} mm; or keep the step on a \
                 round grid with the ends clamped or extrapolated ({} clamp|extrapolate)",
                fmt_mm(*length_mm),
                fmt_mm(*fitting_step_mm),
                name(ExportSetting::Ends)
            ),
            ExportError::ReferenceOffGrid {
                controller,
                reference_mm: r,
                outside,
                first_mm,
                last_mm,
                step_mm,
            } => format!(
                "{controller}: the reference position {r} mm {} ({first_mm} to {last_mm} mm every \
                 {step_mm} mm); FANUC counts the compensation points from the reference position: \
                 keep the step on the grid through it ({} clamp|extrapolate and {} {r}) and a \
                 range that contains it",
                if *outside {
                    "lies outside the table"
                } else {
                    "is not one of its points"
                },
                name(ExportSetting::Ends),
                name(ExportSetting::Reference)
            ),
            // The rest name no setting.
            other => other.to_string(),
        }
    }
}

fn too_many_message(
    controller: &str,
    any_step_fits: bool,
    samples: usize,
    padding: usize,
    limit: usize,
    length_mm: f64,
) -> String {
    let entries = samples + padding;
    let mut m = format!("{controller} allows at most {limit} entries; this table needs {entries}");
    if padding > 0 {
        m.push_str(&format!(" ({samples} samples + {padding} zero end points)"));
    }
    match fitting_step(length_mm, limit, padding) {
        Some((min, suggested)) => {
            let k = (length_mm / suggested).round() as usize;
            m.push_str(&format!(
                ": use a step of at least {} mm that divides the {} mm range, e.g. {} mm ({} entries)",
                fmt_mm(min),
                fmt_mm(length_mm),
                fmt_mm(suggested),
                k + 1 + padding
            ));
        }
        None => m.push_str(": the limit is too small for any table of this format"),
    }
    // A table that lists every nominal (LinuxCNC) takes any step of at least the minimum
    // (the last interval shorter): name a round one.
    if any_step_fits && let Some((min, _)) = fitting_step(length_mm, limit, padding) {
        m.push_str(&format!(
            ", or any round step of at least that, e.g. {} mm (the last interval shorter)",
            fmt_mm(round_step_at_least(min))
        ));
    }
    m
}

/// The smallest step of the 1–2–2.5–5 series (× 10^k mm) that is ≥ `min_mm`.
fn round_step_at_least(min_mm: f64) -> f64 {
    let decade = 10f64.powf(min_mm.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|&s| s >= min_mm * (1.0 - 1e-12))
        .unwrap_or(10.0 * decade)
}

/// The smallest step that fits `limit` entries over `length_mm` (with `padding` extra
/// entries), and the smallest step at least as large that is a whole number of µm and
/// divides the length (falling back to the minimum).
fn fitting_step(length_mm: f64, limit: usize, padding: usize) -> Option<(f64, f64)> {
    // k intervals → k + 1 samples + padding entries ≤ limit.
    let k_max = limit.checked_sub(1 + padding).filter(|&k| k >= 1)?;
    let min = length_mm / k_max as f64;
    let is_round = |s: f64| {
        let um = s * 1e3;
        (um - um.round()).abs() <= 1e-6 * um.abs().max(1.0)
    };
    let suggested = (1..=k_max)
        .rev()
        .map(|k| length_mm / k as f64)
        .find(|&s| is_round(s))
        .unwrap_or(min);
    Some((min, suggested))
}

fn outside_message(
    outside: usize,
    total: usize,
    first: [f64; 3],
    mapped: Option<&MappedBox>,
) -> String {
    match mapped {
        Some(b) => format!(
            "{outside} of {total} positions lie outside the mapped range {b} (the first at {}); \
             shorten the range or allow extrapolation",
            fmt_point(first)
        ),
        None => format!(
            "none of the {total} positions lies inside the mapped volume (the first is {}); \
             check the fixed coordinates and the range",
            fmt_point(first)
        ),
    }
}
