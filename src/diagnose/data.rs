//! From two session tables to one residual series with its covariates, the noise groups
//! and the cross-validation folds.
//!
//! Rows are matched on (`run`, `sample`) through a hash map, whatever their order: O(n).
//! Every covariate comes from the recorded row. Optional columns that are empty on some
//! rows are filled by linear interpolation in time from the rows that have them; a column
//! empty on every row makes the effects that need it untestable (said in the report).

pub(crate) use crate::base::median;
use std::collections::{BTreeMap, HashMap};

use errmap_drivers::{Axis, SessionRow};
use serde::Serialize;

use super::DiagnoseError;
use super::engine::MapGroups;
use super::outcome::StaticMapSummary;

/// At most one matched row in this many may start a new axis (see [`build`]).
const MAX_SWITCH_SHARE: usize = 4;

/// Fewest usable matched rows the diagnosis works on.
pub(crate) const MIN_ROWS: usize = 20;

/// How the two tables matched (all counts are rows).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Matching {
    /// Rows in the recorded table.
    pub recorded_rows: usize,
    /// Rows in the simulated table.
    pub simulated_rows: usize,
    /// Rows matched on (run, sample).
    pub matched_rows: usize,
    /// Matched rows used in the fits.
    pub used_rows: usize,
    /// Recorded rows with no simulated partner.
    pub only_in_recorded: usize,
    /// Simulated rows with no recorded partner.
    pub only_in_simulated: usize,
    /// Matched rows left out because `flags` ≠ 0 in either table.
    pub flagged_rows: usize,
    /// Rows whose (run, sample) occurs more than once in its table (left out, never guessed).
    pub duplicate_keys: usize,
    /// Matched rows left out for a non-finite error or position.
    pub non_finite_rows: usize,
    /// Matched rows measuring another axis than the session's main one (left out).
    pub other_axis_rows: usize,
}

/// The residual and its covariates, one entry per used row (in recorded-table order).
#[derive(Debug, Clone)]
pub(crate) struct Obs {
    pub axis: Axis,
    /// r = recorded − simulated error, µm.
    pub r: Vec<f64>,
    /// The recorded error alone, µm (its own noise: [`shared_noise_floor`]).
    pub rec: Vec<f64>,
    /// Position along the measured axis, mm.
    pub x: Vec<f64>,
    /// Direction ±1 (0 outside a run).
    pub d: Vec<f64>,
    /// Moving row (target = −1).
    pub moving: Vec<bool>,
    /// Feed on moving rows, 0 on dwell rows, mm/s.
    pub v_feed: Vec<f64>,
    /// Carriage speed measured from successive samples on moving rows, 0 on dwell rows.
    pub v_meas: Vec<f64>,
    /// The moves: runs of consecutive moving rows of one run and direction, as row
    /// indices in sample order.
    pub moves: Vec<Vec<usize>>,
    /// `t_s`.
    pub t: Vec<f64>,
    /// First row of the recorded session, s.
    pub t0: f64,
    pub run: Vec<u32>,
    /// `sample` of every row (with `run`, its key in the recording).
    pub sample: Vec<i64>,
    /// Target index (−1 while moving).
    pub target: Vec<i32>,
    /// The two other coordinates (for X: y, z), when every used row has them.
    pub c: [Option<Vec<f64>>; 2],
    /// The two other axes, in the order of `c`.
    pub c_axes: [crate::base::Axis; 2],
    /// Line index of every row, and the lines' two other coordinates.
    pub line: Vec<usize>,
    pub lines: Vec<[f64; 2]>,
    pub scale_t: Option<Vec<f64>>,
    pub air_t: Option<Vec<f64>>,
    pub air_p: Option<Vec<f64>>,
    pub air_rh: Option<Vec<f64>>,
    /// The scale counter's step along the axis, µm, found in the recorded readings
    /// ([`counter_quantum_um`]); 0 when they show none.
    pub quantum_um: f64,
}

impl Obs {
    pub(crate) fn len(&self) -> usize {
        self.r.len()
    }
}

fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::X => "X",
        Axis::Y => "Y",
        Axis::Z => "Z",
    }
}

/// Rows that share one random offset: a dwell's samples (run, line, target, direction)
/// and a move's samples; every other row alone. One id per row.
pub(crate) fn clusters(obs: &Obs) -> Vec<usize> {
    let n = obs.len();
    let mut id = vec![usize::MAX; n];
    let mut next = 0;
    for seg in &obs.moves {
        for &k in seg {
            id[k] = next;
        }
        next += 1;
    }
    let mut dwell: BTreeMap<(u32, usize, i32, i8), usize> = BTreeMap::new();
    for k in 0..n {
        if id[k] != usize::MAX {
            continue;
        }
        id[k] = if obs.target[k] >= 0 {
            *dwell
                .entry((obs.run[k], obs.line[k], obs.target[k], obs.d[k] as i8))
                .or_insert_with(|| {
                    next += 1;
                    next - 1
                })
        } else {
            next += 1;
            next - 1
        };
    }
    id
}

/// Moving rows are grouped by this fraction of the travel (with line and direction).
const MOVING_BIN_FRACTION: f64 = 1.0 / 40.0;

/// Groups of the static map: (line, target, direction) for dwell rows, a constant each;
/// (line, direction, 1/40 of the travel) for moving rows, a straight line in x each; and
/// the map's summary from the plain means of the dwell groups (its span, and the reversal
/// ē↑ − ē↓ per target).
pub(crate) fn static_map(obs: &Obs) -> (MapGroups, StaticMapSummary) {
    let n = obs.len();
    let (lo, hi) = obs
        .x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let bin = ((hi - lo) * MOVING_BIN_FRACTION).max(1e-6);
    let mut ids: BTreeMap<(usize, i64, i8), usize> = BTreeMap::new();
    let group: Vec<usize> = (0..n)
        .map(|k| {
            let place = if obs.moving[k] {
                -1 - ((obs.x[k] - lo) / bin).floor() as i64
            } else {
                i64::from(obs.target[k])
            };
            let key = (obs.line[k], place, obs.d[k] as i8);
            let next = ids.len();
            *ids.entry(key).or_insert(next)
        })
        .collect();
    let ng = ids.len();
    let mut sum = vec![0.0; ng];
    let mut count = vec![0usize; ng];
    for k in 0..n {
        sum[group[k]] += obs.r[k];
        count[group[k]] += 1;
    }
    let means: Vec<f64> = (0..ng).map(|g| sum[g] / count[g].max(1) as f64).collect();
    let mut reversal = Vec::new();
    for (&(line, place, d), &g) in &ids {
        if place >= 0
            && d > 0
            && let Some(&h) = ids.get(&(line, place, -d))
        {
            reversal.push(means[g] - means[h]);
        }
    }
    let dwell: Vec<f64> = ids
        .iter()
        .filter(|(k, _)| k.1 >= 0)
        .map(|(_, &g)| means[g])
        .collect();
    let span = |v: &[f64]| {
        let (a, b) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        if b >= a { b - a } else { 0.0 }
    };
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let summary = StaticMapSummary {
        groups: ng,
        dwell_groups: dwell.len(),
        map_span_um: span(&dwell),
        mean_reversal_um: mean(&reversal),
        reversal_span_um: span(&reversal),
        targets_with_reversal: reversal.len(),
    };
    let mut linear = vec![false; ng];
    for (&(_, place, _), &g) in &ids {
        linear[g] = place < 0;
    }
    let groups = MapGroups {
        group,
        x: obs.x.clone(),
        linear,
    };
    (groups, summary)
}

pub(crate) fn axis_label(a: Axis) -> &'static str {
    axis_name(a)
}

/// The two other axes of `a`, and the coordinate picker for a row.
fn others(a: Axis) -> [crate::base::Axis; 2] {
    use crate::base::Axis as A;
    match a {
        Axis::X => [A::Y, A::Z],
        Axis::Y => [A::X, A::Z],
        Axis::Z => [A::X, A::Y],
    }
}

