//! The diagnosis's settings: [`DiagnoseConfig`] with its defaults and the ranges
//! [`DiagnoseConfig::validate`] checks, and the grating periods searched when the device's
//! is unknown.

use super::HENE_WAVELENGTH_UM;
use super::error::DiagnoseError;
use crate::base::Allowed;

/// Grating periods searched when the device's is unknown, µm (each with P/2 and P/4).
pub const COMMON_GRATINGS_UM: [f64; 4] = [20.0, 40.0, 8.0, 4.0];

/// Settings of the diagnosis. [`DiagnoseConfig::validate`] checks the ranges.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseConfig {
    /// Grating period of the scale, µm, from the device HELLO (`grating_period_nm`/1000).
    /// The periodic search looks at P, P/2 and P/4 (±[`Self::period_window_rel`]) and at
    /// the broad periodogram. `None`: every period of [`COMMON_GRATINGS_UM`] with its
    /// halves and quarters. Default `None`. Range > 0.
    pub grating_period_um: Option<f64>,
    /// Most effects reported. Default 4. Range 0..=12.
    pub max_effects: usize,
    /// Smallest BIC improvement for an effect to enter the model, and to stay in it
    /// (backward check). BIC = n·ln(χ²/n) + k·ln n with k the independent parameters
    /// (+1 for a period or a time constant). Default 10 ("very strong" evidence on the
    /// Kass–Raftery scale, on top of the k·ln n penalty). Range ≥ 0.
    pub min_delta_bic: f64,
    /// An alternative effect that fits within this many BIC units of a found one makes
    /// the pair ambiguous (stated in `where` and `ambiguities`). Default 10. Range ≥ 0.
    pub ambiguity_delta_bic: f64,
    /// An effect whose fitted contribution has an RMS below this fraction of the noise σ
    /// is not reported even when significant. Default 0.1 (a tenth of the noise is below
    /// any error budget; smaller but significant structure is left to the report). Range 0..1.
    pub min_effect_fraction_of_noise: f64,
    /// A parameter is determined when its one-sigma uncertainty is at most this fraction
    /// of its magnitude. Default 0.5. Range (0, 10].
    pub max_relative_uncertainty: f64,
    /// Drop effects whose removal does not raise the leave-one-run-out error. Default true.
    pub cv_confirm: bool,
    /// Half-width of the search window around each grating-tied period, relative.
    /// Default 0.0005 (the interpolation error of a scale is locked to its grating).
    /// Range (0, 0.1].
    pub period_window_rel: f64,
    /// Shortest period of the long-period broad periodogram, mm; below it a second scan
    /// goes down to 4 grating periods (4 × the largest of [`COMMON_GRATINGS_UM`] when
    /// the grating is unknown). Default 0.5. Range > 0.
    pub broad_min_period_mm: f64,
    /// Rows used by the periodograms and the nonlinear searches (an evenly spaced subset
    /// when there are more; the final fit uses all rows). Default 2500. Range ≥ 50.
    pub spectral_max_rows: usize,
    /// Bound on rows × frequencies of each periodogram (the grating windows together, and
    /// the broad scan): a scan over more frequencies uses fewer rows (at least 200).
    /// Default 1.2e6 (a few ms in release). Range ≥ 1e4.
    pub spectral_budget: f64,
    /// Laser vacuum wavelength for the refractive index of `dead_path`, µm. Default HeNe.
    pub laser_wavelength_um: f64,
    /// The dead path the simulation already has, mm, when it is known (diagnosing
    /// against a model): a found `dead_path` D is then a correction, and D below −D_model
    /// by more than two of its sigmas would make the beam's dead path negative, which is
    /// not a length, so it is refused. `None` (default): no such bound. Range ≥ 0.
    pub model_dead_path_mm: Option<f64>,
    /// The longest dead path the set-up's optics allow, mm: the beam length from the
    /// interferometer to the measurement's zero point (e.g. the laser-to-first-target
    /// distance). When `dead_path` and `thermal_drift` cannot be told apart, a fitted dead
    /// path beyond it (or below zero) decides for the drift. `None` (default): the axis
    /// travel, stated as an assumption. Range ≥ 0.
    pub max_dead_path_mm: Option<f64>,
    /// The smallest factor χ²/ν the parameters' covariances are scaled by. 0 (default):
    /// the fit's own χ²/ν. The diagnosis sets 1 when the residual is quieter than the
    /// recording alone (a simulation sharing the recording's noise): the group σ are
    /// then the recording's own noise, and a residual below it must not shrink them.
    pub min_variance_factor: f64,
}

