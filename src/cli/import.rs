//! `errmap import`: a laser vendor's export, a spreadsheet or a controller table into
//! errmap's tables; and `export --existing`: a controller table updated by a session.
//! The flags become `errmap::import` options here; the library reads and checks.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, ValueEnum};
use errmap::base::Axis;
use errmap::base::FileOp;
use errmap::base::io_err;
use errmap::controller::{Dialect, SettingsError, TableFormat, TableSetting, TableSettings};
use errmap::import::ErrorUnit;
use errmap::import::{
    self, ColumnMap, CsvOptions, ErrorSign, ImportOptions, LengthUnit, PressureUnit, SessionFormat,
    TempUnit,
};

use super::guard;
use super::values::{self, CompTypeArg};

/// `--format` of import: decide by content, a laser export, a CSV, or a controller
/// dialect of the registry.
#[derive(Clone, Copy)]
pub(crate) enum ImportFormatArg {
    Auto,
    ApiXd,
    RenishawRtl,
    Csv,
    Table(&'static dyn Dialect),
}

impl std::fmt::Debug for ImportFormatArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ImportFormatArg::Auto => "auto",
            ImportFormatArg::ApiXd => "api-xd",
            ImportFormatArg::RenishawRtl => "renishaw-rtl",
            ImportFormatArg::Csv => "csv",
            ImportFormatArg::Table(d) => d.name(),
        })
    }
}

/// `--format` of import (see [`ImportFormatArg`]).
fn import_format() -> impl TypedValueParser<Value = ImportFormatArg> {
    let mut values = vec![
        PossibleValue::new("auto").help("Decide by content (never by file name)"),
        PossibleValue::new("api-xd")
            .alias("api")
            .help("API XD laser `.pos` \"Linear Data Table\""),
        PossibleValue::new("renishaw-rtl")
            .alias("rtl")
            .help("Renishaw Laser10/LaserXL linear `.rtl`"),
        PossibleValue::new("csv").help("Any table of readings through --map"),
    ];
    values.extend(values::dialect_values());
    PossibleValuesParser::new(values).map(|s| match s.as_str() {
        "auto" => ImportFormatArg::Auto,
        "api-xd" | "api" => ImportFormatArg::ApiXd,
        "renishaw-rtl" | "rtl" => ImportFormatArg::RenishawRtl,
        "csv" => ImportFormatArg::Csv,
        name => {
            errmap::controller::dialect(name).map_or(ImportFormatArg::Auto, ImportFormatArg::Table)
        }
    })
}

#[derive(Debug, Args)]
pub(crate) struct ImportArgs {
    /// The file to read.
    pub file: PathBuf,
    /// The file's format (decided by its content with `auto`, never by its name).
    #[arg(long, default_value = "auto", value_parser = import_format())]
    pub format: ImportFormatArg,
    /// The session table (positioning tests) or error table (controller tables) to
    /// write, .csv or .parquet. Without it the file is read and checked only.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// The measured axis (overrides the file's; csv and linuxcnc: default x); a, b or c
    /// reads a rotary test from --format csv (degrees and arcseconds).
    #[arg(long, value_parser = values::any_axis())]
    pub axis: Option<values::AnyAxis>,
    /// CSV: key=COLUMN,… with target and reference (optional indicated) or error; optional
    /// run, direction, air_temp, air_pressure, air_rh, part_temp, scale_temp. COLUMN is a
    /// header name or #n (1-based).
    #[arg(long, value_parser = column_map)]
    pub map: Option<String>,
    /// CSV delimiter: one character or `tab`.
    #[arg(long, default_value = ",", value_parser = delimiter)]
    pub delimiter: String,
    /// CSV: `,` is the decimal mark in every number.
    #[arg(long)]
    pub decimal_comma: bool,
    // LEN[,TEMP[,PRESS]]; the controllers that take LEN from the registry.
    #[arg(long, value_parser = units_flag, help = units_help())]
    pub units: Option<String>,
    /// CSV error column unit: um, mm or inch (default um); arcsec, deg or urad for a rotary
    /// axis (default arcsec).
    #[arg(long, value_enum)]
    pub error_units: Option<ErrorUnitArg>,
    /// CSV error column sign (required with error=).
    #[arg(long, value_enum)]
    pub error_sign: Option<ErrorSignArg>,
    #[arg(long, value_enum, help = comp_type_help())]
    pub comp_type: Option<CompTypeArg>,
}

