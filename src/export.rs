//! Compensation tables for machine controllers, exported from a fitted error model.
//!
//! A fitted [`Interpolator`] is sampled along one axis ([`sample_line`]) or over a
//! volume ([`volumetric_grid`]) and written in a controller's own format:
//!
//! | function | writes | limit | cost |
//! |---|---|---|---|
//! | [`sample_line`] | a [`Sampled`] line: positions, e, extrapolation flags | [`MAX_SAMPLES`] | n predictions + n `outside` tests |
//! | [`linuxcnc`] | a LinuxCNC `COMP_FILE` (type 0 or 1) | [`LINUXCNC_MAX_ENTRIES`] = 256 | O(n) text |
//! | [`siemens`] | a SINUMERIK 840D sl LEC/MSEC part program (`%_N_AX_EEC_INI`) | the axis' MD38000, a parameter | O(n) text |
//! | [`csv`] | `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated` for one line | — | O(n) text |
//! | [`volumetric_grid`] | the same columns over a box, CSV or Parquet via polars | [`MAX_SAMPLES`] | N predictions |
//!
//! # Sign convention
//!
//! errmap's error is e = indicated − reference (µm, [`crate::table::ErrorPoint`]). The
//! compensation is c = −e ([`compensation_um`]): the amount that, added to the machine's
//! *indicated* (scale/encoder) position, gives the reference (true) position,
//! indicated + c = reference. How a controller applies a table decides which of c and
//! −c it stores:
//!
//! * **Siemens LEC/MSEC corrects the actual (feedback) value.** The compensation value
//!   modifies the axis' position actual value, so a positive value makes the axis move in
//!   the negative direction (SINUMERIK 808D Function Manual 01/2017, "Leadscrew error
//!   compensation"). The table therefore holds c, in mm.
//! * **LinuxCNC adds its trim to the position command.** `control.c` computes
//!   `motor_pos_cmd = pos_cmd + backlash_filt + motor_offset`, where `backlash_filt`
//!   follows the trim interpolated from the table. To reach nominal N on an axis whose
//!   scale over-reads by e, the motor must be commanded to N + e, so the trim is
//!   −c = e. A type-0 file lists instead the *actual* position reached when N is
//!   commanded, N − e = N + c; LinuxCNC turns it into the trim `nominal − value` = e
//!   (`usrmotLoadComp` in `src/emc/motion/usrmotintf.cc`), so both file types load the
//!   same trims.
//!
//! Both are first-order corrections: the table is looked up at the commanded (or
//! indicated) position rather than the corrected one, an error of order
//! e·(de/dx) — µm × µm/mm, i.e. nanometres for ordinary maps.
//!
//! # LinuxCNC `COMP_FILE`
//!
//! `[JOINT_n] COMP_FILE = file`, `COMP_FILE_TYPE = 0|1` (LinuxCNC INI documentation,
//! `docs/src/config/ini-config.adoc`, section `[JOINT_<num>]`). One triplet per line,
//! `nominal forward reverse`, in machine units (this module writes mm; an inch machine
//! needs its own conversion), smallest nominal first and strictly increasing; at most
//! 256 triplets per joint (`EMCMOT_COMP_SIZE` in `motion.h`; `EMCMOT_SET_JOINT_COMP` in
//! `command.c` rejects extra entries and non-increasing nominals). The loader stops at
//! the first line that is not three numbers, so the file has no header and no comments.
//! Between nominals the trim is interpolated linearly; the forward column applies while
//! the joint moves in the positive direction, the reverse column while it moves in the
//! negative one. Without direction-dependent data both columns are equal.
//!
//! | type | forward / reverse column | written as |
//! |---|---|---|
//! | 0 ([`LinuxCncCompType::ActualPosition`]) | actual position when moving up / down | N + c |
//! | 1 ([`LinuxCncCompType::Trim`]) | trim added to the command moving up / down | −c = e |
//!
//! # Siemens 840D sl leadscrew / measuring-system error compensation
//!
//! SINUMERIK 840D sl Extended Functions, Function Manual K3 "Compensations",
//! §4.4.2 "Measuring system error compensation" (6FC5397-1BP40-3BA1, 03/2013): per
//! machine axis and measuring system e (0 = first encoder) the table is the system
//! variables `$AA_ENC_COMP[e,N,AXi]` (the value at interpolation point N, mm),
//! `$AA_ENC_COMP_STEP[e,AXi]` (the distance between points), `$AA_ENC_COMP_MIN[e,AXi]`
//! (the position of point 0), `$AA_ENC_COMP_MAX[e,AXi]` (the position of the last point)
//! and `$AA_ENC_COMP_IS_MODULO[e,AXi]`, loaded by an `%_N_AX_EEC_INI` program
//! (`CHANDATA(1)` … `M17`) while MD32700 `ENC_COMP_ENABLE` = 0. Points are equidistant,
//! so N_points = (MAX − MIN)/STEP + 1, and N_points must not exceed MD38000
//! `MM_ENC_COMP_MAX_POINTS` (0 ≤ N ≤ MD38000 − 1), which is configured per axis (the manual's example needs
//! ≥ 801; the SINUMERIK 808D allows up to 200, [`SIEMENS_808D_MAX_POINTS`]) — so the limit
//! is a parameter here. Between points the value is interpolated linearly; below MIN and
//! above MAX the first and last values stay active over the whole remaining travel,
//! which is why the manual asks for them to be 0 when the table does not cover the whole
//! traversing range. Tables are direction-independent (backlash is a separate function)
//! and this module writes linear axes only (`IS_MODULO = 0`).
//!
//! **How the first and last values are made 0.** The sampled line is written unchanged
//! and one extra point of value 0 is added one step before the first sample and one step
//! after the last (MIN = start − step, MAX = end + step). Inside the mapped range the
//! control applies exactly the compensation the model predicts; over the one step beyond
//! each end it ramps linearly to 0, and beyond that the axis is uncompensated, as it would
//! be without a table. The alternative — subtracting the straight line through the end
//! values — would also zero the ends, but it silently removes a scale error and an
//! offset from the compensation everywhere inside the range, which is not what a
//! commissioning engineer asks for. The two pads count against MD38000. Note also that
//! the 808D manual recommends a zero value at the reference point so that switching the
//! compensation on after referencing causes no jump; errmap's tables are absolute, so if
//! c ≠ 0 there the axis moves by c when the table is activated.
//!
//! # Extrapolation
//!
//! Every sampled position outside the model's nodes is flagged (`extrapolated`, from
//! [`Interpolator::outside`]). With [`Extrapolation::Forbid`] any such position is an
//! error naming the mapped range, which is found from `outside` alone by bisection
//! ([`MappedBox::around`]), so it works for every interpolator.

