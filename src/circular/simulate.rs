//! A simulator of circular tests: a machine model (TOML) with effects of the circular
//! vocabulary → a trace and its TOML.
//!
//! It does not use the signatures the diagnosis fits (`signature`): it moves the two
//! axes along the commanded circle sample by sample, applies each effect to the axis it
//! acts on from its physics (the velocity's sign, the time since the axis last reversed,
//! the axis position), delays each axis by its own lag, and measures the bar as the
//! distance from the actual tool ball to the (offset) table ball, exactly, not to first
//! order. White noise is added last.
//!
//! The model file:
//! ```toml
//! [test]                  # the test's metadata, as in the trace's TOML
//! plane = "XY"
//! radius_mm = 100.0
//! feed_mm_per_min = 1000.0
//! arc_start_deg = 0.0
//! arc_deg = 360.0
//! overshoot_deg = 45.0
//! sample_rate_hz = 200.0
//! [setup]
//! directions = ["ccw", "cw"]   # or one of them
//! centre_offset_um = [3.0, -2.0]
//! bar_error_um = 1.5
//! noise_um = 0.1
//! seed = 1
//! [[effect]]
//! id = "backlash"
//! axis = "X"                   # an axis letter of the plane, or the plane for pair effects
//! params = { b_um = 4.0 }
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use polars::prelude::*;
use rand::SeedableRng;
use rand::rngs::StdRng;
use serde::Deserialize;

use super::effects::{CircularEffect, CircularId, Contribution, Motion, sgn};
use super::error::{CircularError, key_err, parse_toml};
use super::input::{CircularTest, MAX_SAMPLES, Run, Sense, TestMeta, meta_path};
use super::signature::Slot;
use crate::base::gaussian;
use crate::base::io_err;
use crate::base::{EffectId, FileOp, ParamValue};

/// The setup of a simulated test.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimSetup {
    pub directions: Vec<String>,
    #[serde(default)]
    pub centre_offset_um: [f64; 2],
    #[serde(default)]
    pub bar_error_um: f64,
    #[serde(default)]
    pub noise_um: f64,
    #[serde(default)]
    pub seed: u64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEffect {
    id: String,
    axis: String,
    params: BTreeMap<String, ParamValue>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    test: TestMeta,
    setup: SimSetup,
    #[serde(default)]
    effect: Vec<RawEffect>,
}

/// One effect of a machine model and the slot it acts on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimEffect {
    pub effect: CircularEffect,
    pub slot: Slot,
}

/// A machine model for the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct MachineModel {
    pub meta: TestMeta,
    pub directions: Vec<Sense>,
    pub centre_offset_um: [f64; 2],
    pub bar_error_um: f64,
    pub noise_um: f64,
    pub seed: u64,
    pub effects: Vec<SimEffect>,
}

impl MachineModel {
    /// Reads a model TOML: unknown keys, an effect outside the circular vocabulary, a
    /// missing or unknown parameter, an axis outside the plane are refused by name.
    pub fn read(path: &Path) -> Result<MachineModel, CircularError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        let raw: RawModel = parse_toml(path, &text)?;
        raw.test.check(path)?;
        let mut directions = Vec::new();
        for d in &raw.setup.directions {
            let s = [Sense::Ccw, Sense::Cw]
                .into_iter()
                .find(|s| s.as_str() == d)
                .ok_or_else(|| {
                    key_err(path, "setup.directions", format!("`{d}` is not ccw or cw"))
                })?;
            if directions.contains(&s) {
                return Err(key_err(path, "setup.directions", format!("{d} twice")));
            }
            directions.push(s);
        }
        if directions.is_empty() {
            return Err(key_err(path, "setup.directions", "empty"));
        }
        check_setup(path, &raw.setup)?;
        let plane = raw.test.plane;
        let effects = raw
            .effect
            .iter()
            .enumerate()
            .map(|(k, e)| sim_effect(path, plane, k, e))
            .collect::<Result<Vec<_>, _>>()?;
        check_size(path, &raw.test, directions.len())?;
        Ok(MachineModel {
            meta: raw.test,
            directions,
            centre_offset_um: raw.setup.centre_offset_um,
            bar_error_um: raw.setup.bar_error_um,
            noise_um: raw.setup.noise_um,
            seed: raw.setup.seed,
            effects,
        })
    }
}

/// The sample rate the simulator takes when the model gives none, Hz.
pub(crate) const DEFAULT_SAMPLE_RATE_HZ: f64 = 200.0;

/// The samples one simulated run has: the nominal arc and both overshoots at the
/// model's feed and sample rate (a float, so that an absurd count is seen before any
/// allocation).
pub(crate) fn samples_per_run(meta: &TestMeta) -> f64 {
    let omega = meta.omega_rad_per_s();
    let fs = meta.sample_rate_hz.unwrap_or(DEFAULT_SAMPLE_RATE_HZ);
    let (lo, hi) = sim_arc_rad(meta);
    ((hi - lo) / omega * fs).floor() + 1.0
}

