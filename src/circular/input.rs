//! Reading one circular test: the trace (CSV or Parquet, one row per sample) and the TOML
//! beside it (same path, extension `.toml`), validated once so that the evaluation and the
//! diagnosis can trust them.
//!
//! Refused, with the file, the line (header = line 1) and the column: a missing required
//! column, a value that is not a finite number, `direction` not ±1 or changing within a
//! run, a run whose rows are not contiguous, a second run in one direction, angles not
//! strictly monotonic in the run's sense, `t_s` decreasing, a run that does not cover the
//! nominal arc. In the TOML: a parse error or an unknown key by line and column, a missing
//! or invalid key by its name.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::error::{CircularError, key_err, parse_toml};
use crate::base::io_err;
use crate::base::{Axis, FileOp};
use crate::table::TableError;
use crate::table::{Cells, column_cells, optional_column_cells, parse_cell, read_frame};

/// The most samples a test may have, both runs together: checked before a simulated test
/// is allocated and before a trace's rows are read. A ballbar sampling at 1 kHz round a
/// 150 mm radius at 1 000 mm/min, overshoots included, takes about 75 000 samples a run;
/// the diagnosis costs about 40 µs a sample in the test profile (docs/circular-test.md).
pub const MAX_SAMPLES: usize = 500_000;
/// The largest nominal radius, mm: longer than any ballbar with its extensions.
pub(crate) const MAX_RADIUS_MM: f64 = 2000.0;
/// The fastest contouring feed, mm/min (2 m/s).
pub(crate) const MAX_FEED_MM_PER_MIN: f64 = 120_000.0;
/// The highest sample rate, Hz.
pub(crate) const MAX_SAMPLE_RATE_HZ: f64 = 10_000.0;
/// The largest radial deviation a trace may hold, µm: ten times a ballbar's measuring
/// range of about a millimetre.
pub(crate) const MAX_DR_UM: f64 = 10_000.0;

/// The plane of a test: its first axis A lies at angle 0, its second B at +90°.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Plane {
    XY,
    YZ,
    ZX,
}

impl Plane {
    pub const ALL: [Plane; 3] = [Plane::XY, Plane::YZ, Plane::ZX];

    /// (A, B): the axis at 0° and the one at 90°.
    pub fn axes(self) -> (Axis, Axis) {
        match self {
            Plane::XY => (Axis::X, Axis::Y),
            Plane::YZ => (Axis::Y, Axis::Z),
            Plane::ZX => (Axis::Z, Axis::X),
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Plane::XY => "XY",
            Plane::YZ => "YZ",
            Plane::ZX => "ZX",
        }
    }
}

/// The sense of a run: ccw (+1, the angle increases) or cw (−1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Sense {
    Ccw,
    Cw,
}

impl Sense {
    /// s = +1 (ccw) or −1 (cw).
    pub fn s(self) -> f64 {
        match self {
            Sense::Ccw => 1.0,
            Sense::Cw => -1.0,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Sense::Ccw => "ccw",
            Sense::Cw => "cw",
        }
    }
}