use std::fmt;
use std::path::Path;

use polars::prelude::{Column, DataFrame};

use crate::interp::Interpolator;
use crate::table::{Axis, TableError, write_frame};

/// LinuxCNC's limit on compensation triplets per joint (`EMCMOT_COMP_SIZE`).
pub const LINUXCNC_MAX_ENTRIES: usize = 256;

/// The SINUMERIK 808D's LEC table size (N = 0…199). On the 840D sl the limit is the
/// axis' MD38000 `MM_ENC_COMP_MAX_POINTS`, which must be read from the machine.
pub const SIEMENS_808D_MAX_POINTS: usize = 200;

/// errmap's own cap on sampled points per line or volume, so that a mistyped step cannot
/// exhaust memory (a 2 000 000-point volume is about 100 MB in flight).
pub const MAX_SAMPLES: usize = 2_000_000;

/// Resolution of the numbers written to controller files: 1e-6 mm (1 nm).
pub const FILE_RESOLUTION_MM: f64 = 1e-6;

/// The compensation for an error: c = −e (both µm). See the module docs for how each
/// controller applies it.
#[inline]
pub fn compensation_um(e_um: f64) -> f64 {
    -e_um
}

/// LinuxCNC `COMP_FILE_TYPE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LinuxCncCompType {
    /// Type 0: the second and third columns are the actual positions reached when the
    /// nominal is commanded (N + c).
    ActualPosition,
    /// Type 1: the columns are the trims LinuxCNC adds to the command (−c = e).
    Trim,
}

impl LinuxCncCompType {
    /// The value for `COMP_FILE_TYPE`.
    pub fn code(self) -> u8 {
        match self {
            LinuxCncCompType::ActualPosition => 0,
            LinuxCncCompType::Trim => 1,
        }
    }
}

/// What to export.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ExportFormat {
    /// A LinuxCNC `COMP_FILE` for one joint.
    LinuxCnc { comp_type: LinuxCncCompType },
    /// A SINUMERIK 840D sl LEC/MSEC program for machine axis `axis_name` (e.g. `X1`),
    /// whose MD38000 `MM_ENC_COMP_MAX_POINTS` is `max_points`.
    Siemens {
        axis_name: String,
        max_points: usize,
    },
    /// One line as `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`.
    Csv,
    /// A volumetric grid (CSV or Parquet by extension), see [`volumetric_grid`].
    Grid,
}

