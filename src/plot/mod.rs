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

use std::fmt::Display;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use plotters::backend::RGBPixel;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Width of every chart, in pixels.
const WIDTH: u32 = 1000;
/// Height of every chart, in pixels (horizontal bar charts with many labels grow taller).
const HEIGHT: u32 = 600;
/// Horizontal bar charts get at least this many pixels per label...
const MIN_ROW_PX: f64 = 20.0;
/// ...up to this image height; beyond it, labels are thinned out.
const MAX_HEIGHT: u32 = 4000;

const TITLE_SIZE: f64 = 26.0;
const DESC_SIZE: f64 = 19.0;
const TICK_SIZE: f64 = 15.0;
const LEGEND_SIZE: f64 = 15.0;
/// Height of the strip at the top that holds the title.
const TITLE_HEIGHT: u32 = 48;
/// Margin above the plot area (below the title strip); the legend starts at the same height.
const MARGIN_TOP: u32 = 8;
const MARGIN_BOTTOM: u32 = 10;
const MARGIN_LEFT: u32 = 12;
/// Right margin without a legend: room for the last x tick label to overhang the plot.
const MARGIN_RIGHT: u32 = 30;
const LEGEND_ROW: f64 = 24.0;
const MARKER_R: f64 = 5.0;
/// Scatter markers of one series closer than this (px) to one already drawn are dropped.
const THIN_PX: f64 = 2.5;
/// Width of data lines.
const LINE_W: f64 = 2.0;

const TEXT: RGBColor = RGBColor(0x22, 0x22, 0x22);
const BAND: RGBColor = RGBColor(0x80, 0x80, 0x80);
const BAND_ALPHA: f64 = 0.18;
/// Outline of the hollow marker in the legend's highlight entry.
const HOLLOW_SAMPLE: RGBColor = RGBColor(0x55, 0x55, 0x55);

/// Tableau 10: ten colours that stay distinct from one another on white.
const PALETTE: [RGBColor; 10] = [
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
}

/// Why a chart could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A required input slice was empty (names the argument).
    #[error("nothing to plot: {0} is empty")]
    Empty(&'static str),
    /// A slice does not have the length the other arguments imply.
    #[error("length mismatch: {what} has {found} values, expected {expected}")]
    LengthMismatch {
        /// Which argument or series.
        what: String,
        /// Length implied by the other arguments.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// Every value was NaN or infinite.
    #[error("nothing to plot: no finite values")]
    NoFiniteValues,
    /// Any other unusable input (e.g. an output stem without a file name).
    #[error("invalid plot input: {0}")]
    Invalid(String),
    /// The output directory could not be created.
    #[error("cannot create directory {path}: {source}")]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The bundled fonts could not be registered with plotters.
    #[error("the bundled DejaVu fonts could not be registered with plotters")]
    Fonts,
    /// Drawing or writing an output file failed.
    #[error("drawing {path} failed: {message}")]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// plotters' error, as text.
        message: String,
    },
}

static FONT_INIT: Once = Once::new();
static FONTS_OK: AtomicBool = AtomicBool::new(false);

