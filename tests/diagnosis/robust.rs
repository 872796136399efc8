//! Matching, bad input, the JSON contract shape, the report files, random pairs of effects.

use errmap::base::{Axis, Drift, Effect};
use errmap::diagnose::{DiagnoseConfig, DiagnoseError, diagnose};
use errmap::diagnose::{Synth, synth_truth as truth, synthesize as generate};
use errmap::report::write_diagnosis_report;
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn cfg() -> DiagnoseConfig {
    DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    }
}

fn reversal() -> Synth {
    Synth {
        hidden: vec![Effect::Reversal {
            b_um: 0.6,
            b1_um_per_m: None,
        }],
        seed: 3,
        ..Synth::default()
    }
}

/// Shuffled rows, rows missing from either table, flagged rows with garbage errors, a
/// non-finite error: the same effect, and every left-out row counted.
#[test]
fn matching_survives_order_gaps_and_flags() -> TestResult {
    let out = generate(&reversal()).expect("a positioning pair");
    let mut rec = out.recorded.clone();
    let mut sim = out.simulated.clone();
    let mut rng = StdRng::seed_from_u64(9);
    // 30 recorded rows and 20 simulated rows lost.
    for _ in 0..30 {
        let k = rng.random_range(0..rec.len());
        rec.remove(k);
    }
    for _ in 0..20 {
        let k = rng.random_range(0..sim.len());
        sim.remove(k);
    }
    // 15 flagged recorded rows with absurd errors, one non-finite error.
    for k in 0..15 {
        rec[100 + 37 * k].flags = 2;
        rec[100 + 37 * k].error_um = 1e6;
    }
    rec[50].error_um = f64::NAN;
    rec.shuffle(&mut rng);
    sim.shuffle(&mut rng);
    let d = diagnose(&rec, &sim, &cfg())?;
    assert_eq!(d.effects.len(), 1, "{:?}", d.effects);
    assert_eq!(d.effects[0].id().as_str(), "reversal");
    let b = d.effects[0].number_named("b_um").unwrap_or(0.0);
    assert!((b - 0.6).abs() < 0.05, "{b}");
    let m = &d.matching;
    assert_eq!(m.recorded_rows, rec.len());
    assert_eq!(m.simulated_rows, sim.len());
    assert_eq!(m.only_in_recorded + m.matched_rows, rec.len());
    assert_eq!(m.only_in_simulated + m.matched_rows, sim.len());
    assert!(
        m.only_in_recorded >= 15 && m.only_in_simulated >= 25,
        "{m:?}"
    );
    assert!(m.flagged_rows >= 13, "{m:?}");
    assert!(m.non_finite_rows <= 1);
    assert_eq!(
        m.used_rows,
        m.matched_rows - m.flagged_rows - m.non_finite_rows - m.other_axis_rows
    );
    assert_eq!(d.only_in_recorded, m.only_in_recorded);
    Ok(())
}

/// Duplicate (run, sample) keys are left out, never matched by guess.
#[test]
fn duplicate_keys_are_left_out() -> TestResult {
    let out = generate(&reversal()).expect("a positioning pair");
    let mut rec = out.recorded.clone();
    let dup = rec[200].clone();
    rec.push(dup);
    let d = diagnose(&rec, &out.simulated, &cfg())?;
    assert_eq!(d.matching.duplicate_keys, 2);
    assert_eq!(d.matching.matched_rows, out.simulated.len() - 1);
    Ok(())
}

#[test]
fn bad_input_is_a_typed_error() {
    let out = generate(&reversal()).expect("a positioning pair");
    assert!(matches!(
        diagnose(&[], &out.simulated, &cfg()),
        Err(DiagnoseError::Empty { which: "recorded" })
    ));
    assert!(matches!(
        diagnose(&out.recorded, &[], &cfg()),
        Err(DiagnoseError::Empty { which: "simulated" })
    ));
    let mut other = out.simulated.clone();
    for r in &mut other {
        r.run += 100;
    }
    assert!(matches!(
        diagnose(&out.recorded, &other, &cfg()),
        Err(DiagnoseError::NoMatch { .. })
    ));
    assert!(matches!(
        diagnose(&out.recorded[..10], &out.simulated[..10], &cfg()),
        Err(DiagnoseError::TooFewRows { .. })
    ));
    let bad = DiagnoseConfig {
        grating_period_um: Some(-1.0),
        ..cfg()
    };
    assert!(matches!(
        diagnose(&out.recorded, &out.simulated, &bad),
        Err(DiagnoseError::Config(_))
    ));
    let bad = DiagnoseConfig {
        max_relative_uncertainty: 0.0,
        ..cfg()
    };
    assert!(bad.validate().is_err());
}