impl ExportFormat {
    /// A short name for messages.
    pub fn name(&self) -> &'static str {
        match self {
            ExportFormat::LinuxCnc { .. } => "linuxcnc",
            ExportFormat::Siemens { .. } => "siemens",
            ExportFormat::Csv => "csv",
            ExportFormat::Grid => "grid",
        }
    }

    /// Whether the format is written from one sampled line (all but [`ExportFormat::Grid`]).
    pub fn is_line(&self) -> bool {
        !matches!(self, ExportFormat::Grid)
    }

    /// Renders a sampled line. `reverse` (direction-dependent errors, same positions)
    /// is used by LinuxCNC only; the other line formats refuse it.
    pub fn render_line(
        &self,
        forward: &Sampled,
        reverse: Option<&Sampled>,
    ) -> Result<String, ExportError> {
        match self {
            ExportFormat::LinuxCnc { comp_type } => linuxcnc(forward, *comp_type, reverse),
            ExportFormat::Siemens {
                axis_name,
                max_points,
            } => {
                if reverse.is_some() {
                    return Err(ExportError::ReverseUnsupported {
                        format: self.name(),
                    });
                }
                siemens(forward, axis_name, *max_points)
            }
            ExportFormat::Csv => {
                if reverse.is_some() {
                    return Err(ExportError::ReverseUnsupported {
                        format: self.name(),
                    });
                }
                forward.check()?;
                Ok(csv(forward))
            }
            ExportFormat::Grid => Err(ExportError::GridNeedsVolume),
        }
    }
}

/// What to do with positions outside the model's nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Extrapolation {
    /// Predict there and flag the positions (the default).
    #[default]
    Allow,
    /// Refuse, naming the mapped range.
    Forbid,
}

/// One line of a compensation table: along `axis` from `start_mm` to `end_mm` every
/// `step_mm`, the other two coordinates fixed by `at_mm` (its entry for `axis` is
/// ignored).
///
/// The step must divide the range into whole intervals (to 1e-9 relative): controllers
/// with equidistant tables (Siemens) need it, and silently moving the end would change
/// the range the user asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSpec {
    pub axis: Axis,
    pub at_mm: [f64; 3],
    pub start_mm: f64,
    pub end_mm: f64,
    pub step_mm: f64,
}

impl LineSpec {
    /// The 3-D point at `position_mm` along the line.
    pub fn point(&self, position_mm: f64) -> [f64; 3] {
        let mut p = self.at_mm;
        p[self.axis.index()] = position_mm;
        p
    }

    /// The validated positions along the line, start and end included.
    pub fn positions(&self) -> Result<Vec<f64>, ExportError> {
        axis_positions(self.axis, self.start_mm, self.end_mm, self.step_mm, false)
    }
}

/// A box sampled every `spacing_mm` along each axis, `lo_mm` to `hi_mm` inclusive. An
/// axis with `lo == hi` has a single plane; otherwise the spacing must divide its extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeSpec {
    pub lo_mm: [f64; 3],
    pub hi_mm: [f64; 3],
    pub spacing_mm: f64,
}

/// A sampled line: the model's error at each position and whether it was extrapolated.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampled {
    pub axis: Axis,
    /// The fixed coordinates (the entry for `axis` is ignored).
    pub at_mm: [f64; 3],
    /// Strictly increasing positions along `axis`.
    pub positions_mm: Vec<f64>,
    /// Predicted error e = indicated − reference at each position.
    pub error_um: Vec<f64>,
    /// Whether each position lies outside the model's nodes.
    pub extrapolated: Vec<bool>,
}

impl Sampled {
    pub fn len(&self) -> usize {
        self.positions_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions_mm.is_empty()
    }

    /// The 3-D point of sample `i`.
    pub fn point(&self, i: usize) -> [f64; 3] {
        let mut p = self.at_mm;
        p[self.axis.index()] = self.positions_mm[i];
        p
    }

    /// The compensation c = −e at each position, µm.
    pub fn comp_um(&self) -> Vec<f64> {
        self.error_um.iter().map(|&e| compensation_um(e)).collect()
    }

    /// How many positions were extrapolated.
    pub fn extrapolated_count(&self) -> usize {
        self.extrapolated.iter().filter(|&&x| x).count()
    }

    /// Checks what the exporters rely on: equal lengths, at least two samples, finite
    /// numbers, strictly increasing positions.
    pub fn check(&self) -> Result<(), ExportError> {
        let (n, ne, nf) = (self.len(), self.error_um.len(), self.extrapolated.len());
        if ne != n || nf != n {
            return Err(ExportError::LengthMismatch {
                positions: n,
                errors: ne,
                flags: nf,
            });
        }
        if n < 2 {
            return Err(ExportError::TooFewSamples { count: n });
        }
        for (index, (&x, &e)) in self.positions_mm.iter().zip(&self.error_um).enumerate() {
            if !x.is_finite() || !e.is_finite() {
                return Err(ExportError::NonFiniteSample {
                    index,
                    position_mm: x,
                    error_um: e,
                });
            }
            if index > 0 && x <= self.positions_mm[index - 1] {
                return Err(ExportError::NotIncreasing {
                    index,
                    previous_mm: self.positions_mm[index - 1],
                    position_mm: x,
                });
            }
        }
        Ok(())
    }

