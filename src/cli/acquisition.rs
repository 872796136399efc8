//! The acquisition subcommands: serve-sim, capture, replay, table, ports. Glue only: the
//! work is in `errmap::acquire`, `errmap::session` and `errmap-drivers`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use errmap::acquire::{self, SessionPaths};
use errmap::drivers::capture::{CaptureConfig, CaptureEnd, Progress};
use errmap::drivers::serve::{pty_pair, serve_paced};
use errmap::drivers::sim::{Faults, SimStream};
use errmap::drivers::transport::{SerialSource, list_ports};

use super::args::{CaptureArgs, FaultArgs, PortsArgs, ReplayArgs, ServeSimArgs, TableArgs};

static STOP: AtomicBool = AtomicBool::new(false);

/// Ctrl-C (or SIGTERM) sets the stop flag once; a second one ends the run
/// (`guard::on_signals`; the raw file is on disk either way).
fn install_ctrlc() {
    super::guard::stop_on_interrupt(&STOP);
}

fn faults(a: &FaultArgs) -> Result<Faults> {
    let beam_loss_s = a.beam_loss.map(|w| (w.0, w.1));
    for (name, p) in [
        ("--garbage", a.garbage),
        ("--bit-flips", a.bit_flips),
        ("--drop-frames", a.drop_frames),
    ] {
        if !(0.0..=1.0).contains(&p) {
            bail!("{name} is a probability in [0, 1], not {p}");
        }
    }
    Ok(Faults {
        garbage_prob: a.garbage,
        bit_flip_prob: a.bit_flips,
        drop_prob: a.drop_frames,
        beam_loss_s,
        counters_near_wrap: a.near_wrap,
        seed: a.fault_seed,
    })
}

/// Serves a simulated stream on a fresh pty: prints the path on stdout, streams, lingers.
/// Gives up when no host reads for `stall_s` seconds (0: waits for ever).
pub(crate) fn serve_stream(
    stream: &SimStream,
    speed: f64,
    linger_s: f64,
    stall_s: f64,
    announce: impl FnOnce(&str),
) -> Result<u64> {
    let (mut master, _slave, path) = pty_pair().context("cannot open a pseudo-terminal pair")?;
    announce(&path);
    let stall = (stall_s > 0.0).then(|| Duration::from_secs_f64(stall_s.min(1e6)));
    let written = serve_paced(&stream.frames, &mut master, speed, &STOP, stall)
        .with_context(|| format!("writing to {path}"))?;
    std::thread::sleep(Duration::from_secs_f64(linger_s.clamp(0.0, 3600.0)));
    Ok(written)
}

pub(crate) fn serve_sim(a: ServeSimArgs) -> Result<()> {
    install_ctrlc();
    let faults = faults(&a.faults)?;
    let stream = if errmap::sim::is_rotary_model(&a.model) {
        rotary_stream(&a.model, a.plan.as_deref(), &faults, a.truth_out.is_some())?
    } else {
        errmap::sim::simulate_stream(&a.model, a.plan.as_deref(), &faults)?.0
    };
    if let Some(p) = &a.truth_out {
        write_truth(p, &stream)?;
    }
    eprintln!(
        "serve-sim: {} frames, {} samples ({} dropped by the byte budget), {:.1} s of board time at {:.1}× speed",
        stream.frames.len(),
        stream.truth.len(),
        stream.overruns,
        stream.duration_s,
        a.speed
    );
    let mut announced = Ok(());
    let written = serve_stream(&stream, a.speed, a.linger, a.stall_timeout, |path| {
        announced = super::guard::print_stdout(path);
    })?;
    announced?;
    eprintln!("serve-sim: sent {written} bytes");
    Ok(())
}

/// A rotary model's board stream (`docs/rotary.md`, "Capture"): no fault injection and no
/// truth file (the model file is the truth).
fn rotary_stream(
    model: &Path,
    plan: Option<&Path>,
    faults: &Faults,
    truth_out: bool,
) -> Result<SimStream> {
    let seedless = Faults {
        seed: 0,
        ..faults.clone()
    };
    if seedless != Faults::default() {
        bail!(
            "{}: a rotary model's board takes no fault injection (--garbage, --bit-flips, \
             --drop-frames, --beam-loss, --near-wrap)",
            model.display()
        );
    }
    if truth_out {
        bail!(
            "{}: --truth-out is for a linear model (a rotary model's effects are its file)",
            model.display()
        );
    }
    Ok(errmap::sim::simulate_rotary_stream(model, plan)?)
}

