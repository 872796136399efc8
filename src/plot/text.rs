//! Text: the bundled DejaVu fonts and the check that they are registered, the font sizes,
//! text measurement and shortening with "…", and the number formats of tick labels (plain
//! decimals, a shared power of ten such as `1.5×10⁻⁶`, log-axis labels).

use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use plotters::prelude::*;

use super::error::PlotError;

pub(super) const TITLE_SIZE: f64 = 26.0;
pub(super) const DESC_SIZE: f64 = 19.0;
pub(super) const TICK_SIZE: f64 = 15.0;
pub(super) const LEGEND_SIZE: f64 = 15.0;

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

pub(super) fn fonts_ready() -> Result<(), PlotError> {
    register_fonts();
    if FONTS_OK.load(Ordering::Acquire) {
        Ok(())
    } else {
        Err(PlotError::Fonts)
    }
}

/// Fits `text` into `max_w` pixels, shortening it with "…" when needed.
pub(super) fn fit_text(text: &str, size: f64, style: FontStyle, max_w: u32) -> String {
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

pub(super) fn font(size: f64, style: FontStyle) -> FontDesc<'static> {
    FontDesc::new(FontFamily::SansSerif, size, style)
}

/// Width of `text` in pixels (an estimate if the font cannot be measured).
pub(super) fn text_width(text: &str, size: f64, style: FontStyle) -> u32 {
    match font(size, style).box_size(text) {
        Ok((w, _)) => w,
        Err(_) => (text.chars().count() as f64 * size * 0.6) as u32,
    }
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
pub(super) fn format_linear(v: f64, step: f64, mag: f64) -> String {
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
pub(super) fn format_log(v: f64, sci: bool) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = Result<(), Box<dyn std::error::Error>>;

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
}
