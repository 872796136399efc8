//! How every output file is written: whole or not at all, never over something that is
//! not a file, and never with a NaN.
//!
//! - **What the path is.** [`output_target`] looks at the path before anything is written
//!   and decides how (the rules of `docs/robustness.md`, "Outputs"):
//!   a regular file or a new path is written atomically; a **character device** or a
//!   **pipe** (`/dev/null`, `/dev/full`, a FIFO) is written *through*, opened and written in
//!   place, since there is nothing to replace (a rename over it would put a regular file
//!   where the machine's `/dev/null` was); a **symbolic link** is followed and the same
//!   rules apply to what it points to (the link stays a link), and a link inside `/proc`
//!   (`/dev/stdout`, `/dev/fd/N`: an open descriptor of this process) is written through;
//!   a **directory, block device or socket** is refused
//!   ([`TableError::NotAFile`]). A new file's directory must exist: errmap never makes a
//!   directory tree for an output ([`TableError::MissingDirectory`], naming it).
//! - **Atomic.** [`write_atomically`] writes into a temporary file beside the target
//!   (`.STEM.PID.tmp.EXT`, [`temporary`], same directory and so the same file system) and renames it onto
//!   the target only when everything was written and flushed; on any error the temporary
//!   file is removed. An existing file is replaced whole (POSIX `rename` is atomic) or
//!   left as it was; an interrupted run never leaves a truncated file under the final
//!   name.
//! - **Interrupted.** Every name [`temporary`] hands out is remembered;
//!   [`remove_temporaries`] removes those still on disk. The binary calls it when
//!   SIGINT/SIGTERM/SIGHUP ends a run, so a killed `replay` leaves no hidden file behind.
//! - **Finite.** [`check_finite`] refuses a frame holding NaN or ±inf in any float column
//!   ([`TableError::NonFiniteOutput`]). The readers refuse such values at the door, so one
//!   at the writer is a bug in a computation; it is reported, not written.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use polars::prelude::*;

use super::TableError;
use crate::base::io_err;
use crate::base::{FileError, FileOp};

/// Every temporary name handed out by [`temporary`] in this process.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The temporary sibling of `path` that an output is written to first and renamed from
/// (`.STEM.PID.tmp.EXT`): hidden, in the same directory (so the same file system), unique
/// per process, and with `path`'s extension last, so a writer that picks its format by
/// extension (CSV or Parquet) writes the temporary in the target's format. The name is
/// remembered for [`remove_temporaries`].
pub fn temporary(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{stem}.{}.tmp{ext}", std::process::id()));
    let mut known = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    if !known.contains(&tmp) {
        known.push(tmp.clone());
    }
    tmp
}

/// Removes every temporary file or directory [`temporary`] named that is still on disk
/// (the ones renamed into place are gone already). For the end of a run cut short by a
/// signal; returns how many were removed.
pub fn remove_temporaries() -> usize {
    remove_temporaries_where(|_| true)
}

/// [`remove_temporaries`] for the names `which` accepts.
fn remove_temporaries_where(which: impl Fn(&Path) -> bool) -> usize {
    let known = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    let mut removed = 0;
    for t in known.iter().filter(|t| which(t)) {
        let gone = match std::fs::symlink_metadata(t) {
            Ok(m) if m.is_dir() => std::fs::remove_dir_all(t).is_ok(),
            Ok(_) => std::fs::remove_file(t).is_ok(),
            Err(_) => false,
        };
        removed += usize::from(gone);
    }
    removed
}

/// How an output path is written (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OutputTarget {
    /// A regular file or a new path (the end of the symbolic links, if any): written to a
    /// temporary sibling and renamed onto it.
    Atomic(PathBuf),
    /// A character device, a pipe or an open descriptor of this process: opened for
    /// appending and written in place.
    Through(PathBuf),
}

/// Symbolic links followed before a path is refused as a loop.
const MAX_LINKS: usize = 40;

