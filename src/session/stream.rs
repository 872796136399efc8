//! Session tables in bounded memory: a writer that takes rows one at a time and writes
//! them in batches, and a reader that hands a table back batch by batch. Capture, replay
//! and `table` use these, so their memory does not grow with the length of a session.
//!
//! **Writer.** Rows go straight into one vector per column ([`Columns`]) and are written
//! every [`BATCH_ROWS`] rows: CSV through polars' CSV writer (a header, then the rows of
//! each batch), Parquet one row group per batch through [`ParquetSink`] (its encodings,
//! compression and speed are in `columns.rs`). The CSV bytes of a row do not depend on the
//! batch it is in, so a streamed CSV table is byte for byte what [`super::write_session`]
//! writes for the same rows, whatever the batching. A Parquet file's bytes depend on its
//! row groups, which depend only on the row count: `write_session` cuts them as the
//! streaming writer does, so the two give identical files, and so do capture and replay
//! of the same bytes. Each CSV batch is rendered in memory and written with one
//! `write`, so a killed process leaves whole lines. [`SessionWriter::flush`] writes the
//! rows buffered so far to a CSV table at any time (capture calls it with every fsync of
//! the raw file, at least once a second); a Parquet table is readable only once its footer
//! is written by [`SessionWriter::finish`] — after a killed capture, `replay` of the raw
//! file rebuilds it exactly.
//!
//! **Reader.** [`for_each_batch`] reads a CSV table [`BATCH_ROWS`] lines at a time, a
//! Parquet table [`BATCH_ROWS`] rows at a time (one row group of a streamed table), and
//! validates every batch as [`super::read_session`] does, with row numbers counted from
//! the start of the file.
//!
//! **Memory bound.** Writing: one batch of columns (18 of 8 bytes and the axis's 16-byte
//! view, ≈ 160 B a row, reused from batch to batch) plus the encoded and compressed pages
//! of one row group: about 65 536 × 160 B ≈ 10 MB, twice that while a row group is
//! encoded. Reading: one batch of `SessionRow`s (168 B) and its DataFrame, ≈ 21 MB. Both
//! independent of the number of rows.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter};
use std::path::{Path, PathBuf};

use errmap_drivers::SessionRow;
use std::io::Write;

use polars::prelude::*;

use super::columns::{Columns, ParquetSink};
use super::{SampleSet, frame_rows, frame_rows_into};
use crate::base::FileOp;
use crate::base::io_err;
use crate::table::{TableError, format_err, is_parquet};

/// Rows per batch (and per Parquet row group) of the streaming writer and reader.
pub const BATCH_ROWS: usize = 65_536;

enum Sink {
    /// The file, a reused buffer for one batch's text, and whether the header is written.
    Csv(File, Vec<u8>, bool),
    Parquet(Box<ParquetSink<BufWriter<File>>>),
}

/// A session table written row by row (see the module docs).
pub struct SessionWriter {
    path: PathBuf,
    batch: Columns,
    batch_rows: usize,
    rows: u64,
    sink: Sink,
}

impl std::fmt::Debug for SessionWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionWriter")
            .field("path", &self.path)
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

impl SessionWriter {
    /// Creates (or truncates) the table at `path`, CSV or Parquet by extension, with
    /// batches of [`BATCH_ROWS`] rows.
    pub fn create(path: &Path) -> Result<Self, TableError> {
        Self::with_batch(path, BATCH_ROWS)
    }

