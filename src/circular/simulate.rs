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
use std::f64::consts::PI;
use std::path::Path;

use polars::prelude::*;
use rand::SeedableRng;
use rand::rngs::StdRng;
use serde::Deserialize;

use super::error::{CircularError, key_err, parse_toml};
use super::input::{CircularTest, Run, Sense, TestMeta, meta_path};
use super::signature::{Slot, slots};
use crate::base::FileOp;
use crate::base::gaussian;
use crate::base::io_err;
use crate::base::{Effect, EffectId, ParamValue};

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
    pub effect: Effect,
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
            let s = match d.as_str() {
                "ccw" => Sense::Ccw,
                "cw" => Sense::Cw,
                _ => {
                    return Err(key_err(
                        path,
                        "setup.directions",
                        format!("`{d}` is not ccw or cw"),
                    ));
                }
            };
            if directions.contains(&s) {
                return Err(key_err(path, "setup.directions", format!("{d} twice")));
            }
            directions.push(s);
        }
        if directions.is_empty() {
            return Err(key_err(path, "setup.directions", "empty"));
        }
        if !(raw.setup.noise_um.is_finite() && raw.setup.noise_um >= 0.0) {
            return Err(key_err(path, "setup.noise_um", "must be finite and >= 0"));
        }
        let plane = raw.test.plane;
        let mut effects = Vec::new();
        for (k, e) in raw.effect.iter().enumerate() {
            let key = format!("effect[{k}]");
            let id: EffectId = e.id.parse().map_err(|_| {
                key_err(path, &format!("{key}.id"), format!("`{}` is unknown", e.id))
            })?;
            if !EffectId::CIRCULAR.contains(&id) {
                return Err(key_err(
                    path,
                    &format!("{key}.id"),
                    format!("`{id}` is not an effect of the circular test"),
                ));
            }
            let slot = slots(id)
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
                            slots(id)
                                .iter()
                                .map(|s| s.label(plane))
                                .collect::<Vec<_>>()
                                .join(", "),
                            plane.as_str()
                        ),
                    )
                })?;
            let effect = Effect::from_params(id, &e.params)
                .map_err(|err| key_err(path, &format!("{key}.params"), err.to_string()))?;
            if let Some((name, v)) = effect.non_finite() {
                return Err(key_err(
                    path,
                    &format!("{key}.params.{name}"),
                    format!("{v} is not finite"),
                ));
            }
            let positive = match effect {
                Effect::ReversalSpike { tau_ms, .. } => Some(("tau_ms", tau_ms)),
                Effect::CyclicError { period_mm, .. } => Some(("period_mm", period_mm)),
                _ => None,
            };
            if let Some((name, v)) = positive
                && v <= 0.0
            {
                return Err(key_err(
                    path,
                    &format!("{key}.params.{name}"),
                    format!("{v} must be > 0"),
                ));
            }
            effects.push(SimEffect { effect, slot });
        }
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

fn sgn(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Simulates the test a model describes.
pub fn simulate(model: &MachineModel) -> CircularTest {
    let meta = &model.meta;
    let mut rng = StdRng::seed_from_u64(model.seed);
    let omega = meta.omega_rad_per_s();
    let fs = meta.sample_rate_hz.unwrap_or(200.0);
    let (lo, hi) = meta.arc_deg_range();
    let (lo, hi) = (
        (lo - meta.overshoot_deg).to_radians(),
        (hi + meta.overshoot_deg).to_radians(),
    );
    let mut runs = Vec::new();
    for (k, &sense) in model.directions.iter().enumerate() {
        let s = sense.s();
        let start = if s > 0.0 { lo } else { hi };
        let span = hi - lo;
        let n = (span / omega * fs).floor() as usize + 1;
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
    CircularTest {
        trace: Default::default(),
        meta: model.meta.clone(),
        runs,
    }
}

/// The time (s) the run last passed a reversal of the axis whose reversals lie at
/// `offset` + kπ, `None` before the first one (the run started from rest).
fn last_reversal(theta: f64, s: f64, start: f64, offset: f64, omega: f64) -> Option<f64> {
    let travelled = (s * (theta - offset)).rem_euclid(PI);
    let at = theta - s * travelled;
    ((at - start) * s >= 0.0).then(|| (at - start) * s / omega)
}

/// The bar reading (µm, without noise) at angle θ of a run of sense s at time t.
fn bar_reading(model: &MachineModel, theta: f64, s: f64, t: f64, start: f64) -> f64 {
    let meta = &model.meta;
    let r = meta.radius_mm;
    let omega = meta.omega_rad_per_s();
    // Commanded positions (mm) and velocity signs.
    let (qa, qb) = (r * theta.cos(), r * theta.sin());
    let (va, vb) = (sgn(-s * theta.sin()), sgn(s * theta.cos()));
    let mut lag = [0.0f64; 2];
    let (mut ea, mut eb) = (0.0, 0.0);
    for e in &model.effects {
        let a = e.slot == Slot::A;
        let (q, v, offset) = if a { (qa, va, 0.0) } else { (qb, vb, PI / 2.0) };
        // (own axis error, other axis error)
        let (own, other) = match e.effect {
            Effect::Backlash { b_um } => (-(b_um / 2.0) * v, 0.0),
            Effect::ReversalSpike { h_um, tau_ms } => {
                match last_reversal(theta, s, start, offset, omega) {
                    Some(tr) => (-h_um * v * (-(t - tr) * 1e3 / tau_ms).exp(), 0.0),
                    None => (0.0, 0.0),
                }
            }
            Effect::LateralPlay { p_um } => (0.0, (p_um / 2.0) * v),
            Effect::CyclicError {
                amplitude_um,
                period_mm,
                phase_rad,
            } => (
                amplitude_um * (2.0 * PI * q / period_mm + phase_rad).sin(),
                0.0,
            ),
            Effect::Straightness { bow_um } => (0.0, bow_um * (1.0 - (q / r).powi(2))),
            Effect::ServoMismatch { dt_ms } => {
                lag[0] += dt_ms / 2.0;
                lag[1] -= dt_ms / 2.0;
                (0.0, 0.0)
            }
            Effect::ScaleMismatch { ppm } => {
                ea += ppm / 2.0 * qa * 1e-3;
                eb -= ppm / 2.0 * qb * 1e-3;
                (0.0, 0.0)
            }
            Effect::Squareness { urad } => {
                ea += urad * qb * 1e-3;
                (0.0, 0.0)
            }
            _ => (0.0, 0.0),
        };
        if a {
            ea += own;
            eb += other;
        } else {
            eb += own;
            ea += other;
        }
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
