//! A small page writer over `pdf-writer`: A4 pages, text in the bundled DejaVu Sans
//! (regular and bold, embedded as TrueType CID fonts with a ToUnicode map, so the text can
//! be extracted and searched), lines (solid or dashed), rectangles and circles. Coordinates
//! are PDF points from the bottom-left corner. No system font and no external program is
//! involved.
//!
//! Each font is embedded as the subset of the glyphs the document uses (`subsetter`,
//! deflated; tens of KB instead of about 0.35 MB per face), the content addressing glyphs
//! by their index in the whole font and a CIDToGIDMap renumbering them; glyph widths come
//! from the font's own `hmtx` table through `ttf-parser`, so measured text widths are the
//! widths the viewer draws.

use std::collections::BTreeMap;
use std::io::Write as _;

use pdf_writer::types::{CidFontType, FontFlags, SystemInfo};
use pdf_writer::{Content, Filter, Finish, Name, Pdf, Rect, Ref, Str, TextStr};

/// A4 in points.
pub(crate) const PAGE_W: f32 = 595.28;
/// A4 in points.
pub(crate) const PAGE_H: f32 = 841.89;

/// Why a PDF could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PdfError {
    /// The bundled font did not parse (a broken build).
    #[error("the bundled font does not parse: {0}")]
    Font(String),
    /// Deflating the font failed.
    #[error("cannot compress the font: {0}")]
    Compress(#[from] std::io::Error),
}

struct Face {
    data: &'static [u8],
    face: ttf_parser::Face<'static>,
    base: &'static [u8],
    /// Glyphs used, with the text they stand for.
    used: BTreeMap<u16, char>,
}

impl Face {
    fn new(data: &'static [u8], base: &'static [u8]) -> Result<Face, PdfError> {
        let face = ttf_parser::Face::parse(data, 0).map_err(|e| PdfError::Font(e.to_string()))?;
        Ok(Face {
            data,
            face,
            base,
            used: BTreeMap::new(),
        })
    }

    fn per_unit(&self) -> f32 {
        1000.0 / f32::from(self.face.units_per_em())
    }

    fn glyph(&self, c: char) -> u16 {
        self.face.glyph_index(c).map_or(0, |g| g.0)
    }

    /// Advance of a glyph, 1/1000 em.
    fn advance(&self, gid: u16) -> f32 {
        f32::from(
            self.face
                .glyph_hor_advance(ttf_parser::GlyphId(gid))
                .unwrap_or(0),
        ) * self.per_unit()
    }
}

fn deflate(bytes: &[u8]) -> Result<Vec<u8>, PdfError> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(bytes)?;
    Ok(z.finish()?)
}

/// The document being written.
pub struct Doc {
    faces: [Face; 2],
    pages: Vec<Content>,
    title: String,
}

impl std::fmt::Debug for Doc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Doc")
            .field("pages", &self.pages.len())
            .field("title", &self.title)
            .finish()
    }
}

/// Text weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weight {
    /// DejaVu Sans.
    Regular,
    /// DejaVu Sans Bold.
    Bold,
}

impl Weight {
    fn index(self) -> usize {
        match self {
            Weight::Regular => 0,
            Weight::Bold => 1,
        }
    }
}

/// An RGB colour, components 0…1.
pub(crate) type Rgb = (f32, f32, f32);

impl Doc {
    /// An empty document with one blank page.
    pub fn new(title: &str) -> Result<Doc, PdfError> {
        Ok(Doc {
            faces: [
                Face::new(dejavu::sans::regular(), b"DejaVuSans")?,
                Face::new(dejavu::sans::bold(), b"DejaVuSans-Bold")?,
            ],
            pages: vec![Content::new()],
            title: title.to_string(),
        })
    }

    /// Starts a new page; drawing goes there from now on.
    pub fn new_page(&mut self) {
        self.pages.push(Content::new());
    }

    /// Number of pages so far.
    pub fn page_count(&self) -> usize {
        self.pages.len()
    }

    fn page(&mut self) -> &mut Content {
        let n = self.pages.len();
        &mut self.pages[n - 1]
    }

    /// Width of `s` at `size` points.
    pub fn width(&self, s: &str, size: f32, weight: Weight) -> f32 {
        let f = &self.faces[weight.index()];
        s.chars().map(|c| f.advance(f.glyph(c))).sum::<f32>() * size / 1000.0
    }

    /// Text with its baseline's left end at `(x, y)`.
    pub fn text(&mut self, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
        self.text_on(self.pages.len() - 1, x, y, size, weight, s);
    }

