//! The comparison report: `report.md`, `comparison.csv`, `predictions.csv`, and figures
//! (PNG and SVG) in one directory. Nothing in it depends on the time or the machine, so a
//! committed report can be checked against a fresh run byte for byte.

use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::ReportError;
use super::findings::group_by_reason;
use super::json::finite;
use super::md::Md;
use crate::base::FileOp;
use crate::base::io_err;
use crate::evaluate::CvScheme;
use crate::evaluate::{Comparison, SigmaKind};
use crate::interp::Method;
use crate::plot;
use crate::table::{TableError, write_frame};

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map(|x| format!("{x:.digits$}"))
        .unwrap_or_else(|| "—".into())
}

/// The rows shown in the test-point table and the figure: the recommended model, the
/// paper's orders we can fit, the three cell methods, and the best on the test points.
fn featured(c: &Comparison) -> Vec<usize> {
    let mut idx = vec![c.recommended];
    for p in &c.paper {
        if let Some(i) = c.find(&Method::Lagrange(p.order)) {
            idx.push(i);
        }
    }
    for (i, r) in c.rows.iter().enumerate() {
        if r.method.order().is_none() {
            idx.push(i);
        }
    }
    idx.push(c.best_on_test());
    let mut seen = Vec::new();
    idx.retain(|i| {
        let new = !seen.contains(i);
        seen.push(*i);
        new
    });
    idx
}

/// Writes the whole report into `dir`; `command` is the command line that regenerates it.
pub fn write_report(
    c: &Comparison,
    dir: &Path,
    command: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let feat = featured(c);
    let mut by_cv: Vec<usize> = (0..c.rows.len()).collect();
    by_cv.sort_by(|&a, &b| c.rows[a].cv.rms_um.total_cmp(&c.rows[b].cv.rms_um));
    let mut written = vec![comparison_csv(c, dir)?, predictions_csv(c, &feat, dir)?];
    written.extend(measured_vs_predicted_figure(c, &feat, dir)?);
    written.extend(cv_figure(c, &feat, &by_cv, dir)?);
    let path = dir.join("report.md");
    super::write_text(&path, &markdown(c, command, &feat, &by_cv))?;
    written.push(path);
    Ok(written)
}

