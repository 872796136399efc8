//! Where a compensation table's points go when the step does not divide the range
//! ([`StepFit`], [`sample_line_fit`]).
//!
//! Controllers differ in what spacing they accept:
//!
//! * **Uneven spacing allowed** (LinuxCNC's `COMP_FILE` lists each nominal; errmap's CSV):
//!   [`StepFit::LastShorter`] — `start, start + h, start + 2h, …` and the range end as the
//!   last point, so the last interval is shorter than h (never shorter than 1/1000 of h
//!   or the file's 1e-6 mm: a grid point that close to the end is replaced by the end;
//!   the start is always kept, so a range shorter than that is its two ends).
//! * **A fixed interval** (Siemens LEC: MIN, STEP, MAX; Fanuc pitch error compensation: a
//!   reference point and an interval): [`StepFit::Grid`] — the points are the round grid
//!   g_k = r + k·h through a reference position r (the machine's reference point, 0 by
//!   default), from the last grid point at or below `start` to the first at or above
//!   `end`. The one or two grid points beyond the range take, as the user chooses
//!   ([`Ends`]), the model's value at the range end ([`Ends::Clamp`]: the compensation is
//!   held constant beyond the measured range) or the model's prediction there
//!   ([`Ends::Extrapolate`], flagged when outside the model's nodes).
//! * [`StepFit::Divide`] (what [`sample_line`](super::sample_line) does): the step must
//!   divide the range. A step within the file resolution of dividing is accepted too: the
//!   suggestion of [`ExportError::StepDoesNotDivide`](super::ExportError), printed to
//!   1e-6 mm, is range/k rounded to 1e-6 mm, and given back it is taken as k intervals of
//!   exactly the typed step, the last point moving off the range end by at most
//!   k·0.5e-6 mm (0.13 µm for the 267 intervals of `--step 2.991601` on Table 1's
//!   798.7576 mm) so that the points stay exactly equidistant at a step the file can write.
//!
//! Cost: one pass over the points; then n predictions as in `sample_line`.

use super::{
    ExportError, Extrapolation, FILE_RESOLUTION_MM, LineSpec, MAX_SAMPLES, Sampled, evaluate, snap,
};
use crate::interp::Interpolator;
use crate::table::Axis;

/// How the grid points beyond the range are valued.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Ends {
    /// The model's value at the nearest range end.
    Clamp,
    /// The model's prediction at the grid point.
    Extrapolate,
}

/// How a line's points are placed (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepFit {
    /// The step must divide the range (or be its k-th part rounded to 1e-6 mm).
    Divide,
    /// Any step; the range end is the last point.
    LastShorter,
    /// The round grid `reference_mm + k·step` covering the range.
    Grid { reference_mm: f64, ends: Ends },
}

/// The grid positions and, for each, where the model is evaluated.
fn grid_points(
    axis: Axis,
    start_mm: f64,
    end_mm: f64,
    step_mm: f64,
    reference_mm: f64,
    ends: Ends,
) -> Result<(Vec<f64>, Vec<f64>), ExportError> {
    if !reference_mm.is_finite() {
        return Err(ExportError::NonFiniteCoordinate {
            axis,
            value: reference_mm,
        });
    }
    let a = (start_mm - reference_mm) / step_mm;
    let b = (end_mm - reference_mm) / step_mm;
    let tol = |v: f64| 1e-9 * v.abs().max(1.0);
    let k_lo = (a + tol(a)).floor();
    let mut k_hi = (b - tol(b)).ceil();
    if k_hi <= k_lo {
        k_hi = k_lo + 1.0;
    }
    if k_hi - k_lo + 1.0 > MAX_SAMPLES as f64 {
        return Err(ExportError::TooManyPoints {
            points: (k_hi - k_lo) as u128 + 1,
            limit: MAX_SAMPLES,
        });
    }
    let positions: Vec<f64> = (0..=(k_hi - k_lo) as i64)
        .map(|i| snap(reference_mm + (k_lo + i as f64) * step_mm))
        .collect();
    let at = positions
        .iter()
        .map(|&g| match ends {
            Ends::Clamp => g.clamp(start_mm, end_mm),
            Ends::Extrapolate => g,
        })
        .collect();
    Ok((positions, at))
}

/// `start, start + h, …` and `end` last (module docs).
fn last_shorter(start_mm: f64, end_mm: f64, step_mm: f64) -> Vec<f64> {
    // The range and step were checked by the caller (`axis_positions`); here every
    // point is start + i·h exactly, and a point within the gap of the end gives way to it
    // (so a step that divides the range, or nearly, ends on the range end too).
    let k = ((end_mm - start_mm) / step_mm).floor() as usize;
    let gap = (1e-3 * step_mm).max(FILE_RESOLUTION_MM);
    // The start is always a point, even when the whole range is shorter than the gap.
    let mut positions = vec![snap(start_mm)];
    positions.extend(
        (1..=k)
            .map(|i| snap(start_mm + i as f64 * step_mm))
            .filter(|&x| x < end_mm - gap),
    );
    positions.push(end_mm);
    positions
}

