//! Interpolators of an error grid: one small trait, one module per method, one enum
//! that maps a command-line choice to a method.
//!
//! | method | module | fit cost | evaluation cost per point | reference |
//! |---|---|---|---|---|
//! | Lagrange m×n×q | `lagrange` | O(N) barycentric weights | O(m² + n² + q²) weights + (m+1)(n+1)(q+1) terms | Zhang Mei 2013, Eq. P_{m,n,q} |
//! | trilinear | `trilinear` | none | 3 interval searches + 8 terms | Agbegha, Guo and Bai 2011, Eqs. 1–4 |
//! | tricubic natural spline | `spline` | 7 tridiagonal sweeps over the grid, O(N) | 3 interval searches + 64 terms | Agbegha, Guo and Bai 2011, Eqs. 5–7 |
//! | fuzzy (Gaussian memberships) | `fuzzy` | none | 3 interval searches + 8 terms | Agbegha, Guo and Bai 2011, Eqs. 8–13 |
//! | Gaussian process (kriging) | `gp` | O(N³) per likelihood evaluation, ~10 starts | O(N) mean, O(N²) σ | Rasmussen & Williams 2006 |
//!
//! N is the number of grid nodes. Every method evaluates outside the grid too (the rule
//! is in each module's docs) and the caller is told by [`Interpolator::outside`], so
//! extrapolated predictions are always flagged.
//!
//! References (full list in `docs/README.md`):
//! - Zhang Mei, "CMM Measurement Error Model Based on High-order Lagrange Interpolation",
//!   *Information Technology Journal* (2013): the tensor Lagrange interpolant and the
//!   Table 1 / Table 2 data in `datasets/`.
//! - G. Agbegha, N. Guo and Y. Bai, "Compare Fuzzy Interpolation Algorithm with Other
//!   Interpolation Methods Used in Industrial Applications" (2011): trilinear, cubic
//!   spline and fuzzy interpolation, and the random-error simulation of `errmap fuzzy-sim`.
//! - C. E. Rasmussen and C. K. I. Williams, *Gaussian Processes for Machine Learning* (2006).

mod cells;
mod fuzzy;
mod gp;
mod lagrange;
mod method;
mod spline;
mod trilinear;

use std::fmt;
use std::str::FromStr;

use crate::base::{NamesSettings, Setting};
use crate::table::Axis;

pub use cells::Locator;
pub(crate) use cells::{eval_cells, locators};
pub use fuzzy::{DEFAULT_SIGMA as DEFAULT_FUZZY_SIGMA, Fuzzy, high_weight};
pub use gp::{Gp, GpConfig, GpError, GpHyper, Kernel, MAX_POINTS as GP_MAX_POINTS};
pub use lagrange::{Lagrange, MAX_DEGREE, admissible_orders};
pub use method::{FitError, Method, MethodError, MethodName, MethodSettings, UnknownMethod};
pub use spline::{Spline, natural_second_derivatives};
pub use trilinear::Trilinear;

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
    type Err = BadOrder;
    /// Parses `4x1x2` (also `4×1×2` or `4,1,2`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(['x', 'X', '×', ',']).map(str::trim).collect();
        if parts.len() != 3 {
            return Err(BadOrder::NotThree {
                text: s.to_string(),
            });
        }
        let mut o = [0usize; 3];
        for (slot, part) in o.iter_mut().zip(&parts) {
            *slot = part.parse().map_err(|_| BadOrder::NotWhole {
                text: s.to_string(),
                part: part.to_string(),
            })?;
            if *slot > lagrange::MAX_DEGREE {
                return Err(BadOrder::TooHigh {
                    text: s.to_string(),
                    max: lagrange::MAX_DEGREE,
                });
            }
        }
        Ok(Order(o))
    }
}

/// Text that is not an [`Order`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BadOrder {
    /// Not three parts.
    #[error("order `{text}` must be three degrees MxNxQ, e.g. 4x1x2")]
    NotThree { text: String },
    /// A part that is not a whole number.
    #[error("order `{text}`: `{part}` is not a whole number")]
    NotWhole { text: String, part: String },
    /// A degree above what the interpolator computes ([`lagrange::MAX_DEGREE`]).
    #[error("order `{text}`: a degree above {max}, the highest errmap computes")]
    TooHigh { text: String, max: usize },
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
    #[error("{}", self.render(&Setting::words))]
    TooLargeForAuto { nodes: usize, max: usize },
}

/// The settings of the interpolation stage that its messages name (`base::Setting`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InterpSetting {
    /// The Lagrange degrees per axis ([`Method::Lagrange`]).
    Order,
}

impl Setting for InterpSetting {
    fn words(self) -> &'static str {
        match self {
            InterpSetting::Order => "the Lagrange order",
        }
    }
}

impl NamesSettings for InterpError {
    type Setting = InterpSetting;
    fn render(&self, name: &dyn Fn(InterpSetting) -> &'static str) -> String {
        match self {
            InterpError::TooLargeForAuto { nodes, max } => format!(
                "choosing the order by cross-validation refits every admissible order once per \
                 grid plane; on {nodes} nodes (more than {max}) that takes too long: give the \
                 degrees ({} MxNxQ)",
                name(InterpSetting::Order)
            ),
            // The rest name no setting.
            other => other.to_string(),
        }
    }
}

/// Evaluates `model` at every point into `out`, over `threads` worker threads (1: the
/// calling thread only; 0: all cores; more than the cores: the cores). Points are split
/// into chunks of 4096 so each worker's evaluation allocates nothing per point.
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
    // More threads than cores only add switching; 100 000 would take minutes to start.
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.min(cores))
        .build()?;
    pool.install(|| {
        points
            .par_chunks(4096)
            .zip(out.par_chunks_mut(4096))
            .for_each(|(p, o)| model.predict_into(p, o));
    });
    Ok(())
}
