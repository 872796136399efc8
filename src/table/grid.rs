//! The rectilinear grid of node errors, locating a coordinate among its nodes, and the
//! nodes' box ([`Extent`]).

use super::{ErrorPoint, ErrorTable};

/// A rectilinear grid of node errors: strictly increasing node coordinates per axis and
/// one value per node, x fastest (`values[i + nx·(j + ny·k)]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    pub zs: Vec<f64>,
    pub values: Vec<f64>,
}

impl Grid {
    /// Builds a grid from node coordinates and a function of position (tests, simulations).
    /// Axes may have a single node (the field is then constant along that axis).
    pub fn from_fn(
        xs: Vec<f64>,
        ys: Vec<f64>,
        zs: Vec<f64>,
        mut f: impl FnMut([f64; 3]) -> f64,
    ) -> Self {
        let mut values = Vec::with_capacity(xs.len() * ys.len() * zs.len());
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    values.push(f([x, y, z]));
                }
            }
        }
        Self { xs, ys, zs, values }
    }

    pub fn axis(&self, a: usize) -> &[f64] {
        match a {
            0 => &self.xs,
            1 => &self.ys,
            _ => &self.zs,
        }
    }

    pub fn shape(&self) -> [usize; 3] {
        [self.xs.len(), self.ys.len(), self.zs.len()]
    }

    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.xs.len() * (j + self.ys.len() * k)
    }

    pub fn value(&self, i: usize, j: usize, k: usize) -> f64 {
        self.values[self.index(i, j, k)]
    }

    /// Whether a point lies outside the node range on any axis.
    pub fn outside(&self, p: [f64; 3]) -> bool {
        (0..3).any(|a| {
            let v = self.axis(a);
            let (lo, hi) = (v[0], v[v.len() - 1]);
            let tol = 1e-9 * (hi - lo).abs().max(1.0);
            p[a] < lo - tol || p[a] > hi + tol
        })
    }

    /// The grid without plane `plane` along axis `a` (for leave-one-plane-out CV).
    pub fn without_plane(&self, a: usize, plane: usize) -> Grid {
        let mut axes = [self.xs.clone(), self.ys.clone(), self.zs.clone()];
        axes[a].remove(plane);
        let [nx, ny, _] = self.shape();
        let mut values = Vec::with_capacity(self.values.len());
        for (idx, &v) in self.values.iter().enumerate() {
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            if ijk[a] != plane {
                values.push(v);
            }
        }
        let [xs, ys, zs] = axes;
        Grid { xs, ys, zs, values }
    }

    /// The nodes as table points.
    pub fn points(&self) -> Vec<ErrorPoint> {
        let mut out = Vec::with_capacity(self.values.len());
        for (k, &z) in self.zs.iter().enumerate() {
            for (j, &y) in self.ys.iter().enumerate() {
                for (i, &x) in self.xs.iter().enumerate() {
                    out.push(ErrorPoint::new(x, y, z, self.value(i, j, k)));
                }
            }
        }
        out
    }
}

/// Locates `x` in strictly increasing `nodes`: the interval index `i` (clamped to
/// `0..=n−2`) with `nodes[i] ≤ x < nodes[i+1]` inside the range. Needs `n ≥ 2`.
#[inline]
pub fn interval(nodes: &[f64], x: f64) -> usize {
    let n = nodes.len();
    debug_assert!(n >= 2);
    // partition_point: first index whose node is > x.
    let p = nodes.partition_point(|&v| v <= x);
    p.saturating_sub(1).min(n - 2)
}

/// The fitting nodes' extent and typical spacing per axis, as the advice needs them.
#[derive(Debug, Clone, Copy)]
pub struct Extent {
    /// Smallest and largest coordinate per axis, mm.
    pub bounds: [[f64; 2]; 3],
    /// Node spacing per axis, mm: the median gap between grid nodes. For scattered nodes,
    /// the median gap between distinct coordinates when the nodes lie on at most n/2
    /// planes across the axis (a grid with holes), else the spacing of an even grid with
    /// as many nodes over the same box: extent / (n^(1/D) − 1), D the number of axes the
    /// nodes span.
    pub spacing_mm: [f64; 3],
}

impl Extent {
    pub fn of_grid(grid: &Grid) -> Extent {
        Extent {
            bounds: [0, 1, 2].map(|a| {
                let v = grid.axis(a);
                [v[0], v[v.len() - 1]]
            }),
            spacing_mm: [0, 1, 2].map(|a| {
                let mut d: Vec<f64> = grid.axis(a).windows(2).map(|w| w[1] - w[0]).collect();
                d.sort_by(f64::total_cmp);
                d.get(d.len() / 2).copied().unwrap_or(f64::NAN)
            }),
        }
    }

    pub fn of_points(table: &ErrorTable) -> Extent {
        let bounds = [0, 1, 2].map(|a| {
            table
                .points
                .iter()
                .map(|p| p.position()[a])
                .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| {
                    [lo.min(v), hi.max(v)]
                })
        });
        let n = table.points.len();
        let spans = bounds.iter().filter(|b| b[1] > b[0]).count().max(1);
        let per_axis = (n as f64).powf(1.0 / spans as f64);
        let spacing_mm = std::array::from_fn(|a| {
            let [lo, hi] = bounds[a];
            let mut v: Vec<f64> = table.points.iter().map(|p| p.position()[a]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            if hi <= lo {
                f64::NAN
            } else if 2 * v.len() <= n {
                // Nodes on a few planes (a grid with holes): the gap between planes.
                let mut d: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
                d.sort_by(f64::total_cmp);
                d[d.len() / 2]
            } else {
                (hi - lo) / (per_axis - 1.0).max(1.0)
            }
        });
        Extent { bounds, spacing_mm }
    }

    /// Whether `p` lies outside the box (relative tolerance 1e-9).
    pub fn outside(&self, p: [f64; 3]) -> bool {
        (0..3).any(|a| {
            let [lo, hi] = self.bounds[a];
            let tol = 1e-9 * (hi - lo).abs().max(1.0);
            p[a] < lo - tol || p[a] > hi + tol
        })
    }
}
