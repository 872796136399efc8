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
//!   is written. It also records the run's inputs and outputs (the run's plan), and every
//!   file the binary puts in place — a named output ([`write_file`]) and each file of a
//!   report directory ([`into_new_dir`]) — is checked against that plan first
//!   ([`check_target`]): a file inside a report folder that is an input, or another named
//!   output, is refused and nothing of that folder is written (issue 40 item 2).
//! - **Whole files.** [`write_file`] writes text and bytes outputs atomically, like the
//!   library's table writers (a device, pipe or link is written through or followed, never
//!   replaced: `errmap::table::output_target`); [`into_new_dir`] does the same for a new
//!   report directory. Two outputs on one path are refused ([`distinct_outputs`]).
//! - **Signals.** [`on_signals`]: SIGINT/SIGTERM/SIGHUP remove the run's temporary files
//!   and exit 130 (capture and serve-sim first stop gracefully, [`stop_on_interrupt`]).
//! - **A closed stderr.** The binary's `eprintln!` ignores a closed stderr (`main.rs`);
//!   [`quiet_on_closed_output`] catches what other printing code would panic on.

use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use errmap::base::FileOp;
use errmap::base::io_err;

/// The error [`print_stdout`] returns when the reader of stdout has gone; `main` turns it
/// into a quiet exit with [`STDOUT_CLOSED_STATUS`].
#[derive(Debug, thiserror::Error)]
#[error("stdout was closed by its reader")]
pub(crate) struct StdoutClosed;

/// A usage error found after clap: flags that do not go together, or one that another
/// needs. `main` prints it as clap prints its own and exits 2, as `docs/cli.md`
/// asks of every usage error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub(crate) struct Usage(pub String);

/// A [`Usage`] error, for `return Err(usage(…))` and `ok_or_else`.
pub(crate) fn usage(message: impl Into<String>) -> anyhow::Error {
    Usage(message.into()).into()
}

/// Exit status for a closed stdout: 128 + SIGPIPE (13), the shell's status of a program
/// ended by the signal.
pub(crate) const STDOUT_CLOSED_STATUS: u8 = 141;

/// Exit status of a run ended by SIGINT, SIGTERM or SIGHUP after its temporary files
/// were removed: 128 + SIGINT (2), what a shell reports for an interrupted program.
pub(crate) const INTERRUPTED_STATUS: i32 = 130;

/// The stop flag of a command that ends gracefully on an interrupt (capture, serve-sim).
static GRACEFUL: OnceLock<&'static AtomicBool> = OnceLock::new();

/// Makes the first interrupt set `flag` (the command then stops and finishes its files)
/// instead of ending the run; a second one ends it as [`on_signals`] says.
pub(crate) fn stop_on_interrupt(flag: &'static AtomicBool) {
    let _ = GRACEFUL.set(flag);
}

/// Installs, once for the binary, what SIGINT, SIGTERM and SIGHUP do: set the graceful
/// stop flag the first time when a command registered one ([`stop_on_interrupt`]);
/// otherwise remove every temporary output file or directory still on disk
/// (`errmap::table::remove_temporaries`) and exit with [`INTERRUPTED_STATUS`]. An
/// interrupted run leaves what was there before, and nothing else.
pub(crate) fn on_signals() {
    let _ = ctrlc::set_handler(|| {
        if let Some(flag) = GRACEFUL.get()
            && !flag.swap(true, Ordering::SeqCst)
        {
            return;
        }
        errmap::table::remove_temporaries();
        std::process::exit(INTERRUPTED_STATUS);
    });
}

/// Installs the last line of defence against a closed stderr or stdout: a panic of the
/// standard printing macros (`failed printing to stderr: Broken pipe`, from a dependency
/// or a `println!` that escaped [`print_stdout`]) ends the run quietly with
/// [`STDOUT_CLOSED_STATUS`] after removing temporary files, instead of exit 101. The
/// binary's own `eprintln!` never panics (`main.rs`).
pub(crate) fn quiet_on_closed_output() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if payload.starts_with("failed printing to std") {
            errmap::table::remove_temporaries();
            std::process::exit(i32::from(STDOUT_CLOSED_STATUS));
        }
        previous(info);
    }));
}

