//! ISO 230-2 / VDI/DGQ 3441 positioning statistics for one linear axis.
//!
//! # Sign convention — read this first
//!
//! errmap's error is `e = indicated − reference = scale − laser` (µm). ISO 230-2 works
//! with the **positional deviation** `x_ij = P_ij − P_i`: the actual position `P_ij`
//! (what the laser measures) minus the target position `P_i` (what the machine
//! indicates). So
//!
//! ```text
//! x_ij = −e_ij
//! ```
//!
//! [`axis_stats`] takes errmap errors `e` in [`Observation::e_um`] and negates them; every
//! number in [`TargetStats`], [`AxisStats`] and [`VdiStats`], every table of the report (`report/iso230.rs`)
//! and every curve of its chart is an ISO deviation `x`. A scale that reads 3 µm long
//! (`e = +3 µm`) shows up as `x = −3 µm`. Quantities that are ranges or maxima of
//! absolute values (R, E, M, A, B, Ps, U, P) do not depend on the sign; the per-target
//! means, the reversal values `B_i` and the mean reversal `B̄` do.
//!
//! Indices follow ISO 230-2: `i = 1…m` is the target position, `j = 1…n` the run
//! (approach); `↑` is an approach in the positive direction ([`Direction::Up`]), `↓` in
//! the negative one ([`Direction::Down`]).
//!
//! # Method (ISO 230-2:2014, clause 3 "Terms and definitions")
//!
//! The definitions below are those of ISO 230-2:2014, clause 3, quoted by term name (the
//! numbering of clause 3 shifted between the 2006 and 2014 editions; the formulas did
//! not). Per target `i`, with `n↑`, `n↓` runs:
//!
//! | term | symbol | formula |
//! |---|---|---|
//! | positional deviation | `x_ij` | `P_ij − P_i` (= `−e_ij`) |
//! | mean unidirectional positional deviation at a position | `x̄_i↑`, `x̄_i↓` | `(1/n) Σ_j x_ij↑` |
//! | mean bidirectional positional deviation at a position | `x̄_i` | `(x̄_i↑ + x̄_i↓) / 2` |
//! | reversal value at a position | `B_i` | `x̄_i↑ − x̄_i↓` |
//! | estimator for the unidirectional axis repeatability at a position | `s_i↑`, `s_i↓` | `sqrt(Σ_j (x_ij↑ − x̄_i↑)² / (n − 1))` |
//! | unidirectional repeatability of positioning at a position | `R_i↑`, `R_i↓` | `4 s_i↑` |
//! | bidirectional repeatability of positioning at a position | `R_i` | `max[2 s_i↑ + 2 s_i↓ + │B_i│; R_i↑; R_i↓]` |
//!
//! and for the axis (maxima and minima over all targets `i`):
//!
//! | term | symbol | formula |
//! |---|---|---|
//! | reversal value of an axis | `B` | `max[│B_i│]` |
//! | mean reversal value of an axis | `B̄` | `(1/m) Σ_i B_i` (signed) |
//! | unidirectional repeatability of positioning | `R↑`, `R↓` | `max[R_i↑]` |
//! | bidirectional repeatability of positioning of an axis | `R` | `max[R_i]` |
//! | unidirectional systematic positional deviation of an axis | `E↑`, `E↓` | `max[x̄_i↑] − min[x̄_i↑]` |
//! | bidirectional systematic positional deviation of an axis | `E` | `max[x̄_i↑; x̄_i↓] − min[x̄_i↑; x̄_i↓]` |
//! | mean bidirectional positional deviation of an axis | `M` | `max[x̄_i] − min[x̄_i]` |
//! | unidirectional accuracy of positioning of an axis | `A↑`, `A↓` | `max[x̄_i↑ + 2 s_i↑] − min[x̄_i↑ − 2 s_i↑]` |
//! | bidirectional accuracy of positioning of an axis | `A` | `max[x̄_i↑ + 2 s_i↑; x̄_i↓ + 2 s_i↓] − min[x̄_i↑ − 2 s_i↑; x̄_i↓ − 2 s_i↓]` |
//!
//! Every max and min is taken **per quantity over all targets**: `R` is the largest `R_i`
//! wherever it occurs, not `R_i` at the target with the extreme mean, and the maximum of
//! `x̄_i↑ + 2 s_i↑` in `A↑` need not sit where `x̄_i↑` is largest.
//!
//! The standard test cycle of ISO 230-2 asks for 5 runs in each direction at each target
//! and at least 5 targets per metre (5 in all at least). This module does not enforce
//! that — it needs only 2 runs per direction and target, so that `s` is defined — but
//! The report (`report/iso230.rs`) prints `n↑`/`n↓` so that a reader can see a short test. Runs need not be
//! balanced (`n↑ ≠ n↓` is allowed); each mean and `s` uses its own `n`.
//!
//! # VDI/DGQ 3441 (1977)
//!
//! The older German guideline "Statistische Prüfung der Arbeits- und Positionsgenauigkeit
//! von Werkzeugmaschinen", still quoted in machine data sheets, evaluates the same
//! per-target means and standard deviations (`n − 1` estimator) differently
//! ([`VdiStats`]):
//!
//! | VDI/DGQ 3441 term | symbol | formula |
//! |---|---|---|
//! | reversal span at a position (Umkehrspanne) | `U_i` | `│x̄_i↑ − x̄_i↓│` = `│B_i│` |
//! | position scatter at a position (Positionsstreubreite) | `Ps_i` | `6 s̄_i`, `s̄_i = (s_i↑ + s_i↓) / 2` |
//! | reversal span of the axis | `U` (`U_max`) | `max[U_i]`; the mean `Ū = (1/m) Σ U_i` is also reported |
//! | position scatter of the axis | `Ps` (`Ps_max`) | `max[Ps_i]`; the mean `P̄s` is also reported |
//! | position deviation (Positionsabweichung) | `Pa` | `max[x̄_i] − min[x̄_i]` |
//! | position uncertainty (Positionsunsicherheit) | `P` | `max[x̄_i + (U_i + Ps_i)/2] − min[x̄_i − (U_i + Ps_i)/2]` |
//!
//! Where it differs from ISO 230-2:
//!
//! * scatter is `±3 s` (`6 s`, ≈ 99.7 % for a normal distribution) where ISO uses `±2 s`
//!   (`R_i↑ = 4 s_i↑`, the `2 s` terms in `A`);
//! * `Ps_i` averages the two directions' standard deviations and leaves the reversal out;
//!   ISO's `R_i` adds `│B_i│` and takes the worse of that and the unidirectional values;
//! * the mean reversal `Ū` averages `│B_i│`, ISO's `B̄` averages the signed `B_i`;
//! * `Pa` is ISO's `M`; `P` plays the role of ISO's `A`. Because `x̄_i ± U_i/2` are exactly
//!   `max/min(x̄_i↑, x̄_i↓)`, `P` is `A` with `3 s̄_i` in place of `2 s_i↑`/`2 s_i↓`, so
//!   `P ≥ A` whenever `s_i↑ = s_i↓`, but not in general.
//!
//! VDI/DGQ 3441 is out of print and was not available to check against while this module
//! was written; the definitions above are the ones in common use (textbooks and laser
//! analysis software that report `P`, `Ps max`, `Ps mean`, `Pa`, `U max`, `U mean`).
//! Prefer the ISO 230-2 values for acceptance.
//!
//! # Cost
//!
//! `O(N log N)` for `N` observations (one sort), `O(m)` memory for `m` targets.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Two observations of one target index count as the same position if they agree to
/// this (1 nm); anything further apart is [`IsoError::InconsistentPosition`].
pub const POSITION_TOL_MM: f64 = 1e-6;

