//! The history report on disk (`errmap history report --report DIR`): `report.md` (the
//! fleet ranking, then per machine its advice and parameters), `fleet.png`/`.svg` (the
//! ranking by risk) and `<ID>.png`/`.svg` per machine (its riskiest series with the EWMA
//! chart, alarms, trend and tolerance). Machines arrive one at a time
//! ([`ReportWriter::machine`]); their sections wait in a scratch file, so the writer
//! holds no more than one machine.

use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use crate::base::FileOp;
use crate::base::io_err;
use crate::history::parse_utc;
use crate::history::{Advice, FleetEntry, Head, MachineReport, ParameterReport};
use crate::plot::{self, XySeries, XyStyle};

use super::ReportError;
use super::md::Md;

/// At most this many machines in the fleet figure (the riskiest).
pub(crate) const FLEET_FIGURE_MAX: usize = 40;

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}"))
        .unwrap_or_else(|| "—".into())
}

/// A file name for a machine id (ids are `[A-Za-z0-9._-]`; a leading dot is replaced).
fn stem(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.starts_with('.') {
        format!("_{s}")
    } else {
        s
    }
}

/// Writes the report directory machine by machine.
#[derive(Debug)]
pub struct ReportWriter {
    dir: PathBuf,
    scratch_path: PathBuf,
    scratch: BufWriter<std::fs::File>,
    figures: bool,
    machines: usize,
}

impl ReportWriter {
    /// Starts a report in `dir` (created if absent), with a figure per machine.
    pub fn new(dir: &Path) -> Result<ReportWriter, ReportError> {
        ReportWriter::with_figures(dir, true)
    }

    /// Like [`ReportWriter::new`]; `figures` false leaves out every figure (the
    /// benchmark measures the figures apart).
    pub fn with_figures(dir: &Path, figures: bool) -> Result<ReportWriter, ReportError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
        let scratch_path = dir.join(".machines.md.partial");
        let f =
            std::fs::File::create(&scratch_path).map_err(io_err(&scratch_path, FileOp::Write))?;
        Ok(ReportWriter {
            dir: dir.to_path_buf(),
            scratch_path,
            scratch: BufWriter::new(f),
            figures,
            machines: 0,
        })
    }

    /// One machine's section and figure.
    pub fn machine(&mut self, m: &MachineReport) -> Result<(), ReportError> {
        let text = machine_section(m);
        super::finite::check_markdown(&self.dir.join("report.md"), &text)?;
        self.scratch
            .write_all(text.as_bytes())
            .map_err(io_err(&self.scratch_path, FileOp::Write))?;
        if self.figures {
            machine_figure(&self.dir.join(stem(&m.id)), m)?;
        }
        self.machines += 1;
        Ok(())
    }

    /// Writes `report.md` (head, fleet, the machines' sections) and the fleet figure;
    /// returns a one-line summary.
    pub fn finish(mut self, head: &Head, fleet: &[FleetEntry]) -> Result<String, ReportError> {
        self.scratch
            .flush()
            .map_err(io_err(&self.scratch_path, FileOp::Write))?;
        drop(self.scratch);
        let mut md = head_section(head, fleet);
        let mut rest = String::new();
        std::fs::File::open(&self.scratch_path)
            .and_then(|mut f| f.read_to_string(&mut rest))
            .map_err(io_err(&self.scratch_path, FileOp::Write))?;
        md += &rest;
        let path = self.dir.join("report.md");
        super::write_text(&path, &md)?;
        let _ = std::fs::remove_file(&self.scratch_path);
        // A ranking by risk with every risk 0 ranks nothing: no chart.
        if self.figures && fleet.iter().any(|f| f.risk > 0.0) {
            fleet_figure(&self.dir.join("fleet"), fleet)?;
        }
        let count = |a: &str| fleet.iter().filter(|f| f.advice.as_str() == a).count();
        Ok(format!(
            "{} out of tolerance, {} to recalibrate, {} to investigate, {} ok",
            count("out_of_tolerance"),
            count("recalibrate"),
            count("investigate"),
            count("ok")
        ))
    }
}

/// The report's head: the date and ledger, the control chart's method, the fleet ranked.
fn head_section(head: &Head, fleet: &[FleetEntry]) -> String {
    let mut md = Md::new();
    md.heading(1, "Calibration history")
        .para(format_args!(
            "As of {}, horizon {} days. Ledger: {} records, {} current, {} superseded.",
            head.as_of,
            head.horizon_days,
            head.ledger.records,
            head.ledger.current,
            head.ledger.superseded
        ))
        .para(format_args!(
            "Control chart: {} ({}), λ = {}, limits ±{}σ√v_k around the mean of the first {} points of \
             each segment; σ from moving ranges pooled over the machine's axes. Risk: the probability \
             that the trend line is above the tolerance at the horizon.",
            head.chart.method,
            head.chart.standard,
            head.chart.lambda,
            head.chart.l,
            head.chart.baseline
        ))
        .heading(2, "Fleet")
        .table(["rank", "machine", "risk", "advice"]);
    for (i, f) in fleet.iter().enumerate() {
        md.row([
            (i + 1).to_string(),
            f.id.to_string(),
            format!("{:.3}", f.risk),
            f.advice.as_str().to_string(),
        ]);
    }
    md.nl();
    md.finish()
}

