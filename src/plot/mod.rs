//! Charts for errmap reports, rendered with [plotters] to PNG and SVG.
//!
//! Every chart function writes two files next to each other, `<stem>.png` (1000×600 pixels)
//! and `<stem>.svg` (same size), creates the parent directory when it is missing, and
//! returns both paths (PNG first). The one exception to the size: a horizontal bar chart
//! with more than about 25 labels grows taller (20 pixels per label, at most 4000 pixels)
//! so that every label stays readable. The suffix is appended to the stem, so a stem such as
//! `reports/fig.v2` gives `reports/fig.v2.png`.
//!
//! # Fonts
//!
//! Text is drawn with DejaVu Sans, bundled as bytes by the `dejavu` crate and registered
//! with plotters' `ab_glyph` text path ([`register_fonts`]), so rendering needs no system
//! fonts and no fontconfig: a fresh machine with no fonts at all renders the same PNGs.
//! DejaVu Sans covers the symbols errmap labels use (×, µ, σ, ±, −, superscripts).
//! Only the family `sans-serif` is registered (regular, bold, oblique); this module uses
//! nothing else. plotters' `ttf` feature must stay off in the whole dependency tree: with
//! it on, plotters ignores registered fonts and looks for system fonts instead.
//! The SVG files contain the text as `<text>` elements with `font-family="sans-serif"`;
//! the viewer's own sans-serif font renders them.
//!
//! The PNG is drawn at twice its size and averaged down: plotters' bitmap backend draws
//! lines without anti-aliasing and places glyphs only to the whole pixel (letters look
//! unevenly spaced at small sizes), and both look clean after averaging. The module also
//! corrects the vertical offset of centred text in plotters' `ab_glyph` rasteriser, so tick
//! labels sit level with their ticks.
//!
//! # Input conventions
//!
//! * Units are the caller's business: put them in the axis labels.
//! * Non-finite values (NaN, ±∞) are skipped, never plotted. A line is broken where a
//!   value is missing rather than bridged across the gap.
//! * One-sigma error bars are drawn for finite, positive errors only.
//! * Axis ranges are padded and never degenerate: all-equal values and a single point
//!   get a sensible range around them.
//! * Series colours come from a fixed 10-colour palette (Tableau 10) combined with five
//!   marker shapes, so at least 10 series (and in practice many more) stay
//!   distinguishable, also in greyscale print thanks to the shapes.
//! * Legends are drawn in a panel to the right of the plot, so they never hide data.
//!   Long names are shortened with "…" only when they would not fit in 38 % of the width.
//!
//! # Layout of this module
//!
//! The files follow the call order; each one imports only the files below it, so there
//! are no cycles between them:
//!
//! | file | holds | imports |
//! |---|---|---|
//! | `mod.rs` | the public chart functions, their input types and input checks | all below |
//! | `render.rs` | a chart to PNG and SVG: title strip, mesh and ticks, supersampling, files | draw, scale, text, error |
//! | `draw.rs` | what charts are built from (`Frame`, `Prim`, legend entries, series colours and markers) and how each is drawn, the legend included | scale, text |
//! | `scale.rs` | axes: padded ranges, linear, log and category ticks; the page geometry | text, error |
//! | `text.rs` | the bundled fonts, text measurement, tick-label number formats | error |
//! | `error.rs` | [`PlotError`] | — |
//!
//! `error.rs` is the one file beyond the planned five: every layer returns [`PlotError`]
//! (the font check, the log axis, the file writers), so kept in `mod.rs` it would make
//! each of them import its parent and close a cycle. The legend sits in `draw.rs` beside
//! the marker and bar primitives it draws its samples with.

mod arrows;
mod draw;
mod error;
mod polar;
mod render;
mod scale;
mod sphere;
pub use arrows::{Arrow, ArrowMap, LONGEST_SHARE, MAX_ARROWS, SIDE_PX, arrow_map};
mod text;

pub use error::{DrawFailure, PlotError};
pub use polar::{PolarChart, PolarTrace, colour, pixel, polar};
pub use scale::round_ticks;
pub use sphere::{MapPanel, MapPoint, SphereMap, size as sphere_size, sphere_map};
pub use text::register_fonts;

use std::path::{Path, PathBuf};

use plotters::style::{FontStyle, RGBColor};

use draw::{
    Frame, LegendEntry, Marker, PALETTE, Prim, Sample, legend_width, push_lines, series_look,
};
use render::write_both;
use scale::{
    Axis, Extent, HEIGHT, WIDTH, padded_range, plot_height, plot_width, x_label_area, y_label_area,
};
use text::{TICK_SIZE, fonts_ready, text_width};

/// Horizontal bar charts get at least this many pixels per label...
const MIN_ROW_PX: f64 = 20.0;
/// ...up to this image height; beyond it, labels are thinned out.
const MAX_HEIGHT: u32 = 4000;

/// Scatter markers of one series closer than this (px) to one already drawn are dropped.
const THIN_PX: f64 = 2.5;

/// One named data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Name shown in the legend.
    pub name: String,
    /// One value per category (or per label for [`bars`]).
    pub y: Vec<f64>,
    /// One-sigma error bars, drawn when `Some`; same length as `y`.
    pub y_err: Option<Vec<f64>>,
}

/// One series of an [`xy`] chart, with its own x values.
#[derive(Debug, Clone, PartialEq)]
pub struct XySeries {
    /// Name shown in the legend.
    pub name: String,
    /// X values; same length as `y`.
    pub x: Vec<f64>,
    /// Y values; same length as `x`.
    pub y: Vec<f64>,
    /// Points or a line.
    pub style: XyStyle,
}

/// How an [`XySeries`] is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum XyStyle {
    /// One marker per point, no line.
    Points,
    /// A line through the points in the given order (no markers; an isolated point
    /// between two missing values is drawn as a small dot so that it does not vanish).
    Line,
    /// A line in a chosen colour, solid or dashed, with a marker at each point when
    /// `markers`. `colour` indexes the palette (modulo its 10 colours), so several series
    /// can share one colour — as a calibration chart draws a direction's mean solid and its
    /// ±2s limits dashed in the same colour. Dashes are 9 px long with 6 px gaps, measured
    /// along the line in output pixels.
    Styled {
        /// Palette index.
        colour: usize,
        /// Dashed instead of solid.
        dashed: bool,
        /// A marker (the colour's shape) at each finite point.
        markers: bool,
    },
}

