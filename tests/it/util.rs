//! What every integration test needs: the repository's paths, the `errmap` binary, a
//! temporary directory, and the real records that live outside the repository.
//!
//! `tests/diagnosis/` includes this file too (`#[path]`), so a helper one binary does not
//! use is not dead code there.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (the `errmap` package directory).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `errmap` binary this build made.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_errmap")
}

/// A file of `datasets/`, as an absolute path.
pub fn dataset(name: &str) -> PathBuf {
    root().join("datasets").join(name)
}

/// Runs `errmap args` in the repository root and waits for it.
pub fn errmap(args: &[&str]) -> Output {
    errmap_in(&root(), args)
}

/// Runs `errmap args` in `dir` and waits for it.
pub fn errmap_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(bin())
        .current_dir(dir)
        .args(args)
        .output()
        .expect("runs errmap")
}

/// A command's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh temporary directory, removed when dropped.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("tempdir")
}

/// Where the real ISO 230-2 records are looked for: converted session tables of
/// third-party positioning tests (the ecmc motion-control framework's published test
/// logs), kept beside the repository in `../shared/data/real_iso230/converted/` and
/// not distributed with it.
pub fn real_records_dir() -> PathBuf {
    root().join("../shared/data/real_iso230/converted")
}

/// The real record `name`, or `None` after printing which file the test needs and where
/// it looked (the test then skips).
pub fn real_record(name: &str) -> Option<PathBuf> {
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
