//! Identification of the 21 errors from a line table: weighted linear least squares with
//! one free constant per line, the gauge of [`super::basis`], one-sigma bands, the
//! identifiability analysis, the degree chosen by leave-one-line-out cross-validation,
//! and a test of the residual against the noise. Method and conventions: [`super`].

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::basis::{Basis, BasisKind};
use super::choice::{
    Engine, Model, Outcome, RELAX, RICHER_DEGREES, evaluate, poly_model, relaxed, spline_model,
};
use super::error::{Unfit, VolumetricError};
use super::lines::LineTable;
use super::model::{Component, Topology};
pub use super::residual::Z_MISSING;
use super::residual::residual_test;
use super::thermal::{self, ThermalTest};
use crate::diagnose::FoundEffect;

/// Relative tolerance on singular values (after column equilibration) below which a
/// direction of the design is taken as undetermined.
pub(crate) const RANK_TOL: f64 = 1e-8;
/// A component is undetermined when any of its parameters has a null-space weight above
/// this (rows of an orthonormal null-space basis, equilibrated coordinates).
pub(crate) const NULL_TOL: f64 = 1e-6;

/// The highest polynomial degree of a component (a fixed degree, `auto`'s maximum, a
/// per-component degree). Beyond it a line of the usual 11–21 targets determines nothing
/// more, and the catalogue search for lines that would grows steeply with the degree
/// (issue 17: degree 40 ran for minutes).
pub const MAX_DEGREE: usize = 12;

/// The most report positions per component (`positions`): 21 components × 10⁴ positions
/// is a JSON document of a few MB; a billion allocated 24 GB (issue 28).
pub const MAX_REPORT_POSITIONS: usize = 10_000;

/// Degree of the component polynomials.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Degree {
    /// Chosen by leave-one-line-out cross-validation among 1..=max.
    Auto {
        max: usize,
    },
    /// As `Auto`, then each component's own degree by the same cross-validation
    /// ([`super::degree`]).
    AutoEach {
        max: usize,
    },
    Fixed(usize),
}

/// What `identify` needs besides the lines.
#[derive(Debug, Clone)]
pub struct IdentifyConfig {
    pub topology: Topology,
    /// Tables at knots (the default) or polynomials.
    pub basis: BasisKind,
    /// Polynomial degree (the polynomial basis only).
    pub degree: Degree,
    /// Per-component degrees that override the global one (index 0..18).
    pub component_degrees: BTreeMap<usize, usize>,
    /// Positions per component in the report (at least 5; 0 is added).
    pub positions: usize,
}

impl IdentifyConfig {
    pub fn new(topology: Topology) -> IdentifyConfig {
        IdentifyConfig {
            topology,
            basis: BasisKind::default(),
            degree: Degree::Auto { max: 4 },
            component_degrees: BTreeMap::new(),
            positions: 21,
        }
    }
}

/// Everything needed to evaluate the identified errors and their uncertainty (the `fit`
/// object of MODEL.json).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitState {
    pub basis: Basis,
    /// Parameters in the basis' layout.
    pub theta: Vec<f64>,
    /// Their covariance (scaled by the residual), row by row.
    pub covariance: Vec<Vec<f64>>,
    /// Orthonormal null space of the equilibrated design, one row per parameter.
    pub null_space: Vec<Vec<f64>>,
    /// Column equilibration: parameter j in equilibrated coordinates is θ_j·scale_j.
    pub column_scale: Vec<f64>,
    /// Per component (18) and squareness (3): determined by the lines?
    pub identified: Vec<bool>,
    /// Tables at knots: per component (18), the intensity q_c = φ/λ_c of the roughness
    /// prior the smoothing fitted (µm² or µrad² per cubed unit of the normalised axis;
    /// 0 for a component not penalised). Between two knots a component's variance gains
    /// q_c·H³·w²(1 − w)²/2 — H the interval in the normalised axis, w the fraction of it —
    /// the prior's variance of the true function about the table's chord
    /// ([`super::smooth`]). Empty for polynomials.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub roughness: Vec<f64>,
}

impl FitState {
    /// Value and one-sigma of `g·θ` for a linear functional `g` of the parameters, or
    /// `None` when the lines do not determine it.
    pub fn functional(&self, g: &[f64]) -> Option<(f64, f64)> {
        let gs: Vec<f64> = g
            .iter()
            .zip(&self.column_scale)
            .map(|(a, s)| a / s)
            .collect();
        let norm = gs.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 && !self.null_space.is_empty() {
            let q = self.null_space[0].len();
            for k in 0..q {
                let p: f64 = gs.iter().zip(&self.null_space).map(|(a, n)| a * n[k]).sum();
                if p.abs() > NULL_TOL * norm {
                    return None;
                }
            }
        }
        let v: f64 = g.iter().zip(&self.theta).map(|(a, b)| a * b).sum();
        let mut var = 0.0;
        for (i, gi) in g.iter().enumerate() {
            if *gi == 0.0 {
                continue;
            }
            for (j, gj) in g.iter().enumerate() {
                var += gi * self.covariance[i][j] * gj;
            }
        }
        Some((v, var.max(0.0).sqrt()))
    }