/// Prints `text` and a newline on stdout and flushes it. A closed pipe is
/// [`StdoutClosed`]; any other failure an error naming stdout.
pub(crate) fn print_stdout(text: &str) -> Result<()> {
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
pub(crate) fn print_json<T: serde::Serialize + ?Sized>(value: &T) -> Result<()> {
    let text = errmap::report::json_text(Path::new("stdout"), value, false)?;
    print_stdout(&text)
}

/// The run's inputs and outputs as (flag, path), recorded by [`refuse_aliases`] (and
/// [`plan_inputs`]); one command runs per process, so the plan is the process's.
static PLAN: std::sync::Mutex<Plan> = std::sync::Mutex::new(Plan {
    inputs: Vec::new(),
    outputs: Vec::new(),
});

#[derive(Debug)]
struct Plan {
    inputs: Vec<(String, std::path::PathBuf)>,
    outputs: Vec<(String, std::path::PathBuf)>,
}

fn plan() -> std::sync::MutexGuard<'static, Plan> {
    PLAN.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Records more inputs of the run (a ledger, a tolerance file) without outputs to compare
/// them with yet: every later write is checked against them ([`check_target`]).
pub(crate) fn plan_inputs(inputs: &[(&str, &Path)]) {
    let mut p = plan();
    for &(flag, path) in inputs {
        p.inputs.push((flag.to_string(), path.to_path_buf()));
    }
}

/// Whether two paths name one file: the same path once normalised ([`resolved`]), or the
/// same device and inode.
fn same_file(a: &Path, b: &Path) -> bool {
    matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
        || matches!((file_id(a), file_id(b)), (Some(x), Some(y)) if x == y)
}

/// The one check every file the binary writes goes through before it is put in place:
/// `target`, written on behalf of output `flag` (`own` being that output's own path,
/// the file itself or its report directory), must be no input of the run (exit 1) and no
/// other output of it (a usage error, exit 2). Devices and pipes are written through and
/// never refused.
pub(crate) fn check_target(flag: &str, own: &Path, target: &Path) -> Result<()> {
    if through(target) {
        return Ok(());
    }
    let p = plan();
    let shown = |path: &Path| {
        if path == own {
            format!("{flag} {}", own.display())
        } else {
            format!(
                "{flag} {} would write {}, which",
                own.display(),
                path.display()
            )
        }
    };
    for (in_flag, input) in &p.inputs {
        if same_file(target, input) {
            bail!(
                "{} is the input {in_flag} {}: writing it would destroy the input; choose another output path (nothing was written)",
                shown(target),
                input.display()
            );
        }
    }
    for (out_flag, out) in &p.outputs {
        if out != own && out_flag != flag && same_file(target, out) {
            return Err(usage(format!(
                "{} is also the output {out_flag} {}: the second output would replace the first; give each its own path (nothing was written)",
                shown(target),
                out.display()
            )));
        }
    }
    Ok(())
}

/// The flag a planned output was given, for the messages of [`check_target`].
fn flag_of(path: &Path, default: &str) -> String {
    plan()
        .outputs
        .iter()
        .find(|(_, p)| p == path)
        .map_or_else(|| default.to_string(), |(f, _)| f.clone())
}

/// Writes `bytes` to `path` whole or not at all (a temporary file beside it, renamed into
/// place: `errmap::table::write_atomically`), after [`check_target`].
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    check_target(&flag_of(path, "output"), path, path)?;
    errmap::table::write_atomically::<errmap::table::TableError>(path, |f| {
        f.write_all(bytes)
            .map_err(|e| io_err(path, FileOp::Write)(e).into())
    })?;
    Ok(())
}