impl Serialize for Sense {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// The constant metadata of a test (the TOML beside the trace).
///
/// Unknown keys are refused (a misspelt `radius_mn` must not be ignored); the informative
/// keys a ballbar file commonly carries are declared instead (`instrument`, `serial`,
/// `date`, `operator`, `note`). `centre_mm` (the test centre in machine coordinates) is
/// needed only to compare with a volumetric model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestMeta {
    pub plane: Plane,
    pub radius_mm: f64,
    pub feed_mm_per_min: f64,
    pub arc_start_deg: f64,
    pub arc_deg: f64,
    pub overshoot_deg: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_rate_hz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre_mm: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instrument: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub date: Option<toml::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operator: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl TestMeta {
    /// Contouring speed v = F/60, mm/s.
    pub fn v_mm_per_s(&self) -> f64 {
        self.feed_mm_per_min / 60.0
    }

    /// Angular speed ω = v/R, rad/s.
    pub fn omega_rad_per_s(&self) -> f64 {
        self.v_mm_per_s() / self.radius_mm
    }

    /// The nominal arc [start, end], degrees.
    pub fn arc_deg_range(&self) -> (f64, f64) {
        (self.arc_start_deg, self.arc_start_deg + self.arc_deg)
    }

    /// Every value in its range, else the key and the problem.
    pub fn check(&self, path: &Path) -> Result<(), CircularError> {
        let positive = |key: &str, v: f64, max: f64, unit: &str| {
            if !(v.is_finite() && v > 0.0) {
                Err(key_err(
                    path,
                    key,
                    format!("{v} must be a finite number > 0"),
                ))
            } else if v > max {
                Err(key_err(
                    path,
                    key,
                    format!("{v} is above the plausible {max} {unit}"),
                ))
            } else {
                Ok(())
            }
        };
        positive("radius_mm", self.radius_mm, MAX_RADIUS_MM, "mm")?;
        positive(
            "feed_mm_per_min",
            self.feed_mm_per_min,
            MAX_FEED_MM_PER_MIN,
            "mm/min",
        )?;
        if let Some(f) = self.sample_rate_hz {
            positive("sample_rate_hz", f, MAX_SAMPLE_RATE_HZ, "Hz")?;
        }
        if !(self.arc_deg.is_finite() && self.arc_deg > 0.0 && self.arc_deg <= 360.0) {
            return Err(key_err(
                path,
                "arc_deg",
                format!("{} must be in (0, 360]", self.arc_deg),
            ));
        }
        if self.arc_deg.is_nan() || self.arc_deg < 90.0 {
            return Err(key_err(
                path,
                "arc_deg",
                format!(
                    "{} is too short to separate the centring from the errors (at least 90)",
                    self.arc_deg
                ),
            ));
        }
        if !(self.arc_start_deg.is_finite() && self.arc_start_deg.abs() <= 3600.0) {
            return Err(key_err(
                path,
                "arc_start_deg",
                format!("{} must be a finite angle within ±3600", self.arc_start_deg),
            ));
        }
        if !(self.overshoot_deg.is_finite() && (0.0..=360.0).contains(&self.overshoot_deg)) {
            return Err(key_err(
                path,
                "overshoot_deg",
                format!("{} must be in [0, 360]", self.overshoot_deg),
            ));
        }
        if let Some(c) = self.centre_mm
            && c.iter().any(|v| !v.is_finite())
        {
            return Err(key_err(
                path,
                "centre_mm",
                "every coordinate must be finite",
            ));
        }
        Ok(())
    }

    /// Reads and checks the TOML at `path`.
    pub fn read(path: &Path) -> Result<TestMeta, CircularError> {
        let text = std::fs::read_to_string(path).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => CircularError::Test {
                path: path.to_path_buf(),
                problem: "the test's metadata TOML is missing (it lies beside the trace, \
                          same name, extension .toml)"
                    .into(),
            },
            _ => io_err(path, FileOp::Read)(source).into(),
        })?;
        let meta: TestMeta = parse_toml(path, &text)?;
        meta.check(path)?;
        Ok(meta)
    }

    /// The TOML text of this metadata.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }
}

/// One run: the samples of one direction, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub id: i64,
    pub sense: Sense,
    /// File line of its first row.
    pub first_line: usize,
    /// Commanded angle, degrees, unwrapped, strictly monotonic in the run's sense.
    pub angle_deg: Vec<f64>,
    /// Bar length minus the nominal radius, µm.
    pub dr_um: Vec<f64>,
    /// Time, s, when the trace has it.
    pub t_s: Option<Vec<f64>>,
}

impl Run {
    /// The indices of the nominal-arc samples.
    pub fn nominal(&self, meta: &TestMeta) -> Vec<usize> {
        let (lo, hi) = meta.arc_deg_range();
        let tol = 1e-9;
        (0..self.angle_deg.len())
            .filter(|&i| self.angle_deg[i] >= lo - tol && self.angle_deg[i] <= hi + tol)
            .collect()
    }
}

/// One circular test: its metadata and one or two runs (one per direction, ccw first).
#[derive(Debug, Clone, PartialEq)]
pub struct CircularTest {
    pub trace: PathBuf,
    pub meta: TestMeta,
    pub runs: Vec<Run>,
}

