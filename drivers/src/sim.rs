//! The simulated acquisition board, sans-IO: a measurement plan and a truth → the frames
//! a real board would send, with their times on the serial line.
//!
//! The board latches the scale and laser counters from a simulated truth and quantises
//! them like real counters: the scale at its count resolution, the laser at
//! λ_vac/(F·k) of optical path (the counts a real interferometer board accumulates for the
//! actual displacement in air). It sends SAMPLE frames on a timer while moving and while
//! dwelling, MARK frames at every run event, ENV and MATERIAL frames once a second, and a
//! HELLO at power-up. Every SAMPLE carries the device's sample index.
//!
//! **Byte budget.** 8N1 carries baud/10 bytes per second. Each frame is queued on the line
//! when it happens; a SAMPLE that finds more than [`Device::fifo_bytes`] already queued is
//! dropped by the board (its index is still consumed, so the host sees a hole) and the next
//! SAMPLE that gets through carries `OVERRUN`. So a plan that samples faster than the line
//! can carry is simulated honestly rather than sent impossibly fast.
//!
//! **Geometry.** The carriage starts at 0 mm (home) on the first line; the first samples
//! are taken there, so both counters' origins (the first clean SAMPLE) are at home, and the
//! decoded error is truth(position) − truth(home on the first line). Each run goes out in
//! the positive direction through the targets and back in the negative one (ISO 230-2),
//! with a MARK at run start, every target reached and left, the reversal and the run end.
//!
//! **Faults** (for tests and demos): garbage bytes between frames, bit flips inside frames,
//! frames lost on the line (a seq gap), a beam-loss window (BEAM_LOW, laser counter
//! frozen), and counters that start near the 32-bit wrap.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::edlen;
use crate::frame::{
    Axis, DeviceId, Env, Frame, Hello, Mark, MarkKind, Material, Sample, SampleFlags, Text,
    encode_into,
};

/// A measurement plan along one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub axis: Axis,
    /// Lines: the two other coordinates, mm (Y, Z when measuring X; X, Z for Y; X, Y for Z).
    pub lines_mm: Vec<[f64; 2]>,
    /// Target positions along the axis, mm, strictly increasing, ≥ 0.
    pub targets_mm: Vec<f64>,
    /// Runs per line, each out (+) and back (−).
    pub runs: u32,
    pub feed_mm_s: f64,
    /// Further feeds, mm/s: run r of a line moves at `[feed_mm_s, extra_feeds_mm_s…]`
    /// cycled by run (empty: every run at `feed_mm_s`). Two feeds separate a latch delay
    /// (∝ feed) from a reversal (independent of it).
    pub extra_feeds_mm_s: Vec<f64>,
    pub dwell_s: f64,
    /// Timer trigger rate while moving and dwelling.
    pub sample_hz: f64,
    /// Time at home before the first run, s.
    pub settle_s: f64,
    /// Acceleration and deceleration of every move (trapezoidal profile), mm/s².
    pub accel_mm_s2: f64,
    /// Seed of the controller's timing (when dwells end relative to the board's timer).
    pub seed: u64,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            axis: Axis::X,
            lines_mm: vec![[0.0, 0.0]],
            targets_mm: (0..=10).map(|i| f64::from(i) * 50.0).collect(),
            runs: 5,
            feed_mm_s: 100.0,
            extra_feeds_mm_s: Vec::new(),
            dwell_s: 0.5,
            sample_hz: 100.0,
            settle_s: 0.2,
            accel_mm_s2: 2000.0,
            seed: 0,
        }
    }
}

/// The board's fixed description (what its HELLO says) and its line. In a machine-model
/// file this is the `[device]` table; every field has the default below.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Device {
    pub device_id: String,
    pub grating_period_nm: u32,
    pub count_resolution_pm: u32,
    pub laser_wavelength_fm: u32,
    pub optical_fold: u8,
    pub edges_per_fringe: u8,
    pub baud: u32,
    /// Bytes the board can queue before it must drop SAMPLEs.
    pub fifo_bytes: usize,
    /// Period of ENV and MATERIAL frames, s.
    pub env_period_s: f64,
    /// Latch-timing jitter, µs: each timer tick latches both counters after a random
    /// interrupt latency, uniform on [0, `latch_jitter_us`), and the SAMPLE carries the
    /// latch's own time. 0 (the default): the board latches on the exact timer lattice.
    /// At most a quarter of the sample period. Not written when 0, so that a model
    /// written before the term existed reads and writes the same.
    #[serde(skip_serializing_if = "is_zero")]
    pub latch_jitter_us: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for Device {
    fn default() -> Self {
        Device {
            device_id: "errmap-sim".into(),
            grating_period_nm: 20_000,
            count_resolution_pm: 100_000,
            laser_wavelength_fm: 632_991_354,
            optical_fold: 2,
            edges_per_fringe: 4,
            baud: 115_200,
            fifo_bytes: 512,
            env_period_s: 1.0,
            latch_jitter_us: 0.0,
        }
    }
}

