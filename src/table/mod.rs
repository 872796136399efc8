//! Error tables: one row per node, `x_mm,y_mm,z_mm,e_um[,n,s_um,n_eff]` (see
//! `docs/session-table.md`; `n_eff`, the effective sample count of correlated dwell samples,
//! is errmap's own optional column: tables without it read as before).
//!
//! Tables are read and written as CSV or Parquet with polars, chosen by the file extension.
//! Every cell is validated once, here, so that the interpolators can trust their input:
//! missing columns, non-numeric cells, NaN/inf, values outside their physical range
//! (positions ±10⁶ mm, errors ±10⁶ µm: [`crate::base::limits`]), duplicate nodes,
//! scattered nodes that do not form a rectilinear grid, and axes with fewer than two nodes
//! are each reported with the file, the data row (1-based, header excluded; the CSV line
//! is row + 1) and the column. Before the cells, the structure: a column name given twice
//! and a CSV row with more or fewer fields than the header are errors (`structure.rs`).
//! A coordinate written `-0` is 0. Outputs are written whole or not at all and never hold
//! a NaN (`output.rs`).

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
    /// Effective sample count of `e_um` (1 ≤ n_eff ≤ n): the n samples are correlated in
    /// time, so the standard uncertainty of the mean is s/√n_eff, not s/√n. When known.
    pub n_eff: Option<f64>,
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
            n_eff: None,
        }
    }

    /// Standard uncertainty of `e_um` from its samples, µm: s/√n_eff, or s/√n when the
    /// effective count is unknown; None without s or n.
    pub fn u_um(&self) -> Option<f64> {
        let s = self.s_um?;
        let n = self.n_eff.or(self.n.map(f64::from))?;
        (n >= 1.0).then(|| s / n.sqrt())
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

mod error;
mod frame;
mod grid;
mod output;
mod structure;

pub use error::{MISSING_LISTED, TableError};
pub(crate) use frame::{
    Cells, column_cells, format_err, is_parquet, optional_column_cells, output_is_parquet,
    parse_cell, required_cell, text_or_number_cells,
};
pub use frame::{read_frame, write_frame, write_predictions};
pub use grid::{Extent, Grid, interval};
pub use output::{
    OutputTarget, check_finite, output_target, remove_temporaries, temporary, write_atomically,
};
pub(crate) use structure::{check_csv, finish_parquet, guarded, parquet_reader};

const REQUIRED: [&str; 4] = ["x_mm", "y_mm", "z_mm", "e_um"];

/// The closest two coordinates of a grid axis may be, mm (a nanometre): closer nodes are
/// a typing error, and the interpolators' divisions by the spacing would overflow.
pub const MIN_NODE_SPACING_MM: f64 = 1e-6;

use crate::base::{ERROR_UM, POSITION_MM};

/// A cell outside its physical range ([`crate::base::limits`]).
fn out_of_range(path: &Path, row0: usize, column: &str, problem: String) -> TableError {
    TableError::BadValue {
        path: path.to_path_buf(),
        row: row0 + 1,
        line: row0 + 2,
        column: column.to_string(),
        problem,
    }
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
        let n_cells = optional_column_cells(path, df, "n")?;
        let s_cells = optional_column_cells(path, df, "s_um")?;
        let neff_cells = optional_column_cells(path, df, "n_eff")?;
        let mut points = Vec::with_capacity(rows);
        for r in 0..rows {
            let mut v = [0.0, 0.0, 0.0, f64::NAN];
            for (k, cells) in required.iter().enumerate() {
                v[k] = required_cell(path, cells, r, names[k])?;
                let bound = if k < 3 { POSITION_MM } else { ERROR_UM };
                bound
                    .check(v[k])
                    .map_err(|problem| out_of_range(path, r, names[k], problem.to_string()))?;
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
            if let Some(s) = s_um
                && !(0.0..=ERROR_UM.hi).contains(&s)
            {
                let problem = format!(
                    "{s:e} is not a standard deviation within 0 … {} µm",
                    ERROR_UM.hi
                );
                return Err(out_of_range(path, r, "s_um", problem));
            }
            let n_eff = match &neff_cells {
                Some(c) => parse_cell(path, c, r, "n_eff")?,
                None => None,
            };
            if let Some(ne) = n_eff {
                let most = n.map_or(f64::from(u32::MAX), f64::from);
                if !(1.0..=most).contains(&ne) {
                    let problem =
                        format!("{ne} is not an effective sample count within 1 … n ({most})");
                    return Err(out_of_range(path, r, "n_eff", problem));
                }
            }
            points.push(ErrorPoint {
                x_mm: v[0],
                y_mm: v[1],
                z_mm: v[2],
                e_um: v[3],
                n,
                s_um,
                n_eff,
            });
        }
        // Extra numeric columns: kept, never fatal.
        let mut extra = Vec::new();
        for name in df.get_column_names() {
            let name = name.as_str();
            if REQUIRED.contains(&name) || ["n", "s_um", "n_eff"].contains(&name) {
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
            // `+ 0.0` turns −0 into 0: one node, however it was written.
            let mut v: Vec<f64> = self.points.iter().map(|p| p.position()[a] + 0.0).collect();
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
        // Saturating: a scattered table of n nodes spans up to n³ grid nodes, which is
        // never allocated — only the present nodes are indexed.
        let (nx, ny) = (xs.len() as u128, ys.len() as u128);
        let grid_nodes = nx * ny * zs.len() as u128;
        let expected = usize::try_from(grid_nodes).unwrap_or(usize::MAX);
        let find = |v: &[f64], x: f64| v.binary_search_by(|p| p.total_cmp(&x)).ok();
        let mut present = std::collections::HashMap::with_capacity(self.points.len());
        for p in &self.points {
            // Every coordinate is one of the axis values by construction.
            if let (Some(i), Some(j), Some(k)) = (
                find(&xs, p.x_mm + 0.0),
                find(&ys, p.y_mm + 0.0),
                find(&zs, p.z_mm + 0.0),
            ) {
                present.insert(i as u128 + nx * (j as u128 + ny * k as u128), p.e_um);
            }
        }
        let node = |idx: u128| {
            let i = (idx % nx) as usize;
            let j = ((idx / nx) % ny) as usize;
            let k = (idx / (nx * ny)) as usize;
            [xs[i], ys[j], zs[k]]
        };
        // The first missing nodes in index order: found within present + MISSING_LISTED
        // steps, however large `expected` is.
        let mut missing = (0..grid_nodes)
            .filter(|idx| !present.contains_key(idx))
            .map(node);
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
        // A full grid: its spacing must be one interpolation can divide by.
        for (a, v) in [&xs, &ys, &zs].into_iter().enumerate() {
            if let Some(w) = v.windows(2).find(|w| w[1] - w[0] < MIN_NODE_SPACING_MM) {
                return Err(TableError::NodesTooClose {
                    path: self.path(),
                    axis: ['x', 'y', 'z'][a],
                    a: w[0],
                    b: w[1],
                    min_mm: MIN_NODE_SPACING_MM,
                });
            }
        }
        let values = (0..grid_nodes).map(|idx| present[&idx]).collect();
        Ok(Grid { xs, ys, zs, values })
    }

    /// The values of an extra column by name.
    pub fn extra_column(&self, name: &str) -> Option<&ExtraColumn> {
        self.extra.iter().find(|c| c.name == name)
    }

    /// Writes the table (required columns, then `n`/`s_um`/`n_eff` when any row has them).
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
        if self.points.iter().any(|p| p.n_eff.is_some()) {
            cols.push(Column::new(
                "n_eff".into(),
                self.points
                    .iter()
                    .map(|p| p.n_eff)
                    .collect::<Vec<Option<f64>>>(),
            ));
        }
        DataFrame::new(self.points.len(), cols)
    }
}
