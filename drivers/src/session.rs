//! From frames to session-table rows, exactly per `docs/wire-protocol.md` section
//! "From frames to session rows" and the session table of
//! `docs/session-table.md`.
//!
//! [`SessionBuilder`] turns decoded frames into [`SessionRow`]s; [`SessionDecoder`] chains
//! the byte-level [`Decoder`] and the builder (bytes in, rows and problems out); the
//! crate's [`decode_all`](crate::decode_all) runs it over a whole capture.
//!
//! # Rules (spec readings in `drivers/README.md`)
//! - One row per valid SAMPLE, in stream order. `sample` = the unwrapped u32 device index.
//! - Counters are unwrapped to i64 ([`crate::counter`]); the origin of both is their value
//!   in the first SAMPLE with flags = 0. Rows before that SAMPLE, and rows before the
//!   first usable HELLO (which gives axis and scaling), are held back and written, in
//!   order, as soon as both are known (at most [`SessionConfig::max_pending_rows`]).
//! - `scale_mm = ΔS · resolution`, `laser_mm = ΔL · λ_vac / (F · k · n_air)` with n_air
//!   from the modified Edlén equation ([`crate::edlen`]) at the latest ENV (n_air = 1 and
//!   empty air columns before the first ENV).
//! - `t_s` counts from the first timestamped frame (any type but HELLO and TEXT).
//! - MARK state: kind 1 starts a run, kind 2 ends it; inside a run, `run` and `direction`
//!   are those of the latest MARK (any kind), outside a run both are 0. `target` is set by
//!   kind 3 and cleared (−1) by kind 4 only. `feed_mm_s` and the two line coordinates come
//!   from the latest MARK, empty before the first one. The coordinate along the measured
//!   axis is `scale_mm`; the line positions go to the two other axes (Y, Z when measuring
//!   X; X, Z when measuring Y; X, Y when measuring Z).
//! - Flagged rows are kept with their flags (BEAM_LOW rows still get `laser_mm`).
//! - A physically impossible sensor reading (air outside −50 … 100 °C, 300 … 1 300 hPa
//!   or 0 … 100 % RH; a material temperature outside −50 … 100 °C) is a broken sensor:
//!   the frame is not used, so the rows after it are marked the spec's way, with empty
//!   air (or material) columns and n_air = 1, until a plausible frame comes; the problem
//!   log counts it (`implausible_env`, `implausible_material`).
//! - SAMPLEs that no usable HELLO ever describes are counted in
//!   [`DecoderStats::unconverted_samples`](crate::DecoderStats) (and the `no_hello`
//!   problem); [`SessionBuilder::preset_hello`] supplies an earlier capture's HELLO.
//!
//! Cost: O(1) per frame; the Edlén index is recomputed only when ENV or HELLO changes.

use std::collections::VecDeque;

use serde::Serialize;

use crate::counter::{UnwrapI32, UnwrapU32};
use crate::decoder::{DecodedFrame, Decoder, Event};
use crate::edlen;
use crate::frame::{Axis, Env, Frame, Hello, Mark, MarkKind, Material, RawAb, Sample};
use crate::problem::{Counter, HelloError, Problem, ProblemKind, StreamPos};
use crate::quadrature::{AbState, QuadratureDecoder};
use crate::rotary::{RotaryRow, RotaryScaling, mark_feed_deg_s, mark_target_deg};
use crate::stats::DecoderStats;

