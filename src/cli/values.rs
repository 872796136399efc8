//! The value types of the command line's flags: each parsed once, by clap, into a
//! library type. A value outside its set is a usage error (exit 2, as `docs/cli.md`
//! says), listed in `--help` where the set is closed.
//!
//! Names that belong to the library (method names, axes, kernels) come from the
//! library's own registries (`MethodName::ALL`, `Axis::ALL`, `Kernel`'s `FromStr`), so
//! the command line never spells them a second time.

use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

use clap::ValueEnum;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use errmap::base::Axis;
use errmap::controller::program::{self as part_program, ProgramSyntax};
use errmap::controller::{CompType, DIALECTS, Dialect as ControllerDialect, Spacing, TableSetting};
use errmap::export::Ends;
use errmap::interp::Kernel;
use errmap::interp::{MethodName, Order};
use errmap::volumetric::MAX_DEGREE;
use errmap::volumetric::{Component, Topology};

/// `--method`: a name from the method registry.
pub(crate) fn method_name() -> impl TypedValueParser<Value = MethodName> {
    PossibleValuesParser::new(MethodName::ALL.map(MethodName::as_str))
        .try_map(|s| s.parse::<MethodName>())
}

/// `--axis`: x, y or z (either case).
pub(crate) fn axis() -> impl TypedValueParser<Value = Axis> {
    PossibleValuesParser::new(Axis::ALL.map(|a| PossibleValue::new(a.lower()).alias(a.upper())))
        .try_map(|s| s.parse::<Axis>())
}

/// An axis flag that takes a rotary axis too: x, y, z or a, b, c (either case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AnyAxis {
    Linear(Axis),
    Rotary(errmap::base::RotaryAxis),
}

impl AnyAxis {
    /// The linear axis, if this is one.
    pub(crate) fn linear(self) -> Option<Axis> {
        match self {
            AnyAxis::Linear(a) => Some(a),
            AnyAxis::Rotary(_) => None,
        }
    }
}

/// `--axis x|y|z|a|b|c`.
pub(crate) fn any_axis() -> impl TypedValueParser<Value = AnyAxis> {
    let linear = Axis::ALL.map(|a| PossibleValue::new(a.lower()).alias(a.upper()));
    let rotary =
        errmap::base::RotaryAxis::ALL.map(|a| PossibleValue::new(a.lower()).alias(a.upper()));
    PossibleValuesParser::new(linear.into_iter().chain(rotary)).map(|s| match s.parse::<Axis>() {
        Ok(a) => AnyAxis::Linear(a),
        Err(_) => AnyAxis::Rotary(s.parse().unwrap_or(errmap::base::RotaryAxis::A)),
    })
}

/// `--dialect` of plan and volumetric program: a controller of the registry that writes
/// part programs.
pub(crate) fn dialect() -> impl TypedValueParser<Value = &'static dyn ProgramSyntax> {
    PossibleValuesParser::new(part_program::dialects().map(|p| p.name()))
        .try_map(|s| part_program::dialect(&s).map_err(|e| super::flags::said(&e)))
}

/// `--gp-kernel`: matern52 (alias matern) or se (alias squared-exponential).
pub(crate) fn kernel() -> impl TypedValueParser<Value = Kernel> {
    PossibleValuesParser::new([
        PossibleValue::new("matern52").alias("matern"),
        PossibleValue::new("se").alias("squared-exponential"),
    ])
    .try_map(|s| s.parse::<Kernel>())
}

/// `s` (trimmed) parsed, or the message "`s` is not {kind}".
fn parsed<T: FromStr>(s: &str, kind: &str) -> Result<T, String> {
    s.trim().parse().map_err(|_| format!("`{s}` is not {kind}"))
}