fn coord(row: &SessionRow, a: crate::base::Axis) -> Option<f64> {
    use crate::base::Axis as A;
    match a {
        A::X => row.x_mm,
        A::Y => row.y_mm,
        A::Z => row.z_mm,
    }
}

fn along(row: &SessionRow, a: Axis) -> f64 {
    let v = match a {
        Axis::X => row.x_mm,
        Axis::Y => row.y_mm,
        Axis::Z => row.z_mm,
    };
    v.filter(|v| v.is_finite()).unwrap_or(row.scale_mm)
}

/// Key (run, sample) → row index, duplicates marked `usize::MAX`; and how many rows
/// share a key.
fn key_index(rows: &[SessionRow]) -> (HashMap<(u32, i64), usize>, usize) {
    let mut map: HashMap<(u32, i64), usize> = HashMap::with_capacity(rows.len());
    let mut dups = 0usize;
    for (i, r) in rows.iter().enumerate() {
        map.entry((r.run, r.sample))
            .and_modify(|v| {
                if *v != usize::MAX {
                    dups += 1;
                }
                dups += 1;
                *v = usize::MAX;
            })
            .or_insert(i);
    }
    (map, dups)
}

/// Pairs recorded and simulated rows by (run, sample), duplicates left out, counting in
/// `m` what did not pair; refuses sessions with no pair at all.
fn match_rows(
    recorded: &[SessionRow],
    simulated: &[SessionRow],
    m: &mut Matching,
) -> Result<Vec<(usize, usize)>, DiagnoseError> {
    let (sim_map, sim_dups) = key_index(simulated);
    let (rec_map, rec_dups) = key_index(recorded);
    m.duplicate_keys = sim_dups + rec_dups;

    let mut pairs: Vec<(usize, usize)> = Vec::with_capacity(recorded.len());
    for (i, row) in recorded.iter().enumerate() {
        let key = (row.run, row.sample);
        if rec_map.get(&key) == Some(&usize::MAX) {
            continue;
        }
        match sim_map.get(&key) {
            None => m.only_in_recorded += 1,
            Some(&usize::MAX) => {}
            Some(&j) => pairs.push((i, j)),
        }
    }
    m.only_in_simulated = simulated
        .iter()
        .filter(|s| {
            let key = (s.run, s.sample);
            sim_map.get(&key) != Some(&usize::MAX) && !rec_map.contains_key(&key)
        })
        .count();
    m.matched_rows = pairs.len();
    if pairs.is_empty() {
        return Err(DiagnoseError::NoMatch {
            recorded: recorded.len(),
            simulated: simulated.len(),
        });
    }
    Ok(pairs)
}

/// The session's axis, the most common one among matched rows; refuses rows that keep
/// switching axis (a line-to-line move on another axis changes it twice per line; more
/// is interleaved sessions or damage).
fn session_axis(recorded: &[SessionRow], pairs: &[(usize, usize)]) -> Result<Axis, DiagnoseError> {
    let switches = pairs
        .windows(2)
        .filter(|w| recorded[w[0].0].axis != recorded[w[1].0].axis)
        .count();
    if switches * MAX_SWITCH_SHARE > pairs.len() {
        return Err(DiagnoseError::AxesInterleaved {
            switches,
            rows: pairs.len(),
        });
    }
    let mut counts = [0usize; 3];
    for &(i, _) in pairs {
        counts[recorded[i].axis.code() as usize] += 1;
    }
    let code = (0..3).max_by_key(|&k| counts[k]).unwrap_or(0);
    Ok(Axis::from_code(code as u8).unwrap_or(Axis::X))
}

