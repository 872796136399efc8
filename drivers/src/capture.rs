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
//!
//! A capture that started after the device's power-up has no HELLO, and without one no
//! SAMPLE can be converted. So when no usable HELLO has arrived [`HELLO_WAIT`] after the
//! start, the capture sends the protocol's `?` once (`docs/wire-protocol.md`: the board
//! sends a HELLO at power-up and whenever the host sends `?`); the rows held back are converted when
//! the HELLO comes. A source that cannot be written (a file) ignores the request.
//!
//! [`capture_to`] hands each decoder event (rows, and the problems a live view shows) to a
//! [`RowSink`] as it is decoded and asks the sink to flush with every fsync of the raw file, so a capture's memory does not grow with its
//! length; [`capture`] collects the rows in a vector (tests, short captures).

use std::fs::File;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::frame::Hello;
use crate::session::{SessionDecoder, SessionEvent, SessionRow};
use crate::stats::DecoderStats;
use crate::transport::{ByteSource, ReadOutcome, TransportError};

/// How long a capture waits for a usable HELLO before asking for one with `?`.
pub const HELLO_WAIT: Duration = Duration::from_secs(1);

/// The host's request for a HELLO (`docs/wire-protocol.md`).
pub const HELLO_REQUEST: &[u8] = b"?";

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

/// Where [`capture_to`] puts the rows as they are decoded.
pub trait RowSink {
    /// One decoded row.
    fn row(&mut self, row: SessionRow) -> Result<(), SinkError>;
    /// Every decoder event in stream order: rows, problems, HELLOs, TEXT lines. The
    /// default hands the rows to [`RowSink::row`] and drops the rest; a sink that also
    /// watches the decoder's health (the live view) overrides it.
    fn event(&mut self, event: SessionEvent) -> Result<(), SinkError> {
        match event {
            SessionEvent::Row(r) => self.row(r),
            _ => Ok(()),
        }
    }
    /// Called with every fsync of the raw file (at least every
    /// [`CaptureConfig::fsync_every`] while bytes arrive, at every run end, at the end).
    fn flush(&mut self) -> Result<(), SinkError> {
        Ok(())
    }
}

/// A sink's error, kept whole for the caller.
pub type SinkError = Box<dyn std::error::Error + Send + Sync>;

impl RowSink for Vec<SessionRow> {
    fn row(&mut self, row: SessionRow) -> Result<(), SinkError> {
        self.push(row);
        Ok(())
    }
}