/// Writes `df` as `dir/name` (CSV), naming the file when the frame cannot be made.
fn write_csv(
    dir: &Path,
    name: &str,
    height: usize,
    cols: Vec<Column>,
) -> Result<PathBuf, ReportError> {
    let path = dir.join(name);
    let mut df = DataFrame::new(height, cols).map_err(|e| TableError::Format {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_frame(&path, &mut df)?;
    Ok(path)
}

/// `comparison.csv`: one row per model, its errors, cross-validation and predictions.
fn comparison_csv(c: &Comparison, dir: &Path) -> Result<PathBuf, ReportError> {
    let rows = &c.rows;
    let mut cols = vec![
        Column::new(
            "method".into(),
            rows.iter().map(|r| r.method.name()).collect::<Vec<_>>(),
        ),
        Column::new(
            "order".into(),
            rows.iter()
                .map(|r| r.method.order().map(|o| o.to_string()))
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "label".into(),
            rows.iter().map(|r| r.method.label()).collect::<Vec<_>>(),
        ),
        Column::new(
            "rms_um".into(),
            rows.iter().map(|r| r.rms_um).collect::<Vec<_>>(),
        ),
        Column::new(
            "max_abs_um".into(),
            rows.iter().map(|r| r.max_abs_um).collect::<Vec<_>>(),
        ),
        Column::new(
            "inside_rms_um".into(),
            rows.iter().map(|r| r.inside_rms_um).collect::<Vec<_>>(),
        ),
        Column::new(
            "cv_rms_um".into(),
            rows.iter().map(|r| finite(r.cv.rms_um)).collect::<Vec<_>>(),
        ),
        Column::new(
            "cv_interior_rms_um".into(),
            rows.iter()
                .map(|r| r.cv.interior_rms_um)
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "cv_capped_folds".into(),
            rows.iter()
                .map(|r| r.cv.capped_folds as u32)
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "cv_folds".into(),
            rows.iter().map(|r| r.cv.folds as u32).collect::<Vec<_>>(),
        ),
    ];
    for k in 0..c.test.points.len() {
        cols.push(Column::new(
            format!("pred_{}", k + 1).into(),
            rows.iter().map(|r| r.predictions[k]).collect::<Vec<_>>(),
        ));
    }
    write_csv(dir, "comparison.csv", rows.len(), cols)
}

/// `predictions.csv`: one row per test point, the paper's and the featured models'
/// predictions as columns.
fn predictions_csv(c: &Comparison, feat: &[usize], dir: &Path) -> Result<PathBuf, ReportError> {
    let pts = &c.test.points;
    let mut cols = vec![
        Column::new(
            "x_mm".into(),
            pts.iter().map(|p| p.x_mm).collect::<Vec<_>>(),
        ),
        Column::new(
            "y_mm".into(),
            pts.iter().map(|p| p.y_mm).collect::<Vec<_>>(),
        ),
        Column::new(
            "z_mm".into(),
            pts.iter().map(|p| p.z_mm).collect::<Vec<_>>(),
        ),
        Column::new(
            "e_um".into(),
            pts.iter().map(|p| p.e_um).collect::<Vec<_>>(),
        ),
        Column::new("extrapolated".into(), c.extrapolated.clone()),
    ];
    for p in &c.paper {
        cols.push(Column::new(
            format!("paper_{}", p.order).into(),
            p.values.clone(),
        ));
    }
    for &i in feat {
        let r = &c.rows[i];
        let name = r
            .method
            .label()
            .replace('×', "x")
            .replace("σ=", "sigma_")
            .replace(' ', "_");
        cols.push(Column::new(name.clone().into(), r.predictions.clone()));
        if r.sigmas.iter().any(Option::is_some) {
            cols.push(Column::new(
                format!("{name}_sigma").into(),
                r.sigmas.clone(),
            ));
        }
    }
    write_csv(dir, "predictions.csv", pts.len(), cols)
}

/// `measured_vs_predicted`: the measured error and the featured models per test point.
fn measured_vs_predicted_figure(
    c: &Comparison,
    feat: &[usize],
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let n_pts = c.test.points.len();
    let categories: Vec<String> = (1..=n_pts).map(|k| format!("P{k}")).collect();
    let mut series = vec![plot::Series {
        name: "measured".into(),
        y: c.test.points.iter().map(|p| p.e_um).collect(),
        y_err: None,
    }];
    for &i in feat {
        let r = &c.rows[i];
        let mut name = r.method.label();
        if i == c.recommended {
            name.push_str(" (CV pick)");
        }
        // Error bars for the models' own σ only: the interpolators' cross-validated σ
        // would bury the figure (it is in the tables).
        let y_err = (r.sigma_kind == Some(SigmaKind::Model)
            && r.sigmas.iter().all(Option::is_some))
        .then(|| r.sigmas.iter().map(|s| s.unwrap_or(0.0)).collect());
        if y_err.is_some() {
            name.push_str(" ±1σ");
        }
        series.push(plot::Series {
            name,
            y: r.predictions.clone(),
            y_err,
        });
    }
    Ok(plot::category_points(
        &dir.join("measured_vs_predicted"),
        "Measured vs predicted error at the test points",
        "test point",
        "error e / µm",
        &categories,
        &series,
        &c.extrapolated,
        "extrapolated (outside the grid)",
    )?)
}

/// `cv_per_order`: the 24 best models by CV RMS and the featured ones, as bars, with
/// their test RMS as markers.
fn cv_figure(
    c: &Comparison,
    feat: &[usize],
    by_cv: &[usize],
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut shown: Vec<usize> = by_cv.iter().copied().take(24).collect();
    for &i in feat {
        if !shown.contains(&i) {
            shown.push(i);
        }
    }
    Ok(plot::bars(
        &dir.join("cv_per_order"),
        &format!(
            "{} CV RMS per model (bars) and test RMS (markers)",
            capitalise(c.recommended_row().cv.scheme.label())
        ),
        "RMS / µm",
        &shown
            .iter()
            .map(|&i| c.rows[i].method.label())
            .collect::<Vec<_>>(),
        &shown
            .iter()
            .map(|&i| c.rows[i].cv.rms_um)
            .collect::<Vec<_>>(),
        Some(&plot::Series {
            name: "test RMS".into(),
            y: shown.iter().map(|&i| c.rows[i].rms_um).collect(),
            y_err: None,
        }),
        true,
    )?)
}

/// `report.md`, section by section.
fn markdown(c: &Comparison, command: &str, feat: &[usize], by_cv: &[usize]) -> String {
    let mut md = Md::new();
    md.heading(1, "Interpolation order and method comparison")
        .para(format_args!("Regenerate with `{command}`."));
    inputs(&mut md, c);
    md.heading(2, "Findings").bullets(c.findings());
    recommendation(&mut md, c);
    test_points(&mut md, c, feat);
    paper_columns(&mut md, c);
    if let Some(a) = &c.advice {
        sampling_advice(&mut md, a);
    }
    all_models(&mut md, c, by_cv);
    figures_and_method(&mut md);
    md.finish()
}

/// The inputs: the fitting table's grid or nodes, what was not fitted, the test points.
fn inputs(md: &mut Md, c: &Comparison) {
    match &c.grid {
        Some(grid) => {
            let shape = grid.shape();
            md.bullet(format_args!(
                "Fitting table: `{}` — a {}×{}×{} grid ({} nodes).",
                c.fit_source,
                shape[0],
                shape[1],
                shape[2],
                grid.values.len()
            ));
            for (a, name) in ["x", "y", "z"].iter().enumerate() {
                let nodes: Vec<String> = grid.axis(a).iter().map(|v| format!("{v}")).collect();
                md.line(format_args!("  - {name} nodes (mm): {}", nodes.join(", ")));
            }
        }
        None => {
            md.bullet(format_args!(
                "Fitting table: `{}` — {} scattered nodes (not a full grid).",
                c.fit_source, c.fit_nodes
            ));
            for (a, name) in ["x", "y", "z"].iter().enumerate() {
                let [lo, hi] = c.extent.bounds[a];
                md.line(format_args!("  - {name} from {lo} to {hi} mm"));
            }
        }
    }
    for (names, why) in group_by_reason(&c.refused) {
        md.bullet(format_args!("Not fitted: {} — {why}.", names.join(", ")));
    }
    md.bullet(format_args!(
        "Test points: `{}` — {} points, {} outside the {} (extrapolated).",
        c.test.source,
        c.test.points.len(),
        c.extrapolated.iter().filter(|e| **e).count(),
        if c.grid.is_some() {
            "grid"
        } else {
            "fitting nodes' box"
        }
    ));
    md.bullet(format_args!(
        "Models: {} ({} Lagrange orders). Errors are e = indicated − reference, µm.",
        c.rows.len(),
        c.rows.iter().filter(|r| r.method.order().is_some()).count()
    ))
    .nl();
}

/// The recommended model, why, and the caveats of its cross-validation scheme.
fn recommendation(md: &mut Md, c: &Comparison) {
    let rec = c.recommended_row();
    md.nl().heading(2, "Recommendation").para(format_args!(
        "**{}**, chosen by the lowest {} cross-validated RMS on the fitting table \
         ({:.4} µm over {} held-out node predictions in {} folds). The test points played no part in \
         this choice.",
        rec.method.label(),
        rec.cv.scheme.label(),
        rec.cv.rms_um,
        rec.cv.predictions,
        rec.cv.folds
    ));
    md.para(match rec.cv.scheme {
        CvScheme::LeaveOnePlaneOut => {
            "Caveats: each node is predicted with its whole plane removed, so the CV error is pessimistic \
             for a dense grid and dominated by the end planes (extrapolation) on a coarse one; a CV ranking on \
             a grid this small separates models only roughly. Treat it as a guide to the order family, and \
             measure more nodes along the axes flagged above."
        }
        CvScheme::LeaveOneOut => {
            "Caveats: each node is predicted from all the others with the hyperparameters held at their fit \
             to every node, so the CV error is slightly optimistic; nodes on the edge of the cloud are \
             extrapolations and dominate it."
        }
    });
}

/// The test-point table (like the paper's Table 2) with its RMS row.
fn test_points(md: &mut Md, c: &Comparison, feat: &[usize]) {
    md.heading(2, "Test points (like the paper's Table 2)").para(
        "Predictions ± one sigma: the Gaussian process's own predictive σ; for the interpolators \
         their cross-validated RMS (end planes for extrapolated points, interior planes otherwise).",
    );
    let mut header = vec![
        "#".to_string(),
        "x mm".into(),
        "y mm".into(),
        "z mm".into(),
        "e µm".into(),
        "outside".into(),
    ];
    header.extend(c.paper.iter().map(|p| format!("paper {}", p.order)));
    header.extend(feat.iter().map(|&i| c.rows[i].method.label()));
    md.table(header);
    for (k, p) in c.test.points.iter().enumerate() {
        let mut cells = vec![
            format!("P{}", k + 1),
            coordinate(p.x_mm),
            coordinate(p.y_mm),
            coordinate(p.z_mm),
            format!("{:.4}", p.e_um),
            if c.extrapolated[k] { "yes" } else { "no" }.into(),
        ];
        cells.extend(c.paper.iter().map(|pc| opt(pc.values[k], 4)));
        for &i in feat {
            let r = &c.rows[i];
            cells.push(match r.sigmas[k] {
                Some(sd) => format!("{:.4} ± {:.3}", r.predictions[k], sd),
                None => format!("{:.4}", r.predictions[k]),
            });
        }
        md.row(cells);
    }
    let mut cells = vec!["RMS".to_string()];
    cells.extend(std::iter::repeat_n(String::new(), 5));
    for pc in &c.paper {
        let r: Vec<f64> = pc
            .values
            .iter()
            .zip(&c.test.points)
            .filter_map(|(v, p)| v.map(|v| v - p.e_um))
            .collect();
        cells.push(opt(crate::base::rms(&r), 4));
    }
    cells.extend(feat.iter().map(|&i| format!("{:.4}", c.rows[i].rms_um)));
    md.row(cells);
}

/// Whether each of the paper's printed columns was reproduced, and how closely.
fn paper_columns(md: &mut Md, c: &Comparison) {
    md.nl().heading(2, "The paper's columns");
    if c.paper.is_empty() {
        md.line("The test table has no `paper_MxNxQ` columns.");
    }
    for p in &c.paper {
        match (&p.ours, &p.refused) {
            (Some(ours), _) => {
                let worst = ours
                    .iter()
                    .zip(&p.values)
                    .enumerate()
                    .filter_map(|(k, (o, v))| v.map(|v| (k, (o - v).abs())))
                    .fold((0, 0.0), |m, d| if d.1 > m.1 { d } else { m });
                md.bullet(format_args!(
                    "**{}**: reproduced; largest difference from the printed column {:.4} µm (P{}). \
                     Printed values have 4 decimals; a difference of 1e-4 is the last printed digit.",
                    p.order,
                    worst.1,
                    worst.0 + 1
                ));
            }
            (None, Some(why)) => {
                md.bullet(format_args!(
                    "**{}**: not reproducible from the fitting table — {why}.",
                    p.order
                ));
            }
            (None, None) => {}
        }
    }
}

/// The Gaussian process's correlation lengths against the node spacing, and the nodes
/// it would measure next.
fn sampling_advice(md: &mut Md, a: &crate::evaluate::SamplingAdvice) {
    md.nl().heading(2, "Sampling advice (Gaussian process)").para(format_args!(
        "A {} Gaussian process fitted to the table (signal σ {:.3} µm, noise σ {:.3} µm) gives the \
         error's correlation length per axis; where it is shorter than the node spacing, the grid \
         does not resolve the error between nodes.",
        a.kernel, a.signal_sd_um, a.noise_sd_um
    ));
    md.table([
        "axis",
        "correlation length mm",
        "node spacing mm",
        "resolved",
    ]);
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        let (l, d) = (a.length_scales_mm[k], a.spacing_mm[k]);
        md.row([
            name.to_string(),
            format!("{l:.1}"),
            format!("{d:.1}"),
            if d <= l { "yes" } else { "**no**" }.into(),
        ]);
    }
    md.nl().para(format_args!(
        "The largest predictive σ over a lattice of the table's volume (9 points along each axis the nodes span) is {:.3} µm. The next \
         {} nodes that most reduce it (greedy, each chosen where the variance is largest given the \
         nodes before it):",
        a.max_sigma_um,
        a.next_nodes.len()
    ));
    md.numbered(
        a.next_nodes
            .iter()
            .map(|p| format!("({:.1}, {:.1}, {:.1}) mm", p[0], p[1], p[2])),
    );
}

/// Every model, ordered by cross-validated RMS, with its test errors and σ coverage.
fn all_models(md: &mut Md, c: &Comparison, by_cv: &[usize]) {
    md.nl()
        .heading(2, "All models, by cross-validated RMS")
        .para(
            "σ as in the test-point table: the model's own for the Gaussian process, the \
         cross-validated RMS for the interpolators.",
        );
    md.table([
        "model",
        "CV RMS µm",
        "CV interior µm",
        "CV x / y / z µm",
        "capped folds",
        "test RMS µm",
        "test max µm",
        "inside RMS µm",
        "within ±1σ / ±2σ",
        "worst \\|e\\|/σ",
    ]);
    for &i in by_cv {
        let r = &c.rows[i];
        let axes: Vec<String> = r.cv.axis_rms_um.iter().map(|v| opt(*v, 3)).collect();
        md.row([
            format!(
                "{}{}",
                r.method.label(),
                if i == c.recommended { " ★" } else { "" }
            ),
            opt(Some(r.cv.rms_um), 4),
            opt(r.cv.interior_rms_um, 4),
            axes.join(" / "),
            format!("{}/{}", r.cv.capped_folds, r.cv.folds),
            format!("{:.4}", r.rms_um),
            format!("{:.4}", r.max_abs_um),
            opt(r.inside_rms_um, 4),
            match (r.within_1s, r.within_2s) {
                (Some(a), Some(b)) => format!("{:.0} % / {:.0} %", 100.0 * a, 100.0 * b),
                _ => "—".into(),
            },
            opt(r.max_abs_z, 2),
        ]);
    }
}

/// The figures' list and the method in words.
fn figures_and_method(md: &mut Md) {
    md.nl().heading(2, "Figures")
        .bullet(
            "`measured_vs_predicted.png` / `.svg` — measured error and the featured models' predictions \
             per test point (like the paper's Fig. 2); extrapolated points are marked.",
        )
        .bullet(
            "`cv_per_order.png` / `.svg` — cross-validated RMS per model (bars) with the test RMS (markers).",
        )
        .nl()
        .line("![measured vs predicted](measured_vs_predicted.png)")
        .nl()
        .line("![CV per order](cv_per_order.png)");
    md.nl().heading(2, "Method").line(format_args!(
        "Lagrange m×n×q: tensor Lagrange polynomials of degree m, n, q along x, y, z through m+1, n+1, q+1 \
         consecutive nodes around the query (Zhang Mei 2013). Trilinear, natural tricubic spline and the \
         Gaussian-membership fuzzy interpolator (σ = {} of the cell) follow Agbegha, Guo and Bai (2011). Cross-validation leaves \
         out one whole grid plane at a time along each axis, end planes included, fits on the rest and \
         predicts the removed nodes; where a fold has too few nodes for a Lagrange degree, the degree is \
         lowered for that fold and counted under \"capped folds\". A scattered table (not a full grid) \
         has no planes: only the Gaussian process (kriging, Matérn 5/2 or squared-exponential kernel, \
         hyperparameters by maximum likelihood) is fitted, and it is cross-validated leaving one node \
         out at a time.",
        crate::interp::DEFAULT_FUZZY_SIGMA
    ));
}

/// A test point's coordinate, mm: to 0.1 µm, trailing zeros dropped (`200`, `1.2424`,
/// `220.7686`), not the 17 digits of a simulated point's binary value.
fn coordinate(v_mm: f64) -> String {
    let s = format!("{v_mm:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}
