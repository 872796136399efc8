//! The rotary axes on the command line (`docs/rotary.md`): `table` of a rotary session,
//! `import --format csv --axis a|b|c`, `diagnose --recorded` of a rotary session,
//! `export` of a rotary table and `plan --axis a|b|c`. Flags → library calls → output.

use std::io::Read as _;
use std::path::Path;

use anyhow::Result;
use errmap::base::{ARCSEC_PER_DEG, ARCSEC_PER_URAD, RotaryAxis};
use errmap::import::{Col, ErrorUnit};
use errmap::session::rotary::{self, RotaryError, RotaryRow, RotarySession};

use super::args::TableArgs;
use super::guard;
use super::import::{ErrorUnitArg, ImportArgs, ImportFormatArg};

/// Whether the session argument (a table or a capture directory) is rotary.
pub(crate) fn is_rotary_session(session: &Path) -> Result<bool> {
    let path = super::acquisition::session_file(session)?;
    Ok(rotary::is_rotary(&path)?)
}

/// `errmap table` of a rotary session: ISO 230-2 in ″, the closure check, the rotary
/// error table.
pub(crate) fn table_cmd(a: TableArgs) -> Result<()> {
    if a.tolerances.is_some() {
        return Err(guard::usage(
            "--tolerances judges a linear axis' E, A, B, R, M in µm; a rotary session has none",
        ));
    }
    let path = super::acquisition::session_file(&a.session)?;
    guard::refuse_aliases(&[("--out", &a.out)], &[("SESSION", &path)])?;
    let session = rotary::read_rotary_session(&path)?;
    let (iso, closure) = rotary::rotary_iso(&path, &session)?;
    let warnings: Vec<String> = closure
        .as_ref()
        .and_then(rotary::closure_warning)
        .into_iter()
        .collect();
    let table = rotary::rotary_error_table(&session);
    rotary::write_rotary_error_table(&a.out, session.axis, &table)?;
    let dwell_rows = session.rows.iter().filter(|r| r.is_dwell()).count();
    eprintln!(
        "table: rotary axis {}: {} targets from {} dwell rows; E = {:.2}″, A = {:.2}″, R = {:.2}″, \
         B = {:.2}″ → {}",
        session.axis,
        table.len(),
        dwell_rows,
        iso.e_arcsec,
        iso.a_arcsec,
        iso.r_arcsec,
        iso.b_arcsec,
        a.out.display()
    );
    for w in &warnings {
        eprintln!("table: warning: {w}");
    }
    let source = path.display().to_string();
    if let Some(dir) = &a.report {
        let md = errmap::report::rotary::rotary_iso_markdown(
            &source,
            session.axis,
            &iso,
            closure.as_ref(),
            &warnings,
        );
        guard::into_new_dir(dir, |d| {
            Ok(errmap::report::rotary::write_rotary_report(d, &md)?)
        })?;
        eprintln!(
            "table: ISO 230-2 report in {}",
            dir.join("report.md").display()
        );
    }
    if a.json {
        let doc = table_json(
            source,
            session.axis,
            (table.len(), dwell_rows),
            &iso,
            closure.as_ref(),
            &warnings,
        );
        guard::print_json(&doc)?;
    }
    Ok(())
}

/// The document of `errmap table ROTARY --json` (also the workbench's `/api/table`):
/// `counts` are the rotary error table's rows and the dwell rows used.
pub(crate) fn table_json<'a>(
    source: String,
    axis: RotaryAxis,
    counts: (usize, usize),
    iso: &'a rotary::RotaryIso,
    closure: Option<&'a rotary::Closure>,
    warnings: &'a [String],
) -> errmap::report::rotary::RotaryTableJson<'a> {
    use errmap::report::rotary::{RotaryLineJson, RotarySummaryJson, RotaryTableJson};
    RotaryTableJson {
        summary: RotarySummaryJson {
            kind: "rotary",
            axis,
            source,
            targets: counts.0,
            dwell_rows: counts.1,
        },
        nodes: counts.0,
        lines: vec![RotaryLineJson {
            axis,
            iso230: iso,
            closure,
        }],
        warnings,
    }
}