/// Whether the symbolic link `p` lives in `/proc` (an open descriptor: `/proc/self/fd/1`,
/// which `/dev/stdout` and `/dev/fd/N` lead to). Its text (`pipe:[…]`) is no path.
fn descriptor_link(p: &Path) -> bool {
    p.parent()
        .and_then(|d| std::fs::canonicalize(d).ok())
        .is_some_and(|d| d.starts_with("/proc"))
}

/// What `path` is and how it is written (see the module docs); refused when it is a
/// directory, a block device or a socket, or a new file in a directory that does not exist.
pub fn output_target(path: &Path) -> Result<OutputTarget, TableError> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let meta = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty())
                    && !dir.exists()
                {
                    return Err(TableError::MissingDirectory {
                        path: path.to_path_buf(),
                        dir: dir.to_path_buf(),
                    });
                }
                return Ok(OutputTarget::Atomic(p));
            }
            Err(e) => return Err(io_err(path, FileOp::Write)(e).into()),
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            if descriptor_link(&p) {
                return Ok(OutputTarget::Through(p));
            }
            let to = std::fs::read_link(&p).map_err(io_err(path, FileOp::Write))?;
            p = match p.parent() {
                Some(dir) => dir.join(to),
                None => to,
            };
            continue;
        }
        if kind.is_file() {
            return Ok(OutputTarget::Atomic(p));
        }
        let what = if kind.is_dir() {
            "a directory"
        } else {
            "a special file"
        };
        #[cfg(unix)]
        let what = {
            use std::os::unix::fs::FileTypeExt;
            if kind.is_char_device() || kind.is_fifo() {
                return Ok(OutputTarget::Through(p));
            }
            if kind.is_block_device() {
                "a block device"
            } else if kind.is_socket() {
                "a socket"
            } else {
                what
            }
        };
        return Err(TableError::NotAFile {
            path: path.to_path_buf(),
            kind: what,
        });
    }
    Err(TableError::NotAFile {
        path: path.to_path_buf(),
        kind: "a chain of more than 40 symbolic links",
    })
}

