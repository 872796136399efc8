//! The ISO 10360-2 reports: the measured test (`acceptance iso10360 --report`) and the
//! virtual one (`volumetric iso10360 --report`) — `report.md`, `measurements.csv` and the
//! chart of the error against the length with the ±MPE lines as the standard draws them,
//! plus the acceptance limits ±(MPE − w) where a guard band applies.

use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::ReportError;
use super::md::Md;
use crate::acceptance::TestResult;
use crate::acceptance::{DecisionRule, Mpe, Rule};
use crate::acceptance::{VirtualMeasurement, VirtualTest};
use crate::base::FileOp;
use crate::base::io_err;
use crate::plot::{self, XySeries, XyStyle};

fn create(dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| io_err(dir, FileOp::Write)(e).into())
}

/// The MPE curve and its negative, sampled so that the kink of `min(A+L/K,B)` shows.
fn mpe_series(
    mpe: &Mpe,
    l_max: f64,
    sign: f64,
    name: &str,
    colour: usize,
    dashed: bool,
) -> XySeries {
    let n = 200;
    let x: Vec<f64> = (0..=n).map(|i| l_max * i as f64 / n as f64).collect();
    XySeries {
        name: name.into(),
        y: x.iter().map(|&l| sign * mpe.at(l)).collect(),
        x,
        style: XyStyle::Styled {
            colour,
            dashed,
            markers: false,
        },
    }
}

/// Acceptance limits ±(MPE(L) − w(L)) at the measured lengths, sorted by L.
fn acceptance_series(
    points: &[(f64, f64, f64)],
    rule: &DecisionRule,
    sign: f64,
    name: &str,
) -> XySeries {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .map(|&(l, mpe, u)| (l, sign * (mpe - rule.guard_band(u))))
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    p.dedup_by(|a, b| a.0 == b.0);
    XySeries {
        name: name.into(),
        x: p.iter().map(|q| q.0).collect(),
        y: p.iter().map(|q| q.1).collect(),
        style: XyStyle::Styled {
            colour: 3,
            dashed: true,
            markers: false,
        },
    }
}

fn guard_applies(rule: &DecisionRule, us: impl Iterator<Item = f64>) -> bool {
    let mut us = us;
    rule.rule != Rule::Simple && us.any(|u| rule.guard_band(u) > 0.0)
}

/// E0 against L for a measured test: one marker series per position, ±MPE, and the
/// acceptance limits when a guard band applies.
fn e0_chart(dir: &Path, r: &TestResult, rule: &DecisionRule) -> Result<Vec<PathBuf>, ReportError> {
    let l_max = r
        .measurements
        .iter()
        .map(|m| m.calibrated_mm)
        .fold(0.0, f64::max)
        * 1.05;
    let mut series: Vec<XySeries> = r
        .positions
        .iter()
        .map(|p| {
            let ms: Vec<_> = r
                .measurements
                .iter()
                .filter(|m| m.position == p.position)
                .collect();
            XySeries {
                name: format!("position {}", p.position),
                x: ms.iter().map(|m| m.calibrated_mm).collect(),
                y: ms.iter().map(|m| m.e0_um).collect(),
                style: XyStyle::Points,
            }
        })
        .collect();
    series.push(mpe_series(&r.mpe, l_max, 1.0, "+MPE_E0(L)", 0, false));
    series.push(mpe_series(&r.mpe, l_max, -1.0, "−MPE_E0(L)", 0, false));
    if guard_applies(rule, r.measurements.iter().map(|m| m.u_um)) {
        let pts: Vec<(f64, f64, f64)> = r
            .measurements
            .iter()
            .map(|m| (m.calibrated_mm, m.mpe_um, m.u_um))
            .collect();
        series.push(acceptance_series(&pts, rule, 1.0, "acceptance limit"));
        series.push(acceptance_series(&pts, rule, -1.0, "acceptance limit (−)"));
    }
    Ok(plot::xy(
        &dir.join("e0_vs_length"),
        "ISO 10360-2: E0 against the calibrated length",
        "L / mm",
        "E0 / µm",
        &series,
    )?)
}

