//! Acquisition glue: the simulated device's model and plan files, serving it on a
//! pseudo-terminal, capturing a session directory, and replaying a raw capture. The
//! protocol, the capture loop and the simulated board live in `errmap-drivers`; this
//! module connects them to files and to errmap's error maps.
//!
//! A session directory written by `capture` holds:
//! - `raw.bin` — every byte read from the port, appended before decoding, fsynced at
//!   least once a second and at every run end;
//! - `session.csv` (or `.parquet`) — the session table, written as rows are decoded
//!   (see [`capture_session`]; `replay` of `raw.bin` rebuilds it exactly);
//! - `session.json` — the device's HELLO, the decoder statistics (spec shape, with the
//!   stream positions of the first problems), why the capture ended, bytes and fsyncs.

mod measure;
mod reduce;
mod table;

pub use measure::{StreamBench, peak_rss_mb, stream_bench};
pub use reduce::{BudgetInputs, ReduceError, Reduced, reduce_session, reduce_session_with};

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use errmap_drivers::capture::{
    CaptureConfig, CaptureEnd, Captured, Progress, RowSink, SinkError, capture_to,
};
use errmap_drivers::frame::Hello;
use errmap_drivers::{ByteSource, DecoderStats, SessionDecoder, SessionEvent};
use serde::Serialize;

use crate::base::io_err;
use crate::base::{ConfigError, FileError, FileOp};
use crate::session::SessionWriter;
use crate::table::TableError;

/// Errors of the acquisition glue (files and configuration; the capture's own errors are
/// wrapped).
#[derive(Debug, thiserror::Error)]
pub enum AcquireError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("{path}: {source}")]
    Capture {
        path: PathBuf,
        #[source]
        source: errmap_drivers::capture::CaptureError,
    },
    #[error("{path}: no valid frame in {bytes} bytes (is this a raw capture?)")]
    NoFrames { path: PathBuf, bytes: usize },
    /// The capture's raw file exists already (the CLI adds which flag names another).
    #[error("{path} already exists: a capture never overwrites an earlier one")]
    Exists { path: PathBuf },
}

// --------------------------------------------------------------------------------------
// Capture and replay

/// The session directory's JSON description.
#[derive(Debug, Serialize)]
pub struct SessionJson {
    pub hello: Option<HelloJson>,
    pub decoder: DecoderStats,
    pub end: CaptureEnd,
    pub bytes: u64,
    pub fsyncs: u64,
    pub raw: String,
    pub table: String,
}

/// HELLO fields in readable form.
#[derive(Debug, Serialize, serde::Deserialize)]
pub struct HelloJson {
    pub protocol_version: u8,
    pub device_id: String,
    pub grating_period_nm: u32,
    pub count_resolution_pm: u32,
    pub laser_wavelength_fm: u32,
    pub optical_fold: u8,
    pub edges_per_fringe: u8,
    pub axis: String,
}

impl From<&Hello> for HelloJson {
    fn from(h: &Hello) -> Self {
        HelloJson {
            protocol_version: h.protocol_version,
            device_id: h.device_id.as_string(),
            grating_period_nm: h.grating_period_nm,
            count_resolution_pm: h.count_resolution_pm,
            laser_wavelength_fm: h.laser_wavelength_fm,
            optical_fold: h.optical_fold,
            edges_per_fringe: h.edges_per_fringe,
            axis: match (
                h.axis(),
                errmap_drivers::rotary::RotaryAxis::from_code(h.axis_code),
            ) {
                (Some(a), _) => a.to_string(),
                (None, Some(r)) => r.to_string(),
                (None, None) => format!("code {}", h.axis_code),
            },
        }
    }
}

