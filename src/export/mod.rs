//! Compensation tables for machine controllers, exported from a fitted error model.
//!
//! A fitted [`Interpolator`] is sampled along one axis ([`sample_line`]) or over a
//! volume ([`grid::render`]) and rendered in a controller's own format. The renderers
//! are pure: they return the text or the rows, and the caller writes the file
//! ([`write_grid`] writes the grid's rows for now).
//!
//! | function | writes | limit | cost |
//! |---|---|---|---|
//! | [`sample_line`] | a [`Sampled`] line: positions, e, extrapolation flags | [`MAX_SAMPLES`] | n predictions + n `outside` tests |
//! | [`linuxcnc`](mod@linuxcnc) | a LinuxCNC `COMP_FILE` (type 0 or 1) | [`LINUXCNC_MAX_ENTRIES`] = 256 | O(n) text |
//! | [`siemens`](mod@siemens) | a SINUMERIK 840D sl LEC/MSEC part program (`%_N_AX_EEC_INI`); direction-dependent: two CEC tables (`%_N_NC_CEC_INI`, K3 §4.4.4) | the axis' MD38000 (CEC: MD18342), a parameter | O(n) text |
//! | [`fanuc`](mod@fanuc) | FANUC pitch error compensation: parameters 3620–3624 (3605#0, 3626, 3627 bidirectional) and increments per point | point numbers ≤ [`FANUC_MAX_POINT_NUMBER`], \|value\| ≤ a parameter | O(n) text |
//! | [`heidenhain`](mod@heidenhain) | a HEIDENHAIN TNC `.COM` nonlinear axis error compensation table | [`HEIDENHAIN_MAX_POINTS`] = 256, a parameter | O(n) text |
//! | [`isg`](mod@isg) | a TwinCAT CNC (ISG) `kw.ssfk` leadscrew error compensation list, unilateral or bilateral | < P-COMP-00059 ([`ISG_DEFAULT_MAX_POINTS`] = 1500) | O(n) text |
//! | [`fagor`](mod@fagor) | a Fagor 8055 leadscrew table `AL<axis>` (one table, or both directions with a reverse line) | [`FAGOR_8055_MAX_POINTS`] (unverified) | O(n) text |
//! | [`fagor`](mod@fagor) | a Fagor 8065 axis file `<axis>.mp` holding the leadscrew table (UTF-16LE; BIDIR 1 with a reverse line) | [`FAGOR_8065_MAX_POINTS`] (unverified) | O(n) text |
//! | [`csv`](mod@csv) | `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated` for one line | — | O(n) text |
//! | [`grid`] | the same columns over a box ([`GridRows`]; CSV or Parquet via polars by [`write_grid`]) | [`MAX_SAMPLES`] | N predictions |
//!
//! # Sign convention
//!
//! errmap's error is e = indicated − reference (µm, [`crate::table::ErrorPoint`]). The
//! compensation is c = −e ([`compensation_um`]): the amount that, added to the machine's
//! *indicated* (scale/encoder) position, gives the reference (true) position,
//! indicated + c = reference. How a controller applies a table decides which of c and
//! −c it stores:
//!
//! * **Siemens LEC/MSEC corrects the actual (feedback) value**, so the table holds c, in
//!   mm (the controller's documentation is cited in [`siemens`](mod@siemens)).
//! * **TwinCAT CNC (ISG) LSEC holds the position error actual − setpoint**, which is c,
//!   in 0.1 µm ([`isg`](mod@isg)).
//! * **FANUC pitch error compensation outputs pulses added to the motion**, so its
//!   increments are those of e, relative to the reference position ([`fanuc`](mod@fanuc)).
//! * **HEIDENHAIN**: the sign is not stated in the sources consulted; errmap writes c,
//!   ISO 230-2's deviation ([`heidenhain`](mod@heidenhain)).
//! * **LinuxCNC adds its trim to the position command**, so the trim is −c = e; a type-0
//!   file lists the actual position N + c instead, which LinuxCNC turns into the same
//!   trim (the controller's source is cited in [`linuxcnc`](mod@linuxcnc)).
//!
//! Both are first-order corrections: the table is looked up at the commanded (or
//! indicated) position rather than the corrected one, an error of order
//! e·(de/dx) — µm × µm/mm, i.e. nanometres for ordinary maps.
//!
//! # Extrapolation
//!
//! Every sampled position outside the model's nodes is flagged (`extrapolated`, from
//! [`Interpolator::outside`]). With [`Extrapolation::Forbid`] any such position is an
//! error naming the mapped range, which is found from `outside` alone by bisection
//! ([`MappedBox::around`]), so it works for every interpolator.

