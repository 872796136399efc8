//! The gaps a metrologist would still find (issue 16): every parameter of a named effect
//! with its σ, drift against dead path decided by physics, position-dependent reversal,
//! and a recording diagnosed without a simulation. Synthetic sessions from
//! `errmap::diagnose::synth` (seeded).

use crate::common::diagnosis_text;
use errmap::diagnose::synth::{Hidden, Synth, generate};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, FoundEffect, diagnose};

fn config() -> DiagnoseConfig {
    DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    }
}

fn with(hidden: &[Hidden]) -> Synth {
    Synth {
        hidden: hidden.to_vec(),
        seed: 7,
        geometric_um: 8.0,
        ..Synth::default()
    }
}

fn run(s: &Synth) -> Diagnosis {
    let out = generate(s);
    diagnose(&out.recorded, &out.simulated, &config()).expect("diagnoses")
}

fn param(e: &FoundEffect, name: &str) -> (f64, f64) {
    let v = e
        .params
        .get(name)
        .and_then(|v| v.as_f64())
        .unwrap_or(f64::NAN);
    let s = e.uncertainty.get(name).copied().unwrap_or(f64::NAN);
    (v, s)
}

/// The laser compensated with a stuck air-temperature input (the refraction follows the
/// air temperature, about −0.93 ppm/K by Edlén) while its pressure input was right: both
/// refraction parameters come back, fitted jointly, the pressure term ≈ 0 with a finite σ
/// and said to be consistent with zero.
#[test]
fn refraction_reports_both_parameters_when_pressure_is_compensated() {
    let h = Hidden::Refraction {
        ppm_per_k: 0.93,
        ppm_per_hpa: 0.0,
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = d
        .effects
        .iter()
        .find(|e| e.id == "refraction")
        .unwrap_or_else(|| panic!("no refraction\n{text}"));
    let (a, sa) = param(e, "ppm_per_k");
    assert!((a - 0.93).abs() <= 3.0 * sa && sa < 0.2, "{text}");
    let (b, sb) = param(e, "ppm_per_hpa");
    assert!(sb.is_finite() && sb > 0.0, "ppm_per_hpa σ {sb}\n{text}");
    assert!(b.abs() <= 3.0 * sb, "ppm_per_hpa {b} ± {sb}\n{text}");
    assert!(
        e.where_.contains("ppm_per_hpa") && e.where_.contains("consistent with zero"),
        "{text}"
    );
    assert!(!e.where_.contains("ppm_per_k = "), "{text}");
}

/// Abbe with θ1 = 0 and scale expansion about x0 = 0: the other parameter is reported
/// with its σ and consistent with zero; the determined one is not flagged.
#[test]
fn abbe_and_scale_expansion_report_every_parameter() {
    let h = Hidden::Abbe {
        along_z: true,
        theta0_urad: 6.0,
        theta1_urad_per_mm: 0.0,
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = d
        .effects
        .iter()
        .find(|e| e.id == "abbe")
        .unwrap_or_else(|| panic!("no abbe\n{text}"));
    let (t0, s0) = param(e, "theta0_urad");
    assert!((t0 - 6.0).abs() <= 3.0 * s0, "{text}");
    let (t1, s1) = param(e, "theta1_urad_per_mm");
    assert!(s1 > 0.0 && t1.abs() <= 3.0 * s1, "{text}");
    assert!(e.where_.contains("theta1_urad_per_mm"), "{text}");

    let h = Hidden::ScaleThermal {
        alpha_ppm_per_k: 10.5,
        x0_mm: 0.0,
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = d
        .effects
        .iter()
        .find(|e| e.id == "scale_thermal_expansion")
        .unwrap_or_else(|| panic!("no scale_thermal_expansion\n{text}"));
    let (a, sa) = param(e, "alpha_ppm_per_k");
    assert!((a - 10.5).abs() <= 3.0 * sa, "{text}");
    let (x0, sx) = param(e, "x0_mm");
    assert!(sx > 0.0 && x0.abs() <= 3.0 * sx, "x0 {x0} ± {sx}\n{text}");
}

