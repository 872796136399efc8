//! `errmap circular {diagnose, simulate}`: flags into library types, and glue. The work
//! is in `errmap::circular`, the report in `errmap::report::circular`.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Subcommand};

use errmap::circular::{DiagnoseConfig, diagnose, link, read_test};
use errmap::circular::{MachineModel, simulate, write_test};

#[derive(Debug, Args)]
pub(crate) struct CircularArgs {
    #[command(subcommand)]
    pub command: CircularCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum CircularCommand {
    /// ISO 230-4 numbers of a ballbar test and the machine errors behind its trace.
    Diagnose(DiagnoseArgs),
    /// Simulate a ballbar test (a trace and its TOML) from a machine model.
    Simulate(SimulateArgs),
}

#[derive(Debug, Args)]
pub(crate) struct DiagnoseArgs {
    /// The trace (.csv or .parquet); its metadata TOML lies beside it.
    pub trace: PathBuf,
    /// Write the report (circular.json, report.md, polar.png/.svg) into this directory.
    #[arg(long)]
    pub report: PathBuf,
    /// Print the JSON document on stdout.
    #[arg(long)]
    pub json: bool,
    /// Fit the overshoot arcs too (the ISO numbers use the nominal arc only).
    #[arg(long)]
    pub overshoot: bool,
    /// MODEL.json from `volumetric identify --out` (or a machine-model TOML): compare the
    /// circle it implies (needs `centre_mm` in the test's TOML).
    #[arg(long)]
    pub model: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    /// The machine model (TOML, e.g. datasets/circular/machine.toml).
    #[arg(long)]
    pub model: PathBuf,
    /// The trace to write (.csv or .parquet); its TOML is written beside it.
    #[arg(long)]
    pub out: PathBuf,
}

pub(crate) fn circular_cmd(a: CircularArgs) -> Result<()> {
    match a.command {
        CircularCommand::Diagnose(a) => diagnose_cmd(a),
        CircularCommand::Simulate(a) => simulate_cmd(a),
    }
}

fn diagnose_cmd(a: DiagnoseArgs) -> Result<()> {
    let meta = errmap::circular::meta_path(&a.trace);
    let mut inputs: Vec<(&str, &Path)> = vec![("TRACE", &a.trace), ("the trace's TOML", &meta)];
    inputs.extend(a.model.as_deref().map(|m| ("--model", m)));
    super::guard::refuse_aliases(&[("--report", &a.report)], &inputs)?;
    let test = read_test(&a.trace)?;
    let config = DiagnoseConfig {
        use_overshoot: a.overshoot,
        ..DiagnoseConfig::default()
    };
    let mut d = diagnose(&test, &config);
    if let Some(model) = &a.model {
        let centre = test.meta.centre_mm.ok_or_else(|| {
            errmap::base::ConfigError::key(
                &errmap::circular::meta_path(&a.trace),
                "centre_mm",
                "missing; --model needs the test centre in machine coordinates",
            )
        })?;
        d.link = Some(link(model, &test.meta, centre, &d)?);
    }
    errmap::report::check_json(Path::new("circular.json"), &d)?;
    super::guard::into_new_dir(&a.report, |dir| {
        errmap::report::write_circular_report(&test, &d, dir)?;
        Ok(())
    })?;
    if a.json {
        super::guard::print_json(&d)?;
    } else {
        eprintln!(
            "{}: {} effect(s); rms {:.3} → {:.3} µm; report in {}",
            a.trace.display(),
            d.effects.len(),
            d.rms_before_um,
            d.rms_after_um,
            a.report.display()
        );
    }
    Ok(())
}

fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    // The trace's TOML is written beside it: an output as much as --out is.
    let meta = errmap::circular::meta_path(&a.out);
    super::guard::refuse_aliases(
        &[("--out", &a.out), ("the TOML beside --out", &meta)],
        &[("--model", &a.model)],
    )?;
    let model = MachineModel::read(&a.model)?;
    let test = simulate(&model)?;
    write_test(&test, &a.out)?;
    eprintln!(
        "wrote {} and {}",
        a.out.display(),
        errmap::circular::meta_path(&a.out).display()
    );
    Ok(())
}