impl XyStyle {
    /// The colour and marker of series `k` drawn in this style: a styled series takes its
    /// palette colour, the others the `k`-th.
    fn look(self, k: usize) -> (RGBColor, Marker) {
        match self {
            XyStyle::Styled { colour, .. } => series_look(colour % PALETTE.len()),
            XyStyle::Points | XyStyle::Line => series_look(k),
        }
    }
}

/// Dash and gap lengths of [`XyStyle::Styled`] dashed lines, output pixels.
const DASH_PX: f64 = 9.0;
const GAP_PX: f64 = 6.0;

/// Cuts a polyline into dashes `dash` long with gaps `gap` between them, lengths measured
/// after mapping each point through `to_px` (axis units → pixels). The pattern runs on
/// across vertices. Returns the dashes in axis units.
fn dashes(
    pts: &[(f64, f64)],
    to_px: impl Fn((f64, f64)) -> (f64, f64),
    dash: f64,
    gap: f64,
) -> Vec<Vec<(f64, f64)>> {
    const EPS: f64 = 1e-9;
    let period = dash + gap;
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    // Distance into the current dash+gap period, px.
    let mut phase = 0.0;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (pa, pb) = (to_px(a), to_px(b));
        let len = ((pb.0 - pa.0).powi(2) + (pb.1 - pa.1).powi(2)).sqrt();
        let at = |d: f64| {
            let f = if len > 0.0 { d / len } else { 0.0 };
            (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
        };
        let mut d = 0.0;
        while d < len - EPS {
            if phase < dash - EPS {
                let next = (d + dash - phase).min(len);
                if current.is_empty() {
                    current.push(at(d));
                }
                current.push(at(next));
                phase += next - d;
                d = next;
                if phase >= dash - EPS {
                    out.push(std::mem::take(&mut current));
                }
            } else {
                let next = (d + period - phase).min(len);
                phase += next - d;
                d = next;
                if phase >= period - EPS {
                    phase = 0.0;
                }
            }
        }
    }
    if current.len() > 1 {
        out.push(current);
    }
    out
}

/// Category chart like a paper's "measured vs predicted per test point".
///
/// The x axis holds the `categories` (e.g. `"P1"`…`"P7"`); each series is drawn as
/// markers, one value per category, with optional one-sigma error bars (then the series are
/// spread slightly sideways so that the bars do not hide one another). The categories are
/// separate points, not a path: no line joins them. A legend names the series.
///
/// `highlight` marks categories (e.g. extrapolated test points): they get a shaded band
/// and hollow markers, and the legend gets an entry `highlight_label`. Pass an empty slice
/// for no highlighting; otherwise it needs one flag per category.
///
/// Errors: empty `categories` or `series`, a series (or its errors, or `highlight`) whose
/// length differs from `categories`, or no finite value at all.
#[allow(clippy::too_many_arguments)]
pub fn category_points(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    categories: &[String],
    series: &[Series],
    highlight: &[bool],
    highlight_label: &str,
) -> Result<Vec<PathBuf>, PlotError> {
    let n = categories.len();
    if n == 0 {
        return Err(PlotError::Empty("categories"));
    }
    if series.is_empty() {
        return Err(PlotError::Empty("series"));
    }
    if !highlight.is_empty() {
        check_len("highlight", n, highlight.len())?;
    }
    for s in series {
        check_series(s, n)?;
    }
    fonts_ready()?;

    let (lo, hi) = error_extent(series).ok_or(PlotError::NoFiniteValues)?;
    let (lo, hi) = padded_range(lo, hi, true, true)?;
    let hl = |i: usize| highlight.get(i).copied().unwrap_or(false);
    let mut legend: Vec<LegendEntry> = series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (color, marker) = series_look(k);
            LegendEntry {
                label: s.name.clone(),
                sample: Sample::Marker { color, marker },
            }
        })
        .collect();
    if (0..n).any(hl) {
        let label = if highlight_label.is_empty() {
            "highlighted"
        } else {
            highlight_label
        };
        legend.push(LegendEntry {
            label: label.to_owned(),
            sample: Sample::Band,
        });
    }
    let labels = [title, x_label, y_label];
    write_standard(stem, labels, (lo, hi), legend, |plot_w, _| {
        let positions: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let x_axis = Axis::category(categories, &positions, -0.5, n as f64 - 0.5, plot_w, None);
        let mut prims = highlight_bands(n, &hl);
        category_series_prims(&mut prims, series, &hl);
        (x_axis, prims)
    })
}

/// The standard chart (title, axes with their labels, legend) around what `draw` gives
/// for a plot `plot_w` × `plot_h` px — its x axis and its primitives — over the y range
/// `(ylo, yhi)`, written as PNG and SVG.
fn write_standard(
    stem: &Path,
    labels: [&str; 3],
    (ylo, yhi): (f64, f64),
    legend: Vec<LegendEntry>,
    draw: impl FnOnce(f64, f64) -> (Axis, Vec<Prim>),
) -> Result<Vec<PathBuf>, PlotError> {
    let [_, x_label, y_label] = labels;
    let x_area = x_label_area(!x_label.is_empty());
    let plot_h = plot_height(HEIGHT, x_area);
    let y_axis = Axis::linear(ylo, yhi, plot_h, false);
    let legend_width = legend_width(&legend);
    let y_area = y_label_area(&y_axis, !y_label.is_empty());
    let plot_w = plot_width(legend_width, y_area);
    let (x_axis, prims) = draw(plot_w, plot_h);
    let frame = Frame::standard(
        labels,
        (x_axis, x_area),
        (y_axis, y_area),
        legend,
        legend_width,
    );
    write_both(stem, &frame, &prims)
}

/// The range of the series' finite values and of their error bars.
fn error_extent(series: &[Series]) -> Option<(f64, f64)> {
    let mut extent = Extent::default();
    for s in series {
        for (i, &y) in s.y.iter().enumerate() {
            if y.is_finite() {
                extent.add(y);
                if let Some(e) = err_at(s, i) {
                    extent.add(y - e);
                    extent.add(y + e);
                }
            }
        }
    }
    extent.get()
}

