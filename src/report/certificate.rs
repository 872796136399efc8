//! The calibration certificate as a PDF. Page 1 is the summary a reader signs off: the
//! certificate's fields (number, issue date, laboratory, customer, machine, the lines by
//! their coordinates, the date and times of the test), the results of every line with
//! their expanded uncertainties and verdicts, the statement of the coverage, the
//! traceability statement. Then the test parameters (cycle, runs, feed, dwell, overrun,
//! targets), the instruments and the laser set-up, the controller's compensation state,
//! the environment over the test, per line the ISO 230-2 statistics in the certificate
//! layout with the VDI/DGQ 3441 values and the deviation chart, the uncertainty budget with
//! the source of every contribution, the statement of conformity, the signatures.
//!
//! The page layout ([`Sheet`]) is shared with other certificates. Rendering is
//! self-contained (`pdf.rs`): DejaVu Sans is embedded, the chart is drawn as vector
//! graphics. Deviations and uncertainties are printed to one number of decimals over the
//! whole certificate ([`certificate_decimals`]).

mod chart;
mod cmm;
mod conformity;
mod info;
mod layout;
mod pdf;
pub mod rotary;

pub use self::cmm::{Sources as CmmSources, render as render_cmm, write as write_cmm};
pub use self::info::{CertificateInfo, Controller, InfoError, Instrument, Laser, Sensors};
pub use self::layout::{Align, Decimals, Sheet, fixed, zone_words};
pub use self::pdf::PdfError;

use std::path::Path;

use errmap_drivers::SessionRow;

use self::layout::{BODY, second_digit_place};
use self::pdf::Weight;
use super::iso230::{decimals, target_values};
use super::uncertainty::{STANDARDS_NOTE, budget_rows, conditions_text, not_evaluated_text};
use crate::acceptance::Conformity;
use crate::session::{AxisStats, TargetStats};
use crate::session::{Budget, Origin};

/// Smallest type a table is set in.
pub use self::layout::MIN_SIZE;

/// ISO 230-2's minimum number of runs per direction (its standard test cycle: 5).
pub const ISO_MIN_RUNS: usize = 5;

/// One measured line of the axis.
#[derive(Debug, Clone, Copy)]
pub struct LineResult<'a> {
    /// The two fixed coordinates of the line, mm.
    pub line_mm: (f64, f64),
    /// Its ISO 230-2 statistics.
    pub stats: &'a AxisStats,
    /// Its uncertainty budget.
    pub budget: &'a Budget,
}

/// Everything a certificate shows.
#[derive(Debug, Clone)]
pub struct CertificateData<'a> {
    /// The session it was computed from (a path; only its file name is printed).
    pub source: &'a str,
    /// The axis measured (`X`, `Y`, `Z`).
    pub axis: &'a str,
    /// The session's rows (for the environment and the test parameters).
    pub rows: &'a [SessionRow],
    /// The lines measured.
    pub lines: Vec<LineResult<'a>>,
    /// The certificate's fields.
    pub info: &'a CertificateInfo,
}