/// The simulated arc, lead-in and lead-out included, rad.
fn sim_arc_rad(meta: &TestMeta) -> (f64, f64) {
    let (lo, hi) = meta.arc_deg_range();
    (
        (lo - meta.overshoot_deg).to_radians(),
        (hi + meta.overshoot_deg).to_radians(),
    )
}

/// Simulates the test a model describes; a test of more than [`MAX_SAMPLES`] samples is
/// refused before anything is allocated.
pub fn simulate(model: &MachineModel) -> Result<CircularTest, CircularError> {
    let meta = &model.meta;
    let per_run = samples_per_run(meta);
    let total = per_run * model.directions.len() as f64;
    if total.is_nan() || total > MAX_SAMPLES as f64 {
        return Err(CircularError::TooManySamples {
            samples: total,
            max: MAX_SAMPLES,
        });
    }
    let n = per_run as usize;
    let mut rng = StdRng::seed_from_u64(model.seed);
    let omega = meta.omega_rad_per_s();
    let fs = meta.sample_rate_hz.unwrap_or(DEFAULT_SAMPLE_RATE_HZ);
    let (lo, hi) = sim_arc_rad(meta);
    let mut runs = Vec::new();
    for (k, &sense) in model.directions.iter().enumerate() {
        let s = sense.s();
        let start = if s > 0.0 { lo } else { hi };
        let mut run = Run {
            id: k as i64 + 1,
            sense,
            first_line: 0,
            angle_deg: Vec::with_capacity(n),
            dr_um: Vec::with_capacity(n),
            t_s: Some(Vec::with_capacity(n)),
        };
        for i in 0..n {
            let t = i as f64 / fs;
            let theta = start + s * omega * t;
            let dr = bar_reading(model, theta, s, t, start) + model.noise_um * gaussian(&mut rng);
            run.angle_deg.push(theta.to_degrees());
            run.dr_um.push(dr);
            if let Some(ts) = run.t_s.as_mut() {
                ts.push(t);
            }
        }
        runs.push(run);
    }
    runs.sort_by_key(|r| r.sense);
    Ok(CircularTest {
        trace: Default::default(),
        meta: model.meta.clone(),
        runs,
    })
}

/// The bar reading (µm, without noise) at angle θ of a run of sense s at time t.
fn bar_reading(model: &MachineModel, theta: f64, s: f64, t: f64, start: f64) -> f64 {
    let meta = &model.meta;
    let r = meta.radius_mm;
    let omega = meta.omega_rad_per_s();
    // Commanded positions (mm) and velocity signs.
    let motion = Motion {
        theta,
        s,
        t,
        start,
        omega,
        radius_mm: r,
        q_mm: [r * theta.cos(), r * theta.sin()],
        v_sign: [sgn(-s * theta.sin()), sgn(s * theta.cos())],
    };
    let mut lag = [0.0f64; 2];
    let (mut ea, mut eb) = (0.0, 0.0);
    for e in &model.effects {
        let Contribution {
            a_um,
            b_um,
            lag_a_ms,
            lag_b_ms,
        } = e.effect.term().simulate(e.slot, &motion);
        ea += a_um;
        eb += b_um;
        lag[0] += lag_a_ms;
        lag[1] += lag_b_ms;
    }
    // Each axis at its own lag (ms): its commanded position at t − lag, exactly.
    let back = |lag_ms: f64| theta - s * omega * lag_ms * 1e-3;
    let pa = r * back(lag[0]).cos() + ea * 1e-3;
    let pb = r * back(lag[1]).sin() + eb * 1e-3;
    let (ca, cb) = (
        model.centre_offset_um[0] * 1e-3,
        model.centre_offset_um[1] * 1e-3,
    );
    ((pa - ca).hypot(pb - cb) - r) * 1e3 + model.bar_error_um
}

/// The largest centring offset, bar error and noise a simulated setup may have, µm: a
/// ballbar reads about a millimetre either side of its length.
pub(crate) const MAX_SETUP_UM: f64 = 1000.0;

/// Refuses a setup term that is not finite or outside ±[`MAX_SETUP_UM`] (the noise's σ
/// also negative), by its key.
fn check_setup(path: &Path, setup: &SimSetup) -> Result<(), CircularError> {
    let terms = [
        ("setup.centre_offset_um", setup.centre_offset_um[0]),
        ("setup.centre_offset_um", setup.centre_offset_um[1]),
        ("setup.bar_error_um", setup.bar_error_um),
        ("setup.noise_um", setup.noise_um),
    ];
    for (key, v) in terms {
        if !v.is_finite() {
            return Err(key_err(path, key, format!("{v} is not finite")));
        }
        if v.abs() > MAX_SETUP_UM {
            return Err(key_err(
                path,
                key,
                format!("{v} µm is outside the plausible range ±{MAX_SETUP_UM} µm"),
            ));
        }
    }
    if setup.noise_um < 0.0 {
        return Err(key_err(path, "setup.noise_um", "must be finite and >= 0"));
    }
    Ok(())
}

