//! Tensor-product Lagrange interpolation of degrees m×n×q (Zhang Mei 2013, Eq. for P_{m,n,q}).
//!
//! P(x, y, z) = Σ_h Σ_j Σ_i ℓ_h(z) ℓ_j(y) ℓ_i(x) e_ijh, where ℓ are the 1-D Lagrange basis
//! polynomials through d + 1 consecutive nodes along each axis (d the degree on that axis).
//!
//! **Window rule.** Degree d uses d + 1 consecutive nodes chosen around the query:
//! - odd d (an even number of nodes): the cell containing the query sits in the middle,
//!   start = i − (d − 1)/2, where x_i ≤ x < x_{i+1};
//! - even d (an odd number of nodes): the node nearest the query sits in the middle,
//!   start = k − d/2 (ties go to the higher node); degree 0 is nearest-node interpolation;
//! - the start is clamped to 0 ..= n − 1 − d, so near the ends the window is shifted
//!   inwards, and outside the grid the end window's polynomial is evaluated
//!   (extrapolation, flagged by [`Interpolator::outside`]).
//!
//! With d = n − 1 the window is every node: the single global polynomial of the paper.
//! A degree above n − 1 is refused ([`InterpError::OrderTooHigh`]), never clamped.
//!
//! **Cost.** Fit: barycentric weights b_j = 1/Π_{k≠j}(x_j − x_k) for every window,
//! O(n·d²) per axis. Evaluation: an interval search, d + 1 weights per axis
//! (w_j = b_j·Π_{k≠j}(x − x_k) by prefix and suffix products, 3d multiplications and no
//! division), and (m+1)(n+1)(q+1) multiply–adds.
//! Reproduces every polynomial of degree ≤ d along each axis exactly.

use super::{InterpError, Interpolator, Locator, Order};
use crate::table::{Axis, Grid};

/// Highest degree supported along one axis (weights live on the stack).
pub const MAX_DEGREE: usize = 31;

#[derive(Debug, Clone)]
struct AxisBasis {
    degree: usize,
    nodes: Vec<f64>,
    loc: Locator,
    /// Barycentric weights, (d + 1) per window start.
    bary: Vec<f64>,
}

impl AxisBasis {
    fn new(nodes: &[f64], degree: usize) -> Self {
        let n = nodes.len();
        let starts = n - degree;
        let mut bary = Vec::with_capacity(starts * (degree + 1));
        for s in 0..starts {
            let window = &nodes[s..=s + degree];
            for (j, &xj) in window.iter().enumerate() {
                let prod: f64 = window
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| k != j)
                    .map(|(_, &xk)| xj - xk)
                    .product();
                bary.push(1.0 / prod);
            }
        }
        Self {
            degree,
            nodes: nodes.to_vec(),
            loc: Locator::new(nodes),
            bary,
        }
    }

    /// First node of the window used at `x` (the rule in the module docs).
    #[inline(always)]
    fn start(&self, x: f64) -> usize {
        let (n, d) = (self.nodes.len(), self.degree);
        if d + 1 >= n {
            return 0;
        }
        let i = self.loc.interval(x);
        let s = if d % 2 == 1 {
            i as isize - ((d - 1) / 2) as isize
        } else {
            let k = if x - self.nodes[i] < self.nodes[i + 1] - x {
                i
            } else {
                i + 1
            };
            k as isize - (d / 2) as isize
        };
        s.clamp(0, (n - 1 - d) as isize) as usize
    }

    /// Writes the d + 1 basis weights at `x` into `w` and returns the window start.
    /// w_j = b_j · Π_{k<j}(x − x_k) · Π_{k>j}(x − x_k), by prefix and suffix products: no
    /// division, and exactly one non-zero weight when `x` is a node.
    #[inline]
    fn weights(&self, x: f64, w: &mut [f64]) -> usize {
        let s = self.start(x);
        let d = self.degree;
        let window = &self.nodes[s..=s + d];
        let b = &self.bary[s * (d + 1)..(s + 1) * (d + 1)];
        let w = &mut w[..=d];
        let mut left = 1.0;
        for ((wj, &bj), &xj) in w.iter_mut().zip(b).zip(window) {
            *wj = bj * left;
            left *= x - xj;
        }
        let mut right = 1.0;
        for (wj, &xj) in w.iter_mut().zip(window).rev() {
            *wj *= right;
            right *= x - xj;
        }
        s
    }
}

impl AxisBasis {
    /// [`AxisBasis::weights`] with the number of weights `N = d + 1` known at compile
    /// time, so the prefix and suffix products unroll into registers.
    #[inline(always)]
    fn weights_n<const N: usize>(&self, x: f64, w: &mut [f64]) -> usize {
        let s = self.start(x);
        let window: &[f64; N] = self.nodes[s..s + N].try_into().expect("N nodes");
        let b: &[f64; N] = self.bary[s * N..(s + 1) * N].try_into().expect("N weights");
        let mut out = [0.0; N];
        let mut left = 1.0;
        for j in 0..N {
            out[j] = b[j] * left;
            left *= x - window[j];
        }
        let mut right = 1.0;
        for j in (0..N).rev() {
            out[j] *= right;
            right *= x - window[j];
        }
        w[..N].copy_from_slice(&out);
        s
    }

    /// The weights for degrees below [`SMALL`], dispatched once per axis and point.
    #[inline(always)]
    fn weights_small(&self, x: f64, w: &mut [f64]) -> usize {
        match self.degree {
            0 => self.weights_n::<1>(x, w),
            1 => self.weights_n::<2>(x, w),
            2 => self.weights_n::<3>(x, w),
            3 => self.weights_n::<4>(x, w),
            4 => self.weights_n::<5>(x, w),
            5 => self.weights_n::<6>(x, w),
            _ => self.weights(x, w),
        }
    }
}