/// `import --format csv --axis a|b|c`: a rotary test from a spreadsheet (`docs/rotary.md` §6).
pub(crate) fn import(a: &ImportArgs, axis: RotaryAxis) -> Result<()> {
    if !matches!(a.format, ImportFormatArg::Csv) {
        return Err(guard::usage(format!(
            "--axis {} reads a rotary test from --format csv only",
            axis.lower()
        )));
    }
    let units = a.units.as_deref().unwrap_or("deg");
    let (len, rest) = units.split_once(',').unwrap_or((units, ""));
    if len.trim() != "deg" {
        return Err(guard::usage(format!(
            "--units {} with --axis {}: a rotary axis reads its angles in deg",
            len.trim(),
            axis.lower()
        )));
    }
    let arcsec_per_unit = match a.error_units.unwrap_or(ErrorUnitArg::Arcsec) {
        ErrorUnitArg::Arcsec => 1.0,
        ErrorUnitArg::Deg => ARCSEC_PER_DEG,
        ErrorUnitArg::Urad => ARCSEC_PER_URAD,
        u @ (ErrorUnitArg::Um | ErrorUnitArg::Mm | ErrorUnitArg::Inch) => {
            return Err(guard::usage(
                format!(
                    "--error-units {u:?} is a length: with --axis {} use arcsec, deg or urad",
                    axis.lower()
                )
                .to_lowercase(),
            ));
        }
    };
    // The angles read as lengths of unit 1 (mm) and the error column unscaled (um), then
    // converted here: ° stay °, the error becomes ″.
    let length_text = if rest.is_empty() {
        "mm".to_string()
    } else {
        format!("mm,{rest}")
    };
    let options = super::import::csv_options_with(a, &length_text, ErrorUnit::Um)?;
    let bytes = super::import::read_bytes(&a.file)?;
    if let Some(out) = &a.out {
        guard::refuse_aliases(&[("--out", out)], &[("FILE", &a.file)])?;
    }
    let imported = errmap::import::import_session(
        &a.file,
        &bytes,
        &errmap::import::ImportOptions {
            format: errmap::import::SessionFormat::Csv(Box::new(options.clone())),
            axis: Some(errmap::base::Axis::X),
        },
    )?;
    let lines = errmap::import::data_lines(&bytes, options.delimiter)
        .map_err(|e| anyhow::anyhow!("{}: line {}: {}", a.file.display(), e.line, e.message))?;
    let rows = rotary_rows(
        &a.file,
        axis,
        &imported.rows,
        &options,
        &lines,
        arcsec_per_unit,
    )?;
    let session = RotarySession { axis, rows };
    if let Some(out) = &a.out {
        rotary::write_rotary_session(out, &session)?;
    }
    let mut summary = imported.summary;
    summary.axis = axis.upper();
    summary.units_in = "deg";
    super::import::report(&summary, a.json)?;
    eprintln!(
        "import: csv {} rows ({} runs, {} targets) along rotary axis {}, from deg{}",
        summary.rows,
        summary.runs.unwrap_or(0),
        summary.targets,
        axis,
        a.out
            .as_ref()
            .map(|o| format!(" → {}", o.display()))
            .unwrap_or_default()
    );
    Ok(())
}

/// The imported rows (angles read as mm, the error unscaled) as rotary rows: targets
/// checked in [0, 360] at their line, the error converted to ″.
fn rotary_rows(
    file: &Path,
    axis: RotaryAxis,
    imported: &[errmap_drivers::SessionRow],
    options: &errmap::import::CsvOptions,
    lines: &[usize],
    arcsec_per_unit: f64,
) -> Result<Vec<RotaryRow>> {
    let target_col = match &options.map.target {
        Some(Col::Name(n)) => n.clone(),
        Some(Col::Number(k)) => format!("#{k}"),
        None => "target".into(),
    };
    let by_reference = options.map.reference.is_some();
    let mut rows = Vec::with_capacity(imported.len());
    for (k, r) in imported.iter().enumerate() {
        let target_deg = r.x_mm.unwrap_or(r.scale_mm);
        if !(0.0..=360.0).contains(&target_deg) {
            return Err(RotaryError::At {
                path: file.to_path_buf(),
                line: lines.get(k).copied().unwrap_or(k + 2),
                column: target_col.clone(),
                problem: format!(
                    "target {target_deg}° is outside [0, 360] (errmap never wraps an angle: \
                     write {})",
                    target_deg.rem_euclid(360.0)
                ),
            }
            .into());
        }
        // By reference: error_um = (I − R)·1000 with the angles in °; by error: the
        // column's value with its sign.
        let error_arcsec = if by_reference {
            r.error_um / 1000.0 * ARCSEC_PER_DEG
        } else {
            r.error_um * arcsec_per_unit
        };
        rows.push(RotaryRow {
            axis: axis.into(),
            run: r.run,
            sample: r.sample,
            t_s: r.t_s,
            direction: r.direction,
            target: r.target,
            target_deg: Some(target_deg),
            indicated_deg: r.scale_mm,
            reference_deg: if by_reference {
                r.laser_mm
            } else {
                r.scale_mm - error_arcsec / ARCSEC_PER_DEG
            },
            error_arcsec,
            feed_deg_s: None,
            air_temp_c: r.air_temp_c,
            part_temp_c: r.part_temp_c,
            scale_temp_c: r.scale_temp_c,
            flags: r.flags,
        });
    }
    Ok(rows)
}

