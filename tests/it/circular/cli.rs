//! `errmap circular simulate` then `diagnose --json`: the contract's document, exit codes.

use crate::util::{errmap_cmd as errmap, tempdir};

#[test]
fn simulate_then_diagnose_prints_the_contract_document() {
    let dir = tempdir();
    let trace = dir.path().join("t.csv");
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/circular/machine.toml"
    );
    let out = errmap()
        .args(["circular", "simulate", "--model", model, "--out"])
        .arg(&trace)
        .output()
        .expect("test set-up");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("t.toml").exists());
    let report = dir.path().join("rep");
    let out = errmap()
        .args(["circular", "diagnose"])
        .arg(&trace)
        .arg("--report")
        .arg(&report)
        .arg("--json")
        .output()
        .expect("test set-up");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("test set-up");
    assert_eq!(doc["verdict"], "errors_found");
    assert_eq!(doc["plane"], "XY");
    let ids: Vec<(String, String)> = doc["effects"]
        .as_array()
        .expect("test set-up")
        .iter()
        .map(|e| {
            (
                e["id"].as_str().expect("test set-up").into(),
                e["axis"].as_str().expect("test set-up").into(),
            )
        })
        .collect();
    for want in [
        ("backlash", "X"),
        ("reversal_spike", "X"),
        ("cyclic_error", "Y"),
        ("squareness", "XY"),
        ("servo_mismatch", "XY"),
        ("straightness", "Y"),
    ] {
        assert!(
            ids.iter().any(|(i, a)| i == want.0 && a == want.1),
            "{want:?} not in {ids:?}"
        );
    }
    assert_eq!(ids.len(), 6, "{ids:?}");
    let file: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(report.join("circular.json")).expect("test set-up"),
    )
    .expect("test set-up");
    assert_eq!(file, doc);
    assert!(report.join("report.md").exists() && report.join("polar.png").exists());
}

#[test]
fn a_bad_cell_names_file_line_and_column_and_usage_errors_exit_2() {
    let dir = tempdir();
    let trace = dir.path().join("bad.csv");
    std::fs::write(
        &trace,
        "run,direction,angle_deg,dr_um\n1,1,0.0,0.1\n1,1,1.0,nan\n",
    )
    .expect("test set-up");
    std::fs::write(
        dir.path().join("bad.toml"),
        "plane = \"XY\"\nradius_mm = 100.0\nfeed_mm_per_min = 1000.0\narc_start_deg = 0.0\n\
         arc_deg = 360.0\novershoot_deg = 45.0\n",
    )
    .expect("test set-up");
    let out = errmap()
        .args(["circular", "diagnose"])
        .arg(&trace)
        .args(["--report", "/nonexistent-dir-never/x"])
        .output()
        .expect("test set-up");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.csv: line 3: column dr_um:"), "{err}");
    let out = errmap()
        .args(["circular", "diagnose"])
        .output()
        .expect("test set-up");
    assert_eq!(out.status.code(), Some(2));
}
