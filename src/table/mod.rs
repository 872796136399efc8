//! Error tables: one row per node, `x_mm,y_mm,z_mm,e_um[,n,s_um]` (spec `session-table.md`).
//!
//! Tables are read and written as CSV or Parquet with polars, chosen by the file extension.
//! Every cell is validated once, here, so that the interpolators can trust their input:
//! missing columns, non-numeric cells, NaN/inf, duplicate nodes, scattered nodes that do
//! not form a rectilinear grid, and axes with fewer than two nodes are each reported with
//! the file, the data row (1-based, header excluded; the CSV line is row + 1) and the
//! column.

use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};

use polars::prelude::*;

/// One node of an error table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorPoint {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// Error at the node, e = indicated − reference, micrometres.
    pub e_um: f64,
    /// Samples averaged into `e_um`, when known.
    pub n: Option<u32>,
    /// Standard deviation of those samples, micrometres, when known.
    pub s_um: Option<f64>,
}

impl ErrorPoint {
    pub fn new(x_mm: f64, y_mm: f64, z_mm: f64, e_um: f64) -> Self {
        Self {
            x_mm,
            y_mm,
            z_mm,
            e_um,
            n: None,
            s_um: None,
        }
    }

    pub fn position(&self) -> [f64; 3] {
        [self.x_mm, self.y_mm, self.z_mm]
    }
}

/// A column of extra numbers kept from the file (e.g. the paper's `paper_4x1x2`).
#[derive(Debug, Clone, PartialEq)]
pub struct ExtraColumn {
    pub name: String,
    /// One value per row; `None` where the cell was empty or not a number.
    pub values: Vec<Option<f64>>,
}

/// A validated error (or test-point) table: finite numbers in every required cell.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorTable {
    /// Where the table came from (a path, or a description for tables built in memory).
    pub source: String,
    pub points: Vec<ErrorPoint>,
    /// Numeric columns beyond the required ones, kept for reports and otherwise ignored.
    pub extra: Vec<ExtraColumn>,
}

pub use crate::base::Axis;

/// What can be wrong with a table file. Rows are 1-based data rows (the header is not
/// counted; in a CSV file data row r is on line r + 1).
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    #[error("{path}: cannot read or write: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
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
}

const REQUIRED: [&str; 4] = ["x_mm", "y_mm", "z_mm", "e_um"];

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

fn format_err(path: &Path, e: impl fmt::Display) -> TableError {
    TableError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn is_parquet(path: &Path) -> Result<bool, TableError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("csv") | Some("txt") => Ok(false),
        Some("parquet") | Some("pq") => Ok(true),
        _ => Err(TableError::Extension {
            path: path.to_path_buf(),
        }),
    }
}

