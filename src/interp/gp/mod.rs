//! Gaussian-process (kriging) error model: a smooth random-field prior on the error
//! e(x, y, z), conditioned on measured nodes, that predicts the error anywhere with a
//! one-sigma uncertainty, and advises where to measure next. Unlike the grid
//! interpolators in [`crate::interp`] it takes scattered points.
//!
//! # Model
//!
//! e(p) = m + f(p) with f ~ GP(0, k) and observations yᵢ = e(pᵢ) + εᵢ, εᵢ ~ N(0, σₙ²).
//! The kernel is anisotropic (ARD: one length scale ℓₐ per axis), with
//! r² = Σₐ ((pₐ − qₐ)/ℓₐ)²:
//!
//! | [`Kernel`] | k(p, q) | sample paths | reference |
//! |---|---|---|---|
//! | `SquaredExponential` | σ_f² exp(−r²/2) | infinitely differentiable | R&W Eqs. 4.9, 5.1 |
//! | `Matern52` (default) | σ_f² (1 + √5 r + 5r²/3) exp(−√5 r) | twice differentiable | R&W Eq. 4.17 |
//!
//! Matérn 5/2 is the default: machine errors are smooth but not analytic, and the
//! squared exponential's extreme smoothness makes it over-confident between nodes
//! (R&W §4.2.1, citing Stein 1999). Use the squared exponential for fields known to be analytic.
//!
//! The constant mean m is the generalised-least-squares estimate
//! m̂ = 1ᵀK⁻¹y / 1ᵀK⁻¹1 (ordinary kriging), not the sample mean: with few, clustered
//! nodes the sample mean is biased towards the clusters. Its estimation uncertainty
//! enters the predictive variance as in R&W §2.7, Eq. 2.42 with a vague prior on m, so
//! σ grows honestly when extrapolating far from the data.
//!
//! Prediction follows R&W Algorithm 2.1 (a Cholesky factor K + σₙ²I = LLᵀ, then
//! triangular solves) for the predictive mean and variance, Eqs. 2.25–2.26:
//! f̄* = m̂ + k*ᵀα with α = (K + σₙ²I)⁻¹(y − m̂), and
//! V\[f*\] = k(p*, p*) − vᵀv + (1 − bᵀv)²/bᵀb with v = L⁻¹k*, b = L⁻¹1.
//! [`Gp::predict_with_sigma`] returns the σ of the latent error f* (what the machine
//! does); [`Gp::predict_with_sigma_noisy`] adds σₙ² for comparing with a new measurement.
//!
//! # Hyperparameters
//!
//! θ = (ln ℓ_x, ln ℓ_y, ln ℓ_z, ln σ_f, ln σₙ) maximises the log marginal likelihood
//! (R&W Eq. 2.30 with y replaced by y − m̂, i.e. the likelihood profiled over m), whose
//! gradient ½ tr((ααᵀ − K⁻¹) ∂K/∂θⱼ) is analytic (R&W Eq. 5.9). The optimiser is a small
//! deterministic L-BFGS with Armijo backtracking on unconstrained variables u mapped into
//! the box below by a logistic function, θ = lo + (hi − lo)/(1 + e⁻ᵘ). It starts once
//! from a data-driven guess and [`GpConfig::restarts`] more times from log-uniform random
//! points drawn with [`GpConfig::seed`]; the best likelihood wins.
//!
//! Bounds (s = sample sd of e, or 1 µm if every e is equal):
//! - ℓₐ ∈ [10⁻² × smallest spacing between distinct coordinates on axis a,
//!   10² × extent of axis a]. An axis on which every point has the same coordinate
//!   carries no information; its length scale is fixed at 10³ × the largest extent
//!   (≥ 1 mm), i.e. the model is constant along it, like a one-node grid axis.
//! - σ_f ∈ [10⁻³ s, 10² s]; σₙ ∈ [10⁻⁶ s, 10 s].
//! - A nugget of 10⁻¹⁰ σ_f² is always on the diagonal (so noiseless data stay factorable
//!   at every length scale, however smooth the kernel); it is part of the observation
//!   noise and included in [`GpHyper::noise_sd_um`]. If the final factorisation still
//!   fails, the nugget is raised tenfold up to 10⁻⁴ σ_f² before [`GpError::Cholesky`].
//!
//! **Node uncertainty.** A node with `s_um` and `n` (and, from a session's reduction,
//! `n_eff`) carries its own standard uncertainty uᵢ = s/√n_eff ([`ErrorPoint::u_um`]):
//! the noise is heteroscedastic, K + diag(σₙ² + uᵢ²), with σₙ fitted for what the nodes'
//! own scatter does not hold (run-to-run variation, an unmodelled fine structure). The
//! likelihood's gradient in ln σₙ is unchanged (the uᵢ² are known constants). Nodes
//! without `s_um` have uᵢ = 0: a table without the columns fits as before. A predicted
//! measurement ([`Gp::predict_with_sigma_noisy`]) adds σₙ² only: a new node's own
//! uncertainty is not known. [`GpConfig::homoscedastic`] ignores the uᵢ.
//!
//! # Cost
//!
//! n fitted points, d ≤ 5 hyperparameters: each likelihood evaluation is O(n³) (the
//! Cholesky factor and K⁻¹ for the gradient) plus O(d n²), so a fit is O(n³) times the
//! number of evaluations (20–130 per start in the tests; at most 200 L-BFGS iterations).
//! In a debug build a 200-point fit with the default 9 starts takes 30–45 s, most of
//! it in the O(n³) factorisation and inverse. A prediction costs O(n) for the
//! mean and O(n²) for the variance (one triangular solve). [`Gp::next_nodes`] over C
//! candidates picking k costs O(C n²) once plus O(k C (n + k)).
//!
//! # Reference
//!
//! C. E. Rasmussen and C. K. I. Williams, *Gaussian Processes for Machine Learning*,
//! MIT Press, 2006 (R&W): Eqs. 2.25–2.26 (predictive mean and variance), 2.30 (log
//! marginal likelihood), Algorithm 2.1 (Cholesky-based prediction), Eq. 2.42 (explicit
//! mean), Eq. 5.9 (likelihood gradient).

