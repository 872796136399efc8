//! The physics simulator: every effect term has exactly the vocabulary's signature
//! (`docs/vocabulary.md`), the direct evaluation at recorded rows agrees with the full
//! board → wire → decoder path, and the model files parse.

use crate::util::root;
use std::path::{Path, PathBuf};

use errmap::sim::{
    Abbe, History, LatchDelay, MachineModel, PeriodicScale, Refraction, Reversal, Scale,
    ScaleFactor, ThermalDrift, simulate_rows, simulate_session,
};
use errmap_drivers::SessionRow;
use errmap_drivers::edlen::refractive_index;

fn base() -> (MachineModel, PathBuf) {
    let m = errmap::sim::concealed_nominal(&root().join("datasets/table1.csv"), 1);
    (m, root().join("datasets/model.toml"))
}

fn recorded(m: &MachineModel, path: &Path) -> Vec<SessionRow> {
    let plan = errmap_drivers::sim::Plan {
        runs: 2,
        ..errmap::sim::concealed_plan()
    };
    simulate_session(m, path, &plan, false).expect("simulates")
}

/// r = hidden − nominal at every row, by direct evaluation.
fn residual(change: impl Fn(&mut MachineModel)) -> (Vec<SessionRow>, Vec<f64>) {
    let (nominal, path) = base();
    let rows = recorded(&nominal, &path);
    let mut hidden = nominal.clone();
    change(&mut hidden);
    let a = simulate_rows(&hidden, &path, &rows).expect("hidden");
    let b = simulate_rows(&nominal, &path, &rows).expect("nominal");
    let r = a
        .iter()
        .zip(&b)
        .map(|(a, b)| a.error_um - b.error_um)
        .collect();
    (a, r)
}

/// Compares r with a signature up to the constant the origin removes.
fn assert_signature(rows: &[SessionRow], r: &[f64], sig: impl Fn(&SessionRow) -> f64, tol: f64) {
    let s: Vec<f64> = rows.iter().map(&sig).collect();
    let offset = r[0] - s[0];
    for (k, (row, (ri, si))) in rows.iter().zip(r.iter().zip(&s)).enumerate() {
        assert!(
            (ri - si - offset).abs() < tol,
            "row {k} {row:?}: r {ri} vs signature {si}"
        );
    }
}

fn v(r: &SessionRow) -> f64 {
    if r.target >= 0 {
        0.0
    } else {
        r.feed_mm_s.unwrap_or(0.0)
    }
}

