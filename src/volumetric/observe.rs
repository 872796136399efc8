//! The hook for other kinds of observation of the same model (artefact feature centres,
//! the artefact stage): a caller builds rows that see the error vector along a direction
//! ([`super::Basis::line_row`], −u·E as a laser line) plus columns of its own (placements,
//! artefact deviations), and fits them with the line fit's pieces: the equilibrated SVD
//! with its rank rule and null space, the identified-component rule, and the residual's
//! chi-square test. The result is an [`super::Identification`], so `model.json` is the
//! same document as `volumetric identify --out` writes.

use nalgebra::DMatrix;

use super::basis::Basis;

/// The SVD of an equilibrated design on its determined subspace: (V_range, singular
/// values, U_range, null basis). Singular values at or below `rel_tol` × the largest
/// count as null (the line fit uses `RANK_TOL` = 1e−8; a design with barely more rows
/// than unknowns needs a wider gap for an accurate null basis).
pub fn decompose_design(
    a: &DMatrix<f64>,
    rel_tol: f64,
) -> (DMatrix<f64>, Vec<f64>, DMatrix<f64>, DMatrix<f64>) {
    let d = super::identify::decompose(a);
    let smax = d.sv_range.iter().cloned().fold(0.0, f64::max);
    let keep: Vec<usize> = (0..d.sv_range.len())
        .filter(|&k| d.sv_range[k] > rel_tol * smax)
        .collect();
    let drop: Vec<usize> = (0..d.sv_range.len())
        .filter(|k| !keep.contains(k))
        .collect();
    let n = a.ncols();
    let mut null_cols: Vec<nalgebra::DVector<f64>> = drop
        .iter()
        .map(|&k| d.v_range.column(k).into_owned())
        .collect();
    null_cols.extend(d.null.column_iter().map(|c| c.into_owned()));
    let null = if null_cols.is_empty() {
        DMatrix::zeros(n, 0)
    } else {
        DMatrix::from_columns(&null_cols)
    };
    (
        DMatrix::from_fn(n, keep.len(), |i, k| d.v_range[(i, keep[k])]),
        keep.iter().map(|&k| d.sv_range[k]).collect(),
        DMatrix::from_fn(a.nrows(), keep.len(), |i, k| d.u_range[(i, keep[k])]),
        null,
    )
}

/// Which of the 21 components a null space (rows = the basis' parameters first, in
/// equilibrated coordinates) leaves determined: all of a component's rows below the
/// line fit's tolerance.
pub fn identified_components(basis: &Basis, null: &DMatrix<f64>) -> Vec<bool> {
    super::identify::identified_flags(basis, null)
}

/// Wilson–Hilferty z of a chi-square against its degrees of freedom (the line fit's
/// residual test; `missing_physics` above [`super::Z_MISSING`]).
pub fn chi_square_z(chi2: f64, dof: f64) -> f64 {
    let h = 2.0 / (9.0 * dof);
    ((chi2 / dof).cbrt() - (1.0 - h)) / h.sqrt()
}
