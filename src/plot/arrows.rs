//! A residual map on a plate: each feature a dot at its place (mm, the artefact's frame,
//! equal scales on both axes), its residual an arrow from it, magnified so that the
//! largest arrow is [`LONGEST_SHARE`] of the plate's span; a key arrow gives the
//! magnification in µm; round mm values are ticked and labelled on both axes of the
//! frame. PNG and SVG.

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::draw::de;
use super::error::{DrawFailure, PlotError};
use super::render::{Figure, figure_pair, map_heading, map_text as style};
use super::text::fonts_ready;

/// The image's side, pixels.
pub const SIDE_PX: u32 = 800;
/// The largest arrow's length as a share of the plate's larger span.
pub const LONGEST_SHARE: f64 = 0.12;
/// At most this many arrows (a bound on the drawing).
pub const MAX_ARROWS: usize = 100_000;

/// One feature: place (mm) and residual (µm) along the map's two axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arrow {
    pub x_mm: f64,
    pub y_mm: f64,
    pub dx_um: f64,
    pub dy_um: f64,
}

/// What to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct ArrowMap {
    pub title: String,
    /// Lines under the title.
    pub notes: Vec<String>,
    /// The axes' names (e.g. "artefact x, mm").
    pub x_label: String,
    pub y_label: String,
    pub arrows: Vec<Arrow>,
}

const HEADER_PX: f64 = 80.0;
const MARGIN_PX: f64 = 70.0;
/// Below the frame: its tick labels and the x axis' name, above the key.
const FOOTER_PX: f64 = 24.0;
const ARROW: RGBColor = RGBColor(0xd6, 0x27, 0x28);

/// The geometry: mm → pixel, and µm → pixel of the arrows.
struct Geometry {
    x0: f64,
    y0: f64,
    px_per_mm: f64,
    px_per_um: f64,
    um_key: f64,
    span_px: f64,
}

fn geometry(map: &ArrowMap) -> Geometry {
    let ok = |a: &&Arrow| a.x_mm.is_finite() && a.y_mm.is_finite();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for a in map.arrows.iter().filter(ok) {
        lo = [lo[0].min(a.x_mm), lo[1].min(a.y_mm)];
        hi = [hi[0].max(a.x_mm), hi[1].max(a.y_mm)];
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
    let span_px = f64::from(SIDE_PX) - HEADER_PX - 2.0 * MARGIN_PX - FOOTER_PX;
    // The features sit inset by the longest arrow on each side, so that every arrow ends
    // inside the frame (which is drawn around `span_px`).
    let px_per_mm = span_px * (1.0 - 2.0 * LONGEST_SHARE) / span;
    let longest = map
        .arrows
        .iter()
        .map(|a| a.dx_um.hypot(a.dy_um))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let px_per_um = if longest > 0.0 {
        LONGEST_SHARE * span_px / longest
    } else {
        1.0
    };
    // The key: a round number of µm near the longest arrow.
    let um_key = if longest > 0.0 {
        let mag = 10f64.powf(longest.log10().floor());
        [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .rfind(|v| *v <= longest)
            .unwrap_or(mag)
    } else {
        1.0
    };
    let cx = (lo[0] + hi[0]) / 2.0;
    let cy = (lo[1] + hi[1]) / 2.0;
    let mid = f64::from(SIDE_PX) / 2.0;
    Geometry {
        x0: mid - px_per_mm * cx,
        y0: HEADER_PX + MARGIN_PX + span_px / 2.0 + px_per_mm * cy,
        px_per_mm,
        px_per_um,
        um_key,
        span_px,
    }
}

impl Geometry {
    fn px(&self, x_mm: f64, y_mm: f64) -> (f64, f64) {
        (
            self.x0 + self.px_per_mm * x_mm,
            self.y0 - self.px_per_mm * y_mm,
        )
    }
}

/// Writes `<stem>.png` and `<stem>.svg`.
pub fn arrow_map(stem: &Path, map: &ArrowMap) -> Result<Vec<PathBuf>, PlotError> {
    if map.arrows.is_empty() {
        return Err(PlotError::Empty("arrows"));
    }
    if map.arrows.len() > MAX_ARROWS {
        return Err(PlotError::Invalid(format!(
            "{} arrows: at most {MAX_ARROWS} are drawn",
            map.arrows.len()
        )));
    }
    fonts_ready()?;
    figure_pair(stem, (SIDE_PX, SIDE_PX), map)
}

impl Figure for ArrowMap {
    fn draw_on<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), DrawFailure> {
        draw(root, self)
    }
}

fn ip(p: (f64, f64)) -> (i32, i32) {
    (p.0.round() as i32, p.1.round() as i32)
}

/// A line from `a` to `b` with a head at `b`.
fn arrow<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    a: (f64, f64),
    b: (f64, f64),
    colour: RGBColor,
) -> Result<(), DrawFailure> {
    root.draw(&PathElement::new(
        vec![ip(a), ip(b)],
        colour.stroke_width(2),
    ))
    .map_err(de)?;
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy);
    if len < 3.0 {
        return Ok(());
    }
    let head = len.min(10.0) * 0.6;
    let (ux, uy) = (dx / len, dy / len);
    let left = (b.0 - head * (ux - 0.5 * uy), b.1 - head * (uy + 0.5 * ux));
    let right = (b.0 - head * (ux + 0.5 * uy), b.1 - head * (uy - 0.5 * ux));
    root.draw(&Polygon::new(
        vec![ip(b), ip(left), ip(right)],
        colour.filled(),
    ))
    .map_err(de)
}

