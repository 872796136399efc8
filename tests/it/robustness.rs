//! Regression tests of issue 17 (robustness): each test pins one defect the black-box
//! campaign found — a panic, a hang, a NaN that reached an output, a silently accepted
//! mistake or an input destroyed by an output — and asserts the fixed behaviour.

use crate::util::{self, bin, errmap, root, stderr};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn dataset(name: &str) -> String {
    util::dataset(name).display().to_string()
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

// ---- strict structure ----

#[test]
fn a_coordinate_written_minus_zero_is_zero() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grid = |zero: &str| {
        let mut t = String::from("x_mm,y_mm,z_mm,e_um\n");
        for (k, (x, y, z)) in [
            (0, 0, 0),
            (1, 0, 0),
            (0, 1, 0),
            (1, 1, 0),
            (0, 0, 1),
            (1, 0, 1),
            (0, 1, 1),
            (1, 1, 1),
        ]
        .into_iter()
        .enumerate()
        {
            // e = 1 + 2x + 3y + 4z: trilinear reproduces it exactly.
            let e = 1 + 2 * x + 3 * y + 4 * z;
            let xs = if x == 0 && k >= 6 {
                zero.to_string()
            } else {
                x.to_string()
            };
            t.push_str(&format!("{xs},{y},{z},{e}\n"));
        }
        t
    };
    let plain = write(dir.path(), "g.csv", &grid("0"));
    let negative = write(dir.path(), "n.csv", &grid("-0.000"));
    let point = write(dir.path(), "p.csv", "x_mm,y_mm,z_mm\n0.5,0.5,0.5\n");
    for table in [&plain, &negative] {
        let o = errmap(&[
            "fit",
            &table.display().to_string(),
            "--method",
            "trilinear",
            "--predict",
            &point.display().to_string(),
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        let e = v["predictions"][0]["e_um"].as_f64().expect("e_um");
        assert!((e - 5.5).abs() < 1e-12, "{e}");
    }
}

#[test]
fn a_column_given_twice_is_refused_naming_it_and_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let t = write(
        dir.path(),
        "dup.csv",
        "x_mm,y_mm,z_mm,e_um,e_um\n0,0,0,1,2\n1,0,0,1,2\n",
    );
    let o = errmap(&[
        "fit",
        &t.display().to_string(),
        "--method",
        "trilinear",
        "--predict",
        &dataset("table2.csv"),
    ]);
    assert_refused(&o, &["dup.csv", "`e_um` appears 2 times"]);
}

#[test]
fn session_rows_cut_short_or_repeated_are_refused_naming_the_rows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = errmap_session_text();
    let lines: Vec<&str> = text.lines().collect();
    // Cut mid-row: the last row loses its last fields.
    let last = lines[lines.len() - 1];
    let cut = last.rsplitn(4, ',').last().expect("fields");
    let truncated = lines[..lines.len() - 1].join("\n") + "\n" + cut + "\n";
    let t = write(dir.path(), "cut.csv", &truncated);
    let out = dir.path().join("e.csv").display().to_string();
    let o = errmap(&["table", &t.display().to_string(), "--out", &out]);
    let row = lines.len() - 1;
    assert_refused(
        &o,
        &[
            "cut.csv",
            &format!("row {row} (line {})", row + 1),
            "fields",
        ],
    );
    // Every row twice: the second copy of row 1 is named with row 1.
    let n = lines.len() - 1;
    let doubled = text.clone() + &lines[1..].join("\n") + "\n";
    let t = write(dir.path(), "dup.csv", &doubled);
    let o = errmap(&["table", &t.display().to_string(), "--out", &out]);
    assert_refused(
        &o,
        &[
            "dup.csv",
            &format!("row {} (line {})", n + 1, n + 2),
            "of row 1",
        ],
    );
    assert!(!Path::new(&out).exists(), "nothing written");
}

// ---- physical bounds at the door ----