pub mod bidirectional;
pub mod csv;
mod error;
pub mod fagor;
pub mod fanuc;
pub mod grid;
pub mod heidenhain;
pub mod isg;
pub mod linuxcnc;
pub mod siemens;
pub mod step;

use std::path::Path;

use polars::prelude::{Column, DataFrame};

use crate::interp::Interpolator;
use crate::table::{Axis, TableError, write_frame};

pub use csv::render as csv;
pub use error::{Controller, ExportError, MappedBox};
pub use fagor::{FAGOR_8055_MAX_POINTS, FAGOR_8065_MAX_POINTS, Fagor8055Spec};
pub use fanuc::{FANUC_MAX_POINT_NUMBER, FanucSpec, FanucTable};
pub use grid::GridRows;
pub use heidenhain::HEIDENHAIN_MAX_POINTS;
pub use isg::{ISG_DEFAULT_MAX_POINTS, IsgAxis};
pub use linuxcnc::{LINUXCNC_MAX_ENTRIES, LinuxCncCompType, render as linuxcnc};
pub use siemens::{SIEMENS_808D_MAX_POINTS, render as siemens};
pub use step::{Ends, StepFit, regrid_measured, sample_line_fit};

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

/// What to export.
#[derive(Debug, Clone, PartialEq)]
pub enum ExportFormat {
    /// A LinuxCNC `COMP_FILE` for one joint.
    LinuxCnc { comp_type: LinuxCncCompType },
    /// A SINUMERIK 840D sl LEC/MSEC program for machine axis `axis_name` (e.g. `X1`),
    /// whose MD38000 `MM_ENC_COMP_MAX_POINTS` is `max_points`.
    Siemens {
        axis_name: String,
        max_points: usize,
    },
    /// SINUMERIK 840D sl direction-dependent leadscrew error compensation: two CEC tables
    /// from `first_table` on machine axis `AX<axis_number>`, each of at most
    /// `max_points` (MD18342); needs a reverse line.
    SiemensCec {
        axis_number: u32,
        first_table: usize,
        max_points: usize,
    },
    /// FANUC pitch error compensation (bidirectional with a reverse line).
    Fanuc { spec: FanucSpec },
    /// A HEIDENHAIN `.COM` table: the axis key (column name), the table's name and the
    /// entry limit.
    Heidenhain {
        axis_key: String,
        table_name: String,
        max_points: usize,
    },
    /// A TwinCAT CNC (ISG) `kw.ssfk` list (bilateral with a reverse line).
    Isg { axis: IsgAxis },
    /// A Fagor 8055 `AL<axis>` leadscrew table (both directions with a reverse line).
    Fagor8055 { spec: Fagor8055Spec },
    /// A Fagor 8065 `<axis>.mp` axis file holding the leadscrew table (both directions,
    /// BIDIR 1, with a reverse line); UTF-16LE ([`ExportFormat::render_bytes`]).
    Fagor8065 { spec: Fagor8055Spec },
    /// One line as `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`.
    Csv,
    /// A volumetric grid (CSV or Parquet by extension), see [`write_grid`].
    Grid,
}

