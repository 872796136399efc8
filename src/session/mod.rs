//! Session tables (one row per latched sample, `docs/session-table.md`) and their
//! reduction to an error table.
//!
//! Writing and reading go through polars (CSV or Parquet by extension). Capture and replay
//! write through the same function, so a replayed capture gives the same file byte for
//! byte. Reading validates every required cell and reports file, row and column: numbers
//! inside their physical ranges ([`crate::base::limits`]: positions ±10⁶ mm, errors
//! ±10⁶ µm, temperatures −50 … 100 °C, pressure 300 … 1 300 hPa, humidity 0 … 100 %,
//! times ±10⁹ s, feeds 0 … 10⁵ mm/s), every row with all the header's fields, and each
//! `(run, sample)` once (the spec: a sample index is unique within its run).
//!
//! **Session → error table.** For each line (the two fixed coordinates) and target, the
//! error is the mean over runs and both directions of the samples dwelling at the target
//! (target ≥ 0, run ≥ 1), as in ISO 230-2 and the paper's Table 1; `n` counts them and
//! `s_um` is their sample standard deviation. Successive samples of a dwell are
//! correlated (coloured noise, vibration, positioning shared by a dwell), so `n_eff` is
//! the effective sample count, with s/√n_eff the node's standard uncertainty: s²/u² with
//! u² = D·mean(s_j²/m_j)/J over the node's J dwells, D the session's design effect of a
//! dwell mean by batch means (the scatter of the means of repeated dwells at one line,
//! target and direction against their samples' own s²/m, pooled over the session). A
//! session of one run has no repeats: each dwell of m samples then counts
//! m / (1 + 2 Σ (1 − k/m) ρ_k) with ρ_k the session's autocorrelation of dwell samples
//! (pooled, lags up to 32, corrected for the removal of each dwell's mean, the sum stopped
//! before the first ρ_k ≤ 0). Rows with flags ≠ 0 are left out and counted.
//! So are rows without air values in a session that has them elsewhere: the spec's mark of
//! a sample latched before the first ENV frame, whose laser length was not compensated for
//! the air (n = 1, about 270 ppm of the length too long in a normal room). A session with
//! no air values at all is taken as it is: its laser lengths were compensated, or not, by
//! whoever wrote it; the reduction summary says so ([`ReductionSummary::no_air_data`]).
//! The node's coordinate along the measured axis is the mean scale reading at that target
//! index over every line and run, rounded to 0.1 µm, so that one target has one coordinate
//! on every line and the nodes form a grid.

pub(crate) mod columns;
mod environment;
mod iso230;
mod reduce;
pub mod rotary;
mod stream;
mod uncertainty;

pub(crate) use columns::{Columns, ParquetSink};
pub use environment::{EnvironmentStats, Range};
pub use iso230::{AxisStats, IsoError, Observation, POSITION_TOL_MM, TargetStats, axis_stats};
pub use reduce::{
    LineKey, Reducer, ReductionError, ReductionSummary, error_table, iso_by_line, iso_observations,
    line_key, lines,
};
pub use stream::{
    BATCH_ROWS, SessionWriter, Thinned, for_each_batch, read_session_every, read_session_thinned,
};
pub use uncertainty::{
    Budget, BudgetSources, Contribution, DeclaredConditions, DriftCheck, DriftFinder,
    EdlenSensitivities, Eve, Kind as ContributionKind, MIN_DRIFT_ROWS, MIN_DRIFT_S, Origin,
    REFERENCE_TEMP_C, RecordedResolution, Resolution, STANDARD_AIR, StatUncertainty,
    TestConditions, UncertaintyConfig, UncertaintyError, edlen_sensitivities, line_budget,
    line_budget_of, line_budget_with, travel_mm,
};

use std::io::Write;
use std::path::Path;

use errmap_drivers::SessionRow;
use errmap_drivers::frame::Axis as WireAxis;
use polars::prelude::*;

use crate::base::io_err;
use crate::base::{Axis, FileOp};
use crate::table::{
    Cells, TableError, column_cells, optional_column_cells, parse_cell, read_frame, required_cell,
    text_or_number_cells, write_frame,
};

