//! What a chart is built from, and how each piece is drawn: the `Frame` (title, axes,
//! legend), the primitives inside the plot area (`Prim`), the series' colours and marker
//! shapes, and the legend panel, which draws its samples with the same marker and bar
//! primitives as the plot area.

use std::fmt::Display;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::error::DrawFailure;
use super::scale::{Axis, HEIGHT, MARGIN_TOP, WIDTH};
use super::text::{LEGEND_SIZE, fit_text, font, text_width};

const LEGEND_ROW: f64 = 24.0;
const MARKER_R: f64 = 5.0;

/// Width of data lines.
const LINE_W: f64 = 2.0;

pub(super) const TEXT: RGBColor = RGBColor(0x22, 0x22, 0x22);
const BAND: RGBColor = RGBColor(0x80, 0x80, 0x80);
const BAND_ALPHA: f64 = 0.18;
/// Outline of the hollow marker in the legend's highlight entry.
const HOLLOW_SAMPLE: RGBColor = RGBColor(0x55, 0x55, 0x55);

/// Tableau 10: ten colours that stay distinct from one another on white.
pub(super) const PALETTE: [RGBColor; 10] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x7f, 0x7f, 0x7f),
    RGBColor(0xbc, 0xbd, 0x22),
    RGBColor(0x17, 0xbe, 0xcf),
];

const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::TriangleDown,
];

/// Colour and marker shape of series `k`.
pub(super) fn series_look(k: usize) -> (RGBColor, Marker) {
    (
        PALETTE[k % PALETTE.len()],
        MARKERS[(k + k / PALETTE.len()) % MARKERS.len()],
    )
}

/// Turns points with gaps into line segments; isolated points become dots when `dots`.
pub(super) fn push_lines(
    prims: &mut Vec<Prim>,
    pts: &[Option<(f64, f64)>],
    color: RGBColor,
    dots: bool,
) {
    for run in pts.split(|p| p.is_none()) {
        let run: Vec<(f64, f64)> = run.iter().flatten().copied().collect();
        match run.as_slice() {
            [] => {}
            [single] => {
                if dots {
                    prims.push(Prim::Dot { at: *single, color });
                }
            }
            _ => prims.push(Prim::Line { pts: run, color }),
        }
    }
}

pub(super) fn de<E: Display>(e: E) -> DrawFailure {
    DrawFailure::new(e)
}

/// Everything about a chart except the data drawn inside the plot area. Sizes are in
/// output pixels (scale 1).
#[derive(Debug, Clone)]
pub(super) struct Frame {
    pub(super) title: String,
    pub(super) x_desc: String,
    pub(super) y_desc: String,
    /// Image height (the width is always `WIDTH`).
    pub(super) height: u32,
    pub(super) x_area: u32,
    pub(super) y_area: u32,
    pub(super) x: Axis,
    pub(super) y: Axis,
    pub(super) x_grid: bool,
    pub(super) y_grid: bool,
    pub(super) legend: Vec<LegendEntry>,
    pub(super) legend_width: u32,
}

impl Frame {
    /// A frame of the standard height with grid lines both ways: `labels` are the title
    /// and the x and y descriptions; each axis comes with its label area.
    pub(super) fn standard(
        labels: [&str; 3],
        (x, x_area): (Axis, u32),
        (y, y_area): (Axis, u32),
        legend: Vec<LegendEntry>,
        legend_width: u32,
    ) -> Frame {
        let [title, x_desc, y_desc] = labels.map(str::to_owned);
        Frame {
            title,
            x_desc,
            y_desc,
            height: HEIGHT,
            x_area,
            y_area,
            x,
            y,
            x_grid: true,
            y_grid: true,
            legend,
            legend_width,
        }
    }
}

