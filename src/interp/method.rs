//! [`Method`]: the one registry of the methods errmap fits — the name the command line,
//! the JSON, the reports and the machine-model file spell ([`MethodName`], parsed once
//! with `FromStr`), the default list a comparison fits ([`Method::defaults`]), the label
//! for tables and figures, and the fit on a grid or on scattered points.

use std::fmt;
use std::str::FromStr;

use super::gp::Kernel;
use super::lagrange::admissible_orders;
use super::{InterpError, Interpolator, Order, fuzzy, lagrange, spline, trilinear};
use crate::table::{Axis, Grid};

/// A method by its name, as the command line, the JSON outputs, the reports and the
/// machine-model file spell it. Each Gaussian-process kernel has its own name, so rows
/// of a comparison are told apart by it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MethodName {
    Lagrange,
    Trilinear,
    Spline,
    Fuzzy,
    /// The Gaussian process with the configured kernel (Matérn 5/2 unless told otherwise).
    Gp,
    /// The Gaussian process with the squared-exponential kernel.
    GpSe,
}

impl MethodName {
    /// Every name, in the order help texts and refusals list them.
    pub const ALL: [MethodName; 6] = [
        MethodName::Trilinear,
        MethodName::Spline,
        MethodName::Fuzzy,
        MethodName::Lagrange,
        MethodName::Gp,
        MethodName::GpSe,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Lagrange => "lagrange",
            MethodName::Trilinear => "trilinear",
            MethodName::Spline => "spline",
            MethodName::Fuzzy => "fuzzy",
            MethodName::Gp => "gp",
            MethodName::GpSe => "gp-se",
        }
    }

    /// Whether the method fits scattered nodes, not only a full rectilinear grid.
    pub fn accepts_scattered(self) -> bool {
        matches!(self, MethodName::Gp | MethodName::GpSe)
    }

    /// Whether the method takes Lagrange degrees (`--order`).
    pub fn takes_order(self) -> bool {
        self == MethodName::Lagrange
    }

    /// "trilinear, spline, fuzzy, lagrange, gp, gp-se".
    pub fn list() -> String {
        Self::ALL.map(Self::as_str).join(", ")
    }
}

impl fmt::Display for MethodName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A method name errmap does not know.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method `{0}` ({list})", list = MethodName::list())]
pub struct UnknownMethod(pub String);

impl FromStr for MethodName {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|m| m.as_str() == s.trim())
            .ok_or_else(|| UnknownMethod(s.to_string()))
    }
}

/// The settings a method name needs to become a [`Method`] (besides Lagrange's degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodSettings {
    /// Fuzzy membership width as a fraction of the cell size.
    pub fuzzy_sigma: f64,
    /// The kernel of the method named `gp` (`gp-se` is always the squared exponential).
    pub gp_kernel: Kernel,
}

impl Default for MethodSettings {
    fn default() -> Self {
        MethodSettings {
            fuzzy_sigma: fuzzy::DEFAULT_SIGMA,
            gp_kernel: Kernel::default(),
        }
    }
}

/// Why a name and an order do not make a method.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MethodError {
    #[error("lagrange needs degrees MxNxQ along x, y, z (e.g. 4x1x2) or `auto`")]
    NeedsOrder,
    #[error("an order applies to lagrange only, not to {0}")]
    OrderNotApplicable(MethodName),
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
    Gp(super::gp::Kernel),
}

impl Method {
    /// The method's registry name.
    pub fn method_name(&self) -> MethodName {
        match self {
            Method::Lagrange(_) => MethodName::Lagrange,
            Method::Trilinear => MethodName::Trilinear,
            Method::Spline => MethodName::Spline,
            Method::Fuzzy { .. } => MethodName::Fuzzy,
            // Each kernel its own name, so rows of a comparison are told apart by it.
            Method::Gp(Kernel::SquaredExponential) => MethodName::GpSe,
            Method::Gp(_) => MethodName::Gp,
        }
    }

    /// The method's name as the command line spells it.
    pub fn name(&self) -> &'static str {
        self.method_name().as_str()
    }

    /// The method a name stands for: Lagrange needs its degrees, the others take none.
    pub fn from_name(
        name: MethodName,
        order: Option<Order>,
        settings: &MethodSettings,
    ) -> Result<Method, MethodError> {
        if order.is_some() && !name.takes_order() {
            return Err(MethodError::OrderNotApplicable(name));
        }
        Ok(match name {
            MethodName::Lagrange => Method::Lagrange(order.ok_or(MethodError::NeedsOrder)?),
            MethodName::Trilinear => Method::Trilinear,
            MethodName::Spline => Method::Spline,
            MethodName::Fuzzy => Method::Fuzzy {
                sigma: settings.fuzzy_sigma,
            },
            MethodName::Gp => Method::Gp(settings.gp_kernel),
            MethodName::GpSe => Method::Gp(Kernel::SquaredExponential),
        })
    }

    /// The models a comparison fits by default on a grid: trilinear, spline, fuzzy, the
    /// Gaussian process with both kernels (Matérn 5/2 suits rough error fields, the
    /// squared exponential analytic ones; cross-validation tells them apart) and every
    /// admissible Lagrange order up to `max_degree` per axis.
    pub fn defaults(grid: &Grid, max_degree: usize, settings: &MethodSettings) -> Vec<Method> {
        let mut m = vec![
            Method::Trilinear,
            Method::Spline,
            Method::Fuzzy {
                sigma: settings.fuzzy_sigma,
            },
            Method::Gp(Kernel::Matern52),
            Method::Gp(Kernel::SquaredExponential),
        ];
        m.extend(
            admissible_orders(grid.shape(), max_degree)
                .into_iter()
                .map(Method::Lagrange),
        );
        m
    }

    /// The models a comparison fits by default on scattered nodes: the Gaussian process
    /// with both kernels; the other names are listed as not fitted.
    pub fn scattered_defaults() -> (Vec<Method>, Vec<MethodName>) {
        (
            vec![
                Method::Gp(Kernel::Matern52),
                Method::Gp(Kernel::SquaredExponential),
            ],
            MethodName::ALL
                .into_iter()
                .filter(|m| !m.accepts_scattered())
                .collect(),
        )
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
        self.method_name().accepts_scattered()
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