impl HelloJson {
    /// The HELLO these fields describe; `None` when the axis is not X, Y, Z, A, B or C.
    pub fn to_hello(&self) -> Option<Hello> {
        let mut h = Hello {
            protocol_version: self.protocol_version,
            device_id: errmap_drivers::frame::DeviceId::from_text(&self.device_id),
            grating_period_nm: self.grating_period_nm,
            count_resolution_pm: self.count_resolution_pm,
            laser_wavelength_fm: self.laser_wavelength_fm,
            optical_fold: self.optical_fold,
            edges_per_fringe: self.edges_per_fringe,
            axis_code: 0,
        };
        h.axis_code = (0..6u8).find(|&c| {
            let probe = Hello { axis_code: c, ..h };
            probe.axis().is_some_and(|a| a.to_string() == self.axis)
                || errmap_drivers::rotary::RotaryAxis::from_code(c)
                    .is_some_and(|a| a.as_str() == self.axis)
        })?;
        Some(h)
    }
}

/// The device description (`hello`) of an earlier capture's `session.json`, for
/// [`replay_with_hello`].
pub fn hello_from_session_json(path: &Path) -> Result<Hello, AcquireError> {
    #[derive(serde::Deserialize)]
    struct Partial {
        hello: Option<HelloJson>,
    }
    let bad = |message: String| AcquireError::from(ConfigError::file(path, message));
    let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Access))?;
    let p: Partial = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let json = p
        .hello
        .ok_or_else(|| bad("no `hello`: that capture had no device description either".into()))?;
    let hello = json.to_hello().ok_or_else(|| {
        bad(format!(
            "hello.axis `{}` is not X, Y, Z, A, B or C",
            json.axis
        ))
    })?;
    errmap_drivers::SessionDecoder::with_hello(hello).map_err(|e| bad(format!("hello: {e}")))?;
    Ok(hello)
}

/// The HELLO in the `session.json` beside the session table `session`, or in the capture
/// directory `session`; `None` without one.
fn session_hello(session: &Path) -> Option<HelloJson> {
    #[derive(serde::Deserialize)]
    struct Partial {
        hello: Option<HelloJson>,
    }
    let dir = if session.is_dir() {
        session
    } else {
        session.parent()?
    };
    let text = std::fs::read_to_string(dir.join("session.json")).ok()?;
    serde_json::from_str::<Partial>(&text).ok()?.hello
}

/// The resolutions of the reading chain a capture's `session.json` describes (its HELLO):
/// one laser count `λ_vac/(F·k)` and one scale count, µm, each with its source in words.
/// `session` is the session table or the capture directory; `None` when there is no
/// `session.json` beside it, or it has no `hello`.
pub fn device_resolutions(session: &Path) -> Option<Vec<crate::session::Resolution>> {
    use crate::session::Resolution;
    let h = session_hello(session)?;
    let counts = u32::from(h.optical_fold) * u32::from(h.edges_per_fringe);
    let mut out = Vec::new();
    if counts > 0 && h.laser_wavelength_fm > 0 {
        let lambda_nm = f64::from(h.laser_wavelength_fm) * 1e-6;
        out.push(Resolution {
            name: "laser count".into(),
            step_um: lambda_nm / f64::from(counts) * 1e-3,
            source: format!(
                "the device's HELLO: λ_vac/(F·k) = {lambda_nm} nm/({}·{})",
                h.optical_fold, h.edges_per_fringe
            ),
        });
    }
    if h.count_resolution_pm > 0 {
        out.push(Resolution {
            name: "scale count".into(),
            step_um: f64::from(h.count_resolution_pm) * 1e-6,
            source: format!(
                "the device's HELLO: scale count resolution {} pm",
                h.count_resolution_pm
            ),
        });
    }
    (!out.is_empty()).then_some(out)
}

/// One count of a rotary board's axis encoder and of its reference, ″ (from the HELLO in
/// the `session.json` beside `session`, or in the capture directory `session`); `None`
/// without one or when it is not a rotary HELLO.
pub fn rotary_count_arcsec(session: &Path) -> Option<(f64, f64)> {
    let h = session_hello(session)?.to_hello()?;
    let s = errmap_drivers::rotary::RotaryScaling::from_hello(&h)?.ok()?;
    Some((s.encoder_count_arcsec(), s.reference_count_arcsec()))
}

/// Where a capture writes.
#[derive(Debug, Clone)]
pub struct SessionPaths {
    pub dir: PathBuf,
    pub raw: PathBuf,
    pub table: PathBuf,
    pub json: PathBuf,
}

