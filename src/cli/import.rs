//! `errmap import`: a laser vendor's export, a spreadsheet or a controller table into
//! errmap's tables; and `export --existing`: a controller table updated by a session.
//! The flags become `errmap::import` options here; the library reads and checks.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use errmap::base::Axis;
use errmap::base::FileOp;
use errmap::base::error::io_err;
use errmap::import::csv::ErrorUnit;
use errmap::import::{
    self, ColumnMap, CsvOptions, ErrorSign, ImportOptions, LengthUnit, PressureUnit, SessionFormat,
    TableFormat, TempUnit,
};

use super::guard;
use super::values::{self, CompTypeArg};

/// `--format` of import.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ImportFormatArg {
    /// Decide by content (never by file name).
    Auto,
    /// API XD laser `.pos` "Linear Data Table".
    #[value(name = "api-xd", alias = "api")]
    ApiXd,
    /// Renishaw Laser10/LaserXL linear `.rtl`.
    #[value(name = "renishaw-rtl", alias = "rtl")]
    RenishawRtl,
    /// Any table of readings through --map.
    Csv,
    /// Fagor 8055 leadscrew table `AL<axis>` (needs --units).
    #[value(name = "fagor-8055", alias = "fagor8055")]
    Fagor8055,
    /// Fagor 8065 axis parameter file `<axis>.mp` (UTF-16LE).
    #[value(name = "fagor-8065", alias = "fagor8065")]
    Fagor8065,
    /// LinuxCNC COMP_FILE (needs --comp-type).
    Linuxcnc,
    /// Siemens 840D LEC/MSEC or direction-dependent CEC program (as errmap writes it).
    Siemens,
    /// FANUC pitch error data with errmap's parameter comment.
    Fanuc,
    /// HEIDENHAIN TNC .COM table.
    Heidenhain,
    /// TwinCAT CNC (ISG) kw.ssfk compensation value list.
    Isg,
}

