//! The live capture: one at a time, from a serial port or from a simulated board (a
//! machine model and plan of the workspace served on a pseudo-terminal, as `errmap
//! capture --simulate` does), into a new session folder of the workspace, through
//! `acquire::capture_session_watched`: the raw bytes are written first, then decoded.
//!
//! The reading thread never waits for a reader of the page: it keeps its own snapshot and
//! hands a copy to the shared one at most ten times a second, only when nobody holds it
//! (`try_lock`). The event stream reads the shared copy four times a second.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use errmap_drivers::SessionEvent;
use errmap_drivers::capture::{CaptureConfig, CaptureEnd, Progress};
use serde::{Deserialize, Serialize};

use super::items::{Workspace, WorkspaceError};

/// How the page asks for a capture (`POST /api/live/start`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct StartRequest {
    /// A serial port (a character device, e.g. `/dev/ttyUSB0`).
    pub port: Option<String>,
    /// The simulated board's machine model and plan: items of the workspace.
    pub model: Option<String>,
    pub plan: Option<String>,
    /// The simulated board's speed (× real time; default 1).
    pub speed: Option<f64>,
    /// Line speed of a serial port, baud (default 115 200).
    pub baud: Option<u32>,
}

/// The error at one target in one pass: the mean of its dwell samples so far. A linear
/// axis' in mm and µm, a rotary axis' in ° and ″ (the other pair is left out).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub(crate) struct TargetRow {
    pub run: u32,
    pub direction: i8,
    pub target: i32,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_um: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_arcsec: Option<f64>,
    pub n: u64,
}

impl TargetRow {
    fn new(run: u32, direction: i8, target: i32, reading: Reading) -> TargetRow {
        let (pos, err) = (Some(reading.position), Some(reading.error));
        let mut row = TargetRow {
            run,
            direction,
            target,
            position_mm: None,
            error_um: None,
            position_deg: None,
            error_arcsec: None,
            n: 1,
        };
        if reading.rotary {
            (row.position_deg, row.error_arcsec) = (pos, err);
        } else {
            (row.position_mm, row.error_um) = (pos, err);
        }
        row
    }

    /// Adds one dwell sample to the running means.
    fn push(&mut self, reading: Reading) {
        self.n += 1;
        let n = self.n as f64;
        let (pos, err) = if reading.rotary {
            (&mut self.position_deg, &mut self.error_arcsec)
        } else {
            (&mut self.position_mm, &mut self.error_um)
        };
        for (mean, v) in [(pos, reading.position), (err, reading.error)] {
            if let Some(m) = mean {
                *m += (v - *m) / n;
            }
        }
    }
}

/// One dwell sample: a linear axis' position (mm) and error (µm), or a rotary axis'
/// angle (°) and error (″).
#[derive(Debug, Clone, Copy)]
struct Reading {
    rotary: bool,
    position: f64,
    error: f64,
}

/// What the page shows of a capture (one Server-Sent Event).
#[derive(Debug, Clone, Serialize, Default)]
pub(crate) struct Snapshot {
    /// `idle`, `running`, `complete` (the capture ended and its files are whole) or `failed`.
    pub state: &'static str,
    /// The session folder, relative to the workspace.
    pub session: Option<String>,
    pub source: Option<String>,
    pub bytes: u64,
    pub samples: u64,
    pub run: Option<u32>,
    pub target: Option<i32>,
    pub position_mm: Option<f64>,
    pub error_um: Option<f64>,
    /// A rotary board's axis (A, B or C); its readings are `angle_deg` and `error_arcsec`
    /// and its target rows in ° and ″.
    pub rotary_axis: Option<String>,
    /// The rotary axis' indicated angle, °.
    pub angle_deg: Option<f64>,
    /// The rotary axis' error (indicated − reference), ″.
    pub error_arcsec: Option<f64>,
    pub elapsed_s: f64,
    pub crc_failures: u64,
    pub resyncs: u64,
    pub seq_gaps: u64,
    pub flagged: u64,
    /// Problems by kind so far.
    pub problems: BTreeMap<String, u64>,
    /// The last targets (at most [`MAX_TARGET_ROWS`]), in the order reached.
    pub targets: Vec<TargetRow>,
    /// Why the capture ended, when it has.
    pub end: Option<String>,
    pub error: Option<String>,
    /// Events sent on this stream (set by the stream).
    pub updates: u64,
}

/// The most target rows a snapshot carries.
pub(crate) const MAX_TARGET_ROWS: usize = 400;

struct Running {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<()>,
    session: String,
}

/// The workbench's one capture slot and the snapshot readers see.
#[derive(Default)]
pub(crate) struct Live {
    running: Mutex<Option<Running>>,
    shared: Arc<Mutex<Snapshot>>,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Live")
    }
}

