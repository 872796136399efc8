//! A terminal screen as a picture: a ratatui buffer (what the live view drew, on the test
//! backend) rendered cell by cell into a PNG, for the README's picture of the live view.
//!
//! Each cell is a 9 × 18 pixel box filled with its background and its symbol drawn in its
//! foreground colour with the bundled DejaVu Sans Mono (bold when the cell is bold;
//! reversed cells swap the two colours). Braille cells — the chart's dots — are drawn as
//! dots from their code point (U+2800 plus one bit per dot, dots 1–3 and 7 down the left
//! column, 4–6 and 8 down the right), so they look as a terminal shows them whatever the
//! font covers; box-drawing cells likewise as lines through the cell's middle, so borders
//! join. The 16 named colours are xterm's defaults.

use std::path::Path;
use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::Color as _;
use plotters::style::FontStyle;
use plotters::style::text_anchor;
use ratatui::buffer::Buffer;
use ratatui::style::{Color, Modifier};

/// Cell size, pixels.
pub(crate) const CELL_W: u32 = 9;
pub(crate) const CELL_H: u32 = 18;
const FONT_PX: f64 = 15.0;
const FAMILY: &str = "monospace";

/// The screen's default colours (a dark terminal).
const DEFAULT_FG: RGBColor = RGBColor(0xd0, 0xd0, 0xd0);
const DEFAULT_BG: RGBColor = RGBColor(0x1c, 0x1c, 0x1c);

fn register_mono() -> Result<()> {
    static ONCE: Once = Once::new();
    static OK: AtomicBool = AtomicBool::new(false);
    ONCE.call_once(|| {
        let faces: [(FontStyle, &'static [u8]); 2] = [
            (FontStyle::Normal, dejavu::sans_mono::regular()),
            (FontStyle::Bold, dejavu::sans_mono::bold()),
        ];
        let ok = faces
            .into_iter()
            .all(|(style, bytes)| plotters::style::register_font(FAMILY, style, bytes).is_ok());
        OK.store(ok, Ordering::Release);
    });
    if OK.load(Ordering::Acquire) {
        Ok(())
    } else {
        Err(anyhow!(
            "the bundled DejaVu Sans Mono font could not be registered"
        ))
    }
}

/// xterm's default palette for the 16 named colours; `None` for the terminal's default.
pub(crate) fn rgb(c: Color) -> Option<RGBColor> {
    let named = |i: u8| {
        const XTERM: [(u8, u8, u8); 16] = [
            (0x00, 0x00, 0x00),
            (0xcd, 0x00, 0x00),
            (0x00, 0xcd, 0x00),
            (0xcd, 0xcd, 0x00),
            (0x00, 0x00, 0xee),
            (0xcd, 0x00, 0xcd),
            (0x00, 0xcd, 0xcd),
            (0xe5, 0xe5, 0xe5),
            (0x7f, 0x7f, 0x7f),
            (0xff, 0x00, 0x00),
            (0x00, 0xff, 0x00),
            (0xff, 0xff, 0x00),
            (0x5c, 0x5c, 0xff),
            (0xff, 0x00, 0xff),
            (0x00, 0xff, 0xff),
            (0xff, 0xff, 0xff),
        ];
        let (r, g, b) = XTERM[usize::from(i & 15)];
        RGBColor(r, g, b)
    };
    Some(match c {
        Color::Reset => return None,
        Color::Black => named(0),
        Color::Red => named(1),
        Color::Green => named(2),
        Color::Yellow => named(3),
        Color::Blue => named(4),
        Color::Magenta => named(5),
        Color::Cyan => named(6),
        Color::Gray => named(7),
        Color::DarkGray => named(8),
        Color::LightRed => named(9),
        Color::LightGreen => named(10),
        Color::LightYellow => named(11),
        Color::LightBlue => named(12),
        Color::LightMagenta => named(13),
        Color::LightCyan => named(14),
        Color::White => named(15),
        Color::Rgb(r, g, b) => RGBColor(r, g, b),
        Color::Indexed(i) if i < 16 => named(i),
        // The 6×6×6 cube and the grey ramp of the 256-colour palette.
        Color::Indexed(i) if i < 232 => {
            let k = i - 16;
            let level = |v: u8| if v == 0 { 0 } else { 55 + 40 * v };
            RGBColor(level(k / 36), level((k / 6) % 6), level(k % 6))
        }
        Color::Indexed(i) => {
            let v = 8 + 10 * (i - 232);
            RGBColor(v, v, v)
        }
    })
}

/// The dot offsets (column, row) of a Braille cell, from its code point.
pub(crate) fn braille_dots(ch: char) -> Option<Vec<(u32, u32)>> {
    let bits = u32::from(ch).checked_sub(0x2800).filter(|b| *b < 0x100)?;
    const DOTS: [(u32, u32); 8] = [
        (0, 0),
        (0, 1),
        (0, 2),
        (1, 0),
        (1, 1),
        (1, 2),
        (0, 3),
        (1, 3),
    ];
    Some(
        DOTS.iter()
            .enumerate()
            .filter(|(k, _)| bits & (1 << k) != 0)
            .map(|(_, d)| *d)
            .collect(),
    )
}

/// Renders `buf` into a PNG at `path` (`CELL_W` × `CELL_H` pixels a cell), written to a
/// temporary sibling and renamed into place.
pub(crate) fn write_png(buf: &Buffer, path: &Path) -> Result<()> {
    let (w, h) = size(buf);
    let partial = errmap::table::temporary(path);
    let drawn = (|| {
        let root = BitMapBackend::new(&partial, (w, h)).into_drawing_area();
        paint(&root, buf)?;
        root.present().map_err(|e| anyhow!("{e}"))
    })();
    match drawn.and_then(|()| Ok(std::fs::rename(&partial, path)?)) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&partial);
            Err(e.context(format!("{}: screenshot not written", path.display())))
        }
    }
}

