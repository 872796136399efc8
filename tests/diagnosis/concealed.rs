//! The concealed-effect cases of `datasets/concealed/`, checked two ways: against the
//! simulator's truth (parameters, residual, updated model) and by name (what `truth.json`
//! says is hidden is found, nothing in the clean cases).

/// The concealed-effect cases of `datasets/concealed/` (made by `errmap gen-concealed`
/// through the simulator, the board, the wire and the decoder): each hidden effect is
/// found and named, its parameters are within 25 % of the truth with an honest one-sigma
/// no larger than half the value, the residual after is at the noise, the clean cases give
/// no effects, and the updated model reproduces the recording.
mod against_truth {
    use std::path::{Path, PathBuf};

    use errmap::base::ParamValue;
    use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose};
    use errmap::session::read_session;
    use errmap::sim::ConcealedTruth;
    use errmap::sim::{MachineModel, apply_found_effects, simulate_rows};

    use crate::util::root;

    struct Case {
        dir: PathBuf,
        truth: ConcealedTruth,
        diagnosis: Diagnosis,
    }

    fn run(name: &str) -> Case {
        let dir = root().join("datasets/concealed").join(name);
        let recorded = read_session(&dir.join("recorded.parquet")).expect("recorded");
        let simulated = read_session(&dir.join("simulated.parquet")).expect("simulated");
        let truth = ConcealedTruth::read(&dir.join("truth.json")).expect("truth");
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
        let noise = c.truth.sizes.noise_um;
        eprintln!("{name}: {}", serde_json::to_string(d).expect("json"));
        assert_eq!(d.verdict.as_str(), "missing_physics", "{name}");
        let mut ids: Vec<&str> = d.effects.iter().map(|e| e.id().as_str()).collect();
        ids.sort_unstable();
        let mut want: Vec<&str> = c.truth.effects.iter().map(|e| e.id().as_str()).collect();
        want.sort_unstable();
        assert_eq!(ids, want, "{name}: effects named");
        for hidden in &c.truth.effects {
            let id = hidden.id();
            let found = d.effects.iter().find(|e| e.id() == id).expect("found");
            for (k, v) in hidden.params_by_name() {
                let k = k.as_str();
                let ParamValue::Number(truth) = v else {
                    // The axis an Abbe offset lies along: found as it was hidden.
                    assert_eq!(found.param_named(k), Some(v), "{name}: {id}.{k}");
                    continue;
                };
                let got = found.number_named(k);
                let sigma = found.sigma_named(k);
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
                c.diagnosis.verdict.as_str(),
                "consistent",
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
            let rms =
                (r.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / r.len() as f64).sqrt();
            let noise = c.truth.sizes.noise_um;
            // Noise plus counter quantisation (≈ 0.03 µm RMS).
            assert!(
                rms <= 1.3 * noise + 0.03,
                "{name}: updated model leaves {rms} µm"
            );
        }
    }
}

/// The concealed-effect cases of `datasets/concealed/` (made by the physics simulator
/// through the simulated board, the wire and the decoder): the diagnosis finds what
/// `truth.json` says is hidden, and nothing in the clean cases. Skipped with a message
/// when the datasets are absent.
mod by_name {
    use std::path::{Path, PathBuf};

    use crate::common::diagnosis_text;
    use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose};
    use errmap::session::read_session;
    use errmap::sim::ConcealedTruth;

    fn dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/concealed")
    }

    fn case(name: &str) -> Option<(Diagnosis, ConcealedTruth)> {
        let d = dir().join(name);
        if !d.join("recorded.parquet").exists() {
            eprintln!("skipping {name}: {} not found", d.display());
            return None;
        }
        let rec = read_session(&d.join("recorded.parquet")).ok()?;
        let sim = read_session(&d.join("simulated.parquet")).ok()?;
        let truth = ConcealedTruth::read(&d.join("truth.json")).ok()?;
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
        let hidden = &truth.effects;
        if hidden.is_empty() {
            assert_eq!(d.verdict.as_str(), "consistent", "{name}\n{t}");
            return;
        }
        assert_eq!(d.verdict.as_str(), "missing_physics", "{name}\n{t}");
        for h in hidden {
            let id = h.id();
            let Some(e) = d.effects.iter().find(|e| e.id() == id) else {
                panic!("{name}: {id} not found\n{t}");
            };
            for (p, v) in h.params_by_name() {
                let p = p.as_str();
                let Some(truth) = v.as_f64() else {
                    assert_eq!(e.param_named(p), Some(v), "{name}: {id}.{p}\n{t}");
                    continue;
                };
                if p == "phase_rad" || truth == 0.0 {
                    continue;
                }
                let got = e.number_named(p).unwrap_or(f64::NAN);
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
        for case in errmap::sim::concealed_cases() {
            for seed in 0..seeds {
                total += 1;
                let g = match errmap::sim::generate_concealed(&case, &table1, 1000 + seed) {
                    Ok(g) => g,
                    Err(e) => panic!("{}: {e}", case.name),
                };
                let d = match diagnose(&g.recorded, &g.simulated, &cfg) {
                    Ok(d) => d,
                    Err(e) => panic!("{}: {e}", case.name),
                };
                let mut got: Vec<errmap::base::EffectId> =
                    d.effects.iter().map(|e| e.id()).collect();
                let mut want = case.effect_ids();
                got.sort_unstable();
                want.sort_unstable();
                let params_ok = case.hidden.iter().all(|h| {
                    d.effects.iter().any(|e| {
                        e.id() == h.id()
                            && h.params_by_name().iter().all(|(p, v)| match v.as_f64() {
                                None => e.param_named(p.as_str()) == Some(*v),
                                Some(truth) => {
                                    p.as_str() == "phase_rad"
                                        || truth == 0.0
                                        || e.number_named(p.as_str()).is_some_and(|v| {
                                            (v - truth).abs() <= 0.25 * truth.abs()
                                        })
                                }
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
}