/// Register the bundled fonts (idempotent, `std::sync::Once`). Called by every chart function.
///
/// Registers DejaVu Sans regular, bold and oblique (also used for italic) under the family
/// name `sans-serif`, which is plotters' default family.
pub fn register_fonts() {
    FONT_INIT.call_once(|| {
        let family = FontFamily::SansSerif.as_str();
        let faces: [(FontStyle, &'static [u8]); 4] = [
            (FontStyle::Normal, dejavu::sans::regular()),
            (FontStyle::Bold, dejavu::sans::bold()),
            (FontStyle::Oblique, dejavu::sans::oblique()),
            (FontStyle::Italic, dejavu::sans::oblique()),
        ];
        let ok = faces
            .into_iter()
            .all(|(style, bytes)| plotters::style::register_font(family, style, bytes).is_ok());
        FONTS_OK.store(ok, Ordering::Release);
    });
}

/// Category chart like a paper's "measured vs predicted per test point".
///
/// The x axis holds the `categories` (e.g. `"P1"`…`"P7"`); each series is drawn as a line
/// with markers, one value per category, with optional one-sigma error bars (then the
/// series are spread slightly sideways so that the bars do not hide one another). A legend
/// names the series.
///
/// `highlight` marks categories (e.g. extrapolated test points): they get a shaded band
/// and hollow markers, and the legend gets an entry `highlight_label`. Pass an empty slice
/// for no highlighting; otherwise it needs one flag per category.
///
/// Errors: empty `categories` or `series`, a series (or its errors, or `highlight`) whose
/// length differs from `categories`, or no finite value at all.
#[allow(clippy::too_many_arguments)]
pub fn category_lines(
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
    let (lo, hi) = extent.get().ok_or(PlotError::NoFiniteValues)?;
    let (lo, hi) = padded_range(lo, hi, true, true)?;
    let x_area = x_label_area(!x_label.is_empty());
    let y_axis = Axis::linear(lo, hi, plot_height(HEIGHT, x_area), false);

    let hl = |i: usize| highlight.get(i).copied().unwrap_or(false);
    let any_highlight = (0..n).any(hl);

    let mut legend: Vec<LegendEntry> = series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (color, marker) = series_look(k);
            LegendEntry {
                label: s.name.clone(),
                sample: Sample::Line {
                    color,
                    marker: Some(marker),
                },
            }
        })
        .collect();
    if any_highlight {
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
    let legend_width = legend_width(&legend);
    let y_area = y_label_area(&y_axis, !y_label.is_empty());
    let plot_w = plot_width(legend_width, y_area);
    let positions: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let x_axis = Axis::category(categories, &positions, -0.5, n as f64 - 0.5, plot_w, None);

    let mut prims = Vec::new();
    // Shaded bands, one per run of consecutive highlighted categories.
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
    let m = series.len();
    let dodge = if m > 1 && series.iter().any(|s| s.y_err.is_some()) {
        (0.3 / (m - 1) as f64).min(0.08)
    } else {
        0.0
    };
    for (k, s) in series.iter().enumerate() {
        let (color, _) = series_look(k);
        let dx = (k as f64 - (m - 1) as f64 / 2.0) * dodge;
        let pts: Vec<Option<(f64, f64)>> =
            s.y.iter()
                .enumerate()
                .map(|(i, &y)| y.is_finite().then_some((i as f64 + dx, y)))
                .collect();
        push_lines(&mut prims, &pts, color, false);
    }
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

    let frame = Frame::standard(
        [title, x_label, y_label],
        (x_axis, x_area),
        (y_axis, y_area),
        legend,
        legend_width,
    );
    write_both(stem, &frame, &prims)
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

    // Value extent (in data units), including marker error bars where they can be shown.
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
    let linear_range = if log {
        None
    } else {
        Some(padded_range(
            vmin.min(0.0),
            vmax.max(0.0),
            vmin < 0.0,
            vmax > 0.0,
        )?)
    };
    let value_axis_for = |length: f64, along_x: bool| -> Result<Axis, PlotError> {
        match linear_range {
            Some((lo, hi)) => Ok(Axis::linear(lo, hi, length, along_x)),
            None => Axis::log(vmin, vmax),
        }
    };

    let bar_color = PALETTE[0];
    let mark_color = PALETTE[1];
    let mark_shape = Marker::Diamond;
    let legend: Vec<LegendEntry> = match markers {
        Some(s) => vec![
            LegendEntry {
                label: if y_label.is_empty() {
                    "value".to_owned()
                } else {
                    y_label.to_owned()
                },
                sample: Sample::Bar { color: bar_color },
            },
            LegendEntry {
                label: s.name.clone(),
                sample: Sample::Marker {
                    color: mark_color,
                    marker: mark_shape,
                },
            },
        ],
        None => Vec::new(),
    };
    let legend_width = legend_width(&legend);

    // Vertical bars if every label fits under its bar, horizontal bars otherwise.
    let vertical_value_axis = value_axis_for(plot_height(HEIGHT, x_label_area(false)), false)?;
    let vertical_y_area = y_label_area(&vertical_value_axis, !y_label.is_empty());
    let vertical_plot_w = plot_width(legend_width, vertical_y_area);
    let max_label_w = labels
        .iter()
        .map(|l| text_width(l, TICK_SIZE, FontStyle::Normal))
        .max()
        .unwrap_or(0);
    let vertical = f64::from(max_label_w + 12) <= vertical_plot_w / n as f64;

    // Category coordinate of each label: left to right, or top to bottom.
    let positions: Vec<f64> = (0..n)
        .map(|i| if vertical { i } else { n - 1 - i } as f64)
        .collect();
    let (cat_lo, cat_hi) = (-0.5, n as f64 - 0.5);
    // (x, y) of a point at category coordinate `c` and value-axis coordinate `v`.
    let pt = |c: f64, v: f64| if vertical { (c, v) } else { (v, c) };
    let frame = if vertical {
        Frame {
            title: title.to_owned(),
            x_desc: String::new(),
            y_desc: y_label.to_owned(),
            height: HEIGHT,
            x_area: x_label_area(false),
            y_area: vertical_y_area,
            x: Axis::category(labels, &positions, cat_lo, cat_hi, vertical_plot_w, None),
            y: vertical_value_axis,
            x_grid: false,
            y_grid: true,
            legend,
            legend_width,
        }
    } else {
        // Taller than usual when there are many labels, so that every one stays readable.
        let x_area = x_label_area(!y_label.is_empty());
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
            labels,
            &positions,
            cat_lo,
            cat_hi,
            plot_height(height, x_area),
            Some(f64::from(WIDTH) * 0.4),
        );
        let y_area = y_label_area(&cat_axis, false);
        Frame {
            title: title.to_owned(),
            x_desc: y_label.to_owned(),
            y_desc: String::new(),
            height,
            x_area,
            y_area,
            x: value_axis_for(plot_width(legend_width, y_area), true)?,
            y: cat_axis,
            x_grid: true,
            y_grid: false,
            legend,
            legend_width,
        }
    };
    let value_axis = if vertical { &frame.y } else { &frame.x };
    // Coordinate of a value on the value axis (log10 on a log axis).
    let vc = |v: f64| value_axis.coord(v);
    let base = if log { value_axis.lo } else { 0.0 };

    // Bar and marker offsets across the category, in category units; with few bars
    // they are kept to a slot of about 150 pixels.
    let slot_px = if vertical {
        vertical_plot_w
    } else {
        plot_height(frame.height, frame.x_area)
    } / n as f64;
    let shrink = (150.0 / slot_px).min(1.0);
    let (bar_c, bar_half, mark_off) = if markers.is_some() {
        (-0.12 * shrink, 0.25 * shrink, 0.25 * shrink)
    } else {
        (0.0, 0.32 * shrink, 0.0)
    };

    let mut prims = Vec::new();
    if linear_range.is_some_and(|(lo, _)| lo < 0.0) {
        // Signed values: a zero line to grow the bars from.
        prims.push(Prim::Zero {
            a: pt(cat_lo, 0.0),
            b: pt(cat_hi, 0.0),
        });
    }
    for (&v, &p) in values.iter().zip(&positions) {
        if !v.is_finite() {
            continue;
        }
        let c = p + bar_c;
        prims.push(Prim::Rect {
            a: pt(c - bar_half, base),
            b: pt(c + bar_half, vc(v)),
            color: bar_color,
        });
    }
    if let Some(s) = markers {
        for (i, (&y, &p)) in s.y.iter().zip(&positions).enumerate() {
            if !y.is_finite() {
                continue;
            }
            let c = p + mark_off;
            if let Some(e) = err_at(s, i) {
                let low = if log && y - e <= 0.0 {
                    value_axis.lo
                } else {
                    vc(y - e)
                };
                prims.push(Prim::ErrBar {
                    from: pt(c, low),
                    to: pt(c, vc(y + e)),
                    color: mark_color,
                });
            }
            prims.push(Prim::Marker {
                at: pt(c, vc(y)),
                marker: mark_shape,
                color: mark_color,
                filled: true,
            });
        }
    }

    write_both(stem, &frame, &prims)
}

