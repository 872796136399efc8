//! Known answers of `artefact identify` on campaigns errmap simulates: the machine is the
//! example's (`datasets/artefact/machine.toml`, cubic-or-lower components, so the cubic
//! basis holds it exactly), its components compared under the volumetric gauge
//! (`GaugeTruth`), and the residual test's verdict on noise alone.

use std::path::{Path, PathBuf};

use errmap::volumetric::{Component, GaugeTruth, Machine};

use crate::util::{dataset, errmap, json, s, stderr, tempdir};

/// One position: id, plane or direction, rotation, flip, origin, probe.
pub(super) struct Pos<'a> {
    pub id: &'a str,
    pub plane: &'a str,
    pub rot: f64,
    pub flip: bool,
    pub origin: [f64; 3],
    pub probe: [f64; 3],
}

pub(super) const fn pos<'a>(id: &'a str, plane: &'a str, rot: f64, origin: [f64; 3]) -> Pos<'a> {
    Pos {
        id,
        plane,
        rot,
        flip: false,
        origin,
        probe: [0.0; 3],
    }
}

/// The example's eight positions (as datasets/artefact/campaign.toml).
pub(super) fn eight() -> Vec<Pos<'static>> {
    let mut v = vec![
        pos("XY_low", "XY", 0.0, [200.0, 100.0, 50.0]),
        pos("XY_high", "XY", 0.0, [200.0, 100.0, 350.0]),
        pos("XY_turned", "XY", 90.0, [600.0, 100.0, 200.0]),
        pos("XZ_front", "XZ", 0.0, [200.0, 100.0, 0.0]),
        pos("XZ_back", "XZ", 0.0, [200.0, 500.0, 0.0]),
        pos("YZ_left", "YZ", 0.0, [100.0, 100.0, 0.0]),
        pos("YZ_right", "YZ", 0.0, [700.0, 100.0, 0.0]),
        pos("XY_stylus", "XY", 0.0, [200.0, 100.0, 150.0]),
    ];
    v[4].probe = [0.0, 100.0, 0.0];
    v[6].probe = [-100.0, 0.0, 0.0];
    v[7].probe = [0.0, 0.0, -100.0];
    v
}

/// Writes campaign.toml for `positions` of `artefact` (a path) into `dir`.
pub(super) fn campaign(dir: &Path, artefact: &Path, positions: &[Pos], sigma_um: f64) -> PathBuf {
    let mut t = format!("sigma_um = {sigma_um}\n");
    for p in positions {
        t.push_str(&format!(
            "[[position]]\nid = \"{}\"\nartefact = \"{}\"\nfile = \"meas/{}.csv\"\n",
            p.id,
            artefact.display(),
            p.id
        ));
        if p.plane.len() == 2 {
            t.push_str(&format!(
                "plane = \"{}\"\nrotation_deg = {}\nflip = {}\n",
                p.plane, p.rot, p.flip
            ));
        } else {
            t.push_str(&format!("direction = {}\n", p.plane));
        }
        t.push_str(&format!(
            "origin_mm = [{}, {}, {}]\nprobe_mm = [{}, {}, {}]\n",
            p.origin[0], p.origin[1], p.origin[2], p.probe[0], p.probe[1], p.probe[2]
        ));
    }
    let path = dir.join("campaign.toml");
    std::fs::write(&path, t).expect("write");
    path
}

pub(super) fn machine() -> PathBuf {
    dataset("artefact/machine.toml")
}

/// Writes a certified 1-D artefact (`kind` step_gauge or ball_beam): `n` features
/// `pitch_mm` apart along x, exactly at nominal, `u_um` each; returns its path.
pub(super) fn gauge_file(dir: &Path, id: &str, kind: &str, n: usize, pitch_mm: f64) -> PathBuf {
    let mut t = format!("id = \"{id}\"\nkind = \"{kind}\"\n");
    for i in 0..n {
        let x = pitch_mm * i as f64;
        t.push_str(&format!(
            "[[feature]]\nid = \"F{i:02}\"\nnominal_mm = [{x}, 0.0, 0.0]\ncertificate_mm = [{x}, 0.0, 0.0]\nu_um = 0.2\n"
        ));
    }
    let path = dir.join(format!("{id}.toml"));
    std::fs::write(&path, t).expect("test data");
    path
}

