//! Line tables (spec `volumetric.md`, "Line table"): one row per target, grouped into
//! lines by the `line` column, read and written as CSV or Parquet through
//! [`crate::table`]'s frame readers and cell validation.
//!
//! Checks, each an error naming the file, the data row (1-based; CSV line = row + 1) and
//! the column, or the line: a missing required column, a non-numeric or non-finite cell;
//! a beam direction (ux, uy, uz) whose norm differs from 1 by more than 1e−6; rows of one
//! line disagreeing on u (by more than 1e−6) or on the probe offset (by more than
//! 1e−6 mm); a target more than 1 µm off the line through the line's first target along
//! u; a line with fewer than 3 distinct targets (positions along the line 1 µm apart);
//! `s_um` outside 1e−6 … 1e6 µm (a one-sigma, so positive; see [`UNCERTAINTY_UM`]). Rows of a line need not be contiguous; lines keep the order of
//! their first row and targets the order of the file.

use std::path::Path;

use polars::prelude::*;

use super::error::VolumetricError;
use super::model::dot;
use crate::base::{Bound, ERROR_UM, POSITION_MM, TEMPERATURE_C, TIME_S, UNCERTAINTY_UM};
use crate::table::{
    Cells, TableError, column_cells, format_err, optional_column_cells, parse_cell, read_frame,
    required_cell, text_or_number_cells, write_frame,
};

/// Tolerance on |u| − 1 and on the agreement of u between rows of a line.
pub(crate) const UNIT_TOL: f64 = 1e-6;
/// How far a target may lie off its line, mm.
pub(crate) const OFF_LINE_TOL_MM: f64 = 1e-3;
/// Fewest distinct targets of a line.
pub(crate) const MIN_TARGETS: usize = 3;

/// The most rows (targets of all lines) an identification takes. Its cost grows faster
/// than the rows (the decompositions of the design, the smoothing's iterations, the
/// leave-one-line-out scores): issue 40 item 10 measured 18.7 s at 10 780 rows and over
/// 20 s at 19 600, so a larger table is refused before any work, naming its size (a
/// campaign of 44 lines of 21 targets is under a thousand rows).
pub const MAX_IDENTIFY_ROWS: usize = 10_000;

/// One row of a line table.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Data row, 1-based (header excluded).
    pub row: usize,
    pub pos_mm: [f64; 3],
    /// Error along the line, indicated − reference, µm (absent in a table to predict).
    pub e_um: Option<f64>,
    pub s_um: Option<f64>,
    pub t_s: Option<f64>,
    pub scale_temp_c: Option<f64>,
    pub air_temp_c: Option<f64>,
    pub part_temp_c: Option<f64>,
}

impl Target {
    pub fn new(pos_mm: [f64; 3], e_um: f64) -> Target {
        Target {
            row: 0,
            pos_mm,
            e_um: Some(e_um),
            s_um: None,
            t_s: None,
            scale_temp_c: None,
            air_temp_c: None,
            part_temp_c: None,
        }
    }
}

/// One line: a beam direction, a probe offset and its targets.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    pub id: String,
    /// Unit beam direction.
    pub u: [f64; 3],
    pub probe_mm: [f64; 3],
    pub targets: Vec<Target>,
}

impl Line {
    /// Distance along the line from the first target, mm.
    pub fn s_mm(&self, t: &Target) -> f64 {
        let p0 = self.targets[0].pos_mm;
        dot(sub(t.pos_mm, p0), self.u)
    }
}

/// A validated line table.
#[derive(Debug, Clone, PartialEq)]
pub struct LineTable {
    pub source: String,
    pub lines: Vec<Line>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The physical range of a line-table column, by its unit suffix.
fn bound_of(column: &str) -> Bound {
    match column.rsplit('_').next() {
        _ if column == "s_um" => UNCERTAINTY_UM,
        Some("um") => ERROR_UM,
        Some("s") => TIME_S,
        Some("c") => TEMPERATURE_C,
        _ => POSITION_MM,
    }
}

fn bad(path: &Path, row: usize, column: &str, problem: String) -> VolumetricError {
    VolumetricError::Table(TableError::BadValue {
        path: path.to_path_buf(),
        row,
        line: row + 1,
        column: column.to_string(),
        problem,
    })
}

const OPTIONAL: [&str; 8] = [
    "px_mm",
    "py_mm",
    "pz_mm",
    "s_um",
    "t_s",
    "scale_temp_c",
    "air_temp_c",
    "part_temp_c",
];

impl LineTable {
    /// Reads and validates a line table; `e_um` is required when `require_e`.
    pub fn read(path: &Path, require_e: bool) -> Result<LineTable, VolumetricError> {
        let df = read_frame(path)?;
        Self::from_frame(path, &df, require_e)
    }

