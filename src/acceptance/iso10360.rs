//! ISO 10360-2:2009's length measurement error test, evaluated from a measured file.
//!
//! One row per measurement: `position`; `x1_mm, y1_mm, z1_mm` (first probed end);
//! either `x2_mm, y2_mm, z2_mm` (the other end) or `ux, uy, uz` (unit direction);
//! `calibrated_mm`; `measured_mm`; `repetition` (1 … N); optional `nominal_mm`,
//! `px_mm, py_mm, pz_mm` (stylus tip offset from the ram axis; non-zero makes E_L) and
//! `u_um` (this row's expanded uncertainty).
//!
//! E0 = (measured − calibrated)·10³ µm (indicated − reference, the sign of errmap's e);
//! a test length is a (`position`, `calibrated_mm`) pair, its `gauge` the rank of its
//! length in the position (1 = shortest); R0 = max − min of its repetitions' E0. Each E0
//! is judged against ±MPE_E0(L) with U (the row's `u_um`, else the `--u-um` formula at L,
//! else 0), each R0 against [—, MPL_R0] with its own U; the verdict aggregates them all.
//! A design other than 7 positions × 5 lengths × 3 repetitions is evaluated and its
//! differences are listed in `deviations`.

use std::path::Path;

use serde::Serialize;

use super::AcceptanceError;
use super::decide::text_cell;
use super::mpe::Mpe;
use super::rule::{ConformityVerdict, DecisionRule, Limits, Rule, aggregate};
use crate::table::{Cells, column_cells, optional_column_cells, parse_cell, read_frame};

/// The standard's name as the outputs print it.
pub(crate) const STANDARD: &str = "ISO 10360-2:2009";
/// Two calibrated lengths closer than this are one test length, mm.
pub(crate) const LENGTH_TOL_MM: f64 = 1e-6;
/// End points whose distance differs from the calibrated length by more are refused, mm;
/// so are measured and calibrated lengths differing by more.
pub(crate) const GAUGE_TOL_MM: f64 = 1.0;
/// Tolerance on |u| − 1.
pub(crate) const UNIT_TOL: f64 = 1e-6;
/// The standard's design.
pub(crate) const POSITIONS: usize = 7;
pub(crate) const LENGTHS: usize = 5;
pub(crate) const REPETITIONS: usize = 3;

/// How the test is judged.
#[derive(Debug, Clone, PartialEq)]
pub struct TestConfig {
    pub mpe: Mpe,
    /// The expanded uncertainty of E0 as a function of L (`--u-um`); rows' `u_um` win.
    pub u: Option<Mpe>,
    /// MPL of R0, µm.
    pub mpl_r0_um: Option<f64>,
    /// U of R0, µm.
    pub u_r0_um: f64,
    /// N, the repetitions per test length.
    pub repetitions: usize,
    pub rule: DecisionRule,
}

impl TestConfig {
    pub fn new(mpe: Mpe) -> TestConfig {
        TestConfig {
            mpe,
            u: None,
            mpl_r0_um: None,
            u_r0_um: 0.0,
            repetitions: REPETITIONS,
            rule: DecisionRule::default(),
        }
    }
}

/// One measured row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measurement {
    pub row: usize,
    pub position: String,
    pub gauge: usize,
    pub repetition: usize,
    pub calibrated_mm: f64,
    pub measured_mm: f64,
    pub e0_um: f64,
    pub mpe_um: f64,
    pub u_um: f64,
    pub verdict: ConformityVerdict,
}

/// One test length.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gauge {
    pub position: String,
    pub gauge: usize,
    pub calibrated_mm: f64,
    /// Its rows, by repetition.
    pub rows: Vec<usize>,
    /// Its E0, by repetition.
    pub e0_um: Vec<f64>,
    pub r0_um: f64,
    pub verdict_r0: Option<ConformityVerdict>,
}

/// One position.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Position {
    pub position: String,
    pub max_abs_e0_um: f64,
    pub verdict: ConformityVerdict,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Counts {
    pub pass: usize,
    pub indeterminate: usize,
    pub fail: usize,
}