    /// Component `c` (0..18) at `a_mm`: value and one-sigma, `None` if undetermined.
    /// For tables at knots the σ includes the roughness prior's variance between knots
    /// ([`FitState::between_knots_var`]).
    pub fn component(&self, c: usize, a_mm: f64) -> Option<(f64, f64)> {
        if !self.identified[c] {
            return None;
        }
        let mut g = vec![0.0; self.theta.len()];
        let o = self.basis.offset(c);
        for (j, f) in self.basis.functions(c, a_mm).into_iter().enumerate() {
            g[o + j] = f;
        }
        let (v, s) = self.functional(&g)?;
        let extra = self.between_knots_var(c, a_mm);
        Some((v, (s * s + extra).sqrt()))
    }

    /// The roughness prior's variance of component `c` at `a_mm` about the chord of its
    /// table: q_c·H³·w²(1 − w)²/2 (0 at knots, outside the knots and for polynomials).
    /// For f′ a Brownian motion of intensity q′ (the prior whose discrete form is the
    /// second-difference penalty, q′ = 1.5·q_c), the deviation of f from its chord over an
    /// interval of length H, given the values at both ends, has variance
    /// q′·t²(H − t)²/(3H) at distance t from the left knot.
    pub fn between_knots_var(&self, c: usize, a_mm: f64) -> f64 {
        let (Some(q), Some(knots)) = (self.roughness.get(c), self.basis.knots_mm.as_ref()) else {
            return 0.0;
        };
        let axis = Component::from_index(c).axis;
        let kn = &knots[axis];
        if q.is_nan() || *q <= 0.0 || kn.len() < 2 || a_mm < kn[0] || a_mm > kn[kn.len() - 1] {
            return 0.0;
        }
        let (s, w) = super::spline::segment(kn, a_mm);
        let h = (kn[s + 1] - kn[s]) / self.basis.scale_mm[axis];
        q * h.powi(3) * (w * (1.0 - w)).powi(2) / 2.0
    }

    /// Squareness `i` (E_C0Y, E_B0Z, E_A0Z), µrad, with one-sigma.
    pub fn squareness(&self, i: usize) -> Option<(f64, f64)> {
        if !self.identified[18 + i] {
            return None;
        }
        let mut g = vec![0.0; self.theta.len()];
        g[self.basis.offset(18 + i)] = 1.0;
        self.functional(&g)
    }
}

/// A cross-validation score of one degree.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CvScore {
    pub degree: usize,
    /// RMS of the held-out lines' residuals (each line's constant refitted), µm.
    pub cv_rms_um: f64,
    /// Components identified at this degree.
    pub identified: usize,
}

/// The residual of one line, in the order of its targets along the line.
#[derive(Debug, Clone, Serialize)]
pub struct LineResidual {
    pub line: String,
    pub s_mm: Vec<f64>,
    pub t_s: Vec<Option<f64>>,
    pub r_um: Vec<f64>,
}

/// The residual's verdict: the scale-expansion term when the table has temperatures and
/// it is significant ([`super::thermal`]), then a test of what remains against the noise
/// (an `unexplained` effect when it fails). Effects in `cli-contract.md`'s shape.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualVerdict {
    pub verdict: crate::base::Verdict,
    pub effects: Vec<FoundEffect>,
    /// `chi-square` (s_um given) or `lag-1 autocorrelation` (no s_um).
    pub test: String,
    /// The test's standard-normal statistic (Wilson–Hilferty z, or ρ·√n).
    pub z: f64,
    /// When the test fails: the lines carrying most of the residual.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub carriers: Vec<super::residual::Carrier>,
}

/// Components the lines cannot determine and the line that would.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Unidentified {
    pub components: Vec<String>,
    pub why: String,
}