/// Fault injection (all off by default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Faults {
    /// Probability per frame of a burst of 1–16 garbage bytes before it.
    pub garbage_prob: f64,
    /// Probability per frame of one flipped bit inside it.
    pub bit_flip_prob: f64,
    /// Probability per frame that it is lost on the line (seq gap).
    pub drop_prob: f64,
    /// Beam-loss window [start, end) in session seconds: BEAM_LOW, laser counter frozen.
    pub beam_loss_s: Option<(f64, f64)>,
    /// Start both counters this many counts below the i32 wrap.
    pub counters_near_wrap: Option<i32>,
    pub seed: u64,
}

/// The air and material state the board's sensors report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Environment {
    pub air_temp_c: f64,
    pub air_pressure_hpa: f64,
    pub air_rh_pct: f64,
    pub scale_temp_c: f64,
    pub part_temp_c: f64,
}

impl Default for Environment {
    fn default() -> Self {
        Environment {
            air_temp_c: 20.0,
            air_pressure_hpa: 1013.25,
            air_rh_pct: 50.0,
            scale_temp_c: 20.0,
            part_temp_c: 20.0,
        }
    }
}

/// What the truth is asked at every latch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthQuery {
    /// Session seconds.
    pub t_s: f64,
    /// Machine position (indicated), mm.
    pub pos_mm: [f64; 3],
    pub direction: i8,
    /// Feed while moving, 0 while dwelling or at rest.
    pub feed_mm_s: f64,
    /// Instantaneous speed of the carriage (the feed once accelerated), mm/s.
    pub speed_mm_s: f64,
    pub run: u32,
    pub target: i32,
}

/// The simulated machine: its error (indicated − actual, µm, noise included) and the
/// environment. The physics simulator and the plain error-map truth both implement it.
pub trait Truth {
    fn error_um(&mut self, q: &TruthQuery) -> f64;
    /// The environment the sensors report (and the air the beam travels through, unless
    /// [`Truth::true_air`] differs).
    fn environment(&mut self, _t_s: f64) -> Environment {
        Environment::default()
    }
    /// The air the beam actually travels through (default: what the sensors report).
    fn true_air(&mut self, t_s: f64) -> Environment {
        self.environment(t_s)
    }
}

/// One sample's ground truth, for tests and for matching a recording to its truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    pub index: u32,
    pub t_s: f64,
    pub pos_mm: [f64; 3],
    pub error_um: f64,
    pub run: u32,
    pub direction: i8,
    pub target: i32,
    /// Whether the board sent it (false: dropped for the byte budget).
    pub sent: bool,
}

/// A frame on the line: its bytes and the device time when its last byte has been sent.
#[derive(Debug, Clone, PartialEq)]
pub struct Emitted {
    pub line_time_us: u64,
    pub bytes: Vec<u8>,
}

/// The whole simulated stream.
#[derive(Debug, Clone)]
pub struct SimStream {
    pub hello: Hello,
    pub frames: Vec<Emitted>,
    pub truth: Vec<TruthSample>,
    /// SAMPLEs the board dropped because the line was full.
    pub overruns: usize,
    /// Frames lost on the line by fault injection.
    pub dropped: usize,
    pub duration_s: f64,
}

impl SimStream {
    /// The stream's bytes, concatenated.
    pub fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.frames.iter().map(|f| f.bytes.len()).sum());
        for f in &self.frames {
            out.extend_from_slice(&f.bytes);
        }
        out
    }
}

/// Why a plan cannot be simulated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("plan: {0}")]
    Plan(String),
    #[error("device: {0}")]
    Device(String),
}

enum Step {
    Mark(MarkKind, i8, u32, i32),
    Move(f64, i8),
    Dwell(f64),
    Line(usize),
}

/// The most samples a plan may imply (about 1 GB for the simulated session in memory:
/// frames, truth and rows). [`check_plan`] refuses larger plans before any is generated.
pub const MAX_PLAN_SAMPLES: f64 = 2e6;