impl CertificateData<'_> {
    /// The lines measured, by name, `; `-separated.
    pub(super) fn line_names(&self) -> String {
        self.lines
            .iter()
            .map(|x| line_name(self.axis, x.line_mm))
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// Why a certificate could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CertificateError {
    /// The PDF could not be assembled.
    #[error(transparent)]
    Pdf(#[from] PdfError),
    /// The file could not be written (the report writers' error: `FILE: cannot write:
    /// REASON`, or the output refused, e.g. a missing directory).
    #[error(transparent)]
    Write(#[from] super::ReportError),
    /// Nothing to certify.
    #[error("{0}: no line has ISO 230-2 statistics")]
    NoLines(String),
}

fn blank(v: &Option<String>) -> String {
    v.clone().unwrap_or_default()
}

fn instrument(i: &Instrument) -> [String; 3] {
    [blank(&i.model), blank(&i.serial), blank(&i.calibrated)]
}

/// A position in mm to 0.1 µm, trailing zeros dropped (`-4.88`, not `-4.880000000000001`).
pub fn mm(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// The two fixed coordinates of a line along `axis`, named: `y = 1 mm, z = 200 mm`.
pub fn line_name(axis: &str, line_mm: (f64, f64)) -> String {
    let (a, b) = match axis.to_ascii_uppercase().as_str() {
        "Y" => ("x", "z"),
        "Z" => ("x", "y"),
        _ => ("y", "z"),
    };
    format!("{a} = {} mm, {b} = {} mm", mm(line_mm.0), mm(line_mm.1))
}

/// The decimals every deviation and uncertainty of the certificate is printed to, so one
/// quantity has one format throughout: the place of the second significant digit of the
/// smallest expanded uncertainty the certificate states (the GUM, JCGM 100:2008 7.2.6: an
/// uncertainty to at most two significant digits, the result rounded to the same place),
/// never finer than a tenth of the coarsest resolution step of the readings, and between
/// 1 and 4 decimals. A test read with a 0.079 µm laser count and a 0.1 µm scale whose
/// smallest U is 0.104 µm prints 0.01 µm, not the 1 pm its arithmetic carries.
pub fn certificate_decimals(lines: &[LineResult]) -> usize {
    let smallest_u = lines
        .iter()
        .map(|l| l.budget.expanded().at_one_target_um)
        .fold(f64::INFINITY, f64::min);
    let by_u = second_digit_place(smallest_u);
    // A tenth of the coarsest step: the place of its second significant digit.
    let by_resolution = second_digit_place(
        lines
            .iter()
            .map(|l| l.budget.resolution_floor_um)
            .fold(0.0, f64::max),
    );
    let d = match (by_u, by_resolution) {
        (Some(u), Some(r)) => u.min(r),
        (Some(u), None) => u,
        (None, Some(r)) => r,
        // No uncertainty and no resolution: the statistics' own digits.
        (None, None) => lines.iter().map(|l| decimals(l.stats)).max().unwrap_or(3) as i32,
    };
    d.clamp(1, 4) as usize
}

/// The per-target table's rows (certificate layout), µm to `d` places.
pub fn target_rows(stats: &AxisStats, d: usize) -> Vec<Vec<String>> {
    let f = |v: f64| fixed(v, d);
    stats
        .targets
        .iter()
        .map(|t: &TargetStats| {
            [t.target.to_string(), mm(t.position_mm)]
                .into_iter()
                .chain(target_values(t, &f))
                .collect()
        })
        .collect()
}

/// The header of [`target_rows`].
pub const TARGET_HEADER: [&str; 10] = [
    "target i", "P_i / mm", "x̄_i↑", "x̄_i↓", "B_i", "2s_i↑", "2s_i↓", "R_i↑", "R_i↓", "R_i",
];

/// An axis value as the certificate lists it: symbol, name, ↑, ↓, bidirectional, and
/// which expanded uncertainty applies (`true`: along the travel, `false`: at one target).
type AxisValue = (
    &'static str,
    &'static str,
    Option<f64>,
    Option<f64>,
    f64,
    bool,
);

/// ISO 230-2's axis values.
fn iso_values(s: &AxisStats) -> [AxisValue; 6] {
    let (l, t) = (true, false);
    [
        (
            "E",
            "systematic positional deviation",
            Some(s.e_up_um),
            Some(s.e_down_um),
            s.e_um,
            l,
        ),
        (
            "M",
            "mean bidirectional positional deviation",
            None,
            None,
            s.m_um,
            l,
        ),
        (
            "A",
            "accuracy of positioning",
            Some(s.a_up_um),
            Some(s.a_down_um),
            s.a_um,
            l,
        ),
        (
            "R",
            "repeatability of positioning",
            Some(s.r_up_um),
            Some(s.r_down_um),
            s.r_um,
            t,
        ),
        ("B", "reversal value", None, None, s.b_um, t),
        (
            "B̄",
            "mean reversal value",
            None,
            None,
            s.mean_reversal_um,
            t,
        ),
    ]
}

/// VDI/DGQ 3441's values.
fn vdi_values(s: &AxisStats) -> [AxisValue; 6] {
    let (l, t) = (true, false);
    let v = &s.vdi;
    [
        (
            "P",
            "VDI/DGQ 3441 position uncertainty",
            None,
            None,
            v.p_um,
            l,
        ),
        (
            "Pa",
            "VDI/DGQ 3441 position deviation",
            None,
            None,
            v.pa_um,
            l,
        ),
        (
            "Ps max",
            "VDI/DGQ 3441 position scatter",
            None,
            None,
            v.ps_max_um,
            t,
        ),
        (
            "Ps mean",
            "VDI/DGQ 3441 mean position scatter",
            None,
            None,
            v.ps_mean_um,
            t,
        ),
        (
            "U max",
            "VDI/DGQ 3441 reversal span",
            None,
            None,
            v.u_max_um,
            t,
        ),
        (
            "U mean",
            "VDI/DGQ 3441 mean reversal span",
            None,
            None,
            v.u_mean_um,
            t,
        ),
    ]
}

/// The axis table's rows: symbol, name, ↑, ↓, bidirectional, U (k), µm to `d` places.
pub fn axis_rows(stats: &AxisStats, budget: &Budget, d: usize) -> Vec<Vec<String>> {
    let f = |v: f64| fixed(v, d);
    let o = |v: Option<f64>| v.map_or_else(|| "—".to_string(), f);
    let u = budget.expanded();
    iso_values(stats)
        .into_iter()
        .chain(vdi_values(stats))
        .map(|(sym, name, up, down, bi, travel)| {
            vec![
                sym.to_string(),
                name.to_string(),
                o(up),
                o(down),
                f(bi),
                f(if travel {
                    u.along_travel_um
                } else {
                    u.at_one_target_um
                }),
            ]
        })
        .collect()
}

/// Renders the certificate.
pub fn render(data: &CertificateData) -> Result<Vec<u8>, CertificateError> {
    render_with(data, None)
}

/// The session's file name (never a path: a certificate points at nothing outside
/// itself).
fn session_name(source: &str) -> String {
    Path::new(source)
        .file_name()
        .map_or_else(|| source.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Renders the certificate with its statement of conformity when `conformity` is given;
/// without, the certificate has no verdicts.
pub fn render_with(
    data: &CertificateData,
    conformity: Option<&Conformity>,
) -> Result<Vec<u8>, CertificateError> {
    if data.lines.is_empty() {
        return Err(CertificateError::NoLines(data.source.to_string()));
    }
    let dec = Decimals::with_um(certificate_decimals(&data.lines));
    let mut sheet = Sheet::new(
        "Calibration certificate — positioning accuracy",
        "ISO 230-2:2014 (GB/T 17421.2-2016), VDI/DGQ 3441; uncertainty after ISO/TR 230-9 and the GUM",
    )?;
    certificate_fields(&mut sheet, data);
    summary(&mut sheet, data, conformity, dec);
    sheet.new_page();
    test_parameters(&mut sheet, data);
    instruments(&mut sheet, data);
    environment(&mut sheet, data, dec);
    for (k, line) in data.lines.iter().enumerate() {
        line_section(&mut sheet, data.axis, k, line, dec);
    }
    uncertainty_section(&mut sheet, data, dec);
    if let Some(c) = conformity {
        conformity::section(&mut sheet, data, c, dec);
    }
    sheet.signatures();
    let label = format!("Certificate {}", blank(&data.info.certificate_number));
    Ok(sheet.finish(label.trim_end())?)
}

/// The certificate's fields: who, what, when, and which session.
fn certificate_fields(sheet: &mut Sheet, data: &CertificateData) {
    let info = data.info;
    let f = |name: &str, v: String| (name.to_string(), v);
    let lines = data.line_names();
    let times = match (&info.start_time, &info.end_time) {
        (Some(a), Some(b)) => format!(", {a} to {b}"),
        (Some(a), None) => format!(", from {a}"),
        _ => String::new(),
    };
    sheet.fields(&[
        f("Certificate number", blank(&info.certificate_number)),
        f("Date of issue", blank(&info.date_of_issue)),
        f("Laboratory", blank(&info.lab)),
        f("Customer", blank(&info.customer)),
        f("Machine", blank(&info.machine)),
        f("Axis measured", data.axis.to_string()),
        f("Line(s)", lines),
        f(
            "Date of test",
            format!("{}{times}", blank(&info.date_of_test)),
        ),
        f("Operator", blank(&info.operator)),
        f("Session", session_name(data.source)),
    ]);
}

/// Fewest runs per direction over a line's targets.
fn runs(stats: &AxisStats) -> usize {
    stats
        .targets
        .iter()
        .map(|t| t.n_up.min(t.n_down))
        .min()
        .unwrap_or(0)
}

/// Page 1's results: per line E, M, A, R, B, B̄ with U and the verdict, and the
/// statements a reader needs with them.
fn summary(sheet: &mut Sheet, data: &CertificateData, c: Option<&Conformity>, dec: Decimals) {
    sheet.heading("Results", 12.0);
    let f = |v: f64| fixed(v, dec.um);
    let rows: Vec<Vec<String>> = data
        .lines
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let s = l.stats;
            let u = l.budget.expanded();
            let verdict = c.and_then(|c| c.lines.get(k)).map(|(_, lc)| {
                lc.as_ref()
                    .map_or("not judged".to_string(), |x| x.verdict.to_string())
            });
            let mut row = vec![
                line_name(data.axis, l.line_mm),
                runs(s).to_string(),
                f(s.e_um),
                f(s.m_um),
                f(s.a_um),
                f(u.along_travel_um),
                f(s.r_um),
                f(s.b_um),
                f(s.mean_reversal_um),
                f(u.at_one_target_um),
            ];
            row.extend(verdict);
            row
        })
        .collect();
    let mut header = vec![
        "line",
        "runs",
        "E",
        "M",
        "A",
        "U(E, M, A)",
        "R",
        "B",
        "B̄",
        "U(R, B, B̄)",
    ];
    let r = Align::Right;
    let mut align = vec![Align::Left, r, r, r, r, r, r, r, r, r];
    if c.is_some() {
        header.push("verdict");
        align.push(Align::Left);
    }
    sheet.table_sized(&header, &rows, &align, BODY - 0.5);
    sheet.paragraph(
        &format!(
            "Values in µm (ISO 230-2 symbols; bidirectional values). U is the expanded \
             uncertainty of the value beside it: the combined standard uncertainty multiplied \
             by the coverage factor k = {}, which for a normal distribution corresponds to a \
             coverage probability of approximately 95 %. It was evaluated after the GUM (JCGM \
             100:2008) and ISO/TR 230-9, as ISO 230-2 Annex A asks, and is never stated below \
             one step of the coarsest resolution of the readings.",
            data.lines[0].budget.k
        ),
        BODY - 0.5,
    );
    if let Some(c) = c {
        sheet.paragraph_weighted(
            &format!(
                "Statement of conformity with {}: {}.",
                c.specification, c.verdict
            ),
            BODY,
            Weight::Bold,
        );
    }
    let short: Vec<String> = data
        .lines
        .iter()
        .filter(|l| runs(l.stats) < ISO_MIN_RUNS)
        .map(|l| {
            format!(
                "{} ({} runs)",
                line_name(data.axis, l.line_mm),
                runs(l.stats)
            )
        })
        .collect();
    if !short.is_empty() {
        sheet.paragraph_weighted(
            &format!(
                "Fewer runs than ISO 230-2's minimum of {ISO_MIN_RUNS} per direction: {}. \
                 The statistics are computed as the standard defines them, but the test is \
                 below its standard cycle; its repeatability figures rest on few readings.",
                short.join("; ")
            ),
            BODY - 0.5,
            Weight::Bold,
        );
    }
    sheet.heading("Traceability", 10.0);
    sheet.paragraph(&traceability(data.info), BODY - 0.5);
}

/// The laboratory's statement, or one built from the instruments' calibrations.
fn traceability(info: &CertificateInfo) -> String {
    if let Some(t) = &info.traceability {
        return t.clone();
    }
    let s = &info.sensors;
    let cal: Vec<String> = [
        ("laser interferometer", &info.laser.calibrated),
        ("air temperature sensor", &s.air_temperature.calibrated),
        ("air pressure sensor", &s.air_pressure.calibrated),
        ("humidity sensor", &s.humidity.calibrated),
        (
            "material temperature sensor",
            &s.material_temperature.calibrated,
        ),
    ]
    .iter()
    .filter_map(|(n, d)| d.as_ref().map(|d| format!("{n} calibrated {d}")))
    .collect();
    if cal.is_empty() {
        "No traceability is declared: the info file names no calibrated instrument (its \
         `traceability` key or the instruments' `calibrated` dates)."
            .to_string()
    } else {
        format!(
            "The results are traceable to the SI metre and kelvin through the calibrations \
             of the instruments used ({}), as declared by the laboratory; the certificates \
             of those calibrations are held by the laboratory.",
            cal.join("; ")
        )
    }
}

/// What the session's rows say about how the test was run.
struct Parameters {
    runs: u32,
    feeds: Vec<f64>,
    dwell_s: Option<f64>,
    overrun_mm: Option<f64>,
    duration_s: f64,
}

fn parameters(rows: &[SessionRow], lines: &[LineResult]) -> Parameters {
    let runs = rows.iter().map(|r| r.run).max().unwrap_or(0);
    let mut feeds: Vec<f64> = rows
        .iter()
        .filter(|r| r.run > 0)
        .filter_map(|r| r.feed_mm_s)
        .collect();
    feeds.sort_by(f64::total_cmp);
    feeds.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    // Dwell: the time from the first to the last row of a stop, median over the stops.
    // A stop: consecutive rows at one target of one run and direction.
    let mut dwell: Vec<f64> = Vec::new();
    let mut stop: Option<((u32, i8, i32), f64, f64)> = None;
    for r in rows {
        let key = (r.run, r.direction, r.target);
        match &mut stop {
            Some((k, _, end)) if *k == key => *end = r.t_s,
            _ => {
                if let Some((_, a, b)) = stop.take() {
                    dwell.push(b - a);
                }
                if r.target >= 0 && r.run > 0 {
                    stop = Some((key, r.t_s, r.t_s));
                }
            }
        }
    }
    if let Some((_, a, b)) = stop {
        dwell.push(b - a);
    }
    dwell.sort_by(f64::total_cmp);
    let dwell_s = dwell
        .get(dwell.len() / 2)
        .copied()
        .filter(|_| !dwell.is_empty());
    let (lo, hi) = lines
        .iter()
        .flat_map(|l| l.stats.targets.iter().map(|t| t.position_mm))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p), b.max(p))
        });
    let moving = rows.iter().filter(|r| r.run > 0).map(|r| r.scale_mm);
    let (smin, smax) = moving.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p), b.max(p))
    });
    let overrun_mm =
        (smin.is_finite() && lo.is_finite()).then(|| (lo - smin).max(smax - hi).max(0.0));
    let t = rows.iter().map(|r| r.t_s);
    let duration_s = t.clone().fold(f64::NEG_INFINITY, f64::max) - t.fold(f64::INFINITY, f64::min);
    Parameters {
        runs,
        feeds,
        dwell_s,
        overrun_mm,
        duration_s: if duration_s.is_finite() {
            duration_s
        } else {
            0.0
        },
    }
}

