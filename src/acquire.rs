//! Acquisition glue: the simulated device's model and plan files, serving it on a
//! pseudo-terminal, capturing a session directory, and replaying a raw capture. The
//! protocol, the capture loop and the simulated board live in `errmap-drivers`; this
//! module connects them to files and to errmap's error maps.
//!
//! A session directory written by `capture` holds:
//! - `raw.bin` — every byte read from the port, appended before decoding, fsynced at
//!   least once a second and at every run end;
//! - `session.csv` (or `.parquet`) — the session table;
//! - `session.json` — the device's HELLO, the decoder statistics (spec shape, with the
//!   stream positions of the first problems), why the capture ended, bytes and fsyncs.

use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use errmap_drivers::capture::{Capture, CaptureConfig, CaptureEnd, Progress, capture};
use errmap_drivers::frame::{Axis as WireAxis, Hello};
use errmap_drivers::sim::{
    Device, Environment, Faults, Plan, SimStream, Truth, TruthQuery, simulate,
};
use errmap_drivers::{ByteSource, DecoderStats, SessionRow, decode_all};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::interp::{Interpolator, Method, Order, fuzzy};
use crate::session::write_session;
use crate::table::{ErrorTable, TableError};

/// Errors of the acquisition glue (files and configuration; the capture's own errors are
/// wrapped).
#[derive(Debug, thiserror::Error)]
pub enum AcquireError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("{path}: {source}")]
    Capture {
        path: PathBuf,
        #[source]
        source: errmap_drivers::capture::CaptureError,
    },
    #[error("{path}: no valid frame in {bytes} bytes (is this a raw capture?)")]
    NoFrames { path: PathBuf, bytes: usize },
    #[error(
        "{path} already exists: a capture never overwrites an earlier one; choose another --out"
    )]
    Exists { path: PathBuf },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> AcquireError + '_ {
    move |source| AcquireError::Io {
        path: path.to_path_buf(),
        source,
    }
}

// --------------------------------------------------------------------------------------
// Model and plan files

/// The simulated machine for `serve-sim` and the demo: an error map plus noise.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SimModel {
    /// The machine's geometric error map (None: a perfect machine).
    #[serde(default)]
    pub error_map: Option<ErrorMapSpec>,
    /// White noise on every latched error, one sigma, µm.
    #[serde(default = "default_noise")]
    pub noise_um: f64,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub environment: EnvSpec,
    #[serde(default)]
    pub device: DeviceSpec,
}

fn default_noise() -> f64 {
    0.05
}

/// An error map: a table and the method that interpolates it.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorMapSpec {
    /// Error table, relative to the model file.
    pub table: PathBuf,
    #[serde(default = "default_method")]
    pub method: String,
    /// Lagrange degrees MxNxQ.
    #[serde(default)]
    pub order: Option<String>,
    #[serde(default = "default_sigma")]
    pub fuzzy_sigma: f64,
}

fn default_method() -> String {
    "spline".into()
}
fn default_sigma() -> f64 {
    fuzzy::DEFAULT_SIGMA
}

/// Constant environment the sensors report (°C, hPa, %).
#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnvSpec {
    pub air_temp_c: f64,
    pub air_pressure_hpa: f64,
    pub air_rh_pct: f64,
    pub scale_temp_c: f64,
    pub part_temp_c: f64,
}

impl Default for EnvSpec {
    fn default() -> Self {
        let e = Environment::default();
        EnvSpec {
            air_temp_c: e.air_temp_c,
            air_pressure_hpa: e.air_pressure_hpa,
            air_rh_pct: e.air_rh_pct,
            scale_temp_c: e.scale_temp_c,
            part_temp_c: e.part_temp_c,
        }
    }
}

impl From<EnvSpec> for Environment {
    fn from(e: EnvSpec) -> Self {
        Environment {
            air_temp_c: e.air_temp_c,
            air_pressure_hpa: e.air_pressure_hpa,
            air_rh_pct: e.air_rh_pct,
            scale_temp_c: e.scale_temp_c,
            part_temp_c: e.part_temp_c,
        }
    }
}

/// The board: what its HELLO says and its line.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeviceSpec {
    pub device_id: String,
    pub grating_period_nm: u32,
    pub count_resolution_pm: u32,
    pub laser_wavelength_fm: u32,
    pub optical_fold: u8,
    pub edges_per_fringe: u8,
    pub baud: u32,
}

impl Default for DeviceSpec {
    fn default() -> Self {
        let d = Device::default();
        DeviceSpec {
            device_id: d.device_id,
            grating_period_nm: d.grating_period_nm,
            count_resolution_pm: d.count_resolution_pm,
            laser_wavelength_fm: d.laser_wavelength_fm,
            optical_fold: d.optical_fold,
            edges_per_fringe: d.edges_per_fringe,
            baud: d.baud,
        }
    }
}