/// Writes a report directory through `fill`. An existing directory holding no input or
/// other output of the run is written in place. Otherwise, whole or not at all: `fill` writes a
/// temporary sibling (same parent, so the same relative paths); then every file it wrote
/// is checked as `dir`'s file against the run's plan ([`check_target`]: an input lying in
/// the report folder, or another output there, refuses the whole report), and only then
/// put in place — the temporary directory renamed to `dir` when `dir` is new, each file
/// moved into `dir` when it exists (it may hold the user's own files, which stay). On any
/// error the temporary directory is removed and `dir` is as it was.
pub(crate) fn into_new_dir<T>(dir: &Path, fill: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    // A new directory, not a tree: its parent must exist, as a new file's must.
    if !dir.exists()
        && let Some(parent) = dir.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.exists()
    {
        bail!(errmap::table::TableError::MissingDirectory {
            path: dir.to_path_buf(),
            dir: parent.to_path_buf(),
        });
    }
    // An existing folder that holds no input or other output of the run is written in
    // place, as before (its writers tidy what they wrote there earlier).
    if dir.exists() && !holds_planned_file(dir) {
        return fill(dir);
    }
    let tmp = errmap::table::temporary(dir);
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir(&tmp).map_err(io_err(&tmp, FileOp::Write))?;
    let staged = fill(&tmp).and_then(|v| {
        let files = files_under(&tmp, Path::new(""))?;
        let flag = flag_of(dir, "--report");
        for rel in &files {
            let to = dir.join(rel);
            check_target(&flag, dir, &to)?;
            // A directory in the way would stop the move half-way: refused before it.
            if to.is_dir() {
                bail!(
                    "{}: cannot write the report's file: a directory is in the way (nothing was written)",
                    to.display()
                );
            }
        }
        Ok((v, files))
    });
    let (v, files) = match staged {
        Ok(x) => x,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    let moved = if dir.exists() {
        files.iter().try_for_each(|rel| {
            let to = dir.join(rel);
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::rename(tmp.join(rel), to)
        })
    } else {
        std::fs::rename(&tmp, dir)
    };
    let _ = std::fs::remove_dir_all(&tmp);
    moved.with_context(|| format!("cannot move the report {} into place", dir.display()))?;
    Ok(v)
}

/// Whether an input or another output of the run lies inside the folder `dir`.
fn holds_planned_file(dir: &Path) -> bool {
    let Some(d) = std::fs::canonicalize(dir).ok() else {
        return false;
    };
    let p = plan();
    p.inputs
        .iter()
        .chain(p.outputs.iter())
        .filter(|(_, path)| path != dir)
        .any(|(_, path)| resolved(path).is_some_and(|r| r.starts_with(&d)))
}

/// The files under `root/rel`, relative to `root`.
fn files_under(root: &Path, rel: &Path) -> Result<Vec<std::path::PathBuf>> {
    let mut out = Vec::new();
    let here = root.join(rel);
    if !here.exists() {
        return Ok(out);
    }
    for entry in std::fs::read_dir(&here).map_err(io_err(&here, FileOp::Read))? {
        let entry = entry.map_err(io_err(&here, FileOp::Read))?;
        let r = rel.join(entry.file_name());
        if entry
            .file_type()
            .map_err(io_err(&here, FileOp::Read))?
            .is_dir()
        {
            out.extend(files_under(root, &r)?);
        } else {
            out.push(r);
        }
    }
    Ok(out)
}

/// A spinner with the elapsed time on stderr while long work runs (issue 28: `compare` on
/// a 96 000-node grid ran over a minute with nothing shown), drawn only when stderr is a
/// terminal; cleared when dropped.
#[derive(Debug)]
pub(crate) struct Busy(Option<indicatif::ProgressBar>);

/// Starts a [`Busy`] spinner saying `message`.
pub(crate) fn busy(message: impl Into<String>) -> Busy {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return Busy(None);
    }
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
        bar.set_style(style);
    }
    bar.set_message(message.into());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    Busy(Some(bar))
}

impl Drop for Busy {
    fn drop(&mut self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

/// The cores of this machine (1 if unknown).
pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// A `--threads` value for the library: 0 stays 0 (all cores), a count above the
/// machine's cores is capped at them with a warning on stderr.
pub(crate) fn threads(flag: &str, requested: usize) -> usize {
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
/// device and inode. Outputs that do not exist yet cannot be inputs. Two outputs on one
/// path are refused first, as a usage error ([`distinct_outputs`]).
pub(crate) fn refuse_aliases(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<()> {
    distinct_outputs(outputs)?;
    plan_inputs(inputs);
    plan().outputs.extend(
        outputs
            .iter()
            .map(|&(f, p)| (f.to_string(), p.to_path_buf())),
    );
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

/// Refuses two outputs of one command on one path (issue 28: `plan --out P --program P`
/// wrote the plan, then replaced it by the part program): a usage error (exit 2) naming
/// both flags. Paths are compared as written after normalising `.` and `..` against the
/// working directory and following the links of their directories (so `./p` and `p`,
/// or `d/../p` and `p`, are one path), and by device and inode when both exist (hard
/// links). Devices and pipes (`/dev/null` twice) are not files that one output could
/// destroy, and are allowed.
pub(crate) fn distinct_outputs(outputs: &[(&str, &Path)]) -> Result<()> {
    for (i, &(flag_a, a)) in outputs.iter().enumerate() {
        for &(flag_b, b) in &outputs[i + 1..] {
            let same_path = matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y);
            let same_file = matches!((file_id(a), file_id(b)), (Some(x), Some(y)) if x == y);
            if (same_path || same_file) && !through(a) {
                return Err(usage(format!(
                    "{flag_a} and {flag_b} are the same path {}: the second output would replace the first; give each its own path",
                    a.display()
                )));
            }
        }
    }
    Ok(())
}

/// Whether `p` is written through (a device, a pipe, a descriptor): see
/// `errmap::table::output_target`.
fn through(p: &Path) -> bool {
    matches!(
        errmap::table::output_target(p),
        Ok(errmap::table::OutputTarget::Through(_))
    )
}

/// `p` made absolute, its directory with links followed (when it exists) and its last
/// component kept as written.
fn resolved(p: &Path) -> Option<std::path::PathBuf> {
    let abs = std::path::absolute(p).ok()?;
    let name = abs.file_name()?.to_owned();
    let dir = abs.parent()?;
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    Some(dir.join(name))
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
