//! The effect vocabulary of `docs/vocabulary.md` as regressors.
//!
//! Every effect is linear in its parameters once its one nonlinear parameter (the period of
//! `periodic_scale`, the time constant of an exponential `thermal_drift`) is fixed; the
//! model of r is always a free constant plus the selected effects' columns. Columns are
//! scaled so that their coefficients are the contract's parameters:
//!
//! | effect | variant | columns | coefficients |
//! |---|---|---|---|
//! | `scale_thermal_expansion` | x0 = 0 / x0 free | −ΔT_s·x·1e−3, ΔT_s·1e−3 | α, α·x0 |
//! | `scale_factor` | — | x·1e−3 | k |
//! | `abbe` | θ0, θ1 / θ0 only / θ1 only | c·1e−3, c·x·1e−3 | θ0, θ1 |
//! | `reversal` | constant / linear in x | d/2, d/2·(x − x_mid)·1e−3 | b (at the travel's middle), b1 (µm/m) |
//! | `latch_delay` | v = feed / v measured | d·v·1e−3 | τ |
//! | `periodic_scale` | period P | sin(2πx/P), cos(2πx/P) | a·cos φ, a·sin φ |
//! | `thermal_drift` | exponential τ / linear | 1 − e^(−(t−t0)/τ), t − t0 | A, ρ |
//! | `dead_path` | — | −(n(t) − n(t0))·1e3 | D |
//! | `refraction` | a, b / a only / b only | −x·(T − T̄)·1e−3, −x·(p − p̄)·1e−3 | a, b |
//!
//! [`separation_advice`] names the measurement that would tell two effects apart when these
//! data cannot.

use crate::base::{EffectId, ParamName, ParamName as P};
use std::f64::consts::{PI, TAU};

use super::data::Obs;
use super::engine::Engine;
use super::words::{list, range};

/// An effect of the vocabulary (`Abbe(k)`: offset along the k-th other axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) enum Kind {
    ScaleFactor,
    Reversal,
    Abbe(u8),
    ScaleThermal,
    Refraction,
    DeadPath,
    LatchDelay,
    Periodic,
    ThermalDrift,
}

impl Kind {
    /// The contract's id.
    pub(super) fn id(self) -> EffectId {
        match self {
            Kind::ScaleFactor => EffectId::ScaleFactor,
            Kind::Reversal => EffectId::Reversal,
            Kind::Abbe(_) => EffectId::Abbe,
            Kind::ScaleThermal => EffectId::ScaleThermalExpansion,
            Kind::Refraction => EffectId::Refraction,
            Kind::DeadPath => EffectId::DeadPath,
            Kind::LatchDelay => EffectId::LatchDelay,
            Kind::Periodic => EffectId::PeriodicScale,
            Kind::ThermalDrift => EffectId::ThermalDrift,
        }
    }

    /// The id with the Abbe offset axis, for messages.
    pub(super) fn label(self, obs: &Obs) -> String {
        super::outcome::effect_label(self.id(), self.offset_axis(obs))
    }

    /// The axis an Abbe term's offset lies along (`None` for every other effect).
    pub(super) fn offset_axis(self, obs: &Obs) -> Option<crate::base::Axis> {
        match self {
            Kind::Abbe(k) => Some(obs.c_axes[k as usize]),
            _ => None,
        }
    }

    /// Rank among effects that fit the data equally well: the explanation that needs
    /// fewer assumptions or covariates comes first (a pitch error before a temperature
    /// effect, a direction-only offset before one that needs the feed, a measured
    /// covariate before a free function of time).
    pub(super) fn preference(self) -> u8 {
        match self {
            Kind::ScaleFactor => 0,
            Kind::Reversal => 1,
            Kind::Abbe(k) => 2 + k,
            Kind::ScaleThermal => 4,
            Kind::Refraction => 5,
            Kind::DeadPath => 6,
            Kind::LatchDelay => 7,
            Kind::Periodic => 8,
            Kind::ThermalDrift => 9,
        }
    }

