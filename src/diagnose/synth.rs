//! Synthetic recorded/simulated session pairs for tests and demonstrations of the
//! diagnosis, generated directly from the contract's effect signatures (no wire, no
//! decoder: fast, exact, seeded).
//!
//! A plan moves along X over `lines` (y, z), out (+) and back (−) through the targets in
//! every run (ISO 230-2), dwelling at each target and sampling while moving at a fixed
//! spacing from a random phase, so moving positions are irregular. The environment has
//! realistic histories: the scale warming (exponential approach), the air temperature
//! cycling and drifting, the pressure changing slowly. `simulated` is a smooth geometric
//! error (a few µm polynomial in x, y, z, noiseless); `recorded` adds the hidden effects,
//! Gaussian noise and a constant (the counters' origin), and, when switched on in
//! [`SynthNoise`], what makes real sessions untidy: latch-timing jitter, coloured
//! (time-correlated) noise and occasional outliers ([`SynthNoise::untidy`]).

use crate::base::EffectId;
use crate::base::gaussian;
use crate::base::{Drift, Effect};
use std::f64::consts::TAU;

use errmap_drivers::{Axis, SessionRow, edlen};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::base::HENE_WAVELENGTH_UM;

/// The measurement plan.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthPlan {
    /// Lines: (y, z) of each, mm.
    pub lines_mm: Vec<[f64; 2]>,
    /// Targets along X, mm, increasing.
    pub targets_mm: Vec<f64>,
    /// Runs per line.
    pub runs: u32,
    /// Feeds, mm/s: run k uses `feeds_mm_s[(k − 1) % len]`.
    pub feeds_mm_s: Vec<f64>,
    /// Samples per dwell (0: no dwell rows at all).
    pub dwell_samples: usize,
    /// Interval between dwell samples, s.
    pub dwell_interval_s: f64,
    /// Wait after reaching a target before the first dwell sample, s.
    pub settle_s: f64,
    /// Sample spacing while moving, mm (the timer interval is spacing / feed).
    pub move_spacing_mm: f64,
    /// Pause at every reversal, s.
    pub pause_s: f64,
    /// Positioning repeatability at a target (σ of the dwell position), µm.
    pub positioning_um: f64,
}

impl Default for SynthPlan {
    fn default() -> Self {
        SynthPlan {
            lines_mm: vec![[100.0, 150.0], [400.0, 150.0], [100.0, 450.0]],
            targets_mm: (0..=10).map(|k| f64::from(k) * 80.0).collect(),
            runs: 5,
            feeds_mm_s: vec![50.0, 150.0],
            dwell_samples: 10,
            dwell_interval_s: 0.4,
            settle_s: 1.0,
            move_spacing_mm: 7.0,
            pause_s: 2.0,
            positioning_um: 0.5,
        }
    }
}

/// The environment's histories.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthEnv {
    /// Scale temperature at the start and the end, °C (exponential approach, τ = half
    /// the session).
    pub scale_temp_c: (f64, f64),
    /// Air temperature mean, °C.
    pub air_temp_c: f64,
    /// Air temperature cycle amplitude, K, and period, s.
    pub air_temp_cycle: (f64, f64),
    /// Air temperature drift over the session, K.
    pub air_temp_drift_k: f64,
    /// Pressure mean, hPa.
    pub pressure_hpa: f64,
    /// Pressure change amplitude, hPa, and period, s.
    pub pressure_cycle: (f64, f64),
    /// Relative humidity, %.
    pub rh_pct: f64,
}

impl Default for SynthEnv {
    fn default() -> Self {
        SynthEnv {
            scale_temp_c: (20.3, 21.0),
            air_temp_c: 20.1,
            air_temp_cycle: (0.3, 900.0),
            air_temp_drift_k: 0.2,
            pressure_hpa: 1013.0,
            pressure_cycle: (2.0, 5000.0),
            rh_pct: 45.0,
        }
    }
}