impl ExportFormat {
    /// A short name for messages.
    pub fn name(&self) -> &'static str {
        match self {
            ExportFormat::LinuxCnc { .. } => "linuxcnc",
            ExportFormat::Siemens { .. } => "siemens",
            ExportFormat::SiemensCec { .. } => "siemens (direction-dependent, CEC)",
            ExportFormat::Fanuc { .. } => "fanuc",
            ExportFormat::Heidenhain { .. } => "heidenhain",
            ExportFormat::Isg { .. } => "isg",
            ExportFormat::Fagor8055 { .. } => "fagor-8055",
            ExportFormat::Fagor8065 { .. } => "fagor-8065",
            ExportFormat::Csv => "csv",
            ExportFormat::Grid => "grid",
        }
    }

    /// Whether the format lists every position, so that the intervals may differ
    /// (LinuxCNC, ISG, CSV: [`StepFit::LastShorter`] fits any step); Siemens', FANUC's
    /// and HEIDENHAIN's tables have one interval.
    pub fn allows_uneven(&self) -> bool {
        matches!(
            self,
            ExportFormat::LinuxCnc { .. }
                | ExportFormat::Isg { .. }
                | ExportFormat::Fagor8055 { .. }
                | ExportFormat::Fagor8065 { .. }
                | ExportFormat::Csv
        )
    }

    /// Whether the format has direction-dependent tables (a reverse line).
    pub fn bidirectional(&self) -> bool {
        matches!(
            self,
            ExportFormat::LinuxCnc { .. }
                | ExportFormat::SiemensCec { .. }
                | ExportFormat::Fanuc { .. }
                | ExportFormat::Isg { .. }
                | ExportFormat::Fagor8055 { .. }
                | ExportFormat::Fagor8065 { .. }
        )
    }

    /// Whether the format is written from one sampled line (all but [`ExportFormat::Grid`]).
    pub fn is_line(&self) -> bool {
        !matches!(self, ExportFormat::Grid)
    }

    /// Renders a sampled line. `reverse` (direction-dependent errors, same positions)
    /// is used by the formats with direction-dependent tables ([`Self::bidirectional`]);
    /// the other line formats refuse it.
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
            ExportFormat::SiemensCec {
                axis_number,
                first_table,
                max_points,
            } => {
                let Some(reverse) = reverse else {
                    return Err(ExportError::ReverseMismatch {
                        problem: "the direction-dependent Siemens tables need the reverse line"
                            .into(),
                    });
                };
                siemens::render_bidirectional(
                    forward,
                    reverse,
                    *axis_number,
                    *first_table,
                    *max_points,
                )
            }
            ExportFormat::Fanuc { spec } => fanuc::render(forward, reverse, spec),
            ExportFormat::Heidenhain {
                axis_key,
                table_name,
                max_points,
            } => {
                if reverse.is_some() {
                    return Err(ExportError::ReverseUnsupported {
                        format: self.name(),
                    });
                }
                heidenhain::render(forward, axis_key, table_name, *max_points)
            }
            ExportFormat::Isg { axis } => isg::render(forward, reverse, axis),
            ExportFormat::Fagor8055 { spec } => fagor::render_8055(forward, reverse, spec),
            ExportFormat::Fagor8065 { spec } => fagor::render_8065(forward, reverse, spec),
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

    /// The file's bytes for a sampled line: [`Self::render_line`]'s text, UTF-8, except
    /// the Fagor 8065 axis file, which is UTF-16LE with its byte-order mark.
    pub fn render_bytes(
        &self,
        forward: &Sampled,
        reverse: Option<&Sampled>,
    ) -> Result<Vec<u8>, ExportError> {
        let text = self.render_line(forward, reverse)?;
        Ok(match self {
            ExportFormat::Fagor8065 { .. } => fagor::encode_8065(&text),
            _ => text.into_bytes(),
        })
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
/// With [`sample_line`] the step must divide the range into whole intervals (to 1e-9
/// relative, or be range/k rounded to the file's 1e-6 mm, see [`step`]): controllers
/// with equidistant tables (Siemens) need it, and silently moving the end would change
/// the range the user asked for. [`sample_line_fit`] places the points of any step.
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
    /// Errors measured at positions along a line, with no model between them (e.g. a
    /// session's per-target means in one direction); the renderers check them as they
    /// check a sampled model (increasing positions, finite values).
    pub fn measured(
        axis: Axis,
        at_mm: [f64; 3],
        positions_mm: Vec<f64>,
        error_um: Vec<f64>,
    ) -> Self {
        let n = positions_mm.len();
        Sampled {
            axis,
            at_mm,
            positions_mm,
            error_um,
            extrapolated: vec![false; n],
        }
    }

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

/// Checks `forward` and, when given, `reverse` (the same positions, direction-dependent
/// errors); returns the line the reverse column comes from (`forward` without one).
fn paired<'a>(
    forward: &'a Sampled,
    reverse: Option<&'a Sampled>,
) -> Result<&'a Sampled, ExportError> {
    forward.check()?;
    let Some(r) = reverse else {
        return Ok(forward);
    };
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
    Ok(r)
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
            points: (k as u128).saturating_add(1),
            limit: MAX_SAMPLES,
        });
    }
    let kr = k.round();
    let n = kr as usize;
    if (k - kr).abs() <= 1e-9 * kr.max(1.0) {
        return Ok((0..=n)
            .map(|i| {
                if i == n {
                    end_mm
                } else {
                    snap(start_mm + i as f64 * step_mm)
                }
            })
            .collect());
    }
    // range/k rounded to the file resolution (the suggestion below, given back): k
    // intervals of exactly this step, the end moved by at most k·0.5e-6 mm (see `step`).
    if kr >= 1.0 && (kr * step_mm - length_mm).abs() <= kr * 0.5 * FILE_RESOLUTION_MM + 1e-12 {
        return Ok((0..=n)
            .map(|i| snap(start_mm + i as f64 * step_mm))
            .collect());
    }
    Err(ExportError::StepDoesNotDivide {
        axis,
        length_mm,
        step_mm,
        fitting_step_mm: length_mm / k.ceil(),
    })
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
    // The step must divide the range: the placement rule of `step::StepFit::Divide`.
    step::sample_line_fit(model, line, step::StepFit::Divide, extrapolation)
}

