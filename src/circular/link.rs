//! Two instruments, one machine: the circle an identified volumetric model (MODEL.json
//! from `volumetric identify --out`, or a machine-model TOML) implies in the test's plane,
//! and its difference from what the ballbar found.
//!
//! The model's error vector E is predicted (through `volumetric::Predictor`, its public
//! API) at the commanded circle's points, centre `centre_mm` of the test's TOML; the bar
//! would read dr = E_A·cos θ + E_B·sin θ. That predicted trace is fitted with the setup
//! terms and the geometric effects a volumetric model holds — squareness, scale
//! mismatch, straightness of each axis — in this module's sign conventions, so the two
//! instruments are compared in one convention whatever the model's own.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::diagnose::CircularDiagnosis;
use super::effects::CircularId;
use super::error::CircularError;
use super::input::TestMeta;
use super::signature::{Geometry, Point, Slot, setup_columns};
use crate::base::Axis;
use crate::base::ParamName;
use crate::volumetric::{Predictor, Undetermined, VolumetricError};

/// One geometric term: predicted by the volumetric model, measured by the ballbar.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkRow {
    pub id: CircularId,
    pub axis: String,
    #[serde(serialize_with = "param_name")]
    pub param: ParamName,
    pub predicted: f64,
    /// `None` when the ballbar did not find the effect significant.
    pub measured: Option<f64>,
    pub measured_sigma: Option<f64>,
    /// measured − predicted (0 measured when not significant).
    pub difference: f64,
}

/// The comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Link {
    pub model: PathBuf,
    pub centre_mm: [f64; 3],
    pub rows: Vec<LinkRow>,
    /// rms of the predicted trace after the setup terms, µm.
    pub predicted_rms_um: f64,
}

const TERMS: [(CircularId, Slot, ParamName); 4] = [
    (CircularId::Squareness, Slot::Plane, ParamName::Urad),
    (CircularId::ScaleMismatch, Slot::Plane, ParamName::Ppm),
    (CircularId::Straightness, Slot::A, ParamName::BowUm),
    (CircularId::Straightness, Slot::B, ParamName::BowUm),
];

/// A point of the circle may lie this far outside an identified model's measured range,
/// mm (as for a gauge of the predicted ISO 10360-2 test).
pub(crate) const RANGE_TOL_MM: f64 = 1e-3;

/// The points of the test's circle at angles θ (rad) about `centre_mm`, machine coordinates.
fn circle_points(meta: &TestMeta, centre_mm: [f64; 3], thetas: &[f64]) -> Vec<[f64; 3]> {
    let (a, b) = meta.plane.axes();
    let (ia, ib) = (a.index(), b.index());
    thetas
        .iter()
        .map(|&th| {
            let mut p = centre_mm;
            p[ia] += meta.radius_mm * th.cos();
            p[ib] += meta.radius_mm * th.sin();
            p
        })
        .collect()
}

/// Why the link could not be made from a volumetric model (the file is named by
/// [`CircularError::Link`]).
#[derive(Debug, thiserror::Error)]
pub enum LinkProblem {
    /// The model file could not be read.
    #[error(transparent)]
    Model(VolumetricError),
    /// The test's circle leaves the identified model's measured range.
    #[error(
        "the test's circle reaches ({}, {}, {}) mm, outside the model's measured range \
         of {axis} [{}, {}] mm: a prediction there is an extrapolation (move centre_mm or \
         measure the volume the circle covers)",
        .point_mm[0], .point_mm[1], .point_mm[2], .range_mm[0], .range_mm[1]
    )]
    OutOfRange {
        point_mm: [f64; 3],
        axis: Axis,
        range_mm: [f64; 2],
    },
    /// The identified model cannot give the error vector.
    #[error(transparent)]
    Undetermined(Undetermined),
    /// The setup terms could not be solved for.
    #[error("{0}")]
    Solve(&'static str),
}

/// Refuses a circle that leaves an identified model's measured range (a prediction there
/// is an extrapolation its σ does not cover); a machine model holds everywhere.
fn check_in_range(predictor: &Predictor, pts: &[[f64; 3]]) -> Result<(), LinkProblem> {
    let Predictor::Fit(fit) = predictor else {
        return Ok(());
    };
    let range = fit.basis.range_mm;
    for p in pts {
        if let Some(axis) = Axis::ALL.into_iter().find(|a| {
            let k = a.index();
            p[k] < range[k][0] - RANGE_TOL_MM || p[k] > range[k][1] + RANGE_TOL_MM
        }) {
            return Err(LinkProblem::OutOfRange {
                point_mm: *p,
                axis,
                range_mm: range[axis.index()],
            });
        }
    }
    Ok(())
}

