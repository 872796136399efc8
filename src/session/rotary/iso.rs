//! ISO 230-2 in arcseconds, the closure check and the rotary error table
//! (`docs/rotary.md` §2).
//!
//! An observation is one dwell: x_ij = −(mean `error_arcsec` of the dwell rows of target
//! i, run j, one direction). The figures are [`crate::session::axis_stats`]' (ISO
//! 230-2:2014 clause 3), every target evaluated, 0 and 360 both.
//!
//! **Closure.** 0° and 360° are one physical position. Per direction d, the difference
//! x̄_d(360) − x̄_d(0) is compared with 2·max(s_d(0), s_d(360)): two means of the same
//! position should agree within twice the larger scatter of their observations. Beyond
//! it the axis did not come back to where it started: a ratio error (the axis' gear ratio
//! or encoder line count, or the reference's) or a drift during the test.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use super::{ANGLE_TOL_DEG, RotaryError, RotarySession};
use crate::base::{Direction, RotaryAxis};
use crate::session::{AxisStats, Observation, axis_stats};
use crate::table::{format_err, write_frame};

/// One target's ISO 230-2 values, ″ (deviations x = −e), its position in °.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RotaryTargetStats {
    pub target: usize,
    pub position_deg: f64,
    pub n_up: usize,
    pub n_down: usize,
    pub mean_up_arcsec: f64,
    pub mean_down_arcsec: f64,
    pub mean_bidir_arcsec: f64,
    /// B_i = x̄_i↑ − x̄_i↓.
    pub reversal_arcsec: f64,
    pub s_up_arcsec: f64,
    pub s_down_arcsec: f64,
    pub repeat_up_arcsec: f64,
    pub repeat_down_arcsec: f64,
    /// R_i.
    pub repeat_bidir_arcsec: f64,
}

/// The axis' ISO 230-2 values, ″.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RotaryIso {
    pub b_arcsec: f64,
    pub mean_reversal_arcsec: f64,
    pub r_up_arcsec: f64,
    pub r_down_arcsec: f64,
    pub r_arcsec: f64,
    pub e_up_arcsec: f64,
    pub e_down_arcsec: f64,
    pub e_arcsec: f64,
    pub m_arcsec: f64,
    pub a_up_arcsec: f64,
    pub a_down_arcsec: f64,
    pub a_arcsec: f64,
    pub targets: Vec<RotaryTargetStats>,
}

impl RotaryIso {
    fn from_stats(s: &AxisStats) -> Self {
        RotaryIso {
            b_arcsec: s.b_um,
            mean_reversal_arcsec: s.mean_reversal_um,
            r_up_arcsec: s.r_up_um,
            r_down_arcsec: s.r_down_um,
            r_arcsec: s.r_um,
            e_up_arcsec: s.e_up_um,
            e_down_arcsec: s.e_down_um,
            e_arcsec: s.e_um,
            m_arcsec: s.m_um,
            a_up_arcsec: s.a_up_um,
            a_down_arcsec: s.a_down_um,
            a_arcsec: s.a_um,
            targets: s
                .targets
                .iter()
                .map(|t| RotaryTargetStats {
                    target: t.target,
                    position_deg: t.position_mm,
                    n_up: t.n_up,
                    n_down: t.n_down,
                    mean_up_arcsec: t.mean_up_um,
                    mean_down_arcsec: t.mean_down_um,
                    mean_bidir_arcsec: t.mean_bidir_um,
                    reversal_arcsec: t.reversal_um,
                    s_up_arcsec: t.s_up_um,
                    s_down_arcsec: t.s_down_um,
                    repeat_up_arcsec: t.repeat_up_um,
                    repeat_down_arcsec: t.repeat_down_um,
                    repeat_bidir_arcsec: t.repeat_bidir_um,
                })
                .collect(),
        }
    }

    /// The target at `deg`, if measured.
    fn at(&self, deg: f64) -> Option<&RotaryTargetStats> {
        self.targets
            .iter()
            .find(|t| (t.position_deg - deg).abs() <= ANGLE_TOL_DEG)
    }
}