/// The pairs the diagnosis uses, with their residual recorded − simulated: unflagged, on
/// the session's axis, finite (each exclusion counted in `m`); refuses too few rows and
/// sessions without runs.
fn usable_rows(
    recorded: &[SessionRow],
    simulated: &[SessionRow],
    pairs: &[(usize, usize)],
    axis: Axis,
    m: &mut Matching,
) -> Result<Vec<(usize, f64)>, DiagnoseError> {
    let mut used: Vec<(usize, f64)> = Vec::with_capacity(pairs.len());
    for &(i, j) in pairs {
        let (rec, sim) = (&recorded[i], &simulated[j]);
        if rec.flags != 0 || sim.flags != 0 {
            m.flagged_rows += 1;
            continue;
        }
        if rec.axis != axis {
            m.other_axis_rows += 1;
            continue;
        }
        let r = rec.error_um - sim.error_um;
        if !r.is_finite() || !along(rec, axis).is_finite() || !rec.t_s.is_finite() {
            m.non_finite_rows += 1;
            continue;
        }
        used.push((i, r));
    }
    m.used_rows = used.len();
    if used.len() < MIN_ROWS {
        return Err(DiagnoseError::TooFewRows {
            usable: used.len(),
            needed: MIN_ROWS,
            detail: format!(
                "{} matched, {} flagged, {} non-finite, {} on another axis",
                m.matched_rows, m.flagged_rows, m.non_finite_rows, m.other_axis_rows
            ),
        });
    }
    if used.iter().all(|&(i, _)| recorded[i].run == 0) {
        return Err(DiagnoseError::NoRuns { rows: used.len() });
    }
    Ok(used)
}

/// The lines: distinct pairs of the two other coordinates (to 1 µm), numbered in order
/// of first appearance; returns each line's coordinates and each row's line.
fn lines_of(c_filled: &[Option<Vec<f64>>; 2], n: usize) -> (Vec<[f64; 2]>, Vec<usize>) {
    let mut line_ids: BTreeMap<(i64, i64), usize> = BTreeMap::new();
    let key = |v: Option<f64>| v.map_or(i64::MIN, |v| (v * 1000.0).round() as i64);
    let line_key = |k: usize| {
        let get = |i: usize| c_filled[i].as_ref().map(|v| v[k]);
        (key(get(0)), key(get(1)))
    };
    for k in 0..n {
        let next = line_ids.len();
        line_ids.entry(line_key(k)).or_insert(next);
    }
    let mut lines = vec![[f64::NAN; 2]; line_ids.len()];
    for (k, &id) in &line_ids {
        let f = |v: i64| {
            if v == i64::MIN {
                f64::NAN
            } else {
                v as f64 / 1000.0
            }
        };
        lines[id] = [f(k.0), f(k.1)];
    }
    let line: Vec<usize> = (0..n)
        .map(|k| line_ids.get(&line_key(k)).copied().unwrap_or(0))
        .collect();
    (lines, line)
}

