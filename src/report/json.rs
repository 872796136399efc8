//! The JSON documents of `compare --json` (`docs/cli.md`, with extra keys).

use std::path::Path;

use serde::Serialize;

use crate::evaluate::CvScheme;
use crate::evaluate::{Comparison, SigmaKind};
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

/// The JSON document of `diagnose --json`: the diagnosis (contract keys first), and with
/// nothing to diagnose against, the ISO 230-2 figures with the found effects removed.
#[derive(Debug, Serialize)]
pub struct DiagnoseJson<'a> {
    #[serde(flatten)]
    pub diagnosis: &'a crate::diagnose::Diagnosis,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iso230: Option<&'a super::diagnosis::IsoEffect>,
}

/// The JSON document of `replay --json`: the decoder's counts (`rows` among them, the rows
/// written) and the process's resident high-water mark.
#[derive(Debug, Serialize)]
pub struct ReplayJson<'a> {
    #[serde(flatten)]
    pub stats: &'a errmap_drivers::DecoderStats,
    /// MB (Linux; None elsewhere).
    pub peak_rss_mb: Option<f64>,
}

/// One line of `table --json`.
#[derive(Debug, Serialize)]
pub struct TableLineJson<'a> {
    /// With tolerances: the line's conformity (null when no tolerance applies to it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conformity: Option<Option<&'a crate::acceptance::LineConformity>>,
    pub gb_t_17421_2: &'static str,
    pub iso230: &'a crate::session::AxisStats,
    pub line_mm: [f64; 2],
    pub uncertainty: TableUncertaintyJson<'a>,
}

/// A line's uncertainty budget and the expanded uncertainties of its figures.
#[derive(Debug, Serialize)]
pub struct TableUncertaintyJson<'a> {
    pub budget: &'a crate::session::Budget,
    pub expanded: &'a crate::session::StatUncertainty,
}

/// The JSON document of `table --json` (keys in the order they were always printed).
#[derive(Debug, Serialize)]
pub struct TableJson<'a> {
    /// With tolerances: the statement of conformity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conformity: Option<&'a crate::acceptance::Conformity>,
    pub lines: Vec<TableLineJson<'a>>,
    pub nodes: usize,
    pub summary: &'a crate::session::ReductionSummary,
}

/// The document of `table --json` for a reduced session (with the statement of
/// conformity when tolerances were given): the command's and the workbench's.
pub fn table_json<'a>(
    reduced: &'a crate::acquire::Reduced,
    conformity: Option<&'a crate::acceptance::Conformity>,
) -> TableJson<'a> {
    let lines = reduced
        .iso
        .iter()
        .zip(&reduced.budgets)
        .zip(&reduced.expanded)
        .enumerate()
        .map(|(k, (((l, s), budget), expanded))| TableLineJson {
            conformity: conformity.map(|c| c.lines.get(k).and_then(|x| x.1.as_ref())),
            gb_t_17421_2: GB_T_17421_2,
            iso230: s,
            line_mm: [l.0, l.1],
            uncertainty: TableUncertaintyJson { budget, expanded },
        })
        .collect();
    TableJson {
        lines,
        nodes: reduced.table.points.len(),
        summary: &reduced.summary,
        conformity,
    }
}

/// GB/T 17421.2 carries ISO 230-2: the note every `table --json` line holds.
pub const GB_T_17421_2: &str = "same values as iso230 (GB/T 17421.2-2016 carries ISO 230-2)";

/// One point of `volumetric predict --json`: the error vector and its one-sigma.
#[derive(Debug, Serialize)]
pub struct GridPointJson {
    pub ex_um: f64,
    pub ey_um: f64,
    pub ez_um: f64,
    pub sx_um: f64,
    pub sy_um: f64,
    pub sz_um: f64,
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
}

/// The JSON document of `volumetric predict --json`.
#[derive(Debug, Serialize)]
pub struct GridJson {
    pub grid: Vec<GridPointJson>,
}

impl GridJson {
    /// From the points and their (error, one-sigma) vectors.
    pub fn new(points: &[[f64; 3]], errors: &[([f64; 3], [f64; 3])]) -> Self {
        GridJson {
            grid: points
                .iter()
                .zip(errors)
                .map(|(p, (e, s))| GridPointJson {
                    ex_um: e[0],
                    ey_um: e[1],
                    ez_um: e[2],
                    sx_um: s[0],
                    sy_um: s[1],
                    sz_um: s[2],
                    x_mm: p[0],
                    y_mm: p[1],
                    z_mm: p[2],
                })
                .collect(),
        }
    }
}
