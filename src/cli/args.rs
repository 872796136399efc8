//! Every clap struct of the binary.

use std::path::PathBuf;

use clap::Args;
use errmap::base::Axis;
use errmap::controller::TableSetting;
use errmap::evaluate::DEFAULT_MAX_DEGREE;
use errmap::interp::Kernel;
use errmap::interp::{DEFAULT_FUZZY_SIGMA, MethodName};

use super::values::{
    CompTypeArg, EndsArg, ExportFormatArg, LineAt, OrderArg, OrdersArg, SessionFormat, Window,
    at_least_two, axis, axis_number, baud, bench_count, bench_points, controller_name, coordinate,
    fuzzy_width, kernel, lagrange_max_degree, length, method_name, positive, probability, seconds,
    trials,
};
use super::values::{bidirectional_help, ends_help, setting_help};

#[derive(Debug, Args)]
pub(crate) struct ExportArgs {
    /// Error table to fit (with --bidirectional: a session table or capture directory).
    pub table: PathBuf,
    /// The model (the GPs also take a scattered table; gp uses --gp-kernel, gp-se the
    /// squared exponential).
    #[arg(long, value_parser = method_name())]
    pub method: Option<MethodName>,
    // Its help names the two-direction formats, from the registry.
    #[arg(long, conflicts_with_all = ["method", "order"], help = bidirectional_help())]
    pub bidirectional: bool,
    /// Lagrange degrees MxNxQ (or auto).
    #[arg(long)]
    pub order: Option<OrderArg>,
    /// The compensated axis (line formats).
    #[arg(long, default_value = "x", value_parser = axis())]
    pub axis: Axis,
    /// The fixed coordinates of the line, e.g. `y=1,z=200` (mm).
    #[arg(long, default_value = "")]
    pub at: LineAt,
    /// Sampling step along the line, or the grid spacing, mm.
    #[arg(long, value_parser = length)]
    pub step: Option<f64>,
    /// Line start, mm (default: the table's lowest node on the axis).
    #[arg(long, allow_negative_numbers = true, value_parser = coordinate)]
    pub start: Option<f64>,
    /// Line end, mm (default: the table's highest node on the axis).
    #[arg(long, allow_negative_numbers = true, value_parser = coordinate)]
    pub end: Option<f64>,
    // Its help names the formats of one interval, from the registry.
    #[arg(long, value_enum, help = ends_help())]
    pub ends: Option<EndsArg>,
    /// The grid's reference position for --ends, mm (e.g. the machine's reference point).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = coordinate)]
    pub reference: f64,
    /// The table's format.
    #[arg(long, value_parser = super::values::export_format())]
    pub format: ExportFormatArg,
    // This and the other common settings: their help lists the controllers that read
    // them, each in its own words, from the registry.
    #[arg(long, value_enum, help = setting_help(TableSetting::CompType))]
    pub comp_type: Option<CompTypeArg>,
    /// The controller table in use (a dialect of --format): write it back
    /// updated by the session's residual (the session measured with it active), in its
    /// own layout, values only.
    #[arg(long, conflicts_with_all = ["method", "order"])]
    pub existing: Option<PathBuf>,
    #[arg(long, help = setting_help(TableSetting::Units))]
    pub units: Option<String>,
    /// --existing: print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// The settings each dialect declares for its tables (`--siemens-axis`,
    /// `--fanuc-max-value`, …), made from the registry.
    #[command(flatten)]
    pub dialect_options: super::values::DialectOptionArgs,
    #[arg(long, value_parser = at_least_two, help = setting_help(TableSetting::MaxPoints))]
    pub max_points: Option<usize>,
    #[arg(long, value_parser = controller_name, help = setting_help(TableSetting::AxisName))]
    pub axis_name: Option<String>,
    #[arg(long, value_parser = axis_number, help = setting_help(TableSetting::AxisNumber))]
    pub axis_number: Option<u32>,
    #[arg(long, value_parser = controller_name, help = setting_help(TableSetting::TableName))]
    pub table_name: Option<String>,
    /// Refuse positions outside the mapped range instead of flagging them.
    #[arg(long)]
    pub forbid_extrapolation: bool,
    /// The compensation table to write (never one of the inputs; with --existing, a new
    /// file beside the old one).
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub model: ModelArgs,
}