/// Matches the tables and builds the observations.
pub(crate) fn build(
    recorded: &[SessionRow],
    simulated: &[SessionRow],
) -> Result<(Obs, Matching), DiagnoseError> {
    if recorded.is_empty() {
        return Err(DiagnoseError::Empty { which: "recorded" });
    }
    if simulated.is_empty() {
        return Err(DiagnoseError::Empty { which: "simulated" });
    }
    let mut m = Matching {
        recorded_rows: recorded.len(),
        simulated_rows: simulated.len(),
        ..Matching::default()
    };
    let pairs = match_rows(recorded, simulated, &mut m)?;
    let axis = session_axis(recorded, &pairs)?;
    let used = usable_rows(recorded, simulated, &pairs, axis, &mut m)?;

    let t0 = recorded
        .iter()
        .map(|r| r.t_s)
        .filter(|t| t.is_finite())
        .fold(f64::INFINITY, f64::min);
    let rows: Vec<&SessionRow> = used.iter().map(|&(i, _)| &recorded[i]).collect();
    let n = rows.len();
    let r: Vec<f64> = used.iter().map(|&(_, r)| r).collect();
    let x: Vec<f64> = rows.iter().map(|row| along(row, axis)).collect();
    let d: Vec<f64> = rows
        .iter()
        .map(|row| f64::from(row.direction.signum()))
        .collect();
    let moving: Vec<bool> = rows.iter().map(|row| row.target < 0).collect();
    let feed: Vec<Option<f64>> = rows
        .iter()
        .map(|row| row.feed_mm_s.filter(|f| f.is_finite()).map(f64::abs))
        .collect();
    let v_feed: Vec<f64> = (0..n)
        .map(|k| {
            if moving[k] {
                feed[k].unwrap_or(0.0)
            } else {
                0.0
            }
        })
        .collect();
    let t: Vec<f64> = rows.iter().map(|row| row.t_s).collect();
    let run: Vec<u32> = rows.iter().map(|row| row.run).collect();
    let sample: Vec<i64> = rows.iter().map(|row| row.sample).collect();
    let moves = move_segments(&run, &sample, &moving, &d);
    let v_meas = measured_speed(&x, &t, &moves, &v_feed);

    let c_axes = others(axis);
    // The line coordinates: rows without them (before the first MARK) take the value of
    // the nearest earlier row in time, or of the first row that has one.
    let c_filled: [Option<Vec<f64>>; 2] = c_axes.map(|a| {
        step_fill(
            &t,
            rows.iter()
                .map(|row| coord(row, a).filter(|v| v.is_finite())),
        )
    });
    let (lines, line) = lines_of(&c_filled, n);
    let c = c_filled;

    let column = |f: &dyn Fn(&SessionRow) -> Option<f64>| {
        fill_by_time(&t, rows.iter().map(|row| f(row).filter(|v| v.is_finite())))
    };
    let scale_t = column(&|row| row.scale_temp_c);
    let air_t = column(&|row| row.air_temp_c);
    let air_p = column(&|row| row.air_pressure_hpa);
    let air_rh = column(&|row| row.air_rh_pct);
    let rec: Vec<f64> = rows.iter().map(|row| row.error_um).collect();
    let obs = Obs {
        axis,
        r,
        rec,
        x,
        d,
        moving,
        v_feed,
        v_meas,
        moves,
        t,
        t0: if t0.is_finite() { t0 } else { 0.0 },
        run,
        sample,
        target: rows.iter().map(|row| row.target).collect(),
        c,
        c_axes,
        line,
        lines,
        scale_t,
        air_t,
        air_p,
        air_rh,
        quantum_um: counter_quantum_um(rows.iter().map(|row| row.scale_mm)),
    };
    Ok((obs, m))
}

/// The step of a quantised reading, µm: the greatest common divisor of the gaps between
/// its distinct values, in whole picometres (the unit of the HELLO's count resolution).
/// 0 — no step known — when there are fewer than 50 distinct values (a few dwell
/// positions on round targets say nothing about the counter) or the divisor comes out
/// above 1 µm (no laser calibration counts that coarsely).
pub(crate) fn counter_quantum_um(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    if v.len() < 50 {
        return 0.0;
    }
    let gcd = |mut a: u64, mut b: u64| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let q_pm = v
        .windows(2)
        .map(|w| ((w[1] - w[0]) * 1e9).round() as u64)
        .filter(|&g| g > 0)
        .fold(0, gcd);
    let q_um = q_pm as f64 * 1e-6;
    if q_um > 1.0 { 0.0 } else { q_um }
}

/// A column with gaps filled by linear interpolation in time (constant beyond the ends);
/// `None` when no row has a value.
fn fill_by_time(t: &[f64], vals: impl Iterator<Item = Option<f64>>) -> Option<Vec<f64>> {
    let vals: Vec<Option<f64>> = vals.collect();
    let mut known: Vec<(f64, f64)> = t
        .iter()
        .zip(&vals)
        .filter_map(|(&t, v)| v.map(|v| (t, v)))
        .collect();
    if known.is_empty() {
        return None;
    }
    if known.len() == vals.len() {
        return Some(vals.into_iter().map(|v| v.unwrap_or(0.0)).collect());
    }
    known.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some(
        t.iter()
            .zip(&vals)
            .map(|(&tt, v)| {
                v.unwrap_or_else(|| {
                    let k = known.partition_point(|p| p.0 <= tt);
                    if k == 0 {
                        known[0].1
                    } else if k >= known.len() {
                        known[known.len() - 1].1
                    } else {
                        let (a, b) = (known[k - 1], known[k]);
                        if b.0 > a.0 {
                            a.1 + (b.1 - a.1) * (tt - a.0) / (b.0 - a.0)
                        } else {
                            a.1
                        }
                    }
                })
            })
            .collect(),
    )
}

