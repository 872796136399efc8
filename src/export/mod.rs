//! Compensation tables for machine controllers, exported from a fitted error model.
//!
//! A fitted [`Interpolator`] is sampled along one axis ([`sample_line`]) or over a
//! volume ([`grid::render`]); the controller stage renders a line in a controller's own
//! format, this stage the CSV line and the grid (non-controller outputs). The renderers
//! are pure: they return the text or the rows, and the caller writes the file
//! ([`write_grid`] writes the grid's rows for now).
//!
//! | function | writes | limit | cost |
//! |---|---|---|---|
//! | [`sample_line`] | a [`Sampled`] line: positions, e, extrapolation flags | [`MAX_SAMPLES`] | n predictions + n `outside` tests |
//! | [`csv`](mod@csv) | `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated` for one line | — | O(n) text |
//! | [`grid`] | the same columns over a box ([`GridRows`]; CSV or Parquet via polars by [`write_grid`]) | [`MAX_SAMPLES`] | N predictions |
//!
//! The controllers' own table formats, their sign conventions and limits are the
//! controller stage's (`src/controller/`), which renders a [`Sampled`] line.
//!
//! # Extrapolation
//!
//! Every sampled position outside the model's nodes is flagged (`extrapolated`, from
//! [`Interpolator::outside`]). With [`Extrapolation::Forbid`] any such position is an
//! error naming the mapped range, which is found from `outside` alone by bisection
//! ([`MappedBox::around`]), so it works for every interpolator.

pub(crate) mod bidirectional;
mod csv;
mod error;
mod grid;
mod step;

use std::path::Path;

use polars::prelude::{Column, DataFrame};

use crate::interp::Interpolator;
use crate::table::{Axis, TableError, write_frame};

pub use bidirectional::{ChooseLineError, ExportSetting};
pub use csv::render as csv;
pub use error::{ExportError, MappedBox};
pub use grid::GridRows;
pub use step::{Ends, StepFit, regrid_measured, sample_line_fit};

/// errmap's own cap on sampled points per line or volume, so that a mistyped step cannot
/// exhaust memory (a 2 000 000-point volume is about 100 MB in flight).
pub const MAX_SAMPLES: usize = 2_000_000;

/// Resolution of the numbers written to controller files: 1e-6 mm (1 nm).
pub const FILE_RESOLUTION_MM: f64 = 1e-6;

/// The compensation for an error: c = −e (both µm). See the module docs for how each
/// controller applies it.
#[inline]
pub fn compensation_um(e_um: f64) -> f64 {
    -e_um
}

/// What to do with positions outside the model's nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Extrapolation {
    /// Predict there and flag the positions (the default).
    #[default]
    Allow,
    /// Refuse, naming the mapped range.
    Forbid,
}

/// One line of a compensation table: along `axis` from `start_mm` to `end_mm` every
/// `step_mm`, the other two coordinates fixed by `at_mm` (its entry for `axis` is
/// ignored).
///
/// With [`sample_line`] the step must divide the range into whole intervals (to 1e-9
/// relative, or be range/k rounded to the file's 1e-6 mm, see [`step`]): controllers
/// with equidistant tables (Siemens) need it, and silently moving the end would change
/// the range the user asked for. [`sample_line_fit`] places the points of any step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSpec {
    pub axis: Axis,
    pub at_mm: [f64; 3],
    pub start_mm: f64,
    pub end_mm: f64,
    pub step_mm: f64,
}

impl LineSpec {
    /// The 3-D point at `position_mm` along the line.
    pub fn point(&self, position_mm: f64) -> [f64; 3] {
        let mut p = self.at_mm;
        p[self.axis.index()] = position_mm;
        p
    }

    /// The validated positions along the line, start and end included.
    pub fn positions(&self) -> Result<Vec<f64>, ExportError> {
        axis_positions(self.axis, self.start_mm, self.end_mm, self.step_mm, false)
    }
}