mod kernel;
mod likelihood;

use std::fmt;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::base::{ERROR_UM, POSITION_MM};
use crate::interp::Interpolator;
use crate::table::ErrorPoint;

pub use kernel::Kernel;
use likelihood::{Objective, forward_substitute, inverse_lower};

/// The fewest points [`Gp::fit`] accepts.
pub(crate) const MIN_POINTS: usize = 3;

/// The most points [`Gp::fit`] and [`Gp::with_hyper`] accept: the fit is O(n³) per
/// likelihood evaluation (about 30 s for 500 points in a release build, minutes beyond)
/// and the comparison's cross-validation holds n factors of n² numbers (1 GB at 500).
/// Larger tables are refused with [`GpError::TooManyPoints`], which names the
/// alternatives: a grid method on a full grid, or fewer nodes.
pub const MAX_POINTS: usize = 500;

/// Relative nugget: σ_f² × this is always added to the diagonal (see the module docs).
const NUGGET: f64 = 1e-10;
/// The largest relative nugget tried before giving up on a factorisation.
const MAX_NUGGET: f64 = 1e-4;

/// How to fit a [`Gp`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GpConfig {
    /// Covariance function. Default [`Kernel::Matern52`].
    pub kernel: Kernel,
    /// Random optimiser starts in addition to the data-driven one (0 = that one only).
    /// Default 8. Fit time grows linearly with it.
    pub restarts: usize,
    /// Seed of the random starts; the same seed and data give the same fit. Default 0.
    pub seed: u64,
    /// Ignore the nodes' own uncertainty (`s_um`, `n`, `n_eff`): one homoscedastic σₙ,
    /// as before issue 16. Default false.
    #[serde(default)]
    pub homoscedastic: bool,
}

impl Default for GpConfig {
    fn default() -> Self {
        Self {
            kernel: Kernel::Matern52,
            restarts: 8,
            seed: 0,
            homoscedastic: false,
        }
    }
}