/// Writes the measured test's report into `dir`: `report.md`, `measurements.csv`,
/// `e0_vs_length.png`/`.svg`. Returns the files, `report.md` first.
pub fn write_iso10360_report(
    dir: &Path,
    source: &str,
    r: &TestResult,
    rule: &DecisionRule,
) -> Result<Vec<PathBuf>, ReportError> {
    create(dir)?;
    let mut files = vec![dir.join("report.md")];
    files.push(measured_csv(dir, r)?);
    files.extend(e0_chart(dir, r, rule)?);
    super::write_text(&files[0], &measured_markdown(source, r))?;
    Ok(files)
}

/// `measurements.csv` of a measured test: one row per measurement with its verdict.
fn measured_csv(dir: &Path, r: &TestResult) -> Result<PathBuf, ReportError> {
    let csv = dir.join("measurements.csv");
    let m = &r.measurements;
    let mut df = DataFrame::new(
        m.len(),
        vec![
            Column::new(
                "row".into(),
                m.iter().map(|x| x.row as u64).collect::<Vec<_>>(),
            ),
            Column::new(
                "position".into(),
                m.iter().map(|x| x.position.clone()).collect::<Vec<_>>(),
            ),
            Column::new(
                "gauge".into(),
                m.iter().map(|x| x.gauge as u64).collect::<Vec<_>>(),
            ),
            Column::new(
                "repetition".into(),
                m.iter().map(|x| x.repetition as u64).collect::<Vec<_>>(),
            ),
            Column::new(
                "calibrated_mm".into(),
                m.iter().map(|x| x.calibrated_mm).collect::<Vec<_>>(),
            ),
            Column::new(
                "measured_mm".into(),
                m.iter().map(|x| x.measured_mm).collect::<Vec<_>>(),
            ),
            Column::new(
                "e0_um".into(),
                m.iter().map(|x| x.e0_um).collect::<Vec<_>>(),
            ),
            Column::new(
                "mpe_um".into(),
                m.iter().map(|x| x.mpe_um).collect::<Vec<_>>(),
            ),
            Column::new("u_um".into(), m.iter().map(|x| x.u_um).collect::<Vec<_>>()),
            Column::new(
                "verdict".into(),
                m.iter().map(|x| x.verdict.as_str()).collect::<Vec<_>>(),
            ),
        ],
    )
    .map_err(|e| crate::table::format_err(&csv, e))?;
    crate::table::write_frame(&csv, &mut df)?;
    Ok(csv)
}

/// `report.md` of a measured test, section by section.
fn measured_markdown(source: &str, r: &TestResult) -> String {
    let mut md = Md::new();
    md.heading(
        1,
        format_args!("{} — length measurement error test", r.standard),
    );
    measured_summary(&mut md, source, r);
    md.heading(2, "Deviations from the standard's design");
    if r.deviations.is_empty() {
        md.para("None: 7 positions × 5 test lengths × 3 repetitions.");
    } else {
        md.bullets(&r.deviations).nl();
    }
    md.heading(2, "Positions")
        .table_aligned(["position", "max \\|E0\\| / µm", "verdict"], "lrl");
    for p in &r.positions {
        md.row([
            p.position.to_string(),
            format!("{:.3}", p.max_abs_e0_um),
            p.verdict.to_string(),
        ]);
    }
    measured_worst(&mut md, r);
    measured_r0(&mut md, r);
    md.nl()
        .heading(2, "Chart")
        .para("![E0 against L](e0_vs_length.png)")
        .line(
            "E0 of every measurement against its calibrated length, one marker per position; the solid lines are ±MPE_E0(L), the dashed ones (when drawn) the acceptance limits ±(MPE − w) of the decision rule.",
        );
    md.finish()
}