#[derive(Debug, Args)]
pub(crate) struct DiagnoseArgs {
    /// The recorded session (table, or a capture directory).
    #[arg(long)]
    pub recorded: PathBuf,
    /// The simulated session of the same plan. Without it and without --model, the
    /// static part (map and reversal) is taken from the recording itself.
    #[arg(long, conflicts_with = "model")]
    pub simulated: Option<PathBuf>,
    /// A machine model to simulate the recording with (instead of --simulated).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// The longest dead path the set-up's optics allow (interferometer to the
    /// measurement's zero point), mm; decides dead path against drift when the data cannot.
    #[arg(long, value_parser = length)]
    pub max_dead_path_mm: Option<f64>,
    /// Report directory.
    #[arg(long)]
    pub report: PathBuf,
    /// The scale's grating period, µm (default: the model's, or the capture's HELLO).
    #[arg(long, value_parser = length)]
    pub grating_period_um: Option<f64>,
    /// Most rows of the recording to hold: a longer one is thinned uniformly in time to
    /// every 2ᵏ-th device sample, which bounds diagnose's memory (about 1 kB a row).
    #[arg(long, default_value_t = errmap::diagnose::MAX_ROWS as u64,
          value_parser = clap::value_parser!(u64).range(1000..=100_000_000))]
    pub max_rows: u64,
    /// Print the diagnosis as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct BenchArgs {
    /// Query points.
    #[arg(long, default_value_t = 1_000_000, value_parser = bench_points)]
    pub points: usize,
    /// Threads for the parallel runs (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Only the calibration ledger's benchmark (history add and report).
    #[arg(long)]
    pub history_only: bool,
    /// Machines of the ledger benchmark (each with --history-tests tests of 3 axes).
    #[arg(long, default_value_t = 2000, value_parser = bench_count)]
    pub history_machines: usize,
    /// Tests per machine of the ledger benchmark.
    #[arg(long, default_value_t = 40, value_parser = bench_count)]
    pub history_tests: usize,
    /// An empty PostgreSQL database for the ledger benchmark (postgres://…); without
    /// it, SQLite only.
    #[arg(long)]
    pub history_postgres: Option<String>,
    /// Print the measurements as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct ReportConcealedArgs {
    #[arg(long, default_value = "datasets/concealed")]
    pub cases: PathBuf,
    #[arg(long, default_value = "reports/diagnosis")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct GenConcealedArgs {
    #[arg(long, default_value = "datasets/concealed")]
    pub out: PathBuf,
    /// Table 1, the nominal machine's error map.
    #[arg(long, default_value = "datasets/table1.csv")]
    pub table1: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    /// Machine model (TOML).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement plan (TOML).
    #[arg(long)]
    pub plan: PathBuf,
    /// Session table to write (CSV or Parquet).
    #[arg(long)]
    pub out: PathBuf,
    /// The model's expectation without its white noise.
    #[arg(long)]
    pub no_noise: bool,
    /// Also write the board's raw byte stream here (replayable).
    #[arg(long)]
    pub raw: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct FaultArgs {
    /// Probability per frame of a burst of garbage bytes before it.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub garbage: f64,
    /// Probability per frame of one flipped bit.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub bit_flips: f64,
    /// Probability per frame that it is lost on the line.
    #[arg(long, default_value_t = 0.0, value_parser = probability)]
    pub drop_frames: f64,
    /// Beam-loss window in session seconds, START:END.
    #[arg(long)]
    pub beam_loss: Option<Window>,
    /// Start both counters this many counts below the 32-bit wrap.
    #[arg(long)]
    pub near_wrap: Option<i32>,
    /// Seed of the injected faults (the same seed gives the same faults).
    #[arg(long, default_value_t = 1)]
    pub fault_seed: u64,
}

#[derive(Debug, Args)]
pub(crate) struct ServeSimArgs {
    /// Machine model (TOML).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement plan (TOML); a built-in 11-target X plan without it.
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// Playback speed (1 = real time; the byte budget holds in the board's own time).
    #[arg(long, default_value_t = 1.0, value_parser = positive)]
    pub speed: f64,
    /// Seconds to keep the port open after the last frame.
    #[arg(long, default_value_t = 1.0, value_parser = seconds)]
    pub linger: f64,
    /// Give up (exit 1) when no host has read the port for this many seconds: the port
    /// was never opened, or the capture ended early. 0 waits for ever.
    #[arg(long, default_value_t = 60.0, value_parser = seconds)]
    pub stall_timeout: f64,
    /// Write the simulated truth per sample (CSV) here.
    #[arg(long)]
    pub truth_out: Option<PathBuf>,
    #[command(flatten)]
    pub faults: FaultArgs,
}

#[derive(Debug, Args)]
pub(crate) struct PortsArgs {
    /// Print the ports as a JSON array of {"name", "kind"} on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct CaptureArgs {
    /// Serial device path (e.g. /dev/ttyUSB0, or the path serve-sim prints).
    #[arg(
        long,
        required_unless_present = "simulate",
        conflicts_with = "simulate"
    )]
    pub port: Option<String>,
    /// No board: serve this simulated machine (a machine model, TOML) on a pseudo-terminal
    /// and capture from it through the same serial-port code, in one command.
    #[arg(long, value_name = "MODEL")]
    pub simulate: Option<PathBuf>,
    /// With --simulate: the measurement plan (TOML); a built-in 11-target X plan without it.
    #[arg(long, requires = "simulate")]
    pub plan: Option<PathBuf>,
    /// With --simulate: playback speed of the simulated board (1 = real time).
    #[arg(long, default_value_t = 10.0, value_parser = positive, requires = "simulate")]
    pub speed: f64,
    /// Session directory (created; an existing capture there is never overwritten).
    #[arg(long)]
    pub out: PathBuf,
    /// Line speed, baud (8N1).
    #[arg(long, default_value_t = 115_200, value_parser = baud)]
    pub baud: u32,
    /// Session table format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: SessionFormat,
    /// Stop after this many seconds without a byte.
    #[arg(long, value_parser = seconds)]
    pub idle_timeout: Option<f64>,
    /// Stop after this many seconds.
    #[arg(long, value_parser = seconds)]
    pub duration: Option<f64>,
    /// Print the session description as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// No live view on a terminal: the plain progress line (as when stderr is not a
    /// terminal).
    #[arg(long)]
    pub no_view: bool,
}

