//! A vertical cursor over a certificate's pages, for the CMM certificate
//! ([`super::cmm`]): headings kept with what follows, wrapped paragraphs, the signature
//! lines. The positioning certificate lays its pages out with [`super::layout::Sheet`].

use super::layout::{BODY, INK, MARGIN};
use super::pdf::{Doc, PAGE_H, PAGE_W, Weight};

/// A vertical cursor over the pages.
pub(super) struct Flow {
    pub(super) doc: Doc,
    pub(super) y: f32,
}

impl Flow {
    pub(super) fn need(&mut self, h: f32) {
        if self.y - h < MARGIN + 20.0 {
            self.doc.new_page();
            self.y = PAGE_H - MARGIN;
        }
    }

    pub(super) fn heading(&mut self, s: &str, size: f32) {
        self.need(size * 2.0 + 40.0);
        self.y -= size * 1.6;
        self.doc.text(MARGIN, self.y, size, Weight::Bold, s);
        self.y -= size * 0.6;
    }

    /// A paragraph wrapped to the content width.
    pub(super) fn paragraph(&mut self, s: &str, size: f32) {
        let width = PAGE_W - 2.0 * MARGIN;
        let mut line = String::new();
        let mut lines = Vec::new();
        for word in s.split_whitespace() {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if self.doc.width(&candidate, size, Weight::Regular) > width && !line.is_empty() {
                lines.push(std::mem::replace(&mut line, word.to_string()));
            } else {
                line = candidate;
            }
        }
        if !line.is_empty() {
            lines.push(line);
        }
        for l in lines {
            self.need(size * 1.4);
            self.y -= size * 1.4;
            self.doc.text(MARGIN, self.y, size, Weight::Regular, &l);
        }
        self.y -= size * 0.5;
    }
}

/// The signature lines, on the last page.
pub(super) fn signatures(flow: &mut Flow) {
    flow.need(90.0);
    flow.heading("Signatures", 11.0);
    flow.y -= 36.0;
    for (x, label) in [
        (MARGIN, "Calibrated by"),
        (PAGE_W / 2.0 + 10.0, "Approved by"),
    ] {
        flow.doc
            .polyline(&[(x, flow.y), (x + 200.0, flow.y)], 0.5, INK, None);
        flow.doc
            .text(x, flow.y - 11.0, BODY - 1.0, Weight::Regular, label);
    }
}
