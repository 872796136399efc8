//! The map of a probing test's residuals on the sphere, one disc per stylus: the
//! hemisphere the stylus probed seen from its pole (azimuthal equidistant: the distance
//! from the disc's centre is the angle θ from the pole, the direction is the azimuth φ),
//! rings at 22.5° steps, spokes every 45°. Each point is a disc coloured by the sign of its
//! residual (red outside the fitted sphere, blue inside) with its radius proportional to
//! |r| — the magnification is the same in every panel, the largest |r| of the chart drawn
//! [`MAX_DOT_PX`] wide — and its value printed beside it. PNG and SVG.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::draw::de;
use super::error::{DrawFailure, PlotError};
use super::render::{Figure, figure_pair, map_heading, map_text as style};
use super::text::fonts_ready;

/// One panel's side, pixels.
pub(crate) const PANEL_PX: u32 = 400;
/// The disc's radius at θ = the map's largest angle, pixels.
pub(crate) const DISC_PX: f64 = 150.0;
/// The radius of the largest residual's dot, pixels.
pub(crate) const MAX_DOT_PX: f64 = 16.0;
/// Panels per row.
pub(crate) const COLUMNS: usize = 3;
/// At most this many panels (a bound on the image size).
pub(crate) const MAX_PANELS: usize = 24;

const OUTSIDE: RGBColor = RGBColor(0xd6, 0x27, 0x28);
const INSIDE: RGBColor = RGBColor(0x1f, 0x77, 0xb4);

/// One probed point: its angles on the sphere and its residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPoint {
    /// θ, degrees from the pole.
    pub theta_deg: f64,
    /// φ, degrees about the pole.
    pub phi_deg: f64,
    /// The residual, µm (positive outside).
    pub r_um: f64,
}

/// One stylus.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPanel {
    pub title: String,
    /// A second line under the title.
    pub note: String,
    pub points: Vec<MapPoint>,
}

/// What to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereMap {
    pub title: String,
    /// Lines under the title.
    pub notes: Vec<String>,
    pub panels: Vec<MapPanel>,
}

/// The image's size for `panels` panels and `notes` lines of notes.
pub fn size(panels: usize, notes: usize) -> (u32, u32) {
    let rows = panels.div_ceil(COLUMNS).max(1) as u32;
    (
        (columns(panels) * PANEL_PX).max(MIN_WIDTH_PX),
        header_px(notes) + rows * PANEL_PX + 70,
    )
}

/// The narrowest image, pixels (room for the title, the notes and the key).
pub(crate) const MIN_WIDTH_PX: u32 = 680;

fn columns(panels: usize) -> u32 {
    panels.clamp(1, COLUMNS) as u32
}

fn header_px(notes: usize) -> u32 {
    40 + 18 * notes as u32
}

/// The largest θ a panel's disc shows: 90° or the panel's own largest, whichever is more.
fn theta_max(p: &MapPanel) -> f64 {
    p.points
        .iter()
        .map(|q| q.theta_deg)
        .filter(|t| t.is_finite())
        .fold(90.0, f64::max)
        .min(180.0)
}

/// The pixel of (θ, φ) in panel `k`: φ = 0 to the right, 90° up.
pub(crate) fn pixel(map: &SphereMap, k: usize, theta_deg: f64, phi_deg: f64) -> (i32, i32) {
    let (cx, cy) = centre(map, k);
    let rho = DISC_PX * theta_deg / theta_max(&map.panels[k]);
    let p = phi_deg.to_radians();
    (
        (cx + rho * p.cos()).round() as i32,
        (cy - rho * p.sin()).round() as i32,
    )
}

fn centre(map: &SphereMap, k: usize) -> (f64, f64) {
    let n = map.panels.len();
    let (w, _) = size(n, map.notes.len());
    let p = f64::from(PANEL_PX);
    let left = f64::from(w - columns(n) * PANEL_PX) / 2.0;
    let (col, row) = ((k % COLUMNS) as f64, (k / COLUMNS) as f64);
    (
        left + col * p + p / 2.0,
        f64::from(header_px(map.notes.len())) + row * p + p / 2.0 + 20.0,
    )
}

