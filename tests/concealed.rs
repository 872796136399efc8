//! The concealed-effect cases of `datasets/concealed/` (made by `errmap gen-concealed`
//! through the simulator, the board, the wire and the decoder): each hidden effect is
//! found and named, its parameters are within 25 % of the truth with an honest one-sigma
//! no larger than half the value, the residual after is at the noise, the clean cases give
//! no effects, and the updated model reproduces the recording.

use std::path::{Path, PathBuf};

use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose};
use errmap::physics::{MachineModel, apply_found_effects, simulate_rows};
use errmap::session::read_session;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

struct Case {
    dir: PathBuf,
    truth: serde_json::Value,
    diagnosis: Diagnosis,
}

fn run(name: &str) -> Case {
    let dir = root().join("datasets/concealed").join(name);
    let recorded = read_session(&dir.join("recorded.parquet")).expect("recorded");
    let simulated = read_session(&dir.join("simulated.parquet")).expect("simulated");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).expect("truth"))
            .expect("json");
    let config = DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    };
    let diagnosis = diagnose(&recorded, &simulated, &config).expect("diagnoses");
    Case {
        dir,
        truth,
        diagnosis,
    }
}

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

fn check_found(name: &str) {
    let c = run(name);
    let d = &c.diagnosis;
    let noise = c.truth["sizes"]["noise_um"].as_f64().expect("noise");
    eprintln!("{name}: {}", serde_json::to_string(d).expect("json"));
    assert_eq!(d.verdict, "missing_physics", "{name}");
    let hidden = c.truth["params"].as_object().expect("params");
    let mut ids: Vec<&str> = d.effects.iter().map(|e| e.id.as_str()).collect();
    ids.sort_unstable();
    let mut want: Vec<&str> = hidden.keys().map(String::as_str).collect();
    want.sort_unstable();
    assert_eq!(ids, want, "{name}: effects named");
    for (id, params) in hidden {
        let found = d.effects.iter().find(|e| &e.id == id).expect("found");
        for (k, v) in params.as_object().expect("params") {
            let truth = v.as_f64().expect("number");
            let got = found.params.get(k).and_then(|x| x.as_f64());
            let sigma = found.uncertainty.get(k).copied();
            let (Some(got), Some(sigma)) = (got, sigma) else {
                panic!("{name}: {id}.{k} missing in {found:?}");
            };
            if truth == 0.0 {
                // A zero parameter (e.g. the fixed point x0 = 0) must be consistent with 0.
                assert!(
                    got.abs() <= 3.0 * sigma + 1e-9,
                    "{name}: {id}.{k} = {got} ± {sigma}, truth 0"
                );
                continue;
            }
            let err = if k == "phase_rad" {
                angle_diff(got, truth)
            } else {
                (got - truth).abs()
            };
            assert!(
                err <= 0.25 * truth.abs(),
                "{name}: {id}.{k} = {got}, truth {truth}"
            );
            assert!(
                sigma <= 0.5 * got.abs() && sigma > 0.0,
                "{name}: {id}.{k} = {got} ± {sigma}"
            );
        }
    }
    assert!(
        d.rms_after_um <= 1.3 * noise,
        "{name}: RMS after {} vs noise {noise}",
        d.rms_after_um
    );
    assert!(d.rms_after_um < d.rms_before_um, "{name}");
}

#[test]
fn scale_thermal_expansion() {
    check_found("scale_thermal_expansion");
}
#[test]
fn scale_factor() {
    check_found("scale_factor");
}
#[test]
fn abbe() {
    check_found("abbe");
}
#[test]
fn reversal() {
    check_found("reversal");
}
#[test]
fn latch_delay() {
    check_found("latch_delay");
}
#[test]
fn periodic_scale() {
    check_found("periodic_scale");
}
#[test]
fn thermal_drift() {
    check_found("thermal_drift");
}
#[test]
fn dead_path() {
    check_found("dead_path");
}
#[test]
fn refraction() {
    check_found("refraction");
}
#[test]
fn two_effects() {
    check_found("two_effects");
}

#[test]
fn clean_recordings_are_consistent() {
    for name in ["clean", "clean_uneven_noise"] {
        let c = run(name);
        assert_eq!(
            c.diagnosis.verdict, "consistent",
            "{name}: {:?}",
            c.diagnosis.effects
        );
        assert!(c.diagnosis.effects.is_empty(), "{name}");
    }
}

/// The model updated with the found effects reproduces the recording: its residual is
/// the noise.
#[test]
fn updated_model_reproduces_the_recording() {
    for name in ["reversal", "scale_thermal_expansion", "two_effects"] {
        let c = run(name);
        let nominal_path: &Path = &c.dir.join("nominal.toml");
        let mut model = MachineModel::read(nominal_path).expect("nominal");
        apply_found_effects(&mut model, &c.diagnosis.effects);
        let recorded = read_session(&c.dir.join("recorded.parquet")).expect("recorded");
        let sim = simulate_rows(&model, nominal_path, &recorded).expect("simulates");
        let by_key: std::collections::HashMap<(u32, i64), f64> = recorded
            .iter()
            .map(|r| ((r.run, r.sample), r.error_um))
            .collect();
        let r: Vec<f64> = sim
            .iter()
            .filter(|s| s.run > 0)
            .map(|s| by_key[&(s.run, s.sample)] - s.error_um)
            .collect();
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        let rms = (r.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / r.len() as f64).sqrt();
        let noise = c.truth["sizes"]["noise_um"].as_f64().expect("noise");
        // Noise plus counter quantisation (≈ 0.03 µm RMS).
        assert!(
            rms <= 1.3 * noise + 0.03,
            "{name}: updated model leaves {rms} µm"
        );
    }
}