impl DeviceSpec {
    pub fn device(&self) -> Device {
        Device {
            device_id: self.device_id.clone(),
            grating_period_nm: self.grating_period_nm,
            count_resolution_pm: self.count_resolution_pm,
            laser_wavelength_fm: self.laser_wavelength_fm,
            optical_fold: self.optical_fold,
            edges_per_fringe: self.edges_per_fringe,
            baud: self.baud,
            ..Device::default()
        }
    }
}

/// A measurement plan file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlanSpec {
    /// "X", "Y" or "Z".
    pub axis: String,
    /// The two other coordinates of each line, mm.
    pub lines_mm: Vec<[f64; 2]>,
    pub targets_mm: Vec<f64>,
    #[serde(default = "default_runs")]
    pub runs: u32,
    #[serde(default = "default_feed")]
    pub feed_mm_s: f64,
    #[serde(default = "default_dwell")]
    pub dwell_s: f64,
    #[serde(default = "default_rate")]
    pub sample_hz: f64,
    #[serde(default = "default_settle")]
    pub settle_s: f64,
}

fn default_runs() -> u32 {
    5
}
fn default_feed() -> f64 {
    120.0
}
fn default_dwell() -> f64 {
    0.5
}
fn default_rate() -> f64 {
    50.0
}
fn default_settle() -> f64 {
    0.2
}

impl PlanSpec {
    pub fn plan(&self, path: &Path) -> Result<Plan, AcquireError> {
        let axis = match self.axis.trim() {
            "X" | "x" => WireAxis::X,
            "Y" | "y" => WireAxis::Y,
            "Z" | "z" => WireAxis::Z,
            other => {
                return Err(AcquireError::Config {
                    path: path.to_path_buf(),
                    message: format!("axis `{other}` is not X, Y or Z"),
                });
            }
        };
        Ok(Plan {
            axis,
            lines_mm: self.lines_mm.clone(),
            targets_mm: self.targets_mm.clone(),
            runs: self.runs,
            feed_mm_s: self.feed_mm_s,
            dwell_s: self.dwell_s,
            sample_hz: self.sample_hz,
            settle_s: self.settle_s,
        })
    }
}

