//! A campaign of measured lines in space as a part program sees it ([`LinesProgram`]):
//! the volumetric plans' lines, in the order they are visited. The programs themselves —
//! this campaign or a [`TestPlan`](super::TestPlan)'s test cycle in a controller's
//! syntax — are written by `controller::program`.

/// One measured line: its targets in the order they are visited, and its runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramLine {
    pub name: String,
    pub targets_mm: Vec<[f64; 3]>,
    pub runs: u32,
    /// Where the retroreflector sits relative to the tool point, mm (for the comment).
    pub probe_mm: [f64; 3],
}

/// A campaign: its lines, the feed of every move and the dwell at every target.
#[derive(Debug, Clone, PartialEq)]
pub struct LinesProgram {
    pub title: String,
    pub lines: Vec<ProgramLine>,
    pub feed_mm_s: f64,
    pub dwell_s: f64,
}
