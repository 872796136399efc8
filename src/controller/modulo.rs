//! Modulo compensation tables of a rotary axis (`docs/rotary.md` §4): the shared values,
//! the points, and one renderer per controller.
//!
//! **Values.** e_i the rotary table's `e_arcsec` at θ_i; the closure gap g = e(360) − e(0)
//! (0 without a 360 target); e′_i = e_i − g·θ_i/360: a modulo table repeats every
//! revolution, so it cannot carry a ratio error — the trend is left out and reported
//! ("correct the ratio"). e′(q) between targets is linear and periodic (e′(360) = e′(0)).
//! The compensation c(q) = −(e′(q) − e′(R)) ″ with R the reference angle, so c(0) = c(360)
//! and the reference position does not move.
//!
//! **Points.** Equidistant controllers (Siemens, FANUC, HEIDENHAIN) take 0, S, …, 360;
//! S given (360/S an integer) or the finest S = 360/k with k + 1 ≤ N and S a whole
//! multiple of 0.001°. Free controllers (LinuxCNC, Fagor 8055) take the targets (and 360)
//! when they fit in N, else the best placement: at most N targets, 0 and 360 always, that
//! minimise the largest |residual| over all targets (exact, by dynamic programming over
//! the targets: O(n²·N) after O(n³) chord costs, n ≤ [`MAX_TARGETS`]).
//!
//! **Residual** at target i: e′_i − e′(R) + c_table(θ_i), c_table linear between points
//! (FANUC: the table re-summed from its rounded increments).
//!
//! **Controllers' rules** (sources; where a rule could not be read it is an assumption):
//! - Siemens SINUMERIK EEC, `$AA_ENC_COMP_IS_MODULO = 1`: the table repeats cyclically
//!   between `_MIN` 0 and `_MAX` 360, both end values entered and equal; the number of
//!   points is bounded by MD38000 (default 200 assumed). Siemens 840D sl/828D function
//!   manual "Extended functions" (K3 compensation), as the shared contract cites it.
//! - FANUC pitch error compensation of a rotary axis: parameters 3620 (reference point
//!   number), 3621 = 3620, 3622 = 3620 + 360/3624, 3623 magnification, 3624 interval,
//!   3625 = 360 (travel per revolution); the increments of one revolution must sum to 0
//!   and the reference point's value equals the last one's. FANUC 0i-PB parameter
//!   manual, as the contract cites it (not read here).
//! - HEIDENHAIN `.COM`: rotary tables read from 0 to 360° (TNC 306 manual, as cited);
//!   the unit token for a rotary `.COM` was not found: errmap writes `DEG` (assumed).
//! - Fagor 8055 leadscrew table of a rotary axis: 0° and 360° are the first and last
//!   points and carry the same error (8055 installation manual, as cited).
//! - LinuxCNC comp file: `nominal forward reverse`, nominal strictly increasing, at most
//!   256 lines (LinuxCNC's motion module limit); a modulo joint repeating the table over
//!   several revolutions is not covered.

use std::fmt::Write as _;

use super::update::fixed;
use crate::base::RotaryAxis;

/// The most targets a rotary table may hold here (the placement's O(n³) bound).
pub const MAX_TARGETS: usize = 2000;

/// A rotary controller table's controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModuloDialect {
    LinuxCnc,
    Siemens,
    Fanuc,
    Heidenhain,
    Fagor8055,
}

impl ModuloDialect {
    pub const ALL: [Self; 5] = [
        Self::LinuxCnc,
        Self::Siemens,
        Self::Fanuc,
        Self::Heidenhain,
        Self::Fagor8055,
    ];

    /// Whether its points are equidistant.
    pub fn equidistant(self) -> bool {
        matches!(self, Self::Siemens | Self::Fanuc | Self::Heidenhain)
    }

    /// The control's point budget.
    pub fn default_max_points(self) -> usize {
        match self {
            Self::Siemens => 200,
            Self::Fanuc => 1024,
            Self::LinuxCnc | Self::Heidenhain => 256,
            Self::Fagor8055 => 255,
        }
    }