    /// The common step of equidistant positions (checked to 1e-9 mm + 1e-9 relative).
    fn uniform_step(&self) -> Result<f64, ExportError> {
        let n = self.len();
        let step = (self.positions_mm[n - 1] - self.positions_mm[0]) / (n - 1) as f64;
        let tol = 1e-9
            * (1.0
                + self.positions_mm[n - 1]
                    .abs()
                    .max(self.positions_mm[0].abs()));
        for (i, w) in self.positions_mm.windows(2).enumerate() {
            let expected = self.positions_mm[0] + (i + 1) as f64 * step;
            if (w[1] - expected).abs() > tol {
                return Err(ExportError::NotEquidistant {
                    index: i + 1,
                    step_mm: step,
                    gap_mm: w[1] - w[0],
                });
            }
        }
        Ok(step)
    }

    fn length_mm(&self) -> f64 {
        self.positions_mm.last().copied().unwrap_or(0.0)
            - self.positions_mm.first().copied().unwrap_or(0.0)
    }
}

/// The controller whose table limit was exceeded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Controller {
    LinuxCnc,
    Siemens,
}

impl fmt::Display for Controller {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Controller::LinuxCnc => "LinuxCNC (COMP_FILE triplets per joint, EMCMOT_COMP_SIZE)",
            Controller::Siemens => "the Siemens LEC table (MD38000 MM_ENC_COMP_MAX_POINTS)",
        })
    }
}

/// The mapped volume as far as `Interpolator::outside` reveals it: for each axis the
/// extent of the inside segment through one inside point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedBox {
    pub lo_mm: [f64; 3],
    pub hi_mm: [f64; 3],
}

impl MappedBox {
    /// Finds the box around `inside` by doubling outwards, then bisecting, along each
    /// axis (≈ 100 `outside` calls per face). `None` if `inside` is outside. A face the
    /// search does not reach within 1e9 mm is reported as ±∞.
    pub fn around(model: &dyn Interpolator, inside: [f64; 3]) -> Option<Self> {
        if model.outside(inside) {
            return None;
        }
        let mut lo_mm = [0.0; 3];
        let mut hi_mm = [0.0; 3];
        for a in 0..3 {
            lo_mm[a] = edge(model, inside, a, -1.0);
            hi_mm[a] = edge(model, inside, a, 1.0);
        }
        Some(Self { lo_mm, hi_mm })
    }
}

impl fmt::Display for MappedBox {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (a, axis) in Axis::ALL.iter().enumerate() {
            if a > 0 {
                f.write_str(", ")?;
            }
            write!(
                f,
                "{axis} {}–{} mm",
                fmt_fixed(self.lo_mm[a], 4),
                fmt_fixed(self.hi_mm[a], 4)
            )?;
        }
        Ok(())
    }
}

/// The last inside coordinate along axis `a` from `p` in direction `dir`.
fn edge(model: &dyn Interpolator, p: [f64; 3], a: usize, dir: f64) -> f64 {
    let x0 = p[a];
    let is_out = |x: f64| {
        let mut q = p;
        q[a] = x;
        model.outside(q)
    };
    let mut inside = x0;
    let mut d = 1.0;
    let mut outside = loop {
        let x = x0 + dir * d;
        if is_out(x) {
            break x;
        }
        inside = x;
        d *= 2.0;
        if d > 1e9 {
            return dir * f64::INFINITY;
        }
    };
    for _ in 0..200 {
        let mid = 0.5 * (inside + outside);
        if mid == inside || mid == outside {
            break;
        }
        if is_out(mid) {
            outside = mid;
        } else {
            inside = mid;
        }
    }
    inside
}