/// Shaded bands, one per run of consecutive highlighted categories.
fn highlight_bands(n: usize, hl: &dyn Fn(usize) -> bool) -> Vec<Prim> {
    let mut prims = Vec::new();
    let mut i = 0;
    while i < n {
        if hl(i) {
            let start = i;
            while i < n && hl(i) {
                i += 1;
            }
            prims.push(Prim::Band {
                x0: start as f64 - 0.5,
                x1: i as f64 - 0.5,
            });
        } else {
            i += 1;
        }
    }
    prims
}

/// Every series' error bars and markers (hollow on highlighted categories), each series
/// shifted sideways a little when error bars would overlap.
fn category_series_prims(prims: &mut Vec<Prim>, series: &[Series], hl: &dyn Fn(usize) -> bool) {
    let m = series.len();
    let dodge = if m > 1 && series.iter().any(|s| s.y_err.is_some()) {
        (0.3 / (m - 1) as f64).min(0.08)
    } else {
        0.0
    };
    for (k, s) in series.iter().enumerate() {
        let (color, marker) = series_look(k);
        let dx = (k as f64 - (m - 1) as f64 / 2.0) * dodge;
        for (i, &y) in s.y.iter().enumerate() {
            if !y.is_finite() {
                continue;
            }
            let x = i as f64 + dx;
            if let Some(e) = err_at(s, i) {
                prims.push(Prim::ErrBar {
                    from: (x, y - e),
                    to: (x, y + e),
                    color,
                });
            }
            prims.push(Prim::Marker {
                at: (x, y),
                marker,
                color,
                filled: !hl(i),
            });
        }
    }
}

/// Bar chart of one value per label (e.g. cross-validated RMS per interpolation order).
///
/// The bars are vertical when the labels fit under them and horizontal (labels on the left,
/// first label at the top) when they are too long or too many. `y_label` names the value
/// axis whichever way it points. With more than about 25 horizontal bars the image grows
/// taller than 600 pixels (20 pixels per label) instead of dropping labels.
///
/// `markers`: an optional second series (e.g. test RMS), one value per label, drawn as
/// markers beside each bar, with its error bars when it has them. With markers a legend is
/// shown: the bars are listed as `y_label` (or "value" when it is empty), the markers under
/// the series name.
///
/// `log_y`: logarithmic value axis, used only when every finite value (bars and markers) is
/// greater than zero; otherwise the axis silently stays linear. On a linear axis the bars
/// start at zero (with a zero line when values are signed); on a log axis they start at
/// the bottom of the axis, the whole decade below the smallest value.
///
/// A non-finite value leaves its label without a bar.
///
/// Errors: empty `labels`, `values` or `markers` of another length than `labels`, or no
/// finite value among the bars and markers.
pub fn bars(
    stem: &Path,
    title: &str,
    y_label: &str,
    labels: &[String],
    values: &[f64],
    markers: Option<&Series>,
    log_y: bool,
) -> Result<Vec<PathBuf>, PlotError> {
    let n = labels.len();
    if n == 0 {
        return Err(PlotError::Empty("labels"));
    }
    check_len("values", n, values.len())?;
    if let Some(s) = markers {
        check_series(s, n)?;
    }
    fonts_ready()?;

    let scale = ValueScale::of(values, markers, log_y)?;
    let legend = bars_legend(y_label, markers);
    let spec = BarSpec {
        title,
        y_label,
        labels,
        scale: &scale,
    };
    let layout = bar_layout(&spec, legend)?;
    let prims = bar_prims(&layout, &scale, values, markers);
    write_both(stem, &layout.frame, &prims)
}

/// The bars' colour, and the markers' colour and shape.
const BAR_COLOR: RGBColor = PALETTE[0];
const MARK_COLOR: RGBColor = PALETTE[1];
const MARK_SHAPE: Marker = Marker::Diamond;

/// The value axis of a bar chart: logarithmic when asked for and every value is
/// positive, otherwise linear and padded to include zero.
#[derive(Debug, Clone, Copy)]
struct ValueScale {
    log: bool,
    vmin: f64,
    vmax: f64,
    /// The linear axis's range; `None` on a log axis.
    linear: Option<(f64, f64)>,
}

impl ValueScale {
    /// The scale of the bars' values and the markers' (with their error bars where
    /// they can be shown).
    fn of(values: &[f64], markers: Option<&Series>, log_y: bool) -> Result<Self, PlotError> {
        let finite_values = || {
            values
                .iter()
                .chain(markers.iter().flat_map(|s| s.y.iter()))
                .copied()
                .filter(|v| v.is_finite())
        };
        if finite_values().next().is_none() {
            return Err(PlotError::NoFiniteValues);
        }
        let log = log_y && finite_values().all(|v| v > 0.0);
        let mut extent = Extent::default();
        for v in finite_values() {
            extent.add(v);
        }
        if let Some(s) = markers {
            for (i, &y) in s.y.iter().enumerate() {
                if let (true, Some(e)) = (y.is_finite(), err_at(s, i)) {
                    extent.add(y + e);
                    if !log || y - e > 0.0 {
                        extent.add(y - e);
                    }
                }
            }
        }
        let (vmin, vmax) = extent.get().ok_or(PlotError::NoFiniteValues)?;
        let linear = if log {
            None
        } else {
            let (lo, hi) = padded_range(vmin.min(0.0), vmax.max(0.0), vmin < 0.0, vmax > 0.0)?;
            // Bars of values that are all ≥ 0 stand on the axis' lower end even when every
            // one is 0 (a fleet whose risks are all 0), not mid-way on a ±1 axis.
            let lo = if vmin >= 0.0 { lo.max(0.0) } else { lo };
            Some((lo, hi))
        };
        Ok(Self {
            log,
            vmin,
            vmax,
            linear,
        })
    }

    /// The value axis over `length` pixels.
    fn axis(&self, length: f64, along_x: bool) -> Result<Axis, PlotError> {
        match self.linear {
            Some((lo, hi)) => Ok(Axis::linear(lo, hi, length, along_x)),
            None => Axis::log(self.vmin, self.vmax),
        }
    }
}

/// The legend of a bar chart: only with markers, to tell them from the bars.
fn bars_legend(y_label: &str, markers: Option<&Series>) -> Vec<LegendEntry> {
    match markers {
        Some(s) => vec![
            LegendEntry {
                label: if y_label.is_empty() {
                    "value".to_owned()
                } else {
                    y_label.to_owned()
                },
                sample: Sample::Bar { color: BAR_COLOR },
            },
            LegendEntry {
                label: s.name.clone(),
                sample: Sample::Marker {
                    color: MARK_COLOR,
                    marker: MARK_SHAPE,
                },
            },
        ],
        None => Vec::new(),
    }
}

