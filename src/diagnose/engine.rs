//! Weighted linear least squares over a registry of regressor columns, through memoised
//! cross products.
//!
//! Every column is registered once; the weighted cross products Σ w·a·b of the pairs a fit
//! needs are computed once (one O(n) pass per pair) and kept as per-fold sums, so a fit of
//! any subset of columns costs O(k³) and leave-one-fold-out cross-validation costs
//! O(folds · k³), without another pass over the rows. Trial columns (a candidate period or
//! time constant) are not registered: [`Engine::fit_with`] takes them for one fit, O(n·k).
//!
//! **Static map (recorded-only diagnosis).** With a `group` per row given to [`Engine::new`] every row
//! belongs to a group of the static map (one mean per line, target and direction) whose
//! levels are nuisance parameters: y and every column are replaced by their deviations
//! from their weighted group means (the within transform), so by Frisch–Waugh–Lovell a
//! fit on them gives the same effect coefficients as a joint fit with one free constant
//! per group. A column that the map absorbs (its deviations below 1e−10 of its weighted
//! norm) is stored as zeros and set aside as dependent.
//!
//! The normal equations are solved in normalised form (unit diagonal) by a Cholesky
//! factorisation that walks the columns in the order given and sets aside every column
//! whose part not explained by the columns before it is below [`DEPENDENT_TOL`] of its
//! norm (1 − R² < 1e−10): the rank and the dependent columns of a design come out of the
//! same factorisation that solves it.

use std::collections::HashMap;

/// A column is dependent on the ones before it when 1 − R² is below this.
pub(crate) const DEPENDENT_TOL: f64 = 1e-10;

/// The constant column's id.
pub(crate) const CONST: usize = 0;

#[derive(Debug, Clone)]
struct Sums {
    total: f64,
    folds: Vec<f64>,
}

/// The registry and its memo.
#[derive(Debug)]
pub(crate) struct Engine {
    n: usize,
    y: Vec<f64>,
    w: Vec<f64>,
    fold: Vec<usize>,
    nfolds: usize,
    cols: Vec<Vec<f64>>,
    memo: HashMap<(usize, usize), Sums>,
    memo_y: HashMap<usize, Sums>,
    yy: Sums,
    /// The static map's groups (None: no map).
    map: Option<MapGroups>,
}

/// One weighted least-squares solution.
#[derive(Debug, Clone)]
pub(crate) struct Fit {
    /// Coefficient per input column (0 for a dependent one).
    pub coef: Vec<f64>,
    /// Whether each input column was kept as independent.
    pub independent: Vec<bool>,
    /// Weighted residual sum of squares.
    pub chi2: f64,
    /// Number of independent columns.
    pub rank: usize,
    /// (XᵀWX)⁻¹ over the input columns (zero rows/columns for dependent ones).
    pub cov: Vec<Vec<f64>>,
}

/// Leave-one-fold-out result.
#[derive(Debug, Clone)]
pub(crate) struct Cv {
    /// Mean held-out weighted squared error (Σ w·e² / n).
    pub mse: f64,
    /// Coefficients fitted without each fold, per fold, per input column.
    pub coefs: Vec<Vec<f64>>,
}

impl Engine {
    /// A registry for the data `y` with weights `w` and folds; `y` is used as given, or
    /// relative to a static map when `group` gives every row's group (see the module
    /// docs).
    pub(super) fn new(
        mut y: Vec<f64>,
        w: Vec<f64>,
        fold: Vec<usize>,
        nfolds: usize,
        group: Option<MapGroups>,
    ) -> Self {
        let map = group;
        if let Some(m) = &map {
            m.apply(&mut y, &w);
        }
        let n = y.len();
        let mut yy = Sums {
            total: 0.0,
            folds: vec![0.0; nfolds],
        };
        for k in 0..n {
            let v = w[k] * y[k] * y[k];
            yy.total += v;
            yy.folds[fold[k]] += v;
        }
        let mut e = Engine {
            n,
            y,
            w,
            fold,
            nfolds,
            cols: Vec::new(),
            memo: HashMap::new(),
            memo_y: HashMap::new(),
            yy,
            map,
        };
        e.add(vec![1.0; n]);
        e
    }