impl Counts {
    pub fn of(verdicts: impl IntoIterator<Item = ConformityVerdict>) -> Counts {
        let mut c = Counts::default();
        for v in verdicts {
            match v {
                ConformityVerdict::Pass => c.pass += 1,
                ConformityVerdict::Indeterminate => c.indeterminate += 1,
                ConformityVerdict::Fail => c.fail += 1,
            }
        }
        c
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub measurements: usize,
    pub positions: usize,
    pub gauges: usize,
    pub max_abs_e0_um: f64,
    pub max_r0_um: f64,
    /// The E0 verdicts counted.
    pub counts: Counts,
}

/// `acceptance iso10360 --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestResult {
    pub standard: &'static str,
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub statement: String,
    pub mpe: Mpe,
    pub mpl_r0_um: Option<f64>,
    pub measurements: Vec<Measurement>,
    pub gauges: Vec<Gauge>,
    pub positions: Vec<Position>,
    pub summary: Summary,
    pub deviations: Vec<String>,
    pub verdict_e0: ConformityVerdict,
    pub verdict_r0: Option<ConformityVerdict>,
    pub verdict: ConformityVerdict,
}

/// A row as read.
struct Row {
    row: usize,
    position: String,
    calibrated_mm: f64,
    measured_mm: f64,
    repetition: usize,
    u_um: Option<f64>,
    probe: [f64; 3],
}