/// Checks a plan on its own: finite values in their ranges, and at most
/// [`MAX_PLAN_SAMPLES`] samples. Messages start with the plan key they are about.
///
/// | key | accepted |
/// |---|---|
/// | `targets_mm`, `lines_mm` | finite, within ±10⁶ mm; targets ≥ 0, strictly increasing |
/// | `feed_mm_s`, `extra_feeds_mm_s` | 10⁻⁶ … 10⁵ mm/s |
/// | `accel_mm_s2` | 10⁻³ … 10⁷ mm/s² |
/// | `sample_hz` | 10⁻³ … 10⁶ Hz |
/// | `dwell_s`, `settle_s` | 0 … 10⁹ s |
/// | `runs` | ≥ 1 |
pub fn check_plan(plan: &Plan) -> Result<(), SimError> {
    let bad = |m: String| Err(SimError::Plan(m));
    let within = |key: &str, v: f64, lo: f64, hi: f64, unit: &str| {
        if v.is_finite() && lo <= v && v <= hi {
            Ok(())
        } else {
            Err(SimError::Plan(format!(
                "{key} = {v}: must be finite, within {lo} … {hi} {unit}"
            )))
        }
    };
    if plan.targets_mm.is_empty() {
        return bad("targets_mm: no targets".into());
    }
    for (k, &t) in plan.targets_mm.iter().enumerate() {
        within(&format!("targets_mm[{k}]"), t, 0.0, 1e6, "mm")?;
    }
    if plan.targets_mm.windows(2).any(|w| w[1] <= w[0]) {
        return bad("targets_mm: targets must be ≥ 0 and strictly increasing".into());
    }
    if plan.lines_mm.is_empty() {
        return bad("lines_mm: no lines".into());
    }
    for (k, v) in plan.lines_mm.iter().flatten().enumerate() {
        within(
            &format!("lines_mm[{}][{}]", k / 2, k % 2),
            *v,
            -1e6,
            1e6,
            "mm",
        )?;
    }
    within("feed_mm_s", plan.feed_mm_s, 1e-6, 1e5, "mm/s")?;
    for (k, &f) in plan.extra_feeds_mm_s.iter().enumerate() {
        within(&format!("extra_feeds_mm_s[{k}]"), f, 1e-6, 1e5, "mm/s")?;
    }
    within("accel_mm_s2", plan.accel_mm_s2, 1e-3, 1e7, "mm/s²")?;
    within("sample_hz", plan.sample_hz, 1e-3, 1e6, "Hz")?;
    within("dwell_s", plan.dwell_s, 0.0, 1e9, "s")?;
    within("settle_s", plan.settle_s, 0.0, 1e9, "s")?;
    if plan.runs < 1 {
        return bad("runs = 0: at least one run".into());
    }
    let duration = estimated_duration_s(plan);
    let samples = duration * plan.sample_hz;
    let dwells =
        plan.lines_mm.len() as f64 * f64::from(plan.runs) * 2.0 * plan.targets_mm.len() as f64;
    if samples.max(dwells) > MAX_PLAN_SAMPLES {
        return bad(format!(
            "the plan implies about {:.2e} samples ({duration:.3e} s at sample_hz = {}, {dwells:.2e} dwells), \
             more than the simulator's limit of {MAX_PLAN_SAMPLES:.0e}; shorten dwell_s or settle_s, raise \
             feed_mm_s or accel_mm_s2, or use fewer runs, targets_mm or lines_mm, or a lower sample_hz",
            samples.max(dwells),
            plan.sample_hz
        ));
    }
    Ok(())
}

/// The plan's duration in seconds, without generating it: settles, dwells and the moves
/// between targets out and back (a lower bound of what [`simulate`] takes; the moves
/// from home and between lines are left out).
fn estimated_duration_s(plan: &Plan) -> f64 {
    let lines = plan.lines_mm.len() as f64;
    let n_feeds = 1 + plan.extra_feeds_mm_s.len();
    let pass = |feed: f64| -> f64 {
        let moves: f64 = plan
            .targets_mm
            .windows(2)
            .map(|w| Trapezoid::new(w[1] - w[0], feed, plan.accel_mm_s2).duration())
            .sum();
        2.0 * (moves + plan.targets_mm.len() as f64 * plan.dwell_s)
    };
    let mut total = plan.settle_s * (lines + 1.0);
    for k in 0..n_feeds.min(plan.runs as usize) {
        // Runs r = k+1, k+1+n, … move at feed k.
        let runs_at_k = (plan.runs as usize - k).div_ceil(n_feeds) as f64;
        total += lines * runs_at_k * pass(feed_of(plan, k as u32 + 1));
    }
    total
}