/// A machine's section of `report.md`.
pub(crate) fn machine_section(m: &MachineReport) -> String {
    let mut md = Md::new();
    md.heading(2, format_args!("{} — {}", m.id, m.advice.as_str()))
        .para(format_args!(
            "Site: {}. Current records: {}. Recalibrate by: {}.",
            m.site.as_deref().unwrap_or("—"),
            m.records,
            m.recalibrate_by.as_deref().unwrap_or("—")
        ));
    series_table(&mut md, m);
    pairs_table(&mut md, m);
    md.nl();
    md.finish()
}

/// One row per series: its last value, trend, chart and risk.
fn series_table(md: &mut Md, m: &MachineReport) {
    md.table([
        "axis",
        "parameter",
        "n",
        "last",
        "tolerance",
        "rate /year ± σ",
        "EWMA centre",
        "σ",
        "alarms",
        "exceeds tolerance",
        "95 % interval",
        "risk",
    ]);
    for a in &m.axes {
        for p in &a.parameters {
            let rate = match (p.rate_per_year, p.rate_sigma) {
                (Some(r), Some(u)) => format!("{r:.3} ± {u:.3}"),
                _ => "—".into(),
            };
            let iv = match &p.exceeds_interval {
                Some([lo, hi]) => format!(
                    "{} … {}",
                    lo.as_deref().unwrap_or("—"),
                    hi.as_deref().unwrap_or("—")
                ),
                None => "—".into(),
            };
            md.row([
                a.axis.to_string(),
                format!("{} ({})", p.name, display_unit(&p.unit)),
                p.n.to_string(),
                format!("{:.3}", p.last),
                opt(p.tolerance, 3),
                rate,
                opt(p.center, 3),
                opt(p.sigma, 3),
                p.alarms.len().to_string(),
                p.exceeds_tolerance_at.as_deref().unwrap_or("—").to_string(),
                iv,
                opt(p.risk, 3),
            ]);
        }
    }
}

/// The as-found / as-left pairs of an adjustment, when the machine had one.
fn pairs_table(md: &mut Md, m: &MachineReport) {
    let pairs: Vec<[String; 6]> = m
        .axes
        .iter()
        .flat_map(|a| {
            a.parameters.iter().flat_map(move |p| {
                p.pairs.iter().map(move |q| {
                    [
                        a.axis.to_string(),
                        p.name.to_string(),
                        q.as_found_at.as_deref().unwrap_or("—").to_string(),
                        opt(q.as_found, 3),
                        q.as_left_at.to_string(),
                        format!("{:.3}", q.as_left),
                    ]
                })
            })
        })
        .collect();
    if pairs.is_empty() {
        return;
    }
    md.nl().para("As-found / as-left:").table([
        "axis",
        "parameter",
        "as found at",
        "as found",
        "as left at",
        "as left",
    ]);
    for p in pairs {
        md.row(p);
    }
}

/// The machine's riskiest series (the first in axis and parameter order on ties).
fn riskiest(m: &MachineReport) -> Option<(&str, &ParameterReport)> {
    let mut best: Option<(&str, &ParameterReport)> = None;
    for a in &m.axes {
        for p in &a.parameters {
            let r = p.risk.unwrap_or(-1.0);
            if best.is_none_or(|(_, b)| r > b.risk.unwrap_or(-1.0)) {
                best = Some((&a.axis, p));
            }
        }
    }
    best
}

/// `<stem>.png`/`.svg`: the riskiest series, its EWMA and limits, alarms, trend and
/// tolerance, against years since its first point.
pub(crate) fn machine_figure(stem: &Path, m: &MachineReport) -> Result<Vec<PathBuf>, ReportError> {
    let Some((axis, p)) = riskiest(m) else {
        return Ok(Vec::new());
    };
    if p.series.len() < 2 {
        // One visit: no trend, no chart to read; a lone point on an invented time axis
        // says nothing the report's table does not.
        return Ok(Vec::new());
    }
    let t: Vec<i64> = p
        .series
        .iter()
        .map(|s| parse_utc(&s.at).unwrap_or(0))
        .collect();
    let origin = t.first().copied().unwrap_or(0);
    let x: Vec<f64> = t.iter().map(|&v| (v - origin) as f64 / YEAR_S).collect();
    let mut series = chart_series(axis, p, &x);
    series.extend(alarm_series(p, &x));
    let x_end = x.last().copied().unwrap_or(0.0);
    series.extend(trend_and_tolerance(p, origin, x_end));
    let first = p.series.first().map(|s| &s.at[..10]).unwrap_or("");
    Ok(plot::xy(
        stem,
        &format!(
            "{} — {axis} {} ({}): {}",
            m.id,
            p.name,
            display_unit(&p.unit),
            advice_words(m.advice)
        ),
        &format!("years since {first}"),
        &format!("{} / {}", p.name, display_unit(&p.unit)),
        &series,
    )?)
}