    pub fn from_frame(
        path: &Path,
        df: &DataFrame,
        require_e: bool,
    ) -> Result<LineTable, VolumetricError> {
        let cols = LineColumns::read(path, df, require_e)?;
        if df.height() == 0 {
            return Err(TableError::Empty {
                path: path.to_path_buf(),
            }
            .into());
        }
        let mut lines: Vec<Line> = Vec::new();
        let mut first_row: Vec<usize> = Vec::new();
        for r0 in 0..df.height() {
            let ParsedRow {
                id,
                u,
                probe,
                target,
            } = cols.row(path, r0)?;
            let row = target.row;
            match lines.iter_mut().position(|l| l.id == id) {
                None => {
                    first_row.push(row);
                    lines.push(Line {
                        id,
                        u,
                        probe_mm: probe,
                        targets: vec![target],
                    });
                }
                Some(i) => join_line(path, &mut lines[i], first_row[i], (u, probe), target)?,
            }
        }
        check_distinct_targets(path, &lines, &first_row)?;
        Ok(LineTable {
            source: path.display().to_string(),
            lines,
        })
    }

    /// Number of rows.
    pub fn targets(&self) -> usize {
        self.lines.iter().map(|l| l.targets.len()).sum()
    }

    /// Refuses a table larger than [`MAX_IDENTIFY_ROWS`] before any identification work,
    /// naming its size.
    pub fn check_identify_size(&self) -> Result<(), super::VolumetricError> {
        if self.targets() <= MAX_IDENTIFY_ROWS {
            return Ok(());
        }
        Err(super::VolumetricError::Fit {
            file: self.source.clone(),
            message: format!(
                "{} rows: identification takes at most {MAX_IDENTIFY_ROWS} (beyond it, it runs \
                 for more than 20 s); measure fewer targets per line, or fewer runs",
                self.targets()
            ),
        })
    }