/// Writes a session table (CSV or Parquet by extension) with the spec's columns, whole or
/// not at all. A Parquet table is cut in row groups of [`BATCH_ROWS`] rows, as
/// [`SessionWriter`] cuts it, so the two give the same file for the same rows.
pub fn write_session(path: &Path, rows: &[SessionRow]) -> Result<(), TableError> {
    let format = |e: PolarsError| TableError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    if !crate::table::output_is_parquet(path)? {
        let mut df = session_frame(rows).map_err(format)?;
        return write_frame(path, &mut df);
    }
    crate::table::check_finite(path, &session_frame(rows).map_err(format)?)?;
    crate::table::write_atomically::<TableError>(path, |file| {
        let mut sink = ParquetSink::new(std::io::BufWriter::new(file)).map_err(format)?;
        for chunk in rows.chunks(BATCH_ROWS) {
            sink.write(&mut Columns::from_rows(chunk)).map_err(format)?;
        }
        let mut out = sink.finish().map_err(format)?;
        out.flush()
            .map_err(|e| io_err(path, FileOp::Write)(e).into())
    })
}

/// The session rows as a DataFrame with the spec's columns, in the spec's order.
pub fn session_frame(rows: &[SessionRow]) -> PolarsResult<DataFrame> {
    Columns::from_rows(rows).take_frame()
}

/// The spec's required columns (the first 13 of [`SessionRow::COLUMNS`]) and the optional
/// ones after them.
const N_REQUIRED: usize = 13;
const REQUIRED: &[&str] = SessionRow::COLUMNS.split_at(N_REQUIRED).0;
const OPTIONAL: &[&str] = SessionRow::COLUMNS.split_at(N_REQUIRED).1;

fn bad(path: &Path, row0: usize, column: &str, problem: impl Into<String>) -> TableError {
    TableError::BadValue {
        path: path.to_path_buf(),
        row: row0 + 1,
        line: row0 + 2,
        column: column.to_string(),
        problem: problem.into(),
    }
}

/// A session row's direction, target and flags cells as the session table defines them
/// (whole numbers; direction +1, −1 or 0; target an index or −1; flags a byte, 0 when
/// absent), or the column and the problem of the first that is not. The linear and the
/// rotary session readers both check their rows with it.
pub(crate) fn row_indices(
    direction: f64,
    target: f64,
    flags: Option<f64>,
) -> Result<(i8, i32, u8), (&'static str, String)> {
    let whole = |v: f64, column: &'static str| whole_number(v).map_err(|p| (column, p.to_string()));
    let d = whole(direction, "direction")?;
    if !(-1..=1).contains(&d) {
        return Err(("direction", format!("{d} is not +1, −1 or 0")));
    }
    let t = whole(target, "target")?;
    let t = i32::try_from(t)
        .ok()
        .filter(|&t| t >= -1)
        .ok_or_else(|| ("target", format!("{t} is not a target index or −1")))?;
    let f = match flags {
        Some(v) => {
            let f = whole(v, "flags")?;
            u8::try_from(f).map_err(|_| ("flags", format!("{f} is not a flag byte")))?
        }
        None => 0,
    };
    Ok((d as i8, t, f))
}

/// A cell value that is not a whole number.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{0} is not a whole number")]
pub(crate) struct NotWhole(f64);

/// A cell that must hold a whole number (within ±9·10¹⁵, where f64 still counts by ones);
/// every integer column of the session tables is read through it.
pub(crate) fn whole_number(v: f64) -> Result<i64, NotWhole> {
    if v.fract() != 0.0 || v.abs() > 9.0e15 {
        return Err(NotWhole(v));
    }
    Ok(v as i64)
}

fn integer(path: &Path, v: f64, row0: usize, column: &str) -> Result<i64, TableError> {
    whole_number(v).map_err(|p| bad(path, row0, column, p.to_string()))
}

fn axis_cell(path: &Path, cells: &Cells, row0: usize) -> Result<WireAxis, TableError> {
    let text = match cells {
        Cells::Text(v) => v[row0].clone().unwrap_or_default(),
        Cells::Number(v) => v[row0].map(|x| x.to_string()).unwrap_or_default(),
    };
    match text.trim().parse::<Axis>() {
        Ok(a) => Ok(WireAxis::from(a)),
        Err(_) => Err(bad(
            path,
            row0,
            "axis",
            format!("`{}` is not X, Y or Z", text.trim()),
        )),
    }
}

