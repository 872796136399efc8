//! A controller table (read by the controller stage, [`crate::controller::read`]) as an
//! error table: one row per table point, e = the mean of the two directions, and
//! `import --json`'s summary.

use std::path::Path;

use polars::prelude::{Column, DataFrame};
use serde::Serialize;

use super::{ImportSummary, snap};
use crate::base::Axis;
use crate::controller::ControllerTable;
use crate::table::{TableError, write_frame};

/// One row of the error table written from a controller table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TableRow {
    pub point: usize,
    pub xyz_mm: [f64; 3],
    pub e_um: f64,
    pub e_up_um: f64,
    pub e_down_um: f64,
}

impl ControllerTable {
    /// The error table's rows along `axis`: one per point, in file order, e = mean of the
    /// two directions.
    pub fn rows(&self, axis: Axis) -> Vec<TableRow> {
        self.points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut xyz = [0.0; 3];
                xyz[axis.index()] = snap(p.position_mm);
                TableRow {
                    point: i + 1,
                    xyz_mm: xyz,
                    e_um: snap(0.5 * (p.e_up_um + p.e_down_um)),
                    e_up_um: snap(p.e_up_um),
                    e_down_um: snap(p.e_down_um),
                }
            })
            .collect()
    }

    /// `import --json`'s summary for this table.
    pub fn summary(&self, axis: Axis, warnings: Vec<String>) -> ImportSummary {
        ImportSummary {
            format: self.format.name(),
            rows: self.points.len(),
            runs: None,
            targets: self.points.len(),
            directions: if self.bidirectional { 2 } else { 1 },
            units_in: self.format.units().name(),
            axis: axis.upper(),
            machine: None,
            warnings,
            axis_warning: None,
        }
    }
}

/// Writes `point,x_mm,y_mm,z_mm,e_um,e_up_um,e_down_um` (CSV or Parquet by extension),
/// whole or not at all.
pub fn write_error_table(path: &Path, rows: &[TableRow]) -> Result<(), TableError> {
    let n = rows.len();
    let col = |name: &str, f: &dyn Fn(&TableRow) -> f64| {
        Column::new(name.into(), rows.iter().map(f).collect::<Vec<f64>>())
    };
    let cols = vec![
        Column::new(
            "point".into(),
            rows.iter().map(|r| r.point as i64).collect::<Vec<i64>>(),
        ),
        col("x_mm", &|r| r.xyz_mm[0]),
        col("y_mm", &|r| r.xyz_mm[1]),
        col("z_mm", &|r| r.xyz_mm[2]),
        col("e_um", &|r| r.e_um),
        col("e_up_um", &|r| r.e_up_um),
        col("e_down_um", &|r| r.e_down_um),
    ];
    let mut df = DataFrame::new(n, cols).map_err(|e| TableError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(path, &mut df)
}
