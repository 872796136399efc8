//! The model subcommands: fit, compare, export, simulate, fuzzy-sim. Glue only: the work
//! is in `errmap::interp`, `errmap::evaluate`, `errmap::export` and `errmap::report`.

use std::path::Path;

use anyhow::{Context, Result, bail};
use errmap::evaluate::{self, FuzzySimConfig};
use errmap::interp::{Method, MethodError, MethodName};
use errmap::report;
use errmap::table::{ErrorPoint, ErrorTable};

use super::args::*;
use errmap::base::FileOp;
use errmap::base::io_err;
use errmap::controller::TableSettings;
use errmap::controller::job::{self, ExportJob, JobError, Output, Placement, Source, Written};
use errmap::export::{Extrapolation, LineSpec, VolumeSpec};

use super::values::{ExportFormatArg, OrderArg, OrdersArg};

/// The method a name, an order and the model flags stand for; `--order auto` runs the
/// cross-validation on the grid.
fn method_of(
    name: MethodName,
    order: Option<OrderArg>,
    model: &ModelArgs,
    grid: Option<&errmap::table::Grid>,
) -> Result<Method> {
    let degrees = match order {
        None => None,
        Some(OrderArg::Degrees(o)) => Some(o),
        Some(OrderArg::Auto) if name.takes_order() => {
            let grid = grid.context("--order auto needs a grid table")?;
            Some(evaluate::auto_order(grid, model.max_degree)?.0)
        }
        Some(OrderArg::Auto) => {
            return Err(super::guard::usage(format!(
                "--order applies to lagrange only, not to {name}"
            )));
        }
    };
    Method::from_name(name, degrees, &model.settings()).map_err(|e| match e {
        MethodError::NeedsOrder => super::guard::usage(
            "--method lagrange needs --order MxNxQ (degrees along x, y, z) or --order auto",
        ),
        MethodError::OrderNotApplicable(n) => {
            super::guard::usage(format!("--order applies to lagrange only, not to {n}"))
        }
    })
}

/// A table and one method fitted to it, with the nodes' box.
struct Fitted {
    method: Method,
    model: Box<dyn errmap::interp::Interpolator>,
    extent: evaluate::Extent,
}

/// Reads `path` and fits the method named `name`: the Gaussian process to the nodes as
/// they are (scattered or not), the interpolators to the grid (the error names a missing
/// node).
fn fit_table(
    path: &Path,
    name: MethodName,
    order: Option<OrderArg>,
    model: &ModelArgs,
) -> Result<Fitted> {
    let table = ErrorTable::read(path)?;
    let grid = if name.accepts_scattered() {
        None
    } else {
        Some(table.grid()?)
    };
    let method = method_of(name, order, model, grid.as_ref())?;
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
            Some(g) => evaluate::Extent::of_grid(g),
            None => evaluate::Extent::of_points(&table),
        },
    })
}

