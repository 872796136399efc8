//! The concealed artefact campaign (issue 36 item 3): seeded random CMMs whose components
//! are a cubic trend plus local bumps and dips (what a cubic basis cannot hold), a 5 × 5
//! ball plate with random errors, the example's eight positions, 0.2 µm probing noise.
//! Three campaigns on the same kind of machine:
//! - **calibrated plate**: the plate's certificate is its truth plus an error drawn from
//!   the certificate's own uncertainty; the 21 components are compared, in the
//!   volumetric gauge, with the machine's truth: hit rate and σ coverage;
//! - **rigid machines**: no error at all, a random plate, its certificate as above — the
//!   residual test must raise no alarm;
//! - **self-calibration**: the same plate without a certificate; its deviations must be
//!   recovered up to what the named invariants leave open.
//!
//! The identification is the library's (`errmap::artefact::identify`), the same as the
//! command's; the figures are printed (`--nocapture`) and quoted in docs/artefact.md.

use std::path::Path;

use errmap::artefact::{
    ArtefactIdentification, Campaign, IdentifyOptions, MeasuredFeature, Measurement, identify,
    simulate,
};
use errmap::interp::{Method, MethodName, MethodSettings};
use errmap::volumetric::{Component, ComponentFn, GaugeTruth, Machine, Predictor, Topology};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use super::identify::{campaign, eight};
use crate::util::tempdir;

const SIGMA_UM: f64 = 0.2;
/// The certificate's expanded uncertainty (k = 2), µm.
const U_CERT_UM: f64 = 0.6;

/// A component: a cubic trend of amplitude `amp` over `len` plus up to two Gaussian
/// bumps or dips 150–300 mm wide and 0.2–0.8 (µm or µrad) high, zero at 0, tabulated
/// every 2 mm.
fn local_component(rng: &mut StdRng, len: f64, amp: f64) -> ComponentFn {
    let trend: [f64; 3] = [0, 1, 2].map(|_| amp * rng.random_range(-1.0..1.0));
    let bumps: Vec<[f64; 3]> = (0..rng.random_range(0..=2))
        .map(|_| {
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            [
                rng.random_range(0.15 * len..0.85 * len),
                rng.random_range(150.0..300.0),
                sign * rng.random_range(0.2..0.8),
            ]
        })
        .collect();
    let f = |a: f64| {
        let xi = a / len;
        let t = xi * (trend[0] + xi * (trend[1] + xi * trend[2]));
        let b: f64 = bumps
            .iter()
            .map(|[c, w, h]| h * (-0.5 * ((a - c) / (0.25 * w)).powi(2)).exp())
            .sum();
        t + b
    };
    let f0 = f(0.0);
    let positions: Vec<f64> = (-100..=700).map(|i| 2.0 * f64::from(i)).collect();
    let values: Vec<f64> = positions.iter().map(|&a| f(a) - f0).collect();
    let method = Method::from_name(MethodName::Trilinear, None, &MethodSettings::default())
        .expect("trilinear");
    ComponentFn::table(&positions, &values, method).expect("table")
}

/// A random YXZ CMM (1100 × 900 × 750 mm of travel).
fn random_machine(rng: &mut StdRng) -> Machine {
    let travel = [1100.0, 900.0, 750.0];
    let mut m = Machine::perfect(yxz());
    for c in Component::all() {
        let amp = if c.is_straightness() { 1.0 } else { 2.5 };
        m.set(c, local_component(rng, travel[c.axis], amp));
    }
    m.squareness_urad = [0, 1, 2].map(|_| rng.random_range(-10.0..10.0));
    m
}

/// The example plate (5 × 5 balls, 100 mm pitch) with random errors: returns the plate's
/// truth (certificate coordinates = actual ones) and the true deviations, µm.
fn random_plate(rng: &mut StdRng, template: &Campaign) -> (Campaign, Vec<[f64; 3]>) {
    let mut c = template.clone();
    let mut dev = Vec::new();
    for f in &mut c.artefacts[0].features {
        let d = [0, 1, 2].map(|_| rng.random_range(-1.0..1.0));
        f.certificate_mm = Some([0, 1, 2].map(|k| f.nominal_mm[k] + 1e-3 * d[k]));
        f.u_um = Some(U_CERT_UM);
        dev.push(d);
    }
    (c, dev)
}

/// The plate as identify is told it: its certificate off the truth by an error drawn
/// from the certificate's uncertainty (`certified`), or no certificate at all.
fn as_told(rng: &mut StdRng, truth: &Campaign, certified: bool) -> Campaign {
    let mut c = truth.clone();
    for f in &mut c.artefacts[0].features {
        if certified {
            let told = f.certificate_mm.expect("truth is certified");
            f.certificate_mm = Some(told.map(|v| v + 1e-3 * 0.5 * U_CERT_UM * gaussian(rng)));
        } else {
            f.certificate_mm = None;
            f.u_um = None;
        }
    }
    c
}