fn validate(plan: &Plan, device: &Device) -> Result<(), SimError> {
    check_plan(plan)?;
    if device.baud < 300 || device.count_resolution_pm == 0 || device.laser_wavelength_fm == 0 {
        return Err(SimError::Device(
            "baud ≥ 300, non-zero resolution and wavelength".into(),
        ));
    }
    if device.optical_fold == 0 || device.edges_per_fringe == 0 {
        return Err(SimError::Device(
            "fold and edges per fringe must be non-zero".into(),
        ));
    }
    // A laser between 100 nm and 2 µm (HeNe 633 nm), and a scale count of at most 1 mm.
    if !(100_000_000..=2_000_000_000).contains(&device.laser_wavelength_fm) {
        return Err(SimError::Device(format!(
            "laser_wavelength_fm = {} is not a laser's wavelength (100 nm … 2 µm)",
            device.laser_wavelength_fm
        )));
    }
    let quarter_us = 0.25e6 / plan.sample_hz;
    if !(device.latch_jitter_us.is_finite()
        && device.latch_jitter_us >= 0.0
        && device.latch_jitter_us <= quarter_us)
    {
        return Err(SimError::Device(format!(
            "latch_jitter_us = {}: must be within 0 … {quarter_us} µs (a quarter of the sample period)",
            device.latch_jitter_us
        )));
    }
    if device.count_resolution_pm > 1_000_000_000 {
        return Err(SimError::Device(format!(
            "count_resolution_pm = {} is more than 1 mm per count",
            device.count_resolution_pm
        )));
    }
    // The decoder unwraps the 32-bit counters assuming fewer than 2^31 counts between two
    // samples, and reports more than 2^24 as a jump: the fastest move between two samples
    // must stay below 2^24 counts of either counter.
    let fastest = plan
        .extra_feeds_mm_s
        .iter()
        .fold(plan.feed_mm_s, |a, &b| a.max(b));
    let step_mm = fastest / plan.sample_hz;
    let scale_count_mm = f64::from(device.count_resolution_pm) * 1e-9;
    let laser_count_mm = f64::from(device.laser_wavelength_fm) * 1e-12
        / (f64::from(device.optical_fold) * f64::from(device.edges_per_fringe));
    let counts = step_mm / scale_count_mm.min(laser_count_mm);
    if counts > f64::from(1u32 << 24) {
        return Err(SimError::Device(format!(
            "a move of {step_mm} mm between two samples (feed {fastest} mm/s at sample_hz {}) is \
             {counts:.3e} counts of count_resolution_pm = {} or laser_wavelength_fm = {}, more than \
             the 2^24 per sample the decoder takes for motion; raise sample_hz or coarsen the counts",
            plan.sample_hz, device.count_resolution_pm, device.laser_wavelength_fm
        )));
    }
    Ok(())
}

fn steps(plan: &Plan) -> Vec<Step> {
    let mut s = vec![Step::Dwell(plan.settle_s)];
    for line in 0..plan.lines_mm.len() {
        if line > 0 {
            s.push(Step::Move(0.0, -1));
            s.push(Step::Line(line));
            s.push(Step::Dwell(plan.settle_s));
        }
        for run in 1..=plan.runs {
            s.push(Step::Mark(MarkKind::RunStart, 1, run, 0));
            let n = plan.targets_mm.len();
            for (j, &t) in plan.targets_mm.iter().enumerate() {
                s.push(Step::Move(t, 1));
                s.push(Step::Mark(MarkKind::TargetReached, 1, run, j as i32));
                s.push(Step::Dwell(plan.dwell_s));
                s.push(Step::Mark(MarkKind::TargetLeft, 1, run, j as i32));
            }
            s.push(Step::Mark(MarkKind::Reversal, -1, run, (n - 1) as i32));
            for (j, &t) in plan.targets_mm.iter().enumerate().rev() {
                s.push(Step::Move(t, -1));
                s.push(Step::Mark(MarkKind::TargetReached, -1, run, j as i32));
                s.push(Step::Dwell(plan.dwell_s));
                s.push(Step::Mark(MarkKind::TargetLeft, -1, run, j as i32));
            }
            s.push(Step::Mark(MarkKind::RunEnd, -1, run, 0));
        }
    }
    s.push(Step::Move(0.0, -1));
    s.push(Step::Dwell(plan.settle_s));
    s
}

struct Board<'a> {
    plan: &'a Plan,
    device: &'a Device,
    faults: &'a Faults,
    rng: StdRng,
    seq: u16,
    line_free_us: f64,
    frames: Vec<Emitted>,
    dropped: usize,
    us_per_byte: f64,
}

