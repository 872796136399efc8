//! The acquisition subcommands: serve-sim, capture, replay, table, ports. Glue only: the
//! work is in `errmap::acquire`, `errmap::session` and `errmap-drivers`.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use errmap::acquire::{self, SessionPaths};
use errmap::drivers::capture::{CaptureConfig, CaptureEnd, Progress};
use errmap::drivers::serve::{pty_pair, serve_paced};
use errmap::drivers::sim::{Faults, SimStream};
use errmap::drivers::transport::{SerialSource, list_ports};
use errmap::{iso230, session};

use crate::{CaptureArgs, DiagnoseArgs, FaultArgs, ReplayArgs, ServeSimArgs, TableArgs};

static STOP: AtomicBool = AtomicBool::new(false);

/// Ctrl-C sets the stop flag once; a second Ctrl-C is left to the default (the raw file
/// is on disk either way).
fn install_ctrlc() {
    let _ = ctrlc::set_handler(|| STOP.store(true, Ordering::SeqCst));
}

fn faults(a: &FaultArgs) -> Result<Faults> {
    let beam_loss_s = match &a.beam_loss {
        None => None,
        Some(s) => {
            let (x, y) = s
                .split_once(':')
                .context("--beam-loss takes START:END in seconds")?;
            Some((x.trim().parse::<f64>()?, y.trim().parse::<f64>()?))
        }
    };
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
pub fn serve_stream(
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

pub fn serve_sim(a: ServeSimArgs) -> Result<()> {
    install_ctrlc();
    let faults = faults(&a.faults)?;
    let (stream, _) = acquire::simulate_stream(&a.model, a.plan.as_deref(), &faults)?;
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
    let written = serve_stream(&stream, a.speed, a.linger, a.stall_timeout, |path| {
        println!("{path}");
        let _ = std::io::stdout().flush();
    })?;
    eprintln!("serve-sim: sent {written} bytes");
    Ok(())
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
    std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
}

/// Captures from a serial port into `out`; returns the capture's end.
pub fn capture_from_port(
    port: &str,
    baud: u32,
    paths: &SessionPaths,
    config: &CaptureConfig,
    show_progress: bool,
) -> Result<errmap::drivers::capture::Capture> {
    let mut source = SerialSource::open(port, baud, Duration::from_millis(100))?;
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

pub fn capture_cmd(a: CaptureArgs) -> Result<()> {
    install_ctrlc();
    if a.format != "csv" && a.format != "parquet" {
        bail!("--format is csv or parquet, not {}", a.format);
    }
    let paths = SessionPaths::new(&a.out, &a.format);
    let config = CaptureConfig {
        idle_timeout: a.idle_timeout.map(Duration::from_secs_f64),
        max_duration: a.duration.map(Duration::from_secs_f64),
        ..CaptureConfig::default()
    };
    let cap = capture_from_port(&a.port, a.baud, &paths, &config, true)?;
    let s = &cap.stats;
    eprintln!(
        "capture: {} bytes, {} rows, {} frames; CRC failures {}, resyncs {} ({} bytes skipped), seq gaps {} ({} frames lost), wraps {}/{}, flagged samples {}, truncated tail {} bytes",
        cap.bytes,
        cap.rows.len(),
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
        "capture: session in {} ({}, {}, {})",
        paths.dir.display(),
        file(&paths.raw),
        file(&paths.table),
        file(&paths.json)
    );
    if a.json {
        println!("{}", std::fs::read_to_string(&paths.json)?);
    }
    if let CaptureEnd::Vanished(why) = &cap.end {
        bail!(
            "the port vanished during the capture ({why}); everything received is in {} and the session table was written",
            paths.dir.display()
        );
    }
    Ok(())
}

fn file(p: &Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

pub fn replay_cmd(a: ReplayArgs) -> Result<()> {
    let (rows, stats, _) = acquire::replay(&a.raw, &a.out)?;
    if a.json {
        let mut v = serde_json::to_value(&stats)?;
        v["rows"] = serde_json::json!(rows.len());
        println!("{v}");
    } else {
        eprintln!(
            "replay: {} rows from {} frames ({} CRC failures, {} resyncs, {} seq gaps) → {}",
            rows.len(),
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
fn session_file(p: &Path) -> Result<PathBuf> {
    if p.is_dir() {
        for name in ["session.parquet", "session.csv"] {
            if p.join(name).is_file() {
                return Ok(p.join(name));
            }
        }
        bail!(
            "{}: no session.csv or session.parquet in this directory",
            p.display()
        );
    }
    Ok(p.to_path_buf())
}

pub fn table_cmd(a: TableArgs) -> Result<()> {
    let path = session_file(&a.session)?;
    let rows = session::read_session(&path)?;
    let (table, summary) = session::error_table(&path.display().to_string(), &rows)?;
    table.write(&a.out)?;
    eprintln!(
        "table: {} nodes ({} lines × {} targets) from {} dwell samples; {} flagged samples left out, {} rows not dwelling → {}",
        table.points.len(),
        summary.lines,
        summary.targets,
        summary.used,
        summary.flagged,
        summary.not_dwelling,
        a.out.display()
    );
    if summary.uncompensated > 0 {
        eprintln!(
            "table: {} dwell samples latched before the first ENV frame (no air compensation) left out",
            summary.uncompensated
        );
    }
    if summary.no_air_data {
        eprintln!(
            "table: warning: the session has no air values; its laser lengths are used as written \
             (uncompensated lengths read about 270 ppm long in a normal room)"
        );
    }
    let axis = summary.axis.clone().unwrap_or_default();
    let mut iso = Vec::new();
    for line in session::lines(&rows) {
        let obs = session::iso_observations(&rows, Some(line));
        match iso230::axis_stats(&obs) {
            Ok(stats) => iso.push((line, stats)),
            Err(e) => eprintln!("table: no ISO 230-2 statistics for line {line:?}: {e}"),
        }
    }
    if let Some(dir) = &a.report {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let mut md = format!(
            "# ISO 230-2 positioning statistics\n\nSession: `{}`; axis {axis}; {} line(s).\n\n",
            path.display(),
            iso.len()
        );
        md.push_str(&session::environment_summary(&rows));
        md.push('\n');
        for (k, (line, stats)) in iso.iter().enumerate() {
            md.push_str(&format!(
                "## Line {} at ({}, {}) mm\n\n",
                k + 1,
                line.0,
                line.1
            ));
            md.push_str(
                &iso230::markdown(stats, &axis)
                    .replace("\n## ", "\n### ")
                    .replacen("## ", "### ", 1),
            );
            let stem = dir.join(format!("line{}", k + 1));
            iso230::plot(
                stats,
                &stem,
                &format!("Axis {axis}, line ({}, {}) mm", line.0, line.1),
            )?;
            md.push_str(&format!("\n![line {}](line{}.png)\n\n", k + 1, k + 1));
        }
        let p = dir.join("report.md");
        std::fs::write(&p, md).with_context(|| format!("cannot write {}", p.display()))?;
        eprintln!("table: ISO 230-2 report in {}", p.display());
    }
    if a.json {
        let lines: Vec<_> = iso
            .iter()
            .map(|(l, s)| serde_json::json!({"line_mm": [l.0, l.1], "iso230": s}))
            .collect();
        println!(
            "{}",
            serde_json::json!({"summary": summary, "nodes": table.points.len(), "lines": lines})
        );
    }
    Ok(())
}

pub fn ports() -> Result<()> {
    let ports = list_ports()?;
    if ports.is_empty() {
        eprintln!("no serial ports found");
    }
    for p in ports {
        println!("{}\t{:?}", p.name, p.kind);
    }
    Ok(())
}

/// The grating period from a capture directory's session.json, if any, µm.
fn grating_from_capture(session: &Path) -> Option<f64> {
    let dir = if session.is_dir() {
        session
    } else {
        session.parent()?
    };
    let text = std::fs::read_to_string(dir.join("session.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["hello"]["grating_period_nm"]
        .as_f64()
        .map(|nm| nm / 1000.0)
}

pub fn diagnose_cmd(a: DiagnoseArgs) -> Result<()> {
    use errmap::diagnose::{DiagnoseConfig, diagnose, write_report};
    use errmap::physics::{MachineModel, apply_found_effects, simulate_rows};
    let rec_path = session_file(&a.recorded)?;
    let recorded = session::read_session(&rec_path)?;
    let (simulated, model) = match (&a.simulated, &a.model) {
        (Some(s), _) => (session::read_session(&session_file(s)?)?, None),
        (None, Some(m)) => {
            let model = MachineModel::read(m)?;
            (
                simulate_rows(&model, m, &recorded)?,
                Some((model, m.clone())),
            )
        }
        (None, None) => bail!("give --simulated SESSION or --model MODEL.toml"),
    };
    let grating = a
        .grating_period_um
        .or_else(|| {
            model
                .as_ref()
                .map(|(m, _)| f64::from(m.device.grating_period_nm) / 1000.0)
        })
        .or_else(|| grating_from_capture(&a.recorded));
    let config = DiagnoseConfig {
        grating_period_um: grating,
        model_dead_path_mm: model.as_ref().map(|(m, _)| m.laser.dead_path_mm.max(0.0)),
        ..DiagnoseConfig::default()
    };
    let d = diagnose(&recorded, &simulated, &config)
        .with_context(|| format!("{}: diagnosis failed", rec_path.display()))?;
    std::fs::create_dir_all(&a.report)
        .with_context(|| format!("cannot create {}", a.report.display()))?;
    write_report(&d, &a.report)?;
    // Every report carries the session's environment.
    let md_path = a.report.join("report.md");
    if let Ok(mut md) = std::fs::read_to_string(&md_path) {
        md.push('\n');
        md.push_str(&session::environment_summary(&recorded));
        std::fs::write(&md_path, md)
            .with_context(|| format!("cannot write {}", md_path.display()))?;
    }
    if let Some((mut m, path)) = model {
        let notes = apply_found_effects(&mut m, &d.effects);
        let _ = &path;
        if let Some(map) = &mut m.error_map {
            map.table = relative_to(&map.table, &a.report);
        }
        let out = a.report.join("updated-model.toml");
        m.write(&out)?;
        eprintln!(
            "diagnose: updated model ({}) → {}",
            notes.join("; "),
            out.display()
        );
    }
    if a.json {
        println!("{}", serde_json::to_string(&d)?);
    } else {
        eprintln!(
            "diagnose: {} — RMS {:.4} µm before, {:.4} µm after ({:.4} µm cross-validated by run); report in {}",
            d.verdict,
            d.rms_before_um,
            d.rms_after_um,
            d.cv_rms_after_um,
            a.report.display()
        );
        for e in &d.effects {
            eprintln!(
                "  {}: {} — {}",
                e.id,
                serde_json::to_string(&e.params)?,
                e.where_
            );
        }
    }
    Ok(())
}

/// `path` (relative to the working directory, or absolute) as seen from directory `base`.
fn relative_to(path: &Path, base: &Path) -> PathBuf {
    let (Ok(p), Ok(b)) = (std::path::absolute(path), std::path::absolute(base)) else {
        return path.to_path_buf();
    };
    fn norm(x: &Path) -> Vec<std::path::Component<'_>> {
        let mut out = Vec::new();
        for c in x.components() {
            match c {
                std::path::Component::ParentDir => {
                    out.pop();
                }
                std::path::Component::CurDir => {}
                other => out.push(other),
            }
        }
        out
    }
    let (pc, bc) = (norm(&p), norm(&b));
    let common = pc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    let mut rel = PathBuf::new();
    for _ in common..bc.len() {
        rel.push("..");
    }
    for c in &pc[common..] {
        rel.push(c.as_os_str());
    }
    rel
}

/// Diagnoses every case under `cases` (each with recorded.parquet, simulated.parquet and
/// truth.json) into `out/<case>/`, with an index comparing found and hidden effects.
pub fn report_concealed(cases: &Path, out: &Path) -> Result<()> {
    use errmap::diagnose::{DiagnoseConfig, diagnose, write_report};
    let mut names: Vec<String> = std::fs::read_dir(cases)
        .with_context(|| format!("cannot read {}", cases.display()))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("recorded.parquet").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut index = String::from(
        "# Diagnosis of the concealed-effect cases\n\nRegenerate with `errmap report-concealed` \
         (cases from `errmap gen-concealed`). The diagnosis saw only `recorded.parquet` and \
         `simulated.parquet`; the hidden truth comes from `truth.json`.\n\n\
         | case | hidden | found | parameters found (± 1σ) | hidden parameters | RMS before → after µm | noise σ µm |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for name in &names {
        let dir = cases.join(name);
        let recorded = session::read_session(&dir.join("recorded.parquet"))?;
        let simulated = session::read_session(&dir.join("simulated.parquet"))?;
        let truth: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("truth.json"))
                .with_context(|| format!("{}", dir.display()))?,
        )?;
        let d = diagnose(
            &recorded,
            &simulated,
            &DiagnoseConfig {
                grating_period_um: Some(20.0),
                ..DiagnoseConfig::default()
            },
        )?;
        let report = out.join(name);
        std::fs::create_dir_all(&report)?;
        write_report(&d, &report)?;
        std::fs::write(
            report.join("diagnosis.json"),
            serde_json::to_string_pretty(&d)? + "\n",
        )?;
        let found: Vec<String> = d.effects.iter().map(|e| format!("`{}`", e.id)).collect();
        let params: Vec<String> = d
            .effects
            .iter()
            .map(|e| {
                e.params
                    .iter()
                    .map(|(k, v)| match (v.as_f64(), e.uncertainty.get(k)) {
                        (Some(x), Some(u)) => format!("{k} {x:.4} ± {u:.4}"),
                        _ => format!("{k} {v}"),
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect();
        let hidden: Vec<String> = truth["params"]
            .as_object()
            .map(|o| {
                o.iter()
                    .map(|(id, p)| {
                        let ps: Vec<String> = p
                            .as_object()
                            .map(|m| m.iter().map(|(k, v)| format!("{k} {v}")).collect())
                            .unwrap_or_default();
                        format!("`{id}`: {}", ps.join(", "))
                    })
                    .collect()
            })
            .unwrap_or_default();
        index.push_str(&format!(
            "| [{name}]({name}/report.md) | {} | {} | {} | {} | {:.4} → {:.4} | {} |\n",
            if hidden.is_empty() {
                "nothing".to_string()
            } else {
                truth["effects"].to_string()
            },
            if found.is_empty() {
                format!("none ({})", d.verdict)
            } else {
                found.join(", ")
            },
            params.join("; "),
            hidden.join("; "),
            d.rms_before_um,
            d.rms_after_um,
            truth["sizes"]["noise_um"]
        ));
        eprintln!(
            "report-concealed: {name}: {} {:?}",
            d.verdict,
            d.effects.iter().map(|e| &e.id).collect::<Vec<_>>()
        );
    }
    std::fs::write(out.join("README.md"), index)?;
    Ok(())
}
