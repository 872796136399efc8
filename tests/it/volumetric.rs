//! Volumetric errors from laser lines (spec `volumetric.md`, issue #12): known answers of
//! the model (Abbe offsets, squareness, lever arms per topology), identifiability of a
//! poor line set, calibrated recovery on random seeded campaigns, held-out predictions,
//! bad input, and the command line's JSON.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use errmap::volumetric::{
    Component, ComponentFn, Degree, GaugeTruth, IdentifyConfig, Line, LineTable, Machine, PlanFile,
    Predictor, Target, Topology, identify, simulate,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

pub(super) const VOLUME: [[f64; 3]; 2] = [[0.0, 0.0, 0.0], [800.0, 600.0, 400.0]];

pub(super) fn topo(s: &str) -> Topology {
    s.parse().expect("topology")
}

/// c·a (a in mm), µm or µrad.
fn linear(c: f64) -> ComponentFn {
    ComponentFn::Poly {
        coeffs: vec![c],
        scale_mm: 1.0,
    }
}

pub(super) fn plan_file(preset: Option<&str>, seed: u64, noise_um: f64) -> PlanFile {
    PlanFile {
        seed,
        noise_um,
        laser_zero_um: 5.0,
        runs: 1,
        feed_mm_s: 20.0,
        dwell_s: 4.0,
        setup_s: 600.0,
        preset: preset.map(str::to_string),
        volume_mm: Some(VOLUME),
        targets: 11,
        probe_offset_mm: Some(100.0),
        lines: Vec::new(),
        thermal: None,
    }
}

/// A line of `n` targets from `start` to `end` with probe offset `p`, e_um unset.
fn line(id: &str, start: [f64; 3], end: [f64; 3], p: [f64; 3], n: usize) -> Line {
    let d = [0, 1, 2].map(|k| end[k] - start[k]);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    Line {
        id: id.into(),
        u: d.map(|c| c / len),
        probe_mm: p,
        targets: (0..n)
            .map(|i| {
                let f = i as f64 / (n - 1) as f64;
                Target::new([0, 1, 2].map(|k| start[k] + f * d[k]), 0.0)
            })
            .collect(),
    }
}

fn truth_profile(m: &Machine, l: &Line) -> Vec<f64> {
    let p0 = l.targets[0].pos_mm;
    l.targets
        .iter()
        .map(|t| m.line_error_um(t.pos_mm, l.u, l.probe_mm) - m.line_error_um(p0, l.u, l.probe_mm))
        .collect()
}

#[test]
fn pitch_alone_shows_on_offset_lines_as_epsilon_times_h() {
    // YXZ: the lever arm of X is z·ê_z + p. E_BX(x) = 0.005·x µrad (pitch of X).
    let mut m = Machine::perfect(topo("YXZ"));
    m.set("E_BX".parse().expect("name"), linear(0.005));
    for (h, p) in [(0.0, [0.0; 3]), (300.0, [0.0; 3]), (0.0, [0.0, 0.0, 300.0])] {
        let l = line("X", [0.0, 0.0, h], [800.0, 0.0, h], p, 9);
        let heff = h + p[2];
        for (t, e) in l.targets.iter().zip(truth_profile(&m, &l)) {
            // E = 1e-3·(0, ε, 0) × (0, 0, h) = (1e-3·ε·h, 0, 0); e = −u·E.
            let want = -1e-3 * 0.005 * t.pos_mm[0] * heff;
            assert!((e - want).abs() < 1e-12, "h={h} p={p:?}: {e} vs {want}");
        }
    }
    // At 800 mm and h = 300 mm: −1.2 µm, the Abbe error.
    let l = line("X", [0.0, 0.0, 300.0], [800.0, 0.0, 300.0], [0.0; 3], 3);
    assert!((truth_profile(&m, &l)[2] + 1.2).abs() < 1e-12);
    // Lines along Y and Z see nothing of it (the pitch is constant along them).
    for l in [
        line("Y", [800.0, 0.0, 300.0], [800.0, 600.0, 300.0], [0.0; 3], 5),
        line("Z", [800.0, 600.0, 0.0], [800.0, 600.0, 400.0], [0.0; 3], 5),
    ] {
        assert!(
            truth_profile(&m, &l).iter().all(|e| e.abs() < 1e-12),
            "{}",
            l.id
        );
    }
}

