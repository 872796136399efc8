//! Session → error table and ISO 230-2 observations (the rules are in the module docs of
//! [`crate::session`]).

use std::collections::BTreeMap;

use errmap_drivers::SessionRow;
use serde::Serialize;

use super::iso230;
use crate::base::Axis;
use crate::table::{ErrorPoint, ErrorTable};

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
    let mut axes: Vec<Axis> = rows.iter().map(|r| Axis::from(r.axis)).collect();
    axes.sort();
    axes.dedup();
    if axes.len() > 1 {
        return Err(ReductionError::MixedAxes {
            origin: source.to_string(),
            axes: axes
                .iter()
                .map(|a| a.upper())
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
    summary.axis = Some(axis.upper().to_string());
    let a = axis.index();
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
            let a = Axis::from(r.axis).index();
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

/// ISO 230-2 statistics of every line of a session; the lines whose statistics cannot be
/// computed come second, with the reason.
#[allow(clippy::type_complexity)]
pub fn iso_by_line(
    rows: &[SessionRow],
) -> (
    Vec<((f64, f64), iso230::AxisStats)>,
    Vec<((f64, f64), iso230::IsoError)>,
) {
    let mut ok = Vec::new();
    let mut failed = Vec::new();
    for line in lines(rows) {
        match iso230::axis_stats(&iso_observations(rows, Some(line))) {
            Ok(stats) => ok.push((line, stats)),
            Err(e) => failed.push((line, e)),
        }
    }
    (ok, failed)
}

/// The distinct lines (the two fixed coordinates, mm) of a session's dwell rows.
pub fn lines(rows: &[SessionRow]) -> Vec<(f64, f64)> {
    let mut out: Vec<(i64, i64)> = rows
        .iter()
        .filter(|r| r.target >= 0 && r.run > 0)
        .filter_map(|r| {
            let a = Axis::from(r.axis).index();
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