/// Generic x–y chart: several series, each with its own x values, drawn as points or lines.
///
/// A legend names the series. Errors: empty `series`, a series whose `x` and `y` lengths
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

    let finite = |s: &XySeries| -> Vec<Option<(f64, f64)>> {
        s.x.iter()
            .zip(&s.y)
            .map(|(&x, &y)| (x.is_finite() && y.is_finite()).then_some((x, y)))
            .collect()
    };
    let mut ex = Extent::default();
    let mut ey = Extent::default();
    for s in series {
        for (x, y) in finite(s).into_iter().flatten() {
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
    let x_area = x_label_area(!x_label.is_empty());
    let y_axis = Axis::linear(ylo, yhi, plot_height(HEIGHT, x_area), false);

    let legend: Vec<LegendEntry> = series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (color, marker) = series_look(k);
            let sample = match s.style {
                XyStyle::Points => Sample::Marker { color, marker },
                XyStyle::Line => Sample::Line {
                    color,
                    marker: None,
                },
            };
            LegendEntry {
                label: s.name.clone(),
                sample,
            }
        })
        .collect();
    let legend_width = legend_width(&legend);
    let y_area = y_label_area(&y_axis, !y_label.is_empty());
    let plot_w = plot_width(legend_width, y_area);
    let x_axis = Axis::linear(xlo, xhi, plot_w, true);

    let mut prims = Vec::new();
    for (k, s) in series.iter().enumerate() {
        let (color, marker) = series_look(k);
        let pts = finite(s);
        match s.style {
            XyStyle::Line => push_lines(&mut prims, &pts, color, true),
            XyStyle::Points => {
                // A marker whose grid cell of 2.5 px (half its radius) already holds one of
                // the same series adds almost nothing visible: drop it, so a 100 000-point
                // scatter stays a small SVG and looks the same.
                let plot_h = plot_height(HEIGHT, x_area);
                let mut seen = std::collections::HashSet::new();
                for at in pts.into_iter().flatten() {
                    let cell = (
                        ((at.0 - xlo) / (xhi - xlo) * plot_w / THIN_PX).floor() as i64,
                        ((at.1 - ylo) / (yhi - ylo) * plot_h / THIN_PX).floor() as i64,
                    );
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
        }
    }

    let frame = Frame::standard(
        [title, x_label, y_label],
        (x_axis, x_area),
        (y_axis, y_area),
        legend,
        legend_width,
    );
    write_both(stem, &frame, &prims)
}

// ---------------------------------------------------------------------------------------
// Input checks and small helpers
// ---------------------------------------------------------------------------------------

fn fonts_ready() -> Result<(), PlotError> {
    register_fonts();
    if FONTS_OK.load(Ordering::Acquire) {
        Ok(())
    } else {
        Err(PlotError::Fonts)
    }
}

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

/// Colour and marker shape of series `k`.
fn series_look(k: usize) -> (RGBColor, Marker) {
    (
        PALETTE[k % PALETTE.len()],
        MARKERS[(k + k / PALETTE.len()) % MARKERS.len()],
    )
}

/// Turns points with gaps into line segments; isolated points become dots when `dots`.
fn push_lines(prims: &mut Vec<Prim>, pts: &[Option<(f64, f64)>], color: RGBColor, dots: bool) {
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

fn de<E: Display>(e: E) -> String {
    e.to_string()
}

/// Minimum and maximum of the finite values added.
#[derive(Debug, Default, Clone, Copy)]
struct Extent {
    range: Option<(f64, f64)>,
}

impl Extent {
    fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.range = Some(match self.range {
                None => (v, v),
                Some((lo, hi)) => (lo.min(v), hi.max(v)),
            });
        }
    }

    fn get(&self) -> Option<(f64, f64)> {
        self.range
    }
}