    /// Writes the table (CSV or Parquet by extension); optional columns are written when
    /// any row has them.
    pub fn write(&self, path: &Path) -> Result<(), VolumetricError> {
        let rows: Vec<(&Line, &Target)> = self
            .lines
            .iter()
            .flat_map(|l| l.targets.iter().map(move |t| (l, t)))
            .collect();
        let num = |name: &str, f: &dyn Fn(&Line, &Target) -> f64| {
            Column::new(
                name.into(),
                rows.iter().map(|(l, t)| f(l, t)).collect::<Vec<f64>>(),
            )
        };
        let mut cols = vec![
            Column::new(
                "line".into(),
                rows.iter()
                    .map(|(l, _)| l.id.clone())
                    .collect::<Vec<String>>(),
            ),
            num("x_mm", &|_, t| t.pos_mm[0]),
            num("y_mm", &|_, t| t.pos_mm[1]),
            num("z_mm", &|_, t| t.pos_mm[2]),
            num("ux", &|l, _| l.u[0]),
            num("uy", &|l, _| l.u[1]),
            num("uz", &|l, _| l.u[2]),
            num("px_mm", &|l, _| l.probe_mm[0]),
            num("py_mm", &|l, _| l.probe_mm[1]),
            num("pz_mm", &|l, _| l.probe_mm[2]),
        ];
        type Getter<'a> = &'a dyn Fn(&Target) -> Option<f64>;
        let optional: [(&str, Getter); 6] = [
            ("e_um", &|t| t.e_um),
            ("s_um", &|t| t.s_um),
            ("t_s", &|t| t.t_s),
            ("scale_temp_c", &|t| t.scale_temp_c),
            ("air_temp_c", &|t| t.air_temp_c),
            ("part_temp_c", &|t| t.part_temp_c),
        ];
        for (name, f) in optional {
            if rows.iter().any(|(_, t)| f(t).is_some()) {
                cols.push(Column::new(
                    name.into(),
                    rows.iter().map(|(_, t)| f(t)).collect::<Vec<Option<f64>>>(),
                ));
            }
        }
        let mut df = DataFrame::new(rows.len(), cols).map_err(|e| format_err(path, e))?;
        Ok(write_frame(path, &mut df)?)
    }
}

/// The line table's columns, found before any row is read.
struct LineColumns {
    ids: Cells,
    /// x_mm, y_mm, z_mm, ux, uy, uz.
    req: Vec<Cells>,
    e_cells: Option<Cells>,
    require_e: bool,
    /// The `OPTIONAL` columns.
    opt: Vec<Option<Cells>>,
}

/// One row as read: its line, beam direction (normalised), probe offset and target.
struct ParsedRow {
    id: String,
    u: [f64; 3],
    probe: [f64; 3],
    target: Target,
}

impl LineColumns {
    /// Finds the required columns (and `e_um` when `require_e`) and the optional ones.
    fn read(path: &Path, df: &DataFrame, require_e: bool) -> Result<LineColumns, VolumetricError> {
        let ids = text_or_number_cells(path, df, "line")?;
        let req = ["x_mm", "y_mm", "z_mm", "ux", "uy", "uz"]
            .iter()
            .map(|c| column_cells(path, df, c))
            .collect::<Result<Vec<_>, _>>()?;
        let e_cells = if require_e || df.column("e_um").is_ok() {
            Some(column_cells(path, df, "e_um")?)
        } else {
            None
        };
        let opt: Vec<Option<Cells>> = OPTIONAL
            .iter()
            .map(|c| optional_column_cells(path, df, c))
            .collect::<Result<_, _>>()?;
        Ok(LineColumns {
            ids,
            req,
            e_cells,
            require_e,
            opt,
        })
    }