/// What a bar chart is drawn from, in either orientation.
#[derive(Clone, Copy)]
struct BarSpec<'a> {
    title: &'a str,
    /// The value axis' label.
    y_label: &'a str,
    labels: &'a [String],
    scale: &'a ValueScale,
}

/// A bar chart's frame, its orientation, each label's category coordinate, and the
/// pixels per category.
struct BarLayout {
    frame: Frame,
    vertical: bool,
    positions: Vec<f64>,
    slot_px: f64,
}

/// Vertical bars if every label fits under its bar, horizontal bars otherwise.
fn bar_layout(spec: &BarSpec<'_>, legend: Vec<LegendEntry>) -> Result<BarLayout, PlotError> {
    let n = spec.labels.len();
    let legend_width = legend_width(&legend);
    let vertical_value_axis = spec
        .scale
        .axis(plot_height(HEIGHT, x_label_area(false)), false)?;
    let vertical_y_area = y_label_area(&vertical_value_axis, !spec.y_label.is_empty());
    let vertical_plot_w = plot_width(legend_width, vertical_y_area);
    let max_label_w = spec
        .labels
        .iter()
        .map(|l| text_width(l, TICK_SIZE, FontStyle::Normal))
        .max()
        .unwrap_or(0);
    let vertical = f64::from(max_label_w + 12) <= vertical_plot_w / n as f64;

    // Category coordinate of each label: left to right, or top to bottom.
    let positions: Vec<f64> = (0..n)
        .map(|i| if vertical { i } else { n - 1 - i } as f64)
        .collect();
    let frame = if vertical {
        Frame {
            title: spec.title.to_owned(),
            x_desc: String::new(),
            y_desc: spec.y_label.to_owned(),
            height: HEIGHT,
            x_area: x_label_area(false),
            y_area: vertical_y_area,
            x: Axis::category(
                spec.labels,
                &positions,
                -0.5,
                n as f64 - 0.5,
                vertical_plot_w,
                None,
            ),
            y: vertical_value_axis,
            x_grid: false,
            y_grid: true,
            legend,
            legend_width,
        }
    } else {
        horizontal_bar_frame(spec, &positions, legend)?
    };
    let slot_px = if vertical {
        vertical_plot_w
    } else {
        plot_height(frame.height, frame.x_area)
    } / n as f64;
    Ok(BarLayout {
        frame,
        vertical,
        positions,
        slot_px,
    })
}

/// The frame of horizontal bars: taller than usual when there are many labels, so that
/// every one stays readable.
fn horizontal_bar_frame(
    spec: &BarSpec<'_>,
    positions: &[f64],
    legend: Vec<LegendEntry>,
) -> Result<Frame, PlotError> {
    let n = spec.labels.len();
    let legend_width = legend_width(&legend);
    let x_area = x_label_area(!spec.y_label.is_empty());
    let needed = n as f64 * MIN_ROW_PX;
    let available = plot_height(HEIGHT, x_area);
    let height = if needed > available {
        (f64::from(HEIGHT) + needed - available)
            .ceil()
            .min(f64::from(MAX_HEIGHT)) as u32
    } else {
        HEIGHT
    };
    let cat_axis = Axis::category(
        spec.labels,
        positions,
        -0.5,
        n as f64 - 0.5,
        plot_height(height, x_area),
        Some(f64::from(WIDTH) * 0.4),
    );
    let y_area = y_label_area(&cat_axis, false);
    Ok(Frame {
        title: spec.title.to_owned(),
        x_desc: spec.y_label.to_owned(),
        y_desc: String::new(),
        height,
        x_area,
        y_area,
        x: spec.scale.axis(plot_width(legend_width, y_area), true)?,
        y: cat_axis,
        x_grid: true,
        y_grid: false,
        legend,
        legend_width,
    })
}

/// The bars (from zero, or from the axis's bottom on a log axis), a zero line for signed
/// values, and the markers with their error bars.
fn bar_prims(
    layout: &BarLayout,
    scale: &ValueScale,
    values: &[f64],
    markers: Option<&Series>,
) -> Vec<Prim> {
    let (vertical, positions) = (layout.vertical, &layout.positions);
    let (cat_lo, cat_hi) = (-0.5, positions.len() as f64 - 0.5);
    // (x, y) of a point at category coordinate `c` and value-axis coordinate `v`.
    let pt = |c: f64, v: f64| if vertical { (c, v) } else { (v, c) };
    let value_axis = if vertical {
        &layout.frame.y
    } else {
        &layout.frame.x
    };
    // Coordinate of a value on the value axis (log10 on a log axis).
    let vc = |v: f64| value_axis.coord(v);
    let base = if scale.log { value_axis.lo } else { 0.0 };

    // Bar and marker offsets across the category, in category units; with few bars
    // they are kept to a slot of about 150 pixels.
    let shrink = (150.0 / layout.slot_px).min(1.0);
    let (bar_c, bar_half, mark_off) = if markers.is_some() {
        (-0.12 * shrink, 0.25 * shrink, 0.25 * shrink)
    } else {
        (0.0, 0.32 * shrink, 0.0)
    };

    let mut prims = Vec::new();
    if scale.linear.is_some_and(|(lo, _)| lo < 0.0) {
        // Signed values: a zero line to grow the bars from.
        prims.push(Prim::Zero {
            a: pt(cat_lo, 0.0),
            b: pt(cat_hi, 0.0),
        });
    }
    for (&v, &p) in values.iter().zip(positions) {
        if !v.is_finite() {
            continue;
        }
        let c = p + bar_c;
        prims.push(Prim::Rect {
            a: pt(c - bar_half, base),
            b: pt(c + bar_half, vc(v)),
            color: BAR_COLOR,
        });
    }
    let Some(s) = markers else {
        return prims;
    };
    for (i, (&y, &p)) in s.y.iter().zip(positions).enumerate() {
        if !y.is_finite() {
            continue;
        }
        let c = p + mark_off;
        if let Some(e) = err_at(s, i) {
            let low = if scale.log && y - e <= 0.0 {
                value_axis.lo
            } else {
                vc(y - e)
            };
            prims.push(Prim::ErrBar {
                from: pt(c, low),
                to: pt(c, vc(y + e)),
                color: MARK_COLOR,
            });
        }
        prims.push(Prim::Marker {
            at: pt(c, vc(y)),
            marker: MARK_SHAPE,
            color: MARK_COLOR,
            filled: true,
        });
    }
    prims
}

