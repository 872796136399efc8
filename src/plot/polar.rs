//! The polar plot of a circular test in the style ballbar users know: the nominal circle,
//! the trace magnified about it (each direction in its own colour), the least-squares
//! circle dashed, the reversal points marked, rings every `scale` µm. Square, 800×800
//! pixels, PNG and SVG.
//!
//! A deviation dr (µm) is drawn at radius `R_px + dr·px_per_um` along its angle, so the
//! shape of the error shows at a magnification the caller chooses (`um_per_div`: µm per
//! ring; the nominal circle sits at the middle ring).

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::draw::{PALETTE, de};
use super::error::{DrawFailure, PlotError};
use super::render::{png_and_svg, whole};
use super::text::{font, fonts_ready};
use plotters::style::FontStyle;

/// The side of the square image, pixels.
pub(crate) const SIZE: u32 = 800;

/// The chart's height, pixels: the title and notes above the rings, the angle labels all
/// inside the picture (the 270° label was cut off at the foot of an 800 px square).
pub(crate) const HEIGHT: u32 = 860;

/// One trace of the plot: (angle rad, dr µm) in order.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarTrace {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Palette index of its colour.
    pub colour: usize,
}

/// What to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarChart {
    pub title: String,
    pub traces: Vec<PolarTrace>,
    /// The least-squares circle as (angle rad, dr µm) points, dashed grey.
    pub lsc: Vec<(f64, f64)>,
    /// Reversal points (angle rad, dr µm), marked with a black cross.
    pub marks: Vec<(f64, f64)>,
    /// µm per ring.
    pub um_per_div: f64,
    /// Lines of text under the title (the ISO numbers).
    pub notes: Vec<String>,
}

/// The RGB colour of palette entry `k` (what a test reads back from the PNG).
pub fn colour(k: usize) -> (u8, u8, u8) {
    let c = PALETTE[k % PALETTE.len()];
    (c.0, c.1, c.2)
}

/// The geometry: centre (px), nominal radius (px), pixels per µm.
pub(crate) fn layout(um_per_div: f64) -> ((f64, f64), f64, f64) {
    let centre = (SIZE as f64 / 2.0, 470.0);
    let r_px = 220.0;
    // Four rings inside and outside the nominal circle, 32 px apart.
    (centre, r_px, 32.0 / um_per_div)
}

/// The top left corner of the label of the spoke at `deg` degrees (13 px type: about
/// 30 × 14 px).
fn angle_label_origin(deg: u32, um_per_div: f64) -> (i32, i32) {
    let ((cx, cy), r_px, _) = layout(um_per_div);
    let rl = r_px + 4.0 * 32.0 + 12.0 + 14.0;
    let t = f64::from(deg).to_radians();
    (
        (cx + rl * t.cos()) as i32 - 12,
        (cy - rl * t.sin()) as i32 - 7,
    )
}

/// The pixel of (angle, dr): angle 0 to the right, 90° up.
pub fn pixel(theta: f64, dr_um: f64, um_per_div: f64) -> (i32, i32) {
    let ((cx, cy), r_px, k) = layout(um_per_div);
    let r = (r_px + dr_um * k).max(0.0);
    (
        (cx + r * theta.cos()).round() as i32,
        (cy - r * theta.sin()).round() as i32,
    )
}