/// `artefact identify CAMPAIGN --topology YXZ --out MODEL` (the measurements in place).
pub(super) fn identify_out(campaign: &Path, model: &Path) {
    let o = errmap(&[
        "artefact",
        "identify",
        s(campaign),
        "--topology",
        "YXZ",
        "--out",
        s(model),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `artefact simulate CAMPAIGN --model MODEL --out MEAS --sigma-um NOISE --seed SEED`.
pub(super) fn simulate(campaign: &Path, model: &Path, meas: &Path, noise: f64, seed: u64) {
    let (noise, seed) = (noise.to_string(), seed.to_string());
    let o = errmap(&[
        "artefact",
        "simulate",
        s(campaign),
        "--model",
        s(model),
        "--out",
        s(meas),
        "--sigma-um",
        &noise,
        "--seed",
        &seed,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Simulates into dir/meas and identifies; returns the JSON.
pub(super) fn run(
    dir: &Path,
    campaign: &Path,
    model: &Path,
    noise: f64,
    extra: &[&str],
) -> serde_json::Value {
    simulate(campaign, model, &dir.join("meas"), noise, 3);
    identify(campaign, extra)
}

/// `artefact identify CAMPAIGN --topology YXZ --json` plus `extra`, which must succeed;
/// returns the JSON.
pub(super) fn identify(campaign: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "artefact",
        "identify",
        s(campaign),
        "--topology",
        "YXZ",
        "--json",
    ];
    args.extend_from_slice(extra);
    let o = errmap(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    json(&o)
}

/// Every identified component against the truth under the gauge: |est − truth| ≤
/// tol + k·σ at every report position. Returns the number compared.
pub(super) fn compare(v: &serde_json::Value, machine: &Machine, tol: f64, k: f64) -> usize {
    let range: Vec<[f64; 2]> = (0..3)
        .map(|a| {
            let axis = ["E_XX", "E_YY", "E_ZZ"][a];
            let p = v["components"][axis]["positions_mm"]
                .as_array()
                .expect("positions");
            [
                p[0].as_f64().expect("test data"),
                p[p.len() - 1].as_f64().expect("test data"),
            ]
        })
        .collect();
    let truth = GaugeTruth::of(machine, [range[0], range[1], range[2]]);
    let mut n = 0;
    for c in Component::all() {
        let e = &v["components"][c.name()];
        if e["identified"] != true {
            continue;
        }
        let pos = e["positions_mm"].as_array().expect("test data");
        for (i, p) in pos.iter().enumerate() {
            let a = p.as_f64().expect("test data");
            let est = e["values"][i].as_f64().expect("test data");
            let sig = e["sigma"][i].as_f64().expect("test data");
            let t = truth.value(machine, c, a);
            assert!(
                (est - t).abs() <= tol + k * sig,
                "{} at {a}: {est} vs {t} (σ {sig})",
                c.name()
            );
        }
        n += 1;
    }
    for (i, name) in ["E_C0Y", "E_B0Z", "E_A0Z"].iter().enumerate() {
        let e = &v["components"][*name];
        if e["identified"] == true {
            let est = e["value"].as_f64().expect("test data");
            let sig = e["sigma"].as_f64().expect("test data");
            let t = truth.squareness_urad[i];
            assert!(
                (est - t).abs() <= tol + k * sig,
                "{name}: {est} vs {t} (σ {sig})"
            );
            n += 1;
        }
    }
    n
}

#[test]
fn eight_positions_of_a_calibrated_plate_give_the_21_errors() {
    let dir = tempdir();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    let m = Machine::read(&machine()).expect("machine");
    // Noise-free: the cubic basis holds the machine, the fit is exact.
    assert_eq!(compare(&v, &m, 2e-3, 0.0), 21, "{}", v["unidentified"]);
    assert!(v["unidentified"].as_array().expect("test data").is_empty());
    assert!(v["rms_residual_um"].as_f64().expect("test data") < 1e-3);
    assert_eq!(v["positions"], 8);
    assert_eq!(v["features"], 200);
    assert!(v["self_calibration"].is_null());
    // Placements as stated (noise-free, the stated origin is exact).
    let p = &v["placements"][2];
    assert_eq!(p["position"], "XY_turned");
    assert!(
        (p["rotation"][0][1].as_f64().expect("test data") + 1.0).abs() < 1e-6,
        "{p}"
    );
    assert!(
        (p["translation_mm"][0].as_f64().expect("test data") - 600.0).abs() < 1e-3,
        "{p}"
    );
    // With noise: within 4 σ, and the residual consistent with it.
    let dir = tempdir();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(dir.path(), &c, &machine(), 0.2, &[]);
    assert_eq!(compare(&v, &m, 0.0, 4.0), 21);
    assert_eq!(v["residual"]["verdict"], "consistent", "{}", v["residual"]);
    assert_eq!(
        v["residual"]["carriers"]
            .as_array()
            .expect("test data")
            .len(),
        8
    );
}

#[test]
fn four_positions_name_what_they_cannot_determine() {
    let dir = tempdir();
    let four: Vec<Pos> = eight().into_iter().take(4).collect();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &four, 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    let m = Machine::read(&machine()).expect("machine");
    // Weakly determined components carry their (large) σ.
    let n = compare(&v, &m, 2e-3, 4.0);
    let un = v["unidentified"].as_array().expect("test data");
    let named: Vec<&str> = un
        .iter()
        .flat_map(|u| {
            u["components"]
                .as_array()
                .expect("test data")
                .iter()
                .map(|c| c.as_str().expect("test data"))
        })
        .collect();
    // No stylus offset: the ram's (last axis') rotations have no lever arm, nor has X's yaw
    // (its arm is along z): they cannot be seen.
    for c in ["E_AZ", "E_BZ", "E_CZ", "E_CX"] {
        assert!(named.contains(&c), "{c} not named: {named:?}");
        assert_eq!(v["components"][c]["identified"], false);
        assert!(v["components"][c]["values"].is_null());
    }
    assert_eq!(n + named.len(), 21, "{named:?}");
    // The ram's three rotations need stylus offsets in two directions: no single extra
    // position determines the group, and the report says so with an empty list.
    for u in un {
        assert!(u["suggest"].is_array(), "{u}");
        assert!(!u["why"].as_str().expect("test data").is_empty());
    }
}

#[test]
fn the_model_is_volumetrics_model() {
    // model.json read back through volumetric's reader predicts the campaign: simulated
    // with it, the positions fit with nothing left but rounding.
    let dir = tempdir();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let meas = dir.path().join("meas");
    let o = errmap(&[
        "artefact",
        "simulate",
        s(&c),
        "--model",
        s(&machine()),
        "--out",
        s(&meas),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let model = dir.path().join("model.json");
    identify_out(&c, &model);
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).expect("test data"))
            .expect("test data");
    assert_eq!(doc["basis"], "poly");
    assert_eq!(doc["topology"], "YXZ");
    let d2 = tempdir();
    let c2 = campaign(d2.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(d2.path(), &c2, &model, 0.0, &[]);
    assert!(
        v["rms_residual_um"].as_f64().expect("test data") < 1e-3,
        "{}",
        v["rms_residual_um"]
    );
    // volumetric iso10360 takes it.
    let o = errmap(&["volumetric", "iso10360", "--model", s(&model), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_rigid_machine_is_a_null() {
    let dir = tempdir();
    let rigid = dir.path().join("rigid.toml");
    std::fs::write(&rigid, "topology = \"YXZ\"\n[components]\n").expect("test data");
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(dir.path(), &c, &rigid, 0.2, &[]);
    let m = Machine::read(&rigid).expect("rigid");
    assert_eq!(compare(&v, &m, 0.0, 4.0), 21);
    assert_eq!(v["residual"]["verdict"], "consistent", "{}", v["residual"]);
    let z = v["residual"]["z"].as_f64().expect("test data");
    assert!(z.abs() < 3.09, "{z}");
}