    /// What the effect's signature follows, in words.
    pub(super) fn follows(self, obs: &Obs) -> String {
        match self {
            Kind::ScaleFactor => "x (proportional to position)".into(),
            Kind::Reversal => "the direction of travel".into(),
            Kind::Abbe(k) => format!(
                "the line offset {c} and {c}·x",
                c = obs.c_axes[k as usize].lower()
            ),
            Kind::ScaleThermal => "the scale temperature times position, ΔT_scale·x".into(),
            Kind::Refraction => "position times the air temperature and pressure changes".into(),
            Kind::DeadPath => {
                "the air refractive index (air temperature, pressure, humidity)".into()
            }
            Kind::LatchDelay => "direction × speed on moving samples".into(),
            Kind::Periodic => "the phase of x within a short period".into(),
            Kind::ThermalDrift => "time".into(),
        }
    }
}

/// How an effect is parametrised in one fit.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Variant {
    Single,
    /// Reversal linear in position about the middle of the travel.
    ReversalLinear,
    X0Fixed,
    X0Free,
    AbbeFull,
    AbbeTheta0,
    AbbeTheta1,
    LatchFeed,
    LatchMeasured,
    RefrBoth,
    RefrT,
    RefrP,
    DriftExp {
        tau_s: f64,
    },
    DriftLinear,
    Periodic {
        period_um: f64,
    },
}

impl Variant {
    /// Number of nonlinear parameters.
    pub(super) fn nonlinear(&self) -> usize {
        usize::from(matches!(
            self,
            Variant::DriftExp { .. } | Variant::Periodic { .. }
        ))
    }
}

/// Registered static columns (None: not testable on these data).
#[derive(Debug, Clone)]
pub(crate) struct Columns {
    pub x: usize,
    pub ste_x: Option<usize>,
    pub ste_1: Option<usize>,
    pub c: [Option<usize>; 2],
    pub cx: [Option<usize>; 2],
    pub d: Option<usize>,
    /// d/2·(x − x_mid)·1e−3: a reversal that changes along the axis.
    pub d_x: Option<usize>,
    pub dv_feed: Option<usize>,
    pub dv_meas: Option<usize>,
    pub t_lin: Option<usize>,
    pub dn: Option<usize>,
    pub x_dt: Option<usize>,
    pub x_dp: Option<usize>,
    /// Why effects cannot be tested, in words.
    pub untestable: Vec<String>,
}

