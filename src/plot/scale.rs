//! Axes and the page they sit on: padded value ranges, 1-2-5 ticks on linear and log axes,
//! category axes whose labels are shortened and thinned out to fit, and the page geometry
//! (image size, margins, label areas) that the tick density is chosen for.

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::prelude::*;

use super::error::PlotError;
use super::text::{DESC_SIZE, TICK_SIZE, fit_text, format_linear, format_log, text_width};

/// Width of every chart, in pixels.
pub(super) const WIDTH: u32 = 1000;
/// Height of every chart, in pixels (horizontal bar charts with many labels grow taller).
pub(super) const HEIGHT: u32 = 600;

/// Height of the strip at the top that holds the title.
pub(super) const TITLE_HEIGHT: u32 = 48;
/// Margin above the plot area (below the title strip); the legend starts at the same height.
pub(super) const MARGIN_TOP: u32 = 8;
pub(super) const MARGIN_BOTTOM: u32 = 10;
pub(super) const MARGIN_LEFT: u32 = 12;
/// Right margin without a legend: room for the last x tick label to overhang the plot.
pub(super) const MARGIN_RIGHT: u32 = 30;

/// Minimum and maximum of the finite values added.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Extent {
    range: Option<(f64, f64)>,
}

impl Extent {
    pub(super) fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.range = Some(match self.range {
                None => (v, v),
                Some((lo, hi)) => (lo.min(v), hi.max(v)),
            });
        }
    }

    pub(super) fn get(&self) -> Option<(f64, f64)> {
        self.range
    }
}

/// Pads `[min, max]` by 6 % of the span on the chosen sides; a zero or tiny span is widened
/// around the value so that the range is never degenerate.
pub(super) fn padded_range(
    min: f64,
    max: f64,
    pad_lo: bool,
    pad_hi: bool,
) -> Result<(f64, f64), PlotError> {
    let mid = 0.5 * min + 0.5 * max;
    // Below ~1e-9 relative span, tick positions would drown in rounding error.
    let floor = (mid.abs() * 1e-9).max(1e-300);
    let (lo, hi) = if max - min < floor {
        // Not a round fraction, so that ticks do not sit on the very ends of the axis.
        let half = if mid == 0.0 { 1.07 } else { mid.abs() * 0.107 };
        (mid - half, mid + half)
    } else {
        let pad = 0.06 * (max - min);
        (
            if pad_lo { min - pad } else { min },
            if pad_hi { max + pad } else { max },
        )
    };
    if (hi - lo).is_finite() && hi > lo {
        Ok((lo, hi))
    } else {
        Err(PlotError::Invalid(format!(
            "value range {min:e} … {max:e} is too large to plot"
        )))
    }
}

/// The 1, 2 or 5 times a power of ten nearest to `raw`.
fn nice_step(raw: f64) -> f64 {
    let e = raw.log10().floor();
    let base = 10f64.powi(e as i32);
    let f = raw / base;
    let m = if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    };
    m * base
}

/// Multiples of `step` inside `[lo, hi]`.
fn multiples(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let k0 = (lo / step).ceil();
    let k1 = (hi / step).floor();
    if !(k0.is_finite() && k1.is_finite()) || k1 - k0 > 1000.0 {
        return Vec::new();
    }
    let (k0, k1) = (k0 as i64, k1 as i64);
    (k0..=k1).map(|k| k as f64 * step).collect()
}

/// 1-2-5 tick positions, about `n` of them, inside `[lo, hi]`: whole multiples of the
/// step, so 0 is exactly 0 (the certificate's chart and the workbench's charts).
pub fn round_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).take(1000).map(|k| k as f64 * step).collect()
}

/// Major ticks (about `target` of them), minor ticks and the major step for `[lo, hi]`.
/// Minor ticks are only used when they are at least `MIN_MINOR_PX` apart on an axis
/// `length` pixels long.
fn linear_ticks(lo: f64, hi: f64, target: usize, length: f64) -> (Vec<f64>, Vec<f64>, f64) {
    const MIN_MINOR_PX: f64 = 10.0;
    let step = nice_step((hi - lo) / target.max(1) as f64);
    let major = multiples(lo, hi, step);
    let mantissa = (step / 10f64.powi(step.log10().floor() as i32)).round();
    let spacing = length * step / (hi - lo);
    let div = [if mantissa == 2.0 { 4.0 } else { 5.0 }, 2.0]
        .into_iter()
        .find(|d| spacing / d >= MIN_MINOR_PX);
    let Some(div) = div else {
        return (major, Vec::new(), step);
    };
    let minor = multiples(lo, hi, step / div)
        .into_iter()
        .filter(|v| {
            let r = v / step;
            (r - r.round()).abs() > 1e-6
        })
        .collect();
    (major, minor, step)
}