#[test]
fn squareness_alone_shows_only_on_diagonals() {
    let mut m = Machine::perfect(topo("YXZ"));
    m.squareness_urad = [10.0, 0.0, 0.0]; // E_C0Y: Δx = −1e-3·10·y
    for (k, off) in [
        (0, [0.0, 600.0, 400.0]),
        (1, [800.0, 0.0, 0.0]),
        (2, [800.0, 600.0, 0.0]),
    ] {
        let mut s = off;
        let mut e = off;
        s[k] = 0.0;
        e[k] = VOLUME[1][k];
        let l = line("axis", s, e, [0.0, 50.0, 100.0], 5);
        assert!(
            truth_profile(&m, &l).iter().all(|v| v.abs() < 1e-12),
            "axis {k}"
        );
    }
    // XY diagonal: u = (0.8, 0.6, 0), e = −u·E = 0.8·1e-2·y → 4.8 µm at y = 600.
    let l = line("D", [0.0, 0.0, 0.0], [800.0, 600.0, 0.0], [0.0; 3], 5);
    let prof = truth_profile(&m, &l);
    for (t, e) in l.targets.iter().zip(&prof) {
        assert!((e - 0.8e-2 * t.pos_mm[1]).abs() < 1e-12);
    }
    assert!((prof[4] - 4.8).abs() < 1e-12);
}

#[test]
fn lever_arms_of_every_topology_by_hand() {
    let pos = [100.0, 200.0, 300.0];
    let p = [1.0, 2.0, 3.0];
    // (topology, r_X, r_Y, r_Z) computed by hand: r_k = Σ_{j after k} a_j ê_j + p.
    let cases = [
        (
            "XYZ",
            [1.0, 202.0, 303.0],
            [1.0, 2.0, 303.0],
            [1.0, 2.0, 3.0],
        ),
        (
            "XZY",
            [1.0, 202.0, 303.0],
            [1.0, 2.0, 3.0],
            [1.0, 202.0, 3.0],
        ),
        (
            "YXZ",
            [1.0, 2.0, 303.0],
            [101.0, 2.0, 303.0],
            [1.0, 2.0, 3.0],
        ),
        (
            "YZX",
            [1.0, 2.0, 3.0],
            [101.0, 2.0, 303.0],
            [101.0, 2.0, 3.0],
        ),
        (
            "ZXY",
            [1.0, 202.0, 3.0],
            [1.0, 2.0, 3.0],
            [101.0, 202.0, 3.0],
        ),
        (
            "ZYX",
            [1.0, 2.0, 3.0],
            [101.0, 2.0, 3.0],
            [101.0, 202.0, 3.0],
        ),
    ];
    for (t, rx, ry, rz) in cases {
        let t = topo(t);
        assert_eq!(t.lever_arm(0, pos, p), rx, "{t} X");
        assert_eq!(t.lever_arm(1, pos, p), ry, "{t} Y");
        assert_eq!(t.lever_arm(2, pos, p), rz, "{t} Z");
    }
    // The full error vector for YXZ with E_CY = 0.01·y and E_AX = 0.02·x µrad at pos, p:
    // 1e-3·[(0,0,2)×(101,2,303) + (2,0,0)×(1,2,303)] = (−0.004, −0.404, 0.004) µm.
    let mut m = Machine::perfect(topo("YXZ"));
    m.set("E_CY".parse().expect("name"), linear(0.01));
    m.set("E_AX".parse().expect("name"), linear(0.02));
    let e = m.error_um(pos, p);
    for (a, b) in e.iter().zip([-0.004, -0.404, 0.004]) {
        assert!((a - b).abs() < 1e-12, "{e:?}");
    }
}

/// Random polynomial errors of degree ≤ 3 (a few µm, µrad) and squareness (±20 µrad).
pub(super) fn random_machine(t: Topology, rng: &mut StdRng) -> Machine {
    let mut m = Machine::perfect(t);
    for c in Component::all() {
        let amp = if c.is_straightness() { 1.5 } else { 3.0 };
        m.set(
            c,
            ComponentFn::Poly {
                coeffs: (0..3).map(|_| amp * rng.random_range(-1.0..1.0)).collect(),
                scale_mm: VOLUME[1][c.axis],
            },
        );
    }
    m.squareness_urad = [0, 1, 2].map(|_| rng.random_range(-20.0..20.0));
    m
}