/// The closure check: the same physical position, 0° and 360°, per direction (″).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Closure {
    /// x̄↑(360) − x̄↑(0).
    pub diff_up_arcsec: f64,
    /// 2·max(s↑(0), s↑(360)).
    pub limit_up_arcsec: f64,
    pub diff_down_arcsec: f64,
    pub limit_down_arcsec: f64,
    /// Both |diff| ≤ limit.
    pub consistent: bool,
}

impl Closure {
    fn of(iso: &RotaryIso) -> Option<Closure> {
        let (z, f) = (iso.at(0.0)?, iso.at(360.0)?);
        let diff_up_arcsec = f.mean_up_arcsec - z.mean_up_arcsec;
        let diff_down_arcsec = f.mean_down_arcsec - z.mean_down_arcsec;
        let limit_up_arcsec = 2.0 * z.s_up_arcsec.max(f.s_up_arcsec);
        let limit_down_arcsec = 2.0 * z.s_down_arcsec.max(f.s_down_arcsec);
        Some(Closure {
            diff_up_arcsec,
            limit_up_arcsec,
            diff_down_arcsec,
            limit_down_arcsec,
            consistent: diff_up_arcsec.abs() <= limit_up_arcsec
                && diff_down_arcsec.abs() <= limit_down_arcsec,
        })
    }
}

/// The `closure_mismatch:` warning when the closure pair disagrees, with the likely causes.
pub fn closure_warning(c: &Closure) -> Option<String> {
    (!c.consistent).then(|| {
        format!(
            "closure_mismatch: 0° and 360° are one physical position but their mean deviations \
             differ by {:.2}″ (up, limit {:.2}″) and {:.2}″ (down, limit {:.2}″), beyond the \
             position's repeatability; likely causes: a ratio error (the axis' gear ratio or \
             encoder line count, or the reference's), or a drift during the test (thermal, \
             the reference's zero)",
            c.diff_up_arcsec, c.limit_up_arcsec, c.diff_down_arcsec, c.limit_down_arcsec
        )
    })
}

/// The dwell means: (target index, angle, run, direction) → mean `error_arcsec`.
fn dwell_means(s: &RotarySession) -> BTreeMap<(i32, u32, i8), (f64, f64, usize)> {
    let mut m: BTreeMap<(i32, u32, i8), (f64, f64, usize)> = BTreeMap::new();
    for r in s.rows.iter().filter(|r| r.is_dwell()) {
        let e = m.entry((r.target, r.run, r.direction)).or_insert((
            r.target_deg.unwrap_or(0.0),
            0.0,
            0,
        ));
        e.1 += r.error_arcsec;
        e.2 += 1;
    }
    m
}

/// ISO 230-2 of a rotary session in ″, and its closure check when it has 0 and 360.
pub fn rotary_iso(
    path: &Path,
    s: &RotarySession,
) -> Result<(RotaryIso, Option<Closure>), RotaryError> {
    let targets = s.targets();
    let rank = |t: i32| targets.iter().position(|x| x.0 == t).unwrap_or(0);
    let obs: Vec<Observation> = dwell_means(s)
        .into_iter()
        .map(|((target, run, d), (deg, sum, n))| Observation {
            target: rank(target),
            position_mm: deg,
            run,
            direction: if d > 0 {
                Direction::Up
            } else {
                Direction::Down
            },
            e_um: sum / n as f64,
        })
        .collect();
    let stats = axis_stats(&obs).map_err(|e| RotaryError::Whole {
        path: path.to_path_buf(),
        problem: format!(
            "no ISO 230-2 figures: {}",
            e.to_string().replace(" mm", "°")
        ),
    })?;
    let mut iso = RotaryIso::from_stats(&stats);
    for t in &mut iso.targets {
        t.target = targets.get(t.target).map_or(t.target, |x| x.0 as usize);
    }
    let closure = Closure::of(&iso);
    Ok((iso, closure))
}

