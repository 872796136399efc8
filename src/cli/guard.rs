//! Guards on the binary's way out: standard output, the thread count, and outputs that
//! would overwrite inputs.
//!
//! - **stdout.** Every document the binary prints on stdout (the `--json` documents, the
//!   pseudo-terminal path of `serve-sim`) goes through [`print_stdout`] (the `--json`
//!   documents through [`print_json`], which refuses a NaN or inf in them first). A reader that went
//!   away (`errmap … --json | head`) is normal use: the command ends quietly with status
//!   141 = 128 + SIGPIPE, what a shell reports for a program that the signal ended, and
//!   prints nothing. Any other write error (a full disk: `> /dev/full`) is an error naming
//!   stdout, exit 1.
//! - **Threads.** [`threads`] caps a requested thread count at the machine's cores and
//!   says so on stderr: more threads than cores only add switching, and a count like
//!   100 000 would spend minutes starting them.
//! - **Outputs are never inputs.** [`refuse_aliases`] compares every output path that
//!   already exists with every input by device and inode (so a hard link, a symbolic link
//!   or `./x` vs `x` are the same file) and refuses with both flags named, before anything
//!   is written.
//! - **Whole files.** [`write_file`] writes text and bytes outputs atomically, like the
//!   library's table writers; [`into_new_dir`] does the same for a new report directory.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};

/// The error [`print_stdout`] returns when the reader of stdout has gone; `main` turns it
/// into a quiet exit with [`STDOUT_CLOSED_STATUS`].
#[derive(Debug, thiserror::Error)]
#[error("stdout was closed by its reader")]
pub struct StdoutClosed;

/// A usage error found after clap: flags that do not go together, or one that another
/// needs. `main` prints it as clap prints its own and exits 2, as `docs/cli.md`
/// asks of every usage error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Usage(pub String);

/// A [`Usage`] error, for `return Err(usage(…))` and `ok_or_else`.
pub fn usage(message: impl Into<String>) -> anyhow::Error {
    Usage(message.into()).into()
}

/// Exit status for a closed stdout: 128 + SIGPIPE (13), the shell's status of a program
/// ended by the signal.
pub const STDOUT_CLOSED_STATUS: u8 = 141;

/// Prints `text` and a newline on stdout and flushes it. A closed pipe is
/// [`StdoutClosed`]; any other failure an error naming stdout.
pub fn print_stdout(text: &str) -> Result<()> {
    write_line(&mut std::io::stdout().lock(), text)
}

fn write_line(out: &mut impl Write, text: &str) -> Result<()> {
    let r = out
        .write_all(text.as_bytes())
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    match r {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to stdout")),
    }
}

/// Prints `value` as one line of JSON on stdout, like [`print_stdout`], after
/// `errmap::report::json_text` has checked that it holds no NaN or ±inf (which
/// serde_json would print as `null`: a bug reported, not a document printed).
pub fn print_json<T: serde::Serialize + ?Sized>(value: &T) -> Result<()> {
    let text = errmap::report::json_text(Path::new("stdout"), value, false)?;
    print_stdout(&text)
}

/// Writes `bytes` to `path` whole or not at all (a temporary file beside it, renamed into
/// place: `errmap::table::write_atomically`).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    errmap::table::write_atomically::<errmap::table::TableError>(path, |f| {
        f.write_all(bytes)
            .map_err(|source| errmap::table::TableError::Io {
                path: path.to_path_buf(),
                source,
            })
    })?;
    Ok(())
}

/// Writes a report directory through `fill`. A directory that does not exist yet is
/// written whole or not at all: `fill` writes a temporary sibling (same parent, so the
/// same relative paths), renamed to `dir` on success and removed on error. An existing
/// directory may hold the user's own files, so it is written in place.
pub fn into_new_dir<T>(dir: &Path, fill: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    if dir.exists() {
        return fill(dir);
    }
    let tmp = errmap::table::temporary(dir);
    let _ = std::fs::remove_dir_all(&tmp);
    match fill(&tmp) {
        Ok(v) => {
            std::fs::rename(&tmp, dir)
                .with_context(|| format!("cannot move the report {} into place", dir.display()))?;
            Ok(v)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e)
        }
    }
}

