//! The linearised design of a campaign: one row per observed coordinate of a measured
//! feature, columns for the 21 errors (the volumetric basis, cubic polynomials), each
//! position's placement correction and each artefact's deviations; prior rows for
//! certified coordinates; and the constraints that fix what the data cannot (a
//! self-calibrated artefact's rigid motion, the invariants).

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::files::{Artefact, Campaign, Kind, Measurement, Position};
use super::placement::{Placement, col, observed_directions};
use crate::volumetric::{Basis, LineTable};

/// Where each group of unknowns starts.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    /// Machine parameters (the basis').
    pub n_m: usize,
    /// Per position: first placement column and count.
    pub place: Vec<(usize, usize)>,
    /// Laser lines of a joint fit: first column of their free constants (one a line)
    /// and their count.
    pub lines: (usize, usize),
    /// Per artefact: first deviation column (features × observed coordinates), if its
    /// deviations are unknowns.
    pub dev: Vec<Option<usize>>,
    pub n: usize,
}

/// What a position's placement correction moves: rotations about artefact-frame axes
/// (µrad) and translations along machine directions (µm).
pub(crate) fn placement_params(kind: Kind, r: &Matrix3<f64>) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    match kind {
        Kind::BallPlate => (vec![x, y, z], vec![x, y, z]),
        Kind::BallBeam => (vec![y, z], vec![x, y, z]),
        Kind::HolePlate => (vec![z], vec![col(r, 0), col(r, 1)]),
        Kind::StepGauge => (Vec::new(), vec![col(r, 0)]),
    }
}

/// Observed artefact coordinates of a kind (indices 0..3).
pub(crate) fn observed_coords(kind: Kind) -> Vec<usize> {
    (0..3).filter(|&j| kind.observes()[j]).collect()
}

impl Layout {
    pub(crate) fn new(
        basis: &Basis,
        campaign: &Campaign,
        dev_free: &[bool],
        n_lines: usize,
    ) -> Layout {
        let n_m = basis.n_params();
        let mut n = n_m;
        let mut place = Vec::new();
        for pos in &campaign.positions {
            let kind = campaign.artefacts[pos.artefact].kind;
            let (rot, tr) = placement_params(kind, &Matrix3::identity());
            place.push((n, rot.len() + tr.len()));
            n += rot.len() + tr.len();
        }
        let lines = (n, n_lines);
        n += n_lines;
        let mut dev = Vec::new();
        for (a, art) in campaign.artefacts.iter().enumerate() {
            if dev_free[a] {
                dev.push(Some(n));
                n += art.features.len() * observed_coords(art.kind).len();
            } else {
                dev.push(None);
            }
        }
        Layout {
            n_m,
            place,
            lines,
            dev,
            n,
        }
    }

    /// Column of artefact `a`'s feature `i`, observed coordinate number `j` (0-based
    /// among the observed ones).
    pub(crate) fn dev_col(
        &self,
        campaign: &Campaign,
        a: usize,
        i: usize,
        j: usize,
    ) -> Option<usize> {
        let per = observed_coords(campaign.artefacts[a].kind).len();
        self.dev[a].map(|o| o + i * per + j)
    }
}

/// One observed coordinate.
#[derive(Debug, Clone)]
pub(crate) struct Row {
    pub position: usize,
    /// Index into the position's measurement rows.
    pub meas_row: usize,
    pub coef: Vec<f64>,
    /// Observed − rigid placement, µm (along the row's direction).
    pub value_um: f64,
    pub sigma_um: f64,
}

/// Which geometry a position's rows are built on.
#[derive(Debug, Clone, Copy)]
pub(crate) enum View<'a> {
    /// The fit: the fitted orientation, the components at the measured axis positions.
    Fitted,
    /// The observability analysis: the artefact exactly in the given nominal orientation
    /// R0 at the placement's translation t, every feature at its nominal place R0·f + t. The
    /// design is then exactly what the geometry allows: a null direction (an invariant, a
    /// component the positions cannot see) is null to rounding whatever the machine's
    /// errors. Built on the measured places instead, each such direction is lifted by
    /// the errors' size against the range (µm over hundreds of mm, ~10⁻⁶ relative)
    /// to where the rank rule's threshold decides it, and whether it is found depends
    /// on how the basis scales its columns.
    Nominal(&'a Matrix3<f64>),
}