#[test]
fn each_effect_has_the_vocabulary_signature() {
    let (rows, r) = residual(|m| {
        m.scale = Some(Scale {
            enabled: true,
            material: "steel".into(),
            cte_ppm_per_k: 11.5,
            x0_mm: 50.0,
        })
    });
    // The wire carries the scale temperature in m°C: compare within that rounding.
    // A row's temperature is the latest MATERIAL frame's (1 s period, m°C): the scale warms
    // ≤ 1.3 m°C/s here, so 11.5 ppm/K × 1.3 m°C × 850 mm ≈ 0.013 µm at most.
    assert_signature(
        &rows,
        &r,
        |w| -11.5 * (w.scale_temp_c.expect("T") - 20.0) * (w.scale_mm - 50.0) * 1e-3,
        0.015,
    );

    let (rows, r) = residual(|m| {
        m.scale_factor = Some(ScaleFactor {
            enabled: true,
            ppm: 4.0,
        })
    });
    assert_signature(&rows, &r, |w| 4.0 * w.scale_mm * 1e-3, 1e-9);

    let (rows, r) = residual(|m| {
        m.abbe = Some(Abbe {
            enabled: true,
            offset_axis: errmap::base::Axis::Z,
            theta0_urad: 3.0,
            theta1_urad_per_mm: 0.01,
        })
    });
    assert_signature(
        &rows,
        &r,
        |w| w.z_mm.unwrap_or(200.0) * (3.0 + 0.01 * w.scale_mm) * 1e-3,
        1e-9,
    );

    let (rows, r) = residual(|m| {
        m.reversal = Some(Reversal {
            enabled: true,
            b_um: 1.4,
        })
    });
    assert_signature(&rows, &r, |w| f64::from(w.direction) * 0.7, 1e-12);

    let (rows, r) = residual(|m| {
        m.latch_delay = Some(LatchDelay {
            enabled: true,
            tau_us: 7.0,
        })
    });
    assert_signature(&rows, &r, |w| f64::from(w.direction) * v(w) * 7.0e-3, 1e-9);

    let (rows, r) = residual(|m| {
        m.periodic_scale = Some(PeriodicScale {
            enabled: true,
            amplitude_um: 0.2,
            period_um: 20.0,
            phase_rad: 0.3,
        })
    });
    assert_signature(
        &rows,
        &r,
        |w| 0.2 * (std::f64::consts::TAU * w.scale_mm * 1000.0 / 20.0 + 0.3).sin(),
        1e-6,
    );

    let (rows, r) = residual(|m| {
        m.thermal_drift = Some(ThermalDrift {
            enabled: true,
            amplitude_um: 1.5,
            tau_s: Some(400.0),
            rate_um_per_s: 0.0,
        })
    });
    assert_signature(&rows, &r, |w| 1.5 * (1.0 - (-w.t_s / 400.0).exp()), 1e-9);

    let (rows, r) = residual(|m| m.laser.dead_path_mm = 500.0);
    let n = |w: &SessionRow| {
        refractive_index(
            0.632991354,
            w.air_temp_c.expect("T"),
            w.air_pressure_hpa.expect("p") * 100.0,
            w.air_rh_pct.expect("RH"),
        )
    };
    let n0 = n(&rows[0]);
    // The air columns are the latest ENV frame's (1 s period, m°C and Pa): the air changes
    // ≤ 3 m°C/s here, 500 mm × 3e-9 ≈ 1.5e-3 µm.
    assert_signature(&rows, &r, |w| -500.0 * (n(w) - n0) * 1e3, 5e-3);

    let (rows, r) = residual(|m| {
        m.refraction = Some(Refraction {
            enabled: true,
            ppm_per_k: 0.93,
            ppm_per_hpa: -0.27,
        })
    });
    let tm = rows.iter().map(|w| w.air_temp_c.expect("T")).sum::<f64>() / rows.len() as f64;
    let pm = rows
        .iter()
        .map(|w| w.air_pressure_hpa.expect("p"))
        .sum::<f64>()
        / rows.len() as f64;
    // T̄, p̄ are the session means of the histories; the rows' means differ slightly, a
    // scale-factor-like difference far below the noise (checked loosely here).
    assert_signature(
        &rows,
        &r,
        |w| {
            -w.scale_mm
                * 1e-3
                * (0.93 * (w.air_temp_c.expect("T") - tm)
                    - 0.27 * (w.air_pressure_hpa.expect("p") - pm))
        },
        0.02,
    );
}

#[test]
fn direct_evaluation_agrees_with_the_wire_path() {
    let (mut m, path) = base();
    m.reversal = Some(Reversal {
        enabled: true,
        b_um: 1.0,
    });
    m.scale = Some(Scale {
        enabled: true,
        material: "steel".into(),
        cte_ppm_per_k: 11.5,
        x0_mm: 0.0,
    });
    let rows = recorded(&m, &path);
    let direct = simulate_rows(&m, &path, &rows).expect("direct");
    let simulated: Vec<&SessionRow> = rows
        .iter()
        .filter(|r| r.run > 0 || r.feed_mm_s.is_none())
        .collect();
    assert_eq!(simulated.len(), direct.len());
    assert!(direct.len() > rows.len() * 9 / 10);
    for (w, d) in simulated.into_iter().zip(&direct) {
        // Counter quantisation: scale 0.1 µm and laser λ/8 ≈ 0.079 µm.
        assert!(
            (w.error_um - d.error_um).abs() < 0.1,
            "{w:?} vs {}",
            d.error_um
        );
    }
}