    /// The dialect of `--format NAME`, if it has a modulo table.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::LinuxCnc => "linuxcnc",
            Self::Siemens => "siemens",
            Self::Fanuc => "fanuc",
            Self::Heidenhain => "heidenhain",
            Self::Fagor8055 => "fagor-8055",
        }
    }
}

/// What a modulo table is made from.
#[derive(Debug, Clone, Copy)]
pub enum ModuloInput<'a> {
    /// A rotary error table (θ °, e ″), ascending: one correction for both directions.
    Table(&'a [(f64, f64)]),
    /// e↑ and e↓ at the same targets (`--bidirectional`).
    Directions {
        up: &'a [(f64, f64)],
        down: &'a [(f64, f64)],
    },
    /// The table in use, updated by the residual measured with it active: one series,
    /// or two (moving +, moving −).
    Existing {
        bytes: &'a [u8],
        residual: &'a [&'a [(f64, f64)]],
    },
}

/// The table of `input` (see [`ModuloInput`]).
pub fn modulo(input: ModuloInput<'_>, spec: &ModuloSpec) -> Result<ModuloTable, ModuloError> {
    match input {
        ModuloInput::Table(points) => modulo_table(points, spec),
        ModuloInput::Directions { up, down } => modulo_table_bidirectional(up, down, spec),
        ModuloInput::Existing { bytes, residual } => {
            super::modulo_update::update_modulo(bytes, residual, spec)
        }
    }
}

/// What the table is made from and how.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuloSpec {
    pub dialect: ModuloDialect,
    pub axis: RotaryAxis,
    pub step_deg: Option<f64>,
    pub max_points: Option<usize>,
    pub reference_deg: f64,
    /// LinuxCNC: trim (the correction) instead of actual positions.
    pub trim: bool,
    /// Siemens axis name (default the letter + `1`).
    pub siemens_axis: Option<String>,
    /// FANUC reference point number p.
    pub fanuc_reference_number: u32,
    /// FANUC detection unit, ° (0.001 IS-B).
    pub detection_unit_deg: f64,
    pub magnification: u32,
    pub fanuc_max_value: u32,
    /// HEIDENHAIN column key (default the letter).
    pub axis_name: Option<String>,
}

impl ModuloSpec {
    pub fn new(dialect: ModuloDialect, axis: RotaryAxis) -> Self {
        ModuloSpec {
            dialect,
            axis,
            step_deg: None,
            max_points: None,
            reference_deg: 0.0,
            trim: false,
            siemens_axis: None,
            fanuc_reference_number: 0,
            detection_unit_deg: 0.001,
            magnification: 1,
            fanuc_max_value: 7,
            axis_name: None,
        }
    }
}

/// A written modulo table and what it reports.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModuloTable {
    #[serde(skip)]
    pub text: String,
    pub format: &'static str,
    pub axis: RotaryAxis,
    /// The table's angles, °.
    #[serde(skip)]
    pub points_deg: Vec<f64>,
    pub points: usize,
    pub step_deg: Option<f64>,
    pub reference_deg: f64,
    pub closure_gap_arcsec: f64,
    pub ratio_ppm: f64,
    pub datum_offset_arcsec: f64,
    pub max_residual_arcsec: f64,
    /// `--existing`: the largest change of a point's correction, ″.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_change_arcsec: Option<f64>,
    /// The compensation at each point, ″ (with two directions: moving +).
    #[serde(skip)]
    pub c_arcsec: Vec<f64>,
    /// With two directions: the compensation moving −, ″.
    #[serde(skip)]
    pub c_down_arcsec: Option<Vec<f64>>,
    /// With two directions: each one's closure gap and residual.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub directions: Option<DirectionsSummary>,
    pub warnings: Vec<String>,
}

/// Each direction of a two-direction table: its own closure gap, its datum e′_d(R) and
/// its largest residual (`--json`'s `directions`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DirectionsSummary {
    pub closure_gap_up_arcsec: f64,
    pub closure_gap_down_arcsec: f64,
    pub datum_up_arcsec: f64,
    pub datum_down_arcsec: f64,
    pub max_residual_up_arcsec: f64,
    pub max_residual_down_arcsec: f64,
}

