//! The JSON documents of `compare --json` (`docs/cli.md`, with extra keys).

use std::path::Path;

use serde::Serialize;

use crate::evaluate::compare::{Comparison, SigmaKind};
use crate::evaluate::cv::CvScheme;
use crate::interp::Method;

/// The JSON document of `compare --json` (`docs/cli.md`, with extra keys).
#[derive(Debug, Serialize)]
pub struct CompareJson {
    pub rows: Vec<CompareJsonRow>,
    pub recommended: MethodJson,
    pub extrapolated: Vec<bool>,
    pub report: Option<String>,
    /// Methods not fitted (scattered tables), with the reason.
    pub refused: Vec<RefusedJson>,
}

#[derive(Debug, Serialize)]
pub struct RefusedJson {
    pub method: String,
    pub reason: String,
}

#[derive(Debug, Serialize)]
pub struct CompareJsonRow {
    pub method: String,
    pub order: Option<[usize; 3]>,
    pub rms_um: f64,
    pub max_abs_um: f64,
    pub cv_rms_um: Option<f64>,
    pub predictions: Vec<f64>,
    pub label: String,
    pub inside_rms_um: Option<f64>,
    pub cv_interior_rms_um: Option<f64>,
    pub cv_capped_folds: usize,
    pub cv_folds: usize,
    pub cv_scheme: CvScheme,
    /// One-sigma per prediction where the method has one (GP), else null.
    pub sigmas: Vec<Option<f64>>,
    pub within_1s: Option<f64>,
    pub within_2s: Option<f64>,
    pub max_abs_z: Option<f64>,
    /// Where `sigmas` come from: "model" (GP) or "cross_validation".
    pub sigma_kind: Option<SigmaKind>,
}

#[derive(Debug, Serialize)]
pub struct MethodJson {
    pub method: String,
    pub order: Option<[usize; 3]>,
}

impl From<&Method> for MethodJson {
    fn from(m: &Method) -> Self {
        MethodJson {
            method: m.name().to_string(),
            order: m.order().map(|o| o.0),
        }
    }
}

pub(super) fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl Comparison {
    pub fn to_json(&self, report: Option<&Path>) -> CompareJson {
        CompareJson {
            rows: self
                .rows
                .iter()
                .map(|r| CompareJsonRow {
                    method: r.method.name().to_string(),
                    order: r.method.order().map(|o| o.0),
                    rms_um: r.rms_um,
                    max_abs_um: r.max_abs_um,
                    cv_rms_um: finite(r.cv.rms_um),
                    predictions: r.predictions.clone(),
                    label: r.method.label(),
                    inside_rms_um: r.inside_rms_um,
                    cv_interior_rms_um: r.cv.interior_rms_um,
                    cv_capped_folds: r.cv.capped_folds,
                    cv_folds: r.cv.folds,
                    cv_scheme: r.cv.scheme,
                    sigmas: r.sigmas.clone(),
                    within_1s: r.within_1s,
                    within_2s: r.within_2s,
                    max_abs_z: r.max_abs_z,
                    sigma_kind: r.sigma_kind,
                })
                .collect(),
            recommended: (&self.recommended_row().method).into(),
            extrapolated: self.extrapolated.clone(),
            report: report.map(|p| p.display().to_string()),
            refused: self
                .refused
                .iter()
                .map(|(m, why)| RefusedJson {
                    method: m.clone(),
                    reason: why.clone(),
                })
                .collect(),
        }
    }
}