/// Generic x–y chart: several series, each with its own x values, drawn as points or lines.
///
/// A legend names the series; a series with an empty name has no entry (the second of
/// a pair of limit lines drawn alike). Errors: empty `series`, a series whose `x` and `y` lengths
/// differ, or no point with both coordinates finite. Individual series may be empty.
pub fn xy(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[XySeries],
) -> Result<Vec<PathBuf>, PlotError> {
    if series.is_empty() {
        return Err(PlotError::Empty("series"));
    }
    for s in series {
        check_len(&format!("y of series \"{}\"", s.name), s.x.len(), s.y.len())?;
    }
    fonts_ready()?;

    let mut ex = Extent::default();
    let mut ey = Extent::default();
    for s in series {
        for (x, y) in finite_points(s).into_iter().flatten() {
            ex.add(x);
            ey.add(y);
        }
    }
    let ((xlo, xhi), (ylo, yhi)) = match (ex.get(), ey.get()) {
        (Some(x), Some(y)) => (x, y),
        _ => return Err(PlotError::NoFiniteValues),
    };
    let (xlo, xhi) = padded_range(xlo, xhi, true, true)?;
    let (ylo, yhi) = padded_range(ylo, yhi, true, true)?;
    let legend: Vec<LegendEntry> = series
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.name.is_empty())
        .map(|(k, s)| LegendEntry {
            label: s.name.clone(),
            sample: xy_sample(k, s.style),
        })
        .collect();
    let labels = [title, x_label, y_label];
    write_standard(stem, labels, (ylo, yhi), legend, |plot_w, plot_h| {
        let to_px = PxMap {
            xlo,
            xhi,
            ylo,
            yhi,
            w: plot_w,
            h: plot_h,
        };
        let mut prims = Vec::new();
        for (k, s) in series.iter().enumerate() {
            xy_series_prims(&mut prims, k, s, to_px);
        }
        (Axis::linear(xlo, xhi, plot_w, true), prims)
    })
}

/// A series' points, `None` where x or y is not finite (a break in its line).
fn finite_points(s: &XySeries) -> Vec<Option<(f64, f64)>> {
    s.x.iter()
        .zip(&s.y)
        .map(|(&x, &y)| (x.is_finite() && y.is_finite()).then_some((x, y)))
        .collect()
}

/// Where a value lands in the plot area, in pixels from its lower left corner: the
/// data range and the area's size, for dashing lines and thinning scatters.
#[derive(Debug, Clone, Copy)]
struct PxMap {
    xlo: f64,
    xhi: f64,
    ylo: f64,
    yhi: f64,
    w: f64,
    h: f64,
}

impl PxMap {
    fn px(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (
            (x - self.xlo) / (self.xhi - self.xlo) * self.w,
            (y - self.ylo) / (self.yhi - self.ylo) * self.h,
        )
    }
}

/// The legend's sample of series `k` drawn in `style`.
fn xy_sample(k: usize, style: XyStyle) -> Sample {
    let (color, marker) = style.look(k);
    match style {
        XyStyle::Points => Sample::Marker { color, marker },
        XyStyle::Line => Sample::Line {
            color,
            marker: None,
        },
        XyStyle::Styled {
            dashed: true,
            markers,
            ..
        } => Sample::Dashed {
            color,
            marker: markers.then_some(marker),
        },
        XyStyle::Styled {
            dashed: false,
            markers,
            ..
        } => Sample::Line {
            color,
            marker: markers.then_some(marker),
        },
    }
}

/// The primitives of series `k`: its line (solid or dashed), its markers, or its
/// thinned scatter.
fn xy_series_prims(prims: &mut Vec<Prim>, k: usize, s: &XySeries, to_px: PxMap) {
    let (color, marker) = s.style.look(k);
    let pts = finite_points(s);
    match s.style {
        XyStyle::Line => push_lines(prims, &pts, color, true),
        XyStyle::Styled {
            dashed, markers, ..
        } => {
            if dashed {
                for run in pts.split(|p| p.is_none()) {
                    let run: Vec<(f64, f64)> = run.iter().flatten().copied().collect();
                    for pts in dashes(&run, |p| to_px.px(p), DASH_PX, GAP_PX) {
                        prims.push(Prim::Line { pts, color });
                    }
                }
            } else {
                push_lines(prims, &pts, color, !markers);
            }
            if markers {
                for at in pts.iter().flatten() {
                    prims.push(Prim::Marker {
                        at: *at,
                        marker,
                        color,
                        filled: true,
                    });
                }
            }
        }
        XyStyle::Points => push_thinned(prims, &pts, marker, color, to_px),
    }
}

/// Scatter markers, thinned: a marker whose grid cell of 2.5 px (half its radius)
/// already holds one of the same series adds almost nothing visible, so it is dropped
/// and a 100 000-point scatter stays a small SVG that looks the same.
fn push_thinned(
    prims: &mut Vec<Prim>,
    pts: &[Option<(f64, f64)>],
    marker: Marker,
    color: RGBColor,
    to_px: PxMap,
) {
    let mut seen = std::collections::HashSet::new();
    for &at in pts.iter().flatten() {
        let (px, py) = to_px.px(at);
        let cell = ((px / THIN_PX).floor() as i64, (py / THIN_PX).floor() as i64);
        if !seen.insert(cell) {
            continue;
        }
        prims.push(Prim::Marker {
            at,
            marker,
            color,
            filled: true,
        });
    }
}

// ---------------------------------------------------------------------------------------
// Input checks
// ---------------------------------------------------------------------------------------

fn check_len(what: &str, expected: usize, found: usize) -> Result<(), PlotError> {
    if expected == found {
        Ok(())
    } else {
        Err(PlotError::LengthMismatch {
            what: what.to_owned(),
            expected,
            found,
        })
    }
}

fn check_series(s: &Series, n: usize) -> Result<(), PlotError> {
    check_len(&format!("series \"{}\"", s.name), n, s.y.len())?;
    if let Some(e) = &s.y_err {
        check_len(&format!("errors of series \"{}\"", s.name), n, e.len())?;
    }
    Ok(())
}