#[test]
fn values_beyond_the_physical_ranges_are_refused_by_cell() {
    let dir = tempfile::tempdir().expect("tempdir");
    let t1 = std::fs::read_to_string(dataset("table1.csv")).expect("table 1");
    let mut lines: Vec<String> = t1.lines().map(str::to_string).collect();
    let first = lines[1].split_once(',').expect("x").1.to_string();
    lines[1] = format!("1e308,{first}");
    let far = write(dir.path(), "far.csv", &(lines.join("\n") + "\n"));
    let far_s = far.display().to_string();
    // Every method, the Gaussian process included (it panicked on this table).
    for method in ["gp", "gp-se", "spline"] {
        let o = errmap(&[
            "fit",
            &far_s,
            "--method",
            method,
            "--predict",
            &dataset("table2.csv"),
        ]);
        assert_refused(&o, &["far.csv", "row 1 (line 2)", "x_mm", "physical range"]);
    }
    let report = dir.path().join("c").display().to_string();
    let o = errmap(&[
        "compare",
        &far_s,
        "--test",
        &dataset("table2.csv"),
        "--report",
        &report,
    ]);
    assert_refused(&o, &["far.csv", "x_mm"]);
    // A prediction point far outside: refused, not a NaN in the output.
    let p = write(dir.path(), "p.csv", "x_mm,y_mm,z_mm\n1e308,1,200\n");
    let out = dir.path().join("o.csv");
    let o = errmap(&[
        "fit",
        &dataset("table1.csv"),
        "--method",
        "spline",
        "--predict",
        &p.display().to_string(),
        "--out",
        &out.display().to_string(),
    ]);
    assert_refused(&o, &["p.csv", "x_mm"]);
    assert!(!out.exists());
}

#[test]
fn impossible_session_values_are_refused_by_cell() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = errmap_session_text();
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    for (column, value) in [
        ("error_um", "1e308"),
        ("air_temp_c", "-273.15"),
        ("air_pressure_hpa", "5"),
    ] {
        let k = header.iter().position(|h| *h == column).expect("column");
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        // Data row 50, on line 51 (any row with air values).
        let mut f: Vec<String> = lines[50].split(',').map(str::to_string).collect();
        f[k] = value.into();
        lines[50] = f.join(",");
        let s = write(dir.path(), "s.csv", &(lines.join("\n") + "\n"));
        let out = dir.path().join("e.csv").display().to_string();
        let o = errmap(&["table", &s.display().to_string(), "--out", &out]);
        assert_refused(&o, &["s.csv", "row 50 (line 51)", column]);
    }
}

#[test]
fn odd_parquet_column_types_are_refused_by_name() {
    let o = errmap(&[
        "fit",
        &root()
            .join("tests/it/data/table-decimal.parquet")
            .display()
            .to_string(),
        "--method",
        "spline",
        "--predict",
        &dataset("table2.csv"),
    ]);
    assert_refused(&o, &["table-decimal.parquet", "x_mm", "Decimal"]);
    // A boolean e_um is not 0/1 µm.
    use polars::prelude::*;
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("b.parquet");
    let mut df = DataFrame::new(
        2,
        vec![
            Column::new("x_mm".into(), [0.0, 1.0]),
            Column::new("y_mm".into(), [0.0, 0.0]),
            Column::new("z_mm".into(), [0.0, 0.0]),
            Column::new("e_um".into(), [true, false]),
        ],
    )
    .expect("frame");
    ParquetWriter::new(std::fs::File::create(&p).expect("create"))
        .finish(&mut df)
        .expect("write");
    let o = errmap(&[
        "fit",
        &p.display().to_string(),
        "--method",
        "trilinear",
        "--predict",
        &dataset("table2.csv"),
    ]);
    assert_refused(&o, &["b.parquet", "e_um", "true/false"]);
}

#[test]
fn gp_refuses_more_nodes_than_its_limit_naming_the_alternative() {
    use errmap::interp::{GP_MAX_POINTS as MAX_POINTS, Gp, GpConfig, GpError};
    use errmap::table::ErrorPoint;
    let n = MAX_POINTS + 1;
    let points: Vec<ErrorPoint> = (0..n)
        .map(|i| ErrorPoint::new(i as f64, (i % 7) as f64, 0.0, 0.0))
        .collect();
    let e = Gp::fit(&points, &GpConfig::default()).expect_err("refused");
    assert_eq!(
        e,
        GpError::TooManyPoints {
            got: n,
            max: MAX_POINTS
        }
    );
    assert!(e.to_string().contains("spline"), "{e}");
    // Two nodes a denormal apart no longer panic: they fit.
    let tiny = [
        ErrorPoint::new(0.0, 0.0, 0.0, 1.0),
        ErrorPoint::new(5e-324, 1.0, 0.0, 2.0),
        ErrorPoint::new(1.0, 0.0, 0.0, 3.0),
        ErrorPoint::new(1.0, 1.0, 0.0, 4.0),
    ];
    let config = GpConfig {
        restarts: 1,
        ..GpConfig::default()
    };
    let gp = Gp::fit(&tiny, &config).expect("fits");
    use errmap::interp::Interpolator;
    assert!(gp.predict([0.5, 0.5, 0.0]).is_finite());
}