pub(crate) use crate::base::Direction;

/// One approach to one target: errmap's error there, as measured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Observation {
    /// Target index `i` (any numbering; targets are reported in increasing index).
    pub target: usize,
    /// Target position `P_i` along the axis, mm. Must be the same for every observation of
    /// one target (to [`POSITION_TOL_MM`]).
    pub position_mm: f64,
    /// Run (approach) number `j`; unique per target and direction.
    pub run: u32,
    /// Direction of approach.
    pub direction: Direction,
    /// errmap error `e = indicated − reference` (scale − laser), µm. Negated to the ISO
    /// deviation `x = −e`.
    pub e_um: f64,
}

/// Per-target statistics, all as ISO positional deviations `x = −e`, µm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetStats {
    /// Target index `i`.
    pub target: usize,
    /// Target position `P_i`, mm.
    pub position_mm: f64,
    /// Runs in the positive direction, `n↑`.
    pub n_up: usize,
    /// Runs in the negative direction, `n↓`.
    pub n_down: usize,
    /// Mean unidirectional positional deviation `x̄_i↑`.
    pub mean_up_um: f64,
    /// Mean unidirectional positional deviation `x̄_i↓`.
    pub mean_down_um: f64,
    /// Estimator for the unidirectional axis repeatability `s_i↑` (`n − 1` in the denominator).
    pub s_up_um: f64,
    /// Estimator for the unidirectional axis repeatability `s_i↓`.
    pub s_down_um: f64,
    /// Reversal value `B_i = x̄_i↑ − x̄_i↓` (signed).
    pub reversal_um: f64,
    /// Mean bidirectional positional deviation `x̄_i = (x̄_i↑ + x̄_i↓) / 2`.
    pub mean_bidir_um: f64,
    /// Unidirectional repeatability `R_i↑ = 4 s_i↑`.
    pub repeat_up_um: f64,
    /// Unidirectional repeatability `R_i↓ = 4 s_i↓`.
    pub repeat_down_um: f64,
    /// Bidirectional repeatability `R_i = max[2 s_i↑ + 2 s_i↓ + │B_i│; R_i↑; R_i↓]`.
    pub repeat_bidir_um: f64,
    /// VDI/DGQ 3441 position scatter `Ps_i = 6 (s_i↑ + s_i↓) / 2`.
    pub scatter_vdi_um: f64,
}