/// One row of the session table (`docs/session-table.md`); field names are the
/// column names, `None` is an empty field.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionRow {
    /// Run number from 1; 0 outside any run.
    pub run: u32,
    /// The device's (unwrapped) sample index.
    pub sample: i64,
    /// Seconds since the first timestamped frame of the capture.
    pub t_s: f64,
    /// The axis the laser measures along.
    pub axis: Axis,
    /// +1 / −1 inside a run, 0 outside.
    pub direction: i8,
    /// Commanded feed of the latest MARK, mm/s; empty before the first MARK.
    pub feed_mm_s: Option<f64>,
    /// Target index while dwelling (between MARK kinds 3 and 4), else −1.
    pub target: i32,
    /// Machine x, mm (the scale reading when measuring X).
    pub x_mm: Option<f64>,
    /// Machine y, mm.
    pub y_mm: Option<f64>,
    /// Machine z, mm.
    pub z_mm: Option<f64>,
    /// Scale reading along the measured axis, mm.
    pub scale_mm: f64,
    /// Interferometer length in air, mm.
    pub laser_mm: f64,
    /// (scale_mm − laser_mm) · 1000, µm.
    pub error_um: f64,
    /// Air temperature, °C (latest ENV).
    pub air_temp_c: Option<f64>,
    /// Air pressure, hPa (latest ENV).
    pub air_pressure_hpa: Option<f64>,
    /// Relative humidity, % (latest ENV).
    pub air_rh_pct: Option<f64>,
    /// MATERIAL sensor 0, °C.
    pub scale_temp_c: Option<f64>,
    /// MATERIAL sensor 1, °C.
    pub part_temp_c: Option<f64>,
    /// SAMPLE flags.
    pub flags: u8,
}

impl SessionRow {
    /// The session-table columns, in this struct's field order.
    pub const COLUMNS: [&'static str; 19] = [
        "run",
        "sample",
        "t_s",
        "axis",
        "direction",
        "feed_mm_s",
        "target",
        "x_mm",
        "y_mm",
        "z_mm",
        "scale_mm",
        "laser_mm",
        "error_um",
        "air_temp_c",
        "air_pressure_hpa",
        "air_rh_pct",
        "scale_temp_c",
        "part_temp_c",
        "flags",
    ];
}

/// The physical range of a temperature sensor, milli-°C (−50 … 100 °C, the range of
/// errmap's readers: `errmap::base::limits`).
const TEMP_MC: (i32, i32) = (-50_000, 100_000);

/// The physical range of an air pressure, Pa (300 … 1 300 hPa).
const PRESSURE_PA: (u32, u32) = (30_000, 130_000);

fn plausible_temp_mc(t: i32) -> bool {
    (TEMP_MC.0..=TEMP_MC.1).contains(&t)
}

/// Session-layer settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SessionConfig {
    /// Largest counter change per sample interval (index difference) that is believed to
    /// be motion, counts. Larger jumps are applied as read but reported as
    /// [`ProblemKind::CounterJump`]. Default 2^24 (1.68 m at 0.1 µm per count, 1.33 m of
    /// a HeNe laser at λ/8): far beyond any CMM move between two samples, far below the
    /// 2^31 unwrap limit. Range: 1 ..= 2^31.
    pub max_counts_per_sample: i64,
    /// Most rows held back while waiting for the first usable HELLO or the first clean
    /// SAMPLE. Default 2^20 (about 17 min at 1 kHz, ~150 MB). Past it, the first held
    /// SAMPLE becomes the origin ([`ProblemKind::NoCleanSample`]), or, without a HELLO,
    /// the oldest held row is dropped ([`ProblemKind::NoHello`]).
    pub max_pending_rows: usize,
}

impl Default for SessionConfig {
    fn default() -> Self {
        SessionConfig {
            max_counts_per_sample: 1 << 24,
            max_pending_rows: 1 << 20,
        }
    }
}

/// Counter scaling from a usable HELLO.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling {
    /// Measured axis.
    pub axis: Axis,
    /// Scale count resolution, pm per count.
    pub count_resolution_pm: u32,
    /// Laser vacuum wavelength, fm.
    pub laser_wavelength_fm: u32,
    /// F · k: laser counts per vacuum wavelength.
    pub counts_per_wavelength: u32,
}

impl Scaling {
    /// Validate a HELLO: the axis must be 0..=2, F, k and λ non-zero.
    pub fn from_hello(h: &Hello) -> Result<Self, HelloError> {
        let axis = h.axis().ok_or(HelloError::BadAxis(h.axis_code))?;
        if h.optical_fold == 0 || h.edges_per_fringe == 0 {
            return Err(HelloError::ZeroDivisor {
                fold: h.optical_fold,
                edges: h.edges_per_fringe,
            });
        }
        if h.laser_wavelength_fm == 0 {
            return Err(HelloError::ZeroWavelength);
        }
        Ok(Scaling {
            axis,
            count_resolution_pm: h.count_resolution_pm,
            laser_wavelength_fm: h.laser_wavelength_fm,
            counts_per_wavelength: u32::from(h.optical_fold) * u32::from(h.edges_per_fringe),
        })
    }

