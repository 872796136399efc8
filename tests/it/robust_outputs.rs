//! Issue 28 (robustness, second round): outputs that are not regular files, a closed
//! stderr, signals, bounds on counts and integers, Parquet columns of any type, and the
//! exit codes of `plan`. Each test pins one defect of the issue; device nodes, FIFOs and
//! links are made in a temporary directory (never the machine's `/dev`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::util::{bin, errmap_in as errmap, root, stderr};

fn dataset(name: &str) -> String {
    root().join("datasets").join(name).display().to_string()
}

fn code(o: &Output) -> Option<i32> {
    o.status.code()
}

const PLAN: [&str; 9] = [
    "plan",
    "--axis",
    "x",
    "--from",
    "0",
    "--to",
    "100",
    "--targets",
    "5",
];

fn plan_to(dir: &Path, out: &str) -> Output {
    let mut args = PLAN.to_vec();
    args.extend(["--out", out]);
    errmap(dir, &args)
}

/// A private character device node `name` (major 1, `minor`: 3 null, 7 full), or `None`
/// with a message when this process may not make one (not root).
#[cfg(unix)]
fn device(dir: &Path, name: &str, minor: u32) -> Option<PathBuf> {
    let p = dir.join(name);
    let ok = Command::new("mknod")
        .arg(&p)
        .args(["c", "1", &minor.to_string()])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("skipped: cannot mknod here (not root)");
    }
    ok.then_some(p)
}

#[cfg(unix)]
fn is_char_device(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_char_device())
}

// ---- outputs that are not regular files ----

/// Issue 28, item 1: run as root, `--out /dev/null` and `--out /dev/full` replaced the
/// machine's devices by regular files. Devices are written through and stay devices; a
/// full one is an error naming it (exit 1); a link to one is followed and kept.
#[cfg(unix)]
#[test]
fn devices_are_written_through_and_stay_devices() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let (Some(null), Some(full)) = (device(d, "null", 3), device(d, "full", 7)) else {
        return;
    };
    let o = plan_to(d, "null");
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert!(is_char_device(&null), "the null device is still one");
    let o = plan_to(d, "full");
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("full"), "{}", stderr(&o));
    assert!(is_char_device(&full), "the full device is still one");
    // A table written through a link with the extension the writer needs.
    std::os::unix::fs::symlink(&null, d.join("errors.csv")).expect("symlink");
    let session = d.join("s.csv");
    simulate_session(&session);
    let o = errmap(
        d,
        &[
            "table",
            &session.display().to_string(),
            "--out",
            "errors.csv",
        ],
    );
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert!(
        std::fs::symlink_metadata(d.join("errors.csv"))
            .expect("ok")
            .is_symlink()
    );
    assert!(is_char_device(&null));
    let temporaries: Vec<_> = names(d)
        .into_iter()
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(temporaries.is_empty(), "{temporaries:?}");
}

fn names(d: &Path) -> Vec<String> {
    std::fs::read_dir(d)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect()
}

fn simulate_session(out: &Path) {
    let plan = std::fs::read_to_string(root().join("datasets/sim/plan.toml"))
        .expect("plan")
        .replace("runs = 2", "runs = 1");
    let dir = out.parent().expect("parent");
    std::fs::write(dir.join("plan.toml"), plan).expect("write");
    let model = std::fs::read_to_string(root().join("datasets/sim/model.toml")).expect("model");
    let abs = root().join("datasets/sim");
    let model: String = model
        .lines()
        .map(|l| match l.trim_start().strip_prefix("table = \"") {
            Some(rest) => format!(
                "table = \"{}\"",
                abs.join(rest.split('"').next().unwrap_or("")).display()
            ),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.join("model.toml"), model + "\n").expect("write");
    let o = errmap(
        dir,
        &[
            "simulate",
            "--model",
            "model.toml",
            "--plan",
            "plan.toml",
            "--out",
            &out.display().to_string(),
        ],
    );
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
}

/// A FIFO is written through to its reader and stays a FIFO; `/dev/stdout` (a link into
/// `/proc`) reaches stdout.
#[cfg(unix)]
#[test]
fn a_fifo_and_dev_stdout_receive_the_output() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let fifo = d.join("plan.pipe");
    if !Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        eprintln!("skipped: no mkfifo");
        return;
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(&fifo).expect("read the fifo"))
    };
    let o = plan_to(d, "plan.pipe");
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    let got = reader.join().expect("reader");
    assert!(got.contains("targets_mm"), "the plan came through: {got}");
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::symlink_metadata(&fifo)
            .expect("there")
            .file_type()
            .is_fifo()
    );
    let o = plan_to(d, "/dev/stdout");
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("targets_mm"), "the plan on stdout: {out}");
}