/// Seconds: finite and not negative (a `Duration` is built from it).
pub(crate) fn seconds(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number of seconds")?;
    if !v.is_finite() || v < 0.0 {
        return Err(format!("`{s}`: seconds must be finite and ≥ 0"));
    }
    if v > 1e9 {
        return Err(format!("`{s}`: more than 10⁹ s (31 years)"));
    }
    Ok(v)
}

/// A speed factor: finite, within 10⁻³…10⁶ (playback intervals divided by it become
/// `Duration`s, which a speed of 10⁻³⁰⁰ would overflow).
pub(crate) fn positive(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !v.is_finite() || v <= 0.0 {
        return Err(format!("`{s}` must be finite and > 0"));
    }
    if !(1e-3..=1e6).contains(&v) {
        return Err(format!("`{s}` is outside 0.001…1000000"));
    }
    Ok(v)
}

/// A length, mm or µm: finite, > 0, at most 10⁶ (`--step`, `--grating-period-um`).
pub(crate) fn length(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !(v.is_finite() && v > 0.0 && v <= 1e6) {
        return Err(format!("`{s}` must be a finite length > 0 and ≤ 10⁶"));
    }
    Ok(v)
}

/// The largest coordinate a flag takes, mm (issue 17's physical bound on positions).
pub(crate) const MAX_COORDINATE_MM: f64 = 1e6;

/// A coordinate, mm: finite, within ±10⁶ (`--start`, `--end`, `--reference`, `--from`).
pub(crate) fn coordinate(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !(v.is_finite() && v.abs() <= MAX_COORDINATE_MM) {
        return Err(format!("`{s}` must be a finite coordinate within ±10⁶ mm"));
    }
    Ok(v)
}

/// A length that may be 0, mm: finite, 0 … 10⁶ (`--overrun`).
pub(crate) fn non_negative_length(s: &str) -> Result<f64, String> {
    let v = coordinate(s)?;
    if v < 0.0 {
        return Err(format!("`{s}` must be ≥ 0"));
    }
    Ok(v)
}

/// A feed, mm/s: finite, > 0, ≤ 10⁶.
pub(crate) fn feed(s: &str) -> Result<f64, String> {
    let v = coordinate(s)?;
    if v <= 0.0 {
        return Err(format!("`{s}`: a feed must be > 0 mm/s"));
    }
    Ok(v)
}

/// A fraction of an interval in [0, 0.5) (plan's `--random-offset`: the inner targets
/// then stay in order).
pub(crate) fn offset_fraction(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !(0.0..0.5).contains(&v) {
        return Err(format!("`{s}` is not a fraction in [0, 0.5)"));
    }
    Ok(v)
}

/// A point PX,PY,PZ, mm: three coordinates (`--probe`, volumetric export's `--at`).
pub(crate) fn point3(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(coordinate)
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{s}`: three coordinates PX,PY,PZ in mm ({e})"))?;
    match v[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(format!(
            "`{s}`: three coordinates PX,PY,PZ in mm, not {}",
            v.len()
        )),
    }
}

/// volumetric `--topology`: a permutation of XYZ.
pub(crate) fn topology(s: &str) -> Result<Topology, String> {
    s.parse::<Topology>().map_err(|e| e.to_string())
}

/// volumetric `--degree`: `auto`, `auto-each` or a whole number 1 … [`MAX_DEGREE`]
/// (kept as written; `volumetric.rs` maps it).
pub(crate) fn degree(s: &str) -> Result<String, String> {
    match s.trim() {
        "auto" | "auto-each" => Ok(s.trim().to_string()),
        d => {
            component_degree_value(d)?;
            Ok(d.to_string())
        }
    }
}

/// volumetric `--max-degree`: 1 … [`MAX_DEGREE`].
pub(crate) fn max_degree(s: &str) -> Result<usize, String> {
    component_degree_value(s)
}

fn component_degree_value(d: &str) -> Result<usize, String> {
    let v: usize = d
        .trim()
        .parse()
        .map_err(|_| format!("`{d}` is neither `auto`, `auto-each` nor a whole number"))?;
    if !(1..=MAX_DEGREE).contains(&v) {
        return Err(format!("degree `{d}` is outside 1 … {MAX_DEGREE}"));
    }
    Ok(v)
}

/// volumetric `--component-degree E_XX=5,E_CX=2` → {component index: degree}.
pub(crate) fn component_degrees(s: &str) -> Result<BTreeMap<usize, usize>, String> {
    let mut out = BTreeMap::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, d) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}` is not NAME=DEGREE (e.g. E_XX=3)"))?;
        let c: Component = name.trim().parse().map_err(|e| format!("{e}"))?;
        if out.insert(c.index(), component_degree_value(d)?).is_some() {
            return Err(format!("{} is given twice", c.name()));
        }
    }
    Ok(out)
}