#[test]
fn random_campaigns_recover_every_component_within_its_sigma() {
    let mut z = Vec::new();
    for (i, t) in ["YXZ", "XZY", "ZYX"].iter().enumerate() {
        for draw in 0..2u64 {
            let seed = 100 * i as u64 + draw;
            let mut rng = StdRng::seed_from_u64(seed);
            let m = random_machine(topo(t), &mut rng);
            let plan = plan_file(Some("rich"), seed, 0.1)
                .validate(Path::new("test"))
                .expect("plan");
            let table = simulate(&m, &plan);
            let mut cfg = IdentifyConfig::new(topo(t));
            cfg.degree = Degree::Fixed(3);
            cfg.basis = errmap::volumetric::BasisKind::Poly;
            let id = identify(&table, &cfg).expect("identify");
            assert!(
                id.fit.identified.iter().all(|f| *f),
                "{t}: all 21 identified"
            );
            assert!(id.unidentified.is_empty());
            assert_eq!(
                id.residual.verdict.as_str(),
                "consistent",
                "{t} seed {seed}: rigid campaign"
            );
            let gauge = GaugeTruth::of(&m, id.fit.basis.range_mm);
            for c in Component::all() {
                for a in [0.5 * VOLUME[1][c.axis], VOLUME[1][c.axis]] {
                    let (v, s) = id.fit.component(c.index(), a).expect("identified");
                    z.push((v - gauge.value(&m, c, a)) / s);
                }
            }
            for k in 0..3 {
                let (v, s) = id.fit.squareness(k).expect("identified");
                z.push((v - gauge.squareness_urad[k]) / s);
            }
        }
    }
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    let max = z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(max < 4.5, "max |z| = {max}");
    assert!(
        (0.75..1.3).contains(&rms),
        "RMS of standardised errors {rms} (n = {})",
        z.len()
    );
}

#[test]
fn presets_determine_all_21_errors_on_every_topology() {
    let mut rng = StdRng::seed_from_u64(7);
    for t in ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"] {
        let m = random_machine(topo(t), &mut rng);
        for preset in ["zhang22", "rich"] {
            let plan = plan_file(Some(preset), 1, 0.1)
                .validate(Path::new("test"))
                .expect("plan");
            let n = plan.lines.len();
            assert_eq!(n, if preset == "zhang22" { 22 } else { 43 });
            let mut cfg = IdentifyConfig::new(topo(t));
            cfg.degree = Degree::Fixed(3);
            cfg.basis = errmap::volumetric::BasisKind::Poly;
            let id = identify(&simulate(&m, &plan), &cfg).expect("identify");
            assert!(
                id.unidentified.is_empty(),
                "{t} {preset}: {:?}",
                id.unidentified
            );
        }
    }
}

/// Axis-parallel lines at the four corners of the other two ranges, no probe offset.
pub(super) fn poor_lines() -> Vec<Line> {
    let mut out = Vec::new();
    for k in 0..3 {
        let o: Vec<usize> = (0..3).filter(|&j| j != k).collect();
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let mut s = [0.0; 3];
            s[o[0]] = VOLUME[a][o[0]];
            s[o[1]] = VOLUME[b][o[1]];
            let mut e = s;
            e[k] = VOLUME[1][k];
            out.push(line(&format!("{k}{a}{b}"), s, e, [0.0; 3], 9));
        }
    }
    out
}

