//! Predictions from an identified model (MODEL.json, written by `identify --out`) or from
//! a machine-model TOML (the truth: σ = 0): along the lines of a line table — each line
//! relative to its first row, e_i = −u·(E(P_i; p) − E(P_0; p)), so the first row predicts
//! 0 — and the error vector E(x, y, z; p) over a grid.
//!
//! A prediction the identified model cannot make (it depends on an undetermined
//! component: its linear functional of the parameters has a component in the design's
//! null space) is `None`, never a number; a grid needing an undetermined component is
//! refused with the components named.

use std::path::Path;

use serde::Serialize;

use super::error::{VolumetricError, config_err, io_err};
use super::identify::FitState;
use super::lines::LineTable;
use super::model::{Component, Machine, SQUARENESS};

/// One predicted row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    pub line: String,
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// `None` when the model cannot determine it.
    pub e_um: Option<f64>,
    pub sigma_um: Option<f64>,
}

/// The error vector at a point and its one-sigma, µm.
pub type VectorPrediction = ([f64; 3], [f64; 3]);

/// What predicts: an identified fit, or a known machine.
#[derive(Debug)]
pub enum Predictor {
    Fit(FitState),
    Machine(Machine),
}

impl Predictor {
    /// Reads MODEL.json (`.json`) or a machine-model TOML (anything else).
    pub fn read(path: &Path) -> Result<Predictor, VolumetricError> {
        let is_json = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if !is_json {
            return Ok(Predictor::Machine(Machine::read(path)?));
        }
        let text = std::fs::read_to_string(path).map_err(io_err(path))?;
        let doc: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| config_err(path, "file", e.to_string()))?;
        let fit = doc.get("fit").ok_or_else(|| {
            config_err(
                path,
                "fit",
                "missing: write the model with `errmap volumetric identify … --out MODEL.json`",
            )
        })?;
        let mut fit: FitState = serde_json::from_value(fit.clone())
            .map_err(|e| config_err(path, "fit", e.to_string()))?;
        fit.basis
            .reparse()
            .map_err(|e| config_err(path, "fit.basis.topology", e.to_string()))?;
        let n = fit.basis.n_params();
        let ok = fit.basis.degrees.len() == 18
            && fit.theta.len() == n
            && fit.column_scale.len() == n
            && fit.identified.len() == 21
            && fit.covariance.len() == n
            && fit.covariance.iter().all(|r| r.len() == n)
            && fit.null_space.len() == n;
        if !ok {
            return Err(config_err(
                path,
                "fit",
                format!("inconsistent sizes for {n} parameters"),
            ));
        }
        if fit
            .theta
            .iter()
            .chain(fit.covariance.iter().flatten())
            .any(|v| !v.is_finite())
        {
            return Err(config_err(
                path,
                "fit",
                "non-finite parameter or covariance",
            ));
        }
        Ok(Predictor::Fit(fit))
    }

    /// Each row of `table`, relative to its line's first row.
    pub fn predict_lines(&self, table: &LineTable) -> Vec<Prediction> {
        let mut out = Vec::with_capacity(table.targets());
        for line in &table.lines {
            let p0 = line.targets[0].pos_mm;
            let base = match self {
                Predictor::Fit(f) => f.basis.line_row(p0, line.u, line.probe_mm),
                Predictor::Machine(_) => Vec::new(),
            };
            for t in &line.targets {
                let (e, s) = match self {
                    Predictor::Machine(m) => (
                        Some(
                            m.line_error_um(t.pos_mm, line.u, line.probe_mm)
                                - m.line_error_um(p0, line.u, line.probe_mm),
                        ),
                        Some(0.0),
                    ),
                    Predictor::Fit(f) => {
                        let g: Vec<f64> = f
                            .basis
                            .line_row(t.pos_mm, line.u, line.probe_mm)
                            .iter()
                            .zip(&base)
                            .map(|(a, b)| a - b)
                            .collect();
                        match f.functional(&g) {
                            Some((v, s)) => (Some(v), Some(s)),
                            None => (None, None),
                        }
                    }
                };
                out.push(Prediction {
                    line: line.id.clone(),
                    x_mm: t.pos_mm[0],
                    y_mm: t.pos_mm[1],
                    z_mm: t.pos_mm[2],
                    e_um: e,
                    sigma_um: s,
                });
            }
        }
        out
    }

    /// The error vector and its one-sigma at each point, µm. Errors with the names of the
    /// undetermined components when the identified model cannot give it.
    pub fn predict_grid(
        &self,
        points: &[[f64; 3]],
        probe_mm: [f64; 3],
    ) -> Result<Vec<VectorPrediction>, String> {
        match self {
            Predictor::Machine(m) => Ok(points
                .iter()
                .map(|&p| (m.error_um(p, probe_mm), [0.0; 3]))
                .collect()),
            Predictor::Fit(f) => {
                if let Some(missing) = grid_blockers(f) {
                    return Err(format!(
                        "the error vector needs {missing}, which the lines did not determine \
                         (see `unidentified` in the model)"
                    ));
                }
                points
                    .iter()
                    .map(|&p| {
                        let rows = f.basis.effect_rows(p, probe_mm);
                        let mut v = [0.0; 3];
                        let mut s = [0.0; 3];
                        for i in 0..3 {
                            let (a, b) = f.functional(&rows[i]).ok_or_else(|| {
                                format!(
                                    "the error at ({}, {}, {}) mm is not determined by the lines",
                                    p[0], p[1], p[2]
                                )
                            })?;
                            v[i] = a;
                            s[i] = b;
                        }
                        Ok((v, s))
                    })
                    .collect()
            }
        }
    }
}