    pub(super) fn n(&self) -> usize {
        self.n
    }

    pub(super) fn y(&self) -> &[f64] {
        &self.y
    }

    pub(super) fn w(&self) -> &[f64] {
        &self.w
    }

    pub(super) fn col(&self, id: usize) -> &[f64] {
        &self.cols[id]
    }

    /// Number of static-map groups beyond the constant (0 without a map): parameters
    /// the within transform has absorbed, for the degrees of freedom.
    pub(super) fn absorbed(&self) -> usize {
        self.map.as_ref().map_or(0, MapGroups::absorbed)
    }

    /// `v` relative to the static map (unchanged without one).
    pub(super) fn project(&self, mut v: Vec<f64>) -> Vec<f64> {
        if let Some(m) = &self.map {
            let before: f64 = v.iter().zip(&self.w).map(|(a, w)| w * a * a).sum();
            m.apply(&mut v, &self.w);
            let after: f64 = v.iter().zip(&self.w).map(|(a, w)| w * a * a).sum();
            if after <= 1e-10 * before {
                v.iter_mut().for_each(|a| *a = 0.0);
            }
        }
        v
    }

    /// Registers a column (length n) and returns its id.
    pub(super) fn add(&mut self, v: Vec<f64>) -> usize {
        debug_assert_eq!(v.len(), self.n);
        let v = self.project(v);
        self.cols.push(v);
        self.cols.len() - 1
    }

    fn pair(&mut self, i: usize, j: usize) -> &Sums {
        let key = (i.min(j), i.max(j));
        if !self.memo.contains_key(&key) {
            let (a, b) = (&self.cols[key.0], &self.cols[key.1]);
            let mut s = Sums {
                total: 0.0,
                folds: vec![0.0; self.nfolds],
            };
            for k in 0..self.n {
                s.folds[self.fold[k]] += self.w[k] * a[k] * b[k];
            }
            s.total = s.folds.iter().sum();
            self.memo.insert(key, s);
        }
        &self.memo[&key]
    }

    fn with_y(&mut self, i: usize) -> &Sums {
        if !self.memo_y.contains_key(&i) {
            let a = &self.cols[i];
            let mut s = Sums {
                total: 0.0,
                folds: vec![0.0; self.nfolds],
            };
            for k in 0..self.n {
                s.folds[self.fold[k]] += self.w[k] * a[k] * self.y[k];
            }
            s.total = s.folds.iter().sum();
            self.memo_y.insert(i, s);
        }
        &self.memo_y[&i]
    }

    /// Weighted least squares on the registered columns `ids` (in this order).
    pub(super) fn fit(&mut self, ids: &[usize]) -> Fit {
        self.fit_with(ids, &[])
    }

