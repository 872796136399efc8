//! The penalised least-squares fit of tables at knots ([`super::spline`]): smoothing
//! parameters by REML, the Bayesian posterior covariance, the Birge ratio.
//!
//! # Fit
//!
//! With A the centred, weighted, equilibrated design (one free constant per line
//! eliminated, [`super::identify`]), e the readings and S_c the roughness penalty of
//! component c, the estimate minimises |e − Aθ|² + Σ_c λ_c·θ_cᵀS_cθ_c:
//! θ̂ = H⁻¹Aᵀe with H = AᵀA + Σ_c λ_c S_c. Campaign terms (the scale's α, a drift, a bad
//! line) are further columns of A, not penalised; they are selected against the
//! unpenalised tables (least squares on the same design), so that a term must stand out
//! from anything a table could absorb.
//!
//! # Smoothing: REML, per kind, then per component capped at its kind's
//!
//! [`Penalty::reml`] first fits one λ per kind (positioning, straightness, rotation),
//! then one per component with its kind's λ as upper bound (a component whose lines show
//! no roughness is not declared smoother than its kind: uncapped, REML set λ → ∞ and a
//! straightness reported σ → 0 beside an unresolved bump). λ's floor and ceiling are
//! relative to Σ|A_j|²/ΣR_jj, the balance of data and penalty in physical units.
//!
//! Read as a Gaussian model — θ_c a priori N(0, φ/λ_c·S_c⁻) on its penalised part, flat
//! on the straight line through 0, noise of variance φ — the λ_c maximise the restricted
//! likelihood. They are found by the Fellner–Schall update (S. N. Wood and M. Fasiolo, "A
//! generalized Fellner–Schall method for smoothing parameter optimization", Biometrics
//! 73(4), 2017): λ_c ← φ̂·(r_c − λ_c·tr(H⁻¹S_c)) / θ̂_cᵀS_cθ̂_c, r_c the rank of S_c,
//! φ̂ = RSS/(n − lines − edf), repeated until no λ moves by more than 5 % (at most
//! [`MAX_ITER`]). Each step costs one Cholesky factorisation and inverse of H
//! (O(p³), p the parameters). REML rather than GCV or cross-validation: it is the
//! criterion whose model is the posterior the σ bands are taken from, it needs no search
//! over an 18-dimensional grid, and it undersmooths less often than GCV (Wood, "Fast
//! stable restricted maximum likelihood and marginal likelihood estimation of
//! semiparametric generalized linear models", JRSS B 73(1), 2011). φ̂ is estimated even
//! when the table states s_um, so a misstated noise does not change the smoothing.
//!
//! # Covariance and residual
//!
//! The covariance is the Bayesian posterior's, φ·H⁻¹ (G. Wahba, "Bayesian confidence
//! intervals for the cross-validated smoothing spline", JRSS B 45(1), 1983; its coverage
//! averaged over the function is close to nominal, D. Nychka, JASA 83, 1988): it includes
//! the smoothing bias that the frequentist sandwich leaves out. With s_um given, φ = 1
//! (the stated noise) times B², B = √(χ²/ν) the Birge ratio, when B > 1 — never narrower
//! than the stated noise allows, wider when the residual says the noise or the model was
//! understated. Without s_um, φ = χ²/ν. The residual degrees of freedom are
//! ν = n − lines − edf, edf = tr(H⁻¹AᵀA): under the Gaussian model E[χ²] = ν exactly.
//!
//! # What the lines do not determine
//!
//! A component the lines do not determine (identifiability as for the polynomials, see
//! [`super::identify`]) is not penalised — a penalty would make up its shape — and the
//! directions of H that stay singular (N: AᵀA and the other penalties both zero) are kept
//! as the fit's null space: predictions that need them are refused, as for polynomials.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::error::Unfit;
use super::identify::{Design, Solved};

/// Most Fellner–Schall steps.
pub(super) const MAX_ITER: usize = 30;
/// Converged when no λ changes by more than this factor's log.
const TOL_LOG: f64 = 0.1;
/// λ_c stays within [1/LAMBDA_FLOOR, LAMBDA_SPAN] × tr(AᵀA)_c / tr(S_c): above, the
/// table is a straight line to rounding; below the floor REML's likelihood is flat in the
/// knot values the lines barely see (a rotation of the middle axis between the targets of
/// a half-diagonal), and the Fellner–Schall step runs away to λ → 0 with σ of metres.
const LAMBDA_SPAN: f64 = 1e8;
const LAMBDA_FLOOR: f64 = 1e4;

