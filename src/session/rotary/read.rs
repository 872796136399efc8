//! Reading, checking and writing a rotary session table (`docs/rotary.md` §1).

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use polars::prelude::*;

use super::{ANGLE_TOL_DEG, RotaryError, RotaryRow, RotarySession};
use crate::base::{FileOp, RotaryAxis, io_err};
use crate::table::{
    Cells, column_cells, format_err, optional_column_cells, parse_cell, read_frame, required_cell,
    text_or_number_cells, write_frame,
};

/// The columns errmap writes, in order (the first 11 required).
const COLUMNS: [&str; 15] = [
    "run",
    "sample",
    "t_s",
    "axis",
    "direction",
    "target",
    "target_deg",
    "indicated_deg",
    "reference_deg",
    "error_arcsec",
    "flags",
    "feed_deg_s",
    "air_temp_c",
    "part_temp_c",
    "scale_temp_c",
];

/// Angles read or written: within ±10⁶ ° (a few thousand revolutions unwrapped).
const ANGLE_LIMIT_DEG: f64 = 1e6;
/// Angular errors: within ±10⁶ ″ (about 278°).
const ERROR_LIMIT_ARCSEC: f64 = 1e6;

/// Whether the session table at `path` is rotary: its first data row's `axis` is A, B or C.
/// Reads the header and one row only.
pub fn is_rotary(path: &Path) -> Result<bool, RotaryError> {
    if crate::table::is_parquet(path)? {
        let reader = crate::table::parquet_reader(path)?.with_slice(Some((0, 1)));
        let df = crate::table::finish_parquet(path, reader)?;
        let Ok(col) = df.column("axis") else {
            return Ok(false);
        };
        let v = col.get(0).map(|v| v.to_string()).unwrap_or_default();
        return Ok(v.trim_matches('"').trim().parse::<RotaryAxis>().is_ok());
    }
    let file = std::fs::File::open(path).map_err(io_err(path, FileOp::Read))?;
    let mut lines = BufReader::new(file).take(1 << 20).lines();
    let mut next = || -> Result<Option<String>, RotaryError> {
        for l in lines.by_ref() {
            let l = l.map_err(io_err(path, FileOp::Read))?;
            if !l.trim().is_empty() {
                return Ok(Some(l));
            }
        }
        Ok(None)
    };
    let (Some(header), Some(first)) = (next()?, next()?) else {
        return Ok(false);
    };
    let field = |s: &str| s.trim().trim_matches('"').trim().to_string();
    let header: Vec<String> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(field)
        .collect();
    let Some(k) = header.iter().position(|h| h == "axis") else {
        return Ok(false);
    };
    let cells: Vec<String> = first.split(',').map(field).collect();
    Ok(cells
        .get(k)
        .is_some_and(|a| a.parse::<RotaryAxis>().is_ok()))
}

/// Reads and checks a rotary session table (the rules of `docs/rotary.md` §1).
pub fn read_rotary_session(path: &Path) -> Result<RotarySession, RotaryError> {
    let df = read_frame(path)?;
    let (axis, rows) = frame_rows(path, &df)?;
    let session = RotarySession { axis, rows };
    check_targets(path, &session)?;
    check_closure_sets(path, &session)?;
    Ok(session)
}

fn bad(path: &Path, row0: usize, column: &str, problem: impl Into<String>) -> RotaryError {
    RotaryError::at(path, row0 + 2, column, problem)
}

fn integer(path: &Path, v: f64, row0: usize, column: &str) -> Result<i64, RotaryError> {
    crate::session::whole_number(v).map_err(|p| bad(path, row0, column, p.to_string()))
}

fn axis_text(cells: &Cells, row0: usize) -> String {
    match cells {
        Cells::Text(v) => v[row0].clone().unwrap_or_default().trim().to_string(),
        Cells::Number(v) => v[row0].map(|x| x.to_string()).unwrap_or_default(),
    }
}

type Parsed = (RotaryAxis, Vec<RotaryRow>);