impl SessionPaths {
    /// `format` is the session table's extension: "csv" or "parquet".
    pub fn new(dir: &Path, format: &str) -> Self {
        SessionPaths {
            dir: dir.to_path_buf(),
            raw: dir.join("raw.bin"),
            table: dir.join(format!("session.{format}")),
            json: dir.join("session.json"),
        }
    }
}

/// Captures from `source` into a session directory (see the module docs). The raw file
/// must not exist yet. Returns the capture; the session table and JSON are written even
/// when the port vanished (the caller reports that as an error afterwards).
///
/// Rows go to the session table as they are decoded ([`SessionWriter`]): a CSV table is
/// written up to the last row at every fsync of the raw file (≤ 1 s), a Parquet table in
/// row groups of [`crate::session::BATCH_ROWS`] rows with its footer at the end. A killed
/// capture leaves the raw file (fsynced ≤ 1 s ago) and a CSV table valid up to its last
/// complete line or a Parquet table without its footer; `errmap replay raw.bin --out
/// session.parquet` rebuilds the table exactly, byte for byte.
pub fn capture_session(
    source: &mut dyn ByteSource,
    paths: &SessionPaths,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Captured, AcquireError> {
    capture_session_watched(source, paths, config, stop, progress, &mut |_| {})
}

/// [`capture_session`], showing `watch` every decoder event (rows, problems, HELLOs) just
/// before the session table gets the row: the live view is fed by the events the writer
/// consumes. `watch` runs on the reading thread and must not block.
pub fn capture_session_watched(
    source: &mut dyn ByteSource,
    paths: &SessionPaths,
    config: &CaptureConfig,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&Progress),
    watch: &mut dyn FnMut(&SessionEvent),
) -> Result<Captured, AcquireError> {
    std::fs::create_dir_all(&paths.dir).map_err(io_err(&paths.dir, FileOp::Access))?;
    let mut raw: File = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&paths.raw)
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::AlreadyExists {
                AcquireError::Exists {
                    path: paths.raw.clone(),
                }
            } else {
                io_err(&paths.raw, FileOp::Access)(e).into()
            }
        })?;
    let mut table = table::CaptureTable::create(&paths.table)?;
    let mut sink = Watched {
        writer: &mut table,
        watch,
    };
    let cap =
        capture_to(source, &mut raw, &mut sink, config, stop, progress).map_err(|source| {
            AcquireError::Capture {
                path: paths.raw.clone(),
                source,
            }
        })?;
    table.finish()?;
    write_json(
        &paths.json,
        &SessionJson {
            hello: cap.hello.as_ref().map(HelloJson::from),
            decoder: cap.stats.clone(),
            end: cap.end.clone(),
            bytes: cap.bytes,
            fsyncs: cap.fsyncs,
            raw: file_name(&paths.raw),
            table: file_name(&paths.table),
        },
    )?;
    Ok(cap)
}

impl RowSink for SessionWriter {
    fn row(&mut self, row: errmap_drivers::SessionRow) -> Result<(), SinkError> {
        self.push(row).map_err(Into::into)
    }

    fn flush(&mut self) -> Result<(), SinkError> {
        SessionWriter::flush(self).map_err(Into::into)
    }
}

/// The session writer with an onlooker: every event is shown to `watch`, the rows then go
/// to the writer.
struct Watched<'a> {
    writer: &'a mut table::CaptureTable,
    watch: &'a mut dyn FnMut(&SessionEvent),
}

impl RowSink for Watched<'_> {
    fn row(&mut self, row: errmap_drivers::SessionRow) -> Result<(), SinkError> {
        self.writer.linear(row).map_err(Into::into)
    }

    fn event(&mut self, event: SessionEvent) -> Result<(), SinkError> {
        (self.watch)(&event);
        self.writer.event(event).map_err(Into::into)
    }

    fn flush(&mut self) -> Result<(), SinkError> {
        self.writer.flush().map_err(Into::into)
    }
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), AcquireError> {
    let text =
        serde_json::to_string_pretty(value).map_err(|e| ConfigError::file(path, e.to_string()))?;
    // Whole or not at all: a temporary file beside it, renamed into place.
    crate::table::write_atomically::<AcquireError>(path, |f| {
        use std::io::Write;
        f.write_all((text + "\n").as_bytes())
            .map_err(|e| io_err(path, FileOp::Access)(e).into())
    })
}