/// One row of the rotary error table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RotaryTableRow {
    pub angle_deg: f64,
    /// Mean `error_arcsec` of every dwell row at the target, both directions.
    pub e_arcsec: f64,
    pub n: usize,
    /// Their n − 1 standard deviation (0 with one row).
    pub s_arcsec: f64,
}

/// The rotary error table: one row per target, ascending, 0 and 360 both.
pub fn rotary_error_table(s: &RotarySession) -> Vec<RotaryTableRow> {
    s.targets()
        .into_iter()
        .map(|(idx, deg)| {
            let e: Vec<f64> = s
                .rows
                .iter()
                .filter(|r| r.is_dwell() && r.target == idx)
                .map(|r| r.error_arcsec)
                .collect();
            let n = e.len();
            let mean = e.iter().sum::<f64>() / n as f64;
            let ss: f64 = e.iter().map(|v| (v - mean).powi(2)).sum();
            RotaryTableRow {
                angle_deg: deg,
                e_arcsec: mean,
                n,
                s_arcsec: if n > 1 {
                    (ss / (n - 1) as f64).sqrt()
                } else {
                    0.0
                },
            }
        })
        .collect()
}

/// Writes the rotary error table (CSV or Parquet): `<axis>_deg, e_arcsec, n, s_arcsec`.
pub fn write_rotary_error_table(
    path: &Path,
    axis: RotaryAxis,
    rows: &[RotaryTableRow],
) -> Result<(), RotaryError> {
    use polars::prelude::*;
    let col = |name: &str, f: &dyn Fn(&RotaryTableRow) -> f64| {
        Column::new(name.into(), rows.iter().map(f).collect::<Vec<f64>>())
    };
    let mut df = DataFrame::new(
        rows.len(),
        vec![
            col(axis.column(), &|r| r.angle_deg),
            col("e_arcsec", &|r| r.e_arcsec),
            Column::new(
                "n".into(),
                rows.iter().map(|r| r.n as i64).collect::<Vec<i64>>(),
            ),
            col("s_arcsec", &|r| r.s_arcsec),
        ],
    )
    .map_err(|e| format_err(path, e))?;
    Ok(write_frame(path, &mut df)?)
}

/// A rotary error table as read: its axis and (θ °, e ″) rows, ascending.
pub type RotaryTable = (RotaryAxis, Vec<(f64, f64)>);

/// Reads a rotary error table (`<axis>_deg`, `e_arcsec`, …): its axis and (θ, e) rows,
/// ascending; `None` when the table has no `a_deg`, `b_deg` or `c_deg` column.
pub fn read_rotary_error_table(path: &Path) -> Result<Option<RotaryTable>, RotaryError> {
    let df = crate::table::read_frame(path)?;
    let Some(axis) = RotaryAxis::ALL
        .into_iter()
        .find(|a| df.column(a.column()).is_ok())
    else {
        return Ok(None);
    };
    let angle = crate::table::column_cells(path, &df, axis.column())?;
    let e = crate::table::column_cells(path, &df, "e_arcsec")?;
    let mut rows = Vec::with_capacity(df.height());
    for r in 0..df.height() {
        let q = crate::table::required_cell(path, &angle, r, axis.column())?;
        let v = crate::table::required_cell(path, &e, r, "e_arcsec")?;
        if !(0.0..=360.0).contains(&q) {
            return Err(RotaryError::At {
                path: path.to_path_buf(),
                line: r + 2,
                column: axis.column().into(),
                problem: format!("{q}° is outside [0, 360]"),
            });
        }
        if v.abs() > 1e6 {
            return Err(RotaryError::At {
                path: path.to_path_buf(),
                line: r + 2,
                column: "e_arcsec".into(),
                problem: format!("{v} is outside ±1000000″"),
            });
        }
        if let Some(&(p, _)) = rows.last()
            && q <= p
        {
            return Err(RotaryError::At {
                path: path.to_path_buf(),
                line: r + 2,
                column: axis.column().into(),
                problem: format!("{q}° after {p}°: the angles must increase"),
            });
        }
        rows.push((q, v));
    }
    Ok(Some((axis, rows)))
}
