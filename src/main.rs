//! The `errmap` binary: argument parsing and glue. Each subcommand is one short function
//! that validates its flags into library configuration and calls the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};

use errmap::compare::{self, DEFAULT_MAX_DEGREE};
use errmap::experiment::{self, FuzzySimConfig};
use errmap::interp::{Method, Order, fuzzy};
use errmap::report;
use errmap::table::{ErrorPoint, ErrorTable};

#[path = "cli/acquisition.rs"]
mod acquisition;
use acquisition::{capture_cmd, ports, replay_cmd, serve_sim, table_cmd};

/// Measure and model the volumetric error of coordinate measuring machines.
#[derive(Debug, Parser)]
#[command(name = "errmap", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the whole pipeline on built-in data and write the reports.
    Demo(DemoArgs),
    /// Fit one model to an error table and predict at points.
    Fit(FitArgs),
    /// Compare methods and Lagrange orders on test points, with cross-validation.
    Compare(CompareArgs),
    /// Seed 000's simulation: fuzzy vs trilinear vs spline on random node errors.
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
    Ports,
    /// Simulate a session from a machine model and a measurement plan.
    Simulate(SimulateArgs),
    /// Regenerate the concealed-effect cases (recorded/simulated pairs).
    GenConcealed(GenConcealedArgs),
    /// Diagnose every concealed case and write its report (reports/diagnosis/).
    ReportConcealed(ReportConcealedArgs),
    /// Throughput of the interpolators, fit times and the decoder's speed.
    Bench(BenchArgs),
    /// Find and model what the simulation left out of a recording.
    Diagnose(DiagnoseArgs),
    /// Export compensation tables (LinuxCNC, Siemens 840D, CSV) or a volumetric grid.
    Export(ExportArgs),
}

#[derive(Debug, Args)]
struct ExportArgs {
    /// Error table to fit.
    table: PathBuf,
    /// lagrange | trilinear | spline | fuzzy | gp | gp-se (the GPs also take a scattered
    /// table; gp uses --gp-kernel, gp-se the squared exponential)
    #[arg(long)]
    method: String,
    /// Lagrange degrees MxNxQ (or auto).
    #[arg(long)]
    order: Option<String>,
    /// The compensated axis (line formats): x, y or z.
    #[arg(long, default_value = "x")]
    axis: String,
    /// The fixed coordinates of the line, e.g. `y=1,z=200` (mm).
    #[arg(long, default_value = "")]
    at: String,
    /// Sampling step along the line, or the grid spacing, mm.
    #[arg(long)]
    step: f64,
    /// Line start and end, mm (default: the table's range on the axis).
    #[arg(long)]
    start: Option<f64>,
    #[arg(long)]
    end: Option<f64>,
    /// linuxcnc | siemens | csv | grid
    #[arg(long)]
    format: String,
    /// LinuxCNC COMP_FILE_TYPE: actual (0, the positions reached) or trim (1, the offsets).
    #[arg(long, default_value = "actual")]
    comp_type: String,
    /// Siemens machine-axis name, e.g. X1.
    #[arg(long, default_value = "X1")]
    siemens_axis: String,
    /// Siemens MD38000 MM_ENC_COMP_MAX_POINTS of the control.
    #[arg(long, default_value_t = errmap::export::SIEMENS_808D_MAX_POINTS)]
    max_points: usize,
    /// Refuse positions outside the mapped range instead of flagging them.
    #[arg(long)]
    forbid_extrapolation: bool,
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    model: ModelArgs,
}