/// Why a capture could not be started, stopped or run.
#[derive(Debug, thiserror::Error)]
pub(crate) enum LiveError {
    /// One capture at a time (409).
    #[error("a capture is running into {0}")]
    Busy(String),
    /// Stop with nothing running (409).
    #[error("no capture is running")]
    Idle,
    /// The request names neither a port nor a model and plan (400).
    #[error("give {{\"port\": PATH}} or {{\"model\": ITEM, \"plan\": ITEM}}")]
    NoSource,
    /// The port named cannot be looked at (400).
    #[error("{port}: {source}")]
    Port {
        port: String,
        #[source]
        source: std::io::Error,
    },
    /// The port named is not a character device (400).
    #[error("{0}: not a serial port (a character device)")]
    NotSerial(String),
    /// A model or plan that is not an item of the workspace (400).
    #[error(transparent)]
    Item(#[from] WorkspaceError),
    /// A simulated board's speed out of range (400).
    #[error("speed {0}: between 0.01 and 1000 × real time")]
    Speed(f64),
    /// The model and plan cannot be simulated (400: the command's message).
    #[error(transparent)]
    Simulate(#[from] errmap::sim::SimError),
    /// The session folder cannot be made (500).
    #[error("{path}: {source}")]
    Folder {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A thousand capture folders in the same second (500).
    #[error("{0}: no free session folder name")]
    NoFreeFolder(PathBuf),
    /// The simulated board's pseudo-terminal pair (500).
    #[error("cannot open a pseudo-terminal pair: {0}")]
    Pty(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// The port cannot be opened.
    #[error("{port}: {source}")]
    Open {
        port: String,
        #[source]
        source: errmap_drivers::transport::TransportError,
    },
    /// The capture failed (what it received is on disk).
    #[error(transparent)]
    Capture(#[from] errmap::acquire::AcquireError),
    /// A lock held by a thread that panicked (500).
    #[error("the live capture's state was poisoned")]
    Poisoned,
}

impl LiveError {
    /// The HTTP status a refusal is answered with.
    pub(crate) fn status(&self) -> u16 {
        match self {
            LiveError::Busy(_) | LiveError::Idle => 409,
            LiveError::NoSource
            | LiveError::Port { .. }
            | LiveError::NotSerial(_)
            | LiveError::Item(_)
            | LiveError::Speed(_)
            | LiveError::Simulate(_) => 400,
            _ => 500,
        }
    }
}

impl Live {
    /// A copy of the latest snapshot.
    pub(crate) fn snapshot(&self) -> Snapshot {
        let mut s = self.shared.lock().map(|g| g.clone()).unwrap_or_default();
        if s.state.is_empty() {
            s.state = "idle";
        }
        s
    }

    /// Starts a capture into a new session folder of the workspace; its id.
    pub(crate) fn start(&self, ws: &Workspace, req: StartRequest) -> Result<String, LiveError> {
        let mut slot = self.running.lock().map_err(|_| LiveError::Poisoned)?;
        if let Some(r) = slot.as_ref()
            && !r.thread.is_finished()
        {
            return Err(LiveError::Busy(r.session.clone()));
        }
        let source = Source::from_request(ws, &req)?;
        let dir = new_session_dir(ws.root())?;
        let session = ws.id_of(&dir);
        let stop = Arc::new(AtomicBool::new(false));
        let shared = Arc::clone(&self.shared);
        if let Ok(mut g) = shared.lock() {
            *g = Snapshot {
                state: "running",
                session: Some(session.clone()),
                source: Some(source.describe()),
                ..Snapshot::default()
            };
        }
        let (stop2, session2) = (Arc::clone(&stop), session.clone());
        let thread = std::thread::spawn(move || {
            let result = source.capture(&dir, &stop2, &shared);
            if let Ok(mut g) = shared.lock() {
                g.session = Some(session2);
                match result {
                    Ok(end) => {
                        g.state = "complete";
                        g.end = Some(end);
                    }
                    Err(e) => {
                        g.state = "failed";
                        g.error = Some(super::docs::message(&e));
                    }
                }
            }
        });
        *slot = Some(Running {
            stop,
            thread,
            session: session.clone(),
        });
        Ok(session)
    }

    /// Stops the capture and waits until its files are whole; its session id.
    pub(crate) fn stop(&self) -> Result<String, LiveError> {
        let running = self.running.lock().map_err(|_| LiveError::Poisoned)?.take();
        let Some(r) = running else {
            return Err(LiveError::Idle);
        };
        r.stop.store(true, Ordering::SeqCst);
        let _ = r.thread.join();
        Ok(r.session)
    }
}

/// A new folder `live/capture-YYYYMMDDTHHMMSSZ[-N]` (created here, so no other start
/// can take it).
fn new_session_dir(root: &Path) -> Result<PathBuf, LiveError> {
    let base = root.join("live");
    std::fs::create_dir_all(&base).map_err(|source| LiveError::Folder {
        path: base.clone(),
        source,
    })?;
    let now = errmap::history::now_utc();
    let stamp: String = errmap::history::format_utc(now)
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect();
    for k in 0..1000 {
        let name = if k == 0 {
            format!("capture-{stamp}")
        } else {
            format!("capture-{stamp}-{k}")
        };
        let dir = base.join(name);
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(source) => return Err(LiveError::Folder { path: dir, source }),
        }
    }
    Err(LiveError::NoFreeFolder(base))
}

enum Source {
    Port {
        path: String,
        baud: u32,
    },
    Simulated {
        stream: Box<errmap_drivers::sim::SimStream>,
        speed: f64,
        what: String,
    },
}

impl Source {
    fn from_request(ws: &Workspace, req: &StartRequest) -> Result<Source, LiveError> {
        match (&req.port, &req.model, &req.plan) {
            (Some(port), None, None) => {
                let meta = std::fs::metadata(port).map_err(|source| LiveError::Port {
                    port: port.clone(),
                    source,
                })?;
                if !is_char_device(&meta) {
                    return Err(LiveError::NotSerial(port.clone()));
                }
                Ok(Source::Port {
                    path: port.clone(),
                    baud: req.baud.unwrap_or(115_200),
                })
            }
            (None, Some(model), Some(plan)) => {
                let m = ws.resolve(model)?;
                let p = ws.resolve(plan)?;
                let speed = req.speed.unwrap_or(1.0);
                if !(speed.is_finite() && (0.01..=1000.0).contains(&speed)) {
                    return Err(LiveError::Speed(speed));
                }
                let stream = if errmap::sim::is_rotary_model(&m) {
                    errmap::sim::simulate_rotary_stream(&m, Some(&p))?
                } else {
                    errmap::sim::simulate_stream(&m, Some(&p), &Default::default())?.0
                };
                Ok(Source::Simulated {
                    stream: Box::new(stream),
                    speed,
                    what: format!("simulated board ({model}, {plan}, {speed}× real time)"),
                })
            }
            _ => Err(LiveError::NoSource),
        }
    }

    fn describe(&self) -> String {
        match self {
            Source::Port { path, baud } => format!("{path} at {baud} baud"),
            Source::Simulated { what, .. } => what.clone(),
        }
    }

    /// Captures into `dir` until the source ends or `stop`; why it ended.
    fn capture(
        self,
        dir: &Path,
        stop: &Arc<AtomicBool>,
        shared: &Arc<Mutex<Snapshot>>,
    ) -> Result<String, LiveError> {
        match self {
            Source::Port { path, baud } => capture_port(&path, baud, dir, stop, shared),
            Source::Simulated { stream, speed, .. } => {
                let (mut master, _slave, port) =
                    errmap_drivers::serve::pty_pair().map_err(|e| LiveError::Pty(Box::new(e)))?;
                let stop_board = Arc::clone(stop);
                let board = std::thread::spawn(move || {
                    let r = errmap_drivers::serve::serve_paced(
                        &stream.frames,
                        &mut master,
                        speed,
                        &stop_board,
                        Some(Duration::from_secs(30)),
                    );
                    // Linger so the host reads the last frames before the port closes.
                    std::thread::sleep(Duration::from_millis(1500));
                    r
                });
                let r = capture_port(&port, 115_200, dir, stop, shared);
                stop.store(true, Ordering::SeqCst);
                let _ = board.join();
                r
            }
        }
    }
}

#[cfg(unix)]
fn is_char_device(meta: &std::fs::Metadata) -> bool {
    std::os::unix::fs::FileTypeExt::is_char_device(&meta.file_type())
}

#[cfg(not(unix))]
fn is_char_device(_: &std::fs::Metadata) -> bool {
    true
}

fn capture_port(
    port: &str,
    baud: u32,
    dir: &Path,
    stop: &AtomicBool,
    shared: &Arc<Mutex<Snapshot>>,
) -> Result<String, LiveError> {
    let mut source =
        errmap_drivers::transport::SerialSource::open(port, baud, Duration::from_millis(100))
            .map_err(|source| LiveError::Open {
                port: port.to_string(),
                source,
            })?;
    let paths = errmap::acquire::SessionPaths::new(dir, "csv");
    let local = std::cell::RefCell::new(Watcher::new(shared));
    let cap = errmap::acquire::capture_session_watched(
        &mut source,
        &paths,
        &CaptureConfig::default(),
        stop,
        &mut |p: &Progress| local.borrow_mut().progress(p),
        &mut |e: &SessionEvent| local.borrow_mut().event(e),
    )?;
    let mut w = local.into_inner();
    w.snap.bytes = cap.bytes;
    w.snap.crc_failures = cap.stats.crc_failures;
    w.snap.resyncs = cap.stats.resyncs;
    w.snap.seq_gaps = cap.stats.seq_gaps;
    w.snap.flagged = cap.stats.flagged_samples;
    if let Ok(mut g) = shared.lock() {
        let keep = (g.session.clone(), g.source.clone());
        *g = w.snap;
        (g.session, g.source) = keep;
    }
    Ok(match cap.end {
        CaptureEnd::Closed { runs } => {
            format!("the board closed the port after its last run ({runs} runs)")
        }
        CaptureEnd::Stopped => "stopped from the page".into(),
        CaptureEnd::Vanished(why) => {
            format!("the port vanished ({why}); everything received is on disk")
        }
        other => format!("{other:?}"),
    })
}

/// The reading thread's own snapshot, handed over without waiting.
struct Watcher<'a> {
    snap: Snapshot,
    shared: &'a Arc<Mutex<Snapshot>>,
    last: Instant,
    index: BTreeMap<(u32, i8, i32), usize>,
}

impl<'a> Watcher<'a> {
    fn new(shared: &'a Arc<Mutex<Snapshot>>) -> Self {
        Watcher {
            snap: Snapshot {
                state: "running",
                ..Snapshot::default()
            },
            shared,
            last: Instant::now(),
            index: BTreeMap::new(),
        }
    }

    fn event(&mut self, e: &SessionEvent) {
        match e {
            SessionEvent::Row(r) => {
                self.snap.samples += 1;
                self.snap.run = Some(r.run);
                self.snap.target = Some(r.target);
                self.snap.position_mm = Some(r.scale_mm);
                self.snap.error_um = r.error_um.is_finite().then_some(r.error_um);
                if r.target >= 0 && r.error_um.is_finite() && r.flags == 0 {
                    let reading = Reading {
                        rotary: false,
                        position: r.scale_mm,
                        error: r.error_um,
                    };
                    self.dwell(r.run, r.direction, r.target, reading);
                }
            }
            SessionEvent::Problem(p) => {
                let name = format!("{:?}", p.kind);
                let name = name.split([' ', '{', '(']).next().unwrap_or("").to_string();
                *self.snap.problems.entry(name).or_default() += 1;
            }
            // A rotary board's rows: its angle in ° and its error in ″.
            SessionEvent::Rotary(r) => {
                self.snap.samples += 1;
                self.snap.run = Some(r.run);
                self.snap.target = Some(r.target);
                self.snap.rotary_axis = Some(r.axis.to_string());
                self.snap.angle_deg = r.indicated_deg.is_finite().then_some(r.indicated_deg);
                self.snap.error_arcsec = r.error_arcsec.is_finite().then_some(r.error_arcsec);
                if r.target >= 0 && r.error_arcsec.is_finite() && r.flags == 0 {
                    let reading = Reading {
                        rotary: true,
                        position: r.indicated_deg,
                        error: r.error_arcsec,
                    };
                    self.dwell(r.run, r.direction, r.target, reading);
                }
            }
            SessionEvent::Hello(_) | SessionEvent::Text { .. } => {}
        }
        self.publish();
    }

    fn dwell(&mut self, run: u32, direction: i8, target: i32, reading: Reading) {
        let key = (run, direction, target);
        let rows = &mut self.snap.targets;
        match self.index.get(&key).copied().filter(|&k| k < rows.len()) {
            Some(k) if rows[k].run == run && rows[k].target == target => rows[k].push(reading),
            _ => {
                if rows.len() == MAX_TARGET_ROWS {
                    rows.remove(0);
                    self.index.values_mut().for_each(|k| *k = k.wrapping_sub(1));
                }
                rows.push(TargetRow::new(run, direction, target, reading));
                self.index.insert(key, rows.len() - 1);
            }
        }
    }

    fn progress(&mut self, p: &Progress) {
        self.snap.bytes = p.bytes;
        self.snap.elapsed_s = p.elapsed_s;
        self.publish();
    }

    fn publish(&mut self) {
        if self.last.elapsed() < Duration::from_millis(100) {
            return;
        }
        if let Ok(mut g) = self.shared.try_lock() {
            let keep = (g.session.take(), g.source.take());
            *g = self.snap.clone();
            (g.session, g.source) = keep;
            self.last = Instant::now();
        }
    }
}