/// Issue 28: `table … --out /dev/null` was refused for want of an extension. A device or
/// pipe without one gets the CSV text; a new regular file without one is still refused
/// (a file should say what it holds), naming the extensions.
#[cfg(unix)]
#[test]
fn an_extensionless_device_or_pipe_gets_the_table_as_csv() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let session = d.join("s.csv");
    simulate_session(&session);
    let s = session.display().to_string();
    if let Some(null) = device(d, "null", 3) {
        let o = errmap(d, &["table", &s, "--out", "null"]);
        assert_eq!(code(&o), Some(0), "{}", stderr(&o));
        assert!(is_char_device(&null), "the null device is still one");
    }
    let fifo = d.join("errors");
    if Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|st| st.success())
    {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(&fifo).expect("read the fifo"))
        };
        let o = errmap(d, &["table", &s, "--out", "errors"]);
        assert_eq!(code(&o), Some(0), "{}", stderr(&o));
        let got = reader.join().expect("reader");
        let header = got.lines().next().unwrap_or("");
        assert!(
            header.contains("e_um"),
            "a CSV table came through: {header}"
        );
    } else {
        eprintln!("skipped the FIFO half: no mkfifo");
    }
    let o = errmap(d, &["table", &s, "--out", "plain"]);
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(".csv or .parquet"), "{}", stderr(&o));
    assert!(!d.join("plain").exists());
}

/// A link to a regular file stays a link; the file it names gets the output.
#[cfg(unix)]
#[test]
fn a_link_to_a_file_is_followed_and_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    std::fs::create_dir(d.join("plans")).expect("mkdir");
    std::fs::write(d.join("plans/x.toml"), "old").expect("write");
    std::os::unix::fs::symlink("plans/x.toml", d.join("latest.toml")).expect("symlink");
    let o = plan_to(d, "latest.toml");
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert!(
        std::fs::symlink_metadata(d.join("latest.toml"))
            .expect("ok")
            .is_symlink()
    );
    let text = std::fs::read_to_string(d.join("plans/x.toml")).expect("read");
    assert!(text.contains("targets_mm"), "{text}");
}

/// Issue 28, item 9: `--out` under a missing directory created the whole tree. Now the
/// missing directory is named and nothing is made.
#[test]
fn an_output_under_a_missing_directory_is_refused_naming_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let o = plan_to(d, "no/such/p.toml");
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no/such"), "{}", stderr(&o));
    assert!(!d.join("no").exists(), "no directory made");
    let o = errmap(
        d,
        &[
            "compare",
            &dataset("table1.csv"),
            "--test",
            &dataset("table2.csv"),
            "--methods",
            "trilinear",
            "--report",
            "none/rep",
        ],
    );
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("none"), "{}", stderr(&o));
    assert!(!d.join("none").exists(), "no directory made");
}

/// Issue 28, item 7: `plan --out P --program P` wrote the plan and replaced it by the
/// part program. Two outputs on one path are a usage error (exit 2), however spelt.
#[test]
fn two_outputs_on_one_path_are_a_usage_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).expect("mkdir");
    for (out, program) in [
        ("p.ngc", "p.ngc"),
        ("p.ngc", "./p.ngc"),
        ("p.ngc", "sub/../p.ngc"),
    ] {
        let mut args = PLAN.to_vec();
        args.extend(["--out", out, "--program", program]);
        let o = errmap(d, &args);
        assert_eq!(code(&o), Some(2), "{out} {program}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("--out") && e.contains("--program"), "{e}");
        assert!(!d.join("p.ngc").exists(), "nothing written");
    }
    let mut args = PLAN.to_vec();
    args.extend(["--out", "p.toml", "--program", "p.ngc"]);
    let o = errmap(d, &args);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
}

