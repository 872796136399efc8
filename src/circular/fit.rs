//! The linear least-squares fits of the diagnosis, on the Gram matrix of unit-norm columns
//! (pseudo-inverse by SVD), and the dot products they need, computed once per set of
//! columns: a fit on any subset of a set ([`fit_subset`]) costs O(k·n) for its residual
//! and O(k³) for the rest, instead of O(k²·n), and gives the very numbers a fit computed
//! afresh ([`fit_columns`]) gives, each product being the same sum in the same order.

use nalgebra::{DMatrix, DVector};

/// A linear least-squares fit on a set of columns through their Gram matrix.
pub(super) struct Fit {
    /// Coefficients in the columns' own units.
    pub coef: Vec<f64>,
    pub rss: f64,
    /// (XᵀX)⁻¹ in the columns' own units (pseudo-inverse).
    pub inv: DMatrix<f64>,
    pub rank: usize,
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The dot products of a set of columns with each other and with y.
pub(super) struct Products {
    cc: Vec<Vec<f64>>,
    cy: Vec<f64>,
}

impl Products {
    pub(super) fn of(cols: &[&[f64]], y: &[f64]) -> Products {
        let k = cols.len();
        let mut cc = vec![vec![0.0; k]; k];
        for i in 0..k {
            for j in i..k {
                let v = dot(cols[i], cols[j]);
                cc[i][j] = v;
                cc[j][i] = v;
            }
        }
        Products {
            cc,
            cy: cols.iter().map(|c| dot(c, y)).collect(),
        }
    }

    /// The products of `cols` followed by `extra`, those of `cols` being `self`'s.
    pub(super) fn extended(&self, cols: &[&[f64]], extra: &[&[f64]], y: &[f64]) -> Products {
        let (k, e) = (cols.len(), extra.len());
        let mut cc: Vec<Vec<f64>> = self
            .cc
            .iter()
            .map(|row| {
                let mut r = row.clone();
                r.resize(k + e, 0.0);
                r
            })
            .collect();
        cc.resize(k + e, vec![0.0; k + e]);
        for (a, x) in extra.iter().enumerate() {
            for (i, c) in cols.iter().chain(extra.iter().take(a + 1)).enumerate() {
                let v = dot(c, x);
                cc[i][k + a] = v;
                cc[k + a][i] = v;
            }
        }
        let mut cy = self.cy.clone();
        cy.extend(extra.iter().map(|c| dot(c, y)));
        Products { cc, cy }
    }
}

/// The fit of y on every column.
pub(super) fn fit_columns<C: AsRef<[f64]>>(cols: &[C], y: &[f64]) -> Fit {
    let cols: Vec<&[f64]> = cols.iter().map(|c| c.as_ref()).collect();
    let all: Vec<usize> = (0..cols.len()).collect();
    fit_subset(&cols, &all, &Products::of(&cols, y), y)
}

/// The fit of y on the columns `idx` of `cols` (in that order), `p` their products.
pub(super) fn fit_subset(cols: &[&[f64]], idx: &[usize], p: &Products, y: &[f64]) -> Fit {
    let k = idx.len();
    let norms: Vec<f64> = idx
        .iter()
        .map(|&i| {
            let n = p.cc[i][i].sqrt();
            if n > 1e-300 { n } else { 0.0 }
        })
        .collect();
    let mut g = DMatrix::zeros(k, k);
    let mut b = DVector::zeros(k);
    for i in 0..k {
        if norms[i] == 0.0 {
            continue;
        }
        b[i] = p.cy[idx[i]] / norms[i];
        for j in i..k {
            if norms[j] == 0.0 {
                continue;
            }
            let v = p.cc[idx[i]][idx[j]] / (norms[i] * norms[j]);
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
    }
    let svd = g.svd(true, true);
    let tol = 1e-10 * svd.singular_values.max().max(1e-300);
    let rank = svd.singular_values.iter().filter(|&&s| s > tol).count();
    let pinv = svd
        .pseudo_inverse(tol)
        .unwrap_or_else(|_| DMatrix::zeros(k, k));
    let cs = &pinv * &b;
    let coef: Vec<f64> = (0..k)
        .map(|i| {
            if norms[i] > 0.0 {
                cs[i] / norms[i]
            } else {
                0.0
            }
        })
        .collect();
    // The residual itself, not yᵀy − bᵀc (which cancels badly when the columns are
    // nearly dependent).
    let mut r = y.to_vec();
    for (&i, c) in idx.iter().zip(&coef) {
        if *c != 0.0 {
            for (ri, v) in r.iter_mut().zip(cols[i].iter()) {
                *ri -= c * v;
            }
        }
    }
    let rss = dot(&r, &r);
    let mut inv = pinv;
    for i in 0..k {
        for j in 0..k {
            let s = norms[i] * norms[j];
            inv[(i, j)] = if s > 0.0 { inv[(i, j)] / s } else { 0.0 };
        }
    }
    Fit {
        coef,
        rss,
        inv,
        rank,
    }
}
