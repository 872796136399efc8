//! Live capture: every byte read from the source is appended to the raw capture file
//! *before* it is decoded, the file is flushed to disk (fsync) at least once a second and
//! whenever a run ends, and the same sans-IO [`SessionDecoder`] that replay uses turns the
//! bytes into session rows. So a crash loses at most the bytes of the last second, and
//! `replay` of the raw file gives exactly the rows capture produced.
//!
//! The capture ends when the source ends (a file), the host asks it to stop (Ctrl-C sets
//! the stop flag), no byte arrives for the idle timeout, the duration limit passes, or the
//! port closes. A port the board closes after its last run ended (no run open) is the
//! ordinary end of a capture, [`CaptureEnd::Closed`]. A port that vanishes inside a run,
//! or before any run ended, is [`CaptureEnd::Vanished`] with everything received so far:
//! the caller writes a valid session and then reports the error.
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
use crate::rotary::RotaryRow;
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
    /// The board closed the port after its last run ended (no run open): a complete
    /// capture.
    Closed {
        /// Runs the board closed with a run-end MARK.
        runs: u32,
    },
    /// The port went away inside a run (or before any run ended).
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
            SessionEvent::Rotary(r) => self.rotary_row(r),
            _ => Ok(()),
        }
    }
    /// One decoded rotary row (a rotary board: [`crate::rotary`]). The default refuses
    /// it: a sink that writes linear session tables cannot hold it.
    fn rotary_row(&mut self, row: RotaryRow) -> Result<(), SinkError> {
        Err(format!(
            "sample {}: a rotary row (axis {}) for a sink that holds linear session rows only",
            row.sample, row.axis
        )
        .into())
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
    let mut run = CaptureRun::new(raw, sink, config);
    let mut buf = vec![0u8; config.read_buf.max(1)];
    let end = loop {
        if let Some(end) = run.limit_reached(stop) {
            break end;
        }
        let n = match source.read_bytes(&mut buf) {
            Ok(ReadOutcome::Data(n)) => n,
            Ok(ReadOutcome::TimedOut) => 0,
            Ok(ReadOutcome::Eof) => break CaptureEnd::EndOfSource,
            Err(TransportError::Vanished { path, source }) => break run.port_gone(path, source),
            Err(e) => {
                // Keep what we have on disk before giving up.
                run.sync()?;
                return Err(CaptureError::Transport(e));
            }
        };
        if n > 0 {
            run.take(&buf[..n])?;
        }
        run.ask_hello_once(source);
        run.sync_when_due()?;
        run.report(progress, false);
    };
    run.finish(end, progress)
}

/// The state of one capture between reads: the decoder, the counters and the clocks.
struct CaptureRun<'a> {
    raw: &'a mut File,
    sink: &'a mut dyn RowSink,
    config: &'a CaptureConfig,
    decoder: SessionDecoder,
    start: Instant,
    last_sync: Instant,
    last_byte: Instant,
    last_progress: Instant,
    rows: u64,
    bytes: u64,
    fsyncs: u64,
    max_run: u32,
    dirty: bool,
    hello_asked: bool,
    failed: Option<SinkError>,
}

impl<'a> CaptureRun<'a> {
    fn new(raw: &'a mut File, sink: &'a mut dyn RowSink, config: &'a CaptureConfig) -> Self {
        let now = Instant::now();
        CaptureRun {
            raw,
            sink,
            config,
            decoder: SessionDecoder::new(),
            start: now,
            last_sync: now,
            last_byte: now,
            last_progress: now,
            rows: 0,
            bytes: 0,
            fsyncs: 0,
            max_run: 0,
            dirty: false,
            hello_asked: false,
            failed: None,
        }
    }

    /// The stop flag, the duration limit and the idle timeout, in that order.
    fn limit_reached(&self, stop: &AtomicBool) -> Option<CaptureEnd> {
        if stop.load(Ordering::Relaxed) {
            return Some(CaptureEnd::Stopped);
        }
        if self
            .config
            .max_duration
            .is_some_and(|d| self.start.elapsed() >= d)
        {
            return Some(CaptureEnd::Duration);
        }
        if self
            .config
            .idle_timeout
            .is_some_and(|d| self.last_byte.elapsed() >= d)
        {
            return Some(CaptureEnd::Idle);
        }
        None
    }