/// Why no modulo table can be written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModuloError {
    #[error("the rotary table has no target at 0°: a modulo table starts there")]
    NoZero,
    #[error(
        "the targets do not go round the revolution: a gap of {gap_deg}° at {at_deg}° is more \
         than twice their median gap {median_deg}°"
    )]
    Gap {
        gap_deg: f64,
        at_deg: f64,
        median_deg: f64,
    },
    #[error("{count} targets: more than {MAX_TARGETS}")]
    TooMany { count: usize },
    #[error("step {step_deg}°: 360/step is not a whole number (try {fits}°)")]
    Step { step_deg: f64, fits: f64 },
    #[error("reference {reference_deg}°: not a point of the table ({hint})")]
    Reference { reference_deg: f64, hint: String },
    #[error("budget {max_points} points: too few for a revolution (at least 2)")]
    Budget { max_points: usize },
    #[error(
        "FANUC value {value} at point {point} exceeds ±{max} (detection unit × magnification): \
         a magnification of {fits} fits"
    )]
    FanucRange {
        value: i64,
        point: usize,
        max: u32,
        fits: u32,
    },
    #[error(
        "{format} modulo tables hold one value per point for both directions (two-direction \
         tables: linuxcnc forward/reverse, fagor-8055 err−)"
    )]
    OneDirection { format: &'static str },
    /// The table in use (`--existing`) cannot be read or updated as a modulo table.
    #[error("line {line}: {problem}")]
    Existing { line: usize, problem: String },
    /// The table in use does not fit a setting of the update (its step, its axis).
    #[error("line {line}: {}", .mismatch.render(&crate::base::Setting::words))]
    Mismatch {
        line: usize,
        mismatch: super::modulo_update::TableMismatch,
    },
    #[error(
        "the two directions are measured at different targets (moving + {up}, moving − {down})"
    )]
    Targets { up: usize, down: usize },
}

/// The detrended errors e′ at the targets (ascending, 0 first), the gap g.
pub(super) fn detrended(points: &[(f64, f64)]) -> (Vec<(f64, f64)>, f64) {
    let e0 = points[0].1;
    let g = points
        .iter()
        .find(|p| (p.0 - 360.0).abs() < 1e-9)
        .map_or(0.0, |p| p.1 - e0);
    let mut v: Vec<(f64, f64)> = points
        .iter()
        .map(|&(q, e)| (q, e - g * q / 360.0))
        .collect();
    // e′(360) = e′(0) exactly (the subtraction above may differ in its last bit), so the
    // table's two ends get the same correction.
    match v.last_mut() {
        Some(p) if (p.0 - 360.0).abs() <= 1e-9 => p.1 = points[0].1,
        _ => v.push((360.0, points[0].1)),
    }
    (v, g)
}

/// Linear interpolation through (θ, v), ascending, θ in [first, last].
pub(super) fn interp(nodes: &[(f64, f64)], q: f64) -> f64 {
    let i = nodes
        .partition_point(|p| p.0 <= q)
        .clamp(1, nodes.len() - 1);
    let (a, b) = (nodes[i - 1], nodes[i]);
    if b.0 == a.0 {
        return a.1;
    }
    a.1 + (b.1 - a.1) * (q - a.0) / (b.0 - a.0)
}

/// Checks the targets cover the revolution (0 present, no gap over twice the median).
pub(super) fn check_revolution(points: &[(f64, f64)]) -> Result<(), ModuloError> {
    if points.len() > MAX_TARGETS {
        return Err(ModuloError::TooMany {
            count: points.len(),
        });
    }
    if points.first().is_none_or(|p| p.0.abs() > 1e-9) {
        return Err(ModuloError::NoZero);
    }
    let mut gaps: Vec<(f64, f64)> = points
        .windows(2)
        .map(|w| (w[1].0 - w[0].0, w[0].0))
        .collect();
    if let Some(last) = points.last()
        && last.0 < 360.0 - 1e-9
    {
        gaps.push((360.0 - last.0, last.0));
    }
    let mut sorted: Vec<f64> = gaps.iter().map(|g| g.0).collect();
    sorted.sort_by(f64::total_cmp);
    let median = if sorted.is_empty() {
        360.0
    } else if sorted.len() % 2 == 1 {
        sorted[sorted.len() / 2]
    } else {
        (sorted[sorted.len() / 2 - 1] + sorted[sorted.len() / 2]) / 2.0
    };
    match gaps.iter().find(|g| g.0 > 2.0 * median + 1e-9) {
        Some(g) => Err(ModuloError::Gap {
            gap_deg: g.0,
            at_deg: g.1,
            median_deg: median,
        }),
        None if points.len() < 2 => Err(ModuloError::Gap {
            gap_deg: 360.0,
            at_deg: 0.0,
            median_deg: 360.0,
        }),
        None => Ok(()),
    }
}