/// Bytes read from a raw capture per decoder push, in [`replay`].
pub const REPLAY_CHUNK_BYTES: usize = 1 << 20;

/// What [`replay`] decoded.
#[derive(Debug, Clone)]
pub struct Replayed {
    pub rows: u64,
    pub stats: DecoderStats,
    pub hello: Option<Hello>,
}

/// Decodes a raw capture into a session table, streaming: the file is read
/// [`REPLAY_CHUNK_BYTES`] at a time into the [`SessionDecoder`] and its rows go to a
/// [`SessionWriter`] as they come, so memory is bounded by one chunk and one batch of rows
/// whatever the capture's length. A damaged capture is not an error: every decodable row
/// is written and the damage is in the statistics. Fails only when the file cannot be read
/// or holds no valid frame (the table is then removed).
pub fn replay(raw: &Path, out: &Path) -> Result<Replayed, AcquireError> {
    replay_with_hello(raw, out, None)
}

/// [`replay`], with the device description `hello` in force from the first byte when
/// given (from [`hello_from_session_json`]). Samples that no HELLO describes are counted
/// in `unconverted_samples` (the caller says so loudly). A capture whose samples no HELLO
/// describes is a damaged capture, not bad input (`docs/cli.md`): its table is
/// written with what could be converted — possibly nothing — and the count tells why.
pub fn replay_with_hello(
    raw: &Path,
    out: &Path,
    hello: Option<Hello>,
) -> Result<Replayed, AcquireError> {
    let mut decoder = match hello {
        None => SessionDecoder::new(),
        Some(h) => SessionDecoder::with_hello(h).map_err(|e| {
            ConfigError::file(raw, format!("the given HELLO gives no scaling: {e}"))
        })?,
    };
    let mut file = File::open(raw).map_err(io_err(raw, FileOp::Access))?;
    // The table goes to the temporary sibling of `out` (same extension, so the same
    // format) and is renamed into place only when whole: a failed replay leaves no
    // partial table and an existing one untouched.
    // A device or pipe (`--out /dev/stdout`) is written through: nothing to replace.
    let target = match crate::table::output_target(out)? {
        crate::table::OutputTarget::Through(p) => {
            return replay_into(&mut decoder, &mut file, raw, &p);
        }
        crate::table::OutputTarget::Atomic(p) => p,
    };
    let partial = crate::table::temporary(&target);
    let result = replay_into(&mut decoder, &mut file, raw, &partial);
    match result {
        Ok(r) => {
            std::fs::rename(&partial, &target).map_err(io_err(out, FileOp::Access))?;
            Ok(r)
        }
        Err(e) => {
            let _ = std::fs::remove_file(&partial);
            Err(e)
        }
    }
}

/// Decodes `file` into the table at `partial` (an error names that file, beside the
/// intended output).
fn replay_into(
    decoder: &mut SessionDecoder,
    file: &mut File,
    raw: &Path,
    partial: &Path,
) -> Result<Replayed, AcquireError> {
    let mut writer = table::CaptureTable::create(partial)?;
    let mut buf = vec![0u8; REPLAY_CHUNK_BYTES];
    let mut failed: Option<AcquireError> = None;
    let mut bytes = 0usize;
    let mut sink = |e: SessionEvent| {
        if failed.is_none()
            && let Err(e) = writer.event(e)
        {
            failed = Some(e);
        }
    };
    loop {
        let n = match file.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(io_err(raw, FileOp::Access)(e).into()),
        };
        bytes += n;
        decoder.push_with(&buf[..n], &mut sink);
    }
    decoder.finish_with(&mut sink);
    if let Some(e) = failed {
        return Err(e);
    }
    let stats = decoder.stats();
    if stats.frames.total() == 0 {
        drop(writer);
        return Err(AcquireError::NoFrames {
            path: raw.to_path_buf(),
            bytes,
        });
    }
    let rows = writer.finish()?;
    Ok(Replayed {
        rows,
        stats,
        hello: decoder.hello().copied(),
    })
}