/// VDI/DGQ 3441 values of the axis, µm (see the module docs for how they differ from
/// ISO 230-2).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VdiStats {
    /// Position uncertainty `P = max[x̄_i + (U_i + Ps_i)/2] − min[x̄_i − (U_i + Ps_i)/2]`.
    pub p_um: f64,
    /// Position deviation `Pa = max[x̄_i] − min[x̄_i]` (ISO's `M`).
    pub pa_um: f64,
    /// Largest position scatter `Ps = max[Ps_i]`.
    pub ps_max_um: f64,
    /// Mean position scatter `P̄s = (1/m) Σ Ps_i`.
    pub ps_mean_um: f64,
    /// Largest reversal span `U = max[U_i]`, `U_i = │x̄_i↑ − x̄_i↓│` (ISO's `B`).
    pub u_max_um: f64,
    /// Mean reversal span `Ū = (1/m) Σ U_i` (of absolute values, unlike ISO's `B̄`).
    pub u_mean_um: f64,
}

/// ISO 230-2 values of one axis, as positional deviations `x = −e`, µm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisStats {
    /// Per-target values, in increasing target index.
    pub targets: Vec<TargetStats>,
    /// Reversal value of the axis `B = max[│B_i│]`.
    pub b_um: f64,
    /// Mean reversal value of the axis `B̄ = (1/m) Σ B_i` (signed).
    pub mean_reversal_um: f64,
    /// Unidirectional repeatability `R↑ = max[R_i↑]`.
    pub r_up_um: f64,
    /// Unidirectional repeatability `R↓ = max[R_i↓]`.
    pub r_down_um: f64,
    /// Bidirectional repeatability of the axis `R = max[R_i]`.
    pub r_um: f64,
    /// Unidirectional systematic positional deviation `E↑ = max[x̄_i↑] − min[x̄_i↑]`.
    pub e_up_um: f64,
    /// Unidirectional systematic positional deviation `E↓ = max[x̄_i↓] − min[x̄_i↓]`.
    pub e_down_um: f64,
    /// Bidirectional systematic positional deviation `E = max[x̄_i↑; x̄_i↓] − min[x̄_i↑; x̄_i↓]`.
    pub e_um: f64,
    /// Mean bidirectional positional deviation of the axis `M = max[x̄_i] − min[x̄_i]`.
    pub m_um: f64,
    /// Unidirectional accuracy `A↑ = max[x̄_i↑ + 2 s_i↑] − min[x̄_i↑ − 2 s_i↑]`.
    pub a_up_um: f64,
    /// Unidirectional accuracy `A↓ = max[x̄_i↓ + 2 s_i↓] − min[x̄_i↓ − 2 s_i↓]`.
    pub a_down_um: f64,
    /// Bidirectional accuracy of the axis
    /// `A = max[x̄_i↑ + 2 s_i↑; x̄_i↓ + 2 s_i↓] − min[x̄_i↑ − 2 s_i↑; x̄_i↓ − 2 s_i↓]`.
    pub a_um: f64,
    /// The VDI/DGQ 3441 values from the same data.
    pub vdi: VdiStats,
}

