//! The acquisition path end to end, through the binary: the simulated board on a
//! pseudo-terminal → capture → session table → error table; replay identity; a capture
//! killed with SIGKILL loses nothing that was flushed; a vanishing port ends the capture
//! with a clear error and a valid session.

use crate::util::{bin, root};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use errmap::session::{error_table, read_session};
use errmap::sim::{MachineModel, PhysicsTruth};
use errmap::table::ErrorTable;

/// Starts serve-sim and returns it with the pty path it printed.
fn serve(plan: &Path, speed: f64, linger: f64) -> (Child, String) {
    let mut child = Command::new(bin())
        .args(["serve-sim", "--model"])
        .arg(root().join("datasets/sim/model.toml"))
        .arg("--plan")
        .arg(plan)
        .args([
            "--speed",
            &speed.to_string(),
            "--linger",
            &linger.to_string(),
            // A capture that ends early must not leave the device blocked for ever.
            "--stall-timeout",
            "10",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("serve-sim starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("serve-sim prints its path");
    (child, line.trim().to_string())
}

fn capture(port: &str, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(bin());
    c.args(["capture", "--port", port, "--out"])
        .arg(out)
        .args(extra);
    c
}

/// `errmap replay RAW --out OUT [extra…]`.
fn replay(raw: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(bin())
        .arg("replay")
        .arg(raw)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("replay runs")
}

fn truth() -> PhysicsTruth {
    let path = root().join("datasets/sim/model.toml");
    MachineModel::read(&path)
        .expect("model")
        .truth(&path, errmap::drivers::frame::Axis::X, 30.0)
        .expect("truth")
}

#[test]
fn simulated_device_to_error_table_matches_the_truth() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    // The capture ends 3 s after the last byte (a gap that long inside the stream would
    // need a badly overloaded machine), well before the device closes the port at 8 s.
    let (mut sim, port) = serve(&root().join("datasets/sim/plan.toml"), 20.0, 8.0);
    let o = capture(&port, &out, &["--idle-timeout", "3"])
        .output()
        .expect("capture runs");
    let _ = sim.wait();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = read_session(&out.join("session.csv")).expect("session table");
    let (expected, _) = errmap::sim::simulate_stream(
        &root().join("datasets/sim/model.toml"),
        Some(&root().join("datasets/sim/plan.toml")),
        &Default::default(),
    )
    .expect("same simulation in-process");
    assert_eq!(
        rows.len(),
        expected.truth.len(),
        "every simulated sample arrives"
    );
    let (table, summary) = error_table("session", &rows).expect("reduces");
    assert_eq!((summary.lines, summary.targets), (4, 5));
    let grid = table.grid().expect("a 5×2×2 grid");
    assert_eq!(grid.shape(), [5, 2, 2]);
    // The counters' origin is the first sample, at home (x = 0) on the first line
    // (y = 1, z = 200): every error is relative to the truth there, and to that one
    // sample's noise and quantisation, a constant offset common to all nodes.
    let t = truth();
    let home = t.map_um([0.0, 1.0, 200.0]);
    let resid: Vec<f64> = table
        .points
        .iter()
        .map(|p| p.e_um - (t.map_um(p.position()) - home))
        .collect();
    let offset = resid.iter().sum::<f64>() / resid.len() as f64;
    // One sample: 0.05 µm noise and ≤ 0.09 µm of quantisation.
    assert!(offset.abs() < 0.3, "origin offset {offset}");
    for (p, r) in table.points.iter().zip(&resid) {
        // 80 samples of 0.05 µm noise (σ_mean ≈ 0.006 µm) plus counter quantisation
        // (scale 0.1 µm, laser λ/8 ≈ 0.079 µm, dithered by the noise).
        assert!(
            (r - offset).abs() < 0.04,
            "{p:?}: residual {r}, offset {offset}"
        );
        assert!(p.n.is_some_and(|n| n >= 75));
    }
    // Replay gives exactly the rows capture wrote.
    let replayed = dir.path().join("replay.csv");
    let o = replay(&out.join("raw.bin"), &replayed, &["--json"]);
    assert!(o.status.success());
    assert_eq!(
        std::fs::read(&replayed).expect("replayed"),
        std::fs::read(out.join("session.csv")).expect("captured")
    );
    let stats: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(stats["rows"], expected.truth.len());
    assert_eq!(stats["frames"]["sample"], expected.truth.len());
    assert_eq!(stats["crc_failures"], 0);
    // The error table command writes the same table.
    let et = dir.path().join("errors.csv");
    let o = Command::new(bin())
        .arg("table")
        .arg(&out)
        .arg("--out")
        .arg(&et)
        .output()
        .expect("table runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(ErrorTable::read(&et).expect("reads").points.len(), 20);
}

#[test]
fn sigkill_mid_capture_loses_nothing_that_was_flushed() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    // Real time: the 21 s plan is still running when the capture is killed.
    let (mut sim, port) = serve(&root().join("datasets/sim/plan.toml"), 1.0, 0.0);
    let start = Instant::now();
    let mut cap = capture(&port, &out, &[])
        .stderr(Stdio::null())
        .spawn()
        .expect("capture starts");
    std::thread::sleep(Duration::from_millis(3500));
    cap.kill().expect("SIGKILL");
    let killed_after = start.elapsed().as_secs_f64();
    let _ = cap.wait();
    let _ = sim.kill();
    let _ = sim.wait();
    // The session table was written as rows came (flushed with every fsync): valid, and
    // the first rows of what replay rebuilds from the raw file.
    let live = read_session(&out.join("session.csv")).expect("the killed capture's table");
    let replayed = dir.path().join("replay.csv");
    let o = replay(&out.join("raw.bin"), &replayed, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = read_session(&replayed).expect("replayed table");
    assert!(live.len() <= rows.len());
    assert_eq!(live[..], rows[..live.len()]);
    // At 200 samples/s (plus the start-up lag of both processes, under 1 s here) the
    // raw file flushed at least every 0.5 s holds every sample up to ~1 s before the kill.
    let must_have = ((killed_after - 1.5) * 200.0) as usize;
    assert!(
        rows.len() >= must_have,
        "{} rows, expected ≥ {must_have}",
        rows.len()
    );
    // The table was flushed with the raw file, at most 0.5 s (100 samples) before it.
    assert!(
        live.len() + 100 >= must_have,
        "{} rows in the table, expected ≥ {must_have} − 100",
        live.len()
    );
    // And they are the device's first samples, with no hole.
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.sample, k as i64);
    }
}

#[test]
fn a_port_vanishing_inside_a_run_ends_the_capture_with_a_clear_error_and_a_valid_session() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    // Real time: the stream lasts ~28 s; the board is killed 2 s in, inside a run.
    let (mut sim, port) = serve(&root().join("datasets/sim/plan.toml"), 1.0, 1.0);
    let cap = capture(&port, &out, &["--no-view"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("capture runs");
    std::thread::sleep(Duration::from_secs(2));
    let _ = sim.kill();
    let _ = sim.wait();
    let o = cap.wait_with_output().expect("capture ends");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("vanished") && err.contains(&port), "{err}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("session.json")).expect("json"))
            .expect("valid JSON");
    assert_eq!(json["end"]["reason"], "vanished");
    let rows = read_session(&out.join("session.csv")).expect("valid session table");
    assert!(!rows.is_empty());
    // Replayable, and identical.
    let replayed = dir.path().join("replay.csv");
    let o = replay(&out.join("raw.bin"), &replayed, &[]);
    assert!(o.status.success());
    assert_eq!(
        std::fs::read(&replayed).expect("r"),
        std::fs::read(out.join("session.csv")).expect("c")
    );
}

/// The README's first capture: serve-sim and capture with their default flags. The board
/// closes the port after its last run ended: a complete capture, exit 0, every sample.
#[test]
fn the_board_closing_the_port_after_its_last_run_is_a_complete_capture() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    // serve-sim's default linger, 1 s.
    let (mut sim, port) = serve(&root().join("datasets/sim/plan.toml"), 20.0, 1.0);
    let o = capture(&port, &out, &[]).output().expect("capture runs");
    assert!(sim.wait().expect("serve-sim ends").success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("capture: complete"), "{err}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("session.json")).expect("json"))
            .expect("valid JSON");
    assert_eq!(json["end"]["reason"], "closed", "{json}");
    let (expected, _) = errmap::sim::simulate_stream(
        &root().join("datasets/sim/model.toml"),
        Some(&root().join("datasets/sim/plan.toml")),
        &Default::default(),
    )
    .expect("same simulation in-process");
    let rows = read_session(&out.join("session.csv")).expect("session table");
    assert_eq!(rows.len(), expected.truth.len(), "every sample arrives");
}

/// `capture --simulate` serves the board and captures it in one command.
#[test]
fn capture_simulate_serves_and_captures_in_one_command() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    let o = Command::new(bin())
        .args(["capture", "--simulate"])
        .arg(root().join("datasets/sim/model.toml"))
        .arg("--plan")
        .arg(root().join("datasets/sim/plan.toml"))
        .args(["--speed", "20", "--out"])
        .arg(&out)
        .output()
        .expect("capture runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let rows = read_session(&out.join("session.csv")).expect("session table");
    let (expected, _) = errmap::sim::simulate_stream(
        &root().join("datasets/sim/model.toml"),
        Some(&root().join("datasets/sim/plan.toml")),
        &Default::default(),
    )
    .expect("same simulation in-process");
    assert_eq!(rows.len(), expected.truth.len());
    // Neither or both of --port and --simulate is a usage error.
    let o = Command::new(bin())
        .args(["capture", "--out"])
        .arg(dir.path().join("x"))
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn replay_of_garbage_exits_1_and_of_a_damaged_capture_exits_0() {
    let dir = tempfile::tempdir().expect("tempdir");
    let junk = dir.path().join("junk.bin");
    std::fs::write(&junk, b"not a capture at all").expect("write");
    let o = replay(&junk, &dir.path().join("x.csv"), &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no valid frame"));
    let missing = replay(Path::new("/nonexistent/raw.bin"), Path::new("x.csv"), &[]);
    assert_eq!(missing.status.code(), Some(1));
    // A damaged capture: a simulated stream with bit flips and garbage.
    let mut truth = truth();
    let plan = errmap::drivers::sim::Plan {
        lines_mm: vec![[1.0, 200.0]],
        runs: 1,
        ..Default::default()
    };
    let faults = errmap::drivers::sim::Faults {
        bit_flip_prob: 0.05,
        garbage_prob: 0.05,
        seed: 3,
        ..Default::default()
    };
    let s = errmap::drivers::sim::simulate(&plan, &Default::default(), &faults, &mut truth)
        .expect("sim");
    let raw = dir.path().join("damaged.bin");
    std::fs::write(&raw, s.bytes()).expect("write");
    let o = replay(&raw, &dir.path().join("d.csv"), &["--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert!(v["crc_failures"].as_u64().expect("n") > 0);
    assert!(v["rows"].as_u64().expect("n") > 0);
    // Each key once: a JSON parser keeps the last of two equal keys without a word.
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.matches("\"rows\":").count(), 1, "{text}");
}

/// A device nobody reads gives up after its stall timeout with a clear message instead of
/// blocking for ever on a full pseudo-terminal.
#[test]
fn serve_sim_gives_up_when_no_host_reads() {
    let o = Command::new(bin())
        .args(["serve-sim", "--model"])
        .arg(root().join("datasets/sim/model.toml"))
        .arg("--plan")
        .arg(root().join("datasets/sim/plan.toml"))
        .args(["--speed", "100", "--linger", "0", "--stall-timeout", "1"])
        .output()
        .expect("serve-sim runs");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no host read the port for 1 s"), "{err}");
}