impl CircularTest {
    pub fn run(&self, sense: Sense) -> Option<&Run> {
        self.runs.iter().find(|r| r.sense == sense)
    }

    /// The directions present, ccw first.
    pub fn directions(&self) -> Vec<Sense> {
        self.runs.iter().map(|r| r.sense).collect()
    }
}

/// The metadata path beside a trace: same path, extension `.toml`.
pub fn meta_path(trace: &Path) -> PathBuf {
    trace.with_extension("toml")
}

/// One row of the trace as read: its run, direction, angle, radial deviation and time.
struct Sample {
    run_id: i64,
    sense: Sense,
    angle: f64,
    dr: f64,
    t: Option<f64>,
}

/// The trace's columns, found before any row is read, and how a cell of one is read.
struct TraceColumns<'a> {
    trace: &'a Path,
    run_c: Cells,
    dir_c: Cells,
    ang_c: Cells,
    dr_c: Cells,
    t_c: Option<Cells>,
}

impl TraceColumns<'_> {
    /// A problem with row `row0` (0-based; line row0 + 2 of the file) in `column`.
    fn bad(&self, row0: usize, column: &str, problem: String) -> CircularError {
        CircularError::Trace {
            path: self.trace.to_path_buf(),
            line: row0 + 2,
            column: column.to_string(),
            problem,
        }
    }

    /// A required number, its problems named with the file line and column.
    fn cell(&self, cells: &Cells, row0: usize, column: &str) -> Result<f64, CircularError> {
        match parse_cell(self.trace, cells, row0, column) {
            Ok(Some(v)) => Ok(v),
            Ok(None) => Err(self.bad(row0, column, "empty cell".into())),
            Err(TableError::NotNumeric { value, .. }) => {
                Err(self.bad(row0, column, format!("`{value}` is not a number")))
            }
            Err(TableError::NonFinite { value, .. }) => {
                Err(self.bad(row0, column, format!("{value} is not a finite number")))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Row `row0` as a sample: an integer run id, a direction of ±1, the numbers.
    fn sample(&self, row0: usize) -> Result<Sample, CircularError> {
        let run_v = self.cell(&self.run_c, row0, "run")?;
        if run_v.fract() != 0.0 || run_v.abs() > 1e15 {
            return Err(self.bad(row0, "run", format!("{run_v} is not an integer run id")));
        }
        let run_id = run_v as i64;
        let d = self.cell(&self.dir_c, row0, "direction")?;
        let sense = if d == 1.0 {
            Sense::Ccw
        } else if d == -1.0 {
            Sense::Cw
        } else {
            return Err(self.bad(row0, "direction", format!("{d} is not +1 (ccw) or -1 (cw)")));
        };
        let angle = self.cell(&self.ang_c, row0, "angle_deg")?;
        let dr = self.cell(&self.dr_c, row0, "dr_um")?;
        if dr.abs() > MAX_DR_UM {
            return Err(self.bad(
                row0,
                "dr_um",
                format!("{dr} µm is outside the plausible range ±{MAX_DR_UM} µm"),
            ));
        }
        let t = self
            .t_c
            .as_ref()
            .map(|c| self.cell(c, row0, "t_s"))
            .transpose()?;
        Ok(Sample {
            run_id,
            sense,
            angle,
            dr,
            t,
        })
    }

    /// Adds sample `s` (row `row0`) to its run, starting a run at a new id: runs must be
    /// contiguous, one per direction, their angle strictly monotonic in the run's sense
    /// and their time not decreasing.
    fn add(&self, runs: &mut Vec<Run>, row0: usize, s: Sample) -> Result<(), CircularError> {
        let Sample {
            run_id,
            sense,
            angle,
            dr,
            t,
        } = s;
        let new_run = runs.last().is_none_or(|r| r.id != run_id);
        if new_run {
            if runs.iter().any(|r| r.id == run_id) {
                return Err(self.bad(
                    row0,
                    "run",
                    format!("run {run_id} appears again: the rows of a run must be contiguous"),
                ));
            }
            if let Some(other) = runs.iter().find(|r| r.sense == sense) {
                return Err(self.bad(
                    row0,
                    "direction",
                    format!(
                        "run {run_id} is a second {} run (run {} already is); a test holds one \
                         run per direction",
                        sense.as_str(),
                        other.id
                    ),
                ));
            }
            runs.push(Run {
                id: run_id,
                sense,
                first_line: row0 + 2,
                angle_deg: Vec::new(),
                dr_um: Vec::new(),
                t_s: t.map(|_| Vec::new()),
            });
        }
        let r = runs.last_mut().expect("a run was just pushed");
        if r.sense != sense {
            return Err(self.bad(
                row0,
                "direction",
                format!(
                    "changes from {} to {} within run {run_id}",
                    r.sense.as_str(),
                    sense.as_str()
                ),
            ));
        }
        if let Some(&prev) = r.angle_deg.last()
            && (angle - prev) * sense.s() <= 0.0
        {
            return Err(self.bad(
                row0,
                "angle_deg",
                format!(
                    "{angle} after {prev}: the angle must strictly {} within a {} run",
                    if sense == Sense::Ccw {
                        "increase"
                    } else {
                        "decrease"
                    },
                    sense.as_str()
                ),
            ));
        }
        if let (Some(ts), Some(t)) = (r.t_s.as_mut(), t) {
            if let Some(&prev) = ts.last()
                && t < prev
            {
                return Err(self.bad(row0, "t_s", format!("{t} after {prev}: time decreases")));
            }
            ts.push(t);
        }
        r.angle_deg.push(angle);
        r.dr_um.push(dr);
        Ok(())
    }
}

/// Reads the trace at `trace` and its TOML beside it.
pub fn read_test(trace: &Path) -> Result<CircularTest, CircularError> {
    let meta = TestMeta::read(&meta_path(trace))?;
    let df = read_frame(trace)?;
    if df.height() == 0 {
        return Err(TableError::Empty {
            path: trace.to_path_buf(),
        }
        .into());
    }
    if df.height() > MAX_SAMPLES {
        return Err(CircularError::Test {
            path: trace.to_path_buf(),
            problem: format!(
                "{} rows, more than the {MAX_SAMPLES} samples a test may have",
                df.height()
            ),
        });
    }
    let cols = |name: &str| column_cells(trace, &df, name);
    let columns = TraceColumns {
        trace,
        run_c: cols("run")?,
        dir_c: cols("direction")?,
        ang_c: cols("angle_deg")?,
        dr_c: cols("dr_um")?,
        t_c: optional_column_cells(trace, &df, "t_s")?,
    };
    let mut runs: Vec<Run> = Vec::new();
    for row0 in 0..df.height() {
        let s = columns.sample(row0)?;
        columns.add(&mut runs, row0, s)?;
    }
    check_arcs(trace, &runs, &meta)?;
    runs.sort_by_key(|r| r.sense);
    Ok(CircularTest {
        trace: trace.to_path_buf(),
        meta,
        runs,
    })
}

/// Refuses a run that does not cover the nominal arc or has fewer than 16 samples on it.
fn check_arcs(trace: &Path, runs: &[Run], meta: &TestMeta) -> Result<(), CircularError> {
    let (lo, hi) = meta.arc_deg_range();
    for r in runs {
        let (a0, a1) = (r.angle_deg[0], r.angle_deg[r.angle_deg.len() - 1]);
        let (min, max) = (a0.min(a1), a0.max(a1));
        if min > lo + 1e-9 || max < hi - 1e-9 {
            return Err(CircularError::Trace {
                path: trace.to_path_buf(),
                line: r.first_line,
                column: "angle_deg".into(),
                problem: format!(
                    "run {} covers {min}..{max} deg, not the nominal arc {lo}..{hi} deg",
                    r.id
                ),
            });
        }
        if r.nominal(meta).len() < 16 {
            return Err(CircularError::Trace {
                path: trace.to_path_buf(),
                line: r.first_line,
                column: "angle_deg".into(),
                problem: format!(
                    "run {} has {} samples on the nominal arc (at least 16 are needed)",
                    r.id,
                    r.nominal(meta).len()
                ),
            });
        }
    }
    Ok(())
}
