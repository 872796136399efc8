//! Session → error table and ISO 230-2 observations (the rules are in the module docs of
//! [`crate::session`]), in one pass over the rows: [`Reducer`] keeps per-(line, target)
//! Welford accumulators and per-dwell sums, so a session of any length reduces in memory
//! bounded by its number of dwells.

use std::collections::{BTreeMap, BTreeSet};

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

fn has_air(r: &SessionRow) -> bool {
    r.air_temp_c.is_some() && r.air_pressure_hpa.is_some() && r.air_rh_pct.is_some()
}

/// Running mean and sum of squared deviations (Welford 1962): after n values,
/// mean_n = mean_{n−1} + (x − mean_{n−1})/n and M2_n = M2_{n−1} + (x − mean_{n−1})(x − mean_n);
/// the sample standard deviation is √(M2/(n − 1)). Numerically stable in one pass, O(1)
/// memory.
#[derive(Debug, Clone, Copy, Default)]
struct Welford {
    n: u64,
    mean: f64,
    m2: f64,
}

impl Welford {
    fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }

    fn s(&self) -> Option<f64> {
        (self.n > 1).then(|| (self.m2 / (self.n - 1) as f64).sqrt())
    }
}

/// Line key: the two fixed coordinates in whole micrometres (MARK frames carry them so).
type LineKey = (i64, i64);

fn line_key(r: &SessionRow, axis_index: usize) -> Option<LineKey> {
    let coords = [r.x_mm, r.y_mm, r.z_mm];
    let mut o = (0..3).filter(|&b| b != axis_index).map(|b| coords[b]);
    let (c1, c2) = (o.next()??, o.next()??);
    Some(((c1 * 1000.0).round() as i64, (c2 * 1000.0).round() as i64))
}

/// (Σ error µm, Σ scale mm, n) of one dwell.
type DwellSums = (f64, f64, usize);

/// The accumulators of one half of a session: rows with air values, or rows without.
/// Which half is used is known only at the end (see the module docs of
/// [`crate::session`]): the rows without air values count only when no row has them.
#[derive(Debug, Clone, Default)]
struct Half {
    /// Unflagged dwell rows.
    dwell: usize,
    /// Of those, rows without line coordinates (for the session's axis).
    no_line: usize,
    /// Error per (line, target).
    groups: BTreeMap<(i64, i64, i32), Welford>,
    /// Σ scale, n per target over the rows in `groups`.
    positions: BTreeMap<i32, (f64, usize)>,
    /// Dwell sums per (target, run, direction), every line together.
    dwells: BTreeMap<(i32, u32, i8), DwellSums>,
    /// Dwell sums per (line, target, run, direction).
    dwells_by_line: BTreeMap<(LineKey, i32, u32, i8), DwellSums>,
}

/// The reduction of a session fed row by row: what [`error_table`], [`iso_observations`]
/// and [`iso_by_line`] compute, from accumulators instead of the rows. Memory grows with
/// the number of (line, target, run, direction) dwells, not with the number of samples.
///
/// The error table's mean and `s_um` come from Welford's running update, so they agree
/// with the two-pass mean and standard deviation to rounding (≈ 1e−15 relative). A line
/// in [`Reducer::iso_observations`] is matched by its coordinates rounded to whole
/// micrometres (the resolution of MARK frames).
#[derive(Debug, Clone, Default)]
pub struct Reducer {
    rows: usize,
    not_dwelling: usize,
    flagged: usize,
    axes: BTreeSet<Axis>,
    any_air: bool,
    /// Lines of the dwell rows (target ≥ 0, run ≥ 1), flagged or not: [`lines`].
    lines: BTreeSet<LineKey>,
    /// [0]: rows with air values, [1]: rows without.
    halves: [Half; 2],
}

impl Reducer {
    /// An empty reduction.
    pub fn new() -> Self {
        Self::default()
    }

    /// The reduction of `rows`.
    pub fn of(rows: &[SessionRow]) -> Self {
        let mut r = Self::new();
        for row in rows {
            r.push(row);
        }
        r
    }

    /// Adds one row.
    pub fn push(&mut self, r: &SessionRow) {
        self.rows += 1;
        let axis = Axis::from(r.axis);
        self.axes.insert(axis);
        let air = has_air(r);
        self.any_air |= air;
        if r.target < 0 || r.run == 0 {
            self.not_dwelling += 1;
            return;
        }
        let line = line_key(r, axis.index());
        if let Some(l) = line {
            self.lines.insert(l);
        }
        if r.flags != 0 {
            self.flagged += 1;
            return;
        }
        let h = &mut self.halves[usize::from(!air)];
        h.dwell += 1;
        if r.direction != 0 {
            let key = (r.target, r.run, r.direction);
            let add = |e: &mut DwellSums| {
                e.0 += r.error_um;
                e.1 += r.scale_mm;
                e.2 += 1;
            };
            add(h.dwells.entry(key).or_default());
            if let Some(l) = line {
                add(h
                    .dwells_by_line
                    .entry((l, key.0, key.1, key.2))
                    .or_default());
            }
        }
        let Some((c1, c2)) = line else {
            h.no_line += 1;
            return;
        };
        h.groups
            .entry((c1, c2, r.target))
            .or_default()
            .push(r.error_um);
        let p = h.positions.entry(r.target).or_insert((0.0, 0));
        p.0 += r.scale_mm;
        p.1 += 1;
    }