/// Fitted hyperparameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GpHyper {
    /// Correlation length along x, y, z (mm). An axis where every point has the same
    /// coordinate gets a fixed, very long length scale (constant along it).
    pub length_scales_mm: [f64; 3],
    /// Prior standard deviation σ_f of the latent error about the mean (µm).
    pub signal_sd_um: f64,
    /// Observation noise σₙ (µm), including the numerical nugget.
    pub noise_sd_um: f64,
    /// The generalised-least-squares constant mean m̂ (µm).
    pub mean_um: f64,
}

/// Why a Gaussian process cannot be fitted. Point indices are 0-based positions in the
/// slice given to [`Gp::fit`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpError {
    #[error("a Gaussian-process fit needs at least {min} points, got {got}")]
    TooFewPoints { got: usize, min: usize },
    #[error(
        "{got} points are more than the Gaussian process's limit of {max} (its cost grows as n³); \
         fit trilinear or spline to a full grid, or thin the nodes to at most {max}"
    )]
    TooManyPoints { got: usize, max: usize },
    #[error("points[{index}]: {field} = {value:e} is outside {bound}")]
    OutOfRange {
        index: usize,
        field: &'static str,
        value: f64,
        bound: String,
    },
    #[error("points[{index}]: {field} = {value} is not finite")]
    NonFinite {
        index: usize,
        field: &'static str,
        value: f64,
    },
    #[error(
        "points[{first}] and points[{second}] share the position ({x}, {y}, {z}) mm; \
         average repeated measurements before fitting"
    )]
    DuplicatePosition {
        first: usize,
        second: usize,
        x: f64,
        y: f64,
        z: f64,
    },
    #[error(
        "the covariance matrix is not positive definite even with a nugget of \
         {relative_nugget:e} × σ_f² on its diagonal"
    )]
    Cholesky { relative_nugget: f64 },
}

/// A Gaussian-process error model fitted to scattered nodes. See the module docs.
#[derive(Clone)]
pub struct Gp {
    kernel: Kernel,
    hyper: GpHyper,
    lml: f64,
    positions: Vec<[f64; 3]>,
    /// The fitted errors y, µm.
    values: Vec<f64>,
    /// Lower Cholesky factor of K + σₙ²I.
    l: DMatrix<f64>,
    /// (K + σₙ²I)⁻¹(y − m̂).
    alpha: DVector<f64>,
    /// L⁻¹1 and its squared norm 1ᵀ(K + σₙ²I)⁻¹1.
    b: DVector<f64>,
    bb: f64,
    lo: [f64; 3],
    hi: [f64; 3],
}

impl fmt::Debug for Gp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Gp")
            .field("kernel", &self.kernel)
            .field("points", &self.positions.len())
            .field("hyper", &self.hyper)
            .field("log_marginal_likelihood", &self.lml)
            .finish_non_exhaustive()
    }
}

impl Gp {
    /// Fits the hyperparameters and conditions on `points`.
    ///
    /// Rejects fewer than [`MIN_POINTS`] or more than [`MAX_POINTS`] points, a non-finite
    /// coordinate or error or one outside its physical range (±10⁶ mm, ±10⁶ µm:
    /// [`crate::base::limits`]), and two points at exactly the same position (average
    /// repeats first). The points need not
    /// form a grid; an axis along which every point has the same coordinate is allowed.
    pub fn fit(points: &[ErrorPoint], config: &GpConfig) -> Result<Gp, GpError> {
        let positions = validate(points)?;
        let y: Vec<f64> = points.iter().map(|p| p.e_um).collect();
        let (lo, hi) = bounding_box(&positions);
        let node_var = if config.homoscedastic {
            Vec::new()
        } else {
            node_variances(points)
        };
        let (objective, theta) = likelihood::maximise(config, &positions, &y, node_var, lo, hi);

        let (ls, sf2, sn2) = objective.unpack(&theta);
        Self::condition(config.kernel, positions, &objective, ls, sf2, sn2, lo, hi)
    }

