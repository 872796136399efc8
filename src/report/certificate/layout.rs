//! The page layout every certificate shares, so that another certificate (ISO 10360-5
//! probing, …) reads the same: A4 pages from a vertical cursor, a title block, headings
//! that never stand alone at a page foot (a heading is drawn only together with the first
//! line of what follows it), wrapped paragraphs, field lists, tables that size their
//! columns to their text and stay on one page when they fit, signature lines and a footer
//! `LABEL · page i of n` on every page; and one number format per quantity ([`fixed`],
//! [`Decimals`]).
//!
//! ```no_run
//! # fn main() -> Result<(), errmap::report::certificate::PdfError> {
//! use errmap::report::certificate::{Align, Sheet};
//! let mut s = Sheet::new("Calibration certificate — probing", "ISO 10360-5")?;
//! s.heading("Summary", 12.0);
//! s.fields(&[("Certificate number".into(), "EX-1".into())]);
//! s.table(&["parameter", "value / µm"], &[vec!["P_FTU".into(), "1.2".into()]], &[Align::Left, Align::Right]);
//! s.signatures();
//! let pdf: Vec<u8> = s.finish("Certificate EX-1")?;
//! # Ok(()) }
//! ```

use super::pdf::{Doc, PAGE_H, PAGE_W, PdfError, Rgb, Weight};

/// Page margin, pt.
pub(crate) const MARGIN: f32 = 48.0;
/// Body type size, pt.
pub(crate) const BODY: f32 = 9.0;
/// Smallest type a table is set in.
pub const MIN_SIZE: f32 = 5.5;
/// Table rules and secondary lines.
pub(crate) const GREY: Rgb = (0.6, 0.6, 0.6);
/// Text and frames.
pub(crate) const INK: Rgb = (0.1, 0.1, 0.1);

/// Column alignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Left.
    Left,
    /// Right (numbers).
    Right,
}

/// A number to a fixed number of decimals, `-0.000` printed `0.000`.
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].bytes().all(|b| b == b'0' || b == b'.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// The zone [lo, hi] in words, its limits printed by `num`: `≤ 6.00`, `≥ −0.50`,
/// `−0.50 … 0.50`, `—` without limits, and an empty zone said to be empty.
pub fn zone_words(z: [Option<f64>; 2], num: &dyn Fn(f64) -> String) -> String {
    match z {
        [Some(l), Some(h)] if l > h => "empty (nothing can pass)".into(),
        [Some(l), Some(h)] => format!("{} … {}", num(l), num(h)),
        [None, Some(h)] => format!("≤ {}", num(h)),
        [Some(l), None] => format!("≥ {}", num(l)),
        [None, None] => "—".into(),
    }
}

/// The decimal place of the second significant digit of `v` (0.104 → 2, 1.5 → 1, 12 → 0):
/// where an uncertainty stated to two significant digits ends (JCGM 100:2008 7.2.6).
/// `None` for 0, a negative or a non-finite value.
pub(super) fn second_digit_place(v: f64) -> Option<i32> {
    (v.is_finite() && v > 0.0).then(|| 1 - v.log10().floor() as i32)
}

/// The decimals a quantity is printed to, the same wherever it appears.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decimals {
    /// Deviations and their expanded uncertainties, µm.
    pub um: usize,
    /// Temperatures, °C or K.
    pub temp: usize,
    /// Pressure, hPa.
    pub hpa: usize,
    /// Humidity, %RH.
    pub rh: usize,
}

impl Decimals {
    /// µm to `um` places; the environment to 0.01 °C, 0.1 hPa, 1 %RH.
    pub fn with_um(um: usize) -> Decimals {
        Decimals {
            um,
            temp: 2,
            hpa: 1,
            rh: 1,
        }
    }
}

/// Subscripts are set this much smaller, and lowered by this fraction of the size.
const SUB_SCALE: f32 = 0.7;
const SUB_DROP: f32 = 0.25;

/// `s` split into (text, subscript?) runs at `_{…}`: `P_{FTU}` is P, then FTU lowered.
fn runs(s: &str) -> Vec<(&str, bool)> {
    let mut out = Vec::new();
    let mut rest = s;
    while let Some(i) = rest.find("_{") {
        if i > 0 {
            out.push((&rest[..i], false));
        }
        let after = &rest[i + 2..];
        let end = after.find('}').unwrap_or(after.len());
        out.push((&after[..end], true));
        rest = after.get(end + 1..).unwrap_or("");
    }
    if !rest.is_empty() {
        out.push((rest, false));
    }
    out
}

/// The width of `s` with its `_{…}` subscripts set smaller.
fn rich_width(doc: &Doc, s: &str, size: f32, weight: Weight) -> f32 {
    runs(s)
        .iter()
        .map(|&(t, sub)| doc.width(t, if sub { size * SUB_SCALE } else { size }, weight))
        .sum()
}