#[test]
fn axis_parallel_lines_without_probe_offsets_leave_exactly_the_expected_errors_undetermined() {
    // Undetermined: every straightness, every roll, the squareness (no diagonal), the last
    // axis' two other rotations, and the rotation of each axis whose lever arm lies along
    // an axis before it in the chain (YXZ: E_CX needs a lever arm along y).
    let common = [
        "E_YX", "E_ZX", "E_XY", "E_ZY", "E_XZ", "E_YZ", "E_AX", "E_BY", "E_CZ", "E_C0Y", "E_B0Z",
        "E_A0Z",
    ];
    for (t, extra) in [
        ("YXZ", ["E_CX", "E_AZ", "E_BZ"]),
        ("XYZ", ["E_CY", "E_AZ", "E_BZ"]),
    ] {
        let mut rng = StdRng::seed_from_u64(3);
        let m = random_machine(topo(t), &mut rng);
        let mut noise = StdRng::seed_from_u64(4);
        let lines: Vec<Line> = poor_lines()
            .into_iter()
            .map(|mut l| {
                for tg in &mut l.targets {
                    tg.e_um = Some(
                        m.line_error_um(tg.pos_mm, l.u, l.probe_mm)
                            + 0.1 * errmap::base::gaussian(&mut noise),
                    );
                }
                l
            })
            .collect();
        let table = LineTable {
            source: "poor".into(),
            lines,
        };
        let mut cfg = IdentifyConfig::new(topo(t));
        cfg.degree = Degree::Fixed(2);
        cfg.basis = errmap::volumetric::BasisKind::Poly;
        let id = identify(&table, &cfg).expect("identify");
        let mut got: Vec<String> = id
            .unidentified
            .iter()
            .flat_map(|u| u.components.clone())
            .collect();
        let mut want: Vec<String> = common.iter().chain(&extra).map(|s| s.to_string()).collect();
        got.sort();
        want.sort();
        assert_eq!(got, want, "{t}");
        // The identified ones are recovered; the others have no numbers in the JSON.
        let doc = serde_json::to_value(id.doc(11, false)).expect("json");
        for name in &want {
            let c = &doc["components"][name];
            assert_eq!(c["identified"], false, "{name}");
            assert!(c.get("value").is_none_or(|v| v.is_null()));
            assert!(c.get("values").is_none_or(|v| v.is_null()));
        }
        assert_eq!(doc["components"]["E_XX"]["identified"], true);
        // The example: E_CX (YXZ) needs a line along X with a probe offset along Y.
        if t == "YXZ" {
            let why = id
                .unidentified
                .iter()
                .find(|u| u.components.iter().any(|c| c == "E_CX"))
                .map(|u| u.why.clone())
                .unwrap_or_default();
            assert!(
                why.contains("a line along X with a probe offset along Y"),
                "{why}"
            );
        }
    }
}

#[test]
fn held_out_lines_are_predicted_within_noise() {
    let mut rng = StdRng::seed_from_u64(11);
    let m = random_machine(topo("YXZ"), &mut rng);
    let plan = plan_file(Some("rich"), 5, 0.1)
        .validate(Path::new("test"))
        .expect("plan");
    let mut table = simulate(&m, &plan);
    // Hold out the four body diagonals and one XY diagonal.
    let (test, fit): (Vec<Line>, Vec<Line>) = table
        .lines
        .drain(..)
        .partition(|l| l.id.starts_with('B') || l.id == "DXY-hi");
    assert_eq!(test.len(), 5);
    let fit_table = LineTable {
        source: "fit".into(),
        lines: fit,
    };
    let test_table = LineTable {
        source: "test".into(),
        lines: test,
    };
    let mut cfg = IdentifyConfig::new(topo("YXZ"));
    cfg.degree = Degree::Fixed(3);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&fit_table, &cfg).expect("identify");
    let preds = Predictor::Fit(id.fit.clone()).predict_lines(&test_table);
    let mut z = Vec::new();
    let mut resid = Vec::new();
    let mut k = 0;
    for l in &test_table.lines {
        let truth = truth_profile(&m, l);
        let e0 = l.targets[0].e_um.expect("e");
        let mut r_line = Vec::new();
        for (i, t) in l.targets.iter().enumerate() {
            let p = &preds[k];
            k += 1;
            let (e, s) = (p.e_um.expect("determined"), p.sigma_um.expect("σ"));
            if i == 0 {
                assert!(e.abs() < 1e-12 && s.abs() < 1e-12, "first row predicts 0");
                continue;
            }
            z.push((e - truth[i]) / s);
            r_line.push(t.e_um.expect("e") - e0 - e);
        }
        let mean = r_line.iter().sum::<f64>() / r_line.len() as f64;
        resid.extend(r_line.iter().map(|r| r - mean));
    }
    let rms_z = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    assert!(rms_z < 2.0, "held-out standardised RMS {rms_z}");
    let rms = (resid.iter().map(|v| v * v).sum::<f64>() / resid.len() as f64).sqrt();
    // Measured minus predicted: the noise of two readings (0.1 µm each) and the model's σ.
    assert!(rms < 0.2, "held-out residual RMS {rms} µm");
}