/// The picture's size in pixels.
pub(crate) fn size(buf: &Buffer) -> (u32, u32) {
    (
        u32::from(buf.area.width) * CELL_W,
        u32::from(buf.area.height) * CELL_H,
    )
}

/// Paints `buf` onto `root`, which is [`size`] pixels.
pub(crate) fn paint<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, buf: &Buffer) -> Result<()> {
    register_mono()?;
    let area = buf.area;
    let err = |e: &dyn std::fmt::Display| anyhow!("drawing the screenshot: {e}");
    root.fill(&DEFAULT_BG).map_err(|e| err(&e))?;
    for y in 0..area.height {
        for x in 0..area.width {
            let cell = &buf[(area.x + x, area.y + y)];
            let mut fg = rgb(cell.fg).unwrap_or(DEFAULT_FG);
            let mut bg = rgb(cell.bg).unwrap_or(DEFAULT_BG);
            if cell.modifier.contains(Modifier::REVERSED) {
                std::mem::swap(&mut fg, &mut bg);
            }
            let (px, py) = (
                (u32::from(x) * CELL_W) as i32,
                (u32::from(y) * CELL_H) as i32,
            );
            if bg != DEFAULT_BG {
                root.draw(&Rectangle::new(
                    [(px, py), (px + CELL_W as i32, py + CELL_H as i32)],
                    bg.filled(),
                ))
                .map_err(|e| err(&e))?;
            }
            let symbol = cell.symbol();
            let Some(ch) = symbol.chars().next().filter(|c| *c != ' ') else {
                continue;
            };
            if let Some([l, r, u, d]) = box_arms(ch) {
                let (cx, cy) = (px + CELL_W as i32 / 2, py + CELL_H as i32 / 2);
                let arms = [
                    (l, (px, cy), (cx, cy)),
                    (r, (cx, cy), (px + CELL_W as i32 - 1, cy)),
                    (u, (cx, py), (cx, cy)),
                    (d, (cx, cy), (cx, py + CELL_H as i32 - 1)),
                ];
                for (_, a, b) in arms.into_iter().filter(|arm| arm.0) {
                    root.draw(&PathElement::new(vec![a, b], fg.stroke_width(1)))
                        .map_err(|e| err(&e))?;
                }
                continue;
            }
            if let Some(dots) = braille_dots(ch) {
                for (cx, cy) in dots {
                    let (dx, dy) = dot_origin(px, py, cx, cy);
                    root.draw(&Rectangle::new([(dx, dy), (dx + 1, dy + 1)], fg.filled()))
                        .map_err(|e| err(&e))?;
                }
                continue;
            }
            let style = if cell.modifier.contains(Modifier::BOLD) {
                FontStyle::Bold
            } else {
                FontStyle::Normal
            };
            let font =
                (FAMILY, FONT_PX)
                    .into_font()
                    .style(style)
                    .color(&fg)
                    .pos(text_anchor::Pos::new(
                        text_anchor::HPos::Left,
                        text_anchor::VPos::Center,
                    ));
            // plotters' glyphs sit on a baseline half the font size below the anchor; this
            // puts it 4 px above the cell's bottom (DejaVu's descent at 15 px).
            root.draw_text(symbol, &font, (px, py + CELL_H as i32 / 2 + 3))
                .map_err(|e| err(&e))?;
            if cell.modifier.contains(Modifier::UNDERLINED) {
                let uy = py + CELL_H as i32 - 2;
                root.draw(&Rectangle::new(
                    [(px, uy), (px + CELL_W as i32, uy + 1)],
                    fg.filled(),
                ))
                .map_err(|e| err(&e))?;
            }
        }
    }
    Ok(())
}

/// The arms (left, right, up, down) of a box-drawing character, drawn as lines through
/// the cell's middle so that borders join from cell to cell as on a terminal (light,
/// heavy, double and rounded forms alike).
pub(crate) fn box_arms(ch: char) -> Option<[bool; 4]> {
    Some(match ch {
        '─' | '━' | '═' => [true, true, false, false],
        '│' | '┃' | '║' => [false, false, true, true],
        '┌' | '┏' | '╔' | '╭' => [false, true, false, true],
        '┐' | '┓' | '╗' | '╮' => [true, false, false, true],
        '└' | '┗' | '╚' | '╰' => [false, true, true, false],
        '┘' | '┛' | '╝' | '╯' => [true, false, true, false],
        '├' | '┣' | '╠' => [false, true, true, true],
        '┤' | '┫' | '╣' => [true, false, true, true],
        '┬' | '┳' | '╦' => [true, true, false, true],
        '┴' | '┻' | '╩' => [true, true, true, false],
        '┼' | '╋' | '╬' => [true, true, true, true],
        _ => return None,
    })
}

/// Top-left pixel of the 2 × 2 dot (column `cx`, row `cy`) of a Braille cell at (`px`, `py`).
pub(crate) fn dot_origin(px: i32, py: i32, cx: u32, cy: u32) -> (i32, i32) {
    (px + 2 + 4 * cx as i32, py + 2 + 4 * cy as i32)
}