fn write_truth(path: &Path, stream: &SimStream) -> Result<()> {
    let mut s = String::from("sample,t_s,x_mm,y_mm,z_mm,error_um,run,direction,target,sent\n");
    for t in &stream.truth {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            t.index,
            t.t_s,
            t.pos_mm[0],
            t.pos_mm[1],
            t.pos_mm[2],
            t.error_um,
            t.run,
            t.direction,
            t.target,
            t.sent
        ));
    }
    super::guard::write_file(path, s.as_bytes())
}

/// Serves `stream` on a fresh pseudo-terminal from a thread (at `speed`× real time) and
/// captures it from there through the serial-port code: the simulated board's end to end.
pub(crate) fn capture_simulated(
    stream: SimStream,
    speed: f64,
    baud: u32,
    paths: &SessionPaths,
    config: &CaptureConfig,
    display: Display,
) -> Result<errmap::drivers::capture::Captured> {
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let server = std::thread::spawn(move || {
        serve_stream(&stream, speed, 1.5, 30.0, |path| {
            let _ = tx.send(path.to_string());
        })
    });
    let port = rx.recv().context("the simulated board did not start")?;
    eprintln!("capture: simulated board on {port} ({speed}× real time)");
    let cap = capture_from_port(&port, baud, paths, config, display)?;
    match server.join() {
        Ok(r) => {
            r?;
        }
        Err(_) => bail!("the simulated board's thread failed"),
    }
    Ok(cap)
}

/// How a capture shows itself while it runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Display {
    /// A progress line on stderr when it is a terminal.
    Progress,
    /// The live view (`super::view`) on the terminal.
    LiveView,
}

/// Captures from a serial port into `out`; returns the capture's end.
pub(crate) fn capture_from_port(
    port: &str,
    baud: u32,
    paths: &SessionPaths,
    config: &CaptureConfig,
    display: Display,
) -> Result<errmap::drivers::capture::Captured> {
    let mut source = SerialSource::open(port, baud, Duration::from_millis(100))?;
    if display == Display::LiveView {
        match super::view::open() {
            Ok(live) => return super::view::capture(live, &mut source, paths, config, &STOP),
            Err(e) => eprintln!("capture: no live view ({e:#}); the progress line instead"),
        }
    }
    let show_progress = display == Display::Progress;
    let bar = (show_progress && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.enable_steady_tick(Duration::from_millis(120));
        b
    });
    let mut progress = |p: &Progress| {
        if let Some(b) = &bar {
            b.set_message(format!(
                "{} samples, run {}, {:.0} B/s, {} problems, {:.1} s",
                p.samples,
                p.runs,
                p.bytes as f64 / p.elapsed_s.max(1e-3),
                p.problems,
                p.elapsed_s
            ));
        }
    };
    let cap = acquire::capture_session(&mut source, paths, config, &STOP, &mut progress)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(cap)
}

