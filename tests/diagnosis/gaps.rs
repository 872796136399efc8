//! The gaps a metrologist would still find (issue 16): every parameter of a named effect
//! with its σ, drift against dead path decided by physics, position-dependent reversal,
//! and a recording diagnosed without a simulation. Synthetic sessions from
//! `errmap::diagnose::synthesize` (seeded).

use crate::common::diagnosis_text;
use crate::effects::{config, with};
use errmap::base::{Axis, Drift, Effect};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, FoundEffect, diagnose};
use errmap::diagnose::{Synth, synthesize as generate};

fn run(s: &Synth) -> Diagnosis {
    let out = generate(s).expect("a positioning pair");
    diagnose(&out.recorded, &out.simulated, &config()).expect("diagnoses")
}

/// The found effect `id` (the test fails, with the diagnosis, without it).
fn found<'a>(d: &'a Diagnosis, id: &str) -> &'a FoundEffect {
    d.effects
        .iter()
        .find(|e| e.id().as_str() == id)
        .unwrap_or_else(|| panic!("no {id}\n{}", diagnosis_text(d)))
}

fn param(e: &FoundEffect, name: &str) -> (f64, f64) {
    let v = e.number_named(name).unwrap_or(f64::NAN);
    let s = e.sigma_named(name).unwrap_or(f64::NAN);
    (v, s)
}