/// The error bar of point `i`, when there is a usable one.
fn err_at(s: &Series, i: usize) -> Option<f64> {
    s.y_err
        .as_ref()
        .and_then(|e| e.get(i))
        .copied()
        .filter(|e| e.is_finite() && *e > 0.0)
}

#[cfg(test)]
mod tests {
    use super::render::with_suffix;
    use super::*;

    type TestResult = Result<(), Box<dyn std::error::Error>>;

    /// A fresh directory from `tempfile`, removed again on drop (kept when
    /// `ERRMAP_KEEP_PLOTS` is set, to look at the charts).
    fn temp_dir(name: &str) -> std::io::Result<tempfile::TempDir> {
        let keep = std::env::var_os("ERRMAP_KEEP_PLOTS").is_some();
        let dir = tempfile::Builder::new()
            .prefix(&format!("errmap-plot-{name}-"))
            .disable_cleanup(keep)
            .tempdir()?;
        if keep {
            eprintln!("kept {}", dir.path().display());
        }
        Ok(dir)
    }

    /// Both files exist, the PNG is a PNG of the chart size, the SVG holds `title`.
    fn check_outputs(paths: &[PathBuf], stem: &Path, title: &str) -> TestResult {
        check_outputs_sized(paths, stem, title, (WIDTH, HEIGHT))
    }

