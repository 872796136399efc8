//! `errmap volumetric {simulate, identify, predict}`: flags, validation into library
//! configuration, and glue. The work is in `errmap::volumetric` and the report in
//! `errmap::report::volumetric`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};

use super::values;
use errmap::volumetric::{
    BasisKind, Degree, Identification, IdentifyConfig, LineTable, Machine, PlanFile, Predictor,
    Topology, identify, simulate,
};

#[derive(Debug, Subcommand)]
pub(crate) enum VolumetricCommand {
    /// Simulate a laser campaign: a line table from a machine model and a plan.
    Simulate(SimulateArgs),
    /// A line table from captured sessions: every (line position, run, direction) of an
    /// axis-parallel session becomes one line.
    Lines(LinesArgs),
    /// Identify the 21 geometric errors from a line table.
    Identify(IdentifyArgs),
    /// Predict along the lines of a table, or the error vector over a grid.
    Predict(PredictArgs),
    /// Export an identified model for controllers: TwinCAT 3 CNC (TF5280) volumetric
    /// component tables, and each axis' positioning error as a 1-D table.
    Export(ExportArgs),
    /// The plan's lines as a part program: each line's targets in order, a dwell at
    /// each, a programmed stop before each line for the laser alignment.
    Program(ProgramArgs),
    /// The ISO 10360-2 length test predicted from an identified model (a virtual CMM),
    /// before and after compensation.
    Iso10360(super::acceptance::VirtualArgs),
}