/// The true numeric parameters of a hidden effect by the contract's names, in the
/// variant's order (an Abbe offset's axis is not a number and is left out).
///
/// The synthetic pair hides positioning effects by their contract signatures (t0 = the
/// first row): scale thermal expansion −α·(T_scale − 20)·(x − x0)·1e−3; scale factor
/// k·x·1e−3; Abbe c·(θ0 + θ1·x)·1e−3 with c the line's y or z; reversal d·b/2, or
/// d·(b + b1·(x − x_mid)·1e−3)/2 when it changes along the axis (x_mid: the middle of the
/// targets); latch delay d·v·τ·1e−3 (v = the feed on moving rows, 0 dwelling); periodic
/// a·sin(2πx/P + φ); drift A·(1 − exp(−t/τ)) or ρ·t; dead path −D·(n(t) − n(t0))·1e3;
/// refraction −x·Δn·1e3 with Δn·1e6 = a·(T − T̄) + b·(p − p̄), a coefficient left `None`
/// being a term the effect does not have.
pub fn truth(effect: &Effect) -> Vec<(&'static str, f64)> {
    effect
        .params()
        .into_iter()
        .filter_map(|(n, v)| v.as_f64().map(|x| (n.as_str(), x)))
        .collect()
}

/// Why a synthetic pair cannot hide an effect.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SynthError {
    /// `unexplained` has no positioning signature.
    #[error("a synthetic positioning pair cannot hide `{0}`")]
    Unsupported(EffectId),
    /// The lines run along x: an Abbe offset lies along y or z.
    #[error("an Abbe offset along {0} on lines along x: the offset must lie along y or z")]
    AbbeAxis(crate::base::Axis),
}

/// Refuses what [`generate`] cannot hide, before anything is drawn.
fn check_hidden(hidden: &[Effect]) -> Result<(), SynthError> {
    for h in hidden {
        match *h {
            Effect::Abbe {
                offset_axis: crate::base::Axis::X,
                ..
            } => return Err(SynthError::AbbeAxis(crate::base::Axis::X)),
            Effect::Unexplained { .. } => return Err(SynthError::Unsupported(h.id())),
            Effect::Abbe { .. }
            | Effect::ScaleThermalExpansion { .. }
            | Effect::ScaleFactor { .. }
            | Effect::Reversal { .. }
            | Effect::LatchDelay { .. }
            | Effect::PeriodicScale { .. }
            | Effect::ThermalDrift(_)
            | Effect::DeadPath { .. }
            | Effect::Refraction { .. } => {}
        }
    }
    Ok(())
}

/// The noise of the recording.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthNoise {
    /// σ, µm.
    pub sigma_um: f64,
    /// Factor on σ for moving rows.
    pub moving_factor: f64,
    /// Runs with `noisy_factor` × σ.
    pub noisy_runs: Vec<u32>,
    /// Factor on σ for `noisy_runs`.
    pub noisy_factor: f64,
    /// Latch-timing jitter, µs: each sample is latched up to this much after its tick
    /// (uniform), at the position the carriage has then. 0: none.
    pub jitter_us: f64,
    /// Coloured noise: stationary σ, µm, of an Ornstein–Uhlenbeck process in time
    /// (a random walk that forgets over `coloured_tau_s`). 0: none.
    pub coloured_um: f64,
    /// Correlation time of the coloured noise, s.
    pub coloured_tau_s: f64,
    /// Chance per sample of an outlier. 0: none.
    pub outlier_prob: f64,
    /// One-sigma of an outlier's size, µm.
    pub outlier_um: f64,
}

impl SynthNoise {
    /// The untidy terms of a real session on top of this noise: latch jitter of 20 µs,
    /// coloured noise of 0.05 σ with a 120 s correlation time (below the floor of a named
    /// effect, a tenth of σ), and one sample in 500 an outlier of 20 σ.
    pub fn untidy(self) -> Self {
        SynthNoise {
            jitter_us: 20.0,
            coloured_um: 0.05 * self.sigma_um,
            coloured_tau_s: 120.0,
            outlier_prob: 0.002,
            outlier_um: 20.0 * self.sigma_um,
            ..self
        }
    }
}

