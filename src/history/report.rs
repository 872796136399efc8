//! The history report: per machine, axis and parameter the series of current records,
//! its segments (a series splits before every `as-left` point), the EWMA chart of each
//! segment, the trend of the current segment and, against a tolerance, when the trend
//! reaches it and the risk that it has by the horizon; per machine its advice; over the
//! fleet a ranking by risk. The maths is in [`super::stats`] and `docs/history.md`.
//!
//! [`Run`] reads and reports one machine at a time: memory is bounded by the largest
//! machine's history and the fleet's one-line summaries.

use std::collections::BTreeMap;

use serde::Serialize;

use super::ingest::{FUNCTIONS, PARAMETERS, SQUARENESS};
use super::ledger::{Ledger, RawPoint};
use super::stats::{self, Trend};
use super::time::{self, DAY_S};
use super::tolerance::Tolerances;
use super::{HistoryError, MachineId};

/// Default horizon of the risk, days.
pub const DEFAULT_HORIZON_DAYS: f64 = 365.0;
/// An as-found point pairs with an as-left point at most this long before it.
pub const PAIR_WINDOW_S: i64 = 30 * DAY_S;

const YEAR_S: f64 = stats::DAYS_PER_YEAR * DAY_S as f64;

/// What to report.
#[derive(Debug, Clone, Default)]
pub struct ReportConfig {
    /// Only this machine in the output.
    pub machine: Option<MachineId>,
    pub tolerances: Tolerances,
    /// Default: the latest `at` of the current records.
    pub as_of: Option<i64>,
    pub horizon_days: f64,
}

/// The ledger's size.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct LedgerCounts {
    pub records: i64,
    pub current: i64,
    pub superseded: i64,
}

/// The chart's constants.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChartSpec {
    pub method: &'static str,
    pub standard: &'static str,
    pub lambda: f64,
    #[serde(rename = "L")]
    pub l: f64,
    pub baseline: usize,
}

/// Everything of the report before its machines.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Head {
    pub as_of: String,
    pub horizon_days: f64,
    pub ledger: LedgerCounts,
    pub chart: ChartSpec,
}

/// One point of a series.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SeriesPoint {
    pub at: String,
    pub record: i64,
    pub state: String,
    pub value: f64,
    pub ewma: Option<f64>,
    pub lcl: Option<f64>,
    pub ucl: Option<f64>,
}

/// An alarm of the chart.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Alarm {
    pub at: String,
    pub record: i64,
    pub rule: &'static str,
}

/// An as-left point and the as-found point before it.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Pair {
    pub as_found_at: Option<String>,
    pub as_found: Option<f64>,
    pub as_left_at: String,
    pub as_left: f64,
}

/// One parameter of one axis.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParameterReport {
    pub name: String,
    pub unit: String,
    pub n: usize,
    pub last: f64,
    pub tolerance: Option<f64>,
    pub series: Vec<SeriesPoint>,
    pub trend_from: Option<String>,
    pub trend_n: Option<usize>,
    pub rate_per_year: Option<f64>,
    pub rate_sigma: Option<f64>,
    pub center: Option<f64>,
    pub sigma: Option<f64>,
    pub alarms: Vec<Alarm>,
    pub pairs: Vec<Pair>,
    pub exceeds_tolerance_at: Option<String>,
    pub exceeds_interval: Option<[Option<String>; 2]>,
    pub risk: Option<f64>,
    /// The trend's fit and its time origin (seconds), for figures.
    #[serde(skip)]
    pub fit: Option<(i64, Trend)>,
}

/// One axis of a machine.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct AxisReport {
    pub axis: String,
    pub parameters: Vec<ParameterReport>,
}

/// A machine's advice, the first that applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Advice {
    /// Some parameter's last value is above its tolerance.
    OutOfTolerance,
    /// A forecast interval starts before the horizon.
    Recalibrate,
    /// A chart alarms at a series' last point.
    Investigate,
    Ok,
}

impl Advice {
    pub fn as_str(self) -> &'static str {
        match self {
            Advice::OutOfTolerance => "out_of_tolerance",
            Advice::Recalibrate => "recalibrate",
            Advice::Investigate => "investigate",
            Advice::Ok => "ok",
        }
    }
}