#[derive(Debug, Args)]
pub(crate) struct ImportArgs {
    /// The file to read.
    pub file: PathBuf,
    #[arg(long, value_enum, default_value = "auto")]
    pub format: ImportFormatArg,
    /// The session table (positioning tests) or error table (controller tables) to
    /// write, .csv or .parquet. Without it the file is read and checked only.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// The measured axis (overrides the file's; csv and linuxcnc: default x).
    #[arg(long, value_parser = values::axis())]
    pub axis: Option<Axis>,
    /// CSV: key=COLUMN,… with target and reference (optional indicated) or error; optional
    /// run, direction, air_temp, air_pressure, air_rh, part_temp, scale_temp. COLUMN is a
    /// header name or #n (1-based).
    #[arg(long)]
    pub map: Option<String>,
    /// CSV delimiter: one character or `tab`.
    #[arg(long, default_value = ",")]
    pub delimiter: String,
    /// CSV: `,` is the decimal mark in every number.
    #[arg(long)]
    pub decimal_comma: bool,
    /// LEN[,TEMP[,PRESS]]: mm|inch, C|F, hPa|kPa|inHg|mmHg (CSV; Fagor/LinuxCNC: LEN).
    #[arg(long)]
    pub units: Option<String>,
    /// CSV error column unit: um, mm or inch.
    #[arg(long, value_enum, default_value = "um")]
    pub error_units: ErrorUnitArg,
    /// CSV error column sign (required with error=).
    #[arg(long, value_enum)]
    pub error_sign: Option<ErrorSignArg>,
    /// LinuxCNC COMP_FILE_TYPE of the table read: actual (0) or trim (1).
    #[arg(long, value_enum)]
    pub comp_type: Option<CompTypeArg>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ErrorUnitArg {
    Um,
    Mm,
    Inch,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ErrorSignArg {
    /// reference − indicated (ISO 230-2 deviation): e = −value.
    ReferenceMinusIndicated,
    /// indicated − reference (errmap's error): e = +value.
    IndicatedMinusReference,
}

/// `--units LEN[,TEMP[,PRESS]]`.
fn units(s: &str) -> Result<(LengthUnit, TempUnit, PressureUnit)> {
    let p: Vec<&str> = s.split(',').map(str::trim).collect();
    if p.len() > 3 {
        return Err(guard::usage(format!("--units `{s}`: LEN[,TEMP[,PRESS]]")));
    }
    let len = match p[0] {
        "mm" => LengthUnit::Mm,
        "inch" | "in" => LengthUnit::Inch,
        o => return Err(guard::usage(format!("--units: length `{o}` (mm or inch)"))),
    };
    let temp = match p.get(1).copied() {
        None | Some("C") | Some("c") => TempUnit::C,
        Some("F") | Some("f") => TempUnit::F,
        Some(o) => return Err(guard::usage(format!("--units: temperature `{o}` (C or F)"))),
    };
    let press = match p.get(2).copied() {
        None | Some("hPa") => PressureUnit::HPa,
        Some("kPa") => PressureUnit::KPa,
        Some("inHg") => PressureUnit::InHg,
        Some("mmHg") => PressureUnit::MmHg,
        Some(o) => {
            return Err(guard::usage(format!(
                "--units: pressure `{o}` (hPa, kPa, inHg or mmHg)"
            )));
        }
    };
    Ok((len, temp, press))
}

fn length_only(a: Option<&str>, flag_needed: bool, what: &str) -> Result<LengthUnit> {
    match a {
        Some(s) => {
            let (len, ..) = units(s)?;
            Ok(len)
        }
        None if flag_needed => Err(guard::usage(format!(
            "{what} states no unit: --units mm or --units inch is required"
        ))),
        None => Ok(LengthUnit::Mm),
    }
}

fn csv_options(a: &ImportArgs) -> Result<CsvOptions> {
    let Some(map) = &a.map else {
        return Err(guard::usage(
            "--format csv needs --map target=COL,reference=COL (or error=COL with --error-sign)",
        ));
    };
    let map = ColumnMap::parse(map).map_err(guard::usage)?;
    if map.error.is_some() && a.error_sign.is_none() {
        return Err(guard::usage(
            "--map error=… needs --error-sign reference-minus-indicated|indicated-minus-reference \
             (a sign is never guessed)",
        ));
    }
    let delimiter = match a.delimiter.as_str() {
        "tab" | "TAB" | "\\t" => '\t',
        s if s.chars().count() == 1 => s.chars().next().unwrap_or(','),
        s => {
            return Err(guard::usage(format!(
                "--delimiter `{s}`: one character or `tab`"
            )));
        }
    };
    let (length, temperature, pressure) = units(a.units.as_deref().unwrap_or("mm"))?;
    Ok(CsvOptions {
        map,
        delimiter,
        decimal_comma: a.decimal_comma,
        length,
        temperature,
        pressure,
        error_units: match a.error_units {
            ErrorUnitArg::Um => ErrorUnit::Um,
            ErrorUnitArg::Mm => ErrorUnit::Mm,
            ErrorUnitArg::Inch => ErrorUnit::Inch,
        },
        error_sign: a.error_sign.map(|s| match s {
            ErrorSignArg::ReferenceMinusIndicated => ErrorSign::ReferenceMinusIndicated,
            ErrorSignArg::IndicatedMinusReference => ErrorSign::IndicatedMinusReference,
        }),
    })
}

/// The controller-table format of `--format` (or of the detected file) and its flags.
fn table_format(f: ImportFormatArg, a: &ImportArgs) -> Result<Option<TableFormat>> {
    Ok(Some(match f {
        ImportFormatArg::Fagor8055 => TableFormat::Fagor8055 {
            units: length_only(a.units.as_deref(), true, "a Fagor 8055 table")?,
        },
        ImportFormatArg::Fagor8065 => TableFormat::Fagor8065 {
            units: length_only(a.units.as_deref(), false, "")?,
        },
        ImportFormatArg::Linuxcnc => TableFormat::LinuxCnc {
            comp_type: a
                .comp_type
                .ok_or_else(|| {
                    guard::usage(
                        "--format linuxcnc needs --comp-type actual|trim (COMP_FILE_TYPE 0|1)",
                    )
                })?
                .into(),
            units: length_only(a.units.as_deref(), false, "")?,
        },
        ImportFormatArg::Siemens => TableFormat::Siemens,
        ImportFormatArg::Fanuc => TableFormat::Fanuc,
        ImportFormatArg::Heidenhain => TableFormat::Heidenhain,
        ImportFormatArg::Isg => TableFormat::Isg,
        _ => return Ok(None),
    }))
}

fn read_bytes(path: &std::path::Path) -> Result<Vec<u8>> {
    let bytes = std::fs::read(path).map_err(io_err(path, FileOp::Read))?;
    Ok(bytes)
}

fn report(summary: &import::ImportSummary, json: bool) -> Result<()> {
    for w in &summary.warnings {
        eprintln!("import: warning: {w}");
    }
    if json {
        guard::print_json(summary)?;
    }
    Ok(())
}

pub(crate) fn import_cmd(a: ImportArgs) -> Result<()> {
    // Flags first (usage errors, exit 2), then the file.
    let csv = match a.format {
        ImportFormatArg::Csv => Some(csv_options(&a)?),
        _ => None,
    };
    let mut format = a.format;
    let bytes = read_bytes(&a.file)?;
    if format == ImportFormatArg::Auto {
        match import::detect(&bytes) {
            Ok(import::Format::Fagor8055) => format = ImportFormatArg::Fagor8055,
            Ok(import::Format::Fagor8065) => format = ImportFormatArg::Fagor8065,
            Ok(import::Format::Siemens) => format = ImportFormatArg::Siemens,
            Ok(import::Format::Fanuc) => format = ImportFormatArg::Fanuc,
            Ok(import::Format::Heidenhain) => format = ImportFormatArg::Heidenhain,
            Ok(import::Format::Isg) => format = ImportFormatArg::Isg,
            _ => {}
        }
    }
    if let Some(out) = &a.out {
        guard::refuse_aliases(&[("--out", out)], &[("FILE", &a.file)])?;
    }
    if let Some(tf) = table_format(format, &a)? {
        let table = import::tables::read(&bytes, tf).map_err(|e| e.at(&a.file))?;
        let mut warnings = Vec::new();
        let axis = match (a.axis, table.axis) {
            (Some(given), Some(file)) if given != file => {
                warnings.push(format!(
                    "--axis {given} overrides the file's axis {}",
                    file.upper()
                ));
                given
            }
            (Some(given), _) => given,
            (None, Some(file)) => file,
            (None, None) => Axis::X,
        };
        let rows = table.rows(axis);
        if let Some(out) = &a.out {
            import::tables::write_error_table(out, &rows)?;
        }
        let summary = table.summary(axis, warnings);
        report(&summary, a.json)?;
        eprintln!(
            "import: {} {} points along {}, {}{}",
            summary.format,
            summary.rows,
            axis,
            if table.bidirectional {
                "bidirectional"
            } else {
                "one table for both directions"
            },
            a.out
                .as_ref()
                .map(|o| format!(" → {}", o.display()))
                .unwrap_or_default()
        );
        return Ok(());
    }
    let options = ImportOptions {
        format: match (format, csv) {
            (ImportFormatArg::ApiXd, _) => SessionFormat::ApiXd,
            (ImportFormatArg::RenishawRtl, _) => SessionFormat::RenishawRtl,
            (ImportFormatArg::Csv, Some(o)) => SessionFormat::Csv(Box::new(o)),
            _ => SessionFormat::Auto,
        },
        axis: a.axis,
    };
    let imported = import::import_session(&a.file, &bytes, &options)?;
    if let Some(out) = &a.out {
        errmap::session::write_session(out, &imported.rows)
            .with_context(|| format!("{}: writing the session", a.file.display()))?;
    }
    let s = &imported.summary;
    report(s, a.json)?;
    eprintln!(
        "import: {} {} rows ({} runs, {} targets, {} direction{}) along {}, from {}{}",
        s.format,
        s.rows,
        s.runs.unwrap_or(0),
        s.targets,
        s.directions,
        if s.directions == 1 { "" } else { "s" },
        s.axis,
        s.units_in,
        a.out
            .as_ref()
            .map(|o| format!(" → {}", o.display()))
            .unwrap_or_default()
    );
    Ok(())
}

/// The flags of `export SESSION --existing TABLE` (taken from `ExportArgs`).
#[derive(Debug)]
pub(crate) struct ExistingArgs<'a> {
    pub session: &'a std::path::Path,
    pub existing: &'a std::path::Path,
    pub format: TableFormatChoice,
    pub units: Option<&'a str>,
    pub comp_type: Option<CompTypeArg>,
    pub bidirectional: bool,
    pub out: &'a std::path::Path,
    pub json: bool,
    /// The table's axis when the file names none (`--axis`).
    pub axis: Axis,
}

/// The table formats `--existing` updates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TableFormatChoice {
    Fagor8055,
    Fagor8065,
    Linuxcnc,
    Siemens,
    Fanuc,
    Heidenhain,
    Isg,
}

