//! Tensor-product natural cubic spline (Agbegha, Guo and Bai 2011, Section II.B,
//! Eqs. 5–7).
//!
//! Along one axis the natural cubic spline through (x_i, y_i) is, on [x_i, x_{i+1}] with
//! h = x_{i+1} − x_i, A = (x_{i+1} − x)/h, B = 1 − A (Agbegha, Guo and Bai 2011, Eq. 7):
//!
//! s(x) = A·y_i + B·y_{i+1} + (A³ − A)·h²/6·M_i + (B³ − B)·h²/6·M_{i+1},
//!
//! where the second derivatives M solve the tridiagonal system
//! h_{i−1}M_{i−1} + 2(h_{i−1} + h_i)M_i + h_iM_{i+1} = 6[(y_{i+1} − y_i)/h_i − (y_i − y_{i−1})/h_{i−1}]
//! with the natural end conditions M_0 = M_{n−1} = 0.
//!
//! In 3-D the spline is the tensor product of these 1-D splines. Since s is linear in the
//! values and in the M's, it is evaluated from 8 numbers per node computed once at fit
//! time: the value, its second-derivative operators along x, y, z, and their products
//! (M_x, M_y, M_z, M_xy, M_xz, M_yz, M_xyz), each a tridiagonal sweep over the grid. An
//! evaluation is then 3 interval searches and 64 multiply–adds, independent of grid size.
//!
//! **Few nodes.** With 2 nodes on an axis both end conditions force M = 0 and the spline
//! is exactly linear along it. With 3 nodes it is the natural cubic spline with one
//! interior second derivative M_1 = 3·(slope difference)/(h_0 + h_1) — piecewise cubic,
//! each piece's curvature falling linearly to zero at the ends. With 1 node (only inside
//! cross-validation folds) the field is constant along the axis.
//!
//! **Extrapolation.** A natural spline has zero curvature at its ends, so beyond the end
//! nodes it continues as the straight line with the end slope (C² continuous, flagged by
//! [`Interpolator::outside`]). Linear fields are reproduced exactly everywhere.
//!
//! **Cost.** Fit O(N) (N nodes; 7 sweeps), memory 8 values per node; evaluation 64 terms.

use super::{Interpolator, Locator, locators};
use crate::table::Grid;

/// Natural-spline second derivatives of `y` at `nodes` (all zero for n ≤ 2).
pub fn natural_second_derivatives(nodes: &[f64], y: &[f64]) -> Vec<f64> {
    let n = nodes.len();
    let mut m = vec![0.0; n];
    if n <= 2 {
        return m;
    }
    // Thomas algorithm on the n − 2 interior unknowns.
    let h: Vec<f64> = nodes.windows(2).map(|w| w[1] - w[0]).collect();
    let k = n - 2;
    let mut c = vec![0.0; k];
    let mut d = vec![0.0; k];
    for r in 0..k {
        let i = r + 1;
        let a = h[i - 1];
        let b = 2.0 * (h[i - 1] + h[i]);
        let cc = h[i];
        let rhs = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
        if r == 0 {
            c[r] = cc / b;
            d[r] = rhs / b;
        } else {
            let denom = b - a * c[r - 1];
            c[r] = cc / denom;
            d[r] = (rhs - a * d[r - 1]) / denom;
        }
    }
    m[k] = d[k - 1];
    for r in (0..k - 1).rev() {
        m[r + 1] = d[r] - c[r] * m[r + 2];
    }
    m
}

/// Applies the natural-spline second-derivative operator along axis `a` to a grid-shaped
/// array (x fastest).
fn second_derivative_along(grid: &Grid, a: usize, values: &[f64]) -> Vec<f64> {
    let shape = grid.shape();
    let nodes = grid.axis(a);
    let stride = match a {
        0 => 1,
        1 => shape[0],
        _ => shape[0] * shape[1],
    };
    let mut out = vec![0.0; values.len()];
    if nodes.len() <= 2 {
        return out;
    }
    let mut line = vec![0.0; nodes.len()];
    for start in 0..values.len() {
        // A line starts at every index whose coordinate along `a` is 0.
        if (start / stride) % shape[a] != 0 {
            continue;
        }
        for (t, slot) in line.iter_mut().enumerate() {
            *slot = values[start + t * stride];
        }
        let m = natural_second_derivatives(nodes, &line);
        for (t, v) in m.into_iter().enumerate() {
            out[start + t * stride] = v;
        }
    }
    out
}