#[derive(Debug, Args)]
struct DiagnoseArgs {
    /// The recorded session (table, or a capture directory).
    #[arg(long)]
    recorded: PathBuf,
    /// The simulated session of the same plan.
    #[arg(long, conflicts_with = "model", required_unless_present = "model")]
    simulated: Option<PathBuf>,
    /// A machine model to simulate the recording with (instead of --simulated).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Report directory.
    #[arg(long)]
    report: PathBuf,
    /// The scale's grating period, µm (default: the model's, or the capture's HELLO).
    #[arg(long)]
    grating_period_um: Option<f64>,
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct BenchArgs {
    /// Query points.
    #[arg(long, default_value_t = 1_000_000)]
    points: usize,
    /// Threads for the parallel runs (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct ReportConcealedArgs {
    #[arg(long, default_value = "datasets/concealed")]
    cases: PathBuf,
    #[arg(long, default_value = "reports/diagnosis")]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct GenConcealedArgs {
    #[arg(long, default_value = "datasets/concealed")]
    out: PathBuf,
    /// Table 1, the nominal machine's error map.
    #[arg(long, default_value = "datasets/table1.csv")]
    table1: PathBuf,
}

#[derive(Debug, Args)]
struct SimulateArgs {
    /// Machine model (TOML).
    #[arg(long)]
    model: PathBuf,
    /// Measurement plan (TOML).
    #[arg(long)]
    plan: PathBuf,
    /// Session table to write (CSV or Parquet).
    #[arg(long)]
    out: PathBuf,
    /// The model's expectation without its white noise.
    #[arg(long)]
    no_noise: bool,
    /// Also write the board's raw byte stream here (replayable).
    #[arg(long)]
    raw: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct FaultArgs {
    /// Probability per frame of a burst of garbage bytes before it.
    #[arg(long, default_value_t = 0.0)]
    garbage: f64,
    /// Probability per frame of one flipped bit.
    #[arg(long, default_value_t = 0.0)]
    bit_flips: f64,
    /// Probability per frame that it is lost on the line.
    #[arg(long, default_value_t = 0.0)]
    drop_frames: f64,
    /// Beam-loss window in session seconds, START:END.
    #[arg(long)]
    beam_loss: Option<String>,
    /// Start both counters this many counts below the 32-bit wrap.
    #[arg(long)]
    near_wrap: Option<i32>,
    #[arg(long, default_value_t = 1)]
    fault_seed: u64,
}

#[derive(Debug, Args)]
struct ServeSimArgs {
    /// Machine model (TOML).
    #[arg(long)]
    model: PathBuf,
    /// Measurement plan (TOML); a built-in 11-target X plan without it.
    #[arg(long)]
    plan: Option<PathBuf>,
    /// Playback speed (1 = real time; the byte budget holds in the board's own time).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Seconds to keep the port open after the last frame.
    #[arg(long, default_value_t = 1.0)]
    linger: f64,
    /// Give up (exit 1) when no host has read the port for this many seconds: the port
    /// was never opened, or the capture ended early. 0 waits for ever.
    #[arg(long, default_value_t = 60.0)]
    stall_timeout: f64,
    /// Write the simulated truth per sample (CSV) here.
    #[arg(long)]
    truth_out: Option<PathBuf>,
    #[command(flatten)]
    faults: FaultArgs,
}

#[derive(Debug, Args)]
struct CaptureArgs {
    /// Serial device path (e.g. /dev/ttyUSB0, or the path serve-sim prints).
    #[arg(long)]
    port: String,
    /// Session directory (created; an existing capture there is never overwritten).
    #[arg(long)]
    out: PathBuf,
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Session table format: csv or parquet.
    #[arg(long, default_value = "csv")]
    format: String,
    /// Stop after this many seconds without a byte.
    #[arg(long)]
    idle_timeout: Option<f64>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
    /// Print the session description as JSON on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct ReplayArgs {
    /// Raw capture file.
    raw: PathBuf,
    /// Session table to write (CSV or Parquet).
    #[arg(long)]
    out: PathBuf,
    /// Print the decoder statistics as JSON on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct TableArgs {
    /// Session table, or a session directory written by capture.
    session: PathBuf,
    /// Error table to write (CSV or Parquet).
    #[arg(long)]
    out: PathBuf,
    /// Write the ISO 230-2 report (markdown and figures) here.
    #[arg(long)]
    report: Option<PathBuf>,
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct DemoArgs {
    /// Directory for the demo's reports.
    #[arg(long, default_value = "reports/demo")]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct ModelArgs {
    /// Fuzzy membership width σ as a fraction of the cell size (0 < σ).
    #[arg(long, default_value_t = fuzzy::DEFAULT_SIGMA)]
    fuzzy_sigma: f64,
    /// Highest Lagrange degree per axis tried by `auto`/`all`.
    #[arg(long, default_value_t = DEFAULT_MAX_DEGREE)]
    max_degree: usize,
    /// Gaussian-process kernel: matern52 or se (squared exponential).
    #[arg(long, default_value = "matern52")]
    gp_kernel: String,
}

#[derive(Debug, Args)]
struct FitArgs {
    /// Error table (CSV or Parquet): x_mm,y_mm,z_mm,e_um.
    table: PathBuf,
    /// lagrange | trilinear | spline | fuzzy | gp | gp-se (the GPs also take a scattered
    /// table; gp uses --gp-kernel, gp-se the squared exponential)
    #[arg(long)]
    method: String,
    /// Lagrange degrees MxNxQ along x, y, z, or `auto` (chosen by cross-validation).
    #[arg(long)]
    order: Option<String>,
    /// Points to predict at (CSV or Parquet with x_mm,y_mm,z_mm; e_um optional).
    #[arg(long)]
    predict: PathBuf,
    /// Write the predictions as a table (CSV or Parquet).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print one JSON document on stdout.
    #[arg(long)]
    json: bool,
    /// Worker threads for the predictions (0: all cores).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    #[command(flatten)]
    model: ModelArgs,
}

#[derive(Debug, Args)]
struct CompareArgs {
    /// Error table to fit (CSV or Parquet).
    table: PathBuf,
    /// Test points with measured e_um (CSV or Parquet); `paper_MxNxQ` columns are compared too.
    #[arg(long)]
    test: PathBuf,
    /// Comma list of methods (default: all; gp then means both kernels, Matérn 5/2 and SE).
    #[arg(long, value_delimiter = ',')]
    methods: Option<Vec<String>>,
    /// Lagrange orders: `all` (every admissible order up to --max-degree), `auto` (only the
    /// one cross-validation picks), or a comma list like 4x1x2,2x1x2.
    #[arg(long, default_value = "all")]
    orders: String,
    /// Report directory.
    #[arg(long)]
    report: PathBuf,
    /// Print one JSON document on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    model: ModelArgs,
}

#[derive(Debug, Args)]
struct FuzzySimArgs {
    #[arg(long, default_value_t = 2013)]
    seed: u64,
    #[arg(long, default_value_t = 200)]
    trials: usize,
    #[arg(long, default_value_t = fuzzy::DEFAULT_SIGMA)]
    fuzzy_sigma: f64,
    /// Write a markdown report here.
    #[arg(long)]
    report: Option<PathBuf>,
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("errmap: error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(a) => demo(a),
        Command::Fit(a) => fit(a),
        Command::Compare(a) => compare_cmd(a),
        Command::FuzzySim(a) => fuzzy_sim(a),
        Command::ServeSim(a) => serve_sim(a),
        Command::Capture(a) => capture_cmd(a),
        Command::Replay(a) => replay_cmd(a),
        Command::Table(a) => table_cmd(a),
        Command::Ports => ports(),
        Command::Simulate(a) => simulate_cmd(a),
        Command::Diagnose(a) => acquisition::diagnose_cmd(a),
        Command::Export(a) => export_cmd(a),
        Command::Bench(a) => {
            let r = errmap::bench::run(&errmap::bench::BenchConfig {
                points: a.points.max(1),
                threads: a.threads,
                ..Default::default()
            });
            if a.json {
                println!("{}", serde_json::to_string(&r)?);
            } else {
                eprint!("{}", errmap::bench::markdown(&r));
            }
            Ok(())
        }
        Command::ReportConcealed(a) => acquisition::report_concealed(&a.cases, &a.out),
        Command::GenConcealed(a) => {
            let dirs = errmap::concealed::write_all(&a.out, &a.table1)?;
            eprintln!(
                "gen-concealed: {} cases under {}",
                dirs.len(),
                a.out.display()
            );
            Ok(())
        }
    }
}

/// Turns `--method`/`--order` into a method; `auto` runs the cross-validation.
fn parse_method(
    name: &str,
    order: Option<&str>,
    model: &ModelArgs,
    grid: Option<&errmap::table::Grid>,
) -> Result<Method> {
    Ok(match name {
        "lagrange" => match order {
            None => bail!(
                "--method lagrange needs --order MxNxQ (degrees along x, y, z) or --order auto"
            ),
            Some("auto") => {
                let grid = grid.context("--order auto needs a grid table")?;
                Method::Lagrange(compare::auto_order(grid, model.max_degree)?.0)
            }
            Some(o) => Method::Lagrange(o.parse::<Order>().map_err(anyhow::Error::msg)?),
        },
        "trilinear" | "spline" | "fuzzy" | "gp" | "gp-se" if order.is_some() => {
            bail!("--order applies to lagrange only, not to {name}")
        }
        "trilinear" => Method::Trilinear,
        "spline" => Method::Spline,
        "fuzzy" => Method::Fuzzy {
            sigma: model.fuzzy_sigma,
        },
        "gp" => Method::Gp(match model.gp_kernel.as_str() {
            "matern52" | "matern" => errmap::gp::Kernel::Matern52,
            "se" | "squared-exponential" => errmap::gp::Kernel::SquaredExponential,
            other => bail!("--gp-kernel is matern52 or se, not {other}"),
        }),
        // The squared-exponential GP by name (what `compare` calls its row).
        "gp-se" => Method::Gp(errmap::gp::Kernel::SquaredExponential),
        other => bail!("unknown method `{other}` (lagrange, trilinear, spline, fuzzy, gp, gp-se)"),
    })
}

/// A table and one method fitted to it, with the nodes' box.
struct Fitted {
    method: Method,
    model: Box<dyn errmap::interp::Interpolator>,
    extent: compare::Extent,
}

/// Reads `path` and fits the method named `name`: the Gaussian process to the nodes as
/// they are (scattered or not), the interpolators to the grid (the error names a missing
/// node).
fn fit_table(path: &Path, name: &str, order: Option<&str>, model: &ModelArgs) -> Result<Fitted> {
    let table = ErrorTable::read(path)?;
    let grid = if name == "gp" || name == "gp-se" {
        None
    } else {
        Some(table.grid()?)
    };
    let method = parse_method(name, order, model, grid.as_ref())?;
    let fitted = match &grid {
        Some(g) => method.fit(g).map_err(anyhow::Error::from),
        None => method
            .fit_points(&table.points)
            .map_err(anyhow::Error::from),
    }
    .with_context(|| format!("{}: cannot fit {}", path.display(), method.label()))?;
    Ok(Fitted {
        method,
        model: fitted,
        extent: match &grid {
            Some(g) => compare::Extent::of_grid(g),
            None => compare::Extent::of_points(&table),
        },
    })
}

fn fit(a: FitArgs) -> Result<()> {
    let Fitted { method, model, .. } =
        fit_table(&a.table, &a.method, a.order.as_deref(), &a.model)?;
    let points = ErrorTable::read_points(&a.predict)?;
    let positions: Vec<[f64; 3]> = points.points.iter().map(|p| p.position()).collect();
    let mut values = vec![0.0; positions.len()];
    errmap::interp::predict_parallel(model.as_ref(), &positions, &mut values, a.threads)?;
    let preds: Vec<(ErrorPoint, bool)> = positions
        .iter()
        .zip(&values)
        .map(|(&p, &e)| (ErrorPoint::new(p[0], p[1], p[2], e), model.outside(p)))
        .collect();
    // One-sigma of each prediction where the model has one (the Gaussian process).
    let sigmas: Vec<Option<f64>> = {
        use rayon::prelude::*;
        positions.par_iter().map(|&p| model.sigma(p)).collect()
    };
    if let Some(out) = &a.out {
        errmap::table::write_predictions(out, &preds, &sigmas)?;
    }
    let n_out = preds.iter().filter(|p| p.1).count();
    if a.json {
        let json = serde_json::json!({
            "method": method.name(),
            "order": method.order().map(|o| o.0),
            "predictions": preds.iter().zip(&sigmas).map(|((p, e), s)| serde_json::json!({
                "x_mm": p.x_mm, "y_mm": p.y_mm, "z_mm": p.z_mm, "e_um": p.e_um, "extrapolated": e,
                "sigma_um": s
            })).collect::<Vec<_>>(),
        });
        println!("{json}");
    } else {
        eprintln!(
            "{}: {} predictions ({} extrapolated){}",
            method.label(),
            preds.len(),
            n_out,
            a.out
                .as_ref()
                .map(|p| format!(", written to {}", p.display()))
                .unwrap_or_default()
        );
        for ((p, e), s) in preds.iter().zip(&sigmas) {
            eprintln!(
                "  {:>10.4} {:>10.4} {:>10.4}  {:>10.4} µm{}{}",
                p.x_mm,
                p.y_mm,
                p.z_mm,
                p.e_um,
                s.map(|s| format!(" ± {s:.4}")).unwrap_or_default(),
                if *e { "  (extrapolated)" } else { "" }
            );
        }
    }
    Ok(())
}

/// The model list of `compare` from `--methods` and `--orders`.
fn compare_methods(a: &CompareArgs, grid: &errmap::table::Grid) -> Result<Vec<Method>> {
    let names: Vec<String> = a.methods.clone().unwrap_or_else(|| {
        ["trilinear", "spline", "fuzzy", "gp", "lagrange"]
            .map(String::from)
            .to_vec()
    });
    let mut out = Vec::new();
    for name in &names {
        match name.trim() {
            "lagrange" => match a.orders.trim() {
                "all" => out.extend(
                    errmap::interp::lagrange::admissible_orders(grid.shape(), a.model.max_degree)
                        .into_iter()
                        .map(Method::Lagrange),
                ),
                "auto" => out.push(Method::Lagrange(
                    compare::auto_order(grid, a.model.max_degree)?.0,
                )),
                list => {
                    for o in list.split(',') {
                        let order: Order = o.parse().map_err(anyhow::Error::msg)?;
                        Method::Lagrange(order).fit(grid).with_context(|| {
                            format!("{}: order {order} cannot be fitted", a.table.display())
                        })?;
                        out.push(Method::Lagrange(order));
                    }
                }
            },
            // By default both kernels: the squared exponential suits analytic error
            // fields, Matérn 5/2 rougher ones, and cross-validation tells them apart.
            "gp" if a.methods.is_none() => out.extend([
                Method::Gp(errmap::gp::Kernel::Matern52),
                Method::Gp(errmap::gp::Kernel::SquaredExponential),
            ]),
            other => out.push(parse_method(other, None, &a.model, Some(grid))?),
        }
    }
    if out.is_empty() {
        bail!("no methods to compare");
    }
    Ok(out)
}

/// The models `compare` fits to a scattered table: the Gaussian process only. Asked for
/// by name, any other method is an error naming the missing grid node; by default both
/// kernels are compared and the grid methods are listed as not fitted, with the reason.
fn scattered_methods(
    a: &CompareArgs,
    missing: &errmap::table::TableError,
) -> Result<(Vec<Method>, compare::Refusals)> {
    use errmap::gp::Kernel;
    let grid_only = ["trilinear", "spline", "fuzzy", "lagrange"];
    let why = format!("a full grid is needed ({missing})");
    match &a.methods {
        Some(names) => {
            let mut methods = Vec::new();
            for name in names {
                match name.trim() {
                    gp @ ("gp" | "gp-se") => methods.push(parse_method(gp, None, &a.model, None)?),
                    other if grid_only.contains(&other) => bail!(
                        "{other} cannot be fitted to {}: {why}. Only gp and gp-se accept scattered nodes.",
                        a.table.display()
                    ),
                    other => {
                        bail!(
                            "unknown method `{other}` (lagrange, trilinear, spline, fuzzy, gp, gp-se)"
                        )
                    }
                }
            }
            if methods.is_empty() {
                bail!("no methods to compare");
            }
            Ok((methods, Vec::new()))
        }
        None => Ok((
            vec![
                Method::Gp(Kernel::Matern52),
                Method::Gp(Kernel::SquaredExponential),
            ],
            grid_only
                .iter()
                .map(|m| (m.to_string(), why.clone()))
                .collect(),
        )),
    }
}

fn compare_cmd(a: CompareArgs) -> Result<()> {
    let table = ErrorTable::read(&a.table)?;
    let test = ErrorTable::read(&a.test)?;
    let comparison = match table.grid() {
        Ok(grid) => {
            let methods = compare_methods(&a, &grid)?;
            if a.methods.is_some() {
                compare::compare(&table, &grid, &test, &methods)
            } else {
                compare::compare_where_possible(&table, &grid, &test, &methods)
            }
        }
        Err(e @ errmap::table::TableError::MissingNode { .. }) => {
            let (methods, refused) = scattered_methods(&a, &e)?;
            compare::compare_scattered(&table, &test, &methods, refused)
        }
        Err(e) => return Err(e.into()),
    }
    .with_context(|| format!("{}: comparison failed", a.table.display()))?;
    let command = format!(
        "errmap compare {} --test {} --report {}{}",
        a.table.display(),
        a.test.display(),
        a.report.display(),
        if a.orders == "all" {
            String::new()
        } else {
            format!(" --orders {}", a.orders)
        }
    );
    report::write_report(&comparison, &a.report, &command)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string(&comparison.to_json(Some(&a.report)))?
        );
    } else {
        print_summary(&comparison, &a.report);
    }
    Ok(())
}

fn print_summary(c: &compare::Comparison, dir: &Path) {
    let rec = c.recommended_row();
    eprintln!(
        "{} models compared on {} test points ({} extrapolated).",
        c.rows.len(),
        c.test.points.len(),
        c.extrapolated.iter().filter(|e| **e).count()
    );
    eprintln!(
        "recommended by cross-validation: {} (CV RMS {:.4} µm; test RMS {:.4} µm)",
        rec.method.label(),
        rec.cv.rms_um,
        rec.rms_um
    );
    eprintln!("report: {}", dir.join("report.md").display());
}

fn write_input(dir: &Path, name: &str, text: &str) -> Result<PathBuf> {
    let p = dir.join(name);
    std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
    Ok(p)
}

fn demo_compare(table: PathBuf, test: PathBuf, report: PathBuf) -> Result<()> {
    compare_cmd(CompareArgs {
        table,
        test,
        methods: None,
        orders: "all".into(),
        report,
        json: false,
        model: ModelArgs {
            fuzzy_sigma: fuzzy::DEFAULT_SIGMA,
            max_degree: DEFAULT_MAX_DEGREE,
            gp_kernel: "matern52".into(),
        },
    })
}

/// The whole pipeline on built-in data: the simulated board on a pseudo-terminal →
/// capture → error table (+ ISO 230-2) → comparison against the simulated truth; then the
/// paper's Table 1 → Table 2 comparison.
fn demo(a: DemoArgs) -> Result<()> {
    let inputs = a.out.join("inputs");
    std::fs::create_dir_all(&inputs)
        .with_context(|| format!("cannot create {}", inputs.display()))?;
    let t1 = write_input(
        &inputs,
        "table1.csv",
        include_str!("../datasets/table1.csv"),
    )?;
    let t2 = write_input(
        &inputs,
        "table2.csv",
        include_str!("../datasets/table2.csv"),
    )?;
    let model = write_input(
        &inputs,
        "model.toml",
        &include_str!("../datasets/sim/model.toml").replace("\"../table1.csv\"", "\"table1.csv\""),
    )?;
    let plan = write_input(
        &inputs,
        "plan.toml",
        include_str!("../datasets/sim/plan.toml"),
    )?;
    let machine = write_input(
        &inputs,
        "machine.toml",
        &include_str!("../datasets/sim/machine.toml")
            .replace("\"../table1.csv\"", "\"table1.csv\""),
    )?;

    eprintln!("errmap demo [1/5]: simulated board (machine.toml) on a pseudo-terminal → capture");
    let session_dir = a.out.join("session");
    if session_dir.exists() {
        std::fs::remove_dir_all(&session_dir).with_context(|| {
            format!(
                "cannot clear the previous demo session {}",
                session_dir.display()
            )
        })?;
    }
    let (stream, truth) =
        errmap::acquire::simulate_stream(&machine, Some(&plan), &Default::default())?;
    let baud = errmap::physics::MachineModel::read(&model)?.device.baud;
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let server = std::thread::spawn(move || {
        acquisition::serve_stream(&stream, 10.0, 1.5, 30.0, |path| {
            let _ = tx.send(path.to_string());
        })
    });
    let port = rx.recv().context("the simulated device did not start")?;
    eprintln!("  device on {port} (10× real time)");
    let paths = errmap::acquire::SessionPaths::new(&session_dir, "csv");
    let config = errmap::drivers::capture::CaptureConfig {
        idle_timeout: Some(std::time::Duration::from_millis(800)),
        ..Default::default()
    };
    let cap = acquisition::capture_from_port(&port, baud, &paths, &config, true)?;
    match server.join() {
        Ok(r) => {
            r?;
        }
        Err(_) => bail!("the simulated device thread failed"),
    }
    eprintln!(
        "  captured {} bytes, {} rows, {} CRC failures → {}",
        cap.bytes,
        cap.rows.len(),
        cap.stats.crc_failures,
        session_dir.display()
    );

    eprintln!("errmap demo [2/5]: session → error table (+ ISO 230-2 report)");
    let errors = session_dir.join("errors.csv");
    acquisition::table_cmd(TableArgs {
        session: session_dir.clone(),
        out: errors.clone(),
        report: Some(session_dir.join("iso230")),
        json: false,
    })?;

    eprintln!("errmap demo [3/5]: fit every method to the captured table, compare with the truth");
    let test = errmap::acquire::truth_test_points(&truth, &errors, 40, 11)?;
    let test_path = session_dir.join("truth_points.csv");
    test.write(&test_path)?;
    demo_compare(errors, test_path, a.out.join("capture_comparison"))?;

    eprintln!("errmap demo [4/5]: diagnose the capture against the nominal model (model.toml)");
    acquisition::diagnose_cmd(DiagnoseArgs {
        recorded: session_dir.clone(),
        simulated: None,
        model: Some(model),
        report: a.out.join("diagnosis"),
        grating_period_um: None,
        json: false,
    })?;

    eprintln!("errmap demo [5/5]: the paper's Table 1 → Table 2 (seed 001)");
    demo_compare(t1, t2, a.out.join("table2"))?;
    eprintln!("errmap demo: done; reports under {}", a.out.display());
    Ok(())
}

fn export_cmd(a: ExportArgs) -> Result<()> {
    use errmap::export::{
        ExportFormat, Extrapolation, LineSpec, LinuxCncCompType, VolumeSpec, sample_line,
        volumetric_grid,
    };
    use errmap::table::Axis;
    let Fitted { model, extent, .. } =
        fit_table(&a.table, &a.method, a.order.as_deref(), &a.model)?;
    let extrapolation = if a.forbid_extrapolation {
        Extrapolation::Forbid
    } else {
        Extrapolation::Allow
    };
    let format = match a.format.as_str() {
        "linuxcnc" => ExportFormat::LinuxCnc {
            comp_type: match a.comp_type.as_str() {
                "actual" | "0" => LinuxCncCompType::ActualPosition,
                "trim" | "1" => LinuxCncCompType::Trim,
                other => bail!("--comp-type is actual (0) or trim (1), not {other}"),
            },
        },
        "siemens" => ExportFormat::Siemens {
            axis_name: a.siemens_axis.clone(),
            max_points: a.max_points,
        },
        "csv" => ExportFormat::Csv,
        "grid" => ExportFormat::Grid,
        other => bail!("--format is linuxcnc, siemens, csv or grid, not {other}"),
    };
    let lo = extent.bounds.map(|b| b[0]);
    let hi = extent.bounds.map(|b| b[1]);
    if !format.is_line() {
        let n = volumetric_grid(
            model.as_ref(),
            &VolumeSpec {
                lo_mm: lo,
                hi_mm: hi,
                spacing_mm: a.step,
            },
            extrapolation,
            &a.out,
        )?;
        eprintln!("export: {n} grid points → {}", a.out.display());
        return Ok(());
    }
    let axis = match a.axis.as_str() {
        "x" | "X" => Axis::X,
        "y" | "Y" => Axis::Y,
        "z" | "Z" => Axis::Z,
        other => bail!("--axis is x, y or z, not {other}"),
    };
    // The line's fixed coordinates: given ones, else the first node on that axis.
    let mut at = lo;
    for part in a.at.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (k, v) = part
            .split_once('=')
            .with_context(|| format!("--at takes axis=value pairs like y=1,z=200, not `{part}`"))?;
        let v: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("--at: `{v}` is not a number"))?;
        match k.trim() {
            "x" | "X" => at[0] = v,
            "y" | "Y" => at[1] = v,
            "z" | "Z" => at[2] = v,
            other => bail!("--at: unknown axis `{other}`"),
        }
    }
    let line = LineSpec {
        axis,
        at_mm: at,
        start_mm: a.start.unwrap_or(lo[axis.index()]),
        end_mm: a.end.unwrap_or(hi[axis.index()]),
        step_mm: a.step,
    };
    let sampled = sample_line(model.as_ref(), &line, extrapolation)?;
    let text = format.render_line(&sampled, None)?;
    std::fs::write(&a.out, text).with_context(|| format!("cannot write {}", a.out.display()))?;
    eprintln!(
        "export: {} {} entries along {} at ({}, {}, {}) mm ({} extrapolated) → {}; compensation = −error",
        format.name(),
        sampled.positions_mm.len(),
        a.axis,
        at[0],
        at[1],
        at[2],
        sampled.extrapolated_count(),
        a.out.display()
    );
    Ok(())
}

fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    let model = errmap::physics::MachineModel::read(&a.model)?;
    let plan = errmap::acquire::read_plan(Some(&a.plan))?;
    let (stream, _) =
        errmap::physics::simulate_plan(&model, &a.model, &plan, &Default::default(), !a.no_noise)?;
    let bytes = stream.bytes();
    if let Some(raw) = &a.raw {
        std::fs::write(raw, &bytes).with_context(|| format!("cannot write {}", raw.display()))?;
    }
    let (rows, _, _) = errmap::drivers::decode_all(&bytes);
    errmap::session::write_session(&a.out, &rows)?;
    eprintln!(
        "simulate: {} rows, {:.1} s of session time → {}",
        rows.len(),
        stream.duration_s,
        a.out.display()
    );
    Ok(())
}

fn fuzzy_sim(a: FuzzySimArgs) -> Result<()> {
    let config = FuzzySimConfig {
        seed: a.seed,
        trials: a.trials.max(1),
        fuzzy_sigma: a.fuzzy_sigma,
        ..FuzzySimConfig::default()
    };
    let result = experiment::run(&config)?;
    let md = experiment::markdown(&result);
    if let Some(dir) = &a.report {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let path = dir.join("report.md");
        std::fs::write(&path, &md).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if a.json {
        println!("{}", serde_json::to_string(&result)?);
    } else {
        eprint!("{md}");
    }
    Ok(())
}