/// Why a table cannot be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("step {step_mm} mm must be a positive, finite length")]
    BadStep { step_mm: f64 },
    #[error("coordinate {value} mm along {axis} is not a finite number")]
    NonFiniteCoordinate { axis: Axis, value: f64 },
    #[error(
        "the range along {axis} from {start_mm} mm to {end_mm} mm is empty: the end must be greater than the start"
    )]
    EmptyRange {
        axis: Axis,
        start_mm: f64,
        end_mm: f64,
    },
    #[error(
        "step {step_mm} mm does not divide the {length} mm range along {axis} into whole intervals; \
         the nearest finer step that does is {fitting} mm",
        length = fmt_mm(*length_mm),
        fitting = fmt_mm(*fitting_step_mm)
    )]
    StepDoesNotDivide {
        axis: Axis,
        length_mm: f64,
        step_mm: f64,
        fitting_step_mm: f64,
    },
    #[error("{points} sample points exceed errmap's cap of {limit}; use a coarser step")]
    TooManyPoints { points: u128, limit: usize },
    #[error("{}", too_many_message(*controller, *samples, *padding, *limit, *length_mm))]
    TooManyEntries {
        controller: Controller,
        /// Sampled positions.
        samples: usize,
        /// Entries the format adds (Siemens: 2 zero end points).
        padding: usize,
        limit: usize,
        length_mm: f64,
    },
    #[error("{}", outside_message(*outside, *total, *first_mm, mapped.as_ref()))]
    OutsideMappedRange {
        outside: usize,
        total: usize,
        first_mm: [f64; 3],
        mapped: Option<MappedBox>,
    },
    #[error("the model predicts {value} µm at {point}, which is not a finite number", point = fmt_point(*position_mm))]
    NonFinitePrediction { position_mm: [f64; 3], value: f64 },
    #[error(
        "sampled line has {positions} positions, {errors} errors and {flags} extrapolation flags"
    )]
    LengthMismatch {
        positions: usize,
        errors: usize,
        flags: usize,
    },
    #[error("a compensation table needs at least 2 samples, got {count}")]
    TooFewSamples { count: usize },
    #[error("sample {index}: position {position_mm} mm or error {error_um} µm is not finite")]
    NonFiniteSample {
        index: usize,
        position_mm: f64,
        error_um: f64,
    },
    #[error(
        "sample {index}: position {position_mm} mm does not increase on {previous_mm} mm \
         (at the file's 1e-6 mm resolution)"
    )]
    NotIncreasing {
        index: usize,
        previous_mm: f64,
        position_mm: f64,
    },
    #[error(
        "sample {index}: gap {gap_mm} mm differs from the table step {step_mm} mm; Siemens tables are equidistant"
    )]
    NotEquidistant {
        index: usize,
        step_mm: f64,
        gap_mm: f64,
    },
    #[error(
        "Siemens table step {step_mm} mm is not a whole number of 1e-6 mm, so MIN, MAX and STEP \
         would not describe the points exactly; choose a step with at most 6 decimals"
    )]
    StepNotRepresentable { step_mm: f64 },
    #[error("reverse line does not match the forward line: {problem}")]
    ReverseMismatch { problem: String },
    #[error(
        "the {format} format has no direction-dependent table; export the forward errors \
         and configure backlash separately, or use the linuxcnc format"
    )]
    ReverseUnsupported { format: &'static str },
    #[error(
        "`{name}` is not a machine axis name (letters, digits and `_`, starting with a letter, at most 32 characters, e.g. X1)"
    )]
    BadAxisName { name: String },
    #[error("the grid format samples a volume: call volumetric_grid, not render_line")]
    GridNeedsVolume,
    #[error(transparent)]
    Table(#[from] TableError),
}

fn too_many_message(
    controller: Controller,
    samples: usize,
    padding: usize,
    limit: usize,
    length_mm: f64,
) -> String {
    let entries = samples + padding;
    let mut m = format!("{controller} allows at most {limit} entries; this table needs {entries}");
    if padding > 0 {
        m.push_str(&format!(" ({samples} samples + {padding} zero end points)"));
    }
    match fitting_step(length_mm, limit, padding) {
        Some((min, suggested)) => {
            let k = (length_mm / suggested).round() as usize;
            m.push_str(&format!(
                ": use a step of at least {} mm that divides the {} mm range, e.g. {} mm ({} entries)",
                fmt_mm(min),
                fmt_mm(length_mm),
                fmt_mm(suggested),
                k + 1 + padding
            ));
        }
        None => m.push_str(": the limit is too small for any table of this format"),
    }
    m
}

/// The smallest step that fits `limit` entries over `length_mm` (with `padding` extra
/// entries), and the smallest step at least as large that is a whole number of µm and
/// divides the length (falling back to the minimum).
fn fitting_step(length_mm: f64, limit: usize, padding: usize) -> Option<(f64, f64)> {
    // k intervals → k + 1 samples + padding entries ≤ limit.
    let k_max = limit.checked_sub(1 + padding).filter(|&k| k >= 1)?;
    let min = length_mm / k_max as f64;
    let is_round = |s: f64| {
        let um = s * 1e3;
        (um - um.round()).abs() <= 1e-6 * um.abs().max(1.0)
    };
    let suggested = (1..=k_max)
        .rev()
        .map(|k| length_mm / k as f64)
        .find(|&s| is_round(s))
        .unwrap_or(min);
    Some((min, suggested))
}

