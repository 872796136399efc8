//! Self-calibration (an uncalibrated plate, `--self-calibrate`) and a step-gauge set.
//! The plate's truth is the example certificate (what `simulate` places); identify is
//! given the same plate without its certificate, so its deviations are unknown.

use std::path::Path;

use super::identify::{Pos, campaign, eight, gauge_file, identify, machine, pos, run};
use crate::util::{dataset, errmap, s, stderr, tempdir};

/// Simulates `positions` of the certified plate (the truth), then identifies the same
/// measurements with `plate` (uncertified) and `--self-calibrate`.
fn self_calibrate(dir: &Path, plate: &Path, positions: &[Pos]) -> serde_json::Value {
    let truth = campaign(dir, &dataset("artefact/plate.toml"), positions, 0.2);
    let o = errmap(&[
        "artefact",
        "simulate",
        s(&truth),
        "--model",
        s(&machine()),
        "--out",
        s(&dir.join("meas")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c = campaign(dir, plate, positions, 0.2);
    identify(&c, &["--self-calibrate"])
}

/// The example plate without its certificate; returns (path, true deviations µm).
fn uncertified(dir: &Path) -> (std::path::PathBuf, Vec<[f64; 3]>) {
    let text = std::fs::read_to_string(dataset("artefact/plate.toml")).expect("test data");
    let t: toml::Table = text.parse().expect("test data");
    let mut out = String::from("id = \"BP-free\"\nkind = \"ball_plate\"\n");
    let mut dev = Vec::new();
    for f in t["feature"].as_array().expect("test data") {
        let n: Vec<f64> = f["nominal_mm"]
            .as_array()
            .expect("test data")
            .iter()
            .map(|v| v.as_float().expect("test data"))
            .collect();
        let c: Vec<f64> = f["certificate_mm"]
            .as_array()
            .expect("test data")
            .iter()
            .map(|v| v.as_float().expect("test data"))
            .collect();
        // The certificate is the plate: its coordinates become the nominal ones shifted
        // back, and the truth is what the file no longer says.
        out.push_str(&format!(
            "[[feature]]\nid = \"{}\"\nnominal_mm = [{}, {}, {}]\n",
            f["id"].as_str().expect("test data"),
            n[0],
            n[1],
            n[2]
        ));
        dev.push([
            1000.0 * (c[0] - n[0]),
            1000.0 * (c[1] - n[1]),
            1000.0 * (c[2] - n[2]),
        ]);
    }
    let p = dir.join("free.toml");
    std::fs::write(&p, out).expect("test data");
    (p, dev)
}

/// Residual of (truth − estimate) after a least-squares fit of what the named
/// invariants allow: per coordinate an affine field in the plate's (x, y) (rigid motion,
/// scale, squareness) and cubic profiles along the plate's x and y (the `other`
/// invariants of these campaigns: a profile of the plate along one of its axes that the
/// positioning components, cubic in the basis, reproduce in every position). 18 of the
/// 25 values per coordinate remain to be recovered. µm, the largest.
fn beyond_invariants(v: &serde_json::Value, truth: &[[f64; 3]]) -> f64 {
    let f = v["self_calibration"]["features"]
        .as_array()
        .expect("features");
    let pts: Vec<[f64; 2]> = (0..25)
        .map(|i| [(i % 5) as f64 / 4.0, (i / 5) as f64 / 4.0])
        .collect();
    let mut worst: f64 = 0.0;
    for c in 0..3 {
        let d = nalgebra::DVector::from_fn(25, |i, _| {
            truth[i][c] - f[i]["dev_um"][c].as_f64().expect("test data")
        });
        let a = nalgebra::DMatrix::from_fn(25, 7, |i, j| {
            let [x, y] = pts[i];
            [1.0, x, y, x * x, x * x * x, y * y, y * y * y][j]
        });
        let sol = a
            .clone()
            .svd(true, true)
            .solve(&d, 1e-12)
            .expect("test data");
        let r = d - a * sol;
        worst = worst.max(r.amax());
    }
    worst
}

/// The kinds of the self-calibration's invariants, in the JSON's order.
pub(super) fn invariant_kinds(v: &serde_json::Value) -> Vec<String> {
    v["self_calibration"]["invariants"]
        .as_array()
        .expect("invariants")
        .iter()
        .map(|i| i["kind"].as_str().expect("test data").to_string())
        .collect()
}

#[test]
fn self_calibration_with_rotations_recovers_the_plate() {
    let dir = tempdir();
    let (plate, truth) = uncertified(dir.path());
    let v = self_calibrate(dir.path(), &plate, &eight());
    assert_eq!(v["self_calibration"]["artefact"], "BP-free");
    let kinds = invariant_kinds(&v);
    // No traceable length: the plate's scale against the machine's is an invariant.
    assert!(kinds.iter().any(|k| k == "scale"), "{kinds:?}");
    // A turned position separates the plate's squareness from the machine's.
    assert!(!kinds.iter().any(|k| k == "squareness"), "{kinds:?}");
    let w = beyond_invariants(&v, &truth);
    assert!(w < 1e-3, "deviations beyond the invariants: {w} µm");
}

#[test]
fn self_calibration_without_rotations_names_the_squareness() {
    let dir = tempdir();
    let (plate, truth) = uncertified(dir.path());
    let unturned: Vec<Pos> = eight().into_iter().filter(|p| p.rot == 0.0).collect();
    let v = self_calibrate(dir.path(), &plate, &unturned);
    let kinds = invariant_kinds(&v);
    assert!(kinds.iter().any(|k| k == "scale"), "{kinds:?}");
    assert!(kinds.iter().any(|k| k == "squareness"), "{kinds:?}");
    let w = beyond_invariants(&v, &truth);
    assert!(w < 1e-3, "deviations beyond the invariants: {w} µm");
}

#[test]
fn a_step_gauge_set_gives_the_three_scales() {
    let dir = tempdir();
    let gauge = gauge_file(dir.path(), "SG-500", "step_gauge", 11, 50.0);
    let mut set = Vec::new();
    for (id, d, o) in [
        ("X1", "[1.0, 0.0, 0.0]", [100.0, 100.0, 100.0]),
        ("X2", "[1.0, 0.0, 0.0]", [100.0, 500.0, 300.0]),
        ("Y1", "[0.0, 1.0, 0.0]", [100.0, 50.0, 100.0]),
        ("Y2", "[0.0, 1.0, 0.0]", [700.0, 50.0, 300.0]),
        ("Y3", "[0.0, 1.0, 0.0]", [700.0, 50.0, 100.0]),
        ("Z1", "[0.0, 0.0, 1.0]", [100.0, 100.0, 0.0]),
    ] {
        set.push(pos(id, d, 0.0, o));
    }
    let c = campaign(dir.path(), &gauge, &set, 0.1);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    for name in ["E_XX", "E_YY", "E_ZZ"] {
        assert_eq!(v["components"][name]["identified"], true, "{name}");
    }
    // Gauges see lengths along their direction only: straightness never.
    for name in ["E_YX", "E_ZX", "E_XY"] {
        assert_eq!(v["components"][name]["identified"], false, "{name}");
    }
    let m = errmap::volumetric::Machine::read(&machine()).expect("test data");
    let e = &v["components"]["E_XX"];
    let pos = e["positions_mm"].as_array().expect("test data");
    for (i, a) in pos.iter().enumerate() {
        let a = a.as_f64().expect("test data");
        let est = e["values"][i].as_f64().expect("test data");
        let truth = m.value("E_XX".parse().expect("test data"), a);
        assert!((est - truth).abs() < 2e-3, "E_XX at {a}: {est} vs {truth}");
    }
}