#[derive(Debug, Args)]
pub(crate) struct ProgramArgs {
    /// Measurement plan (TOML, e.g. datasets/volumetric/plan.toml).
    #[arg(long)]
    pub plan: PathBuf,
    /// The controller whose part-program syntax the program uses.
    #[arg(long, default_value = errmap::controller::program::default_dialect().name(), value_parser = super::values::dialect())]
    pub dialect: &'static dyn errmap::controller::program::ProgramSyntax,
    /// The part program to write.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct VolumetricArgs {
    #[command(subcommand)]
    pub command: VolumetricCommand,
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    /// Volumetric machine model (TOML, e.g. datasets/volumetric/model.toml).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement plan (TOML, e.g. datasets/volumetric/plan.toml).
    #[arg(long)]
    pub plan: PathBuf,
    /// The line table to write (.csv or .parquet).
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct LinesArgs {
    /// Session tables (CSV/Parquet) or capture directories, one axis each; the line
    /// positions come from the sessions' MARK frames.
    #[arg(required = true)]
    pub sessions: Vec<PathBuf>,
    /// The line table to write (.csv or .parquet).
    #[arg(long)]
    pub out: PathBuf,
    /// Probe (retroreflector) offset of every line, mm: PX,PY,PZ.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true, value_parser = values::point3)]
    pub probe: [f64; 3],
}

#[derive(Debug, Args)]
pub(crate) struct IdentifyArgs {
    /// The line table (.csv or .parquet).
    pub lines: PathBuf,
    /// Kinematic chain from the workpiece to the probe, a permutation of XYZ (YXZ: a
    /// moving-bridge CMM).
    #[arg(long, value_parser = values::topology)]
    pub topology: Topology,
    /// Component model: `spline` (tables at knots with a roughness penalty, smoothing by
    /// REML; the default) or `poly` (polynomials). Giving --degree, --max-degree or
    /// --component-degree without --basis means `poly`.
    #[arg(long, value_parser = basis_kind)]
    pub basis: Option<BasisKind>,
    /// Polynomial degree of every component, `auto` (one degree by leave-one-line-out
    /// CV, the default for `poly`) or `auto-each` (then each component's own degree by
    /// the same CV).
    #[arg(long, value_parser = values::degree)]
    pub degree: Option<String>,
    /// Highest degree `auto` tries (default 4).
    #[arg(long, value_parser = values::max_degree)]
    pub max_degree: Option<usize>,
    /// Per-component degrees overriding --degree, e.g. `E_XX=5,E_CX=2`.
    #[arg(long, value_parser = values::component_degrees)]
    pub component_degree: Option<BTreeMap<usize, usize>>,
    /// Positions per component in the output (0 is added).
    #[arg(long, default_value_t = 21, value_parser = values::report_positions)]
    pub positions: usize,
    /// Write the report (report.md, figures, model.json) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the identified model (the JSON document plus the fit) for `predict`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("what").required(true).args(["lines", "grid"])))]
pub(crate) struct PredictArgs {
    /// MODEL.json from `identify --out`, or a machine-model TOML (the truth, σ = 0).
    #[arg(long)]
    pub model: PathBuf,
    /// A line table: predict every row relative to its line's first row.
    #[arg(long)]
    pub lines: Option<PathBuf>,
    /// Grid points (x_mm, y_mm, z_mm): write the error vector there (needs --out).
    #[arg(long)]
    pub grid: Option<PathBuf>,
    /// Probe offset for --grid, mm: PX,PY,PZ.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true, value_parser = values::point3)]
    pub probe: [f64; 3],
    /// Write the predictions (with --lines) or the error vector (with --grid) as a table.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the predictions along the lines as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("what").required(true).multiple(true).args(["twincat", "axis_tables"])))]
pub(crate) struct ExportArgs {
    /// MODEL.json from `identify --out` (or the report's model.json).
    #[arg(long)]
    pub model: PathBuf,
    /// Write the TwinCAT 3 CNC TF5280 ISG CSV component tables (file_format ISG_CSV).
    #[arg(long)]
    pub twincat: Option<PathBuf>,
    /// Write each axis' positioning error as a 1-D table into this directory (X, Y, Z).
    #[arg(long)]
    pub axis_tables: Option<PathBuf>,
    /// Format of the 1-D tables.
    #[arg(long, default_value = "csv", value_parser = values::axis_table_format())]
    pub format: values::AxisTableFormat,
    /// The line the 1-D tables run along, through this point (mm): X,Y,Z.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true, value_parser = values::point3)]
    pub at: [f64; 3],
    /// Positions per axis, evenly spaced over the identified range.
    #[arg(long, default_value_t = 21, value_parser = values::at_least_two)]
    pub points: usize,
}

pub(crate) fn volumetric_cmd(a: VolumetricArgs) -> Result<()> {
    match a.command {
        VolumetricCommand::Simulate(a) => simulate_cmd(a),
        VolumetricCommand::Lines(a) => lines_cmd(a),
        VolumetricCommand::Identify(a) => identify_cmd(a),
        VolumetricCommand::Predict(a) => predict_cmd(a),
        VolumetricCommand::Export(a) => export_cmd(a),
        VolumetricCommand::Program(a) => program_cmd(a),
        VolumetricCommand::Iso10360(a) => super::acceptance::virtual_cmd(a),
    }
}

fn lines_cmd(a: LinesArgs) -> Result<()> {
    let probe = a.probe;
    let files: Vec<PathBuf> = a
        .sessions
        .iter()
        .map(|p| super::acquisition::session_file(p))
        .collect::<Result<_>>()?;
    let inputs: Vec<(&str, &Path)> = files.iter().map(|f| ("SESSION", f.as_path())).collect();
    super::guard::refuse_aliases(&[("--out", &a.out)], &inputs)?;
    let mut acc = errmap::volumetric::SessionLines::new();
    for f in &files {
        errmap::session::for_each_batch(f, 1 << 16, &mut |rows| {
            rows.iter().for_each(|r| acc.push(r));
            Ok(())
        })?;
    }
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    let (table, conv) = acc.finish(&names.join(", "), probe);
    if table.lines.is_empty() {
        bail!(
            "{}: no line with at least 3 targets ({} rows, {} dwelling, {} flagged, {} without \
             the line position of a MARK)",
            names.join(", "),
            conv.rows,
            conv.dwell_rows,
            conv.flagged,
            conv.no_line
        );
    }
    table.write(&a.out)?;
    eprintln!(
        "volumetric lines: {} lines, {} targets from {} rows of {} → {}",
        conv.lines,
        table.targets(),
        conv.rows,
        names.join(", "),
        a.out.display()
    );
    if conv.flagged > 0 || conv.no_line > 0 || !conv.short_passes.is_empty() {
        eprintln!(
            "  left out: {} flagged dwell rows, {} dwell rows without a line position, {} passes \
             with fewer than 3 targets{}",
            conv.flagged,
            conv.no_line,
            conv.short_passes.len(),
            if conv.short_passes.is_empty() {
                String::new()
            } else {
                format!(" ({})", conv.short_passes.join(", "))
            }
        );
    }
    Ok(())
}

fn program_cmd(a: ProgramArgs) -> Result<()> {
    use errmap::controller::program::render_lines;
    super::guard::refuse_aliases(&[("--out", &a.out)], &[("--plan", &a.plan)])?;
    let plan = PlanFile::read(&a.plan)?;
    let program = plan.lines_program(&a.plan.display().to_string());
    // The plan file gives the feed and the dwell: its refusal is the file's, in the
    // library's words (no flag sets them).
    let text = render_lines(&program, a.dialect)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.plan.display()))?;
    write_text(&a.out, &text)?;
    eprintln!(
        "volumetric program: {} lines in the {} dialect → {}",
        program.lines.len(),
        a.dialect.name(),
        a.out.display()
    );
    Ok(())
}

fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    super::guard::refuse_aliases(
        &[("--out", &a.out)],
        &[("--model", &a.model), ("--plan", &a.plan)],
    )?;
    let machine = Machine::read(&a.model)?;
    let plan = PlanFile::read(&a.plan)?;
    let table = simulate(&machine, &plan);
    table.write(&a.out)?;
    let end_s = table
        .lines
        .iter()
        .flat_map(|l| &l.targets)
        .filter_map(|t| t.t_s)
        .fold(0.0, f64::max);
    eprintln!(
        "volumetric simulate: {} lines, {} targets, campaign {:.1} h → {}",
        table.lines.len(),
        table.targets(),
        end_s / 3600.0,
        a.out.display()
    );
    Ok(())
}