/// Text with `_{…}` subscripts, its baseline's left end at (x, y).
fn rich(doc: &mut Doc, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
    let mut x = x;
    for (t, sub) in runs(s) {
        let (sz, dy) = if sub {
            (size * SUB_SCALE, -size * SUB_DROP)
        } else {
            (size, 0.0)
        };
        doc.text(x, y + dy, sz, weight, t);
        x += doc.width(t, sz, weight);
    }
}

/// A vertical cursor over the pages, with the heading waiting for its first line.
pub struct Sheet {
    /// The document drawn into.
    pub doc: Doc,
    /// The cursor: the baseline of the last thing drawn, pt from the page foot.
    pub y: f32,
    pending: Option<(String, f32)>,
}

impl std::fmt::Debug for Sheet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sheet").field("y", &self.y).finish()
    }
}

impl Sheet {
    /// A document whose first page starts with `title` (16 pt) and `subtitle`.
    pub fn new(title: &str, subtitle: &str) -> Result<Sheet, PdfError> {
        let mut s = Sheet {
            doc: Doc::new(title)?,
            y: PAGE_H - MARGIN,
            pending: None,
        };
        s.y -= 16.0;
        s.doc.text(MARGIN, s.y, 16.0, Weight::Bold, title);
        s.y -= 14.0;
        s.doc.text(MARGIN, s.y, BODY, Weight::Regular, subtitle);
        s.y -= 8.0;
        Ok(s)
    }

    /// Content width, pt.
    pub fn width(&self) -> f32 {
        PAGE_W - 2.0 * MARGIN
    }

    /// Makes room for `h` pt (and the waiting heading): a new page when it does not fit.
    /// Draws the waiting heading.
    pub fn need(&mut self, h: f32) {
        let head = self.pending.as_ref().map_or(0.0, |(_, s)| s * 2.2);
        if self.y - h - head < MARGIN + 20.0 {
            self.new_page();
        }
        if let Some((s, size)) = self.pending.take() {
            self.y -= size * 1.6;
            self.doc.text(MARGIN, self.y, size, Weight::Bold, &s);
            self.y -= size * 0.6;
        }
    }

    /// Starts a new page (the waiting heading moves with the content).
    pub fn new_page(&mut self) {
        self.doc.new_page();
        self.y = PAGE_H - MARGIN;
    }

    /// A heading of `size` pt, drawn with the first line of what follows it.
    pub fn heading(&mut self, s: &str, size: f32) {
        self.pending = Some((s.to_string(), size));
    }

    /// A paragraph wrapped to the content width.
    pub fn paragraph(&mut self, s: &str, size: f32) {
        self.paragraph_weighted(s, size, Weight::Regular);
    }

    /// One line with `_{…}` subscripts (it must fit the width: it is not wrapped).
    pub fn rich_line(&mut self, s: &str, size: f32) {
        self.need(size * 1.6);
        self.y -= size * 1.6;
        rich(&mut self.doc, MARGIN, self.y, size, Weight::Regular, s);
        self.y -= size * 0.5;
    }

    /// A paragraph in a given weight.
    pub fn paragraph_weighted(&mut self, s: &str, size: f32, weight: Weight) {
        let width = self.width();
        let mut line = String::new();
        let mut lines = Vec::new();
        for word in s.split_whitespace() {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if self.doc.width(&candidate, size, weight) > width && !line.is_empty() {
                lines.push(std::mem::replace(&mut line, word.to_string()));
            } else {
                line = candidate;
            }
        }
        if !line.is_empty() {
            lines.push(line);
        }
        // Keep a short paragraph (up to 4 lines) together.
        if lines.len() <= 4 {
            self.need(size * 1.4 * lines.len() as f32);
        }
        for l in lines {
            self.need(size * 1.4);
            self.y -= size * 1.4;
            self.doc.text(MARGIN, self.y, size, weight, &l);
        }
        self.y -= size * 0.5;
    }

    /// A field list: name and value, two columns.
    pub fn fields(&mut self, fields: &[(String, String)]) {
        let rows: Vec<Vec<String>> = fields
            .iter()
            .map(|(a, b)| vec![a.clone(), b.clone()])
            .collect();
        self.table_sized(&[], &rows, &[Align::Left, Align::Left], BODY);
    }