/// Writes `path` through `fill` (see the module docs): atomically over a regular file or
/// a new path, through to a device or pipe, refused otherwise. `fill`'s own errors are
/// returned as they are; I/O errors name `path` (`PATH: cannot write: REASON`).
pub fn write_atomically<E: From<TableError> + From<FileError>>(
    path: &Path,
    fill: impl FnOnce(&mut File) -> Result<(), E>,
) -> Result<(), E> {
    let target = match output_target(path)? {
        OutputTarget::Through(p) => {
            let mut file = OpenOptions::new()
                .append(true)
                .open(&p)
                .map_err(|e| E::from(io_err(path, FileOp::Write)(e)))?;
            fill(&mut file)?;
            return file
                .flush()
                .map_err(|e| E::from(io_err(path, FileOp::Write)(e)));
        }
        OutputTarget::Atomic(p) => p,
    };
    let tmp = temporary(&target);
    let result = (|| {
        let mut file = File::create(&tmp).map_err(|e| E::from(io_err(path, FileOp::Write)(e)))?;
        fill(&mut file)?;
        file.flush()
            .map_err(|e| E::from(io_err(path, FileOp::Write)(e)))?;
        file.sync_data()
            .map_err(|e| E::from(io_err(path, FileOp::Write)(e)))?;
        drop(file);
        std::fs::rename(&tmp, &target).map_err(|e| E::from(io_err(path, FileOp::Write)(e)))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Refuses a frame with a non-finite value in a float column (see the module docs).
pub fn check_finite(path: &Path, df: &DataFrame) -> Result<(), TableError> {
    for col in df.columns() {
        let s = col.as_materialized_series();
        let values: Box<dyn Iterator<Item = Option<f64>>> = match s.dtype() {
            DataType::Float64 => match s.f64() {
                Ok(ca) => Box::new(ca.iter()),
                Err(_) => continue,
            },
            DataType::Float32 => match s.f32() {
                Ok(ca) => Box::new(ca.iter().map(|v| v.map(f64::from))),
                Err(_) => continue,
            },
            _ => continue,
        };
        if let Some((row0, value)) = values
            .enumerate()
            .find_map(|(i, v)| v.filter(|x| !x.is_finite()).map(|x| (i, x)))
        {
            return Err(TableError::NonFiniteOutput {
                path: path.to_path_buf(),
                row: row0 + 1,
                column: col.name().to_string(),
                value,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table error of an I/O failure on `path`, for the closures handed to
    /// [`write_atomically`].
    fn io(path: &Path) -> impl FnOnce(std::io::Error) -> TableError + '_ {
        move |e| io_err(path, FileOp::Write)(e).into()
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("out.csv");
        std::fs::write(&p, "old").expect("write");
        let r: Result<(), TableError> = write_atomically(&p, |f| {
            f.write_all(b"half").map_err(io(&p))?;
            Err(TableError::Empty { path: p.clone() })
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).expect("read"), "old");
        let left: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").collect();
        assert_eq!(left.len(), 1, "only the old file remains");
        write_atomically::<TableError>(&p, |f| f.write_all(b"new").map_err(io(&p)))
            .expect("writes");
        assert_eq!(std::fs::read_to_string(&p).expect("read"), "new");
    }

    /// A private device node in `dir` (never the machine's `/dev`), or `None` when this
    /// process may not make one (not root).
    #[cfg(unix)]
    fn device(dir: &Path, name: &str, minor: u32) -> Option<PathBuf> {
        let p = dir.join(name);
        let ok = std::process::Command::new("mknod")
            .arg(&p)
            .args(["c", "1", &minor.to_string()])
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            Some(p)
        } else {
            eprintln!("skipped: mknod is not allowed here (not root)");
            None
        }
    }

    #[cfg(unix)]
    fn is_char_device(p: &Path) -> bool {
        use std::os::unix::fs::FileTypeExt;
        std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_char_device())
    }

    /// Issue 28: `--out /dev/null` (as root) replaced the machine's /dev/null by a file.
    #[cfg(unix)]
    #[test]
    fn a_device_is_written_through_and_stays_a_device() {
        let dir = tempfile::tempdir().expect("tempdir");
        let Some(null) = device(dir.path(), "null", 3) else {
            return;
        };
        let Some(full) = device(dir.path(), "full", 7) else {
            return;
        };
        assert_eq!(
            output_target(&null).expect("ok"),
            OutputTarget::Through(null.clone())
        );
        write_atomically::<TableError>(&null, |f| f.write_all(b"plan").map_err(io(&null)))
            .expect("written through");
        assert!(is_char_device(&null), "still a device");
        // A full device: the error names it, and it stays a device.
        let e = write_atomically::<TableError>(&full, |f| {
            f.write_all(&[b'x'; 1 << 16]).map_err(io(&full))
        })
        .expect_err("no space");
        assert!(e.to_string().contains("full"), "{e}");
        assert!(is_char_device(&full), "still a device");
        // A link to the device: followed, link and device both kept.
        let link = dir.path().join("out.toml");
        std::os::unix::fs::symlink(&null, &link).expect("symlink");
        write_atomically::<TableError>(&link, |f| f.write_all(b"x").map_err(io(&link)))
            .expect("ok");
        assert!(std::fs::symlink_metadata(&link).expect("ok").is_symlink());
        assert!(is_char_device(&null));
        let left: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").collect();
        assert_eq!(left.len(), 3, "no temporary file: {left:?}");
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_written_through_to_its_reader() {
        let dir = tempfile::tempdir().expect("tempdir");
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        if !made {
            eprintln!("skipped: no mkfifo");
            return;
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(&fifo).expect("read the fifo"))
        };
        write_atomically::<TableError>(&fifo, |f| f.write_all(b"x_mm\n1\n").map_err(io(&fifo)))
            .expect("written through");
        assert_eq!(reader.join().expect("reader"), b"x_mm\n1\n");
        use std::os::unix::fs::FileTypeExt;
        let m = std::fs::symlink_metadata(&fifo).expect("still there");
        assert!(m.file_type().is_fifo(), "still a fifo");
    }

    #[cfg(unix)]
    #[test]
    fn a_link_to_a_file_keeps_the_link_and_replaces_the_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::create_dir(dir.path().join("data")).expect("mkdir");
        let real = dir.path().join("data/t.csv");
        std::fs::write(&real, "old").expect("write");
        let link = dir.path().join("latest.csv");
        std::os::unix::fs::symlink("data/t.csv", &link).expect("symlink");
        assert_eq!(
            output_target(&link).expect("ok"),
            OutputTarget::Atomic(dir.path().join("data/t.csv"))
        );
        write_atomically::<TableError>(&link, |f| f.write_all(b"new").map_err(io(&link)))
            .expect("ok");
        assert!(std::fs::symlink_metadata(&link).expect("ok").is_symlink());
        assert_eq!(std::fs::read_to_string(&real).expect("read"), "new");
        // A dangling link: the file it names is made.
        let dangling = dir.path().join("next.csv");
        std::os::unix::fs::symlink("data/new.csv", &dangling).expect("symlink");
        write_atomically::<TableError>(&dangling, |f| f.write_all(b"n").map_err(io(&dangling)))
            .expect("ok");
        assert_eq!(
            std::fs::read_to_string(dir.path().join("data/new.csv")).expect("read"),
            "n"
        );
        // A loop is refused.
        let a = dir.path().join("a");
        std::os::unix::fs::symlink("b", &a).expect("symlink");
        std::os::unix::fs::symlink("a", dir.path().join("b")).expect("symlink");
        let e = output_target(&a).expect_err("a loop");
        assert!(e.to_string().contains("symbolic links"), "{e}");
    }

    #[test]
    fn a_directory_and_a_missing_directory_are_refused_by_name() {
        let dir = tempfile::tempdir().expect("tempdir");
        let e = output_target(dir.path()).expect_err("a directory");
        assert!(
            matches!(
                e,
                TableError::NotAFile {
                    kind: "a directory",
                    ..
                }
            ),
            "{e}"
        );
        let deep = dir.path().join("no/such/dir/out.csv");
        let e = write_atomically::<TableError>(&deep, |_| Ok(())).expect_err("refused");
        assert!(
            matches!(&e, TableError::MissingDirectory { dir: d, .. } if d.ends_with("no/such/dir")),
            "{e}"
        );
        assert!(!dir.path().join("no").exists(), "no tree made");
    }

    #[test]
    fn temporaries_left_by_an_interruption_are_removed() {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().join("session.parquet");
        let tmp = temporary(&out);
        std::fs::write(&tmp, "half").expect("write");
        let report_tmp = temporary(&dir.path().join("report"));
        std::fs::create_dir(&report_tmp).expect("mkdir");
        std::fs::write(report_tmp.join("a.md"), "half").expect("write");
        // (Only this test's: the other tests' writers run in parallel.)
        assert_eq!(remove_temporaries_where(|p| p.starts_with(dir.path())), 2);
        assert!(!tmp.exists() && !report_tmp.exists());
    }

    #[test]
    fn a_nan_in_a_frame_is_refused_with_its_row_and_column() {
        let df = DataFrame::new(
            2,
            vec![
                Column::new("x_mm".into(), vec![1.0, 2.0]),
                Column::new("e_um".into(), vec![0.5, f64::NAN]),
            ],
        )
        .expect("frame");
        let e = check_finite(Path::new("p.csv"), &df).expect_err("refused");
        assert!(
            matches!(&e, TableError::NonFiniteOutput { row: 2, column, .. } if column == "e_um"),
            "{e}"
        );
    }
}