    /// Vacuum wavelength, µm.
    pub fn lambda_vac_um(&self) -> f64 {
        f64::from(self.laser_wavelength_fm) / 1e9
    }

    /// Scale displacement of `counts`, mm.
    pub fn scale_mm(&self, counts: i64) -> f64 {
        counts as f64 * f64::from(self.count_resolution_pm) / 1e9
    }

    /// Laser displacement in air of `counts`, mm: counts · λ_vac / (F · k · n_air).
    pub fn laser_mm(&self, counts: i64, n_air: f64) -> f64 {
        counts as f64 * f64::from(self.laser_wavelength_fm)
            / (f64::from(self.counts_per_wavelength) * n_air)
            / 1e12
    }
}

/// Refractive index of air for an ENV frame at vacuum wavelength `lambda_vac_um`.
pub fn n_air(env: &Env, lambda_vac_um: f64) -> f64 {
    edlen::refractive_index(
        lambda_vac_um,
        f64::from(env.air_temp_mc) / 1000.0,
        f64::from(env.pressure_pa),
        f64::from(env.rh_permille) / 10.0,
    )
}

/// What the session layer produces.
#[derive(Debug, Clone, PartialEq)]
pub enum SessionEvent {
    /// A session-table row.
    Row(SessionRow),
    /// A rotary session-table row (a HELLO with axis code 3, 4 or 5: [`crate::rotary`]).
    Rotary(RotaryRow),
    /// A problem (from the decoder or the session layer).
    Problem(Problem),
    /// A HELLO frame arrived.
    Hello(Hello),
    /// A device log line.
    Text {
        /// Where.
        pos: StreamPos,
        /// The line.
        text: String,
    },
}

