//! The `errmap` binary: argument parsing and glue. Each subcommand is one short function
//! that validates its flags into library configuration and calls the library.
//!
//! | module | holds |
//! |---|---|
//! | [`args`] | every clap struct |
//! | [`values`] | the flags' value types, parsed once into library types (bad value: exit 2) |
//! | [`flags`] | the library's settings as flags: a library error that names settings, said with the flags |
//! | [`model`] | fit, compare, export (its flags → one `controller::job::ExportJob`), simulate, fuzzy-sim |
//! | [`acquisition`] | serve-sim, capture, replay, table, ports |
//! | [`diagnose`] | diagnose, gen-concealed, report-concealed |
//! | [`certificate`] | certificate |
//! | [`demo`] | the demo: the whole pipeline on built-in data |
//! | [`plan`] | plan: an ISO 230-2 test plan and its part program |
//! | [`stream`] | gen-capture: a long generated raw capture for benchmarks
//! | [`volumetric`] | volumetric simulate, identify, predict |
//! | [`import`] | import; the flag values a controller table needs (`--units`, `--comp-type`) |
//! | [`history`] | history add, report, verify: the calibration ledger |
//! | [`rotary`] | a rotary axis' table, import, diagnosis, export and plan |
//! | `workbench` | workbench: the local web application (pages, JSON API, live capture; cargo feature `workbench`) |
//! | [`acceptance`] | acceptance decide, acceptance iso10360, volumetric iso10360; the rule flags |

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

pub(crate) mod acceptance;
pub(crate) mod acquisition;
pub(crate) mod args;
pub(crate) mod artefact;
pub(crate) mod certificate;
pub(crate) mod circular;
pub(crate) mod demo;
pub(crate) mod diagnose;
pub(crate) mod flags;
pub(crate) mod guard;
pub(crate) mod history;
pub(crate) mod import;
pub(crate) mod model;
pub(crate) mod plan;
pub(crate) mod probing;
pub(crate) mod rotary;
pub(crate) mod stream;
pub(crate) mod values;
pub(crate) mod view;
pub(crate) mod volumetric;
#[cfg(feature = "workbench")]
pub(crate) mod workbench;

use args::*;

/// The map at the foot of `errmap --help`: every stage of the library (`src/lib.rs`), in
/// pipeline order, with the commands that run it.
const STAGES: &str = "\
Stages of the pipeline and the commands that run them:
  acquire      capture, replay, serve-sim, ports: board bytes into a session
  session      table: session tables, error tables, ISO 230-2 / VDI 3441 numbers
  table        the error tables every model is fitted to
  interp       fit: models of the error field
  evaluate     compare, fuzzy-sim: cross-validation and comparison of models
  diagnose     diagnose: the named effects a simulation left out of a recording
  sim          simulate, plan: the machine simulator and test plans
  export       export: a model sampled along a line or over a volume
  controller   export, import: controller tables written, read back, updated
  import       import: laser exports, spreadsheets and controller tables in
  volumetric   volumetric: the 21 geometric errors from laser line measurements
  circular     circular: ballbar tests (ISO 230-4)
  history      history: the calibration ledger of a fleet
  artefact     artefact: ball and hole plates, ball beams, step gauges; plate fits
  acceptance   acceptance: decisions of conformity, ISO 10360-2 and 10360-5
  report       certificate, and every --report: words, tables and figures
  bench        bench: throughput of the models and the decoder
  workbench    workbench: the same jobs in a browser, with live capture
docs/cli.md describes every command and flag.";

