//! The joint fit (issue 36 item 1, "going beyond"): laser lines and artefact positions in
//! one identification (`artefact identify --laser LINES`). A self-calibrated plate cannot
//! tell its scale from the machine's (the `scale` invariant); one laser line along X,
//! a traceable length, determines it, and with it the plate's scale and the three
//! positioning errors. The truth is the simulator's machine and a plate planted with a
//! scale error; a rigid machine is the null.

use std::path::{Path, PathBuf};

use errmap::volumetric::Machine;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use super::identify::{campaign, compare, eight, identify, machine, run, simulate};
use super::selfcal::invariant_kinds;
use crate::util::{dataset, errmap, s, stderr, tempdir};

/// The plate's planted scale error, ppm.
const PLATE_PPM: f64 = 5.0;

/// The example plate as it really is (its certificate stretched by `ppm` about B01) and
/// the same plate uncertified; returns (truth plate, free plate, true deviations µm).
fn plates(dir: &Path, ppm: f64) -> (PathBuf, PathBuf, Vec<[f64; 3]>) {
    let text = std::fs::read_to_string(dataset("artefact/plate.toml")).expect("test data");
    let t: toml::Table = text.parse().expect("test data");
    let mut truth = String::from("id = \"BP-true\"\nkind = \"ball_plate\"\n");
    let mut free = String::from("id = \"BP-free\"\nkind = \"ball_plate\"\n");
    let mut dev = Vec::new();
    let floats = |v: &toml::Value| -> Vec<f64> {
        v.as_array()
            .expect("test data")
            .iter()
            .map(|x| x.as_float().expect("test data"))
            .collect()
    };
    for f in t["feature"].as_array().expect("test data") {
        let (n, c) = (floats(&f["nominal_mm"]), floats(&f["certificate_mm"]));
        let id = f["id"].as_str().expect("test data");
        let real: Vec<f64> = c.iter().map(|v| v * (1.0 + ppm * 1e-6)).collect();
        truth.push_str(&format!(
            "[[feature]]\nid = \"{id}\"\nnominal_mm = [{}, {}, {}]\ncertificate_mm = [{}, {}, {}]\nu_um = 0.6\n",
            n[0], n[1], n[2], real[0], real[1], real[2]
        ));
        free.push_str(&format!(
            "[[feature]]\nid = \"{id}\"\nnominal_mm = [{}, {}, {}]\n",
            n[0], n[1], n[2]
        ));
        dev.push([0, 1, 2].map(|k| 1000.0 * (real[k] - n[k])));
    }
    let (tp, fp) = (dir.join("true.toml"), dir.join("free.toml"));
    std::fs::write(&tp, truth).expect("test data");
    std::fs::write(&fp, free).expect("test data");
    (tp, fp, dev)
}

/// A laser line table of `m`: per line (id, start, unit direction) nine targets 100 mm
/// apart, e = −u·E + 3 µm (the line's own constant) + noise of one-sigma `noise_um`;
/// s_um 0.1 µm.
fn laser(dir: &Path, m: &Machine, lines: &[(&str, [f64; 3], [f64; 3])], noise_um: f64) -> PathBuf {
    let mut rng = StdRng::seed_from_u64(36);
    let mut t = String::from("line,x_mm,y_mm,z_mm,ux,uy,uz,px_mm,py_mm,pz_mm,e_um,s_um\n");
    for (id, start, u) in lines {
        for i in 0..9 {
            let p = [0, 1, 2].map(|k| start[k] + 100.0 * i as f64 * u[k]);
            let e = m.error_um(p, [0.0; 3]);
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            let g = (-2.0 * (1.0 - a).ln()).sqrt() * (std::f64::consts::TAU * b).cos();
            let r = -(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]) + 3.0 + noise_um * g;
            t.push_str(&format!(
                "{id},{},{},{},{},{},{},0,0,0,{r},0.1\n",
                p[0], p[1], p[2], u[0], u[1], u[2]
            ));
        }
    }
    let path = dir.join("lines.csv");
    std::fs::write(&path, t).expect("test data");
    path
}

/// Simulates the eight positions of the true plate on the example machine (noise
/// `noise_um`) and identifies them with the free plate, self-calibrated, plus `extra`.
fn self_calibrated(dir: &Path, noise_um: f64, extra: &[&str]) -> serde_json::Value {
    let (truth, free, _) = plates(dir, PLATE_PPM);
    let c = campaign(dir, &truth, &eight(), 0.2);
    let meas = dir.join("meas");
    if !meas.exists() {
        simulate(&c, &machine(), &meas, noise_um, 5);
    }
    let c = campaign(dir, &free, &eight(), 0.2);
    identify(&c, &[&["--self-calibrate"], extra].concat())
}