/// What [`capture_to`] produced (the rows went to the sink).
#[derive(Debug, Clone)]
pub struct Captured {
    pub rows: u64,
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
    /// The row sink failed (the session table cannot be written); the raw file is synced.
    #[error("cannot write the session table: {0}")]
    Rows(#[source] SinkError),
    #[error(transparent)]
    Transport(TransportError),
}

fn problems(s: &DecoderStats) -> u64 {
    s.crc_failures + s.resyncs + s.seq_gaps + s.flagged_samples
}

/// Runs a capture from `source` into `raw`, collecting the rows (see the module docs).
pub fn capture(
    source: &mut dyn ByteSource,
    raw: &mut File,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Capture, CaptureError> {
    let mut rows = Vec::new();
    let c = capture_to(source, raw, &mut rows, config, stop, progress)?;
    Ok(Capture {
        rows,
        stats: c.stats,
        hello: c.hello,
        end: c.end,
        bytes: c.bytes,
        fsyncs: c.fsyncs,
    })
}

/// Runs a capture from `source` into `raw`, handing the rows to `sink` as they are
/// decoded (see the module docs).
pub fn capture_to(
    source: &mut dyn ByteSource,
    raw: &mut File,
    sink: &mut dyn RowSink,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Captured, CaptureError> {
    let start = Instant::now();
    let mut decoder = SessionDecoder::new();
    let mut n_rows = 0u64;
    let mut failed: Option<SinkError> = None;
    let mut buf = vec![0u8; config.read_buf.max(1)];
    let (mut bytes, mut fsyncs) = (0u64, 0u64);
    let mut last_sync = Instant::now();
    let mut last_byte = Instant::now();
    let mut last_progress = Instant::now();
    let mut dirty = false;
    let mut max_run = 0u32;
    let mut hello_asked = false;
    let sync =
        |raw: &mut File, sink: &mut dyn RowSink, fsyncs: &mut u64| -> Result<(), CaptureError> {
            raw.flush().map_err(CaptureError::Raw)?;
            raw.sync_data().map_err(CaptureError::Raw)?;
            *fsyncs += 1;
            sink.flush().map_err(CaptureError::Rows)
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
                sync(raw, sink, &mut fsyncs)?;
                return Err(CaptureError::Transport(e));
            }
        };
        if n > 0 {
            last_byte = Instant::now();
            // The promise: bytes are on disk (in the file) before they are decoded.
            raw.write_all(&buf[..n]).map_err(CaptureError::Raw)?;
            dirty = true;
            bytes += n as u64;
            let mut run_ended = false;
            decoder.push_with(&buf[..n], &mut |e| {
                if let SessionEvent::Row(r) = &e {
                    if r.run < max_run || (r.run == 0 && max_run > 0) {
                        run_ended = true;
                    }
                    max_run = max_run.max(r.run);
                    n_rows += 1;
                }
                if failed.is_none()
                    && let Err(e) = sink.event(e)
                {
                    failed = Some(e);
                }
            });
            if let Some(e) = failed.take() {
                sync(raw, sink, &mut fsyncs)?;
                return Err(CaptureError::Rows(e));
            }
            if run_ended && dirty {
                sync(raw, sink, &mut fsyncs)?;
                last_sync = Instant::now();
                dirty = false;
            }
        }
        if !hello_asked && start.elapsed() >= HELLO_WAIT && decoder.builder().scaling().is_none() {
            hello_asked = true;
            // Best effort: a port that takes no bytes still gives what it sends.
            let _ = source.send(HELLO_REQUEST);
        }
        if dirty && last_sync.elapsed() >= config.fsync_every {
            sync(raw, sink, &mut fsyncs)?;
            last_sync = Instant::now();
            dirty = false;
        }
        if last_progress.elapsed() >= config.progress_every {
            last_progress = Instant::now();
            progress(&Progress {
                bytes,
                samples: n_rows,
                runs: max_run,
                elapsed_s: start.elapsed().as_secs_f64(),
                problems: problems(&decoder.stats()),
            });
        }
    };
    decoder.finish_with(&mut |e| {
        if matches!(e, SessionEvent::Row(_)) {
            n_rows += 1;
        }
        if failed.is_none()
            && let Err(e) = sink.event(e)
        {
            failed = Some(e);
        }
    });
    sync(raw, sink, &mut fsyncs)?;
    if let Some(e) = failed {
        return Err(CaptureError::Rows(e));
    }
    let stats = decoder.stats();
    progress(&Progress {
        bytes,
        samples: n_rows,
        runs: max_run,
        elapsed_s: start.elapsed().as_secs_f64(),
        problems: problems(&stats),
    });
    Ok(Captured {
        rows: n_rows,
        stats,
        hello: decoder.hello().copied(),
        end,
        bytes,
        fsyncs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Device, Faults, Plan, Truth, TruthQuery, simulate};

    struct Zero;
    impl Truth for Zero {
        fn error_um(&mut self, _q: &TruthQuery) -> f64 {
            0.0
        }
    }

    /// A device that was powered up before the capture: it sends its frames without the
    /// HELLO, then the HELLO once it receives `?`, then ends.
    struct LateDevice {
        body: Option<Vec<u8>>,
        hello: Vec<u8>,
        asked: Vec<u8>,
        answered: bool,
    }

    impl ByteSource for LateDevice {
        fn read_bytes(&mut self, buf: &mut [u8]) -> Result<ReadOutcome, TransportError> {
            if let Some(body) = self.body.take() {
                buf[..body.len()].copy_from_slice(&body);
                return Ok(ReadOutcome::Data(body.len()));
            }
            if self.asked == HELLO_REQUEST && !self.answered {
                self.answered = true;
                buf[..self.hello.len()].copy_from_slice(&self.hello);
                return Ok(ReadOutcome::Data(self.hello.len()));
            }
            if self.answered {
                return Ok(ReadOutcome::Eof);
            }
            std::thread::sleep(Duration::from_millis(20));
            Ok(ReadOutcome::TimedOut)
        }

        fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
            self.asked.extend_from_slice(bytes);
            Ok(())
        }
    }

    #[test]
    fn a_capture_without_hello_asks_for_one_and_converts_every_sample() {
        let plan = Plan {
            targets_mm: vec![0.0, 50.0],
            runs: 1,
            dwell_s: 0.1,
            ..Plan::default()
        };
        let stream =
            simulate(&plan, &Device::default(), &Faults::default(), &mut Zero).expect("simulates");
        let body: Vec<u8> = stream.frames[1..]
            .iter()
            .flat_map(|f| f.bytes.clone())
            .collect();
        let samples = stream.truth.iter().filter(|t| t.sent).count();
        let mut device = LateDevice {
            body: Some(body.clone()),
            hello: stream.frames[0].bytes.clone(),
            asked: Vec::new(),
            answered: false,
        };
        let raw_path =
            std::env::temp_dir().join(format!("errmap-late-hello-{}.bin", std::process::id()));
        let mut raw = File::create(&raw_path).expect("raw");
        let config = CaptureConfig {
            read_buf: body.len() + 64,
            idle_timeout: Some(Duration::from_secs(10)),
            ..CaptureConfig::default()
        };
        let cap = capture(
            &mut device,
            &mut raw,
            &config,
            &AtomicBool::new(false),
            &mut |_| {},
        )
        .expect("captures");
        let _ = std::fs::remove_file(&raw_path);
        assert_eq!(device.asked, HELLO_REQUEST, "asked once for a HELLO");
        assert_eq!(cap.rows.len(), samples, "every sample converted");
        assert_eq!(cap.stats.unconverted_samples, 0);
        // Without the answer the same bytes leave every sample unconverted, counted.
        let (rows, stats, _) = crate::decode_all(&body);
        assert!(rows.is_empty());
        assert_eq!(stats.unconverted_samples, samples as u64);
    }
}
