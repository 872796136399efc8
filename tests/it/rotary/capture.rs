//! The rotary capture (`docs/rotary.md`, "Capture"): errmap's simulated rotary board
//! served on a real pseudo-terminal by `serve-sim`, captured by `capture --port`; the
//! session's errors against the model's analytic r(θ, d); replay identity; `table` and
//! `diagnose` on the captured session; `capture --simulate` giving the same table; a plan
//! from `plan --axis b` driving the board; bad model files refused by key.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

use errmap::session::rotary::read_rotary_session;

use super::{plan_revolution, simulate_capture};
use crate::util::{bin, errmap, json, s, stderr, tempdir};

/// A noiseless B axis: eccentricity 4″ at 30°, reversal 3″ (e = 4·sin(θ + 30°) + d·1.5).
const MODEL: &str = "[rotary]\naxis = \"B\"\npositioning_arcsec = 0.0\nnoise_arcsec = 0.0\n\
    seed = 5\n\n[[rotary.effects]]\nid = \"eccentricity\"\namplitude_arcsec = 4.0\n\
    phase_deg = 30.0\n\n[[rotary.effects]]\nid = \"reversal\"\nb_arcsec = 3.0\n";

fn r_arcsec(theta_deg: f64, d: i8) -> f64 {
    4.0 * (theta_deg + 30.0).to_radians().sin() + f64::from(d) * 1.5
}

/// One encoder count (2²⁶ a revolution) plus one reference count (6.48·10⁷), ″: the
/// captured error's quantisation bound.
const QUANTUM_ARCSEC: f64 = 1_296_000.0 / 67_108_864.0 + 1_296_000.0 / 64_800_000.0;

/// `serve-sim` on a fresh pty (its path from stdout) and `capture --port` from it.
fn serve_and_capture(model: &Path, plan: Option<&Path>, out: &Path) -> std::process::Output {
    let mut c = Command::new(bin());
    c.args(["serve-sim", "--model", s(model), "--speed", "500"])
        .args(["--linger", "1", "--stall-timeout", "10"]);
    if let Some(p) = plan {
        c.args(["--plan", s(p)]);
    }
    let mut sim = c
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("serve-sim starts");
    let mut port = String::new();
    BufReader::new(sim.stdout.take().expect("stdout"))
        .read_line(&mut port)
        .expect("serve-sim prints its pty");
    let o = errmap(&[
        "capture",
        "--port",
        port.trim(),
        "--out",
        s(out),
        "--no-view",
        "--idle-timeout",
        "5",
    ]);
    let served = sim.wait_with_output().expect("serve-sim ends");
    assert!(served.status.success(), "{}", stderr(&served));
    o
}