/// The result of `identify`.
#[derive(Debug, Clone)]
pub struct Identification {
    pub topology: Topology,
    /// The polynomial degree (highest of the components'; 0 for tables at knots).
    pub degree: usize,
    pub cv: Vec<CvScore>,
    pub fit: FitState,
    pub lines: usize,
    pub targets: usize,
    pub rms_residual_um: f64,
    /// Reduced chi-square's square root (the factor σ bands were scaled by).
    pub sigma0: f64,
    /// Residual degrees of freedom (rows − lines − effective parameters).
    pub dof: f64,
    pub weighted: bool,
    pub residuals: Vec<LineResidual>,
    pub residual: ResidualVerdict,
    pub unidentified: Vec<Unidentified>,
    /// The scale-expansion test, when every row has `scale_temp_c`.
    pub thermal: Option<ThermalTest>,
    /// The per-component degree search (`Degree::AutoEach`).
    pub cv_each: Option<super::degree::EachScore>,
    /// The smoothing of tables at knots (`None` for polynomials).
    pub smoothing: Option<Smoothing>,
}

/// What the smoothing of tables at knots did (JSON and `model.json` `smoothing`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Smoothing {
    /// How λ was chosen.
    pub criterion: String,
    /// The roughness measure penalised.
    pub penalty: String,
    /// REML's λ were multiplied by this (1 unless the residual test asked for rougher
    /// tables).
    pub relaxed_by: f64,
    /// √(χ²/ν) of the reported fit.
    pub birge_ratio: f64,
    /// The factor the covariance carries: 1 (the stated noise) or B² when B > 1; χ²/ν
    /// without s_um.
    pub covariance_scale: f64,
    /// Per component: knots, λ (equilibrated units) and effective degrees of freedom;
    /// components the lines do not determine are not penalised and not listed.
    pub components: BTreeMap<String, ComponentSmoothing>,
}

/// One component's smoothing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComponentSmoothing {
    pub knots: usize,
    pub lambda: f64,
    pub edf: f64,
}

impl Smoothing {
    pub(crate) fn of(
        basis: &Basis,
        pen: &super::smooth::Penalty,
        edf_block: &[f64],
        relaxed_by: f64,
        birge_ratio: f64,
        known_noise: bool,
    ) -> Smoothing {
        let components = pen
            .blocks
            .iter()
            .zip(&pen.lambda)
            .enumerate()
            .map(|(i, (b, l))| {
                let c = Component::from_index(b.component);
                let knots = basis.knots_mm.as_ref().map_or(0, |k| k[c.axis].len());
                (
                    c.name(),
                    ComponentSmoothing {
                        knots,
                        lambda: *l,
                        edf: edf_block.get(i).copied().unwrap_or(f64::NAN),
                    },
                )
            })
            .collect();
        let ratio = birge_ratio * birge_ratio;
        Smoothing {
            criterion: "REML, one λ per component (Fellner–Schall iteration)".into(),
            penalty: "squared second divided differences of the knot values (∫f''² in a/L)".into(),
            relaxed_by,
            birge_ratio,
            covariance_scale: if known_noise { ratio.max(1.0) } else { ratio },
            components,
        }
    }
}

/// The centred, weighted design of a line table under a basis.
pub(crate) struct Design {
    /// Equilibrated, centred, weighted rows (rows × params).
    pub a: DMatrix<f64>,
    pub e: DVector<f64>,
    /// Row range of each line.
    pub line_rows: Vec<std::ops::Range<usize>>,
    pub sqrt_w: Vec<f64>,
    pub scale: Vec<f64>,
}

pub(crate) fn weights(table: &LineTable) -> Option<Vec<f64>> {
    let all = table
        .lines
        .iter()
        .flat_map(|l| &l.targets)
        .map(|t| t.s_um)
        .collect::<Option<Vec<f64>>>()?;
    Some(all.into_iter().map(|s| 1.0 / s).collect())
}

pub(crate) fn design(table: &LineTable, basis: &Basis, sqrt_w: &[f64]) -> Design {
    let n = basis.n_params();
    let rows = table.targets();
    let mut a = DMatrix::zeros(rows, n);
    let mut e = DVector::zeros(rows);
    let mut line_rows = Vec::new();
    // Norm of each column before centring: a column that centring cancels to rounding
    // level (a parameter no line sees) must stay zero, not be equilibrated into noise.
    let mut raw = vec![0.0f64; n];
    let mut r = 0;
    for line in &table.lines {
        let start = r;
        let mut g_mean = vec![0.0; n];
        let mut e_mean = 0.0;
        let mut w_sum = 0.0;
        for t in &line.targets {
            let g = basis.line_row(t.pos_mm, line.u, line.probe_mm);
            let w = sqrt_w[r] * sqrt_w[r];
            for j in 0..n {
                a[(r, j)] = g[j];
                g_mean[j] += w * g[j];
                raw[j] += w * g[j] * g[j];
            }
            e[r] = t.e_um.unwrap_or(0.0);
            e_mean += w * e[r];
            w_sum += w;
            r += 1;
        }
        for i in start..r {
            for j in 0..n {
                a[(i, j)] = sqrt_w[i] * (a[(i, j)] - g_mean[j] / w_sum);
            }
            e[i] = sqrt_w[i] * (e[i] - e_mean / w_sum);
        }
        line_rows.push(start..r);
    }
    let scale: Vec<f64> = (0..n)
        .map(|j| {
            let s = a.column(j).norm();
            if s > 1e-10 * raw[j].sqrt() && s > 0.0 {
                s
            } else {
                a.column_mut(j).fill(0.0);
                1.0
            }
        })
        .collect();
    for (j, s) in scale.iter().enumerate() {
        a.column_mut(j).scale_mut(1.0 / s);
    }
    Design {
        a,
        e,
        line_rows,
        sqrt_w: sqrt_w.to_vec(),
        scale,
    }
}

