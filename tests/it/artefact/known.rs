//! More known answers of `errmap artefact` (issue 36, "Done means"): the forward model's
//! temperature and stylus offset against the analytic displacement, a hole plate and a
//! ball beam identified against the simulated truth, an artefact-identified model.json
//! taken by `circular diagnose --model` and `volumetric iso10360`, and the report.

use std::path::Path;

use errmap::volumetric::Machine;

use super::identify::{Pos, campaign, compare, eight, gauge_file, identify_out, machine, pos, run};
use crate::util::{dataset, errmap, json, s, stderr, tempdir};

/// The measured rows of a simulated file: (id, [x, y, z]).
fn read_csv(path: &Path) -> Vec<(String, [f64; 3])> {
    let text = std::fs::read_to_string(path).expect("simulated file");
    text.lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let v = |i: usize| c[i].parse::<f64>().expect("number");
            (c[0].to_string(), [v(1), v(2), v(3)])
        })
        .collect()
}

#[test]
fn simulate_expands_the_plate_and_swings_the_stylus() {
    // A machine whose only error is the ram's yaw, E_CZ(z) = 40·z/400 µrad, and a plate of
    // steel (11.5 ppm/K) at 25 °C. The yaw turns a stylus offset p = (100, 0, 0) mm by ε
    // about z: the tip moves by 1e−3·ε × p = (0, 0.1·ε, 0) µm, and the machine indicates
    // X = R0·f·(1 + α·5 K) + t − E. Without an offset the yaw moves nothing.
    let dir = tempdir();
    let m = dir.path().join("yaw.toml");
    std::fs::write(
        &m,
        "topology = \"YXZ\"\n[components]\nE_CZ = { poly = [40.0], scale_mm = 400.0 }\n",
    )
    .expect("test data");
    let plate = std::fs::read_to_string(dataset("artefact/plate.toml"))
        .expect("test data")
        .replace("alpha_ppm_per_k = 0.0", "alpha_ppm_per_k = 11.5");
    let plate_path = dir.path().join("steel.toml");
    std::fs::write(&plate_path, &plate).expect("test data");
    let mut with = pos("offset", "XY", 0.0, [200.0, 100.0, 300.0]);
    with.probe = [100.0, 0.0, 0.0];
    let without = pos("plain", "XY", 0.0, [200.0, 100.0, 300.0]);
    let c = campaign(dir.path(), &plate_path, &[with, without], 0.2);
    let text = std::fs::read_to_string(&c)
        .expect("campaign")
        .replace("probe_mm", "temp_c = 25.0\nprobe_mm");
    std::fs::write(&c, text).expect("test data");
    let o = errmap(&[
        "artefact",
        "simulate",
        s(&c),
        "--model",
        s(&m),
        "--out",
        s(&dir.path().join("meas")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cert: toml::Table = plate.parse().expect("test data");
    let feats = cert["feature"].as_array().expect("features");
    let k = 1.0 + 11.5e-6 * 5.0;
    for (file, arm_mm) in [("offset.csv", 100.0), ("plain.csv", 0.0)] {
        let rows = read_csv(&dir.path().join("meas").join(file));
        assert_eq!(rows.len(), 25);
        for ((id, x), f) in rows.iter().zip(feats) {
            assert_eq!(id, f["id"].as_str().expect("id"));
            let c: Vec<f64> = f["certificate_mm"]
                .as_array()
                .expect("certificate")
                .iter()
                .map(|v| v.as_float().expect("number"))
                .collect();
            // The yaw at the ball's own height, a_z = z (the offset has no z part).
            let z = 300.0 + c[2] * k;
            let eps_urad = 40.0 * z / 400.0;
            let want = [
                200.0 + c[0] * k,
                100.0 + c[1] * k - 1e-6 * eps_urad * arm_mm,
                z,
            ];
            for j in 0..3 {
                assert!(
                    (x[j] - want[j]).abs() < 2e-9,
                    "{file} {id} axis {j}: {} vs {}",
                    x[j],
                    want[j]
                );
            }
        }
    }
}

/// The example plate as a hole plate (the same certificate; holes observe x and y).
fn hole_plate(dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(dataset("artefact/plate.toml"))
        .expect("test data")
        .replace("kind = \"ball_plate\"", "kind = \"hole_plate\"")
        .replace("id = \"BP-400\"", "id = \"HP-400\"");
    let p = dir.join("hole_plate.toml");
    std::fs::write(&p, text).expect("test data");
    p
}

#[test]
fn a_hole_plate_in_eight_positions_gives_the_in_plane_errors() {
    let dir = tempdir();
    let plate = hole_plate(dir.path());
    let c = campaign(dir.path(), &plate, &eight(), 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    let m = Machine::read(&machine()).expect("machine");
    // Noise-free: what the holes determine is the truth, exactly.
    let n = compare(&v, &m, 2e-3, 0.0);
    eprintln!("hole plate: {n} of 21 determined; {}", v["unidentified"]);
    // The planes XY, XZ, YZ put every pair of axes in a plate's plane: the three scales
    // and the three squareness errors are seen.
    for name in ["E_XX", "E_YY", "E_ZZ", "E_C0Y", "E_B0Z", "E_A0Z"] {
        assert_eq!(v["components"][name]["identified"], true, "{name}");
    }
    assert!(n >= 12, "{n}");
    assert!(v["rms_residual_um"].as_f64().expect("test data") < 1e-3);
    // Holes observe two coordinates: 8 × 25 × 2 rows.
    assert_eq!(v["features"], 200);
    // What is not determined is named, with the components' values null.
    let named = v["unidentified"]
        .as_array()
        .expect("unidentified")
        .iter()
        .map(|u| u["components"].as_array().expect("components").len())
        .sum::<usize>();
    assert_eq!(n + named, 21);
}

#[test]
fn a_ball_beam_along_the_axes_gives_straightness_but_no_squareness() {
    let dir = tempdir();
    let beam = gauge_file(dir.path(), "BB-800", "ball_beam", 9, 100.0);
    const X: &str = "[1.0, 0.0, 0.0]";
    const Y: &str = "[0.0, 1.0, 0.0]";
    const Z: &str = "[0.0, 0.0, 1.0]";
    let mut set: Vec<Pos> = vec![
        pos("X_low", X, 0.0, [100.0, 100.0, 100.0]),
        pos("X_high", X, 0.0, [100.0, 100.0, 600.0]),
        pos("X_back", X, 0.0, [100.0, 700.0, 100.0]),
        pos("Y_left", Y, 0.0, [100.0, 0.0, 100.0]),
        pos("Y_right", Y, 0.0, [900.0, 0.0, 100.0]),
        pos("Y_high", Y, 0.0, [100.0, 0.0, 600.0]),
        pos("Z_a", Z, 0.0, [100.0, 100.0, 0.0]),
        pos("Z_b", Z, 0.0, [900.0, 100.0, 0.0]),
        pos("Z_c", Z, 0.0, [100.0, 700.0, 0.0]),
        pos("X_stylus_y", X, 0.0, [100.0, 300.0, 300.0]),
        pos("Y_stylus_x", Y, 0.0, [500.0, 0.0, 300.0]),
        pos("Z_stylus_x", Z, 0.0, [500.0, 300.0, 0.0]),
        pos("Z_stylus_y", Z, 0.0, [300.0, 500.0, 0.0]),
        pos("X_stylus_z", X, 0.0, [100.0, 500.0, 300.0]),
    ];
    set[9].probe = [0.0, 100.0, 0.0];
    set[10].probe = [100.0, 0.0, 0.0];
    set[11].probe = [100.0, 0.0, 0.0];
    set[12].probe = [0.0, 100.0, 0.0];
    set[13].probe = [0.0, 0.0, -100.0];
    let c = campaign(dir.path(), &beam, &set, 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    let m = Machine::read(&machine()).expect("machine");
    let n = compare(&v, &m, 2e-3, 0.0);
    eprintln!("ball beam: {n} of 21 determined; {}", v["unidentified"]);
    for name in ["E_XX", "E_YY", "E_ZZ", "E_YX", "E_ZX", "E_XY"] {
        assert_eq!(v["components"][name]["identified"], true, "{name}");
    }
    // A beam parallel to an axis relates no two axes: the squareness errors (and the
    // rolls about each beam's own axis) are named as not determined.
    let named: Vec<&str> = v["unidentified"]
        .as_array()
        .expect("unidentified")
        .iter()
        .flat_map(|u| u["components"].as_array().expect("components"))
        .map(|c| c.as_str().expect("name"))
        .collect();
    for name in ["E_C0Y", "E_B0Z", "E_A0Z", "E_AX", "E_BY"] {
        assert!(named.contains(&name), "{name}: {named:?}");
    }
    assert_eq!(n + named.len(), 21);
    assert!(v["rms_residual_um"].as_f64().expect("test data") < 1e-3);
    assert_eq!(v["features"], 14 * 9);
}

/// Identifies the example campaign (noise-free) into `dir/model.json`.
fn artefact_model(dir: &Path) -> std::path::PathBuf {
    let c = campaign(dir, &dataset("artefact/plate.toml"), &eight(), 0.2);
    let v = run(dir, &c, &machine(), 0.0, &[]);
    assert!(v["unidentified"].as_array().expect("test data").is_empty());
    let model = dir.join("model.json");
    identify_out(&c, &model);
    model
}

#[test]
fn circular_and_iso10360_take_an_artefact_identified_model() {
    let dir = tempdir();
    let model = artefact_model(dir.path());
    // The example ballbar trace, centred inside the artefact campaign's volume.
    let trace = dir.path().join("xy.csv");
    std::fs::copy(dataset("circular/xy.csv"), &trace).expect("test data");
    let meta = std::fs::read_to_string(dataset("circular/xy.toml")).expect("test data");
    assert!(
        meta.contains("centre_mm = [250.0, 200.0, -100.0]"),
        "{meta}"
    );
    std::fs::write(
        dir.path().join("xy.toml"),
        meta.replace("[250.0, 200.0, -100.0]", "[400.0, 300.0, 200.0]"),
    )
    .expect("test data");
    let diagnose = |m: &Path, report: &str| {
        let o = errmap(&[
            "circular",
            "diagnose",
            s(&trace),
            "--model",
            s(m),
            "--report",
            s(&dir.path().join(report)),
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        json(&o)
    };
    // The identified model predicts what the machine itself predicts (the cubic basis
    // holds the example machine exactly).
    let by_truth = diagnose(&machine(), "by-machine");
    let by_model = diagnose(&model, "by-model");
    let rows = |d: &serde_json::Value| d["link"]["rows"].as_array().expect("rows").clone();
    let (a, b) = (rows(&by_truth), rows(&by_model));
    assert!(!a.is_empty());
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.iter().zip(&b) {
        assert_eq!(ra["id"], rb["id"]);
        let (pa, pb) = (
            ra["predicted"].as_f64().expect("predicted"),
            rb["predicted"].as_f64().expect("predicted"),
        );
        assert!((pa - pb).abs() < 1e-3, "{}: {pa} vs {pb}", ra["id"]);
    }
    // ISO 10360-2 predicted from the artefact-identified model: every length error that
    // of the machine itself, E = −u·(E(p2) − E(p1)) (a rigid turn of the field, the gauge,
    // changes no length).
    let o = errmap(&["volumetric", "iso10360", "--model", s(&model), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = json(&o);
    let truth = Machine::read(&machine()).expect("machine");
    let ms = doc["measurements"].as_array().expect("measurements");
    assert!(ms.len() >= 35, "{}", ms.len());
    for m in ms {
        let p = |k: &str| [0, 1, 2].map(|i| m[k][i].as_f64().expect("point"));
        let (p1, p2) = (p("p1_mm"), p("p2_mm"));
        let d = [0, 1, 2].map(|i| p2[i] - p1[i]);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let (t1, t2) = (truth.error_um(p1, [0.0; 3]), truth.error_um(p2, [0.0; 3]));
        let e_true = -(0..3).map(|i| d[i] / l * (t2[i] - t1[i])).sum::<f64>();
        let e = m["e_um"].as_f64().expect("e_um");
        assert!((e - e_true).abs() < 2e-3, "{m}: {e} vs {e_true}");
    }
}

#[test]
fn the_report_shows_components_placements_observability_and_maps() {
    let dir = tempdir();
    let four: Vec<Pos> = eight().into_iter().take(4).collect();
    let c = campaign(dir.path(), &dataset("artefact/plate.toml"), &four, 0.2);
    let rep = dir.path().join("report");
    let v = run(dir.path(), &c, &machine(), 0.2, &["--report", s(&rep)]);
    let md = std::fs::read_to_string(rep.join("report.md")).expect("report.md");
    for section in [
        "## Components",
        "## Placements",
        "## Residual by position",
        "## Residual maps",
    ] {
        assert!(md.contains(section), "{section} missing:\n{md}");
    }
    // Every component with its band, the undetermined ones said to be so.
    for name in ["E_XX", "E_C0Y", "E_AZ"] {
        assert!(md.contains(name), "{name} missing");
    }
    // Each determined component says in µm or µrad whether its value stands beyond 2σ.
    let rows: Vec<Vec<&str>> = md
        .lines()
        .filter(|l| l.starts_with("| E_"))
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 21, "{md}");
    let mut determined = 0;
    for r in &rows {
        assert!(r[2] == "µm" || r[2] == "µrad", "{r:?}");
        if let (Ok(v), Ok(sd)) = (r[3].parse::<f64>(), r[4].parse::<f64>()) {
            determined += 1;
            if (v.abs() - 2.0 * sd).abs() < 0.003 {
                continue; // printed to 3 decimals: too close to tell
            }
            let want = if v.abs() > 2.0 * sd { "yes" } else { "no" };
            assert_eq!(r[5], want, "{r:?}");
        }
    }
    assert!(determined > 0, "{md}");
    for u in v["unidentified"].as_array().expect("unidentified") {
        for c in u["components"].as_array().expect("components") {
            assert!(md.contains(c.as_str().expect("name")), "{c}");
        }
    }
    // One map per position, a PNG and its SVG, each arrow a feature.
    for (k, id) in ["XY_low", "XY_high", "XY_turned", "XZ_front"]
        .iter()
        .enumerate()
    {
        assert!(md.contains(id), "{id} missing");
        let stem = format!("residual_{:02}_{id}", k + 1);
        let png = std::fs::read(rep.join(format!("{stem}.png"))).expect("png");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let svg = std::fs::read_to_string(rep.join(format!("{stem}.svg"))).expect("svg");
        assert!(
            svg.contains(&format!("Residuals of position {id}")),
            "{stem}"
        );
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rep.join("identify.json")).expect("json"))
            .expect("json");
    assert_eq!(doc["positions"], 4);
    assert!(rep.join("model.json").exists());
}

#[test]
fn a_missing_position_is_named_and_the_suggested_one_determines_the_rest() {
    // The example's eight positions without XZ_back (the one whose stylus points along y):
    // the X yaw and the ram's roll then have no lever arm across them.
    let dir = tempdir();
    let plate = dataset("artefact/plate.toml");
    let seven: Vec<Pos> = eight().into_iter().filter(|p| p.id != "XZ_back").collect();
    let c = campaign(dir.path(), &plate, &seven, 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    let un = v["unidentified"].as_array().expect("unidentified");
    assert_eq!(un.len(), 1, "{un:?}");
    let names: Vec<&str> = un[0]["components"]
        .as_array()
        .expect("components")
        .iter()
        .map(|c| c.as_str().expect("name"))
        .collect();
    assert_eq!(names, ["E_CX", "E_AZ"]);
    let m = Machine::read(&machine()).expect("machine");
    assert_eq!(compare(&v, &m, 2e-3, 0.0), 19);
    // The first suggestion, placed as the spec says: the plate in its plane at rotation
    // 0, its centroid at the middle of the measured range plus the stylus offset, the
    // normal axis' tip coordinate at_mm.
    let s0 = &un[0]["suggest"][0];
    assert_eq!(s0["plane"], "XZ", "{s0}");
    let probe: Vec<f64> = s0["probe_mm"]
        .as_array()
        .expect("probe")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect();
    assert!(probe[1].abs() > 0.0, "a stylus across y: {probe:?}");
    let mid = |axis: &str| {
        let p = v["components"][axis]["positions_mm"]
            .as_array()
            .expect("positions");
        0.5 * (p[0].as_f64().expect("lo") + p[p.len() - 1].as_f64().expect("hi"))
    };
    // R0(XZ)·(200, 200, 0) = (200, 0, 200): the plate's centroid.
    let at = s0["at_mm"].as_f64().expect("at");
    let origin = [
        mid("E_XX") + probe[0] - 200.0,
        at,
        mid("E_ZZ") + probe[2] - 200.0,
    ];
    let mut eight_again = seven;
    eight_again.push(Pos {
        id: "suggested",
        plane: "XZ",
        rot: 0.0,
        flip: false,
        origin,
        probe: [probe[0], probe[1], probe[2]],
    });
    let dir = tempdir();
    let c = campaign(dir.path(), &plate, &eight_again, 0.2);
    let v = run(dir.path(), &c, &machine(), 0.0, &[]);
    assert!(
        v["unidentified"].as_array().expect("test data").is_empty(),
        "{}",
        v["unidentified"]
    );
    assert_eq!(compare(&v, &m, 2e-3, 0.0), 21);
}