/// The test file, the verdict and its statement, the counts and the MPE.
fn measured_summary(md: &mut Md, source: &str, r: &TestResult) {
    md.para(format_args!("Test file: `{source}`"));
    md.para(format_args!(
        "**Verdict: {}** (E0: {}{})",
        r.verdict,
        r.verdict_e0,
        r.verdict_r0
            .map(|v| format!(", R0: {v}"))
            .unwrap_or_default()
    ));
    md.para(&r.statement);
    let s = &r.summary;
    md.para(format_args!(
        "{} measurements, {} positions, {} test lengths; largest |E0| {:.3} µm, largest R0 \
         {:.3} µm; E0 verdicts: {} pass, {} indeterminate, {} fail.",
        s.measurements,
        s.positions,
        s.gauges,
        s.max_abs_e0_um,
        s.max_r0_um,
        s.counts.pass,
        s.counts.indeterminate,
        s.counts.fail
    ));
    md.para(format_args!(
        "MPE_E0(L) = {} µm (L in mm){}.",
        r.mpe.formula,
        r.mpl_r0_um
            .map(|m| format!("; MPL_R0 = {m} µm"))
            .unwrap_or_default()
    ));
}

/// The ten measurements nearest their MPE (by |E0|/MPE).
fn measured_worst(md: &mut Md, r: &TestResult) {
    md.nl().heading(2, "Worst results").table_aligned(
        [
            "row",
            "position",
            "gauge",
            "rep.",
            "L / mm",
            "E0 / µm",
            "MPE / µm",
            "U / µm",
            "verdict",
        ],
        "rlrrrrrrl",
    );
    let mut worst: Vec<_> = r.measurements.iter().collect();
    worst.sort_by(|a, b| {
        (b.e0_um.abs() / b.mpe_um.max(1e-12)).total_cmp(&(a.e0_um.abs() / a.mpe_um.max(1e-12)))
    });
    for m in worst.iter().take(10) {
        md.row([
            m.row.to_string(),
            m.position.to_string(),
            m.gauge.to_string(),
            m.repetition.to_string(),
            format!("{:.4}", m.calibrated_mm),
            format!("{:.3}", m.e0_um),
            format!("{:.3}", m.mpe_um),
            format!("{:.3}", m.u_um),
            m.verdict.to_string(),
        ]);
    }
}

/// The repeatability range of each position and length.
fn measured_r0(md: &mut Md, r: &TestResult) {
    md.nl().heading(2, "Repeatability range R0").table_aligned(
        ["position", "gauge", "L / mm", "rows", "R0 / µm", "verdict"],
        "lrrlrl",
    );
    for g in &r.gauges {
        md.row([
            g.position.to_string(),
            g.gauge.to_string(),
            format!("{:.4}", g.calibrated_mm),
            g.rows
                .iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            format!("{:.3}", g.r0_um),
            g.verdict_r0.map_or("not judged", |v| v.as_str()).into(),
        ]);
    }
}

fn virtual_rows(ms: &[VirtualMeasurement]) -> Vec<&VirtualMeasurement> {
    ms.iter().filter(|m| m.repetition == 1).collect()
}

/// Writes the virtual test's report into `dir`: `report.md`, `measurements.csv` (one row
/// per test length, repetitions being identical) and `e_vs_length.png`/`.svg` (before,
/// and after compensation when predicted).
pub fn write_virtual_report(
    dir: &Path,
    model: &str,
    t: &VirtualTest,
) -> Result<Vec<PathBuf>, ReportError> {
    create(dir)?;
    let mut files = vec![dir.join("report.md")];
    let before = virtual_rows(&t.measurements);
    let after: Option<Vec<&VirtualMeasurement>> = t
        .compensated
        .as_ref()
        .map(|c| virtual_rows(&c.measurements));
    files.push(virtual_csv(dir, &before, after.as_deref())?);
    files.extend(virtual_chart(dir, t, &before, after.as_deref())?);
    super::write_text(
        &files[0],
        &virtual_markdown(model, t, &before, after.as_deref()),
    )?;
    Ok(files)
}