pub(crate) fn fit(a: FitArgs) -> Result<()> {
    if let Some(out) = &a.out {
        super::guard::refuse_aliases(
            &[("--out", out)],
            &[("TABLE", &a.table), ("--predict", &a.predict)],
        )?;
    }
    let Fitted { method, model, .. } = fit_table(&a.table, a.method, a.order, &a.model)?;
    let points = ErrorTable::read_points(&a.predict)?;
    let positions: Vec<[f64; 3]> = points.points.iter().map(|p| p.position()).collect();
    let mut values = vec![0.0; positions.len()];
    let threads = super::guard::threads("--threads", a.threads);
    errmap::interp::predict_parallel(model.as_ref(), &positions, &mut values, threads)?;
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
    // The inputs are finite and in range, so a non-finite prediction is a bug: reported,
    // never written (JSON would show it as null, CSV as NaN).
    if let Some((p, e)) = positions
        .iter()
        .zip(values.iter().zip(&sigmas))
        .find(|(_, (e, s))| !e.is_finite() || s.is_some_and(|s| !s.is_finite()))
    {
        bail!(
            "{}: the {} model gave {} µm (σ {:?}) at ({}, {}, {}) mm; nothing written (a bug: please report it)",
            a.table.display(),
            method.label(),
            e.0,
            e.1,
            p[0],
            p[1],
            p[2]
        );
    }
    if let Some(out) = &a.out {
        errmap::table::write_predictions(out, &preds, &sigmas)?;
    }
    let n_out = preds.iter().filter(|p| p.1).count();
    if a.json {
        // A struct, not `json!`: a NaN must reach the check, not become `null` first.
        // Keys in the order `json!` printed them (sorted).
        #[derive(serde::Serialize)]
        struct Prediction {
            e_um: f64,
            extrapolated: bool,
            sigma_um: Option<f64>,
            x_mm: f64,
            y_mm: f64,
            z_mm: f64,
        }
        #[derive(serde::Serialize)]
        struct Fit<'a> {
            method: &'a str,
            order: Option<[usize; 3]>,
            predictions: Vec<Prediction>,
        }
        super::guard::print_json(&Fit {
            method: method.name(),
            order: method.order().map(|o| o.0),
            predictions: preds
                .iter()
                .zip(&sigmas)
                .map(|((p, e), s)| Prediction {
                    e_um: p.e_um,
                    extrapolated: *e,
                    sigma_um: *s,
                    x_mm: p.x_mm,
                    y_mm: p.y_mm,
                    z_mm: p.z_mm,
                })
                .collect(),
        })?;
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

/// `--methods` with each method once, in the order given: `spline,spline` compares
/// spline once (twice made two result columns of one name, a polars error).
fn listed(names: &[MethodName]) -> Vec<MethodName> {
    let mut out: Vec<MethodName> = Vec::new();
    for &n in names {
        if !out.contains(&n) {
            out.push(n);
        }
    }
    out
}

/// The model list of `compare` from `--methods` and `--orders`.
fn compare_methods(a: &CompareArgs, grid: &errmap::table::Grid) -> Result<Vec<Method>> {
    let settings = a.model.settings();
    let Some(names) = &a.methods else {
        // The registry's default list, with the Lagrange orders --orders asks for.
        let mut out: Vec<Method> = Method::defaults(grid, 0, &settings)
            .into_iter()
            .filter(|m| m.order().is_none())
            .collect();
        out.extend(lagrange_orders(a, grid)?);
        return Ok(out);
    };
    let mut out = Vec::new();
    for name in listed(names) {
        if name.takes_order() {
            out.extend(lagrange_orders(a, grid)?);
        } else {
            out.push(method_of(name, None, &a.model, Some(grid))?);
        }
    }
    if out.is_empty() {
        bail!("no methods to compare");
    }
    Ok(out)
}

/// The Lagrange models of `compare --orders`.
fn lagrange_orders(a: &CompareArgs, grid: &errmap::table::Grid) -> Result<Vec<Method>> {
    Ok(match &a.orders {
        OrdersArg::All => errmap::interp::admissible_orders(grid.shape(), a.model.max_degree)
            .into_iter()
            .map(Method::Lagrange)
            .collect(),
        OrdersArg::Auto => vec![Method::Lagrange(
            evaluate::auto_order(grid, a.model.max_degree)
                .map_err(|e| {
                    // compare's flag for the order is `--orders`.
                    use errmap::base::NamesSettings;
                    use errmap::interp::InterpSetting;
                    anyhow::anyhow!(e.render(&|s| match s {
                        InterpSetting::Order => "--orders",
                    }))
                })?
                .0,
        )],
        OrdersArg::List(orders) => {
            let mut out = Vec::new();
            for &order in orders {
                Method::Lagrange(order).fit(grid).with_context(|| {
                    format!("{}: order {order} cannot be fitted", a.table.display())
                })?;
                out.push(Method::Lagrange(order));
            }
            out
        }
    })
}

/// The models `compare` fits to a scattered table: the Gaussian process only. Asked for
/// by name, any other method is an error naming the missing grid node; by default both
/// kernels are compared and the grid methods are listed as not fitted, with the reason.
fn scattered_methods(
    a: &CompareArgs,
    missing: &errmap::table::TableError,
) -> Result<(Vec<Method>, evaluate::Refusals)> {
    let why = format!("a full grid is needed ({missing})");
    match &a.methods {
        Some(names) => {
            let mut methods = Vec::new();
            for name in listed(names) {
                if !name.accepts_scattered() {
                    bail!(
                        "{name} cannot be fitted to {}: {why}. Only gp and gp-se accept scattered nodes.",
                        a.table.display()
                    );
                }
                methods.push(method_of(name, None, &a.model, None)?);
            }
            if methods.is_empty() {
                bail!("no methods to compare");
            }
            Ok((methods, Vec::new()))
        }
        None => {
            let (methods, refused) = Method::scattered_defaults();
            Ok((
                methods,
                refused
                    .iter()
                    .map(|m| (m.to_string(), why.clone()))
                    .collect(),
            ))
        }
    }
}

pub(crate) fn compare_cmd(a: CompareArgs) -> Result<()> {
    super::guard::refuse_aliases(
        &[("--report", &a.report)],
        &[("TABLE", &a.table), ("--test", &a.test)],
    )?;
    let table = ErrorTable::read(&a.table)?;
    let test = ErrorTable::read(&a.test)?;
    let busy = super::guard::busy(format!(
        "compare: fitting and cross-validating on {} nodes, {} test points",
        table.points.len(),
        test.points.len()
    ));
    let comparison = match table.grid() {
        Ok(grid) => {
            let methods = compare_methods(&a, &grid)?;
            if a.methods.is_some() {
                evaluate::compare(&table, &grid, &test, &methods)
            } else {
                evaluate::compare_where_possible(&table, &grid, &test, &methods)
            }
        }
        Err(e @ errmap::table::TableError::MissingNode { .. }) => {
            let (methods, refused) = scattered_methods(&a, &e)?;
            evaluate::compare_scattered(&table, &test, &methods, refused)
        }
        Err(e) => return Err(e.into()),
    }
    .with_context(|| format!("{}: comparison failed", a.table.display()))?;
    drop(busy);
    let command = format!(
        "errmap compare {} --test {} --report {}{}",
        a.table.display(),
        a.test.display(),
        a.report.display(),
        if a.orders == OrdersArg::All {
            String::new()
        } else {
            format!(" --orders {}", a.orders)
        }
    );
    // The JSON document checked before the report is written: a failure leaves nothing.
    let json = match a.json {
        true => Some(errmap::report::json_text(
            Path::new("stdout"),
            &comparison.to_json(Some(&a.report)),
            false,
        )?),
        false => None,
    };
    super::guard::into_new_dir(&a.report, |dir| {
        Ok(report::write_compare_report(&comparison, dir, &command)?)
    })?;
    if let Some(text) = json {
        super::guard::print_stdout(&text)?;
    } else {
        print_summary(&comparison, &a.report);
    }
    Ok(())
}

pub(crate) fn print_summary(c: &evaluate::Comparison, dir: &Path) {
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

/// The typed settings of a controller table, from export's flags.
fn table_settings(a: &ExportArgs) -> Result<TableSettings> {
    Ok(TableSettings {
        axis: a.axis,
        axis_name: a.axis_name.clone(),
        axis_number: a.axis_number,
        max_points: a.max_points,
        table_name: a.table_name.clone(),
        units: super::import::length_unit(a.units.as_deref())?,
        comp_type: a.comp_type.map(Into::into),
        reference_mm: a.reference,
        options: a.dialect_options.0.clone(),
    })
}

/// `errmap export`: the flags become one [`ExportJob`] (or, for `--format grid`, the
/// volume written by `errmap::export::write_grid`), run once; the CLI reads the inputs,
/// writes the bytes and prints the summary.
pub(crate) fn export_cmd(a: ExportArgs) -> Result<()> {
    if let Some((axis, rows)) = super::rotary::rotary_table(&a.table)? {
        return super::rotary::export(&a, axis, &rows);
    }
    let output = match a.format {
        ExportFormatArg::Table(d) => Output::Table(d),
        ExportFormatArg::Csv => Output::Csv,
        ExportFormatArg::Grid if a.existing.is_some() || a.bidirectional => {
            return Err(super::guard::usage(format!(
                "--existing and --bidirectional take a controller table: {}",
                errmap::controller::names_where(|_| true, "or")
            )));
        }
        ExportFormatArg::Grid => return export_grid(&a),
    };
    let settings = table_settings(&a)?;
    // A table whose file states no unit needs one before anything is read.
    if let Output::Table(d) = output
        && a.existing.is_none()
    {
        d.export_format(&settings, a.bidirectional)
            .map_err(|e| super::import::settings_error(e, ""))?;
    }
    let placement = Placement {
        ends: a.ends.map(Into::into),
        reference_mm: a.reference,
    };
    if let Some(existing) = &a.existing {
        return export_existing(&a, output, settings, placement, existing);
    }
    if a.bidirectional {
        return export_bidirectional(&a, output, settings, placement);
    }
    // clap requires both without --bidirectional.
    let (Some(method), Some(step)) = (a.method, a.step) else {
        return Err(super::guard::usage(
            "--method and --step are needed (or --bidirectional with a session)",
        ));
    };
    super::guard::refuse_aliases(&[("--out", &a.out)], &[("TABLE", &a.table)])?;
    let Fitted { model, extent, .. } = fit_table(&a.table, method, a.order, &a.model)?;
    let lo = extent.bounds.map(|b| b[0]);
    let hi = extent.bounds.map(|b| b[1]);
    let axis = a.axis;
    // The line's fixed coordinates: given ones, else the first node on that axis.
    let mut at = lo;
    for &(k, v) in &a.at.0 {
        if k == axis {
            return Err(super::guard::usage(format!(
                "--at: {k} is the axis of the line (--axis {k}); give the other two"
            )));
        }
        at[k.index()] = v;
    }
    let job = ExportJob {
        output,
        settings,
        placement,
        source: Source::Model {
            model: model.as_ref(),
            line: LineSpec {
                axis,
                at_mm: at,
                start_mm: a.start.unwrap_or(lo[axis.index()]),
                end_mm: a.end.unwrap_or(hi[axis.index()]),
                step_mm: step,
            },
            extrapolation: extrapolation(&a),
        },
    };
    let what = || {
        format!(
            "{}: the line along {axis} (--at, --start, --end, --step)",
            a.table.display()
        )
    };
    let exported = job::run(&job)
        .map_err(|e| job_error(e, ""))
        .with_context(what)?;
    super::guard::write_file(&a.out, &exported.bytes)?;
    let Written::Line { sampled, note } = &exported.written else {
        bail!("export: a line was asked for");
    };
    let fixed: Vec<String> = errmap::base::Axis::ALL
        .iter()
        .filter(|&&k| k != axis)
        .map(|k| format!("{k}={}", at[k.index()]))
        .collect();
    eprintln!(
        "export: {} {} entries along {} from {} to {} mm at {} mm ({} extrapolated) → {}; \
         compensation = −error",
        exported.format,
        sampled.positions_mm.len(),
        a.axis,
        sampled.positions_mm[0],
        sampled.positions_mm[sampled.len() - 1],
        fixed.join(","),
        sampled.extrapolated_count(),
        a.out.display()
    );
    if let Some(note) = note {
        eprintln!("export: {note}");
    }
    Ok(())
}

fn extrapolation(a: &ExportArgs) -> Extrapolation {
    if a.forbid_extrapolation {
        Extrapolation::Forbid
    } else {
        Extrapolation::Allow
    }
}

/// A job's refusal as the command line says it: a missing setting or a format without a
/// second direction is a usage error (exit 2), the rest exit 1.
fn job_error(e: JobError, comp_type_hint: &str) -> anyhow::Error {
    match e {
        JobError::Settings(s) => super::import::settings_error(s, comp_type_hint),
        e @ (JobError::NoReverse { .. } | JobError::NotUpdatable { .. }) => {
            super::guard::usage(format!(
                "{}{e}",
                if matches!(e, JobError::NoReverse { .. }) {
                    "--bidirectional: "
                } else {
                    "--existing: "
                }
            ))
        }
        // The export stage's refusals stay typed: `flags::in_flags` names their settings.
        JobError::Line(e) | JobError::Table(e) => anyhow::Error::from(e),
        JobError::ChooseLine(e) => anyhow::Error::from(e),
        other => anyhow::Error::from(other),
    }
}

/// `export --format grid`: the model over the nodes' box, every `--step` (not a
/// controller table: the export stage writes it).
fn export_grid(a: &ExportArgs) -> Result<()> {
    let (Some(method), Some(step)) = (a.method, a.step) else {
        return Err(super::guard::usage(
            "--method and --step are needed (or --bidirectional with a session)",
        ));
    };
    super::guard::refuse_aliases(&[("--out", &a.out)], &[("TABLE", &a.table)])?;
    let Fitted { model, extent, .. } = fit_table(&a.table, method, a.order, &a.model)?;
    let n = errmap::export::write_grid(
        model.as_ref(),
        &VolumeSpec {
            lo_mm: extent.bounds.map(|b| b[0]),
            hi_mm: extent.bounds.map(|b| b[1]),
            spacing_mm: step,
        },
        extrapolation(a),
        &a.out,
    )
    .with_context(|| format!("{}: the grid of --step {step} mm", a.table.display()))?;
    eprintln!("export: {n} grid points → {}", a.out.display());
    Ok(())
}

pub(crate) fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    let model = errmap::sim::MachineModel::read(&a.model)?;
    let map_table = model.error_map.as_ref().map(|m| m.table.clone());
    let mut inputs = vec![("--model", a.model.as_path()), ("--plan", a.plan.as_path())];
    if let Some(t) = &map_table {
        inputs.push(("--model's error_map.table", t.as_path()));
    }
    let mut outputs = vec![("--out", a.out.as_path())];
    if let Some(raw) = &a.raw {
        outputs.push(("--raw", raw.as_path()));
    }
    super::guard::refuse_aliases(&outputs, &inputs)?;
    let plan = errmap::sim::read_plan(Some(&a.plan))?;
    let (stream, _) =
        errmap::sim::simulate_plan(&model, &a.model, &plan, &Default::default(), !a.no_noise)?;
    let bytes = stream.bytes();
    if let Some(raw) = &a.raw {
        super::guard::write_file(raw, &bytes)?;
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

pub(crate) fn fuzzy_sim(a: FuzzySimArgs) -> Result<()> {
    let config = FuzzySimConfig {
        seed: a.seed,
        trials: a.trials.max(1),
        fuzzy_sigma: a.fuzzy_sigma,
        ..FuzzySimConfig::default()
    };
    let result = evaluate::run_fuzzy_sim(&config)?;
    let md = errmap::report::experiment_markdown(&result);
    if let Some(dir) = &a.report {
        super::guard::into_new_dir(dir, |d| {
            Ok(errmap::report::write_text(&d.join("report.md"), &md)?)
        })?;
    }
    if a.json {
        super::guard::print_json(&result)?;
    } else {
        eprint!("{md}");
    }
    Ok(())
}

/// `export SESSION --bidirectional`: a direction-dependent table from the session's
/// per-direction means at each target (ISO 230-2's x̄↑ and x̄↓, with the sign turned back
/// to errmap's e = −x), on one line of the session (`errmap::controller::job`).
fn export_bidirectional(
    a: &ExportArgs,
    output: Output,
    settings: TableSettings,
    placement: Placement,
) -> Result<()> {
    // Refused before the session is read: a format without a second direction.
    let has_reverse = match output {
        Output::Table(d) => d.limits().bidirectional,
        Output::Csv => false,
    };
    if !has_reverse {
        return Err(job_error(
            JobError::NoReverse {
                format: output.name(),
                with: errmap::controller::names_where(|d| d.limits().bidirectional, "and"),
            },
            "",
        ));
    }
    let (path, rows) = session_rows(a)?;
    let job = ExportJob {
        output,
        settings,
        placement,
        source: Source::Session {
            rows: &rows,
            at: &a.at.0,
            step_mm: a.step,
        },
    };
    let exported = match job::run(&job) {
        Ok(e) => e,
        Err(e @ (JobError::NoReverse { .. } | JobError::Settings(_))) => {
            return Err(job_error(e, ""));
        }
        Err(JobError::Table(e)) => {
            return Err(anyhow::Error::from(e))
                .with_context(|| format!("{}: {} table", path.display(), output.name()));
        }
        Err(JobError::Line(e)) => return Err(e.into()),
        // The line's position is named by its flag (`flags::in_flags`).
        Err(JobError::ChooseLine(e)) => {
            return Err(anyhow::Error::from(e)).context(path.display().to_string());
        }
        Err(e) => return Err(anyhow::Error::from(e)).context(path.display().to_string()),
    };
    super::guard::write_file(&a.out, &exported.bytes)?;
    let Written::Directions {
        forward,
        mean_reversal_um,
    } = &exported.written
    else {
        bail!("export: both directions were asked for");
    };
    let at_mm = forward.at_mm;
    eprintln!(
        "export: {} {} points along {} at ({}, {}, {}) mm, forward = x̄↑ and reverse = x̄↓ \
         (mean reversal {:.4} µm) → {}; compensation = −error",
        exported.format,
        forward.len(),
        forward.axis,
        at_mm[0],
        at_mm[1],
        at_mm[2],
        mean_reversal_um,
        a.out.display()
    );
    Ok(())
}

/// The session table `export SESSION` names, and its rows.
fn session_rows(a: &ExportArgs) -> Result<(std::path::PathBuf, Vec<errmap_drivers::SessionRow>)> {
    let path = super::acquisition::session_file(&a.table)?;
    let rows = errmap::session::read_session(&path)?;
    Ok((path, rows))
}

/// `export SESSION --existing TABLE --format F --out NEW`: the table updated by the
/// session's residual, in the table's own layout (`errmap::controller::update`).
fn export_existing(
    a: &ExportArgs,
    output: Output,
    settings: TableSettings,
    placement: Placement,
    existing: &Path,
) -> Result<()> {
    if let Output::Table(d) = output {
        let hint = format!("--existing with {} needs --comp-type actual|trim", d.name());
        super::import::table_format(d, &settings, &hint)?;
    } else {
        return Err(super::guard::usage(format!(
            "--existing updates {} tables",
            errmap::controller::names_where(|_| true, "or")
        )));
    }
    super::guard::refuse_aliases(
        &[("--out", &a.out)],
        &[("SESSION", &a.table), ("--existing", existing)],
    )?;
    let bytes = std::fs::read(existing).map_err(io_err(existing, FileOp::Read))?;
    let (path, rows) = session_rows(a)?;
    let job = ExportJob {
        output,
        settings,
        placement,
        source: Source::Existing {
            bytes: &bytes,
            rows: &rows,
            bidirectional: a.bidirectional,
        },
    };
    let exported = match job::run(&job) {
        Ok(e) => e,
        Err(JobError::Read(at)) => return Err(at.at(existing).into()),
        Err(JobError::Residual(e)) => {
            return Err(anyhow::Error::from(e))
                .with_context(|| format!("{}: the residual", path.display()));
        }
        Err(JobError::Update(e)) => {
            return Err(anyhow::Error::from(e))
                .with_context(|| format!("{} with {}", path.display(), existing.display()));
        }
        Err(e) => {
            return Err(job_error(e, ""));
        }
    };
    super::guard::write_file(&a.out, &exported.bytes)?;
    let Written::Updated(summary) = &exported.written else {
        bail!("export: an update was asked for");
    };
    for w in &summary.warnings {
        eprintln!("export: warning: {w}");
    }
    if a.json {
        super::guard::print_json(summary)?;
    }
    eprintln!(
        "export: {} {} points updated by the residual of {} (largest change {:.4} µm, {} \
         direction{}) → {}",
        summary.format,
        summary.points,
        path.display(),
        summary.max_change_um,
        summary.directions,
        if summary.directions == 1 { "" } else { "s" },
        a.out.display()
    );
    Ok(())
}