#[derive(Debug, Clone)]
enum Scale {
    Linear,
    /// Axis coordinates are log10 of the values.
    Log10,
}

#[derive(Debug, Clone)]
enum Labels {
    /// Plain numbers; `step` and `mag` (in value units) choose the number of decimals.
    Number { step: f64, mag: f64 },
    /// 1, 2 or 5 times a power of ten; `sci`: as `2×10⁻⁶` rather than `0.000002`.
    Log { sci: bool },
    /// Category names at `positions` (only thinned-out positions get ticks).
    Category {
        names: Vec<String>,
        positions: Vec<f64>,
    },
}

/// One axis: its range in axis coordinates, tick positions and how to label them.
#[derive(Debug, Clone)]
pub(super) struct Axis {
    pub(super) lo: f64,
    pub(super) hi: f64,
    scale: Scale,
    major: Vec<f64>,
    minor: Vec<f64>,
    labels: Labels,
}

impl Axis {
    /// Linear axis over `[lo, hi]`, `length` pixels long; along x, the tick count is
    /// reduced until the labels fit side by side.
    pub(super) fn linear(lo: f64, hi: f64, length: f64, along_x: bool) -> Axis {
        let per_tick = if along_x { 90.0 } else { 65.0 };
        let mut target = ((length / per_tick).round() as usize).clamp(2, 10);
        loop {
            let (major, minor, step) = linear_ticks(lo, hi, target, length);
            let axis = Axis {
                lo,
                hi,
                scale: Scale::Linear,
                major,
                minor,
                labels: Labels::Number {
                    step,
                    mag: lo.abs().max(hi.abs()),
                },
            };
            let spacing = length * step / (hi - lo);
            if !along_x || target <= 2 || f64::from(axis.widest_label() + 20) <= spacing {
                return axis;
            }
            target -= 1;
        }
    }

    /// Log axis for positive data between `min` and `max`.
    pub(super) fn log(min: f64, max: f64) -> Result<Axis, PlotError> {
        let (l0, l1) = (min.log10(), max.log10());
        let span = l1 - l0;
        // The bottom is a whole decade below the smallest value, so that bars (which start
        // at the bottom) have lengths that mean something.
        let (lo, hi) = (
            (l0 - (0.05 * span).max(0.02)).floor(),
            l1 + (0.06 * span).max(0.1),
        );
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(PlotError::Invalid(format!(
                "value range {min:e} … {max:e} cannot be drawn on a log axis"
            )));
        }
        if hi - lo < 1.0 {
            // Less than a decade: ordinary 1-2-5 ticks, placed on the log axis.
            let (vlo, vhi) = (10f64.powf(lo), 10f64.powf(hi));
            let (major, minor, step) = linear_ticks(vlo, vhi, 5, 0.0);
            return Ok(Axis {
                lo,
                hi,
                scale: Scale::Log10,
                major: major.iter().map(|v| v.log10()).collect(),
                minor: minor.iter().map(|v| v.log10()).collect(),
                labels: Labels::Number { step, mag: vhi },
            });
        }
        let d0 = lo.ceil() as i32;
        let d1 = hi.floor() as i32;
        let decades = (d1 - d0 + 1).max(1);
        let every = (decades + 7) / 8;
        let mut major = Vec::new();
        let mut minor = Vec::new();
        for d in (lo.floor() as i32)..=d1 {
            for m in 1..=9 {
                let c = f64::from(d) + f64::from(m).log10();
                if c < lo || c > hi {
                    continue;
                }
                let is_major = if m == 1 {
                    (d - d0).rem_euclid(every) == 0
                } else {
                    decades <= 3 && (m == 2 || m == 5)
                };
                if is_major {
                    major.push(c);
                } else if every == 1 || m == 1 {
                    minor.push(c);
                }
            }
        }
        // Plain numbers when every label is short that way, powers of ten otherwise.
        let sci = major
            .iter()
            .any(|c| !(-3.0..5.0).contains(&(c + 1e-9).floor()));
        Ok(Axis {
            lo,
            hi,
            scale: Scale::Log10,
            major,
            minor,
            labels: Labels::Log { sci },
        })
    }

    /// Category axis over `[lo, hi]` with `names[i]` at `positions[i]`; labels are thinned
    /// out so that they fit along `length` pixels. `label_room`: `None` for an x axis,
    /// the width available for the labels beside a y axis.
    pub(super) fn category(
        names: &[String],
        positions: &[f64],
        lo: f64,
        hi: f64,
        length: f64,
        label_room: Option<f64>,
    ) -> Axis {
        let n = names.len().max(1);
        let slot = length / n as f64;
        let (names, every) = if let Some(room) = label_room {
            let names: Vec<String> = names
                .iter()
                .map(|s| fit_text(s, TICK_SIZE, FontStyle::Normal, room as u32))
                .collect();
            let every = ((TICK_SIZE + 4.0) / slot).ceil().max(1.0) as usize;
            (names, every)
        } else {
            let max_w = (length * 0.9).max(40.0) as u32;
            let names: Vec<String> = names
                .iter()
                .map(|s| fit_text(s, TICK_SIZE, FontStyle::Normal, max_w))
                .collect();
            let widest = names
                .iter()
                .map(|s| text_width(s, TICK_SIZE, FontStyle::Normal))
                .max()
                .unwrap_or(0);
            let every = (f64::from(widest + 12) / slot).ceil().max(1.0) as usize;
            (names, every)
        };
        let major = positions.iter().step_by(every).copied().collect();
        Axis {
            lo,
            hi,
            scale: Scale::Linear,
            major,
            minor: Vec::new(),
            labels: Labels::Category {
                names,
                positions: positions.to_vec(),
            },
        }
    }

    /// Axis coordinate of a data value.
    pub(super) fn coord(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }

    /// Tick label at axis coordinate `c`.
    fn label(&self, c: f64) -> String {
        let v = match self.scale {
            Scale::Linear => c,
            Scale::Log10 => 10f64.powf(c),
        };
        match &self.labels {
            Labels::Number { step, mag } => format_linear(v, *step, *mag),
            Labels::Log { sci } => format_log(v, *sci),
            Labels::Category { names, positions } => positions
                .iter()
                .position(|p| (p - c).abs() < 1e-6)
                .and_then(|i| names.get(i))
                .cloned()
                .unwrap_or_default(),
        }
    }

    fn widest_label(&self) -> u32 {
        self.major
            .iter()
            .map(|&c| text_width(&self.label(c), TICK_SIZE, FontStyle::Normal))
            .max()
            .unwrap_or(0)
    }
}