#[test]
fn auto_degree_finds_the_cubic_and_a_warming_scale_is_not_consistent() {
    let mut rng = StdRng::seed_from_u64(21);
    let m = random_machine(topo("ZXY"), &mut rng);
    let plan = plan_file(Some("rich"), 9, 0.05)
        .validate(Path::new("test"))
        .expect("plan");
    let table = simulate(&m, &plan);
    let mut auto = IdentifyConfig::new(topo("ZXY"));
    auto.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&table, &auto).expect("identify");
    assert!(id.degree >= 3, "auto chose {} ({:?})", id.degree, id.cv);
    assert_eq!(id.cv.len(), 4);
    assert_eq!(id.residual.verdict.as_str(), "consistent");
    // The scale warms by 1 ppm per hour during the campaign: each line's error grows
    // with its distance and its time — a rigid model cannot absorb it.
    let mut warm = table.clone();
    for l in &mut warm.lines {
        let p0 = l.targets[0].pos_mm;
        for t in &mut l.targets {
            let s_mm = (0..3).map(|k| (t.pos_mm[k] - p0[k]) * l.u[k]).sum::<f64>();
            let hours = t.t_s.expect("t") / 3600.0;
            *t.e_um.as_mut().expect("e") += 1e-6 * hours * s_mm * 1e3;
        }
    }
    let mut cfg = IdentifyConfig::new(topo("ZXY"));
    cfg.degree = Degree::Fixed(3);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&warm, &cfg).expect("identify");
    assert_eq!(
        id.residual.verdict.as_str(),
        "missing_physics",
        "z = {}",
        id.residual.z
    );
}

#[test]
fn gauge_maps_the_dataset_model_as_computed_by_hand() {
    let m = Machine::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/volumetric/model.toml"
    )))
    .expect("model");
    let range = [[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]];
    let g = GaugeTruth::of(&m, range);
    // LS slopes on [0, 1] of ξ² and ξ³: 1 and 0.9. β_YX = (1.5 − 0.8·0.9)/800,
    // β_XY = (0.9 + 0.4·0.9)/600 → E_C0Y' = 8 − 1e3·(0.975e-3 + 2.1e-3) = 4.925.
    assert!(
        (g.squareness_urad[0] - 4.925).abs() < 1e-6,
        "{:?}",
        g.squareness_urad
    );
    // β_XZ = 0.6/400, β_ZX = −1.2/800: they cancel, E_B0Z' = −5.
    assert!((g.squareness_urad[1] + 5.0).abs() < 1e-6);
    // β_YZ = (−0.5 + 0.3·0.9)/400, β_ZY = −0.7/600 → E_A0Z' = 3 + 1.741667.
    assert!((g.squareness_urad[2] - (3.0 + 0.575 + 0.7 / 0.6)).abs() < 1e-6);
}

pub(super) fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

const HEADER: &str = "line,x_mm,y_mm,z_mm,ux,uy,uz,e_um\n";

