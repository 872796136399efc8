//! Session tables (one row per latched sample, spec `session-table.md`) and their
//! reduction to an error table.
//!
//! Writing and reading go through polars (CSV or Parquet by extension). Capture and replay
//! write through the same function, so a replayed capture gives the same file byte for
//! byte. Reading validates every required cell and reports file, row and column.
//!
//! **Session → error table.** For each line (the two fixed coordinates) and target, the
//! error is the mean over runs and both directions of the samples dwelling at the target
//! (target ≥ 0, run ≥ 1), as in ISO 230-2 and the paper's Table 1; `n` counts them and
//! `s_um` is their sample standard deviation. Rows with flags ≠ 0 are left out and counted.
//! So are rows without air values in a session that has them elsewhere: the spec's mark of
//! a sample latched before the first ENV frame, whose laser length was not compensated for
//! the air (n = 1, about 270 ppm of the length too long in a normal room). A session with
//! no air values at all is taken as it is: its laser lengths were compensated, or not, by
//! whoever wrote it; the reduction summary says so ([`ReductionSummary::no_air_data`]).
//! The node's coordinate along the measured axis is the mean scale reading at that target
//! index over every line and run, rounded to 0.1 µm, so that one target has one coordinate
//! on every line and the nodes form a grid.

pub mod iso230;

use std::collections::BTreeMap;
use std::path::Path;

use errmap_drivers::SessionRow;
use errmap_drivers::frame::Axis as WireAxis;
use polars::prelude::*;
use serde::Serialize;

use crate::table::{
    Cells, ErrorPoint, ErrorTable, TableError, column_cells, parse_cell, read_frame, required_cell,
    write_frame,
};

