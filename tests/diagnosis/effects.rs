//! The diagnosis finds each hidden effect of the vocabulary, two at once, none in clean
//! recordings (also with uneven noise), and states the ambiguities of poor designs.
//! Synthetic sessions from `errmap::diagnose::synthesize` (seeded).

use crate::common::diagnosis_text;
use errmap::base::{Axis, Drift, Effect};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, FoundEffect, diagnose};
use errmap::diagnose::{Synth, synth_truth as truth, synthesize as generate};

pub(crate) fn config() -> DiagnoseConfig {
    DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    }
}

fn run(s: &Synth) -> Diagnosis {
    let out = generate(s).expect("a positioning pair");
    // The hidden effects are concealed: each smaller than the geometric error's range.
    for (h, v) in s.hidden.iter().zip(&out.hidden_um) {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        assert!(
            hi - lo < out.geometric_pp_um,
            "{h:?} is not concealed: {:.2} µm p-p against a geometric {:.2} µm",
            hi - lo,
            out.geometric_pp_um
        );
    }
    match diagnose(&out.recorded, &out.simulated, &config()) {
        Ok(d) => d,
        Err(e) => panic!("diagnose failed: {e}"),
    }
}

fn param(e: &FoundEffect, name: &str) -> f64 {
    e.number_named(name).unwrap_or(f64::NAN)
}

/// The effect is found alone with its parameters within 25 % (and one-sigma ≤ half the
/// value), and the residual after is at noise level.
fn check_single(s: &Synth, hidden: Effect, keys: &[&str]) {
    let d = run(s);
    let text = diagnosis_text(&d);
    assert_eq!(d.verdict.as_str(), "missing_physics", "{text}");
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id(), hidden.id(), "{text}");
    for (name, truth) in truth(&hidden) {
        if !keys.contains(&name) {
            continue;
        }
        let v = param(e, name);
        assert!(
            (v - truth).abs() <= 0.25 * truth.abs(),
            "{name}: {v} vs truth {truth}\n{text}"
        );
        let sigma = e.sigma_named(name).unwrap_or(f64::NAN);
        assert!(sigma <= 0.5 * v.abs(), "{name}: σ {sigma} vs {v}\n{text}");
    }
    assert!(
        d.rms_after_um <= 1.3 * s.noise.sigma_um,
        "rms after {} vs noise {}\n{text}",
        d.rms_after_um,
        s.noise.sigma_um
    );
}

pub(crate) fn with(hidden: &[Effect]) -> Synth {
    Synth {
        hidden: hidden.to_vec(),
        seed: 7,
        geometric_um: 8.0,
        ..Synth::default()
    }
}

#[test]
fn finds_two_periodic_terms_at_p_and_p_over_2() {
    check_multi_periodic();
}

fn check_multi_periodic() {
    let s = with(&[
        Effect::PeriodicScale {
            amplitude_um: 0.2,
            period_um: 20.0,
            phase_rad: 0.4,
        },
        Effect::PeriodicScale {
            amplitude_um: 0.08,
            period_um: 10.0,
            phase_rad: -2.0,
        },
    ]);
    let d = run(&s);
    let text = diagnosis_text(&d);
    let mut periods: Vec<f64> = d
        .effects
        .iter()
        .filter(|e| e.id().as_str() == "periodic_scale")
        .map(|e| param(e, "period_um"))
        .collect();
    periods.sort_by(f64::total_cmp);
    assert_eq!(periods.len(), 2, "{text}");
    assert!(
        (periods[0] - 10.0).abs() < 1e-3 && (periods[1] - 20.0).abs() < 1e-3,
        "{text}"
    );
    assert!(d.rms_after_um <= 1.3 * s.noise.sigma_um, "{text}");
}

#[test]
fn finds_scale_thermal_expansion() {
    let h = Effect::ScaleThermalExpansion {
        alpha_ppm_per_k: 10.5,
        x0_mm: 0.0,
    };
    check_single(&with(&[h]), h, &["alpha_ppm_per_k"]);
}

