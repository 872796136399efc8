//! errmap's simulated rotary board: the rotary simulator's cycle ([`simulate_rotary`]) sent
//! as the wire frames a rotary acquisition board would send (`errmap_drivers::rotary`:
//! a HELLO with axis code 3–5, the encoder on the scale counter, the reference on the
//! laser counter, MARKs with the target angle in µ° and the feed in m°/s), for
//! `serve-sim` and `capture --simulate` with a rotary model (`docs/rotary.md`, "Capture").
//!
//! The model file is TOML with one `[rotary]` table: `axis` ("A", "B" or "C"),
//! `positioning_arcsec` (one offset per dwell, one-sigma, default 0.5), `noise_arcsec`
//! (per sample, default 0.3), `seed` (0), `samples_per_dwell` (4), and `[[rotary.effects]]`
//! each with `id` and the parameters of `docs/rotary.md`'s effect table. The plan is a
//! rotary PLAN.toml (`errmap plan --axis …`), or without one 24 targets every 15°, 5 runs.
//! The board samples during the dwells and once at each reversal (a moving row).

use std::path::Path;

use errmap_drivers::frame::{DeviceId, Env, Frame, Hello, Mark, MarkKind, Sample, SampleFlags};
use errmap_drivers::sim::{Emitted, SimStream};
use serde::Deserialize;

use super::rotary::{RotaryAxisModel, RotaryCycle, simulate_rotary};
use super::{SimError, check_numbers};
use crate::base::{ConfigError, RotaryAxis, read_toml};
use crate::diagnose::rotary::{RotaryDrift, RotaryEffect};

/// Encoder counts per revolution of the simulated board: 2²⁶ (0.019″ a count).
const SIM_ENCODER_COUNTS_PER_REV: u32 = 1 << 26;
/// Reference signal periods per revolution (× F·k = 1·4 counts a period: 0.005″ a count).
const SIM_REFERENCE_PERIODS_PER_REV: u32 = 64_800_000;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    rotary: RotarySpec,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RotarySpec {
    axis: String,
    #[serde(default = "default_positioning")]
    positioning_arcsec: f64,
    #[serde(default = "default_noise")]
    noise_arcsec: f64,
    #[serde(default)]
    seed: u64,
    #[serde(default = "default_samples")]
    samples_per_dwell: usize,
    #[serde(default)]
    effects: Vec<EffectSpec>,
}

fn default_positioning() -> f64 {
    0.5
}
fn default_noise() -> f64 {
    0.3
}
fn default_samples() -> usize {
    4
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EffectSpec {
    id: String,
    amplitude_arcsec: Option<f64>,
    phase_deg: Option<f64>,
    per_rev: Option<u32>,
    b_arcsec: Option<f64>,
    ppm: Option<f64>,
    rate_arcsec_per_s: Option<f64>,
    tau_s: Option<f64>,
}

/// A rotary PLAN.toml, as `errmap plan --axis …` writes it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    axis: String,
    targets_deg: Vec<f64>,
    runs: u32,
    overrun_deg: f64,
    dwell_s: f64,
    feed_deg_s: f64,
    #[serde(default)]
    seed: u64,
}

/// Whether a model file is a rotary one (a top-level `rotary` table). A file that does not
/// parse is not (its reader then says why).
pub fn is_rotary_model(path: &Path) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.parse::<toml::Table>().ok())
        .is_some_and(|t| t.contains_key("rotary"))
}

fn effect(path: &Path, i: usize, e: &EffectSpec) -> Result<RotaryEffect, ConfigError> {
    let key = |k: &str| format!("rotary.effects[{i}].{k}");
    let need = |v: Option<f64>, k: &str| {
        v.ok_or_else(|| ConfigError::key(path, key(k), format!("`{}` needs `{k}`", e.id)))
    };
    let harmonic = |n: u32| -> Result<RotaryEffect, ConfigError> {
        Ok(RotaryEffect::harmonic(
            n,
            need(e.amplitude_arcsec, "amplitude_arcsec")?,
            need(e.phase_deg, "phase_deg")?,
        ))
    };
    match e.id.as_str() {
        "eccentricity" => harmonic(1),
        "twice_per_rev" => harmonic(2),
        "gear_periodic" => match e.per_rev {
            Some(n) if (3..=10_000).contains(&n) => harmonic(n),
            _ => Err(ConfigError::key(
                path,
                key("per_rev"),
                "`gear_periodic` needs an integer `per_rev` in 3 … 10000",
            )),
        },
        "reversal" => Ok(RotaryEffect::Reversal {
            b_arcsec: need(e.b_arcsec, "b_arcsec")?,
        }),
        "scale_factor" => Ok(RotaryEffect::ScaleFactor {
            ppm: need(e.ppm, "ppm")?,
        }),
        "thermal_drift" => Ok(RotaryEffect::ThermalDrift(match e.rate_arcsec_per_s {
            Some(rate_arcsec_per_s) => RotaryDrift::Linear { rate_arcsec_per_s },
            None => RotaryDrift::Exponential {
                amplitude_arcsec: need(e.amplitude_arcsec, "amplitude_arcsec")?,
                tau_s: need(e.tau_s, "tau_s").and_then(|t| {
                    (t > 0.0)
                        .then_some(t)
                        .ok_or_else(|| ConfigError::key(path, key("tau_s"), "must be positive"))
                })?,
            },
        })),
        other => Err(ConfigError::key(
            path,
            key("id"),
            format!(
                "`{other}` is not a rotary effect (eccentricity, twice_per_rev, gear_periodic, \
                 reversal, scale_factor, thermal_drift)"
            ),
        )),
    }
}