/// A probability: finite, within 0 … 1 (`--garbage`, `--bit-flips`, `--drop-frames`).
pub(crate) fn probability(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !(0.0..=1.0).contains(&v) {
        return Err(format!("`{s}` is not a probability in [0, 1]"));
    }
    Ok(v)
}

/// The fuzzy membership width σ, a fraction of the cell: finite, > 0, ≤ 100.
pub(crate) fn fuzzy_width(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if !(v.is_finite() && v > 0.0 && v <= 100.0) {
        return Err(format!("`{s}`: σ must be finite, > 0 and ≤ 100 cells"));
    }
    Ok(v)
}

/// A count of at least 2 and at most the export's sample bound (`--max-points`, volumetric
/// export's `--points`: a compensation table needs two points).
pub(crate) fn at_least_two(s: &str) -> Result<usize, String> {
    count_within(s, 2, errmap::export::MAX_SAMPLES)
}

/// A whole number within `lo ..= hi`, checked before anything is allocated for it (the
/// bounds table of `docs/robustness.md`).
fn count_within(s: &str, lo: usize, hi: usize) -> Result<usize, String> {
    let v: usize = parsed(s, "a whole number")?;
    if !(lo..=hi).contains(&v) {
        return Err(format!("`{s}` is outside {lo} … {hi}"));
    }
    Ok(v)
}

/// volumetric identify `--positions`: 2 … [`MAX_REPORT_POSITIONS`] per component (issue 28:
/// 10⁹ allocated 24 GB).
///
/// [`MAX_REPORT_POSITIONS`]: errmap::volumetric::MAX_REPORT_POSITIONS
pub(crate) fn report_positions(s: &str) -> Result<usize, String> {
    count_within(s, 2, errmap::volumetric::MAX_REPORT_POSITIONS)
}

/// bench `--points`: 1 … 10⁷ query points (240 MB of coordinates and results).
pub(crate) fn bench_points(s: &str) -> Result<usize, String> {
    count_within(s, 1, 10_000_000)
}

/// bench `--history-machines`, `--history-tests`: 1 … 10⁶.
pub(crate) fn bench_count(s: &str) -> Result<usize, String> {
    count_within(s, 1, 1_000_000)
}

/// fuzzy-sim `--trials`: 1 … 10⁵.
pub(crate) fn trials(s: &str) -> Result<usize, String> {
    count_within(s, 1, 100_000)
}

/// fit, compare and export `--max-degree`: the highest Lagrange degree tried, 0 …
/// [`errmap::interp::MAX_DEGREE`] (what the interpolator computes).
pub(crate) fn lagrange_max_degree(s: &str) -> Result<usize, String> {
    count_within(s, 0, errmap::interp::MAX_DEGREE)
}

/// artefact identify `--positions`: 5 … [`MAX_REPORT_POSITIONS`] per component (5 was
/// the floor the command raised a smaller value to without a word).
///
/// [`MAX_REPORT_POSITIONS`]: errmap::volumetric::MAX_REPORT_POSITIONS
pub(crate) fn artefact_positions(s: &str) -> Result<usize, String> {
    count_within(s, 5, errmap::volumetric::MAX_REPORT_POSITIONS)
}