/// The largest |r| over all panels, µm (the magnification's reference).
pub(crate) fn max_abs_um(map: &SphereMap) -> f64 {
    map.panels
        .iter()
        .flat_map(|p| p.points.iter().map(|q| q.r_um.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
}

/// Writes `<stem>.png` and `<stem>.svg`.
pub fn sphere_map(stem: &Path, map: &SphereMap) -> Result<Vec<PathBuf>, PlotError> {
    if map.panels.is_empty() || map.panels.iter().all(|p| p.points.is_empty()) {
        return Err(PlotError::Empty("points"));
    }
    if map.panels.len() > MAX_PANELS {
        return Err(PlotError::Invalid(format!(
            "{} panels: at most {MAX_PANELS} styli are drawn",
            map.panels.len()
        )));
    }
    fonts_ready()?;
    let (w, h) = size(map.panels.len(), map.notes.len());
    figure_pair(stem, (w, h), map)
}

impl Figure for SphereMap {
    fn draw_on<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), DrawFailure> {
        draw(root, self)
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    map: &SphereMap,
) -> Result<(), DrawFailure> {
    map_heading(root, &map.title, &map.notes)?;
    let max = max_abs_um(map);
    let dot = |r: f64| {
        if max > 0.0 {
            (MAX_DOT_PX * r.abs() / max).max(2.0)
        } else {
            2.0
        }
    };
    for k in 0..map.panels.len() {
        panel(root, map, k, &dot)?;
    }
    legend(root, map, max)
}

fn panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    map: &SphereMap,
    k: usize,
    dot: &dyn Fn(f64) -> f64,
) -> Result<(), DrawFailure> {
    let p = &map.panels[k];
    let (cx, cy) = centre(map, k);
    let grid = RGBColor(0xcc, 0xcc, 0xcc);
    let tmax = theta_max(p);
    let x0 = cx as i32 - PANEL_PX as i32 / 2 + 12;
    let top = cy as i32 - PANEL_PX as i32 / 2 - 20;
    root.draw(&Text::new(p.title.clone(), (x0, top + 4), style(16.0)))
        .map_err(de)?;
    root.draw(&Text::new(p.note.clone(), (x0, top + 24), style(12.0)))
        .map_err(de)?;
    let mut theta = 22.5;
    while theta <= tmax + 1e-9 {
        let rho = DISC_PX * theta / tmax;
        let pts: Vec<(i32, i32)> = (0..=180)
            .map(|d| {
                let t = f64::from(d * 2).to_radians();
                (
                    (cx + rho * t.cos()).round() as i32,
                    (cy - rho * t.sin()).round() as i32,
                )
            })
            .collect();
        let colour = if (theta - 90.0).abs() < 1e-9 {
            RGBColor(0x80, 0x80, 0x80)
        } else {
            grid
        };
        root.draw(&PathElement::new(pts, colour.stroke_width(1)))
            .map_err(de)?;
        theta += 22.5;
    }
    for d in (0..360).step_by(45) {
        let t = f64::from(d).to_radians();
        let end = (
            (cx + DISC_PX * t.cos()).round() as i32,
            (cy - DISC_PX * t.sin()).round() as i32,
        );
        root.draw(&PathElement::new(
            vec![(cx as i32, cy as i32), end],
            grid.stroke_width(1),
        ))
        .map_err(de)?;
        let rl = DISC_PX + 14.0;
        root.draw(&Text::new(
            format!("φ {d}°"),
            (
                (cx + rl * t.cos()) as i32 - 16,
                (cy - rl * t.sin()) as i32 - 6,
            ),
            style(10.0),
        ))
        .map_err(de)?;
    }
    for q in p
        .points
        .iter()
        .filter(|q| q.theta_deg.is_finite() && q.r_um.is_finite())
    {
        let (x, y) = pixel(map, k, q.theta_deg, q.phi_deg);
        let c = if q.r_um >= 0.0 { OUTSIDE } else { INSIDE };
        let r = dot(q.r_um).round() as i32;
        root.draw(&Circle::new((x, y), r, c.mix(0.75).filled()))
            .map_err(de)?;
        root.draw(&Circle::new((x, y), r, c.stroke_width(1)))
            .map_err(de)?;
        root.draw(&Text::new(
            format!("{:+.2}", q.r_um),
            (x + r + 2, y - 6),
            style(11.0),
        ))
        .map_err(de)?;
    }
    Ok(())
}

/// The key: the two colours and the dot of the largest |r|.
fn legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    map: &SphereMap,
    max: f64,
) -> Result<(), DrawFailure> {
    let (_, h) = size(map.panels.len(), map.notes.len());
    let y = h as i32 - 44;
    let mut x = 24;
    for (c, label) in [
        (OUTSIDE, "outside the sphere (r > 0)"),
        (INSIDE, "inside (r < 0)"),
    ] {
        root.draw(&Circle::new((x, y), 7, c.mix(0.75).filled()))
            .map_err(de)?;
        root.draw(&Text::new(label, (x + 12, y - 7), style(13.0)))
            .map_err(de)?;
        x += 200;
    }
    x += 10;
    root.draw(&Circle::new(
        (x, y),
        MAX_DOT_PX as i32,
        BLACK.stroke_width(1),
    ))
    .map_err(de)?;
    root.draw(&Text::new(
        format!("|r| = {max:.2} µm"),
        (x + MAX_DOT_PX as i32 + 6, y - 7),
        style(13.0),
    ))
    .map_err(de)?;
    root.draw(&Text::new(
        "dot radius ∝ |r| (one scale for every stylus); labels: r / µm; rings: θ = 22.5°, 45°, 67.5°, 90° from the pole",
        (24, y + 20),
        style(12.0),
    ))
    .map_err(de)?;
    Ok(())
}