/// The Cholesky factor of a symmetric positive definite `h` (its lower triangle read),
/// `None` when a pivot is not positive: the right-looking column algorithm in plain loops
/// over nalgebra's column-major storage (p³/3 multiply-adds), packed as nalgebra's
/// `Cholesky` for its solves. Several times faster than `Cholesky::new` in the test
/// profile, where nalgebra's generic code is barely optimised.
pub(crate) fn cholesky(h: DMatrix<f64>) -> Option<Cholesky<f64, Dyn>> {
    let p = h.nrows();
    let mut a = h;
    {
        let s = a.as_mut_slice();
        for k in 0..p {
            let d = s[k * p + k];
            if !(d > 0.0 && d.is_finite()) {
                return None;
            }
            let l = d.sqrt();
            s[k * p + k] = l;
            for v in &mut s[k * p + k + 1..(k + 1) * p] {
                *v /= l;
            }
            let (left, right) = s.split_at_mut((k + 1) * p);
            let colk = &left[k * p..];
            for j in k + 1..p {
                let ljk = colk[j];
                if ljk == 0.0 {
                    continue;
                }
                let off = (j - k - 1) * p;
                let colj = &mut right[off + j..off + p];
                for (x, y) in colj.iter_mut().zip(&colk[j..p]) {
                    *x -= ljk * y;
                }
            }
        }
    }
    Some(Cholesky::pack_dirty(a))
}

/// H⁻¹ from H's Cholesky factor L: L⁻¹ by forward substitution on its columns (p³/6
/// multiply-adds in plain loops), then H⁻¹ = L⁻ᵀL⁻¹ as one matrix product (nalgebra's
/// optimised kernel). Equal to `Cholesky::inverse` to rounding, several times faster
/// in the test profile, where the generic solve is barely optimised.
pub(crate) fn spd_inverse(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let l = chol.l_dirty();
    let p = l.nrows();
    let ls = l.as_slice();
    let mut x = vec![0.0f64; p * p];
    for j in 0..p {
        let col = &mut x[j * p..(j + 1) * p];
        col[j] = 1.0;
        for k in j..p {
            let lk = &ls[k * p..(k + 1) * p];
            let v = col[k] / lk[k];
            col[k] = v;
            if v != 0.0 {
                for i in k + 1..p {
                    col[i] -= lk[i] * v;
                }
            }
        }
    }
    // x holds L⁻¹ column by column (column-major), as nalgebra stores matrices.
    let linv = DMatrix::from_vec(p, p, x);
    // `transpose() *` goes to the gemm kernel; `tr_mul` would take a dot product per entry.
    linv.transpose() * &linv
}

/// The group whose λ caps a component's: 0 positioning, 1 straightness, 2 rotation.
pub(crate) fn group(component: usize) -> usize {
    let c = super::model::Component::from_index(component);
    if c.is_positioning() {
        0
    } else if c.is_straightness() {
        1
    } else {
        2
    }
}

/// One component's penalty in equilibrated coordinates.
#[derive(Debug, Clone)]
pub(crate) struct Block {
    pub component: usize,
    pub start: usize,
    /// Penalty (params × params) of θ·scale (equilibrated parameters).
    pub s: DMatrix<f64>,
    pub rank: usize,
}

/// The penalties of a fit, the smoothing parameters and the null directions.
#[derive(Debug, Clone)]
pub(crate) struct Penalty {
    pub blocks: Vec<Block>,
    pub lambda: Vec<f64>,
    /// Null directions (rows: the first parameters of the design), equilibrated.
    pub null: DMatrix<f64>,
}

/// The normal equations of a design: AᵀA, Aᵀe, eᵀe.
struct Normal {
    g: DMatrix<f64>,
    b: DVector<f64>,
    ee: f64,
}

impl Normal {
    fn of(d: &Design) -> Normal {
        Normal {
            g: d.a.transpose() * &d.a,
            b: d.a.tr_mul(&d.e),
            ee: d.e.norm_squared(),
        }
    }
}

/// Orthonormal directions (columns) that neither AᵀA (`g`) nor the penalties at `lambda`
/// determine: eigenvalues of G + Σ λ_c S_c at or below 1e−8 of the largest.
pub(crate) fn null_directions(g: &DMatrix<f64>, blocks: &[Block], lambda: &[f64]) -> DMatrix<f64> {
    let mut h = g.clone();
    for (blk, l) in blocks.iter().zip(lambda) {
        let m = blk.s.nrows();
        let mut view = h.view_mut((blk.start, blk.start), (m, m));
        view += &blk.s * *l;
    }
    let eig = h.symmetric_eigen();
    let top = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let keep: Vec<usize> = (0..eig.eigenvalues.len())
        .filter(|&i| eig.eigenvalues[i] <= 1e-8 * top)
        .collect();
    let n = g.nrows();
    DMatrix::from_fn(n, keep.len(), |i, k| eig.eigenvectors[(i, keep[k])])
}