/// Reads and validates a session table (the whole table in memory; [`for_each_batch`]
/// reads it in bounded memory).
pub fn read_session(path: &Path) -> Result<Vec<SessionRow>, TableError> {
    let df = read_frame(path)?;
    frame_rows(path, &df, 0, &mut SampleSet::default())
}

/// Row `r` of a frame that starts at data row `first` of the file (0-based): errors name
/// the file's row and line.
fn shifted(e: TableError, first: usize) -> TableError {
    match e {
        TableError::NotNumeric {
            path,
            row,
            line,
            column,
            value,
        } => TableError::NotNumeric {
            path,
            row: row + first,
            line: line + first,
            column,
            value,
        },
        TableError::EmptyCell {
            path,
            row,
            line,
            column,
        } => TableError::EmptyCell {
            path,
            row: row + first,
            line: line + first,
            column,
        },
        TableError::NonFinite {
            path,
            row,
            line,
            column,
            value,
        } => TableError::NonFinite {
            path,
            row: row + first,
            line: line + first,
            column,
            value,
        },
        TableError::BadValue {
            path,
            row,
            line,
            column,
            problem,
        } => TableError::BadValue {
            path,
            row: row + first,
            line: line + first,
            column,
            problem,
        },
        other => other,
    }
}

/// The validated rows of a session-table frame whose first row is data row `first`
/// (0-based) of the file; `seen` holds the (run, sample) pairs of the file's earlier
/// rows, so a repeat is found across the batches of a streamed read too.
fn frame_rows(
    path: &Path,
    df: &DataFrame,
    first: usize,
    seen: &mut SampleSet,
) -> Result<Vec<SessionRow>, TableError> {
    let mut rows = Vec::new();
    frame_rows_into(path, df, first, seen, &mut rows)?;
    Ok(rows)
}