    /// Text on page `page` (0-based), e.g. a footer written once the page count is known.
    pub fn text_on(&mut self, page: usize, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
        let face = &mut self.faces[weight.index()];
        let mut bytes = Vec::with_capacity(2 * s.len());
        // A combining macron (U+0304, as in B̄) is kept in the text, so it is extracted
        // and searched, and drawn as a rule over the letter before it: the font's
        // zero-width mark does not show in every viewer.
        let mut bars = Vec::new();
        let (mut x_at, mut last) = (x, (x, 0.0f32));
        for c in s.chars() {
            let g = face.glyph(c);
            face.used.entry(g).or_insert(c);
            bytes.extend_from_slice(&g.to_be_bytes());
            let w = face.advance(g) * size / 1000.0;
            if c == '\u{304}' {
                bars.push(last);
            } else {
                last = (x_at, w);
            }
            x_at += w;
        }
        let name = [Name(b"F0"), Name(b"F1")][weight.index()];
        let content = &mut self.pages[page];
        content.begin_text();
        content.set_fill_rgb(0.1, 0.1, 0.1);
        content.set_font(name, size);
        content.next_line(x, y);
        content.show(Str(&bytes));
        content.end_text();
        for (bx, bw) in bars {
            let top = y + size * 0.86;
            content.save_state();
            content.set_line_width(size * 0.07);
            content.set_stroke_rgb(0.1, 0.1, 0.1);
            content.move_to(bx + bw * 0.12, top);
            content.line_to(bx + bw * 0.88, top);
            content.stroke();
            content.restore_state();
        }
    }

    /// Text right-aligned at `x`.
    pub fn text_right(&mut self, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
        let w = self.width(s, size, weight);
        self.text(x - w, y, size, weight, s);
    }

    /// Text centred on `x`.
    pub fn text_centre(&mut self, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
        let w = self.width(s, size, weight);
        self.text(x - w / 2.0, y, size, weight, s);
    }

    /// A polyline, solid or with a `[dash, gap]` pattern.
    pub fn polyline(
        &mut self,
        pts: &[(f32, f32)],
        width: f32,
        colour: Rgb,
        dash: Option<[f32; 2]>,
    ) {
        if pts.len() < 2 {
            return;
        }
        let c = self.page();
        c.save_state();
        c.set_line_width(width);
        c.set_stroke_rgb(colour.0, colour.1, colour.2);
        if let Some(d) = dash {
            c.set_dash_pattern(d, 0.0);
        }
        c.move_to(pts[0].0, pts[0].1);
        for p in &pts[1..] {
            c.line_to(p.0, p.1);
        }
        c.stroke();
        c.restore_state();
    }

    /// A stroked rectangle.
    pub fn rect(&mut self, x: f32, y: f32, w: f32, h: f32, width: f32, colour: Rgb) {
        let c = self.page();
        c.save_state();
        c.set_line_width(width);
        c.set_stroke_rgb(colour.0, colour.1, colour.2);
        c.rect(x, y, w, h);
        c.stroke();
        c.restore_state();
    }

    /// A filled rectangle.
    pub fn fill_rect(&mut self, x: f32, y: f32, w: f32, h: f32, colour: Rgb) {
        let c = self.page();
        c.save_state();
        c.set_fill_rgb(colour.0, colour.1, colour.2);
        c.rect(x, y, w, h);
        c.fill_nonzero();
        c.restore_state();
    }

    /// A filled circle (four Bézier arcs).
    pub fn dot(&mut self, x: f32, y: f32, r: f32, colour: Rgb) {
        const K: f32 = 0.552_284_8;
        let c = self.page();
        c.save_state();
        c.set_fill_rgb(colour.0, colour.1, colour.2);
        c.move_to(x + r, y);
        c.cubic_to(x + r, y + K * r, x + K * r, y + r, x, y + r);
        c.cubic_to(x - K * r, y + r, x - r, y + K * r, x - r, y);
        c.cubic_to(x - r, y - K * r, x - K * r, y - r, x, y - r);
        c.cubic_to(x + K * r, y - r, x + r, y - K * r, x + r, y);
        c.fill_nonzero();
        c.restore_state();
    }

