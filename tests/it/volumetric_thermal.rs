//! A campaign during which the scales warmed (spec `volumetric.md`, "Line table";
//! `docs/vocabulary.md`'s `scale_thermal_expansion`): the simulator's thermal history (sign
//! and size by hand), the joint fit of α with the 21 errors on random seeded campaigns
//! (α within 3σ, components at 20 °C within their σ), no false alarm on rigid campaigns
//! with temperatures, an undetermined α when the temperature never changes, bad
//! `[thermal]` and α input, and the command line's effect shape.

use std::path::Path;

use errmap::volumetric::{
    Component, Degree, GaugeTruth, IdentifyConfig, Machine, PlanFile, ThermalHistory, identify,
    simulate,
};
use rand::SeedableRng;
use rand::rngs::StdRng;

use super::volumetric::{VOLUME, errmap, plan_file, random_machine, topo, write};

const WARMING: ThermalHistory = ThermalHistory {
    start_c: 20.0,
    end_c: 22.5,
    tau_s: 4.0 * 3600.0,
};

fn warm_plan(seed: u64, thermal: ThermalHistory) -> errmap::volumetric::Plan {
    let mut f = plan_file(Some("rich"), seed, 0.1);
    f.thermal = Some(thermal);
    f.validate(Path::new("test")).expect("plan")
}

#[test]
fn a_warm_scale_shifts_an_axis_line_by_minus_alpha_dt_a() {
    // One line along X, no noise, no laser zero, the scale at a constant 25 °C:
    // E_XX gains +α·ΔT·x·1e−3 (the scale carries X further than it indicates), the laser
    // records e = −u·E = −10·5·x·1e−3 µm: −40 µm at 800 mm.
    let mut m = Machine::perfect(topo("YXZ"));
    m.scale_alpha_ppm_per_k = 10.0;
    let mut f = plan_file(None, 1, 0.0);
    f.laser_zero_um = 0.0;
    f.volume_mm = None;
    f.thermal = Some(ThermalHistory {
        start_c: 25.0,
        end_c: 25.0,
        tau_s: 1.0,
    });
    f.lines = vec![
        toml::from_str("start_mm = [0, 100, 50]\nend_mm = [800, 100, 50]\ntargets = 5")
            .expect("line"),
        toml::from_str("start_mm = [800, 600, 0]\nend_mm = [0, 0, 0]\ntargets = 3").expect("line"),
    ];
    let table = simulate(&m, &f.validate(Path::new("t")).expect("plan"));
    let x = &table.lines[0];
    for t in &x.targets {
        let want = -10.0 * 5.0 * t.pos_mm[0] * 1e-3;
        assert!((t.e_um.expect("e") - want).abs() < 1e-12, "{t:?}");
        assert_eq!(t.scale_temp_c, Some(25.0));
    }
    // The diagonal from (800, 600, 0) towards 0: u = −(0.8, 0.6, 0), e = −u·α·ΔT·P·1e−3
    // = +0.05·(0.8·800 + 0.6·600) = 50 µm at the start, 0 at the origin.
    let d = &table.lines[1];
    let e: Vec<f64> = d.targets.iter().map(|t| t.e_um.expect("e")).collect();
    assert!((e[0] - 50.0).abs() < 1e-12 && (e[1] - 25.0).abs() < 1e-12 && e[2].abs() < 1e-12);
}

#[test]
fn the_thermal_history_is_exponential_and_written_with_the_time() {
    let plan = warm_plan(3, WARMING);
    let table = simulate(&Machine::perfect(topo("XYZ")), &plan);
    for t in table.lines.iter().flat_map(|l| &l.targets) {
        let ts = t.t_s.expect("t_s");
        let want = 22.5 - 2.5 * (-ts / (4.0 * 3600.0)).exp();
        assert!((t.scale_temp_c.expect("temp") - want).abs() < 1e-12);
    }
    // Written and read back.
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("lines.csv");
    table.write(&path).expect("write");
    let back = errmap::volumetric::LineTable::read(&path, true).expect("read");
    let temps = |t: &errmap::volumetric::LineTable| {
        t.lines
            .iter()
            .flat_map(|l| l.targets.iter().map(|t| t.scale_temp_c.expect("temp")))
            .collect::<Vec<f64>>()
    };
    for (a, b) in temps(&table).iter().zip(temps(&back)) {
        assert!((a - b).abs() < 1e-9);
    }
}

