//! The Gaussian process's log marginal likelihood, its analytic gradient (R&W Eqs. 2.30,
//! 5.9) and the hyperparameter fit that maximises it, with the Cholesky helpers they and
//! the prediction share. The bounds and starts are specified in the module docs of
//! [`super`], section *Hyperparameters*.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use super::{GpConfig, Kernel, NUGGET};
use crate::base::lbfgs;

/// L-BFGS iterations per start.
const MAX_ITERATIONS: usize = 200;

/// Maximises the log marginal likelihood of `y` at `positions` (bounding box `lo`–`hi`)
/// over θ within the bounds of the module docs: one data-driven start, then
/// [`GpConfig::restarts`] random ones drawn with [`GpConfig::seed`], each by L-BFGS on the
/// logistic-mapped variables; the best likelihood wins. Returns the objective and that θ
/// (the data-driven guess if every start failed to factor).
pub(super) fn maximise<'a>(
    config: &GpConfig,
    positions: &[[f64; 3]],
    y: &'a [f64],
    node_var: Vec<f64>,
    lo: [f64; 3],
    hi: [f64; 3],
) -> (Objective<'a>, Vec<f64>) {
    let n = y.len();

    let mean = y.iter().sum::<f64>() / n as f64;
    let sd = (y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    let scale = if sd > 0.0 && sd.is_finite() { sd } else { 1.0 };

    // Per-axis extent and smallest spacing of distinct coordinates.
    let mut spacing = [f64::INFINITY; 3];
    for a in 0..3 {
        let mut c: Vec<f64> = positions.iter().map(|p| p[a]).collect();
        c.sort_by(f64::total_cmp);
        for w in c.windows(2) {
            let d = w[1] - w[0];
            if d > 0.0 {
                spacing[a] = spacing[a].min(d);
            }
        }
    }
    let extent: [f64; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    // Coordinates a denormal apart (5e-324 mm) would put a length-scale bound at ln 0 =
    // −inf: the smallest spacing counts as at least 10⁻⁹ of the extent (and 10⁻⁹ mm).
    for a in 0..3 {
        spacing[a] = spacing[a].max(1e-9 * extent[a]).max(1e-9);
    }
    // An axis spanning less than 10⁻⁹ mm (two coordinates a denormal apart) is one
    // coordinate: fixed like an axis with none, or its bounds would reach ln 0.
    let free: Vec<usize> = (0..3).filter(|&a| extent[a] > 1e-9).collect();
    let longest = extent.iter().copied().fold(1.0, f64::max);
    let fixed_ls = [1e3 * longest; 3];

    let mut bounds = Vec::with_capacity(free.len() + 2);
    for &a in &free {
        bounds.push(((1e-2 * spacing[a]).ln(), (1e2 * extent[a]).ln()));
    }
    bounds.push(((1e-3 * scale).ln(), (1e2 * scale).ln()));
    bounds.push(((1e-6 * scale).ln(), (10.0 * scale).ln()));

    let objective =
        Objective::new(config.kernel, positions, y, free.clone(), fixed_ls).with_node_var(node_var);

    // Starts: one data-driven, then `restarts` log-uniform random ones.
    let mut starts = Vec::with_capacity(config.restarts + 1);
    let mut guess: Vec<f64> = free.iter().map(|&a| (0.5 * extent[a]).ln()).collect();
    guess.push(scale.ln());
    guess.push((0.1 * scale).ln());
    starts.push(guess);
    let mut rng = StdRng::seed_from_u64(config.seed);
    let mut log_uniform = |lo: f64, hi: f64| rng.random_range(lo.ln()..=hi.ln());
    for _ in 0..config.restarts {
        let mut s: Vec<f64> = free
            .iter()
            .map(|&a| log_uniform(0.05 * extent[a], 2.0 * extent[a]))
            .collect();
        s.push(log_uniform(0.3 * scale, 3.0 * scale));
        s.push(log_uniform(1e-4 * scale, 0.5 * scale));
        starts.push(s);
    }

    let to_theta = |u: &[f64]| -> (Vec<f64>, Vec<f64>) {
        u.iter()
            .zip(&bounds)
            .map(|(&u, &(lo, hi))| {
                let s = logistic(u);
                (lo + (hi - lo) * s, (hi - lo) * s * (1.0 - s))
            })
            .unzip()
    };
    let to_u = |theta: &[f64]| -> Vec<f64> {
        theta
            .iter()
            .zip(&bounds)
            .map(|(&t, &(lo, hi))| {
                let s = ((t - lo) / (hi - lo)).clamp(1e-6, 1.0 - 1e-6);
                (s / (1.0 - s)).ln()
            })
            .collect()
    };
    let cost = |u: &[f64]| -> Option<(f64, Vec<f64>)> {
        let (theta, dtheta) = to_theta(u);
        let (lml, grad) = objective.value_grad(&theta)?;
        let g = grad.iter().zip(&dtheta).map(|(g, d)| -g * d).collect();
        Some((-lml, g))
    };

    let mut best: Option<(f64, Vec<f64>)> = None;
    for start in &starts {
        if let Some((f, u)) = lbfgs(&cost, to_u(start), MAX_ITERATIONS)
            && best.as_ref().is_none_or(|(bf, _)| f < *bf)
        {
            best = Some((f, u));
        }
    }
    let theta = match best {
        Some((_, u)) => to_theta(&u).0,
        // Every start failed to factor: try the data-driven guess with escalating nugget.
        None => to_theta(&to_u(&starts[0])).0,
    };

    (objective, theta)
}

#[inline]
fn logistic(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

/// Solves L v = k for lower-triangular L (column-major, forward substitution).
pub(super) fn forward_substitute(l: &DMatrix<f64>, mut k: DVector<f64>) -> DVector<f64> {
    let n = l.nrows();
    let ls = l.as_slice();
    let v = k.as_mut_slice();
    for j in 0..n {
        let col = &ls[j * n..(j + 1) * n];
        v[j] /= col[j];
        let vj = v[j];
        for (vi, lij) in v[j + 1..].iter_mut().zip(&col[j + 1..]) {
            *vi -= lij * vj;
        }
    }
    k
}

/// (LLᵀ)⁻¹ from the lower Cholesky factor L (column-major n × n; only its lower triangle
/// is read). Only the lower triangle of the result (row ≥ column) is filled. O(n³/3):
/// X = L⁻¹ column by column, then (K⁻¹)ᵢⱼ = Σ_{k ≥ i} Xₖᵢ Xₖⱼ for i ≥ j, each a
/// contiguous dot product in column-major storage.
pub(super) fn inverse_lower(l: &[f64], n: usize) -> Vec<f64> {
    let mut x = vec![0.0; n * n];
    for j in 0..n {
        let col = &mut x[j * n..(j + 1) * n];
        col[j] = 1.0;
        for c in j..n {
            let lc = &l[c * n..(c + 1) * n];
            col[c] /= lc[c];
            let xc = col[c];
            for (xi, lic) in col[c + 1..].iter_mut().zip(&lc[c + 1..]) {
                *xi -= lic * xc;
            }
        }
    }
    let mut inv = vec![0.0; n * n];
    for j in 0..n {
        let xj = &x[j * n..(j + 1) * n];
        for i in j..n {
            let xi = &x[i * n..(i + 1) * n];
            inv[i + j * n] = xi[i..].iter().zip(&xj[i..]).map(|(a, b)| a * b).sum();
        }
    }
    inv
}

/// Index of the pair (i, j), i > j, in a packed strictly-lower triangle.
#[inline]
fn packed(i: usize, j: usize) -> usize {
    i * (i - 1) / 2 + j
}

/// A Cholesky factorisation of K + σₙ²I and what follows from it.
pub(super) struct Factor {
    pub(super) chol: Cholesky<f64, Dyn>,
    pub(super) mean: f64,
    pub(super) alpha: DVector<f64>,
    pub(super) l_inv_ones: DVector<f64>,
    pub(super) lml: f64,
}

/// The log marginal likelihood as a function of θ (log parameters of the free axes, then
/// ln σ_f, ln σₙ), with the pairwise squared coordinate differences precomputed.
pub(super) struct Objective<'a> {
    kernel: Kernel,
    pub(super) y: &'a [f64],
    /// Squared differences per axis over pairs i > j, packed.
    d2: [Vec<f64>; 3],
    free: Vec<usize>,
    fixed_ls: [f64; 3],
    /// Each node's own noise variance, µm² (heteroscedastic, known), added to σₙ².
    node_var: Vec<f64>,
}

impl<'a> Objective<'a> {
    /// With each node's own noise variance (empty: none).
    pub(super) fn with_node_var(mut self, node_var: Vec<f64>) -> Self {
        self.node_var = node_var;
        self
    }

    pub(super) fn new(
        kernel: Kernel,
        positions: &[[f64; 3]],
        y: &'a [f64],
        free: Vec<usize>,
        fixed_ls: [f64; 3],
    ) -> Self {
        let n = positions.len();
        let d2 = std::array::from_fn(|a| {
            let mut v = Vec::with_capacity(n * (n - 1) / 2);
            for i in 1..n {
                for j in 0..i {
                    v.push((positions[i][a] - positions[j][a]).powi(2));
                }
            }
            v
        });
        Self {
            kernel,
            y,
            d2,
            free,
            fixed_ls,
            node_var: Vec::new(),
        }
    }

    /// Length scales, σ_f² and σₙ² from θ.
    pub(super) fn unpack(&self, theta: &[f64]) -> ([f64; 3], f64, f64) {
        let mut ls = self.fixed_ls;
        for (slot, &a) in self.free.iter().enumerate() {
            ls[a] = theta[slot].exp();
        }
        let k = self.free.len();
        (ls, (2.0 * theta[k]).exp(), (2.0 * theta[k + 1]).exp())
    }

    /// Pairwise r² over the packed lower triangle.
    fn r2(&self, ls: [f64; 3]) -> Vec<f64> {
        let inv: [f64; 3] = std::array::from_fn(|a| ls[a].powi(-2));
        let mut r2 = self.d2[0].iter().map(|d| d * inv[0]).collect::<Vec<_>>();
        for (d2, ia) in self.d2.iter().zip(inv).skip(1) {
            for (r, d) in r2.iter_mut().zip(d2) {
                *r += d * ia;
            }
        }
        r2
    }

    fn factor_with(&self, r2: &[f64], sf2: f64, sn2: f64, nugget: f64) -> Option<Factor> {
        let n = self.y.len();
        let diag = sf2 * (1.0 + nugget) + sn2;
        let mut k = DMatrix::<f64>::zeros(n, n);
        {
            let s = k.as_mut_slice();
            for i in 0..n {
                s[i + i * n] = diag + self.node_var.get(i).copied().unwrap_or(0.0);
                for j in 0..i {
                    let v = sf2 * self.kernel.corr(r2[packed(i, j)]);
                    s[i + j * n] = v;
                    s[j + i * n] = v;
                }
            }
        }
        let chol = Cholesky::new(k)?;
        let l = chol.l_dirty();
        let mut log_det = 0.0;
        for i in 0..n {
            log_det += 2.0 * l[(i, i)].ln();
        }
        let kinv_y = chol.solve(&DVector::from_column_slice(self.y));
        let kinv_1 = chol.solve(&DVector::from_element(n, 1.0));
        let ones_kinv_1 = kinv_1.sum();
        if ones_kinv_1.is_nan() || ones_kinv_1 <= 0.0 {
            return None;
        }
        let mean = kinv_y.sum() / ones_kinv_1;
        let alpha = kinv_y - &kinv_1 * mean;
        let quad: f64 = self
            .y
            .iter()
            .zip(alpha.iter())
            .map(|(y, a)| (y - mean) * a)
            .sum();
        let lml = -0.5 * quad - 0.5 * log_det - 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
        if !lml.is_finite() {
            return None;
        }
        let l_inv_ones = forward_substitute(&chol.l(), DVector::from_element(n, 1.0));
        Some(Factor {
            chol,
            mean,
            alpha,
            l_inv_ones,
            lml,
        })
    }

    pub(super) fn factor(&self, ls: [f64; 3], sf2: f64, sn2: f64, nugget: f64) -> Option<Factor> {
        self.factor_with(&self.r2(ls), sf2, sn2, nugget)
    }

    /// The log marginal likelihood and its gradient with respect to θ (R&W Eq. 5.9);
    /// `None` when K + σₙ²I does not factor.
    fn value_grad(&self, theta: &[f64]) -> Option<(f64, Vec<f64>)> {
        let n = self.y.len();
        let (ls, sf2, sn2) = self.unpack(theta);
        let r2 = self.r2(ls);
        let f = self.factor_with(&r2, sf2, sn2, NUGGET)?;
        let ki = inverse_lower(f.chol.l_dirty().as_slice(), n);
        let al = f.alpha.as_slice();
        // W = ααᵀ − K⁻¹ (symmetric); ∂ln p/∂θⱼ = ½ tr(W ∂K/∂θⱼ).
        let nf = self.free.len();
        let mut grad = vec![0.0; nf + 2];
        let inv: Vec<f64> = self.free.iter().map(|&a| ls[a].powi(-2)).collect();
        let mut trace_w = 0.0;
        let mut w_dot_kf = 0.0;
        for i in 0..n {
            let w_ii = al[i] * al[i] - ki[i + i * n];
            trace_w += w_ii;
            w_dot_kf += w_ii * sf2 * (1.0 + NUGGET);
            for j in 0..i {
                let w = al[i] * al[j] - ki[i + j * n];
                let idx = packed(i, j);
                let rr = r2[idx];
                // Off-diagonal terms appear twice in the trace; ½ · 2 = 1.
                w_dot_kf += 2.0 * w * sf2 * self.kernel.corr(rr);
                let ws = w * sf2 * self.kernel.slope(rr);
                for (g, (&a, ia)) in grad.iter_mut().zip(self.free.iter().zip(&inv)) {
                    *g += ws * self.d2[a][idx] * ia;
                }
            }
        }
        // ∂K/∂ln σ_f = 2 (K − σₙ²I); ∂K/∂ln σₙ = 2σₙ² I.
        grad[nf] = w_dot_kf;
        grad[nf + 1] = sn2 * trace_w;
        Some((f.lml, grad))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic gradient of the log marginal likelihood matches central differences.
    #[test]
    fn gradient_matches_finite_differences() {
        let mut rng = StdRng::seed_from_u64(3);
        let positions: Vec<[f64; 3]> = (0..25)
            .map(|_| {
                [
                    rng.random_range(0.0..300.0),
                    rng.random_range(0.0..200.0),
                    rng.random_range(0.0..100.0),
                ]
            })
            .collect();
        let y: Vec<f64> = positions
            .iter()
            .map(|p| (p[0] / 80.0).sin() + 0.3 * (p[1] / 50.0).cos() + rng.random_range(-0.1..0.1))
            .collect();
        for kernel in [Kernel::SquaredExponential, Kernel::Matern52] {
            let obj = Objective::new(kernel, &positions, &y, vec![0, 1, 2], [1.0; 3]);
            let theta = [
                90f64.ln(),
                60f64.ln(),
                150f64.ln(),
                0.8f64.ln(),
                0.05f64.ln(),
            ];
            let (_, grad) = obj.value_grad(&theta).expect("factors");
            for j in 0..theta.len() {
                let h = 1e-5;
                let mut tp = theta;
                let mut tm = theta;
                tp[j] += h;
                tm[j] -= h;
                let fp = obj.value_grad(&tp).expect("factors").0;
                let fm = obj.value_grad(&tm).expect("factors").0;
                let fd = (fp - fm) / (2.0 * h);
                // Central differences are accurate to O(h²) plus rounding ~1e-9 here.
                assert!(
                    (fd - grad[j]).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "{kernel} θ[{j}]: analytic {} vs finite difference {fd}",
                    grad[j]
                );
            }
        }
    }
}