/// The predicted radial trace at angles θ (rad) of the test's circle.
pub(crate) fn predicted_trace(
    predictor: &Predictor,
    meta: &TestMeta,
    centre_mm: [f64; 3],
    thetas: &[f64],
) -> Result<Vec<f64>, LinkProblem> {
    let (a, b) = meta.plane.axes();
    let (ia, ib) = (a.index(), b.index());
    let pts = circle_points(meta, centre_mm, thetas);
    check_in_range(predictor, &pts)?;
    let e = predictor
        .predict_grid(&pts, [0.0; 3])
        .map_err(LinkProblem::Undetermined)?;
    Ok(thetas
        .iter()
        .zip(&e)
        .map(|(&th, (v, _))| v[ia] * th.cos() + v[ib] * th.sin())
        .collect())
}

/// Compares the model at `path` with a diagnosis of the test `meta` describes.
pub fn link(
    path: &Path,
    meta: &TestMeta,
    centre_mm: [f64; 3],
    diagnosis: &CircularDiagnosis,
) -> Result<Link, CircularError> {
    let err = |problem: LinkProblem| CircularError::Link {
        path: path.to_path_buf(),
        problem,
    };
    let predictor = Predictor::read(path).map_err(|e| err(LinkProblem::Model(e)))?;
    let (lo, _) = meta.arc_deg_range();
    let thetas: Vec<f64> = (0..=720)
        .map(|k| (lo + meta.arc_deg * k as f64 / 720.0).to_radians())
        .collect();
    let dr = predicted_trace(&predictor, meta, centre_mm, &thetas).map_err(err)?;
    let g = Geometry::of(meta);
    let pts: Vec<Point> = thetas
        .iter()
        .map(|&theta| Point::at(theta, 1.0, 0.0, 0.0))
        .collect();
    let mut cols: Vec<Vec<f64>> = (0..3)
        .map(|k| pts.iter().map(|p| setup_columns(p)[k]).collect())
        .collect();
    for (id, slot, _) in TERMS {
        let columns = id.kind().columns;
        cols.push(pts.iter().map(|p| columns(slot, 0.0, p, &g)[0]).collect());
    }
    let k = cols.len();
    let ata = nalgebra::DMatrix::from_fn(k, k, |i, j| {
        cols[i]
            .iter()
            .zip(&cols[j])
            .map(|(a, b)| a * b)
            .sum::<f64>()
    });
    let atb = nalgebra::DVector::from_fn(k, |i, _| {
        cols[i].iter().zip(&dr).map(|(a, b)| a * b).sum::<f64>()
    });
    let coef = ata
        .clone()
        .svd(true, true)
        .solve(&atb, 1e-12)
        .map_err(|e| err(LinkProblem::Solve(e)))?;
    let mut resid = dr.clone();
    for (c, col) in coef.iter().take(3).zip(&cols) {
        for (r, v) in resid.iter_mut().zip(col) {
            *r -= c * v;
        }
    }
    let predicted_rms_um =
        (resid.iter().map(|r| r * r).sum::<f64>() / resid.len().max(1) as f64).sqrt();
    let rows = TERMS
        .iter()
        .enumerate()
        .map(|(i, &(id, slot, param))| {
            let found = diagnosis
                .effects
                .iter()
                .find(|e| e.effect.id() == id && e.axis.slot == slot);
            let measured = found.and_then(|e| e.effect.number(param));
            let predicted = coef[3 + i];
            LinkRow {
                id,
                axis: slot.label(meta.plane),
                param,
                predicted,
                measured,
                measured_sigma: found.and_then(|e| e.sigma(param)),
                difference: measured.unwrap_or(0.0) - predicted,
            }
        })
        .collect();
    Ok(Link {
        model: path.to_path_buf(),
        centre_mm,
        rows,
        predicted_rms_um,
    })
}

fn param_name<S: serde::Serializer>(p: &ParamName, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.as_str())
}