    /// Conditions on `points` with the hyperparameters held at `hyper` (no likelihood
    /// search): e.g. the model of a subset, or of new nodes, under the same prior. The
    /// mean is re-estimated by GLS; `hyper.mean_um` is ignored. Same checks on the points
    /// as [`Gp::fit`].
    pub fn with_hyper(
        points: &[ErrorPoint],
        kernel: Kernel,
        hyper: &GpHyper,
    ) -> Result<Gp, GpError> {
        let positions = validate(points)?;
        let y: Vec<f64> = points.iter().map(|p| p.e_um).collect();
        let (lo, hi) = bounding_box(&positions);
        let ls = hyper.length_scales_mm;
        let objective = Objective::new(kernel, &positions, &y, Vec::new(), ls)
            .with_node_var(node_variances(points));
        let sf2 = hyper.signal_sd_um.powi(2);
        // The fitted noise includes the nugget, which factoring adds again.
        let sn2 = (hyper.noise_sd_um.powi(2) - NUGGET * sf2).max(0.0);
        Self::condition(kernel, positions, &objective, ls, sf2, sn2, lo, hi)
    }

    /// Factors K + σₙ²I at the given hyperparameters (raising the nugget if it must) and
    /// builds the model.
    #[allow(clippy::too_many_arguments)]
    fn condition(
        kernel: Kernel,
        positions: Vec<[f64; 3]>,
        objective: &Objective<'_>,
        ls: [f64; 3],
        sf2: f64,
        sn2: f64,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> Result<Gp, GpError> {
        let mut nugget = NUGGET;
        let factor = loop {
            if let Some(f) = objective.factor(ls, sf2, sn2, nugget) {
                break f;
            }
            nugget *= 10.0;
            if nugget > MAX_NUGGET * (1.0 + 1e-9) {
                return Err(GpError::Cholesky {
                    relative_nugget: nugget / 10.0,
                });
            }
        };
        let hyper = GpHyper {
            length_scales_mm: ls,
            signal_sd_um: sf2.sqrt(),
            noise_sd_um: (sn2 + nugget * sf2).sqrt(),
            mean_um: factor.mean,
        };
        let b = factor.l_inv_ones;
        let bb = b.norm_squared();
        Ok(Gp {
            kernel,
            hyper,
            lml: factor.lml,
            positions,
            values: objective.y.to_vec(),
            l: factor.chol.unpack(),
            alpha: factor.alpha,
            b,
            bb,
            lo,
            hi,
        })
    }

    /// Leave-one-out predictions of every fitted node from all the others, with the
    /// hyperparameters held and the GLS mean re-estimated in each fold, in closed form
    /// (Dubrule 1983; R&W Eq. 5.12 for a known mean): with
    /// Q = K⁻¹ − K⁻¹11ᵀK⁻¹ / 1ᵀK⁻¹1 (K including the noise), the held-out residual is
    /// yᵢ − ŷ₋ᵢ = (Qy)ᵢ / Qᵢᵢ = αᵢ / Qᵢᵢ and its one-sigma, for a measured value, is
    /// 1/√Qᵢᵢ. Returns (ŷ₋ᵢ, σ₋ᵢ) per node in fit order. O(n³), one inverse.
    pub fn leave_one_out(&self) -> Vec<(f64, f64)> {
        let n = self.positions.len();
        let ki = inverse_lower(self.l.as_slice(), n);
        let at = |i: usize, j: usize| if i >= j { ki[i + j * n] } else { ki[j + i * n] };
        (0..n)
            .map(|i| {
                let kinv_1: f64 = (0..n).map(|j| at(i, j)).sum();
                let q = at(i, i) - kinv_1 * kinv_1 / self.bb;
                (self.values[i] - self.alpha[i] / q, q.recip().sqrt())
            })
            .collect()
    }

    /// The fitted hyperparameters.
    pub fn hyper(&self) -> &GpHyper {
        &self.hyper
    }

    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The number of fitted points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Always false: a fitted model has at least [`MIN_POINTS`] points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// ln p(y | X, θ̂) at the fitted hyperparameters, with the mean at its GLS estimate
    /// (R&W Eq. 2.30 applied to y − m̂).
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Predictive mean (µm) and one-sigma (µm) of the latent error at `p` (mm), excluding
    /// observation noise but including the uncertainty of the estimated mean. At a fitted
    /// node σ is at most about the noise sd. Costs O(n²).
    pub fn predict_with_sigma(&self, p: [f64; 3]) -> (f64, f64) {
        let k = self.cross(p);
        let mean = self.hyper.mean_um + k.dot(&self.alpha);
        let v = forward_substitute(&self.l, k);
        (mean, self.latent_variance(&v).sqrt())
    }

    /// Like [`Gp::predict_with_sigma`], with the observation noise σₙ² added to the
    /// variance: the one-sigma spread of a new *measurement* at `p`, the right σ for
    /// judging a measured test value.
    pub fn predict_with_sigma_noisy(&self, p: [f64; 3]) -> (f64, f64) {
        let (mean, sigma) = self.predict_with_sigma(p);
        (mean, sigma.hypot(self.hyper.noise_sd_um))
    }

    /// The largest latent one-sigma (µm) over `candidates`; 0 for none.
    pub fn max_sigma(&self, candidates: &[[f64; 3]]) -> f64 {
        candidates
            .iter()
            .map(|&c| self.predict_with_sigma(c).1)
            .fold(0.0, f64::max)
    }

    /// Where to measure next: up to `n` of `candidates`, in pick order. Greedy: take the
    /// candidate with the largest latent variance (the first such on ties), add it as a
    /// pseudo-observation with the fitted noise (the GP variance does not depend on the
    /// value observed), and repeat. Each candidate is picked at most once, so fewer than
    /// `n` come back when there are fewer candidates. Hyperparameters stay fixed.
    ///
    /// Cost O(C n²) for C candidates, then O(C (n + k)) per pick k.
    pub fn next_nodes(&self, candidates: &[[f64; 3]], n: usize) -> Vec<[f64; 3]> {
        let count = n.min(candidates.len());
        if count == 0 {
            return Vec::new();
        }
        let sf2 = self.hyper.signal_sd_um.powi(2);
        let noise2 = self.hyper.noise_sd_um.powi(2);
        // v_c = L⁻¹k_c and r_c = 1 − bᵀv_c for every candidate: the posterior covariance
        // given the data is cov₀(c, d) = k(c, d) − v_cᵀv_d + r_c r_d / bᵀb.
        let v: Vec<DVector<f64>> = candidates
            .iter()
            .map(|&c| forward_substitute(&self.l, self.cross(c)))
            .collect();
        let r: Vec<f64> = v.iter().map(|v| 1.0 - self.b.dot(v)).collect();
        let mut var: Vec<f64> = v.iter().map(|v| self.latent_variance(v)).collect();
        // Rank-one updates after each pseudo-observation: cov_k = cov₀ − Σⱼ uⱼ uⱼᵀ.
        let mut updates: Vec<Vec<f64>> = Vec::with_capacity(count);
        let mut picked = vec![false; candidates.len()];
        let mut out = Vec::with_capacity(count);
        for _ in 0..count {
            let mut pick = None;
            for (c, &vc) in var.iter().enumerate() {
                if !picked[c] && pick.is_none_or(|(_, best)| vc > best) {
                    pick = Some((c, vc));
                }
            }
            let Some((p, var_p)) = pick else { break };
            picked[p] = true;
            out.push(candidates[p]);
            let scale = 1.0 / (var_p.max(0.0) + noise2).sqrt();
            let u: Vec<f64> = (0..candidates.len())
                .map(|c| {
                    let mut cov = sf2 * self.kernel.corr(self.r2(candidates[c], candidates[p]))
                        - v[c].dot(&v[p])
                        + r[c] * r[p] / self.bb;
                    for prev in &updates {
                        cov -= prev[c] * prev[p];
                    }
                    cov * scale
                })
                .collect();
            for (vc, uc) in var.iter_mut().zip(&u) {
                *vc = (*vc - uc * uc).max(0.0);
            }
            updates.push(u);
        }
        out
    }

    /// Scaled squared distance r² between two positions.
    fn r2(&self, p: [f64; 3], q: [f64; 3]) -> f64 {
        (0..3)
            .map(|a| ((p[a] - q[a]) / self.hyper.length_scales_mm[a]).powi(2))
            .sum()
    }

    /// k* = k(X, p), the covariances between the fitted points and `p`.
    fn cross(&self, p: [f64; 3]) -> DVector<f64> {
        let sf2 = self.hyper.signal_sd_um.powi(2);
        DVector::from_iterator(
            self.positions.len(),
            self.positions
                .iter()
                .map(|&x| sf2 * self.kernel.corr(self.r2(x, p))),
        )
    }

    /// σ_f² − vᵀv + (1 − bᵀv)²/bᵀb for v = L⁻¹k*, clamped at 0.
    fn latent_variance(&self, v: &DVector<f64>) -> f64 {
        let r = 1.0 - self.b.dot(v);
        (self.hyper.signal_sd_um.powi(2) - v.norm_squared() + r * r / self.bb).max(0.0)
    }
}

impl Interpolator for Gp {
    /// The predictive mean (µm).
    fn predict(&self, p: [f64; 3]) -> f64 {
        let k = self.cross(p);
        self.hyper.mean_um + k.dot(&self.alpha)
    }