/// `--basis`: `spline` or `poly`.
fn basis_kind(s: &str) -> Result<BasisKind, String> {
    match s.trim() {
        "spline" => Ok(BasisKind::Spline),
        "poly" => Ok(BasisKind::Poly),
        other => Err(format!("`{other}` is neither `spline` nor `poly`")),
    }
}

fn identify_cmd(a: IdentifyArgs) -> Result<()> {
    let topology = a.topology;
    let poly_flags = a.degree.is_some() || a.max_degree.is_some() || a.component_degree.is_some();
    let basis = match a.basis {
        Some(BasisKind::Spline) if poly_flags => {
            return Err(super::guard::usage(
                "--degree, --max-degree and --component-degree apply to --basis poly",
            ));
        }
        Some(b) => b,
        None if poly_flags => BasisKind::Poly,
        None => BasisKind::Spline,
    };
    let max_degree = a.max_degree.unwrap_or(4);
    let degree = match a.degree.as_deref().map(str::trim).unwrap_or("auto") {
        "auto" => Degree::Auto { max: max_degree },
        "auto-each" => Degree::AutoEach { max: max_degree },
        d => Degree::Fixed(d.parse().with_context(|| {
            format!("--degree `{d}` is neither `auto`, `auto-each` nor a whole number")
        })?),
    };
    let config = IdentifyConfig {
        topology,
        basis,
        degree,
        component_degrees: a.component_degree.clone().unwrap_or_default(),
        positions: a.positions,
    };
    let outputs: Vec<(&str, &Path)> = [("--out", &a.out), ("--report", &a.report)]
        .into_iter()
        .filter_map(|(f, p)| p.as_deref().map(|p| (f, p)))
        .collect();
    super::guard::refuse_aliases(&outputs, &[("LINES", &a.lines)])?;
    // `--out R/model.json --report R`: two outputs on one path, refused before the
    // identification runs (the report folder's own files are model.json and report.md).
    if let (Some(out), Some(dir)) = (&a.out, &a.report) {
        for name in ["model.json", "report.md"] {
            let file = dir.join(name);
            super::guard::distinct_outputs(&[("--out", out), ("--report", &file)])?;
        }
    }
    let table = LineTable::read(&a.lines, true)?;
    let id = identify(&table, &config)?;
    let doc = id.doc(config.positions, true);
    // The inputs are finite and in range: a non-finite figure is a bug, reported (naming
    // the first output it would reach) before anything is written.
    let first_output = a
        .out
        .as_deref()
        .or(a.report.as_deref())
        .or(a.json.then_some(Path::new("stdout")));
    if let Some(path) = first_output {
        errmap::report::check_json(path, &doc)?;
    }
    // The report first: its files are checked against --out before anything is put in
    // place (`--out R/model.json --report R` is two outputs on one path).
    if let Some(dir) = &a.report {
        super::guard::into_new_dir(dir, |d| {
            Ok(errmap::report::write_volumetric_report(
                &id,
                config.positions,
                d,
            )?)
        })?;
    }
    if let Some(out) = &a.out {
        let text = errmap::report::json_text(out, &doc, true)?;
        super::guard::write_file(out, text.as_bytes())?;
    }
    if a.json {
        super::guard::print_json(&id.doc(config.positions, false))?;
    } else {
        print_summary(&id);
    }
    Ok(())
}