#[test]
fn bad_line_tables_are_refused_naming_file_row_and_column() {
    let dir = tempfile::tempdir().expect("tempdir");
    let cases = [
        (
            "nonunit.csv",
            "L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0.01,0,0\nL1,200,0,0,1,0,0,0\n",
            vec!["row 2", "ux", "norm"],
        ),
        (
            "offline.csv",
            "L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0,0,0\nL1,200,0.002,0,1,0,0,0\n",
            vec!["row 3", "off line `L1`", "2.0000 µm"],
        ),
        (
            "short.csv",
            "L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0,0,0\nL2,0,0,0,0,1,0,0\nL2,0,1,0,0,1,0,0\nL2,0,2,0,0,1,0,0\n",
            vec!["line `L1`", "row 1", "at least 3"],
        ),
        (
            "disagree.csv",
            "L1,0,0,0,1,0,0,0\nL1,100,0,0,0,1,0,0\nL1,200,0,0,1,0,0,0\n",
            vec!["row 2", "share the beam direction"],
        ),
        (
            "nan.csv",
            "L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0,0,NaN\nL1,200,0,0,1,0,0,0\n",
            vec!["row 2", "e_um", "not finite"],
        ),
    ];
    for (name, body, needles) in cases {
        let p = write(dir.path(), name, &format!("{HEADER}{body}"));
        let err = LineTable::read(&p, true).expect_err(name).to_string();
        assert!(err.contains(name), "{err}");
        for n in needles {
            assert!(err.contains(n), "{name}: `{n}` not in: {err}");
        }
    }
    // Rows of a line disagreeing on the probe offset.
    let p = write(
        dir.path(),
        "probe.csv",
        "line,x_mm,y_mm,z_mm,ux,uy,uz,pz_mm,e_um\nL1,0,0,0,1,0,0,0,0\nL1,100,0,0,1,0,0,50,0\nL1,200,0,0,1,0,0,0,0\n",
    );
    let err = LineTable::read(&p, true).expect_err("probe").to_string();
    assert!(err.contains("row 2") && err.contains("pz_mm"), "{err}");
}

#[test]
fn line_tables_round_trip_through_csv_and_parquet() {
    let dir = tempfile::tempdir().expect("tempdir");
    let m = Machine::perfect(topo("YXZ"));
    let plan = plan_file(Some("zhang22"), 2, 0.1)
        .validate(Path::new("test"))
        .expect("plan");
    let table = simulate(&m, &plan);
    for ext in ["csv", "parquet"] {
        let p = dir.path().join(format!("lines.{ext}"));
        table.write(&p).expect("write");
        let back = LineTable::read(&p, true).expect("read");
        assert_eq!(back.lines.len(), 22);
        for (a, b) in table.lines.iter().zip(&back.lines) {
            assert_eq!(a.id, b.id);
            assert_eq!(a.targets.len(), b.targets.len());
            for (s, t) in a.targets.iter().zip(&b.targets) {
                assert!((s.e_um.expect("e") - t.e_um.expect("e")).abs() < 1e-12);
                assert_eq!(s.t_s, t.t_s);
            }
        }
    }
    // Timing: 22 lines with a 600 s set-up each take more than 22 × 600 s.
    let end = table
        .lines
        .last()
        .and_then(|l| l.targets.last())
        .and_then(|t| t.t_s);
    assert!(end.expect("t") > 22.0 * 600.0);
}

#[test]
fn machine_model_files_refuse_misspelt_names_and_non_finite_values() {
    let dir = tempfile::tempdir().expect("tempdir");
    let cases = [
        (
            "misspelt.toml",
            "topology = \"YXZ\"\n[components]\nE_XXX = { poly = [1.0] }\n",
            "components.E_XXX",
        ),
        ("unknown.toml", "topology = \"YXZ\"\ncolour = 3\n", "colour"),
        (
            "square.toml",
            "topology = \"YXZ\"\n[squareness_urad]\nE_C0X = 1.0\n",
            "squareness_urad.E_C0X",
        ),
        (
            "nan.toml",
            "topology = \"YXZ\"\n[components]\nE_XX = { poly = [1.0, nan] }\n",
            "components.E_XX.poly[1]",
        ),
        ("topo.toml", "topology = \"XXY\"\n", "topology"),
        (
            "zero.toml",
            "topology = \"XYZ\"\n[components]\nE_XX = { positions_mm = [0, 100], values = [0.5, 1.0] }\n",
            "components.E_XX",
        ),
    ];
    for (name, body, key) in cases {
        let p = write(dir.path(), name, body);
        let err = Machine::read(&p).expect_err(name).to_string();
        assert!(err.contains(name) && err.contains(key), "{name}: {err}");
    }
}

pub(super) fn errmap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_errmap"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("runs errmap")
}