/// Tiny, degenerate and identical sessions do not panic; identical ones are consistent.
#[test]
fn degenerate_sessions_do_not_panic() -> TestResult {
    let out = generate(&reversal()).expect("a positioning pair");
    // Identical tables: the residual is exactly zero.
    let d = diagnose(&out.simulated, &out.simulated, &cfg())?;
    assert_eq!(d.verdict.as_str(), "consistent");
    assert!(d.rms_after_um.abs() < 1e-9);
    // A few dozen rows of one dwell.
    let few: Vec<_> = out.recorded.iter().take(40).cloned().collect();
    let d = diagnose(&few, &out.simulated, &cfg())?;
    assert!(d.rms_after_um.is_finite());
    // No environment columns, no line coordinates, every row outside a run: no line was
    // measured, so it is refused by name (issue 28), never diagnosed.
    let mut rec = out.recorded.clone();
    for r in &mut rec {
        r.air_temp_c = None;
        r.air_pressure_hpa = None;
        r.air_rh_pct = None;
        r.scale_temp_c = None;
        r.y_mm = None;
        r.z_mm = None;
        r.direction = 0;
        r.run = 0;
        r.feed_mm_s = None;
    }
    let mut sim = out.simulated.clone();
    for r in &mut sim {
        r.run = 0;
    }
    let e = diagnose(&rec, &sim, &cfg()).expect_err("every row outside a run");
    assert!(
        matches!(e, errmap::diagnose::DiagnoseError::NoRuns { .. }),
        "{e}"
    );
    assert!(e.to_string().contains("inside a run"), "{e}");
    Ok(())
}

/// `--json` shape of the contract: exactly these keys with these types (extras allowed).
#[test]
fn json_has_the_contract_shape() -> TestResult {
    let out = generate(&Synth {
        hidden: vec![Effect::Abbe {
            offset_axis: Axis::Z,
            theta0_urad: 4.0,
            theta1_urad_per_mm: 0.01,
        }],
        seed: 5,
        ..Synth::default()
    })
    .expect("a positioning pair");
    let d = diagnose(&out.recorded, &out.simulated, &cfg())?;
    let v = serde_json::to_value(&d)?;
    assert!(matches!(
        v["verdict"].as_str(),
        Some("consistent" | "missing_physics")
    ));
    for k in ["rms_before_um", "rms_after_um", "cv_rms_after_um"] {
        assert!(v[k].as_f64().is_some_and(f64::is_finite), "{k}");
    }
    let effects = v["effects"].as_array().ok_or("effects")?;
    assert_eq!(effects.len(), 1);
    for e in effects {
        assert!(e["id"].is_string());
        assert!(e["where"].is_string());
        assert!(e["explains_um"].as_f64().is_some());
        let params = e["params"].as_object().ok_or("params")?;
        let unc = e["uncertainty"].as_object().ok_or("uncertainty")?;
        assert_eq!(params["offset_axis"], "z");
        for (name, p) in params {
            if name != "offset_axis" {
                assert!(p.as_f64().is_some(), "{name}");
                assert!(unc[name].as_f64().is_some(), "{name}");
            }
        }
        assert!(params.contains_key("theta0_urad") && params.contains_key("theta1_urad_per_mm"));
    }
    Ok(())
}

#[test]
fn report_has_markdown_and_charts() -> TestResult {
    let out = generate(&Synth {
        hidden: vec![
            Effect::Reversal {
                b_um: 0.7,
                b1_um_per_m: None,
            },
            Effect::PeriodicScale {
                amplitude_um: 0.2,
                period_um: 20.0,
                phase_rad: 0.3,
            },
        ],
        seed: 8,
        ..Synth::default()
    })
    .expect("a positioning pair");
    let d = diagnose(&out.recorded, &out.simulated, &cfg())?;
    let dir = tempfile::tempdir()?;
    let files = write_diagnosis_report(&d, dir.path(), None)?;
    assert!(files[0].ends_with("report.md"));
    for f in &files {
        assert!(f.exists(), "{}", f.display());
    }
    for name in [
        "residual_vs_x.png",
        "residual_vs_x.svg",
        "residual_vs_time.png",
        "effect_1_reversal.png",
        "effect_2_periodic_scale.svg",
    ] {
        assert!(dir.path().join(name).exists(), "{name} missing");
    }
    let md = std::fs::read_to_string(dir.path().join("report.md"))?;
    for text in [
        "missing physics",
        "reversal",
        "periodic_scale",
        "Along the axis",
        "Periodogram peaks",
        "residual_vs_x.png",
    ] {
        assert!(md.contains(text), "report lacks {text:?}");
    }
    Ok(())
}