/// The identification in a few lines on stderr.
fn print_summary(id: &Identification) {
    let n_id = id.fit.identified.iter().filter(|f| **f).count();
    let model = match id.fit.basis.kind() {
        BasisKind::Poly => format!("polynomials of degree {}", id.degree),
        BasisKind::Spline => "tables at knots (REML smoothing)".to_string(),
    };
    eprintln!(
        "volumetric identify: {} lines, {} targets, {model}, RMS residual {:.4} µm, {} of 21 \
         errors identified, residual {}",
        id.lines, id.targets, id.rms_residual_um, n_id, id.residual.verdict
    );
    for e in &id.residual.effects {
        let params: Vec<String> = e
            .effect
            .params_by_name()
            .iter()
            .map(|(k, v)| match (v.as_f64(), e.uncertainty.get(k)) {
                (Some(x), Some(s)) => format!("{k} = {x:.4} ± {s:.4}"),
                _ => format!("{k} = {v}"),
            })
            .collect();
        eprintln!(
            "  {}: {} (explains {:.3} µm)",
            e.id(),
            params.join(", "),
            e.explains_um
        );
    }
    for u in &id.unidentified {
        eprintln!("  {}: {}", u.components.join(", "), u.why);
    }
}

/// `errmap demo`'s volumetric step: the dataset's machine (`datasets/volumetric/model.toml`)
/// measured with the dataset's plan, simulated into `OUT/volumetric/lines.csv`, identified
/// (degree by cross-validation) with the report, `model.json` included, in
/// `OUT/volumetric/`, the summary printed, and the TwinCAT component tables exported
/// (`volcomp_twincat.csv`). Returns the identification.
pub(crate) fn demo_step(out: &Path) -> Result<Identification> {
    let dir = out.join("volumetric");
    let inputs = dir.join("inputs");
    std::fs::create_dir_all(&inputs)
        .with_context(|| format!("cannot create {}", inputs.display()))?;
    let model = inputs.join("model.toml");
    let plan = inputs.join("plan.toml");
    for (path, text) in [
        (&model, include_str!("../../datasets/volumetric/model.toml")),
        (&plan, include_str!("../../datasets/volumetric/plan.toml")),
    ] {
        super::guard::write_file(path, text.as_bytes())?;
    }
    let machine = Machine::read(&model)?;
    let plan = PlanFile::read(&plan)?;
    let table = simulate(&machine, &plan);
    let lines = dir.join("lines.csv");
    table.write(&lines)?;
    eprintln!(
        "  simulated {} lines, {} targets ({}) → {}",
        table.lines.len(),
        table.targets(),
        machine.topology,
        lines.display()
    );
    let table = LineTable::read(&lines, true)?;
    let config = IdentifyConfig::new(machine.topology);
    let id = identify(&table, &config)?;
    errmap::report::write_volumetric_report(&id, config.positions, &dir)?;
    print_summary(&id);
    eprintln!("  report → {}", dir.join("report.md").display());
    let tables = errmap::volumetric::component_tables(&id.fit, 21)
        .map_err(|m| anyhow::anyhow!("{}: {m}", lines.display()))?;
    for v in errmap::controller::volumetric_tables() {
        let file = dir.join(v.file_name);
        write_text(&file, &(v.render)(&tables, &lines.display().to_string()))?;
        eprintln!("  {} → {}", v.summary, file.display());
    }
    Ok(id)
}

fn predict_cmd(a: PredictArgs) -> Result<()> {
    if let Some(out) = &a.out {
        let mut inputs: Vec<(&str, &Path)> = vec![("--model", &a.model)];
        inputs.extend(a.lines.as_deref().map(|p| ("--lines", p)));
        inputs.extend(a.grid.as_deref().map(|p| ("--grid", p)));
        super::guard::refuse_aliases(&[("--out", out)], &inputs)?;
    }
    let model = Predictor::read(&a.model)?;
    if let Some(lines) = &a.lines {
        let table = LineTable::read(lines, false)?;
        let preds = model.predict_lines(&table);
        if let Some(out) = &a.out {
            errmap::volumetric::write_predictions(out, &preds)?;
        }
        let undetermined = preds.iter().filter(|p| p.e_um.is_none()).count();
        if undetermined > 0 {
            eprintln!(
                "volumetric predict: {undetermined} of {} rows depend on errors the lines did not \
                 determine: e_um and sigma_um are null there",
                preds.len()
            );
        }
        if a.json {
            super::guard::print_json(&std::collections::BTreeMap::from([("predictions", &preds)]))?;
        } else if a.out.is_none() {
            eprintln!(
                "volumetric predict: {} rows (use --out FILE or --json)",
                preds.len()
            );
        }
        return Ok(());
    }
    let Some(grid) = &a.grid else {
        bail!("give --lines TABLE or --grid GRID");
    };
    let Some(out) = &a.out else {
        return Err(super::guard::usage(
            "--grid writes a table: give --out FILE",
        ));
    };
    let probe = a.probe;
    let points: Vec<[f64; 3]> = errmap::table::ErrorTable::read_points(grid)?
        .points
        .iter()
        .map(|p| p.position())
        .collect();
    let errors = model
        .predict_grid(&points, probe)
        .map_err(|m| anyhow::anyhow!("{}: {m}", a.model.display()))?;
    errmap::volumetric::write_grid(out, &points, &errors)?;
    if a.json {
        super::guard::print_json(&errmap::report::GridJson::new(&points, &errors))?;
    }
    eprintln!(
        "volumetric predict: error vector at {} points → {}",
        points.len(),
        out.display()
    );
    Ok(())
}

