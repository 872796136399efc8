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
pub type LineKey = (i64, i64);

/// The line of a row along `axis_index`: its two other coordinates in whole
/// micrometres, `None` when either is missing.
pub fn line_key(r: &SessionRow, axis_index: usize) -> Option<LineKey> {
    let coords = [r.x_mm, r.y_mm, r.z_mm];
    let mut o = (0..3).filter(|&b| b != axis_index).map(|b| coords[b]);
    let (c1, c2) = (o.next()??, o.next()??);
    Some(((c1 * 1000.0).round() as i64, (c2 * 1000.0).round() as i64))
}

/// (Σ error µm, Σ scale mm, n) of one dwell.
type DwellSums = (f64, f64, usize);

/// Longest lag of the dwell autocorrelation, samples.
const MAX_LAG: usize = 32;

/// One dwell's lagged sums, in one pass: Σe, Σe², Σ e_t·e_{t+k} for k ≤ [`MAX_LAG`], and
/// the first and last [`MAX_LAG`] values (for the sums over e_t with t < m − k and
/// t ≥ k). Values are shifted by the dwell's first one (the autocovariance does not
/// depend on a shift, and the sums stay well conditioned).
#[derive(Debug, Clone, Default)]
struct Lagged {
    m: usize,
    shift: f64,
    sum: f64,
    sumsq: f64,
    /// Σ e_t·e_{t+k}, k = 0..=MAX_LAG (index 0 unused).
    prod: Vec<f64>,
    head: Vec<f64>,
    /// The last values, oldest first.
    tail: std::collections::VecDeque<f64>,
}

impl Lagged {
    fn push(&mut self, e: f64) {
        if self.m == 0 {
            self.shift = e;
            self.prod = vec![0.0; MAX_LAG + 1];
        }
        let v = e - self.shift;
        for (k, &prev) in self.tail.iter().rev().enumerate() {
            self.prod[k + 1] += prev * v;
        }
        if self.head.len() < MAX_LAG {
            self.head.push(v);
        }
        self.tail.push_back(v);
        if self.tail.len() > MAX_LAG {
            self.tail.pop_front();
        }
        self.m += 1;
        self.sum += v;
        self.sumsq += v * v;
    }

    /// Σ over the dwell of (e_t − ē)(e_{t+k} − ē), k = 0..=min(MAX_LAG, m − 1).
    fn autocovariance_sums(&self) -> Vec<f64> {
        let m = self.m;
        if m == 0 {
            return Vec::new();
        }
        let mean = self.sum / m as f64;
        let mut c = vec![self.sumsq - m as f64 * mean * mean];
        for k in 1..=MAX_LAG.min(m - 1) {
            let last_k: f64 = self.tail.iter().rev().take(k).sum();
            let first_k: f64 = self.head.iter().take(k).sum();
            let (early, late) = (self.sum - last_k, self.sum - first_k);
            c.push(self.prod[k] - mean * (early + late) + (m - k) as f64 * mean * mean);
        }
        c
    }
}

/// The session's autocorrelation of dwell samples, ρ_k for k = 1..=[`MAX_LAG`] (ρ_0 = 1),
/// from the autocovariances about each dwell's mean pooled over every dwell (the mean
/// product of pairs k apart over the mean square, over the dwells longer than k), corrected for the mean's own removal: about a mean of
/// m samples, E ĉ_k ≈ γ_k − Var(x̄) with Var(x̄) = γ_0·τ/m, so the raw ρ̂_k =
/// (ρ_k − b)/(1 − b) with b = τ/m̄ (m̄ the mean dwell length, τ the integrated
/// autocorrelation time of [`effective_count`]); solved for ρ_k by fixed-point iteration
/// (b held below 0.9). Without the correction a dwell of 40 samples with ρ_1 = 0.7 reads
/// an effective count about 45 % too high. ρ_k is 0 where no dwell reaches lag k.
fn pooled_autocorrelation<'a>(dwells: impl Iterator<Item = &'a Lagged>) -> [f64; MAX_LAG + 1] {
    // Per lag: Σ products and Σ pairs (m − k) over the dwells longer than k; lag 0 the
    // same over every dwell.
    let mut num = [0.0; MAX_LAG + 1];
    let mut pairs = [0.0; MAX_LAG + 1];
    let (mut samples, mut count) = (0usize, 0usize);
    for d in dwells {
        let c = d.autocovariance_sums();
        for k in 0..c.len() {
            num[k] += c[k];
            pairs[k] += (d.m - k) as f64;
        }
        samples += d.m;
        count += 1;
    }
    let mut raw = [0.0; MAX_LAG + 1];
    raw[0] = 1.0;
    let mut reach = 0;
    let var = if pairs[0] > 0.0 {
        num[0] / pairs[0]
    } else {
        0.0
    };
    for k in 1..=MAX_LAG {
        if pairs[k] > 0.0 && var > 0.0 {
            raw[k] = num[k] / pairs[k] / var;
            reach = k;
        }
    }
    if count == 0 {
        return raw;
    }
    let m = samples as f64 / count as f64;
    let mut rho = raw;
    for _ in 0..50 {
        let b = (integrated_time(m, &rho, reach) / m).min(0.9);
        let mut next = raw;
        for k in 1..=reach {
            next[k] = raw[k] * (1.0 - b) + b;
        }
        let done = next.iter().zip(&rho).all(|(a, b)| (a - b).abs() < 1e-9);
        rho = next;
        if done {
            break;
        }
    }
    rho
}