/// Random pairs of distinct effects with random parameters: both found.
#[test]
fn random_pairs_of_effects() -> TestResult {
    let mut rng = StdRng::seed_from_u64(31);
    // 16 draws, or `ERRMAP_DIAG_DRAWS` for a longer campaign (best with --release).
    let draws: u64 = std::env::var("ERRMAP_DIAG_DRAWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(16);
    let mut fails = Vec::new();
    for k in 0..draws {
        let mut pool: Vec<Effect> = vec![
            Effect::ScaleThermalExpansion {
                alpha_ppm_per_k: rng.random_range(8.0..12.0),
                x0_mm: 0.0,
            },
            Effect::ScaleFactor {
                ppm: rng.random_range(2.0..20.0),
            },
            Effect::Abbe {
                offset_axis: if rng.random_bool(0.5) {
                    Axis::Z
                } else {
                    Axis::Y
                },
                theta0_urad: rng.random_range(2.0..20.0),
                theta1_urad_per_mm: rng.random_range(0.005..0.05),
            },
            Effect::Reversal {
                b_um: rng.random_range(0.3..3.0),
                b1_um_per_m: None,
            },
            Effect::LatchDelay {
                tau_us: rng.random_range(20.0..200.0),
            },
            Effect::PeriodicScale {
                amplitude_um: rng.random_range(0.05..0.5),
                period_um: 20.0,
                phase_rad: rng.random_range(-3.0..3.0),
            },
            Effect::ThermalDrift(Drift::Exponential {
                amplitude_um: rng.random_range(0.5..3.0),
                tau_s: rng.random_range(300.0..1000.0),
            }),
            Effect::DeadPath {
                dead_path_mm: rng.random_range(200.0..500.0),
            },
            Effect::Refraction {
                ppm_per_k: Some(rng.random_range(0.9..1.0)),
                ppm_per_hpa: Some(-0.27),
            },
        ];
        pool.shuffle(&mut rng);
        let hidden = vec![pool[0], pool[1]];
        let s = Synth {
            hidden: hidden.clone(),
            seed: 500 + k,
            ..Synth::default()
        };
        let out = generate(&s).expect("a positioning pair");
        let d = diagnose(&out.recorded, &out.simulated, &cfg())?;
        let mut want: Vec<&str> = hidden.iter().map(|h| h.id().as_str()).collect();
        let mut got: Vec<&str> = d.effects.iter().map(|e| e.id().as_str()).collect();
        want.sort_unstable();
        got.sort_unstable();
        let ok_ids = want == got;
        let ok_params = hidden.iter().all(|h| {
            d.effects.iter().any(|e| {
                e.id() == h.id() && {
                    let (name, truth) = truth(h)[0];
                    let v = e.number_named(name).unwrap_or(f64::NAN);
                    (v - truth).abs() <= 0.25 * truth.abs()
                }
            })
        });
        if !(ok_ids && ok_params && d.rms_after_um <= 1.3 * s.noise.sigma_um) {
            fails.push(format!(
                "draw {k}: hidden {hidden:?}; found {:?}; rms after {:.4}",
                d.effects
                    .iter()
                    .map(|e| (e.id(), e.effect.params()))
                    .collect::<Vec<_>>(),
                d.rms_after_um
            ));
        }
    }
    println!("pairs: {}/{draws} found", draws as usize - fails.len());
    for f in &fails {
        println!("  {f}");
    }
    assert!(
        fails.len() as f64 <= (draws as f64 / 16.0).ceil(),
        "{}",
        fails.join("\n")
    );
    Ok(())
}

/// Random, partly absurd rows (NaNs, mixed axes, empty columns, huge values) never make
/// the diagnosis panic: it returns a diagnosis or a typed error.
#[test]
fn random_rows_never_panic() {
    use errmap::drivers::{Axis, SessionRow};
    let mut rng = StdRng::seed_from_u64(77);
    let pick = |rng: &mut StdRng, v: f64| -> Option<f64> {
        match rng.random_range(0..10) {
            0 => None,
            1 => Some(f64::NAN),
            2 => Some(1e12),
            _ => Some(v),
        }
    };
    for case in 0..30 {
        let n = rng.random_range(0..400);
        let mut rec = Vec::new();
        let mut sim = Vec::new();
        for k in 0..n {
            let axis = match rng.random_range(0..6) {
                0 => Axis::Y,
                1 => Axis::Z,
                _ => Axis::X,
            };
            let x = rng.random_range(-10.0..900.0);
            let air = 20.0 + rng.random_range(-1.0..1.0);
            let row = SessionRow {
                run: rng.random_range(0..4),
                sample: k as i64 / rng.random_range(1..3),
                t_s: if rng.random_bool(0.02) {
                    f64::NAN
                } else {
                    k as f64 * 0.1
                },
                axis,
                direction: rng.random_range(-1..=1),
                feed_mm_s: pick(&mut rng, 100.0),
                target: rng.random_range(-1..5),
                x_mm: pick(&mut rng, x),
                y_mm: pick(&mut rng, 100.0),
                z_mm: pick(&mut rng, 200.0),
                scale_mm: x,
                laser_mm: x,
                error_um: if rng.random_bool(0.03) {
                    f64::INFINITY
                } else {
                    rng.random_range(-5.0..5.0)
                },
                air_temp_c: pick(&mut rng, air),
                air_pressure_hpa: pick(&mut rng, 1013.0),
                air_rh_pct: pick(&mut rng, 45.0),
                scale_temp_c: pick(&mut rng, 20.5),
                part_temp_c: None,
                flags: u8::from(rng.random_bool(0.05)),
            };
            let mut s = row.clone();
            s.error_um = rng.random_range(-5.0..5.0);
            rec.push(row);
            if rng.random_bool(0.9) {
                sim.push(s);
            }
        }
        match diagnose(&rec, &sim, &DiagnoseConfig::default()) {
            Ok(d) => {
                assert!(
                    d.rms_after_um.is_finite() || d.used_rows == 0,
                    "case {case}"
                );
                let json = serde_json::to_string(&d);
                assert!(json.is_ok(), "case {case}");
            }
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
}

/// The same physics measured along Y: the position is y_mm, the line offsets x and z.
#[test]
fn works_on_the_y_axis() -> TestResult {
    let out = generate(&Synth {
        hidden: vec![Effect::Abbe {
            offset_axis: Axis::Z,
            theta0_urad: 6.0,
            theta1_urad_per_mm: 0.01,
        }],
        seed: 12,
        ..Synth::default()
    })
    .expect("a positioning pair");
    let to_y = |rows: &[errmap::drivers::SessionRow]| -> Vec<errmap::drivers::SessionRow> {
        rows.iter()
            .map(|r| {
                let mut r = r.clone();
                r.axis = errmap::drivers::Axis::Y;
                std::mem::swap(&mut r.x_mm, &mut r.y_mm);
                r
            })
            .collect()
    };
    let d = diagnose(&to_y(&out.recorded), &to_y(&out.simulated), &cfg())?;
    assert_eq!(d.axis, "Y");
    assert_eq!(d.effects.len(), 1, "{:?}", d.effects);
    assert_eq!(d.effects[0].id().as_str(), "abbe");
    assert_eq!(
        d.effects[0]
            .param_named("offset_axis")
            .map(|v| v.to_string())
            .as_deref(),
        Some("\"z\"")
    );
    assert!(
        d.effects[0].where_.starts_with("Y axis, y "),
        "{}",
        d.effects[0].where_
    );
    Ok(())
}

/// Structure outside the vocabulary (a local bump along x) is neither hidden nor forced
/// into a vocabulary effect: the verdict is missing_physics with an `unexplained` entry
/// that says where it is.
#[test]
fn structure_outside_the_vocabulary_is_reported_as_unexplained() -> TestResult {
    let mut out = generate(&Synth {
        seed: 77,
        ..Synth::default()
    })
    .expect("a positioning pair");
    for r in &mut out.recorded {
        let x = r.x_mm.unwrap_or(0.0);
        r.error_um += 0.4 * (-((x - 400.0) / 40.0).powi(2)).exp();
    }
    let d = diagnose(&out.recorded, &out.simulated, &cfg())?;
    assert_eq!(d.verdict.as_str(), "missing_physics");
    assert_eq!(d.effects.len(), 1, "{:?}", d.effects);
    assert_eq!(d.effects[0].id().as_str(), "unexplained");
    assert!(
        d.effects[0].where_.contains("x 3") || d.effects[0].where_.contains("x 4"),
        "{}",
        d.effects[0].where_
    );
    assert!(d.locate.unexplained.is_some());
    Ok(())
}