/// The help of `import --units`: the CSV's units, and the controller tables' length unit
/// where their files do not state it (from the registry).
fn units_help() -> String {
    format!(
        "LEN[,TEMP[,PRESS]]: mm|inch, C|F, hPa|kPa|inHg|mmHg (CSV); a controller table's \
         LEN where its file does not state it: {}",
        values::readers_help(TableSetting::Units)
    )
}

/// The help of `import --comp-type` (from the registry).
fn comp_type_help() -> String {
    format!(
        "The type of the table read, where its file does not state it: actual (0) or trim \
         (1). {}",
        values::readers_help(TableSetting::CompType)
    )
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ErrorUnitArg {
    Um,
    Mm,
    Inch,
    Arcsec,
    Deg,
    Urad,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ErrorSignArg {
    /// reference − indicated (ISO 230-2 deviation): e = −value.
    ReferenceMinusIndicated,
    /// indicated − reference (errmap's error): e = +value.
    IndicatedMinusReference,
}

/// `--map` checked when the flags are parsed (kept as written; [`csv_options_with`] reads it).
fn column_map(s: &str) -> Result<String, String> {
    ColumnMap::parse(s)
        .map(|_| s.to_string())
        .map_err(|e| super::flags::said(&e))
}

/// `--delimiter` checked when the flags are parsed: one character or `tab`.
fn delimiter(s: &str) -> Result<String, String> {
    match s {
        "tab" | "TAB" | "\\t" => Ok(s.to_string()),
        s if s.chars().count() == 1 => Ok(s.to_string()),
        s => Err(format!("`{s}`: one character or `tab`")),
    }
}

/// `--units` checked when the flags are parsed: [`units`]' syntax, with `deg` (a rotary
/// axis' length unit, which [`units`] refuses for a linear one) taken as well.
fn units_flag(s: &str) -> Result<String, String> {
    let linear = match s.split_once(',') {
        Some(("deg", rest)) => format!("mm,{rest}"),
        None if s.trim() == "deg" => "mm".to_string(),
        _ => s.to_string(),
    };
    units(&linear)
        .map(|_| s.to_string())
        .map_err(|e| e.to_string())
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
        "deg" => {
            return Err(guard::usage(
                "--units deg is for a rotary axis (--axis a|b|c); a linear axis reads mm or inch",
            ));
        }
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

pub(crate) fn csv_options(a: &ImportArgs) -> Result<CsvOptions> {
    let error_units = match a.error_units.unwrap_or(ErrorUnitArg::Um) {
        ErrorUnitArg::Um => ErrorUnit::Um,
        ErrorUnitArg::Mm => ErrorUnit::Mm,
        ErrorUnitArg::Inch => ErrorUnit::Inch,
        u @ (ErrorUnitArg::Arcsec | ErrorUnitArg::Deg | ErrorUnitArg::Urad) => {
            return Err(guard::usage(format!(
                "--error-units {} is an angle: it is for a rotary axis (--axis a|b|c); a \
                 linear axis reads um, mm or inch",
                u.to_possible_value()
                    .map(|v| v.get_name().to_string())
                    .unwrap_or_default()
            )));
        }
    };
    csv_options_with(a, a.units.as_deref().unwrap_or("mm"), error_units)
}

/// The CSV options of the flags, with the units `LEN[,TEMP[,PRESS]]` and the error unit
/// given (a rotary import reads its angles as lengths of unit 1 and converts after).
pub(crate) fn csv_options_with(
    a: &ImportArgs,
    units_text: &str,
    error_units: ErrorUnit,
) -> Result<CsvOptions> {
    let Some(map) = &a.map else {
        return Err(guard::usage(
            "--format csv needs --map target=COL,reference=COL (or error=COL with --error-sign)",
        ));
    };
    let map = ColumnMap::parse(map).map_err(|e| guard::usage(super::flags::said(&e)))?;
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
    let (length, temperature, pressure) = units(units_text)?;
    Ok(CsvOptions {
        map,
        delimiter,
        decimal_comma: a.decimal_comma,
        length,
        temperature,
        pressure,
        error_units,
        error_sign: a.error_sign.map(|s| match s {
            ErrorSignArg::ReferenceMinusIndicated => ErrorSign::ReferenceMinusIndicated,
            ErrorSignArg::IndicatedMinusReference => ErrorSign::IndicatedMinusReference,
        }),
    })
}

/// What a controller table does not say, from the flags (a usage error when it is missing).
pub(crate) fn table_format(
    d: &'static dyn Dialect,
    settings: &TableSettings,
    comp_type_hint: &str,
) -> Result<TableFormat> {
    d.table_format(settings)
        .map_err(|e| settings_error(e, comp_type_hint))
}

/// A setting a dialect needs, as the flag that gives it (exit 2).
pub(crate) fn settings_error(e: SettingsError, comp_type_hint: &str) -> anyhow::Error {
    match e {
        SettingsError::NoUnit { what } => guard::usage(format!(
            "{what} states no unit: --units mm or --units inch is required"
        )),
        SettingsError::NoCompType => guard::usage(comp_type_hint.to_string()),
    }
}

/// The length unit of `--units LEN[,…]`, when given.
pub(crate) fn length_unit(a: Option<&str>) -> Result<Option<LengthUnit>> {
    a.map(|s| units(s).map(|u| u.0)).transpose()
}

pub(crate) fn read_bytes(path: &std::path::Path) -> Result<Vec<u8>> {
    let bytes = std::fs::read(path).map_err(io_err(path, FileOp::Read))?;
    Ok(bytes)
}

pub(crate) fn report(summary: &import::ImportSummary, json: bool) -> Result<()> {
    for (i, w) in summary.warnings.iter().enumerate() {
        if summary.axis_warning == Some(i) {
            eprintln!("import: warning: {w}; --axis sets it");
        } else {
            eprintln!("import: warning: {w}");
        }
    }
    if json {
        guard::print_json(summary)?;
    }
    Ok(())
}

pub(crate) fn import_cmd(a: ImportArgs) -> Result<()> {
    if let Some(values::AnyAxis::Rotary(axis)) = a.axis {
        return super::rotary::import(&a, axis);
    }
    let axis_flag = a.axis.and_then(values::AnyAxis::linear);
    // Flags first (usage errors, exit 2), then the file.
    let csv = match a.format {
        ImportFormatArg::Csv => Some(csv_options(&a)?),
        _ => None,
    };
    let mut format = a.format;
    let bytes = read_bytes(&a.file)?;
    if let ImportFormatArg::Auto = format
        && let Some(d) = errmap::controller::detect(&bytes)
    {
        format = ImportFormatArg::Table(d);
    }
    if let Some(out) = &a.out {
        guard::refuse_aliases(&[("--out", out)], &[("FILE", &a.file)])?;
    }
    if let ImportFormatArg::Table(d) = format {
        let settings = TableSettings {
            units: length_unit(a.units.as_deref())?,
            comp_type: a.comp_type.map(Into::into),
            ..TableSettings::new(axis_flag.unwrap_or(Axis::X))
        };
        let hint = format!(
            "--format {} needs --comp-type actual|trim (COMP_FILE_TYPE 0|1)",
            d.name()
        );
        let tf = table_format(d, &settings, &hint)?;
        let table = errmap::controller::read(&bytes, tf).map_err(|e| e.at(&a.file))?;
        let mut warnings = Vec::new();
        let axis = match (axis_flag, table.axis) {
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
            import::write_error_table(out, &rows)?;
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
        axis: axis_flag,
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