/// The test's parameters, from the session's rows.
fn test_parameters(sheet: &mut Sheet, data: &CertificateData) {
    sheet.heading("Test parameters", 11.0);
    let p = parameters(data.rows, &data.lines);
    let targets = data.lines[0]
        .stats
        .targets
        .iter()
        .map(|t| mm(t.position_mm))
        .collect::<Vec<_>>()
        .join(", ");
    let bidirectional = data.lines[0]
        .stats
        .targets
        .iter()
        .all(|t| t.n_up > 0 && t.n_down > 0);
    let f = |a: &str, b: String| (a.to_string(), b);
    let info = data.info;
    sheet.fields(&[
        f(
            "Test cycle",
            format!(
                "{} (ISO 230-2 linear cycle: each run approaches every target in turn)",
                if bidirectional {
                    "bidirectional, each run out ↑ and back ↓"
                } else {
                    "unidirectional"
                }
            ),
        ),
        f("Runs", p.runs.to_string()),
        f(
            "Feed",
            if p.feeds.is_empty() {
                "not recorded".into()
            } else {
                p.feeds
                    .iter()
                    .map(|v| format!("{} mm/s", mm(*v)))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
        ),
        f(
            "Dwell at a target",
            p.dwell_s.map_or("not recorded".into(), |d| {
                format!("{d:.1} s (median over the stops)")
            }),
        ),
        f(
            "Overrun beyond the end targets",
            p.overrun_mm
                .map_or("not recorded".into(), |o| format!("{} mm", mm(o))),
        ),
        f("Targets P_i / mm", targets),
        f(
            "Start and end",
            match (&info.start_time, &info.end_time) {
                (Some(a), Some(b)) => format!(
                    "{} {a} to {b} (session: {:.1} min)",
                    blank(&info.date_of_test),
                    p.duration_s / 60.0
                ),
                _ => format!(
                    "{} (session: {:.1} min; clock times not declared)",
                    blank(&info.date_of_test),
                    p.duration_s / 60.0
                ),
            },
        ),
    ]);
}

/// The instruments, the laser set-up, the resolutions and the controller's state.
fn instruments(sheet: &mut Sheet, data: &CertificateData) {
    let info = data.info;
    let l = Align::Left;
    sheet.heading("Instruments and set-up", 11.0);
    let s = &info.sensors;
    let laser = info.laser.instrument();
    let rows: Vec<Vec<String>> = [
        ("laser interferometer", &laser),
        ("air temperature sensor", &s.air_temperature),
        ("air pressure sensor", &s.air_pressure),
        ("humidity sensor", &s.humidity),
        ("material temperature sensor", &s.material_temperature),
    ]
    .iter()
    .map(|(name, i)| {
        let [m, sn, c] = instrument(i);
        vec![name.to_string(), m, sn, c]
    })
    .collect();
    sheet.table(
        &["instrument", "model", "serial", "calibrated"],
        &rows,
        &[l, l, l, l],
    );
    let b = data.lines[0].budget;
    let u = &info.uncertainty;
    let resolutions = b
        .contributions
        .iter()
        .filter(|c| c.id == "resolution")
        .map(|c| format!("{} {} µm ({})", c.name, fixed(c.input, 4), c.source))
        .collect::<Vec<_>>()
        .join("; ");
    let f = |a: &str, b: String| (a.to_string(), b);
    sheet.fields(&[
        f(
            "Laser set-up",
            info.laser
                .setup
                .clone()
                .unwrap_or_else(|| "not declared".into()),
        ),
        f(
            "Dead path, misalignment",
            format!(
                "{} mm, {} µrad (bound)",
                mm(u.dead_path_mm),
                mm(u.misalignment_urad)
            ),
        ),
        f("Resolution", resolutions),
        f(
            "Expansion coefficient used",
            format!(
                "{} ppm/K, u(α) = {} ppm/K (deviations not normalised to 20 °C)",
                mm(u.expansion_ppm_per_k),
                mm(u.expansion_u_ppm_per_k)
            ),
        ),
        f(
            "Controller compensation",
            info.controller
                .compensation
                .clone()
                .unwrap_or_else(|| "not declared".into()),
        ),
        f(
            "As found / as left",
            info.controller
                .state
                .clone()
                .unwrap_or_else(|| "not declared".into()),
        ),
    ]);
}

/// Four significant digits.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".to_string();
    }
    let d = (3.0 - v.abs().log10().floor()).clamp(0.0, 12.0) as usize;
    format!("{v:.d$}")
}