fn yxz() -> Topology {
    crate::volumetric::topo("YXZ")
}

fn gaussian(rng: &mut StdRng) -> f64 {
    // Box–Muller.
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Simulates `truth` on `machine` and identifies the measurements as `told`.
fn run(
    machine: &Predictor,
    truth: &Campaign,
    told: &Campaign,
    seed: u64,
    self_calibrate: bool,
) -> (ArtefactIdentification, serde_json::Value) {
    let files = simulate(truth, machine, SIGMA_UM, seed).expect("simulate");
    let meas: Vec<Measurement> = files
        .iter()
        .map(|f| Measurement {
            path: f.name.clone().into(),
            rows: f
                .rows
                .iter()
                .enumerate()
                .map(|(i, (_, x))| MeasuredFeature {
                    feature: i,
                    row: i + 1,
                    x_mm: *x,
                    has_z: true,
                })
                .collect(),
        })
        .collect();
    let opts = IdentifyOptions {
        topology: yxz(),
        self_calibrate,
        positions: 11,
    };
    let id = identify(told, &meas, &opts).expect("identify");
    let v = serde_json::to_value(id.doc(11)).expect("json");
    (id, v)
}

/// The comparison of identified components with the truth. A component is
/// *detectable* when the truth's RMS over the report positions exceeds twice the RMS of
/// its one-sigma there, and a detectable component is a *hit* when the RMS of
/// estimate − truth is at most half the truth's RMS. Coverage counts every report
/// position (but 0, where the gauge fixes the value).
#[derive(Default)]
struct Tally {
    hits: usize,
    detectable: usize,
    components: usize,
    within1: usize,
    within2: usize,
    points: usize,
}

impl Tally {
    fn add(&mut self, pairs: &[(f64, f64, f64)]) {
        self.components += 1;
        if pairs.is_empty() {
            return;
        }
        let n = pairs.len() as f64;
        let rms = |f: &dyn Fn(&(f64, f64, f64)) -> f64| {
            (pairs.iter().map(|p| f(p).powi(2)).sum::<f64>() / n).sqrt()
        };
        let err = rms(&|(e, t, _)| e - t);
        let size = rms(&|(_, t, _)| *t);
        let sigma = rms(&|(_, _, s)| *s);
        if size > 2.0 * sigma {
            self.detectable += 1;
            self.hits += usize::from(err <= 0.5 * size);
        }
        for (e, t, s) in pairs {
            if *s <= 0.0 {
                continue;
            }
            self.points += 1;
            self.within1 += usize::from((e - t).abs() <= *s);
            self.within2 += usize::from((e - t).abs() <= 2.0 * s);
        }
    }
}

/// Compares every component of `v` with the machine's truth in the gauge.
fn tally(v: &serde_json::Value, m: &Machine, t: &mut Tally) {
    let range = [0, 1, 2].map(|a| {
        let p = v["components"][["E_XX", "E_YY", "E_ZZ"][a]]["positions_mm"]
            .as_array()
            .expect("positions");
        let lo = p[0].as_f64().expect("test data");
        let hi = p[p.len() - 1].as_f64().expect("test data");
        [lo, hi]
    });
    let truth = GaugeTruth::of(m, range);
    for c in Component::all() {
        let e = &v["components"][c.name()];
        if e["identified"] != true {
            t.add(&[]);
            continue;
        }
        let pos = e["positions_mm"].as_array().expect("test data");
        let pairs: Vec<(f64, f64, f64)> = pos
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let a = p.as_f64().expect("test data");
                (
                    e["values"][i].as_f64().expect("test data"),
                    truth.value(m, c, a),
                    e["sigma"][i].as_f64().expect("test data"),
                )
            })
            .collect();
        t.add(&pairs);
    }
    for (i, name) in ["E_C0Y", "E_B0Z", "E_A0Z"].iter().enumerate() {
        let e = &v["components"][*name];
        if e["identified"] != true {
            t.add(&[]);
            continue;
        }
        t.add(&[(
            e["value"].as_f64().expect("test data"),
            truth.squareness_urad[i],
            e["sigma"].as_f64().expect("test data"),
        )]);
    }
}

