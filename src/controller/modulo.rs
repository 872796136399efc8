//! Modulo compensation tables of a rotary axis (`docs/rotary.md` §4): the shared values
//! and the points; each controller's table (writer, reader, values) is its dialect's
//! [`ModuloSyntax`] ([`Dialect::modulo`]), in the dialect's own file.
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

use super::{Dialect, DialectOptions, Field};
use crate::base::RotaryAxis;

/// The most targets a rotary table may hold here (the placement's O(n³) bound).
pub const MAX_TARGETS: usize = 2000;

/// Every dialect with a modulo table ([`Dialect::modulo`]), in the registry's order.
pub fn modulo_dialects() -> impl Iterator<Item = &'static dyn Dialect> {
    super::DIALECTS
        .iter()
        .copied()
        .filter(|d| d.modulo().is_some())
}

/// The dialect of `--format NAME`, if it has a modulo table.
pub fn modulo_dialect(name: &str) -> Option<&'static dyn Dialect> {
    modulo_dialects().find(|d| d.name() == name)
}

/// Every dialect with a modulo table, by name: `a, b, c`.
pub fn modulo_names() -> String {
    modulo_dialects()
        .map(|d| d.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The dialects whose table holds both directions, each with its columns, as
/// [`ModuloError::OneDirection`] lists them: `a x, b y`.
fn two_direction_columns() -> String {
    modulo_dialects()
        .filter_map(|d| Some(format!("{} {}", d.name(), d.modulo()?.direction_columns()?)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The dialects whose table holds both directions, with what each calls them:
/// `a (x) and b (y)`.
pub fn two_direction_tables() -> String {
    let each: Vec<String> = modulo_dialects()
        .filter_map(|d| {
            let columns = d.modulo()?.direction_columns()?;
            Some(format!("{} ({columns})", d.name()))
        })
        .collect();
    super::join_list(&each, "and")
}

/// What a dialect's modulo table is, where it has one ([`Dialect::modulo`]): how its points
/// are placed, its budget, its writer, its reader of the table in use and its values in
/// the update. The shared values, placement and update are this module's and
/// [`update_modulo`](super::update_modulo)'s.
pub trait ModuloSyntax: Sync {
    /// Whether its points are equidistant (else the targets, or the best placement).
    fn equidistant(&self) -> bool;
    /// The control's point budget.
    fn default_max_points(&self) -> usize;
    /// What the two directions of its table are called, where its table holds both.
    fn direction_columns(&self) -> Option<&'static str> {
        None
    }
    /// Whether its table in use does not say how it is to be read, so that an update
    /// must be told ([`ModuloSpec::trim`]).
    fn needs_comp_type(&self) -> bool {
        false
    }
    /// Writes the table's text into `t.text` from its points and compensation; returns
    /// the compensation the controller will apply at each point, ″, per direction.
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError>;
    /// Reads the table in use `text` (`--existing`), refused at the line that breaks its
    /// rules; the rules common to every modulo table are checked after.
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError>;
    /// The value text of correction `c` ″ at `q` ° for `field`, whose old text is `old`.
    fn encode(&self, spec: &ModuloSpec, q: f64, c: f64, field: Field, old: &str) -> String;
    /// The update's new texts of the table read `old` (`text`), each point's correction
    /// changed by `change`: by default every value through [`Self::encode`], a value
    /// whose number does not change keeping its text.
    fn edits(
        &self,
        old: &ModuloRead,
        text: &str,
        change: &ModuloChange<'_>,
        spec: &ModuloSpec,
    ) -> Result<Vec<(Field, String)>, ModuloError> {
        Ok(super::modulo_update::value_edits(
            self, old, text, change, spec,
        ))
    }
}

/// A modulo table as read ([`ModuloSyntax::read`]): its points and each direction's
/// compensation, ″, and where each value stands in the text.
#[derive(Debug, Clone, Default)]
pub struct ModuloRead {
    pub angles: Vec<f64>,
    /// Each point's line.
    pub lines: Vec<usize>,
    /// Each point's value field(s): moving + and (two-column tables) moving −.
    pub up: Vec<Field>,
    pub down: Vec<Option<Field>>,
    pub c_up: Vec<f64>,
    pub c_down: Vec<f64>,
    /// A two-direction table (its moving − column differs from moving +, or is not all 0).
    pub two: bool,
    /// Its moving − column repeats moving + in a one-direction table, so it is always
    /// written (LinuxCNC's reverse column).
    pub repeats: bool,
    /// The line that states the step, else the second point's.
    pub step_line: usize,
    /// A table of increments (FANUC): its counts, with the unit of one count.
    pub counts: Option<Counts>,
}

/// A table of increments as read: the unit of one count, ″, and each point's increment.
#[derive(Debug, Clone)]
pub struct Counts {
    pub unit_arcsec: f64,
    pub increments: Vec<(Field, i64)>,
}

/// The change of each point's correction in an update, ″, per direction, and whether
/// the result holds two directions.
#[derive(Debug, Clone, Copy)]
pub struct ModuloChange<'a> {
    pub up: &'a [f64],
    pub down: &'a [f64],
    pub two: bool,
}

/// A dialect setting given as a length where a rotary table wants an angle.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{setting} is a length: a rotary {controller} table takes {instead}")]
pub struct LengthSetting {
    /// The setting given ([`DialectOption::name`](super::DialectOption)).
    pub setting: &'static str,
    /// The setting to give instead.
    pub instead: &'static str,
    /// The controller whose setting it is.
    pub controller: &'static str,
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
    /// The dialect whose modulo table it is ([`modulo_dialects`]).
    pub dialect: &'static dyn Dialect,
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
    pub fn new(dialect: &'static dyn Dialect, axis: RotaryAxis) -> Self {
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

    /// Its dialect's modulo table ([`Dialect::modulo`]); a dialect without one is refused.
    pub fn syntax(&self) -> Result<&'static dyn ModuloSyntax, ModuloError> {
        self.dialect.modulo().ok_or(ModuloError::NoModulo {
            format: self.dialect.name(),
        })
    }

    /// Takes the dialects' settings a modulo table uses from `o` (their defaults
    /// and what was given); a length where an angle is wanted is refused.
    pub fn set_options(&mut self, o: &DialectOptions) -> Result<(), LengthSetting> {
        if o.real("detection-unit-um") != Some(1.0) {
            return Err(LengthSetting {
                setting: "detection-unit-um",
                instead: "detection-unit-deg",
                controller: super::fanuc::Fanuc.controller(),
            });
        }
        // X1 is the linear default: a rotary axis defaults to its letter + 1.
        self.siemens_axis = o
            .text("siemens-axis")
            .filter(|s| *s != "X1")
            .map(str::to_string);
        self.fanuc_reference_number = o.number("fanuc-reference-number").unwrap_or(0);
        self.detection_unit_deg = o.real("detection-unit-deg").unwrap_or(0.001);
        self.magnification = o.number("magnification").unwrap_or(1);
        self.fanuc_max_value = o.number("fanuc-max-value").unwrap_or(7);
        Ok(())
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

impl ModuloTable {
    /// Takes the written `text`; the compensation the controller applies at each point,
    /// ″, per direction: the table's own (a renderer whose values are its corrections).
    pub(super) fn written(&mut self, text: String) -> Vec<Vec<f64>> {
        self.text = text;
        let mut c = vec![self.c_arcsec.clone()];
        c.extend(self.c_down_arcsec.clone());
        c
    }
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
    #[error("{format} has no modulo table for a rotary axis")]
    NoModulo { format: &'static str },
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
         tables: {})",
        two_direction_columns()
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
    if spec.syntax()?.equidistant() {
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
    let m = spec.syntax()?;
    let budget = spec.max_points.unwrap_or_else(|| m.default_max_points());
    let v = &series[0];
    if !m.equidistant() && spec.step_deg.is_none() {
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

pub(super) fn deg6(v: f64) -> String {
    format!("{:.6}", v + 0.0)
}

/// Writes the dialect's text; returns the compensation the controller will apply at each
/// point, ″, per direction (FANUC: from its rounded increments).
fn render(t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
    let m = spec.syntax()?;
    if t.c_down_arcsec.is_some() && m.equidistant() {
        return Err(ModuloError::OneDirection {
            format: spec.dialect.name(),
        });
    }
    m.render(t, spec)
}