/// The laser compensated with a stuck air-temperature input (the refraction follows the
/// air temperature, about −0.93 ppm/K by Edlén) while its pressure input was right: both
/// refraction parameters come back, fitted jointly, the pressure term ≈ 0 with a finite σ
/// and said to be consistent with zero.
#[test]
fn refraction_reports_both_parameters_when_pressure_is_compensated() {
    let h = Effect::Refraction {
        ppm_per_k: Some(0.93),
        ppm_per_hpa: Some(0.0),
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = found(&d, "refraction");
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
    let h = Effect::Abbe {
        offset_axis: Axis::Z,
        theta0_urad: 6.0,
        theta1_urad_per_mm: 0.0,
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = found(&d, "abbe");
    let (t0, s0) = param(e, "theta0_urad");
    assert!((t0 - 6.0).abs() <= 3.0 * s0, "{text}");
    let (t1, s1) = param(e, "theta1_urad_per_mm");
    assert!(s1 > 0.0 && t1.abs() <= 3.0 * s1, "{text}");
    assert!(e.where_.contains("theta1_urad_per_mm"), "{text}");

    let h = Effect::ScaleThermalExpansion {
        alpha_ppm_per_k: 10.5,
        x0_mm: 0.0,
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    let e = found(&d, "scale_thermal_expansion");
    let (a, sa) = param(e, "alpha_ppm_per_k");
    assert!((a - 10.5).abs() <= 3.0 * sa, "{text}");
    let (x0, sx) = param(e, "x0_mm");
    assert!(sx > 0.0 && x0.abs() <= 3.0 * sx, "x0 {x0} ± {sx}\n{text}");
}

/// The air drifting monotonically (no cycle, steady pressure): the dead-path column is a
/// smooth function of time, so a drift fits it as well.
fn monotone_air(hidden: &[Effect]) -> Synth {
    let mut s = with(hidden);
    s.env.air_temp_cycle = (0.0, 900.0);
    s.env.air_temp_drift_k = 0.6;
    s.env.pressure_cycle = (0.0, 5000.0);
    s
}

/// The separating plan is a plan file the simulator reads and the board accepts.
fn check_plan(d: &Diagnosis) -> String {
    let text = diagnosis_text(d);
    assert_eq!(d.separating_plans.len(), 1, "{text}");
    let sp = &d.separating_plans[0];
    let plan: errmap::sim::PlanSpec = toml::from_str(&sp.plan_toml)
        .unwrap_or_else(|e| panic!("plan does not parse: {e}\n{}", sp.plan_toml));
    plan.plan(std::path::Path::new("separating-plan.toml"))
        .unwrap_or_else(|e| panic!("plan refused: {e}\n{}", sp.plan_toml));
    assert_eq!(plan.targets_mm.len(), 1, "{}", sp.plan_toml);
    assert!(plan.dwell_s >= 600.0, "{}", sp.plan_toml);
    sp.basis.clone()
}

/// A 300 mm dead path under monotone air: a length the optics can have, so `dead_path`
/// is reported, the basis is stated, and the separating dwell is a ready plan.
#[test]
fn a_plausible_dead_path_is_kept_with_its_basis_and_plan() {
    let d = run(&monotone_air(&[Effect::DeadPath {
        dead_path_mm: 300.0,
    }]));
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id().as_str(), "dead_path", "{text}");
    let (dp, sd) = param(e, "dead_path_mm");
    assert!((dp - 300.0).abs() <= 3.0 * sd.max(10.0), "{text}");
    let basis = check_plan(&d);
    assert!(basis.contains("possible for the optics"), "{basis}");
    assert!(e.where_.contains("of physics"), "{text}");
    assert_eq!(d.separating_plans[0].chosen.as_str(), "dead_path");

    // The same data with the set-up's optics known to be 150 mm long: no dead path of
    // 300 mm is possible, so the drift is reported.
    let out = generate(&monotone_air(&[Effect::DeadPath {
        dead_path_mm: 300.0,
    }]))
    .expect("a positioning pair");
    let short = DiagnoseConfig {
        max_dead_path_mm: Some(150.0),
        ..config()
    };
    let d = diagnose(&out.recorded, &out.simulated, &short).expect("diagnoses");
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    assert_eq!(d.effects[0].id().as_str(), "thermal_drift", "{text}");
    assert!(check_plan(&d).contains("150 mm"), "{text}");
}

/// A machine drift of 1.2 µm under the same air would need a dead path of about 2.2 m,
/// longer than the 800 mm axis: `thermal_drift` is reported, with the basis and the plan.
#[test]
fn an_impossible_dead_path_decides_for_the_drift() {
    let d = run(&monotone_air(&[Effect::ThermalDrift(Drift::Linear {
        rate_um_per_s: 6e-4,
    })]));
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id().as_str(), "thermal_drift", "{text}");
    let basis = check_plan(&d);
    assert!(basis.contains("longer than"), "{basis}");
    assert!(e.where_.contains("dead_path"), "{text}");
    assert_eq!(d.separating_plans[0].chosen.as_str(), "thermal_drift");
}

/// Backlash growing along the axis (0.4 µm at x = 0 to 1.2 µm at 800 mm) is found as
/// position-dependent, with both parameters within their σ; a constant backlash is
/// still reported as one constant.
#[test]
fn position_dependent_reversal_is_found_and_constant_stays_constant() {
    let h = Effect::Reversal {
        b_um: 0.8,
        b1_um_per_m: Some(1.0),
    };
    let d = run(&with(&[h]));
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id().as_str(), "reversal", "{text}");
    let (b, sb) = param(e, "b_um");
    let (b1, sb1) = param(e, "b1_um_per_m");
    assert!((b - 0.8).abs() <= 3.0 * sb, "b {b} ± {sb}\n{text}");
    assert!(
        (b1 - 1.0).abs() <= 3.0 * sb1 && sb1 < 0.25,
        "b1 {b1} ± {sb1}\n{text}"
    );
    assert!(e.where_.contains("changes along the axis"), "{text}");
    assert!(d.rms_after_um <= 1.3 * 0.05, "{text}");

    let d = run(&with(&[Effect::Reversal {
        b_um: 0.8,
        b1_um_per_m: None,
    }]));
    let text = diagnosis_text(&d);
    assert_eq!(d.effects.len(), 1, "{text}");
    let e = &d.effects[0];
    assert_eq!(e.id().as_str(), "reversal", "{text}");
    assert!(e.param_named("b1_um_per_m").is_none(), "{text}");
    assert!(!e.where_.contains("changes along the axis"), "{text}");
    let (b, sb) = param(e, "b_um");
    assert!((b - 0.8).abs() <= 3.0 * sb, "{text}");
}