#[test]
fn finds_scale_thermal_expansion_with_x0() {
    let h = Effect::ScaleThermalExpansion {
        alpha_ppm_per_k: 11.5,
        x0_mm: 300.0,
    };
    check_single(&with(&[h]), h, &["alpha_ppm_per_k", "x0_mm"]);
}

#[test]
fn finds_scale_factor() {
    let h = Effect::ScaleFactor { ppm: 4.0 };
    check_single(&with(&[h]), h, &["ppm"]);
}

#[test]
fn finds_abbe_along_z() {
    let h = Effect::Abbe {
        offset_axis: Axis::Z,
        theta0_urad: 5.0,
        theta1_urad_per_mm: 0.01,
    };
    let s = with(&[h]);
    check_single(&s, h, &["theta0_urad", "theta1_urad_per_mm"]);
    let d = run(&s);
    assert_eq!(
        d.effects[0]
            .param_named("offset_axis")
            .map(|v| v.to_string())
            .as_deref(),
        Some("\"z\"")
    );
}

#[test]
fn finds_abbe_along_y() {
    let h = Effect::Abbe {
        offset_axis: Axis::Y,
        theta0_urad: -8.0,
        theta1_urad_per_mm: 0.02,
    };
    let s = with(&[h]);
    check_single(&s, h, &["theta0_urad", "theta1_urad_per_mm"]);
    let d = run(&s);
    assert_eq!(
        d.effects[0]
            .param_named("offset_axis")
            .map(|v| v.to_string())
            .as_deref(),
        Some("\"y\"")
    );
}

#[test]
fn finds_reversal() {
    let h = Effect::Reversal {
        b_um: 0.8,
        b1_um_per_m: None,
    };
    check_single(&with(&[h]), h, &["b_um"]);
}

#[test]
fn finds_latch_delay() {
    let h = Effect::LatchDelay { tau_us: 25.0 };
    check_single(&with(&[h]), h, &["tau_us"]);
}

#[test]
fn finds_periodic_scale_at_half_the_grating_period() {
    let h = Effect::PeriodicScale {
        amplitude_um: 0.15,
        period_um: 10.0,
        phase_rad: 0.7,
    };
    check_single(&with(&[h]), h, &["amplitude_um", "period_um"]);
}

#[test]
fn finds_periodic_scale_at_a_non_grating_period() {
    let h = Effect::PeriodicScale {
        amplitude_um: 0.2,
        period_um: 1000.0,
        phase_rad: -1.2,
    };
    check_single(&with(&[h]), h, &["amplitude_um", "period_um"]);
}

#[test]
fn finds_exponential_thermal_drift() {
    let h = Effect::ThermalDrift(Drift::Exponential {
        amplitude_um: 1.5,
        tau_s: 600.0,
    });
    check_single(&with(&[h]), h, &["amplitude_um", "tau_s"]);
}

#[test]
fn finds_dead_path() {
    let h = Effect::DeadPath {
        dead_path_mm: 300.0,
    };
    let mut s = with(&[h]);
    s.env.air_temp_drift_k = 0.5;
    check_single(&s, h, &["dead_path_mm"]);
}

#[test]
fn finds_refraction() {
    let h = Effect::Refraction {
        ppm_per_k: Some(0.93),
        ppm_per_hpa: Some(-0.27),
    };
    check_single(&with(&[h]), h, &["ppm_per_k", "ppm_per_hpa"]);
}

#[test]
fn clean_recording_is_consistent() {
    let d = run(&with(&[]));
    assert_eq!(d.verdict.as_str(), "consistent", "{}", diagnosis_text(&d));
    assert!(d.effects.is_empty());
}

#[test]
fn finds_linear_thermal_drift() {
    let h = Effect::ThermalDrift(Drift::Linear {
        rate_um_per_s: 6e-4,
    });
    check_single(&with(&[h]), h, &["rate_um_per_s"]);
}

