//! The calibration certificate as a PDF: the fields a certificate carries (from an info
//! TOML, blank when absent), the machine, axis and lines, the instruments and the
//! environment over the test, and per line the ISO 230-2 statistics in the certificate
//! layout with the expanded uncertainty beside each axis value, the VDI/DGQ 3441 values,
//! the deviation chart in the standard's style, and the uncertainty budget.
//!
//! Rendering is self-contained ([`pdf`]): DejaVu Sans is embedded, the chart is drawn as
//! vector graphics, no system font and no external program is used. Tables size their
//! columns from the measured width of their text, and a table too wide for the page is set
//! in a smaller type until it fits ([`MIN_SIZE`] at the least), so no text leaves its cell.
//! Numbers use the print precision of [`super::iso230::decimals`].

pub mod cmm;
pub mod conformity;
pub mod info;
pub mod pdf;

use std::path::Path;

use errmap_drivers::SessionRow;

use self::info::{CertificateInfo, Instrument};
use self::pdf::{Doc, PAGE_H, PAGE_W, PdfError, Rgb, Weight};
use super::iso230::decimals;
use super::uncertainty::{STANDARDS_NOTE, budget_rows};
use crate::acceptance::tolerance::Conformity;
use crate::session::uncertainty::Budget;
use crate::session::{AxisStats, TargetStats};

const MARGIN: f32 = 48.0;
const BODY: f32 = 9.0;
/// Smallest type a table is set in.
pub const MIN_SIZE: f32 = 5.5;
const UP: Rgb = (0.12, 0.47, 0.71);
const DOWN: Rgb = (0.84, 0.15, 0.16);
const GREY: Rgb = (0.6, 0.6, 0.6);
const INK: Rgb = (0.1, 0.1, 0.1);

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
    /// The session it was computed from (a path, as given).
    pub source: &'a str,
    /// The axis measured (`X`, `Y`, `Z`).
    pub axis: &'a str,
    /// The session's rows (for the environment over the test).
    pub rows: &'a [SessionRow],
    /// The lines measured.
    pub lines: Vec<LineResult<'a>>,
    /// The certificate's fields.
    pub info: &'a CertificateInfo,
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

/// Column alignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Align {
    Left,
    Right,
}

/// A vertical cursor over the pages.
struct Flow {
    doc: Doc,
    y: f32,
}

impl Flow {
    fn need(&mut self, h: f32) {
        if self.y - h < MARGIN + 20.0 {
            self.doc.new_page();
            self.y = PAGE_H - MARGIN;
        }
    }

    fn heading(&mut self, s: &str, size: f32) {
        self.need(size * 2.0 + 40.0);
        self.y -= size * 1.6;
        self.doc.text(MARGIN, self.y, size, Weight::Bold, s);
        self.y -= size * 0.6;
    }

    /// A paragraph wrapped to the content width.
    fn paragraph(&mut self, s: &str, size: f32) {
        let width = PAGE_W - 2.0 * MARGIN;
        let mut line = String::new();
        let mut lines = Vec::new();
        for word in s.split_whitespace() {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if self.doc.width(&candidate, size, Weight::Regular) > width && !line.is_empty() {
                lines.push(std::mem::replace(&mut line, word.to_string()));
            } else {
                line = candidate;
            }
        }
        if !line.is_empty() {
            lines.push(line);
        }
        for l in lines {
            self.need(size * 1.4);
            self.y -= size * 1.4;
            self.doc.text(MARGIN, self.y, size, Weight::Regular, &l);
        }
        self.y -= size * 0.5;
    }