/// A fitted tensor Lagrange interpolator.
#[derive(Debug, Clone)]
pub struct Lagrange {
    grid: Grid,
    order: Order,
    axes: [AxisBasis; 3],
}

impl Lagrange {
    /// Refuses a degree that needs more nodes than the axis has.
    pub fn new(grid: &Grid, order: Order) -> Result<Self, InterpError> {
        for axis in Axis::ALL {
            let a = axis.index();
            let nodes = grid.axis(a).len();
            let d = order.0[a];
            if d + 1 > nodes {
                return Err(InterpError::OrderTooHigh {
                    axis,
                    order: d,
                    nodes,
                });
            }
            if d > MAX_DEGREE {
                return Err(InterpError::OrderUnsupported {
                    axis,
                    order: d,
                    max: MAX_DEGREE,
                });
            }
        }
        let axes = [0, 1, 2].map(|a| AxisBasis::new(grid.axis(a), order.0[a]));
        Ok(Self {
            grid: grid.clone(),
            order,
            axes,
        })
    }

    pub fn order(&self) -> Order {
        self.order
    }
}

/// Weight buffers of this many entries serve degrees up to 7 without zeroing the
/// 32-entry buffers the highest degrees need.
const SMALL: usize = 8;

impl Lagrange {
    /// The tensor sum with weight buffers of `B` entries (B > every degree).
    #[inline(always)]
    fn predict_with<const B: usize>(&self, p: [f64; 3]) -> f64 {
        let mut wx = [0.0; B];
        let mut wy = [0.0; B];
        let mut wz = [0.0; B];
        let [sx, sy, sz] = if B == SMALL {
            [
                self.axes[0].weights_small(p[0], &mut wx),
                self.axes[1].weights_small(p[1], &mut wy),
                self.axes[2].weights_small(p[2], &mut wz),
            ]
        } else {
            [
                self.axes[0].weights(p[0], &mut wx),
                self.axes[1].weights(p[1], &mut wy),
                self.axes[2].weights(p[2], &mut wz),
            ]
        };
        let [dx, dy, dz] = self.order.0;
        let [nx, ny, _] = self.grid.shape();
        let v = &self.grid.values;
        // The innermost dot product has d_x + 1 terms: unrolled for the common degrees,
        // the dispatch made once per point.
        let t = Tensor {
            wy: &wy[..=dy],
            wz: &wz[..=dz],
            v,
            nx,
            ny,
            base: [sx, sy, sz],
        };
        match dx {
            1 => t.sum::<2>(&wx),
            2 => t.sum::<3>(&wx),
            3 => t.sum::<4>(&wx),
            4 => t.sum::<5>(&wx),
            5 => t.sum::<6>(&wx),
            _ => t.sum_dyn(&wx[..=dx]),
        }
    }
}

impl Interpolator for Lagrange {
    fn predict(&self, p: [f64; 3]) -> f64 {
        if self.order.0.iter().all(|&d| d < SMALL) {
            self.predict_with::<SMALL>(p)
        } else {
            self.predict_with::<{ MAX_DEGREE + 1 }>(p)
        }
    }

    fn outside(&self, p: [f64; 3]) -> bool {
        self.grid.outside(p)
    }
}

/// The y–z part of a tensor sum: weights, values and the window's first node.
struct Tensor<'a> {
    wy: &'a [f64],
    wz: &'a [f64],
    v: &'a [f64],
    nx: usize,
    ny: usize,
    base: [usize; 3],
}

impl Tensor<'_> {
    /// Σ_k wz_k Σ_j wy_j Σ_i wx_i v_ijk with N = d_x + 1 known at compile time.
    #[inline(always)]
    fn sum<const N: usize>(&self, wx: &[f64]) -> f64 {
        let wx: &[f64; N] = wx[..N].try_into().expect("N weights");
        let [sx, sy, sz] = self.base;
        let mut sum = 0.0;
        for (k, &wzk) in self.wz.iter().enumerate() {
            let first = sx + self.nx * (sy + self.ny * (sz + k));
            let mut plane = 0.0;
            for (j, &wyj) in self.wy.iter().enumerate() {
                let b = first + self.nx * j;
                let line: &[f64; N] = self.v[b..b + N].try_into().expect("N values");
                let mut acc = 0.0;
                for i in 0..N {
                    acc += wx[i] * line[i];
                }
                plane += wyj * acc;
            }
            sum += wzk * plane;
        }
        sum
    }

    fn sum_dyn(&self, wx: &[f64]) -> f64 {
        let [sx, sy, sz] = self.base;
        let mut sum = 0.0;
        for (k, &wzk) in self.wz.iter().enumerate() {
            let mut plane = 0.0;
            for (j, &wyj) in self.wy.iter().enumerate() {
                let b = sx + self.nx * (sy + j + self.ny * (sz + k));
                let line: f64 = wx
                    .iter()
                    .zip(&self.v[b..b + wx.len()])
                    .map(|(w, e)| w * e)
                    .sum();
                plane += wyj * line;
            }
            sum += wzk * plane;
        }
        sum
    }
}

/// Every order admissible on a grid of this shape, each degree capped at `max_degree`.
pub fn admissible_orders(shape: [usize; 3], max_degree: usize) -> Vec<Order> {
    let cap = |n: usize| n.saturating_sub(1).min(max_degree).min(MAX_DEGREE);
    let mut out = Vec::new();
    for m in 0..=cap(shape[0]) {
        for n in 0..=cap(shape[1]) {
            for q in 0..=cap(shape[2]) {
                out.push(Order([m, n, q]));
            }
        }
    }
    out
}
