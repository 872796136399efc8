//! Bad input refused as `artefact.md` says: exit 1 naming the file and the key or row,
//! exit 2 for usage; nothing written.

use std::path::Path;

use super::identify::{campaign, eight, machine};
use crate::util::{dataset, errmap, s, stderr, tempdir};

fn refused(args: &[&str], code: i32, words: &[&str]) {
    let o = errmap(args);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    for w in words {
        assert!(e.contains(w), "{args:?}: `{w}` not in {e}");
    }
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("test data");
    p.display().to_string()
}

const PLATE: &str = "kind = \"hole_plate\"\n[[feature]]\nid = \"A\"\nnominal_mm = [0.0, 0.0, 0.0]\n\
    [[feature]]\nid = \"B\"\nnominal_mm = [100.0, 0.0, 0.0]\n[[feature]]\nid = \"C\"\nnominal_mm = [0.0, 100.0, 0.0]\n\
    [[feature]]\nid = \"D\"\nnominal_mm = [100.0, 100.0, 0.0]\n";

#[test]
fn artefact_files_are_checked_by_key() {
    let d = tempdir();
    let meas = write(
        d.path(),
        "m.csv",
        "feature,x_mm,y_mm\nA,0,0\nB,100,0\nC,0,100\n",
    );
    let cases: Vec<(String, Vec<&str>)> = vec![
        (PLATE.replace("kind", "knid"), vec!["knid", "unknown key"]),
        (
            PLATE.replace("hole_plate", "hole_plat"),
            vec!["kind", "hole_plat"],
        ),
        (
            PLATE.replacen(
                "nominal_mm = [0.0, 0.0, 0.0]",
                "nominal_mm = [0.0, 0.0, 0.0]\ncertificate_mm = [0.0, 0.0, 0.0]\nu_um = 0.5",
                1,
            ),
            vec!["feature[2].certificate_mm", "every feature or none"],
        ),
        (
            PLATE.replacen(
                "nominal_mm = [0.0, 0.0, 0.0]",
                "nominal_mm = [0.0, 0.0, 0.0]\ncertificate_mm = [0.0, 0.0, 0.0]",
                1,
            ),
            vec!["feature[1].u_um", "go together"],
        ),
        (
            PLATE.replace("hole_plate", "step_gauge"),
            vec!["feature[3].nominal_mm", "x axis"],
        ),
        (
            PLATE.replacen("id = \"B\"", "id = \"A\"", 1),
            vec!["feature[2].id", "twice"],
        ),
    ];
    for (text, words) in cases {
        let a = write(d.path(), "a.toml", &text);
        let mut w = vec!["a.toml"];
        w.extend(words);
        refused(&["artefact", "evaluate", &a, &meas], 1, &w);
    }
}

#[test]
fn measurement_files_are_checked_by_row() {
    let d = tempdir();
    let a = write(d.path(), "a.toml", PLATE);
    let cases = [
        (
            "feature,x_mm,y_mm\nA,0,0\nB,100,0\nE,0,100\n",
            vec!["row 3 (line 4)", "`E`"],
        ),
        (
            "feature,x_mm,y_mm\nA,0,0\nB,100,0\nA,0,100\n",
            vec!["row 3 (line 4)", "twice"],
        ),
        (
            "feature,x_mm,y_mm\nA,0,0\nB,nan,0\nC,0,100\n",
            vec!["row 2 (line 3)", "x_mm", "finite"],
        ),
        ("feature,x_mm\nA,0\n", vec!["y_mm"]),
        ("feature,x_mm,y_mm\nA,0,0\nB,100,0\n", vec!["at least 3"]),
    ];
    for (text, words) in cases {
        let m = write(d.path(), "m.csv", text);
        let mut w = vec!["m.csv"];
        w.extend(words);
        refused(&["artefact", "evaluate", &a, &m], 1, &w);
    }
    let m = write(
        d.path(),
        "m.csv",
        "feature,x_mm,y_mm\nA,0,0\nB,100,0\nC,0,100\n",
    );
    let old = write(
        d.path(),
        "old.csv",
        "feature,x_mm,y_mm\nA,0,0\nB,100,0\nD,100,100\n",
    );
    refused(
        &["artefact", "evaluate", &a, &m, "--against", &old],
        1,
        &["old.csv", "2 features in common"],
    );
    refused(
        &["artefact", "evaluate", &a, &m, "--model", "affine"],
        2,
        &["affine"],
    );
    refused(
        &["artefact", "evaluate", &a, &m, "--plane", "XX"],
        2,
        &["XX"],
    );
    refused(
        &["artefact", "evaluate", &a, "missing.csv"],
        1,
        &["missing.csv"],
    );
}

#[test]
fn campaigns_are_checked_by_key_and_placement() {
    let d = tempdir();
    let plate = dataset("artefact/plate.toml");
    let c = campaign(d.path(), &plate, &eight(), 0.2);
    let meas = d.path().join("meas");
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
    // The output directory exists now: refused, nothing replaced.
    let before = std::fs::read(meas.join("XY_low.csv")).expect("test data");
    refused(
        &[
            "artefact",
            "simulate",
            s(&c),
            "--model",
            s(&machine()),
            "--out",
            s(&meas),
        ],
        1,
        &["exists"],
    );
    assert_eq!(
        std::fs::read(meas.join("XY_low.csv")).expect("test data"),
        before
    );
    let text = std::fs::read_to_string(&c).expect("test data");
    let id = |t: &str, words: &[&str]| {
        std::fs::write(&c, t).expect("test data");
        refused(
            &["artefact", "identify", s(&c), "--topology", "YXZ"],
            1,
            words,
        );
    };
    id(
        &text.replacen("probe_mm", "probe_nm", 1),
        &["position[1].probe_nm", "unknown key"],
    );
    id(
        &text.replacen("origin_mm = [200, 100, 50]", "origin_mm = [200, 100]", 1),
        &["position[1].origin_mm"],
    );
    id(
        &text.replacen(
            "origin_mm = [200, 100, 50]",
            "origin_mm = [300, 100, 50]",
            1,
        ),
        &["position[1].origin_mm", "50 mm"],
    );
    id(
        &text.replacen("rotation_deg = 90", "rotation_deg = 75", 1),
        &["position[3].rotation_deg", "10°"],
    );
    id(
        &text.replacen("plane = \"XY\"", "direction = [1.0, 0.0, 0.0]", 1),
        &["position[1].direction"],
    );
    id(
        &text.replacen("XY_low.csv", "nothing.csv", 1),
        &["nothing.csv"],
    );
    std::fs::write(&c, &text).expect("test data");
    // A ball 0.8 mm off: named by file, row and id.
    let f = meas.join("XY_high.csv");
    let csv = std::fs::read_to_string(&f).expect("test data");
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let cells: Vec<String> = lines[5].split(',').map(str::to_string).collect();
    let x: f64 = cells[1].parse().expect("test data");
    lines[5] = format!("{},{},{},{}", cells[0], x + 0.8, cells[2], cells[3]);
    std::fs::write(&f, lines.join("\n") + "\n").expect("test data");
    refused(
        &["artefact", "identify", s(&c), "--topology", "YXZ"],
        1,
        &["XY_high.csv", "row 5 (line 6)", "B05", "0.5 mm"],
    );
    refused(
        &["artefact", "identify", s(&c), "--topology", "YXQ"],
        2,
        &["--topology"],
    );
}