/// The equidistant step: S given (checked) or the finest within the budget.
fn equidistant_step(step: Option<f64>, budget: usize) -> Result<f64, ModuloError> {
    if let Some(s) = step {
        let k = 360.0 / s;
        if s > 0.0 && (k - k.round()).abs() <= 1e-9 * k.max(1.0) && k.round() >= 1.0 {
            return Ok(360.0 / k.round());
        }
        let fits = 360.0 / (360.0 / s).round().max(1.0);
        return Err(ModuloError::Step { step_deg: s, fits });
    }
    if budget < 2 {
        return Err(ModuloError::Budget { max_points: budget });
    }
    (1..budget)
        .rev()
        .find(|&k| 360_000 % k == 0)
        .map(|k| 360.0 / k as f64)
        .ok_or(ModuloError::Budget { max_points: budget })
}

/// The best placement: at most `n` of the targets, the first and last always, minimising
/// the largest deviation of the targets from the chords over every series (one per
/// direction, at the same targets; exact, dynamic programming).
fn best_placement(series: &[Vec<(f64, f64)>], n: usize) -> Vec<usize> {
    let m = series[0].len();
    // cost[i][j]: the largest |deviation| of the targets strictly between i and j from
    // the chord i–j.
    let mut cost = vec![vec![0.0f64; m]; m];
    for i in 0..m {
        for j in i + 1..m {
            cost[i][j] = series
                .iter()
                .flat_map(|v| {
                    let (a, b) = (v[i], v[j]);
                    (i + 1..j).map(move |k| {
                        let c = a.1 + (b.1 - a.1) * (v[k].0 - a.0) / (b.0 - a.0);
                        (v[k].1 - c).abs()
                    })
                })
                .fold(0.0, f64::max);
        }
    }
    // best[k][j]: the least worst cost of reaching j with k + 1 points; from[k][j] its
    // previous point.
    let n = n.max(2).min(m);
    let mut best = vec![vec![f64::INFINITY; m]; n];
    let mut from = vec![vec![0usize; m]; n];
    best[0][0] = 0.0;
    for k in 1..n {
        for j in 1..m {
            for i in 0..j {
                let c = best[k - 1][i].max(cost[i][j]);
                if c < best[k][j] {
                    best[k][j] = c;
                    from[k][j] = i;
                }
            }
        }
    }
    let k_best = (1..n)
        .min_by(|&a, &b| best[a][m - 1].total_cmp(&best[b][m - 1]).then(a.cmp(&b)))
        .unwrap_or(1);
    let mut path = vec![m - 1];
    let (mut k, mut j) = (k_best, m - 1);
    while k > 0 {
        j = from[k][j];
        path.push(j);
        k -= 1;
    }
    path.reverse();
    path
}

/// The modulo table of a rotary error table `points` ((θ °, e ″), ascending): one
/// correction for both directions.
pub fn modulo_table(points: &[(f64, f64)], spec: &ModuloSpec) -> Result<ModuloTable, ModuloError> {
    build(&[points], spec)
}

