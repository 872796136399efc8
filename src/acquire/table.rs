//! The session table a capture or a replay writes: linear rows stream into the
//! [`SessionWriter`]; a rotary board's rows (`errmap_drivers::rotary`) make it a rotary
//! session table (`docs/rotary.md`). A CSV rotary table is written line by line as rows
//! come (all fifteen columns, empty optional cells), at every flush; a Parquet one is
//! written whole at the end (a killed capture's table is rebuilt by `replay`). One capture
//! holds one kind: a rotary row after linear rows (or the reverse) is refused.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use errmap_drivers::{SessionEvent, SessionRow};

use crate::base::{ConfigError, FileOp, RotaryAxis, io_err};
use crate::session::SessionWriter;
use crate::session::rotary::{
    RotaryRow, RotarySession, rotary_csv_header, rotary_csv_line, write_rotary_session,
};

use super::AcquireError;

/// The most rows a Parquet rotary table holds in memory before it is written.
pub(super) const MAX_PARQUET_ROTARY_ROWS: usize = 5_000_000;

/// The capture's table, linear until a rotary row comes.
pub(super) enum CaptureTable {
    Linear(Box<SessionWriter>),
    RotaryCsv {
        path: PathBuf,
        axis: RotaryAxis,
        file: File,
        text: String,
        rows: u64,
    },
    RotaryParquet {
        path: PathBuf,
        session: RotarySession,
    },
}

impl CaptureTable {
    pub(super) fn create(path: &Path) -> Result<Self, AcquireError> {
        Ok(CaptureTable::Linear(Box::new(SessionWriter::create(path)?)))
    }

    fn mixed(path: &Path, what: &str) -> AcquireError {
        ConfigError::file(
            path,
            format!("{what}: a capture holds one axis kind (the device's HELLO changed axis)"),
        )
        .into()
    }

    /// One decoder event: rows are written, the rest ignored.
    pub(super) fn event(&mut self, e: SessionEvent) -> Result<(), AcquireError> {
        match e {
            SessionEvent::Row(r) => self.linear(r),
            SessionEvent::Rotary(r) => self.rotary(&r),
            _ => Ok(()),
        }
    }

    pub(super) fn linear(&mut self, r: SessionRow) -> Result<(), AcquireError> {
        match self {
            CaptureTable::Linear(w) => Ok(w.push(r)?),
            CaptureTable::RotaryCsv { path, .. } | CaptureTable::RotaryParquet { path, .. } => {
                Err(Self::mixed(path, "a linear row after rotary rows"))
            }
        }
    }

    fn rotary(&mut self, r: &RotaryRow) -> Result<(), AcquireError> {
        if let CaptureTable::Linear(w) = self {
            let path = w.path().to_path_buf();
            if w.rows() > 0 {
                return Err(Self::mixed(&path, "a rotary row after linear rows"));
            }
            *self = if crate::table::is_parquet(&path)? {
                CaptureTable::RotaryParquet {
                    session: RotarySession {
                        axis: RotaryAxis::from(r.axis),
                        rows: Vec::new(),
                    },
                    path,
                }
            } else {
                let mut file = File::create(&path).map_err(io_err(&path, FileOp::Write))?;
                file.write_all(rotary_csv_header().as_bytes())
                    .map_err(io_err(&path, FileOp::Write))?;
                CaptureTable::RotaryCsv {
                    path,
                    axis: RotaryAxis::from(r.axis),
                    file,
                    text: String::new(),
                    rows: 0,
                }
            };
        }
        match self {
            CaptureTable::RotaryCsv {
                path,
                axis: a,
                text,
                rows,
                ..
            } => {
                if *a != RotaryAxis::from(r.axis) {
                    return Err(Self::mixed(path, "a rotary row of another axis"));
                }
                text.push_str(&rotary_csv_line(*a, r));
                *rows += 1;
                Ok(())
            }
            CaptureTable::RotaryParquet { path, session } => {
                if session.axis != RotaryAxis::from(r.axis) {
                    return Err(Self::mixed(path, "a rotary row of another axis"));
                }
                if session.rows.len() >= MAX_PARQUET_ROTARY_ROWS {
                    let problem = format!(
                        "more than {MAX_PARQUET_ROTARY_ROWS} rotary rows: a Parquet rotary table \
                         is held until the end; capture to CSV"
                    );
                    return Err(ConfigError::file(path, problem).into());
                }
                session.rows.push(*r);
                Ok(())
            }
            CaptureTable::Linear(_) => unreachable!("switched to rotary above"),
        }
    }

    /// Rows so far.
    pub(super) fn rows(&self) -> u64 {
        match self {
            CaptureTable::Linear(w) => w.rows(),
            CaptureTable::RotaryCsv { rows, .. } => *rows,
            CaptureTable::RotaryParquet { session, .. } => session.rows.len() as u64,
        }
    }

    /// CSV: the rows so far to the file (whole lines in one write).
    pub(super) fn flush(&mut self) -> Result<(), AcquireError> {
        match self {
            CaptureTable::Linear(w) => Ok(w.flush()?),
            CaptureTable::RotaryCsv {
                path, file, text, ..
            } => {
                file.write_all(text.as_bytes())
                    .map_err(io_err(path, FileOp::Write))?;
                text.clear();
                Ok(())
            }
            CaptureTable::RotaryParquet { .. } => Ok(()),
        }
    }

    /// The table's end; returns the number of rows.
    pub(super) fn finish(mut self) -> Result<u64, AcquireError> {
        self.flush()?;
        let rows = self.rows();
        match self {
            CaptureTable::Linear(w) => Ok((*w).finish()?),
            CaptureTable::RotaryCsv { .. } => Ok(rows),
            CaptureTable::RotaryParquet { path, session } => {
                write_rotary_session(&path, &session)
                    .map_err(|e| ConfigError::file(&path, e.to_string()))?;
                Ok(rows)
            }
        }
    }
}