/// Why the statistics could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IsoError {
    /// No observations at all.
    #[error("no observations")]
    Empty,
    /// A value is NaN or infinite.
    #[error("observation {index} (target {target}): {what} is not finite")]
    NonFinite {
        /// Index of the observation in the input slice.
        index: usize,
        /// Its target index.
        target: usize,
        /// `"position_mm"` or `"e_um"`.
        what: &'static str,
    },
    /// Observations of one target index disagree about its position.
    #[error(
        "target {target}: position {other_mm} mm (observation {index}) differs from {first_mm} mm"
    )]
    InconsistentPosition {
        /// The target index.
        target: usize,
        /// The position first seen for it.
        first_mm: f64,
        /// The differing position.
        other_mm: f64,
        /// Index of the differing observation in the input slice.
        index: usize,
    },
    /// The same run appears twice for one target and direction.
    #[error("target {target}, direction {direction}: run {run} appears more than once")]
    DuplicateRun {
        /// The target index.
        target: usize,
        /// The direction.
        direction: Direction,
        /// The repeated run number.
        run: u32,
    },
    /// Fewer than two runs in one direction at one target: `s` is undefined.
    #[error(
        "target {target}, direction {direction}: {runs} run(s), at least 2 are needed \
         (ISO 230-2's standard test cycle uses 5)"
    )]
    TooFewRuns {
        /// The target index.
        target: usize,
        /// The direction short of runs.
        direction: Direction,
        /// Runs found (0 or 1).
        runs: usize,
    },
}

/// Observations of one target, sorted into directions, as ISO deviations `x = −e`.
#[derive(Default)]
struct Bucket {
    position_mm: f64,
    up: Vec<(u32, f64)>,
    down: Vec<(u32, f64)>,
}

/// Mean and sample standard deviation (`n − 1`), two-pass.
fn mean_s(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let ss: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    (mean, (ss / (n - 1.0)).sqrt())
}

fn max_of(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(f64::NEG_INFINITY, f64::max)
}

fn min_of(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(f64::INFINITY, f64::min)
}

fn range_of(values: impl Iterator<Item = f64> + Clone) -> f64 {
    max_of(values.clone()) - min_of(values)
}

/// Runs of one direction at one target, checked: unique run numbers, at least 2.
fn direction_values(
    target: usize,
    direction: Direction,
    runs: &mut [(u32, f64)],
) -> Result<Vec<f64>, IsoError> {
    runs.sort_by_key(|&(run, _)| run);
    if let Some(w) = runs.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(IsoError::DuplicateRun {
            target,
            direction,
            run: w[0].0,
        });
    }
    if runs.len() < 2 {
        return Err(IsoError::TooFewRuns {
            target,
            direction,
            runs: runs.len(),
        });
    }
    Ok(runs.iter().map(|&(_, x)| x).collect())
}

fn target_stats(target: usize, bucket: &mut Bucket) -> Result<TargetStats, IsoError> {
    let up = direction_values(target, Direction::Up, &mut bucket.up)?;
    let down = direction_values(target, Direction::Down, &mut bucket.down)?;
    let (mean_up, s_up) = mean_s(&up);
    let (mean_down, s_down) = mean_s(&down);
    let reversal = mean_up - mean_down;
    let repeat_up = 4.0 * s_up;
    let repeat_down = 4.0 * s_down;
    Ok(TargetStats {
        target,
        position_mm: bucket.position_mm,
        n_up: up.len(),
        n_down: down.len(),
        mean_up_um: mean_up,
        mean_down_um: mean_down,
        s_up_um: s_up,
        s_down_um: s_down,
        reversal_um: reversal,
        mean_bidir_um: 0.5 * (mean_up + mean_down),
        repeat_up_um: repeat_up,
        repeat_down_um: repeat_down,
        repeat_bidir_um: (2.0 * s_up + 2.0 * s_down + reversal.abs())
            .max(repeat_up)
            .max(repeat_down),
        scatter_vdi_um: 6.0 * 0.5 * (s_up + s_down),
    })
}

