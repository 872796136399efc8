//! The Gaussian (least-squares) sphere: centre c and radius r minimising Σ(|p_i − c| − r)²,
//! the radius free, every point used.
//!
//! The points are first moved to their mean (so a sphere far from the origin is fitted
//! with the same precision as one at it). The start is the algebraic fit — the linear
//! least-squares solution of |q|² = 2c·q + (r² − |c|²), solved by SVD — which minimises
//! a different sum (of squared *power* distances) and so misses the geometric sphere by
//! nanometres on a cap. From it a Levenberg–Marquardt iteration on the geometric residual
//! f_i = |q_i − c| − r, Jacobian ∂f_i/∂c = −(q_i − c)/|q_i − c|, ∂f_i/∂r = −1, runs until
//! the step is below [`STEP_TOL_MM`] (usually 3 to 5 Gauss–Newton steps; the damping only
//! acts when a step would raise the sum). Cost O(n) per iteration with a 4 × 4 solve.
//!
//! Reference: Forbes, A. B., *Least-squares best-fit geometric elements*, NPL Report DITC
//! 140/89 (1989): the sphere as a nonlinear least-squares problem started from its linear
//! (algebraic) form.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, Vector3, Vector4};

/// The iteration stops when a step moves the centre and radius by less than this, mm.
pub(crate) const STEP_TOL_MM: f64 = 1e-13;
/// At most this many iterations.
pub(crate) const MAX_ITERATIONS: usize = 200;

/// A fitted sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereFit {
    pub centre_mm: [f64; 3],
    pub radius_mm: f64,
    /// r_i = |p_i − c| − r, mm, in the order of the points (positive outside).
    pub residuals_mm: Vec<f64>,
    /// Levenberg–Marquardt iterations made.
    pub iterations: usize,
}

impl SphereFit {
    /// max r_i − min r_i, mm.
    pub fn form_mm(&self) -> f64 {
        let hi = self.residuals_mm.iter().copied().fold(f64::MIN, f64::max);
        let lo = self.residuals_mm.iter().copied().fold(f64::MAX, f64::min);
        hi - lo
    }

    /// √(mean r_i²), mm.
    pub fn rms_mm(&self) -> f64 {
        let n = self.residuals_mm.len().max(1) as f64;
        (self.residuals_mm.iter().map(|r| r * r).sum::<f64>() / n).sqrt()
    }
}

/// Why no sphere could be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("{0} point(s): a sphere needs at least 4")]
    TooFewPoints(usize),
    #[error("the points determine no sphere (coplanar, collinear or coincident)")]
    Degenerate,
    #[error("the least-squares sphere did not converge in {MAX_ITERATIONS} iterations")]
    NotConverged,
}

fn mean(points: &[[f64; 3]]) -> Vector3<f64> {
    let n = points.len().max(1) as f64;
    points
        .iter()
        .fold(Vector3::zeros(), |s, p| s + Vector3::from(*p))
        / n
}

/// s₁ ≥ s₂ ≥ s₃, the singular values of the points' coordinates minus their mean.
pub(crate) fn singular_values(points: &[[f64; 3]]) -> [f64; 3] {
    let m = mean(points);
    let mut a = Matrix3::zeros();
    for p in points {
        let q = Vector3::from(*p) - m;
        a += q * q.transpose();
    }
    let mut s: Vec<f64> = a
        .symmetric_eigenvalues()
        .iter()
        .map(|e| e.max(0.0).sqrt())
        .collect();
    s.sort_by(|x, y| y.total_cmp(x));
    [s[0], s[1], s[2]]
}

/// The algebraic sphere of the centred points `q`: (centre, radius), or `None` when the
/// linear problem is singular or gives no real radius.
fn algebraic(q: &[Vector3<f64>]) -> Option<(Vector3<f64>, f64)> {
    let n = q.len();
    let a = DMatrix::from_fn(n, 4, |i, j| if j < 3 { 2.0 * q[i][j] } else { 1.0 });
    let b = DVector::from_fn(n, |i, _| q[i].norm_squared());
    let svd = a.svd(true, true);
    let s_max = svd.singular_values.max();
    if s_max.is_nan() || s_max <= 0.0 || svd.singular_values.min() <= s_max * 1e-12 {
        return None;
    }
    let x = svd.solve(&b, 0.0).ok()?;
    let c = Vector3::new(x[0], x[1], x[2]);
    let r2 = x[3] + c.norm_squared();
    (r2 > 0.0 && r2.is_finite()).then(|| (c, r2.sqrt()))
}