/// Pads `[min, max]` by 6 % of the span on the chosen sides; a zero or tiny span is widened
/// around the value so that the range is never degenerate.
fn padded_range(min: f64, max: f64, pad_lo: bool, pad_hi: bool) -> Result<(f64, f64), PlotError> {
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

fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            other => other,
        })
        .collect()
}

/// Replaces a leading hyphen with a typographic minus sign.
fn minus_sign(s: String) -> String {
    match s.strip_prefix('-') {
        Some(rest) => format!("−{rest}"),
        None => s,
    }
}

fn floor_log10(v: f64) -> i32 {
    (v.abs().log10() + 1e-9).floor() as i32
}

/// Tick label for `v` on a linear axis with major step `step` and largest magnitude `mag`:
/// plain decimals normally, a shared power of ten (`1.5×10⁻⁶`) for very large or small values.
fn format_linear(v: f64, step: f64, mag: f64) -> String {
    if v.abs() < step * 1e-6 {
        return "0".to_owned();
    }
    let step_exp = floor_log10(step);
    let mag_exp = floor_log10(mag);
    if mag_exp >= 6 || step_exp <= -5 {
        let digits = (mag_exp - step_exp).clamp(0, 12) as usize;
        let m = v / 10f64.powi(mag_exp);
        minus_sign(format!("{m:.digits$}×10{}", superscript(mag_exp)))
    } else {
        let decimals = (-step_exp).max(0) as usize;
        minus_sign(format!("{v:.decimals$}"))
    }
}

