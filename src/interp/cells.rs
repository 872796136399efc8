//! The cell machinery shared by the two-node (cell) schemes: a per-axis [`Locator`] built
//! at fit time, and [`eval_cells`], which sums a weight rule over a cell's 8 corners.
//! A cell scheme is only its weight rule (see `trilinear.rs`).

use crate::table::{Grid, interval};

/// Weights of a two-node (cell) scheme along one axis: the low node's index, the
/// weights of the low and high node, and the high node's index step (1, or 0 on an axis
/// with a single node, which gets weight 1 on that node and reads it twice).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CellWeights {
    pub lo: usize,
    pub w: [f64; 2],
    pub next: usize,
}

/// Finds a query's interval along one axis: O(1) on evenly spaced nodes (the usual
/// calibration grid), a binary search otherwise. Built once at fit time.
#[derive(Debug, Clone)]
pub struct Locator {
    nodes: Vec<f64>,
    /// (first node, 1/spacing) when the nodes are evenly spaced.
    uniform: Option<(f64, f64)>,
}

impl Locator {
    pub fn new(nodes: &[f64]) -> Self {
        let n = nodes.len();
        let uniform = (n >= 2)
            .then(|| {
                let h = (nodes[n - 1] - nodes[0]) / (n - 1) as f64;
                let even = nodes
                    .iter()
                    .enumerate()
                    .all(|(i, &x)| (x - (nodes[0] + i as f64 * h)).abs() <= 1e-9 * h.abs());
                (even && h > 0.0).then_some((nodes[0], 1.0 / h))
            })
            .flatten();
        Locator {
            nodes: nodes.to_vec(),
            uniform,
        }
    }

    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// The interval index `i` (clamped to `0..=n−2`) with `x_i ≤ x < x_{i+1}` inside the
    /// range. Needs `n ≥ 2`.
    #[inline]
    pub fn interval(&self, x: f64) -> usize {
        match self.uniform {
            Some((x0, inv_h)) => self.scaled(x0, inv_h, x).0,
            None => interval(&self.nodes, x),
        }
    }

    /// On evenly spaced nodes: the interval index (clamped to `0..=n−2`) and the scaled
    /// coordinate's offset from it, u = (x − x0)/h − i, with no division.
    #[inline(always)]
    fn scaled(&self, x0: f64, inv_h: f64, x: f64) -> (usize, f64) {
        let f = (x - x0) * inv_h;
        // NaN and negatives go to 0; the cast saturates.
        let i = if f > 0.0 { f as usize } else { 0 }.min(self.nodes.len() - 2);
        (i, f - i as f64)
    }

    /// The cell containing `x` (clamped to the end cells) and `x`'s position in it,
    /// u = (x − x_i)/(x_{i+1} − x_i), not clamped (u < 0 or u > 1 outside the grid).
    /// `None` for a single-node axis.
    #[inline]
    pub fn cell(&self, x: f64) -> Option<(usize, f64)> {
        if self.nodes.len() < 2 {
            return None;
        }
        match self.uniform {
            Some((x0, inv_h)) => Some(self.scaled(x0, inv_h, x)),
            None => {
                let i = interval(&self.nodes, x);
                Some((i, (x - self.nodes[i]) / (self.nodes[i + 1] - self.nodes[i])))
            }
        }
    }
}

/// The three axes' locators of a grid.
pub(crate) fn locators(grid: &Grid) -> [Locator; 3] {
    [0, 1, 2].map(|a| Locator::new(grid.axis(a)))
}

/// Σ over the 8 cell corners of w_x · w_y · w_z · value, without branches: a
/// single-node axis reads its one node twice with weights 1 and 0.
#[inline(always)]
pub(crate) fn cell_sum(grid: &Grid, w: [CellWeights; 3]) -> f64 {
    let [nx, ny, _] = grid.shape();
    let v = &grid.values;
    let step = [w[0].next, nx * w[1].next, nx * ny * w[2].next];
    let base = w[0].lo + nx * (w[1].lo + ny * w[2].lo);
    let line = |b: usize| w[0].w[0] * v[b] + w[0].w[1] * v[b + step[0]];
    let plane = |b: usize| w[1].w[0] * line(b) + w[1].w[1] * line(b + step[1]);
    w[2].w[0] * plane(base) + w[2].w[1] * plane(base + step[2])
}

/// Cell weights for a single-node axis: all weight on node 0.
pub(crate) const SINGLE: CellWeights = CellWeights {
    lo: 0,
    w: [1.0, 0.0],
    next: 0,
};

/// Evaluates a scheme given by a per-axis weight rule over the grid's cells. Single-node
/// axes get [`SINGLE`].
#[inline(always)]
pub(crate) fn eval_cells(
    grid: &Grid,
    loc: &[Locator; 3],
    p: [f64; 3],
    rule: impl Fn(f64) -> [f64; 2],
) -> f64 {
    let mut w = [SINGLE; 3];
    for (a, slot) in w.iter_mut().enumerate() {
        if let Some((lo, u)) = loc[a].cell(p[a]) {
            *slot = CellWeights {
                lo,
                w: rule(u),
                next: 1,
            };
        }
    }
    cell_sum(grid, w)
}