/// A coordinate column with gaps filled by the nearest earlier row in time (the first
/// known value before it); `None` when fewer than 95 % of the rows have a value.
fn step_fill(t: &[f64], vals: impl Iterator<Item = Option<f64>>) -> Option<Vec<f64>> {
    let vals: Vec<Option<f64>> = vals.collect();
    let known = vals.iter().filter(|v| v.is_some()).count();
    if known == 0 || (known as f64) < 0.95 * vals.len() as f64 {
        return None;
    }
    let mut order: Vec<usize> = (0..t.len()).collect();
    order.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
    let first = order.iter().find_map(|&k| vals[k])?;
    let mut out = vec![0.0; t.len()];
    let mut last = first;
    for &k in &order {
        if let Some(v) = vals[k] {
            last = v;
        }
        out[k] = last;
    }
    Some(out)
}

/// The moves: maximal runs of consecutive moving rows (in (run, sample) order) with one
/// run and one direction, each as row indices in sample order. O(n log n).
fn move_segments(run: &[u32], sample: &[i64], moving: &[bool], d: &[f64]) -> Vec<Vec<usize>> {
    let n = run.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&k| (run[k], sample[k]));
    let mut out = Vec::new();
    let mut start = 0;
    while start < n {
        let k0 = order[start];
        if !moving[k0] {
            start += 1;
            continue;
        }
        let mut end = start + 1;
        while end < n {
            let k = order[end];
            if !moving[k] || run[k] != run[k0] || d[k] != d[k0] {
                break;
            }
            end += 1;
        }
        out.push(order[start..end].to_vec());
        start = end;
    }
    out
}

/// Carriage speed on moving rows from the neighbouring moving samples of the same move
/// (central difference, one-sided at the ends of a move); the feed when a move has a
/// single sample; 0 on dwell rows. O(n).
fn measured_speed(x: &[f64], t: &[f64], moves: &[Vec<usize>], v_feed: &[f64]) -> Vec<f64> {
    let mut v = vec![0.0; x.len()];
    for seg in moves {
        for (p, &k) in seg.iter().enumerate() {
            let (a, b) = match (p.checked_sub(1), seg.get(p + 1)) {
                (Some(pa), Some(&kb)) => (seg[pa], kb),
                (None, Some(&kb)) => (k, kb),
                (Some(pa), None) => (seg[pa], k),
                (None, None) => (k, k),
            };
            let dt = t[b] - t[a];
            v[k] = if a != b && dt > 0.0 {
                ((x[b] - x[a]) / dt).abs()
            } else {
                v_feed[k]
            };
        }
    }
    v
}

/// Noise groups: run × moving/dwell.
#[derive(Debug, Clone)]
pub(crate) struct Groups {
    pub id: Vec<usize>,
    pub labels: Vec<String>,
    pub count: Vec<usize>,
}

pub(crate) fn groups(obs: &Obs) -> Groups {
    let mut map: BTreeMap<(u32, bool), usize> = BTreeMap::new();
    for k in 0..obs.len() {
        let next = map.len();
        map.entry((obs.run[k], obs.moving[k])).or_insert(next);
    }
    let id: Vec<usize> = (0..obs.len())
        .map(|k| map[&(obs.run[k], obs.moving[k])])
        .collect();
    let mut labels = vec![String::new(); map.len()];
    for (&(run, moving), &g) in &map {
        labels[g] = format!("run {run}, {}", if moving { "moving" } else { "dwell" });
    }
    let mut count = vec![0; map.len()];
    for &g in &id {
        count[g] += 1;
    }
    Groups { id, labels, count }
}

/// Robust σ from a sample: 1.4826 · MAD.
pub(crate) fn mad_sigma(v: &[f64]) -> f64 {
    let m = median(v);
    let dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    1.4826 * median(&dev)
}