#[test]
fn cli_simulate_identify_predict_json() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = |n: &str| dir.path().join(n).display().to_string();
    let plan = write(
        dir.path(),
        "plan.toml",
        "seed = 3\nnoise_um = 0.1\npreset = \"zhang22\"\nvolume_mm = [[0, 0, 0], [800, 600, 400]]\ntargets = 9\n",
    );
    let o = errmap(&[
        "volumetric",
        "simulate",
        "--model",
        "datasets/volumetric/model.toml",
        "--plan",
        &plan.display().to_string(),
        "--out",
        &d("lines.csv"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = errmap(&[
        "volumetric",
        "identify",
        &d("lines.csv"),
        "--topology",
        "YXZ",
        "--degree",
        "3",
        "--out",
        &d("model.json"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON document");
    assert_eq!(doc["topology"], "YXZ");
    assert_eq!(doc["lines"], 22);
    assert_eq!(doc["targets"], 22 * 9);
    assert!(doc["rms_residual_um"].as_f64().expect("rms") < 0.2);
    let comps = doc["components"].as_object().expect("components");
    assert_eq!(comps.len(), 21);
    for c in Component::all() {
        let v = &comps[&c.name()];
        assert_eq!(v["unit"], c.unit());
        assert_eq!(v["identified"], true, "{}", c.name());
        let pos = v["positions_mm"].as_array().expect("positions");
        assert!(pos.len() >= 5 && pos.iter().any(|p| p.as_f64() == Some(0.0)));
        assert_eq!(v["values"].as_array().map(Vec::len), Some(pos.len()));
        assert_eq!(v["sigma"].as_array().map(Vec::len), Some(pos.len()));
    }
    for s in ["E_C0Y", "E_B0Z", "E_A0Z"] {
        assert_eq!(comps[s]["unit"], "urad");
        assert!(comps[s]["value"].is_f64() && comps[s]["sigma"].is_f64());
    }
    assert_eq!(doc["unidentified"], serde_json::json!([]));
    assert_eq!(doc["residual"]["verdict"], "consistent");
    assert_eq!(doc["residual"]["effects"], serde_json::json!([]));

    let o = errmap(&[
        "volumetric",
        "predict",
        "--model",
        &d("model.json"),
        "--lines",
        &d("lines.csv"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let preds = p["predictions"].as_array().expect("predictions");
    assert_eq!(preds.len(), 22 * 9);
    for first in preds.iter().step_by(9) {
        assert_eq!(
            first["e_um"].as_f64(),
            Some(0.0),
            "first row of a line predicts 0"
        );
    }
    assert!(
        preds
            .iter()
            .all(|r| r["sigma_um"].is_f64() && r["line"].is_string())
    );

    let grid = write(
        dir.path(),
        "grid.csv",
        "x_mm,y_mm,z_mm\n0,0,0\n400,300,200\n800,600,400\n",
    );
    let o = errmap(&[
        "volumetric",
        "predict",
        "--model",
        &d("model.json"),
        "--grid",
        &grid.display().to_string(),
        "--probe",
        "0,0,-50",
        "--out",
        &d("vec.csv"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(d("vec.csv")).expect("grid out");
    assert!(
        text.starts_with("x_mm,y_mm,z_mm,ex_um,ey_um,ez_um\n"),
        "{text}"
    );
    // The truth model predicts too (σ = 0), through the same command.
    let o = errmap(&[
        "volumetric",
        "predict",
        "--model",
        "datasets/volumetric/model.toml",
        "--lines",
        &d("lines.csv"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn cli_bad_input_exits_1_and_usage_errors_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = write(
        dir.path(),
        "bad.csv",
        &format!("{HEADER}L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0,0,0\n"),
    );
    let good = write(
        dir.path(),
        "good.csv",
        &format!("{HEADER}L1,0,0,0,1,0,0,0\nL1,100,0,0,1,0,0,0.1\nL1,200,0,0,1,0,0,0.3\n"),
    );
    let o = errmap(&[
        "volumetric",
        "identify",
        &good.display().to_string(),
        "--topology",
        "XQZ",
    ]);
    // A bad flag value is a usage error (issue 17), named by clap with the reason.
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("topology `XQZ`"));
    let o = errmap(&[
        "volumetric",
        "identify",
        &bad.display().to_string(),
        "--topology",
        "XYZ",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        err.contains("bad.csv") && err.contains("line `L1`"),
        "{err}"
    );
    let o = errmap(&["volumetric", "identify", &good.display().to_string()]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "missing --topology is a usage error"
    );
}