/// Measure and model the volumetric error of coordinate measuring machines.
#[derive(Debug, Parser)]
#[command(name = "errmap", version, about, after_help = STAGES)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size of the largest variant (export's flags) costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Run the whole pipeline on built-in data and write the reports.
    Demo(DemoArgs),
    /// Fit one model to an error table and predict at points.
    Fit(FitArgs),
    /// Compare methods and Lagrange orders on test points, with cross-validation.
    Compare(CompareArgs),
    /// Simulate random node errors and compare fuzzy, trilinear and spline interpolation.
    FuzzySim(FuzzySimArgs),
    /// Run the simulated acquisition device on a pseudo-terminal and stream its frames.
    ServeSim(ServeSimArgs),
    /// Acquire from a serial device into a session directory.
    Capture(CaptureArgs),
    /// Decode a raw capture into a session table.
    Replay(ReplayArgs),
    /// Reduce a session table to an error table (with ISO 230-2 statistics).
    Table(TableArgs),
    /// List the serial ports of this system.
    Ports(PortsArgs),
    /// Simulate a session from a machine model and a measurement plan.
    Simulate(SimulateArgs),
    /// Regenerate the concealed-effect cases (recorded/simulated pairs). Developer command.
    #[command(hide = true)]
    GenConcealed(GenConcealedArgs),
    /// Diagnose every concealed case and write its report (reports/diagnosis/). Developer
    /// command.
    #[command(hide = true)]
    ReportConcealed(ReportConcealedArgs),
    /// Measure speed: the interpolators, fits, the decoder, streaming replay and table, and
    /// volumetric identification.
    Bench(BenchArgs),
    /// Find and model what the simulation left out of a recording.
    Diagnose(DiagnoseArgs),
    // Export compensation tables (every controller of the registry, CSV) or a volumetric
    // grid; --existing updates a table in use: `values::export_about`, from the registry.
    #[command(about = values::export_about())]
    Export(ExportArgs),
    /// Write an ISO 230-2 test plan along one axis and its part program.
    Plan(plan::PlanArgs),
    /// Volumetric error from laser line measurements: the 21 geometric errors, identified,
    /// predicted and exported.
    Volumetric(volumetric::VolumetricArgs),
    /// Artefacts (ball and hole plates, ball beams, step gauges): plate fits, and the 21
    /// errors identified from positions of an artefact.
    Artefact(artefact::ArtefactArgs),
    /// Ballbar circular tests (ISO 230-4): evaluate, diagnose, simulate.
    Circular(circular::CircularArgs),
    /// Write the calibration certificate (PDF) of a session.
    Certificate(certificate::CertificateArgs),
    /// Write a long simulated raw capture (benchmarks and soak tests of replay and table).
    /// Developer command.
    #[command(hide = true)]
    GenCapture(stream::GenCaptureArgs),
    // Read a laser export, a spreadsheet or a controller table (the controllers from the
    // registry: `values::import_about`).
    #[command(about = values::import_about())]
    Import(import::ImportArgs),
    /// The calibration history of a fleet in a ledger (SQLite or PostgreSQL): add, report, verify.
    History(history::HistoryArgs),
    /// Decisions of conformity; the ISO 10360-2 length measurement error test.
    Acceptance(acceptance::AcceptanceArgs),
    /// Serve the workbench: errmap's results in a local web browser (pages, charts, JSON,
    /// live capture).
    #[cfg(feature = "workbench")]
    Workbench(workbench::WorkbenchArgs),
}

pub(crate) fn main() -> ExitCode {
    guard::quiet_on_closed_output();
    guard::on_signals();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<guard::StdoutClosed>().is_some() => {
            ExitCode::from(guard::STDOUT_CLOSED_STATUS)
        }
        Err(e) if e.downcast_ref::<guard::Usage>().is_some() => {
            eprintln!("error: {e:#}\n\nFor more information, try '--help'.");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("errmap: error: {}", message(&e));
            ExitCode::from(1)
        }
    }
}

/// The error and its causes, `: `-separated, each cause left out when the text before
/// already holds it (errors that print their source, such as an I/O error's OS reason,
/// gave `No such file or directory (os error 2): No such file or directory (os error 2)`).
fn message(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let c = in_flags(cause);
        if text.is_empty() {
            text = c;
        } else if !text.contains(&c) {
            text = format!("{text}: {c}");
        }
    }
    text
}

