//! Regression tests of issue 17 (robustness): each test pins one defect the black-box
//! campaign found — a panic, a hang, a NaN that reached an output, a silently accepted
//! mistake or an input destroyed by an output — and asserts the fixed behaviour.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_errmap")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn dataset(name: &str) -> String {
    root().join("datasets").join(name).display().to_string()
}

fn errmap(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(root())
        .output()
        .expect("runs errmap")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Waits for `child` at most `limit`; kills it and fails the test when it takes longer.
fn wait_within(mut child: Child, limit: Duration, what: &str) -> Output {
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Asserts the run ended with a message and exit 1, no panic, and the message holds
/// every one of `words`.
fn assert_refused(o: &Output, words: &[&str]) {
    let e = stderr(o);
    assert!(!e.contains("panicked"), "panic: {e}");
    assert_eq!(o.status.code(), Some(1), "exit 1 expected: {e}");
    for w in words {
        assert!(e.contains(w), "message lacks `{w}`: {e}");
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

// ---- clean exits on a closed or full stdout ----

/// Runs `args` with stdout a pipe whose reader is closed before the command writes.
fn with_closed_stdout(args: &[&str]) -> Output {
    let mut child = Command::new(bin())
        .args(args)
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    drop(child.stdout.take());
    wait_within(
        child,
        Duration::from_secs(120),
        "a command with closed stdout",
    )
}

#[test]
fn json_commands_exit_quietly_when_stdout_is_closed() {
    let dir = tempfile::tempdir().expect("tempdir");
    let report = dir.path().join("rep").display().to_string();
    let session = dir.path().join("e.csv").display().to_string();
    let cases: Vec<Vec<String>> = vec![
        vec![
            "fit".into(),
            dataset("table1.csv"),
            "--method".into(),
            "spline".into(),
            "--predict".into(),
            dataset("table2.csv"),
            "--json".into(),
        ],
        vec![
            "compare".into(),
            dataset("table1.csv"),
            "--test".into(),
            dataset("table2.csv"),
            "--methods".into(),
            "trilinear".into(),
            "--report".into(),
            report,
            "--json".into(),
        ],
        vec![
            "table".into(),
            dataset("physics/example-session.parquet"),
            "--out".into(),
            session,
            "--json".into(),
        ],
    ];
    for args in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = with_closed_stdout(&args);
        let e = stderr(&o);
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        assert!(
            !e.contains("errmap: error"),
            "{args:?}: quiet exit expected: {e}"
        );
        assert_eq!(o.status.code(), Some(141), "{args:?}: {e}");
    }
}

#[test]
fn a_full_stdout_is_an_error_naming_stdout() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return; // not a Linux-like system
    };
    let o = Command::new(bin())
        .args(["fit", &dataset("table1.csv"), "--method", "spline"])
        .args(["--predict", &dataset("table2.csv"), "--json"])
        .stdout(full)
        .output()
        .expect("runs");
    assert_refused(&o, &["stdout"]);
}

// ---- bounded work ----

#[test]
fn threads_beyond_the_cores_are_capped_with_a_warning() {
    let child = Command::new(bin())
        .args(["fit", &dataset("table1.csv"), "--method", "spline"])
        .args(["--predict", &dataset("table2.csv"), "--threads", "100000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let o = wait_within(child, Duration::from_secs(60), "fit --threads 100000");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("more than the"), "{}", stderr(&o));
}

#[test]
fn serve_sim_refuses_a_speed_that_would_overflow_a_duration() {
    let o = errmap(&[
        "serve-sim",
        "--model",
        &dataset("sim/model.toml"),
        "--speed",
        "1e-300",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

// ---- no output may be an input ----

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let t1 = dir.path().join("t1.csv");
    std::fs::copy(dataset("table1.csv"), &t1).expect("copy");
    let before = std::fs::read(&t1).expect("read");
    // The same file by another name: a hard link.
    let link = dir.path().join("link.csv");
    std::fs::hard_link(&t1, &link).expect("link");
    let t1s = t1.display().to_string();
    let links = link.display().to_string();
    let t2 = dataset("table2.csv");
    for args in [
        vec![
            "fit",
            &t1s,
            "--method",
            "trilinear",
            "--predict",
            &t2,
            "--out",
            &t1s,
        ],
        vec![
            "fit",
            &t1s,
            "--method",
            "trilinear",
            "--predict",
            &t2,
            "--out",
            &links,
        ],
        vec![
            "fit",
            &t2,
            "--method",
            "gp",
            "--predict",
            &t1s,
            "--out",
            &links,
        ],
        vec![
            "export", &t1s, "--method", "spline", "--format", "csv", "--step", "50", "--axis", "x",
            "--out", &links,
        ],
    ] {
        let o = errmap(&args);
        assert_refused(&o, &["--out", "is the input"]);
        assert_eq!(
            std::fs::read(&t1).expect("read"),
            before,
            "{args:?} changed the input"
        );
    }
    // A session replaced by its own error table.
    let session = write(dir.path(), "session.csv", &errmap_session_text());
    let bytes = std::fs::read(&session).expect("read");
    let ss = session.display().to_string();
    let o = errmap(&["table", &ss, "--out", &ss]);
    assert_refused(&o, &["--out", "SESSION"]);
    assert_eq!(std::fs::read(&session).expect("read"), bytes);
}

/// A small recorded session (the example session as CSV).
fn errmap_session_text() -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("s.csv");
    let rows =
        errmap::session::read_session(&root().join("datasets/physics/example-session.parquet"))
            .expect("example session");
    errmap::session::write_session(&csv, &rows).expect("write");
    std::fs::read_to_string(&csv).expect("read")
}

#[test]
fn table_with_a_report_path_that_is_a_file_writes_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let e = write(dir.path(), "e.csv", "SENTINEL\n");
    let rep = write(dir.path(), "rep", "");
    let o = errmap(&[
        "table",
        &dataset("physics/example-session.parquet"),
        "--out",
        &e.display().to_string(),
        "--report",
        &rep.display().to_string(),
    ]);
    assert_refused(&o, &["--report", "not a directory"]);
    assert_eq!(std::fs::read_to_string(&e).expect("read"), "SENTINEL\n");
}