/// SVD pieces of an equilibrated design: range basis, singular values, null basis.
pub(crate) struct Decomposition {
    pub v_range: DMatrix<f64>,
    pub sv_range: Vec<f64>,
    pub u_range: DMatrix<f64>,
    pub null: DMatrix<f64>,
}

pub(crate) fn decompose(a: &DMatrix<f64>) -> Decomposition {
    decompose_with(a, None)
}

/// As [`decompose`], with singular values at or below `abs_tol` (instead of
/// [`RANK_TOL`] × the largest) counted as null.
pub(crate) fn decompose_with(a: &DMatrix<f64>, abs_tol: Option<f64>) -> Decomposition {
    let (m, n) = a.shape();
    let padded = if m < n {
        let mut p = DMatrix::zeros(n, n);
        p.view_mut((0, 0), (m, n)).copy_from(a);
        p
    } else {
        a.clone()
    };
    let svd = padded.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        unreachable!("SVD computed with u and v")
    };
    let smax = svd.singular_values.iter().fold(0.0f64, |a, &b| a.max(b));
    let tol = abs_tol.unwrap_or(RANK_TOL * smax);
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| smax > 0.0 && svd.singular_values[i] > tol)
        .collect();
    let drop: Vec<usize> = (0..n).filter(|i| !keep.contains(i)).collect();
    let v_range = DMatrix::from_fn(n, keep.len(), |i, k| v_t[(keep[k], i)]);
    let u_range = DMatrix::from_fn(m, keep.len(), |i, k| u[(i, keep[k])]);
    let null = DMatrix::from_fn(n, drop.len(), |i, k| v_t[(drop[k], i)]);
    Decomposition {
        sv_range: keep.iter().map(|&i| svd.singular_values[i]).collect(),
        v_range,
        u_range,
        null,
    }
}

/// Which of the 21 components a null space leaves undetermined.
pub(crate) fn identified_flags(basis: &Basis, null: &DMatrix<f64>) -> Vec<bool> {
    (0..21)
        .map(|c| basis.params(c).all(|j| null.row(j).norm() <= NULL_TOL))
        .collect()
}

fn axis_range(table: &LineTable) -> [[f64; 2]; 3] {
    let mut r = [[0.0f64; 2]; 3];
    for t in table.lines.iter().flat_map(|l| &l.targets) {
        for (rk, p) in r.iter_mut().zip(t.pos_mm) {
            rk[0] = rk[0].min(p);
            rk[1] = rk[1].max(p);
        }
    }
    r
}

pub(crate) fn degrees(config: &IdentifyConfig, d: usize) -> Vec<usize> {
    (0..18)
        .map(|c| config.component_degrees.get(&c).copied().unwrap_or(d))
        .collect()
}

/// Leave-one-line-out score of a design: per held-out line, the others' fit predicts its
/// (centred) profile. Returns the sum of squared weighted residuals per line, `None` for
/// a line the others cannot predict (it alone determines some direction).
pub(crate) fn cv_per_line(d: &Design) -> Vec<Option<f64>> {
    let dec = decompose(&d.a);
    let ah = &d.a * &dec.v_range;
    let g = ah.transpose() * &ah;
    let b = ah.transpose() * &d.e;
    d.line_rows
        .iter()
        .map(|rows| {
            let aj = ah.rows(rows.start, rows.len());
            let ej = d.e.rows(rows.start, rows.len());
            let h = &g - aj.transpose() * aj;
            let bj = &b - aj.transpose() * ej;
            let maxd = h.diagonal().max();
            let chol = nalgebra::Cholesky::new(h)?;
            let mind = chol.l_dirty().diagonal().map(|x| x * x).min();
            if mind.is_nan() || mind <= 1e-12 * maxd {
                return None;
            }
            let phi = chol.solve(&bj);
            let res = ej - aj * phi;
            Some(res.norm_squared())
        })
        .collect()
}