fn frame_rows(path: &Path, df: &DataFrame) -> Result<Parsed, RotaryError> {
    let cells: Vec<Cells> = COLUMNS[..10]
        .iter()
        .map(|&c| match c {
            "axis" => text_or_number_cells(path, df, c),
            _ => column_cells(path, df, c),
        })
        .collect::<Result<_, _>>()?;
    let optional: Vec<Option<Cells>> = COLUMNS[10..]
        .iter()
        .map(|c| optional_column_cells(path, df, c))
        .collect::<Result<_, _>>()?;
    if df.height() == 0 {
        return Err(RotaryError::Whole {
            path: path.to_path_buf(),
            problem: "a header and no data rows".into(),
        });
    }
    let first_axis = axis_text(&cells[3], 0);
    let axis: RotaryAxis = first_axis
        .parse()
        .map_err(|_| bad(path, 0, "axis", format!("`{first_axis}` is not A, B or C")))?;
    let mut seen = super::super::SampleSet::default();
    let mut rows = Vec::with_capacity(df.height());
    for r in 0..df.height() {
        let req = |k: usize| required_cell(path, &cells[k], r, COLUMNS[k]);
        let opt = |k: usize| match &optional[k - 10] {
            Some(c) => parse_cell(path, c, r, COLUMNS[k]),
            None => Ok(None),
        };
        let a = axis_text(&cells[3], r);
        if a.parse::<RotaryAxis>() != Ok(axis) {
            let what = if a.parse::<RotaryAxis>().is_ok() {
                format!("`{a}` differs from the first row's `{axis}` (one axis per session)")
            } else {
                format!("`{a}` is not A, B or C")
            };
            return Err(bad(path, r, "axis", what));
        }
        let run = integer(path, req(0)?, r, "run")?;
        let run = u32::try_from(run)
            .map_err(|_| bad(path, r, "run", format!("{run} is not a run number ≥ 0")))?;
        let sample = integer(path, req(1)?, r, "sample")?;
        if let Some(earlier) = seen.insert(run, sample, r) {
            return Err(bad(
                path,
                r,
                "sample",
                format!(
                    "run {run} sample {sample} repeats line {} (a sample is unique within its run)",
                    earlier + 2
                ),
            ));
        }
        let (direction, target, flags) = crate::session::row_indices(req(4)?, req(5)?, opt(10)?)
            .map_err(|(column, problem)| bad(path, r, column, problem))?;
        let row = RotaryRow {
            axis: axis.into(),
            run,
            sample,
            t_s: req(2)?,
            direction,
            target,
            target_deg: parse_cell(path, &cells[6], r, "target_deg")?,
            indicated_deg: req(7)?,
            reference_deg: req(8)?,
            error_arcsec: req(9)?,
            flags,
            feed_deg_s: opt(11)?,
            air_temp_c: opt(12)?,
            part_temp_c: opt(13)?,
            scale_temp_c: opt(14)?,
        };
        check_ranges(path, r, &row)?;
        rows.push(row);
    }
    Ok((axis, rows))
}

fn check_ranges(path: &Path, r: usize, row: &RotaryRow) -> Result<(), RotaryError> {
    if row.is_dwell() && row.target_deg.is_none() {
        return Err(bad(
            path,
            r,
            "target_deg",
            "empty on a dwell row (target ≥ 0)",
        ));
    }
    if let Some(d) = row.target_deg
        && !(0.0..=360.0).contains(&d)
    {
        return Err(bad(
            path,
            r,
            "target_deg",
            format!(
                "{d}° is outside [0, 360] (errmap never wraps an angle: write {})",
                d.rem_euclid(360.0)
            ),
        ));
    }
    let checks: [(&str, Option<f64>, f64); 6] = [
        ("t_s", Some(row.t_s), 1e9),
        ("indicated_deg", Some(row.indicated_deg), ANGLE_LIMIT_DEG),
        ("reference_deg", Some(row.reference_deg), ANGLE_LIMIT_DEG),
        ("error_arcsec", Some(row.error_arcsec), ERROR_LIMIT_ARCSEC),
        ("feed_deg_s", row.feed_deg_s.map(f64::abs), 1e5),
        ("air_temp_c", row.air_temp_c.map(|t| t - 25.0), 75.0),
    ];
    for (column, v, limit) in checks {
        if let Some(v) = v
            && v.abs() > limit
        {
            return Err(bad(path, r, column, format!("{v} is outside ±{limit}")));
        }
    }
    for (column, v) in [
        ("part_temp_c", row.part_temp_c),
        ("scale_temp_c", row.scale_temp_c),
    ] {
        if let Some(v) = v
            && !(-50.0..=100.0).contains(&v)
        {
            return Err(bad(
                path,
                r,
                column,
                format!("{v} °C is outside −50 … 100 °C"),
            ));
        }
    }
    Ok(())
}

/// One target index, one angle; one angle, one index (`docs/rotary.md` §1).
fn check_targets(path: &Path, s: &RotarySession) -> Result<(), RotaryError> {
    let mut by_index: BTreeMap<i32, (f64, usize)> = BTreeMap::new();
    for (r, row) in s.rows.iter().enumerate() {
        let (Some(deg), true) = (row.target_deg, row.target >= 0) else {
            continue;
        };
        match by_index.get(&row.target) {
            Some(&(d0, r0)) if (d0 - deg).abs() > ANGLE_TOL_DEG => {
                return Err(bad(
                    path,
                    r,
                    "target_deg",
                    format!(
                        "target {} is {deg}° here and {d0}° on line {} (one target index, one angle)",
                        row.target,
                        r0 + 2
                    ),
                ));
            }
            Some(_) => {}
            None => {
                if let Some((&other, &(_, r0))) = by_index
                    .iter()
                    .find(|(_, (d0, _))| (d0 - deg).abs() <= ANGLE_TOL_DEG)
                {
                    return Err(bad(
                        path,
                        r,
                        "target",
                        format!(
                            "{deg}° is target {} here and target {other} on line {} (one angle, one target index)",
                            row.target,
                            r0 + 2
                        ),
                    ));
                }
                by_index.insert(row.target, (deg, r));
            }
        }
    }
    Ok(())
}