/// The undetermined components, named, if any.
fn grid_blockers(f: &FitState) -> Option<String> {
    let names: Vec<String> = (0..21)
        .filter(|&c| !f.identified[c])
        .map(|c| {
            if c < 18 {
                Component::from_index(c).name()
            } else {
                SQUARENESS[c - 18].to_string()
            }
        })
        .collect();
    (!names.is_empty()).then(|| names.join(", "))
}

/// Writes line predictions as CSV/Parquet: `line,x_mm,y_mm,z_mm,e_um,sigma_um`.
pub fn write_predictions(path: &Path, preds: &[Prediction]) -> Result<(), VolumetricError> {
    use polars::prelude::*;
    let f = |g: &dyn Fn(&Prediction) -> f64| preds.iter().map(g).collect::<Vec<f64>>();
    let o = |g: &dyn Fn(&Prediction) -> Option<f64>| preds.iter().map(g).collect::<Vec<_>>();
    let cols = vec![
        Column::new(
            "line".into(),
            preds
                .iter()
                .map(|p| p.line.clone())
                .collect::<Vec<String>>(),
        ),
        Column::new("x_mm".into(), f(&|p| p.x_mm)),
        Column::new("y_mm".into(), f(&|p| p.y_mm)),
        Column::new("z_mm".into(), f(&|p| p.z_mm)),
        Column::new("e_um".into(), o(&|p| p.e_um)),
        Column::new("sigma_um".into(), o(&|p| p.sigma_um)),
    ];
    let mut df =
        DataFrame::new(preds.len(), cols).map_err(|e| crate::table::format_err(path, e))?;
    Ok(crate::table::write_frame(path, &mut df)?)
}

/// Writes the error vector over a grid: `x_mm,y_mm,z_mm,ex_um,ey_um,ez_um` (the spec's
/// columns; each component is an error table for `fit`, `compare`, `export`).
pub fn write_grid(
    path: &Path,
    points: &[[f64; 3]],
    errors: &[VectorPrediction],
) -> Result<(), VolumetricError> {
    use polars::prelude::*;
    let p = |k: usize| points.iter().map(|q| q[k]).collect::<Vec<f64>>();
    let e = |k: usize| errors.iter().map(|q| q.0[k]).collect::<Vec<f64>>();
    let cols = vec![
        Column::new("x_mm".into(), p(0)),
        Column::new("y_mm".into(), p(1)),
        Column::new("z_mm".into(), p(2)),
        Column::new("ex_um".into(), e(0)),
        Column::new("ey_um".into(), e(1)),
        Column::new("ez_um".into(), e(2)),
    ];
    let mut df =
        DataFrame::new(points.len(), cols).map_err(|e| crate::table::format_err(path, e))?;
    Ok(crate::table::write_frame(path, &mut df)?)
}