/// `measurements.csv` of a virtual test: one row per test length, before and (when
/// predicted) after compensation.
fn virtual_csv(
    dir: &Path,
    before: &[&VirtualMeasurement],
    after: Option<&[&VirtualMeasurement]>,
) -> Result<PathBuf, ReportError> {
    let csv = dir.join("measurements.csv");
    let f64s =
        |f: &dyn Fn(&VirtualMeasurement) -> f64| before.iter().map(|m| f(m)).collect::<Vec<_>>();
    let mut cols = vec![
        Column::new(
            "position".into(),
            before
                .iter()
                .map(|m| m.position.clone())
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "gauge".into(),
            before.iter().map(|m| m.gauge as u64).collect::<Vec<_>>(),
        ),
        Column::new("length_mm".into(), f64s(&|m| m.length_mm)),
    ];
    for (k, name) in ["x1_mm", "y1_mm", "z1_mm"].iter().enumerate() {
        cols.push(Column::new((*name).into(), f64s(&|m| m.p1_mm[k])));
    }
    for (k, name) in ["x2_mm", "y2_mm", "z2_mm"].iter().enumerate() {
        cols.push(Column::new((*name).into(), f64s(&|m| m.p2_mm[k])));
    }
    cols.push(Column::new("e_um".into(), f64s(&|m| m.e_um)));
    cols.push(Column::new("sigma_um".into(), f64s(&|m| m.sigma_um)));
    cols.push(Column::new(
        "mpe_um".into(),
        before.iter().map(|m| m.mpe_um).collect::<Vec<_>>(),
    ));
    cols.push(Column::new(
        "u_um".into(),
        before.iter().map(|m| m.u_um).collect::<Vec<_>>(),
    ));
    cols.push(Column::new(
        "verdict".into(),
        before
            .iter()
            .map(|m| m.verdict.map(|v| v.as_str()))
            .collect::<Vec<_>>(),
    ));
    if let Some(a) = after {
        cols.push(Column::new(
            "e_after_um".into(),
            a.iter().map(|m| m.e_um).collect::<Vec<_>>(),
        ));
        cols.push(Column::new(
            "verdict_after".into(),
            a.iter()
                .map(|m| m.verdict.map(|v| v.as_str()))
                .collect::<Vec<_>>(),
        ));
    }
    let mut df =
        DataFrame::new(before.len(), cols).map_err(|e| crate::table::format_err(&csv, e))?;
    crate::table::write_frame(&csv, &mut df)?;
    Ok(csv)
}

/// E against L of a virtual test, before and after compensation, with ±MPE when given.
fn virtual_chart(
    dir: &Path,
    t: &VirtualTest,
    before: &[&VirtualMeasurement],
    after: Option<&[&VirtualMeasurement]>,
) -> Result<Vec<PathBuf>, ReportError> {
    let l_max = before.iter().map(|m| m.length_mm).fold(0.0, f64::max) * 1.05;
    let mut series = vec![XySeries {
        name: "predicted E (model)".into(),
        x: before.iter().map(|m| m.length_mm).collect(),
        y: before.iter().map(|m| m.e_um).collect(),
        style: XyStyle::Points,
    }];
    if let Some(a) = after {
        series.push(XySeries {
            name: "after compensation".into(),
            x: a.iter().map(|m| m.length_mm).collect(),
            y: a.iter().map(|m| m.e_um).collect(),
            style: XyStyle::Points,
        });
    }
    if let Some(mpe) = &t.mpe {
        series.push(mpe_series(mpe, l_max, 1.0, "+MPE_E0(L)", 0, false));
        series.push(mpe_series(mpe, l_max, -1.0, "−MPE_E0(L)", 0, false));
    }
    Ok(plot::xy(
        &dir.join("e_vs_length"),
        "ISO 10360-2 predicted from the volumetric model",
        "L / mm",
        "E / µm",
        &series,
    )?)
}

/// `report.md` of a virtual test, section by section.
fn virtual_markdown(
    model: &str,
    t: &VirtualTest,
    before: &[&VirtualMeasurement],
    after: Option<&[&VirtualMeasurement]>,
) -> String {
    let mut md = Md::new();
    md.heading(
        1,
        format_args!("{} predicted — the virtual test", t.standard),
    );
    virtual_summary(&mut md, model, t);
    virtual_positions(&mut md, t);
    virtual_lengths(&mut md, before, after);
    md.nl()
        .heading(2, "Chart")
        .para("![E against L](e_vs_length.png)")
        .line(
            "The predicted error of each test length against its length (repetitions are identical), with ±MPE_E0(L) when given.",
        );
    md.finish()
}