/// A box sampled every `spacing_mm` along each axis, `lo_mm` to `hi_mm` inclusive. An
/// axis with `lo == hi` has a single plane; otherwise the spacing must divide its extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeSpec {
    pub lo_mm: [f64; 3],
    pub hi_mm: [f64; 3],
    pub spacing_mm: f64,
}

/// A sampled line: the model's error at each position and whether it was extrapolated.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampled {
    pub axis: Axis,
    /// The fixed coordinates (the entry for `axis` is ignored).
    pub at_mm: [f64; 3],
    /// Strictly increasing positions along `axis`.
    pub positions_mm: Vec<f64>,
    /// Predicted error e = indicated − reference at each position.
    pub error_um: Vec<f64>,
    /// Whether each position lies outside the model's nodes.
    pub extrapolated: Vec<bool>,
}

impl Sampled {
    /// Errors measured at positions along a line, with no model between them (e.g. a
    /// session's per-target means in one direction); the renderers check them as they
    /// check a sampled model (increasing positions, finite values).
    pub fn measured(
        axis: Axis,
        at_mm: [f64; 3],
        positions_mm: Vec<f64>,
        error_um: Vec<f64>,
    ) -> Self {
        let n = positions_mm.len();
        Sampled {
            axis,
            at_mm,
            positions_mm,
            error_um,
            extrapolated: vec![false; n],
        }
    }

    pub fn len(&self) -> usize {
        self.positions_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions_mm.is_empty()
    }

    /// The 3-D point of sample `i`.
    pub fn point(&self, i: usize) -> [f64; 3] {
        let mut p = self.at_mm;
        p[self.axis.index()] = self.positions_mm[i];
        p
    }

    /// The compensation c = −e at each position, µm.
    pub fn comp_um(&self) -> Vec<f64> {
        self.error_um.iter().map(|&e| compensation_um(e)).collect()
    }

    /// How many positions were extrapolated.
    pub fn extrapolated_count(&self) -> usize {
        self.extrapolated.iter().filter(|&&x| x).count()
    }

    /// Checks what the exporters rely on: equal lengths, at least two samples, finite
    /// numbers, strictly increasing positions.
    pub fn check(&self) -> Result<(), ExportError> {
        let (n, ne, nf) = (self.len(), self.error_um.len(), self.extrapolated.len());
        if ne != n || nf != n {
            return Err(ExportError::LengthMismatch {
                positions: n,
                errors: ne,
                flags: nf,
            });
        }
        if n < 2 {
            return Err(ExportError::TooFewSamples { count: n });
        }
        for (index, (&x, &e)) in self.positions_mm.iter().zip(&self.error_um).enumerate() {
            if !x.is_finite() || !e.is_finite() {
                return Err(ExportError::NonFiniteSample {
                    index,
                    position_mm: x,
                    error_um: e,
                });
            }
            if index > 0 && x <= self.positions_mm[index - 1] {
                return Err(ExportError::NotIncreasing {
                    index,
                    previous_mm: self.positions_mm[index - 1],
                    position_mm: x,
                });
            }
        }
        Ok(())
    }

    /// The common step of equidistant positions (checked to 1e-9 mm + 1e-9 relative).
    pub(crate) fn uniform_step(&self) -> Result<f64, ExportError> {
        let n = self.len();
        let step = (self.positions_mm[n - 1] - self.positions_mm[0]) / (n - 1) as f64;
        let tol = 1e-9
            * (1.0
                + self.positions_mm[n - 1]
                    .abs()
                    .max(self.positions_mm[0].abs()));
        for (i, w) in self.positions_mm.windows(2).enumerate() {
            let expected = self.positions_mm[0] + (i + 1) as f64 * step;
            if (w[1] - expected).abs() > tol {
                return Err(ExportError::NotEquidistant {
                    index: i + 1,
                    step_mm: step,
                    gap_mm: w[1] - w[0],
                });
            }
        }
        Ok(step)
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.positions_mm.last().copied().unwrap_or(0.0)
            - self.positions_mm.first().copied().unwrap_or(0.0)
    }
}