/// The rows of one position on `view`'s geometry; `fitted` is the rigid placement the
/// values are taken against.
pub(crate) fn position_rows(
    basis: &Basis,
    layout: &Layout,
    campaign: &Campaign,
    k: usize,
    meas: &Measurement,
    view: View,
    fitted: &Placement,
) -> Vec<Row> {
    let pos: &Position = &campaign.positions[k];
    let art: &Artefact = &campaign.artefacts[pos.artefact];
    let r_design = match view {
        View::Fitted => &fitted.r,
        View::Nominal(r0) => r0,
    };
    let (rot, tr) = placement_params(art.kind, r_design);
    let dirs = observed_directions(art.kind, r_design);
    let coords = observed_coords(art.kind);
    let (p0, _) = layout.place[k];
    let p = Vector3::from(pos.probe_mm);
    let mut rows = Vec::with_capacity(meas.rows.len() * dirs.len());
    for (mi, m) in meas.rows.iter().enumerate() {
        let f = Vector3::from(art.at_temp_mm(m.feature, pos.temp_c));
        let x = Vector3::from(m.x_mm);
        let a = match view {
            View::Fitted => x - p,
            View::Nominal(r0) => r0 * f + fitted.t_mm - p,
        };
        let resid = x - Vector3::from(fitted.apply(f.into()));
        for u in dirs.iter() {
            let uv = Vector3::from(*u);
            let mut coef = vec![0.0; layout.n];
            let g = basis.line_row(a.into(), *u, pos.probe_mm);
            coef[..layout.n_m].copy_from_slice(&g);
            for (q, w) in rot.iter().enumerate() {
                let moved = r_design * Vector3::from(*w).cross(&f);
                coef[p0 + q] = 1e-3 * uv.dot(&moved);
            }
            for (q, v) in tr.iter().enumerate() {
                coef[p0 + rot.len() + q] = uv.dot(&Vector3::from(*v));
            }
            for (jj, &c) in coords.iter().enumerate() {
                if let Some(cc) = layout.dev_col(campaign, pos.artefact, m.feature, jj) {
                    coef[cc] = uv.dot(&r_design.column(c).into_owned());
                }
            }
            rows.push(Row {
                position: k,
                meas_row: mi,
                coef,
                value_um: 1000.0 * uv.dot(&resid),
                sigma_um: pos.sigma_um,
            });
        }
    }
    rows
}

/// The rows of a joint fit's laser lines, line `l` numbered `first + l` (past the
/// campaign's positions): each target's reading e = −u·E(a; p) + c_l, c_l the line's free
/// constant, as the volumetric line fit models it; weighted by the target's `s_um`.
pub(crate) fn laser_rows(
    basis: &Basis,
    layout: &Layout,
    table: &LineTable,
    first: usize,
) -> Vec<Row> {
    let mut rows = Vec::with_capacity(table.targets());
    for (l, line) in table.lines.iter().enumerate() {
        for (i, t) in line.targets.iter().enumerate() {
            let mut coef = vec![0.0; layout.n];
            coef[..layout.n_m].copy_from_slice(&basis.line_row(t.pos_mm, line.u, line.probe_mm));
            coef[layout.lines.0 + l] = 1.0;
            rows.push(Row {
                position: first + l,
                meas_row: i,
                coef,
                value_um: t.e_um.unwrap_or(0.0),
                sigma_um: t.s_um.unwrap_or(1.0),
            });
        }
    }
    rows
}