/// Reads a rotary model file (see the module docs).
pub fn read_rotary_model(path: &Path) -> Result<(RotaryAxisModel, usize), SimError> {
    let f: ModelFile = read_toml::<_, SimError>(path, check_numbers)?;
    let s = f.rotary;
    let axis: RotaryAxis = s
        .axis
        .parse()
        .map_err(|e| ConfigError::key(path, "rotary.axis", format!("{e}")))?;
    for (k, v) in [
        ("rotary.positioning_arcsec", s.positioning_arcsec),
        ("rotary.noise_arcsec", s.noise_arcsec),
    ] {
        if !(0.0..=3600.0).contains(&v) {
            return Err(ConfigError::key(path, k, format!("{v} is outside 0 … 3600″")).into());
        }
    }
    if !(1..=1000).contains(&s.samples_per_dwell) {
        return Err(ConfigError::key(path, "rotary.samples_per_dwell", "1 … 1000").into());
    }
    let effects = s
        .effects
        .iter()
        .enumerate()
        .map(|(i, e)| effect(path, i, e))
        .collect::<Result<Vec<_>, _>>()?;
    let model = RotaryAxisModel {
        axis,
        effects,
        positioning_arcsec: s.positioning_arcsec,
        noise_arcsec: s.noise_arcsec,
        seed: s.seed,
    };
    Ok((model, s.samples_per_dwell))
}

/// Reads a rotary PLAN.toml for `axis` (or the default cycle without one).
pub fn read_rotary_cycle(
    path: Option<&Path>,
    axis: RotaryAxis,
    samples_per_dwell: usize,
) -> Result<RotaryCycle, SimError> {
    let Some(path) = path else {
        return Ok(RotaryCycle {
            samples_per_dwell,
            ..RotaryCycle::revolution(24)
        });
    };
    let p: PlanFile = read_toml::<_, SimError>(path, check_numbers)?;
    if p.axis.parse::<RotaryAxis>().ok() != Some(axis) {
        let problem = format!("`{}`: the model's axis is {axis}", p.axis);
        return Err(ConfigError::key(path, "axis", problem).into());
    }
    let ascending = p.targets_deg.windows(2).all(|w| w[0] < w[1]);
    let inside = p.targets_deg.iter().all(|t| (0.0..=360.0).contains(t));
    if p.targets_deg.len() < 2
        || p.targets_deg.len() > super::MAX_PLAN_TARGETS
        || !ascending
        || !inside
    {
        let problem = "2 … 10000 angles, ascending, in [0, 360]";
        return Err(ConfigError::key(path, "targets_deg", problem).into());
    }
    let checks = [
        ("runs", f64::from(p.runs), 1.0, 1000.0),
        ("overrun_deg", p.overrun_deg, 0.0, 3600.0),
        ("dwell_s", p.dwell_s, 0.001, 3600.0),
        ("feed_deg_s", p.feed_deg_s, 0.001, 3600.0),
    ];
    for (k, v, lo, hi) in checks {
        if !(lo..=hi).contains(&v) {
            return Err(ConfigError::key(path, k, format!("{v} is outside {lo} … {hi}")).into());
        }
    }
    let _ = p.seed;
    Ok(RotaryCycle {
        targets_deg: p.targets_deg,
        runs: p.runs,
        overrun_deg: p.overrun_deg,
        dwell_s: p.dwell_s,
        feed_deg_s: p.feed_deg_s,
        samples_per_dwell,
    })
}

/// The simulated rotary board's HELLO.
pub fn rotary_hello(axis: RotaryAxis) -> Hello {
    let code = match axis {
        RotaryAxis::A => 3,
        RotaryAxis::B => 4,
        RotaryAxis::C => 5,
    };
    Hello {
        protocol_version: 1,
        device_id: DeviceId::from_text("errmap-sim-rot"),
        grating_period_nm: 32_768,
        count_resolution_pm: SIM_ENCODER_COUNTS_PER_REV,
        laser_wavelength_fm: SIM_REFERENCE_PERIODS_PER_REV / 4,
        optical_fold: 1,
        edges_per_fringe: 4,
        axis_code: code,
    }
}

/// Frames in order, with their line times at 115 200 baud (10 bits a byte).
struct Line {
    frames: Vec<Emitted>,
    seq: u16,
    free_us: f64,
}

impl Line {
    fn send(&mut self, frame: &Frame, t_us: u64) {
        let bytes = errmap_drivers::encode(frame, self.seq).expect("the board's frames encode");
        self.seq = self.seq.wrapping_add(1);
        self.free_us = self.free_us.max(t_us as f64) + bytes.len() as f64 * 1e7 / 115_200.0;
        self.frames.push(Emitted {
            line_time_us: self.free_us.round() as u64,
            bytes,
        });
    }
}