/// `export SESSION --existing TABLE --format F --out NEW`: the table updated by the
/// session's residual, in the table's own layout.
pub(crate) fn export_existing(a: ExistingArgs<'_>) -> Result<()> {
    let tf = match a.format {
        TableFormatChoice::Fagor8055 => TableFormat::Fagor8055 {
            units: length_only(a.units, true, "a Fagor 8055 table")?,
        },
        TableFormatChoice::Fagor8065 => TableFormat::Fagor8065 {
            units: length_only(a.units, false, "")?,
        },
        TableFormatChoice::Linuxcnc => TableFormat::LinuxCnc {
            comp_type: a
                .comp_type
                .ok_or_else(|| {
                    guard::usage("--existing with linuxcnc needs --comp-type actual|trim")
                })?
                .into(),
            units: length_only(a.units, false, "")?,
        },
        TableFormatChoice::Siemens => TableFormat::Siemens,
        TableFormatChoice::Fanuc => TableFormat::Fanuc,
        TableFormatChoice::Heidenhain => TableFormat::Heidenhain,
        TableFormatChoice::Isg => TableFormat::Isg,
    };
    guard::refuse_aliases(
        &[("--out", a.out)],
        &[("SESSION", a.session), ("--existing", a.existing)],
    )?;
    let bytes = read_bytes(a.existing)?;
    let table = import::tables::read(&bytes, tf)
        .map_err(|e| e.at(a.existing))?
        .assume_axis(a.axis);
    let path = super::acquisition::session_file(a.session)?;
    let rows = errmap::session::read_session(&path)?;
    let residual = import::Residual::from_session(&rows, a.bidirectional)
        .with_context(|| format!("{}: the residual", path.display()))?;
    let updated = import::update_table(&table, &residual, a.bidirectional)
        .with_context(|| format!("{} with {}", path.display(), a.existing.display()))?;
    guard::write_file(a.out, &updated.bytes)?;
    for w in &updated.summary.warnings {
        eprintln!("export: warning: {w}");
    }
    if a.json {
        guard::print_json(&updated.summary)?;
    }
    eprintln!(
        "export: {} {} points updated by the residual of {} (largest change {:.4} µm, {} \
         direction{}) → {}",
        updated.summary.format,
        updated.summary.points,
        path.display(),
        updated.summary.max_change_um,
        updated.summary.directions,
        if updated.summary.directions == 1 {
            ""
        } else {
            "s"
        },
        a.out.display()
    );
    Ok(())
}