    /// One-sigma uncertainty of a measured value at `p`: the latent σ with the fitted
    /// observation noise added (what a test point's measured error should fall within).
    fn sigma(&self, p: [f64; 3]) -> Option<f64> {
        Some(self.predict_with_sigma_noisy(p).1)
    }

    /// Outside the bounding box of the fitted points on any axis (relative tolerance 1e-9).
    fn outside(&self, p: [f64; 3]) -> bool {
        (0..3).any(|a| {
            let tol = 1e-9 * (self.hi[a] - self.lo[a]).abs().max(1.0);
            p[a] < self.lo[a] - tol || p[a] > self.hi[a] + tol
        })
    }
}

/// The smallest and largest coordinate per axis.
/// Each node's own noise variance uᵢ², µm² (0 without `s_um`); empty when no node has one.
fn node_variances(points: &[ErrorPoint]) -> Vec<f64> {
    let v: Vec<f64> = points
        .iter()
        .map(|p| p.u_um().map_or(0.0, |u| u * u))
        .collect();
    if v.iter().any(|&u| u > 0.0) {
        v
    } else {
        Vec::new()
    }
}

fn bounding_box(positions: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

fn validate(points: &[ErrorPoint]) -> Result<Vec<[f64; 3]>, GpError> {
    if points.len() < MIN_POINTS {
        return Err(GpError::TooFewPoints {
            got: points.len(),
            min: MIN_POINTS,
        });
    }
    if points.len() > MAX_POINTS {
        return Err(GpError::TooManyPoints {
            got: points.len(),
            max: MAX_POINTS,
        });
    }
    for (index, p) in points.iter().enumerate() {
        for (field, value) in [
            ("x_mm", p.x_mm),
            ("y_mm", p.y_mm),
            ("z_mm", p.z_mm),
            ("e_um", p.e_um),
        ] {
            if !value.is_finite() {
                return Err(GpError::NonFinite {
                    index,
                    field,
                    value,
                });
            }
            // Inside the physical ranges the extents, spacings and scales of the
            // hyperparameter bounds stay finite (1e308 would make them inf).
            let bound = if field == "e_um" {
                ERROR_UM
            } else {
                POSITION_MM
            };
            if !bound.contains(value) {
                return Err(GpError::OutOfRange {
                    index,
                    field,
                    value,
                    bound: bound.to_string(),
                });
            }
        }
    }
    let positions: Vec<[f64; 3]> = points.iter().map(ErrorPoint::position).collect();
    let mut order: Vec<usize> = (0..positions.len()).collect();
    let key = |i: usize| positions[i];
    order.sort_by(|&a, &b| {
        let (pa, pb) = (key(a), key(b));
        pa[0]
            .total_cmp(&pb[0])
            .then(pa[1].total_cmp(&pb[1]))
            .then(pa[2].total_cmp(&pb[2]))
            .then(a.cmp(&b))
    });
    for w in order.windows(2) {
        if key(w[0]) == key(w[1]) {
            let (first, second) = (w[0].min(w[1]), w[0].max(w[1]));
            let [x, y, z] = positions[second];
            return Err(GpError::DuplicatePosition {
                first,
                second,
                x,
                y,
                z,
            });
        }
    }
    Ok(positions)
}