fn cells_of(
    path: &Path,
    df: &polars::prelude::DataFrame,
    names: [&str; 3],
) -> Result<Option<[Cells; 3]>, AcceptanceError> {
    let present: Vec<bool> = names.iter().map(|n| df.column(n).is_ok()).collect();
    if present.iter().all(|p| !p) {
        return Ok(None);
    }
    if let Some(k) = present.iter().position(|p| !p) {
        return Err(AcceptanceError::file(
            path,
            format!(
                "column `{}` is missing while {} are there",
                names[k],
                names
                    .iter()
                    .zip(&present)
                    .filter(|(_, p)| **p)
                    .map(|(n, _)| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let [a, b, c] = names;
    Ok(Some([
        column_cells(path, df, a)?,
        column_cells(path, df, b)?,
        column_cells(path, df, c)?,
    ]))
}

/// The file's columns, checked for presence and consistency before any row is read.
struct Columns {
    positions: Cells,
    p1: [Cells; 3],
    p2: Option<[Cells; 3]>,
    dir: Option<[Cells; 3]>,
    calibrated: Cells,
    measured: Cells,
    repetition: Cells,
    nominal: Option<Cells>,
    probe: Option<[Cells; 3]>,
    u: Option<Cells>,
}

impl Columns {
    /// Finds the required and optional columns, refusing a file with both or neither of
    /// the second end and the direction.
    fn read(path: &Path, df: &polars::prelude::DataFrame) -> Result<Columns, AcceptanceError> {
        let positions = column_cells(path, df, "position")?;
        let p1 = cells_of(path, df, ["x1_mm", "y1_mm", "z1_mm"])?.ok_or_else(|| {
            AcceptanceError::file(
                path,
                "columns `x1_mm, y1_mm, z1_mm` (the first end) are missing",
            )
        })?;
        let p2 = cells_of(path, df, ["x2_mm", "y2_mm", "z2_mm"])?;
        let dir = cells_of(path, df, ["ux", "uy", "uz"])?;
        match (&p2, &dir) {
            (Some(_), Some(_)) => {
                return Err(AcceptanceError::file(
                    path,
                    "both `x2_mm, y2_mm, z2_mm` and `ux, uy, uz`: give one of them",
                ));
            }
            (None, None) => {
                return Err(AcceptanceError::file(
                    path,
                    "neither `x2_mm, y2_mm, z2_mm` (the other end) nor `ux, uy, uz` (the direction)",
                ));
            }
            _ => {}
        }
        Ok(Columns {
            positions,
            p1,
            p2,
            dir,
            calibrated: column_cells(path, df, "calibrated_mm")?,
            measured: column_cells(path, df, "measured_mm")?,
            repetition: column_cells(path, df, "repetition")?,
            nominal: optional_column_cells(path, df, "nominal_mm")?,
            probe: cells_of(path, df, ["px_mm", "py_mm", "pz_mm"])?,
            u: optional_column_cells(path, df, "u_um")?,
        })
    }
}

/// A required number of row `r0` (0-based), an empty cell refused.
fn req(path: &Path, c: &Cells, r0: usize, name: &str) -> Result<f64, AcceptanceError> {
    parse_cell(path, c, r0, name)?
        .ok_or_else(|| AcceptanceError::row(path, r0 + 1, Some(name), "empty"))
}

fn read_rows(path: &Path) -> Result<Vec<Row>, AcceptanceError> {
    let df = read_frame(path)?;
    let cols = Columns::read(path, &df)?;
    if df.height() == 0 {
        return Err(AcceptanceError::file(path, "no data rows"));
    }
    let mut rows = Vec::with_capacity(df.height());
    for r0 in 0..df.height() {
        rows.push(read_row(path, &cols, r0)?);
    }
    Ok(rows)
}

/// Reads row `r0` (0-based) and checks it on its own: a length, measured near calibrated,
/// end points or direction consistent with it, a repetition number, U ≥ 0.
fn read_row(path: &Path, cols: &Columns, r0: usize) -> Result<Row, AcceptanceError> {
    let row = r0 + 1;
    let req = |c: &Cells, r0: usize, name: &str| req(path, c, r0, name);
    let position = text_cell(&cols.positions, r0)
        .ok_or_else(|| AcceptanceError::row(path, row, Some("position"), "empty"))?;
    let p1 = &cols.p1;
    let a = [
        req(&p1[0], r0, "x1_mm")?,
        req(&p1[1], r0, "y1_mm")?,
        req(&p1[2], r0, "z1_mm")?,
    ];
    let calibrated_mm = req(&cols.calibrated, r0, "calibrated_mm")?;
    if !(calibrated_mm > 0.0 && calibrated_mm <= 1e6) {
        return Err(AcceptanceError::row(
            path,
            row,
            Some("calibrated_mm"),
            format!("{calibrated_mm} mm is not a length (> 0, ≤ 10⁶)"),
        ));
    }
    let measured_mm = req(&cols.measured, r0, "measured_mm")?;
    if (measured_mm - calibrated_mm).abs() > GAUGE_TOL_MM {
        return Err(AcceptanceError::row(
            path,
            row,
            Some("measured_mm"),
            format!(
                "measured {measured_mm} mm and calibrated {calibrated_mm} mm differ by more \
                 than {GAUGE_TOL_MM} mm: another gauge, or a unit mistake"
            ),
        ));
    }
    if let Some(c) = &cols.p2 {
        let b = [
            req(&c[0], r0, "x2_mm")?,
            req(&c[1], r0, "y2_mm")?,
            req(&c[2], r0, "z2_mm")?,
        ];
        let d = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        if (d - calibrated_mm).abs() > GAUGE_TOL_MM {
            return Err(AcceptanceError::row(
                path,
                row,
                None,
                format!(
                    "the end points are {d} mm apart but the calibrated length is \
                     {calibrated_mm} mm (more than {GAUGE_TOL_MM} mm off)"
                ),
            ));
        }
    }
    if let Some(c) = &cols.dir {
        let v = [
            req(&c[0], r0, "ux")?,
            req(&c[1], r0, "uy")?,
            req(&c[2], r0, "uz")?,
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if (n - 1.0).abs() > UNIT_TOL {
            return Err(AcceptanceError::row(
                path,
                row,
                None,
                format!("the direction (ux, uy, uz) has length {n}, not 1 (to {UNIT_TOL})"),
            ));
        }
    }
    if let Some(c) = &cols.nominal {
        parse_cell(path, c, r0, "nominal_mm")?;
    }
    let rep = req(&cols.repetition, r0, "repetition")?;
    if !(rep >= 1.0 && rep.fract() == 0.0 && rep <= 1e6) {
        return Err(AcceptanceError::row(
            path,
            row,
            Some("repetition"),
            format!("{rep} is not a repetition number (1, 2, …)"),
        ));
    }
    let u_um = match &cols.u {
        Some(c) => parse_cell(path, c, r0, "u_um")?,
        None => None,
    };
    if let Some(v) = u_um
        && !(0.0..=1e6).contains(&v)
    {
        return Err(AcceptanceError::row(
            path,
            row,
            Some("u_um"),
            format!("U = {v} µm must be ≥ 0"),
        ));
    }
    let mut p = [0.0; 3];
    if let Some(c) = &cols.probe {
        for (k, name) in ["px_mm", "py_mm", "pz_mm"].iter().enumerate() {
            p[k] = parse_cell(path, &c[k], r0, name)?.unwrap_or(0.0);
        }
    }
    Ok(Row {
        row,
        position,
        calibrated_mm,
        measured_mm,
        repetition: rep as usize,
        u_um,
        probe: p,
    })
}

fn rows_text(rows: &[usize]) -> String {
    let words: Vec<String> = rows.iter().map(usize::to_string).collect();
    format!(
        "{} {}",
        if rows.len() == 1 { "row" } else { "rows" },
        words.join(", ")
    )
}

/// Reads and evaluates a measured ISO 10360-2 test.
pub fn evaluate_file(path: &Path, config: &TestConfig) -> Result<TestResult, AcceptanceError> {
    let rows = read_rows(path)?;
    evaluate(path, &rows, config)
}

/// The test lengths of one position: (calibrated length, indices of its rows), in first
/// appearance.
type Lengths = Vec<(f64, Vec<usize>)>;

/// Groups the rows by position and, within one, by calibrated length (within
/// `LENGTH_TOL_MM`), both in first-appearance order.
fn group(rows: &[Row]) -> Vec<(String, Lengths)> {
    let mut positions: Vec<(String, Lengths)> = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        let k = match positions.iter().position(|p| p.0 == r.position) {
            Some(k) => k,
            None => {
                positions.push((r.position.clone(), Vec::new()));
                positions.len() - 1
            }
        };
        let lengths = &mut positions[k].1;
        match lengths
            .iter_mut()
            .find(|(l, _)| (l - r.calibrated_mm).abs() <= LENGTH_TOL_MM)
        {
            Some((_, members)) => members.push(i),
            None => lengths.push((r.calibrated_mm, vec![i])),
        }
    }
    positions
}

/// Refuses a test length whose repetitions are not exactly 1 … n, naming the repeated,
/// missing and extra ones.
fn check_repetitions(
    path: &Path,
    rows: &[Row],
    positions: &[(String, Lengths)],
    n: usize,
) -> Result<(), AcceptanceError> {
    for (pos, lengths) in positions {
        for (l, members) in lengths {
            let mut by_rep: Vec<(usize, usize)> = members
                .iter()
                .map(|&i| (rows[i].repetition, rows[i].row))
                .collect();
            by_rep.sort();
            if let Some(w) = by_rep.windows(2).find(|w| w[0].0 == w[1].0) {
                return Err(AcceptanceError::file(
                    path,
                    format!(
                        "rows {} and {}: position `{pos}`, calibrated length {l} mm: repetition \
                         {} appears twice",
                        w[0].1, w[1].1, w[0].0
                    ),
                ));
            }
            let reps: Vec<usize> = by_rep.iter().map(|x| x.0).collect();
            if reps != (1..=n).collect::<Vec<_>>() {
                let present: Vec<usize> = by_rep.iter().map(|x| x.1).collect();
                let missing: Vec<String> = (1..=n)
                    .filter(|k| !reps.contains(k))
                    .map(|k| k.to_string())
                    .collect();
                let extra: Vec<String> = reps
                    .iter()
                    .filter(|k| **k > n)
                    .map(|k| k.to_string())
                    .collect();
                let mut problem = format!(
                    "position `{pos}`, calibrated length {l} mm: repetitions must be 1 … {n}"
                );
                if !missing.is_empty() {
                    problem.push_str(&format!("; missing {}", missing.join(", ")));
                }
                if !extra.is_empty() {
                    problem.push_str(&format!("; beyond {n}: {}", extra.join(", ")));
                }
                problem.push_str(&format!(" ({} present)", rows_text(&present)));
                return Err(AcceptanceError::file(path, problem));
            }
        }
    }
    Ok(())
}

/// A row's expanded uncertainty: its own `u_um`, else `--u-um` at its length.
fn u_of(r: &Row, config: &TestConfig) -> Option<f64> {
    r.u_um
        .or_else(|| config.u.as_ref().map(|u| u.at(r.calibrated_mm)))
}

/// The test lengths ranked within each position (the gauge number of every row, and the
/// gauges with their E0 by repetition, R0 and R0's verdict).
fn rank_gauges(
    rows: &[Row],
    positions: &[(String, Lengths)],
    config: &TestConfig,
) -> Result<(Vec<usize>, Vec<Gauge>), AcceptanceError> {
    let rule = &config.rule;
    let mut gauge_of = vec![0usize; rows.len()];
    let mut gauges = Vec::new();
    for (pos, lengths) in positions {
        let mut order: Vec<usize> = (0..lengths.len()).collect();
        order.sort_by(|&a, &b| lengths[a].0.total_cmp(&lengths[b].0));
        for (rank, &li) in order.iter().enumerate() {
            let (l, members) = &lengths[li];
            let mut m = members.clone();
            m.sort_by_key(|&i| rows[i].repetition);
            for &i in &m {
                gauge_of[i] = rank + 1;
            }
            let e0: Vec<f64> = m
                .iter()
                .map(|&i| (rows[i].measured_mm - rows[i].calibrated_mm) * 1e3)
                .collect();
            let hi = e0.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let lo = e0.iter().copied().fold(f64::INFINITY, f64::min);
            let r0 = hi - lo;
            let verdict_r0 = match config.mpl_r0_um {
                Some(mpl) => Some(
                    rule.decide(
                        r0,
                        config.u_r0_um,
                        Limits {
                            lower: None,
                            upper: Some(mpl),
                        },
                    )?
                    .verdict,
                ),
                None => None,
            };
            gauges.push(Gauge {
                position: pos.clone(),
                gauge: rank + 1,
                calibrated_mm: *l,
                rows: m.iter().map(|&i| rows[i].row).collect(),
                e0_um: e0,
                r0_um: r0,
                verdict_r0,
            });
        }
    }
    Ok((gauge_of, gauges))
}

/// Every row's E0 judged against ±MPE_E0(L) with its U.
fn judge_rows(
    path: &Path,
    rows: &[Row],
    gauge_of: &[usize],
    config: &TestConfig,
) -> Result<Vec<Measurement>, AcceptanceError> {
    let mut measurements = Vec::with_capacity(rows.len());
    for (i, r) in rows.iter().enumerate() {
        let e0 = (r.measured_mm - r.calibrated_mm) * 1e3;
        let mpe = config.mpe.at(r.calibrated_mm);
        let u = u_of(r, config).unwrap_or(0.0);
        let d = config
            .rule
            .decide(
                e0,
                u,
                Limits {
                    lower: Some(-mpe),
                    upper: Some(mpe),
                },
            )
            .map_err(|e| AcceptanceError::row(path, r.row, None, e.to_string()))?;
        measurements.push(Measurement {
            row: r.row,
            position: r.position.clone(),
            gauge: gauge_of[i],
            repetition: r.repetition,
            calibrated_mm: r.calibrated_mm,
            measured_mm: r.measured_mm,
            e0_um: e0,
            mpe_um: mpe,
            u_um: u,
            verdict: d.verdict,
        });
    }
    Ok(measurements)
}

/// How the test departs from the standard's design (7 × 5 × 3, no stylus offset).
fn deviations(rows: &[Row], positions: &[(String, Lengths)], n: usize) -> Vec<String> {
    let mut deviations = Vec::new();
    if positions.len() != POSITIONS {
        deviations.push(format!(
            "{} position(s) where the standard asks for {POSITIONS} (the 4 space diagonals and 3 \
             more)",
            positions.len()
        ));
    }
    for (pos, lengths) in positions {
        if lengths.len() != LENGTHS {
            deviations.push(format!(
                "position `{pos}`: {} test length(s) where the standard asks for {LENGTHS}",
                lengths.len()
            ));
        }
    }
    if n != REPETITIONS {
        deviations.push(format!(
            "each test length measured {n} time(s) where the standard asks for {REPETITIONS}"
        ));
    }
    let offsets: Vec<f64> = rows
        .iter()
        .map(|r| (r.probe[0].powi(2) + r.probe[1].powi(2) + r.probe[2].powi(2)).sqrt())
        .filter(|d| *d > 0.0)
        .collect();
    if !offsets.is_empty() {
        let max = offsets.iter().copied().fold(0.0, f64::max);
        deviations.push(format!(
            "{} row(s) with a stylus tip offset (up to {max} mm): their errors are E_L (E150 for \
             150 mm), not E0",
            offsets.len()
        ));
    }
    deviations
}

/// The decision statement: the rule's, then what E0 and R0 are judged against.
fn statement(config: &TestConfig, u_given: bool) -> String {
    let rule = &config.rule;
    let mut statement = rule.statement(u_given, None);
    statement.push_str(&format!(
        " Each E0 is judged against ±MPE_E0(L) = ±({}) µm, L the calibrated length in mm",
        config.mpe.formula
    ));
    match config.mpl_r0_um {
        Some(m) => statement.push_str(&format!(
            ", each R0 against MPL_R0 = {m} µm with U = {} µm.",
            config.u_r0_um
        )),
        None => statement.push_str("; R0 is reported, not judged (no MPL_R0 given)."),
    }
    if rule.rule == Rule::Iso14253 {
        statement.push_str(
            " This is ISO 10360-2's conformance with specification decided per ISO 14253-1: \
             pass proves conformity (acceptance test), fail proves nonconformity \
             (reverification), indeterminate proves neither. No re-measurement allowance is \
             applied.",
        );
    }
    statement
}

fn evaluate(path: &Path, rows: &[Row], config: &TestConfig) -> Result<TestResult, AcceptanceError> {
    let n = config.repetitions;
    let positions = group(rows);
    check_repetitions(path, rows, &positions, n)?;
    let rule = &config.rule;
    let u_given = rows.iter().any(|r| u_of(r, config).is_some());
    let (gauge_of, gauges) = rank_gauges(rows, &positions, config)?;
    let measurements = judge_rows(path, rows, &gauge_of, config)?;
    let position_list: Vec<Position> = positions
        .iter()
        .map(|(pos, _)| {
            let ms = measurements.iter().filter(|m| &m.position == pos);
            let gs = gauges.iter().filter(|g| &g.position == pos);
            Position {
                position: pos.clone(),
                max_abs_e0_um: ms.clone().map(|m| m.e0_um.abs()).fold(0.0, f64::max),
                verdict: aggregate(ms.map(|m| m.verdict).chain(gs.filter_map(|g| g.verdict_r0)))
                    .unwrap_or(ConformityVerdict::Pass),
            }
        })
        .collect();
    let deviations = deviations(rows, &positions, n);
    let verdict_e0 =
        aggregate(measurements.iter().map(|m| m.verdict)).unwrap_or(ConformityVerdict::Pass);
    let verdict_r0 = config.mpl_r0_um.map(|_| {
        aggregate(gauges.iter().filter_map(|g| g.verdict_r0)).unwrap_or(ConformityVerdict::Pass)
    });
    let verdict =
        aggregate([verdict_e0].into_iter().chain(verdict_r0)).unwrap_or(ConformityVerdict::Pass);
    let statement = statement(config, u_given);
    let summary = Summary {
        measurements: measurements.len(),
        positions: positions.len(),
        gauges: gauges.len(),
        max_abs_e0_um: measurements
            .iter()
            .map(|m| m.e0_um.abs())
            .fold(0.0, f64::max),
        max_r0_um: gauges.iter().map(|g| g.r0_um).fold(0.0, f64::max),
        counts: Counts::of(measurements.iter().map(|m| m.verdict)),
    };
    Ok(TestResult {
        standard: STANDARD,
        rule: rule.rule.name(),
        guard_fraction: rule.fraction_shown(),
        statement,
        mpe: config.mpe.clone(),
        mpl_r0_um: config.mpl_r0_um,
        measurements,
        gauges,
        positions: position_list,
        summary,
        deviations,
        verdict_e0,
        verdict_r0,
        verdict,
    })
}