    /// The port went away: the board closing it after its last run ended is the end of a
    /// complete capture; a port lost inside a run (or before any run ended) is not.
    fn port_gone(&self, path: String, source: std::io::Error) -> CaptureEnd {
        let b = self.decoder.builder();
        if !b.run_open() && b.runs_ended() > 0 {
            CaptureEnd::Closed {
                runs: b.runs_ended(),
            }
        } else {
            CaptureEnd::Vanished(format!("{path}: {source}"))
        }
    }

    /// Bytes read: on disk first, then decoded; a run's end syncs the file.
    fn take(&mut self, bytes: &[u8]) -> Result<(), CaptureError> {
        self.last_byte = Instant::now();
        // The promise: bytes are on disk (in the file) before they are decoded.
        self.raw.write_all(bytes).map_err(CaptureError::Raw)?;
        self.dirty = true;
        self.bytes += bytes.len() as u64;
        let mut run_ended = false;
        let (max_run, rows, failed, sink) = (
            &mut self.max_run,
            &mut self.rows,
            &mut self.failed,
            &mut *self.sink,
        );
        self.decoder.push_with(bytes, &mut |e| {
            if let Some(run) = e.row_run() {
                if run < *max_run || (run == 0 && *max_run > 0) {
                    run_ended = true;
                }
                *max_run = (*max_run).max(run);
                *rows += 1;
            }
            if failed.is_none()
                && let Err(e) = sink.event(e)
            {
                *failed = Some(e);
            }
        });
        if let Some(e) = self.failed.take() {
            self.sync()?;
            return Err(CaptureError::Rows(e));
        }
        if run_ended && self.dirty {
            self.sync()?;
        }
        Ok(())
    }

    /// Asks once for a HELLO when none usable has come after [`HELLO_WAIT`].
    fn ask_hello_once(&mut self, source: &mut dyn ByteSource) {
        if !self.hello_asked
            && self.start.elapsed() >= HELLO_WAIT
            && !self.decoder.builder().converts()
        {
            self.hello_asked = true;
            // Best effort: a port that takes no bytes still gives what it sends.
            let _ = source.send(HELLO_REQUEST);
        }
    }

    fn sync_when_due(&mut self) -> Result<(), CaptureError> {
        if self.dirty && self.last_sync.elapsed() >= self.config.fsync_every {
            self.sync()?;
        }
        Ok(())
    }

    /// The raw file to disk, then the sink's flush.
    fn sync(&mut self) -> Result<(), CaptureError> {
        self.raw.flush().map_err(CaptureError::Raw)?;
        self.raw.sync_data().map_err(CaptureError::Raw)?;
        self.fsyncs += 1;
        self.last_sync = Instant::now();
        self.dirty = false;
        self.sink.flush().map_err(CaptureError::Rows)
    }

    fn report(&mut self, progress: &mut dyn FnMut(&Progress), now: bool) {
        if now || self.last_progress.elapsed() >= self.config.progress_every {
            self.last_progress = Instant::now();
            progress(&Progress {
                bytes: self.bytes,
                samples: self.rows,
                runs: self.max_run,
                elapsed_s: self.start.elapsed().as_secs_f64(),
                problems: problems(&self.decoder.stats()),
            });
        }
    }

    /// The decoder's tail, the last sync and the last progress report.
    fn finish(
        mut self,
        end: CaptureEnd,
        progress: &mut dyn FnMut(&Progress),
    ) -> Result<Captured, CaptureError> {
        let (rows, failed, sink) = (&mut self.rows, &mut self.failed, &mut *self.sink);
        self.decoder.finish_with(&mut |e| {
            if e.row_run().is_some() {
                *rows += 1;
            }
            if failed.is_none()
                && let Err(e) = sink.event(e)
            {
                *failed = Some(e);
            }
        });
        self.sync()?;
        if let Some(e) = self.failed.take() {
            return Err(CaptureError::Rows(e));
        }
        self.report(progress, true);
        Ok(Captured {
            rows: self.rows,
            stats: self.decoder.stats(),
            hello: self.decoder.hello().copied(),
            end,
            bytes: self.bytes,
            fsyncs: self.fsyncs,
        })
    }
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