    /// As [`SessionWriter::create`] with `batch_rows` rows per batch (at least 1).
    pub fn with_batch(path: &Path, batch_rows: usize) -> Result<Self, TableError> {
        let parquet = crate::table::output_is_parquet(path)?;
        // Its directory must exist (errmap makes no directory tree for an output).
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty())
            && !parent.exists()
        {
            return Err(TableError::MissingDirectory {
                path: path.to_path_buf(),
                dir: parent.to_path_buf(),
            });
        }
        let file = File::create(path).map_err(io_err(path, FileOp::Write))?;
        let sink = if parquet {
            Sink::Parquet(Box::new(
                ParquetSink::new(BufWriter::with_capacity(1 << 20, file))
                    .map_err(|e| format_err(path, e))?,
            ))
        } else {
            Sink::Csv(file, Vec::new(), false)
        };
        let batch_rows = batch_rows.max(1);
        Ok(SessionWriter {
            path: path.to_path_buf(),
            batch: Columns::default(),
            batch_rows,
            rows: 0,
            sink,
        })
    }

    /// Adds a row; writes the batch when it is full.
    pub fn push(&mut self, row: SessionRow) -> Result<(), TableError> {
        self.batch.push(&row);
        self.rows += 1;
        if self.batch.len() >= self.batch_rows {
            self.write_batch()?;
        }
        Ok(())
    }

    /// The table's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rows pushed so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// CSV: writes the rows buffered so far to the file now. Parquet: nothing (a row group
    /// boundary here would make the file depend on timing; see the module docs).
    pub fn flush(&mut self) -> Result<(), TableError> {
        match self.sink {
            Sink::Csv(..) => self.write_batch(),
            Sink::Parquet(_) => Ok(()),
        }
    }

    fn write_batch(&mut self) -> Result<(), TableError> {
        if self.batch.is_empty() {
            return Ok(());
        }
        match &mut self.sink {
            Sink::Parquet(w) => w
                .write(&mut self.batch)
                .map_err(|e| format_err(&self.path, e))?,
            Sink::Csv(file, text, header) => {
                let mut df = self
                    .batch
                    .take_frame()
                    .map_err(|e| format_err(&self.path, e))?;
                write_csv(&self.path, (file, text, header), &mut df)?;
            }
        }
        Ok(())
    }

    /// Writes the last batch and the file's end (CSV: the header if no row came; Parquet:
    /// the footer). Returns the number of rows.
    pub fn finish(mut self) -> Result<u64, TableError> {
        self.write_batch()?;
        match self.sink {
            Sink::Csv(_, _, true) => {}
            Sink::Csv(mut file, mut text, mut header) => {
                let mut empty = Columns::default()
                    .take_frame()
                    .map_err(|e| format_err(&self.path, e))?;
                write_csv(&self.path, (&mut file, &mut text, &mut header), &mut empty)?;
            }
            Sink::Parquet(w) => {
                let mut out = w.finish().map_err(|e| format_err(&self.path, e))?;
                out.flush().map_err(io_err(&self.path, FileOp::Write))?;
            }
        }
        Ok(self.rows)
    }
}

/// Writes one CSV batch: rendered whole, then handed to the file in one `write` (a killed
/// process leaves whole lines; a regular file's write is not cut by a signal). `header`:
/// whether the header is written already (it is, after this).
fn write_csv(
    path: &Path,
    (file, text, header): (&mut File, &mut Vec<u8>, &mut bool),
    df: &mut DataFrame,
) -> Result<(), TableError> {
    text.clear();
    CsvWriter::new(&mut *text)
        .include_header(!*header)
        .finish(df)
        .map_err(|e| format_err(path, e))?;
    *header = true;
    file.write_all(text)
        .map_err(|e| io_err(path, FileOp::Write)(e).into())
}

