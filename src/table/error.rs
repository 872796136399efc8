//! [`TableError`]: what can be wrong with a table file, naming the file, row and column.

use std::path::PathBuf;

use crate::base::FileError;

/// What can be wrong with a table file. Rows are 1-based data rows (the header is not
/// counted; in a CSV file data row r is on line r + 1).
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The file cannot be opened, read or written (the shared [`FileError`] shape).
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error(
        "{path}: not written: the directory {dir} does not exist (create it first; errmap does not make directory trees)"
    )]
    MissingDirectory { path: PathBuf, dir: PathBuf },
    #[error(
        "{path}: not written: it is {kind}, not a file (errmap writes regular files, and writes through to character devices and pipes)"
    )]
    NotAFile { path: PathBuf, kind: &'static str },
    #[error("{path}: unsupported extension (use .csv or .parquet)")]
    Extension { path: PathBuf },
    #[error("{path}: required column `{column}` is missing (columns found: {found})")]
    MissingColumn {
        path: PathBuf,
        column: String,
        found: String,
    },
    #[error("{path}: no data rows")]
    Empty { path: PathBuf },
    #[error("{path}: row {row} (line {line}), column `{column}`: `{value}` is not a number")]
    NotNumeric {
        path: PathBuf,
        row: usize,
        line: usize,
        column: String,
        value: String,
    },
    #[error("{path}: row {row} (line {line}), column `{column}`: empty cell in a required column")]
    EmptyCell {
        path: PathBuf,
        row: usize,
        line: usize,
        column: String,
    },
    #[error("{path}: row {row} (line {line}), column `{column}`: value {value} is not finite")]
    NonFinite {
        path: PathBuf,
        row: usize,
        line: usize,
        column: String,
        value: f64,
    },
    #[error("{path}: row {row} (line {line}), column `{column}`: {problem}")]
    BadValue {
        path: PathBuf,
        row: usize,
        line: usize,
        column: String,
        problem: String,
    },
    #[error(
        "{path}: row {row} (line {line}) repeats the node ({x}, {y}, {z}) mm of row {first_row}; \
         average repeated measurements before fitting"
    )]
    DuplicateNode {
        path: PathBuf,
        row: usize,
        line: usize,
        first_row: usize,
        x: f64,
        y: f64,
        z: f64,
    },
    #[error(
        "{path}: the nodes do not form a rectilinear grid: {} ({present} of {expected} grid nodes \
         present)",
        describe_missing([*x, *y, *z], more, expected - present)
    )]
    MissingNode {
        path: PathBuf,
        /// The first missing node.
        x: f64,
        y: f64,
        z: f64,
        /// The next few missing nodes (at most [`MISSING_LISTED`] − 1).
        more: Vec<[f64; 3]>,
        present: usize,
        expected: usize,
    },
    #[error(
        "{path}: {count} node(s) at one position; interpolation needs at least 2 nodes along some axis"
    )]
    TooFewNodes { path: PathBuf, count: usize },
    #[error(
        "{path}: the {axis} coordinates {a:e} and {b:e} mm of two grid nodes are closer than {min_mm:e} mm; \
         no interpolation is meaningful across that gap (a typing error?)"
    )]
    NodesTooClose {
        path: PathBuf,
        axis: char,
        a: f64,
        b: f64,
        min_mm: f64,
    },
    #[error(
        "{path}: column `{column}` appears {count} times in the header; which one holds the data is ambiguous"
    )]
    DuplicateColumn {
        path: PathBuf,
        column: String,
        count: usize,
    },
    #[error("{path}: row {row} (line {line}) is not valid UTF-8 text")]
    NotUtf8 {
        path: PathBuf,
        row: usize,
        line: usize,
    },
    #[error(
        "{path}: row {row} (line {line}) repeats (run, sample) = ({run}, {sample}) of row {first_row}; \
         a sample index is unique within its run"
    )]
    DuplicateSample {
        path: PathBuf,
        row: usize,
        line: usize,
        first_row: usize,
        run: u32,
        sample: i64,
    },
    #[error(
        "{path}: not written: row {row}, column `{column}` would hold {value} (a bug: every output value must be finite)"
    )]
    NonFiniteOutput {
        path: PathBuf,
        row: usize,
        column: String,
        value: f64,
    },
}

/// "node (x, y, z) mm is missing", or "nodes (…), (…), … mm are missing" for several.
fn describe_missing(first: [f64; 3], more: &[[f64; 3]], missing: usize) -> String {
    let mut names: Vec<String> = std::iter::once(first)
        .chain(more.iter().copied())
        .map(|[x, y, z]| format!("({x}, {y}, {z})"))
        .collect();
    if missing > names.len() {
        names.push("…".into());
    }
    if names.len() == 1 {
        format!("node {} mm is missing", names[0])
    } else {
        format!("nodes {} mm are missing", names.join(", "))
    }
}

/// How many missing grid nodes [`TableError::MissingNode`] names.
pub const MISSING_LISTED: usize = 5;
