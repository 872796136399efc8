//! The live view in a real terminal: `capture` runs inside tmux, fed by the simulated
//! board (with bit flips, so the health counters move) on a pty; the screen read with
//! `capture-pane` shows the chart and the counters; `p` pauses the chart; a resized
//! terminal is drawn again; `q` stops the capture cleanly, and the
//! session table it wrote equals `replay` of its raw file. Skips (saying so) without tmux;
//! `.ci/run` installs it.

use crate::util::{bin, root};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A tmux server of this test's own (its own socket), killed on drop.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn cmd(&self) -> Command {
        let mut c = Command::new("tmux");
        c.args(["-L", &self.socket]);
        c
    }

    fn screen(&self) -> String {
        let o = self
            .cmd()
            .args(["capture-pane", "-p", "-t", "view"])
            .output()
            .expect("tmux capture-pane");
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// Polls the screen until `ok` holds (returns that screen) or `secs` pass (panics with
    /// the last screen).
    fn wait_for(&self, secs: u64, what: &str, ok: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let s = self.screen();
            if ok(&s) {
                return s;
            }
            assert!(
                start.elapsed() < Duration::from_secs(secs),
                "no {what} after {secs} s; the screen:\n{s}"
            );
            std::thread::sleep(Duration::from_millis(250));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = self.cmd().arg("kill-server").status();
    }
}

fn quoted(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', r"'\''"))
}

/// The count on the health line `label` ("CRC failures   12").
fn count(screen: &str, label: &str) -> Option<u64> {
    let l = screen.lines().find(|l| l.contains(label))?;
    let rest = &l[l.find(label)? + label.len()..];
    rest.split_whitespace().next()?.parse().ok()
}

#[test]
fn capture_in_a_terminal_shows_the_live_view_and_q_writes_the_session() {
    if Command::new("tmux").arg("-V").output().is_err() {
        eprintln!("SKIPPED: tmux is not installed (.ci/run installs it)");
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session");
    // 4× real time: the 28 s plan takes ~7 s; the device then stays on the line, so only
    // `q` ends the capture.
    let mut sim = Command::new(bin())
        .args(["serve-sim", "--model"])
        .arg(root().join("datasets/sim/model.toml"))
        .arg("--plan")
        .arg(root().join("datasets/sim/plan.toml"))
        .args(["--speed", "4", "--linger", "60", "--stall-timeout", "20"])
        .args(["--bit-flips", "0.003", "--fault-seed", "3"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("serve-sim starts");
    let mut port = String::new();
    BufReader::new(sim.stdout.take().expect("stdout"))
        .read_line(&mut port)
        .expect("serve-sim prints its path");
    let tmux = Tmux {
        socket: format!("errmap-it-view-{}", std::process::id()),
    };
    let script = format!(
        "{} capture --port {} --out {}; echo EXIT=$?; sleep 120",
        quoted(Path::new(bin())),
        port.trim(),
        quoted(&out)
    );
    let started = tmux
        .cmd()
        .args(["new-session", "-d", "-s", "view", "-x", "120", "-y", "36"])
        .arg(script)
        .status()
        .expect("tmux runs");
    assert!(started.success());
    // The chart with both directions of a run, and a CRC failure counted.
    let screen = tmux.wait_for(40, "chart and counters", |s| {
        s.contains("run 2 −")
            && s.contains("Decoder health")
            && count(s, "CRC failures").is_some_and(|n| n > 0)
            && s.chars()
                .filter(|c| ('\u{2801}'..='\u{28ff}').contains(c))
                .count()
                > 30
    });
    for what in [
        "Readings",
        "│position",
        "│laser",
        "│n air",
        "error µm against position mm",
        "run 1 +",
        "resyncs",
        "seq gaps",
        "beam low",
        "q stop",
    ] {
        assert!(screen.contains(what), "{what} missing:\n{screen}");
    }
    let crc_on_screen = count(&screen, "CRC failures").unwrap_or(0);
    // `p` pauses the chart, and says so.
    tmux.cmd()
        .args(["send-keys", "-t", "view", "p"])
        .status()
        .expect("send-keys");
    tmux.wait_for(10, "the paused chart", |s| s.contains("PAUSED"));
    // A terminal shrunk to almost nothing and grown again: the view draws on, the capture
    // loses nothing (checked below against replay).
    for (w, h) in [("30", "8"), ("130", "40")] {
        tmux.cmd()
            .args(["resize-window", "-t", "view", "-x", w, "-y", h])
            .status()
            .expect("resize-window");
        std::thread::sleep(Duration::from_millis(400));
    }
    tmux.wait_for(10, "the view after the resizes", |s| {
        s.contains("Decoder health") && s.lines().count() >= 36
    });
    tmux.cmd()
        .args(["send-keys", "-t", "view", "q"])
        .status()
        .expect("send-keys");
    let end = tmux.wait_for(20, "the capture's exit", |s| s.contains("EXIT="));
    let _ = sim.kill();
    let _ = sim.wait();
    assert!(end.contains("EXIT=0"), "{end}");
    // The view left the terminal as it found it: the plain summary is printed there.
    assert!(end.contains("capture: session in"), "{end}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("session.json")).expect("session.json"))
            .expect("JSON");
    assert_eq!(json["end"]["reason"], "stopped", "{json}");
    let crc_total = json["decoder"]["crc_failures"].as_u64().expect("count");
    assert!(crc_on_screen <= crc_total && crc_total > 0);
    // The session written live equals replay of its raw file, byte for byte.
    let replayed = dir.path().join("replayed.csv");
    let o = Command::new(bin())
        .arg("replay")
        .arg(out.join("raw.bin"))
        .arg("--out")
        .arg(&replayed)
        .output()
        .expect("replay runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let live = std::fs::read(out.join("session.csv")).expect("session table");
    assert!(live.len() > 10_000, "{} bytes", live.len());
    assert_eq!(live, std::fs::read(&replayed).expect("replayed table"));
}