/// The air and material temperatures over the test, where they come from, and the sign
/// convention.
fn environment(sheet: &mut Sheet, data: &CertificateData, dec: Decimals) {
    let l = Align::Left;
    let r = Align::Right;
    sheet.heading("Environment over the test", 11.0);
    type Col = (&'static str, fn(&SessionRow) -> Option<f64>, usize);
    let cols: [Col; 5] = [
        ("air temperature / °C", |r| r.air_temp_c, dec.temp),
        ("air pressure / hPa", |r| r.air_pressure_hpa, dec.hpa),
        ("relative humidity / %", |r| r.air_rh_pct, dec.rh),
        ("scale temperature / °C", |r| r.scale_temp_c, dec.temp),
        ("part/table temperature / °C", |r| r.part_temp_c, dec.temp),
    ];
    let rows: Vec<Vec<String>> = cols
        .iter()
        .map(|(name, f, d)| {
            let v: Vec<f64> = data
                .rows
                .iter()
                .filter_map(f)
                .filter(|x| x.is_finite())
                .collect();
            if v.is_empty() {
                return vec![
                    name.to_string(),
                    "no sensor".into(),
                    String::new(),
                    String::new(),
                ];
            }
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            vec![
                name.to_string(),
                fixed(lo, *d),
                fixed(mean, *d),
                fixed(hi, *d),
            ]
        })
        .collect();
    sheet.table(&["quantity", "min", "mean", "max"], &rows, &[l, r, r, r]);
    let b = data.lines[0].budget;
    let declared = &b.conditions.declared;
    let mut text = format!(
        "Conditions used by the uncertainty budget: {}.",
        conditions_text(b)
    );
    if b.conditions.air == Origin::Declared || b.conditions.material == Origin::Declared {
        let span = |s: Option<[f64; 2]>, unit: &str| s.map(|[a, z]| format!("{a}…{z} {unit}"));
        let parts: Vec<String> = [
            span(declared.air_temp_c, "°C air"),
            span(declared.air_pressure_hpa, "hPa"),
            span(declared.air_rh_pct, "%RH"),
            span(declared.material_temp_c, "°C material"),
        ]
        .into_iter()
        .flatten()
        .collect();
        text.push_str(&format!(
            " Declared in the info file{}: {}.",
            declared
                .source
                .as_deref()
                .map_or_else(String::new, |s| format!(" ({s})")),
            parts.join(", ")
        ));
    }
    text.push_str(
        " Deviations are as measured (not normalised to 20 °C). Positional deviation \
         x = P_ij − P_i (actual − target), µm; ↑ positive approach, ↓ negative approach; \
         s with n − 1.",
    );
    sheet.paragraph(&text, BODY - 1.0);
}

/// One line: its targets, axis values and chart.
fn line_section(sheet: &mut Sheet, axis: &str, k: usize, line: &LineResult, dec: Decimals) {
    let l = Align::Left;
    let r = Align::Right;
    let stats = line.stats;
    sheet.heading(
        &format!(
            "Line {}: {} (axis {axis})",
            k + 1,
            line_name(axis, line.line_mm)
        ),
        12.0,
    );
    let n_up = stats.targets.iter().map(|t| t.n_up).min().unwrap_or(0);
    let n_down = stats.targets.iter().map(|t| t.n_down).min().unwrap_or(0);
    let mut note = format!(
        "{} targets, at least {n_up} runs ↑ and {n_down} runs ↓ per target; values in µm.",
        stats.targets.len()
    );
    if n_up.min(n_down) < ISO_MIN_RUNS {
        note.push_str(&format!(
            " Below ISO 230-2's minimum of {ISO_MIN_RUNS} runs per direction."
        ));
    }
    let zero_s = stats
        .targets
        .iter()
        .filter(|t| t.s_up_um == 0.0 || t.s_down_um == 0.0)
        .count();
    if zero_s > 0 {
        note.push_str(&format!(
            " At {zero_s} target(s) the runs gave identical readings in one direction, so \
             2s = 0 there: the scatter is below the readings' resolution, which the expanded \
             uncertainty U accounts for."
        ));
    }
    sheet.paragraph(&note, BODY - 0.5);
    sheet.table(
        &TARGET_HEADER,
        &target_rows(stats, dec.um),
        &[r, r, r, r, r, r, r, r, r, r],
    );
    let u = line.budget.expanded();
    let u_head = format!("U (k = {})", u.k);
    sheet.table(
        &["symbol", "axis value", "↑", "↓", "bidirectional", &u_head],
        &axis_rows(stats, line.budget, dec.um),
        &[l, l, r, r, r, r],
    );
    chart::chart(sheet, stats, axis);
}

/// The budgets: one table per distinct budget (lines measured under the same conditions
/// share one), each contribution's source, what was not evaluated, and U.
fn uncertainty_section(sheet: &mut Sheet, data: &CertificateData, dec: Decimals) {
    let l = Align::Left;
    let r = Align::Right;
    let d = dec.um;
    sheet.heading("Measurement uncertainty (ISO/TR 230-9, GUM)", 12.0);
    sheet.paragraph(
        "Each influence is an input quantity with a standard uncertainty u(x_i), a \
         sensitivity coefficient c_i and the contribution u_i = |c_i|·u(x_i); length terms \
         (ppm of the distance compared) and reading terms (µm) are each combined in \
         quadrature, U = k·√((u_rel·L)² + 2·u_read²), never below one resolution step.",
        BODY - 1.0,
    );
    let mut groups: Vec<(Vec<usize>, &Budget)> = Vec::new();
    for (k, line) in data.lines.iter().enumerate() {
        let same = |b: &Budget| {
            b.contributions
                .iter()
                .zip(&line.budget.contributions)
                .all(|(a, z)| a.id == z.id && a.u == z.u && a.source == z.source)
                && b.contributions.len() == line.budget.contributions.len()
        };
        match groups.iter_mut().find(|(_, b)| same(b)) {
            Some(g) => g.0.push(k),
            None => groups.push((vec![k], line.budget)),
        }
    }
    for (members, budget) in groups {
        let names = members
            .iter()
            .map(|&k| format!("line {}", k + 1))
            .collect::<Vec<_>>()
            .join(", ");
        sheet.heading(&format!("Budget of {names}"), 10.0);
        let rows: Vec<Vec<String>> = budget_rows(budget, d)
            .into_iter()
            .map(|b| vec![b.name, b.input, b.sensitivity, b.u])
            .collect();
        sheet.table(&["influence", "u(x_i)", "c_i", "u_i"], &rows, &[l, r, r, r]);
        let sources: Vec<String> = budget
            .contributions
            .iter()
            .map(|c| format!("{}: {}", c.name, c.source))
            .collect();
        sheet.paragraph(&format!("Sources. {}.", sources.join("; ")), BODY - 1.5);
        let missing = not_evaluated_text(budget);
        if !missing.is_empty() {
            sheet.paragraph(&missing, BODY - 1.5);
        }
        for &k in &members {
            let line = &data.lines[k];
            let u = line.budget.expanded();
            sheet.paragraph(
                &format!(
                    "Line {}: u_rel = {} ppm, u_read = {} µm; U = {} µm over the {} mm travel \
                     (E, M, A, P, Pa), {} µm at one target (R, B, B̄, Ps, U); k = {}; \
                     resolution floor {} µm.",
                    k + 1,
                    sig(line.budget.u_rel_ppm),
                    fixed(line.budget.u_read_um, d),
                    fixed(u.along_travel_um, d),
                    mm(u.travel_mm),
                    fixed(u.at_one_target_um, d),
                    u.k,
                    sig(u.resolution_floor_um)
                ),
                BODY - 1.0,
            );
        }
    }
    sheet.paragraph(STANDARDS_NOTE, BODY - 2.0);
}

/// Writes the certificate to `path`.
pub fn write(path: &Path, data: &CertificateData) -> Result<(), CertificateError> {
    write_with(path, data, None)
}

/// Writes the certificate to `path`, with its statement of conformity when given.
pub fn write_with(
    path: &Path,
    data: &CertificateData,
    conformity: Option<&Conformity>,
) -> Result<(), CertificateError> {
    let bytes = render_with(data, conformity)?;
    // Whole or not at all: a temporary file beside `path`, renamed into place.
    Ok(super::write_bytes(path, &bytes)?)
}