/// `diagnose --recorded ROTARY --report DIR [--json]`: the rotary effects from the
/// recording alone.
pub(crate) fn diagnose(a: &super::args::DiagnoseArgs) -> Result<()> {
    if a.simulated.is_some() || a.model.is_some() {
        return Err(guard::usage(
            "--simulated and --model are for a linear axis: a rotary session is diagnosed from \
             the recording alone (--recorded)",
        ));
    }
    let path = super::acquisition::session_file(&a.recorded)?;
    let session = rotary::read_rotary_session(&path)?;
    let closure_mismatch = rotary::rotary_iso(&path, &session)
        .ok()
        .and_then(|(_, c)| c)
        .is_some_and(|c| !c.consistent);
    let t0 = session
        .rows
        .iter()
        .map(|r| r.t_s)
        .fold(f64::INFINITY, f64::min);
    let samples: Vec<errmap::diagnose::rotary::RotarySample> = session
        .rows
        .iter()
        .filter(|r| r.is_dwell())
        .map(|r| errmap::diagnose::rotary::RotarySample {
            run: r.run,
            direction: r.direction,
            target_deg: r.target_deg.unwrap_or(0.0),
            t_s: r.t_s - t0,
            e_arcsec: r.error_arcsec,
        })
        .collect();
    let d = errmap::diagnose::rotary::diagnose_rotary(&samples, closure_mismatch)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let j = errmap::report::rotary::RotaryDiagnosisJson::new(session.axis, &d);
    let md = j.markdown(&path.display().to_string());
    guard::into_new_dir(&a.report, |dir| {
        Ok(errmap::report::rotary::write_rotary_report(dir, &md)?)
    })?;
    if a.json {
        guard::print_json(&j)?;
    } else {
        eprintln!(
            "diagnose: rotary axis {}: {} ({} effects); report in {}",
            session.axis,
            j.verdict,
            j.effects.len(),
            a.report.display()
        );
    }
    Ok(())
}

/// A rotary table for `export`: a rotary session reduced as `table`, or a rotary error
/// table; `None` for anything else.
pub(crate) fn rotary_table(p: &Path) -> Result<Option<rotary::RotaryTable>> {
    let Ok(path) = super::acquisition::session_file(p) else {
        return Ok(None);
    };
    if rotary::is_rotary(&path).unwrap_or(false) {
        let s = rotary::read_rotary_session(&path)?;
        let rows = rotary::rotary_error_table(&s)
            .iter()
            .map(|r| (r.angle_deg, r.e_arcsec))
            .collect();
        return Ok(Some((s.axis, rows)));
    }
    let parquet = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"));
    let header_says_rotary = parquet
        || std::fs::File::open(&path).ok().is_some_and(|f| {
            use std::io::BufRead;
            let mut h = String::new();
            let _ = std::io::BufReader::new(f).take(1 << 16).read_line(&mut h);
            h.split(',')
                .any(|c| ["a_deg", "b_deg", "c_deg"].contains(&c.trim().trim_matches('"')))
        });
    if !header_says_rotary {
        return Ok(None);
    }
    Ok(rotary::read_rotary_error_table(&path)?)
}

/// Each direction's errors of a rotary session, e↑ = −x̄↑ and e↓ = −x̄↓ (ISO 230-2 means
/// over the runs), at every target; `--bidirectional` needs both at each.
type Directions = (Vec<(f64, f64)>, Vec<(f64, f64)>);