/// The axis is its own plotters coordinate: linear in axis coordinates, with our ticks.
impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = (value - self.lo) / (self.hi - self.lo);
        let p = f64::from(limit.0) + f64::from(limit.1 - limit.0) * t;
        if p.is_finite() {
            // Saturating cast; far-off points are clipped by the drawing area anyway.
            p.round() as i32
        } else if p > 0.0 {
            limit.1
        } else {
            limit.0
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        self.label(*value)
    }
}

/// Pixels to reserve left of the plot for the y tick labels and description.
pub(super) fn y_label_area(axis: &Axis, with_desc: bool) -> u32 {
    let desc = if with_desc { DESC_SIZE as u32 + 6 } else { 0 };
    axis.widest_label() + 16 + desc
}

/// Pixels to reserve below the plot for the x tick labels and description.
pub(super) fn x_label_area(with_desc: bool) -> u32 {
    let desc = if with_desc { DESC_SIZE as u32 + 12 } else { 0 };
    TICK_SIZE as u32 + 18 + desc
}

/// Approximate height of the plot area, for choosing ticks.
pub(super) fn plot_height(height: u32, x_area: u32) -> f64 {
    f64::from(height.saturating_sub(TITLE_HEIGHT + MARGIN_TOP + MARGIN_BOTTOM + x_area)).max(100.0)
}

/// Approximate width of the plot area, for choosing ticks and thinning out category labels.
pub(super) fn plot_width(legend_width: u32, y_area: u32) -> f64 {
    let right = if legend_width == 0 { MARGIN_RIGHT } else { 12 };
    f64::from(WIDTH.saturating_sub(legend_width + y_area + MARGIN_LEFT + right)).max(100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = Result<(), Box<dyn std::error::Error>>;

    #[test]
    fn ranges_and_ticks_never_degenerate() -> TestResult {
        for (lo, hi) in [(5.0, 5.0), (0.0, 0.0), (-1e-9, -1e-9), (1e10, 1e10 + 1e-6)] {
            let (a, b) = padded_range(lo, hi, true, true)?;
            assert!(a < lo.min(hi) && b > lo.max(hi), "{lo}..{hi} -> {a}..{b}");
            let axis = Axis::linear(a, b, 400.0, true);
            assert!(axis.major.len() >= 2, "{a}..{b}: {:?}", axis.major);
            assert!(axis.major.iter().all(|t| (a..=b).contains(t)));
        }
        assert_eq!(nice_step(0.11), 0.1);
        assert_eq!(nice_step(2.6), 2.0);
        assert_eq!(nice_step(40.0), 50.0);
        for (lo, hi) in [(1.0, 1.0), (0.5, 0.6), (1e-6, 1.0), (1e-30, 1e30)] {
            let axis = Axis::log(lo, hi)?;
            assert!(axis.lo < lo.log10() && axis.hi > hi.log10());
            assert!(
                (2..=12).contains(&axis.major.len()),
                "{lo}..{hi}: {:?}",
                axis.major
            );
        }
        Ok(())
    }
}