/// A number inside one of the library's physical ranges (`errmap::base::limits`).
fn within(s: &str, bound: &errmap::base::Bound) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    bound.check(v).map_err(|e| format!("`{s}`: {e}"))?;
    Ok(v)
}

/// A temperature, °C, within the readers' range (artefact `--temp-c`).
pub(crate) fn temperature_c(s: &str) -> Result<f64, String> {
    within(s, &errmap::base::TEMPERATURE_C)
}

/// An MPE or tolerance given alone, µm, within 10⁻³ … 10⁴ (the probing test's
/// `--mpe-form`, `--mpe-size`, `--mpe-location`; the same range as a tolerance file's).
pub(crate) fn limit_um(s: &str) -> Result<f64, String> {
    within(s, &errmap::base::TOLERANCE_UM)
}

/// A simulated noise σ, µm: 0, or a standard uncertainty's range (artefact simulate
/// `--sigma-um`).
pub(crate) fn noise_um(s: &str) -> Result<f64, String> {
    let v: f64 = parsed(s, "a number")?;
    if v == 0.0 {
        return Ok(v);
    }
    within(s, &errmap::base::UNCERTAINTY_UM)
}

/// A record of a ledger, numbered from 1 (history add `--supersede`).
pub(crate) fn record_id(s: &str) -> Result<i64, String> {
    match parsed::<i64>(s, "a record number") {
        Ok(v) if v >= 1 => Ok(v),
        _ => Err(format!("`{s}` is not a record number (1, 2, …)")),
    }
}

/// Text a document states (a certificate's specification, the CMM's name): not only
/// blanks, at most 200 characters on one line.
pub(crate) fn text(s: &str) -> Result<String, String> {
    if s.trim().is_empty() || s.chars().count() > 200 || s.contains(['\n', '\r']) {
        return Err(format!(
            "`{s}`: some text on one line, at most 200 characters"
        ));
    }
    Ok(s.to_string())
}