impl Penalty {
    /// The Cholesky factor of H = AᵀA + Σ λ_c S_c + μ·N Nᵀ (the blocks are the first
    /// columns; further columns are not penalised).
    fn factor(&self, g: &DMatrix<f64>, lambda: &[f64]) -> Option<Cholesky<f64, Dyn>> {
        let mut h = g.clone();
        for (blk, l) in self.blocks.iter().zip(lambda) {
            let m = blk.s.nrows();
            let mut view = h.view_mut((blk.start, blk.start), (m, m));
            view += &blk.s * *l;
        }
        if self.null.ncols() > 0 {
            let mu = g.diagonal().max().max(1.0);
            let n = self.null.nrows();
            let nn = &self.null * self.null.transpose();
            let mut view = h.view_mut((0, 0), (n, n));
            view += nn * mu;
        }
        // A ridge at rounding level keeps directions that are null to within rounding
        // (but above N's threshold) from failing the factorisation.
        // Relative to the data's diagonal: a penalty on a knot value the lines barely see
        // is large in equilibrated units and must not set the ridge.
        let top = g.diagonal().max().max(f64::MIN_POSITIVE);
        for i in 0..h.nrows() {
            h[(i, i)] += 1e-12 * top;
        }
        cholesky(h)
    }

    /// REML's smoothing parameters from the current λ: first one λ per group of
    /// components ([`group`]: positioning, straightness, rotation), then one per
    /// component, each capped at its group's (see the module docs: a component whose
    /// lines show no roughness is not declared smoother than its kind).
    pub(crate) fn reml(&self, d: &Design, n_lines: usize) -> Vec<f64> {
        let nm = Normal::of(d);
        let groups: Vec<usize> = self.blocks.iter().map(|b| group(b.component)).collect();
        let pooled = self.fellner_schall(&nm, d, n_lines, &self.lambda, &groups, None);
        let own: Vec<usize> = (0..groups.len()).collect();
        self.fellner_schall(&nm, d, n_lines, &pooled, &own, Some(&pooled))
    }

