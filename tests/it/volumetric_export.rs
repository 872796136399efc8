//! Volumetric export for controllers: the TwinCAT 3 CNC (TF5280) ISG CSV component
//! tables, read back by a parser of the documented structure, reproduce the identified
//! error vector exactly (squareness folded into the straightness of Y and Z; mm and rad);
//! undetermined components refuse the export; the 1-D positioning tables are −E_kk and
//! go through the existing exporters from the command line.

use std::path::Path;

use errmap::volumetric::{Component, squareness_effect};
use errmap::volumetric::{Degree, IdentifyConfig, LineTable, Predictor, identify, simulate};
use errmap::volumetric::{component_tables, positioning_profile};
use rand::SeedableRng;
use rand::rngs::StdRng;

use super::volumetric::{errmap, plan_file, poor_lines, random_machine, topo, write};

/// One block of an ISG CSV file: header names and rows.
type Block = (Vec<String>, Vec<Vec<f64>>);

/// Parses the ISG CSV structure of the TF5280 manual: `//` row comments, a `#` line is a
/// file break, then a header of names and rows of numbers separated by blanks.
fn parse_isg_csv(text: &str) -> Vec<Block> {
    let mut blocks: Vec<Block> = vec![(Vec::new(), Vec::new())];
    for line in text.lines() {
        let t = line.trim();
        if t.is_empty() || t.starts_with("//") {
            continue;
        }
        if t == "#" {
            blocks.push((Vec::new(), Vec::new()));
            continue;
        }
        let b = blocks.last_mut().expect("a block");
        if b.0.is_empty() {
            b.0 = t.split_whitespace().map(str::to_string).collect();
        } else {
            let row: Vec<f64> = t
                .split_whitespace()
                .map(|v| v.parse().expect("number"))
                .collect();
            assert_eq!(row.len(), b.0.len(), "row width: {t}");
            b.1.push(row);
        }
    }
    blocks
}

#[test]
fn twincat_tables_reproduce_the_identified_error_vector() {
    for t in ["YXZ", "ZXY"] {
        let mut rng = StdRng::seed_from_u64(11);
        let m = random_machine(topo(t), &mut rng);
        let plan = plan_file(Some("rich"), 2, 0.1)
            .validate(Path::new("test"))
            .expect("plan");
        let mut cfg = IdentifyConfig::new(topo(t));
        cfg.degree = Degree::Fixed(3);
        cfg.basis = errmap::volumetric::BasisKind::Poly;
        let id = identify(&simulate(&m, &plan), &cfg).expect("identify");
        let tables = component_tables(&id.fit, 5).expect("all determined");
        let text = errmap::controller::isg::render_volumetric(&tables, "test");
        let blocks = parse_isg_csv(&text);
        assert_eq!(blocks.len(), 3, "{text}");
        let want_headers = [
            "X EXX EYX EZX EAX EBX ECX",
            "Y EXY EYY EZY EAY EBY ECY",
            "Z EXZ EYZ EZZ EAZ EBZ ECZ",
        ];
        for (b, h) in blocks.iter().zip(want_headers) {
            assert_eq!(b.0.join(" "), h);
            assert_eq!(b.1.len(), 5);
        }
        assert!(text.contains(&format!("chain from the workpiece (base) to the tool: {t}")));
        // The first-order model evaluated from the file alone (mm → µm, rad → µrad, no
        // squareness: it is folded in) at points on the tables' nodes …
        let value = |k: usize, kind: usize, i: usize| {
            let v = blocks[k].1[i][1 + kind];
            if kind < 3 { v * 1e3 } else { v * 1e6 }
        };
        let model = Predictor::Fit(id.fit.clone());
        let topology = topo(t);
        for (i, j, l) in [(0, 0, 0), (4, 4, 4), (1, 3, 2), (4, 0, 3), (2, 2, 0)] {
            let idx = [i, j, l];
            let p: [f64; 3] = [0, 1, 2].map(|k| blocks[k].1[idx[k]][0]);
            let mut e = [0.0; 3];
            for c in Component::all() {
                let v = value(c.axis, c.kind, idx[c.axis]);
                let d = c.unit_effect(topology.lever_arm(c.axis, p, [0.0; 3]));
                for q in 0..3 {
                    e[q] += v * d[q];
                }
            }
            // … equals the identified error vector, squareness included.
            let (want, _) = model.predict_grid(&[p], [0.0; 3]).expect("map")[0];
            for q in 0..3 {
                assert!(
                    (e[q] - want[q]).abs() < 1e-6,
                    "{t} {p:?}: {e:?} vs {want:?}"
                );
            }
        }
        // The squareness is in the file: without folding, E_XY would miss −1e−3·E_C0Y·y.
        let (sq, _) = id.fit.squareness(0).expect("E_C0Y");
        let y = blocks[1].1[4][0];
        let (exy, _) = id.fit.component(6, y).expect("E_XY");
        assert!((value(1, 0, 4) - (exy - 1e-3 * sq * y)).abs() < 1e-6);
        assert!(squareness_effect(0, [0.0, y, 0.0])[0] == -1e-3 * y);
    }
}