#[test]
fn histories_follow_their_definitions() {
    let ramp = History::Ramp {
        start: 20.0,
        end: 21.0,
        duration_s: 100.0,
    };
    assert_eq!(
        (ramp.at(-5.0), ramp.at(50.0), ramp.at(500.0)),
        (20.0, 20.5, 21.0)
    );
    let cyc = History::Cycle {
        mean: 20.0,
        amplitude: 0.5,
        period_s: 40.0,
        phase_rad: 0.0,
    };
    assert!((cyc.at(10.0) - 20.5).abs() < 1e-12);
    let exp = History::Exponential {
        start: 20.0,
        end: 21.0,
        tau_s: 100.0,
    };
    assert!((exp.at(100.0) - (21.0 - (-1f64).exp())).abs() < 1e-12);
    let table = History::Table {
        t_s: vec![0.0, 10.0, 30.0],
        value: vec![1.0, 3.0, 2.0],
    };
    assert_eq!(
        (table.at(5.0), table.at(20.0), table.at(99.0)),
        (2.0, 2.5, 2.0)
    );
}

#[test]
fn the_example_model_parses_and_bad_models_are_refused() {
    let m = MachineModel::read(&root().join("datasets/physics/example-model.toml"))
        .expect("example parses");
    assert!(m.scale.is_some() && m.error_map.is_some());
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "noise_um = -1\n").expect("write");
    let e = MachineModel::read(&bad).expect_err("negative noise");
    assert!(
        e.to_string().contains("bad.toml") && e.to_string().contains("noise_um"),
        "{e}"
    );
    std::fs::write(&bad, "[reversal]\nb_um = 1\nbogus = 2\n").expect("write");
    let e = MachineModel::read(&bad).expect_err("unknown key");
    assert!(e.to_string().contains("bogus"), "{e}");
}

/// Dwell samples latched before the first ENV frame (no air values while other rows have
/// them) read ~270 ppm long: the reduction leaves them out and counts them, so the error
/// table is unaffected; a session with no air values at all is reduced as written.
#[test]
fn samples_before_the_first_env_are_left_out_of_the_error_table() {
    use errmap::session::{error_table, iso_observations, read_session};
    let rows = read_session(&root().join("datasets/physics/example-session.parquet"))
        .expect("example session");
    let (clean, s0) = error_table("example", &rows).expect("reduces");
    assert_eq!(s0.uncompensated, 0);
    assert!(!s0.no_air_data);
    // Make 40 dwell samples far along the axis (where the bias is large) look latched
    // before any ENV: no air values, and the uncompensated error they would carry
    // (n − 1 ≈ 270 ppm of the laser length, ~0.1 mm here).
    let mut early = rows.clone();
    for r in early
        .iter_mut()
        .filter(|r| r.target >= 0 && r.run > 0 && r.scale_mm > 300.0)
        .take(40)
    {
        r.air_temp_c = None;
        r.air_pressure_hpa = None;
        r.air_rh_pct = None;
        r.error_um -= 270e-6 * r.laser_mm * 1000.0;
    }
    let (table, s1) = error_table("early", &early).expect("reduces");
    assert_eq!(s1.uncompensated, 40);
    assert_eq!(s1.used, s0.used - 40);
    for (a, b) in table.points.iter().zip(&clean.points) {
        assert_eq!(a.position(), b.position());
        // Fewer samples in a few nodes' means: noise-level change, not the ~0.1 mm bias.
        assert!((a.e_um - b.e_um).abs() < 0.05, "{a:?} vs {b:?}");
    }
    assert_eq!(
        iso_observations(&early, None).len(),
        iso_observations(&rows, None).len(),
        "each dwell still has later compensated samples"
    );
    // No air values anywhere: nothing to tell early rows by; reduced as written.
    let mut none = rows.clone();
    for r in &mut none {
        r.air_temp_c = None;
        r.air_pressure_hpa = None;
        r.air_rh_pct = None;
    }
    let (t2, s2) = error_table("no air", &none).expect("reduces");
    assert!(s2.no_air_data);
    assert_eq!((s2.uncompensated, s2.used), (0, s0.used));
    assert_eq!(t2.points.len(), clean.points.len());
}

/// A session from the example model — whose board counts the scale in 0.1 µm steps —
/// along `axis` (X or Y, 2 lines × 5 targets × 3 runs), with `hide` applied to the
/// recording's model; returns the diagnosis against the unchanged model.
fn coarse_counter_diagnosis(
    axis: &str,
    hide: impl Fn(&mut MachineModel),
) -> errmap::diagnose::Diagnosis {
    coarse_counter_diagnosis_with(axis, None, "", hide)
}