impl SessionEvent {
    /// The run of a row (linear or rotary); `None` for the other events.
    pub fn row_run(&self) -> Option<u32> {
        match self {
            SessionEvent::Row(r) => Some(r.run),
            SessionEvent::Rotary(r) => Some(r.run),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct MarkState {
    /// Inside a run (after kind 1, before kind 2).
    in_run: bool,
    /// The latest MARK, if any.
    latest: Option<Mark>,
    /// Direction of the latest MARK, as a sign.
    direction: i8,
    /// Target index while dwelling, else −1.
    target: i32,
    /// Runs closed by a run-end MARK so far.
    runs_ended: u32,
}

/// A SAMPLE waiting for its scaling (HELLO) and origin.
#[derive(Debug, Clone, Copy)]
struct PendingRow {
    pos: StreamPos,
    run: u32,
    sample: i64,
    t_s: f64,
    direction: i8,
    feed_um_s: Option<u32>,
    lines_um: Option<(i32, i32)>,
    target: i32,
    scale: i64,
    laser: i64,
    env: Option<Env>,
    material_mc: Option<(i32, Option<i32>)>,
    flags: u8,
}

/// Frames → session rows. See the module docs.
#[derive(Debug, Clone)]
pub struct SessionBuilder {
    config: SessionConfig,
    stats: DecoderStats,
    first_hello: Option<Hello>,
    hello_in_force: Option<Hello>,
    scaling: Option<Scaling>,
    /// The rotary scaling in force (a rotary HELLO); `scaling` is then `None`.
    rotary: Option<RotaryScaling>,
    t0_us: Option<u64>,
    last_t_us: Option<u64>,
    marks: MarkState,
    env: Option<Env>,
    material_mc: Option<(i32, Option<i32>)>,
    scale: UnwrapI32,
    laser: UnwrapI32,
    index: UnwrapU32,
    origin: Option<(i64, i64)>,
    pending: VecDeque<PendingRow>,
    quad_scale: QuadratureDecoder,
    quad_laser: QuadratureDecoder,
    /// (λ fm, air mc, Pa, ‰) → n_air.
    n_cache: Option<((u32, i32, u32, u16), f64)>,
}

impl Default for SessionBuilder {
    fn default() -> Self {
        Self::new(SessionConfig::default())
    }
}

impl SessionBuilder {
    /// A builder at the start of a capture.
    pub fn new(config: SessionConfig) -> Self {
        SessionBuilder {
            config,
            stats: DecoderStats::default(),
            first_hello: None,
            hello_in_force: None,
            scaling: None,
            rotary: None,
            t0_us: None,
            last_t_us: None,
            marks: MarkState {
                target: -1,
                ..MarkState::default()
            },
            env: None,
            material_mc: None,
            scale: UnwrapI32::new(),
            laser: UnwrapI32::new(),
            index: UnwrapU32::new(),
            origin: None,
            pending: VecDeque::new(),
            quad_scale: QuadratureDecoder::new(),
            quad_laser: QuadratureDecoder::new(),
            n_cache: None,
        }
    }

    /// Session-layer statistics (`counter_wraps`, `flagged_samples`, `raw_ab`, `rows` and
    /// the session problems; the link-layer fields stay 0 here).
    pub fn stats(&self) -> &DecoderStats {
        &self.stats
    }

    /// Puts a device description in force before any frame: the HELLO of an earlier
    /// capture of the same device, for a stream whose own HELLO is missing or damaged.
    /// A usable HELLO in the stream still takes over (a different one is reported as
    /// [`ProblemKind::HelloChanged`]). Refuses a HELLO that gives no scaling.
    pub fn preset_hello(&mut self, h: Hello) -> Result<(), HelloError> {
        self.set_scaling(&h)?;
        self.first_hello = Some(h);
        self.hello_in_force = Some(h);
        Ok(())
    }

    /// Puts the HELLO's scaling, linear or rotary, in force.
    fn set_scaling(&mut self, h: &Hello) -> Result<(), HelloError> {
        if let Some(r) = RotaryScaling::from_hello(h) {
            self.rotary = Some(r?);
            self.scaling = None;
        } else {
            self.scaling = Some(Scaling::from_hello(h)?);
            self.rotary = None;
        }
        Ok(())
    }

    /// Whether a usable HELLO (linear or rotary) is in force.
    pub fn converts(&self) -> bool {
        self.scaling.is_some() || self.rotary.is_some()
    }

    /// The rotary scaling in force.
    pub fn rotary_scaling(&self) -> Option<&RotaryScaling> {
        self.rotary.as_ref()
    }

    /// The first usable HELLO (or, if none was usable, the first HELLO seen).
    pub fn hello(&self) -> Option<&Hello> {
        self.first_hello.as_ref()
    }

    /// The linear scaling in force.
    pub fn scaling(&self) -> Option<&Scaling> {
        self.scaling.as_ref()
    }

    /// Whether a run is open: a run-start MARK arrived and its run-end MARK has not.
    pub fn run_open(&self) -> bool {
        self.marks.in_run
    }

    /// How many runs a run-end MARK has closed so far.
    pub fn runs_ended(&self) -> u32 {
        self.marks.runs_ended
    }

    /// Rows held back (waiting for a HELLO or a clean SAMPLE).
    pub fn pending_rows(&self) -> usize {
        self.pending.len()
    }

    /// Handle one decoded frame.
    pub fn handle<F: FnMut(SessionEvent)>(&mut self, df: DecodedFrame, sink: &mut F) {
        if df.lost_before > 0 {
            // A seq gap may have swallowed RAW_AB states: restart the quadrature.
            self.quad_scale.reset();
            self.quad_laser.reset();
        }
        if let Some(t) = df.frame.t_us() {
            self.t0_us.get_or_insert(t);
            self.last_t_us = Some(t);
        }
        let pos = StreamPos {
            offset: df.offset,
            seq: Some(df.seq),
            t_us: self.last_t_us,
        };
        match df.frame {
            Frame::Hello(h) => self.on_hello(h, pos, sink),
            Frame::Sample(s) => self.on_sample(&s, pos, sink),
            Frame::Env(e) => self.on_env(e, pos, sink),
            Frame::Material(m) => self.on_material(&m, pos, sink),
            Frame::Mark(m) => self.on_mark(&m, pos, sink),
            Frame::RawAb(r) => self.on_raw_ab(&r, pos, sink),
            Frame::Text(t) => sink(SessionEvent::Text { pos, text: t.text }),
        }
    }

    /// End of capture: write the rows still held back (with the fallbacks of
    /// [`SessionConfig::max_pending_rows`]).
    pub fn finish<F: FnMut(SessionEvent)>(&mut self, sink: &mut F) {
        if let Some(first) = self.pending.front().copied() {
            if self.origin.is_none() {
                self.origin = Some((first.scale, first.laser));
                self.problem(first.pos, ProblemKind::NoCleanSample, sink);
            }
            if !self.converts() {
                let rows_dropped = self.pending.len() as u64;
                self.pending.clear();
                self.stats.unconverted_samples += rows_dropped;
                self.problem(first.pos, ProblemKind::NoHello { rows_dropped }, sink);
            }
        }
        self.flush(sink);
    }

    fn problem<F: FnMut(SessionEvent)>(&mut self, pos: StreamPos, kind: ProblemKind, sink: &mut F) {
        let p = Problem { pos, kind };
        self.stats.problems.record(&p);
        sink(SessionEvent::Problem(p));
    }

    fn on_hello<F: FnMut(SessionEvent)>(&mut self, h: Hello, pos: StreamPos, sink: &mut F) {
        if h.protocol_version != 1 {
            self.problem(
                pos,
                ProblemKind::UnsupportedVersion {
                    version: h.protocol_version,
                },
                sink,
            );
        }
        match self.set_scaling(&h) {
            Ok(()) => {
                if let Some(prev) = &self.hello_in_force {
                    if *prev != h {
                        self.problem(pos, ProblemKind::HelloChanged, sink);
                    }
                } else {
                    // The first usable HELLO is the session's device description.
                    self.first_hello = Some(h);
                }
                self.hello_in_force = Some(h);
            }
            Err(error) => {
                if self.first_hello.is_none() {
                    self.first_hello = Some(h);
                }
                self.problem(pos, ProblemKind::BadHello { error }, sink);
            }
        }
        sink(SessionEvent::Hello(h));
        self.flush(sink);
    }

    fn on_env<F: FnMut(SessionEvent)>(&mut self, e: Env, pos: StreamPos, sink: &mut F) {
        if plausible_temp_mc(e.air_temp_mc)
            && (PRESSURE_PA.0..=PRESSURE_PA.1).contains(&e.pressure_pa)
            && e.rh_permille <= 1000
        {
            self.env = Some(e);
        } else {
            // A broken sensor: its n_air would make every laser length wrong.
            self.env = None;
            self.problem(
                pos,
                ProblemKind::ImplausibleEnv {
                    air_temp_mc: e.air_temp_mc,
                    pressure_pa: e.pressure_pa,
                    rh_permille: e.rh_permille,
                },
                sink,
            );
        }
    }

    fn on_material<F: FnMut(SessionEvent)>(&mut self, m: &Material, pos: StreamPos, sink: &mut F) {
        // Sensors 0 (scale) and 1 (part) are the ones the session table holds.
        if let Some((sensor, &t)) = m
            .temps_mc
            .iter()
            .take(2)
            .enumerate()
            .find(|(_, t)| !plausible_temp_mc(**t))
        {
            self.material_mc = None;
            self.problem(
                pos,
                ProblemKind::ImplausibleMaterial {
                    sensor: sensor as u8,
                    temp_mc: t,
                },
                sink,
            );
            return;
        }
        if let Some(&scale) = m.temps_mc.first() {
            self.material_mc = Some((scale, m.temps_mc.get(1).copied()));
        }
    }

    fn on_mark<F: FnMut(SessionEvent)>(&mut self, m: &Mark, pos: StreamPos, sink: &mut F) {
        let kind = m.kind();
        if kind.is_none() || m.direction.abs() != 1 {
            self.problem(
                pos,
                ProblemKind::BadMark {
                    kind: m.kind_code,
                    direction: m.direction,
                },
                sink,
            );
        }
        let Some(kind) = kind else {
            return;
        };
        let st = &mut self.marks;
        st.latest = Some(*m);
        st.direction = m.direction.signum();
        match kind {
            MarkKind::RunStart => st.in_run = true,
            MarkKind::RunEnd => {
                if st.in_run {
                    st.runs_ended = st.runs_ended.saturating_add(1);
                }
                st.in_run = false;
            }
            MarkKind::TargetReached => st.target = i32::from(m.target),
            MarkKind::TargetLeft => st.target = -1,
            MarkKind::Reversal => {}
        }
    }

    fn on_raw_ab<F: FnMut(SessionEvent)>(&mut self, r: &RawAb, pos: StreamPos, sink: &mut F) {
        for (i, &byte) in r.states.iter().enumerate() {
            let lines = [
                (Counter::Scale, AbState::from_bits(byte & 3)),
                (Counter::Laser, AbState::from_bits((byte >> 2) & 3)),
            ];
            for (counter, state) in lines {
                let (quad, counts, illegal) = match counter {
                    Counter::Scale => (
                        &mut self.quad_scale,
                        &mut self.stats.raw_ab.scale_counts,
                        &mut self.stats.raw_ab.scale_illegal,
                    ),
                    Counter::Laser => (
                        &mut self.quad_laser,
                        &mut self.stats.raw_ab.laser_counts,
                        &mut self.stats.raw_ab.laser_illegal,
                    ),
                };
                match quad.step(state) {
                    Ok(step) => *counts += i64::from(step),
                    Err(e) => {
                        *illegal += 1;
                        let t_us = r.t_us.saturating_add(i as u64 * u64::from(r.period_us));
                        let at = StreamPos {
                            t_us: Some(t_us),
                            ..pos
                        };
                        self.problem(
                            at,
                            ProblemKind::IllegalTransition {
                                counter,
                                from: e.from.bits(),
                                to: e.to.bits(),
                            },
                            sink,
                        );
                    }
                }
            }
        }
    }

    fn on_sample<F: FnMut(SessionEvent)>(&mut self, s: &Sample, pos: StreamPos, sink: &mut F) {
        if !s.flags.is_clean() {
            self.stats.flagged_samples += 1;
            self.problem(pos, ProblemKind::FlaggedSample { flags: s.flags.0 }, sink);
        }
        let first = self.index.value().is_none();
        let index = self.index.push(s.index);
        if !first && index.delta <= 0 {
            self.problem(
                pos,
                ProblemKind::SampleIndexNotIncreasing {
                    previous: index.value - index.delta,
                    index: index.value,
                },
                sink,
            );
        }
        let intervals = index.delta.max(1);
        let scale = self.scale.push(s.scale_count);
        let laser = self.laser.push(s.laser_count);
        for (counter, u) in [(Counter::Scale, scale), (Counter::Laser, laser)] {
            if u.wrapped {
                match counter {
                    Counter::Scale => self.stats.counter_wraps.scale += 1,
                    Counter::Laser => self.stats.counter_wraps.laser += 1,
                }
                self.problem(pos, ProblemKind::CounterWrap { counter }, sink);
            }
            let limit = self.config.max_counts_per_sample.saturating_mul(intervals);
            if u.delta.abs() > limit {
                self.problem(
                    pos,
                    ProblemKind::CounterJump {
                        counter,
                        counts: u.delta,
                        intervals,
                    },
                    sink,
                );
            }
        }
        if self.origin.is_none() && s.flags.is_clean() {
            self.origin = Some((scale.value, laser.value));
        }
        let t_s = match self.t0_us {
            Some(t0) => (i128::from(s.t_us) - i128::from(t0)) as f64 / 1e6,
            None => 0.0,
        };
        let marks = &self.marks;
        let (run, direction) = match (marks.in_run, marks.latest) {
            (true, Some(m)) => (u32::from(m.run), marks.direction),
            _ => (0, 0),
        };
        let row = PendingRow {
            pos,
            run,
            sample: index.value,
            t_s,
            direction,
            feed_um_s: marks.latest.map(|m| m.feed_um_s),
            lines_um: marks.latest.map(|m| (m.line_first_um, m.line_second_um)),
            target: marks.target,
            scale: scale.value,
            laser: laser.value,
            env: self.env,
            material_mc: self.material_mc,
            flags: s.flags.0,
        };
        if let (true, true, Some(origin)) = (self.pending.is_empty(), self.converts(), self.origin)
        {
            // Fast path: nothing held back, write the row at once.
            let event = self.emit(&row, origin);
            self.stats.rows += 1;
            sink(event);
            return;
        }
        self.pending.push_back(row);
        self.flush(sink);
        if self.pending.len() > self.config.max_pending_rows {
            if let Some(first) = self.pending.front().copied() {
                if self.origin.is_none() {
                    self.origin = Some((first.scale, first.laser));
                    self.problem(first.pos, ProblemKind::NoCleanSample, sink);
                    self.flush(sink);
                } else if !self.converts() {
                    self.pending.pop_front();
                    self.stats.unconverted_samples += 1;
                    self.problem(first.pos, ProblemKind::NoHello { rows_dropped: 1 }, sink);
                }
            }
        }
    }

    /// Write every held row if scaling and origin are known.
    fn flush<F: FnMut(SessionEvent)>(&mut self, sink: &mut F) {
        let (true, Some(origin)) = (self.converts(), self.origin) else {
            return;
        };
        while let Some(p) = self.pending.pop_front() {
            let event = self.emit(&p, origin);
            self.stats.rows += 1;
            sink(event);
        }
    }

    /// The row of a held SAMPLE under the scaling in force (one is).
    fn emit(&mut self, p: &PendingRow, origin: (i64, i64)) -> SessionEvent {
        match (self.rotary, self.scaling) {
            (Some(r), _) => SessionEvent::Rotary(rotary_row(p, &r)),
            (None, Some(s)) => SessionEvent::Row(self.finalize(p, &s, origin)),
            (None, None) => unreachable!("emit is called only when a scaling is in force"),
        }
    }

    fn n_air_for(&mut self, env: &Env, scaling: &Scaling) -> f64 {
        let key = (
            scaling.laser_wavelength_fm,
            env.air_temp_mc,
            env.pressure_pa,
            env.rh_permille,
        );
        match self.n_cache {
            Some((k, n)) if k == key => n,
            _ => {
                let n = n_air(env, scaling.lambda_vac_um());
                self.n_cache = Some((key, n));
                n
            }
        }
    }

    fn finalize(&mut self, p: &PendingRow, scaling: &Scaling, origin: (i64, i64)) -> SessionRow {
        let n = match &p.env {
            Some(env) => self.n_air_for(env, scaling),
            None => 1.0,
        };
        let scale_mm = scaling.scale_mm(p.scale - origin.0);
        let laser_mm = scaling.laser_mm(p.laser - origin.1, n);
        let lines = p
            .lines_um
            .map(|(a, b)| (f64::from(a) / 1000.0, f64::from(b) / 1000.0));
        let first = lines.map(|l| l.0);
        let second = lines.map(|l| l.1);
        let (x_mm, y_mm, z_mm) = match scaling.axis {
            Axis::X => (Some(scale_mm), first, second),
            Axis::Y => (first, Some(scale_mm), second),
            Axis::Z => (first, second, Some(scale_mm)),
        };
        SessionRow {
            run: p.run,
            sample: p.sample,
            t_s: p.t_s,
            axis: scaling.axis,
            direction: p.direction,
            feed_mm_s: p.feed_um_s.map(|f| f64::from(f) / 1000.0),
            target: p.target,
            x_mm,
            y_mm,
            z_mm,
            scale_mm,
            laser_mm,
            error_um: (scale_mm - laser_mm) * 1000.0,
            air_temp_c: p.env.map(|e| f64::from(e.air_temp_mc) / 1000.0),
            air_pressure_hpa: p.env.map(|e| f64::from(e.pressure_pa) / 100.0),
            air_rh_pct: p.env.map(|e| f64::from(e.rh_permille) / 10.0),
            scale_temp_c: p.material_mc.map(|m| f64::from(m.0) / 1000.0),
            part_temp_c: p
                .material_mc
                .and_then(|m| m.1)
                .map(|t| f64::from(t) / 1000.0),
            flags: p.flags,
        }
    }
}

/// A rotary row: the counters from zero (a rotary encoder counts from its reference
/// mark), the MARK's fields in their rotary reading ([`crate::rotary`]).
fn rotary_row(p: &PendingRow, r: &RotaryScaling) -> RotaryRow {
    let indicated_deg = r.indicated_deg(p.scale);
    let reference_deg = r.reference_deg(p.laser);
    RotaryRow {
        run: p.run,
        sample: p.sample,
        t_s: p.t_s,
        axis: r.axis,
        direction: p.direction,
        target: p.target,
        target_deg: p
            .lines_um
            .filter(|_| p.target >= 0)
            .map(|l| mark_target_deg(l.0)),
        indicated_deg,
        reference_deg,
        error_arcsec: (indicated_deg - reference_deg) * 3600.0,
        feed_deg_s: p.feed_um_s.map(mark_feed_deg_s),
        air_temp_c: p.env.map(|e| f64::from(e.air_temp_mc) / 1000.0),
        part_temp_c: p
            .material_mc
            .and_then(|m| m.1)
            .map(|t| f64::from(t) / 1000.0),
        scale_temp_c: p.material_mc.map(|m| f64::from(m.0) / 1000.0),
        flags: p.flags,
    }
}

/// Bytes → session rows: the stream [`Decoder`] and the [`SessionBuilder`] in one.
#[derive(Debug, Clone, Default)]
pub struct SessionDecoder {
    decoder: Decoder,
    builder: SessionBuilder,
}

impl SessionDecoder {
    /// A session decoder with the default [`SessionConfig`].
    pub fn new() -> Self {
        Self::default()
    }

    /// A session decoder with `config`.
    pub fn with_config(config: SessionConfig) -> Self {
        SessionDecoder {
            decoder: Decoder::new(),
            builder: SessionBuilder::new(config),
        }
    }

    /// A session decoder with the default [`SessionConfig`] and `hello` in force from
    /// the start ([`SessionBuilder::preset_hello`]).
    pub fn with_hello(hello: Hello) -> Result<Self, HelloError> {
        let mut d = Self::new();
        d.builder.preset_hello(hello)?;
        Ok(d)
    }

    /// Decode `bytes`, handing rows, problems, HELLOs and TEXT lines to `sink`.
    pub fn push_with<F: FnMut(SessionEvent)>(&mut self, bytes: &[u8], sink: &mut F) {
        let builder = &mut self.builder;
        self.decoder.push_with(bytes, &mut |ev| match ev {
            Event::Frame(f) => builder.handle(f, sink),
            Event::Problem(p) => sink(SessionEvent::Problem(p)),
        });
    }

    /// Decode `bytes`, returning the rows completed (other events are in the statistics).
    pub fn push(&mut self, bytes: &[u8]) -> Vec<SessionRow> {
        // At most one row per SAMPLE frame: reserving that many saves the copies of a
        // growing vector (untouched capacity costs no memory pages).
        let mut rows = Vec::with_capacity(bytes.len() / crate::frame::SAMPLE_FRAME_BYTES + 1);
        self.push_with(bytes, &mut |e| {
            if let SessionEvent::Row(r) = e {
                rows.push(r);
            }
        });
        rows
    }

    /// End of capture: the truncated tail, the skipped run in progress, and the rows still
    /// held back.
    pub fn finish_with<F: FnMut(SessionEvent)>(&mut self, sink: &mut F) {
        let builder = &mut self.builder;
        self.decoder.finish_with(&mut |ev| match ev {
            Event::Frame(f) => builder.handle(f, sink),
            Event::Problem(p) => sink(SessionEvent::Problem(p)),
        });
        self.builder.finish(sink);
    }

    /// [`SessionDecoder::finish_with`], returning the rows.
    pub fn finish(&mut self) -> Vec<SessionRow> {
        let mut rows = Vec::new();
        self.finish_with(&mut |e| {
            if let SessionEvent::Row(r) = e {
                rows.push(r);
            }
        });
        rows
    }

    /// All statistics so far (link and session layers merged).
    pub fn stats(&self) -> DecoderStats {
        self.decoder.stats().merged(self.builder.stats())
    }

    /// The session's HELLO (see [`SessionBuilder::hello`]).
    pub fn hello(&self) -> Option<&Hello> {
        self.builder.hello()
    }

    /// The byte-level decoder.
    pub fn decoder(&self) -> &Decoder {
        &self.decoder
    }

    /// The frame-to-row builder.
    pub fn builder(&self) -> &SessionBuilder {
        &self.builder
    }
}