/// [`frame_rows`] into `rows` (emptied first), whose memory a streamed read keeps from
/// batch to batch.
fn frame_rows_into(
    path: &Path,
    df: &DataFrame,
    first: usize,
    seen: &mut SampleSet,
    rows: &mut Vec<SessionRow>,
) -> Result<(), TableError> {
    rows.clear();
    // The frame's rows are numbered from 0; an error names the file's (`shifted`).
    let mut read = || -> Result<(), TableError> {
        let cells = REQUIRED
            .iter()
            .map(|&c| match c {
                // Text or a number; every other column holds numbers.
                "axis" => text_or_number_cells(path, df, c),
                _ => column_cells(path, df, c),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let optional: Vec<Option<Cells>> = OPTIONAL
            .iter()
            .map(|c| optional_column_cells(path, df, c))
            .collect::<Result<_, _>>()?;
        rows.reserve(df.height());
        for r in 0..df.height() {
            let req = |k: usize| required_cell(path, &cells[k], r, REQUIRED[k]);
            let opt = |k: usize| parse_cell(path, &cells[k], r, REQUIRED[k]);
            let extra = |k: usize| match &optional[k] {
                Some(c) => parse_cell(path, c, r, OPTIONAL[k]),
                None => Ok(None),
            };
            let run = integer(path, req(0)?, r, "run")?;
            let (direction, target, flags) = row_indices(req(4)?, req(6)?, extra(5)?)
                .map_err(|(column, problem)| bad(path, r, column, problem))?;
            let run = u32::try_from(run)
                .map_err(|_| bad(path, r, "run", format!("{run} is negative")))?;
            let sample = integer(path, req(1)?, r, "sample")?;
            // The file's rows, not the frame's (`shifted` leaves this error as it is).
            if let Some(earlier) = seen.insert(run, sample, first + r) {
                return Err(TableError::DuplicateSample {
                    path: path.to_path_buf(),
                    row: first + r + 1,
                    line: first + r + 2,
                    first_row: earlier + 1,
                    run,
                    sample,
                });
            }
            let row = SessionRow {
                run,
                sample,
                t_s: req(2)?,
                axis: axis_cell(path, &cells[3], r)?,
                direction,
                feed_mm_s: opt(5)?,
                target,
                x_mm: opt(7)?,
                y_mm: opt(8)?,
                z_mm: opt(9)?,
                scale_mm: req(10)?,
                laser_mm: req(11)?,
                error_um: req(12)?,
                air_temp_c: extra(0)?,
                air_pressure_hpa: extra(1)?,
                air_rh_pct: extra(2)?,
                scale_temp_c: extra(3)?,
                part_temp_c: extra(4)?,
                flags,
            };
            check_ranges(path, r, &row)?;
            rows.push(row);
        }
        Ok(())
    };
    read().map_err(|e| shifted(e, first))
}

/// Every number of a session row inside its physical range ([`crate::base::limits`]).
fn check_ranges(path: &Path, row0: usize, row: &SessionRow) -> Result<(), TableError> {
    use crate::base::{
        Bound, ERROR_UM, FEED_MM_S, HUMIDITY_PCT, POSITION_MM, PRESSURE_HPA, TEMPERATURE_C, TIME_S,
    };
    let cells: [(&str, Option<f64>, Bound); 13] = [
        ("t_s", Some(row.t_s), TIME_S),
        ("feed_mm_s", row.feed_mm_s, FEED_MM_S),
        ("x_mm", row.x_mm, POSITION_MM),
        ("y_mm", row.y_mm, POSITION_MM),
        ("z_mm", row.z_mm, POSITION_MM),
        ("scale_mm", Some(row.scale_mm), POSITION_MM),
        ("laser_mm", Some(row.laser_mm), POSITION_MM),
        ("error_um", Some(row.error_um), ERROR_UM),
        ("air_temp_c", row.air_temp_c, TEMPERATURE_C),
        ("air_pressure_hpa", row.air_pressure_hpa, PRESSURE_HPA),
        ("air_rh_pct", row.air_rh_pct, HUMIDITY_PCT),
        ("scale_temp_c", row.scale_temp_c, TEMPERATURE_C),
        ("part_temp_c", row.part_temp_c, TEMPERATURE_C),
    ];
    for (column, value, bound) in cells {
        if let Some(v) = value {
            bound
                .check(v)
                .map_err(|problem| bad(path, row0, column, problem.to_string()))?;
        }
    }
    Ok(())
}

/// The (run, sample) pairs seen so far, as intervals of consecutive samples on
/// consecutive rows: a capture's rows take one interval per run (and one more per hole in
/// the counter), whatever the session's length.
#[derive(Debug, Default)]
pub(crate) struct SampleSet {
    /// Per run, disjoint intervals sorted by their first sample: (first sample, last
    /// sample, the 0-based row of the first).
    runs: std::collections::HashMap<u32, Vec<(i64, i64, usize)>>,
}

impl SampleSet {
    /// Adds `(run, sample)` read at 0-based row `row`; the row that had it before, if any.
    fn insert(&mut self, run: u32, sample: i64, row: usize) -> Option<usize> {
        let v = self.runs.entry(run).or_default();
        let i = v.partition_point(|iv| iv.0 <= sample);
        if i > 0 {
            let (lo, hi, row_lo) = v[i - 1];
            if sample <= hi {
                return Some(row_lo + (sample - lo) as usize);
            }
            let next_free = v.get(i).is_none_or(|n| n.0 > sample);
            if sample == hi + 1 && row == row_lo + (sample - lo) as usize && next_free {
                v[i - 1].1 = sample;
                return None;
            }
        }
        v.insert(i, (sample, sample, row));
        None
    }
}

#[cfg(test)]
mod sample_set_tests {
    use super::SampleSet;

    #[test]
    fn repeats_are_found_with_the_row_that_had_them_first() {
        let mut s = SampleSet::default();
        for (k, sample) in (0..1000).enumerate() {
            assert_eq!(s.insert(1, sample, k), None);
        }
        assert_eq!(s.runs[&1].len(), 1, "one interval for consecutive rows");
        assert_eq!(s.insert(2, 5, 1000), None, "another run");
        assert_eq!(s.insert(1, 1010, 1001), None, "a hole");
        assert_eq!(s.insert(1, 500, 1002), Some(500));
        assert_eq!(s.insert(1, 1010, 1003), Some(1001));
        assert_eq!(s.insert(2, 5, 1004), Some(1000));
        // Out of order: still exact.
        assert_eq!(s.insert(3, 9, 1005), None);
        assert_eq!(s.insert(3, 8, 1006), None);
        assert_eq!(s.insert(3, 9, 1007), Some(1005));
        assert_eq!(s.insert(3, 8, 1008), Some(1006));
    }
}