impl Board<'_> {
    /// Queues a frame on the line; `droppable` frames (SAMPLEs) are dropped when the FIFO
    /// is full. Returns whether it was queued.
    fn send(&mut self, frame: &Frame, t_us: f64, droppable: bool) -> bool {
        let backlog = (self.line_free_us - t_us).max(0.0) / self.us_per_byte;
        if droppable && backlog > self.device.fifo_bytes as f64 {
            return false;
        }
        let mut bytes = Vec::with_capacity(64);
        if self.faults.garbage_prob > 0.0 && self.rng.random_bool(self.faults.garbage_prob.min(1.0))
        {
            for _ in 0..self.rng.random_range(1..=16) {
                bytes.push(self.rng.random());
            }
        }
        let start = bytes.len();
        if encode_into(frame, self.seq, &mut bytes).is_err() {
            return false;
        }
        self.seq = self.seq.wrapping_add(1);
        if self.faults.bit_flip_prob > 0.0
            && self.rng.random_bool(self.faults.bit_flip_prob.min(1.0))
        {
            let i = self.rng.random_range(start..bytes.len());
            bytes[i] ^= 1 << self.rng.random_range(0..8);
        }
        self.line_free_us = self.line_free_us.max(t_us) + bytes.len() as f64 * self.us_per_byte;
        if self.faults.drop_prob > 0.0 && self.rng.random_bool(self.faults.drop_prob.min(1.0)) {
            self.dropped += 1;
            return true;
        }
        self.frames.push(Emitted {
            line_time_us: self.line_free_us.round() as u64,
            bytes,
        });
        true
    }

    fn line_um(&self, line: usize) -> (i32, i32) {
        let l = self.plan.lines_mm[line];
        (
            (l[0] * 1000.0).round() as i32,
            (l[1] * 1000.0).round() as i32,
        )
    }
}

/// The feed of run `run` (1-based; run 0, between runs, moves at the first feed).
fn feed_of(plan: &Plan, run: u32) -> f64 {
    let n = 1 + plan.extra_feeds_mm_s.len();
    match run.saturating_sub(1) as usize % n {
        0 => plan.feed_mm_s,
        k => plan.extra_feeds_mm_s[k - 1],
    }
}

/// A trapezoidal (or, for short moves, triangular) velocity profile over a distance.
#[derive(Debug, Clone, Copy)]
struct Trapezoid {
    dist: f64,
    accel: f64,
    peak: f64,
    t_acc: f64,
    total: f64,
}

impl Trapezoid {
    fn new(dist: f64, feed: f64, accel: f64) -> Self {
        let t_full = feed / accel;
        if accel * t_full * t_full >= dist {
            let t_acc = (dist / accel).sqrt();
            Trapezoid {
                dist,
                accel,
                peak: accel * t_acc,
                t_acc,
                total: 2.0 * t_acc,
            }
        } else {
            Trapezoid {
                dist,
                accel,
                peak: feed,
                t_acc: t_full,
                total: 2.0 * t_full + (dist - accel * t_full * t_full) / feed,
            }
        }
    }

    fn duration(&self) -> f64 {
        self.total
    }

    /// Distance travelled and speed at time `tau` into the move.
    fn at(&self, tau: f64) -> (f64, f64) {
        // max/min, not clamp: clamp panics when the bound is NaN.
        let tau = tau.max(0.0).min(self.total);
        if tau < self.t_acc {
            (0.5 * self.accel * tau * tau, self.accel * tau)
        } else if tau <= self.total - self.t_acc {
            (
                0.5 * self.accel * self.t_acc * self.t_acc + self.peak * (tau - self.t_acc),
                self.peak,
            )
        } else {
            let r = self.total - tau;
            (self.dist - 0.5 * self.accel * r * r, self.accel * r)
        }
    }
}

/// The machine position for axis-coordinate `s` on line `l`.
fn position(axis: Axis, s: f64, l: [f64; 2]) -> [f64; 3] {
    match axis {
        Axis::X => [s, l[0], l[1]],
        Axis::Y => [l[0], s, l[1]],
        Axis::Z => [l[0], l[1], s],
    }
}

/// Generates the whole stream of a plan: the HELLO and a greeting, then the plan's steps
/// (dwells, moves, MARKs) with the periodic SAMPLE, ENV and MATERIAL frames between them.
pub fn simulate(
    plan: &Plan,
    device: &Device,
    faults: &Faults,
    truth: &mut dyn Truth,
) -> Result<SimStream, SimError> {
    validate(plan, device)?;
    let hello = Hello {
        protocol_version: 1,
        device_id: DeviceId::from_text(&device.device_id),
        grating_period_nm: device.grating_period_nm,
        count_resolution_pm: device.count_resolution_pm,
        laser_wavelength_fm: device.laser_wavelength_fm,
        optical_fold: device.optical_fold,
        edges_per_fringe: device.edges_per_fringe,
        axis_code: plan.axis.code(),
    };
    let mut b = Board {
        plan,
        device,
        faults,
        rng: StdRng::seed_from_u64(faults.seed),
        seq: 0,
        line_free_us: 0.0,
        frames: Vec::new(),
        dropped: 0,
        us_per_byte: 10.0e6 / f64::from(device.baud),
    };
    b.send(&Frame::Hello(hello), 0.0, false);
    b.send(
        &Frame::Text(Text {
            text: format!("{} ready", device.device_id),
            lossy: false,
        }),
        0.0,
        false,
    );
    let mut sampler = Sampler::new(plan, device, faults);
    let mut carriage = Carriage::new(plan.seed);
    for step in steps(plan) {
        carriage.step(step, &mut b, &mut sampler, truth);
    }
    let dropped = b.dropped;
    Ok(SimStream {
        hello,
        frames: b.frames,
        truth: sampler.truth_log,
        overruns: sampler.overruns,
        dropped,
        duration_s: carriage.t,
    })
}