fn outside_message(
    outside: usize,
    total: usize,
    first: [f64; 3],
    mapped: Option<&MappedBox>,
) -> String {
    match mapped {
        Some(b) => format!(
            "{outside} of {total} positions lie outside the mapped range {b} (the first at {}); \
             shorten the range or allow extrapolation",
            fmt_point(first)
        ),
        None => format!(
            "none of the {total} positions lies inside the mapped volume (the first is {}); \
             check the fixed coordinates and the range",
            fmt_point(first)
        ),
    }
}

/// `v` with `decimals` decimals, trailing zeros trimmed (one kept), and no `-0.0`.
fn fmt_fixed(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.push('0');
        }
    }
    if s.parse::<f64>() == Ok(0.0) {
        return "0.0".into();
    }
    s
}

/// A length in mm at the file resolution (1e-6 mm).
fn fmt_mm(v: f64) -> String {
    fmt_fixed(v, 6)
}

fn fmt_point(p: [f64; 3]) -> String {
    format!(
        "({}, {}, {}) mm",
        fmt_fixed(p[0], 4),
        fmt_fixed(p[1], 4),
        fmt_fixed(p[2], 4)
    )
}

/// Rounds to 1e-9 mm so that `start + i·step` prints as the user typed it.
fn snap(x: f64) -> f64 {
    if x.abs() < 1e6 {
        let s = (x * 1e9).round() / 1e9;
        if s == 0.0 { 0.0 } else { s }
    } else {
        x
    }
}

/// Positions `start, start + step, …, end`; `allow_single` accepts `start == end`.
fn axis_positions(
    axis: Axis,
    start_mm: f64,
    end_mm: f64,
    step_mm: f64,
    allow_single: bool,
) -> Result<Vec<f64>, ExportError> {
    if !(step_mm.is_finite() && step_mm > 0.0) {
        return Err(ExportError::BadStep { step_mm });
    }
    for value in [start_mm, end_mm] {
        if !value.is_finite() {
            return Err(ExportError::NonFiniteCoordinate { axis, value });
        }
    }
    if end_mm < start_mm || (end_mm == start_mm && !allow_single) {
        return Err(ExportError::EmptyRange {
            axis,
            start_mm,
            end_mm,
        });
    }
    let length_mm = end_mm - start_mm;
    let k = length_mm / step_mm;
    if k + 1.0 > MAX_SAMPLES as f64 {
        return Err(ExportError::TooManyPoints {
            points: k as u128 + 1,
            limit: MAX_SAMPLES,
        });
    }
    let kr = k.round();
    if (k - kr).abs() > 1e-9 * kr.max(1.0) {
        return Err(ExportError::StepDoesNotDivide {
            axis,
            length_mm,
            step_mm,
            fitting_step_mm: length_mm / k.ceil(),
        });
    }
    let n = kr as usize;
    Ok((0..=n)
        .map(|i| {
            if i == n {
                end_mm
            } else {
                snap(start_mm + i as f64 * step_mm)
            }
        })
        .collect())
}

/// Predictions, flags and the extrapolation policy for a list of points.
fn evaluate(
    model: &dyn Interpolator,
    points: &[[f64; 3]],
    extrapolation: Extrapolation,
) -> Result<(Vec<f64>, Vec<bool>), ExportError> {
    let mut error_um = vec![0.0; points.len()];
    model.predict_into(points, &mut error_um);
    if let Some((p, &value)) = points.iter().zip(&error_um).find(|(_, v)| !v.is_finite()) {
        return Err(ExportError::NonFinitePrediction {
            position_mm: *p,
            value,
        });
    }
    let flags: Vec<bool> = points.iter().map(|p| model.outside(*p)).collect();
    if extrapolation == Extrapolation::Forbid {
        let outside = flags.iter().filter(|&&f| f).count();
        if let Some(first) = points
            .iter()
            .zip(&flags)
            .find(|(_, f)| **f)
            .map(|(p, _)| *p)
        {
            let mapped = points
                .iter()
                .zip(&flags)
                .find(|(_, f)| !**f)
                .and_then(|(p, _)| MappedBox::around(model, *p));
            return Err(ExportError::OutsideMappedRange {
                outside,
                total: points.len(),
                first_mm: first,
                mapped,
            });
        }
    }
    Ok((error_um, flags))
}