/// τ = 1 + 2 Σ_{k=1}^{K} (1 − k/m) ρ_k, the sum stopped before the first ρ_k ≤ 0 and at
/// lag `reach` (Geyer's initial positive sequence, so that noise in ρ at long lags does
/// not count).
fn integrated_time(m: f64, rho: &[f64; MAX_LAG + 1], reach: usize) -> f64 {
    let mut tau = 1.0;
    for (k, &r) in rho.iter().enumerate().take(reach + 1).skip(1) {
        if r <= 0.0 || k as f64 >= m {
            break;
        }
        tau += 2.0 * (1.0 - k as f64 / m) * r;
    }
    tau
}

/// Effective sample count of the mean of m successive samples with autocorrelation ρ:
/// m/τ with τ of [`integrated_time`] (the variance of the mean of a stationary series is
/// γ_0·τ/m; Bayley & Hammersley 1946). At most m, at least 1.
fn effective_count(m: usize, rho: &[f64; MAX_LAG + 1]) -> f64 {
    let mf = m as f64;
    (mf / integrated_time(mf, rho, MAX_LAG)).clamp(1.0_f64.min(mf), mf)
}

impl Lagged {
    /// The dwell's mean and the variance of its samples about it (None below 2 samples).
    fn mean_var(&self) -> Option<(f64, f64)> {
        (self.m >= 2).then(|| {
            let m = self.m as f64;
            let mean = self.sum / m;
            (
                self.shift + mean,
                ((self.sumsq - m * mean * mean) / (m - 1.0)).max(0.0),
            )
        })
    }
}

/// Smallest number of repeated dwells (Σ over (line, target, direction) of dwells − 1)
/// for the batch-means design effect; fewer: the autocorrelation alone.
const MIN_BATCH_DOF: usize = 3;

/// The design effect of a dwell mean, pooled over the session (batch means: each dwell
/// a batch): the observed variance of the means of repeated dwells at one (line, target,
/// direction), against what their samples' own scatter says, s²/m. It sees correlation
/// longer than a dwell and offsets a dwell's samples share (positioning, drift between
/// runs), which the autocorrelation within a dwell cannot. None with fewer than
/// [`MIN_BATCH_DOF`] repeats.
fn batch_design_effect(lagged: &BTreeMap<(LineKey, i32, u32, i8), Lagged>) -> Option<f64> {
    let mut groups: BTreeMap<(LineKey, i32, i8), Vec<(f64, f64)>> = BTreeMap::new();
    for (&(line, target, _, dir), d) in lagged {
        if let Some((mean, var)) = d.mean_var() {
            groups
                .entry((line, target, dir))
                .or_default()
                .push((mean, var / d.m as f64));
        }
    }
    let (mut between, mut within, mut dof) = (0.0, 0.0, 0usize);
    for g in groups.values().filter(|g| g.len() >= 2) {
        let j = g.len() as f64;
        let mean = g.iter().map(|v| v.0).sum::<f64>() / j;
        between += g.iter().map(|v| (v.0 - mean).powi(2)).sum::<f64>();
        within += (j - 1.0) * g.iter().map(|v| v.1).sum::<f64>() / j;
        dof += g.len() - 1;
    }
    (dof >= MIN_BATCH_DOF && within > 0.0).then(|| (between / within).max(1.0))
}

/// Effective sample count per (line, target): n_eff = s²/u² with u² the variance of the
/// node's mean. With repeated dwells (batch means), u² = D·mean(s_j²/m_j)/J over the
/// node's J dwells, D from [`batch_design_effect`]; otherwise (one run) each dwell of m
/// samples counts m/τ with τ from the session's autocorrelation
/// ([`pooled_autocorrelation`], [`effective_count`]).
fn effective_counts(
    lagged: &BTreeMap<(LineKey, i32, u32, i8), Lagged>,
    nodes: &BTreeMap<(i64, i64, i32), Welford>,
) -> BTreeMap<(i64, i64, i32), f64> {
    let mut out: BTreeMap<(i64, i64, i32), f64> = BTreeMap::new();
    match batch_design_effect(lagged) {
        Some(design) => {
            let mut naive: BTreeMap<(i64, i64, i32), (f64, f64)> = BTreeMap::new();
            for (&((c1, c2), target, _, _), d) in lagged {
                if let Some((_, var)) = d.mean_var() {
                    let e = naive.entry((c1, c2, target)).or_default();
                    e.0 += var / d.m as f64;
                    e.1 += 1.0;
                }
            }
            for (key, (sum, j)) in naive {
                let u2 = design * (sum / j) / j;
                if let Some(s) = nodes.get(&key).and_then(Welford::s)
                    && u2 > 0.0
                {
                    out.insert(key, s * s / u2);
                }
            }
        }
        None => {
            let rho = pooled_autocorrelation(lagged.values());
            for (&((c1, c2), target, _, _), d) in lagged {
                *out.entry((c1, c2, target)).or_default() += effective_count(d.m, &rho);
            }
        }
    }
    out
}

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
    /// Lagged sums per (line, target, run, direction), for the effective sample counts.
    lagged: BTreeMap<(LineKey, i32, u32, i8), Lagged>,
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
        h.lagged
            .entry(((c1, c2), r.target, r.run, r.direction))
            .or_default()
            .push(r.error_um);
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
        let n_eff = effective_counts(&h.lagged, &h.groups);
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
                    n_eff: n_eff
                        .get(&(c1, c2, target))
                        .map(|&v| v.clamp(1.0, w.n as f64)),
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