fn counts(angle_deg: f64, per_rev: f64) -> i32 {
    // Wrapping two's complement, as the board's counter.
    ((angle_deg / 360.0 * per_rev).round() as i64) as i32
}

/// The rotary cycle on the model as the board's byte stream (see the module docs).
pub fn rotary_stream(model: &RotaryAxisModel, cycle: &RotaryCycle) -> SimStream {
    let session = simulate_rotary(model, cycle);
    let hello = rotary_hello(model.axis);
    let mut line = Line {
        frames: Vec::new(),
        seq: 0,
        free_us: 0.0,
    };
    line.send(&Frame::Hello(hello), 0);
    let env = Env {
        t_us: 0,
        air_temp_mc: 20_000,
        pressure_pa: 101_325,
        rh_permille: 500,
    };
    line.send(&Frame::Env(env), 0);
    let feed_mdeg_s = (cycle.feed_deg_s * 1000.0).round() as u32;
    let mark = |kind: MarkKind, t_us: u64, d: i8, run: u32, target: i32, deg: f64| Mark {
        t_us,
        kind_code: kind.code(),
        direction: d,
        run: run as u16,
        target: target.max(0) as u16,
        feed_um_s: feed_mdeg_s,
        line_first_um: (deg * 1e6).round() as i32,
        line_second_um: 0,
    };
    let (enc, refc) = (
        f64::from(SIM_ENCODER_COUNTS_PER_REV),
        f64::from(SIM_REFERENCE_PERIODS_PER_REV),
    );
    let mut index = 0u32;
    let mut sample = |line: &mut Line, t_us: u64, indicated: f64, reference: f64| {
        let s = Sample {
            t_us,
            index,
            scale_count: counts(indicated, enc),
            laser_count: counts(reference, refc),
            flags: SampleFlags(0),
            trigger_code: 0,
        };
        index = index.wrapping_add(1);
        line.send(&Frame::Sample(s), t_us);
    };
    // (run, direction, target) of the dwell being sampled.
    let mut at: Option<(u32, i8, i32, f64)> = None;
    let to = cycle.targets_deg.last().copied().unwrap_or(360.0);
    let from = cycle.targets_deg.first().copied().unwrap_or(0.0);
    let mut last_t_us = 0;
    for r in &session.rows {
        let t_us = (r.t_s * 1e6).round() as u64;
        let deg = r.target_deg.unwrap_or(0.0);
        let key = (r.run, r.direction, r.target);
        if at.map(|a| (a.0, a.1, a.2)) != Some(key) {
            let before = t_us.saturating_sub(1000);
            if let Some((run, d, target, tdeg)) = at {
                line.send(
                    &Frame::Mark(mark(MarkKind::TargetLeft, before, d, run, target, tdeg)),
                    before,
                );
                if run != r.run {
                    // Back at from − overrun: a moving sample, then the run's end.
                    sample(
                        &mut line,
                        before,
                        from - cycle.overrun_deg,
                        from - cycle.overrun_deg,
                    );
                    line.send(
                        &Frame::Mark(mark(MarkKind::RunEnd, before, d, run, -1, 0.0)),
                        before,
                    );
                } else if d != r.direction {
                    sample(
                        &mut line,
                        before,
                        to + cycle.overrun_deg,
                        to + cycle.overrun_deg,
                    );
                    let m = mark(MarkKind::Reversal, before, r.direction, run, -1, 0.0);
                    line.send(&Frame::Mark(m), before);
                }
            }
            if at.is_none_or(|a| a.0 != r.run) {
                let m = mark(MarkKind::RunStart, before, r.direction, r.run, -1, 0.0);
                line.send(&Frame::Mark(m), before);
            }
            let m = mark(
                MarkKind::TargetReached,
                before,
                r.direction,
                r.run,
                r.target,
                deg,
            );
            line.send(&Frame::Mark(m), before);
            at = Some((r.run, r.direction, r.target, deg));
        }
        sample(&mut line, t_us, r.indicated_deg, r.reference_deg);
        last_t_us = t_us;
    }
    if let Some((run, d, target, tdeg)) = at {
        let t = last_t_us + 1000;
        line.send(
            &Frame::Mark(mark(MarkKind::TargetLeft, t, d, run, target, tdeg)),
            t,
        );
        line.send(&Frame::Mark(mark(MarkKind::RunEnd, t, d, run, -1, 0.0)), t);
    }
    SimStream {
        hello,
        duration_s: line.free_us * 1e-6,
        frames: line.frames,
        truth: Vec::new(),
        overruns: 0,
        dropped: 0,
    }
}

/// A rotary model file and plan as the board's stream.
pub fn simulate_rotary_stream(model: &Path, plan: Option<&Path>) -> Result<SimStream, SimError> {
    let (m, samples) = read_rotary_model(model)?;
    let cycle = read_rotary_cycle(plan, m.axis, samples)?;
    Ok(rotary_stream(&m, &cycle))
}