/// A library error in the command line's words: where the library's message stops at its
/// own terms, the flag that would change the outcome is added.
fn in_flags(cause: &(dyn std::error::Error + 'static)) -> String {
    if let Some(text) = flags::in_flags(cause) {
        return text;
    }
    if let Some(errmap::acquire::AcquireError::Exists { .. }) = cause.downcast_ref() {
        return format!("{cause}; choose another --out");
    }
    if let Some(e) = cause.downcast_ref::<errmap::acceptance::AcceptanceError>()
        && let Some(text) = probing::in_flags(e)
    {
        return text;
    }
    if let Some(e) = cause.downcast_ref::<errmap::history::HistoryError>()
        && let Some(text) = history::in_flags(e)
    {
        return text;
    }
    if let Some(errmap::volumetric::VolumetricError::NoFit { .. }) = cause.downcast_ref() {
        return format!(
            "{cause}: write the model with `errmap volumetric identify … --out MODEL.json`"
        );
    }
    cause.to_string()
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(a) => demo::demo(a),
        Command::Fit(a) => model::fit(a),
        Command::Compare(a) => model::compare_cmd(a),
        Command::FuzzySim(a) => model::fuzzy_sim(a),
        Command::ServeSim(a) => acquisition::serve_sim(a),
        Command::Capture(a) => acquisition::capture_cmd(a),
        Command::Replay(a) => acquisition::replay_cmd(a),
        Command::Table(a) => acquisition::table_cmd(a),
        Command::Ports(a) => acquisition::ports(a),
        Command::Simulate(a) => model::simulate_cmd(a),
        Command::Diagnose(a) => diagnose::diagnose_cmd(a),
        Command::Export(a) => model::export_cmd(a),
        Command::Plan(a) => plan::plan_cmd(a),
        Command::Volumetric(a) => volumetric::volumetric_cmd(a),
        Command::Certificate(a) => certificate::certificate_cmd(a),
        Command::Circular(a) => circular::circular_cmd(a),
        Command::Artefact(a) => artefact::artefact_cmd(a),
        Command::GenCapture(a) => stream::gen_capture(a),
        Command::Import(a) => import::import_cmd(a),
        Command::History(a) => history::history_cmd(a),
        Command::Acceptance(a) => acceptance::acceptance_cmd(a),
        #[cfg(feature = "workbench")]
        Command::Workbench(a) => workbench::workbench_cmd(a),
        Command::Bench(a) => {
            let mut r = if a.history_only {
                errmap::bench::BenchReport::default()
            } else {
                errmap::bench::run(&errmap::bench::BenchConfig {
                    points: a.points.max(1),
                    threads: guard::threads("--threads", a.threads),
                    ..Default::default()
                })
            };
            r.history = history::bench(&a)?;
            if a.json {
                guard::print_json(&r)?;
            } else {
                eprint!("{}", errmap::bench::markdown(&r));
            }
            Ok(())
        }
        Command::ReportConcealed(a) => diagnose::report_concealed(&a.cases, &a.out),
        Command::GenConcealed(a) => {
            // A new output directory appears whole or not at all.
            let dirs =
                guard::into_new_dir(&a.out, |d| Ok(errmap::sim::write_concealed(d, &a.table1)?))?;
            eprintln!(
                "gen-concealed: {} cases under {}",
                dirs.len(),
                a.out.display()
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    /// Issue 17: OS errors were printed twice, by the error and again as its cause.
    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        #[derive(Debug, thiserror::Error)]
        #[error("t.csv: cannot read: {0}")]
        struct Io(#[source] std::io::Error);
        let e = anyhow::Error::from(Io(std::io::Error::from(std::io::ErrorKind::NotFound)));
        let m = super::message(&e);
        assert_eq!(m, "t.csv: cannot read: entity not found");
        let e = anyhow::anyhow!("inner").context("outer");
        assert_eq!(super::message(&e), "outer: inner");
    }

    /// Every flag and argument a user can see says what it is, in a whole sentence (issue
    /// 35: `export --out` and `--json` had no help, one help text stopped mid-sentence).
    #[test]
    fn every_visible_argument_has_a_whole_help_text() {
        use clap::CommandFactory;
        // clap drops a one-line help's final period, so a sentence cut short shows as a
        // help ending in a word that needs another after it.
        const DANGLING: [&str; 12] = [
            "without", "with", "and", "or", "the", "of", "to", "a", "an", "by", "for", "in",
        ];
        fn walk(cmd: &clap::Command, path: &str, missing: &mut Vec<String>) {
            for a in cmd.get_arguments() {
                let id = a.get_id().as_str();
                if a.is_hide_set() || id == "help" || id == "version" {
                    continue;
                }
                let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                let help = help.trim();
                if help.is_empty() {
                    missing.push(format!("{path} {id}: no help"));
                } else if let Some(last) = help.split_whitespace().last()
                    && DANGLING.contains(&last)
                {
                    missing.push(format!("{path} {id}: stops mid-sentence: {help}"));
                }
            }
            for sub in cmd.get_subcommands() {
                if sub.is_hide_set() {
                    continue;
                }
                walk(sub, &format!("{path} {}", sub.get_name()), missing);
            }
        }
        let mut missing = Vec::new();
        walk(&super::Cli::command(), "errmap", &mut missing);
        assert!(missing.is_empty(), "{}", missing.join("\n"));
    }

    /// A model without a fit: the command line says which command writes one.
    #[test]
    fn a_model_without_a_fit_names_the_command_that_writes_one() {
        let e = anyhow::Error::from(errmap::volumetric::VolumetricError::NoFit {
            path: "m.json".into(),
        });
        assert_eq!(
            super::message(&e),
            "m.json: fit: missing: write the model with `errmap volumetric identify … --out MODEL.json`"
        );
    }

    /// The library says a capture never overwrites; the command line adds its flag.
    #[test]
    fn an_existing_capture_names_the_out_flag() {
        let e = anyhow::Error::from(errmap::acquire::AcquireError::Exists {
            path: "s/raw.bin".into(),
        });
        assert_eq!(
            super::message(&e),
            "s/raw.bin already exists: a capture never overwrites an earlier one; choose another --out"
        );
    }
}