    /// The finished PDF.
    pub fn finish(self) -> Result<Vec<u8>, PdfError> {
        let mut pdf = Pdf::new();
        let mut next = 1;
        let mut alloc = || {
            let r = Ref::new(next);
            next += 1;
            r
        };
        let catalog = alloc();
        let tree = alloc();
        let info = alloc();
        let font_refs: Vec<Ref> = (0..2).map(|_| alloc()).collect();
        let page_refs: Vec<(Ref, Ref)> = self.pages.iter().map(|_| (alloc(), alloc())).collect();

        pdf.catalog(catalog).pages(tree);
        pdf.pages(tree)
            .kids(page_refs.iter().map(|p| p.0))
            .count(page_refs.len() as i32);
        pdf.document_info(info)
            .title(TextStr(&self.title))
            .producer(TextStr("errmap"));
        for ((page_id, content_id), content) in page_refs.iter().zip(self.pages) {
            let mut page = pdf.page(*page_id);
            page.media_box(Rect::new(0.0, 0.0, PAGE_W, PAGE_H));
            page.parent(tree);
            page.contents(*content_id);
            let mut res = page.resources();
            let mut fonts = res.fonts();
            fonts.pair(Name(b"F0"), font_refs[0]);
            fonts.pair(Name(b"F1"), font_refs[1]);
            fonts.finish();
            res.finish();
            page.finish();
            pdf.stream(*content_id, &content.finish());
        }
        for (face, &type0) in self.faces.iter().zip(&font_refs) {
            let (cid, descriptor, file, cmap, gid_map) =
                (alloc(), alloc(), alloc(), alloc(), alloc());
            // The content addresses glyphs by their index in the whole font (CID = old
            // glyph id); the embedded subset renumbers them from 0, and the CIDToGIDMap
            // (two bytes per CID, ISO 32000-1 §9.7.4.2) sends each CID to its new glyph.
            let used: Vec<u16> = face.used.keys().copied().collect();
            let remapper = subsetter::GlyphRemapper::new_from_glyphs_sorted(&used);
            let program = subsetter::subset(face.data, 0, &remapper)
                .map_err(|e| PdfError::Font(format!("subsetting: {e}")))?;
            // A subset's font name carries a six-letter tag (ISO 32000-1 §9.6.4), here
            // derived from the glyph set so equal documents get equal names.
            let tag = used.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &g| {
                (h ^ u64::from(g)).wrapping_mul(0x0100_0000_01b3)
            });
            let mut subset_name: Vec<u8> = (0..6)
                .map(|k| b'A' + ((tag >> (5 * k)) % 26) as u8)
                .collect();
            subset_name.push(b'+');
            subset_name.extend_from_slice(face.base);
            let max_cid = used.last().copied().unwrap_or(0);
            let map: Vec<u8> = (0..=max_cid)
                .flat_map(|c| remapper.get(c).unwrap_or(0).to_be_bytes())
                .collect();
            pdf.stream(gid_map, &deflate(&map)?)
                .filter(Filter::FlateDecode);
            let system = SystemInfo {
                registry: Str(b"Adobe"),
                ordering: Str(b"Identity"),
                supplement: 0,
            };
            pdf.type0_font(type0)
                .base_font(Name(&subset_name))
                .encoding_predefined(Name(b"Identity-H"))
                .descendant_font(cid)
                .to_unicode(cmap);
            let mut cid_font = pdf.cid_font(cid);
            cid_font
                .subtype(CidFontType::Type2)
                .base_font(Name(&subset_name))
                .system_info(system)
                .font_descriptor(descriptor)
                .default_width(0.0)
                .cid_to_gid_map_stream(gid_map);
            let mut widths = cid_font.widths();
            for &g in face.used.keys() {
                widths.consecutive(g, [face.advance(g)]);
            }
            widths.finish();
            cid_font.finish();
            let s = face.per_unit();
            let bbox = face.face.global_bounding_box();
            pdf.font_descriptor(descriptor)
                .name(Name(&subset_name))
                .flags(FontFlags::NON_SYMBOLIC)
                .bbox(Rect::new(
                    f32::from(bbox.x_min) * s,
                    f32::from(bbox.y_min) * s,
                    f32::from(bbox.x_max) * s,
                    f32::from(bbox.y_max) * s,
                ))
                .italic_angle(0.0)
                .ascent(f32::from(face.face.ascender()) * s)
                .descent(f32::from(face.face.descender()) * s)
                .cap_height(f32::from(face.face.capital_height().unwrap_or(0)) * s)
                .stem_v(80.0)
                .font_file2(file);
            pdf.stream(file, &deflate(&program)?)
                .filter(Filter::FlateDecode)
                .pair(Name(b"Length1"), program.len() as i32);
            let mut map = pdf_writer::types::UnicodeCmap::new(Name(b"Custom"), system);
            for (&g, &c) in &face.used {
                map.pair(g, c);
            }
            pdf.cmap(cmap, &map.finish()).system_info(system);
        }
        Ok(pdf.finish())
    }
}