/// The closure pair (0 and 360) measured in the same (run, direction) sets: the first run,
/// + before −, holding one of the pair and not the other is named.
fn check_closure_sets(path: &Path, s: &RotarySession) -> Result<(), RotaryError> {
    let targets = s.targets();
    let (Some(zero), Some(full)) = (
        targets.iter().find(|t| t.1.abs() <= ANGLE_TOL_DEG),
        targets
            .iter()
            .find(|t| (t.1 - 360.0).abs() <= ANGLE_TOL_DEG),
    ) else {
        return Ok(());
    };
    // (run, −direction so + sorts first) → first line at 0, first line at 360.
    let mut sets: BTreeMap<(u32, i8), [Option<usize>; 2]> = BTreeMap::new();
    for (r, row) in s.rows.iter().enumerate().filter(|(_, r)| r.is_dwell()) {
        let slot = if row.target == zero.0 {
            0
        } else if row.target == full.0 {
            1
        } else {
            continue;
        };
        let e = sets.entry((row.run, -row.direction)).or_default();
        e[slot].get_or_insert(r);
    }
    for ((run, nd), lines) in &sets {
        let sign = if *nd < 0 { "+" } else { "−" };
        let (have, lacks, r) = match lines {
            [Some(r), None] => ("0°", "360°", *r),
            [None, Some(r)] => ("360°", "0°", *r),
            _ => continue,
        };
        return Err(bad(
            path,
            r,
            "target_deg",
            format!(
                "run {run}, direction {sign}: dwells at {have} but not at {lacks} (the closure pair \
                 0/360 must be measured in the same runs and directions)"
            ),
        ));
    }
    Ok(())
}

/// The rows as a frame with errmap's columns, in order (optional columns only when any
/// row has a value).
pub fn rotary_frame(s: &RotarySession) -> PolarsResult<DataFrame> {
    let rows = &s.rows;
    let f = |name: &str, g: &dyn Fn(&RotaryRow) -> f64| {
        Column::new(name.into(), rows.iter().map(g).collect::<Vec<f64>>())
    };
    let o = |name: &str, g: &dyn Fn(&RotaryRow) -> Option<f64>| {
        Column::new(
            name.into(),
            rows.iter().map(g).collect::<Vec<Option<f64>>>(),
        )
    };
    let i = |name: &str, g: &dyn Fn(&RotaryRow) -> i64| {
        Column::new(name.into(), rows.iter().map(g).collect::<Vec<i64>>())
    };
    let mut cols = vec![
        i("run", &|r| i64::from(r.run)),
        i("sample", &|r| r.sample),
        f("t_s", &|r| r.t_s),
        Column::new(
            "axis".into(),
            rows.iter().map(|_| s.axis.upper()).collect::<Vec<&str>>(),
        ),
        i("direction", &|r| i64::from(r.direction)),
        i("target", &|r| i64::from(r.target)),
        o("target_deg", &|r| r.target_deg),
        f("indicated_deg", &|r| r.indicated_deg),
        f("reference_deg", &|r| r.reference_deg),
        f("error_arcsec", &|r| r.error_arcsec),
        i("flags", &|r| i64::from(r.flags)),
    ];
    type Get = fn(&RotaryRow) -> Option<f64>;
    let extra: [(&str, Get); 4] = [
        ("feed_deg_s", |r| r.feed_deg_s),
        ("air_temp_c", |r| r.air_temp_c),
        ("part_temp_c", |r| r.part_temp_c),
        ("scale_temp_c", |r| r.scale_temp_c),
    ];
    for (name, g) in extra {
        if rows.iter().any(|r| g(r).is_some()) {
            cols.push(o(name, &g));
        }
    }
    DataFrame::new(rows.len(), cols)
}

/// Writes a rotary session table (CSV or Parquet by extension), whole or not at all.
pub fn write_rotary_session(path: &Path, s: &RotarySession) -> Result<(), RotaryError> {
    let mut df = rotary_frame(s).map_err(|e| format_err(path, e))?;
    Ok(write_frame(path, &mut df)?)
}

/// The header of a rotary session CSV written row by row (a capture): every column of
/// errmap's, the optional ones included.
pub fn rotary_csv_header() -> String {
    let mut s = COLUMNS.join(",");
    s.push('\n');
    s
}

/// One line of a rotary session CSV written row by row (the columns of
/// [`rotary_csv_header`]; an empty optional value is an empty cell). Floats in Rust's
/// shortest round-trip form.
pub fn rotary_csv_line(axis: RotaryAxis, r: &RotaryRow) -> String {
    let o = |v: Option<f64>| v.map(|v| format!("{v}")).unwrap_or_default();
    format!(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
        r.run,
        r.sample,
        r.t_s,
        axis.upper(),
        r.direction,
        r.target,
        o(r.target_deg),
        r.indicated_deg,
        r.reference_deg,
        r.error_arcsec,
        r.flags,
        o(r.feed_deg_s),
        o(r.air_temp_c),
        o(r.part_temp_c),
        o(r.scale_temp_c),
    )
}