// ---- a closed stderr ----

/// Runs `args` in `dir` with stderr a pipe whose reader is closed before the run starts
/// (a FIFO opened at both ends, then its reading end closed: `std::io::pipe` is newer
/// than the crate's Rust version).
#[cfg(unix)]
fn with_closed_stderr(dir: &Path, args: &[&str]) -> Output {
    let fifo = dir.join("stderr.pipe");
    if !fifo.exists() {
        let made = Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        assert!(made, "mkfifo");
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || drop(std::fs::File::open(&fifo).expect("open to read")))
    };
    let writer = std::fs::OpenOptions::new()
        .write(true)
        .open(&fifo)
        .expect("open to write");
    reader.join().expect("reader");
    Command::new(bin())
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(writer)
        .output()
        .expect("runs errmap")
}

/// Issue 28, item 2: with stderr a closed pipe, `eprintln!` panicked (exit 101) in every
/// command tried. Now each command does its work and ends with the status it has when
/// stderr is open: success, a data error, a usage error of ours and one of clap's.
#[cfg(unix)]
#[test]
fn a_closed_stderr_changes_no_exit_status() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let session = d.join("s.csv");
    simulate_session(&session);
    let s = session.display().to_string();
    let t1 = dataset("table1.csv");
    let t2 = dataset("table2.csv");
    let cases: Vec<Vec<&str>> = vec![
        vec!["table", &s, "--out", "e.csv"],
        vec![
            "fit",
            "missing.csv",
            "--method",
            "trilinear",
            "--predict",
            &t2,
        ],
        vec!["fit", &t1, "--method", "lagrange", "--predict", &t2],
        vec![
            "fit",
            &t1,
            "--method",
            "trilinear",
            "--predict",
            &t2,
            "--bogus",
        ],
        vec![
            "plan",
            "--axis",
            "x",
            "--from",
            "0",
            "--to",
            "100",
            "--targets",
            "5",
            "--out",
            "p.toml",
        ],
        vec![
            "plan",
            "--axis",
            "x",
            "--from",
            "0",
            "--to",
            "100",
            "--targets",
            "1",
            "--out",
            "q.toml",
        ],
    ];
    for args in cases {
        let open = errmap(d, &args);
        let closed = with_closed_stderr(d, &args);
        assert_ne!(code(&closed), Some(101), "{args:?} panicked");
        assert_eq!(
            code(&closed),
            code(&open),
            "{args:?}: closed stderr {:?}, open {:?} ({})",
            code(&closed),
            code(&open),
            stderr(&open)
        );
    }
    assert!(
        d.join("e.csv").is_file() && d.join("p.toml").is_file(),
        "work done"
    );
}

// ---- signals ----

/// Issue 28, item 9: a killed `replay` left its hidden temporary file. SIGTERM (and
/// SIGINT) now remove it and end the run with 130; the old output is kept.
#[cfg(unix)]
#[test]
fn a_replay_killed_midway_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let o = errmap(d, &["gen-capture", "--mb", "40", "--out", "big.bin"]);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    std::fs::write(d.join("s.csv"), "old").expect("write");
    for signal in ["-TERM", "-INT"] {
        let mut child = Command::new(bin())
            .args(["replay", "big.bin", "--out", "s.csv"])
            .current_dir(d)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn");
        // Wait for the temporary file: the run is then writing it.
        let start = Instant::now();
        let seen = loop {
            if names(d).iter().any(|n| n.contains(".tmp")) {
                break true;
            }
            if child.try_wait().expect("wait").is_some()
                || start.elapsed() > Duration::from_secs(60)
            {
                break false;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        if !seen {
            let _ = child.kill();
            let _ = child.wait();
            eprintln!("skipped {signal}: the replay ended before its temporary file was seen");
            continue;
        }
        let ok = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "kill {signal}");
        let status = child.wait().expect("wait");
        assert_eq!(status.code(), Some(130), "{signal}: {status:?}");
        let left: Vec<_> = names(d)
            .into_iter()
            .filter(|n| n.contains(".tmp"))
            .collect();
        assert!(left.is_empty(), "{signal}: {left:?} left");
        assert_eq!(
            std::fs::read_to_string(d.join("s.csv")).expect("read"),
            "old"
        );
    }
}