    /// The Fellner–Schall iteration: blocks with the same `tie` share one λ; `cap` bounds
    /// each λ from above.
    fn fellner_schall(
        &self,
        nm: &Normal,
        d: &Design,
        n_lines: usize,
        start: &[f64],
        tie: &[usize],
        cap: Option<&[f64]>,
    ) -> Vec<f64> {
        let rows = d.a.nrows() as f64;
        let mut lambda = start.to_vec();
        let g0 = &nm.g;
        let bounds: Vec<(f64, f64)> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(k, blk)| {
                // The balance of data and penalty in physical units, Σ|A_j|² / Σ R_jj:
                // in equilibrated units a knot value the lines barely see (a column norm
                // near 0) would blow the penalty's trace up and the bounds down with it.
                let m = blk.s.nrows();
                let sc = &d.scale[blk.start..blk.start + m];
                let tg: f64 = (0..m)
                    .map(|i| g0[(blk.start + i, blk.start + i)] * sc[i] * sc[i])
                    .sum();
                let ts: f64 = (0..m).map(|i| blk.s[(i, i)] * sc[i] * sc[i]).sum();
                let base = if ts > 0.0 && tg > 0.0 { tg / ts } else { 1.0 };
                let hi = base * LAMBDA_SPAN;
                (base / LAMBDA_FLOOR, cap.map_or(hi, |c| c[k].min(hi)))
            })
            .collect();
        let n_tie = tie.iter().max().map_or(0, |m| m + 1);
        for _ in 0..MAX_ITER {
            let Some(chol) = self.factor(&nm.g, &lambda) else {
                break;
            };
            let theta = chol.solve(&nm.b);
            let hinv = spd_inverse(&chol);
            let rss = (nm.ee - 2.0 * theta.dot(&nm.b) + theta.dot(&(&nm.g * &theta))).max(0.0);
            let edf = hinv.component_mul(&nm.g).sum();
            let nu = rows - n_lines as f64 - edf;
            if nu <= 0.0 {
                break;
            }
            let phi = rss / nu;
            // Per tie: Σ rank, Σ λ·tr(H⁻¹S), Σ θᵀSθ.
            let mut acc = vec![(0.0f64, 0.0f64, 0.0f64); n_tie];
            for (k, blk) in self.blocks.iter().enumerate() {
                let m = blk.s.nrows();
                let th = theta.rows(blk.start, m);
                let q = th.dot(&(&blk.s * th));
                let t = hinv
                    .view((blk.start, blk.start), (m, m))
                    .component_mul(&blk.s)
                    .sum();
                let a = &mut acc[tie[k]];
                a.0 += blk.rank as f64;
                a.1 += lambda[k] * t;
                a.2 += q;
            }
            let mut moved = 0.0f64;
            for (k, _) in self.blocks.iter().enumerate() {
                let (r, lt, q) = acc[tie[k]];
                let num = r - lt;
                let (lo, hi) = bounds[k];
                let next = if q > 0.0 && num > 0.0 {
                    (phi * num / q).clamp(lo, hi)
                } else {
                    // Nothing rough left to estimate: as smooth as allowed.
                    hi
                };
                moved = moved.max((next / lambda[k]).ln().abs());
                lambda[k] = next;
            }
            if moved < TOL_LOG {
                break;
            }
        }
        lambda
    }

    /// What the campaign terms are scored against: the tables with λ × `relax` (a tiny
    /// factor: nearly the unpenalised least squares, without its SVD). The residual r,
    /// ν = rows − lines − tr(H⁻¹AᵀA), and g ↦ g − A·H⁻¹Aᵀg by the Cholesky factor.
    pub(crate) fn residualiser<'a>(
        &self,
        d: &'a Design,
        n_lines: usize,
        relax: f64,
    ) -> Option<super::campaign::Residualiser<'a>> {
        let nm = Normal::of(d);
        let lambda: Vec<f64> = self.lambda.iter().map(|l| l * relax).collect();
        let chol = self.factor(&nm.g, &lambda)?;
        let theta = chol.solve(&nm.b);
        let r = &d.e - &d.a * &theta;
        let edf = spd_inverse(&chol).component_mul(&nm.g).sum();
        let a = &d.a;
        Some(super::campaign::Residualiser {
            r,
            dof: d.a.nrows() as f64 - n_lines as f64 - edf,
            project: Box::new(move |g: &DMatrix<f64>| {
                let x = chol.solve(&a.tr_mul(g));
                g - a * x
            }),
        })
    }

    /// The fit at `lambda` with the posterior covariance; `known_noise` when rows are
    /// weighted by a stated σ (then φ = max(1, χ²/ν)).
    pub(crate) fn fit(
        &self,
        d: &Design,
        lambda: &[f64],
        n_lines: usize,
        known_noise: bool,
    ) -> Result<Solved, Unfit> {
        let nm = Normal::of(d);
        let chol = self.factor(&nm.g, lambda).ok_or(Unfit::Singular)?;
        let theta_s = chol.solve(&nm.b);
        let hinv = spd_inverse(&chol);
        let res_w = &d.e - &d.a * &theta_s;
        let chi2 = res_w.norm_squared();
        // diag(H⁻¹G) without the product: (H⁻¹G)_ii = Σ_j H⁻¹_ij G_ji.
        let p = d.a.ncols();
        let fdiag: Vec<f64> = (0..p)
            .map(|i| {
                hinv.row(i)
                    .iter()
                    .zip(nm.g.column(i).iter())
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect();
        let edf: f64 = fdiag.iter().sum();
        let rows = d.a.nrows() as f64;
        let dof = rows - n_lines as f64 - edf;
        if dof <= 0.5 {
            return Err(Unfit::NoFreedomPenalised {
                rows: d.a.nrows(),
                lines: n_lines,
                edf,
            });
        }
        let ratio = chi2 / dof;
        let phi = if known_noise { ratio.max(1.0) } else { ratio };
        let edf_block = self
            .blocks
            .iter()
            .map(|blk| fdiag[blk.start..blk.start + blk.s.nrows()].iter().sum())
            .collect();
        Ok(Solved {
            theta: (0..p).map(|j| theta_s[j] / d.scale[j]).collect(),
            cov: DMatrix::from_fn(p, p, |i, j| phi * hinv[(i, j)] / (d.scale[i] * d.scale[j])),
            res_w,
            chi2,
            dof,
            sigma0: ratio.sqrt(),
            // The penalised fit's null directions are the penalty's, not the solution's.
            null: DMatrix::zeros(p, 0),
            edf_block,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inverse by L⁻¹ is the inverse: H·H⁻¹ = I on a random SPD matrix.
    #[test]
    fn spd_inverse_inverts() {
        let p = 37;
        let a = DMatrix::from_fn(p + 5, p, |i, j| ((i * 31 + j * 17) % 23) as f64 - 11.0);
        let h = a.tr_mul(&a) + DMatrix::identity(p, p);
        let chol = cholesky(h.clone()).expect("spd");
        let l = chol.l();
        let reference = Cholesky::new(h.clone()).expect("spd");
        assert!((&l - reference.l()).abs().max() < 1e-9 * l.abs().max());
        assert!(cholesky(-h.clone()).is_none());
        let inv = spd_inverse(&chol);
        let err = (&h * &inv - DMatrix::<f64>::identity(p, p)).abs().max();
        assert!(err < 1e-9, "{err}");
        assert!((&inv - reference.inverse()).abs().max() < 1e-9 * inv.abs().max());
    }
}