fn spread(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    if hi >= lo { hi - lo } else { 0.0 }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Δn·1e6 relative to the first row in time, from the Edlén equation at every row's air.
pub(crate) fn index_change_ppm(obs: &Obs, lambda_um: f64) -> Option<Vec<f64>> {
    let (at, ap) = (obs.air_t.as_ref()?, obs.air_p.as_ref()?);
    let rh = |k: usize| obs.air_rh.as_ref().map_or(50.0, |v| v[k]);
    let n: Vec<f64> = (0..obs.len())
        .map(|k| errmap_drivers::edlen::refractive_index(lambda_um, at[k], ap[k] * 100.0, rh(k)))
        .collect();
    let first = (0..obs.len()).min_by(|&a, &b| obs.t[a].total_cmp(&obs.t[b]))?;
    let n0 = n[first];
    Some(n.iter().map(|v| (v - n0) * 1e6).collect())
}

/// Registers the static columns an effect can use.
pub(crate) fn register(engine: &mut Engine, obs: &Obs, lambda_um: f64) -> Columns {
    let n = obs.len();
    let mut untestable = Vec::new();
    let x = engine.add(obs.x.iter().map(|x| x * 1e-3).collect());
    let varies = |v: &[f64], tol: f64| spread(v) > tol;

    let (ste_x, ste_1) = match &obs.scale_t {
        Some(ts) => {
            let dt: Vec<f64> = ts.iter().map(|t| t - 20.0).collect();
            let a = engine.add((0..n).map(|k| -dt[k] * obs.x[k] * 1e-3).collect());
            let b = varies(&dt, 1e-9).then(|| engine.add(dt.iter().map(|v| v * 1e-3).collect()));
            (Some(a), b)
        }
        None => {
            untestable.push(
                "scale_thermal_expansion: no scale temperature (scale_temp_c) in the recording"
                    .into(),
            );
            (None, None)
        }
    };

    let mut c = [None, None];
    let mut cx = [None, None];
    for k in 0..2 {
        match &obs.c[k] {
            Some(cv) if varies(cv, 1e-9) || cv.iter().any(|v| *v != 0.0) => {
                c[k] = Some(engine.add(cv.iter().map(|v| v * 1e-3).collect()));
                cx[k] = Some(engine.add((0..n).map(|i| cv[i] * obs.x[i] * 1e-3).collect()));
            }
            Some(_) => untestable.push(format!(
                "abbe along {}: every line is at {} = 0, so no offset acts",
                obs.c_axes[k].lower(),
                obs.c_axes[k].lower()
            )),
            None => untestable.push(format!(
                "abbe along {}: the {} coordinate is missing on more than 5 % of the rows",
                obs.c_axes[k].lower(),
                obs.c_axes[k].lower()
            )),
        }
    }

    let d = obs
        .d
        .iter()
        .any(|v| *v != 0.0)
        .then(|| engine.add(obs.d.iter().map(|d| d / 2.0).collect()));
    if d.is_none() {
        untestable.push("reversal, latch_delay: no row has a direction of travel".into());
    }
    let x_mid = reversal_centre_mm(obs);
    let d_x = d.and_then(|_| {
        varies(&obs.x, 1e-6).then(|| {
            engine.add(
                (0..n)
                    .map(|k| obs.d[k] / 2.0 * (obs.x[k] - x_mid) * 1e-3)
                    .collect(),
            )
        })
    });
    let any_moving = obs
        .v_feed
        .iter()
        .zip(&obs.d)
        .any(|(v, d)| *v > 0.0 && *d != 0.0);
    let (dv_feed, dv_meas) = if any_moving {
        let f = engine.add((0..n).map(|k| obs.d[k] * obs.v_feed[k] * 1e-3).collect());
        let m = engine.add((0..n).map(|k| obs.d[k] * obs.v_meas[k] * 1e-3).collect());
        (Some(f), Some(m))
    } else {
        untestable.push("latch_delay: no moving samples with a feed".into());
        (None, None)
    };
    let t_lin =
        varies(&obs.t, 1e-9).then(|| engine.add(obs.t.iter().map(|t| t - obs.t0).collect()));

    let dn = match index_change_ppm(obs, lambda_um) {
        Some(dn) if varies(&dn, 1e-6) => Some(engine.add(dn.iter().map(|v| -v * 1e-3).collect())),
        Some(_) => {
            untestable.push("dead_path: the air refractive index did not change".into());
            None
        }
        None => {
            untestable
                .push("dead_path, refraction: no air temperature/pressure in the recording".into());
            None
        }
    };
    let x_dt = obs.air_t.as_ref().and_then(|at| {
        let m = mean(at);
        varies(at, 1e-6)
            .then(|| engine.add((0..n).map(|k| -obs.x[k] * (at[k] - m) * 1e-3).collect()))
    });
    let x_dp = obs.air_p.as_ref().and_then(|ap| {
        let m = mean(ap);
        varies(ap, 1e-6)
            .then(|| engine.add((0..n).map(|k| -obs.x[k] * (ap[k] - m) * 1e-3).collect()))
    });
    if obs.air_t.is_some() && x_dt.is_none() && x_dp.is_none() {
        untestable.push("refraction: air temperature and pressure did not change".into());
    }
    Columns {
        x,
        ste_x,
        ste_1,
        c,
        cx,
        d,
        d_x,
        dv_feed,
        dv_meas,
        t_lin,
        dn,
        x_dt,
        x_dp,
        untestable,
    }
}

/// The kinds testable on these columns (periodic and drift need only x and t).
pub(crate) fn kinds(cols: &Columns) -> Vec<Kind> {
    let mut k = vec![Kind::ScaleFactor];
    if cols.d.is_some() {
        k.push(Kind::Reversal);
    }
    for a in 0..2u8 {
        if cols.c[a as usize].is_some() {
            k.push(Kind::Abbe(a));
        }
    }
    if cols.ste_x.is_some() {
        k.push(Kind::ScaleThermal);
    }
    if cols.x_dt.is_some() || cols.x_dp.is_some() {
        k.push(Kind::Refraction);
    }
    if cols.dn.is_some() {
        k.push(Kind::DeadPath);
    }
    if cols.dv_feed.is_some() {
        k.push(Kind::LatchDelay);
    }
    k.push(Kind::Periodic);
    if cols.t_lin.is_some() {
        k.push(Kind::ThermalDrift);
    }
    k
}

/// The variants of a kind made of registered columns (the dynamic ones — periodic, the
/// exponential drift — are built by the selection).
pub(crate) fn static_variants(kind: Kind, cols: &Columns) -> Vec<(Variant, Vec<usize>)> {
    let mut v = Vec::new();
    match kind {
        Kind::ScaleFactor => v.push((Variant::Single, vec![cols.x])),
        Kind::Reversal => {
            if let Some(d) = cols.d {
                v.push((Variant::Single, vec![d]));
                if let Some(dx) = cols.d_x {
                    v.push((Variant::ReversalLinear, vec![d, dx]));
                }
            }
        }
        Kind::Abbe(a) => {
            let a = a as usize;
            if let (Some(c), Some(cx)) = (cols.c[a], cols.cx[a]) {
                v.push((Variant::AbbeFull, vec![c, cx]));
                v.push((Variant::AbbeTheta0, vec![c]));
                v.push((Variant::AbbeTheta1, vec![cx]));
            }
        }
        Kind::ScaleThermal => {
            if let Some(sx) = cols.ste_x {
                v.push((Variant::X0Fixed, vec![sx]));
                if let Some(s1) = cols.ste_1 {
                    v.push((Variant::X0Free, vec![sx, s1]));
                }
            }
        }
        Kind::Refraction => match (cols.x_dt, cols.x_dp) {
            (Some(a), Some(b)) => {
                v.push((Variant::RefrBoth, vec![a, b]));
                v.push((Variant::RefrT, vec![a]));
                v.push((Variant::RefrP, vec![b]));
            }
            (Some(a), None) => v.push((Variant::RefrT, vec![a])),
            (None, Some(b)) => v.push((Variant::RefrP, vec![b])),
            (None, None) => {}
        },
        Kind::DeadPath => {
            if let Some(d) = cols.dn {
                v.push((Variant::Single, vec![d]));
            }
        }
        Kind::LatchDelay => {
            if let Some(f) = cols.dv_feed {
                v.push((Variant::LatchFeed, vec![f]));
            }
            if let Some(m) = cols.dv_meas {
                v.push((Variant::LatchMeasured, vec![m]));
            }
        }
        Kind::ThermalDrift => {
            if let Some(t) = cols.t_lin {
                v.push((Variant::DriftLinear, vec![t]));
            }
        }
        Kind::Periodic => {}
    }
    v
}

/// The position about which a position-dependent reversal is expanded: the middle of the
/// recorded travel, mm (so `b_um` is the reversal there, the mean over the axis).
pub(crate) fn reversal_centre_mm(obs: &Obs) -> f64 {
    let (lo, hi) = range(&obs.x);
    if hi >= lo { 0.5 * (lo + hi) } else { 0.0 }
}

/// sin and cos columns of a period (µm) over x (mm).
pub(crate) fn periodic_cols(x_mm: &[f64], period_um: f64) -> [Vec<f64>; 2] {
    let w = TAU * 1000.0 / period_um;
    let mut s = Vec::with_capacity(x_mm.len());
    let mut c = Vec::with_capacity(x_mm.len());
    for &x in x_mm {
        let (a, b) = (w * x).sin_cos();
        s.push(a);
        c.push(b);
    }
    [s, c]
}

/// 1 − exp(−(t − t0)/τ).
pub(crate) fn drift_col(t: &[f64], t0: f64, tau_s: f64) -> Vec<f64> {
    t.iter().map(|t| 1.0 - (-(t - t0) / tau_s).exp()).collect()
}

/// Derivative of the term's contribution with respect to its nonlinear parameter.
pub(crate) fn nonlinear_derivative(variant: &Variant, coef: &[f64], obs: &Obs) -> Option<Vec<f64>> {
    match *variant {
        Variant::Periodic { period_um } => {
            let w = TAU * 1000.0 / period_um;
            let (s, c) = (coef[0], coef[1]);
            Some(
                obs.x
                    .iter()
                    .map(|&x| {
                        let (sn, cs) = (w * x).sin_cos();
                        (s * cs - c * sn) * x * (-w / period_um)
                    })
                    .collect(),
            )
        }
        Variant::DriftExp { tau_s } => {
            let a = coef[0];
            Some(
                obs.t
                    .iter()
                    .map(|&t| {
                        let s = t - obs.t0;
                        -a * (-s / tau_s).exp() * s / (tau_s * tau_s)
                    })
                    .collect(),
            )
        }
        _ => None,
    }
}

/// One reported parameter.
#[derive(Debug, Clone)]
pub(crate) struct Param {
    pub name: ParamName,
    pub value: f64,
    pub sigma: f64,
    /// Fitted (false: fixed by the chosen variant, e.g. x0 = 0).
    pub fitted: bool,
    /// Subject to the determinedness rule.
    pub key: bool,
}

fn p(name: ParamName, value: f64, sigma: f64, key: bool) -> Param {
    Param {
        name,
        value,
        sigma,
        fitted: true,
        key,
    }
}

fn fixed(name: ParamName) -> Param {
    Param {
        name,
        value: 0.0,
        sigma: 0.0,
        fitted: false,
        key: false,
    }
}

/// Wraps a phase to (−π, π].
pub(crate) fn wrap(phi: f64) -> f64 {
    let mut p = phi.rem_euclid(TAU);
    if p > PI {
        p -= TAU;
    }
    p
}

/// The contract's parameters from the term's parameter vector θ = (linear coefficients in
/// column order, then the nonlinear parameter) and its covariance (delta method for the
/// derived ones).
pub(crate) fn params(kind: Kind, variant: &Variant, th: &[f64], cov: &[Vec<f64>]) -> Vec<Param> {
    let sd = |i: usize| cov[i][i].max(0.0).sqrt();
    match (kind, variant) {
        (Kind::ScaleFactor, _) => vec![p(P::Ppm, th[0], sd(0), true)],
        (Kind::Reversal, Variant::ReversalLinear) => vec![
            p(P::BUm, th[0], sd(0), true),
            p(P::B1UmPerM, th[1], sd(1), true),
        ],
        (Kind::Reversal, _) => vec![p(P::BUm, th[0], sd(0), true)],
        (Kind::Abbe(_), Variant::AbbeFull) => vec![
            p(P::Theta0Urad, th[0], sd(0), true),
            p(P::Theta1UradPerMm, th[1], sd(1), true),
        ],
        (Kind::Abbe(_), Variant::AbbeTheta0) => {
            vec![
                p(P::Theta0Urad, th[0], sd(0), true),
                fixed(P::Theta1UradPerMm),
            ]
        }
        (Kind::Abbe(_), _) => {
            vec![
                fixed(P::Theta0Urad),
                p(P::Theta1UradPerMm, th[0], sd(0), true),
            ]
        }
        (Kind::ScaleThermal, Variant::X0Free) => {
            let (a, b) = (th[0], th[1]);
            let x0 = b / a;
            // x0 = b/a: gradient (−b/a², 1/a).
            let (ga, gb) = (-b / (a * a), 1.0 / a);
            let var = ga * ga * cov[0][0] + 2.0 * ga * gb * cov[0][1] + gb * gb * cov[1][1];
            vec![
                p(P::AlphaPpmPerK, a, sd(0), true),
                p(P::X0Mm, x0, var.max(0.0).sqrt(), true),
            ]
        }
        (Kind::ScaleThermal, _) => vec![p(P::AlphaPpmPerK, th[0], sd(0), true), fixed(P::X0Mm)],
        (Kind::LatchDelay, _) => vec![p(P::TauUs, th[0], sd(0), true)],
        (Kind::Periodic, Variant::Periodic { period_um }) => {
            let (s, c) = (th[0], th[1]);
            let a = s.hypot(c).max(1e-300);
            let (gas, gac) = (s / a, c / a);
            let va = gas * gas * cov[0][0] + 2.0 * gas * gac * cov[0][1] + gac * gac * cov[1][1];
            let (gps, gpc) = (-c / (a * a), s / (a * a));
            let vp = gps * gps * cov[0][0] + 2.0 * gps * gpc * cov[0][1] + gpc * gpc * cov[1][1];
            vec![
                p(P::AmplitudeUm, a, va.max(0.0).sqrt(), true),
                p(P::PeriodUm, *period_um, sd(2), false),
                p(P::PhaseRad, wrap(c.atan2(s)), vp.max(0.0).sqrt(), false),
            ]
        }
        (Kind::ThermalDrift, Variant::DriftExp { tau_s }) => vec![
            p(P::AmplitudeUm, th[0], sd(0), true),
            p(P::TauS, *tau_s, sd(1), true),
        ],
        (Kind::ThermalDrift, _) => vec![p(P::RateUmPerS, th[0], sd(0), true)],
        (Kind::DeadPath, _) => vec![p(P::DeadPathMm, th[0], sd(0), true)],
        (Kind::Refraction, Variant::RefrBoth) => vec![
            p(P::PpmPerK, th[0], sd(0), true),
            p(P::PpmPerHpa, th[1], sd(1), true),
        ],
        (Kind::Refraction, Variant::RefrT) => vec![p(P::PpmPerK, th[0], sd(0), true)],
        (Kind::Refraction, _) => vec![p(P::PpmPerHpa, th[0], sd(0), true)],
        (Kind::Periodic, _) => Vec::new(),
    }
}

/// Whether every key parameter is determined: one-sigma ≤ `rel` × |value|. Returns the
/// first undetermined one.
pub(crate) fn undetermined(params: &[Param], rel: f64) -> Option<&Param> {
    params
        .iter()
        .find(|p| p.key && p.fitted && !(p.sigma.is_finite() && p.sigma <= rel * p.value.abs()))
}

/// A fitted parameter outside what the effect's physics allows, in words: the fixed point
/// x0 of a scale must lie on the axis or near it (within one axis length beyond either
/// end); farther out, "α·ΔT·(x − x0)" is really a pure function of the scale temperature
/// in time, which thermal expansion of the scale cannot produce.
pub(crate) fn implausible(kind: Kind, params: &[Param], obs: &Obs) -> Option<String> {
    if kind != Kind::ScaleThermal {
        return None;
    }
    let x0 = params.iter().find(|p| p.name == P::X0Mm && p.fitted)?;
    let (lo, hi) = obs
        .x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let len = (hi - lo).max(1.0);
    (x0.value < lo - len || x0.value > hi + len).then(|| {
        format!(
            "x0 = {:.0} mm lies far outside the axis ({}–{} mm): not a fixed point of the scale",
            x0.value,
            super::fixed(lo, 0),
            super::fixed(hi, 0)
        )
    })
}

/// The parameter each linear coefficient of a variant stands for, then the nonlinear one
/// (for correlation statements; `amplitude_um` for both sine and cosine coefficients).
pub(crate) fn coef_names(kind: Kind, variant: &Variant) -> Vec<ParamName> {
    match (kind, variant) {
        (Kind::ScaleFactor, _) => vec![P::Ppm],
        (Kind::Reversal, Variant::ReversalLinear) => vec![P::BUm, P::B1UmPerM],
        (Kind::Reversal, _) => vec![P::BUm],
        (Kind::Abbe(_), Variant::AbbeFull) => vec![P::Theta0Urad, P::Theta1UradPerMm],
        (Kind::Abbe(_), Variant::AbbeTheta0) => vec![P::Theta0Urad],
        (Kind::Abbe(_), _) => vec![P::Theta1UradPerMm],
        (Kind::ScaleThermal, Variant::X0Free) => vec![P::AlphaPpmPerK, P::X0Mm],
        (Kind::ScaleThermal, _) => vec![P::AlphaPpmPerK],
        (Kind::LatchDelay, _) => vec![P::TauUs],
        (Kind::Periodic, _) => vec![P::AmplitudeUm, P::AmplitudeUm, P::PeriodUm],
        (Kind::ThermalDrift, Variant::DriftExp { .. }) => vec![P::AmplitudeUm, P::TauS],
        (Kind::ThermalDrift, _) => vec![P::RateUmPerS],
        (Kind::DeadPath, _) => vec![P::DeadPathMm],
        (Kind::Refraction, Variant::RefrBoth) => vec![P::PpmPerK, P::PpmPerHpa],
        (Kind::Refraction, Variant::RefrT) => vec![P::PpmPerK],
        (Kind::Refraction, _) => vec![P::PpmPerHpa],
    }
}

/// The measurement that would separate two effects, with this data set's reason.
pub(crate) fn separation_advice(a: Kind, b: Kind, obs: &Obs) -> String {
    use Kind::*;
    let pair = |p: Kind, q: Kind| (a == p && b == q) || (a == q && b == p);
    let feeds: Vec<f64> = (0..obs.len())
        .filter(|&k| obs.moving[k] && obs.v_feed[k] > 0.0)
        .map(|k| obs.v_feed[k])
        .collect();
    let dwell = obs.moving.iter().filter(|m| !**m).count();
    if pair(ScaleThermal, ScaleFactor) {
        let (lo, hi) = obs.scale_t.as_deref().map_or((f64::NAN, f64::NAN), range);
        return format!(
            "the scale temperature stayed within {lo:.2}–{hi:.2} °C, so α·ΔT acts like a constant pitch error; repeat the measurement with the scale at another temperature (ΔT_scale must change)"
        );
    }
    if pair(LatchDelay, Reversal) {
        return format!(
            "the moving samples were taken at {} and {}, so d·v·τ is a constant times d; measure at a second feed or latch samples while dwelling",
            list(&feeds, "mm/s"),
            if dwell == 0 {
                "there are no dwell samples".to_string()
            } else {
                format!("only {dwell} dwell samples")
            }
        );
    }
    if let (Abbe(i), ScaleFactor) | (ScaleFactor, Abbe(i)) = (a, b) {
        let c = obs.c_axes[i as usize].lower();
        let vals: Vec<f64> = obs.lines.iter().map(|l| l[i as usize]).collect();
        return format!(
            "the lines lie at {c} = {}, so c·θ(x) is a constant plus a term in x alone; measure a second line at another {c}",
            list(&vals, "mm")
        );
    }
    if let (Abbe(_), Abbe(_)) = (a, b) {
        return format!(
            "the lines' {} and {} offsets change together; measure lines that differ in {} only and in {} only",
            obs.c_axes[0].lower(),
            obs.c_axes[1].lower(),
            obs.c_axes[0].lower(),
            obs.c_axes[1].lower()
        );
    }
    if let (Abbe(i), _) | (_, Abbe(i)) = (a, b) {
        let c = obs.c_axes[i as usize].lower();
        return format!(
            "measure more lines at other {c} offsets, so the line-to-line pattern is unique"
        );
    }
    if pair(Refraction, ScaleThermal) {
        return "the air and scale temperatures changed together; record a session where they change independently (e.g. the scale warmed while the room is steady)".into();
    }
    if pair(DeadPath, ThermalDrift) {
        return "dwell at the laser's zero point with the retroreflector at the interferometer (dead path about 0) for as long as the session: a residual that still follows time is a drift; or repeat with the air cycling instead of drifting".into();
    }
    if pair(Refraction, ThermalDrift) || pair(ScaleThermal, ThermalDrift) {
        return "the temperature and the time trend move together; repeat with the machine warmed up (drift gone) or with the air/scale temperature changing at another pace".into();
    }
    if pair(DeadPath, Refraction) || pair(Refraction, ScaleFactor) || pair(DeadPath, Reversal) {
        return "let the air change more (pressure and temperature independently) or measure with a known dead path".into();
    }
    format!(
        "{} follows {} and {} follows {}; a measurement in which these vary independently would separate them",
        a.id(),
        a.follows(obs),
        b.id(),
        b.follows(obs)
    )
}

/// The measurement that separates two effects, as a plan file (TOML in the form of
/// `sim::PlanSpec`, which the simulator and `errmap plan` read), when there is one.
/// Dead path against thermal drift: a dwell at the laser's zero point (where the first
/// row was taken) for as long as the session, with the retroreflector moved up to the
/// interferometer so that the dead path is about zero: a residual that still follows
/// time is a drift of the machine, one that is gone was the dead path.
pub(crate) fn separation_plan(obs: &Obs, a: Kind, b: Kind) -> Option<String> {
    let pair = |p: Kind, q: Kind| (a == p && b == q) || (a == q && b == p);
    if !pair(Kind::DeadPath, Kind::ThermalDrift) {
        return None;
    }
    let first = (0..obs.len()).min_by(|&i, &j| obs.t[i].total_cmp(&obs.t[j]))?;
    let x_ref = obs.x[first].max(0.0);
    let line = obs
        .lines
        .get(obs.line[first])
        .copied()
        .unwrap_or([0.0, 0.0]);
    let (tlo, thi) = range(&obs.t);
    let duration = (thi - tlo).max(600.0).ceil();
    let feed = obs
        .v_feed
        .iter()
        .copied()
        .find(|v| *v > 0.0)
        .unwrap_or(50.0);
    Some(format!(
        "# errmap diagnose: the measurement that separates dead_path from thermal_drift.\n\
         # Move the retroreflector up to the interferometer (dead path about 0), zero the\n\
         # laser there at {axis} = {x_ref} mm, and dwell for as long as the diagnosed session\n\
         # ({duration} s) while the air is recorded as before. A residual that still follows\n\
         # time is a drift of the machine; one that is gone was the dead path. (A repeat of\n\
         # the session with the air cycling, not drifting, separates them too.)\n\
         axis = \"{axis}\"\n\
         lines_mm = [[{y}, {z}]]\n\
         targets_mm = [{x_ref}]\n\
         runs = 1\n\
         feed_mm_s = {feed}\n\
         dwell_s = {duration}\n\
         sample_hz = 2.0\n",
        axis = super::data::axis_label(obs.axis),
        y = line[0],
        z = line[1],
    ))
}
