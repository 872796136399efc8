//! `errmap history {add, report, verify}`: flags into library configuration, and glue.
//! The ledger and the numbers are in `errmap::history`, the report's words and figures in
//! `errmap::report::history`.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};

use errmap::history::{
    self, DEFAULT_HORIZON_DAYS, Ledger, MachineId, NewRecord, ReportConfig, Run, State, Supersede,
    Tolerances,
};

use super::guard;

#[derive(Debug, Args)]
pub(crate) struct HistoryArgs {
    #[command(subcommand)]
    pub command: HistoryCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum HistoryCommand {
    /// Record a session (its ISO 230-2 statistics per line) or a volumetric model.
    Add(AddArgs),
    /// Trends, EWMA charts, tolerance forecasts, advice and the fleet ranking.
    Report(ReportArgs),
    /// Re-hash every file the records came from; name what changed or vanished.
    Verify(VerifyArgs),
}

fn machine(s: &str) -> Result<MachineId, String> {
    MachineId::parse(s)
        .ok_or_else(|| format!("{s:?}: a machine id is 1–64 characters of A-Z a-z 0-9 . _ -"))
}

/// `--at`, `--as-of`: a time inside the window a ledger takes (from 1970 to now plus the
/// ledger's clock skew), checked when the flags are parsed (exit 2); the ledger checks its
/// records' times again when it writes them.
fn utc(s: &str) -> Result<i64, String> {
    let t = history::parse_utc(s).map_err(|e| e.to_string())?;
    let latest = history::latest_at(history::now_utc());
    if !(history::EARLIEST_S..=latest).contains(&t) {
        return Err(format!(
            "{s:?} is outside the window a ledger takes, {} … {} (now + a clock skew of {} h)",
            history::format_utc(history::EARLIEST_S),
            history::format_utc(latest),
            history::CLOCK_SKEW_S / 3600
        ));
    }
    Ok(t)
}

fn state(s: &str) -> Result<State, String> {
    State::parse(s).ok_or_else(|| format!("{s:?}: as-found or as-left"))
}

fn days(s: &str) -> Result<f64, String> {
    super::values::positive(s)
}

#[derive(Debug, Args)]
pub(crate) struct AddArgs {
    /// A session table (.csv, .parquet), a capture's session directory, or a volumetric
    /// model (.json from `volumetric identify --out`).
    pub result: PathBuf,
    /// The ledger: a SQLite file (created if absent) or postgres://user@host[:port]/db.
    #[arg(long)]
    pub ledger: String,
    /// The machine: 1–64 characters of A-Z a-z 0-9 . _ -
    #[arg(long, value_parser = machine)]
    pub machine: MachineId,
    /// Where the machine stands (free text).
    #[arg(long)]
    pub site: Option<String>,
    /// as-found (default) or as-left (after an adjustment or a compensation).
    #[arg(long, default_value = "as-found", value_parser = state)]
    pub state: State,
    /// When the test was made: RFC 3339 (Z or an offset) or YYYY-MM-DD (default: now).
    #[arg(long, value_parser = utc)]
    pub at: Option<i64>,
    /// Amend record N (it must be current); needs --reason.
    #[arg(long, requires = "reason", value_parser = super::values::record_id)]
    pub supersede: Option<i64>,
    /// Why the record is amended.
    #[arg(long, requires = "supersede", value_parser = super::values::reason)]
    pub reason: Option<String>,
    /// Print the new record as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct ReportArgs {
    /// The ledger: a SQLite file or postgres://user@host[:port]/db.
    #[arg(long)]
    pub ledger: String,
    /// Only this machine in the output.
    #[arg(long, value_parser = machine)]
    pub machine: Option<MachineId>,
    /// The tolerance file (TOML, µm; docs/tolerances.md): [default], [axis.X],
    /// [machine.ID], [machine.ID.X].
    #[arg(long)]
    pub tolerances: Option<PathBuf>,
    /// The report's date (default: the latest test in the ledger).
    #[arg(long, value_parser = utc)]
    pub as_of: Option<i64>,
    /// Risk horizon, days after --as-of.
    #[arg(long, default_value_t = DEFAULT_HORIZON_DAYS, value_parser = days)]
    pub horizon: f64,
    /// Directory for report.md, fleet.png/.svg and one figure per machine.
    #[arg(long)]
    pub report: PathBuf,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct VerifyArgs {
    /// The ledger: a SQLite file or postgres://user@host[:port]/db.
    #[arg(long)]
    pub ledger: String,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn history_cmd(a: HistoryArgs) -> Result<()> {
    match a.command {
        HistoryCommand::Add(a) => add(a),
        HistoryCommand::Report(a) => report(a),
        HistoryCommand::Verify(a) => verify(a),
    }
}

fn add(a: AddArgs) -> Result<()> {
    let ingested = history::ingest(&a.result)?;
    for w in &ingested.warnings {
        eprintln!("history add: warning: {w}");
    }
    let rec = NewRecord {
        machine: a.machine,
        site: a.site,
        state: a.state,
        at: a.at.unwrap_or_else(history::now_utc),
        supersede: a
            .supersede
            .zip(a.reason)
            .map(|(record, reason)| Supersede { record, reason }),
        content: ingested.content,
        sources: ingested.sources,
    };
    let mut ledger = Ledger::open(&a.ledger, true)?;
    let added = history::add(&mut ledger, &rec)?;
    eprintln!(
        "history add: record {} ({} {}, {} {}{}) in {}",
        added.record,
        added.kind,
        added.machine,
        added.state,
        added.at,
        added
            .supersedes
            .map(|n| format!(", supersedes record {n}"))
            .unwrap_or_default(),
        ledger.name()
    );
    if a.json {
        guard::print_json(&added)?;
    }
    Ok(())
}

/// stdout, with a closed pipe turned into [`guard::StdoutClosed`].
struct Out(std::io::BufWriter<std::io::StdoutLock<'static>>);

impl Out {
    fn put(&mut self, text: &str) -> Result<()> {
        match self.0.write_all(text.as_bytes()) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(guard::StdoutClosed.into()),
            Err(e) => Err(anyhow::Error::new(e).context("cannot write to stdout")),
        }
    }

    fn finish(mut self) -> Result<()> {
        match self.0.flush() {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(guard::StdoutClosed.into()),
            Err(e) => Err(anyhow::Error::new(e).context("cannot write to stdout")),
        }
    }
}

fn json(value: &(impl serde::Serialize + ?Sized)) -> Result<String> {
    Ok(errmap::report::json_text(
        Path::new("stdout"),
        value,
        false,
    )?)
}

fn report(a: ReportArgs) -> Result<()> {
    if a.report.exists() && !a.report.is_dir() {
        anyhow::bail!(
            "--report {}: exists and is not a directory (nothing was written)",
            a.report.display()
        );
    }
    // The ledger (a file) and the tolerances are inputs: no file of the report may land
    // on them (issue 40 item 2: `--ledger R/report.md --report R` replaced the ledger).
    let mut inputs: Vec<(&str, &Path)> = a
        .tolerances
        .iter()
        .map(|t| ("--tolerances", t.as_path()))
        .collect();
    if !history::is_postgres(&a.ledger) {
        inputs.push(("--ledger", Path::new(&a.ledger)));
    }
    guard::refuse_aliases(&[("--report", &a.report)], &inputs)?;
    let tolerances = match &a.tolerances {
        Some(p) => Tolerances::read(p)?,
        None => Tolerances::default(),
    };
    let mut ledger = Ledger::open(&a.ledger, false)?;
    let config = ReportConfig {
        machine: a.machine,
        tolerances,
        as_of: a.as_of,
        horizon_days: a.horizon,
    };
    let mut run = Run::new(&mut ledger, config)?;
    let head = run.head().clone();
    let head_json = json(&head)?;
    // The document is streamed, one machine at a time: the head's object is left open
    // for "machines" and "fleet".
    let mut out = a
        .json
        .then(|| Out(std::io::BufWriter::new(std::io::stdout().lock())));
    if let Some(o) = out.as_mut() {
        o.put(&head_json[..head_json.len() - 1])?;
        o.put(",\"machines\":[")?;
    }
    let dir = a.report.clone();
    let n = run.machines();
    let summary = guard::into_new_dir(&dir, |d| {
        let mut writer = errmap::report::HistoryReportWriter::new(d)?;
        let mut first = true;
        while let Some(m) = run.next_machine()? {
            writer.machine(&m)?;
            if let Some(o) = out.as_mut() {
                if !first {
                    o.put(",")?;
                }
                o.put(&json(&m)?)?;
            }
            first = false;
        }
        let fleet = run.fleet();
        let summary = writer.finish(&head, &fleet)?;
        if let Some(o) = out.as_mut() {
            o.put("],\"fleet\":")?;
            o.put(&json(&fleet)?)?;
            o.put("}\n")?;
        }
        Ok(summary)
    })
    .with_context(|| format!("history report on {}", ledger_name(&a.ledger)))?;
    eprintln!(
        "history report: {n} machines as of {}: {} → {}",
        head.as_of,
        summary,
        dir.join("report.md").display()
    );
    if let Some(o) = out {
        o.finish()?;
    }
    Ok(())
}

fn ledger_name(spec: &str) -> String {
    if history::is_postgres(spec) {
        "the PostgreSQL ledger".into()
    } else {
        spec.to_string()
    }
}

fn verify(a: VerifyArgs) -> Result<()> {
    let mut ledger = Ledger::open(&a.ledger, false)?;
    let v = history::verify(&mut ledger)?;
    for c in &v.changed {
        eprintln!(
            "history verify: record {}: {} ({}) changed: sha256 {} expected, {} now",
            c.record, c.path, c.role, c.expected, c.actual
        );
    }
    for m in &v.missing {
        eprintln!(
            "history verify: record {}: {} ({}) is missing",
            m.record, m.path, m.role
        );
    }
    for d in &v.damage {
        eprintln!("history verify: damaged: {}", d.problem);
    }
    eprintln!(
        "history verify: {} files checked, {} changed, {} missing; {} problems in the ledger itself",
        v.checked,
        v.changed.len(),
        v.missing.len(),
        v.damage.len()
    );
    if a.json {
        guard::print_json(&v)?;
    }
    if !v.damage.is_empty() {
        anyhow::bail!(
            "{}: the ledger is damaged: {} problems (listed above)",
            ledger.name(),
            v.damage.len()
        );
    }
    if !v.is_sound() {
        anyhow::bail!(
            "{}: {} of {} files changed or vanished since they were recorded",
            ledger.name(),
            v.changed.len() + v.missing.len(),
            v.checked
        );
    }
    Ok(())
}

/// The ledger benchmark: SQLite in a temporary directory, and PostgreSQL when given.
pub(crate) fn bench(a: &super::args::BenchArgs) -> Result<Vec<errmap::bench::HistoryBench>> {
    let dir = tempfile_dir()?;
    let sqlite = dir.join("bench.sqlite");
    let _ = std::fs::remove_file(&sqlite);
    let mut out = Vec::new();
    let (m, t) = (a.history_machines, a.history_tests);
    eprintln!("bench: calibration ledger, {m} machines × {t} tests × 3 axes on SQLite …");
    let r = errmap::bench::run_history(&sqlite.display().to_string(), m, t);
    let _ = std::fs::remove_dir_all(&dir);
    out.push(r?);
    if let Some(url) = &a.history_postgres {
        eprintln!("bench: … and on PostgreSQL");
        out.push(errmap::bench::run_history(url, m, t)?);
    }
    Ok(out)
}

/// A fresh directory under the system's temporary directory.
fn tempfile_dir() -> Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("errmap-bench-history-{}", std::process::id()));
    std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    Ok(d)
}

/// The demo's step (for `errmap demo`): records the demo's session directory, and its
/// volumetric model when given, as machine `DEMO-1` in a fresh ledger
/// `<out>/history/lab.sqlite`, writes the report to `<out>/history/report/` and prints
/// its first lines on stderr. The ledger is the demo's own output and is made anew on
/// every run (a real ledger is never removed).
pub(crate) fn demo_step(out: &Path, session_dir: &Path, model: Option<&Path>) -> Result<()> {
    let dir = out.join("history");
    if dir.exists() {
        std::fs::remove_dir_all(&dir)
            .with_context(|| format!("cannot clear the previous demo ledger {}", dir.display()))?;
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let spec = dir.join("lab.sqlite").display().to_string();
    let mut ledger = Ledger::open(&spec, true)?;
    let machine = MachineId::parse("DEMO-1").context("the demo's machine id")?;
    for result in std::iter::once(session_dir).chain(model) {
        let ingested = history::ingest(result)?;
        let added = history::add(
            &mut ledger,
            &NewRecord {
                machine: machine.clone(),
                site: Some("demo".into()),
                state: State::AsFound,
                at: history::now_utc(),
                supersede: None,
                content: ingested.content,
                sources: ingested.sources,
            },
        )?;
        eprintln!(
            "  record {} ({}, {} lines) ← {}",
            added.record,
            added.kind,
            added.lines,
            result.display()
        );
    }
    let report_dir = dir.join("report");
    let mut run = Run::new(
        &mut ledger,
        ReportConfig {
            horizon_days: DEFAULT_HORIZON_DAYS,
            ..Default::default()
        },
    )?;
    let head = run.head().clone();
    let mut writer = errmap::report::HistoryReportWriter::new(&report_dir)?;
    while let Some(m) = run.next_machine()? {
        writer.machine(&m)?;
    }
    writer.finish(&head, &run.fleet())?;
    let md = std::fs::read_to_string(report_dir.join("report.md")).unwrap_or_default();
    for line in md.lines().filter(|l| !l.is_empty()).take(8) {
        eprintln!("  | {line}");
    }
    eprintln!(
        "  ledger {spec}, report → {}",
        report_dir.join("report.md").display()
    );
    Ok(())
}

/// A ledger error in the command line's words: the flag that names the record or the
/// machine, or that would amend the record (`None`: the library's words stand).
pub(crate) fn in_flags(e: &history::HistoryError) -> Option<String> {
    use history::HistoryError as E;
    Some(match e {
        E::Duplicate { record, .. } => {
            format!("{e} (to amend that record: --supersede {record} --reason TEXT)")
        }
        E::NoSuchRecord { ledger, record } => {
            format!("{ledger}: --supersede {record}: there is no record {record}")
        }
        E::NotCurrent { ledger, record, by } => format!(
            "{ledger}: --supersede {record}: record {record} is not current (record {by} supersedes it)"
        ),
        E::UnknownMachine { ledger, machine } => {
            format!("--machine {machine}: no current record of this machine in {ledger}")
        }
        _ => return None,
    })
}