/// [`coarse_counter_diagnosis`] with other targets (a TOML list) and extra plan lines.
fn coarse_counter_diagnosis_with(
    axis: &str,
    targets: Option<&str>,
    extra: &str,
    hide: impl Fn(&mut MachineModel),
) -> errmap::diagnose::Diagnosis {
    use errmap::diagnose::{DiagnoseConfig, diagnose};
    let model_path = root().join("datasets/physics/example-model.toml");
    let model = MachineModel::read(&model_path).expect("example model");
    assert_eq!(
        model.device.count_resolution_pm, 100_000,
        "the premise: a 0.1 µm counter"
    );
    let (lines, default_targets) = match axis {
        "X" => (
            "[[1.0, 200.0], [400.0, 500.0]]",
            "[1.2424, 200.0, 400.0, 600.0, 800.0]",
        ),
        _ => (
            "[[200.0, 200.0], [600.0, 350.0]]",
            "[1.0, 100.0, 200.0, 300.0, 400.0]",
        ),
    };
    let targets = targets.unwrap_or(default_targets);
    let dir = tempfile::tempdir().expect("tempdir");
    let plan_path = dir.path().join("plan.toml");
    std::fs::write(
        &plan_path,
        format!(
            "axis = \"{axis}\"\nlines_mm = {lines}\ntargets_mm = {targets}\nruns = 3\n\
             feed_mm_s = 120.0\ndwell_s = 0.5\nsample_hz = 50.0\nsettle_s = 0.2\n{extra}"
        ),
    )
    .expect("plan");
    let plan = errmap::sim::read_plan(Some(&plan_path)).expect("plan reads");
    let mut hidden = model.clone();
    hide(&mut hidden);
    let rec = simulate_session(&hidden, &model_path, &plan, true).expect("simulates");
    let sim = simulate_rows(&model, &model_path, &rec).expect("evaluates");
    diagnose(&rec, &sim, &DiagnoseConfig::default()).expect("diagnoses")
}

fn ids(d: &errmap::diagnose::Diagnosis) -> Vec<&str> {
    d.effects.iter().map(|e| e.id().as_str()).collect()
}

/// Clean sessions on the 0.1 µm counter are `consistent` along X and Y: the ~0.01 µm
/// structure that quantisation leaves when sampling is locked to the counter's grid is not
/// blamed on refraction or dead path. A hidden reversal is found alone, and a drift of
/// 0.12 µm over the session (0.027 µm RMS, of the order of the quantisation) is still found.
#[test]
fn coarse_counter_quantisation_is_not_an_effect() {
    for axis in ["X", "Y"] {
        let d = coarse_counter_diagnosis(axis, |_| {});
        assert_eq!(d.verdict.as_str(), "consistent", "{axis}: {:?}", ids(&d));
    }
    let d = coarse_counter_diagnosis("Y", |m| {
        m.reversal = Some(Reversal {
            enabled: true,
            b_um: 1.2,
        })
    });
    assert_eq!(ids(&d), ["reversal"]);
    let d = coarse_counter_diagnosis("Y", |m| {
        if let Some(t) = m.thermal_drift.as_mut() {
            t.enabled = true;
        }
    });
    assert_eq!(ids(&d), ["thermal_drift"]);
    // A 10 µm periodic error along X, without the 0.6 mm "period" that the 2.4 mm pitch of
    // the moving samples (120 mm/s at 50 Hz) puts into the quantisation error.
    // With a second feed of 60 mm/s (1.2 mm pitch) on 4 targets.
    let d = coarse_counter_diagnosis_with(
        "X",
        Some("[1.2424, 267.4949, 533.7475, 800.0]"),
        "extra_feeds_mm_s = [60.0]\n",
        |m| {
            m.periodic_scale = Some(PeriodicScale {
                enabled: true,
                amplitude_um: 0.2,
                period_um: 10.0,
                phase_rad: 0.012,
            })
        },
    );
    assert_eq!(ids(&d), ["periodic_scale"]);
}