fn read_toml<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, AcquireError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    toml::from_str(&text).map_err(|e| AcquireError::Config {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

impl SimModel {
    pub fn read(path: &Path) -> Result<Self, AcquireError> {
        let mut m: SimModel = read_toml(path)?;
        if let Some(map) = &mut m.error_map
            && map.table.is_relative()
        {
            map.table = path.parent().unwrap_or(Path::new(".")).join(&map.table);
        }
        Ok(m)
    }

    /// The truth this model describes.
    pub fn truth(&self, path: &Path) -> Result<ErrorMapTruth, AcquireError> {
        let model: Option<Box<dyn Interpolator>> = match &self.error_map {
            None => None,
            Some(spec) => {
                let table = ErrorTable::read(&spec.table)?;
                let grid = table.grid()?;
                let method = match spec.method.as_str() {
                    "lagrange" => {
                        let order: Order =
                            spec.order.as_deref().unwrap_or("1x1x1").parse().map_err(
                                |message| AcquireError::Config {
                                    path: path.to_path_buf(),
                                    message,
                                },
                            )?;
                        Method::Lagrange(order)
                    }
                    "trilinear" => Method::Trilinear,
                    "spline" => Method::Spline,
                    "fuzzy" => Method::Fuzzy {
                        sigma: spec.fuzzy_sigma,
                    },
                    other => {
                        return Err(AcquireError::Config {
                            path: path.to_path_buf(),
                            message: format!("unknown method `{other}`"),
                        });
                    }
                };
                Some(method.fit(&grid).map_err(|e| AcquireError::Config {
                    path: path.to_path_buf(),
                    message: e.to_string(),
                })?)
            }
        };
        if !(self.noise_um.is_finite() && self.noise_um >= 0.0) {
            return Err(AcquireError::Config {
                path: path.to_path_buf(),
                message: format!("noise_um = {} must be ≥ 0", self.noise_um),
            });
        }
        Ok(ErrorMapTruth {
            model,
            noise_um: self.noise_um,
            rng: StdRng::seed_from_u64(self.seed),
            env: self.environment.into(),
        })
    }
}

impl PlanSpec {
    pub fn read(path: &Path) -> Result<Self, AcquireError> {
        read_toml(path)
    }
}

/// The truth of an error map plus white noise (the physics simulator replaces it).
#[derive(Debug)]
pub struct ErrorMapTruth {
    model: Option<Box<dyn Interpolator>>,
    noise_um: f64,
    rng: StdRng,
    env: Environment,
}

impl ErrorMapTruth {
    /// The noiseless error at a position.
    pub fn map_um(&self, p: [f64; 3]) -> f64 {
        self.model.as_ref().map_or(0.0, |m| m.predict(p))
    }
}

/// One standard normal deviate (Box–Muller).
pub fn gaussian(rng: &mut StdRng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl Truth for ErrorMapTruth {
    fn error_um(&mut self, q: &TruthQuery) -> f64 {
        self.map_um(q.pos_mm) + self.noise_um * gaussian(&mut self.rng)
    }

    fn environment(&mut self, _t_s: f64) -> Environment {
        self.env
    }
}

/// Simulates a whole stream from a model and plan file.
pub fn simulate_stream(
    model_path: &Path,
    plan_path: Option<&Path>,
    faults: &Faults,
) -> Result<(SimStream, ErrorMapTruth), AcquireError> {
    let model = SimModel::read(model_path)?;
    let plan = match plan_path {
        Some(p) => PlanSpec::read(p)?.plan(p)?,
        None => Plan::default(),
    };
    let mut truth = model.truth(model_path)?;
    let stream = simulate(&plan, &model.device.device(), faults, &mut truth).map_err(|e| {
        AcquireError::Config {
            path: plan_path.unwrap_or(model_path).to_path_buf(),
            message: e.to_string(),
        }
    })?;
    Ok((stream, truth))
}

// --------------------------------------------------------------------------------------
// Capture and replay

/// The session directory's JSON description.
#[derive(Debug, Serialize)]
pub struct SessionJson {
    pub hello: Option<HelloJson>,
    pub decoder: DecoderStats,
    pub end: CaptureEnd,
    pub bytes: u64,
    pub fsyncs: u64,
    pub raw: String,
    pub table: String,
}

/// HELLO fields in readable form.
#[derive(Debug, Serialize)]
pub struct HelloJson {
    pub protocol_version: u8,
    pub device_id: String,
    pub grating_period_nm: u32,
    pub count_resolution_pm: u32,
    pub laser_wavelength_fm: u32,
    pub optical_fold: u8,
    pub edges_per_fringe: u8,
    pub axis: String,
}

impl From<&Hello> for HelloJson {
    fn from(h: &Hello) -> Self {
        HelloJson {
            protocol_version: h.protocol_version,
            device_id: h.device_id.as_string(),
            grating_period_nm: h.grating_period_nm,
            count_resolution_pm: h.count_resolution_pm,
            laser_wavelength_fm: h.laser_wavelength_fm,
            optical_fold: h.optical_fold,
            edges_per_fringe: h.edges_per_fringe,
            axis: h
                .axis()
                .map_or_else(|| format!("code {}", h.axis_code), |a| a.to_string()),
        }
    }
}

/// Where a capture writes.
#[derive(Debug, Clone)]
pub struct SessionPaths {
    pub dir: PathBuf,
    pub raw: PathBuf,
    pub table: PathBuf,
    pub json: PathBuf,
}

impl SessionPaths {
    /// `format` is the session table's extension: "csv" or "parquet".
    pub fn new(dir: &Path, format: &str) -> Self {
        SessionPaths {
            dir: dir.to_path_buf(),
            raw: dir.join("raw.bin"),
            table: dir.join(format!("session.{format}")),
            json: dir.join("session.json"),
        }
    }
}

/// Captures from `source` into a session directory (see the module docs). The raw file
/// must not exist yet. Returns the capture; the session table and JSON are written even
/// when the port vanished (the caller reports that as an error afterwards).
pub fn capture_session(
    source: &mut dyn ByteSource,
    paths: &SessionPaths,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Capture, AcquireError> {
    std::fs::create_dir_all(&paths.dir).map_err(io_err(&paths.dir))?;
    let mut raw: File = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&paths.raw)
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::AlreadyExists {
                AcquireError::Exists {
                    path: paths.raw.clone(),
                }
            } else {
                AcquireError::Io {
                    path: paths.raw.clone(),
                    source: e,
                }
            }
        })?;
    let cap = capture(source, &mut raw, config, stop, progress).map_err(|source| {
        AcquireError::Capture {
            path: paths.raw.clone(),
            source,
        }
    })?;
    write_session(&paths.table, &cap.rows)?;
    write_json(
        &paths.json,
        &SessionJson {
            hello: cap.hello.as_ref().map(HelloJson::from),
            decoder: cap.stats.clone(),
            end: cap.end.clone(),
            bytes: cap.bytes,
            fsyncs: cap.fsyncs,
            raw: file_name(&paths.raw),
            table: file_name(&paths.table),
        },
    )?;
    Ok(cap)
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), AcquireError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| AcquireError::Config {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    std::fs::write(path, text + "\n").map_err(io_err(path))
}

/// Decodes a raw capture into a session table. A damaged capture is not an error: every
/// decodable row is written and the damage is in the statistics. Fails only when the file
/// cannot be read or holds no valid frame.
pub fn replay(
    raw: &Path,
    out: &Path,
) -> Result<(Vec<SessionRow>, DecoderStats, Option<Hello>), AcquireError> {
    let bytes = std::fs::read(raw).map_err(io_err(raw))?;
    let (rows, stats, hello) = decode_all(&bytes);
    let frames = stats.frames.total();
    if frames == 0 {
        return Err(AcquireError::NoFrames {
            path: raw.to_path_buf(),
            bytes: bytes.len(),
        });
    }
    write_session(out, &rows)?;
    Ok((rows, stats, hello))
}