impl Default for DiagnoseConfig {
    fn default() -> Self {
        DiagnoseConfig {
            grating_period_um: None,
            max_effects: 4,
            min_delta_bic: 10.0,
            ambiguity_delta_bic: 10.0,
            min_effect_fraction_of_noise: 0.1,
            max_relative_uncertainty: 0.5,
            cv_confirm: true,
            period_window_rel: 0.0005,
            broad_min_period_mm: 0.5,
            spectral_max_rows: 2500,
            spectral_budget: 1.2e6,
            laser_wavelength_um: HENE_WAVELENGTH_UM,
            model_dead_path_mm: None,
            max_dead_path_mm: None,
            min_variance_factor: 0.0,
        }
    }
}

impl DiagnoseConfig {
    /// Checks every setting against its documented range.
    pub fn validate(&self) -> Result<(), DiagnoseError> {
        let bad = |m: String| Err(DiagnoseError::Config(m));
        if let Some(d) = self.model_dead_path_mm
            && !(d.is_finite() && d >= 0.0)
        {
            return bad(format!("model_dead_path_mm = {d} must be a length ≥ 0"));
        }
        if let Some(d) = self.max_dead_path_mm
            && !(d.is_finite() && d >= 0.0)
        {
            return bad(format!("max_dead_path_mm = {d} must be a length ≥ 0"));
        }
        if let Some(p) = self.grating_period_um {
            Allowed::Positive
                .check("grating_period_um", p)
                .map_err(|e| DiagnoseError::Config(e.to_string()))?;
        }
        if self.max_effects > 12 {
            return bad(format!(
                "max_effects = {} must be at most 12",
                self.max_effects
            ));
        }
        for (key, v, allowed) in [
            ("min_delta_bic", self.min_delta_bic, Allowed::NonNegative),
            (
                "ambiguity_delta_bic",
                self.ambiguity_delta_bic,
                Allowed::NonNegative,
            ),
            (
                "min_effect_fraction_of_noise",
                self.min_effect_fraction_of_noise,
                Allowed::FromBelow(0.0, 1.0),
            ),
            (
                "max_relative_uncertainty",
                self.max_relative_uncertainty,
                Allowed::AboveUpTo(0.0, 10.0),
            ),
            (
                "period_window_rel",
                self.period_window_rel,
                Allowed::AboveUpTo(0.0, 0.1),
            ),
            (
                "broad_min_period_mm",
                self.broad_min_period_mm,
                Allowed::Positive,
            ),
        ] {
            allowed
                .check(key, v)
                .map_err(|e| DiagnoseError::Config(e.to_string()))?;
        }
        if self.spectral_max_rows < 50 {
            return bad(format!(
                "spectral_max_rows = {} must be at least 50",
                self.spectral_max_rows
            ));
        }
        if !(self.spectral_budget.is_finite() && self.spectral_budget >= 1e4) {
            return bad(format!(
                "spectral_budget = {} must be at least 1e4",
                self.spectral_budget
            ));
        }
        if !(self.laser_wavelength_um > 0.2 && self.laser_wavelength_um < 2.0) {
            return bad(format!(
                "laser_wavelength_um = {} must be a visible or near-infrared wavelength",
                self.laser_wavelength_um
            ));
        }
        Ok(())
    }
}