/// A recording alone (no simulation): the static part — here a geometric map, a scale
/// factor and a reversal — is the recording's own, and a concealed linear drift is found
/// in what is left, within its σ.
#[test]
fn recorded_only_finds_a_concealed_drift() {
    let s = with(&[
        Effect::Reversal {
            b_um: 0.8,
            b1_um_per_m: None,
        },
        Effect::ScaleFactor { ppm: 4.0 },
        Effect::ThermalDrift(Drift::Linear {
            rate_um_per_s: 4e-4,
        }),
    ]);
    let out = generate(&s).expect("a positioning pair");
    let d = errmap::diagnose::diagnose_recorded(&out.recorded, &config()).expect("diagnoses");
    let text = diagnosis_text(&d);
    let ids: Vec<&str> = d.effects.iter().map(|e| e.id().as_str()).collect();
    assert_eq!(ids, ["thermal_drift"], "{text}");
    let e = &d.effects[0];
    let (rate, sr) = if e.param_named("rate_um_per_s").is_some() {
        param(e, "rate_um_per_s")
    } else {
        // An exponential: its mean slope over the session.
        let (a, _) = param(e, "amplitude_um");
        let (tau, _) = param(e, "tau_s");
        let span = out.recorded.last().map_or(1.0, |r| r.t_s);
        (a * (1.0 - (-span / tau).exp()) / span, f64::NAN)
    };
    assert!(
        (rate - 4e-4).abs() <= 3.0 * sr.max(0.1 * 4e-4),
        "rate {rate} ± {sr}\n{text}"
    );
    let map = d.static_map.as_ref().expect("static map");
    // The reversal of the map is the concealed one (ē↑ − ē↓ = b).
    assert!((map.mean_reversal_um - 0.8).abs() < 0.05, "{map:?}");
    assert!(d.rms_after_um <= 1.3 * s.noise.sigma_um, "{text}");
}

/// A recording with static effects only (map, scale factor, reversal, Abbe): nothing is
/// left beyond the map, so no effect is reported.
#[test]
fn recorded_only_clean_recording_gives_no_effect() {
    let s = with(&[
        Effect::Reversal {
            b_um: 0.8,
            b1_um_per_m: None,
        },
        Effect::ScaleFactor { ppm: 4.0 },
        Effect::Abbe {
            offset_axis: Axis::Z,
            theta0_urad: 5.0,
            theta1_urad_per_mm: 0.01,
        },
    ]);
    let out = generate(&s).expect("a positioning pair");
    let d = errmap::diagnose::diagnose_recorded(&out.recorded, &config()).expect("diagnoses");
    let text = diagnosis_text(&d);
    assert_eq!(d.verdict.as_str(), "consistent", "{text}");
    assert!(d.effects.is_empty(), "{text}");
}

/// The real ISO 230-2 record b02-x-log (41 min, real time stamps, dwell rows only): the
/// drift left beyond the map and the reversal is checked against an independent
/// computation — the plain least-squares slope of (error − its mean per target and
/// direction) on (t − its mean per target and direction), with a cluster-robust σ over
/// the 90 dwells — and removing it lowers the ISO 230-2 repeatability.
#[test]
fn recorded_only_on_the_real_b02_record() {
    let Some(path) = crate::util::real_record("b02-x-log.csv") else {
        return;
    };
    let rows = errmap::session::read_session(&path).expect("reads b02-x-log.csv");
    let d =
        errmap::diagnose::diagnose_recorded(&rows, &DiagnoseConfig::default()).expect("diagnoses");
    let text = diagnosis_text(&d);

    // Independent: within transform by (target, direction), plain least squares.
    use std::collections::BTreeMap;
    let key = |r: &errmap_drivers::SessionRow| (r.target, r.direction);
    let mut sums: BTreeMap<(i32, i8), (f64, f64, f64)> = BTreeMap::new();
    for r in &rows {
        let s = sums.entry(key(r)).or_insert((0.0, 0.0, 0.0));
        s.0 += r.error_um;
        s.1 += r.t_s;
        s.2 += 1.0;
    }
    let within: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| {
            let s = sums[&key(r)];
            (r.error_um - s.0 / s.2, r.t_s - s.1 / s.2)
        })
        .collect();
    let stt: f64 = within.iter().map(|(_, t)| t * t).sum();
    let slope = within.iter().map(|(e, t)| e * t).sum::<f64>() / stt;
    let mut score: BTreeMap<(u32, i32, i8), f64> = BTreeMap::new();
    for (r, (e, t)) in rows.iter().zip(&within) {
        *score.entry((r.run, r.target, r.direction)).or_insert(0.0) += t * (e - slope * t);
    }
    let robust = score.values().map(|u| u * u).sum::<f64>().sqrt() / stt;

    let e = found(&d, "thermal_drift");
    assert_eq!(d.effects.len(), 1, "{text}");
    let (rate, sr) = param(e, "rate_um_per_s");
    assert!(
        (rate - slope).abs() <= 0.2 * robust,
        "rate {rate} ± {sr} against the plain slope {slope} ± {robust}\n{text}"
    );
    assert!(
        sr > 0.7 * robust && sr < 1.5 * robust,
        "σ {sr} against the cluster-robust {robust}\n{text}"
    );

    let iso = errmap::report::iso_effect(&rows, &d);
    let (before, after) = (&iso.measured[0], &iso.effects_removed[0]);
    assert!(after.r_um < before.r_um - 5.0, "{iso:?}");
    assert!((after.b_um - before.b_um).abs() < 1.0, "{iso:?}");
}