/// The two-direction modulo table (`--bidirectional`, LinuxCNC and Fagor 8055) of the
/// errors moving + (`up`, e↑ = −x̄↑) and moving − (`down`, e↓ = −x̄↓) at the same targets:
/// each direction detrended by its own closure gap, both relative to the mean datum
/// (e′↑(R) + e′↓(R))/2, so the reference position is not moved on average.
pub fn modulo_table_bidirectional(
    up: &[(f64, f64)],
    down: &[(f64, f64)],
    spec: &ModuloSpec,
) -> Result<ModuloTable, ModuloError> {
    if spec.dialect.equidistant() {
        return Err(ModuloError::OneDirection {
            format: spec.dialect.name(),
        });
    }
    let same = up.len() == down.len() && up.iter().zip(down).all(|(a, b)| a.0 == b.0);
    if !same {
        return Err(ModuloError::Targets {
            up: up.len(),
            down: down.len(),
        });
    }
    build(&[up, down], spec)
}

/// The table's angles and step: the targets (or the best placement) for a free dialect,
/// else the equidistant points.
fn place(
    series: &[Vec<(f64, f64)>],
    spec: &ModuloSpec,
) -> Result<(Vec<f64>, Option<f64>), ModuloError> {
    let budget = spec
        .max_points
        .unwrap_or_else(|| spec.dialect.default_max_points());
    let v = &series[0];
    if !spec.dialect.equidistant() && spec.step_deg.is_none() {
        if v.len() <= budget {
            return Ok((v.iter().map(|p| p.0).collect(), None));
        }
        let idx = best_placement(series, budget);
        return Ok((idx.iter().map(|&i| v[i].0).collect(), None));
    }
    let s = equidistant_step(spec.step_deg, budget)?;
    let k = (360.0 / s).round() as usize;
    Ok(((0..=k).map(|j| j as f64 * s).collect(), Some(s)))
}