/// One machine.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MachineReport {
    pub id: String,
    pub site: Option<String>,
    pub records: i64,
    pub advice: Advice,
    pub recalibrate_by: Option<String>,
    pub axes: Vec<AxisReport>,
    /// The largest parameter risk (0 if none), as in the fleet ranking.
    #[serde(skip)]
    pub risk: f64,
}

/// One line of the fleet ranking.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FleetEntry {
    pub id: String,
    pub risk: f64,
    pub advice: Advice,
}

/// The whole report, for callers that hold it in memory (tests, small ledgers).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Report {
    #[serde(flatten)]
    pub head: Head,
    pub machines: Vec<MachineReport>,
    pub fleet: Vec<FleetEntry>,
}

/// A report in progress: the head is known, machines come one at a time.
#[derive(Debug)]
pub struct Run<'a> {
    ledger: &'a mut Ledger,
    config: ReportConfig,
    machines: Vec<String>,
    next: usize,
    head: Head,
    as_of_s: i64,
    fleet: Vec<FleetEntry>,
}

impl<'a> Run<'a> {
    /// Counts the ledger, fixes `as_of` and lists the machines to report.
    pub fn new(ledger: &'a mut Ledger, config: ReportConfig) -> Result<Run<'a>, HistoryError> {
        let (records, superseded) = ledger.counts()?;
        let as_of_s = match config.as_of {
            Some(t) => t,
            // The latest test the ledger takes as true now: a record dated later (in
            // the future when it was added) does not move every report's date.
            None => {
                let now = time::now_utc();
                ledger
                    .latest_current_at(time::latest_at(now))?
                    .unwrap_or(now)
            }
        };
        let mut machines = ledger.current_machines()?;
        if let Some(m) = &config.machine {
            if !machines.iter().any(|x| x == m.as_str()) {
                return Err(HistoryError::UnknownMachine {
                    ledger: ledger.name().to_string(),
                    machine: m.as_str().to_string(),
                });
            }
            machines = vec![m.as_str().to_string()];
        }
        let head = Head {
            as_of: time::format_utc(as_of_s),
            horizon_days: config.horizon_days,
            ledger: LedgerCounts {
                records,
                current: records - superseded,
                superseded,
            },
            chart: ChartSpec {
                method: "EWMA",
                standard: "ISO 7870-6:2016",
                lambda: stats::LAMBDA,
                l: stats::L_SIGMA,
                baseline: stats::BASELINE,
            },
        };
        Ok(Run {
            ledger,
            config,
            machines,
            next: 0,
            head,
            as_of_s,
            fleet: Vec::new(),
        })
    }

    pub fn head(&self) -> &Head {
        &self.head
    }

    /// How many machines the report holds.
    pub fn machines(&self) -> usize {
        self.machines.len()
    }

    /// The next machine (by id), or `None` when all are done.
    pub fn next_machine(&mut self) -> Result<Option<MachineReport>, HistoryError> {
        let Some(id) = self.machines.get(self.next).cloned() else {
            return Ok(None);
        };
        self.next += 1;
        let rows = self.ledger.machine_rows(&id)?;
        let name = self.ledger.name().to_string();
        let m = machine_report(&name, &id, rows, &self.config, self.as_of_s)?;
        self.fleet.push(FleetEntry {
            id: m.id.clone(),
            risk: m.risk,
            advice: m.advice,
        });
        Ok(Some(m))
    }

    /// The fleet ranking: risk descending, then id.
    pub fn fleet(mut self) -> Vec<FleetEntry> {
        self.fleet
            .sort_by(|a, b| b.risk.total_cmp(&a.risk).then(a.id.cmp(&b.id)));
        self.fleet
    }
}

/// The whole report in memory.
pub fn report(ledger: &mut Ledger, config: ReportConfig) -> Result<Report, HistoryError> {
    let mut run = Run::new(ledger, config)?;
    let head = run.head().clone();
    let mut machines = Vec::new();
    while let Some(m) = run.next_machine()? {
        machines.push(m);
    }
    Ok(Report {
        head,
        machines,
        fleet: run.fleet(),
    })
}

#[derive(Debug, Clone)]
struct Point {
    t_s: i64,
    at: String,
    as_left: bool,
    record: i64,
    value: f64,
}

/// (axis rank, axis, parameter rank, parameter): the report's order.
type SeriesKey = (usize, String, usize, String);

fn axis_rank(axis: &str) -> usize {
    ["X", "Y", "Z", "XYZ"]
        .iter()
        .position(|a| *a == axis)
        .unwrap_or(4)
}

fn parameter_rank(name: &str) -> usize {
    PARAMETERS
        .iter()
        .chain(SQUARENESS.iter())
        .chain(FUNCTIONS.iter())
        .position(|p| *p == name)
        .unwrap_or(usize::MAX)
}

/// Start indices of the segments: 0 and every as-left point after it.
fn segment_starts(points: &[Point]) -> Vec<usize> {
    let mut s = vec![0];
    s.extend((1..points.len()).filter(|&i| points[i].as_left));
    s
}

fn segments(points: &[Point]) -> Vec<&[Point]> {
    let starts = segment_starts(points);
    starts
        .iter()
        .enumerate()
        .map(|(k, &a)| &points[a..starts.get(k + 1).copied().unwrap_or(points.len())])
        .collect()
}

fn years(t_s: i64, origin: i64) -> f64 {
    (t_s - origin) as f64 / YEAR_S
}

fn seconds(y: f64, origin: i64) -> f64 {
    origin as f64 + y * YEAR_S
}

/// A machine's series by key: each one's unit and points in time order.
type SeriesMap = BTreeMap<SeriesKey, (String, Vec<Point>)>;

/// What the machine's advice is made of, gathered over all its series.
#[derive(Default)]
struct AdviceState {
    out_of_tolerance: bool,
    alarm_at_last: bool,
    recalibrate_by: Option<f64>,
    risk_max: f64,
}

/// What every parameter report of one machine needs besides its series.
struct MachineContext<'a> {
    id: &'a str,
    config: &'a ReportConfig,
    /// The horizon's end, s.
    t_h_s: f64,
}