/// Certificate priors: each certified deviation N(0, (u/2)²).
pub(crate) fn prior_rows(campaign: &Campaign, layout: &Layout) -> Vec<(usize, f64)> {
    let mut out = Vec::new();
    for (a, art) in campaign.artefacts.iter().enumerate() {
        if layout.dev[a].is_none() || !art.certified() {
            continue;
        }
        for (i, f) in art.features.iter().enumerate() {
            let u = f.u_um.unwrap_or(1.0);
            for j in 0..observed_coords(art.kind).len() {
                if let Some(c) = layout.dev_col(campaign, a, i, j) {
                    out.push((c, u / 2.0));
                }
            }
        }
    }
    out
}

/// The weighted design matrix and right-hand side: data rows then prior rows.
pub(crate) fn weighted(
    rows: &[Row],
    priors: &[(usize, f64)],
    n: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let m = rows.len() + priors.len();
    let mut a = DMatrix::zeros(m, n);
    let mut b = DVector::zeros(m);
    for (i, r) in rows.iter().enumerate() {
        let w = 1.0 / r.sigma_um;
        for (j, c) in r.coef.iter().enumerate() {
            if *c != 0.0 {
                a[(i, j)] = w * c;
            }
        }
        b[i] = w * r.value_um;
    }
    for (k, (c, s)) in priors.iter().enumerate() {
        a[(rows.len() + k, *c)] = 1.0 / s;
    }
    (a, b)
}

/// The rigid-motion patterns of a self-calibrated artefact's deviations (translations
/// and rotations restricted to the coordinates it observes), as full-length vectors.
pub(crate) fn rigid_patterns(campaign: &Campaign, layout: &Layout, a: usize) -> Vec<DVector<f64>> {
    let art = &campaign.artefacts[a];
    let coords = observed_coords(art.kind);
    let mut out = Vec::new();
    let unit = |j: usize| {
        let mut v = Vector3::zeros();
        v[j] = 1.0;
        v
    };
    for m in 0..6 {
        let mut v = DVector::zeros(layout.n);
        for i in 0..art.features.len() {
            let f = Vector3::from(art.reference_mm(i));
            let d = if m < 3 {
                unit(m)
            } else {
                unit(m - 3).cross(&f)
            };
            for (jj, &c) in coords.iter().enumerate() {
                if let Some(cc) = layout.dev_col(campaign, a, i, jj) {
                    v[cc] = d[c];
                }
            }
        }
        if v.norm() > 1e-12 {
            out.push(v);
        }
    }
    out
}

/// An orthonormal basis of the complement of `constraints` (vectors of length n, zero
/// before `from`): the columns Z with x = Z·y satisfying every constraint exactly; the
/// first `from` coordinates map to themselves.
pub(crate) fn complement(n: usize, from: usize, constraints: &[DVector<f64>]) -> DMatrix<f64> {
    let m = n - from;
    let mut z = DMatrix::zeros(n, 0);
    let mut keep_cols: Vec<DVector<f64>> = (0..from)
        .map(|i| {
            let mut v = DVector::zeros(n);
            v[i] = 1.0;
            v
        })
        .collect();
    if m > 0 {
        let sub: Vec<DVector<f64>> = constraints
            .iter()
            .map(|c| c.rows(from, m).into_owned())
            .collect();
        let mut proj = DMatrix::identity(m, m);
        if !sub.is_empty() {
            let c = DMatrix::from_columns(&sub);
            let svd = c.svd(true, false);
            let u = svd.u.unwrap_or_else(|| DMatrix::zeros(m, 0));
            let smax = svd.singular_values.max();
            for (k, s) in svd.singular_values.iter().enumerate() {
                if *s > 1e-10 * smax {
                    let q = u.column(k);
                    proj -= q * q.transpose();
                }
            }
        }
        let e = proj.symmetric_eigen();
        for i in 0..m {
            if e.eigenvalues[i] > 0.5 {
                let mut v = DVector::zeros(n);
                v.rows_mut(from, m).copy_from(&e.eigenvectors.column(i));
                keep_cols.push(v);
            }
        }
    }
    if !keep_cols.is_empty() {
        z = DMatrix::from_columns(&keep_cols);
    }
    z
}