/// ISO 230-2 (and VDI/DGQ 3441) statistics of one axis from errmap errors.
///
/// Each [`Observation`] carries `e = scale − laser`; the statistics use `x = −e` (see the
/// module docs). Observations may come in any order.
///
/// Errors (checked in this order): [`IsoError::Empty`]; [`IsoError::NonFinite`] for a
/// NaN/∞ position or error; [`IsoError::InconsistentPosition`] when one target index has
/// positions more than [`POSITION_TOL_MM`] apart; then per target in increasing index,
/// [`IsoError::DuplicateRun`] and [`IsoError::TooFewRuns`] (a direction with 0 or 1
/// runs), up before down.
pub fn axis_stats(obs: &[Observation]) -> Result<AxisStats, IsoError> {
    if obs.is_empty() {
        return Err(IsoError::Empty);
    }
    let mut buckets: BTreeMap<usize, Bucket> = BTreeMap::new();
    for (index, o) in obs.iter().enumerate() {
        for (what, v) in [("position_mm", o.position_mm), ("e_um", o.e_um)] {
            if !v.is_finite() {
                return Err(IsoError::NonFinite {
                    index,
                    target: o.target,
                    what,
                });
            }
        }
        let bucket = buckets.entry(o.target).or_insert_with(|| Bucket {
            position_mm: o.position_mm,
            ..Bucket::default()
        });
        if (o.position_mm - bucket.position_mm).abs() > POSITION_TOL_MM {
            return Err(IsoError::InconsistentPosition {
                target: o.target,
                first_mm: bucket.position_mm,
                other_mm: o.position_mm,
                index,
            });
        }
        let x_um = -o.e_um;
        match o.direction {
            Direction::Up => bucket.up.push((o.run, x_um)),
            Direction::Down => bucket.down.push((o.run, x_um)),
        }
    }
    let targets = buckets
        .iter_mut()
        .map(|(&target, bucket)| target_stats(target, bucket))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(summarise(targets))
}

fn summarise(targets: Vec<TargetStats>) -> AxisStats {
    let t = &targets;
    let m = t.len() as f64;
    let up = || t.iter().map(|s| s.mean_up_um);
    let down = || t.iter().map(|s| s.mean_down_um);
    let both = || up().chain(down());
    let hi_up = || t.iter().map(|s| s.mean_up_um + 2.0 * s.s_up_um);
    let lo_up = || t.iter().map(|s| s.mean_up_um - 2.0 * s.s_up_um);
    let hi_down = || t.iter().map(|s| s.mean_down_um + 2.0 * s.s_down_um);
    let lo_down = || t.iter().map(|s| s.mean_down_um - 2.0 * s.s_down_um);

    // VDI/DGQ 3441: band x̄_i ± (U_i + Ps_i)/2 per target.
    let half_band = |s: &TargetStats| 0.5 * (s.reversal_um.abs() + s.scatter_vdi_um);
    let vdi = VdiStats {
        p_um: max_of(t.iter().map(|s| s.mean_bidir_um + half_band(s)))
            - min_of(t.iter().map(|s| s.mean_bidir_um - half_band(s))),
        pa_um: range_of(t.iter().map(|s| s.mean_bidir_um)),
        ps_max_um: max_of(t.iter().map(|s| s.scatter_vdi_um)),
        ps_mean_um: t.iter().map(|s| s.scatter_vdi_um).sum::<f64>() / m,
        u_max_um: max_of(t.iter().map(|s| s.reversal_um.abs())),
        u_mean_um: t.iter().map(|s| s.reversal_um.abs()).sum::<f64>() / m,
    };

    AxisStats {
        b_um: max_of(t.iter().map(|s| s.reversal_um.abs())),
        mean_reversal_um: t.iter().map(|s| s.reversal_um).sum::<f64>() / m,
        r_up_um: max_of(t.iter().map(|s| s.repeat_up_um)),
        r_down_um: max_of(t.iter().map(|s| s.repeat_down_um)),
        r_um: max_of(t.iter().map(|s| s.repeat_bidir_um)),
        e_up_um: range_of(up()),
        e_down_um: range_of(down()),
        e_um: range_of(both()),
        m_um: range_of(t.iter().map(|s| s.mean_bidir_um)),
        a_up_um: max_of(hi_up()) - min_of(lo_up()),
        a_down_um: max_of(hi_down()) - min_of(lo_down()),
        a_um: max_of(hi_up().chain(hi_down())) - min_of(lo_up().chain(lo_down())),
        vdi,
        targets,
    }
}