/// A solved least-squares problem (or a penalised one, `smooth.rs`), parameters unscaled.
#[derive(Debug)]
pub(crate) struct Solved {
    pub theta: Vec<f64>,
    pub cov: DMatrix<f64>,
    /// Weighted residual per row.
    pub res_w: DVector<f64>,
    pub chi2: f64,
    pub dof: f64,
    pub sigma0: f64,
    pub null: DMatrix<f64>,
    /// Effective degrees of freedom per penalised component (tables only).
    pub edf_block: Vec<f64>,
}

/// θ = V Σ⁻¹ Uᵀ e on the determined subspace, the covariance σ₀²·V Σ⁻² Vᵀ, the null space.
pub(crate) fn solve(d: &Design, n_lines: usize) -> Result<Solved, Unfit> {
    let dec = decompose(&d.a);
    let rank = dec.sv_range.len();
    let rows = d.a.nrows();
    if rows <= rank + n_lines {
        return Err(Unfit::NoFreedom {
            rows,
            lines: n_lines,
            rank,
        });
    }
    let dof = (rows - rank - n_lines) as f64;
    let ut_e = dec.u_range.transpose() * &d.e;
    let coef = DVector::from_fn(rank, |k, _| ut_e[k] / dec.sv_range[k]);
    let theta_s = &dec.v_range * coef;
    let res_w = &d.e - &d.a * &theta_s;
    let chi2 = res_w.norm_squared();
    let sigma0 = (chi2 / dof).sqrt();
    let n = d.a.ncols();
    let vs = DMatrix::from_fn(n, rank, |i, k| dec.v_range[(i, k)] / dec.sv_range[k]);
    let cov_s = &vs * vs.transpose() * (sigma0 * sigma0);
    Ok(Solved {
        theta: (0..n).map(|j| theta_s[j] / d.scale[j]).collect(),
        cov: DMatrix::from_fn(n, n, |i, j| cov_s[(i, j)] / (d.scale[i] * d.scale[j])),
        res_w,
        chi2,
        dof,
        sigma0,
        null: dec.null,
        edf_block: Vec::new(),
    })
}

/// `v` (one value per row, in the table's row order) with each line's weighted mean
/// removed, `w` the row weights: what a column must be before [`augment`].
pub(crate) fn centre_per_line(table: &LineTable, w: &[f64], v: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let mut r = 0;
    for line in &table.lines {
        let n = line.targets.len();
        let (vs, ws) = (&v[r..r + n], &w[r..r + n]);
        let mean = vs.iter().zip(ws).map(|(a, b)| a * b).sum::<f64>() / ws.iter().sum::<f64>();
        out.extend(vs.iter().map(|x| x - mean));
        r += n;
    }
    out
}

/// The design with one more column (unweighted, centred per line), equilibrated; `None`
/// when the column is zero.
pub(crate) fn augment(d: &Design, col: &[f64]) -> Option<Design> {
    let weighted: Vec<f64> = col.iter().zip(&d.sqrt_w).map(|(a, b)| a * b).collect();
    let norm = weighted.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let n = d.a.ncols();
    let mut a = d.a.clone().insert_column(n, 0.0);
    for (i, v) in weighted.iter().enumerate() {
        a[(i, n)] = v / norm;
    }
    let mut scale = d.scale.clone();
    scale.push(norm);
    Some(Design {
        a,
        e: d.e.clone(),
        line_rows: d.line_rows.clone(),
        sqrt_w: d.sqrt_w.clone(),
        scale,
    })
}

/// The joint fit with the scale-expansion column and its t-test ([`super::thermal`]).
pub(crate) fn thermal_fit(
    d: &Design,
    col: &thermal::ThermalColumn,
    n_lines: usize,
    engine: &super::choice::Engine,
) -> (ThermalTest, Option<Solved>) {
    let mut test = ThermalTest {
        alpha_ppm_per_k: None,
        sigma_ppm_per_k: None,
        t: None,
        kept: false,
        temp_c: col.temp_c,
        t_s: col.t_s,
        explains_um: 0.0,
    };
    let Some(aug) = augment(d, &col.centred) else {
        return (test, None);
    };
    let Ok(solved) = engine.solve(&aug, n_lines) else {
        return (test, None);
    };
    let n = d.a.ncols();
    if solved.null.nrows() > n && solved.null.row(n).norm() > NULL_TOL {
        return (test, None);
    }
    let alpha = solved.theta[n];
    let sigma = solved.cov[(n, n)].max(0.0).sqrt();
    // σ = 0 (an exact fit): significant beyond any bound when α explains something, not
    // at all when α = 0; the unbounded t is not a number a document can carry (`None`).
    let t = if sigma > 0.0 {
        Some(alpha.abs() / sigma)
    } else if alpha != 0.0 {
        None
    } else {
        Some(0.0)
    };
    test.alpha_ppm_per_k = Some(alpha);
    test.sigma_ppm_per_k = Some(sigma);
    test.t = t;
    test.kept = t.is_none_or(|t| t > thermal::THERMAL_T);
    if !test.kept {
        return (test, None);
    }
    let contribution: Vec<f64> = col.centred.iter().map(|g| alpha * g).collect();
    test.explains_um = crate::base::rms(&contribution).unwrap_or(0.0);
    (test, Some(solved))
}