/// Per-axis basis at a point: the cell's low node, the index step to the high node (1,
/// or 0 on a single-node axis, whose high-node weights are 0), and the weights
/// [value_lo, value_hi, M_lo, M_hi].
#[inline(always)]
fn axis_basis(loc: &Locator, x: f64) -> (usize, usize, [f64; 4]) {
    let nodes = loc.nodes();
    let Some((i, u)) = loc.cell(x) else {
        return (0, 0, [1.0, 0.0, 0.0, 0.0]);
    };
    let h = nodes[i + 1] - nodes[i];
    let b = if u < 0.0 {
        // Below the first node: y_0 + δ·s'(x_0), s'(x_0) = (y_1 − y_0)/h − h(2M_0 + M_1)/6.
        let d = u * h;
        [1.0 - u, u, -d * h / 3.0, -d * h / 6.0]
    } else if u > 1.0 {
        // Beyond the last node: y_n + δ·s'(x_n), s'(x_n) = (y_n − y_{n−1})/h + h(M_{n−1} + 2M_n)/6.
        let d = (u - 1.0) * h;
        [-(u - 1.0), u, d * h / 6.0, d * h / 3.0]
    } else {
        let (a, bb) = (1.0 - u, u);
        let h26 = h * h / 6.0;
        [a, bb, (a * a * a - a) * h26, (bb * bb * bb - bb) * h26]
    };
    (i, 1, b)
}

/// A node's 8 coefficients, one cache line each: bit 0 of the index = M along x, bit 1 =
/// along y, bit 2 = along z (0 = the value itself).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Coef([f64; 8]);

/// One corner's contribution, contracted x, then y, then z; `w` are the corner's
/// [value, M] weights per axis.
#[inline(always)]
fn corner(c: &Coef, w: [[f64; 2]; 3]) -> f64 {
    let c = &c.0;
    let [wx, wy, wz] = w;
    let t = |b: usize| wx[0] * c[b] + wx[1] * c[b | 1];
    let u0 = wy[0] * t(0) + wy[1] * t(2);
    let u1 = wy[0] * t(4) + wy[1] * t(6);
    wz[0] * u0 + wz[1] * u1
}

/// A fitted tensor natural cubic spline.
#[derive(Debug, Clone)]
pub struct Spline {
    grid: Grid,
    loc: [Locator; 3],
    coef: Vec<Coef>,
}

impl Spline {
    pub fn new(grid: &Grid) -> Self {
        let v = grid.values.clone();
        let mx = second_derivative_along(grid, 0, &v);
        let my = second_derivative_along(grid, 1, &v);
        let mz = second_derivative_along(grid, 2, &v);
        let mxy = second_derivative_along(grid, 1, &mx);
        let mxz = second_derivative_along(grid, 2, &mx);
        let myz = second_derivative_along(grid, 2, &my);
        let mxyz = second_derivative_along(grid, 2, &mxy);
        let coef = (0..v.len())
            .map(|i| Coef([v[i], mx[i], my[i], mxy[i], mz[i], mxz[i], myz[i], mxyz[i]]))
            .collect();
        Self {
            grid: grid.clone(),
            loc: locators(grid),
            coef,
        }
    }
}

impl Interpolator for Spline {
    /// Σ over the cell's 8 corners, each contracted on its own (short dependency chains)
    /// and summed pairwise; no branches on single-node axes (they read one node twice,
    /// the second time with weight 0).
    fn predict(&self, p: [f64; 3]) -> f64 {
        let (ix, sx, bx) = axis_basis(&self.loc[0], p[0]);
        let (iy, sy, by) = axis_basis(&self.loc[1], p[1]);
        let (iz, sz, bz) = axis_basis(&self.loc[2], p[2]);
        let [nx, ny, _] = self.grid.shape();
        let base = ix + nx * (iy + ny * iz);
        let step = [sx, nx * sy, nx * ny * sz];
        let v: [f64; 8] = std::array::from_fn(|d| {
            let (dx, dy, dz) = (d & 1, (d >> 1) & 1, d >> 2);
            let c = &self.coef[base + dx * step[0] + dy * step[1] + dz * step[2]];
            corner(
                c,
                [
                    [bx[dx], bx[2 + dx]],
                    [by[dy], by[2 + dy]],
                    [bz[dz], bz[2 + dz]],
                ],
            )
        });
        ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))
    }

    fn outside(&self, p: [f64; 3]) -> bool {
        self.grid.outside(p)
    }
}