/// Samples the model along a line. Cost: n predictions and n `outside` tests
/// (+ ≈ 600 `outside` calls to name the mapped range when refusing).
pub fn sample_line(
    model: &dyn Interpolator,
    line: &LineSpec,
    extrapolation: Extrapolation,
) -> Result<Sampled, ExportError> {
    for axis in Axis::ALL {
        let value = line.at_mm[axis.index()];
        if axis != line.axis && !value.is_finite() {
            return Err(ExportError::NonFiniteCoordinate { axis, value });
        }
    }
    let positions_mm = line.positions()?;
    let points: Vec<[f64; 3]> = positions_mm.iter().map(|&x| line.point(x)).collect();
    let (error_um, extrapolated) = evaluate(model, &points, extrapolation)?;
    Ok(Sampled {
        axis: line.axis,
        at_mm: line.at_mm,
        positions_mm,
        error_um,
        extrapolated,
    })
}

/// A LinuxCNC `COMP_FILE`: one `nominal forward reverse` line per sample, mm, no header.
///
/// `reverse` holds direction-dependent errors measured moving in the negative direction,
/// at the same positions; without it both columns come from `forward`. Refuses more
/// than [`LINUXCNC_MAX_ENTRIES`] samples, naming a step that fits.
pub fn linuxcnc(
    forward: &Sampled,
    comp_type: LinuxCncCompType,
    reverse: Option<&Sampled>,
) -> Result<String, ExportError> {
    forward.check()?;
    let rev = match reverse {
        Some(r) => {
            r.check()?;
            if r.len() != forward.len() {
                return Err(ExportError::ReverseMismatch {
                    problem: format!("{} reverse samples for {} forward", r.len(), forward.len()),
                });
            }
            if let Some(i) =
                (0..r.len()).find(|&i| (r.positions_mm[i] - forward.positions_mm[i]).abs() > 1e-9)
            {
                return Err(ExportError::ReverseMismatch {
                    problem: format!(
                        "sample {i} is at {} mm forward but {} mm reverse",
                        forward.positions_mm[i], r.positions_mm[i]
                    ),
                });
            }
            r
        }
        None => forward,
    };
    let n = forward.len();
    if n > LINUXCNC_MAX_ENTRIES {
        return Err(ExportError::TooManyEntries {
            controller: Controller::LinuxCnc,
            samples: n,
            padding: 0,
            limit: LINUXCNC_MAX_ENTRIES,
            length_mm: forward.length_mm(),
        });
    }
    let mut out = String::with_capacity(n * 36);
    let mut previous: Option<f64> = None;
    for i in 0..n {
        let nominal = forward.positions_mm[i];
        let nominal_txt = fmt_mm(nominal);
        // The loader compares the numbers it reads: check them, not the f64s.
        let written: f64 = nominal_txt.parse().unwrap_or(f64::NAN);
        if let Some(prev) = previous
            && written.partial_cmp(&prev) != Some(std::cmp::Ordering::Greater)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: prev,
                position_mm: written,
            });
        }
        previous = Some(written);
        let c_fwd_mm = compensation_um(forward.error_um[i]) * 1e-3;
        let c_rev_mm = compensation_um(rev.error_um[i]) * 1e-3;
        let (a, b) = match comp_type {
            LinuxCncCompType::ActualPosition => (nominal + c_fwd_mm, nominal + c_rev_mm),
            LinuxCncCompType::Trim => (-c_fwd_mm, -c_rev_mm),
        };
        out.push_str(&format!("{nominal_txt} {} {}\n", fmt_mm(a), fmt_mm(b)));
    }
    Ok(out)
}

fn check_axis_name(name: &str) -> Result<(), ExportError> {
    let ok = !name.is_empty()
        && name.len() <= 32
        && name.starts_with(|c: char| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(ExportError::BadAxisName {
            name: name.to_string(),
        })
    }
}