/// `errmap diagnose --recorded REC --report DIR --json` with nothing to compare against:
/// exit 0, the static map and the ISO 230-2 figures with the drift removed in the JSON,
/// the table in the report.
#[test]
fn recorded_only_from_the_command_line() {
    let Some(path) = crate::util::real_record("b02-x-log.csv") else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let report = dir.path().join("report");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_errmap"))
        .args(["diagnose", "--recorded"])
        .arg(&path)
        .arg("--report")
        .arg(&report)
        .arg("--json")
        .output()
        .expect("runs errmap");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON document");
    assert_eq!(v["effects"][0]["id"], "thermal_drift", "{v}");
    assert!(v["static_map"]["dwell_groups"].as_u64() == Some(18), "{v}");
    let r0 = v["iso230"]["measured"][0]["r_um"]
        .as_f64()
        .expect("R measured");
    let r1 = v["iso230"]["effects_removed"][0]["r_um"]
        .as_f64()
        .expect("R removed");
    assert!(r1 < r0, "{v}");
    let md = std::fs::read_to_string(report.join("report.md")).expect("report.md");
    assert!(
        md.contains("ISO 230-2 figures with the found effects removed"),
        "{md}"
    );
    assert!(md.contains("Static part taken from the recording"), "{md}");
}

/// `diagnose --max-rows` below the recording's length thins it uniformly in time (and the
/// simulation with it), says so, and still finds the concealed drift: the 13 145-row case
/// on a 4 000-row budget is diagnosed on every 4th sample.
#[test]
fn a_recording_longer_than_the_row_budget_is_thinned_and_still_diagnosed() {
    let case =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/concealed/thermal_drift");
    let dir = tempfile::tempdir().expect("tempdir");
    let report = dir.path().join("report");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_errmap"))
        .arg("diagnose")
        .arg("--recorded")
        .arg(case.join("recorded.parquet"))
        .arg("--simulated")
        .arg(case.join("simulated.parquet"))
        .args(["--max-rows", "4000", "--json", "--report"])
        .arg(&report)
        .output()
        .expect("runs errmap");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON document");
    let rows = v["matching"]["recorded_rows"].as_u64().expect("rows");
    assert!((3000..=4000).contains(&rows), "{rows} rows kept of 13 145");
    let notes = v["design_notes"].to_string();
    assert!(notes.contains("multiple of 4"), "{notes}");
    assert!(err.contains("13145 rows"), "{err}");
    let e = &v["effects"][0];
    assert_eq!(e["id"], "thermal_drift", "{v}");
    // truth.json: amplitude 1.5 µm, τ 400 s; within 4σ of the thinned fit's own σ.
    for (name, truth) in [("amplitude_um", 1.5), ("tau_s", 400.0)] {
        let (p, s) = (e["params"][name].as_f64(), e["uncertainty"][name].as_f64());
        let (p, s) = (p.expect("param"), s.expect("σ"));
        assert!(
            (p - truth).abs() < 4.0 * s,
            "{name} {p} ± {s}, truth {truth}"
        );
    }
}
