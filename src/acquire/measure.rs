//! Throughput and peak memory of the streaming pipeline on a generated long capture
//! (`errmap_drivers::longrun`): raw bytes → session table (replay, Parquet), and session
//! table → error table with ISO 230-2 statistics (the `table` command's reduction).
//!
//! Peak memory is the process's resident high-water mark (`VmHWM` of
//! `/proc/self/status`, Linux), reset before each step by writing `5` to
//! `/proc/self/clear_refs`; where that is unavailable the figure is `None`. Throughput is
//! capture bytes per wall-clock second, one run (a long capture is its own repetition).

use std::path::{Path, PathBuf};
use std::time::Instant;

use errmap_drivers::longrun::write_long_capture;
use serde::Serialize;

use super::{AcquireError, replay};
use crate::base::FileOp;
use crate::base::io_err;
use crate::session::{BATCH_ROWS, Reducer, for_each_batch};

/// What [`stream_bench`] measured.
#[derive(Debug, Clone, Serialize)]
pub struct StreamBench {
    /// Size of the generated capture, bytes.
    pub capture_bytes: u64,
    /// Session rows decoded from it.
    pub rows: u64,
    /// Replay to Parquet: capture MB (10⁶ B) per second.
    pub replay_mb_s: f64,
    /// Peak resident memory during replay, MB (None: not measurable here).
    pub replay_peak_rss_mb: Option<f64>,
    /// Table (read the Parquet session in batches, reduce): capture MB per second.
    pub table_mb_s: f64,
    /// Peak resident memory during the reduction, MB.
    pub table_peak_rss_mb: Option<f64>,
    /// Nodes of the error table.
    pub nodes: usize,
}

/// Resets the resident high-water mark; false where Linux's `clear_refs` is unavailable.
pub(crate) fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The resident high-water mark, MB (`VmHWM`).
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn scratch_dir() -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    std::env::temp_dir().join(format!(
        "errmap-stream-bench-{}-{nanos}",
        std::process::id()
    ))
}

/// Generates a capture of at least `mb` MB in a scratch directory, replays it to Parquet
/// and reduces the table, measuring both; removes the directory afterwards.
pub fn stream_bench(mb: f64) -> Result<StreamBench, AcquireError> {
    let dir = scratch_dir();
    std::fs::create_dir_all(&dir).map_err(io_err(&dir, FileOp::Access))?;
    let r = measure(&dir, mb);
    let _ = std::fs::remove_dir_all(&dir);
    r
}

fn measure(dir: &Path, mb: f64) -> Result<StreamBench, AcquireError> {
    let raw = dir.join("raw.bin");
    let table = dir.join("session.parquet");
    {
        let file = std::fs::File::create(&raw).map_err(io_err(&raw, FileOp::Access))?;
        let mut out = std::io::BufWriter::new(file);
        write_long_capture(&mut out, (mb.max(0.0) * 1e6) as u64, 0, 1000.0)
            .map_err(io_err(&raw, FileOp::Access))?;
    }
    let bytes = std::fs::metadata(&raw)
        .map_err(io_err(&raw, FileOp::Access))?
        .len();
    let reset = reset_peak_rss();
    let t = Instant::now();
    let replayed = replay(&raw, &table)?;
    let replay_s = t.elapsed().as_secs_f64();
    let replay_rss = peak_rss_mb().filter(|_| reset);
    let reset = reset_peak_rss();
    let t = Instant::now();
    let mut reducer = Reducer::new();
    for_each_batch(&table, BATCH_ROWS, &mut |rows| {
        rows.iter().for_each(|r| reducer.push(r));
        Ok(())
    })?;
    let nodes = reducer
        .error_table("bench")
        .map_or(0, |(t, _)| t.points.len());
    let _ = reducer.iso_by_line();
    let table_s = t.elapsed().as_secs_f64();
    let table_rss = peak_rss_mb().filter(|_| reset);
    Ok(StreamBench {
        capture_bytes: bytes,
        rows: replayed.rows,
        replay_mb_s: bytes as f64 / replay_s.max(1e-9) / 1e6,
        replay_peak_rss_mb: replay_rss,
        table_mb_s: bytes as f64 / table_s.max(1e-9) / 1e6,
        table_peak_rss_mb: table_rss,
        nodes,
    })
}