/// Σ f_i² at (c, r).
fn cost(q: &[Vector3<f64>], c: &Vector3<f64>, r: f64) -> f64 {
    q.iter().map(|p| ((p - c).norm() - r).powi(2)).sum()
}

/// The normal equations' JᵀJ and Jᵀf at (c, r).
fn normal(q: &[Vector3<f64>], c: &Vector3<f64>, r: f64) -> Option<(Matrix4<f64>, Vector4<f64>)> {
    let mut jtj = Matrix4::zeros();
    let mut jtf = Vector4::zeros();
    for p in q {
        let d = p - c;
        let dist = d.norm();
        if dist <= 0.0 {
            return None;
        }
        let u = d / dist;
        let j = Vector4::new(-u.x, -u.y, -u.z, -1.0);
        jtj += j * j.transpose();
        jtf += j * (dist - r);
    }
    Some((jtj, jtf))
}

/// The least-squares sphere of `points` (mm).
pub fn fit_sphere(points: &[[f64; 3]]) -> Result<SphereFit, FitError> {
    if points.len() < 4 {
        return Err(FitError::TooFewPoints(points.len()));
    }
    let m = mean(points);
    let q: Vec<Vector3<f64>> = points.iter().map(|p| Vector3::from(*p) - m).collect();
    let (mut c, mut r) = algebraic(&q).ok_or(FitError::Degenerate)?;
    let mut f = cost(&q, &c, r);
    let mut lambda = 0.0f64;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let (jtj, jtf) = normal(&q, &c, r).ok_or(FitError::Degenerate)?;
        let mut a = jtj;
        for k in 0..4 {
            a[(k, k)] += lambda * jtj[(k, k)];
        }
        let step = a.lu().solve(&(-jtf)).ok_or(FitError::Degenerate)?;
        if !step.iter().all(|v| v.is_finite()) {
            return Err(FitError::Degenerate);
        }
        let c_new = c + Vector3::new(step[0], step[1], step[2]);
        let r_new = r + step[3];
        let f_new = cost(&q, &c_new, r_new);
        let small = step.norm() <= STEP_TOL_MM;
        if f_new <= f {
            c = c_new;
            r = r_new;
            f = f_new;
            lambda = (lambda * 0.1).max(0.0);
            if lambda < 1e-12 {
                lambda = 0.0;
            }
            if small {
                converged = true;
                break;
            }
        } else if small {
            // The sum cannot fall any further at this resolution: a minimum.
            converged = true;
            break;
        } else {
            lambda = if lambda == 0.0 { 1e-6 } else { lambda * 10.0 };
        }
    }
    if !converged {
        return Err(FitError::NotConverged);
    }
    let residuals_mm = q.iter().map(|p| (p - c).norm() - r).collect();
    Ok(SphereFit {
        centre_mm: [c.x + m.x, c.y + m.y, c.z + m.z],
        radius_mm: r,
        residuals_mm,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_sphere_is_found_from_any_start() {
        let c = [10.0, -20.0, 30.0];
        let r = 12.5;
        let mut pts = Vec::new();
        for i in 0..6 {
            for j in 0..5 {
                let t = 0.2 + 0.25 * i as f64;
                let p = 1.1 * j as f64;
                pts.push([
                    c[0] + r * t.sin() * p.cos(),
                    c[1] + r * t.sin() * p.sin(),
                    c[2] + r * t.cos(),
                ]);
            }
        }
        let f = fit_sphere(&pts).expect("fits");
        for (got, want) in f.centre_mm.iter().zip(c) {
            assert!((got - want).abs() < 1e-12, "{:?}", f.centre_mm);
        }
        assert!((f.radius_mm - r).abs() < 1e-12);
        assert!(f.form_mm() < 1e-12);
        let flat: Vec<[f64; 3]> = (0..30).map(|i| [i as f64, (i * i) as f64, 0.0]).collect();
        assert_eq!(fit_sphere(&flat), Err(FitError::Degenerate));
        assert!(singular_values(&flat)[2] < 1e-9);
    }
}