/// One series' EWMA charts, segment by segment: the points with their chart values, the
/// alarms, and the last segment's centre line and σ.
struct Chart {
    out: Vec<SeriesPoint>,
    alarms: Vec<Alarm>,
    center: Option<f64>,
    chart_sigma: Option<f64>,
}

/// What the current segment's trend says against a tolerance.
#[derive(Default)]
struct Forecast {
    exceeds_tolerance_at: Option<String>,
    exceeds_interval: Option<[Option<String>; 2]>,
    risk: Option<f64>,
}

/// One machine's report from its rows.
pub fn machine_report(
    ledger: &str,
    id: &str,
    rows: super::ledger::MachineRows,
    config: &ReportConfig,
    as_of_s: i64,
) -> Result<MachineReport, HistoryError> {
    let series = collect_series(ledger, rows.points)?;
    let sigma_by_name = pooled_sigmas(&series);
    let horizon_s = config.horizon_days * DAY_S as f64;
    let t_h_s = as_of_s as f64 + horizon_s;
    let ctx = MachineContext { id, config, t_h_s };
    let mut axes: Vec<AxisReport> = Vec::new();
    let mut state = AdviceState::default();
    for ((_, axis, _, name), (unit, pts)) in &series {
        let sigma = sigma_by_name
            .get(name.as_str())
            .copied()
            .unwrap_or(stats::SIGMA_FLOOR);
        let p = parameter_report(&ctx, (axis, name), unit, pts, sigma, &mut state);
        match axes.last_mut() {
            Some(a) if a.axis == *axis => a.parameters.push(p),
            _ => axes.push(AxisReport {
                axis: axis.clone(),
                parameters: vec![p],
            }),
        }
    }
    let recalibrate_date = state.recalibrate_by.and_then(time::format_date);
    let advice = if state.out_of_tolerance {
        Advice::OutOfTolerance
    } else if state.recalibrate_by.is_some_and(|r| r <= t_h_s) {
        Advice::Recalibrate
    } else if state.alarm_at_last {
        Advice::Investigate
    } else {
        Advice::Ok
    };
    Ok(MachineReport {
        id: id.to_string(),
        site: rows.site,
        records: rows.records,
        advice,
        recalibrate_by: recalibrate_date,
        axes,
        risk: state.risk_max,
    })
}

