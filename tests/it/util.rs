//! What every integration test needs: the repository's paths, the `errmap` binary, a
//! temporary directory, and the real records that live outside the repository.
//!
//! `tests/diagnosis/` includes this file too (`#[path]`), so a helper one binary does not
//! use is not dead code there.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (the `errmap` package directory).
pub(crate) fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `errmap` binary this build made.
pub(crate) fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_errmap")
}

/// A file of `datasets/`, as an absolute path.
pub(crate) fn dataset(name: &str) -> PathBuf {
    root().join("datasets").join(name)
}

/// Runs `errmap args` in the repository root and waits for it.
pub(crate) fn errmap(args: &[&str]) -> Output {
    errmap_in(&root(), args)
}

/// Runs `errmap args` in `dir` and waits for it.
pub(crate) fn errmap_in(dir: &Path, args: &[&str]) -> Output {
    errmap_cmd()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("runs errmap")
}

/// The `errmap` binary as a command to complete (arguments, standard streams, spawn),
/// for a test that pipes, kills or runs it in parallel.
pub(crate) fn errmap_cmd() -> Command {
    Command::new(bin())
}

/// A command's standard error as text.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The one JSON document a successful command printed (the test fails with the
/// command's standard error otherwise).
pub(crate) fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("one JSON document on stdout")
}

/// A path as the `&str` an argument list takes.
pub(crate) fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// One sample of a simulated positioning session at reference conditions (air, scale
/// and part at 20 °C, 1013.25 hPa, 50 % RH, feed 100 mm/s, no flag): the laser reads the
/// scale minus the error. Run, sample number and time are the caller's
/// (`SessionRow { run, sample, t_s, ..reference_row(…) }`).
pub(crate) fn reference_row(
    axis: errmap::drivers::Axis,
    direction: i8,
    target: i32,
    pos_mm: [f64; 3],
    scale_mm: f64,
    error_um: f64,
) -> errmap::drivers::SessionRow {
    errmap::drivers::SessionRow {
        run: 1,
        sample: 0,
        t_s: 0.0,
        axis,
        direction,
        feed_mm_s: Some(100.0),
        target,
        x_mm: Some(pos_mm[0]),
        y_mm: Some(pos_mm[1]),
        z_mm: Some(pos_mm[2]),
        scale_mm,
        laser_mm: scale_mm - error_um * 1e-3,
        error_um,
        air_temp_c: Some(20.0),
        air_pressure_hpa: Some(1013.25),
        air_rh_pct: Some(50.0),
        scale_temp_c: Some(20.0),
        part_temp_c: Some(20.0),
        flags: 0,
    }
}

/// A fresh temporary directory, removed when dropped.
pub(crate) fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("tempdir")
}

/// Where the real ISO 230-2 records are looked for: converted session tables of
/// third-party positioning tests (the ecmc motion-control framework's published test
/// logs), kept beside the repository in `../shared/data/real_iso230/converted/` and
/// not distributed with it.
pub(crate) fn real_records_dir() -> PathBuf {
    root().join("../shared/data/real_iso230/converted")
}

/// The real record `name`, or `None` after printing which file the test needs and where
/// it looked (the test then skips).
pub(crate) fn real_record(name: &str) -> Option<PathBuf> {
    let p = real_records_dir().join(name);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!(
            "skipped: this test needs the real ISO 230-2 record {name} (a converted session \
             table of a third-party positioning test, not distributed with errmap); it \
             looked for {}",
            p.display()
        );
        None
    }
}