    fn check_outputs_sized(
        paths: &[PathBuf],
        stem: &Path,
        title: &str,
        size: (u32, u32),
    ) -> TestResult {
        assert_eq!(
            paths,
            [with_suffix(stem, ".png"), with_suffix(stem, ".svg")].as_slice()
        );
        let png = std::fs::read(&paths[0])?;
        assert!(png.len() > 24, "PNG too short: {} bytes", png.len());
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        assert_eq!(&png[12..16], b"IHDR", "first chunk is IHDR");
        let width = u32::from_be_bytes([png[16], png[17], png[18], png[19]]);
        let height = u32::from_be_bytes([png[20], png[21], png[22], png[23]]);
        assert_eq!((width, height), size);
        let svg = std::fs::read_to_string(&paths[1])?;
        let svg_size = format!("<svg width=\"{}\" height=\"{}\"", size.0, size.1);
        assert!(
            svg.starts_with(&svg_size),
            "SVG does not start with {svg_size}"
        );
        assert!(svg.contains(title), "SVG lacks the title {title:?}");
        Ok(())
    }

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| (*s).to_owned()).collect()
    }

    fn points(n: usize) -> Vec<String> {
        (1..=n).map(|i| format!("P{i}")).collect()
    }

    fn series(name: &str, y: Vec<f64>, y_err: Option<Vec<f64>>) -> Series {
        Series {
            name: name.to_owned(),
            y,
            y_err,
        }
    }

    fn xy_series(name: &str, x: Vec<f64>, y: Vec<f64>, style: XyStyle) -> XySeries {
        XySeries {
            name: name.to_owned(),
            x,
            y,
            style,
        }
    }

    #[test]
    fn category_points_renders() -> TestResult {
        let dir = temp_dir("category")?;
        let stem = dir.path().join("measured_vs_predicted");
        let title = "Measured vs predicted, lagrange 4×1×2";
        let s = [
            series(
                "measured",
                vec![1.2, 2.5, 3.1, 2.8, f64::NAN, 4.9, 6.3],
                Some(vec![0.2, 0.3, 0.25, f64::INFINITY, 0.2, 0.4, 0.5]),
            ),
            series(
                "predicted (lagrange 4×1×2)",
                vec![1.0, 2.7, 3.0, 3.0, 3.9, 5.4, 7.0],
                None,
            ),
        ];
        let hl = [false, false, false, false, false, true, true];
        let paths = category_points(
            &stem,
            title,
            "test point",
            "length error / µm",
            &points(7),
            &s,
            &hl,
            "extrapolated",
        )?;
        check_outputs(&paths, &stem, title)?;
        let svg = std::fs::read_to_string(&paths[1])?;
        for text in [
            "test point",
            "length error / µm",
            "P7",
            "extrapolated",
            "4×1×2",
        ] {
            assert!(svg.contains(text), "SVG lacks {text:?}");
        }
        Ok(())
    }

    #[test]
    fn category_points_handles_many_series_and_degenerate_values() -> TestResult {
        let dir = temp_dir("category-many")?;
        // Twelve series, all values equal: palette wraps, the range must not collapse.
        let s: Vec<Series> = (0..12)
            .map(|k| series(&format!("series {k}"), vec![5.0; 3], None))
            .collect();
        let stem = dir.path().join("flat");
        let paths = category_points(&stem, "Flat", "", "", &points(3), &s, &[], "")?;
        check_outputs(&paths, &stem, "Flat")?;
        // One category, one point, all zero.
        let stem = dir.path().join("single");
        let one = [series("zero", vec![0.0], Some(vec![0.0]))];
        let paths = category_points(&stem, "Single", "x", "y", &points(1), &one, &[true], "hl")?;
        check_outputs(&paths, &stem, "Single")?;
        Ok(())
    }

    #[test]
    fn bars_render_linear_log_vertical_and_horizontal() -> TestResult {
        let dir = temp_dir("bars")?;
        let long = names(&[
            "lagrange 1×1×1",
            "lagrange 2×1×1",
            "lagrange 2×2×1",
            "lagrange 3×2×2",
            "lagrange 4×1×2",
            "lagrange 4×4×4",
            "spline 3×3×3",
        ]);
        let values = [4.1, 2.3, 1.2, 0.61, 0.42, f64::NAN, 0.5];
        let test = series(
            "test RMS",
            vec![4.5, 2.1, 1.4, 0.7, 0.5, 1.6, 0.45],
            Some(vec![0.3, 0.2, 0.1, 0.1, 0.05, 0.2, 0.05]),
        );
        let cases: [(&str, &[String], Option<&Series>, bool); 4] = [
            ("log_markers", &long, Some(&test), true),
            ("linear_markers", &long, Some(&test), false),
            ("short_log", &[], None, true),
            ("short_linear", &[], None, false),
        ];
        let short = names(&["1", "2", "3", "4", "5", "6", "7"]);
        for (name, labels, markers, log) in cases {
            let labels = if labels.is_empty() { &short } else { labels };
            let stem = dir.path().join(name);
            let title = format!("Cross-validated RMS ({name})");
            let paths = bars(&stem, &title, "RMS / µm", labels, &values, markers, log)?;
            check_outputs(&paths, &stem, &title)?;
        }
        // Bars that are all 0 stand on an axis from 0, not on −1…1.
        let zero = ValueScale::of(&[0.0, 0.0], None, false)?;
        let (lo, hi) = zero.linear.ok_or("a linear axis")?;
        assert!(lo == 0.0 && hi > 0.0, "{lo} … {hi}");
        // log_y with a negative value falls back to a linear axis; a single bar works too.
        let stem = dir.path().join("signed");
        let paths = bars(
            &stem,
            "Signed",
            "error",
            &names(&["a", "b"]),
            &[1.5, -2.0],
            None,
            true,
        )?;
        check_outputs(&paths, &stem, "Signed")?;
        let stem = dir.path().join("one");
        let paths = bars(&stem, "One", "", &names(&["only"]), &[3.0], None, true)?;
        check_outputs(&paths, &stem, "One")?;
        Ok(())
    }

    #[test]
    fn many_horizontal_bars_make_a_taller_image() -> TestResult {
        let dir = temp_dir("bars-tall")?;
        let n = 40;
        let labels: Vec<String> = (0..n)
            .map(|k| {
                format!(
                    "lagrange {}×{}×{} (model {k})",
                    k % 5 + 1,
                    k % 3 + 1,
                    k % 2 + 1
                )
            })
            .collect();
        let values: Vec<f64> = (0..n).map(|k| 0.3 + f64::from(k) * 0.05).collect();
        let stem = dir.path().join("tall");
        let paths = bars(&stem, "Tall", "RMS (µm)", &labels, &values, None, true)?;
        let x_area = x_label_area(true);
        let extra = f64::from(n) * MIN_ROW_PX - plot_height(HEIGHT, x_area);
        let height = (f64::from(HEIGHT) + extra).ceil() as u32;
        assert!(height > HEIGHT);
        check_outputs_sized(&paths, &stem, "Tall", (WIDTH, height))?;
        let svg = std::fs::read_to_string(&paths[1])?;
        for label in &labels {
            assert!(svg.contains(label.as_str()), "label {label:?} was dropped");
        }
        Ok(())
    }

    #[test]
    fn xy_renders_points_lines_and_single_point() -> TestResult {
        let dir = temp_dir("xy")?;
        let x: Vec<f64> = (0..50).map(|i| f64::from(i) * 0.2).collect();
        let s: Vec<XySeries> = (0..9)
            .map(|k| {
                let y = x
                    .iter()
                    .map(|v| {
                        if k == 1 && (*v - 5.0).abs() < 0.5 {
                            f64::NAN
                        } else {
                            (v + f64::from(k)).sin() * 1e-6
                        }
                    })
                    .collect();
                let style = if k % 2 == 0 {
                    XyStyle::Line
                } else {
                    XyStyle::Points
                };
                xy_series(&format!("axis {k}, lagrange {k}×1×2"), x.clone(), y, style)
            })
            .collect();
        let stem = dir.path().join("residuals");
        let paths = xy(&stem, "Residuals", "x / mm", "residual / m", &s)?;
        check_outputs(&paths, &stem, "Residuals")?;

        let stem = dir.path().join("single");
        let one = [
            xy_series("point", vec![3.0], vec![3.0], XyStyle::Points),
            xy_series("empty", vec![], vec![], XyStyle::Line),
        ];
        let paths = xy(&stem, "Single point", "x", "y", &one)?;
        check_outputs(&paths, &stem, "Single point")?;
        Ok(())
    }

    /// The rows and columns of the pixels in `colour` left of column `max_col`: (top,
    /// bottom, left, right).
    fn colour_extent(png: &Path, colour: [u8; 3], max_col: usize) -> Option<[usize; 4]> {
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).ok()?));
        let mut reader = decoder.read_info().ok()?;
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).ok()?;
        let channels = info.color_type.samples();
        let mut ext: Option<[usize; 4]> = None;
        for row in 0..info.height as usize {
            for col in 0..(info.width as usize).min(max_col) {
                let i = (row * info.width as usize + col) * channels;
                if buf[i..i + 3] == colour {
                    let e = ext.get_or_insert([row, row, col, col]);
                    e[0] = e[0].min(row);
                    e[1] = e[1].max(row);
                    e[2] = e[2].min(col);
                    e[3] = e[3].max(col);
                }
            }
        }
        ext
    }

    /// Issue 35: the periodogram's spikes were drawn far outside the plot frame (the
    /// bitmap backend's miter joins). A spiky trace reaches no higher or lower than a
    /// plain line through its extreme values on the same axes.
    #[test]
    fn a_spiky_trace_stays_inside_its_frame() -> TestResult {
        let dir = temp_dir("spiky")?;
        // A periodogram's shape: periods 60/k of a uniform frequency grid, crowded at the
        // short end, with powers jumping between 0 and 14 from one to the next.
        let x: Vec<f64> = (1..=2000).map(|k| 60.0 / f64::from(k)).collect();
        let y: Vec<f64> = (1..=2000u32)
            .map(|k| f64::from((k * 7919) % 1000) / 1000.0 * 14.0)
            .collect();
        let spiky = xy(
            &dir.path().join("spiky"),
            "spikes",
            "period / mm",
            "power",
            &[xy_series("trace", x.clone(), y, XyStyle::Line)],
        )?;
        let plain = xy(
            &dir.path().join("plain"),
            "spikes",
            "period / mm",
            "power",
            &[xy_series(
                "trace",
                vec![x[1999], 30.0, x[0]],
                vec![0.0, 14.0, 0.0],
                XyStyle::Line,
            )],
        )?;
        let c = PALETTE[0];
        let colour = [c.0, c.1, c.2];
        // Left of the legend, which stands right of the plot area.
        let max_col = WIDTH as usize * 3 / 4;
        let frame = colour_extent(&plain[0], colour, max_col).ok_or("no plain trace")?;
        let trace = colour_extent(&spiky[0], colour, max_col).ok_or("no spiky trace")?;
        assert!(
            trace[0] + 2 >= frame[0] && trace[1] <= frame[1] + 2,
            "the spiky trace spans rows {}..{}, the values {}..{}",
            trace[0],
            trace[1],
            frame[0],
            frame[1]
        );
        Ok(())
    }

    /// A two-point falling line, the series of the file-handling tests.
    fn falling_line() -> XySeries {
        xy_series("s", vec![1.0, 2.0], vec![2.0, 1.0], XyStyle::Line)
    }

    #[test]
    fn stem_with_dots_and_missing_directories() -> TestResult {
        let dir = temp_dir("stem")?;
        let stem = dir.path().join("a").join("b").join("fig.v2");
        let s = [falling_line()];
        let paths = xy(&stem, "Dots", "x", "y", &s)?;
        assert!(paths[0].ends_with("fig.v2.png") && paths[1].ends_with("fig.v2.svg"));
        check_outputs(&paths, &stem, "Dots")?;
        assert!(matches!(
            xy(Path::new(""), "t", "x", "y", &s),
            Err(PlotError::Invalid(_))
        ));
        Ok(())
    }

    /// Issue 17: figures are written whole. A figure that cannot be put in place (its
    /// name taken by a directory) is an error naming it and leaves no temporary file; an
    /// existing figure is replaced, again with nothing left beside it.
    #[test]
    fn a_figure_appears_whole_or_not_at_all() -> TestResult {
        let dir = temp_dir("whole")?;
        let stem = dir.path().join("fig");
        let s = [falling_line()];
        let first = xy(&stem, "First", "x", "y", &s)?;
        let again = xy(&stem, "Again", "x", "y", &s)?;
        assert_eq!(first, again);
        check_outputs(&again, &stem, "Again")?;
        let blocked = dir.path().join("blocked");
        std::fs::create_dir_all(with_suffix(&blocked, ".png"))?;
        let r = xy(&blocked, "Blocked", "x", "y", &s);
        assert!(
            matches!(&r, Err(PlotError::Draw { path, .. }) if path.ends_with("blocked.png")),
            "{r:?}"
        );
        let mut names: Vec<String> = std::fs::read_dir(dir.path())?
            .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
            .collect::<Result<_, _>>()?;
        names.sort();
        assert_eq!(names, ["blocked.png", "fig.png", "fig.svg"]);
        Ok(())
    }

    #[test]
    fn invalid_input_is_an_error_and_writes_nothing() -> TestResult {
        let dir = temp_dir("errors")?;
        let stem = dir.path().join("never");
        let ok = [series("s", vec![1.0, 2.0], None)];
        let cats = points(2);

        let r = category_points(&stem, "t", "x", "y", &[], &ok, &[], "");
        assert!(matches!(r, Err(PlotError::Empty("categories"))), "{r:?}");
        let r = category_points(&stem, "t", "x", "y", &cats, &[], &[], "");
        assert!(matches!(r, Err(PlotError::Empty("series"))), "{r:?}");
        let short = [series("short", vec![1.0], None)];
        let r = category_points(&stem, "t", "x", "y", &cats, &short, &[], "");
        assert!(
            matches!(
                r,
                Err(PlotError::LengthMismatch {
                    expected: 2,
                    found: 1,
                    ..
                })
            ),
            "{r:?}"
        );
        let bad_err = [series("e", vec![1.0, 2.0], Some(vec![0.1]))];
        let r = category_points(&stem, "t", "x", "y", &cats, &bad_err, &[], "");
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let r = category_points(&stem, "t", "x", "y", &cats, &ok, &[true], "");
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let nan = [series("nan", vec![f64::NAN, f64::INFINITY], None)];
        let r = category_points(&stem, "t", "x", "y", &cats, &nan, &[], "");
        assert!(matches!(r, Err(PlotError::NoFiniteValues)), "{r:?}");

        let r = bars(&stem, "t", "y", &[], &[], None, false);
        assert!(matches!(r, Err(PlotError::Empty("labels"))), "{r:?}");
        let r = bars(&stem, "t", "y", &cats, &[1.0], None, false);
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let r = bars(&stem, "t", "y", &cats, &[1.0, 2.0], Some(&short[0]), false);
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let r = bars(&stem, "t", "y", &cats, &[f64::NAN, f64::NAN], None, true);
        assert!(matches!(r, Err(PlotError::NoFiniteValues)), "{r:?}");

        let r = xy(&stem, "t", "x", "y", &[]);
        assert!(matches!(r, Err(PlotError::Empty("series"))), "{r:?}");
        let uneven = [xy_series("u", vec![1.0, 2.0], vec![1.0], XyStyle::Points)];
        let r = xy(&stem, "t", "x", "y", &uneven);
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let none = [xy_series(
            "n",
            vec![f64::NAN, 1.0],
            vec![1.0, f64::NAN],
            XyStyle::Line,
        )];
        let r = xy(&stem, "t", "x", "y", &none);
        assert!(matches!(r, Err(PlotError::NoFiniteValues)), "{r:?}");
        let huge = [xy_series(
            "h",
            vec![-f64::MAX, f64::MAX],
            vec![0.0, 1.0],
            XyStyle::Line,
        )];
        let r = xy(&stem, "t", "x", "y", &huge);
        assert!(matches!(r, Err(PlotError::Invalid(_))), "{r:?}");

        assert!(!with_suffix(&stem, ".png").exists());
        assert!(!with_suffix(&stem, ".svg").exists());
        Ok(())
    }

    #[test]
    fn dashes_follow_the_pattern_across_vertices() {
        let id = |p: (f64, f64)| p;
        // 30 px straight: dashes 0–9 and 15–24, the gap 24–30 left empty.
        let d = dashes(&[(0.0, 0.0), (30.0, 0.0)], id, 9.0, 6.0);
        assert_eq!(
            d,
            vec![vec![(0.0, 0.0), (9.0, 0.0)], vec![(15.0, 0.0), (24.0, 0.0)]]
        );
        // A dash bends round a corner 5 px along and ends 4 px up the second leg.
        let d = dashes(&[(0.0, 0.0), (5.0, 0.0), (5.0, 10.0)], id, 9.0, 6.0);
        assert_eq!(d, vec![vec![(0.0, 0.0), (5.0, 0.0), (5.0, 4.0)]]);
        // Lengths are measured in pixels: a unit step in x that maps to 30 px.
        let d = dashes(&[(0.0, 0.0), (1.0, 0.0)], |(x, y)| (30.0 * x, y), 9.0, 6.0);
        assert_eq!(d.len(), 2);
        assert!((d[1][0].0 - 0.5).abs() < 1e-12 && (d[1][1].0 - 0.8).abs() < 1e-12);
    }
}
