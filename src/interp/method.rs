//! [`Method`]: the methods errmap fits — the command line's name, the
//! label for tables and figures, and the fit on a grid or on scattered points.

use super::{InterpError, Interpolator, Order, fuzzy, lagrange, spline, trilinear};
use crate::table::{Axis, Grid};

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
    Gp(super::gp::Kernel),
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
            Method::Gp(super::gp::Kernel::SquaredExponential) => "gp-se",
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
            Method::Gp(k) if *k != super::gp::Kernel::default() => format!("gp {}", k.name()),
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
            Method::Gp(kernel) => Ok(Box::new(super::gp::Gp::fit(
                points,
                &super::gp::GpConfig {
                    kernel,
                    ..super::gp::GpConfig::default()
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
    Gp(#[from] super::gp::GpError),
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