/// What every candidate model of one identification shares: the table, the configuration,
/// the axis ranges and the row weights (with the thermal column built on them).
struct FitInputs<'a> {
    table: &'a LineTable,
    config: &'a IdentifyConfig,
    range: [[f64; 2]; 3],
    sqrt_w: Vec<f64>,
    row_w: Vec<f64>,
    thermal_col: Option<thermal::ThermalColumn>,
    weighted: bool,
}

impl FitInputs<'_> {
    /// Fits and tests model `m` ([`evaluate`]).
    fn evaluate(&self, m: &Model) -> Result<Outcome, Unfit> {
        evaluate(
            self.table,
            &m.d,
            &m.engine,
            self.thermal_col.as_ref(),
            &self.row_w,
            self.weighted,
        )
    }

    /// The thermal column centred per line, as the degree searches take it.
    fn thermal_centred(&self) -> Option<&[f64]> {
        self.thermal_col.as_ref().map(|c| c.centred.as_slice())
    }
}

/// The configured first model and what choosing it found (the polynomial degree and the
/// cross-validation scores; zero and empty for tables at knots).
struct FirstModel {
    model: Model,
    degree: usize,
    cv: Vec<CvScore>,
    cv_each: Option<super::degree::EachScore>,
}

/// A fit error naming the table's file.
fn fit_err(table: &LineTable, message: String) -> VolumetricError {
    VolumetricError::Fit {
        file: table.source.clone(),
        message,
    }
}

/// Refuses component degrees of 0 and any degree above [`MAX_DEGREE`] before anything is
/// fitted.
fn check_degrees(table: &LineTable, config: &IdentifyConfig) -> Result<(), VolumetricError> {
    if let Some((&c, &d)) = config.component_degrees.iter().find(|(_, d)| **d == 0) {
        return Err(fit_err(
            table,
            format!(
                "degree {d} for {}: degrees start at 1",
                Component::from_index(c).name()
            ),
        ));
    }
    let asked = match config.degree {
        Degree::Fixed(d) | Degree::Auto { max: d } | Degree::AutoEach { max: d } => d,
    };
    if let Some(d) = config
        .component_degrees
        .values()
        .copied()
        .chain([asked])
        .max()
        && d > MAX_DEGREE
    {
        return Err(fit_err(
            table,
            format!("degree {d} is above {MAX_DEGREE}, the highest component degree errmap fits"),
        ));
    }
    Ok(())
}

/// The configured model: tables at knots with REML's smoothing, or polynomials of the
/// fixed degree or the one cross-validation chooses (per component with `AutoEach`).
fn first_model(inp: &FitInputs) -> Result<FirstModel, VolumetricError> {
    let (table, config) = (inp.table, inp.config);
    match config.basis {
        BasisKind::Spline => Ok(FirstModel {
            model: spline_model(
                table,
                config.topology,
                inp.range,
                &inp.sqrt_w,
                inp.thermal_col.as_ref(),
                inp.weighted,
            ),
            degree: 0,
            cv: Vec::new(),
            cv_each: None,
        }),
        BasisKind::Poly => {
            let (degree, cv) = match config.degree {
                Degree::Fixed(0) => {
                    return Err(fit_err(table, "degree 0: degrees start at 1".into()));
                }
                Degree::Fixed(d) => (d, Vec::new()),
                Degree::Auto { max } | Degree::AutoEach { max } => super::degree::choose_degree(
                    table,
                    config,
                    inp.range,
                    &inp.sqrt_w,
                    inp.thermal_centred(),
                    max.max(1),
                ),
            };
            let mut degs = degrees(config, degree);
            let mut cv_each = None;
            if let Degree::AutoEach { max } = config.degree {
                let fixed: Vec<bool> = (0..18)
                    .map(|c| config.component_degrees.contains_key(&c))
                    .collect();
                let (chosen, score) = super::degree::choose_each(
                    table,
                    config.topology,
                    inp.range,
                    &inp.sqrt_w,
                    inp.thermal_centred(),
                    degs,
                    &fixed,
                    max.max(1),
                );
                degs = chosen;
                cv_each = Some(score);
            }
            Ok(FirstModel {
                model: poly_model(table, config.topology, inp.range, &inp.sqrt_w, degs),
                degree,
                cv,
                cv_each,
            })
        }
    }
}