fn directions(table: &Path) -> Result<Directions> {
    let path = super::acquisition::session_file(table)?;
    if !rotary::is_rotary(&path).unwrap_or(false) {
        return Err(guard::usage(format!(
            "--bidirectional with a rotary table needs a rotary session (both directions' \
             means), not the error table {}",
            path.display()
        )));
    }
    let session = rotary::read_rotary_session(&path)?;
    let (iso, _) = rotary::rotary_iso(&path, &session)?;
    if let Some(t) = iso.targets.iter().find(|t| t.n_up == 0 || t.n_down == 0) {
        anyhow::bail!(
            "{}: --bidirectional needs both directions at every target; the target at {}° has \
             {} up and {} down",
            path.display(),
            t.position_deg,
            t.n_up,
            t.n_down
        );
    }
    Ok((
        iso.targets
            .iter()
            .map(|t| (t.position_deg, -t.mean_up_arcsec))
            .collect(),
        iso.targets
            .iter()
            .map(|t| (t.position_deg, -t.mean_down_arcsec))
            .collect(),
    ))
}

/// The modulo table's settings from the flags (`docs/rotary.md` §4).
fn modulo_spec(
    a: &super::args::ExportArgs,
    axis: RotaryAxis,
) -> Result<errmap::controller::modulo::ModuloSpec> {
    use super::values::ExportFormatArg;
    use errmap::controller::modulo::{
        ModuloSpec, modulo_dialect, modulo_names, two_direction_tables,
    };
    let names = modulo_names();
    let dialect = match a.format {
        ExportFormatArg::Table(d) => modulo_dialect(d.name()).ok_or_else(|| {
            guard::usage(format!(
                "--format {} has no modulo table for a rotary axis ({names})",
                d.name()
            ))
        })?,
        _ => {
            return Err(guard::usage(format!(
                "a rotary table exports as a controller's modulo table: --format {names}"
            )));
        }
    };
    if a.method.is_some() || a.order.is_some() {
        return Err(guard::usage(
            "--method is not used with a rotary table (no model is fitted)",
        ));
    }
    let syntax = dialect.modulo().ok_or_else(|| {
        guard::usage(format!(
            "--format {} has no modulo table for a rotary axis ({names})",
            dialect.name()
        ))
    })?;
    if a.bidirectional && syntax.equidistant() {
        return Err(guard::usage(format!(
            "--bidirectional: {} modulo tables hold one value per point for both directions; \
             the two-direction rotary tables are {}",
            dialect.name(),
            two_direction_tables()
        )));
    }
    if a.units.is_some() {
        return Err(guard::usage("--units: a rotary table is in degrees"));
    }
    if a.existing.is_some() && syntax.needs_comp_type() && a.comp_type.is_none() {
        return Err(guard::usage(format!(
            "--existing with {} needs --comp-type actual|trim (the file does not say)",
            dialect.name()
        )));
    }
    let mut spec = ModuloSpec::new(dialect, axis);
    spec.set_options(&a.dialect_options.0).map_err(|e| {
        guard::usage(format!(
            "--{} is a length: a rotary {} table takes --{}",
            e.setting, e.controller, e.instead
        ))
    })?;
    spec.step_deg = a.step;
    spec.max_points = a.max_points;
    spec.reference_deg = a.reference;
    spec.trim = matches!(a.comp_type, Some(super::values::CompTypeArg::Trim));
    spec.axis_name = a.axis_name.clone();
    Ok(spec)
}

/// The largest table in use `--existing` reads (a modulo table has at most a few
/// thousand short lines).
const MAX_EXISTING_BYTES: u64 = 1 << 20;

