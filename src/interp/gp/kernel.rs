//! The covariance functions of the Gaussian process (the [`Kernel`] table in the
//! [module docs](super)): the correlation ρ(r²) and its slope for the likelihood gradient.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Covariance function of the latent error field; both are anisotropic (ARD).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Kernel {
    /// σ_f² exp(−r²/2): infinitely smooth sample paths.
    SquaredExponential,
    /// Matérn ν = 5/2, σ_f² (1 + √5 r + 5r²/3) exp(−√5 r): twice-differentiable paths.
    #[default]
    Matern52,
}

/// A kernel name that is not `matern52` (`matern`) or `se` (`squared-exponential`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown kernel `{0}` (matern52 or se)")]
pub struct UnknownKernel(pub String);

impl std::str::FromStr for Kernel {
    type Err = UnknownKernel;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "matern52" | "matern" => Ok(Kernel::Matern52),
            "se" | "squared-exponential" => Ok(Kernel::SquaredExponential),
            other => Err(UnknownKernel(other.to_string())),
        }
    }
}

impl Kernel {
    /// The kernel's name as a command line would spell it.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::SquaredExponential => "se",
            Kernel::Matern52 => "matern52",
        }
    }

    /// Correlation ρ(r²) = k/σ_f².
    #[inline]
    pub(super) fn corr(self, r2: f64) -> f64 {
        match self {
            Kernel::SquaredExponential => (-0.5 * r2).exp(),
            Kernel::Matern52 => {
                let s = (5.0 * r2).sqrt();
                (1.0 + s + 5.0 / 3.0 * r2) * (-s).exp()
            }
        }
    }

    /// g(r²) = −2 dρ/d(r²), so that ∂k/∂ln ℓₐ = σ_f² g(r²) (Δₐ/ℓₐ)².
    #[inline]
    pub(super) fn slope(self, r2: f64) -> f64 {
        match self {
            Kernel::SquaredExponential => (-0.5 * r2).exp(),
            Kernel::Matern52 => {
                let s = (5.0 * r2).sqrt();
                5.0 / 3.0 * (1.0 + s) * (-s).exp()
            }
        }
    }
}

impl fmt::Display for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