/// r of a guard band w = r·U (`--guard-fraction`): finite and ≥ 0, checked when the flags
/// are parsed, before any file is read (a tolerance file's own r is checked by its reader).
pub(crate) fn guard_fraction(s: &str) -> Result<f64, String> {
    match parsed::<f64>(s, "a number") {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}`: r must be finite and ≥ 0")),
    }
}

/// Why a record is amended (history add `--reason`): some text, not only blanks.
pub(crate) fn reason(s: &str) -> Result<String, String> {
    if s.trim().is_empty() {
        return Err("an amendment gives its reason: the text is empty".to_string());
    }
    Ok(s.to_string())
}

/// A controller's axis number, from 1 (FANUC 3620–3627, Siemens `AX<n>`, ISG
/// kopf.log_achs_nr).
pub(crate) fn axis_number(s: &str) -> Result<u32, String> {
    match parsed::<u32>(s, "a whole number") {
        Ok(v) if v >= 1 => Ok(v),
        _ => Err(format!("`{s}` is not an axis number (1 … 4294967295)")),
    }
}

/// A name written into a controller's table (`--axis-name`, `--table-name`): 1–32
/// letters, digits, `_` or `.`, starting with a letter (`errmap::controller::is_table_name`).
pub(crate) fn controller_name(s: &str) -> Result<String, String> {
    if errmap::controller::is_table_name(s) {
        Ok(s.to_string())
    } else {
        Err(format!(
            "`{s}` is not a controller name (1–32 letters, digits, `_` or `.`, starting with a letter)"
        ))
    }
}

/// workbench `--addr`: HOST:PORT, the port a whole number 0 … 65535 and the host named
/// (`127.0.0.1:8765`, `localhost:0`, `[::1]:8765`); kept as written, resolved when bound.
pub(crate) fn host_port(s: &str) -> Result<String, String> {
    match s.trim().rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => {
            Ok(s.trim().to_string())
        }
        _ => Err(format!(
            "`{s}` is not HOST:PORT with a port 0 … 65535 (e.g. 127.0.0.1:8765)"
        )),
    }
}

/// A baud rate of a serial line: 50 … 10 000 000.
pub(crate) fn baud(s: &str) -> Result<u32, String> {
    let v: u32 = parsed(s, "a whole number")?;
    if !(50..=10_000_000).contains(&v) {
        return Err(format!("`{s}` is not a baud rate (50 … 10 000 000)"));
    }
    Ok(v)
}

/// `--beam-loss START:END`: a window of session seconds, 0 ≤ START < END ≤ 10⁹.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Window(pub f64, pub f64);

impl FromStr for Window {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (a, b) = s
            .split_once(':')
            .ok_or_else(|| format!("`{s}`: START:END in seconds, like 5:7.5"))?;
        let a = seconds(a)?;
        let b = seconds(b)?;
        if a >= b {
            return Err(format!("`{s}`: START must be before END"));
        }
        Ok(Window(a, b))
    }
}

/// `--order`: Lagrange degrees `MxNxQ`, or `auto` (chosen by cross-validation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum OrderArg {
    Auto,
    Degrees(Order),
}

impl FromStr for OrderArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "auto" => Ok(OrderArg::Auto),
            other => other
                .parse::<Order>()
                .map(OrderArg::Degrees)
                .map_err(|e| e.to_string()),
        }
    }
}

/// `--orders` of compare: `all` admissible orders, `auto` (the cross-validated one), or
/// a comma list like `4x1x2,2x1x2`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum OrdersArg {
    All,
    Auto,
    List(Vec<Order>),
}

impl FromStr for OrdersArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "all" => Ok(OrdersArg::All),
            "auto" => Ok(OrdersArg::Auto),
            list => list
                .split(',')
                .map(str::parse::<Order>)
                .collect::<Result<Vec<_>, _>>()
                .map(OrdersArg::List)
                .map_err(|e| e.to_string()),
        }
    }
}

impl fmt::Display for OrdersArg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OrdersArg::All => f.write_str("all"),
            OrdersArg::Auto => f.write_str("auto"),
            OrdersArg::List(l) => {
                let parts: Vec<String> = l.iter().map(Order::to_string).collect();
                f.write_str(&parts.join(","))
            }
        }
    }
}

/// `--at`: the fixed coordinates of a line, `y=1,z=200` (mm); empty for none.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct LineAt(pub Vec<(Axis, f64)>);

impl FromStr for LineAt {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut out = Vec::new();
        if s.trim().is_empty() {
            return Ok(LineAt(out));
        }
        for part in s.split(',').map(str::trim) {
            // `,,,` is no line position (issue 28), and `y=1,` a typing slip.
            if part.is_empty() {
                return Err(format!(
                    "`{s}`: an empty item between commas; axis=value pairs like y=1,z=200"
                ));
            }
            let (k, v) = part
                .split_once('=')
                .ok_or_else(|| format!("axis=value pairs like y=1,z=200, not `{part}`"))?;
            let axis: Axis = k.trim().parse().map_err(|e| format!("{e}"))?;
            let v: f64 = parsed(v.trim(), "a number")?;
            if !(v.is_finite() && v.abs() <= MAX_COORDINATE_MM) {
                return Err(format!(
                    "`{part}`: the coordinate must be finite, within ±10⁶ mm"
                ));
            }
            if out.iter().any(|&(a, _)| a == axis) {
                return Err(format!("`{s}`: {axis} is given twice"));
            }
            out.push((axis, v));
        }
        Ok(LineAt(out))
    }
}

/// `export`'s line in `errmap --help`: the controllers as a user knows them, from the
/// registry.
pub(crate) fn export_about() -> String {
    format!(
        "Export compensation tables ({}, CSV) or a volumetric grid; --existing updates a \
         table in use",
        controllers()
    )
}

/// Every registered controller as a user knows it: `LinuxCNC, Siemens 840D, …`.
fn controllers() -> String {
    let names: Vec<&str> = DIALECTS.iter().map(|d| d.controller()).collect();
    names.join(", ")
}

/// The help of `export`'s flag for `setting`: what it is, then each controller that reads
/// it in its own words (from the registry; controllers with the same words share them).
pub(crate) fn setting_help(setting: TableSetting) -> String {
    let lead = match setting {
        TableSetting::AxisName => {
            "The axis' name in the controller (default: the axis letter, upper case)"
        }
        TableSetting::AxisNumber => "The axis' number in the controller (default: x 1, y 2, z 3)",
        TableSetting::MaxPoints => "The control's table size",
        TableSetting::TableName => "The table's name in the controller",
        TableSetting::Units => {
            "--existing: the table's length unit, mm or inch, where the file does not state it"
        }
        TableSetting::CompType => {
            "The table's type: actual (0, the positions reached; the default) or trim (1, the \
             offsets). Required with --existing"
        }
    };
    format!("{lead}. {}.", readers_help(setting))
}

/// The controllers that read `setting`, each with its words for it, from the registry
/// (controllers with the same words share them): `HEIDENHAIN: the column; ISG/TwinCAT: …`.
pub(crate) fn readers_help(setting: TableSetting) -> String {
    let mut groups: Vec<(Vec<&str>, String)> = Vec::new();
    for (d, words) in errmap::controller::readers_of(setting) {
        match groups.iter_mut().find(|(_, w)| *w == words) {
            Some((names, _)) => names.push(d.controller()),
            None => groups.push((vec![d.controller()], words)),
        }
    }
    let readers: Vec<String> = groups
        .iter()
        .map(|(names, words)| format!("{}: {words}", names.join(", ")))
        .collect();
    readers.join("; ")
}

/// `import`'s line in `errmap --help`: the controllers from the registry.
pub(crate) fn import_about() -> String {
    format!(
        "Read a laser export (API XD .pos, Renishaw .rtl), a spreadsheet (--map) or a \
         controller table ({}) into errmap's tables",
        controllers()
    )
}

/// The help of `export --bidirectional`: the formats whose tables hold two directions.
pub(crate) fn bidirectional_help() -> String {
    format!(
        "Direction-dependent table from a session's per-direction means (ISO 230-2's x̄↑ and \
         x̄↓ at each target), no model: {}. With --step the means are interpolated linearly \
         onto the grid through --reference",
        errmap::controller::names_where(|d| d.limits().bidirectional, "or")
    )
}

/// The help of `export --ends`: which formats end on the range end without it, which need
/// a step that divides the range (their tables have one interval).
pub(crate) fn ends_help() -> String {
    let equidistant = |d: &dyn ControllerDialect| d.limits().spacing == Spacing::Equidistant;
    let listed: Vec<&str> = DIALECTS
        .iter()
        .filter(|d| !equidistant(**d))
        .map(|d| d.name())
        .chain(["csv"])
        .collect();
    format!(
        "A round grid of --step through --reference covering the range, the points beyond it \
         clamped (the value at the range end) or extrapolated. Without it, {} end on the range \
         end (the last interval shorter); {} need a step that divides the range",
        errmap::controller::join_list(&listed, "and"),
        errmap::controller::names_where(equidistant, "and"),
    )
}

/// `--format` of export: a controller dialect from the registry
/// (`errmap::controller::DIALECTS`), or errmap's own CSV line and volumetric grid.
#[derive(Clone, Copy)]
pub(crate) enum ExportFormatArg {
    Table(&'static dyn ControllerDialect),
    Csv,
    Grid,
}

impl fmt::Debug for ExportFormatArg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ExportFormatArg::Table(d) => d.name(),
            ExportFormatArg::Csv => "csv",
            ExportFormatArg::Grid => "grid",
        })
    }
}

/// A dialect of the registry as a possible value: its name, aliases and help line.
pub(crate) fn dialect_values() -> Vec<PossibleValue> {
    DIALECTS
        .iter()
        .map(|d| {
            PossibleValue::new(d.name())
                .help(d.about())
                .aliases(d.aliases().iter().copied())
        })
        .collect()
}

/// `--format` of export (see [`ExportFormatArg`]).
pub(crate) fn export_format() -> impl TypedValueParser<Value = ExportFormatArg> {
    let mut values = dialect_values();
    values.push(PossibleValue::new("csv").help("CSV of a line"));
    values.push(PossibleValue::new("grid").help("A volumetric grid table (CSV or Parquet)"));
    PossibleValuesParser::new(values).map(|s| match s.as_str() {
        "grid" => ExportFormatArg::Grid,
        name => {
            errmap::controller::dialect(name).map_or(ExportFormatArg::Csv, ExportFormatArg::Table)
        }
    })
}

/// `--format` of `volumetric export --axis-tables`: errmap's CSV line, or a dialect's
/// 1-D tables ([`errmap::controller::AxisTables`]).
#[derive(Debug, Clone, Copy)]
pub(crate) enum AxisTableFormat {
    Csv,
    Table(errmap::controller::AxisTables),
}

/// `--format` of `volumetric export` (see [`AxisTableFormat`]): csv and the dialects of
/// the registry that write axis tables.
pub(crate) fn axis_table_format() -> impl TypedValueParser<Value = AxisTableFormat> {
    let mut values =
        vec![PossibleValue::new("csv").help("`x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`")];
    values.extend(DIALECTS.iter().filter_map(|d| {
        d.axis_tables()
            .map(|t| PossibleValue::new(d.name()).help(t.about))
    }));
    PossibleValuesParser::new(values).map(|s| {
        match errmap::controller::dialect(&s).and_then(|d| d.axis_tables()) {
            Some(t) => AxisTableFormat::Table(t),
            None => AxisTableFormat::Csv,
        }
    })
}

/// The settings every dialect declares ([`errmap::controller::dialect_options`]), one
/// flag each, with the dialect's help, default and parser: clap gets them from the
/// registry, so a dialect's settings are spelled only in its file.
#[derive(Debug, Clone, Default)]
pub(crate) struct DialectOptionArgs(pub errmap::controller::DialectOptions);

impl clap::FromArgMatches for DialectOptionArgs {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut options = errmap::controller::DialectOptions::default();
        for o in errmap::controller::dialect_options() {
            if let Some(v) = m.get_one::<errmap::controller::OptionValue>(o.name) {
                options.set(o.name, v.clone());
            }
        }
        Ok(DialectOptionArgs(options))
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl clap::Args for DialectOptionArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        errmap::controller::dialect_options()
            .into_iter()
            .fold(cmd, |cmd, o| {
                let value_name: &'static str =
                    Box::leak(o.name.to_uppercase().replace('-', "_").into_boxed_str());
                let arg = clap::Arg::new(o.name)
                    .long(o.name)
                    .help(o.help)
                    .value_name(value_name)
                    .value_parser(move |s: &str| (o.parse)(s));
                cmd.arg(match o.default {
                    Some(d) => arg.default_value(d),
                    None => arg,
                })
            })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// `--comp-type` of the LinuxCNC format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CompTypeArg {
    /// COMP_FILE_TYPE 0: the positions actually reached.
    #[value(alias = "0")]
    Actual,
    /// COMP_FILE_TYPE 1: the offsets.
    #[value(alias = "1")]
    Trim,
}

impl From<CompTypeArg> for CompType {
    fn from(c: CompTypeArg) -> Self {
        match c {
            CompTypeArg::Actual => CompType::ActualPosition,
            CompTypeArg::Trim => CompType::Trim,
        }
    }
}

/// `--format` of capture: the session table's format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum SessionFormat {
    Csv,
    Parquet,
}

impl SessionFormat {
    /// The file extension.
    pub(crate) fn extension(self) -> &'static str {
        match self {
            SessionFormat::Csv => "csv",
            SessionFormat::Parquet => "parquet",
        }
    }
}

/// `--ends` of export: where a round grid's points beyond the range go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EndsArg {
    /// The value at the range end.
    Clamp,
    /// The model's extrapolation.
    Extrapolate,
}

impl From<EndsArg> for Ends {
    fn from(e: EndsArg) -> Self {
        match e {
            EndsArg::Clamp => Ends::Clamp,
            EndsArg::Extrapolate => Ends::Extrapolate,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 17's campaign: these flag values were taken as numbers (`nan`, `1e308`) or
    /// strings checked after clap, so a bad one exited 1, or ran on (`--start -1e308`
    /// overflowed the point count). Each parser now refuses them, a usage error.
    #[test]
    fn the_campaigns_bad_flag_values_are_refused_by_their_parsers() {
        for bad in ["nan", "inf", "-inf", "1e308", "-1e7", "abc", ""] {
            assert!(coordinate(bad).is_err(), "coordinate {bad:?}");
        }
        assert_eq!(coordinate(" -1e6 "), Ok(-1e6));
        assert_eq!(coordinate("-0"), Ok(0.0));
        assert!(non_negative_length("-1").is_err());
        assert_eq!(non_negative_length("0"), Ok(0.0));
        assert!(feed("0").is_err() && feed("nan").is_err());
        for bad in ["0.5", "-0.1", "nan", "inf"] {
            assert!(offset_fraction(bad).is_err(), "offset {bad:?}");
        }
        assert_eq!(offset_fraction("0.49"), Ok(0.49));
        for bad in ["1,2", "nan,0,0", "a,b,c", "1,2,3,4", "inf,0,0", "1e308,0,0"] {
            assert!(point3(bad).is_err(), "point {bad:?}");
        }
        assert_eq!(point3("1, -2.5,3"), Ok([1.0, -2.5, 3.0]));
        for bad in ["XXZ", "ABC", "", "XY", "XYZX"] {
            assert!(topology(bad).is_err(), "topology {bad:?}");
        }
        assert_eq!(topology("yxz"), Ok(Topology([1, 0, 2])));
        for bad in ["-1", "abc", "", "0", "1000"] {
            assert!(degree(bad).is_err(), "degree {bad:?}");
        }
        assert_eq!(degree("auto-each").as_deref(), Ok("auto-each"));
        assert!(max_degree(&(MAX_DEGREE + 1).to_string()).is_err());
        assert_eq!(max_degree("5"), Ok(5));
        for bad in [
            "E_QQ=2",
            "E_XX=",
            "E_XX=-1",
            "E_XX=abc",
            "==",
            "E_XX=1,E_XX=2",
        ] {
            assert!(component_degrees(bad).is_err(), "component degree {bad:?}");
        }
        let ok = component_degrees("E_XX=5, E_CX=2").expect("valid");
        assert_eq!(ok.len(), 2);
        assert_eq!(ok.values().copied().max(), Some(5));
    }

    #[test]
    fn a_line_position_gives_each_axis_once_within_the_bound() {
        for bad in [
            "y=1,y=2", "y=nan", "y=inf", "y=1e308", "q=1", "y", "=1", ",,,", "y=1,", ",z=2",
        ] {
            assert!(bad.parse::<LineAt>().is_err(), "--at {bad:?}");
        }
        let at: LineAt = "y=1, z=-200".parse().expect("valid");
        assert_eq!("".parse::<LineAt>().expect("none").0, vec![]);
        assert_eq!(at.0, vec![(Axis::Y, 1.0), (Axis::Z, -200.0)]);
    }
}