    /// Reads row `r0` (0-based) and checks it on its own: every value within the physical
    /// bounds, a unit beam direction.
    fn row(&self, path: &Path, r0: usize) -> Result<ParsedRow, VolumetricError> {
        let row = r0 + 1;
        let id = line_id(path, &self.ids, r0)?;
        let mut v = [0.0; 6];
        for (k, name) in ["x_mm", "y_mm", "z_mm", "ux", "uy", "uz"]
            .iter()
            .enumerate()
        {
            v[k] = required_cell(path, &self.req[k], r0, name)?;
        }
        let e_um = match &self.e_cells {
            Some(c) if self.require_e => Some(required_cell(path, c, r0, "e_um")?),
            Some(c) => parse_cell(path, c, r0, "e_um")?,
            None => None,
        };
        let mut o = [None; 8];
        for (k, cells) in self.opt.iter().enumerate() {
            if let Some(c) = cells {
                o[k] = parse_cell(path, c, r0, OPTIONAL[k])?;
            }
        }
        // Physical bounds at the door (`base::limits`): a position of 1e308 mm
        // passed the finiteness check and came out as NaN predictions.
        let values = [
            ("x_mm", Some(v[0])),
            ("y_mm", Some(v[1])),
            ("z_mm", Some(v[2])),
        ]
        .into_iter()
        .chain([("e_um", e_um)])
        .chain(OPTIONAL.iter().copied().zip(o));
        for (name, value) in values {
            if let Some(x) = value
                && let Err(problem) = bound_of(name).check(x)
            {
                return Err(bad(path, row, name, problem.to_string()));
            }
        }
        let u = [v[3], v[4], v[5]];
        let norm = dot(u, u).sqrt();
        if (norm - 1.0).abs() > UNIT_TOL {
            return Err(bad(
                path,
                row,
                "ux",
                format!(
                    "the beam direction ({}, {}, {}) of line `{id}` has norm {norm:.9}, not 1 \
                     (checked to 1e-6)",
                    u[0], u[1], u[2]
                ),
            ));
        }
        let u = u.map(|c| c / norm);
        let probe = [o[0], o[1], o[2]].map(|p| p.unwrap_or(0.0));
        let target = Target {
            row,
            pos_mm: [v[0], v[1], v[2]],
            e_um,
            s_um: o[3],
            t_s: o[4],
            scale_temp_c: o[5],
            air_temp_c: o[6],
            part_temp_c: o[7],
        };
        Ok(ParsedRow {
            id,
            u,
            probe,
            target,
        })
    }
}

/// Adds `target` to line `l` (first read on row `first_row`) after checking that its row
/// shares the line's beam direction and probe offset (`(u, probe)`) and lies on the line
/// (within `OFF_LINE_TOL_MM`).
fn join_line(
    path: &Path,
    l: &mut Line,
    first_row: usize,
    (u, probe): ([f64; 3], [f64; 3]),
    target: Target,
) -> Result<(), VolumetricError> {
    let row = target.row;
    for (k, col) in ["ux", "uy", "uz"].iter().enumerate() {
        if (l.u[k] - u[k]).abs() > UNIT_TOL {
            return Err(bad(
                path,
                row,
                col,
                format!(
                    "{} differs from {} on row {} of the same line `{}`: rows of a \
                     line share the beam direction",
                    u[k], l.u[k], first_row, l.id
                ),
            ));
        }
    }
    for (k, col) in ["px_mm", "py_mm", "pz_mm"].iter().enumerate() {
        if (l.probe_mm[k] - probe[k]).abs() > 1e-6 {
            return Err(bad(
                path,
                row,
                col,
                format!(
                    "probe offset {} mm differs from {} mm on row {} of the same \
                     line `{}`: rows of a line share the probe offset",
                    probe[k], l.probe_mm[k], first_row, l.id
                ),
            ));
        }
    }
    let p0 = l.targets[0].pos_mm;
    let d = sub(target.pos_mm, p0);
    let s = dot(d, l.u);
    let off = sub(d, l.u.map(|c| c * s));
    let dist = dot(off, off).sqrt();
    if dist > OFF_LINE_TOL_MM {
        return Err(bad(
            path,
            row,
            "x_mm",
            format!(
                "target ({}, {}, {}) mm is {:.4} µm off line `{}` (through row {} \
                 along ({:.6}, {:.6}, {:.6}); the limit is 1 µm)",
                target.pos_mm[0],
                target.pos_mm[1],
                target.pos_mm[2],
                dist * 1e3,
                l.id,
                first_row,
                l.u[0],
                l.u[1],
                l.u[2]
            ),
        ));
    }
    l.targets.push(target);
    Ok(())
}

/// Refuses a line with fewer than `MIN_TARGETS` distinct targets (to `OFF_LINE_TOL_MM`).
fn check_distinct_targets(
    path: &Path,
    lines: &[Line],
    first_row: &[usize],
) -> Result<(), VolumetricError> {
    for (l, &row) in lines.iter().zip(first_row) {
        let mut s: Vec<f64> = l.targets.iter().map(|t| l.s_mm(t)).collect();
        s.sort_by(f64::total_cmp);
        s.dedup_by(|a, b| (*a - *b).abs() < OFF_LINE_TOL_MM);
        if s.len() < MIN_TARGETS {
            return Err(VolumetricError::Line {
                path: path.to_path_buf(),
                line: l.id.clone(),
                row,
                file_line: row + 1,
                problem: format!(
                    "{} distinct target(s); a line needs at least {MIN_TARGETS}",
                    s.len()
                ),
            });
        }
    }
    Ok(())
}

fn line_id(path: &Path, cells: &Cells, r0: usize) -> Result<String, VolumetricError> {
    let id = match cells {
        Cells::Text(v) => v[r0].as_deref().map(str::trim).map(str::to_string),
        Cells::Number(v) => v[r0].map(|x| {
            if x.fract() == 0.0 && x.abs() < 1e15 {
                format!("{}", x as i64)
            } else {
                format!("{x}")
            }
        }),
    };
    match id {
        Some(s) if !s.is_empty() => Ok(s),
        _ => Err(TableError::EmptyCell {
            path: path.to_path_buf(),
            row: r0 + 1,
            line: r0 + 2,
            column: "line".into(),
        }
        .into()),
    }
}