/// Reads any table (CSV with every column as text, or Parquet) into a DataFrame.
///
/// CSV is read with all columns as strings so that a bad cell is reported by its row
/// and column here rather than silently turning a whole column into text.
pub fn read_frame(path: &Path) -> Result<DataFrame, TableError> {
    if is_parquet(path)? {
        let file = File::open(path).map_err(|source| TableError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        ParquetReader::new(file)
            .finish()
            .map_err(|e| format_err(path, e))
    } else {
        // Open first so that a missing file is an I/O error with the OS's words.
        File::open(path).map_err(|source| TableError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        CsvReadOptions::default()
            .with_has_header(true)
            .with_infer_schema_length(Some(0))
            .try_into_reader_with_file_path(Some(path.to_path_buf()))
            .and_then(|r| r.finish())
            .map_err(|e| format_err(path, e))
    }
}

/// Writes a DataFrame as CSV or Parquet by extension, creating the parent directory.
pub fn write_frame(path: &Path, df: &mut DataFrame) -> Result<(), TableError> {
    let parquet = is_parquet(path)?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|source| TableError::Io {
            path: parent.to_path_buf(),
            source,
        })?;
    }
    let mut file = File::create(path).map_err(|source| TableError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if parquet {
        ParquetWriter::new(&mut file)
            .finish(df)
            .map(|_| ())
            .map_err(|e| format_err(path, e))
    } else {
        CsvWriter::new(&mut file)
            .include_header(true)
            .finish(df)
            .map_err(|e| format_err(path, e))
    }
}

/// A column's cells as optional text (CSV) or optional f64 (Parquet), row by row.
pub(crate) enum Cells {
    Text(Vec<Option<String>>),
    Number(Vec<Option<f64>>),
}

pub(crate) fn column_cells(path: &Path, df: &DataFrame, name: &str) -> Result<Cells, TableError> {
    let col = df
        .column(name)
        .map_err(|_| TableError::MissingColumn {
            path: path.to_path_buf(),
            column: name.to_string(),
            found: df
                .get_column_names()
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })?
        .as_materialized_series();
    if let Ok(ca) = col.str() {
        return Ok(Cells::Text(
            ca.iter().map(|v| v.map(str::to_string)).collect(),
        ));
    }
    let cast = col
        .cast(&DataType::Float64)
        .map_err(|e| format_err(path, format!("column `{name}`: {e}")))?;
    let ca = cast
        .f64()
        .map_err(|e| format_err(path, format!("column `{name}`: {e}")))?;
    Ok(Cells::Number(ca.iter().collect()))
}

/// Parses one cell; `Ok(None)` for an empty cell.
pub(crate) fn parse_cell(
    path: &Path,
    cells: &Cells,
    row0: usize,
    column: &str,
) -> Result<Option<f64>, TableError> {
    let row = row0 + 1;
    let v = match cells {
        Cells::Number(v) => v[row0],
        Cells::Text(v) => match v[row0].as_deref().map(str::trim) {
            None | Some("") => None,
            Some(s) => Some(s.parse::<f64>().map_err(|_| TableError::NotNumeric {
                path: path.to_path_buf(),
                row,
                line: row + 1,
                column: column.to_string(),
                value: s.to_string(),
            })?),
        },
    };
    if let Some(value) = v
        && !value.is_finite()
    {
        return Err(TableError::NonFinite {
            path: path.to_path_buf(),
            row,
            line: row + 1,
            column: column.to_string(),
            value,
        });
    }
    Ok(v)
}

pub(crate) fn required_cell(
    path: &Path,
    cells: &Cells,
    row0: usize,
    column: &str,
) -> Result<f64, TableError> {
    parse_cell(path, cells, row0, column)?.ok_or_else(|| TableError::EmptyCell {
        path: path.to_path_buf(),
        row: row0 + 1,
        line: row0 + 2,
        column: column.to_string(),
    })
}

impl ErrorTable {
    /// Reads and validates an error table or test-point table. Duplicate nodes are an
    /// error; whether the nodes form a grid is checked by [`ErrorTable::grid`].
    pub fn read(path: &Path) -> Result<Self, TableError> {
        let df = read_frame(path)?;
        Self::from_frame(path, &df)
    }

    pub fn from_frame(path: &Path, df: &DataFrame) -> Result<Self, TableError> {
        let table = Self::parse(path, df, true)?;
        table.check_duplicates()?;
        Ok(table)
    }

    /// Reads query points: `x_mm,y_mm,z_mm` required, `e_um` optional (NaN where absent),
    /// repeated positions allowed.
    pub fn read_points(path: &Path) -> Result<Self, TableError> {
        let df = read_frame(path)?;
        Self::parse(path, &df, false)
    }

    fn parse(path: &Path, df: &DataFrame, require_e: bool) -> Result<Self, TableError> {
        let has_e = require_e || df.column("e_um").is_ok();
        let names = if has_e { &REQUIRED[..] } else { &REQUIRED[..3] };
        let required = names
            .iter()
            .map(|c| column_cells(path, df, c))
            .collect::<Result<Vec<_>, _>>()?;
        let rows = df.height();
        if rows == 0 {
            return Err(TableError::Empty {
                path: path.to_path_buf(),
            });
        }
        let n_cells = df
            .column("n")
            .ok()
            .map(|_| column_cells(path, df, "n"))
            .transpose()?;
        let s_cells = df
            .column("s_um")
            .ok()
            .map(|_| column_cells(path, df, "s_um"))
            .transpose()?;
        let mut points = Vec::with_capacity(rows);
        for r in 0..rows {
            let mut v = [0.0, 0.0, 0.0, f64::NAN];
            for (k, cells) in required.iter().enumerate() {
                v[k] = required_cell(path, cells, r, names[k])?;
            }
            let n = match &n_cells {
                Some(c) => match parse_cell(path, c, r, "n")? {
                    None => None,
                    Some(x) if x >= 0.0 && x.fract() == 0.0 && x <= f64::from(u32::MAX) => {
                        Some(x as u32)
                    }
                    Some(x) => {
                        return Err(TableError::BadValue {
                            path: path.to_path_buf(),
                            row: r + 1,
                            line: r + 2,
                            column: "n".into(),
                            problem: format!("{x} is not a sample count"),
                        });
                    }
                },
                None => None,
            };
            let s_um = match &s_cells {
                Some(c) => parse_cell(path, c, r, "s_um")?,
                None => None,
            };
            points.push(ErrorPoint {
                x_mm: v[0],
                y_mm: v[1],
                z_mm: v[2],
                e_um: v[3],
                n,
                s_um,
            });
        }
        // Extra numeric columns: kept, never fatal.
        let mut extra = Vec::new();
        for name in df.get_column_names() {
            let name = name.as_str();
            if REQUIRED.contains(&name) || name == "n" || name == "s_um" {
                continue;
            }
            if let Ok(cells) = column_cells(path, df, name) {
                let values = (0..rows)
                    .map(|r| parse_cell(path, &cells, r, name).ok().flatten())
                    .collect();
                extra.push(ExtraColumn {
                    name: name.to_string(),
                    values,
                });
            }
        }
        Ok(ErrorTable {
            source: path.display().to_string(),
            points,
            extra,
        })
    }

    /// A table built in memory (tests, simulations).
    pub fn from_points(source: impl Into<String>, points: Vec<ErrorPoint>) -> Self {
        Self {
            source: source.into(),
            points,
            extra: Vec::new(),
        }
    }

    fn path(&self) -> PathBuf {
        PathBuf::from(&self.source)
    }

    fn check_duplicates(&self) -> Result<(), TableError> {
        let mut order: Vec<usize> = (0..self.points.len()).collect();
        let key = |i: usize| self.points[i].position();
        order.sort_by(|&a, &b| {
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(a.cmp(&b))
        });
        for w in order.windows(2) {
            if key(w[0]) == key(w[1]) {
                let (first, dup) = (w[0].min(w[1]), w[0].max(w[1]));
                let p = self.points[dup];
                return Err(TableError::DuplicateNode {
                    path: self.path(),
                    row: dup + 1,
                    line: dup + 2,
                    first_row: first + 1,
                    x: p.x_mm,
                    y: p.y_mm,
                    z: p.z_mm,
                });
            }
        }
        Ok(())
    }

    /// Arranges the nodes as a rectilinear grid, or says which node is missing. An axis
    /// may have a single node (a table measured on one line or in one plane: the models
    /// are constant along it), but at least one axis needs two.
    pub fn grid(&self) -> Result<Grid, TableError> {
        let mut axes: [Vec<f64>; 3] = Default::default();
        for (a, axis) in axes.iter_mut().enumerate() {
            let mut v: Vec<f64> = self.points.iter().map(|p| p.position()[a]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            *axis = v;
        }
        if axes.iter().all(|v| v.len() < 2) {
            return Err(TableError::TooFewNodes {
                path: self.path(),
                count: self.points.len(),
            });
        }
        let [xs, ys, zs] = axes;
        let expected = xs.len() * ys.len() * zs.len();
        let mut values = vec![f64::NAN; expected];
        let mut filled = vec![false; expected];
        let find = |v: &[f64], x: f64| v.binary_search_by(|p| p.total_cmp(&x)).ok();
        for p in &self.points {
            // Every coordinate is one of the axis values by construction.
            if let (Some(i), Some(j), Some(k)) =
                (find(&xs, p.x_mm), find(&ys, p.y_mm), find(&zs, p.z_mm))
            {
                let idx = i + xs.len() * (j + ys.len() * k);
                values[idx] = p.e_um;
                filled[idx] = true;
            }
        }
        let node = |idx: usize| {
            let i = idx % xs.len();
            let j = (idx / xs.len()) % ys.len();
            let k = idx / (xs.len() * ys.len());
            [xs[i], ys[j], zs[k]]
        };
        let mut missing = (0..expected).filter(|&idx| !filled[idx]).map(node);
        if let Some([x, y, z]) = missing.next() {
            return Err(TableError::MissingNode {
                path: self.path(),
                x,
                y,
                z,
                more: missing.take(MISSING_LISTED - 1).collect(),
                present: self.points.len(),
                expected,
            });
        }
        Ok(Grid { xs, ys, zs, values })
    }

    /// The values of an extra column by name.
    pub fn extra_column(&self, name: &str) -> Option<&ExtraColumn> {
        self.extra.iter().find(|c| c.name == name)
    }

    /// Writes the table (required columns, then `n`/`s_um` when any row has them).
    pub fn write(&self, path: &Path) -> Result<(), TableError> {
        let mut df = self.to_frame().map_err(|e| format_err(path, e))?;
        write_frame(path, &mut df)
    }

    pub fn to_frame(&self) -> PolarsResult<DataFrame> {
        let col = |name: &str, f: &dyn Fn(&ErrorPoint) -> f64| {
            Column::new(name.into(), self.points.iter().map(f).collect::<Vec<f64>>())
        };
        let mut cols = vec![
            col("x_mm", &|p| p.x_mm),
            col("y_mm", &|p| p.y_mm),
            col("z_mm", &|p| p.z_mm),
            col("e_um", &|p| p.e_um),
        ];
        if self.points.iter().any(|p| p.n.is_some()) {
            cols.push(Column::new(
                "n".into(),
                self.points
                    .iter()
                    .map(|p| p.n)
                    .collect::<Vec<Option<u32>>>(),
            ));
        }
        if self.points.iter().any(|p| p.s_um.is_some()) {
            cols.push(Column::new(
                "s_um".into(),
                self.points
                    .iter()
                    .map(|p| p.s_um)
                    .collect::<Vec<Option<f64>>>(),
            ));
        }
        DataFrame::new(self.points.len(), cols)
    }
}

/// A rectilinear grid of node errors: strictly increasing node coordinates per axis and
/// one value per node, x fastest (`values[i + nx·(j + ny·k)]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    pub zs: Vec<f64>,
    pub values: Vec<f64>,
}

impl Grid {
    /// Builds a grid from node coordinates and a function of position (tests, simulations).
    /// Axes may have a single node (the field is then constant along that axis).
    pub fn from_fn(
        xs: Vec<f64>,
        ys: Vec<f64>,
        zs: Vec<f64>,
        mut f: impl FnMut([f64; 3]) -> f64,
    ) -> Self {
        let mut values = Vec::with_capacity(xs.len() * ys.len() * zs.len());
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    values.push(f([x, y, z]));
                }
            }
        }
        Self { xs, ys, zs, values }
    }

    pub fn axis(&self, a: usize) -> &[f64] {
        match a {
            0 => &self.xs,
            1 => &self.ys,
            _ => &self.zs,
        }
    }

    pub fn shape(&self) -> [usize; 3] {
        [self.xs.len(), self.ys.len(), self.zs.len()]
    }

    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.xs.len() * (j + self.ys.len() * k)
    }

    pub fn value(&self, i: usize, j: usize, k: usize) -> f64 {
        self.values[self.index(i, j, k)]
    }

    /// Whether a point lies outside the node range on any axis.
    pub fn outside(&self, p: [f64; 3]) -> bool {
        (0..3).any(|a| {
            let v = self.axis(a);
            let (lo, hi) = (v[0], v[v.len() - 1]);
            let tol = 1e-9 * (hi - lo).abs().max(1.0);
            p[a] < lo - tol || p[a] > hi + tol
        })
    }

    /// The grid without plane `plane` along axis `a` (for leave-one-plane-out CV).
    pub fn without_plane(&self, a: usize, plane: usize) -> Grid {
        let mut axes = [self.xs.clone(), self.ys.clone(), self.zs.clone()];
        axes[a].remove(plane);
        let [nx, ny, _] = self.shape();
        let mut values = Vec::with_capacity(self.values.len());
        for (idx, &v) in self.values.iter().enumerate() {
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            if ijk[a] != plane {
                values.push(v);
            }
        }
        let [xs, ys, zs] = axes;
        Grid { xs, ys, zs, values }
    }

    /// The nodes as table points.
    pub fn points(&self) -> Vec<ErrorPoint> {
        let mut out = Vec::with_capacity(self.values.len());
        for (k, &z) in self.zs.iter().enumerate() {
            for (j, &y) in self.ys.iter().enumerate() {
                for (i, &x) in self.xs.iter().enumerate() {
                    out.push(ErrorPoint::new(x, y, z, self.value(i, j, k)));
                }
            }
        }
        out
    }
}