/// Finds every hidden effect of `hidden` (ids), nothing else, residual at noise level.
fn check_multi(s: &Synth) -> Diagnosis {
    let d = run(s);
    let text = diagnosis_text(&d);
    let mut want: Vec<&str> = s.hidden.iter().map(|h| h.id().as_str()).collect();
    let mut got: Vec<&str> = d.effects.iter().map(|e| e.id().as_str()).collect();
    want.sort_unstable();
    got.sort_unstable();
    assert_eq!(got, want, "{text}");
    for h in &s.hidden {
        let e = d
            .effects
            .iter()
            .find(|e| e.id() == h.id())
            .unwrap_or_else(|| panic!("{} missing\n{text}", h.id()));
        let (name, truth) = truth(h)[0];
        let v = param(e, name);
        assert!(
            (v - truth).abs() <= 0.25 * truth.abs(),
            "{name}: {v} vs {truth}\n{text}"
        );
    }
    assert!(d.rms_after_um <= 1.3 * s.noise.sigma_um, "{text}");
    d
}

#[test]
fn finds_reversal_and_periodic_together() {
    check_multi(&with(&[
        Effect::Reversal {
            b_um: 0.8,
            b1_um_per_m: None,
        },
        Effect::PeriodicScale {
            amplitude_um: 0.15,
            period_um: 10.0,
            phase_rad: -1.1,
        },
    ]));
}

#[test]
fn finds_scale_thermal_expansion_and_latch_delay_together() {
    check_multi(&with(&[
        Effect::ScaleThermalExpansion {
            alpha_ppm_per_k: 9.0,
            x0_mm: 0.0,
        },
        Effect::LatchDelay { tau_us: 30.0 },
    ]));
}

#[test]
fn finds_abbe_and_thermal_drift_together() {
    let mut s = with(&[
        Effect::Abbe {
            offset_axis: Axis::Y,
            theta0_urad: 6.0,
            theta1_urad_per_mm: -0.02,
        },
        Effect::ThermalDrift(Drift::Exponential {
            amplitude_um: -2.0,
            tau_s: 500.0,
        }),
    ]);
    s.noise.sigma_um = 0.08;
    check_multi(&s);
}

#[test]
fn finds_dead_path_and_scale_factor_together() {
    let mut s = with(&[
        Effect::DeadPath {
            dead_path_mm: 400.0,
        },
        Effect::ScaleFactor { ppm: -6.0 },
    ]);
    s.env.air_temp_drift_k = -0.5;
    check_multi(&s);
}

#[test]
fn uneven_noise_on_moving_rows_is_consistent() {
    let mut s = with(&[]);
    s.noise.moving_factor = 3.0;
    let d = run(&s);
    assert_eq!(d.verdict.as_str(), "consistent", "{}", diagnosis_text(&d));
    assert!(d.effects.is_empty());
    // The noise groups see the difference.
    let moving: Vec<f64> = d
        .noise_groups
        .iter()
        .filter(|g| g.group.ends_with("moving") && g.rows > 50)
        .map(|g| g.sigma_um)
        .collect();
    let dwell: Vec<f64> = d
        .noise_groups
        .iter()
        .filter(|g| g.group.ends_with("dwell"))
        .map(|g| g.sigma_um)
        .collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(
        mean(&moving) > 2.0 * mean(&dwell),
        "{moving:?} vs {dwell:?}"
    );
}

#[test]
fn uneven_noise_in_two_runs_is_consistent() {
    let mut s = with(&[]);
    s.noise.noisy_runs = vec![2, 5];
    s.noise.noisy_factor = 3.0;
    s.noise.sigma_um = 0.1;
    let d = run(&s);
    assert_eq!(d.verdict.as_str(), "consistent", "{}", diagnosis_text(&d));
}

#[test]
fn uneven_noise_does_not_hide_an_effect() {
    let h = Effect::Reversal {
        b_um: 0.5,
        b1_um_per_m: None,
    };
    let mut s = with(&[h]);
    s.noise.moving_factor = 3.0;
    let d = run(&s);
    assert_eq!(d.effects.len(), 1, "{}", diagnosis_text(&d));
    assert_eq!(d.effects[0].id().as_str(), "reversal");
}

fn all_text(d: &Diagnosis) -> String {
    let mut t: Vec<String> = d.effects.iter().map(|e| e.where_.clone()).collect();
    t.extend(d.ambiguities.iter().cloned());
    t.join("\n")
}