/// The run state a sample is labelled with: (run, direction, target, feed mm/s, line).
type RunState = (u32, i8, i32, f64, usize);

/// The carriage and the controller's run state, stepping through the plan.
struct Carriage {
    /// Session seconds of the next event.
    t: f64,
    pos: f64,
    line: usize,
    run: u32,
    dir: i8,
    target: i32,
    in_run: bool,
    motion_rng: StdRng,
}

impl Carriage {
    fn new(seed: u64) -> Self {
        Carriage {
            t: 0.0,
            pos: 0.0,
            line: 0,
            run: 0,
            dir: 0,
            target: -1,
            in_run: false,
            motion_rng: StdRng::seed_from_u64(seed),
        }
    }

    fn step(&mut self, step: Step, b: &mut Board, sampler: &mut Sampler, truth: &mut dyn Truth) {
        match step {
            Step::Dwell(secs) => self.dwell(secs, b, sampler, truth),
            Step::Move(to, d) => self.move_to(to, d, b, sampler, truth),
            Step::Line(l) => self.line = l,
            Step::Mark(kind, d, r, tgt) => self.mark(kind, d, r, tgt, b),
        }
    }

    fn dwell(&mut self, secs: f64, b: &mut Board, sampler: &mut Sampler, truth: &mut dyn Truth) {
        let st = (
            if self.in_run { self.run } else { 0 },
            self.dir,
            self.target,
            0.0,
            self.line,
        );
        // The controller ends a dwell on its own clock, not on the board's timer tick: a
        // random extra wait of up to one sample period, so that moves start at any phase
        // of the timer (a real board is not phase-locked to motion).
        let secs = secs + self.motion_rng.random_range(0.0..sampler.dt);
        let here = self.pos;
        sampler.advance(b, truth, self.t, self.t + secs, &move |_| (here, 0.0), st);
        self.t += secs;
    }

    fn move_to(
        &mut self,
        to: f64,
        d: i8,
        b: &mut Board,
        sampler: &mut Sampler,
        truth: &mut dyn Truth,
    ) {
        let dist = (to - self.pos).abs();
        if dist <= 0.0 {
            return;
        }
        let feed = feed_of(b.plan, self.run);
        let st = (
            if self.in_run { self.run } else { 0 },
            if self.in_run { self.dir } else { 0 },
            -1,
            feed,
            self.line,
        );
        let here = self.pos;
        let profile = Trapezoid::new(dist, feed, b.plan.accel_mm_s2);
        let sign = f64::from(d);
        let dur = profile.duration();
        let motion = move |tau| {
            let (s, v) = profile.at(tau);
            (here + sign * s, v)
        };
        sampler.advance(b, truth, self.t, self.t + dur, &motion, st);
        self.t += dur;
        self.pos = to;
    }

    fn mark(&mut self, kind: MarkKind, d: i8, r: u32, tgt: i32, b: &mut Board) {
        let (l1, l2) = b.line_um(self.line);
        match kind {
            MarkKind::RunStart => {
                self.in_run = true;
                self.run = r;
                self.target = -1;
            }
            MarkKind::RunEnd => {
                self.in_run = false;
                self.target = -1;
            }
            MarkKind::TargetReached => self.target = tgt,
            MarkKind::TargetLeft => self.target = -1,
            MarkKind::Reversal => {}
        }
        self.dir = if self.in_run { d } else { 0 };
        b.send(
            &Frame::Mark(Mark {
                t_us: (self.t * 1e6).round() as u64,
                kind_code: kind.code(),
                direction: d,
                run: r as u16,
                target: tgt.max(0) as u16,
                feed_um_s: (feed_of(b.plan, r) * 1000.0).round() as u32,
                line_first_um: l1,
                line_second_um: l2,
            }),
            self.t * 1e6,
            false,
        );
    }
}