    /// A table: a bold header row, then rows; columns as wide as their widest cell. A
    /// table wider than the page is set smaller until it fits.
    fn table(&mut self, header: &[&str], rows: &[Vec<String>], align: &[Align], size: f32) {
        let pad = 4.0;
        let avail = PAGE_W - 2.0 * MARGIN;
        let mut size = size;
        let widths = loop {
            let w: Vec<f32> = (0..header.len())
                .map(|k| {
                    let head = self.doc.width(header[k], size, Weight::Bold);
                    rows.iter()
                        .map(|r| self.doc.width(&r[k], size, Weight::Regular))
                        .fold(head, f32::max)
                        + 2.0 * pad
                })
                .collect();
            if w.iter().sum::<f32>() <= avail || size <= MIN_SIZE {
                break w;
            }
            size = (size - 0.5).max(MIN_SIZE);
        };
        let row_h = size * 1.6;
        let draw_row = |flow: &mut Flow, cells: &[String], weight: Weight| {
            flow.need(row_h);
            flow.y -= row_h;
            let mut x = MARGIN;
            for (k, c) in cells.iter().enumerate() {
                let base = flow.y + size * 0.45;
                match align.get(k).copied().unwrap_or(Align::Left) {
                    Align::Left => flow.doc.text(x + pad, base, size, weight, c),
                    Align::Right => flow
                        .doc
                        .text_right(x + widths[k] - pad, base, size, weight, c),
                }
                x += widths[k];
            }
            let total: f32 = widths.iter().sum();
            flow.doc.polyline(
                &[(MARGIN, flow.y), (MARGIN + total, flow.y)],
                0.3,
                GREY,
                None,
            );
        };
        let head: Vec<String> = header.iter().map(|s| s.to_string()).collect();
        // Keep a table on one page when it fits on one.
        let whole = row_h * (rows.len() as f32 + 1.0) + size;
        let page = PAGE_H - 2.0 * MARGIN - 20.0;
        self.need(if whole < page { whole } else { row_h * 3.0 });
        draw_row(self, &head, Weight::Bold);
        for r in rows {
            draw_row(self, r, Weight::Regular);
        }
        self.y -= size;
    }
}

fn blank(v: &Option<String>) -> String {
    v.clone().unwrap_or_default()
}

fn instrument(i: &Instrument) -> [String; 3] {
    [blank(&i.model), blank(&i.serial), blank(&i.calibrated)]
}

/// Min, mean and max of a session column, formatted, or blanks.
fn column_stats(rows: &[SessionRow], f: impl Fn(&SessionRow) -> Option<f64>) -> [String; 3] {
    let v: Vec<f64> = rows
        .iter()
        .filter_map(&f)
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return ["—".into(), "—".into(), "—".into()];
    }
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    [format!("{lo:.2}"), format!("{mean:.2}"), format!("{hi:.2}")]
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