    /// A capture from `source` into a raw file in the temp folder (removed after).
    fn capture_into_temp(
        source: &mut dyn ByteSource,
        config: &CaptureConfig,
        name: &str,
    ) -> Capture {
        let raw_path =
            std::env::temp_dir().join(format!("errmap-{name}-{}.bin", std::process::id()));
        let mut raw = File::create(&raw_path).expect("raw");
        let cap = capture(
            source,
            &mut raw,
            config,
            &AtomicBool::new(false),
            &mut |_| {},
        )
        .expect("captures");
        let _ = std::fs::remove_file(&raw_path);
        cap
    }

    /// The simulated stream of `runs` runs over targets 0 and 50 mm, no error.
    fn two_target_stream(runs: u32) -> crate::sim::SimStream {
        let plan = Plan {
            targets_mm: vec![0.0, 50.0],
            runs,
            dwell_s: 0.1,
            ..Plan::default()
        };
        simulate(&plan, &Device::default(), &Faults::default(), &mut Zero).expect("simulates")
    }

    #[test]
    fn a_capture_without_hello_asks_for_one_and_converts_every_sample() {
        let stream = two_target_stream(1);
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
        let config = CaptureConfig {
            read_buf: body.len() + 64,
            idle_timeout: Some(Duration::from_secs(10)),
            ..CaptureConfig::default()
        };
        let cap = capture_into_temp(&mut device, &config, "late-hello");
        assert_eq!(device.asked, HELLO_REQUEST, "asked once for a HELLO");
        assert_eq!(cap.rows.len(), samples, "every sample converted");
        assert_eq!(cap.stats.unconverted_samples, 0);
        // Without the answer the same bytes leave every sample unconverted, counted.
        let (rows, stats, _) = crate::decode_all(&body);
        assert!(rows.is_empty());
        assert_eq!(stats.unconverted_samples, samples as u64);
    }

    /// Hands its bytes over in one read, then reports the port gone.
    struct Closing(Option<Vec<u8>>);

    impl ByteSource for Closing {
        fn read_bytes(&mut self, buf: &mut [u8]) -> Result<ReadOutcome, TransportError> {
            match self.0.take() {
                Some(b) => {
                    buf[..b.len()].copy_from_slice(&b);
                    Ok(ReadOutcome::Data(b.len()))
                }
                None => Err(TransportError::Vanished {
                    path: "/dev/pts/test".into(),
                    source: std::io::Error::from_raw_os_error(5),
                }),
            }
        }
    }

    fn end_after(bytes: Vec<u8>) -> CaptureEnd {
        let config = CaptureConfig {
            read_buf: bytes.len() + 64,
            ..CaptureConfig::default()
        };
        let name = format!("closing-{}", bytes.len());
        capture_into_temp(&mut Closing(Some(bytes)), &config, &name).end
    }

    #[test]
    fn a_port_closed_after_the_last_run_ended_is_complete_and_inside_a_run_vanished() {
        let stream = two_target_stream(2);
        let all: Vec<u8> = stream.frames.iter().flat_map(|f| f.bytes.clone()).collect();
        assert_eq!(end_after(all.clone()), CaptureEnd::Closed { runs: 2 });
        // Cut in the middle of the second run: the port vanished.
        let half: Vec<u8> = stream.frames[..stream.frames.len() * 3 / 4]
            .iter()
            .flat_map(|f| f.bytes.clone())
            .collect();
        assert!(matches!(end_after(half), CaptureEnd::Vanished(_)));
        // Before any run ended (the HELLO alone): vanished too.
        let hello = stream.frames[0].bytes.clone();
        assert!(matches!(end_after(hello), CaptureEnd::Vanished(_)));
    }
}