    /// A table at the body size less one.
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>], align: &[Align]) {
        self.table_sized(header, rows, align, BODY - 1.0);
    }

    /// A table: a bold header row (none when `header` is empty), then rows; columns as
    /// wide as their widest cell; `_{…}` in a cell is set as a subscript. A table wider than the page is set smaller until it
    /// fits; a table that fits on a page is not split.
    pub fn table_sized(
        &mut self,
        header: &[&str],
        rows: &[Vec<String>],
        align: &[Align],
        size: f32,
    ) {
        let pad = 4.0;
        let avail = self.width();
        let ncol = rows
            .first()
            .map_or(header.len(), Vec::len)
            .max(header.len());
        let mut size = size;
        let widths = loop {
            let w: Vec<f32> = (0..ncol)
                .map(|k| {
                    let head = header
                        .get(k)
                        .map_or(0.0, |h| rich_width(&self.doc, h, size, Weight::Bold));
                    rows.iter()
                        .map(|r| {
                            r.get(k)
                                .map_or(0.0, |c| rich_width(&self.doc, c, size, Weight::Regular))
                        })
                        .fold(head, f32::max)
                        + 2.0 * pad
                })
                .collect();
            if w.iter().sum::<f32>() <= avail || size <= MIN_SIZE {
                break w;
            }
            size = (size - 0.5).max(MIN_SIZE);
        };
        let row_h = size * 1.6;
        let total: f32 = widths.iter().sum();
        let nrows = rows.len() + usize::from(!header.is_empty());
        let whole = row_h * nrows as f32 + size;
        let page = PAGE_H - 2.0 * MARGIN - 60.0;
        self.need(if whole < page { whole } else { row_h * 3.0 });
        let draw = |s: &mut Sheet, cells: &[String], weight: Weight| {
            s.need(row_h);
            s.y -= row_h;
            let mut x = MARGIN;
            for (k, c) in cells.iter().enumerate() {
                let base = s.y + size * 0.45;
                match align.get(k).copied().unwrap_or(Align::Left) {
                    Align::Left => rich(&mut s.doc, x + pad, base, size, weight, c),
                    Align::Right if !c.contains("_{") => {
                        s.doc.text_right(x + widths[k] - pad, base, size, weight, c)
                    }
                    Align::Right => {
                        let left = x + widths[k] - pad - rich_width(&s.doc, c, size, weight);
                        rich(&mut s.doc, left, base, size, weight, c)
                    }
                }
                x += widths[k];
            }
            s.doc
                .polyline(&[(MARGIN, s.y), (MARGIN + total, s.y)], 0.3, GREY, None);
        };
        if !header.is_empty() {
            let head: Vec<String> = header.iter().map(|s| s.to_string()).collect();
            draw(self, &head, Weight::Bold);
        }
        for r in rows {
            draw(self, r, Weight::Regular);
        }
        self.y -= size;
    }

    /// The signature lines.
    pub fn signatures(&mut self) {
        self.heading("Signatures", 11.0);
        self.need(60.0);
        self.y -= 36.0;
        for (x, label) in [
            (MARGIN, "Calibrated by"),
            (PAGE_W / 2.0 + 10.0, "Approved by"),
        ] {
            self.doc
                .polyline(&[(x, self.y), (x + 200.0, self.y)], 0.5, INK, None);
            self.doc
                .text(x, self.y - 11.0, BODY - 1.0, Weight::Regular, label);
        }
        self.y -= 14.0;
    }

    /// The finished PDF, `label · page i of n · errmap` at the foot of every page.
    pub fn finish(mut self, label: &str) -> Result<Vec<u8>, PdfError> {
        let pages = self.doc.page_count();
        for p in 0..pages {
            let footer = format!("{label} · page {} of {pages} · errmap", p + 1);
            self.doc.text_on(
                p,
                MARGIN,
                MARGIN / 2.0,
                BODY - 2.0,
                Weight::Regular,
                &footer,
            );
        }
        self.doc.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscripts_split_into_runs() {
        assert_eq!(runs("P_{FTU}"), vec![("P", false), ("FTU", true)]);
        assert_eq!(
            runs("E_{0} largest |E_{0}|"),
            vec![
                ("E", false),
                ("0", true),
                (" largest |E", false),
                ("0", true),
                ("|", false)
            ]
        );
        assert_eq!(runs("plain"), vec![("plain", false)]);
        assert_eq!(runs("x_{open"), vec![("x", false), ("open", true)]);
    }

    #[test]
    fn the_second_significant_digit_has_its_place() {
        assert_eq!(second_digit_place(0.104), Some(2));
        assert_eq!(second_digit_place(1.5), Some(1));
        assert_eq!(second_digit_place(12.0), Some(0));
        assert_eq!(second_digit_place(0.0), None);
        assert_eq!(second_digit_place(f64::NAN), None);
    }

    #[test]
    fn fixed_prints_no_negative_zero() {
        assert_eq!(fixed(-0.00004, 4), "0.0000");
        assert_eq!(fixed(-0.00005001, 4), "-0.0001");
        assert_eq!(fixed(1.5, 0), "2");
    }
}