#[test]
fn warming_campaigns_recover_alpha_within_3_sigma_and_the_components_at_20_c() {
    let mut z = Vec::new();
    for (i, t) in ["YXZ", "XZY", "ZYX"].iter().enumerate() {
        let seed = 40 + i as u64;
        let mut rng = StdRng::seed_from_u64(seed);
        let mut m = random_machine(topo(t), &mut rng);
        m.scale_alpha_ppm_per_k = 11.5;
        let table = simulate(&m, &warm_plan(seed, WARMING));
        let mut cfg = IdentifyConfig::new(topo(t));
        cfg.degree = Degree::Fixed(3);
        cfg.basis = errmap::volumetric::BasisKind::Poly;
        let id = identify(&table, &cfg).expect("identify");
        let th = id.thermal.as_ref().expect("temperatures in the table");
        let (a, s) = (
            th.alpha_ppm_per_k.expect("determined"),
            th.sigma_ppm_per_k.expect("sigma"),
        );
        assert!(th.kept, "{t}: α = {a} ± {s}");
        assert!((a - 11.5).abs() < 3.0 * s, "{t}: α = {a} ± {s}");
        assert!(s < 0.5, "{t}: σ_α = {s} ppm/K");
        assert_eq!(id.residual.verdict.as_str(), "missing_physics");
        assert_eq!(id.residual.effects.len(), 1, "{:?}", id.residual.effects);
        let e = &id.residual.effects[0];
        assert_eq!(e.id().as_str(), "scale_thermal_expansion");
        assert_eq!(e.number_named("alpha_ppm_per_k"), Some(a));
        assert_eq!(e.sigma_named("alpha_ppm_per_k").expect("a one-sigma"), s);
        // The term is microns: ΔT up to ~2 K × 11.5 ppm/K × up to 1000 mm.
        assert!(e.explains_um > 1.0, "explains {}", e.explains_um);
        // The residual after the joint fit is noise (0.1 µm).
        assert!(id.rms_residual_um < 0.15, "{}", id.rms_residual_um);
        // The components are those at 20 °C: the machine without expansion.
        let gauge = GaugeTruth::of(&m, id.fit.basis.range_mm);
        for c in Component::all() {
            for pos in [0.5 * VOLUME[1][c.axis], VOLUME[1][c.axis]] {
                let (v, s) = id.fit.component(c.index(), pos).expect("identified");
                z.push((v - gauge.value(&m, c, pos)) / s);
            }
        }
        for k in 0..3 {
            let (v, s) = id.fit.squareness(k).expect("identified");
            z.push((v - gauge.squareness_urad[k]) / s);
        }
    }
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    let max = z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(max < 4.5, "max |z| = {max}");
    assert!((0.7..1.35).contains(&rms), "RMS z {rms} (n = {})", z.len());
}

#[test]
fn ignoring_the_temperature_would_bias_the_positioning_components() {
    // The same warming campaign without its temperature column: the rigid fit cannot
    // absorb the change between lines and calls the residual missing physics.
    let mut rng = StdRng::seed_from_u64(5);
    let mut m = random_machine(topo("YXZ"), &mut rng);
    m.scale_alpha_ppm_per_k = 11.5;
    let mut table = simulate(&m, &warm_plan(5, WARMING));
    for t in table.lines.iter_mut().flat_map(|l| &mut l.targets) {
        t.scale_temp_c = None;
    }
    let mut cfg = IdentifyConfig::new(topo("YXZ"));
    cfg.degree = Degree::Fixed(3);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&table, &cfg).expect("identify");
    assert!(id.thermal.is_none());
    assert_eq!(id.residual.verdict.as_str(), "missing_physics");
    // What the warming leaves is not one bad line (every line scales, more as the hours
    // pass); a drift in time may take part of it, but not all: the rest stays
    // `unexplained`, and no line is blamed.
    let ids: Vec<&str> = id
        .residual
        .effects
        .iter()
        .map(|e| e.id().as_str())
        .collect();
    assert!(!ids.contains(&"scale_factor"), "{ids:?}");
    let rest = id
        .residual
        .effects
        .iter()
        .find(|e| e.id().as_str() == "unexplained")
        .expect("unexplained");
    assert!(rest.explains_um > 0.3);
}

#[test]
fn rigid_campaigns_with_temperatures_raise_no_false_alarm() {
    for (i, t) in ["YXZ", "ZXY", "XYZ", "YZX"].iter().enumerate() {
        let seed = 70 + i as u64;
        let mut rng = StdRng::seed_from_u64(seed);
        let m = random_machine(topo(t), &mut rng); // α = 0: the scales do not expand
        let table = simulate(&m, &warm_plan(seed, WARMING));
        let mut cfg = IdentifyConfig::new(topo(t));
        cfg.degree = Degree::Fixed(3);
        cfg.basis = errmap::volumetric::BasisKind::Poly;
        let id = identify(&table, &cfg).expect("identify");
        let th = id.thermal.as_ref().expect("temperatures in the table");
        assert!(!th.kept, "{t}: {th:?}");
        assert!(th.t.expect("t") < 3.0);
        assert_eq!(
            id.residual.verdict.as_str(),
            "consistent",
            "{t}: z = {}",
            id.residual.z
        );
        assert!(id.residual.effects.is_empty());
        assert_eq!(
            serde_json::to_value(id.doc(5, false)).expect("json")["residual"]["effects"],
            serde_json::json!([])
        );
    }
}