/// Groups the stored points into series by (axis, parameter), each in time order
/// (as-found before as-left at one time, then by record).
fn collect_series(ledger: &str, points: Vec<RawPoint>) -> Result<SeriesMap, HistoryError> {
    // (axis, parameter) → (unit, points)
    let mut series: SeriesMap = BTreeMap::new();
    for RawPoint {
        record,
        at,
        state,
        axis,
        parameter,
        unit,
        value,
    } in points
    {
        let t_s = time::parse_utc(&at).map_err(|source| HistoryError::Stored {
            ledger: ledger.to_string(),
            record,
            source,
        })?;
        let key = (
            axis_rank(&axis),
            axis,
            parameter_rank(&parameter),
            parameter,
        );
        let entry = series.entry(key).or_insert_with(|| (unit, Vec::new()));
        entry.1.push(Point {
            t_s,
            at,
            as_left: state == "as-left",
            record,
            value,
        });
    }
    for (_, pts) in series.values_mut() {
        pts.sort_by(|a, b| {
            a.t_s
                .cmp(&b.t_s)
                .then(a.as_left.cmp(&b.as_left))
                .then(a.record.cmp(&b.record))
        });
    }
    Ok(series)
}

/// σ per parameter name, pooled over the machine's axes and segments (one axis has too
/// few points for its own).
fn pooled_sigmas(series: &SeriesMap) -> BTreeMap<&str, f64> {
    let mut sigma_by_name: BTreeMap<&str, f64> = BTreeMap::new();
    let mut values_by_name: BTreeMap<&str, Vec<Vec<f64>>> = BTreeMap::new();
    for ((_, _, _, name), (_, pts)) in series {
        let v = values_by_name.entry(name.as_str()).or_default();
        for seg in segments(pts) {
            v.push(seg.iter().map(|p| p.value).collect());
        }
    }
    for (name, segs) in values_by_name {
        sigma_by_name.insert(
            name,
            stats::moving_range_sigma(segs.iter().map(|s| s.as_slice())),
        );
    }
    sigma_by_name
}

/// One parameter's report: its charts, its current trend and, against the tolerance,
/// the forecast; feeds the machine's advice in `state`.
fn parameter_report(
    ctx: &MachineContext,
    (axis, name): (&str, &str),
    unit: &str,
    pts: &[Point],
    sigma: f64,
    state: &mut AdviceState,
) -> ParameterReport {
    let chart = chart(pts, sigma, state);
    let starts = segment_starts(pts);
    // Trend of the current segment.
    let cur = &pts[*starts.last().unwrap_or(&0)..];
    let origin = cur.first().map(|p| p.t_s).unwrap_or(0);
    let xy: Vec<(f64, f64)> = cur
        .iter()
        .map(|p| (years(p.t_s, origin), p.value))
        .collect();
    let trend = Trend::fit(&xy);
    let tolerance = if axis_rank(axis) < 3 {
        ctx.config.tolerances.get(ctx.id, axis, name)
    } else {
        None
    };
    let last = pts.last().map(|p| p.value).unwrap_or(f64::NAN);
    let forecast = match tolerance {
        Some(tol) => forecast(trend.as_ref(), tol, last, origin, ctx.t_h_s, state),
        None => Forecast::default(),
    };
    if let Some(r) = forecast.risk {
        state.risk_max = state.risk_max.max(r);
    }
    let pairs = pairs(pts);
    ParameterReport {
        name: name.to_string(),
        unit: unit.to_string(),
        n: pts.len(),
        last,
        tolerance,
        series: chart.out,
        trend_from: trend.as_ref().and(cur.first()).map(|p| p.at.clone()),
        trend_n: trend.as_ref().map(|t| t.n),
        rate_per_year: trend.as_ref().map(|t| t.slope),
        rate_sigma: trend.as_ref().map(|t| t.slope_sigma()),
        center: chart.center,
        sigma: chart.chart_sigma,
        alarms: chart.alarms,
        pairs,
        exceeds_tolerance_at: forecast.exceeds_tolerance_at,
        exceeds_interval: forecast.exceeds_interval,
        risk: forecast.risk,
        fit: trend.map(|t| (origin, t)),
    }
}