/// The per-target table's rows (certificate layout).
pub fn target_rows(stats: &AxisStats) -> Vec<Vec<String>> {
    let d = decimals(stats);
    let f = |v: f64| format!("{v:.d$}");
    stats
        .targets
        .iter()
        .map(|t: &TargetStats| {
            vec![
                t.target.to_string(),
                mm(t.position_mm),
                f(t.mean_up_um),
                f(t.mean_down_um),
                f(t.reversal_um),
                f(2.0 * t.s_up_um),
                f(2.0 * t.s_down_um),
                f(t.repeat_up_um),
                f(t.repeat_down_um),
                f(t.repeat_bidir_um),
            ]
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

/// The axis table's rows: symbol, name, ↑, ↓, bidirectional, U (k).
pub fn axis_rows(stats: &AxisStats, budget: &Budget) -> Vec<Vec<String>> {
    let d = decimals(stats);
    let f = |v: f64| format!("{v:.d$}");
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

/// Renders the certificate with its statement of conformity when `conformity` is given
/// (after the statistics, before the signatures); without, exactly as [`render`].
pub fn render_with(
    data: &CertificateData,
    conformity: Option<&Conformity>,
) -> Result<Vec<u8>, CertificateError> {
    if data.lines.is_empty() {
        return Err(CertificateError::NoLines(data.source.to_string()));
    }
    let mut flow = Flow {
        doc: Doc::new("Calibration certificate: positioning accuracy (ISO 230-2)")?,
        y: PAGE_H - MARGIN,
    };
    title(&mut flow);
    certificate_fields(&mut flow, data);
    instruments(&mut flow, data.info);
    environment(&mut flow, data);
    for (k, line) in data.lines.iter().enumerate() {
        line_pages(&mut flow, data.axis, k, line);
    }
    if let Some(c) = conformity {
        conformity::section(&mut flow, data, c);
    }
    signatures(&mut flow);
    footers(&mut flow, data.info);
    Ok(flow.doc.finish()?)
}

/// The title and the standards the certificate follows.
fn title(flow: &mut Flow) {
    flow.y -= 16.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        16.0,
        Weight::Bold,
        "Calibration certificate — positioning accuracy",
    );
    flow.y -= 14.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        BODY,
        Weight::Regular,
        "ISO 230-2:2014 (GB/T 17421.2-2016), VDI/DGQ 3441; uncertainty after ISO/TR 230-9 and the GUM",
    );
}

/// The certificate's fields: who, what, when, and which session.
fn certificate_fields(flow: &mut Flow, data: &CertificateData) {
    let info = data.info;
    let l = Align::Left;
    flow.heading("Certificate", 11.0);
    let field = |name: &str, v: &Option<String>| vec![name.to_string(), blank(v)];
    let lines_text = data
        .lines
        .iter()
        .map(|x| format!("({}, {}) mm", mm(x.line_mm.0), mm(x.line_mm.1)))
        .collect::<Vec<_>>()
        .join("; ");
    let fields = vec![
        field("Certificate number", &info.certificate_number),
        field("Laboratory", &info.lab),
        field("Operator", &info.operator),
        field("Customer", &info.customer),
        field("Machine", &info.machine),
        vec!["Axis".into(), data.axis.to_string()],
        vec!["Line(s) (fixed coordinates)".into(), lines_text],
        field("Date of test", &info.date_of_test),
        vec!["Session".into(), data.source.to_string()],
    ];
    flow.table(&["field", "value"], &fields, &[l, l], BODY);
}

/// The instruments and their calibrations.
fn instruments(flow: &mut Flow, info: &CertificateInfo) {
    let l = Align::Left;
    flow.heading("Instruments", 11.0);
    let s = &info.sensors;
    let instruments: Vec<Vec<String>> = [
        ("laser interferometer", &info.laser),
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
    flow.table(
        &["instrument", "model", "serial", "calibrated"],
        &instruments,
        &[l, l, l, l],
        BODY,
    );
}

/// The air and material temperatures over the test, and the sign convention.
fn environment(flow: &mut Flow, data: &CertificateData) {
    let l = Align::Left;
    let r = Align::Right;
    flow.heading("Environment over the test", 11.0);
    type Col = (&'static str, fn(&SessionRow) -> Option<f64>);
    let cols: [Col; 5] = [
        ("air temperature / °C", |r| r.air_temp_c),
        ("air pressure / hPa", |r| r.air_pressure_hpa),
        ("relative humidity / %", |r| r.air_rh_pct),
        ("scale temperature / °C", |r| r.scale_temp_c),
        ("part/table temperature / °C", |r| r.part_temp_c),
    ];
    let env: Vec<Vec<String>> = cols
        .iter()
        .map(|(name, f)| {
            let [lo, m, hi] = column_stats(data.rows, f);
            vec![name.to_string(), lo, m, hi]
        })
        .collect();
    flow.table(
        &["quantity", "min", "mean", "max"],
        &env,
        &[l, r, r, r],
        BODY,
    );
    flow.paragraph(
        "Deviations are as measured (not normalised to 20 °C); the material temperature above \
         is the one they hold at. Positional deviation x = P_ij − P_i (actual − target), µm; \
         ↑ positive approach, ↓ negative approach; s with n − 1.",
        BODY - 1.0,
    );
}

/// One line's pages: its targets, axis values, chart and uncertainty budget.
fn line_pages(flow: &mut Flow, axis: &str, k: usize, line: &LineResult) {
    let l = Align::Left;
    let r = Align::Right;
    flow.doc.new_page();
    flow.y = PAGE_H - MARGIN;
    let stats = line.stats;
    flow.heading(
        &format!(
            "Line {} at ({}, {}) mm — axis {}",
            k + 1,
            mm(line.line_mm.0),
            mm(line.line_mm.1),
            axis
        ),
        12.0,
    );
    let n_up = stats.targets.iter().map(|t| t.n_up).min().unwrap_or(0);
    let n_down = stats.targets.iter().map(|t| t.n_down).min().unwrap_or(0);
    flow.paragraph(
        &format!(
            "{} targets, at least {n_up} runs ↑ and {n_down} runs ↓ per target; values in µm.",
            stats.targets.len()
        ),
        BODY,
    );
    flow.table(
        &TARGET_HEADER,
        &target_rows(stats),
        &[r, r, r, r, r, r, r, r, r, r],
        BODY - 1.0,
    );
    let u = line.budget.expanded();
    let u_head = format!("U (k = {})", u.k);
    flow.table(
        &["symbol", "axis value", "↑", "↓", "bidirectional", &u_head],
        &axis_rows(stats, line.budget),
        &[l, l, r, r, r, r],
        BODY - 1.0,
    );
    flow.paragraph(STANDARDS_NOTE, BODY - 2.0);
    chart(flow, stats, axis);
    flow.heading("Measurement uncertainty", 11.0);
    let d = decimals(stats);
    let budget: Vec<Vec<String>> = budget_rows(line.budget, d)
        .into_iter()
        .map(|b| vec![b.name, b.input, b.sensitivity, b.u, b.u_travel_um])
        .collect();
    flow.table(
        &["influence", "u(x_i)", "c_i", "u_i", "over travel / µm"],
        &budget,
        &[l, r, r, r, r],
        BODY - 1.0,
    );
    flow.paragraph(
        &format!(
            "u_rel = {:.4} ppm (length terms), u_read = {:.d$} µm (reading terms). \
             U = k·√((u_rel·L)² + 2·u_read²): {:.d$} µm over the {} mm travel (E, M, A, P, \
             Pa), {:.d$} µm at one target (R, B, Ps, U). k = {}.",
            line.budget.u_rel_ppm,
            line.budget.u_read_um,
            u.along_travel_um,
            mm(u.travel_mm),
            u.at_one_target_um,
            u.k
        ),
        BODY - 1.0,
    );
}

/// The signature lines, on the last page.
fn signatures(flow: &mut Flow) {
    flow.need(90.0);
    flow.heading("Signatures", 11.0);
    flow.y -= 36.0;
    for (x, label) in [
        (MARGIN, "Calibrated by"),
        (PAGE_W / 2.0 + 10.0, "Approved by"),
    ] {
        flow.doc
            .polyline(&[(x, flow.y), (x + 200.0, flow.y)], 0.5, INK, None);
        flow.doc
            .text(x, flow.y - 11.0, BODY - 1.0, Weight::Regular, label);
    }
}

/// `Certificate N · page i of n` at the foot of every page.
fn footers(flow: &mut Flow, info: &CertificateInfo) {
    let pages = flow.doc.page_count();
    let number = blank(&info.certificate_number);
    for p in 0..pages {
        let footer = format!("Certificate {number} · page {} of {pages} · errmap", p + 1);
        flow.doc.text_on(
            p,
            MARGIN,
            MARGIN / 2.0,
            BODY - 2.0,
            Weight::Regular,
            &footer,
        );
    }
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

/// 1-2-5 tick spacing giving about `n` ticks over `[lo, hi]`.
fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// The deviation chart: ↑ blue, ↓ red; means solid with a dot at each target, ±2s dashed.
fn chart(flow: &mut Flow, stats: &AxisStats, axis: &str) {
    let h = 210.0;
    flow.need(h + 70.0);
    flow.y -= 12.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        10.0,
        Weight::Bold,
        &format!("Positional deviation along {axis} (ISO 230-2)"),
    );
    let mut t: Vec<&TargetStats> = stats.targets.iter().collect();
    t.sort_by(|a, b| a.position_mm.total_cmp(&b.position_mm));
    let b = ChartBox::new(&t, flow.y - 10.0, h);
    chart_grid(&mut flow.doc, &b, &t);
    chart_series(&mut flow.doc, &b, &t);
    flow.y = chart_legend(&mut flow.doc, &b);
}

/// The chart's area on the page (points) and the data range it shows.
struct ChartBox {
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    xlo: f64,
    xhi: f64,
    ylo: f64,
    yhi: f64,
}

impl ChartBox {
    /// A box `h` high with its top at `top`, over the targets' positions and their
    /// x̄ ± 2s bands, padded.
    fn new(t: &[&TargetStats], top: f32, h: f32) -> Self {
        let (x0, x1) = (MARGIN + 42.0, PAGE_W - MARGIN - 8.0);
        let (y1, y0) = (top, top - h);
        let bands = |s: &TargetStats| {
            [
                s.mean_up_um + 2.0 * s.s_up_um,
                s.mean_up_um - 2.0 * s.s_up_um,
                s.mean_down_um + 2.0 * s.s_down_um,
                s.mean_down_um - 2.0 * s.s_down_um,
            ]
        };
        let ys: Vec<f64> = t.iter().flat_map(|s| bands(s)).collect();
        let (mut ylo, mut yhi) = (
            ys.iter().copied().fold(f64::INFINITY, f64::min),
            ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let pad = ((yhi - ylo) * 0.08).max(1e-6);
        ylo -= pad;
        yhi += pad;
        let (plo, phi) = (
            t.first().map_or(0.0, |s| s.position_mm),
            t.last().map_or(1.0, |s| s.position_mm),
        );
        let xpad = ((phi - plo) * 0.04).max(1e-6);
        Self {
            x0,
            x1,
            y0,
            y1,
            xlo: plo - xpad,
            xhi: phi + xpad,
            ylo,
            yhi,
        }
    }

    fn px(&self, x: f64) -> f32 {
        self.x0 + ((x - self.xlo) / (self.xhi - self.xlo)) as f32 * (self.x1 - self.x0)
    }

    fn py(&self, y: f64) -> f32 {
        self.y0 + ((y - self.ylo) / (self.yhi - self.ylo)) as f32 * (self.y1 - self.y0)
    }
}

/// The frame, the grid with its labels, a tick at each target along both edges, and
/// the zero line.
fn chart_grid(doc: &mut Doc, b: &ChartBox, t: &[&TargetStats]) {
    let (x0, x1, y0, y1) = (b.x0, b.x1, b.y0, b.y1);
    doc.rect(x0, y0, x1 - x0, y1 - y0, 0.6, INK);
    let yt = ticks(b.ylo, b.yhi, 6);
    let step = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
    let yd = (-step.log10().floor()).max(0.0) as usize;
    for v in &yt {
        let y = b.py(*v);
        doc.polyline(&[(x0, y), (x1, y)], 0.2, (0.85, 0.85, 0.85), None);
        doc.text_right(
            x0 - 3.0,
            y - 2.5,
            7.0,
            Weight::Regular,
            &format!("{v:.yd$}"),
        );
    }
    let xt = ticks(b.xlo, b.xhi, 8);
    let xs = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
    let xd = (-xs.log10().floor()).max(0.0) as usize;
    for v in &xt {
        doc.text_centre(
            b.px(*v),
            y0 - 10.0,
            7.0,
            Weight::Regular,
            &format!("{v:.xd$}"),
        );
    }
    // Targets marked: a tick at each target position along both edges.
    for s in t {
        let x = b.px(s.position_mm);
        doc.polyline(&[(x, y0), (x, y0 + 5.0)], 0.8, INK, None);
        doc.polyline(&[(x, y1), (x, y1 - 5.0)], 0.8, INK, None);
    }
    if b.ylo < 0.0 && b.yhi > 0.0 {
        doc.polyline(&[(x0, b.py(0.0)), (x1, b.py(0.0))], 0.5, GREY, None);
    }
}

/// Per direction: the mean deviations solid with a dot at each target, x̄ ± 2s dashed.
fn chart_series(doc: &mut Doc, b: &ChartBox, t: &[&TargetStats]) {
    let series = |f: &dyn Fn(&TargetStats) -> f64| -> Vec<(f32, f32)> {
        t.iter()
            .map(|s| (b.px(s.position_mm), b.py(f(s))))
            .collect()
    };
    let dash = Some([3.5, 2.5]);
    for (colour, mean, hi, lo) in [
        (
            UP,
            series(&|s| s.mean_up_um),
            series(&|s| s.mean_up_um + 2.0 * s.s_up_um),
            series(&|s| s.mean_up_um - 2.0 * s.s_up_um),
        ),
        (
            DOWN,
            series(&|s| s.mean_down_um),
            series(&|s| s.mean_down_um + 2.0 * s.s_down_um),
            series(&|s| s.mean_down_um - 2.0 * s.s_down_um),
        ),
    ] {
        doc.polyline(&mean, 1.2, colour, None);
        doc.polyline(&hi, 0.8, colour, dash);
        doc.polyline(&lo, 0.8, colour, dash);
        for &(x, y) in &mean {
            doc.dot(x, y, 1.8, colour);
        }
    }
}

/// The axis titles and the legend below the chart; returns where the text continues.
fn chart_legend(doc: &mut Doc, b: &ChartBox) -> f32 {
    let (x0, x1, y0, y1) = (b.x0, b.x1, b.y0, b.y1);
    doc.text_centre(
        (x0 + x1) / 2.0,
        y0 - 21.0,
        7.5,
        Weight::Regular,
        "target position P_i / mm",
    );
    doc.text(MARGIN, y1 + 3.0, 7.5, Weight::Regular, "x / µm");
    let ly = y0 - 34.0;
    let mut lx = x0;
    for (colour, label, dashed) in [
        (UP, "mean x̄↑", false),
        (UP, "x̄↑ ± 2s↑", true),
        (DOWN, "mean x̄↓", false),
        (DOWN, "x̄↓ ± 2s↓", true),
    ] {
        doc.polyline(
            &[(lx, ly + 2.5), (lx + 22.0, ly + 2.5)],
            if dashed { 0.8 } else { 1.2 },
            colour,
            dashed.then_some([3.5, 2.5]),
        );
        doc.text(lx + 26.0, ly, 7.5, Weight::Regular, label);
        lx += 26.0 + doc.width(label, 7.5, Weight::Regular) + 18.0;
    }
    ly - 10.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        assert_eq!(ticks(0.0, 10.0, 5), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        // 0.065 / 6 = 0.0108: the next 1-2-5 step up is 0.02.
        let t = ticks(-0.013, 0.052, 6);
        assert!(t.iter().all(|v| (-0.013..=0.052).contains(v)), "{t:?}");
        assert_eq!(t, vec![0.0, 0.02, 0.04]);
    }
}