/// The model and plan, the warnings, the predicted verdict and the largest errors.
fn virtual_summary(md: &mut Md, model: &str, t: &VirtualTest) {
    md.para(format_args!(
        "Model: `{model}` (topology {}, residual `{}`); plan: {}; volume [{:?}, {:?}] mm.",
        t.topology, t.model_residual, t.plan, t.volume_mm[0], t.volume_mm[1]
    ));
    for w in &t.warnings {
        md.para(format_args!("> **Warning:** {w}"));
    }
    match (t.verdict, &t.statement) {
        (Some(v), Some(s)) => {
            md.para(format_args!(
                "**Predicted verdict: {v}**{}",
                t.compensated
                    .as_ref()
                    .and_then(|c| c.verdict)
                    .map(|a| format!("; after compensation: **{a}**"))
                    .unwrap_or_default()
            ));
            md.para(s);
        }
        _ => {
            md.para("No MPE given: the errors are predicted, not judged.");
        }
    }
    md.para(format_args!(
        "Largest |E| {:.3} µm{}. E is the geometric part of E0 only (no probing error, repeatability or thermal state); σ is the model's one-sigma.",
        t.max_abs_e_um,
        t.compensated
            .as_ref()
            .map(|c| format!(
                ", after compensation {:.3} µm ({} table positions per axis, tool point; \
                 what the model and a 0.1 µm table cannot resolve: ±{:.3} µm, so a smaller \
                 value is not evidence of zero error)",
                c.max_abs_e_um, c.table_points, c.floor_um
            ))
            .unwrap_or_default()
    ));
}

/// The largest error per position, before and (when predicted) after compensation.
fn virtual_positions(md: &mut Md, t: &VirtualTest) {
    md.heading(2, "Positions");
    let after_pos = t.compensated.as_ref().map(|c| &c.positions);
    let mut header = vec!["position", "max \\|E\\| / µm", "σ / µm", "gauge", "verdict"];
    let mut align = String::from("lrrrl");
    if after_pos.is_some() {
        header.extend(["after: max \\|E\\| / µm", "verdict"]);
        align.push_str("rl");
    }
    md.table_aligned(header, &align);
    for (i, p) in t.positions.iter().enumerate() {
        let mut cells = vec![
            p.position.to_string(),
            format!("{:.3}", p.max_abs_e_um),
            format!("{:.3}", p.sigma_um),
            p.gauge.to_string(),
            p.verdict.map_or("—", |v| v.as_str()).to_string(),
        ];
        if let Some(a) = after_pos.and_then(|a| a.get(i)) {
            cells.push(format!("{:.3}", a.max_abs_e_um));
            cells.push(a.verdict.map_or("—", |v| v.as_str()).to_string());
        }
        md.row(cells);
    }
}

/// One row per test length, before and (when predicted) after compensation.
fn virtual_lengths(
    md: &mut Md,
    before: &[&VirtualMeasurement],
    after: Option<&[&VirtualMeasurement]>,
) {
    let mut header = vec![
        "position",
        "gauge",
        "L / mm",
        "E / µm",
        "σ / µm",
        "MPE / µm",
        "U / µm",
        "verdict",
    ];
    let mut align = String::from("lrrrrrrl");
    if after.is_some() {
        header.extend(["after: E / µm", "verdict"]);
        align.push_str("rl");
    }
    md.nl()
        .heading(2, "Test lengths")
        .table_aligned(header, &align);
    let o = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
    for (i, m) in before.iter().enumerate() {
        let mut cells = vec![
            m.position.to_string(),
            m.gauge.to_string(),
            format!("{:.3}", m.length_mm),
            format!("{:.3}", m.e_um),
            format!("{:.3}", m.sigma_um),
            o(m.mpe_um),
            o(m.u_um),
            m.verdict.map_or("—", |v| v.as_str()).to_string(),
        ];
        if let Some(a) = after.and_then(|a| a.get(i)) {
            cells.push(format!("{:.3}", a.e_um));
            cells.push(a.verdict.map_or("—", |v| v.as_str()).to_string());
        }
        md.row(cells);
    }
}