#[test]
fn a_constant_temperature_leaves_alpha_undetermined() {
    // At a constant 23 °C the expansion is a scale factor of the three positioning
    // components: indistinguishable from their linear terms, so α is not determined and
    // the positioning components carry the expansion at 23 °C.
    let mut rng = StdRng::seed_from_u64(8);
    let mut m = random_machine(topo("YXZ"), &mut rng);
    m.scale_alpha_ppm_per_k = 11.5;
    let hot = ThermalHistory {
        start_c: 23.0,
        end_c: 23.0,
        tau_s: 3600.0,
    };
    let table = simulate(&m, &warm_plan(8, hot));
    let mut cfg = IdentifyConfig::new(topo("YXZ"));
    cfg.degree = Degree::Fixed(3);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&table, &cfg).expect("identify");
    let th = id.thermal.as_ref().expect("temperatures");
    assert_eq!(th.alpha_ppm_per_k, None);
    assert!(!th.kept);
    assert_eq!(id.residual.verdict.as_str(), "consistent");
    // E_XX at 800 mm: truth at 20 °C plus 11.5·3·800·1e−3 = 27.6 µm.
    let gauge = GaugeTruth::of(&m, id.fit.basis.range_mm);
    let (v, s) = id.fit.component(0, 800.0).expect("E_XX");
    let want = gauge.value(&m, Component { axis: 0, kind: 0 }, 800.0) + 27.6;
    assert!((v - want).abs() < 4.0 * s, "{v} vs {want} ± {s}");
}

#[test]
fn bad_thermal_input_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().expect("tempdir");
    let base = "preset = \"zhang22\"\nvolume_mm = [[0, 0, 0], [800, 600, 400]]\n";
    for (text, key) in [
        (
            "[thermal]\nstart_c = 20\nend_c = 22\ntau_s = 0\n",
            "thermal.tau_s",
        ),
        (
            "[thermal]\nstart_c = 20\nend_c = 900\ntau_s = 60\n",
            "thermal.end_c",
        ),
        ("[thermal]\nstart_c = 20\nend_c = 22\ntau = 60\n", "tau"),
    ] {
        let p = write(dir.path(), "plan.toml", &format!("{base}{text}"));
        let err = PlanFile::read(&p).expect_err(text).to_string();
        assert!(err.contains("plan.toml") && err.contains(key), "{err}");
    }
    for (text, key) in [
        (
            "topology = \"XYZ\"\nscale_alpha_ppm_per_k = 1e9\n",
            "scale_alpha_ppm_per_k",
        ),
        (
            "topology = \"XYZ\"\nscale_alpha_ppm = 11.5\n",
            "scale_alpha_ppm",
        ),
    ] {
        let p = write(dir.path(), "model.toml", text);
        let err = Machine::read(&p).expect_err(text).to_string();
        assert!(err.contains("model.toml") && err.contains(key), "{err}");
    }
}

#[test]
fn cli_reports_the_scale_expansion_in_the_contract_shape() {
    let dir = tempfile::tempdir().expect("tempdir");
    let model = std::fs::read_to_string("datasets/volumetric/model.toml").expect("dataset");
    let model = write(
        dir.path(),
        "model.toml",
        &model.replace(
            "topology = \"YXZ\"",
            "topology = \"YXZ\"\nscale_alpha_ppm_per_k = 11.5",
        ),
    );
    let plan = write(
        dir.path(),
        "plan.toml",
        "seed = 4\nnoise_um = 0.1\npreset = \"rich\"\nvolume_mm = [[0, 0, 0], [800, 600, 400]]\n\
         [thermal]\nstart_c = 20.0\nend_c = 22.0\ntau_s = 10800\n",
    );
    let lines = dir.path().join("lines.csv");
    let p = |x: &Path| x.to_str().expect("utf-8").to_string();
    let out = errmap(&[
        "volumetric",
        "simulate",
        "--model",
        &p(&model),
        "--plan",
        &p(&plan),
        "--out",
        &p(&lines),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = errmap(&[
        "volumetric",
        "identify",
        &p(&lines),
        "--topology",
        "YXZ",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(doc["residual"]["verdict"], "missing_physics");
    let e = &doc["residual"]["effects"][0];
    assert_eq!(e["id"], "scale_thermal_expansion");
    let a = e["params"]["alpha_ppm_per_k"].as_f64().expect("alpha");
    let s = e["uncertainty"]["alpha_ppm_per_k"].as_f64().expect("sigma");
    assert!((a - 11.5).abs() < 3.0 * s, "{a} ± {s}");
    assert_eq!(e["params"]["x0_mm"], 0.0);
    assert!(e["where"].as_str().expect("where").contains("20 °C"));
    assert!(e["explains_um"].as_f64().expect("explains") > 1.0);
    // E_XX at 20 °C: the dataset's 4·ξ − 2.5·ξ² + ξ³ at x = 800 mm is 2.5 µm.
    let exx = &doc["components"]["E_XX"];
    let pos = exx["positions_mm"].as_array().expect("positions");
    let i = pos
        .iter()
        .position(|v| v.as_f64() == Some(800.0))
        .expect("800");
    let v = exx["values"][i].as_f64().expect("v");
    let sv = exx["sigma"][i].as_f64().expect("s");
    assert!(
        (v - 2.5).abs() < 4.0 * sv.max(0.01),
        "E_XX(800) = {v} ± {sv}"
    );
}