/// Locates `x` in strictly increasing `nodes`: the interval index `i` (clamped to
/// `0..=n−2`) with `nodes[i] ≤ x < nodes[i+1]` inside the range. Needs `n ≥ 2`.
#[inline]
pub fn interval(nodes: &[f64], x: f64) -> usize {
    let n = nodes.len();
    debug_assert!(n >= 2);
    // partition_point: first index whose node is > x.
    let p = nodes.partition_point(|&v| v <= x);
    p.saturating_sub(1).min(n - 2)
}

/// Writes predictions: `x_mm,y_mm,z_mm,e_um,extrapolated`, and `sigma_um` (one-sigma)
/// when any prediction has one.
pub fn write_predictions(
    path: &Path,
    preds: &[(ErrorPoint, bool)],
    sigmas: &[Option<f64>],
) -> Result<(), TableError> {
    let col = |name: &str, f: &dyn Fn(&ErrorPoint) -> f64| {
        Column::new(
            name.into(),
            preds.iter().map(|(p, _)| f(p)).collect::<Vec<f64>>(),
        )
    };
    let mut cols = vec![
        col("x_mm", &|p| p.x_mm),
        col("y_mm", &|p| p.y_mm),
        col("z_mm", &|p| p.z_mm),
        col("e_um", &|p| p.e_um),
        Column::new(
            "extrapolated".into(),
            preds.iter().map(|(_, e)| *e).collect::<Vec<bool>>(),
        ),
    ];
    if sigmas.iter().any(Option::is_some) {
        cols.push(Column::new("sigma_um".into(), sigmas.to_vec()));
    }
    let mut df = DataFrame::new(preds.len(), cols).map_err(|e| format_err(path, e))?;
    write_frame(path, &mut df)
}