// ---- exit codes ----

/// Issue 28, item 8: `plan` exited 1 for out-of-range flag values; the contract says 2.
#[test]
fn plan_refuses_out_of_range_flags_with_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let base = ["plan", "--axis", "x", "--out", "p.toml"];
    let cases: [&[&str]; 5] = [
        &["--from", "0", "--to", "100", "--targets", "1"],
        &["--from", "800", "--to", "0", "--targets", "5"],
        &[
            "--from",
            "0",
            "--to",
            "100",
            "--targets",
            "5",
            "--runs",
            "0",
        ],
        &["--from", "0", "--to", "100", "--interval", "1e-12"],
        &["--from", "0", "--to", "100", "--targets", "100000"],
    ];
    for extra in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let o = errmap(dir.path(), &args);
        assert_eq!(code(&o), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(!dir.path().join("p.toml").exists());
    }
}

/// Issue 28, item 9: `export --at x=5` on a line along x and `--at ,,,` were accepted.
#[test]
fn export_line_positions_name_the_other_two_axes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let t1 = dataset("table1.csv");
    for at in ["x=5", ",,,", "y=1,", "y=1,x=5"] {
        let o = errmap(
            dir.path(),
            &[
                "export",
                &t1,
                "--method",
                "trilinear",
                "--format",
                "csv",
                "--axis",
                "x",
                "--step",
                "50",
                "--out",
                "o.csv",
                "--at",
                at,
            ],
        );
        assert_eq!(code(&o), Some(2), "--at {at}: {}", stderr(&o));
        assert!(stderr(&o).contains("--at"), "{}", stderr(&o));
    }
}

// ---- bounds ----

fn vol_plan(dir: &Path, edit: impl Fn(&str) -> String) -> String {
    let text = std::fs::read_to_string(root().join("datasets/volumetric/plan.toml")).expect("plan");
    let edited = edit(&text);
    assert_ne!(edited, text, "the edit applies");
    std::fs::write(dir.join("plan.toml"), edited).expect("write");
    "plan.toml".into()
}

/// Issue 28, item 3: `targets = 9223372036854775807` panicked (capacity overflow),
/// `4294967296` aborted on a 103 GB allocation, `100000` made 4.3 M targets. Each is
/// refused by key before anything is allocated, and so is a campaign of too many readings.
#[test]
fn volumetric_plan_counts_are_bounded_before_allocation() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    for targets in ["9223372036854775807", "4294967296", "100000", "5000"] {
        let plan = vol_plan(d, |t| {
            t.replace("targets = 11", &format!("targets = {targets}"))
        });
        let start = Instant::now();
        let o = errmap(
            d,
            &[
                "volumetric",
                "simulate",
                "--model",
                &dataset("volumetric/model.toml"),
                "--plan",
                &plan,
                "--out",
                "lines.csv",
            ],
        );
        assert_eq!(code(&o), Some(1), "targets = {targets}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("plan.toml") && e.contains("targets"), "{e}");
        assert!(start.elapsed() < Duration::from_secs(30), "refused at once");
        assert!(!d.join("lines.csv").exists());
    }
}

