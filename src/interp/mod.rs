//! Interpolators of an error grid: one small trait, one module per method, one enum
//! that maps a command-line choice to a method.
//!
//! | method | module | fit cost | evaluation cost per point | reference |
//! |---|---|---|---|---|
//! | Lagrange m×n×q | [`lagrange`] | O(N) barycentric weights | O(m² + n² + q²) weights + (m+1)(n+1)(q+1) terms | seed 001, Eq. P_{m,n,q} |
//! | trilinear | [`trilinear`] | none | 3 interval searches + 8 terms | seed 000, Eqs. 1–4 |
//! | tricubic natural spline | [`spline`] | 7 tridiagonal sweeps over the grid, O(N) | 3 interval searches + 64 terms | seed 000, Eqs. 5–7 |
//! | fuzzy (Gaussian memberships) | [`fuzzy`] | none | 3 interval searches + 8 terms | seed 000, Eqs. 8–13 |
//! | Gaussian process (kriging) | [`crate::gp`] | O(N³) per likelihood evaluation, ~10 starts | O(N) mean, O(N²) σ | Rasmussen & Williams 2006 |
//!
//! N is the number of grid nodes. Every method evaluates outside the grid too (the rule
//! is in each module's docs) and the caller is told by [`Interpolator::outside`], so
//! extrapolated predictions are always flagged.

pub mod fuzzy;
pub mod lagrange;
pub mod spline;
pub mod trilinear;

use std::fmt;
use std::str::FromStr;

use crate::table::{Axis, Grid, interval};

/// What a fitted model can do: predict the error (µm) at a position (mm).
pub trait Interpolator: Send + Sync + fmt::Debug {
    /// The predicted error at `p = [x, y, z]` mm, in µm.
    fn predict(&self, p: [f64; 3]) -> f64;

    /// Whether `p` lies outside the fitted nodes (the prediction is an extrapolation).
    fn outside(&self, p: [f64; 3]) -> bool;

    /// One-sigma uncertainty of the prediction for a measured value at `p`, µm, for
    /// methods that have one (the Gaussian process); `None` for the interpolators.
    fn sigma(&self, _p: [f64; 3]) -> Option<f64> {
        None
    }

    /// Batch evaluation into a caller's buffer (no allocation per point).
    fn predict_into(&self, points: &[[f64; 3]], out: &mut [f64]) {
        for (p, o) in points.iter().zip(out.iter_mut()) {
            *o = self.predict(*p);
        }
    }
}

/// Polynomial degrees along x, y and z (the paper's m×n×q).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Order(pub [usize; 3]);

impl fmt::Display for Order {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}x{}", self.0[0], self.0[1], self.0[2])
    }
}

impl FromStr for Order {
    type Err = String;
    /// Parses `4x1x2` (also `4×1×2` or `4,1,2`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(['x', 'X', '×', ',']).map(str::trim).collect();
        if parts.len() != 3 {
            return Err(format!(
                "order `{s}` must be three degrees MxNxQ, e.g. 4x1x2"
            ));
        }
        let mut o = [0usize; 3];
        for (slot, part) in o.iter_mut().zip(&parts) {
            *slot = part
                .parse()
                .map_err(|_| format!("order `{s}`: `{part}` is not a whole number"))?;
        }
        Ok(Order(o))
    }
}

/// The methods errmap fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Tensor Lagrange of the given degrees.
    Lagrange(Order),
    Trilinear,
    /// Tensor natural cubic spline.
    Spline,
    /// Gaussian-membership fuzzy interpolator; `sigma` is the membership width as a
    /// fraction of the cell size.
    Fuzzy {
        sigma: f64,
    },
    /// Gaussian-process (kriging) model with hyperparameters by maximum likelihood.
    Gp(crate::gp::Kernel),
}

