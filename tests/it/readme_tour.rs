//! The README's tour, run the way a new user runs it: every `sh` block of the section
//! "A tour", in order, in one shell that stops at the first failing command, from a
//! folder laid out as the repository's top (`datasets/` beside the tour's scratch folder).
//!
//! Every line runs as written but one that says `# needs the board` (no serial hardware
//! here). The set-up line puts `target/release` on the `PATH`; in the test's folder that
//! holds a link to the `errmap` this build made, so the tour runs the code under test,
//! never a stale release build. The numbers the README quotes from the tour are compared
//! with what the tour's own commands print.

use std::process::Command;

use crate::util::{bin, root};

/// The shell lines of the tour's `sh` blocks, continuation lines joined.
fn tour_commands(readme: &str) -> Vec<String> {
    let start = readme.find("\n## A tour").expect("the README has a tour");
    let rest = &readme[start + 1..];
    let end = rest[3..].find("\n## ").map_or(rest.len(), |e| e + 3);
    let tour = &rest[..end];
    let mut commands = Vec::new();
    let mut in_block = false;
    let mut pending = String::new();
    for line in tour.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block && line.trim() == "```sh";
            continue;
        }
        if !in_block {
            continue;
        }
        if let Some(head) = line.strip_suffix('\\') {
            pending.push_str(head);
            continue;
        }
        pending.push_str(line);
        let command = std::mem::take(&mut pending);
        if !command.trim().is_empty() {
            commands.push(command);
        }
    }
    commands
}

fn runs_as_written(command: &str) -> bool {
    !command.contains("# needs the board")
}

#[test]
fn the_readmes_tour_parses_into_its_commands() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let commands = tour_commands(&readme);
    assert!(commands.len() >= 25, "{commands:#?}");
    assert!(commands.iter().any(|c| c.contains("# needs the board")));
    // Every command is errmap's, or the scratch folder's set-up.
    for c in commands.iter().filter(|c| runs_as_written(c)) {
        let c = c.trim_start();
        assert!(
            c.starts_with("errmap ")
                || c.starts_with("mkdir -p tour && cd tour")
                || c.starts_with("export PATH=\"$PWD/target/release:$PATH\""),
            "a tour line a user could not run as errmap: {c}"
        );
    }
}

#[test]
fn the_readmes_tour_runs_as_written() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let script: String = tour_commands(&readme)
        .into_iter()
        .filter(|c| runs_as_written(c))
        .map(|c| c + "\n")
        .collect();
    let dir = tempfile::tempdir().expect("tempdir");
    std::os::unix::fs::symlink(root().join("datasets"), dir.path().join("datasets"))
        .expect("datasets beside the scratch folder");
    // What the demo's release build leaves: target/release/errmap (here, this build's).
    let release = dir.path().join("target/release");
    std::fs::create_dir_all(&release).expect("target/release");
    std::os::unix::fs::symlink(bin(), release.join("errmap")).expect("errmap in target/release");
    let o = Command::new("bash")
        .args(["-e", "-o", "pipefail", "-x", "-c", &script])
        .current_dir(dir.path())
        .output()
        .expect("bash runs");
    let err = String::from_utf8_lossy(&o.stderr);
    let tail: String = err
        .lines()
        .rev()
        .take(25)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        o.status.success(),
        "the tour stopped (the last line with + is the failing command):\n{tail}"
    );
    let tour = dir.path().join("tour");
    for made in [
        "x-axis/session.csv",
        "certificate.pdf",
        "plan.ngc",
        "table2/report.md",
        "diag/updated-model.toml",
        "model.json",
        "x_cec.mpf",
        "ALX.new",
        "iso10360/report.md",
        "circular/report.md",
        "lab.sqlite",
        "history/report.md",
    ] {
        assert!(tour.join(made).exists(), "the tour made no {made}");
    }
    // The numbers section 4 quotes are the ones its command gives.
    let stdout = String::from_utf8_lossy(&o.stdout);
    let diagnosis = stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|v| v["verdict"].is_string() && v["rms_before_um"].is_number())
        .expect("section 4's diagnose --json document");
    let effect = &diagnosis["effects"][0];
    let quoted = format!(
        "b = {:.3} ± {:.3} µm), and the residual drops from {:.3} to {:.3} µm RMS",
        effect["params"]["b_um"].as_f64().expect("b"),
        effect["uncertainty"]["b_um"].as_f64().expect("σ"),
        diagnosis["rms_before_um"].as_f64().expect("before"),
        diagnosis["rms_after_um"].as_f64().expect("after"),
    );
    let flat = readme.split_whitespace().collect::<Vec<_>>().join(" ");
    assert_eq!(effect["id"], "reversal");
    assert!(
        flat.contains(&quoted),
        "README section 4 should quote: {quoted}"
    );
}