/// The EWMA chart of each segment of a series with the pooled `sigma`; an alarm on the
/// series' last point is noted in `state`.
fn chart(pts: &[Point], sigma: f64, state: &mut AdviceState) -> Chart {
    let mut out: Vec<SeriesPoint> = pts
        .iter()
        .map(|p| SeriesPoint {
            at: p.at.clone(),
            record: p.record,
            state: if p.as_left { "as-left" } else { "as-found" }.to_string(),
            value: p.value,
            ewma: None,
            lcl: None,
            ucl: None,
        })
        .collect();
    let mut alarms = Vec::new();
    let mut center = None;
    let mut chart_sigma = None;
    let starts = segment_starts(pts);
    for (k, &a) in starts.iter().enumerate() {
        let b = starts.get(k + 1).copied().unwrap_or(pts.len());
        let values: Vec<f64> = pts[a..b].iter().map(|p| p.value).collect();
        let last_segment = k + 1 == starts.len();
        if let Some((mu0, chart)) = stats::ewma_chart(&values, sigma) {
            for (i, c) in chart.into_iter().enumerate() {
                let Some(c) = c else { continue };
                let j = a + i;
                out[j].ewma = Some(c.ewma);
                out[j].lcl = Some(c.lcl);
                out[j].ucl = Some(c.ucl);
                if let Some(rule) = c.alarm {
                    alarms.push(Alarm {
                        at: pts[j].at.clone(),
                        record: pts[j].record,
                        rule: rule.as_str(),
                    });
                    if j + 1 == pts.len() {
                        state.alarm_at_last = true;
                    }
                }
            }
            if last_segment {
                center = Some(mu0);
                chart_sigma = Some(sigma);
            }
        }
    }
    Chart {
        out,
        alarms,
        center,
        chart_sigma,
    }
}

/// When the trend reaches the tolerance `tol` (with its interval) and the risk of being
/// beyond it at the horizon; an exceeded tolerance and the earliest recalibration date
/// are noted in `state`.
fn forecast(
    trend: Option<&Trend>,
    tol: f64,
    last: f64,
    origin: i64,
    t_h_s: f64,
    state: &mut AdviceState,
) -> Forecast {
    let mut f = Forecast::default();
    if last > tol {
        state.out_of_tolerance = true;
    }
    if let Some(tr) = trend {
        if let Some(t) = tr.crossing(tol) {
            f.exceeds_tolerance_at = time::format_date(seconds(t, origin));
            let iv = tr.crossing_interval(tol);
            let lo = iv.map(|(lo, _)| seconds(lo, origin));
            let hi = iv.map(|(_, hi)| seconds(hi, origin));
            let dates = [
                lo.and_then(time::format_date),
                hi.and_then(time::format_date),
            ];
            if let (Some(lo), Some(_), Some(_)) = (lo, &dates[0], &dates[1]) {
                state.recalibrate_by = Some(state.recalibrate_by.map_or(lo, |r: f64| r.min(lo)));
            }
            f.exceeds_interval = Some(dates);
        }
        f.risk = Some(tr.risk(tol, years(0, origin) + t_h_s / YEAR_S));
    } else {
        f.risk = Some(if last > tol { 1.0 } else { 0.0 });
    }
    f
}

/// Each as-left point with the latest as-found point at most 30 days before it.
fn pairs(pts: &[Point]) -> Vec<Pair> {
    let mut out = Vec::new();
    for (i, p) in pts.iter().enumerate().filter(|(_, p)| p.as_left) {
        let found = pts[..i]
            .iter()
            .rev()
            .find(|q| !q.as_left && q.t_s <= p.t_s && p.t_s - q.t_s <= PAIR_WINDOW_S);
        out.push(Pair {
            as_found_at: found.map(|q| q.at.clone()),
            as_found: found.map(|q| q.value),
            as_left_at: p.at.clone(),
            as_left: p.value,
        });
    }
    out
}