// ---- machine models and plans: finite, in range, bounded work ----

const TINY_PLAN: &str = "axis = \"X\"\nlines_mm = [[1.0, 200.0]]\ntargets_mm = [200.0, 400.0]\n\
runs = 2\nfeed_mm_s = 1000.0\ndwell_s = 0.05\nsample_hz = 100.0\nsettle_s = 0.0\naccel_mm_s2 = 10000.0\n";

/// `simulate` with the model text and plan text given, run under a time limit.
fn simulate(dir: &Path, model: &str, plan: &str) -> Output {
    let m = write(dir, "m.toml", model);
    let p = write(dir, "p.toml", plan);
    let child = Command::new(bin())
        .args(["simulate", "--model"])
        .arg(&m)
        .arg("--plan")
        .arg(&p)
        .arg("--out")
        .arg(dir.join("s.csv"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    wait_within(child, Duration::from_secs(60), "simulate")
}

#[test]
fn non_finite_or_impossible_model_values_are_refused_by_key() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (model, key) in [
        ("[scale_factor]\nppm = nan\n", "scale_factor.ppm"),
        (
            "[abbe]\noffset_axis = \"y\"\ntheta0_urad = inf\n",
            "abbe.theta0_urad",
        ),
        (
            "[environment]\nair_temp_c = { kind = \"constant\", value = nan }\n",
            "environment.air_temp_c.value",
        ),
        (
            "[environment]\nair_temp_c = { kind = \"constant\", value = -273.15 }\n",
            "environment.air_temp_c.value",
        ),
        (
            "[thermal_drift]\namplitude_um = 1.0\ntau_s = inf\n",
            "thermal_drift.tau_s",
        ),
        (
            "[environment]\nair_pressure_hpa = { kind = \"table\", t_s = [0.0, 5.0, 5.0], value = [1013.0, 1012.0, 1011.0] }\n",
            "strictly increasing",
        ),
    ] {
        let o = simulate(dir.path(), model, TINY_PLAN);
        assert_refused(&o, &["m.toml", key]);
        assert!(
            !dir.path().join("s.csv").exists(),
            "{model}: nothing written"
        );
    }
}

#[test]
fn plans_implying_too_much_work_or_bad_values_are_refused_by_key() {
    let dir = tempfile::tempdir().expect("tempdir");
    let plan = |key: &str, value: &str| {
        TINY_PLAN
            .lines()
            .map(|l| {
                if l.starts_with(&format!("{key} =")) {
                    format!("{key} = {value}")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    let targets: Vec<String> = (0..20_000).map(|i| format!("{}.0", i * 10)).collect();
    for (p, key) in [
        (plan("dwell_s", "1e9"), "dwell_s"),
        (plan("dwell_s", "1e7"), "samples"),
        (plan("feed_mm_s", "1e-9"), "feed_mm_s"),
        (plan("sample_hz", "inf"), "sample_hz"),
        (plan("sample_hz", "5e-324"), "sample_hz"),
        (plan("accel_mm_s2", "inf"), "accel_mm_s2"),
        (plan("settle_s", "-1.0"), "settle_s"),
        (
            plan("targets_mm", &format!("[{}]", targets.join(", ")))
                .replace("dwell_s = 0.05", "dwell_s = 0.5"),
            "samples",
        ),
    ] {
        let o = simulate(dir.path(), "", &p);
        assert_refused(&o, &["p.toml", key]);
    }
    // The tiny plan itself simulates.
    let o = simulate(dir.path(), "", TINY_PLAN);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_scattered_table_is_not_expanded_to_its_n_cubed_grid() {
    use errmap::table::{ErrorPoint, ErrorTable, TableError};
    // 3 000 scattered nodes span 2.7·10¹⁰ grid nodes (216 GB of f64): the grid check
    // used to allocate them and abort. Now it names the first missing node at once.
    let points: Vec<ErrorPoint> = (0..3000)
        .map(|i| {
            let f = f64::from(i);
            ErrorPoint::new(f, (f * 7.0) % 3001.0, (f * 13.0) % 3001.0, 0.0)
        })
        .collect();
    let start = Instant::now();
    let e = ErrorTable::from_points("scattered", points)
        .grid()
        .expect_err("not a grid");
    assert!(
        matches!(
            e,
            TableError::MissingNode {
                present: 3000,
                expected: 27_000_000_000,
                ..
            }
        ),
        "{e}"
    );
    assert!(start.elapsed() < Duration::from_secs(10));
}

#[test]
fn grid_nodes_a_denormal_apart_are_refused_and_the_gp_fits_them() {
    use errmap::interp::Interpolator;
    use errmap::interp::{Gp, GpConfig};
    use errmap::table::{ErrorPoint, ErrorTable, TableError};
    let mut points = Vec::new();
    for (x, y, z) in [
        (0.0, 0.0, 0.0),
        (5e-324, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (5e-324, 1.0, 0.0),
    ] {
        points.push(ErrorPoint::new(x, y, z, y));
    }
    let e = ErrorTable::from_points("tiny", points.clone())
        .grid()
        .expect_err("too close");
    assert!(
        matches!(e, TableError::NodesTooClose { axis: 'x', .. }),
        "{e}"
    );
    // The Gaussian process treats an axis spanning 5e-324 mm as one coordinate.
    let config = GpConfig {
        restarts: 1,
        ..GpConfig::default()
    };
    let gp = Gp::fit(&points[..3], &config).expect("fits");
    let e = gp.predict([0.0, 0.5, 0.0]);
    assert!(e.is_finite(), "{e}");
}

// ---- no sample lost silently ----

#[test]
fn replay_without_a_hello_says_so_and_converts_with_an_earlier_description() {
    let dir = tempfile::tempdir().expect("tempdir");
    let stream = errmap::sim::simulate_stream(
        &root().join("datasets/sim/model.toml"),
        Some(&root().join("datasets/sim/plan.toml")),
        &errmap::drivers::sim::Faults::default(),
    )
    .expect("simulates")
    .0;
    let whole = write_bytes(dir.path(), "ok.bin", &stream.bytes());
    let headless: Vec<u8> = stream.frames[1..]
        .iter()
        .flat_map(|f| f.bytes.clone())
        .collect();
    let headless = write_bytes(dir.path(), "no-hello.bin", &headless);
    let path = |p: &Path| p.display().to_string();
    let ok_csv = dir.path().join("ok.csv");
    let o = errmap(&["replay", &path(&whole), "--out", &path(&ok_csv)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Without a HELLO: a damaged capture (exit 0 per docs/cli.md), but never silent:
    // the samples are counted as unconverted and a warning says what to do.
    let out = dir.path().join("b.csv");
    let o = errmap(&["replay", &path(&headless), "--out", &path(&out), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("WARNING")
            && err.contains("could not be converted")
            && err.contains("--hello-from"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["rows"], 0, "{v}");
    assert!(
        v["unconverted_samples"].as_u64().expect("counted") > 100,
        "{v}"
    );
    // With the device description of an earlier session: the very same rows.
    let json = serde_json::json!({
        "hello": errmap::acquire::HelloJson::from(&stream.hello),
    });
    let session_json = write(dir.path(), "session.json", &json.to_string());
    let o = errmap(&[
        "replay",
        &path(&headless),
        "--out",
        &path(&out),
        "--hello-from",
        &path(&session_json),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!(v.get("unconverted_samples").is_none(), "{v}");
    let a = errmap::session::read_session(&ok_csv).expect("intact");
    let b = errmap::session::read_session(&out).expect("converted");
    assert_eq!(a.len(), b.len());
    assert!(a.len() > 100);
    assert_eq!(a, b);
}

fn write_bytes(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write");
    p
}

// ---- bad flag values are usage errors (exit 2) ----

#[test]
fn out_of_range_flag_values_exit_2_before_any_work() {
    let t1 = dataset("table1.csv");
    let t2 = dataset("table2.csv");
    let model = dataset("sim/model.toml");
    let export = |flag: &str, value: &str| -> Vec<String> {
        let mut v: Vec<String> = [
            "export",
            &t1,
            "--method",
            "spline",
            "--format",
            "csv",
            "--axis",
            "x",
            "--out",
            "/nonexistent/x.csv",
            "--step",
            "50",
        ]
        .map(String::from)
        .to_vec();
        v.push(flag.into());
        v.push(value.into());
        v
    };
    let cases: Vec<Vec<String>> = vec![
        export("--step", "0"),
        export("--step", "nan"),
        export("--step", "-1"),
        export("--max-points", "0"),
        export("--fuzzy-sigma", "0"),
        [
            "fit",
            &t1,
            "--method",
            "fuzzy",
            "--predict",
            &t2,
            "--fuzzy-sigma",
            "inf",
        ]
        .map(String::from)
        .to_vec(),
        ["serve-sim", "--model", &model, "--garbage", "2"]
            .map(String::from)
            .to_vec(),
        ["serve-sim", "--model", &model, "--beam-loss", "5:1"]
            .map(String::from)
            .to_vec(),
        ["serve-sim", "--model", &model, "--beam-loss", "nan:inf"]
            .map(String::from)
            .to_vec(),
        [
            "capture",
            "--port",
            "/nonexistent",
            "--out",
            "/nonexistent/c",
            "--baud",
            "0",
        ]
        .map(String::from)
        .to_vec(),
        [
            "diagnose",
            "--recorded",
            "r.csv",
            "--model",
            "m.toml",
            "--report",
            "/nonexistent/r",
            "--grating-period-um",
            "0",
        ]
        .map(String::from)
        .to_vec(),
    ];
    for args in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = errmap(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn order_auto_refuses_grids_beyond_its_bound_at_once() {
    use errmap::evaluate::{AUTO_ORDER_MAX_NODES, auto_order};
    use errmap::interp::InterpError;
    use errmap::table::{ErrorPoint, ErrorTable};
    let mut points = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            for k in 0..40 {
                points.push(ErrorPoint::new(
                    f64::from(i),
                    f64::from(j),
                    f64::from(k),
                    0.0,
                ));
            }
        }
    }
    let grid = ErrorTable::from_points("40³", points).grid().expect("grid");
    let start = Instant::now();
    let e = auto_order(&grid, 4).expect_err("refused");
    assert!(
        matches!(e, InterpError::TooLargeForAuto { nodes: 64_000, max } if max == AUTO_ORDER_MAX_NODES),
        "{e}"
    );
    assert!(
        e.to_string()
            .ends_with("give the degrees (the Lagrange order MxNxQ)"),
        "{e}"
    );
    assert!(start.elapsed() < Duration::from_secs(5));
}

// ---- properties: whatever the input, an answer or a typed error, never a panic ----

mod never_panics {
    use std::path::Path;

    use errmap::interp::Method;
    use errmap::table::ErrorTable;
    use proptest::prelude::*;

    use super::{dataset, root};

    /// Values that broke readers in the campaign, and ordinary ones.
    const SPECIAL: [&str; 16] = [
        "nan", "inf", "-inf", "1e308", "-1e308", "1e309", "5e-324", "-0", "-0.000", "", "abc",
        "0x10", "1,5", "0", "12.5", "-3",
    ];

    /// `text` with the cell at (row, column) of its CSV body replaced by `value`.
    fn with_cell(text: &str, row: usize, column: usize, value: &str) -> String {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let r = 1 + row % (lines.len() - 1);
        let mut cells: Vec<String> = lines[r].split(',').map(str::to_string).collect();
        let c = column % cells.len();
        cells[c] = value.to_string();
        lines[r] = cells.join(",");
        lines.join("\n") + "\n"
    }

    fn in_dir(name: &str, bytes: &[u8]) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).expect("write");
        (dir, p)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn a_damaged_error_table_fits_to_finite_values_or_is_refused(
            row in 0usize..64, column in 0usize..8, k in 0usize..SPECIAL.len()
        ) {
            let text = std::fs::read_to_string(dataset("table1.csv")).expect("table 1");
            let (_d, p) = in_dir("t.csv", with_cell(&text, row, column, SPECIAL[k]).as_bytes());
            if let Ok(t) = ErrorTable::read(&p)
                && let Ok(g) = t.grid()
                && let Ok(m) = Method::Spline.fit(&g)
            {
                for q in [[1.2424, 391.0, 129.3769], [200.0, 560.0, 600.0]] {
                    prop_assert!(m.predict(q).is_finite());
                }
            }
        }

        #[test]
        fn random_bytes_are_no_table_and_no_session(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let (_d, p) = in_dir("r.csv", &bytes);
            let _ = ErrorTable::read(&p);
            let _ = errmap::session::read_session(&p);
        }

        #[test]
        fn a_damaged_session_reads_to_valid_rows_or_is_refused(
            row in 0usize..200, column in 0usize..19, k in 0usize..SPECIAL.len()
        ) {
            static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
            let text = TEXT.get_or_init(super::errmap_session_text);
            let (_d, p) = in_dir("s.csv", with_cell(text, row, column, SPECIAL[k]).as_bytes());
            if let Ok(rows) = errmap::session::read_session(&p) {
                prop_assert!(rows.iter().all(|r| r.error_um.is_finite() && r.laser_mm.is_finite()));
                if let Ok((t, _)) = errmap::session::error_table("s", &rows) {
                    prop_assert!(t.points.iter().all(|q| q.e_um.is_finite()));
                }
            }
        }

        #[test]
        fn a_damaged_machine_model_is_refused_or_simulates_finite_rows(
            line in 0usize..200, k in 0usize..SPECIAL.len()
        ) {
            let path = root().join("datasets/physics/example-model.toml");
            let text = std::fs::read_to_string(&path).expect("model");
            // Replace the number of the chosen `key = number` line.
            let lines: Vec<&str> = text.lines().collect();
            let numeric: Vec<usize> = (0..lines.len())
                .filter(|&i| {
                    let l = lines[i];
                    !l.trim_start().starts_with('#')
                        && l.split_once('=').is_some_and(|(_, v)| {
                            v.split('#').next().is_some_and(|v| v.trim().parse::<f64>().is_ok())
                        })
                })
                .collect();
            let i = numeric[line % numeric.len()];
            let key = lines[i].split_once('=').expect("key").0;
            let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
            let v = if SPECIAL[k].is_empty() { "0" } else { SPECIAL[k] };
            out[i] = format!("{key}= {v}");
            let dir = tempfile::tempdir().expect("tempdir");
            // Beside a copy of the table it names, so the relative path still resolves.
            let model = dir.path().join("physics").join("m.toml");
            std::fs::create_dir_all(model.parent().expect("dir")).expect("mkdir");
            std::fs::copy(dataset("table1.csv"), dir.path().join("table1.csv")).expect("copy");
            std::fs::write(&model, out.join("\n")).expect("write");
            if let Ok(m) = errmap::sim::MachineModel::read(&model) {
                let plan = errmap::sim::read_plan(Some(Path::new(&dataset("sim/plan.toml"))))
                    .expect("plan");
                if let Ok(rows) = errmap::sim::simulate_session(&m, &model, &plan, false) {
                    // Finite, and physical: the example's effects are µm, not the metres a
                    // NaN turned into (`ppm = nan` gave laser_mm = 0 on every row).
                    prop_assert!(rows.iter().all(|r| r.error_um.is_finite()
                        && (r.scale_mm - r.laser_mm).abs() < 1.0));
                }
            }
        }
    }
}

/// `replay --out` writes beside the output and renames into place: a replay that fails
/// (here: bytes with no frame in them) leaves an existing table as it was and no partial
/// file; one that succeeds replaces it whole.
#[test]
fn a_failed_replay_leaves_the_old_table_and_no_partial_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("session.parquet");
    std::fs::write(&out, b"the table of yesterday").expect("write");
    let junk = dir.path().join("junk.bin");
    std::fs::write(&junk, vec![0x55u8; 4096]).expect("write");
    let o = errmap(&[
        "replay",
        junk.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        std::fs::read(&out).expect("read"),
        b"the table of yesterday"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // A good capture replaces it whole: the simulated device's bytes.
    let raw = dir.path().join("raw.bin");
    let o = errmap(&[
        "simulate",
        "--model",
        "datasets/sim/model.toml",
        "--plan",
        "datasets/sim/plan.toml",
        "--out",
        dir.path().join("sim.csv").to_str().expect("utf-8"),
        "--raw",
        raw.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = errmap(&[
        "replay",
        raw.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        errmap::session::read_session(&out)
            .expect("a whole table")
            .len()
            > 100
    );
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 4);
}