/// `export` of a rotary table: a modulo compensation table (`docs/rotary.md` §4), one
/// correction or both directions (`--bidirectional`), or the table in use updated
/// (`--existing`).
pub(crate) fn export(
    a: &super::args::ExportArgs,
    axis: RotaryAxis,
    rows: &[(f64, f64)],
) -> Result<()> {
    use errmap::controller::job::{self, ExportJob, JobError, Output, Placement, Source, Written};
    use errmap::controller::modulo::{ModuloError, ModuloInput};
    let spec = modulo_spec(a, axis)?;
    let mut inputs = vec![("TABLE", a.table.as_path())];
    inputs.extend(a.existing.as_deref().map(|e| ("--existing", e)));
    guard::refuse_aliases(&[("--out", &a.out)], &inputs)?;
    let both = if a.bidirectional {
        Some(directions(&a.table)?)
    } else {
        None
    };
    let existing = match &a.existing {
        Some(p) => Some(read_bounded(p)?),
        None => None,
    };
    let residual: Vec<&[(f64, f64)]> = match &both {
        Some((up, down)) => vec![up, down],
        None => vec![rows],
    };
    let input = match (&existing, &both) {
        (Some(bytes), _) => ModuloInput::Existing {
            bytes,
            residual: &residual,
        },
        (None, Some((up, down))) => ModuloInput::Directions { up, down },
        (None, None) => ModuloInput::Table(rows),
    };
    let super::values::ExportFormatArg::Table(d) = a.format else {
        unreachable!("modulo_spec accepts controller tables only");
    };
    let exported = job::run(&ExportJob {
        output: Output::Table(d),
        settings: errmap::controller::TableSettings::new(errmap::base::Axis::X),
        placement: Placement {
            ends: None,
            reference_mm: a.reference,
        },
        source: Source::Modulo { spec: &spec, input },
    })
    .map_err(|e| match (e, &a.existing) {
        // A step that does not divide the revolution is the flag's fault alone (exit 2,
        // docs/cli.md); every other refusal is the table's (exit 1).
        (JobError::Modulo(e @ ModuloError::Step { .. }), _) => guard::usage(format!("--step: {e}")),
        (JobError::Modulo(e @ ModuloError::Existing { .. }), Some(p)) => {
            anyhow::anyhow!("{}: {e}", p.display())
        }
        (JobError::Modulo(e @ ModuloError::Mismatch { .. }), Some(p)) => {
            anyhow::anyhow!("{}: {}", p.display(), super::flags::said(&e))
        }
        (e, _) => anyhow::anyhow!("{}: {e}", a.table.display()),
    })?;
    let Written::Modulo(t) = &exported.written else {
        anyhow::bail!("export: a modulo table was asked for");
    };
    errmap::table::write_atomically::<anyhow::Error>(&a.out, |f| {
        use std::io::Write;
        f.write_all(&exported.bytes)
            .map_err(|e| errmap::base::io_err(&a.out, errmap::base::FileOp::Write)(e).into())
    })?;
    for w in &t.warnings {
        eprintln!("export: warning: {w}");
    }
    let what = match (&a.existing, &t.directions) {
        (Some(p), _) => format!(
            "{} updated, largest change {:.3}″,",
            p.display(),
            t.max_change_arcsec.unwrap_or(0.0)
        ),
        (None, Some(_)) => "two-direction modulo table".into(),
        (None, None) => "modulo table".into(),
    };
    eprintln!(
        "export: {} {what} of rotary axis {}: {} points, largest residual {:.3}″ → {}",
        t.format,
        axis,
        t.points,
        t.max_residual_arcsec,
        a.out.display()
    );
    if a.json {
        guard::print_json(t)?;
    }
    Ok(())
}

/// The table in use, read whole when it is at most [`MAX_EXISTING_BYTES`].
fn read_bounded(p: &Path) -> Result<Vec<u8>> {
    use errmap::base::{FileOp, io_err};
    let f = std::fs::File::open(p).map_err(io_err(p, FileOp::Read))?;
    let mut bytes = Vec::new();
    f.take(MAX_EXISTING_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io_err(p, FileOp::Read))?;
    if bytes.len() as u64 > MAX_EXISTING_BYTES {
        anyhow::bail!(
            "{}: more than {MAX_EXISTING_BYTES} bytes: not a modulo table",
            p.display()
        );
    }
    Ok(bytes)
}