/// Largest |truth − estimate| of the plate's deviations after the rigid motion the
/// self-calibration removes (a translation and a rotation, fitted by least squares), µm.
fn beyond_rigid(v: &serde_json::Value, truth: &[[f64; 3]]) -> f64 {
    let f = v["self_calibration"]["features"]
        .as_array()
        .expect("features");
    let n = truth.len();
    let d = nalgebra::DVector::from_fn(3 * n, |r, _| {
        let (i, k) = (r / 3, r % 3);
        truth[i][k] - f[i]["dev_um"][k].as_f64().expect("dev")
    });
    // Rigid motion of the plate's point (x, y, 0): t + ω × f, ω in µm per mm.
    let a = nalgebra::DMatrix::from_fn(3 * n, 6, |r, j| {
        let (i, k) = (r / 3, r % 3);
        let (x, y) = ((i % 5) as f64 * 100.0, (i / 5) as f64 * 100.0);
        let rot = [[0.0, 0.0, -y], [0.0, 0.0, x], [y, -x, 0.0]];
        if j < 3 {
            f64::from(j == k)
        } else {
            rot[j - 3][k]
        }
    });
    let sol = a
        .clone()
        .svd(true, true)
        .solve(&d, 1e-12)
        .expect("rigid fit");
    (d - a * sol).amax()
}

#[test]
fn a_laser_line_determines_the_scale_a_self_calibration_leaves_invariant() {
    let m = Machine::read(&machine()).expect("machine");
    let dir = tempdir();
    let (_, _, dev) = plates(dir.path(), PLATE_PPM);
    // The plate alone: its scale is an invariant, carried by the machine's components,
    // so the planted 5 ppm (1 µm over the plate's half-diagonal) stays in the machine.
    let alone = self_calibrated(dir.path(), 0.0, &[]);
    let kinds = invariant_kinds(&alone);
    assert!(kinds.iter().any(|k| k == "scale"), "{kinds:?}");
    let w = beyond_rigid(&alone, &dev);
    assert!(w > 0.5, "the plate alone recovered its scale: {w} µm");
    // One line along X at y = 100, z = 200 mm (noise-free): a traceable length.
    let lines = laser(
        dir.path(),
        &m,
        &[("X1", [0.0, 100.0, 200.0], [1.0, 0.0, 0.0])],
        0.0,
    );
    let joint = self_calibrated(dir.path(), 0.0, &["--laser", s(&lines)]);
    let kinds = invariant_kinds(&joint);
    assert!(!kinds.iter().any(|k| k == "scale"), "{kinds:?}");
    assert!(
        joint["unidentified"]
            .as_array()
            .expect("unidentified")
            .is_empty()
    );
    let w = beyond_rigid(&joint, &dev);
    assert!(w < 0.01, "deviations beyond the rigid motion: {w} µm");
    assert_eq!(compare(&joint, &m, 0.01, 0.0), 21);
    // The laser line carries its share of the residual test.
    let carriers = joint["residual"]["carriers"].as_array().expect("carriers");
    assert!(
        carriers.iter().any(|c| c["position"] == "laser X1"),
        "{carriers:?}"
    );
}

#[test]
fn the_joint_fit_covers_the_truth_with_noise() {
    let m = Machine::read(&machine()).expect("machine");
    let dir = tempdir();
    let lines = laser(
        dir.path(),
        &m,
        &[("X1", [0.0, 100.0, 200.0], [1.0, 0.0, 0.0])],
        0.1,
    );
    let joint = self_calibrated(dir.path(), 0.2, &["--laser", s(&lines)]);
    assert_eq!(compare(&joint, &m, 0.0, 4.0), 21);
    assert_eq!(
        joint["residual"]["verdict"], "consistent",
        "{}",
        joint["residual"]
    );
}

#[test]
fn a_rigid_machine_with_a_laser_line_is_a_null() {
    let dir = tempdir();
    let rigid = dir.path().join("rigid.toml");
    std::fs::write(&rigid, "topology = \"YXZ\"\n[components]\n").expect("test data");
    let m = Machine::read(&rigid).expect("rigid");
    let lines = laser(
        dir.path(),
        &m,
        &[
            ("X1", [0.0, 100.0, 200.0], [1.0, 0.0, 0.0]),
            ("Y1", [400.0, 0.0, 200.0], [0.0, 1.0, 0.0]),
        ],
        0.1,
    );
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(dir.path(), &c, &rigid, 0.2, &["--laser", s(&lines)]);
    assert_eq!(compare(&v, &m, 0.0, 4.0), 21);
    assert_eq!(v["residual"]["verdict"], "consistent", "{}", v["residual"]);
    let carriers = v["residual"]["carriers"].as_array().expect("carriers");
    assert_eq!(carriers.len(), 10, "{carriers:?}");
}

#[test]
fn a_laser_table_without_one_sigmas_is_refused() {
    let dir = tempdir();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    simulate(&c, &machine(), &dir.path().join("meas"), 0.0, 1);
    let lines = dir.path().join("lines.csv");
    let mut t = String::from("line,x_mm,y_mm,z_mm,ux,uy,uz,e_um\n");
    for i in 0..5 {
        t.push_str(&format!("X1,{},100,200,1,0,0,0.5\n", 100 * i));
    }
    std::fs::write(&lines, t).expect("test data");
    let o = errmap(&[
        "artefact",
        "identify",
        s(&c),
        "--topology",
        "YXZ",
        "--laser",
        s(&lines),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("lines.csv") && e.contains("s_um") && e.contains("X1"),
        "{e}"
    );
}