#[derive(Debug, Args)]
pub(crate) struct ReplayArgs {
    /// Raw capture file.
    pub raw: PathBuf,
    /// Session table to write (CSV or Parquet).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the decoder statistics as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// The device description (HELLO) from an earlier capture's session.json, for a
    /// capture whose own HELLO is missing or damaged.
    #[arg(long)]
    pub hello_from: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct TableArgs {
    /// Session table, or a session directory written by capture.
    pub session: PathBuf,
    /// Error table to write (CSV or Parquet).
    #[arg(long)]
    pub out: PathBuf,
    /// Write the ISO 230-2 report (markdown and figures) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Judge every line's E, A, B, R, M against these tolerances (TOML).
    #[arg(long)]
    pub tolerances: Option<PathBuf>,
    /// The test's description (the certificate's info TOML): its stated laser
    /// resolution, drift check, declared conditions and [uncertainty] settings enter the
    /// uncertainty budget, as in `certificate`.
    #[arg(long)]
    pub info: Option<PathBuf>,
    #[command(flatten)]
    pub rule: super::acceptance::RuleArgs,
    /// Print the per-line statistics as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct DemoArgs {
    /// Directory for the demo's reports.
    #[arg(long, default_value = "reports/demo")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct ModelArgs {
    /// Fuzzy membership width σ as a fraction of the cell size (0 < σ).
    #[arg(long, default_value_t = DEFAULT_FUZZY_SIGMA, value_parser = fuzzy_width)]
    pub fuzzy_sigma: f64,
    /// Highest Lagrange degree per axis tried by `auto`/`all`.
    #[arg(long, default_value_t = DEFAULT_MAX_DEGREE, value_parser = lagrange_max_degree)]
    pub max_degree: usize,
    /// Gaussian-process kernel of the method `gp`: Matérn 5/2 or squared exponential.
    #[arg(long, default_value = "matern52", value_parser = kernel())]
    pub gp_kernel: Kernel,
}

impl ModelArgs {
    /// The registry's settings these flags give.
    pub(crate) fn settings(&self) -> errmap::interp::MethodSettings {
        errmap::interp::MethodSettings {
            fuzzy_sigma: self.fuzzy_sigma,
            gp_kernel: self.gp_kernel,
        }
    }
}

#[derive(Debug, Args)]
pub(crate) struct FitArgs {
    /// Error table (CSV or Parquet): x_mm,y_mm,z_mm,e_um.
    pub table: PathBuf,
    /// The model (the GPs also take a scattered table; gp uses --gp-kernel, gp-se the
    /// squared exponential).
    #[arg(long, value_parser = method_name())]
    pub method: MethodName,
    /// Lagrange degrees MxNxQ along x, y, z, or `auto` (chosen by cross-validation).
    #[arg(long)]
    pub order: Option<OrderArg>,
    /// Points to predict at (CSV or Parquet with x_mm,y_mm,z_mm; e_um optional).
    #[arg(long)]
    pub predict: PathBuf,
    /// Write the predictions as a table (CSV or Parquet).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
    /// Worker threads for the predictions (0: all cores).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    #[command(flatten)]
    pub model: ModelArgs,
}

#[derive(Debug, Args)]
pub(crate) struct CompareArgs {
    /// Error table to fit (CSV or Parquet).
    pub table: PathBuf,
    /// Test points with measured e_um (CSV or Parquet); `paper_MxNxQ` columns are compared too.
    #[arg(long)]
    pub test: PathBuf,
    /// Comma list of methods (default: all; gp then means both kernels, Matérn 5/2 and SE).
    #[arg(long, value_delimiter = ',', value_parser = method_name())]
    pub methods: Option<Vec<MethodName>>,
    /// Lagrange orders: `all` (every admissible order up to --max-degree), `auto` (only the
    /// one cross-validation picks), or a comma list like 4x1x2,2x1x2.
    #[arg(long, default_value = "all")]
    pub orders: OrdersArg,
    /// Report directory.
    #[arg(long)]
    pub report: PathBuf,
    /// Print one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub model: ModelArgs,
}

#[derive(Debug, Args)]
pub(crate) struct FuzzySimArgs {
    /// Seed of the first trial's random node and target errors.
    #[arg(long, default_value_t = 2013)]
    pub seed: u64,
    /// Number of trials, each a fresh random grid and targets.
    #[arg(long, default_value_t = 200, value_parser = trials)]
    pub trials: usize,
    /// Fuzzy membership width σ as a fraction of the cell size (0 < σ).
    #[arg(long, default_value_t = DEFAULT_FUZZY_SIGMA, value_parser = fuzzy_width)]
    pub fuzzy_sigma: f64,
    /// Write a markdown report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the result as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}