/// A SINUMERIK 840D sl LEC/MSEC program (`%_N_AX_EEC_INI`) for machine axis
/// `axis_name`, measuring system 0, values c in mm.
///
/// The samples must be equidistant (as [`sample_line`] makes them). A zero point is
/// added one step before the first and one after the last sample, so that the first and
/// last compensation values are 0 (see the module docs); the table then has
/// `s.len() + 2` points, which must not exceed `max_points` (the axis' MD38000).
pub fn siemens(s: &Sampled, axis_name: &str, max_points: usize) -> Result<String, ExportError> {
    check_axis_name(axis_name)?;
    s.check()?;
    let step = s.uniform_step()?;
    let step_txt = fmt_mm(step);
    let step_written: f64 = step_txt.parse().unwrap_or(0.0);
    if step_written <= 0.0 || (step_written - step).abs() > 1e-9 * step.max(1.0) {
        return Err(ExportError::StepNotRepresentable { step_mm: step });
    }
    let n = s.len();
    if n + 2 > max_points {
        return Err(ExportError::TooManyEntries {
            controller: Controller::Siemens,
            samples: n,
            padding: 2,
            limit: max_points,
            length_mm: s.length_mm(),
        });
    }
    let min = s.positions_mm[0] - step;
    let max = s.positions_mm[n - 1] + step;
    let ax = axis_name;
    let mut out = String::with_capacity((n + 16) * 40);
    out.push_str("%_N_AX_EEC_INI\n");
    out.push_str(&format!(
        "; errmap leadscrew/measuring-system error compensation for machine axis {ax}\n"
    ));
    out.push_str(&format!(
        "; line along {} at {}; values c = -e in mm (e = indicated - reference)\n",
        s.axis,
        fmt_point(s.at_mm)
    ));
    out.push_str(&format!(
        "; {n} samples from {} to {} mm plus a zero point one step beyond each end; \
         {} extrapolated\n",
        fmt_mm(s.positions_mm[0]),
        fmt_mm(s.positions_mm[n - 1]),
        s.extrapolated_count()
    ));
    out.push_str(&format!(
        "; needs MD38000 MM_ENC_COMP_MAX_POINTS >= {}; load with MD32700 ENC_COMP_ENABLE = 0\n",
        n + 2
    ));
    out.push_str("CHANDATA(1)\n");
    out.push_str(&format!("$AA_ENC_COMP[0,0,{ax}]=0.0\n"));
    for (i, &e) in s.error_um.iter().enumerate() {
        out.push_str(&format!(
            "$AA_ENC_COMP[0,{},{ax}]={}\n",
            i + 1,
            fmt_mm(compensation_um(e) * 1e-3)
        ));
    }
    out.push_str(&format!("$AA_ENC_COMP[0,{},{ax}]=0.0\n", n + 1));
    out.push_str(&format!("$AA_ENC_COMP_STEP[0,{ax}]={step_txt}\n"));
    out.push_str(&format!("$AA_ENC_COMP_MIN[0,{ax}]={}\n", fmt_mm(min)));
    out.push_str(&format!("$AA_ENC_COMP_MAX[0,{ax}]={}\n", fmt_mm(max)));
    out.push_str(&format!("$AA_ENC_COMP_IS_MODULO[0,{ax}]=0\n"));
    out.push_str("M17\n");
    Ok(out)
}

/// One line as CSV, `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`, the same columns as
/// [`volumetric_grid`]; numbers in Rust's shortest round-trip form.
pub fn csv(s: &Sampled) -> String {
    let mut out = String::with_capacity(48 + s.len() * 64);
    out.push_str("x_mm,y_mm,z_mm,e_um,comp_um,extrapolated\n");
    for (i, (&e, &x)) in s.error_um.iter().zip(&s.extrapolated).enumerate() {
        let p = s.point(i);
        out.push_str(&format!(
            "{},{},{},{},{},{}\n",
            p[0],
            p[1],
            p[2],
            e,
            compensation_um(e),
            x
        ));
    }
    out
}

/// Samples the model over a box and writes `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`
/// (x fastest) as CSV or Parquet, by the extension of `out`, through
/// [`crate::table::write_frame`]. Returns the number of rows. Cost: N predictions.
pub fn volumetric_grid(
    model: &dyn Interpolator,
    spec: &VolumeSpec,
    extrapolation: Extrapolation,
    out: &Path,
) -> Result<usize, ExportError> {
    let mut axes: [Vec<f64>; 3] = Default::default();
    for axis in Axis::ALL {
        let a = axis.index();
        axes[a] = axis_positions(axis, spec.lo_mm[a], spec.hi_mm[a], spec.spacing_mm, true)?;
    }
    let total = axes.iter().map(|v| v.len() as u128).product::<u128>();
    if total > MAX_SAMPLES as u128 {
        return Err(ExportError::TooManyPoints {
            points: total,
            limit: MAX_SAMPLES,
        });
    }
    let [xs, ys, zs] = &axes;
    let mut points = Vec::with_capacity(total as usize);
    for &z in zs {
        for &y in ys {
            for &x in xs {
                points.push([x, y, z]);
            }
        }
    }
    let (error_um, flags) = evaluate(model, &points, extrapolation)?;
    let coord = |name: &str, a: usize| {
        Column::new(
            name.into(),
            points.iter().map(|p| p[a]).collect::<Vec<f64>>(),
        )
    };
    let comp: Vec<f64> = error_um.iter().map(|&e| compensation_um(e)).collect();
    let cols = vec![
        coord("x_mm", 0),
        coord("y_mm", 1),
        coord("z_mm", 2),
        Column::new("e_um".into(), error_um),
        Column::new("comp_um".into(), comp),
        Column::new("extrapolated".into(), flags),
    ];
    let mut df = DataFrame::new(points.len(), cols).map_err(|e| TableError::Format {
        path: out.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(out, &mut df)?;
    Ok(points.len())
}