impl Default for SynthNoise {
    fn default() -> Self {
        SynthNoise {
            sigma_um: 0.05,
            moving_factor: 1.0,
            noisy_runs: Vec::new(),
            noisy_factor: 1.0,
            jitter_us: 0.0,
            coloured_um: 0.0,
            coloured_tau_s: 60.0,
            outlier_prob: 0.0,
            outlier_um: 0.0,
        }
    }
}

/// Everything that defines a synthetic pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Synth {
    pub plan: SynthPlan,
    pub env: SynthEnv,
    pub hidden: Vec<Effect>,
    pub noise: SynthNoise,
    /// Scale of the geometric error, µm (its peak to peak is about twice this).
    pub geometric_um: f64,
    /// Constant added to the recording (counter origin), µm.
    pub offset_um: f64,
    pub seed: u64,
}

impl Default for Synth {
    fn default() -> Self {
        Synth {
            plan: SynthPlan::default(),
            env: SynthEnv::default(),
            hidden: Vec::new(),
            noise: SynthNoise::default(),
            geometric_um: 5.0,
            offset_um: 1.7,
            seed: 1,
        }
    }
}

/// A generated pair and what is in it.
#[derive(Debug, Clone)]
pub struct SynthOutput {
    pub recorded: Vec<SessionRow>,
    pub simulated: Vec<SessionRow>,
    /// Each hidden effect's contribution per row (same order as `hidden`).
    pub hidden_um: Vec<Vec<f64>>,
    /// Peak to peak of the geometric error, µm.
    pub geometric_pp_um: f64,
}

struct Slot {
    run: u32,
    t: f64,
    x: f64,
    line: usize,
    d: i8,
    target: i32,
    feed: Option<f64>,
}

fn schedule(p: &SynthPlan, rng: &mut StdRng) -> Vec<Slot> {
    let mut s = Vec::new();
    let mut t = 0.0;
    let first = p.targets_mm.first().copied().unwrap_or(0.0);
    // A few samples at home before the first run (run 0).
    for _ in 0..5 {
        s.push(Slot {
            run: 0,
            t,
            x: first,
            line: 0,
            d: 0,
            target: -1,
            feed: None,
        });
        t += 0.2;
    }
    let gauss = |rng: &mut StdRng| -> f64 { gaussian(rng) };
    for line in 0..p.lines_mm.len() {
        if line > 0 {
            t += 10.0;
        }
        for run in 1..=p.runs {
            let feed = p.feeds_mm_s[(run as usize - 1) % p.feeds_mm_s.len().max(1)];
            for (d, order) in [
                (1i8, (0..p.targets_mm.len()).collect::<Vec<_>>()),
                (-1i8, (0..p.targets_mm.len()).rev().collect::<Vec<_>>()),
            ] {
                let mut pos: Option<f64> = None;
                for j in order {
                    let target = p.targets_mm[j];
                    if let Some(x0) = pos {
                        // Move at the feed, sampled every spacing/feed from a random phase.
                        let dt = p.move_spacing_mm / feed;
                        let dur = (target - x0).abs() / feed;
                        let mut tau = rng.random_range(0.0..dt);
                        while tau < dur {
                            let x = x0 + f64::from(d) * feed * tau;
                            s.push(Slot {
                                run,
                                t: t + tau,
                                x,
                                line,
                                d,
                                target: -1,
                                feed: Some(feed),
                            });
                            tau += dt;
                        }
                        t += dur;
                    }
                    pos = Some(target);
                    if p.dwell_samples > 0 {
                        t += p.settle_s;
                        let x = target + p.positioning_um * 1e-3 * gauss(rng);
                        for _ in 0..p.dwell_samples {
                            s.push(Slot {
                                run,
                                t,
                                x,
                                line,
                                d,
                                target: j as i32,
                                feed: Some(feed),
                            });
                            t += p.dwell_interval_s;
                        }
                    }
                }
                t += p.pause_s;
            }
        }
    }
    s
}

