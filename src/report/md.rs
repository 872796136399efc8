//! A small Markdown writer for the report builders: a document is written as its outline
//! (headings, paragraphs, lists, tables) into a `String`, which cannot fail, so the
//! builders need no `let _ = writeln!`.
//!
//! The writer adds no formatting of its own to numbers: every cell and line arrives
//! formatted by the caller, so the reports stay byte for byte what they were. Nothing is
//! inserted implicitly either: a heading or a paragraph ends with a blank line, a line,
//! list item or table row with a line end, and a blank line anywhere else is an explicit
//! [`Md::nl`], so the writer reproduces any existing document exactly.

use std::fmt::{Display, Write as _};

/// A Markdown document being written.
#[derive(Debug, Default, Clone)]
pub(crate) struct Md {
    s: String,
}

/// How a table column is aligned, written in the rule under its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Align {
    /// `---`: the renderer's default (left).
    Default,
    /// `---:`
    Right,
}

impl From<char> for Align {
    /// `r` is [`Align::Right`], anything else [`Align::Default`].
    fn from(c: char) -> Self {
        if c == 'r' {
            Align::Right
        } else {
            Align::Default
        }
    }
}

impl Md {
    /// An empty document.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// The text written so far.
    pub(crate) fn finish(self) -> String {
        self.s
    }

    /// The text written so far, borrowed (to write it out without giving up the writer).
    pub(crate) fn as_str(&self) -> &str {
        &self.s
    }

    /// Writes `text` as it is, with no newline: for the few places where a line is
    /// assembled from parts.
    pub(crate) fn raw(&mut self, text: impl Display) -> &mut Self {
        // Writing into a String cannot fail.
        let _ = write!(self.s, "{text}");
        self
    }

    /// One line of text.
    pub(crate) fn line(&mut self, text: impl Display) -> &mut Self {
        self.raw(text).nl()
    }

    /// A line break (an empty line after a line, a line end after [`Md::raw`]).
    pub(crate) fn nl(&mut self) -> &mut Self {
        self.s.push('\n');
        self
    }

    /// A heading of `level` (1 = `#`) and the blank line after it.
    pub(crate) fn heading(&mut self, level: usize, text: impl Display) -> &mut Self {
        self.s.push_str(&"#".repeat(level));
        self.s.push(' ');
        self.raw(text).nl().nl()
    }

    /// A paragraph and the blank line after it.
    pub(crate) fn para(&mut self, text: impl Display) -> &mut Self {
        self.raw(text).nl().nl()
    }

    /// One item of a bullet list (`- text`).
    pub(crate) fn bullet(&mut self, text: impl Display) -> &mut Self {
        self.raw("- ").line(text)
    }

    /// A bullet list, one item per element.
    pub(crate) fn bullets<T: Display>(&mut self, items: impl IntoIterator<Item = T>) -> &mut Self {
        for item in items {
            self.bullet(item);
        }
        self
    }

    /// A numbered list (`1. text`), one item per element.
    pub(crate) fn numbered<T: Display>(&mut self, items: impl IntoIterator<Item = T>) -> &mut Self {
        for (k, item) in items.into_iter().enumerate() {
            self.line(format_args!("{}. {item}", k + 1));
        }
        self
    }

    /// A table's header and its rule with every column in the default alignment; rows
    /// follow with [`Md::row`].
    pub(crate) fn table<T: Display>(&mut self, header: impl IntoIterator<Item = T>) -> &mut Self {
        let header: Vec<String> = header.into_iter().map(|h| h.to_string()).collect();
        let align = "l".repeat(header.len());
        self.table_aligned(header, &align)
    }

    /// A table's header and its rule, column `k` aligned as character `k` of `align`
    /// says: `r` right (`---:`), anything else the default (`---`).
    pub(crate) fn table_aligned<T: Display>(
        &mut self,
        header: impl IntoIterator<Item = T>,
        align: &str,
    ) -> &mut Self {
        self.row(header);
        self.s.push('|');
        for a in align.chars() {
            self.s.push_str(match Align::from(a) {
                Align::Default => "---|",
                Align::Right => "---:|",
            });
        }
        self.nl()
    }

    /// One table row: `| a | b |`. A `|` inside a cell (an absolute value `|E0|`, a
    /// file's own text) is written `\|` and a line break as a space, so that no cell's
    /// text can split or end the row.
    pub(crate) fn row<T: Display>(&mut self, cells: impl IntoIterator<Item = T>) -> &mut Self {
        self.s.push('|');
        for c in cells {
            let text = c.to_string();
            let mut cell = String::with_capacity(text.len() + 2);
            let mut escaped = false;
            for ch in text.chars() {
                match ch {
                    '|' if !escaped => cell.push_str("\\|"),
                    '\n' | '\r' => cell.push(' '),
                    _ => cell.push(ch),
                }
                escaped = ch == '\\' && !escaped;
            }
            self.raw(format_args!(" {cell} |"));
        }
        self.nl()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_and_paragraphs_end_with_a_blank_line() {
        let mut md = Md::new();
        md.heading(1, "Title")
            .para("Regenerate with `x`.")
            .bullet("one")
            .bullet(2)
            .nl()
            .heading(2, "Next")
            .line("a line")
            .nl()
            .heading(2, "Last")
            .para("end");
        assert_eq!(
            md.finish(),
            "# Title\n\nRegenerate with `x`.\n\n- one\n- 2\n\n## Next\n\na line\n\n## Last\n\nend\n\n"
        );
    }

    #[test]
    fn tables_write_header_rule_and_rows() {
        let mut md = Md::new();
        md.table(["axis", "value µm"])
            .row(["x", "1.000"])
            .row(["", ""]);
        assert_eq!(
            md.finish(),
            "| axis | value µm |\n|---|---|\n| x | 1.000 |\n|  |  |\n"
        );
    }

    #[test]
    fn the_alignment_row_follows_the_columns() {
        let mut md = Md::new();
        md.table_aligned(["a", "b", "c"], "lrr").row(vec![
            String::from("1"),
            "2".into(),
            "3".into(),
        ]);
        assert_eq!(
            md.finish(),
            "| a | b | c |\n|---|---:|---:|\n| 1 | 2 | 3 |\n"
        );
    }

    #[test]
    fn lists() {
        let mut md = Md::new();
        md.bullets(["a", "b"]).numbered(["x", "y"]);
        assert_eq!(md.finish(), "- a\n- b\n1. x\n2. y\n");
    }

    #[test]
    fn a_bar_or_line_break_in_a_cell_cannot_split_the_row() {
        let mut md = Md::new();
        md.row(["a|b", "largest |E0|", "x\\|y", "two\nlines"]);
        assert_eq!(
            md.finish(),
            "| a\\|b | largest \\|E0\\| | x\\|y | two lines |\n"
        );
    }
}
