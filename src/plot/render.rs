//! Rendering a chart (a `Frame` and its `Prim`s) to `<stem>.png` and `<stem>.svg`: the
//! title strip, the mesh with its ticks, the primitives and the legend panel; the PNG drawn
//! at `SUPERSAMPLE` times its size and averaged down.

use std::path::{Path, PathBuf};

use plotters::backend::RGBPixel;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use super::draw::{Frame, Prim, TEXT, Target, de, draw_legend, draw_prim};
use super::error::{DrawFailure, PlotError};
use super::scale::{MARGIN_BOTTOM, MARGIN_LEFT, MARGIN_RIGHT, MARGIN_TOP, TITLE_HEIGHT, WIDTH};
use super::text::{DESC_SIZE, TICK_SIZE, TITLE_SIZE, fit_text};

/// The PNG is rendered at this multiple of its size and averaged down: plotters draws
/// lines without anti-aliasing and places glyphs only to the whole pixel, and both look
/// much better after averaging.
const SUPERSAMPLE: u32 = 2;

pub(super) fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

pub(super) fn write_both(
    stem: &Path,
    frame: &Frame,
    prims: &[Prim],
) -> Result<Vec<PathBuf>, PlotError> {
    let (png, svg) = png_and_svg(stem)?;
    whole(&png, |p| write_png(p, frame, prims))?;
    whole(&svg, |p| write_svg(p, frame, prims))?;
    Ok(vec![png, svg])
}

/// `<stem>.png` and `<stem>.svg`, their directory created when missing.
pub(super) fn png_and_svg(stem: &Path) -> Result<(PathBuf, PathBuf), PlotError> {
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
    Ok((png, svg))
}

/// A picture drawn the same way on the PNG and the SVG backend.
pub(super) trait Figure {
    fn draw_on<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>)
    -> Result<(), DrawFailure>;
}

/// The dark grey text of the arrow and sphere maps, `size` points.
pub(super) fn map_text(size: f64) -> TextStyle<'static> {
    TextStyle::from(super::text::font(size, plotters::style::FontStyle::Normal))
        .color(&RGBColor(0x22, 0x22, 0x22))
}

/// A white page with `title` at the top left and `notes` below it, one a line: the head of
/// the arrow and sphere maps.
pub(super) fn map_heading<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    notes: &[String],
) -> Result<(), DrawFailure> {
    root.fill(&WHITE).map_err(de)?;
    root.draw(&Text::new(title.to_string(), (16, 10), map_text(20.0)))
        .map_err(de)?;
    for (i, line) in notes.iter().enumerate() {
        root.draw(&Text::new(
            line.clone(),
            (16, 38 + 18 * i as i32),
            map_text(14.0),
        ))
        .map_err(de)?;
    }
    Ok(())
}

/// Writes `<stem>.png` and `<stem>.svg` of `figure`, `size` pixels, each whole or not at
/// all ([`whole`]); returns their paths.
pub(super) fn figure_pair(
    stem: &Path,
    size: (u32, u32),
    figure: &impl Figure,
) -> Result<Vec<PathBuf>, PlotError> {
    let (png, svg) = png_and_svg(stem)?;
    whole(&png, |p| {
        let root = BitMapBackend::new(p, size).into_drawing_area();
        figure.draw_on(&root)?;
        root.present().map_err(de)
    })?;
    whole(&svg, |p| {
        let root = SVGBackend::new(p, size).into_drawing_area();
        figure.draw_on(&root)?;
        root.present().map_err(de)
    })?;
    Ok(vec![png, svg])
}

/// Writes `path` whole or not at all: `draw` writes a temporary sibling, which is renamed
/// into place when it succeeded and removed when it failed, so an error (or a kill)
/// never leaves a half-drawn figure in a report directory, nor destroys the old one.
/// The sibling is named like `table::temporary`'s (`.STEM.PID.tmp.EXT`, the extension
/// kept for the backend); `plot` imports nothing of the crate, so it builds the name.
pub(super) fn whole(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), DrawFailure>,
) -> Result<(), PlotError> {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let ext = path.extension().unwrap_or_default().to_string_lossy();
    let tmp = path.with_file_name(format!(".{stem}.{}.tmp.{ext}", std::process::id()));
    let result = draw(&tmp)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(DrawFailure::new))
        .map_err(|source| PlotError::Draw {
            path: path.to_path_buf(),
            source,
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn write_png(path: &Path, frame: &Frame, prims: &[Prim]) -> Result<(), DrawFailure> {
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

fn write_svg(path: &Path, frame: &Frame, prims: &[Prim]) -> Result<(), DrawFailure> {
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
) -> Result<(), DrawFailure> {
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