/// The session's conditions every row's error is computed from: the scale's warming, the
/// air along the slots (with its refractive index) and the smooth geometric error.
struct Conditions<'a> {
    cfg: &'a Synth,
    /// The session's duration, s (≥ 1).
    total: f64,
    at: Vec<f64>,
    ap: Vec<f64>,
    t_mean: f64,
    p_mean: f64,
    n0: f64,
    /// The geometric polynomial's seeded coefficients.
    g: Vec<f64>,
    xlo: f64,
    xhi: f64,
    xspan: f64,
}

impl<'a> Conditions<'a> {
    /// The air at every slot, then the geometric coefficients drawn from `rng` (after the
    /// schedule's draws, so a seed keeps its pair).
    fn new(cfg: &'a Synth, slots: &[Slot], rng: &mut StdRng) -> Conditions<'a> {
        let n = slots.len();
        let total = slots.last().map_or(1.0, |s| s.t).max(1.0);
        let e = &cfg.env;
        let air_t = |t: f64| {
            e.air_temp_c
                + e.air_temp_cycle.0 * (TAU * t / e.air_temp_cycle.1).sin()
                + e.air_temp_drift_k * (t / total - 0.5)
        };
        let air_p = |t: f64| {
            e.pressure_hpa + e.pressure_cycle.0 * (TAU * t / e.pressure_cycle.1 + 1.0).sin()
        };
        let at: Vec<f64> = slots.iter().map(|s| air_t(s.t)).collect();
        let ap: Vec<f64> = slots.iter().map(|s| air_p(s.t)).collect();
        let t_mean = at.iter().sum::<f64>() / n as f64;
        let p_mean = ap.iter().sum::<f64>() / n as f64;
        let n0 = edlen::refractive_index(HENE_WAVELENGTH_UM, at[0], ap[0] * 100.0, e.rh_pct);
        // Geometric error: a smooth polynomial in x, y, z with seeded coefficients.
        let g: Vec<f64> = (0..7).map(|_| rng.random_range(-1.0..1.0)).collect();
        let (xlo, xhi) = cfg
            .plan
            .targets_mm
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        let xspan = (xhi - xlo).max(1.0);
        Conditions {
            cfg,
            total,
            at,
            ap,
            t_mean,
            p_mean,
            n0,
            g,
            xlo,
            xhi,
            xspan,
        }
    }

    /// The scale temperature at time `t`: an exponential approach over the session.
    fn scale_t(&self, t: f64) -> f64 {
        let e = &self.cfg.env;
        let total = self.total;
        let tau = total / 2.0;
        let f = (1.0 - (-t / tau).exp()) / (1.0 - (-total / tau).exp());
        e.scale_temp_c.0 + (e.scale_temp_c.1 - e.scale_temp_c.0) * f
    }

    /// The air's refractive index at slot `k`.
    fn index(&self, k: usize) -> f64 {
        let e = &self.cfg.env;
        edlen::refractive_index(HENE_WAVELENGTH_UM, self.at[k], self.ap[k] * 100.0, e.rh_pct)
    }

    /// The geometric error at (x, y, z), µm.
    fn geo(&self, x: f64, y: f64, z: f64) -> f64 {
        let g = &self.g;
        let u = (x - self.xlo) / self.xspan;
        self.cfg.geometric_um
            * (4.0 * u * (1.0 - u)
                + (2.0 * u - 1.0)
                + 0.4 * g[0] * (3.0 * u).sin()
                + 0.3 * g[1] * u * u
                + 0.4 * g[2] * y / 500.0
                + 0.4 * g[3] * z / 500.0
                + 0.3 * g[4] * u * y / 500.0
                + 0.3 * g[5] * u * z / 500.0
                + 0.2 * g[6])
    }

    /// Hidden effect `h`'s contribution at slot `k` (`s`), the scale at `ts` °C, µm: each
    /// effect's contract signature.
    fn hidden(&self, h: &Effect, s: &Slot, k: usize, ts: f64) -> f64 {
        let [y, z] = self.cfg.plan.lines_mm[s.line];
        let d = f64::from(s.d);
        let v = if s.target < 0 {
            s.feed.unwrap_or(0.0)
        } else {
            0.0
        };
        let (xlo, xhi, n0) = (self.xlo, self.xhi, self.n0);
        let (at, ap) = (&self.at, &self.ap);
        match *h {
            Effect::ScaleThermalExpansion {
                alpha_ppm_per_k,
                x0_mm,
            } => -alpha_ppm_per_k * (ts - 20.0) * (s.x - x0_mm) * 1e-3,
            Effect::ScaleFactor { ppm } => ppm * s.x * 1e-3,
            Effect::Abbe {
                offset_axis,
                theta0_urad,
                theta1_urad_per_mm,
            } => {
                let c = if offset_axis == crate::base::Axis::Z {
                    z
                } else {
                    y
                };
                c * (theta0_urad + theta1_urad_per_mm * s.x) * 1e-3
            }
            Effect::Reversal {
                b_um,
                b1_um_per_m: None,
            } => d * b_um / 2.0,
            Effect::Reversal {
                b_um,
                b1_um_per_m: Some(b1_um_per_m),
            } => d * (b_um + b1_um_per_m * (s.x - 0.5 * (xlo + xhi)) * 1e-3) / 2.0,
            Effect::LatchDelay { tau_us } => d * v * tau_us * 1e-3,
            Effect::PeriodicScale {
                amplitude_um,
                period_um,
                phase_rad,
            } => amplitude_um * (TAU * s.x * 1000.0 / period_um + phase_rad).sin(),
            Effect::ThermalDrift(Drift::Exponential {
                amplitude_um,
                tau_s,
            }) => amplitude_um * (1.0 - (-s.t / tau_s).exp()),
            Effect::ThermalDrift(Drift::Linear { rate_um_per_s }) => rate_um_per_s * s.t,
            Effect::DeadPath { dead_path_mm } => -dead_path_mm * (self.index(k) - n0) * 1e3,
            Effect::Refraction {
                ppm_per_k,
                ppm_per_hpa,
            } => {
                // A coefficient left out is a term the effect does not have.
                let a = ppm_per_k.unwrap_or(0.0);
                let b = ppm_per_hpa.unwrap_or(0.0);
                let dn = 1e-6 * (a * (at[k] - self.t_mean) + b * (ap[k] - self.p_mean));
                -s.x * dn * 1e3
            }
            // Refused by `check_hidden` before anything was drawn.
            Effect::Unexplained { .. } => 0.0,
        }
    }
}

/// Latch-timing jitter: each slot sampled late by up to `jitter_us`, a moving one further
/// along by the distance travelled meanwhile (draws from the untidy generator).
fn jitter(slots: &mut [Slot], jitter_us: f64, untidy: &mut StdRng) {
    for s in slots {
        let late = untidy.random_range(0.0..jitter_us) * 1e-6;
        s.t += late;
        if s.target < 0 {
            s.x += f64::from(s.d) * s.feed.unwrap_or(0.0) * late;
        }
    }
}

/// The noise σ of slot `s`: the base, times the moving and noisy-run factors.
fn slot_sigma(nz: &SynthNoise, s: &Slot) -> f64 {
    let mut sigma = nz.sigma_um;
    if s.target < 0 {
        sigma *= nz.moving_factor;
    }
    if nz.noisy_runs.contains(&s.run) {
        sigma *= nz.noisy_factor;
    }
    sigma
}

/// Generates the pair; refuses an effect the pair cannot hide.
pub fn generate(cfg: &Synth) -> Result<SynthOutput, SynthError> {
    check_hidden(&cfg.hidden)?;
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let mut slots = schedule(&cfg.plan, &mut rng);
    // The untidy terms draw from their own generator: without them a seed gives the
    // same pair as before they existed.
    let mut untidy = StdRng::seed_from_u64(cfg.seed ^ 0x3c6e_f372_fe94_f82b);
    let nz = &cfg.noise;
    if nz.jitter_us > 0.0 {
        jitter(&mut slots, nz.jitter_us, &mut untidy);
    }
    let n = slots.len();
    let e = &cfg.env;
    let cond = Conditions::new(cfg, &slots, &mut rng);
    let (at, ap) = (&cond.at, &cond.ap);

    let mut hidden_um = vec![vec![0.0; n]; cfg.hidden.len()];
    let mut recorded = Vec::with_capacity(n);
    let mut simulated = Vec::with_capacity(n);
    let gauss = |rng: &mut StdRng| -> f64 { gaussian(rng) };
    let (mut glo, mut ghi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut coloured: Option<(f64, f64)> = None;
    for (k, s) in slots.iter().enumerate() {
        let [y, z] = cfg.plan.lines_mm[s.line];
        let ts = cond.scale_t(s.t);
        let mut h_total = 0.0;
        for (i, h) in cfg.hidden.iter().enumerate() {
            let val = cond.hidden(h, s, k, ts);
            hidden_um[i][k] = val;
            h_total += val;
        }
        let sigma = slot_sigma(&cfg.noise, s);
        let e_geo = cond.geo(s.x, y, z);
        glo = glo.min(e_geo);
        ghi = ghi.max(e_geo);
        let mut e_rec = e_geo + h_total + cfg.offset_um + sigma * gauss(&mut rng);
        if nz.coloured_um > 0.0 {
            let g = gauss(&mut untidy);
            coloured = match coloured {
                None => Some((s.t, nz.coloured_um * g)),
                Some((t0, w0)) => {
                    let a = (-(s.t - t0).max(0.0) / nz.coloured_tau_s.max(1e-9)).exp();
                    Some((s.t, a * w0 + nz.coloured_um * (1.0 - a * a).sqrt() * g))
                }
            };
            e_rec += coloured.map_or(0.0, |c| c.1);
        }
        if nz.outlier_prob > 0.0 && untidy.random_bool(nz.outlier_prob.min(1.0)) {
            e_rec += nz.outlier_um * gauss(&mut untidy);
        }
        let row = |err: f64| SessionRow {
            run: s.run,
            sample: k as i64,
            t_s: s.t,
            axis: Axis::X,
            direction: s.d,
            feed_mm_s: s.feed,
            target: s.target,
            x_mm: Some(s.x),
            y_mm: Some(y),
            z_mm: Some(z),
            scale_mm: s.x,
            laser_mm: s.x - err * 1e-3,
            error_um: err,
            air_temp_c: Some(at[k]),
            air_pressure_hpa: Some(ap[k]),
            air_rh_pct: Some(e.rh_pct),
            scale_temp_c: Some(ts),
            part_temp_c: Some(ts + 0.1),
            flags: 0,
        };
        recorded.push(row(e_rec));
        simulated.push(row(e_geo));
    }
    Ok(SynthOutput {
        recorded,
        simulated,
        hidden_um,
        geometric_pp_um: ghi - glo,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::Axis;

    /// What a positioning pair cannot carry is refused by name before anything is drawn;
    /// what it can is generated with one contribution per effect.
    #[test]
    fn unexplained_and_an_offset_along_the_axis_are_refused() {
        let with = |h: Effect| Synth {
            hidden: vec![h],
            ..Synth::default()
        };
        let e = generate(&with(Effect::Unexplained { rms_um: 1.0 })).expect_err("no signature");
        assert_eq!(e, SynthError::Unsupported(EffectId::Unexplained));
        let abbe = |offset_axis| Effect::Abbe {
            offset_axis,
            theta0_urad: 5.0,
            theta1_urad_per_mm: 0.0,
        };
        let e = generate(&with(abbe(Axis::X))).expect_err("along the axis");
        assert_eq!(e, SynthError::AbbeAxis(Axis::X));
        let out = generate(&with(abbe(Axis::Z))).expect("along z");
        assert_eq!(out.hidden_um.len(), 1);
        // θ0 = 5 µrad over the lines' z offsets: c·θ0·1e−3 µm on every row.
        let lines = SynthPlan::default().lines_mm;
        let zs: Vec<f64> = lines.iter().map(|l| l[1] * 5.0 * 1e-3).collect();
        assert!(
            out.hidden_um[0]
                .iter()
                .all(|v| zs.iter().any(|z| (v - z).abs() < 1e-12)),
            "{:?}",
            &out.hidden_um[0][..5]
        );
    }
}