/// Things drawn in the plot area, in axis coordinates.
#[derive(Debug, Clone)]
pub(super) enum Prim {
    /// Shaded vertical band over the full height.
    Band { x0: f64, x1: f64 },
    /// Filled bar between two corners.
    Rect {
        a: (f64, f64),
        b: (f64, f64),
        color: RGBColor,
    },
    /// Polyline.
    Line {
        pts: Vec<(f64, f64)>,
        color: RGBColor,
    },
    /// Thin dark reference line (zero of a signed bar chart).
    Zero { a: (f64, f64), b: (f64, f64) },
    /// Small dot (an isolated point of a line).
    Dot { at: (f64, f64), color: RGBColor },
    /// Error bar with end caps.
    ErrBar {
        from: (f64, f64),
        to: (f64, f64),
        color: RGBColor,
    },
    /// Marker, filled or hollow.
    Marker {
        at: (f64, f64),
        marker: Marker,
        color: RGBColor,
        filled: bool,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
}

#[derive(Debug, Clone)]
pub(super) enum Sample {
    /// A line, optionally with a marker in the middle.
    Line {
        color: RGBColor,
        marker: Option<Marker>,
    },
    /// A dashed line, optionally with a marker in the middle.
    Dashed {
        color: RGBColor,
        marker: Option<Marker>,
    },
    /// A filled marker.
    Marker { color: RGBColor, marker: Marker },
    /// A bar swatch.
    Bar { color: RGBColor },
    /// The highlight band with a hollow marker.
    Band,
}

#[derive(Debug, Clone)]
pub(super) struct LegendEntry {
    pub(super) label: String,
    pub(super) sample: Sample,
}

const LEGEND_SAMPLE_W: f64 = 34.0;
const LEGEND_PAD: f64 = 10.0;
/// Space between the legend box and the right edge of the image.
const LEGEND_RIGHT: f64 = 12.0;

pub(super) fn legend_width(entries: &[LegendEntry]) -> u32 {
    if entries.is_empty() {
        return 0;
    }
    let widest = entries
        .iter()
        .map(|e| text_width(&e.label, LEGEND_SIZE, FontStyle::Normal))
        .max()
        .unwrap_or(0);
    let chrome = (LEGEND_SAMPLE_W + 3.0 * LEGEND_PAD + LEGEND_RIGHT) as u32;
    (widest + chrome).min((f64::from(WIDTH) * 0.38) as u32)
}

pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    t: Target,
) -> Result<(), DrawFailure> {
    let (w, _) = area.dim_in_pixel();
    let top = t.px(f64::from(MARGIN_TOP));
    let right = w as i32 - t.px(LEGEND_RIGHT);
    let row = t.px(LEGEND_ROW);
    let pad = t.px(LEGEND_PAD);
    let bottom = top + row * entries.len() as i32 + pad;
    area.draw(&Rectangle::new([(0, top), (right, bottom)], WHITE.filled()))
        .map_err(de)?;
    area.draw(&Rectangle::new(
        [(0, top), (right, bottom)],
        BLACK.mix(0.35).stroke_width(t.upx(1.0)),
    ))
    .map_err(de)?;
    let x0 = pad;
    let x1 = x0 + t.px(LEGEND_SAMPLE_W);
    let xm = (x0 + x1) / 2;
    let text_x = x1 + pad;
    // Measured at scale 1, like the legend width.
    let text_max = ((f64::from(right - text_x) / t.s) - LEGEND_PAD / 2.0).max(10.0) as u32;
    let style = t.text_style(LEGEND_SIZE, FontStyle::Normal, HPos::Left, VPos::Center);
    for (k, e) in entries.iter().enumerate() {
        let y = top + pad / 2 + row * k as i32 + row / 2;
        match e.sample {
            Sample::Line { color, marker } => {
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    color.stroke_width(t.upx(LINE_W)),
                ))
                .map_err(de)?;
                if let Some(m) = marker {
                    draw_marker(area, (xm, y), m, color, true, t)?;
                }
            }
            Sample::Dashed { color, marker } => {
                // Three dashes across the sample's width.
                let w = x1 - x0;
                for k in 0..3 {
                    let a = x0 + w * (5 * k) / 14;
                    area.draw(&PathElement::new(
                        vec![(a, y), (a + w * 4 / 14, y)],
                        color.stroke_width(t.upx(LINE_W)),
                    ))
                    .map_err(de)?;
                }
                if let Some(m) = marker {
                    draw_marker(area, (xm, y), m, color, true, t)?;
                }
            }
            Sample::Marker { color, marker } => draw_marker(area, (xm, y), marker, color, true, t)?,
            Sample::Bar { color } => {
                let (dx, dy) = (t.px(4.0), t.px(7.0));
                draw_bar(area, [(x0 + dx, y - dy), (x1 - dx, y + dy)], color, t)?;
            }
            Sample::Band => {
                let (dx, dy) = (t.px(4.0), t.px(10.0));
                area.draw(&Rectangle::new(
                    [(x0 + dx, y - dy), (x1 - dx, y + dy)],
                    BAND.mix(BAND_ALPHA).filled(),
                ))
                .map_err(de)?;
                draw_marker(area, (xm, y), Marker::Circle, HOLLOW_SAMPLE, false, t)?;
            }
        }
        let label = fit_text(&e.label, LEGEND_SIZE, FontStyle::Normal, text_max);
        area.draw_text(&label, &style, (text_x, y + t.text_dy(LEGEND_SIZE)))
            .map_err(de)?;
    }
    Ok(())
}