    /// Weighted least squares on the registered columns `ids` followed by the unregistered
    /// trial columns `extra` (each of length n).
    pub(super) fn fit_with(&mut self, ids: &[usize], extra: &[&[f64]]) -> Fit {
        let projected: Vec<Vec<f64>>;
        let extra: Vec<&[f64]> = if self.map.is_some() {
            projected = extra.iter().map(|c| self.project(c.to_vec())).collect();
            projected.iter().map(Vec::as_slice).collect()
        } else {
            extra.to_vec()
        };
        let extra = extra.as_slice();
        let k0 = ids.len();
        let k = k0 + extra.len();
        let mut g = vec![vec![0.0; k]; k];
        let mut gy = vec![0.0; k];
        for a in 0..k0 {
            for b in a..k0 {
                let v = self.pair(ids[a], ids[b]).total;
                g[a][b] = v;
                g[b][a] = v;
            }
            gy[a] = self.with_y(ids[a]).total;
        }
        if !extra.is_empty() {
            let (w, y) = (&self.w, &self.y);
            for (e, col) in extra.iter().enumerate() {
                let p = k0 + e;
                let mut cross = vec![0.0; k0];
                let (mut own, mut with_y) = (0.0, 0.0);
                let mut others = vec![0.0; e];
                for r in 0..self.n {
                    let wc = w[r] * col[r];
                    for (a, &id) in ids.iter().enumerate() {
                        cross[a] += wc * self.cols[id][r];
                    }
                    for (q, o) in others.iter_mut().enumerate() {
                        *o += wc * extra[q][r];
                    }
                    own += wc * col[r];
                    with_y += wc * y[r];
                }
                for a in 0..k0 {
                    g[a][p] = cross[a];
                    g[p][a] = cross[a];
                }
                for (q, o) in others.iter().enumerate() {
                    g[k0 + q][p] = *o;
                    g[p][k0 + q] = *o;
                }
                g[p][p] = own;
                gy[p] = with_y;
            }
        }
        solve(&g, &gy, self.yy.total)
    }

    /// Leave-one-fold-out cross-validation of the registered columns `ids`: for every
    /// fold, fit on the others (the independent columns of the full fit) and score the
    /// held-out rows. O(folds · k³) once the memo is filled.
    pub(super) fn cv(&mut self, ids: &[usize]) -> Cv {
        let full = self.fit(ids);
        let k = ids.len();
        let mut gf = vec![vec![vec![0.0; k]; k]; self.nfolds];
        let mut gt = vec![vec![0.0; k]; k];
        let mut gyf = vec![vec![0.0; k]; self.nfolds];
        let mut gyt = vec![0.0; k];
        for a in 0..k {
            for b in a..k {
                let s = self.pair(ids[a], ids[b]).clone();
                gt[a][b] = s.total;
                gt[b][a] = s.total;
                for (f, v) in s.folds.iter().enumerate() {
                    gf[f][a][b] = *v;
                    gf[f][b][a] = *v;
                }
            }
            let s = self.with_y(ids[a]).clone();
            gyt[a] = s.total;
            for (f, v) in s.folds.iter().enumerate() {
                gyf[f][a] = *v;
            }
        }
        let keep: Vec<usize> = (0..k).filter(|&a| full.independent[a]).collect();
        let mut sse = 0.0;
        let mut coefs = Vec::with_capacity(self.nfolds);
        for f in 0..self.nfolds {
            let m = keep.len();
            let mut g = vec![vec![0.0; m]; m];
            let mut gy = vec![0.0; m];
            for (p, &a) in keep.iter().enumerate() {
                for (q, &b) in keep.iter().enumerate() {
                    g[p][q] = gt[a][b] - gf[f][a][b];
                }
                gy[p] = gyt[a] - gyf[f][a];
            }
            let b = solve_ridge(&g, &gy);
            let mut coef = vec![0.0; k];
            for (p, &a) in keep.iter().enumerate() {
                coef[a] = b[p];
            }
            // Held-out Σw(y − Xb)² = yy_f − 2 bᵀg_f + bᵀ G_f b.
            let mut q = self.yy.folds[f];
            for a in 0..k {
                q -= 2.0 * coef[a] * gyf[f][a];
                for c in 0..k {
                    q += coef[a] * gf[f][a][c] * coef[c];
                }
            }
            sse += q.max(0.0);
            coefs.push(coef);
        }
        Cv {
            mse: sse / self.n.max(1) as f64,
            coefs,
        }
    }

    /// Weighted squared norm of the part of column `col` that the columns `base` do not
    /// explain (its residual after regressing it on them).
    pub(super) fn unexplained(&mut self, base: &[usize], col: usize) -> f64 {
        let k = base.len();
        let mut g = vec![vec![0.0; k]; k];
        let mut gy = vec![0.0; k];
        for a in 0..k {
            for b in a..k {
                let v = self.pair(base[a], base[b]).total;
                g[a][b] = v;
                g[b][a] = v;
            }
            gy[a] = self.pair(base[a], col).total;
        }
        let cc = self.pair(col, col).total;
        solve(&g, &gy, cc).chi2
    }

