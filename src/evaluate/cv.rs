//! Cross-validation on the fitting table alone: leave one grid plane out.
//!
//! Leaving one node out would break the tensor grid, so each fold removes a whole plane
//! of nodes (every node with a given x, or y, or z), fits the method on the rest, and
//! predicts the removed nodes. Every plane of every axis is left out once, end planes
//! included (their prediction is an extrapolation, which is how a model is often used:
//! test points beyond the measured nodes). The interior planes alone are summarised too.
//!
//! A Lagrange degree that the fold's remaining nodes cannot carry (degree d needs d + 1
//! nodes) is lowered to the highest the fold allows, and the folds where that happened
//! are counted: the cross-validated error of "degree 4 through 5 nodes" is then the
//! error of the same recipe — the highest degree the nodes allow — one node short.
//! This is reported beside the number, never hidden.
//!
//! A scattered table (no grid, so no planes) is cross-validated node by node; only the
//! Gaussian process fits one, and [`leave_one_out_gp`] does it in closed form.

use serde::Serialize;

use crate::interp::Gp;
use crate::interp::{InterpError, Method, Order};
use crate::table::{Axis, Grid};

pub(crate) use crate::base::rms;

/// How the fitting table was split.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CvScheme {
    /// Each fold leaves one grid plane out and refits ([`leave_one_plane_out`]).
    LeaveOnePlaneOut,
    /// Each fold leaves one node out, hyperparameters held ([`leave_one_out_gp`]).
    LeaveOneOut,
}

impl CvScheme {
    /// Words for reports: "leave-one-plane-out".
    pub fn label(self) -> &'static str {
        match self {
            CvScheme::LeaveOnePlaneOut => "leave-one-plane-out",
            CvScheme::LeaveOneOut => "leave-one-out",
        }
    }
}

/// Cross-validation result for one method.
#[derive(Debug, Clone, Serialize)]
pub struct CvResult {
    pub scheme: CvScheme,
    /// RMS of (prediction − node value) over every held-out node of every fold, µm.
    pub rms_um: f64,
    pub max_abs_um: f64,
    /// RMS over the folds that left out an interior plane only (None without any).
    pub interior_rms_um: Option<f64>,
    /// RMS over the folds that left out an end plane only: predictions beyond the
    /// remaining nodes (None without any).
    pub exterior_rms_um: Option<f64>,
    /// RMS per axis along which planes were left out (x, y, z).
    pub axis_rms_um: [Option<f64>; 3],
    pub folds: usize,
    /// Folds in which a Lagrange degree had to be lowered to fit the remaining nodes.
    pub capped_folds: usize,
    pub predictions: usize,
}

/// Runs leave-one-plane-out cross-validation. Axes with a single node are skipped.
pub fn leave_one_plane_out(grid: &Grid, method: &Method) -> Result<CvResult, InterpError> {
    let shape = grid.shape();
    let mut all = Vec::new();
    let mut interior = Vec::new();
    let mut exterior = Vec::new();
    let mut per_axis: [Vec<f64>; 3] = Default::default();
    let (mut folds, mut capped_folds) = (0, 0);
    for axis in Axis::ALL {
        let a = axis.index();
        if shape[a] < 2 {
            continue;
        }
        for plane in 0..shape[a] {
            let fold = grid.without_plane(a, plane);
            let fold_method = match method {
                Method::Lagrange(Order(o)) => {
                    let mut o2 = *o;
                    for (b, d) in o2.iter_mut().enumerate() {
                        *d = (*d).min(fold.axis(b).len() - 1);
                    }
                    if o2 != *o {
                        capped_folds += 1;
                    }
                    Method::Lagrange(Order(o2))
                }
                m => *m,
            };
            let model = fold_method.fit(&fold)?;
            folds += 1;
            let is_interior = plane > 0 && plane + 1 < shape[a];
            let [nx, ny, _] = shape;
            for (idx, p) in grid.points().iter().enumerate() {
                // points() runs x fastest, like the grid's values.
                let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
                if ijk[a] != plane {
                    continue;
                }
                let r = model.predict(p.position()) - p.e_um;
                all.push(r);
                per_axis[a].push(r);
                if is_interior {
                    interior.push(r);
                } else {
                    exterior.push(r);
                }
            }
        }
    }
    Ok(CvResult {
        scheme: CvScheme::LeaveOnePlaneOut,
        rms_um: rms(&all).unwrap_or(f64::NAN),
        max_abs_um: all.iter().fold(0.0, |m, r| m.max(r.abs())),
        interior_rms_um: rms(&interior),
        exterior_rms_um: rms(&exterior),
        axis_rms_um: [rms(&per_axis[0]), rms(&per_axis[1]), rms(&per_axis[2])],
        folds,
        capped_folds,
        predictions: all.len(),
    })
}

impl CvResult {
    /// The cross-validated one-sigma of a prediction: the RMS of held-out predictions
    /// like it — interior planes for a point inside the nodes, end planes for an
    /// extrapolation — falling back to the overall RMS. `None` when nothing was held out.
    pub fn sigma(&self, outside: bool) -> Option<f64> {
        let like = if outside {
            self.exterior_rms_um
        } else {
            self.interior_rms_um
        };
        like.or(Some(self.rms_um)).filter(|s| s.is_finite())
    }
}

/// Leave-one-out cross-validation of a Gaussian process on its own nodes, for scattered
/// tables where there are no planes to leave out: every node is predicted from all the
/// others in closed form ([`Gp::leave_one_out`]), the hyperparameters held at their fit
/// to all nodes (so the error is slightly optimistic; refitting them per fold would cost
/// n full fits). `values` are the fitted errors in fit order.
pub(crate) fn leave_one_out_gp(gp: &Gp, values: &[f64]) -> CvResult {
    let r: Vec<f64> = gp
        .leave_one_out()
        .iter()
        .zip(values)
        .map(|((m, _), y)| m - y)
        .collect();
    CvResult {
        scheme: CvScheme::LeaveOneOut,
        rms_um: rms(&r).unwrap_or(f64::NAN),
        max_abs_um: r.iter().fold(0.0, |m, v| m.max(v.abs())),
        interior_rms_um: None,
        exterior_rms_um: None,
        axis_rms_um: [None; 3],
        folds: r.len(),
        capped_folds: 0,
        predictions: r.len(),
    }
}
