//! The volumetric grid export ([`render`]): the model sampled over a box as rows of
//! `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`, x fastest, the same columns as the
//! [`csv`](mod@super::csv) line export. Pure: no files, no polars; the caller writes the rows
//! ([`write_grid`](super::write_grid) writes them as CSV or Parquet).

use super::{
    ExportError, Extrapolation, MAX_SAMPLES, VolumeSpec, axis_positions, compensation_um, evaluate,
};
use crate::interp::Interpolator;
use crate::table::Axis;

/// The rows of a volumetric grid export, one per sample point: x fastest, then y, then z.
#[derive(Debug, Clone, PartialEq)]
pub struct GridRows {
    /// The sample points [x, y, z], mm.
    pub points_mm: Vec<[f64; 3]>,
    /// Predicted error e = indicated − reference at each point, µm.
    pub error_um: Vec<f64>,
    /// Whether each point lies outside the model's nodes.
    pub extrapolated: Vec<bool>,
}

impl GridRows {
    pub fn len(&self) -> usize {
        self.points_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points_mm.is_empty()
    }

    /// The compensation c = −e at each point, µm.
    pub fn comp_um(&self) -> Vec<f64> {
        self.error_um.iter().map(|&e| compensation_um(e)).collect()
    }
}

/// Samples the model over a box, x fastest. Refuses more than [`MAX_SAMPLES`] points.
/// Cost: N predictions.
pub(super) fn render(
    model: &dyn Interpolator,
    spec: &VolumeSpec,
    extrapolation: Extrapolation,
) -> Result<GridRows, ExportError> {
    let mut axes: [Vec<f64>; 3] = Default::default();
    for axis in Axis::ALL {
        let a = axis.index();
        axes[a] = axis_positions(axis, spec.lo_mm[a], spec.hi_mm[a], spec.spacing_mm, true)?;
    }
    let total = axes.iter().map(|v| v.len() as u128).product::<u128>();
    if total > MAX_SAMPLES as u128 {
        return Err(ExportError::TooManyPoints {
            points: total,
            limit: MAX_SAMPLES,
        });
    }
    let [xs, ys, zs] = &axes;
    let mut points = Vec::with_capacity(total as usize);
    for &z in zs {
        for &y in ys {
            for &x in xs {
                points.push([x, y, z]);
            }
        }
    }
    let (error_um, flags) = evaluate(model, &points, extrapolation)?;
    Ok(GridRows {
        points_mm: points,
        error_um,
        extrapolated: flags,
    })
}