/// `plan --axis a|b|c`: the ISO 230-2 cycle in degrees and its part program.
pub(crate) fn plan(a: &super::plan::PlanArgs, axis: RotaryAxis) -> Result<()> {
    if a.feed_mm_s.is_some() || !a.at.0.is_empty() {
        return Err(guard::usage(format!(
            "--feed-mm-s and --at are for a linear axis; --axis {} takes --feed-deg-s",
            axis.lower()
        )));
    }
    if !(0.0 <= a.from && a.from < a.to && a.to <= 360.0) {
        return Err(guard::usage(format!(
            "--from {} --to {}: 0 ≤ from < to ≤ 360 for a rotary axis (errmap never wraps an \
             angle)",
            a.from, a.to
        )));
    }
    if a.mark_output.is_some() {
        return Err(guard::usage("--mark-output is not built for a rotary plan"));
    }
    let mut outputs = vec![("--out", a.out.as_path())];
    outputs.extend(a.program.as_deref().map(|p| ("--program", p)));
    guard::refuse_aliases(&outputs, &[])?;
    let plan = errmap::sim::RotaryPlan::generate(errmap::sim::RotaryPlanConfig {
        axis,
        from_deg: a.from,
        to_deg: a.to,
        targets: a.targets,
        interval_deg: a.interval,
        runs: a.runs,
        overrun_deg: a.overrun,
        dwell_s: a.dwell_s,
        feed_deg_s: a.feed_deg_s.unwrap_or(10.0),
        random_offset: a.random_offset,
        seed: a.seed,
    })
    .map_err(|e| guard::usage(format!("--{}", e.to_string().replace('_', "-"))))?;
    // Rendered first: a program the dialect refuses (a dwell too long) writes nothing.
    let program = a
        .program
        .as_ref()
        .map(|_| errmap::controller::program::render_rotary(&plan, a.dialect))
        .transpose()?;
    guard::write_file(&a.out, plan.toml().as_bytes())?;
    eprintln!(
        "plan: {} targets of rotary axis {axis}, {}° to {}°, {} runs → {}",
        plan.targets_deg.len(),
        a.from,
        a.to,
        a.runs,
        a.out.display()
    );
    if let (Some(p), Some(text)) = (&a.program, program) {
        guard::write_file(p, text.as_bytes())?;
        eprintln!("plan: {} program → {}", a.dialect.name(), p.display());
    }
    Ok(())
}

/// `errmap certificate` of a rotary session (`docs/rotary.md`, "The rotary certificate").
pub(crate) fn certificate_cmd(a: super::certificate::CertificateArgs) -> Result<()> {
    use errmap::report::certificate::CertificateInfo;
    use errmap::report::certificate::rotary::{RotaryCertificate, write};
    if a.tolerances.is_some() {
        return Err(guard::usage(
            "--tolerances judges a linear axis' E, A, B, R, M in µm; a rotary session has none",
        ));
    }
    let path = super::acquisition::session_file(&a.session)?;
    let mut inputs = vec![("SESSION", path.as_path())];
    inputs.extend(a.info.as_deref().map(|p| ("--info", p)));
    guard::refuse_aliases(&[("--out", &a.out)], &inputs)?;
    let info = match &a.info {
        Some(p) => CertificateInfo::read(p)?,
        None => CertificateInfo::default(),
    };
    let session = rotary::read_rotary_session(&path)?;
    let (iso, closure) = rotary::rotary_iso(&path, &session)?;
    let counts = errmap::acquire::rotary_count_arcsec(&path);
    let budget = rotary::rotary_budget(
        &iso,
        &rotary::RotaryBudgetInputs {
            reference_accuracy_arcsec: info.reference.accuracy_arcsec,
            centring_arcsec: info.reference.centring_arcsec,
            encoder_count_arcsec: counts.map(|c| c.0),
            reference_count_arcsec: counts.map(|c| c.1),
        },
    );
    let dwell: Vec<&RotaryRow> = session.rows.iter().filter(|r| r.is_dwell()).collect();
    let temps = dwell.iter().filter_map(|r| r.air_temp_c);
    let air_temp_c = temps.clone().reduce(f64::min).zip(temps.reduce(f64::max));
    let source = path.display().to_string();
    let cert = RotaryCertificate {
        source: &source,
        axis: session.axis,
        iso: &iso,
        closure: closure.as_ref(),
        budget: &budget,
        info: &info,
        dwell_rows: dwell.len(),
        air_temp_c,
    };
    write(&a.out, &cert)?;
    if let Some(w) = closure.as_ref().and_then(rotary::closure_warning) {
        eprintln!("certificate: warning: {w}");
    }
    if budget.reference_assumed {
        eprintln!(
            "certificate: the reference's accuracy is not stated ([reference] accuracy_arcsec \
             in --info): ±{}″ assumed",
            rotary::ASSUMED_REFERENCE_ACCURACY_ARCSEC
        );
    }
    eprintln!(
        "certificate: rotary axis {}: E = {:.2}″, A = {:.2}″, U = {:.2}″ (k = 2) → {}",
        session.axis,
        iso.e_arcsec,
        iso.a_arcsec,
        budget.expanded_arcsec,
        a.out.display()
    );
    Ok(())
}