/// Samples the model over a box ([`grid::render`]) and writes
/// `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated` (x fastest) as CSV or Parquet, by the
/// extension of `out`, through [`crate::table::write_frame`]. Returns the number of rows.
/// Cost: N predictions. The renderer ([`grid::render`]) is pure; this is the one place
/// the export touches a file, and it does so through the table stage's writer.
pub fn write_grid(
    model: &dyn Interpolator,
    spec: &VolumeSpec,
    extrapolation: Extrapolation,
    out: &Path,
) -> Result<usize, ExportError> {
    let rows = grid::render(model, spec, extrapolation)?;
    let coord = |name: &str, a: usize| {
        Column::new(
            name.into(),
            rows.points_mm.iter().map(|p| p[a]).collect::<Vec<f64>>(),
        )
    };
    let n = rows.len();
    let comp = rows.comp_um();
    let cols = vec![
        coord("x_mm", 0),
        coord("y_mm", 1),
        coord("z_mm", 2),
        Column::new("e_um".into(), rows.error_um),
        Column::new("comp_um".into(), comp),
        Column::new("extrapolated".into(), rows.extrapolated),
    ];
    let mut df = DataFrame::new(n, cols).map_err(|e| TableError::Format {
        path: out.to_path_buf(),
        message: e.to_string(),
    })?;
    write_frame(out, &mut df)?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 17's campaign: `export --start -1e308` overflowed the point count (a
    /// panic in a debug build) instead of refusing the line as too long.
    #[test]
    fn a_line_of_astronomically_many_points_is_refused_not_overflowed() {
        let spec = LineSpec {
            axis: Axis::X,
            at_mm: [0.0; 3],
            start_mm: -1e308,
            end_mm: 800.0,
            step_mm: 50.0,
        };
        match spec.positions() {
            Err(ExportError::TooManyPoints { points, limit }) => {
                assert_eq!(points, u128::MAX);
                assert_eq!(limit, MAX_SAMPLES);
            }
            other => panic!("expected TooManyPoints, got {other:?}"),
        }
    }
}