/// Writes `<stem>.png` and `<stem>.svg`.
pub fn polar(stem: &Path, chart: &PolarChart) -> Result<Vec<PathBuf>, PlotError> {
    if !(chart.um_per_div.is_finite() && chart.um_per_div > 0.0) {
        return Err(PlotError::Invalid(format!(
            "µm per division {} must be > 0",
            chart.um_per_div
        )));
    }
    if chart.traces.iter().all(|t| t.points.is_empty()) {
        return Err(PlotError::Empty("traces"));
    }
    fonts_ready()?;
    let (png, svg) = png_and_svg(stem)?;
    whole(&png, |p| {
        let root = BitMapBackend::new(p, (SIZE, HEIGHT)).into_drawing_area();
        draw(&root, chart, true)?;
        root.present().map_err(de)
    })?;
    whole(&svg, |p| {
        let root = SVGBackend::new(p, (SIZE, HEIGHT)).into_drawing_area();
        draw(&root, chart, false)?;
        root.present().map_err(de)
    })?;
    Ok(vec![png, svg])
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &PolarChart,
    bitmap: bool,
) -> Result<(), DrawFailure> {
    root.fill(&WHITE).map_err(de)?;
    let text = RGBColor(0x22, 0x22, 0x22);
    let grid = RGBColor(0xd0, 0xd0, 0xd0);
    let ((cx, cy), r_px, _) = layout(chart.um_per_div);
    let style = |size: f64| TextStyle::from(font(size, FontStyle::Normal)).color(&text);
    root.draw(&Text::new(chart.title.clone(), (20, 12), style(20.0)))
        .map_err(de)?;
    for (i, line) in chart.notes.iter().enumerate() {
        root.draw(&Text::new(
            line.clone(),
            (20, 40 + 18 * i as i32),
            style(14.0),
        ))
        .map_err(de)?;
    }
    // Rings every division, the nominal circle darker; spokes every 30°.
    for ring in -4i32..=4 {
        let r = r_px + 32.0 * ring as f64;
        let colour = if ring == 0 {
            RGBColor(0x60, 0x60, 0x60)
        } else {
            grid
        };
        let pts: Vec<(i32, i32)> = (0..=360)
            .map(|d| {
                let t = (d as f64).to_radians();
                (
                    (cx + r * t.cos()).round() as i32,
                    (cy - r * t.sin()).round() as i32,
                )
            })
            .collect();
        root.draw(&PathElement::new(pts, colour.stroke_width(1)))
            .map_err(de)?;
    }
    for d in (0..360).step_by(30) {
        let t = (d as f64).to_radians();
        let (r0, r1) = (r_px - 4.0 * 32.0, r_px + 4.0 * 32.0 + 12.0);
        root.draw(&PathElement::new(
            vec![
                ((cx + r0 * t.cos()) as i32, (cy - r0 * t.sin()) as i32),
                ((cx + r1 * t.cos()) as i32, (cy - r1 * t.sin()) as i32),
            ],
            grid.stroke_width(1),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            format!("{d}°"),
            angle_label_origin(d, chart.um_per_div),
            style(13.0),
        ))
        .map_err(de)?;
    }
    root.draw(&Text::new(
        format!("{} µm/div", chart.um_per_div),
        (20, HEIGHT as i32 - 30),
        style(14.0),
    ))
    .map_err(de)?;
    let px = |(t, d): (f64, f64)| pixel(t, d, chart.um_per_div);
    // The least-squares circle, dashed.
    let lsc: Vec<(i32, i32)> = chart.lsc.iter().map(|&p| px(p)).collect();
    for (i, w) in lsc.windows(2).enumerate() {
        if i % 6 < 3 {
            root.draw(&PathElement::new(
                w.to_vec(),
                RGBColor(0x55, 0x55, 0x55).stroke_width(1),
            ))
            .map_err(de)?;
        }
    }
    for (k, t) in chart.traces.iter().enumerate() {
        let c = PALETTE[t.colour % PALETTE.len()];
        let pts: Vec<(i32, i32)> = t
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|&p| px(p))
            .collect();
        if bitmap {
            // Segment by segment: the bitmap backend's miter joins of a thick polyline
            // draw spikes at every sharp turn of a noisy trace that are not in the data.
            for seg in pts.windows(2) {
                root.draw(&PathElement::new(seg.to_vec(), c.stroke_width(3)))
                    .map_err(de)?;
            }
        } else {
            root.draw(&PathElement::new(pts, c.stroke_width(3)))
                .map_err(de)?;
        }
        let y = HEIGHT as i32 - 60 + 18 * k as i32 - 18;
        root.draw(&PathElement::new(
            vec![(SIZE as i32 - 110, y + 7), (SIZE as i32 - 80, y + 7)],
            c.stroke_width(3),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            t.name.clone(),
            (SIZE as i32 - 70, y),
            style(14.0),
        ))
        .map_err(de)?;
    }
    for &m in &chart.marks {
        let (x, y) = px(m);
        root.draw(&Cross::new((x, y), 6, BLACK.stroke_width(2)))
            .map_err(de)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 35: "270°" was cut off at the foot of the picture and "90°" ran into the
    /// notes under the title. Every angle label lies inside the picture, below the title
    /// and two lines of notes.
    #[test]
    fn every_angle_label_is_inside_the_picture_and_clear_of_the_notes() {
        let notes_bottom = 40 + 18 + 16;
        for d in (0..360).step_by(30) {
            let (x, y) = angle_label_origin(d, 5.0);
            let (w, h) = (32, 15);
            assert!(x >= 0 && x + w <= SIZE as i32, "{d}°: x {x}");
            assert!(
                y >= notes_bottom && y + h <= HEIGHT as i32 - 4,
                "{d}°: y {y}"
            );
        }
    }
}