/// Issue 28, item 4: an integer coefficient (`E_C0Y = 1000000000000000000`) skipped the
/// range check that refuses the float `1e18`.
#[test]
fn integers_in_toml_go_through_the_range_checks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let model =
        std::fs::read_to_string(root().join("datasets/volumetric/model.toml")).expect("model");
    for value in ["1000000000000000000", "1e18"] {
        let edited = model.replace("E_C0Y = 8.0", &format!("E_C0Y = {value}"));
        assert_ne!(edited, model);
        std::fs::write(d.join("m.toml"), edited).expect("write");
        let o = errmap(
            d,
            &[
                "volumetric",
                "simulate",
                "--model",
                "m.toml",
                "--plan",
                &dataset("volumetric/plan.toml"),
                "--out",
                "lines.csv",
            ],
        );
        assert_eq!(code(&o), Some(1), "{value}: {}", stderr(&o));
        assert!(stderr(&o).contains("E_C0Y"), "{}", stderr(&o));
    }
}

/// Issue 28, item 3: `--positions 1000000000` allocated 24 GB.
#[test]
fn identify_positions_are_bounded() {
    let dir = tempfile::tempdir().expect("tempdir");
    for n in ["1000000000", "10000000", "1"] {
        let o = errmap(
            dir.path(),
            &[
                "volumetric",
                "identify",
                "lines.csv",
                "--topology",
                "YXZ",
                "--positions",
                n,
            ],
        );
        assert_eq!(code(&o), Some(2), "--positions {n}: {}", stderr(&o));
        assert!(stderr(&o).contains("--positions"), "{}", stderr(&o));
    }
}

/// Issue 28, item 5: `air_temp_k = 9223372036854775807` gave `u_rel =
/// 8819167232000000000 ppm`, and `dead_path_mm = 1e18` was printed as given.
#[test]
fn certificate_uncertainty_inputs_have_physical_bounds() {
    use errmap::report::certificate::CertificateInfo;
    let p = Path::new("info.toml");
    for (key, value) in [
        ("air_temp_k", "9223372036854775807"),
        ("dead_path_mm", "1e18"),
        ("k", "1000"),
        ("misalignment_urad", "1e9"),
    ] {
        let text = format!("[uncertainty]\n{key} = {value}\n");
        let e = CertificateInfo::parse(&text, p).expect_err("refused");
        let m = e.to_string();
        assert!(m.contains(key) && m.contains("info.toml"), "{m}");
    }
    CertificateInfo::parse("[uncertainty]\nair_temp_k = 0.05\ndead_path_mm = 250\n", p)
        .expect("ordinary values pass");
}

// ---- Parquet columns of any type ----

use polars_arrow::array::{Array, PrimitiveArray, Utf8ViewArray};
use polars_arrow::datatypes::{ArrowDataType, ArrowSchema, Field, TimeUnit};
use polars_arrow::record_batch::RecordBatchT;
use polars_parquet::write::{
    CompressionOptions, Encoding, FileWriter, RowGroupIterator, StatisticsOptions, Version,
    WriteOptions,
};

/// Table 1's columns, as read from the CSV.
fn table1() -> Vec<[f64; 4]> {
    std::fs::read_to_string(root().join("datasets/table1.csv"))
        .expect("table1")
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|c| c.parse().expect("number")).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

/// Writes a Parquet file of `columns` (name, array) with polars' own Parquet writer.
fn write_parquet(path: &Path, columns: Vec<(&str, Box<dyn Array>)>) {
    let rows = columns[0].1.len();
    let schema: ArrowSchema = columns
        .iter()
        .map(|(n, a)| {
            (
                (*n).into(),
                Field::new((*n).into(), a.dtype().clone(), true),
            )
        })
        .collect();
    let arrays: Vec<Box<dyn Array>> = columns.into_iter().map(|(_, a)| a).collect();
    let options = WriteOptions {
        statistics: StatisticsOptions::default(),
        version: Version::V2,
        compression: CompressionOptions::Uncompressed,
        data_page_size: None,
    };
    let encodings: Vec<Vec<Encoding>> = arrays.iter().map(|_| vec![Encoding::Plain]).collect();
    let batch = RecordBatchT::new(rows, std::sync::Arc::new(schema.clone()), arrays);
    let groups = RowGroupIterator::try_new(
        vec![Ok(batch)].into_iter(),
        &schema,
        options,
        encodings.into(),
    )
    .expect("row groups");
    let file = std::fs::File::create(path).expect("create");
    let mut writer = FileWriter::try_new(file, schema, options).expect("writer");
    for group in groups {
        writer
            .write(rows as u64, group.expect("group"))
            .expect("write");
    }
    writer.end(None).expect("footer");
}