/// The cores of this machine (1 if unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// A `--threads` value for the library: 0 stays 0 (all cores), a count above the
/// machine's cores is capped at them with a warning on stderr.
pub fn threads(flag: &str, requested: usize) -> usize {
    let cores = cores();
    if requested > cores {
        eprintln!(
            "errmap: warning: {flag} {requested} is more than the {cores} cores of this machine; using {cores}"
        );
        cores
    } else {
        requested
    }
}

/// Refuses when an output (flag, path) is the same file as an input (flag, path): same
/// device and inode. Outputs that do not exist yet cannot be inputs.
pub fn refuse_aliases(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<()> {
    for &(out_flag, out) in outputs {
        let Some(out_id) = file_id(out) else { continue };
        for &(in_flag, input) in inputs {
            if file_id(input) == Some(out_id) {
                bail!(
                    "{out_flag} {} is the input {in_flag} {}: writing it would destroy the input; choose another output path",
                    out.display(),
                    input.display()
                );
            }
        }
    }
    Ok(())
}

#[cfg(unix)]
fn file_id(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(p: &Path) -> Option<(u64, u64)> {
    // No inodes: compare canonical paths (a hash of them stands in for the id).
    use std::hash::{Hash, Hasher};
    let c = std::fs::canonicalize(p).ok()?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    c.hash(&mut h);
    Some((0, h.finish()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer that fails every write with one error kind.
    struct Failing(std::io::ErrorKind);

    impl Write for Failing {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(self.0.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn broken_pipe_is_stdout_closed_and_a_full_disk_names_stdout() {
        let e =
            write_line(&mut Failing(std::io::ErrorKind::BrokenPipe), "{}").expect_err("refused");
        assert!(e.downcast_ref::<StdoutClosed>().is_some());
        let e =
            write_line(&mut Failing(std::io::ErrorKind::StorageFull), "{}").expect_err("refused");
        assert!(e.downcast_ref::<StdoutClosed>().is_none());
        assert!(format!("{e:#}").contains("cannot write to stdout"), "{e:#}");
        let mut v = Vec::new();
        write_line(&mut v, "{\"a\":1}").expect("ok");
        assert_eq!(v, b"{\"a\":1}\n");
    }

    #[test]
    fn threads_are_capped_at_the_cores() {
        assert_eq!(threads("--threads", 0), 0);
        assert_eq!(threads("--threads", 1), 1);
        assert_eq!(threads("--threads", 100_000), cores());
    }

    #[test]
    fn a_new_report_directory_appears_whole_or_not_at_all() {
        let root = tempfile::tempdir().expect("ok");
        let dir = root.path().join("report");
        let failed: Result<()> = into_new_dir(&dir, |d| {
            std::fs::create_dir_all(d)?;
            std::fs::write(d.join("comparison.csv"), "half")?;
            bail!("a chart failed")
        });
        assert!(failed.is_err());
        let left: Vec<_> = std::fs::read_dir(root.path()).expect("ok").collect();
        assert!(left.is_empty(), "nothing left after the error");
        into_new_dir(&dir, |d| {
            std::fs::create_dir_all(d)?;
            std::fs::write(d.join("report.md"), "# ok")?;
            Ok(())
        })
        .expect("ok");
        assert_eq!(
            std::fs::read_to_string(dir.join("report.md")).expect("ok"),
            "# ok"
        );
        // An existing directory keeps the user's files.
        std::fs::write(dir.join("notes.txt"), "mine").expect("ok");
        into_new_dir(&dir, |d| {
            Ok(std::fs::write(d.join("report.md"), "# again")?)
        })
        .expect("ok");
        assert!(dir.join("notes.txt").exists());
    }

    #[test]
    fn an_output_linked_to_an_input_is_refused() {
        let dir = tempfile::tempdir().expect("ok");
        let input = dir.path().join("t.csv");
        std::fs::write(&input, "x").expect("ok");
        let link = dir.path().join("link.csv");
        std::fs::hard_link(&input, &link).expect("ok");
        let other = dir.path().join("o.csv");
        std::fs::write(&other, "y").expect("ok");
        let e = refuse_aliases(&[("--out", &link)], &[("TABLE", &input)]).expect_err("refused");
        let m = e.to_string();
        assert!(m.contains("--out") && m.contains("TABLE"), "{m}");
        refuse_aliases(&[("--out", &other)], &[("TABLE", &input)]).expect("ok");
        refuse_aliases(
            &[("--out", &dir.path().join("new.csv"))],
            &[("TABLE", &input)],
        )
        .expect("ok");
    }
}