impl Method {
    /// The method's name as the command line spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Lagrange(_) => "lagrange",
            Method::Trilinear => "trilinear",
            Method::Spline => "spline",
            Method::Fuzzy { .. } => "fuzzy",
            // Each kernel its own name, so rows of a comparison are told apart by it.
            Method::Gp(crate::gp::Kernel::SquaredExponential) => "gp-se",
            Method::Gp(_) => "gp",
        }
    }

    pub fn order(&self) -> Option<Order> {
        match self {
            Method::Lagrange(o) => Some(*o),
            _ => None,
        }
    }

    /// A label for tables and figures, e.g. `lagrange 4×1×2`.
    pub fn label(&self) -> String {
        match self {
            Method::Lagrange(o) => format!("lagrange {}×{}×{}", o.0[0], o.0[1], o.0[2]),
            Method::Fuzzy { sigma } if (*sigma - fuzzy::DEFAULT_SIGMA).abs() > 1e-12 => {
                format!("fuzzy σ={sigma}")
            }
            Method::Gp(k) if *k != crate::gp::Kernel::default() => format!("gp {}", k.name()),
            m => m.name().to_string(),
        }
    }

    /// Fits the method to a grid. Every method needs at least one node per axis (an axis
    /// with one node is treated as constant along it); Lagrange also checks its degrees.
    pub fn fit(&self, grid: &Grid) -> Result<Box<dyn Interpolator>, InterpError> {
        check_grid(grid)?;
        Ok(match *self {
            Method::Lagrange(order) => Box::new(lagrange::Lagrange::new(grid, order)?),
            Method::Trilinear => Box::new(trilinear::Trilinear::new(grid)),
            Method::Spline => Box::new(spline::Spline::new(grid)),
            Method::Fuzzy { sigma } => Box::new(fuzzy::Fuzzy::new(grid, sigma)?),
            Method::Gp(_) => self.fit_points(&grid.points()).map_err(|e| match e {
                FitError::Interp(e) => e,
                FitError::Gp(e) => InterpError::Gp(e.to_string()),
            })?,
        })
    }

    /// Whether the method works on scattered nodes (not only on a rectilinear grid).
    pub fn accepts_scattered(&self) -> bool {
        matches!(self, Method::Gp(_))
    }

    /// Fits a method that accepts scattered nodes to a table's points.
    pub fn fit_points(
        &self,
        points: &[crate::table::ErrorPoint],
    ) -> Result<Box<dyn Interpolator>, FitError> {
        match *self {
            Method::Gp(kernel) => Ok(Box::new(crate::gp::Gp::fit(
                points,
                &crate::gp::GpConfig {
                    kernel,
                    ..crate::gp::GpConfig::default()
                },
            )?)),
            _ => Err(FitError::Interp(InterpError::NeedsGrid {
                method: self.name(),
            })),
        }
    }
}

/// Why a model cannot be fitted to scattered points.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Interp(#[from] InterpError),
    #[error(transparent)]
    Gp(#[from] crate::gp::GpError),
}

/// Why a model cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InterpError {
    #[error(
        "degree {order} along {axis} needs {needed} nodes but the table has {nodes} on that axis \
         (the highest admissible degree is {max})",
        needed = order + 1,
        max = nodes.saturating_sub(1)
    )]
    OrderTooHigh {
        axis: Axis,
        order: usize,
        nodes: usize,
    },
    #[error("degree {order} along {axis} exceeds the supported maximum {max}")]
    OrderUnsupported {
        axis: Axis,
        order: usize,
        max: usize,
    },
    #[error("the grid has no nodes along {axis}")]
    EmptyAxis { axis: Axis },
    #[error("grid nodes along {axis} are not strictly increasing at index {index}")]
    NotIncreasing { axis: Axis, index: usize },
    #[error("the grid has {values} values for {nodes} nodes")]
    Shape { values: usize, nodes: usize },
    #[error("grid value at node index {index} is not finite")]
    NonFinite { index: usize },
    #[error("fuzzy membership width σ = {sigma} must be a positive finite fraction of the cell")]
    BadSigma { sigma: f64 },
    #[error("{method} needs the nodes on a rectilinear grid")]
    NeedsGrid { method: &'static str },
    #[error("Gaussian process: {0}")]
    Gp(String),
    #[error("no method can be fitted to this table ({why})")]
    NothingFits { why: String },
}

fn check_grid(grid: &Grid) -> Result<(), InterpError> {
    for axis in Axis::ALL {
        let v = grid.axis(axis.index());
        if v.is_empty() {
            return Err(InterpError::EmptyAxis { axis });
        }
        if let Some(index) = v
            .windows(2)
            .position(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(InterpError::NotIncreasing {
                axis,
                index: index + 1,
            });
        }
    }
    let nodes = grid.xs.len() * grid.ys.len() * grid.zs.len();
    if grid.values.len() != nodes {
        return Err(InterpError::Shape {
            values: grid.values.len(),
            nodes,
        });
    }
    if let Some(index) = grid.values.iter().position(|v| !v.is_finite()) {
        return Err(InterpError::NonFinite { index });
    }
    Ok(())
}

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

/// Evaluates `model` at every point into `out`, over `threads` worker threads (1: the
/// calling thread only; 0: all cores). Points are split into chunks of 4096 so each
/// worker's evaluation allocates nothing per point.
pub fn predict_parallel(
    model: &dyn Interpolator,
    points: &[[f64; 3]],
    out: &mut [f64],
    threads: usize,
) -> Result<(), rayon::ThreadPoolBuildError> {
    use rayon::prelude::*;
    if threads == 1 {
        model.predict_into(points, out);
        return Ok(());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    pool.install(|| {
        points
            .par_chunks(4096)
            .zip(out.par_chunks_mut(4096))
            .for_each(|(p, o)| model.predict_into(p, o));
    });
    Ok(())
}