/// Row indices in time order within each run (run, then t).
fn time_order(obs: &Obs, n: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        (obs.run[a], obs.t[a])
            .partial_cmp(&(obs.run[b], obs.t[b]))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    order
}

/// Per-group noise σ from first differences of successive samples of the same dwell or
/// the same move (σ = 1.4826·MAD/√2): smooth effects cancel, so this sees the noise
/// before any model is fitted. Groups with fewer than 10 differences take the pooled
/// moving or dwell value.
pub(crate) fn noise_from_differences(obs: &Obs, g: &Groups) -> Vec<f64> {
    noise_of_series(obs, &obs.r, g)
}

/// The recording's own noise on its dwells, when the residual is much quieter than it:
/// `Some(σ)` to floor every group's σ at, else `None`. Independent noises add
/// (σ_r² = σ_rec² + σ_sim²), so a residual quieter than the recording alone means the
/// simulation reproduced the recording's noise — a simulated "recording" made with the
/// simulation's own noise seed — and the residual's σ would claim a precision the
/// measurement does not have (issue 40). Compared on the dwell groups only (on a dwell the
/// recorded error is constant but for noise and drift, which first differences cancel); a
/// residual below half the recording's own σ counts as shared.
pub(crate) fn shared_noise_floor(obs: &Obs, g: &Groups, sigma: &[f64]) -> Option<f64> {
    let own = noise_of_series(obs, &obs.rec, g);
    let dwell: Vec<usize> = (0..g.labels.len())
        .filter(|&k| !g.labels[k].ends_with("moving"))
        .collect();
    let own_dwell = median(&dwell.iter().map(|&k| own[k]).collect::<Vec<_>>());
    let resid_dwell = median(&dwell.iter().map(|&k| sigma[k]).collect::<Vec<_>>());
    (own_dwell.is_finite() && resid_dwell.is_finite() && resid_dwell < 0.5 * own_dwell)
        .then_some(own_dwell)
}

/// [`noise_from_differences`] of any series on the rows of `obs` (the residual, or the
/// recording alone).
fn noise_of_series(obs: &Obs, series: &[f64], g: &Groups) -> Vec<f64> {
    let target_of = &obs.target;
    let n = obs.len();
    let order = time_order(obs, n);
    let ng = g.labels.len();
    let mut diffs: Vec<Vec<f64>> = vec![Vec::new(); ng];
    let mut pooled: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for w in order.windows(2) {
        let (a, b) = (w[0], w[1]);
        if obs.run[a] != obs.run[b]
            || obs.moving[a] != obs.moving[b]
            || obs.d[a] != obs.d[b]
            || target_of[a] != target_of[b]
            || obs.line[a] != obs.line[b]
        {
            continue;
        }
        let dr = (series[b] - series[a]) / std::f64::consts::SQRT_2;
        diffs[g.id[a]].push(dr);
        pooled[usize::from(obs.moving[a])].push(dr);
    }
    let all: Vec<f64> = pooled.iter().flatten().copied().collect();
    let global = if all.len() >= 5 {
        mad_sigma(&all)
    } else {
        mad_sigma(series)
    };
    let pooled_sigma = pooled
        .each_ref()
        .map(|p| if p.len() >= 10 { mad_sigma(p) } else { global });
    (0..ng)
        .map(|k| {
            if diffs[k].len() >= 10 {
                mad_sigma(&diffs[k])
            } else {
                let moving = g.labels[k].ends_with("moving");
                pooled_sigma[usize::from(moving)]
            }
        })
        .collect()
}

/// How far (in the group's σ) a residual must stand from the median of its neighbours
/// to be an outlier. The median of six white-noise neighbours has a standard deviation
/// of about 0.5 σ, so white noise passes 6 σ once in 10⁷ rows.
pub(crate) const OUTLIER_SIGMAS: f64 = 6.0;