/// Tick label for a "nice" positive value `v` = m×10^e (m = 1, 2 or 5) on a log axis.
fn format_log(v: f64, sci: bool) -> String {
    let e = floor_log10(v);
    let m = (v / 10f64.powi(e)).round();
    if !sci {
        let decimals = (-e).max(0) as usize;
        format!("{v:.decimals$}")
    } else if m == 1.0 {
        format!("10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

/// Fits `text` into `max_w` pixels, shortening it with "…" when needed.
fn fit_text(text: &str, size: f64, style: FontStyle, max_w: u32) -> String {
    if text_width(text, size, style) <= max_w {
        return text.to_owned();
    }
    let chars: Vec<char> = text.chars().collect();
    for keep in (0..chars.len()).rev() {
        let candidate: String = chars.iter().take(keep).chain(['…'].iter()).collect();
        if text_width(&candidate, size, style) <= max_w {
            return candidate;
        }
    }
    "…".to_owned()
}

fn font(size: f64, style: FontStyle) -> FontDesc<'static> {
    FontDesc::new(FontFamily::SansSerif, size, style)
}

/// Width of `text` in pixels (an estimate if the font cannot be measured).
fn text_width(text: &str, size: f64, style: FontStyle) -> u32 {
    match font(size, style).box_size(text) {
        Ok((w, _)) => w,
        Err(_) => (text.chars().count() as f64 * size * 0.6) as u32,
    }
}

// ---------------------------------------------------------------------------------------
// Axes
// ---------------------------------------------------------------------------------------

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
struct Axis {
    lo: f64,
    hi: f64,
    scale: Scale,
    major: Vec<f64>,
    minor: Vec<f64>,
    labels: Labels,
}

impl Axis {
    /// Linear axis over `[lo, hi]`, `length` pixels long; along x, the tick count is
    /// reduced until the labels fit side by side.
    fn linear(lo: f64, hi: f64, length: f64, along_x: bool) -> Axis {
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
    fn log(min: f64, max: f64) -> Result<Axis, PlotError> {
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
    fn category(
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
    fn coord(&self, v: f64) -> f64 {
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
fn y_label_area(axis: &Axis, with_desc: bool) -> u32 {
    let desc = if with_desc { DESC_SIZE as u32 + 6 } else { 0 };
    axis.widest_label() + 16 + desc
}

/// Pixels to reserve below the plot for the x tick labels and description.
fn x_label_area(with_desc: bool) -> u32 {
    let desc = if with_desc { DESC_SIZE as u32 + 12 } else { 0 };
    TICK_SIZE as u32 + 18 + desc
}

/// Approximate height of the plot area, for choosing ticks.
fn plot_height(height: u32, x_area: u32) -> f64 {
    f64::from(height.saturating_sub(TITLE_HEIGHT + MARGIN_TOP + MARGIN_BOTTOM + x_area)).max(100.0)
}

/// Approximate width of the plot area, for choosing ticks and thinning out category labels.
fn plot_width(legend_width: u32, y_area: u32) -> f64 {
    let right = if legend_width == 0 { MARGIN_RIGHT } else { 12 };
    f64::from(WIDTH.saturating_sub(legend_width + y_area + MARGIN_LEFT + right)).max(100.0)
}

// ---------------------------------------------------------------------------------------
// Legend
// ---------------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
}

#[derive(Debug, Clone)]
enum Sample {
    /// A line, optionally with a marker in the middle.
    Line {
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
struct LegendEntry {
    label: String,
    sample: Sample,
}

const LEGEND_SAMPLE_W: f64 = 34.0;
const LEGEND_PAD: f64 = 10.0;
/// Space between the legend box and the right edge of the image.
const LEGEND_RIGHT: f64 = 12.0;

fn legend_width(entries: &[LegendEntry]) -> u32 {
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

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    t: Target,
) -> Result<(), String> {
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

// ---------------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------------

/// Everything about a chart except the data drawn inside the plot area. Sizes are in
/// output pixels (scale 1).
#[derive(Debug, Clone)]
struct Frame {
    title: String,
    x_desc: String,
    y_desc: String,
    /// Image height (the width is always `WIDTH`).
    height: u32,
    x_area: u32,
    y_area: u32,
    x: Axis,
    y: Axis,
    x_grid: bool,
    y_grid: bool,
    legend: Vec<LegendEntry>,
    legend_width: u32,
}

impl Frame {
    /// A frame of the standard height with grid lines both ways: `labels` are the title
    /// and the x and y descriptions; each axis comes with its label area.
    fn standard(
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
enum Prim {
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

/// How one output is rendered: pixel scale (the PNG is drawn at `SUPERSAMPLE` times its
/// size, then averaged down) and whether text goes through plotters' rasteriser.
#[derive(Debug, Clone, Copy)]
struct Target {
    s: f64,
    bitmap: bool,
}

impl Target {
    fn px(self, v: f64) -> i32 {
        (v * self.s).round() as i32
    }

    fn upx(self, v: f64) -> u32 {
        (v * self.s).round().max(0.0) as u32
    }

    /// plotters' `ab_glyph` rasteriser puts centre-anchored text about a fifth of the font
    /// size too high; the SVG viewer places it right. Returns the correction.
    fn text_dy(self, size: f64) -> i32 {
        if self.bitmap { self.px(0.2 * size) } else { 0 }
    }

    fn font(self, size: f64, style: FontStyle) -> FontDesc<'static> {
        font(size * self.s, style)
    }

    fn text_style(self, size: f64, style: FontStyle, h: HPos, v: VPos) -> TextStyle<'static> {
        TextStyle::from(self.font(size, style))
            .color(&TEXT)
            .pos(Pos::new(h, v))
    }
}

/// The PNG is rendered at this multiple of its size and averaged down: plotters draws
/// lines without anti-aliasing and places glyphs only to the whole pixel, and both look
/// much better after averaging.
const SUPERSAMPLE: u32 = 2;

fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

fn write_both(stem: &Path, frame: &Frame, prims: &[Prim]) -> Result<Vec<PathBuf>, PlotError> {
    if stem.file_name().is_none() {
        return Err(PlotError::Invalid(format!(
            "output stem {} has no file name",
            stem.display()
        )));
    }
    let png = with_suffix(stem, ".png");
    let svg = with_suffix(stem, ".svg");
    if let Some(dir) = png.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlotError::CreateDir {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    write_png(&png, frame, prims).map_err(|message| PlotError::Draw {
        path: png.clone(),
        message,
    })?;
    write_svg(&svg, frame, prims).map_err(|message| PlotError::Draw {
        path: svg.clone(),
        message,
    })?;
    Ok(vec![png, svg])
}

fn write_png(path: &Path, frame: &Frame, prims: &[Prim]) -> Result<(), String> {
    let ss = SUPERSAMPLE;
    let (bw, bh) = (WIDTH * ss, frame.height * ss);
    let mut big = vec![0u8; bw as usize * bh as usize * 3];
    {
        let backend =
            BitMapBackend::<RGBPixel>::with_buffer_and_format(&mut big, (bw, bh)).map_err(de)?;
        let root = backend.into_drawing_area();
        let t = Target {
            s: f64::from(ss),
            bitmap: true,
        };
        render(&root, frame, prims, t)?;
        root.present().map_err(de)?;
    }
    let small = downsample(&big, bw as usize, bh as usize, ss as usize);
    let mut out = BitMapBackend::new(path, (WIDTH, frame.height));
    out.blit_bitmap((0, 0), (WIDTH, frame.height), &small)
        .map_err(de)?;
    out.present().map_err(de)
}

fn write_svg(path: &Path, frame: &Frame, prims: &[Prim]) -> Result<(), String> {
    let root = SVGBackend::new(path, (WIDTH, frame.height)).into_drawing_area();
    let t = Target {
        s: 1.0,
        bitmap: false,
    };
    render(&root, frame, prims, t)?;
    root.present().map_err(de)
}

/// Averages `f`×`f` blocks of an RGB image `w`×`h` pixels.
fn downsample(src: &[u8], w: usize, h: usize, f: usize) -> Vec<u8> {
    let f = f.max(1);
    let (ow, oh) = (w / f, h / f);
    let mut out = vec![0u8; ow * oh * 3];
    let n = (f * f) as u32;
    for oy in 0..oh {
        for ox in 0..ow {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..f {
                    for dx in 0..f {
                        let i = ((oy * f + dy) * w + ox * f + dx) * 3 + c;
                        sum += u32::from(src.get(i).copied().unwrap_or(255));
                    }
                }
                if let Some(o) = out.get_mut((oy * ow + ox) * 3 + c) {
                    *o = ((sum + n / 2) / n) as u8;
                }
            }
        }
    }
    out
}

fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    frame: &Frame,
    prims: &[Prim],
    t: Target,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(de)?;
    let (w, _) = root.dim_in_pixel();
    let title_h = t.upx(f64::from(TITLE_HEIGHT));
    let (title_area, body) = root.split_vertically(title_h);
    if !frame.title.is_empty() {
        let title = fit_text(
            &frame.title,
            TITLE_SIZE,
            FontStyle::Bold,
            WIDTH.saturating_sub(40),
        );
        let style = t.text_style(TITLE_SIZE, FontStyle::Bold, HPos::Center, VPos::Center);
        let y = title_h as i32 / 2 + t.px(3.0) + t.text_dy(TITLE_SIZE);
        title_area
            .draw_text(&title, &style, (w as i32 / 2, y))
            .map_err(de)?;
    }
    let legend_w = t.upx(f64::from(frame.legend_width));
    let (plot_region, legend_region) = body.split_horizontally(w.saturating_sub(legend_w));
    let margin_right = if frame.legend.is_empty() {
        MARGIN_RIGHT
    } else {
        12
    };
    let mut chart = ChartBuilder::on(&plot_region)
        .margin_top(t.upx(f64::from(MARGIN_TOP)))
        .margin_bottom(t.upx(f64::from(MARGIN_BOTTOM)))
        .margin_left(t.upx(f64::from(MARGIN_LEFT)))
        .margin_right(t.upx(f64::from(margin_right)))
        .x_label_area_size(t.upx(f64::from(frame.x_area)))
        .y_label_area_size(t.upx(f64::from(frame.y_area)))
        .build_cartesian_2d(frame.x.clone(), frame.y.clone())
        .map_err(de)?;

    let mut mesh = chart.configure_mesh();
    mesh.label_style(TextStyle::from(t.font(TICK_SIZE, FontStyle::Normal)).color(&TEXT))
        .axis_desc_style(TextStyle::from(t.font(DESC_SIZE, FontStyle::Normal)).color(&TEXT))
        .axis_style(BLACK.mix(0.75).stroke_width(t.upx(1.0)))
        .bold_line_style(BLACK.mix(0.13).stroke_width(t.upx(1.0)))
        .light_line_style(BLACK.mix(0.05).stroke_width(t.upx(1.0)))
        .set_all_tick_mark_size(t.px(5.0))
        .y_label_offset(t.text_dy(TICK_SIZE));
    if !frame.x_desc.is_empty() {
        mesh.x_desc(frame.x_desc.as_str());
    }
    if !frame.y_desc.is_empty() {
        mesh.y_desc(frame.y_desc.as_str());
    }
    if !frame.x_grid {
        mesh.disable_x_mesh();
    }
    if !frame.y_grid {
        mesh.disable_y_mesh();
    }
    mesh.draw().map_err(de)?;

    let plot = chart.plotting_area();
    for p in prims {
        draw_prim(root, plot, frame, p, t)?;
    }
    if !frame.legend.is_empty() {
        draw_legend(&legend_region, &frame.legend, t)?;
    }
    Ok(())
}

type PlotArea<DB> = DrawingArea<DB, Cartesian2d<Axis, Axis>>;

/// Draws one primitive: areas and lines in axis coordinates on `plot` (clipped to it),
/// bars, markers and error bars in pixels on `root` (so that they keep their shape).
fn draw_prim<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &PlotArea<DB>,
    frame: &Frame,
    prim: &Prim,
    t: Target,
) -> Result<(), String> {
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
            plot.draw(&PathElement::new(
                pts.clone(),
                color.stroke_width(t.upx(LINE_W)),
            ))
            .map_err(de)?;
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
) -> Result<(), String> {
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
) -> Result<(), String> {
    let r = t.px(MARKER_R);
    let fill = if filled {
        color.filled()
    } else {
        WHITE.filled()
    };
    let edge = color.stroke_width(t.upx(if filled { 1.0 } else { 2.0 }));
    let outline = |pts: Vec<(i32, i32)>| -> Result<(), String> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;
    use std::time::{SystemTime, UNIX_EPOCH};

    type TestResult = Result<(), Box<dyn std::error::Error>>;

    /// A fresh directory under the system temp dir, removed again on drop (kept when
    /// `ERRMAP_KEEP_PLOTS` is set, to look at the charts).
    #[derive(Debug)]
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> std::io::Result<Self> {
            static COUNTER: AtomicUsize = AtomicUsize::new(0);
            let nanos = SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0);
            let dir = std::env::temp_dir().join(format!(
                "errmap-plot-{name}-{}-{}-{nanos}",
                std::process::id(),
                COUNTER.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::create_dir_all(&dir)?;
            Ok(Self(dir))
        }

        fn stem(&self, name: &str) -> PathBuf {
            self.0.join(name)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            if std::env::var_os("ERRMAP_KEEP_PLOTS").is_none() {
                let _ = std::fs::remove_dir_all(&self.0);
            } else {
                eprintln!("kept {}", self.0.display());
            }
        }
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
    fn fonts_register_once_and_cover_the_times_sign() -> TestResult {
        register_fonts();
        register_fonts();
        assert!(FONTS_OK.load(Ordering::Acquire));
        for (name, style) in [("normal", FontStyle::Normal), ("bold", FontStyle::Bold)] {
            let (w, h) = font(20.0, style)
                .box_size("4×1×2")
                .map_err(|e| format!("{name}: {e:?}"))?;
            assert!(w > 40 && h > 10, "{name}: {w}×{h}");
            assert!(text_width("×", 20.0, style) > 5, "{name}");
        }
        Ok(())
    }

    #[test]
    fn category_lines_renders() -> TestResult {
        let dir = TempDir::new("category")?;
        let stem = dir.stem("measured_vs_predicted");
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
        let paths = category_lines(
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
    fn category_lines_handles_many_series_and_degenerate_values() -> TestResult {
        let dir = TempDir::new("category-many")?;
        // Twelve series, all values equal: palette wraps, the range must not collapse.
        let s: Vec<Series> = (0..12)
            .map(|k| series(&format!("series {k}"), vec![5.0; 3], None))
            .collect();
        let stem = dir.stem("flat");
        let paths = category_lines(&stem, "Flat", "", "", &points(3), &s, &[], "")?;
        check_outputs(&paths, &stem, "Flat")?;
        // One category, one point, all zero.
        let stem = dir.stem("single");
        let one = [series("zero", vec![0.0], Some(vec![0.0]))];
        let paths = category_lines(&stem, "Single", "x", "y", &points(1), &one, &[true], "hl")?;
        check_outputs(&paths, &stem, "Single")?;
        Ok(())
    }

    #[test]
    fn bars_render_linear_log_vertical_and_horizontal() -> TestResult {
        let dir = TempDir::new("bars")?;
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
            let stem = dir.stem(name);
            let title = format!("Cross-validated RMS ({name})");
            let paths = bars(&stem, &title, "RMS / µm", labels, &values, markers, log)?;
            check_outputs(&paths, &stem, &title)?;
        }
        // log_y with a negative value falls back to a linear axis; a single bar works too.
        let stem = dir.stem("signed");
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
        let stem = dir.stem("one");
        let paths = bars(&stem, "One", "", &names(&["only"]), &[3.0], None, true)?;
        check_outputs(&paths, &stem, "One")?;
        Ok(())
    }

    #[test]
    fn many_horizontal_bars_make_a_taller_image() -> TestResult {
        let dir = TempDir::new("bars-tall")?;
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
        let stem = dir.stem("tall");
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
        let dir = TempDir::new("xy")?;
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
        let stem = dir.stem("residuals");
        let paths = xy(&stem, "Residuals", "x / mm", "residual / m", &s)?;
        check_outputs(&paths, &stem, "Residuals")?;

        let stem = dir.stem("single");
        let one = [
            xy_series("point", vec![3.0], vec![3.0], XyStyle::Points),
            xy_series("empty", vec![], vec![], XyStyle::Line),
        ];
        let paths = xy(&stem, "Single point", "x", "y", &one)?;
        check_outputs(&paths, &stem, "Single point")?;
        Ok(())
    }

    #[test]
    fn stem_with_dots_and_missing_directories() -> TestResult {
        let dir = TempDir::new("stem")?;
        let stem = dir.0.join("a").join("b").join("fig.v2");
        let s = [xy_series(
            "s",
            vec![1.0, 2.0],
            vec![2.0, 1.0],
            XyStyle::Line,
        )];
        let paths = xy(&stem, "Dots", "x", "y", &s)?;
        assert!(paths[0].ends_with("fig.v2.png") && paths[1].ends_with("fig.v2.svg"));
        check_outputs(&paths, &stem, "Dots")?;
        assert!(matches!(
            xy(Path::new(""), "t", "x", "y", &s),
            Err(PlotError::Invalid(_))
        ));
        Ok(())
    }

    #[test]
    fn invalid_input_is_an_error_and_writes_nothing() -> TestResult {
        let dir = TempDir::new("errors")?;
        let stem = dir.stem("never");
        let ok = [series("s", vec![1.0, 2.0], None)];
        let cats = points(2);

        let r = category_lines(&stem, "t", "x", "y", &[], &ok, &[], "");
        assert!(matches!(r, Err(PlotError::Empty("categories"))), "{r:?}");
        let r = category_lines(&stem, "t", "x", "y", &cats, &[], &[], "");
        assert!(matches!(r, Err(PlotError::Empty("series"))), "{r:?}");
        let short = [series("short", vec![1.0], None)];
        let r = category_lines(&stem, "t", "x", "y", &cats, &short, &[], "");
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
        let r = category_lines(&stem, "t", "x", "y", &cats, &bad_err, &[], "");
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let r = category_lines(&stem, "t", "x", "y", &cats, &ok, &[true], "");
        assert!(matches!(r, Err(PlotError::LengthMismatch { .. })), "{r:?}");
        let nan = [series("nan", vec![f64::NAN, f64::INFINITY], None)];
        let r = category_lines(&stem, "t", "x", "y", &cats, &nan, &[], "");
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
    fn tick_labels_are_tidy() {
        assert_eq!(format_linear(0.1 + 0.2, 0.1, 1.0), "0.3");
        assert_eq!(format_linear(-2.5, 0.5, 4.0), "−2.5");
        assert_eq!(format_linear(1e-17, 0.1, 1.0), "0");
        assert_eq!(format_linear(1200.0, 200.0, 2000.0), "1200");
        assert_eq!(format_linear(1.5e-6, 5e-7, 3e-6), "1.5×10⁻⁶");
        assert_eq!(format_linear(2e7, 1e7, 5e7), "2×10⁷");
        assert_eq!(format_log(1e-6, true), "10⁻⁶");
        assert_eq!(format_log(5e-4, true), "5×10⁻⁴");
        assert_eq!(format_log(0.002, false), "0.002");
        assert_eq!(format_log(20.0, false), "20");
    }

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