/// The board's periodic frames: SAMPLEs at the sample rate, ENV and MATERIAL at the
/// environment period, and the truth of every sample.
struct Sampler<'a> {
    plan: &'a Plan,
    faults: &'a Faults,
    dt: f64,
    env_period: f64,
    jitter_s: f64,
    res_mm: f64,
    lambda_um: f64,
    laser_count_mm: f64,
    offset: i64,
    // Drawn only when the board jitters, so that a board without jitter gives the same
    // stream as before the term existed.
    jitter_rng: StdRng,
    next_sample: f64,
    next_env: f64,
    index: u32,
    overruns: usize,
    pending_overrun: bool,
    last_laser: Option<i64>,
    truth_log: Vec<TruthSample>,
}

impl<'a> Sampler<'a> {
    fn new(plan: &'a Plan, device: &Device, faults: &'a Faults) -> Self {
        let dt = 1.0 / plan.sample_hz;
        let lambda_um = f64::from(device.laser_wavelength_fm) * 1e-9;
        Sampler {
            plan,
            faults,
            dt,
            env_period: device.env_period_s.max(dt),
            jitter_s: device.latch_jitter_us * 1e-6,
            res_mm: f64::from(device.count_resolution_pm) * 1e-9,
            lambda_um,
            laser_count_mm: lambda_um * 1e-3
                / (f64::from(device.optical_fold) * f64::from(device.edges_per_fringe)),
            offset: faults
                .counters_near_wrap
                .map_or(0i64, |d| i64::from(i32::MAX) - i64::from(d)),
            jitter_rng: StdRng::seed_from_u64(plan.seed ^ 0x6a09_e667_f3bc_c908),
            next_sample: 0.0,
            next_env: 0.0,
            index: 0,
            overruns: 0,
            pending_overrun: false,
            last_laser: None,
            truth_log: Vec::new(),
        }
    }

    /// Emits the periodic frames and samples in [t, until), the carriage at motion(t' − t).
    fn advance(
        &mut self,
        b: &mut Board,
        truth: &mut dyn Truth,
        t: f64,
        until: f64,
        motion: &dyn Fn(f64) -> (f64, f64),
        st: RunState,
    ) {
        loop {
            let next = self.next_sample.min(self.next_env);
            if next >= until {
                break;
            }
            if self.next_env <= self.next_sample {
                self.environment(b, truth, next);
                continue;
            }
            let mut tt = next;
            if self.jitter_s > 0.0 {
                // Interrupt latency, inside this step of the plan.
                let late = self
                    .jitter_rng
                    .random_range(0.0..self.jitter_s)
                    .min((until - tt) * 0.999);
                tt += late.max(0.0);
            }
            self.sample(b, truth, tt, motion(tt - t), st);
            self.next_sample += self.dt;
        }
    }

    /// The ENV and MATERIAL frames at `tt`.
    fn environment(&mut self, b: &mut Board, truth: &mut dyn Truth, tt: f64) {
        let t_us = tt * 1e6;
        let env = truth.environment(tt);
        b.send(
            &Frame::Env(Env {
                t_us: t_us.round() as u64,
                air_temp_mc: (env.air_temp_c * 1000.0).round() as i32,
                pressure_pa: (env.air_pressure_hpa * 100.0).round().max(0.0) as u32,
                rh_permille: (env.air_rh_pct * 10.0).round().clamp(0.0, 1000.0) as u16,
            }),
            t_us,
            false,
        );
        b.send(
            &Frame::Material(Material {
                t_us: t_us.round() as u64,
                temps_mc: vec![
                    (env.scale_temp_c * 1000.0).round() as i32,
                    (env.part_temp_c * 1000.0).round() as i32,
                ],
            }),
            t_us,
            false,
        );
        self.next_env += self.env_period;
    }