/// How one output is rendered: pixel scale (the PNG is drawn at `SUPERSAMPLE` times its
/// size, then averaged down) and whether text goes through plotters' rasteriser.
#[derive(Debug, Clone, Copy)]
pub(super) struct Target {
    pub(super) s: f64,
    pub(super) bitmap: bool,
}

impl Target {
    pub(super) fn px(self, v: f64) -> i32 {
        (v * self.s).round() as i32
    }

    pub(super) fn upx(self, v: f64) -> u32 {
        (v * self.s).round().max(0.0) as u32
    }

    /// plotters' `ab_glyph` rasteriser puts centre-anchored text about a fifth of the font
    /// size too high; the SVG viewer places it right. Returns the correction.
    pub(super) fn text_dy(self, size: f64) -> i32 {
        if self.bitmap { self.px(0.2 * size) } else { 0 }
    }

    pub(super) fn font(self, size: f64, style: FontStyle) -> FontDesc<'static> {
        font(size * self.s, style)
    }

    pub(super) fn text_style(
        self,
        size: f64,
        style: FontStyle,
        h: HPos,
        v: VPos,
    ) -> TextStyle<'static> {
        TextStyle::from(self.font(size, style))
            .color(&TEXT)
            .pos(Pos::new(h, v))
    }
}

type PlotArea<DB> = DrawingArea<DB, Cartesian2d<Axis, Axis>>;

/// Draws one primitive: areas and lines in axis coordinates on `plot` (clipped to it),
/// bars, markers and error bars in pixels on `root` (so that they keep their shape).
pub(super) fn draw_prim<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PlotArea<DB>,
    frame: &Frame,
    prim: &Prim,
    t: Target,
) -> Result<(), DrawFailure> {
    match prim {
        Prim::Band { x0, x1 } => {
            plot.draw(&Rectangle::new(
                [(*x0, frame.y.lo), (*x1, frame.y.hi)],
                BAND.mix(BAND_ALPHA).filled(),
            ))
            .map_err(de)?;
        }
        Prim::Rect { a, b, color } => {
            let (pa, pb) = (plot.map_coordinate(a), plot.map_coordinate(b));
            draw_bar(root, [pa, pb], *color, t)?;
        }
        Prim::Line { pts, color } => {
            let style = color.stroke_width(t.upx(LINE_W));
            if t.bitmap {
                // The bitmap backend joins a thick polyline's segments with unlimited
                // miters: at a sharp turn (a periodogram's spikes) the join shoots far
                // past the point, outside the plot frame. Segment by segment there are
                // no joins to overshoot.
                for seg in pts.windows(2) {
                    plot.draw(&PathElement::new(seg.to_vec(), style))
                        .map_err(de)?;
                }
            } else {
                plot.draw(&PathElement::new(pts.clone(), style))
                    .map_err(de)?;
            }
        }
        Prim::Zero { a, b } => {
            plot.draw(&PathElement::new(
                vec![*a, *b],
                BLACK.mix(0.6).stroke_width(t.upx(1.0)),
            ))
            .map_err(de)?;
        }
        Prim::Dot { at, color } => {
            root.draw(&Circle::new(
                plot.map_coordinate(at),
                t.px(3.0),
                color.filled(),
            ))
            .map_err(de)?;
        }
        Prim::ErrBar { from, to, color } => {
            let (a, b) = (plot.map_coordinate(from), plot.map_coordinate(to));
            let style = color.stroke_width(t.upx(1.0));
            root.draw(&PathElement::new(vec![a, b], style))
                .map_err(de)?;
            let cap = t.px(5.0);
            for (x, y) in [a, b] {
                let ends = if a.0 == b.0 {
                    [(x - cap, y), (x + cap, y)]
                } else {
                    [(x, y - cap), (x, y + cap)]
                };
                root.draw(&PathElement::new(ends.to_vec(), style))
                    .map_err(de)?;
            }
        }
        Prim::Marker {
            at,
            marker,
            color,
            filled,
        } => draw_marker(root, plot.map_coordinate(at), *marker, *color, *filled, t)?,
    }
    Ok(())
}