/// Refuses a model whose test would have more than [`MAX_SAMPLES`] samples, before
/// anything is simulated.
fn check_size(path: &Path, meta: &TestMeta, runs: usize) -> Result<(), CircularError> {
    let total = samples_per_run(meta) * runs as f64;
    if total <= MAX_SAMPLES as f64 {
        return Ok(());
    }
    let key = if meta.sample_rate_hz.is_some() {
        "test.sample_rate_hz"
    } else {
        "test.feed_mm_per_min"
    };
    Err(key_err(
        path,
        key,
        format!(
            "{runs} run(s) of {} deg at {} mm/min on a radius of {} mm sampled at {} Hz make \
             {total:.3e} samples, more than the {MAX_SAMPLES} a test may have (raise the feed \
             or lower the sample rate)",
            meta.arc_deg + 2.0 * meta.overshoot_deg,
            meta.feed_mm_per_min,
            meta.radius_mm,
            meta.sample_rate_hz.unwrap_or(DEFAULT_SAMPLE_RATE_HZ)
        ),
    ))
}

/// The `k`-th `[[effect]]` of a model: an effect of the circular vocabulary, on a slot it
/// may act on in `plane`, with its parameters finite and within their plausible bounds.
fn sim_effect(
    path: &Path,
    plane: super::input::Plane,
    k: usize,
    e: &RawEffect,
) -> Result<SimEffect, CircularError> {
    let key = format!("effect[{k}]");
    let id: CircularId = e.id.parse().map_err(|_| {
        let problem = match e.id.parse::<EffectId>() {
            Ok(id) => format!("`{id}` is not an effect of the circular test"),
            Err(_) => format!("`{}` is unknown", e.id),
        };
        key_err(path, &format!("{key}.id"), problem)
    })?;
    let slot = id
        .slots()
        .iter()
        .copied()
        .find(|s| s.label(plane).eq_ignore_ascii_case(&e.axis))
        .ok_or_else(|| {
            key_err(
                path,
                &format!("{key}.axis"),
                format!(
                    "`{}` is not one of {} for `{id}` in plane {}",
                    e.axis,
                    id.slots()
                        .iter()
                        .map(|s| s.label(plane))
                        .collect::<Vec<_>>()
                        .join(", "),
                    plane.as_str()
                ),
            )
        })?;
    let effect = CircularEffect::from_params(id, &e.params)
        .map_err(|err| key_err(path, &format!("{key}.params"), err.to_string()))?;
    effect
        .check()
        .map_err(|(name, problem)| key_err(path, &format!("{key}.params.{name}"), problem))?;
    Ok(SimEffect { effect, slot })
}

/// Writes a test as a trace (CSV or Parquet by extension) and its TOML beside it, each
/// whole or not at all.
pub fn write_test(test: &CircularTest, trace: &Path) -> Result<(), CircularError> {
    let mut run = Vec::new();
    let mut dir = Vec::new();
    let mut ang = Vec::new();
    let mut dr = Vec::new();
    let mut ts = Vec::new();
    // Ccw first is as good as any order; keep the runs' ids.
    for r in &test.runs {
        for i in 0..r.angle_deg.len() {
            run.push(r.id);
            dir.push(r.sense.s() as i64);
            ang.push(r.angle_deg[i]);
            dr.push(r.dr_um[i]);
            ts.push(r.t_s.as_ref().map(|t| t[i]).unwrap_or(f64::NAN));
        }
    }
    let mut cols = vec![
        Column::new("run".into(), run),
        Column::new("direction".into(), dir),
        Column::new("angle_deg".into(), ang),
        Column::new("dr_um".into(), dr),
    ];
    if test.runs.iter().all(|r| r.t_s.is_some()) {
        cols.push(Column::new("t_s".into(), ts));
    }
    let height = cols[0].len();
    let mut df = DataFrame::new(height, cols).map_err(|e| CircularError::Test {
        path: trace.to_path_buf(),
        problem: e.to_string(),
    })?;
    crate::table::write_frame(trace, &mut df)?;
    let toml_path = meta_path(trace);
    let text = test.meta.to_toml();
    crate::table::write_atomically::<CircularError>(&toml_path, |f| {
        use std::io::Write;
        f.write_all(text.as_bytes())
            .map_err(|e| io_err(&toml_path, FileOp::Write)(e).into())
    })
}