/// Checks `forward` and, when given, `reverse` (the same positions, direction-dependent
/// errors); returns the line the reverse column comes from (`forward` without one).
pub(crate) fn paired<'a>(
    forward: &'a Sampled,
    reverse: Option<&'a Sampled>,
) -> Result<&'a Sampled, ExportError> {
    forward.check()?;
    let Some(r) = reverse else {
        return Ok(forward);
    };
    r.check()?;
    if r.len() != forward.len() {
        return Err(ExportError::ReverseMismatch {
            problem: format!("{} reverse samples for {} forward", r.len(), forward.len()),
        });
    }
    if let Some(i) =
        (0..r.len()).find(|&i| (r.positions_mm[i] - forward.positions_mm[i]).abs() > 1e-9)
    {
        return Err(ExportError::ReverseMismatch {
            problem: format!(
                "sample {i} is at {} mm forward but {} mm reverse",
                forward.positions_mm[i], r.positions_mm[i]
            ),
        });
    }
    Ok(r)
}

/// `v` with `decimals` decimals, trailing zeros trimmed (one kept), and no `-0.0`.
pub(crate) fn fmt_fixed(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.push('0');
        }
    }
    if s.parse::<f64>() == Ok(0.0) {
        return "0.0".into();
    }
    s
}

/// A length in mm at the file resolution (1e-6 mm).
pub(crate) fn fmt_mm(v: f64) -> String {
    fmt_fixed(v, 6)
}

pub(crate) fn fmt_point(p: [f64; 3]) -> String {
    format!(
        "({}, {}, {}) mm",
        fmt_fixed(p[0], 4),
        fmt_fixed(p[1], 4),
        fmt_fixed(p[2], 4)
    )
}

/// Rounds to 1e-9 mm so that `start + i·step` prints as the user typed it.
fn snap(x: f64) -> f64 {
    if x.abs() < 1e6 {
        let s = (x * 1e9).round() / 1e9;
        if s == 0.0 { 0.0 } else { s }
    } else {
        x
    }
}

/// Positions `start, start + step, …, end`; `allow_single` accepts `start == end`.
fn axis_positions(
    axis: Axis,
    start_mm: f64,
    end_mm: f64,
    step_mm: f64,
    allow_single: bool,
) -> Result<Vec<f64>, ExportError> {
    if !(step_mm.is_finite() && step_mm > 0.0) {
        return Err(ExportError::BadStep { step_mm });
    }
    for value in [start_mm, end_mm] {
        if !value.is_finite() {
            return Err(ExportError::NonFiniteCoordinate { axis, value });
        }
    }
    if end_mm < start_mm || (end_mm == start_mm && !allow_single) {
        return Err(ExportError::EmptyRange {
            axis,
            start_mm,
            end_mm,
        });
    }
    let length_mm = end_mm - start_mm;
    let k = length_mm / step_mm;
    if k + 1.0 > MAX_SAMPLES as f64 {
        return Err(ExportError::TooManyPoints {
            points: (k as u128).saturating_add(1),
            limit: MAX_SAMPLES,
        });
    }
    let kr = k.round();
    let n = kr as usize;
    if (k - kr).abs() <= 1e-9 * kr.max(1.0) {
        return Ok((0..=n)
            .map(|i| {
                if i == n {
                    end_mm
                } else {
                    snap(start_mm + i as f64 * step_mm)
                }
            })
            .collect());
    }
    // range/k rounded to the file resolution (the suggestion below, given back): k
    // intervals of exactly this step, the end moved by at most k·0.5e-6 mm (see `step`).
    if kr >= 1.0 && (kr * step_mm - length_mm).abs() <= kr * 0.5 * FILE_RESOLUTION_MM + 1e-12 {
        return Ok((0..=n)
            .map(|i| snap(start_mm + i as f64 * step_mm))
            .collect());
    }
    Err(ExportError::StepDoesNotDivide {
        axis,
        length_mm,
        step_mm,
        fitting_step_mm: length_mm / k.ceil(),
    })
}