/// The richer models tried when the first one's residual fails (see `identify`'s
/// Selection), in order, and the description of what was tried when there are any.
fn richer_models(inp: &FitInputs, first: &Model, degree: usize) -> (Vec<Model>, Option<String>) {
    let config = inp.config;
    let richer: Vec<Model> = match config.basis {
        BasisKind::Spline => RELAX[1..]
            .iter()
            .filter_map(|&r| relaxed(first, r))
            .collect(),
        BasisKind::Poly if !matches!(config.degree, Degree::Fixed(_)) => {
            let top = (degree + RICHER_DEGREES).min(MAX_DEGREE);
            (degree + 1..=top)
                .map(|d| {
                    let degs: Vec<usize> = first.basis.degrees.iter().map(|&x| x.max(d)).collect();
                    poly_model(inp.table, config.topology, inp.range, &inp.sqrt_w, degs)
                })
                .filter(|m| {
                    first
                        .identified
                        .iter()
                        .zip(&m.identified)
                        .all(|(a, b)| !a || *b)
                })
                .collect()
        }
        BasisKind::Poly => Vec::new(),
    };
    let tried = richer.last().map(|last| match config.basis {
        BasisKind::Spline => format!(
            "tables at knots, REML smoothing relaxed down to {:.0e}×",
            last.relax
        ),
        BasisKind::Poly => format!(
            "polynomials of degree {degree} to {}",
            last.basis.degrees.iter().max().copied().unwrap_or(degree)
        ),
    });
    (richer, tried)
}

/// Puts the scale's expansion (when kept) and the campaign's effects in front of the
/// residual's own effects: found physics, so the verdict becomes missing physics.
fn add_found_effects(
    residual: &mut ResidualVerdict,
    thermal: Option<&ThermalTest>,
    campaign_effects: Vec<FoundEffect>,
) {
    if let Some(e) = thermal.filter(|t| t.kept).and_then(thermal::effect) {
        residual.effects.insert(0, e);
        residual.verdict = crate::base::Verdict::MissingPhysics;
    }
    if !campaign_effects.is_empty() {
        let at = usize::from(thermal.is_some_and(|t| t.kept));
        residual.effects.splice(at..at, campaign_effects);
        residual.verdict = crate::base::Verdict::MissingPhysics;
    }
}

/// Per component, the variance the penalty's λ stands for (φ/λ, φ the noise scale), for
/// the tables' roughness; empty for least squares.
fn roughness(engine: &Engine, sigma0: f64) -> Vec<f64> {
    match engine {
        Engine::Penalised { pen, known_noise } => {
            let ratio = sigma0 * sigma0;
            let phi = if *known_noise { ratio.max(1.0) } else { ratio };
            let mut q = vec![0.0; 18];
            for (b, l) in pen.blocks.iter().zip(&pen.lambda) {
                if *l > 0.0 {
                    q[b.component] = phi / l;
                }
            }
            q
        }
        Engine::LeastSquares => Vec::new(),
    }
}