/// Rows whose model residual stands more than [`OUTLIER_SIGMAS`] × their group's σ from
/// the median residual of up to three neighbours on each side in the same dwell or move
/// (time order): a spike on the line or a vibration, not structure, which lasts longer
/// than one sample. Segments with fewer than 5 rows are not screened.
pub(crate) fn outliers(obs: &Obs, g: &Groups, resid: &[f64], sigma: &[f64]) -> Vec<bool> {
    let n = obs.len();
    let order = time_order(obs, n);
    let same = |a: usize, b: usize| {
        obs.run[a] == obs.run[b]
            && obs.moving[a] == obs.moving[b]
            && obs.d[a] == obs.d[b]
            && obs.target[a] == obs.target[b]
            && obs.line[a] == obs.line[b]
    };
    let mut out = vec![false; n];
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && same(order[start], order[end]) {
            end += 1;
        }
        let seg = &order[start..end];
        if seg.len() >= 5 {
            for (i, &k) in seg.iter().enumerate() {
                let lo = i.saturating_sub(3);
                let hi = (i + 4).min(seg.len());
                let near: Vec<f64> = (lo..hi)
                    .filter(|&j| j != i)
                    .map(|j| resid[seg[j]])
                    .collect();
                let dev = resid[k] - median(&near);
                out[k] = dev.abs() > OUTLIER_SIGMAS * sigma[g.id[k]];
            }
        }
        start = end;
    }
    out
}

/// Per-group robust σ of model residuals (groups with fewer than 10 rows: NaN).
pub(crate) fn noise_from_residuals(resid: &[f64], g: &Groups) -> Vec<f64> {
    let ng = g.labels.len();
    let mut v: Vec<Vec<f64>> = vec![Vec::new(); ng];
    for (k, &e) in resid.iter().enumerate() {
        v[g.id[k]].push(e);
    }
    v.iter()
        .map(|e| {
            if e.len() >= 10 {
                mad_sigma(e)
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// Floors σ per group (≥ 1e-6 µm and ≥ 0.1 × the median group σ) so that no group gets
/// an unbounded weight.
pub(crate) fn floor_sigmas(s: &mut [f64]) {
    let finite: Vec<f64> = s
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let med = median(&finite);
    let floor = if med.is_finite() {
        (0.1 * med).max(1e-6)
    } else {
        1e-6
    };
    for v in s.iter_mut() {
        if !v.is_finite() || *v < floor {
            *v = if v.is_finite() { floor } else { med.max(floor) };
        }
    }
}

/// Cross-validation folds: one per run when there are at least 3 runs, else 5 blocks of
/// consecutive time. Returns (fold of each row, number of folds, what a fold is).
pub(crate) fn folds(obs: &Obs) -> (Vec<usize>, usize, &'static str) {
    let mut runs: Vec<u32> = obs.run.clone();
    runs.sort_unstable();
    runs.dedup();
    if runs.len() >= 3 {
        let id: Vec<usize> = obs
            .run
            .iter()
            .map(|r| runs.binary_search(r).unwrap_or(0))
            .collect();
        return (id, runs.len(), "run");
    }
    let n = obs.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| obs.t[a].total_cmp(&obs.t[b]));
    let k = 5.min(n);
    let mut id = vec![0; n];
    for (p, &i) in order.iter().enumerate() {
        id[i] = p * k / n;
    }
    (id, k, "time block")
}

#[cfg(test)]
mod tests {
    use super::counter_quantum_um;

    #[test]
    fn quantum_is_the_counter_step() {
        // 0.1 µm counts at scattered positions; 78.6 nm steps; no quantisation at all.
        let counts = [3u64, 10, 17, 1_000, 4_001, 8_000_003];
        let on =
            |q_mm: f64| (0..200u64).map(move |k| (counts[(k % 6) as usize] + 7 * k) as f64 * q_mm);
        assert!((counter_quantum_um(on(1e-4)) - 0.1).abs() < 1e-9);
        assert!((counter_quantum_um(on(78.6e-6)) - 0.0786).abs() < 1e-9);
        let smooth = (0..200).map(|k| (k as f64 * 0.1234567).sin() * 400.0);
        assert!(counter_quantum_um(smooth) < 1e-5);
        // Too few distinct values (dwell positions only): unknown.
        assert_eq!(counter_quantum_um([0.0, 100.0, 200.0].into_iter()), 0.0);
    }
}