/// Writes a session table (CSV or Parquet by extension) with the spec's columns.
pub fn write_session(path: &Path, rows: &[SessionRow]) -> Result<(), TableError> {
    let mut df = session_frame(rows).map_err(|e| TableError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(path, &mut df)
}

/// The session rows as a DataFrame with the spec's columns, in the spec's order.
pub fn session_frame(rows: &[SessionRow]) -> PolarsResult<DataFrame> {
    fn f(rows: &[SessionRow], name: &str, g: impl Fn(&SessionRow) -> f64) -> Column {
        Column::new(name.into(), rows.iter().map(g).collect::<Vec<f64>>())
    }
    fn o(rows: &[SessionRow], name: &str, g: impl Fn(&SessionRow) -> Option<f64>) -> Column {
        Column::new(
            name.into(),
            rows.iter().map(g).collect::<Vec<Option<f64>>>(),
        )
    }
    fn i(rows: &[SessionRow], name: &str, g: impl Fn(&SessionRow) -> i64) -> Column {
        Column::new(name.into(), rows.iter().map(g).collect::<Vec<i64>>())
    }
    let cols = vec![
        i(rows, "run", |r| i64::from(r.run)),
        i(rows, "sample", |r| r.sample),
        f(rows, "t_s", |r| r.t_s),
        Column::new(
            "axis".into(),
            rows.iter().map(|r| r.axis.as_str()).collect::<Vec<&str>>(),
        ),
        i(rows, "direction", |r| i64::from(r.direction)),
        o(rows, "feed_mm_s", |r| r.feed_mm_s),
        i(rows, "target", |r| i64::from(r.target)),
        o(rows, "x_mm", |r| r.x_mm),
        o(rows, "y_mm", |r| r.y_mm),
        o(rows, "z_mm", |r| r.z_mm),
        f(rows, "scale_mm", |r| r.scale_mm),
        f(rows, "laser_mm", |r| r.laser_mm),
        f(rows, "error_um", |r| r.error_um),
        o(rows, "air_temp_c", |r| r.air_temp_c),
        o(rows, "air_pressure_hpa", |r| r.air_pressure_hpa),
        o(rows, "air_rh_pct", |r| r.air_rh_pct),
        o(rows, "scale_temp_c", |r| r.scale_temp_c),
        o(rows, "part_temp_c", |r| r.part_temp_c),
        i(rows, "flags", |r| i64::from(r.flags)),
    ];
    DataFrame::new(rows.len(), cols)
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

fn integer(path: &Path, v: f64, row0: usize, column: &str) -> Result<i64, TableError> {
    if v.fract() != 0.0 || v.abs() > 9.0e15 {
        return Err(bad(
            path,
            row0,
            column,
            format!("{v} is not a whole number"),
        ));
    }
    Ok(v as i64)
}

fn axis_cell(path: &Path, cells: &Cells, row0: usize) -> Result<WireAxis, TableError> {
    let text = match cells {
        Cells::Text(v) => v[row0].clone().unwrap_or_default(),
        Cells::Number(v) => v[row0].map(|x| x.to_string()).unwrap_or_default(),
    };
    match text.trim() {
        "X" | "x" => Ok(WireAxis::X),
        "Y" | "y" => Ok(WireAxis::Y),
        "Z" | "z" => Ok(WireAxis::Z),
        other => Err(bad(
            path,
            row0,
            "axis",
            format!("`{other}` is not X, Y or Z"),
        )),
    }
}

/// Reads and validates a session table.
pub fn read_session(path: &Path) -> Result<Vec<SessionRow>, TableError> {
    let df = read_frame(path)?;
    let cells = REQUIRED
        .iter()
        .map(|c| column_cells(path, &df, c))
        .collect::<Result<Vec<_>, _>>()?;
    let optional: Vec<Option<Cells>> = OPTIONAL
        .iter()
        .map(|c| {
            df.column(c)
                .ok()
                .map(|_| column_cells(path, &df, c))
                .transpose()
        })
        .collect::<Result<_, _>>()?;
    let mut rows = Vec::with_capacity(df.height());
    for r in 0..df.height() {
        let req = |k: usize| required_cell(path, &cells[k], r, REQUIRED[k]);
        let opt = |k: usize| parse_cell(path, &cells[k], r, REQUIRED[k]);
        let extra = |k: usize| match &optional[k] {
            Some(c) => parse_cell(path, c, r, OPTIONAL[k]),
            None => Ok(None),
        };
        let run = integer(path, req(0)?, r, "run")?;
        let direction = integer(path, req(4)?, r, "direction")?;
        if !(-1..=1).contains(&direction) {
            return Err(bad(
                path,
                r,
                "direction",
                format!("{direction} is not +1, −1 or 0"),
            ));
        }
        let target = integer(path, req(6)?, r, "target")?;
        if target < -1 || target > i64::from(i32::MAX) {
            return Err(bad(
                path,
                r,
                "target",
                format!("{target} is not a target index or −1"),
            ));
        }
        let flags = match extra(5)? {
            Some(v) => {
                let f = integer(path, v, r, "flags")?;
                u8::try_from(f)
                    .map_err(|_| bad(path, r, "flags", format!("{f} is not a flag byte")))?
            }
            None => 0,
        };
        rows.push(SessionRow {
            run: u32::try_from(run)
                .map_err(|_| bad(path, r, "run", format!("{run} is negative")))?,
            sample: integer(path, req(1)?, r, "sample")?,
            t_s: req(2)?,
            axis: axis_cell(path, &cells[3], r)?,
            direction: direction as i8,
            feed_mm_s: opt(5)?,
            target: target as i32,
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
        });
    }
    Ok(rows)
}

/// What the reduction used and left out.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ReductionSummary {
    pub rows: usize,
    /// Dwell samples averaged into nodes.
    pub used: usize,
    /// Dwell samples left out because their flags were set.
    pub flagged: usize,
    /// Rows not dwelling at a target inside a run (moving, or run 0).
    pub not_dwelling: usize,
    /// Dwell rows without known line coordinates (no MARK yet).
    pub no_line: usize,
    /// Dwell samples left out because they carry no air values while others do (latched
    /// before the first ENV frame: laser length not compensated for the air).
    pub uncompensated: usize,
    /// No row has air values: nothing was left out for it, and the laser lengths are used
    /// as written.
    pub no_air_data: bool,
    pub axis: Option<String>,
    pub lines: usize,
    pub targets: usize,
}

/// Why a session cannot be reduced.
#[derive(Debug, thiserror::Error)]
pub enum ReductionError {
    #[error(
        "{origin}: no usable dwell samples (rows {rows}, flagged {flagged}, not dwelling {not_dwelling}, \
         latched before the first ENV frame {uncompensated})"
    )]
    NoDwell {
        origin: String,
        rows: usize,
        flagged: usize,
        not_dwelling: usize,
        uncompensated: usize,
    },
    #[error(
        "{origin}: the session measures along more than one axis ({axes}); reduce each axis separately"
    )]
    MixedAxes { origin: String, axes: String },
}

