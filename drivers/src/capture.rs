//! Live capture: every byte read from the source is appended to the raw capture file
//! *before* it is decoded, the file is flushed to disk (fsync) at least once a second and
//! whenever a run ends, and the same sans-IO [`SessionDecoder`] that replay uses turns the
//! bytes into session rows. So a crash loses at most the bytes of the last second, and
//! `replay` of the raw file gives exactly the rows capture produced.
//!
//! The capture ends when the source ends (a file), the host asks it to stop (Ctrl-C sets
//! the stop flag), no byte arrives for the idle timeout, the duration limit passes, or the
//! port vanishes. A vanished port is reported as [`CaptureEnd::Vanished`] with everything
//! received so far: the caller writes a valid session and then reports the error.

use std::fs::File;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::frame::Hello;
use crate::session::{SessionDecoder, SessionRow};
use crate::stats::DecoderStats;
use crate::transport::{ByteSource, ReadOutcome, TransportError};

/// Capture settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureConfig {
    /// Longest time between two fsyncs of the raw file (the spec asks ≤ 1 s).
    pub fsync_every: Duration,
    /// Stop after this long without a byte (None: wait forever).
    pub idle_timeout: Option<Duration>,
    /// Stop after this long in total (None: no limit).
    pub max_duration: Option<Duration>,
    /// Read buffer size, bytes.
    pub read_buf: usize,
    /// How often the progress callback runs.
    pub progress_every: Duration,
}

impl Default for CaptureConfig {
    fn default() -> Self {
        CaptureConfig {
            fsync_every: Duration::from_millis(500),
            idle_timeout: None,
            max_duration: None,
            read_buf: 4096,
            progress_every: Duration::from_millis(200),
        }
    }
}

/// Why a capture ended.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "reason", content = "detail")]
pub enum CaptureEnd {
    /// The source has no more bytes (a file).
    EndOfSource,
    /// The stop flag was set (Ctrl-C).
    Stopped,
    /// No byte arrived within the idle timeout.
    Idle,
    /// The duration limit passed.
    Duration,
    /// The port went away.
    Vanished(String),
}

/// Live figures for a progress display.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Progress {
    pub bytes: u64,
    pub samples: u64,
    /// Highest run number seen so far.
    pub runs: u32,
    pub elapsed_s: f64,
    /// CRC failures + resyncs + seq gaps + flagged samples so far.
    pub problems: u64,
}

/// What a capture produced.
#[derive(Debug, Clone)]
pub struct Capture {
    pub rows: Vec<SessionRow>,
    pub stats: DecoderStats,
    pub hello: Option<Hello>,
    pub end: CaptureEnd,
    pub bytes: u64,
    pub fsyncs: u64,
}

/// What stops a capture from keeping its promise: the raw file cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("cannot write the raw capture file: {0}")]
    Raw(#[source] std::io::Error),
    #[error(transparent)]
    Transport(TransportError),
}

fn problems(s: &DecoderStats) -> u64 {
    s.crc_failures + s.resyncs + s.seq_gaps + s.flagged_samples
}

/// Runs a capture from `source` into `raw` (see the module docs).
pub fn capture(
    source: &mut dyn ByteSource,
    raw: &mut File,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Capture, CaptureError> {
    let start = Instant::now();
    let mut decoder = SessionDecoder::new();
    let mut rows: Vec<SessionRow> = Vec::new();
    let mut buf = vec![0u8; config.read_buf.max(1)];
    let (mut bytes, mut fsyncs) = (0u64, 0u64);
    let mut last_sync = Instant::now();
    let mut last_byte = Instant::now();
    let mut last_progress = Instant::now();
    let mut dirty = false;
    let mut max_run = 0u32;
    let sync = |raw: &mut File, fsyncs: &mut u64| -> Result<(), CaptureError> {
        raw.flush().map_err(CaptureError::Raw)?;
        raw.sync_data().map_err(CaptureError::Raw)?;
        *fsyncs += 1;
        Ok(())
    };
    let end = loop {
        if stop.load(Ordering::Relaxed) {
            break CaptureEnd::Stopped;
        }
        if config.max_duration.is_some_and(|d| start.elapsed() >= d) {
            break CaptureEnd::Duration;
        }
        if config
            .idle_timeout
            .is_some_and(|d| last_byte.elapsed() >= d)
        {
            break CaptureEnd::Idle;
        }
        let n = match source.read_bytes(&mut buf) {
            Ok(ReadOutcome::Data(n)) => n,
            Ok(ReadOutcome::TimedOut) => 0,
            Ok(ReadOutcome::Eof) => break CaptureEnd::EndOfSource,
            Err(TransportError::Vanished { path, source }) => {
                break CaptureEnd::Vanished(format!("{path}: {source}"));
            }
            Err(e) => {
                // Keep what we have on disk before giving up.
                sync(raw, &mut fsyncs)?;
                return Err(CaptureError::Transport(e));
            }
        };
        if n > 0 {
            last_byte = Instant::now();
            // The promise: bytes are on disk (in the file) before they are decoded.
            raw.write_all(&buf[..n]).map_err(CaptureError::Raw)?;
            dirty = true;
            bytes += n as u64;
            let before = rows.len();
            rows.extend(decoder.push(&buf[..n]));
            let mut run_ended = false;
            for r in &rows[before..] {
                if r.run < max_run || (r.run == 0 && max_run > 0) {
                    run_ended = true;
                }
                max_run = max_run.max(r.run);
            }
            if run_ended && dirty {
                sync(raw, &mut fsyncs)?;
                last_sync = Instant::now();
                dirty = false;
            }
        }
        if dirty && last_sync.elapsed() >= config.fsync_every {
            sync(raw, &mut fsyncs)?;
            last_sync = Instant::now();
            dirty = false;
        }
        if last_progress.elapsed() >= config.progress_every {
            last_progress = Instant::now();
            progress(&Progress {
                bytes,
                samples: rows.len() as u64,
                runs: max_run,
                elapsed_s: start.elapsed().as_secs_f64(),
                problems: problems(&decoder.stats()),
            });
        }
    };
    sync(raw, &mut fsyncs)?;
    rows.extend(decoder.finish());
    let stats = decoder.stats();
    progress(&Progress {
        bytes,
        samples: rows.len() as u64,
        runs: max_run,
        elapsed_s: start.elapsed().as_secs_f64(),
        problems: problems(&stats),
    });
    Ok(Capture {
        rows,
        stats,
        hello: decoder.hello().copied(),
        end,
        bytes,
        fsyncs,
    })
}