    /// The half the reduction uses: rows with air values if any row has them, else all.
    fn used(&self) -> &Half {
        &self.halves[usize::from(!self.any_air)]
    }

    /// The error table (see [`error_table`]).
    pub fn error_table(
        &self,
        source: &str,
    ) -> Result<(ErrorTable, ReductionSummary), ReductionError> {
        if self.axes.len() > 1 {
            return Err(ReductionError::MixedAxes {
                origin: source.to_string(),
                axes: self
                    .axes
                    .iter()
                    .map(|a| a.upper())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let h = self.used();
        let uncompensated = if self.any_air {
            self.halves[1].dwell
        } else {
            0
        };
        let Some(&axis) = self.axes.first() else {
            return Err(ReductionError::NoDwell {
                origin: source.to_string(),
                rows: 0,
                flagged: 0,
                not_dwelling: 0,
                uncompensated: 0,
            });
        };
        if h.groups.is_empty() {
            return Err(ReductionError::NoDwell {
                origin: source.to_string(),
                rows: self.rows,
                flagged: self.flagged,
                not_dwelling: self.not_dwelling,
                uncompensated,
            });
        }
        let a = axis.index();
        let mut lines: Vec<(i64, i64)> = h.groups.keys().map(|k| (k.0, k.1)).collect();
        lines.dedup();
        let summary = ReductionSummary {
            rows: self.rows,
            used: h.dwell - h.no_line,
            flagged: self.flagged,
            not_dwelling: self.not_dwelling,
            no_line: h.no_line,
            uncompensated,
            no_air_data: !self.any_air,
            axis: Some(axis.upper().to_string()),
            lines: lines.len(),
            targets: h.positions.len(),
        };
        let points = h
            .groups
            .iter()
            .map(|(&(c1, c2, target), w)| {
                let (sum, n) = h.positions[&target];
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
                ErrorPoint {
                    x_mm: pos[0],
                    y_mm: pos[1],
                    z_mm: pos[2],
                    e_um: w.mean,
                    n: Some(w.n as u32),
                    s_um: w.s(),
                }
            })
            .collect();
        Ok((ErrorTable::from_points(source, points), summary))
    }

    /// ISO 230-2 observations of one line, or of every row when `line` is `None` (see
    /// [`iso_observations`]).
    pub fn iso_observations(&self, line: Option<(f64, f64)>) -> Vec<iso230::Observation> {
        let h = self.used();
        let acc: Vec<((i32, u32, i8), DwellSums)> = match line {
            None => h.dwells.iter().map(|(k, v)| (*k, *v)).collect(),
            Some((c1, c2)) => {
                let l = ((c1 * 1000.0).round() as i64, (c2 * 1000.0).round() as i64);
                h.dwells_by_line
                    .range((l, i32::MIN, 0, i8::MIN)..=(l, i32::MAX, u32::MAX, i8::MAX))
                    .map(|(k, v)| ((k.1, k.2, k.3), *v))
                    .collect()
            }
        };
        observations(&acc)
    }

    /// The distinct lines of the dwell rows, mm (see [`lines`]).
    pub fn lines(&self) -> Vec<(f64, f64)> {
        self.lines
            .iter()
            .map(|&(a, b)| (a as f64 / 1000.0, b as f64 / 1000.0))
            .collect()
    }

    /// ISO 230-2 statistics per line (see [`iso_by_line`]).
    #[allow(clippy::type_complexity)]
    pub fn iso_by_line(
        &self,
    ) -> (
        Vec<((f64, f64), iso230::AxisStats)>,
        Vec<((f64, f64), iso230::IsoError)>,
    ) {
        let mut ok = Vec::new();
        let mut failed = Vec::new();
        for line in self.lines() {
            match iso230::axis_stats(&self.iso_observations(Some(line))) {
                Ok(stats) => ok.push((line, stats)),
                Err(e) => failed.push((line, e)),
            }
        }
        (ok, failed)
    }
}

/// One observation per dwell, the position of a target being the mean of its dwells'
/// mean scale readings (ISO 230-2's P_i).
fn observations(acc: &[((i32, u32, i8), DwellSums)]) -> Vec<iso230::Observation> {
    let mut pos_sum: BTreeMap<i32, (f64, usize)> = BTreeMap::new();
    for &((target, _, _), (_, pos, n)) in acc {
        let p = pos_sum.entry(target).or_insert((0.0, 0));
        p.0 += pos / n as f64;
        p.1 += 1;
    }
    acc.iter()
        .map(|&((target, run, dir), (e, _, n))| {
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

/// Reduces a session to an error table (see the module docs).
pub fn error_table(
    source: &str,
    rows: &[SessionRow],
) -> Result<(ErrorTable, ReductionSummary), ReductionError> {
    Reducer::of(rows).error_table(source)
}

/// ISO 230-2 observations of one line of a session: one per (target, run, direction),
/// the mean of that dwell's unflagged samples.
pub fn iso_observations(rows: &[SessionRow], line: Option<(f64, f64)>) -> Vec<iso230::Observation> {
    Reducer::of(rows).iso_observations(line)
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
    Reducer::of(rows).iso_by_line()
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
