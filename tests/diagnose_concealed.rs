//! The concealed-effect cases of `datasets/concealed/` (made by the physics simulator
//! through the simulated board, the wire and the decoder): the diagnosis finds what
//! `truth.json` says is hidden, and nothing in the clean cases. Skipped with a message
//! when the datasets are absent.

use std::path::{Path, PathBuf};

mod common;

use common::diagnosis_text;
use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose};
use errmap::session::read_session;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/concealed")
}

fn case(name: &str) -> Option<(Diagnosis, serde_json::Value)> {
    let d = dir().join(name);
    if !d.join("recorded.parquet").exists() {
        eprintln!("skipping {name}: {} not found", d.display());
        return None;
    }
    let rec = read_session(&d.join("recorded.parquet")).ok()?;
    let sim = read_session(&d.join("simulated.parquet")).ok()?;
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("truth.json")).ok()?).ok()?;
    let cfg = DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    };
    let diag = match diagnose(&rec, &sim, &cfg) {
        Ok(x) => x,
        Err(e) => panic!("{name}: {e}"),
    };
    Some((diag, truth))
}

fn check(name: &str) {
    let Some((d, truth)) = case(name) else { return };
    let t = diagnosis_text(&d);
    println!("{name}: {t}");
    let hidden = truth["params"].as_object().cloned().unwrap_or_default();
    if hidden.is_empty() {
        assert_eq!(d.verdict, "consistent", "{name}\n{t}");
        return;
    }
    assert_eq!(d.verdict, "missing_physics", "{name}\n{t}");
    for (id, params) in &hidden {
        let Some(e) = d.effects.iter().find(|e| &e.id == id) else {
            panic!("{name}: {id} not found\n{t}");
        };
        for (p, v) in params.as_object().cloned().unwrap_or_default() {
            let truth = v.as_f64().unwrap_or(f64::NAN);
            if p == "phase_rad" || truth == 0.0 {
                continue;
            }
            let got = e
                .params
                .get(&p)
                .and_then(|v| v.as_f64())
                .unwrap_or(f64::NAN);
            assert!(
                (got - truth).abs() <= 0.25 * truth.abs(),
                "{name}: {id}.{p} = {got} vs {truth}\n{t}"
            );
        }
    }
    assert_eq!(d.effects.len(), hidden.len(), "{name}: extra effects\n{t}");
}

#[test]
fn scale_thermal_expansion() {
    check("scale_thermal_expansion");
}
#[test]
fn scale_factor() {
    check("scale_factor");
}
#[test]
fn abbe() {
    check("abbe");
}
#[test]
fn reversal() {
    check("reversal");
}
#[test]
fn latch_delay() {
    check("latch_delay");
}
#[test]
fn periodic_scale() {
    check("periodic_scale");
}
#[test]
fn thermal_drift() {
    check("thermal_drift");
}
#[test]
fn dead_path() {
    check("dead_path");
}
#[test]
fn refraction() {
    check("refraction");
}
#[test]
fn two_effects() {
    check("two_effects");
}
#[test]
fn clean() {
    check("clean");
}
#[test]
fn clean_uneven_noise() {
    check("clean_uneven_noise");
}

/// Every concealed case generated again through the physics simulator, the wire and the
/// decoder with other noise seeds (`ERRMAP_DIAG_DRAWS` seeds per case, default 1): the
/// same effects are found (parameters within 25 %), nothing in the clean cases.
#[test]
fn concealed_cases_with_other_noise() {
    let table1 = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/table1.csv");
    if !table1.exists() {
        eprintln!("skipping: {} not found", table1.display());
        return;
    }
    let seeds: u64 = std::env::var("ERRMAP_DIAG_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let cfg = DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    };
    let mut fails = Vec::new();
    let mut total = 0;
    for case in errmap::concealed::cases() {
        for seed in 0..seeds {
            total += 1;
            let g = match errmap::concealed::generate(&case, &table1, 1000 + seed) {
                Ok(g) => g,
                Err(e) => panic!("{}: {e}", case.name),
            };
            let d = match diagnose(&g.recorded, &g.simulated, &cfg) {
                Ok(d) => d,
                Err(e) => panic!("{}: {e}", case.name),
            };
            let mut got: Vec<&str> = d.effects.iter().map(|e| e.id.as_str()).collect();
            let mut want = case.effects.clone();
            got.sort_unstable();
            want.sort_unstable();
            let params_ok = case.truth.iter().all(|(id, params)| {
                d.effects.iter().any(|e| {
                    &e.id == id
                        && params.iter().all(|(p, &truth)| {
                            p == "phase_rad"
                                || truth == 0.0
                                || e.params
                                    .get(p)
                                    .and_then(|v| v.as_f64())
                                    .is_some_and(|v| (v - truth).abs() <= 0.25 * truth.abs())
                        })
                })
            });
            if got != want || !params_ok {
                fails.push(format!(
                    "{} seed {seed}:\n{}",
                    case.name,
                    diagnosis_text(&d)
                ));
            }
        }
    }
    println!(
        "concealed regenerated: {}/{total} right",
        total - fails.len()
    );
    for f in &fails {
        println!("{f}");
    }
    assert!(fails.is_empty(), "{}", fails.join("\n"));
}