/// A filled bar with a slightly darker outline, between two pixel corners.
fn draw_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    corners: [(i32, i32); 2],
    color: RGBColor,
    t: Target,
) -> Result<(), DrawFailure> {
    let RGBColor(r, g, b) = color;
    let edge = RGBColor(
        (f64::from(r) * 0.7) as u8,
        (f64::from(g) * 0.7) as u8,
        (f64::from(b) * 0.7) as u8,
    );
    area.draw(&Rectangle::new(corners, color.mix(0.85).filled()))
        .map_err(de)?;
    area.draw(&Rectangle::new(corners, edge.stroke_width(t.upx(1.0))))
        .map_err(de)?;
    Ok(())
}

/// A marker centred on pixel `(x, y)`: filled in `color`, or white with a `color` outline.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    marker: Marker,
    color: RGBColor,
    filled: bool,
    t: Target,
) -> Result<(), DrawFailure> {
    let r = t.px(MARKER_R);
    let fill = if filled {
        color.filled()
    } else {
        WHITE.filled()
    };
    let edge = color.stroke_width(t.upx(if filled { 1.0 } else { 2.0 }));
    let outline = |pts: Vec<(i32, i32)>| -> Result<(), DrawFailure> {
        let mut closed = pts.clone();
        if let Some(&first) = pts.first() {
            closed.push(first);
        }
        area.draw(&Polygon::new(pts, fill)).map_err(de)?;
        // A filled marker's outline would be its own colour: one shape is enough (and
        // halves the size of a scatter's SVG).
        if filled {
            return Ok(());
        }
        area.draw(&PathElement::new(closed, edge)).map_err(de)
    };
    match marker {
        Marker::Circle => {
            area.draw(&Circle::new((x, y), r, fill)).map_err(de)?;
            if !filled {
                area.draw(&Circle::new((x, y), r, edge)).map_err(de)?;
            }
        }
        Marker::Square => {
            let s = t.px(MARKER_R - 0.8);
            outline(vec![
                (x - s, y - s),
                (x + s, y - s),
                (x + s, y + s),
                (x - s, y + s),
            ])?;
        }
        Marker::Triangle | Marker::TriangleDown => {
            let sign = if marker == Marker::Triangle { 1 } else { -1 };
            let (half, up, down) = (
                t.px(MARKER_R + 1.2),
                t.px(MARKER_R + 1.2),
                t.px(MARKER_R - 0.6),
            );
            outline(vec![
                (x, y - sign * up),
                (x + half, y + sign * down),
                (x - half, y + sign * down),
            ])?;
        }
        Marker::Diamond => {
            let d = t.px(MARKER_R + 1.2);
            outline(vec![(x, y - d), (x + d, y), (x, y + d), (x - d, y)])?;
        }
    }
    Ok(())
}