#[test]
fn a_rotary_board_on_a_pty_gives_the_models_errors_and_the_table_takes_them() {
    let dir = tempdir();
    let model = dir.path().join("rot.toml");
    std::fs::write(&model, MODEL).expect("model");
    let out = dir.path().join("cap");
    let o = serve_and_capture(&model, None, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let session = read_rotary_session(&out.join("session.csv")).expect("a rotary session");
    assert_eq!(session.axis.upper(), "B");
    let dwell: Vec<_> = session.rows.iter().filter(|r| r.is_dwell()).collect();
    // The default cycle: 25 targets (every 15°, 0 and 360), 5 runs, 2 directions, 4 samples.
    assert_eq!(dwell.len(), 25 * 5 * 2 * 4);
    assert!(
        session.rows.len() > dwell.len(),
        "the reversals' moving rows are kept"
    );
    for r in &dwell {
        let theta = r.target_deg.expect("a dwell row has its angle");
        assert!(
            (theta / 15.0 - (theta / 15.0).round()).abs() < 1e-9,
            "{theta}"
        );
        let want = r_arcsec(theta, r.direction);
        assert!(
            (r.error_arcsec - want).abs() <= QUANTUM_ARCSEC,
            "θ {theta} d {}: {} ″ against {want} ″",
            r.direction,
            r.error_arcsec
        );
        // e = (indicated − reference)·3600, and the axis reads its target (no offset).
        let e = (r.indicated_deg - r.reference_deg) * 3600.0;
        assert!((e - r.error_arcsec).abs() < 1e-6);
        assert!((r.indicated_deg - theta).abs() * 3600.0 < 0.02);
        assert_eq!(r.feed_deg_s, Some(10.0));
        assert_eq!(r.air_temp_c, Some(20.0));
    }
    // Replay gives the captured table byte for byte.
    let replayed = dir.path().join("replay.csv");
    let o = errmap(&["replay", s(&out.join("raw.bin")), "--out", s(&replayed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&replayed).expect("replayed"),
        std::fs::read(out.join("session.csv")).expect("captured")
    );
    // `table` takes the capture directory: per target, the bidirectional mean deviation is
    // x̄ = −mean e = −4·sin(θ + 30°) (the reversal cancels), B_i = −3″ (x = −e).
    let t = dir.path().join("t.csv");
    let o = errmap(&["table", s(&out), "--out", s(&t), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    let line = &j["lines"][0];
    for tg in line["iso230"]["targets"].as_array().expect("targets") {
        let theta = tg["position_deg"].as_f64().expect("angle");
        let x = tg["mean_bidir_arcsec"].as_f64().expect("x̄");
        assert!((x + 4.0 * (theta + 30.0).to_radians().sin()).abs() < QUANTUM_ARCSEC);
        let b = tg["reversal_arcsec"].as_f64().expect("B_i");
        assert!((b + 3.0).abs() < 2.0 * QUANTUM_ARCSEC, "B_i {b}");
    }
    // 0 and 360 are one position: their means differ by the counters' quantisation only
    // (noiseless, so the closure limit 2·max(s) is that small too: not asserted).
    for d in ["diff_up_arcsec", "diff_down_arcsec"] {
        let diff = line["closure"][d].as_f64().expect("closure");
        assert!(diff.abs() < 2.0 * QUANTUM_ARCSEC, "{d} {diff}");
    }
    // The diagnosis finds both effects from the capture.
    let o = errmap(&[
        "diagnose",
        "--recorded",
        s(&out),
        "--report",
        s(&dir.path().join("d")),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let d = json(&o);
    let ids: Vec<&str> = d["effects"]
        .as_array()
        .expect("effects")
        .iter()
        .filter_map(|e| e["id"].as_str())
        .collect();
    assert!(
        ids.contains(&"eccentricity") && ids.contains(&"reversal"),
        "{ids:?}"
    );
    // `capture --simulate` serves the same board on its own pty: the same table.
    let sim_out = dir.path().join("sim");
    let o = simulate_capture(&model, &sim_out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(sim_out.join("session.csv")).expect("simulated capture"),
        std::fs::read(out.join("session.csv")).expect("captured")
    );
    let hello: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("session.json")).expect("session.json"))
            .expect("JSON");
    assert_eq!(hello["hello"]["axis"], "B");
}

#[test]
fn a_rotary_plan_drives_the_board_and_a_bad_model_is_refused_by_key() {
    let dir = tempdir();
    let model = dir.path().join("rot.toml");
    std::fs::write(&model, MODEL).expect("model");
    let plan = dir.path().join("plan.toml");
    let o = plan_revolution("b", &["--targets", "9", "--runs", "3", "--out", s(&plan)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("cap");
    let o = serve_and_capture(&model, Some(&plan), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let session = read_rotary_session(&out.join("session.csv")).expect("rotary session");
    let targets: Vec<f64> = session.targets().iter().map(|t| t.1).collect();
    let text = std::fs::read_to_string(&plan).expect("plan");
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("targets_deg = ["))
        .expect("targets_deg");
    let planned: Vec<f64> = line
        .trim_end_matches(']')
        .split(',')
        .map(|v| v.trim().parse().expect("angle"))
        .collect();
    assert_eq!(
        targets, planned,
        "the MARKs carry the plan's angles to the µ°"
    );
    assert_eq!(session.rows.iter().map(|r| r.run).max(), Some(3));
    // A plan for another axis, an unknown effect, a missing parameter: exit 1, by key.
    let a_plan = dir.path().join("a.toml");
    std::fs::write(
        &a_plan,
        std::fs::read_to_string(&plan)
            .expect("plan")
            .replace("axis = \"B\"", "axis = \"A\""),
    )
    .expect("write");
    let cases = [
        (MODEL.to_string(), Some(&a_plan), "axis"),
        (
            MODEL.replace("\"reversal\"", "\"wobble\""),
            None,
            "rotary.effects[1].id",
        ),
        (
            MODEL.replace("b_arcsec = 3.0", ""),
            None,
            "rotary.effects[1].b_arcsec",
        ),
    ];
    for (i, (text, plan, key)) in cases.into_iter().enumerate() {
        let m = dir.path().join(format!("bad{i}.toml"));
        std::fs::write(&m, text).expect("model");
        let mut args = vec!["serve-sim", "--model", s(&m)];
        if let Some(p) = plan {
            args.extend(["--plan", s(p)]);
        }
        let o = errmap(&args);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains(key), "{key}: {}", stderr(&o));
    }
    // Fault injection is for the linear board.
    let o = errmap(&["serve-sim", "--model", s(&model), "--garbage", "0.1"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("fault injection"), "{}", stderr(&o));
}