    /// One SAMPLE latched at `tt` with the carriage at `(s, speed)`, and its truth.
    fn sample(
        &mut self,
        b: &mut Board,
        truth: &mut dyn Truth,
        tt: f64,
        (s, speed): (f64, f64),
        (run, dir, target, feed, line): RunState,
    ) {
        let t_us = tt * 1e6;
        let p = position(self.plan.axis, s, self.plan.lines_mm[line]);
        let q = TruthQuery {
            t_s: tt,
            pos_mm: p,
            direction: dir,
            feed_mm_s: feed,
            speed_mm_s: speed,
            run,
            target,
        };
        let e_um = truth.error_um(&q);
        let air = truth.true_air(tt);
        let n_air = edlen::refractive_index(
            self.lambda_um,
            air.air_temp_c,
            air.air_pressure_hpa * 100.0,
            air.air_rh_pct,
        );
        // Actual displacement from home = indicated − error.
        let actual_mm = s - e_um * 1e-3;
        let scale = (s / self.res_mm).round() as i64 + self.offset;
        let mut laser = (actual_mm * n_air / self.laser_count_mm).round() as i64 + self.offset;
        let mut flags = 0u8;
        if let Some((a, z)) = self.faults.beam_loss_s
            && tt >= a
            && tt < z
        {
            flags |= SampleFlags::BEAM_LOW;
            laser = self.last_laser.unwrap_or(laser);
        }
        if self.pending_overrun {
            flags |= SampleFlags::OVERRUN;
        }
        let sample = Sample {
            t_us: t_us.round() as u64,
            index: self.index,
            scale_count: scale as i32,
            laser_count: laser as i32,
            flags: SampleFlags(flags),
            trigger_code: 0,
        };
        let sent = b.send(&Frame::Sample(sample), t_us, true);
        if sent {
            self.pending_overrun = false;
        } else {
            self.overruns += 1;
            self.pending_overrun = true;
        }
        self.last_laser = Some(laser);
        self.truth_log.push(TruthSample {
            index: self.index,
            t_s: tt,
            pos_mm: p,
            error_um: e_um,
            run,
            direction: dir,
            target,
            sent,
        });
        self.index = self.index.wrapping_add(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Zero;
    impl Truth for Zero {
        fn error_um(&mut self, _q: &TruthQuery) -> f64 {
            0.0
        }
    }

    #[test]
    fn the_estimated_duration_is_the_hand_computed_one_and_a_lower_bound() {
        // One line, one run, targets 0 and 100 mm at 100 mm/s with a brisk 10⁷ mm/s²:
        // each move takes 2·10⁻⁵ + (100 − 10⁻³)/100 s; out and back, 2 moves and 4 dwells
        // of 1 s, no settle.
        let plan = Plan {
            targets_mm: vec![0.0, 100.0],
            runs: 1,
            dwell_s: 1.0,
            settle_s: 0.0,
            accel_mm_s2: 1e7,
            ..Plan::default()
        };
        let one_move = 2e-5 + (100.0 - 1e-3) / 100.0;
        let want = 2.0 * (one_move + 2.0);
        let got = estimated_duration_s(&plan);
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        let real = simulate(&plan, &Device::default(), &Faults::default(), &mut Zero)
            .expect("simulates")
            .duration_s;
        assert!(got <= real, "{got} > {real}");
        // The default plan, with two feeds cycled over five runs, is a lower bound too.
        let plan = Plan {
            extra_feeds_mm_s: vec![50.0],
            ..Plan::default()
        };
        let real = simulate(&plan, &Device::default(), &Faults::default(), &mut Zero)
            .expect("simulates")
            .duration_s;
        let got = estimated_duration_s(&plan);
        assert!(got <= real && got > 0.8 * real, "{got} vs {real}");
    }

    #[test]
    fn plans_past_the_sample_budget_or_with_non_finite_values_are_refused_by_key() {
        let long = Plan {
            dwell_s: 1e9,
            ..Plan::default()
        };
        let e = check_plan(&long).expect_err("too long").to_string();
        assert!(e.contains("samples") && e.contains("dwell_s"), "{e}");
        for (plan, key) in [
            (
                Plan {
                    sample_hz: f64::INFINITY,
                    ..Plan::default()
                },
                "sample_hz",
            ),
            (
                Plan {
                    accel_mm_s2: f64::NAN,
                    ..Plan::default()
                },
                "accel_mm_s2",
            ),
            (
                Plan {
                    settle_s: -1.0,
                    ..Plan::default()
                },
                "settle_s",
            ),
        ] {
            let e = check_plan(&plan).expect_err("refused").to_string();
            assert!(e.contains(key), "{e}");
        }
        check_plan(&Plan::default()).expect("the default plan");
    }

    #[test]
    fn a_device_whose_counts_outrun_the_decoder_is_refused_by_key() {
        let simulate_with = |device: Device| {
            simulate(&Plan::default(), &device, &Faults::default(), &mut Zero)
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        // 16 fm is no laser: 1 mm between samples would be 5·10¹¹ counts.
        let e = simulate_with(Device {
            laser_wavelength_fm: 16,
            ..Device::default()
        })
        .expect_err("refused");
        assert!(e.contains("laser_wavelength_fm"), "{e}");
        // 1 pm per count: the default plan's 1 mm per sample is 10⁹ counts > 2^24.
        let e = simulate_with(Device {
            count_resolution_pm: 1,
            ..Device::default()
        })
        .expect_err("refused");
        assert!(
            e.contains("count_resolution_pm") && e.contains("2^24"),
            "{e}"
        );
        simulate_with(Device::default()).expect("the default device");
    }
}