/// `export`'s hook: `Some` when `--existing` is given (the update) or a Fagor format is
/// asked for without it (refused: errmap writes Fagor tables only by updating one).
pub(crate) fn existing_or_refuse(a: &super::args::ExportArgs) -> Option<Result<()>> {
    use super::values::ExportFormatArg as F;
    let choice = match a.format {
        F::Fagor8055 => Some(TableFormatChoice::Fagor8055),
        F::Fagor8065 => Some(TableFormatChoice::Fagor8065),
        F::Linuxcnc => Some(TableFormatChoice::Linuxcnc),
        F::Siemens => Some(TableFormatChoice::Siemens),
        F::Fanuc => Some(TableFormatChoice::Fanuc),
        F::Heidenhain => Some(TableFormatChoice::Heidenhain),
        F::Isg => Some(TableFormatChoice::Isg),
        _ => None,
    };
    let Some(existing) = &a.existing else {
        if choice == Some(TableFormatChoice::Fagor8055)
            && let Err(e) = length_only(a.units.as_deref(), true, "a Fagor 8055 table")
        {
            return Some(Err(e));
        }
        return None;
    };
    let Some(format) = choice else {
        return Some(Err(guard::usage(
            "--existing updates fagor-8055, fagor-8065, linuxcnc, siemens, fanuc, heidenhain or \
             isg tables",
        )));
    };
    Some(export_existing(ExistingArgs {
        session: &a.table,
        existing,
        format,
        units: a.units.as_deref(),
        comp_type: a.comp_type,
        bidirectional: a.bidirectional,
        out: &a.out,
        json: a.json,
        axis: a.axis,
    }))
}

/// `export --format fagor-8055|fagor-8065` (from a model or a session's means): the axis
/// letter and the unit (`--units`; the 8055's checked by [`existing_or_refuse`] before,
/// the 8065's mm unless `--units inch`).
pub(crate) fn fagor_format(a: &super::args::ExportArgs) -> errmap::export::ExportFormat {
    let inch = a.units.as_deref().is_some_and(|u| u.starts_with("in"));
    let letter = a
        .axis_name
        .as_deref()
        .and_then(|n| n.chars().next())
        .unwrap_or_else(|| a.axis.upper().chars().next().unwrap_or('X'));
    let spec = errmap::export::Fagor8055Spec {
        axis_letter: letter,
        inch,
    };
    if a.format == super::values::ExportFormatArg::Fagor8065 {
        errmap::export::ExportFormat::Fagor8065 { spec }
    } else {
        errmap::export::ExportFormat::Fagor8055 { spec }
    }
}