/// Round values (1, 2 or 5 × 10ᵏ apart, at most eight steps) inside [lo, hi], with the
/// decimals their labels need.
fn ticks(lo: f64, hi: f64) -> (Vec<f64>, usize) {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return (Vec::new(), 0);
    }
    let mag = 10f64.powf((span / 8.0).log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 8.0)
        .unwrap_or(10.0 * mag);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let (first, last) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    ((first..=last).map(|i| i as f64 * step).collect(), decimals)
}

/// Tick marks and mm labels under the frame (x) and left of it (y); `lo`, `hi` are the
/// frame's top-left and bottom-right pixels.
fn frame_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    g: &Geometry,
    lo: (f64, f64),
    hi: (f64, f64),
) -> Result<(), DrawFailure> {
    let grey = RGBColor(0x99, 0x99, 0x99);
    let label = |v: f64, d: usize| {
        // No "-0" label.
        let t = format!("{v:.d$}");
        if t.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            format!("{:.d$}", 0.0)
        } else {
            t
        }
    };
    let (xs, dx) = ticks((lo.0 - g.x0) / g.px_per_mm, (hi.0 - g.x0) / g.px_per_mm);
    for v in xs {
        let px = g.x0 + g.px_per_mm * v;
        root.draw(&PathElement::new(
            vec![ip((px, hi.1)), ip((px, hi.1 + 5.0))],
            grey.stroke_width(1),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            label(v, dx),
            ip((px, hi.1 + 7.0)),
            style(11.0).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(de)?;
    }
    let (ys, dy) = ticks((g.y0 - hi.1) / g.px_per_mm, (g.y0 - lo.1) / g.px_per_mm);
    for v in ys {
        let py = g.y0 - g.px_per_mm * v;
        root.draw(&PathElement::new(
            vec![ip((lo.0 - 5.0, py)), ip((lo.0, py))],
            grey.stroke_width(1),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            label(v, dy),
            ip((lo.0 - 8.0, py)),
            style(11.0).pos(Pos::new(HPos::Right, VPos::Center)),
        ))
        .map_err(de)?;
    }
    Ok(())
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    map: &ArrowMap,
) -> Result<(), DrawFailure> {
    map_heading(root, &map.title, &map.notes)?;
    let g = geometry(map);
    let grey = RGBColor(0x99, 0x99, 0x99);
    // The frame of the plot area with its axis names.
    let lo = (
        f64::from(SIDE_PX) / 2.0 - g.span_px / 2.0 - 30.0,
        HEADER_PX + MARGIN_PX - 30.0,
    );
    let hi = (lo.0 + g.span_px + 60.0, lo.1 + g.span_px + 60.0);
    root.draw(&Rectangle::new(
        [ip(lo), ip(hi)],
        RGBColor(0xdd, 0xdd, 0xdd).stroke_width(1),
    ))
    .map_err(de)?;
    root.draw(&Text::new(
        map.x_label.clone(),
        (hi.0 as i32, hi.1 as i32 + 22),
        style(12.0).pos(Pos::new(HPos::Right, VPos::Top)),
    ))
    .map_err(de)?;
    frame_ticks(root, &g, lo, hi)?;
    root.draw(&Text::new(
        map.y_label.clone(),
        (lo.0 as i32, lo.1 as i32 - 18),
        style(12.0),
    ))
    .map_err(de)?;
    for a in &map.arrows {
        if !(a.x_mm.is_finite() && a.y_mm.is_finite()) {
            continue;
        }
        let p = g.px(a.x_mm, a.y_mm);
        root.draw(&Circle::new(ip(p), 3, grey.filled()))
            .map_err(de)?;
        if a.dx_um.is_finite() && a.dy_um.is_finite() {
            let q = (p.0 + g.px_per_um * a.dx_um, p.1 - g.px_per_um * a.dy_um);
            arrow(root, p, q, ARROW)?;
        }
    }
    // The key: an arrow of um_key µm, and the mm scale.
    let ky = f64::from(SIDE_PX) - 22.0;
    let kx = 20.0;
    arrow(root, (kx, ky), (kx + g.px_per_um * g.um_key, ky), ARROW)?;
    root.draw(&Text::new(
        format!(
            "arrow: {} µm (magnified {}×; the plate {:.0} mm wide)",
            g.um_key,
            two_digits(g.px_per_um / g.px_per_mm * 1000.0),
            g.span_px * (1.0 - 2.0 * LONGEST_SHARE) / g.px_per_mm
        ),
        ((kx + g.px_per_um * g.um_key + 12.0) as i32, ky as i32 - 7),
        style(13.0),
    ))
    .map_err(de)
}

/// `v` > 0 to two significant digits, the thousands of a number from 10 000 set apart by a
/// space: 146 150 → `150 000`, 2.345 → `2.3` (the key's magnification, which the map's
/// scale decides to no more than that).
fn two_digits(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v:.0}");
    }
    let exponent = v.log10().floor() as i32;
    let unit = 10f64.powi(exponent - 1);
    let rounded = (v / unit).round() * unit;
    let decimals = (1 - exponent).max(0) as usize;
    let text = format!("{rounded:.decimals$}");
    if rounded < 10_000.0 {
        return text;
    }
    let mut grouped = String::new();
    for (i, c) in text.chars().enumerate() {
        if i > 0 && (text.len() - i) % 3 == 0 {
            grouped.push(' ');
        }
        grouped.push(c);
    }
    grouped
}

