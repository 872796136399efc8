//! How every output file is written: whole or not at all, and never with a NaN.
//!
//! - **Atomic.** [`write_atomically`] writes into a temporary file beside the target
//!   (`.STEM.PID.tmp.EXT`, [`temporary`], same directory and so the same file system) and renames it onto
//!   the target only when everything was written and flushed; on any error the temporary
//!   file is removed. An existing file is replaced whole (POSIX `rename` is atomic) or
//!   left as it was; an interrupted run never leaves a truncated file under the final
//!   name.
//! - **Finite.** [`check_finite`] refuses a frame holding NaN or ±inf in any float column
//!   ([`TableError::NonFiniteOutput`]). The readers refuse such values at the door, so one
//!   at the writer is a bug in a computation; it is reported, not written.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::TableError;

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> TableError + '_ {
    move |source| TableError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The temporary sibling of `path` that an output is written to first and renamed from
/// (`.STEM.PID.tmp.EXT`): hidden, in the same directory (so the same file system), unique
/// per process, and with `path`'s extension last, so a writer that picks its format by
/// extension (CSV or Parquet) writes the temporary in the target's format.
pub fn temporary(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    path.with_file_name(format!(".{stem}.{}.tmp{ext}", std::process::id()))
}

/// Writes `path` through `fill` (see the module docs), creating its parent directory.
/// `fill`'s own errors are returned as they are; I/O errors name `path`.
pub fn write_atomically<E: From<TableError>>(
    path: &Path,
    fill: impl FnOnce(&mut File) -> Result<(), E>,
) -> Result<(), E> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| E::from(io(parent)(e)))?;
    }
    let tmp = temporary(path);
    let result = (|| {
        let mut file = File::create(&tmp).map_err(|e| E::from(io(path)(e)))?;
        fill(&mut file)?;
        file.flush().map_err(|e| E::from(io(path)(e)))?;
        file.sync_data().map_err(|e| E::from(io(path)(e)))?;
        drop(file);
        std::fs::rename(&tmp, path).map_err(|e| E::from(io(path)(e)))
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