    pub(super) fn fold(&self) -> &[usize] {
        &self.fold
    }

    /// Fitted values Σ coef·column over registered ids.
    pub(super) fn predict(&self, ids: &[usize], coef: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.n];
        for (&id, &c) in ids.iter().zip(coef) {
            if c != 0.0 {
                for (o, v) in out.iter_mut().zip(&self.cols[id]) {
                    *o += c * v;
                }
            }
        }
        out
    }
}

/// The groups of a static map: every row's group, and for each group whether its level is
/// a straight line in x (moving rows, binned along the travel) or a constant (a dwell).
#[derive(Debug, Clone)]
pub(crate) struct MapGroups {
    pub group: Vec<usize>,
    pub x: Vec<f64>,
    pub linear: Vec<bool>,
}

impl MapGroups {
    /// Parameters the map takes beyond the constant.
    pub(super) fn absorbed(&self) -> usize {
        let used: std::collections::BTreeSet<usize> = self.group.iter().copied().collect();
        let lin = used.iter().filter(|&&g| self.linear[g]).count();
        (used.len() + lin).saturating_sub(1)
    }

    /// `v` minus its weighted fit by the map (the within transform): per group its mean,
    /// or its straight line in x for a linear group.
    pub(super) fn apply(&self, v: &mut [f64], w: &[f64]) {
        let ng = self.linear.len();
        let (mut s0, mut sx) = (vec![0.0; ng], vec![0.0; ng]);
        for (k, &g) in self.group.iter().enumerate() {
            s0[g] += w[k];
            sx[g] += w[k] * self.x[k];
        }
        let xm: Vec<f64> = (0..ng)
            .map(|g| if s0[g] > 0.0 { sx[g] / s0[g] } else { 0.0 })
            .collect();
        let (mut sv, mut sxx, mut sxv) = (vec![0.0; ng], vec![0.0; ng], vec![0.0; ng]);
        for (k, &g) in self.group.iter().enumerate() {
            let dx = self.x[k] - xm[g];
            sv[g] += w[k] * v[k];
            sxx[g] += w[k] * dx * dx;
            sxv[g] += w[k] * dx * v[k];
        }
        for (k, &g) in self.group.iter().enumerate() {
            if s0[g] <= 0.0 {
                continue;
            }
            let slope = if self.linear[g] && sxx[g] > 0.0 {
                sxv[g] / sxx[g]
            } else {
                0.0
            };
            v[k] -= sv[g] / s0[g] + slope * (self.x[k] - xm[g]);
        }
    }
}