/// Seconds in a (Julian) year: the figures' time axis is in years.
const YEAR_S: f64 = 365.25 * 86_400.0;

/// A line in palette colour `colour`, dashed or solid, without markers.
fn styled(name: String, x: Vec<f64>, y: Vec<f64>, colour: usize, dashed: bool) -> XySeries {
    XySeries {
        name,
        x,
        y,
        style: XyStyle::Styled {
            colour,
            dashed,
            markers: false,
        },
    }
}

/// The series itself with markers, its EWMA, and the EWMA's control limits (the lower
/// one unnamed, so the legend lists the limits once).
fn chart_series(axis: &str, p: &ParameterReport, x: &[f64]) -> Vec<XySeries> {
    let col = |f: fn(&crate::history::SeriesPoint) -> Option<f64>| -> Vec<f64> {
        p.series.iter().map(|s| f(s).unwrap_or(f64::NAN)).collect()
    };
    vec![
        XySeries {
            name: format!("{axis} {}", p.name),
            x: x.to_vec(),
            y: p.series.iter().map(|s| s.value).collect(),
            style: XyStyle::Styled {
                colour: 0,
                dashed: false,
                markers: true,
            },
        },
        styled("EWMA".into(), x.to_vec(), col(|s| s.ewma), 1, false),
        styled("EWMA limits".into(), x.to_vec(), col(|s| s.ucl), 2, true),
        styled("".into(), x.to_vec(), col(|s| s.lcl), 2, true),
    ]
}

/// The points that raised an alarm, when any did.
fn alarm_series(p: &ParameterReport, x: &[f64]) -> Option<XySeries> {
    let alarm_x: Vec<f64> = p
        .alarms
        .iter()
        .filter_map(|a| {
            p.series
                .iter()
                .position(|s| s.record == a.record)
                .map(|i| x[i])
        })
        .collect();
    let alarm_y: Vec<f64> = p
        .alarms
        .iter()
        .filter_map(|a| {
            p.series
                .iter()
                .find(|s| s.record == a.record)
                .map(|s| s.value)
        })
        .collect();
    (!alarm_x.is_empty()).then(|| XySeries {
        name: "alarm".into(),
        x: alarm_x,
        y: alarm_y,
        style: XyStyle::Points,
    })
}

/// The trend line from the start of its fit to the last point, and the tolerance, each
/// when there is one.
fn trend_and_tolerance(p: &ParameterReport, origin: i64, x_end: f64) -> Vec<XySeries> {
    let mut series = Vec::new();
    if let Some((o, tr)) = &p.fit {
        let shift = (*o - origin) as f64 / YEAR_S;
        let x0 = shift;
        let line = |xx: f64| tr.y_mean + tr.slope * (xx - shift - tr.t_mean);
        series.push(styled(
            format!("trend {:+.3} {}/year", tr.slope, display_unit(&p.unit)),
            vec![x0, x_end],
            vec![line(x0), line(x_end)],
            3,
            false,
        ));
    }
    if let Some(tol) = p.tolerance {
        series.push(styled(
            "tolerance".into(),
            vec![0.0, x_end.max(1e-3)],
            vec![tol, tol],
            4,
            true,
        ));
    }
    series
}

/// A unit as a reader expects it: the ledger and the JSON documents store micrometres
/// and microradians as ASCII `um` and `urad`.
pub(super) fn display_unit(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        other => other,
    }
}

/// What a chart or a label says of a machine's advice, in words (the JSON keeps
/// [`Advice::as_str`]'s identifiers).
fn advice_words(a: Advice) -> &'static str {
    match a {
        Advice::OutOfTolerance => "out of tolerance",
        Advice::Recalibrate => "recalibrate",
        Advice::Investigate => "investigate",
        Advice::Ok => "in order",
    }
}

/// `<stem>.png`/`.svg`: the riskiest machines' risk.
pub(crate) fn fleet_figure(stem: &Path, fleet: &[FleetEntry]) -> Result<Vec<PathBuf>, ReportError> {
    let top = &fleet[..fleet.len().min(FLEET_FIGURE_MAX)];
    let labels: Vec<String> = top
        .iter()
        .map(|f| format!("{} ({})", f.id, advice_words(f.advice)))
        .collect();
    let values: Vec<f64> = top.iter().map(|f| f.risk).collect();
    Ok(plot::bars(
        stem,
        &format!(
            "Fleet: risk of exceeding a tolerance by the horizon (top {} of {})",
            top.len(),
            fleet.len()
        ),
        "risk",
        &labels,
        &values,
        None,
        false,
    )?)
}