/// The positions `fit` places over `start..end` every `step`, and for each where the
/// value is taken (a grid point beyond the range is valued at the range end with
/// [`Ends::Clamp`]).
fn place(
    axis: Axis,
    start_mm: f64,
    end_mm: f64,
    step_mm: f64,
    fit: StepFit,
) -> Result<(Vec<f64>, Vec<f64>), ExportError> {
    // The range and step checks of `axis_positions` come first for every fit.
    let exact = super::axis_positions(axis, start_mm, end_mm, step_mm, false);
    Ok(match (fit, exact) {
        (_, Err(e)) if !matches!(e, ExportError::StepDoesNotDivide { .. }) => return Err(e),
        (StepFit::Divide, exact) => {
            let p = exact?;
            (p.clone(), p)
        }
        (StepFit::LastShorter, _) => {
            let p = last_shorter(start_mm, end_mm, step_mm);
            (p.clone(), p)
        }
        (StepFit::Grid { reference_mm, ends }, _) => {
            grid_points(axis, start_mm, end_mm, step_mm, reference_mm, ends)?
        }
    })
}

/// A measured line (e.g. a session's per-direction means at its targets) moved onto the
/// points `fit` places every `step_mm` over its range: the values interpolated linearly
/// between the measured positions (the rule of the controllers that interpolate), and
/// beyond them held ([`Ends::Clamp`]) or continued along the end interval
/// ([`Ends::Extrapolate`], flagged as extrapolated). Cost: O(n + m).
pub fn regrid_measured(s: &Sampled, step_mm: f64, fit: StepFit) -> Result<Sampled, ExportError> {
    s.check()?;
    let n = s.len();
    let (start, end) = (s.positions_mm[0], s.positions_mm[n - 1]);
    let (positions_mm, at_mm) = place(s.axis, start, end, step_mm, fit)?;
    let xs = &s.positions_mm;
    let value = |x: f64| {
        let i = xs.partition_point(|&p| p <= x).clamp(1, n - 1) - 1;
        let u = (x - xs[i]) / (xs[i + 1] - xs[i]);
        s.error_um[i] + u * (s.error_um[i + 1] - s.error_um[i])
    };
    let error_um = at_mm.iter().map(|&x| value(x)).collect();
    let extrapolated = at_mm
        .iter()
        .map(|&x| x < start - 1e-9 || x > end + 1e-9)
        .collect();
    Ok(Sampled {
        axis: s.axis,
        at_mm: s.at_mm,
        positions_mm,
        error_um,
        extrapolated,
    })
}

/// Samples the model along a line with the points placed by `fit`. With
/// [`StepFit::Divide`] this is [`sample_line`](super::sample_line).
pub fn sample_line_fit(
    model: &dyn Interpolator,
    line: &LineSpec,
    fit: StepFit,
    extrapolation: Extrapolation,
) -> Result<Sampled, ExportError> {
    for axis in Axis::ALL {
        let value = line.at_mm[axis.index()];
        if axis != line.axis && !value.is_finite() {
            return Err(ExportError::NonFiniteCoordinate { axis, value });
        }
    }
    let (positions_mm, at_mm) = place(line.axis, line.start_mm, line.end_mm, line.step_mm, fit)?;
    let points: Vec<[f64; 3]> = at_mm.iter().map(|&x| line.point(x)).collect();
    let (error_um, extrapolated) = evaluate(model, &points, extrapolation)?;
    Ok(Sampled {
        axis: line.axis,
        at_mm: line.at_mm,
        positions_mm,
        error_um,
        extrapolated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_the_range_from_the_reference() {
        let (p, at) = grid_points(Axis::X, 0.0, 798.7576, 10.0, 0.0, Ends::Clamp).expect("ok");
        assert_eq!(p.len(), 81);
        assert_eq!((p[0], p[80]), (0.0, 800.0));
        assert_eq!(at[80], 798.7576);
        let (p, at) = grid_points(Axis::X, -17.0, 23.0, 10.0, 5.0, Ends::Extrapolate).expect("ok");
        assert_eq!(p, vec![-25.0, -15.0, -5.0, 5.0, 15.0, 25.0]);
        assert_eq!(at, p);
    }

    #[test]
    fn last_interval_is_shorter_and_never_tiny() {
        let p = last_shorter(0.0, 798.7576, 10.0);
        assert_eq!(p.len(), 81);
        assert_eq!((p[79], p[80]), (790.0, 798.7576));
        // 800.005 / 10: the 800 mm grid point is 5 µm (< h/1000) from the end: replaced.
        let p = last_shorter(0.0, 800.005, 10.0);
        assert_eq!((p.len(), p[79], p[80]), (81, 790.0, 800.005));
    }
}