/// Solves the normal equations G b = g (yᵀWy = `yy`) in normalised form with ordered
/// dependency detection; see the module docs.
pub(crate) fn solve(g: &[Vec<f64>], gy: &[f64], yy: f64) -> Fit {
    let k = g.len();
    let s: Vec<f64> = (0..k).map(|i| g[i][i].max(0.0).sqrt()).collect();
    let mut acc: Vec<usize> = Vec::new();
    let mut l: Vec<Vec<f64>> = Vec::new();
    for j in 0..k {
        if !(s[j] > 0.0 && s[j].is_finite()) {
            continue;
        }
        let m = acc.len();
        let mut z = vec![0.0; m];
        for a in 0..m {
            let mut v = g[acc[a]][j] / (s[acc[a]] * s[j]);
            for b in 0..a {
                v -= l[a][b] * z[b];
            }
            z[a] = v / l[a][a];
        }
        let d = 1.0 - z.iter().map(|v| v * v).sum::<f64>();
        if d > DEPENDENT_TOL {
            z.push(d.sqrt());
            l.push(z);
            acc.push(j);
        }
    }
    let m = acc.len();
    let gn: Vec<f64> = acc.iter().map(|&i| gy[i] / s[i]).collect();
    let mut u = vec![0.0; m];
    for a in 0..m {
        let mut v = gn[a];
        for b in 0..a {
            v -= l[a][b] * u[b];
        }
        u[a] = v / l[a][a];
    }
    let chi2 = (yy - u.iter().map(|v| v * v).sum::<f64>()).max(0.0);
    let mut bp = vec![0.0; m];
    for a in (0..m).rev() {
        let mut v = u[a];
        for b in a + 1..m {
            v -= l[b][a] * bp[b];
        }
        bp[a] = v / l[a][a];
    }
    // L⁻¹ (lower triangular), then Gn⁻¹ = L⁻ᵀ L⁻¹.
    let mut li = vec![vec![0.0; m]; m];
    for c in 0..m {
        for a in c..m {
            let mut v = if a == c { 1.0 } else { 0.0 };
            for b in c..a {
                v -= l[a][b] * li[b][c];
            }
            li[a][c] = v / l[a][a];
        }
    }
    let mut cov = vec![vec![0.0; k]; k];
    for p in 0..m {
        for q in p..m {
            let mut v = 0.0;
            for a in q..m {
                v += li[a][p] * li[a][q];
            }
            let (i, j) = (acc[p], acc[q]);
            let c = v / (s[i] * s[j]);
            cov[i][j] = c;
            cov[j][i] = c;
        }
    }
    let mut coef = vec![0.0; k];
    let mut independent = vec![false; k];
    for (p, &i) in acc.iter().enumerate() {
        coef[i] = bp[p] / s[i];
        independent[i] = true;
    }
    Fit {
        coef,
        independent,
        chi2,
        rank: m,
        cov,
    }
}

/// Plain solve of a (nearly) positive definite system in normalised form with a tiny
/// ridge, for the cross-validation folds (a fold may lose a column's support).
fn solve_ridge(g: &[Vec<f64>], gy: &[f64]) -> Vec<f64> {
    let m = g.len();
    let s: Vec<f64> = (0..m).map(|i| g[i][i].max(1e-300).sqrt()).collect();
    let a = nalgebra::DMatrix::from_fn(m, m, |i, j| {
        g[i][j] / (s[i] * s[j]) + if i == j { 1e-12 } else { 0.0 }
    });
    let b = nalgebra::DVector::from_fn(m, |i, _| gy[i] / s[i]);
    let x = match a.clone().cholesky() {
        Some(c) => c.solve(&b),
        None => a
            .svd(true, true)
            .solve(&b, 1e-12)
            .unwrap_or_else(|_| nalgebra::DVector::zeros(m)),
    };
    (0..m).map(|i| x[i] / s[i]).collect()
}

/// Bayesian information criterion with the noise scale estimated:
/// n·ln(χ²/n) + k·ln n.
pub(crate) fn bic(chi2: f64, n: usize, k: usize) -> f64 {
    let n = n.max(1) as f64;
    n * (chi2.max(1e-300) / n).ln() + k as f64 * n.ln()
}

/// Symmetric (pseudo-)inverse of a normal matrix in normalised form, via SVD with a
/// relative tolerance; used for the final covariance with nonlinear parameters.
pub(crate) fn pinv_sym(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let m = a.len();
    let s: Vec<f64> = (0..m).map(|i| a[i][i].max(1e-300).sqrt()).collect();
    let mat = nalgebra::DMatrix::from_fn(m, m, |i, j| a[i][j] / (s[i] * s[j]));
    let inv = mat
        .pseudo_inverse(1e-12)
        .unwrap_or_else(|_| nalgebra::DMatrix::zeros(m, m));
    (0..m)
        .map(|i| (0..m).map(|j| inv[(i, j)] / (s[i] * s[j])).collect())
        .collect()
}