pub(crate) fn capture_cmd(a: CaptureArgs) -> Result<()> {
    install_ctrlc();
    let paths = SessionPaths::new(&a.out, a.format.extension());
    let config = CaptureConfig {
        idle_timeout: a.idle_timeout.map(Duration::from_secs_f64),
        max_duration: a.duration.map(Duration::from_secs_f64),
        ..CaptureConfig::default()
    };
    // The live view needs a terminal to draw on (stderr: stdout stays free for --json).
    let display = if a.no_view || !std::io::stderr().is_terminal() {
        Display::Progress
    } else {
        Display::LiveView
    };
    let cap = match (&a.simulate, &a.port) {
        (Some(model), _) => {
            let stream = if errmap::sim::is_rotary_model(model) {
                rotary_stream(model, a.plan.as_deref(), &Faults::default(), false)?
            } else {
                errmap::sim::simulate_stream(model, a.plan.as_deref(), &Faults::default())?.0
            };
            capture_simulated(stream, a.speed, a.baud, &paths, &config, display)?
        }
        (None, Some(port)) => capture_from_port(port, a.baud, &paths, &config, display)?,
        (None, None) => bail!("capture needs --port or --simulate"),
    };
    let s = &cap.stats;
    eprintln!(
        "capture: {} bytes, {} rows, {} frames; CRC failures {}, resyncs {} ({} bytes skipped), seq gaps {} ({} frames lost), wraps {}/{}, flagged samples {}, truncated tail {} bytes",
        cap.bytes,
        cap.rows,
        s.frames.total(),
        s.crc_failures,
        s.resyncs,
        s.bytes_skipped,
        s.seq_gaps,
        s.frames_lost,
        s.counter_wraps.scale,
        s.counter_wraps.laser,
        s.flagged_samples,
        s.truncated_tail_bytes
    );
    for (kind, p) in s.problems.iter() {
        eprintln!(
            "  {kind}: {} (first at {})",
            p.count,
            p.first
                .iter()
                .map(|q| format!("{q}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    eprintln!(
        "capture: session in {} ({}, {}, {}); `errmap replay {} --out {}` rebuilds the table exactly \
         (after a killed capture too)",
        paths.dir.display(),
        file(&paths.raw),
        file(&paths.table),
        file(&paths.json),
        paths.raw.display(),
        paths.table.display()
    );
    if a.json {
        let json = std::fs::read_to_string(&paths.json)
            .with_context(|| format!("cannot read {}", paths.json.display()))?;
        super::guard::print_stdout(&json)?;
    }
    match &cap.end {
        CaptureEnd::Vanished(why) => bail!(
            "the port vanished during the capture ({why}); everything received is in {} and the session table was written",
            paths.dir.display()
        ),
        CaptureEnd::Closed { runs } => eprintln!(
            "capture: complete: the board closed the port after its last run ended ({runs} runs, {} rows)",
            cap.rows
        ),
        CaptureEnd::EndOfSource | CaptureEnd::Stopped | CaptureEnd::Idle | CaptureEnd::Duration => {
        }
    }
    Ok(())
}

fn file(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

pub(crate) fn replay_cmd(a: ReplayArgs) -> Result<()> {
    let mut inputs = vec![("RAW", a.raw.as_path())];
    if let Some(h) = &a.hello_from {
        inputs.push(("--hello-from", h.as_path()));
    }
    super::guard::refuse_aliases(&[("--out", &a.out)], &inputs)?;
    let hello = a
        .hello_from
        .as_deref()
        .map(acquire::hello_from_session_json)
        .transpose()?;
    let acquire::Replayed { rows, stats, .. } = acquire::replay_with_hello(&a.raw, &a.out, hello)?;
    if stats.unconverted_samples > 0 {
        // Loud, whatever --json says: samples were lost to a missing device description.
        eprintln!(
            "replay: WARNING: {} of {} samples could not be converted (no usable HELLO when they \
             arrived); give the device's description with --hello-from <an earlier capture's \
             session.json>",
            stats.unconverted_samples, stats.frames.sample
        );
    }
    if a.json {
        super::guard::print_json(&errmap::report::ReplayJson {
            stats: &stats,
            // The process's resident high-water mark (Linux), MB: memory stays bounded.
            peak_rss_mb: acquire::peak_rss_mb(),
        })?;
    } else {
        eprintln!(
            "replay: {} rows from {} frames ({} CRC failures, {} resyncs, {} seq gaps) → {}",
            rows,
            stats.frames.total(),
            stats.crc_failures,
            stats.resyncs,
            stats.seq_gaps,
            a.out.display()
        );
    }
    Ok(())
}

/// A session argument: a table file, or a capture directory holding one.
pub(super) fn session_file(p: &Path) -> Result<PathBuf> {
    Ok(errmap::sim::session_file(p)?)
}

pub(crate) fn table_cmd(a: TableArgs) -> Result<()> {
    if super::rotary::is_rotary_session(&a.session)? {
        return super::rotary::table_cmd(a);
    }
    let tolerances = super::acceptance::tolerances(a.tolerances.as_deref(), &a.rule)?;
    let reduced = reduce_session(&a.session, &a.out, a.report.as_deref(), a.info.as_deref())?;
    let conformity = match &tolerances {
        Some((t, rule)) => {
            if reduced.iso.is_empty() {
                bail!(
                    "{}: no line has ISO 230-2 statistics (the reason is above), so no line \
                     can be judged against --tolerances {}",
                    a.session.display(),
                    t.path.display()
                );
            }
            let axis = reduced.summary.axis.clone().unwrap_or_default();
            let lines: Vec<_> = reduced
                .iso
                .iter()
                .zip(&reduced.budgets)
                .map(|((l, s), b)| (*l, s, b.expanded()))
                .collect();
            let c = t.judge(&axis, &lines, rule)?;
            eprintln!(
                "table: conformity with {} ({}): {}",
                c.specification, c.rule, c.verdict
            );
            Some(c)
        }
        None => None,
    };
    if a.json {
        // Typed, so the guard sees every number before it is written.
        super::guard::print_json(&errmap::report::table_json(&reduced, conformity.as_ref()))?;
    }
    Ok(())
}

pub(crate) use errmap::acquire::Reduced;

/// Reduces a session (table or capture directory) to the error table `out`, with the
/// ISO 230-2 report in `report` when given; says what it did on stderr.
pub(crate) fn reduce_session(
    session_arg: &Path,
    out: &Path,
    report: Option<&Path>,
    info_file: Option<&Path>,
) -> Result<Reduced> {
    let path = session_file(session_arg)?;
    let mut inputs = vec![("SESSION", path.as_path())];
    inputs.extend(info_file.map(|p| ("--info", p)));
    let mut outputs = vec![("--out", out)];
    outputs.extend(report.map(|r| ("--report", r)));
    super::guard::refuse_aliases(&outputs, &inputs)?;
    let info = match info_file {
        Some(p) => errmap::report::certificate::CertificateInfo::read(p)?,
        None => Default::default(),
    };
    if let Some(dir) = report.filter(|d| d.exists() && !d.is_dir()) {
        bail!(
            "--report {}: exists and is not a directory (nothing was written)",
            dir.display()
        );
    }
    let inputs = acquire::BudgetInputs {
        config: info.uncertainty.clone(),
        stated_laser_um: info.laser.resolution_um,
        drift_check: info.drift_check.clone(),
        declared: info.conditions.clone(),
    };
    let reduced = acquire::reduce_session_with(&path, &inputs)?;
    let (table, summary) = (&reduced.table, &reduced.summary);
    table.write(out)?;
    eprintln!(
        "table: {} nodes ({} lines × {} targets) from {} dwell samples; {} flagged samples left out, {} rows not dwelling → {}",
        table.points.len(),
        summary.lines,
        summary.targets,
        summary.used,
        summary.flagged,
        summary.not_dwelling,
        out.display()
    );
    if summary.uncompensated > 0 {
        eprintln!(
            "table: {} dwell samples latched before the first ENV frame (no air compensation) left out",
            summary.uncompensated
        );
    }
    if summary.no_air_data {
        // A capture (its HELLO beside the table) writes air values on every compensated
        // row; a table without any is an export whose lengths its own software compensated.
        if reduced.device_known {
            eprintln!(
                "table: warning: the capture has no air values; its laser lengths are \
                 uncompensated (about 270 ppm long in a normal room)"
            );
        } else {
            eprintln!(
                "table: the session has no air values: its laser lengths are taken as written \
                 (as compensated by the software that exported them); the uncertainty budget \
                 leaves the air terms out and says so"
            );
        }
    }
    for (line, e) in &reduced.failed {
        eprintln!("table: no ISO 230-2 statistics for line {line:?}: {e}");
    }
    if let Some(dir) = report {
        let axis = summary.axis.clone().unwrap_or_default();
        let environment = errmap::report::environment_text(&reduced.environment);
        // A new report directory appears whole or not at all.
        let p = super::guard::into_new_dir(dir, |d| {
            errmap::report::write_session_report(
                &path.display().to_string(),
                &axis,
                &environment,
                &reduced.iso,
                &reduced.budgets,
                d,
            )
            .map(|_| dir.join("report.md"))
            .map_err(Into::into)
        })?;
        eprintln!("table: ISO 230-2 report in {}", p.display());
    }
    Ok(reduced)
}

pub(crate) fn ports(a: PortsArgs) -> Result<()> {
    let ports = list_ports()?;
    if a.json {
        return super::guard::print_json(&ports);
    }
    if ports.is_empty() {
        eprintln!("no serial ports found");
    }
    for p in ports {
        super::guard::print_stdout(&format!("{}\t{:?}", p.name, p.kind))?;
    }
    Ok(())
}