/// Predictions, flags and the extrapolation policy for a list of points.
fn evaluate(
    model: &dyn Interpolator,
    points: &[[f64; 3]],
    extrapolation: Extrapolation,
) -> Result<(Vec<f64>, Vec<bool>), ExportError> {
    let mut error_um = vec![0.0; points.len()];
    model.predict_into(points, &mut error_um);
    if let Some((p, &value)) = points.iter().zip(&error_um).find(|(_, v)| !v.is_finite()) {
        return Err(ExportError::NonFinitePrediction {
            position_mm: *p,
            value,
        });
    }
    let flags: Vec<bool> = points.iter().map(|p| model.outside(*p)).collect();
    if extrapolation == Extrapolation::Forbid {
        let outside = flags.iter().filter(|&&f| f).count();
        if let Some(first) = points
            .iter()
            .zip(&flags)
            .find(|(_, f)| **f)
            .map(|(p, _)| *p)
        {
            let mapped = points
                .iter()
                .zip(&flags)
                .find(|(_, f)| !**f)
                .and_then(|(p, _)| MappedBox::around(model, *p));
            return Err(ExportError::OutsideMappedRange {
                outside,
                total: points.len(),
                first_mm: first,
                mapped,
            });
        }
    }
    Ok((error_um, flags))
}

/// Samples the model along a line. Cost: n predictions and n `outside` tests
/// (+ ≈ 600 `outside` calls to name the mapped range when refusing).
pub fn sample_line(
    model: &dyn Interpolator,
    line: &LineSpec,
    extrapolation: Extrapolation,
) -> Result<Sampled, ExportError> {
    // The step must divide the range: the placement rule of `step::StepFit::Divide`.
    step::sample_line_fit(model, line, step::StepFit::Divide, extrapolation)
}

/// Samples the model over a box ([`grid::render`]) and writes
/// `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated` (x fastest) as CSV or Parquet, by the
/// extension of `out`, through [`crate::table::write_frame`]. Returns the number of rows.
/// Cost: N predictions. The renderer ([`grid::render`]) is pure; this is the one place
/// the export touches a file, and it does so through the table stage's writer.
pub fn write_grid(
    model: &dyn Interpolator,
    spec: &VolumeSpec,
    extrapolation: Extrapolation,
    out: &Path,
) -> Result<usize, ExportError> {
    let rows = grid::render(model, spec, extrapolation)?;
    let coord = |name: &str, a: usize| {
        Column::new(
            name.into(),
            rows.points_mm.iter().map(|p| p[a]).collect::<Vec<f64>>(),
        )
    };
    let n = rows.len();
    let comp = rows.comp_um();
    let cols = vec![
        coord("x_mm", 0),
        coord("y_mm", 1),
        coord("z_mm", 2),
        Column::new("e_um".into(), rows.error_um),
        Column::new("comp_um".into(), comp),
        Column::new("extrapolated".into(), rows.extrapolated),
    ];
    let mut df = DataFrame::new(n, cols).map_err(|e| TableError::Format {
        path: out.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(out, &mut df)?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 17's campaign: `export --start -1e308` overflowed the point count (a
    /// panic in a debug build) instead of refusing the line as too long.
    #[test]
    fn a_line_of_astronomically_many_points_is_refused_not_overflowed() {
        let spec = LineSpec {
            axis: Axis::X,
            at_mm: [0.0; 3],
            start_mm: -1e308,
            end_mm: 800.0,
            step_mm: 50.0,
        };
        match spec.positions() {
            Err(ExportError::TooManyPoints { points, limit }) => {
                assert_eq!(points, u128::MAX);
                assert_eq!(limit, MAX_SAMPLES);
            }
            other => panic!("expected TooManyPoints, got {other:?}"),
        }
    }
}
