//! The diagnosis finds each hidden effect of the vocabulary, two at once, none in clean
//! recordings (also with uneven noise), and states the ambiguities of poor designs.
//! Synthetic sessions from `errmap::diagnose::synth` (seeded).

use errmap::diagnose::synth::{Hidden, Synth, SynthNoise, generate};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, FoundEffect, diagnose};

fn config() -> DiagnoseConfig {
    DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    }
}

fn run(s: &Synth) -> Diagnosis {
    let out = generate(s);
    match diagnose(&out.recorded, &out.simulated, &config()) {
        Ok(d) => d,
        Err(e) => panic!("diagnose failed: {e}"),
    }
}

fn summary(d: &Diagnosis) -> String {
    let mut s = format!(
        "verdict {} rms {:.4} → {:.4} (cv {:.4}), noise {:.4}\n",
        d.verdict, d.rms_before_um, d.rms_after_um, d.cv_rms_after_um, d.noise_sigma_um
    );
    for e in &d.effects {
        s.push_str(&format!(
            "  {} {:?} ± {:?} explains {:.4}\n    where: {}\n",
            e.id, e.params, e.uncertainty, e.explains_um, e.where_
        ));
    }
    for a in &d.ambiguities {
        s.push_str(&format!("  ambiguity: {a}\n"));
    }
    for a in &d.selection_log {
        s.push_str(&format!("  log: {a}\n"));
    }
    s
}

fn param(e: &FoundEffect, name: &str) -> f64 {
    e.params
        .get(name)
        .and_then(|v| v.as_f64())
        .unwrap_or(f64::NAN)
}

/// The effect is found alone with its parameters within 25 % (and one-sigma ≤ half the
/// value), and the residual after is at noise level.
fn check_single(s: &Synth, hidden: Hidden, keys: &[&str]) {
    let d = run(s);
    let text = summary(&d);
    assert_eq!(d.verdict, "missing_physics", "{text}");
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id, hidden.id(), "{text}");
    for (name, truth) in hidden.truth() {
        if !keys.contains(&name) {
            continue;
        }
        let v = param(e, name);
        assert!(
            (v - truth).abs() <= 0.25 * truth.abs(),
            "{name}: {v} vs truth {truth}\n{text}"
        );
        let sigma = e.uncertainty.get(name).copied().unwrap_or(f64::NAN);
        assert!(sigma <= 0.5 * v.abs(), "{name}: σ {sigma} vs {v}\n{text}");
    }
    assert!(
        d.rms_after_um <= 1.3 * s.noise.sigma_um,
        "rms after {} vs noise {}\n{text}",
        d.rms_after_um,
        s.noise.sigma_um
    );
}

fn with(hidden: &[Hidden]) -> Synth {
    Synth {
        hidden: hidden.to_vec(),
        seed: 7,
        ..Synth::default()
    }
}

#[test]
fn finds_scale_thermal_expansion() {
    let h = Hidden::ScaleThermal {
        alpha_ppm_per_k: 10.5,
        x0_mm: 0.0,
    };
    check_single(&with(&[h]), h, &["alpha_ppm_per_k"]);
}

#[test]
fn finds_scale_thermal_expansion_with_x0() {
    let h = Hidden::ScaleThermal {
        alpha_ppm_per_k: 11.5,
        x0_mm: 300.0,
    };
    check_single(&with(&[h]), h, &["alpha_ppm_per_k", "x0_mm"]);
}

#[test]
fn finds_scale_factor() {
    let h = Hidden::ScaleFactor { ppm: 4.0 };
    check_single(&with(&[h]), h, &["ppm"]);
}

#[test]
fn finds_abbe_along_z() {
    let h = Hidden::Abbe {
        along_z: true,
        theta0_urad: 5.0,
        theta1_urad_per_mm: 0.01,
    };
    let s = with(&[h]);
    check_single(&s, h, &["theta0_urad", "theta1_urad_per_mm"]);
    let d = run(&s);
    assert_eq!(d.effects[0].params["offset_axis"], "z");
}

#[test]
fn finds_abbe_along_y() {
    let h = Hidden::Abbe {
        along_z: false,
        theta0_urad: -8.0,
        theta1_urad_per_mm: 0.02,
    };
    let s = with(&[h]);
    check_single(&s, h, &["theta0_urad", "theta1_urad_per_mm"]);
    let d = run(&s);
    assert_eq!(d.effects[0].params["offset_axis"], "y");
}

#[test]
fn finds_reversal() {
    let h = Hidden::Reversal { b_um: 0.8 };
    check_single(&with(&[h]), h, &["b_um"]);
}

#[test]
fn finds_latch_delay() {
    let h = Hidden::LatchDelay { tau_us: 40.0 };
    check_single(&with(&[h]), h, &["tau_us"]);
}

#[test]
fn finds_periodic_scale_at_half_the_grating_period() {
    let h = Hidden::Periodic {
        amplitude_um: 0.15,
        period_um: 10.0,
        phase_rad: 0.7,
    };
    check_single(&with(&[h]), h, &["amplitude_um", "period_um"]);
}

#[test]
fn finds_periodic_scale_at_a_non_grating_period() {
    let h = Hidden::Periodic {
        amplitude_um: 0.2,
        period_um: 1000.0,
        phase_rad: -1.2,
    };
    check_single(&with(&[h]), h, &["amplitude_um", "period_um"]);
}

#[test]
fn finds_exponential_thermal_drift() {
    let h = Hidden::DriftExp {
        amplitude_um: 1.5,
        tau_s: 600.0,
    };
    check_single(&with(&[h]), h, &["amplitude_um", "tau_s"]);
}

#[test]
fn finds_dead_path() {
    let h = Hidden::DeadPath {
        dead_path_mm: 300.0,
    };
    let mut s = with(&[h]);
    s.env.air_temp_drift_k = 0.5;
    check_single(&s, h, &["dead_path_mm"]);
}

#[test]
fn finds_refraction() {
    let h = Hidden::Refraction {
        ppm_per_k: 0.93,
        ppm_per_hpa: -0.27,
    };
    check_single(&with(&[h]), h, &["ppm_per_k", "ppm_per_hpa"]);
}

#[test]
fn clean_recording_is_consistent() {
    let d = run(&with(&[]));
    assert_eq!(d.verdict, "consistent", "{}", summary(&d));
    assert!(d.effects.is_empty());
}

#[test]
fn smoke_print() {
    let d = run(&with(&[Hidden::Reversal { b_um: 0.8 }]));
    println!("{}", summary(&d));
    println!("{}", serde_json::to_string_pretty(&d).unwrap_or_default());
}