/// Fits the lines. Errors when the table cannot carry a fit at all (no degrees of
/// freedom left after the line constants and the determined parameters).
///
/// # Selection
///
/// The first model is the configured one: tables at knots with REML's smoothing, or
/// polynomials of the chosen degree. When its residual (after the scale's α and the
/// campaign terms) fails the test against the noise, richer component models are fitted
/// before anything is called unexplained — the tables with REML's λ relaxed by each of
/// [`RELAX`], the polynomials (degree chosen by CV) up to [`RICHER_DEGREES`] degrees
/// higher, as long as they determine what the first determines — and the first whose
/// residual passes is reported. When none passes, the first model is reported with an
/// `unexplained` effect naming the lines that carry the residual.
pub fn identify(
    table: &LineTable,
    config: &IdentifyConfig,
) -> Result<Identification, VolumetricError> {
    table.check_identify_size()?;
    let range = axis_range(table);
    let w = weights(table);
    let weighted = w.is_some();
    let sqrt_w: Vec<f64> = w.clone().unwrap_or_else(|| vec![1.0; table.targets()]);
    check_degrees(table, config)?;
    let row_w: Vec<f64> = sqrt_w.iter().map(|s| s * s).collect();
    let thermal_col = thermal::column(table, &row_w);
    let inp = FitInputs {
        table,
        config,
        range,
        sqrt_w,
        row_w,
        thermal_col,
        weighted,
    };
    let n_lines = table.lines.len();
    let FirstModel {
        model: first,
        mut degree,
        cv,
        cv_each,
    } = first_model(&inp)?;
    let first_outcome = inp
        .evaluate(&first)
        .map_err(|m| fit_err(table, m.to_string()))?;
    let mut chosen: Option<(Model, Outcome)> = None;
    let mut tried = match config.basis {
        BasisKind::Spline => "tables at knots with REML smoothing".to_string(),
        BasisKind::Poly => format!("polynomials of degree {degree}"),
    };
    if first_outcome.z > Z_MISSING {
        let (richer, richer_tried) = richer_models(&inp, &first, degree);
        if let Some(t) = richer_tried {
            tried = t;
        }
        for m in richer {
            let Ok(o) = inp.evaluate(&m) else { continue };
            if o.z <= Z_MISSING {
                chosen = Some((m, o));
                break;
            }
        }
    }
    let (model, outcome) = chosen.unwrap_or((first, first_outcome));
    if model.basis.kind() == BasisKind::Poly {
        degree = model.basis.degrees.iter().max().copied().unwrap_or(degree);
    }
    let Outcome {
        solved,
        thermal,
        campaign_effects,
        residuals,
        rms_residual_um,
        ..
    } = outcome;
    let mut residual = residual_test(
        &residuals,
        weighted.then_some((solved.chi2, solved.dof)),
        rms_residual_um,
        solved.sigma0,
        &tried,
    );
    add_found_effects(&mut residual, thermal.as_ref(), campaign_effects);
    let n = model.basis.n_params();
    let roughness = roughness(&model.engine, solved.sigma0);
    let smoothing = match &model.engine {
        Engine::Penalised { pen, known_noise } => Some(Smoothing::of(
            &model.basis,
            pen,
            &solved.edf_block,
            model.relax,
            solved.sigma0,
            *known_noise,
        )),
        Engine::LeastSquares => None,
    };
    Ok(Identification {
        topology: config.topology,
        degree,
        cv,
        fit: FitState {
            theta: solved.theta[..n].to_vec(),
            covariance: (0..n)
                .map(|i| (0..n).map(|j| solved.cov[(i, j)]).collect())
                .collect(),
            null_space: model.null_space,
            column_scale: model.d.scale[..n].to_vec(),
            identified: model.identified,
            roughness,
            basis: model.basis,
        },
        lines: n_lines,
        targets: table.targets(),
        rms_residual_um,
        sigma0: solved.sigma0,
        dof: solved.dof,
        weighted,
        residuals,
        residual,
        unidentified: model.unidentified,
        thermal,
        cv_each,
        smoothing,
    })
}

impl Identification {
    /// Report positions along axis k: `n` evenly over the range, 0 included.
    pub fn positions(&self, k: usize, n: usize) -> Vec<f64> {
        let [lo, hi] = self.fit.basis.range_mm[k];
        let n = n.max(5);
        let mut v: Vec<f64> = (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect();
        if !v.iter().any(|x| x.abs() < 1e-9) {
            v.push(0.0);
            v.sort_by(f64::total_cmp);
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumetric::simulate::{Plan, preset};
    use crate::volumetric::{Machine, simulate};

    /// Issue 17's campaign: `--degree 40` ran for minutes. A degree above the bound is
    /// refused at once, naming the bound; the bound itself is still fitted.
    #[test]
    fn a_degree_above_the_bound_is_refused_at_once() {
        let topo = Topology([1, 0, 2]);
        let plan = Plan {
            seed: 1,
            noise_um: 0.1,
            laser_zero_um: 0.0,
            feed_mm_s: 20.0,
            dwell_s: 1.0,
            setup_s: 1.0,
            lines: preset("rich", [[0.0; 3], [400.0, 300.0, 200.0]], 7, 50.0, 1).expect("preset"),
            thermal: None,
        };
        let table = simulate(&Machine::perfect(topo), &plan);
        for degree in [
            Degree::Fixed(MAX_DEGREE + 1),
            Degree::Fixed(40),
            Degree::Auto { max: 1000 },
            Degree::AutoEach {
                max: MAX_DEGREE + 1,
            },
        ] {
            let mut cfg = IdentifyConfig::new(topo);
            cfg.degree = degree;
            let e = identify(&table, &cfg).expect_err("refused").to_string();
            assert!(
                e.contains(&format!("above {MAX_DEGREE}")),
                "{degree:?}: {e}"
            );
        }
        let mut cfg = IdentifyConfig::new(topo);
        cfg.degree = Degree::Fixed(2);
        cfg.basis = crate::volumetric::BasisKind::Poly;
        cfg.component_degrees.insert(0, MAX_DEGREE + 1);
        assert!(identify(&table, &cfg).is_err());
        cfg.component_degrees.clear();
        assert!(identify(&table, &cfg).is_ok());
    }
}