/// The self-calibrated deviations against the truth beyond the invariants: per
/// coordinate, truth − estimate with its least-squares fit removed over what the
/// invariants of an eight-position campaign leave open (an affine field of the plate's
/// x, y: rigid motion, scale; and cubic profiles along x and along y: the positioning
/// components' share). Returns (RMS of what is left, RMS of the reported σ), µm.
fn beyond_invariants(v: &serde_json::Value, truth: &[[f64; 3]], template: &Campaign) -> (f64, f64) {
    let f = v["self_calibration"]["features"]
        .as_array()
        .expect("features");
    let n = truth.len();
    let art = &template.artefacts[0];
    let (mut left, mut sig, mut count) = (0.0, 0.0, 0.0);
    for c in 0..3 {
        let d = nalgebra::DVector::from_fn(n, |i, _| {
            truth[i][c] - f[i]["dev_um"][c].as_f64().expect("test data")
        });
        let a = nalgebra::DMatrix::from_fn(n, 7, |i, j| {
            let x = art.features[i].nominal_mm[0] / 400.0;
            let y = art.features[i].nominal_mm[1] / 400.0;
            [1.0, x, y, x * x, x * x * x, y * y, y * y * y][j]
        });
        let sol = a.clone().svd(true, true).solve(&d, 1e-12).expect("lsq");
        let r = d - a * sol;
        left += r.norm_squared();
        for fi in f {
            sig += fi["sigma_um"][c].as_f64().expect("test data").powi(2);
        }
        count += n as f64;
    }
    ((left / count).sqrt(), (sig / count).sqrt())
}

fn template(dir: &Path) -> Campaign {
    let plate = crate::util::dataset("artefact/plate.toml");
    Campaign::read(&campaign(dir, &plate, &eight(), SIGMA_UM)).expect("campaign")
}

#[test]
fn concealed_campaign_on_random_cmms_with_local_features() {
    let dir = tempdir();
    let template = template(dir.path());
    let mut rng = StdRng::seed_from_u64(36);
    let mut t = Tally::default();
    let mut alarms_on_features = 0;
    const MACHINES: u64 = 6;
    for i in 0..MACHINES {
        let p = Predictor::Machine(random_machine(&mut rng));
        let (truth, _) = random_plate(&mut rng, &template);
        let told = as_told(&mut rng, &truth, true);
        let (_, v) = run(&p, &truth, &told, 100 + i, false);
        let Predictor::Machine(m) = &p else {
            unreachable!("a machine")
        };
        tally(&v, m, &mut t);
        alarms_on_features += usize::from(v["residual"]["verdict"] == "missing_physics");
    }
    let hit = t.hits as f64 / t.detectable.max(1) as f64;
    let c1 = t.within1 as f64 / t.points as f64;
    let c2 = t.within2 as f64 / t.points as f64;
    eprintln!(
        "calibrated plate, {MACHINES} machines: hit rate {hit:.3} ({} of {} detectable \
         components, {} compared), 1σ coverage {c1:.3}, 2σ coverage {c2:.3} over {} points; \
         residual test named the local features on {alarms_on_features}",
        t.hits, t.detectable, t.components, t.points
    );

    // Rigid machines: no alarm, and the components within their bands.
    let mut alarms = 0;
    let mut r = Tally::default();
    const RIGID: u64 = 6;
    for i in 0..RIGID {
        let p = Predictor::Machine(Machine::perfect(yxz()));
        let (truth, _) = random_plate(&mut rng, &template);
        let told = as_told(&mut rng, &truth, true);
        let (_, v) = run(&p, &truth, &told, 200 + i, false);
        alarms += usize::from(v["residual"]["verdict"] == "missing_physics");
        tally(&v, &Machine::perfect(yxz()), &mut r);
    }
    let r2 = r.within2 as f64 / r.points as f64;
    eprintln!("rigid machines: {alarms} false alarms in {RIGID}; 2σ coverage {r2:.3}");

    // Self-calibration: the plate's deviations up to the named invariants.
    let mut worst: f64 = 0.0;
    const SELF: u64 = 4;
    for i in 0..SELF {
        let p = Predictor::Machine(random_machine(&mut rng));
        let (truth, dev) = random_plate(&mut rng, &template);
        let told = as_told(&mut rng, &truth, false);
        let (id, v) = run(&p, &truth, &told, 300 + i, true);
        let kinds: Vec<&str> = id
            .self_calibration
            .as_ref()
            .expect("self-calibration")
            .invariants
            .iter()
            .map(|k| k.kind)
            .collect();
        assert!(kinds.contains(&"scale"), "{kinds:?}");
        assert!(!kinds.contains(&"squareness"), "{kinds:?}");
        let (left, sigma) = beyond_invariants(&v, &dev, &template);
        eprintln!(
            "self-calibration {i}: invariants {kinds:?}; deviations beyond them {left:.3} µm RMS \
             (reported σ {sigma:.3} µm RMS, true deviations ±1 µm)"
        );
        worst = worst.max(left / sigma.max(1e-9));
    }
    assert!(t.detectable >= 10, "{} detectable", t.detectable);
    assert!(hit >= 0.75, "hit rate {hit}");
    assert!(c2 >= 0.85, "2σ coverage {c2}");
    assert!(c1 >= 0.5, "1σ coverage {c1}");
    assert_eq!(alarms, 0);
    assert!(r2 >= 0.9, "rigid 2σ coverage {r2}");
    assert!(
        worst <= 2.0,
        "self-calibrated deviations beyond the invariants: {worst} σ"
    );
}