#[test]
fn undetermined_components_refuse_the_export() {
    let mut rng = StdRng::seed_from_u64(3);
    let m = random_machine(topo("YXZ"), &mut rng);
    let lines = poor_lines()
        .into_iter()
        .map(|mut l| {
            for tg in &mut l.targets {
                tg.e_um = Some(m.line_error_um(tg.pos_mm, l.u, l.probe_mm));
            }
            l
        })
        .collect();
    let table = LineTable {
        source: "poor".into(),
        lines,
    };
    let mut cfg = IdentifyConfig::new(topo("YXZ"));
    cfg.degree = Degree::Fixed(2);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    let id = identify(&table, &cfg).expect("identify");
    let err = component_tables(&id.fit, 5)
        .expect_err("undetermined")
        .to_string();
    assert!(err.contains("E_YX") && err.contains("E_C0Y"), "{err}");
    // Positioning along X at the origin is determined by these lines, so its profile is.
    let pos = [0.0, 400.0, 800.0];
    let prof = positioning_profile(&id.fit, 0, [0.0; 3], &pos).expect("E_XX determined");
    for (a, (e, _)) in pos.iter().zip(&prof) {
        let (exx, _) = id.fit.component(0, *a).expect("E_XX");
        assert!((e + exx).abs() < 1e-9);
    }
}

#[test]
fn cli_exports_twincat_tables_and_positioning_tables() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = |x: &Path| x.to_str().expect("utf-8").to_string();
    let lines = dir.path().join("lines.csv");
    let model = dir.path().join("model.json");
    let out = errmap(&[
        "volumetric",
        "simulate",
        "--model",
        "datasets/volumetric/model.toml",
        "--plan",
        "datasets/volumetric/plan.toml",
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
        "--out",
        &p(&model),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let twincat = dir.path().join("volcomp.csv");
    let axes = dir.path().join("axes");
    let out = errmap(&[
        "volumetric",
        "export",
        "--model",
        &p(&model),
        "--twincat",
        &p(&twincat),
        "--axis-tables",
        &p(&axes),
        "--format",
        "csv",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let blocks = parse_isg_csv(&std::fs::read_to_string(&twincat).expect("twincat"));
    assert_eq!(blocks.len(), 3);
    assert_eq!(blocks[0].1.len(), 21);
    // E_XX in the file (mm) and in the model (µm), and the X table's e = −E_XX (µm).
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).expect("model")).expect("json");
    let exx = &doc["components"]["E_XX"];
    let x_csv = std::fs::read_to_string(axes.join("X.csv")).expect("X.csv");
    let rows: Vec<Vec<String>> = x_csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), 21);
    for (i, row) in rows.iter().enumerate() {
        let x: f64 = row[0].parse().expect("x");
        let e: f64 = row[3].parse().expect("e");
        assert_eq!(exx["positions_mm"][i].as_f64(), Some(x));
        let v = exx["values"][i].as_f64().expect("value");
        assert!((e + v).abs() < 1e-9, "{x}: {e} vs −{v}");
        assert!((blocks[0].1[i][1] * 1e3 - v).abs() < 1e-6);
    }
    for f in ["Y.csv", "Z.csv"] {
        assert!(axes.join(f).is_file());
    }
    // LinuxCNC through the same path; a machine-model TOML is refused (exit 1).
    let out = errmap(&[
        "volumetric",
        "export",
        "--model",
        &p(&model),
        "--axis-tables",
        &p(&axes),
        "--format",
        "linuxcnc",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(axes.join("X.comp").is_file());
    let toml = write(dir.path(), "m.toml", "topology = \"XYZ\"\n");
    let out = errmap(&[
        "volumetric",
        "export",
        "--model",
        &p(&toml),
        "--twincat",
        &p(&twincat),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("identified model"));
    // Neither output: a usage error.
    let out = errmap(&["volumetric", "export", "--model", &p(&model)]);
    assert_eq!(out.status.code(), Some(2));
}