fn export_cmd(a: ExportArgs) -> Result<()> {
    use errmap::controller::ExportFormat;
    use errmap::export::Sampled;
    use errmap::volumetric::{axis_positions, component_tables, positioning_profile};
    let fit = match Predictor::read(&a.model)? {
        Predictor::Fit(f) => f,
        Predictor::Machine(_) => bail!(
            "{}: export needs an identified model (MODEL.json from `volumetric identify --out`)",
            a.model.display()
        ),
    };
    if let Some(out) = &a.twincat {
        super::guard::refuse_aliases(&[("--twincat", out)], &[("--model", &a.model)])?;
    }
    if let Some(out) = &a.twincat {
        let tables = component_tables(&fit, a.points)
            .map_err(|m| anyhow::anyhow!("{}: {m}", a.model.display()))?;
        let v = errmap::controller::volumetric_tables()
            .next()
            .ok_or_else(|| anyhow::anyhow!("no controller dialect writes a volumetric table"))?;
        write_text(out, &(v.render)(&tables, &a.model.display().to_string()))?;
        eprintln!(
            "volumetric export: {} ({} positions per axis) → {}",
            v.summary,
            a.points,
            out.display()
        );
    }
    if let Some(dir) = &a.axis_tables {
        let at = a.at;
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for axis in errmap::base::Axis::ALL {
            let k = axis.index();
            let positions = axis_positions(&fit, k, a.points);
            let profile = positioning_profile(&fit, k, at, &positions)
                .map_err(|m| anyhow::anyhow!("{}: {m}", a.model.display()))?;
            let sampled = Sampled {
                axis,
                at_mm: at,
                error_um: profile.iter().map(|p| p.0).collect(),
                extrapolated: vec![false; positions.len()],
                positions_mm: positions,
            };
            let letter = axis.upper();
            let (format, ext) = match a.format {
                values::AxisTableFormat::Csv => (ExportFormat::Csv, "csv"),
                values::AxisTableFormat::Table(t) => ((t.format)(axis), t.extension),
            };
            let text = format.render_line(&sampled, None)?;
            let path = dir.join(format!("{letter}.{ext}"));
            write_text(&path, &text)?;
        }
        eprintln!(
            "volumetric export: positioning errors of X, Y, Z ({}) → {}",
            match a.format {
                values::AxisTableFormat::Csv => "CSV",
                values::AxisTableFormat::Table(t) => t.summary,
            },
            dir.display()
        );
    }
    Ok(())
}

/// Whole or not at all (`guard::write_file` creates the parent directory).
fn write_text(path: &Path, text: &str) -> Result<()> {
    super::guard::write_file(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demo_step_identifies_the_dataset_campaign_and_writes_the_report() {
        let dir = tempfile::tempdir().expect("tempdir");
        let id = demo_step(dir.path()).expect("demo step");
        // The rich preset determines all 21 errors of the dataset's YXZ machine, and the
        // rigid campaign's residual is noise.
        assert_eq!(id.topology.to_string(), "YXZ");
        assert!(id.fit.identified.iter().all(|f| *f));
        assert_eq!(id.residual.verdict, errmap::base::Verdict::Consistent);
        // E_XX at 800 mm is 4 − 2.5 + 1 = 2.5 µm in the dataset (positioning: no gauge).
        let (v, s) = id.fit.component(0, 800.0).expect("E_XX");
        assert!((v - 2.5).abs() < 4.0 * s, "{v} ± {s}");
        let v = dir.path().join("volumetric");
        for f in [
            "lines.csv",
            "report.md",
            "model.json",
            "E_XX.png",
            "residual_time.png",
            "volcomp_twincat.csv",
        ] {
            assert!(v.join(f).is_file(), "{f}");
        }
    }
}