fn f64_column(rows: &[[f64; 4]], k: usize) -> Box<dyn Array> {
    PrimitiveArray::<f64>::from_vec(rows.iter().map(|r| r[k]).collect()).boxed()
}

fn fit_json(dir: &Path, table: &str) -> Output {
    errmap(
        dir,
        &[
            "fit",
            table,
            "--method",
            "trilinear",
            "--predict",
            &dataset("table2.csv"),
            "--json",
        ],
    )
}

/// Issue 28, item 6: an unused column of a type errmap does not read (uint8, int16,
/// date32, timestamp…) made the table unreadable in every reader. Such columns are left
/// out; the fit's predictions are those of the table without them. A needed column of
/// such a type, or of text, is refused naming it.
#[test]
fn parquet_columns_errmap_does_not_use_may_have_any_type() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let rows = table1();
    let n = rows.len();
    let base = |extra: Vec<(&'static str, Box<dyn Array>)>| {
        let mut c: Vec<(&str, Box<dyn Array>)> = ["x_mm", "y_mm", "z_mm", "e_um"]
            .into_iter()
            .enumerate()
            .map(|(k, name)| (name, f64_column(&rows, k)))
            .collect();
        c.extend(extra);
        c
    };
    write_parquet(&d.join("plain.parquet"), base(vec![]));
    let odd: Vec<(&str, Box<dyn Array>)> = vec![
        (
            "operator_id",
            PrimitiveArray::<u8>::from_vec((0..n).map(|i| (i % 7) as u8).collect()).boxed(),
        ),
        (
            "probe",
            PrimitiveArray::<i16>::from_vec((0..n).map(|i| i as i16).collect()).boxed(),
        ),
        (
            "measured_on",
            PrimitiveArray::<i32>::from_vec(vec![20_000; n])
                .to(ArrowDataType::Date32)
                .boxed(),
        ),
        (
            "logged_at",
            PrimitiveArray::<i64>::from_vec(vec![1_700_000_000_000; n])
                .to(ArrowDataType::Timestamp(TimeUnit::Millisecond, None))
                .boxed(),
        ),
    ];
    write_parquet(&d.join("odd.parquet"), base(odd));
    let plain = fit_json(d, "plain.parquet");
    assert_eq!(code(&plain), Some(0), "{}", stderr(&plain));
    let odd = fit_json(d, "odd.parquet");
    assert_eq!(code(&odd), Some(0), "{}", stderr(&odd));
    assert_eq!(odd.stdout, plain.stdout, "the same predictions");
    // A needed column of an odd type: named, with its type.
    let mut c = base(vec![]);
    c[0].1 = PrimitiveArray::<u8>::from_vec(rows.iter().map(|r| r[0] as u8).collect()).boxed();
    write_parquet(&d.join("u8-x.parquet"), c);
    let o = fit_json(d, "u8-x.parquet");
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("u8-x.parquet") && e.contains("x_mm") && e.contains("UInt8"),
        "{e}"
    );
    // Text where a number belongs: refused, named (it was parsed silently).
    let mut c = base(vec![]);
    c[3].1 =
        Utf8ViewArray::from_slice_values(rows.iter().map(|r| r[3].to_string()).collect::<Vec<_>>())
            .boxed();
    write_parquet(&d.join("text-e.parquet"), c);
    let o = fit_json(d, "text-e.parquet");
    assert_eq!(code(&o), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("text-e.parquet") && e.contains("e_um") && e.contains("text"),
        "{e}"
    );
}