#[cfg(test)]
mod tests {
    use super::{ticks, two_digits};

    #[test]
    fn the_magnification_has_two_significant_digits() {
        for (v, want) in [
            (146_150.0, "150 000"),
            (144_962.0, "140 000"),
            (1_234_567.0, "1 200 000"),
            (12_345.0, "12 000"),
            (9_949.0, "9900"),
            (987.0, "990"),
            (99.6, "100"),
            (42.0, "42"),
            (2.345, "2.3"),
            (0.0123, "0.012"),
        ] {
            assert_eq!(two_digits(v), want, "{v}");
        }
    }

    #[test]
    fn ticks_are_round_values_inside_the_range() {
        // 474 mm: steps of 10, 20 and 50 give more than eight intervals, 100 does not.
        assert_eq!(
            ticks(-37.0, 437.0),
            (vec![0.0, 100.0, 200.0, 300.0, 400.0], 0)
        );
        let (t, d) = ticks(0.0, 0.45);
        assert_eq!(d, 1);
        assert_eq!(t.len(), 5);
        assert!((t[4] - 0.4).abs() < 1e-12, "{t:?}");
        assert_eq!(
            ticks(-160.0, 160.0).0,
            vec![-150.0, -100.0, -50.0, 0.0, 50.0, 100.0, 150.0]
        );
        assert_eq!(ticks(1.0, 1.0), (Vec::new(), 0));
    }
}
