//! Soak (issue 13): a compressed-time simulated session of 10⁶ samples through the
//! pseudo-terminal into `capture`, whose resident memory is sampled while it runs and must
//! stay flat; the session it writes equals `replay` of its raw file. About 20–40 s in a
//! debug build. The long version (10⁷ samples, hours of board time) is a command to run by
//! hand, see `soak_plan` and `docs/performance.md`.

use crate::util::bin;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A plan of `runs` runs on 4 lines × 5 targets with 5 s dwells at 200 Hz: 1 000 dwells
/// and ~10⁶ samples for 25 runs (≈ 5 300 s of board time).
pub(crate) fn soak_plan(runs: u32) -> String {
    format!(
        "axis = \"X\"\nlines_mm = [[1.0, 200.0], [400.0, 200.0], [1.0, 500.0], [400.0, 500.0]]\n\
         targets_mm = [0.0, 200.0, 400.0, 600.0, 800.0]\nruns = {runs}\nfeed_mm_s = 1000.0\n\
         dwell_s = 5.0\nsample_hz = 200.0\nsettle_s = 0.1\naccel_mm_s2 = 10000.0\n"
    )
}

fn rss_kb(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let l = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    l.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn a_million_sample_capture_through_the_pty_runs_in_flat_memory() {
    if !Path::new("/proc/self/status").exists() {
        return; // RSS sampling needs Linux's /proc
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let plan = dir.path().join("soak.toml");
    std::fs::write(&plan, soak_plan(25)).expect("plan");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut sim = Command::new(bin())
        .args(["serve-sim", "--model"])
        .arg(root.join("datasets/sim/model.toml"))
        .arg("--plan")
        .arg(&plan)
        .args(["--speed", "4000", "--linger", "0", "--stall-timeout", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("serve-sim starts");
    let mut port = String::new();
    BufReader::new(sim.stdout.take().expect("stdout"))
        .read_line(&mut port)
        .expect("serve-sim prints its path");
    let out = dir.path().join("session");
    let mut cap = Command::new(bin())
        .args([
            "capture",
            "--port",
            port.trim(),
            "--format",
            "parquet",
            "--out",
        ])
        .arg(&out)
        // Generous: on a loaded machine the device can pause for seconds between bursts,
        // and a 2 s timeout ended the capture early (seen twice with other builds running).
        .args(["--idle-timeout", "10"])
        .stderr(Stdio::null())
        .spawn()
        .expect("capture starts");
    let start = Instant::now();
    let mut samples: Vec<(f64, u64)> = Vec::new();
    while cap.try_wait().expect("wait").is_none() {
        if let Some(kb) = rss_kb(cap.id()) {
            samples.push((start.elapsed().as_secs_f64(), kb));
        }
        assert!(start.elapsed() < Duration::from_secs(600), "capture hangs");
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = sim.wait();
    let raw = std::fs::metadata(out.join("raw.bin")).expect("raw").len();
    assert!(raw > 28_000_000, "{raw} bytes captured");
    // Flat: the second half of the capture never rises 25 MB above the first half's peak
    // (holding the rows would add 168 B × 5·10⁵ rows ≈ 84 MB).
    let n = samples.len();
    assert!(n >= 10, "{n} RSS samples");
    let first = samples[..n / 2].iter().map(|s| s.1).max().unwrap_or(0);
    let second = samples[n / 2..].iter().map(|s| s.1).max().unwrap_or(0);
    assert!(
        second < first + 25_000,
        "RSS rose from {first} kB to {second} kB: {samples:?}"
    );
    let replayed = dir.path().join("replay.parquet");
    let o = Command::new(bin())
        .arg("replay")
        .arg(out.join("raw.bin"))
        .arg("--out")
        .arg(&replayed)
        .arg("--json")
        .output()
        .expect("replay");
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!(v["rows"].as_u64().expect("rows") >= 1_000_000, "{v}");
    assert!(
        std::fs::read(out.join("session.parquet")).expect("s")
            == std::fs::read(&replayed).expect("r"),
        "capture and replay differ"
    );
}
