//! FANUC's part-program words ([`ProgramSyntax`]); the words and their sources are in
//! the [module docs of `fanuc`](super).

use super::Fanuc;
use crate::controller::Dialect;
use crate::controller::program::{ProgramError, ProgramKind, ProgramSyntax, iso_move};

/// The program number written (`O0230`, after ISO 230).
pub const PROGRAM_NUMBER: u32 = 230;

/// The largest `G04 P` (ms).
pub const MAX_DWELL_MS: u64 = 99_999_999;

impl ProgramSyntax for Fanuc {
    fn name(&self) -> &'static str {
        Dialect::name(self)
    }
    fn extension(&self) -> &'static str {
        "nc"
    }
    /// Upper case, ASCII letters, digits, spaces and `.,-+=:/` only (no parentheses).
    fn comment(&self, text: &str) -> String {
        let words = text
            .to_ascii_uppercase()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || " .,-+=:/".contains(c) {
                    c
                } else {
                    ' '
                }
            })
            .collect::<String>();
        format!(
            "({})",
            words.split_whitespace().collect::<Vec<_>>().join(" ")
        )
    }
    fn begin(&self, kind: ProgramKind) -> Vec<String> {
        vec![
            "%".into(),
            format!("O{PROGRAM_NUMBER:04} (ERRMAP {})", kind.title()),
        ]
    }
    fn setup(&self) -> Option<&'static str> {
        Some("G21 G90 G94")
    }
    fn feed_move(&self, axes: &[(&str, f64)], feed: Option<&str>) -> String {
        iso_move("G01", axes, feed)
    }
    fn dwell(&self, dwell_s: f64) -> Result<Vec<String>, ProgramError> {
        let ms = (dwell_s * 1000.0).round();
        if ms > MAX_DWELL_MS as f64 {
            return Err(ProgramError::DwellTooLong {
                dialect: ProgramSyntax::name(self),
                dwell_s,
                max_s: MAX_DWELL_MS as f64 / 1000.0,
            });
        }
        if ms < 1.0 {
            return Err(ProgramError::DwellTooShort {
                dialect: ProgramSyntax::name(self),
                dwell_s,
                min_s: 0.001,
            });
        }
        Ok(vec![format!("G04 P{}", ms as u64)])
    }
    fn stop(&self) -> &'static str {
        "M00"
    }
    fn end(&self, _: ProgramKind) -> Vec<String> {
        vec!["M30".into(), "%".into()]
    }
}