/// A constant scale temperature: α·ΔT·x is a scale factor. One of the two is reported,
/// the ambiguity is stated with the measurement that separates them.
#[test]
fn constant_scale_temperature_makes_thermal_expansion_ambiguous() {
    let mut s = with(&[Effect::ScaleThermalExpansion {
        alpha_ppm_per_k: 10.0,
        x0_mm: 0.0,
    }]);
    s.env.scale_temp_c = (20.5, 20.5);
    let d = run(&s);
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let id = d.effects[0].id().as_str();
    assert!(
        id == "scale_factor" || id == "scale_thermal_expansion",
        "{text}"
    );
    let other = if id == "scale_factor" {
        "scale_thermal_expansion"
    } else {
        "scale_factor"
    };
    let w = &d.effects[0].where_;
    assert!(w.contains("ambiguous") && w.contains(other), "{text}");
    assert!(
        all_text(&d).contains("scale at another temperature"),
        "{text}"
    );
}

/// One feed and no dwell rows: d·v·τ is a reversal.
#[test]
fn one_feed_without_dwell_makes_latch_delay_ambiguous() {
    let mut s = with(&[Effect::LatchDelay { tau_us: 20.0 }]);
    s.plan.feeds_mm_s = vec![100.0];
    s.plan.dwell_samples = 0;
    let d = run(&s);
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let id = d.effects[0].id().as_str();
    assert!(id == "reversal" || id == "latch_delay", "{text}");
    let other = if id == "reversal" {
        "latch_delay"
    } else {
        "reversal"
    };
    assert!(d.effects[0].where_.contains(other), "{text}");
    assert!(all_text(&d).contains("second feed"), "{text}");
}

/// A single line: c·θ(x) is a constant plus a scale factor.
#[test]
fn single_line_makes_abbe_ambiguous() {
    let mut s = with(&[Effect::Abbe {
        offset_axis: Axis::Z,
        theta0_urad: 5.0,
        theta1_urad_per_mm: 0.01,
    }]);
    s.plan.lines_mm = vec![[200.0, 300.0]];
    let d = run(&s);
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    assert_eq!(d.effects[0].id().as_str(), "scale_factor", "{text}");
    assert!(d.effects[0].where_.contains("abbe"), "{text}");
    assert!(all_text(&d).contains("second line"), "{text}");
    // 0.01 µrad/mm over z = 300 mm is 3 ppm.
    let k = param(&d.effects[0], "ppm");
    assert!((k - 3.0).abs() < 0.3, "{text}");
}

/// Against a model whose own dead path is known, a dead-path correction that would make
/// the beam's dead path negative is refused; without that knowledge the same data give
/// the correction (a model may over-compensate).
#[test]
fn a_negative_total_dead_path_is_refused_when_the_model_is_known() {
    let h = Effect::DeadPath {
        dead_path_mm: -300.0,
    };
    let mut s = with(&[h]);
    s.env.air_temp_drift_k = 0.5;
    let out = generate(&s).expect("a positioning pair");
    let free = diagnose(&out.recorded, &out.simulated, &config()).expect("diagnoses");
    assert_eq!(
        free.effects.first().map(|e| e.id().as_str()),
        Some("dead_path"),
        "{}",
        diagnosis_text(&free)
    );
    let known = DiagnoseConfig {
        model_dead_path_mm: Some(100.0),
        ..config()
    };
    let d = diagnose(&out.recorded, &out.simulated, &known).expect("diagnoses");
    assert!(
        d.effects.iter().all(|e| e.id().as_str() != "dead_path"),
        "{}",
        diagnosis_text(&d)
    );
    assert!(
        d.ambiguities
            .iter()
            .any(|a| a.contains("a length cannot be negative")),
        "{:?}",
        d.ambiguities
    );
    // With a model dead path long enough to absorb it, the correction stands.
    let long = DiagnoseConfig {
        model_dead_path_mm: Some(1000.0),
        ..config()
    };
    let d = diagnose(&out.recorded, &out.simulated, &long).expect("diagnoses");
    assert_eq!(
        d.effects.first().map(|e| e.id().as_str()),
        Some("dead_path"),
        "{}",
        diagnosis_text(&d)
    );
}