/// Reads the session table at `path` in batches of at most `batch_rows` rows, validated
/// as [`super::read_session`] does, and hands each to `each`. Returns the row count.
pub fn for_each_batch(
    path: &Path,
    batch_rows: usize,
    each: &mut dyn FnMut(&[SessionRow]) -> Result<(), TableError>,
) -> Result<u64, TableError> {
    let batch_rows = batch_rows.max(1);
    let io = |e| io_err(path, FileOp::Read)(e);
    // The structure checks of `read_frame` (ragged rows, repeated column names, column
    // types polars cannot read), in one streaming pass or from the schema.
    let parquet = is_parquet(path)?;
    if parquet {
        let _schema_checked = crate::table::parquet_reader(path)?;
    } else {
        crate::table::check_csv(path)?;
    }
    // (run, sample) unique across batches too, in memory bounded by the holes in the
    // sample counters rather than by the rows.
    let mut seen = SampleSet::default();
    // One row buffer for every batch: its memory is reused, not freed and faulted in again.
    let mut rows: Vec<SessionRow> = Vec::new();
    let file = File::open(path).map_err(io)?;
    let mut total = 0u64;
    if parquet {
        let mut reader = ParquetReader::new(file);
        let n =
            crate::table::guarded(path, "the footer (file metadata) cannot be decoded", || {
                reader.num_rows()
            })?;
        let mut offset = 0;
        while offset < n {
            let len = batch_rows.min(n - offset);
            // The schema's checks and its projection (columns polars cannot read left out).
            let reader = crate::table::parquet_reader(path)?.with_slice(Some((offset, len)));
            let df = crate::table::finish_parquet(path, reader)?;
            frame_rows_into(path, &df, offset, &mut seen, &mut rows)?;
            each(&rows)?;
            total += rows.len() as u64;
            offset += len;
        }
        return Ok(total);
    }
    let mut lines = BufReader::with_capacity(1 << 20, file);
    let mut header = String::new();
    if lines.read_line(&mut header).map_err(io)? == 0 {
        return Err(format_err(path, "empty file: no header"));
    }
    if !header.ends_with('\n') {
        header.push('\n');
    }
    let mut chunk = header.clone().into_bytes();
    let mut in_chunk = 0usize;
    let mut offset = 0usize;
    let mut line = Vec::new();
    loop {
        line.clear();
        let got = lines.read_until(b'\n', &mut line).map_err(io)?;
        if got > 0 && !line.iter().all(u8::is_ascii_whitespace) {
            chunk.extend_from_slice(&line);
            if !line.ends_with(b"\n") {
                chunk.push(b'\n');
            }
            in_chunk += 1;
        }
        if in_chunk > 0 && (got == 0 || in_chunk >= batch_rows) {
            let df = CsvReadOptions::default()
                .with_has_header(true)
                .with_infer_schema_length(Some(0))
                .into_reader_with_file_handle(std::io::Cursor::new(std::mem::take(&mut chunk)))
                .finish()
                .map_err(|e| format_err(path, e))?;
            frame_rows_into(path, &df, offset, &mut seen, &mut rows)?;
            each(&rows)?;
            total += rows.len() as u64;
            offset += in_chunk;
            in_chunk = 0;
            chunk = header.clone().into_bytes();
        }
        if got == 0 {
            break;
        }
    }
    if total == 0 {
        // Same as read_session: a header alone is a table of no rows; let the columns be
        // checked on the empty frame.
        let df = CsvReadOptions::default()
            .with_has_header(true)
            .with_infer_schema_length(Some(0))
            .into_reader_with_file_handle(std::io::Cursor::new(header.into_bytes()))
            .finish()
            .map_err(|e| format_err(path, e))?;
        frame_rows(path, &df, 0, &mut SampleSet::default())?;
    }
    Ok(total)
}

/// A session table read in bounded memory ([`read_session_thinned`]).
#[derive(Debug, Clone)]
pub struct Thinned {
    /// The rows kept, in table order.
    pub rows: Vec<SessionRow>,
    /// Rows are kept when their device `sample` index is a multiple of this (1: all).
    pub stride: i64,
    /// Rows in the table.
    pub total: u64,
}

/// Reads the session table at `path` as [`for_each_batch`] does, keeping at most
/// `max_rows` rows: when the table has more, every `stride`-th device sample (those whose
/// `sample` is a multiple of `stride`), with `stride` the smallest power of two that keeps
/// the rows within `max_rows`. One pass: the stride doubles (and the kept rows are thinned
/// to it) whenever they would exceed the bound. Thinning by the sample index is uniform in
/// time and picks the same samples from every table of one capture (a recording and its
/// simulation), so their rows still match on `(run, sample)`.
pub fn read_session_thinned(path: &Path, max_rows: usize) -> Result<Thinned, TableError> {
    let max_rows = max_rows.max(1);
    let mut stride = 1i64;
    let mut rows: Vec<SessionRow> = Vec::new();
    let total = for_each_batch(path, BATCH_ROWS, &mut |batch| {
        keep_every(batch, stride, &mut rows);
        // Rows sharing one sample index (one per run) cannot be thinned apart: stop
        // doubling when the stride is past every index.
        while rows.len() > max_rows && stride < (1 << 62) {
            stride *= 2;
            rows.retain(|r| r.sample.rem_euclid(stride) == 0);
        }
        Ok(())
    })?;
    Ok(Thinned {
        rows,
        stride,
        total,
    })
}

/// Reads the rows of the session table at `path` whose `sample` is a multiple of `stride`
/// (all of them when it is 1), as [`for_each_batch`] does. Returns them and the table's
/// row count.
pub fn read_session_every(path: &Path, stride: i64) -> Result<(Vec<SessionRow>, u64), TableError> {
    let stride = stride.max(1);
    let mut rows = Vec::new();
    let total = for_each_batch(path, BATCH_ROWS, &mut |batch| {
        keep_every(batch, stride, &mut rows);
        Ok(())
    })?;
    Ok((rows, total))
}

/// Appends to `rows` the rows of `batch` whose device sample index is a multiple of
/// `stride`.
fn keep_every(batch: &[SessionRow], stride: i64, rows: &mut Vec<SessionRow>) {
    rows.extend(
        batch
            .iter()
            .filter(|r| r.sample.rem_euclid(stride) == 0)
            .cloned(),
    );
}