/// The table of one series (both directions) or two (moving +, moving −).
fn build(inputs: &[&[(f64, f64)]], spec: &ModuloSpec) -> Result<ModuloTable, ModuloError> {
    for points in inputs {
        check_revolution(points)?;
    }
    let (series, gaps): (Vec<Vec<(f64, f64)>>, Vec<f64>) =
        inputs.iter().map(|p| detrended(p)).unzip();
    let (angles, step_deg) = place(&series, spec)?;
    let r = spec.reference_deg;
    if !angles.iter().any(|a| (a - r).abs() <= 1e-9) {
        return Err(ModuloError::Reference {
            reference_deg: r,
            hint: match step_deg {
                Some(s) => format!("a multiple of the step {s}°"),
                None => "one of the table's targets".into(),
            },
        });
    }
    let datums: Vec<f64> = series.iter().map(|v| interp(v, r)).collect();
    let datum = datums.iter().sum::<f64>() / datums.len() as f64;
    let c_of = |v: &[(f64, f64)]| -> Vec<f64> {
        angles.iter().map(|&q| -(interp(v, q) - datum)).collect()
    };
    let g = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let mut table = ModuloTable {
        text: String::new(),
        format: spec.dialect.name(),
        axis: spec.axis,
        points: angles.len(),
        step_deg,
        reference_deg: r,
        closure_gap_arcsec: g,
        ratio_ppm: g / 1.296,
        datum_offset_arcsec: datum,
        max_residual_arcsec: 0.0,
        max_change_arcsec: None,
        c_arcsec: c_of(&series[0]),
        c_down_arcsec: series.get(1).map(|v| c_of(v)),
        directions: None,
        points_deg: angles,
        warnings: Vec::new(),
    };
    if g.abs() > 1e-9 {
        table.warnings.push(format!(
            "closure gap {g:.3}″ ({:.3} ppm){} left out of the table: a modulo table cannot \
             carry a ratio error; correct the ratio",
            g / 1.296,
            if gaps.len() == 2 {
                format!(", moving + {:.3}″ and moving − {:.3}″,", gaps[0], gaps[1])
            } else {
                String::new()
            }
        ));
    }
    let applied = render(&mut table, spec)?;
    let residuals: Vec<f64> = series
        .iter()
        .zip(&applied)
        .map(|(v, c_table)| {
            let nodes: Vec<(f64, f64)> = table
                .points_deg
                .iter()
                .copied()
                .zip(c_table.iter().copied())
                .collect();
            v.iter()
                .map(|&(q, e)| (e - datum + interp(&nodes, q)).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    table.max_residual_arcsec = residuals.iter().copied().fold(0.0, f64::max);
    if let ([g_up, g_down], [d_up, d_down], [r_up, r_down]) =
        (gaps.as_slice(), datums.as_slice(), residuals.as_slice())
    {
        table.directions = Some(DirectionsSummary {
            closure_gap_up_arcsec: *g_up,
            closure_gap_down_arcsec: *g_down,
            datum_up_arcsec: *d_up,
            datum_down_arcsec: *d_down,
            max_residual_up_arcsec: *r_up,
            max_residual_down_arcsec: *r_down,
        });
    }
    Ok(table)
}

/// A LinuxCNC column's value of correction `c` ″ at `q` °: the trim −c or the actual
/// position q + c, the correction put on the file's `decimals` grid before q is added
/// (so the two ends' equal corrections give equal texts, 0 + x and 360 + x).
pub(super) fn linuxcnc_value(q: f64, c: f64, trim: bool, decimals: usize) -> f64 {
    let scale = 10f64.powi(decimals as i32);
    let c_deg = (c / 3600.0 * scale).round() / scale;
    if trim { -c_deg } else { q + c_deg }
}

pub(super) fn deg6(v: f64) -> String {
    format!("{:.6}", v + 0.0)
}

/// Writes the dialect's text; returns the compensation the controller will apply at each
/// point, ″, per direction (FANUC: from its rounded increments).
fn render(t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
    let letter = spec.axis.upper();
    let mut s = String::new();
    let c = t.c_arcsec.clone();
    let c_down = t.c_down_arcsec.clone();
    if c_down.is_some() && spec.dialect.equidistant() {
        return Err(ModuloError::OneDirection {
            format: spec.dialect.name(),
        });
    }
    let down = c_down.as_ref().unwrap_or(&c);
    match spec.dialect {
        ModuloDialect::LinuxCnc => {
            let value = |q: f64, c: f64| linuxcnc_value(q, c, spec.trim, 6);
            for ((q, c), c_down) in t.points_deg.iter().zip(&c).zip(down) {
                let (fwd, rev) = (value(*q, *c), value(*q, *c_down));
                let _ = writeln!(s, "{} {} {}", deg6(*q), deg6(fwd), deg6(rev));
            }
        }
        ModuloDialect::Siemens => {
            let ax = spec
                .siemens_axis
                .clone()
                .unwrap_or_else(|| format!("{letter}1"));
            let _ = writeln!(
                s,
                "; errmap: rotary axis {letter}, modulo encoder compensation (EEC), ″→°; \
                 closure gap {:.3}″ left out (correct the ratio)",
                t.closure_gap_arcsec
            );
            let _ = writeln!(s, "CHANDATA(1)");
            for (i, c) in c.iter().enumerate() {
                let _ = writeln!(s, "$AA_ENC_COMP[0,{i},{ax}]={}", deg6(c / 3600.0));
            }
            let _ = writeln!(
                s,
                "$AA_ENC_COMP_STEP[0,{ax}]={}",
                deg6(t.step_deg.unwrap_or(0.0))
            );
            let _ = writeln!(s, "$AA_ENC_COMP_MIN[0,{ax}]=0.0");
            let _ = writeln!(s, "$AA_ENC_COMP_MAX[0,{ax}]=360.0");
            let _ = writeln!(s, "$AA_ENC_COMP_IS_MODULO[0,{ax}]=1");
            let _ = writeln!(s, "M17");
        }
        ModuloDialect::Fanuc => return fanuc(t, spec).map(|c| vec![c]),
        ModuloDialect::Heidenhain => {
            let key = spec.axis_name.clone().unwrap_or_else(|| letter.to_string());
            let _ = writeln!(s, "BEGIN {key}.COM DEG");
            let _ = writeln!(s, "{:<6}{:<18}{key}", "NR", "AXISPOS");
            for (i, (q, c)) in t.points_deg.iter().zip(&c).enumerate() {
                let _ = writeln!(
                    s,
                    "{:<6}{:<18}{}",
                    i,
                    format!("+{}", deg6(*q)),
                    signed6(c / 3600.0)
                );
            }
            let _ = writeln!(s, "[END]");
        }
        ModuloDialect::Fagor8055 => {
            let e = format!("E{letter}");
            for (i, (q, c)) in t.points_deg.iter().zip(&c).enumerate() {
                // err− 0 everywhere: the same table both ways (Fagor's rule).
                let minus = c_down
                    .as_ref()
                    .map_or_else(|| "0.0000".to_string(), |d| fixed(d[i] / 3600.0, 4));
                let _ = write!(
                    s,
                    "{:>10}{letter:>11}{:>11}{:>9}{:>11}{:>10}{:>11}\r\n",
                    format!("P{:03}", i + 1),
                    format!("{q:.4}"),
                    e,
                    fixed(c / 3600.0, 4),
                    e,
                    minus
                );
            }
        }
    }
    t.text = s;
    Ok(match c_down {
        Some(d) => vec![c, d],
        None => vec![c],
    })
}

pub(super) fn signed6(v: f64) -> String {
    let v = v + 0.0;
    if v >= 0.0 {
        format!("+{v:.6}")
    } else {
        format!("{v:.6}")
    }
}

/// FANUC's increments of the absolute curve `abs` (counts): v_j = abs_j − abs_{j−1} for
/// j ≥ 1 (a revolution sums to abs_last − abs_0), v₀ = v_last; each within
/// `--fanuc-max-value`, else the refusal naming a magnification that fits.
pub(super) fn fanuc_increments(abs: &[i64], spec: &ModuloSpec) -> Result<Vec<i64>, ModuloError> {
    let mut v: Vec<i64> = vec![0; abs.len()];
    for j in 1..abs.len() {
        v[j] = abs[j] - abs[j - 1];
    }
    v[0] = *v.last().unwrap_or(&0);
    if let Some((point, &value)) = v
        .iter()
        .enumerate()
        .find(|(_, x)| x.unsigned_abs() > u64::from(spec.fanuc_max_value))
    {
        let worst = v.iter().map(|x| x.unsigned_abs()).max().unwrap_or(0) as f64;
        let fits = (worst * f64::from(spec.magnification.max(1))
            / f64::from(spec.fanuc_max_value.max(1)))
        .ceil() as u32;
        return Err(ModuloError::FanucRange {
            value,
            point,
            max: spec.fanuc_max_value,
            fits: fits.max(spec.magnification + 1),
        });
    }
    Ok(v)
}

/// FANUC: increments of E = e′ − e′(R) in detection units × magnification, rounded as
/// absolute values then differenced (so a revolution sums to 0 exactly); v₀ = v_last.
fn fanuc(t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<f64>, ModuloError> {
    let unit_arcsec = spec.detection_unit_deg * 3600.0 * f64::from(spec.magnification.max(1));
    // E = −c; absolute values rounded.
    let abs: Vec<i64> = t
        .c_arcsec
        .iter()
        .map(|c| (-c / unit_arcsec).round() as i64)
        .collect();
    let v = fanuc_increments(&abs, spec)?;
    let p = spec.fanuc_reference_number;
    let step = t.step_deg.unwrap_or(0.0);
    let k = v.len().saturating_sub(1) as u32;
    let mut s = String::new();
    let _ = writeln!(s, "%");
    let _ = writeln!(
        s,
        "(errmap: rotary axis {} pitch error, detection unit {} deg, closure gap {:.3} arcsec left out: correct the ratio)",
        spec.axis.upper(),
        spec.detection_unit_deg,
        t.closure_gap_arcsec
    );
    let _ = writeln!(
        s,
        "(3620={p} 3621={p} 3622={} 3623={} 3624={} 3625=360)",
        p + k,
        spec.magnification,
        deg6(step)
    );
    for (j, x) in v.iter().enumerate() {
        let _ = writeln!(s, "N{}P{x}", 10000 + p as usize + j);
    }
    let _ = writeln!(s, "%");
    t.text = s;
    // The compensation the controller applies: −E summed from the increments.
    let mut sum = 0i64;
    Ok(v.iter()
        .enumerate()
        .map(|(j, x)| {
            if j > 0 {
                sum += x;
            }
            -(sum as f64) * unit_arcsec
        })
        .collect())
}