fn axis_index(a: WireAxis) -> usize {
    match a {
        WireAxis::X => 0,
        WireAxis::Y => 1,
        WireAxis::Z => 2,
    }
}

/// Which rows lack air compensation: those without air values, when the session has air
/// values on some row (see the module docs). Holds whether any row has them.
struct AirRule(bool);

impl AirRule {
    fn of(rows: &[SessionRow]) -> Self {
        AirRule(rows.iter().any(has_air))
    }

    fn uncompensated(&self, r: &SessionRow) -> bool {
        self.0 && !has_air(r)
    }
}

fn has_air(r: &SessionRow) -> bool {
    r.air_temp_c.is_some() && r.air_pressure_hpa.is_some() && r.air_rh_pct.is_some()
}

/// Reduces a session to an error table (see the module docs).
pub fn error_table(
    source: &str,
    rows: &[SessionRow],
) -> Result<(ErrorTable, ReductionSummary), ReductionError> {
    let mut summary = ReductionSummary {
        rows: rows.len(),
        ..Default::default()
    };
    let mut axes: Vec<WireAxis> = rows.iter().map(|r| r.axis).collect();
    axes.sort_by_key(|a| a.code());
    axes.dedup();
    if axes.len() > 1 {
        return Err(ReductionError::MixedAxes {
            origin: source.to_string(),
            axes: axes
                .iter()
                .map(|a| a.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    let Some(&axis) = axes.first() else {
        return Err(ReductionError::NoDwell {
            origin: source.to_string(),
            rows: 0,
            flagged: 0,
            not_dwelling: 0,
            uncompensated: 0,
        });
    };
    summary.axis = Some(axis.as_str().to_string());
    let a = axis_index(axis);
    let air = AirRule::of(rows);
    summary.no_air_data = !air.0;
    // Samples per (line, target) and scale readings per target.
    let mut groups: BTreeMap<(i64, i64, i32), Vec<f64>> = BTreeMap::new();
    let mut positions: BTreeMap<i32, (f64, usize)> = BTreeMap::new();
    for r in rows {
        if r.target < 0 || r.run == 0 {
            summary.not_dwelling += 1;
            continue;
        }
        if r.flags != 0 {
            summary.flagged += 1;
            continue;
        }
        if air.uncompensated(r) {
            summary.uncompensated += 1;
            continue;
        }
        let coords = [r.x_mm, r.y_mm, r.z_mm];
        let others: Vec<Option<f64>> = (0..3).filter(|&b| b != a).map(|b| coords[b]).collect();
        let (Some(c1), Some(c2)) = (others[0], others[1]) else {
            summary.no_line += 1;
            continue;
        };
        // Line coordinates come from MARK frames in whole micrometres.
        let key = (
            (c1 * 1000.0).round() as i64,
            (c2 * 1000.0).round() as i64,
            r.target,
        );
        groups.entry(key).or_default().push(r.error_um);
        let p = positions.entry(r.target).or_insert((0.0, 0));
        p.0 += r.scale_mm;
        p.1 += 1;
        summary.used += 1;
    }
    if groups.is_empty() {
        return Err(ReductionError::NoDwell {
            origin: source.to_string(),
            rows: summary.rows,
            flagged: summary.flagged,
            not_dwelling: summary.not_dwelling,
            uncompensated: summary.uncompensated,
        });
    }
    let mut lines: Vec<(i64, i64)> = groups.keys().map(|k| (k.0, k.1)).collect();
    lines.dedup();
    summary.lines = lines.len();
    summary.targets = positions.len();
    let points = groups
        .iter()
        .map(|(&(c1, c2, target), e)| {
            let (sum, n) = positions[&target];
            let along = ((sum / n as f64) * 1e4).round() / 1e4;
            let others = [c1 as f64 / 1000.0, c2 as f64 / 1000.0];
            let mut pos = [0.0; 3];
            let mut k = 0;
            for (b, slot) in pos.iter_mut().enumerate() {
                if b == a {
                    *slot = along;
                } else {
                    *slot = others[k];
                    k += 1;
                }
            }
            let n = e.len();
            let mean = e.iter().sum::<f64>() / n as f64;
            let s = (n > 1).then(|| {
                (e.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64).sqrt()
            });
            ErrorPoint {
                x_mm: pos[0],
                y_mm: pos[1],
                z_mm: pos[2],
                e_um: mean,
                n: Some(n as u32),
                s_um: s,
            }
        })
        .collect();
    Ok((ErrorTable::from_points(source, points), summary))
}

/// ISO 230-2 observations of one line of a session: one per (target, run, direction),
/// the mean of that dwell's unflagged samples.
pub fn iso_observations(rows: &[SessionRow], line: Option<(f64, f64)>) -> Vec<iso230::Observation> {
    let mut acc: BTreeMap<(i32, u32, i8), (f64, f64, usize)> = BTreeMap::new();
    let air = AirRule::of(rows);
    for r in rows {
        if r.target < 0 || r.run == 0 || r.flags != 0 || r.direction == 0 || air.uncompensated(r) {
            continue;
        }
        if let Some((c1, c2)) = line {
            let a = axis_index(r.axis);
            let coords = [r.x_mm, r.y_mm, r.z_mm];
            let others: Vec<Option<f64>> = (0..3).filter(|&b| b != a).map(|b| coords[b]).collect();
            let same = |v: Option<f64>, c: f64| v.is_some_and(|v| (v - c).abs() < 5e-4);
            if !(same(others[0], c1) && same(others[1], c2)) {
                continue;
            }
        }
        let e = acc
            .entry((r.target, r.run, r.direction))
            .or_insert((0.0, 0.0, 0));
        e.0 += r.error_um;
        e.1 += r.scale_mm;
        e.2 += 1;
    }
    // One position per target (ISO 230-2's P_i): the mean scale reading over its dwells.
    let mut pos_sum: BTreeMap<i32, (f64, usize)> = BTreeMap::new();
    for (&(target, _, _), &(_, pos, n)) in &acc {
        let p = pos_sum.entry(target).or_insert((0.0, 0));
        p.0 += pos / n as f64;
        p.1 += 1;
    }
    acc.into_iter()
        .map(|((target, run, dir), (e, _, n))| {
            let (sum, k) = pos_sum[&target];
            iso230::Observation {
                target: target as usize,
                position_mm: sum / k as f64,
                run,
                direction: if dir > 0 {
                    iso230::Direction::Up
                } else {
                    iso230::Direction::Down
                },
                e_um: e / n as f64,
            }
        })
        .collect()
}

/// The distinct lines (the two fixed coordinates, mm) of a session's dwell rows.
pub fn lines(rows: &[SessionRow]) -> Vec<(f64, f64)> {
    let mut out: Vec<(i64, i64)> = rows
        .iter()
        .filter(|r| r.target >= 0 && r.run > 0)
        .filter_map(|r| {
            let a = axis_index(r.axis);
            let coords = [r.x_mm, r.y_mm, r.z_mm];
            let o: Vec<Option<f64>> = (0..3).filter(|&b| b != a).map(|b| coords[b]).collect();
            Some((
                (o[0]? * 1000.0).round() as i64,
                (o[1]? * 1000.0).round() as i64,
            ))
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out.into_iter()
        .map(|(a, b)| (a as f64 / 1000.0, b as f64 / 1000.0))
        .collect()
}

/// The environment of a session in words and a table (markdown): air and material
/// temperatures over the session, the refraction compensation the laser lengths used, and
/// what normalisation to the 20 °C reference temperature (ISO 1) would mean.
pub fn environment_summary(rows: &[SessionRow]) -> String {
    use std::fmt::Write as _;
    let stat = |f: &dyn Fn(&SessionRow) -> Option<f64>| -> Option<(f64, f64, f64)> {
        let v: Vec<f64> = rows.iter().filter_map(f).collect();
        (!v.is_empty()).then(|| {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (lo, v.iter().sum::<f64>() / v.len() as f64, hi)
        })
    };
    let mut s =
        String::from("## Environment\n\n| quantity | min | mean | max |\n|---|---|---|---|\n");
    type Column<'a> = (&'a str, &'a dyn Fn(&SessionRow) -> Option<f64>);
    let items: [Column; 5] = [
        ("air temperature °C", &|r| r.air_temp_c),
        ("air pressure hPa", &|r| r.air_pressure_hpa),
        ("relative humidity %", &|r| r.air_rh_pct),
        ("scale temperature °C", &|r| r.scale_temp_c),
        ("part/table temperature °C", &|r| r.part_temp_c),
    ];
    for (name, f) in items {
        match stat(f) {
            Some((lo, m, hi)) => {
                let _ = writeln!(s, "| {name} | {lo:.3} | {m:.3} | {hi:.3} |");
            }
            None => {
                let _ = writeln!(s, "| {name} | — | — | — |");
            }
        }
    }
    let n = |r: &SessionRow| -> Option<f64> {
        Some(errmap_drivers::edlen::refractive_index(
            0.632_991_354,
            r.air_temp_c?,
            r.air_pressure_hpa? * 100.0,
            r.air_rh_pct?,
        ))
    };
    let uncompensated = rows.iter().filter(|r| r.air_temp_c.is_none()).count();
    match stat(&n) {
        Some((lo, m, hi)) => {
            let _ = writeln!(
                s,
                "\nRefraction: every laser length was compensated with the modified Edlén equation \
                 (Birch & Downs 1994) at the row's own air temperature, pressure and humidity (HeNe \
                 633 nm): n − 1 from {:.3} to {:.3} ppm (mean {:.3} ppm), a {:.3} ppm span.",
                (lo - 1.0) * 1e6,
                (hi - 1.0) * 1e6,
                (m - 1.0) * 1e6,
                (hi - lo) * 1e6
            );
        }
        None => s.push_str(
            "\nRefraction: no air data; laser lengths are in vacuum wavelengths (n = 1).\n",
        ),
    }
    if uncompensated > 0 {
        let _ = writeln!(
            s,
            "\n{uncompensated} rows came before the first ENV frame and carry no air compensation (n = 1)."
        );
    }
    if let Some((_, m, _)) = stat(&|r| r.scale_temp_c) {
        let len = rows.iter().map(|r| r.scale_mm).fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "\nNormalisation to 20 °C (ISO 1): the errors above are as measured, not normalised. \
             The scale was on average {:+.3} K from 20 °C; for a steel scale (11.5 ppm/K) that is \
             {:+.3} µm over the {:.0} mm travel — the size of the correction a normalisation would \
             apply, and why a thermal model of the scale belongs in the machine model.",
            m - 20.0,
            -11.5 * (m - 20.0) * len * 1e-3,
            len
        );
    }
    s
}
