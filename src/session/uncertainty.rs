//! Measurement uncertainty of ISO 230-2 positioning statistics measured with a laser
//! interferometer: a budget per axis (per measured line), the combined standard
//! uncertainty and the expanded uncertainty `U = k·u_c` (k = 2) of each statistic.
//! Numbers only; the tables are drawn by `report`.
//!
//! # Method
//!
//! The budget follows the scheme of ISO/TR 230-9:2005 ("Estimation of measurement
//! uncertainty for machine tool tests according to series ISO 230, basic equations") and
//! ISO 230-2:2014 Annex A, evaluated with the GUM (JCGM 100:2008): each influence is an
//! input quantity with a standard uncertainty `u(x_i)` (a Type B evaluation: a sensor or
//! laser specification, or a bound with a rectangular distribution, GUM 4.3.7, `u = a/√3`
//! for a half-width `a`), a sensitivity coefficient `c_i` (GUM 5.1.3), the contribution
//! `u_i = │c_i│·u(x_i)`, combined in quadrature (GUM 5.1.2; the inputs are taken as
//! uncorrelated). Neither the standard nor the technical report was available to quote
//! while this was written: the list of influences is theirs, the formulas below are
//! errmap's application of the GUM to them, stated in full so that a reader can check them.
//!
//! Two kinds of contribution:
//!
//! * **length terms**, relative (ppm), systematic over the test: the error they cause is
//!   proportional to the distance `L` between the two positions a statistic compares;
//! * **reading terms**, µm, that can differ from one reading to the next during the test
//!   (they do not scale with length).
//!
//! | influence | input and its default standard uncertainty | sensitivity | contribution |
//! |---|---|---|---|
//! | laser vacuum wavelength | `u(λ)/λ` = 0.02 ppm (a stabilised HeNe laser's calibration) | 1 | length, `u(λ)/λ` |
//! | the modified Edlén equation itself | 0.01 ppm (see below) | 1 | length |
//! | air temperature sensor | `u(T)` = 0.1 K | `∂n/∂T` ≈ −0.93 ppm/K | length, `│∂n/∂T│·u(T)` |
//! | air pressure sensor | `u(p)` = 0.5 hPa | `∂n/∂p` ≈ +0.27 ppm/hPa | length |
//! | humidity sensor | `u(RH)` = 3 %RH | `∂n/∂RH` ≈ −0.0085 ppm/%RH | length |
//! | material temperature sensor | `u(θ)` = 0.1 K | `α` (default 11.5 ppm/K) | length, `α·u(θ)` |
//! | expansion coefficient | `u(α)` = 1 ppm/K | `│θ̄ − 20 °C│` | length, `│θ̄ − 20│·u(α)` |
//! | cosine error (misalignment) | largest angle `θ_c` = 200 µrad | — | length, `θ_c²/(4√3)` |
//! | dead path | dead path `L_d` = 100 mm | span `Δn` of `n` over the test | reading, `L_d·Δn/(2√3)` |
//! | device resolution | resolution `r` = 0.001 µm | — | reading, `r/(2√3)` |
//!
//! * The air terms go through the sensitivities of the modified Edlén equation
//!   ([`errmap_drivers::edlen`]) at the test's mean air temperature, pressure and humidity
//!   (20 °C, 1013.25 hPa, 50 %RH when the session has no air data), computed by central
//!   differences ([`edlen_sensitivities`]). A length is `λ_vac/n` fringes, so a relative
//!   error of `n` is the same relative error of the length, with the opposite sign.
//! * The cosine error `L(1 − cos θ) ≈ L θ²/2` is one-sided: with the angle anywhere up to
//!   `θ_c`, the relative error lies in `[0, θ_c²/2]`, a rectangular distribution of
//!   half-width `θ_c²/4`, so `u = θ_c²/(4√3)`.
//! * The dead path `L_d` (interferometer to the datum) is not compensated: when the air
//!   changes by `Δn` after the datum was set, the reading moves by `L_d·Δn`; taking it
//!   anywhere in an interval of the width of the test's span of `n`, `u = L_d·Δn/(2√3)`.
//!   The span comes from the session's air data (max − min of `n` over its rows); with no
//!   air data, from the default drifts of [`UncertaintyConfig::air_temp_drift_k`] and
//!   [`UncertaintyConfig::air_pressure_drift_hpa`] through the sensitivities.
//! * The resolution `r` of the reading: quantisation error uniform in `±r/2`, GUM F.2.2.1.
//! * The material temperature and expansion-coefficient terms are the uncertainty of the
//!   length's reference to 20 °C (ISO 1). errmap reports deviations as measured (not
//!   normalised); the certificate states the material temperature beside them.
//!
//! The Edlén equation's own uncertainty: Birch and Downs give the modified equation an
//! uncertainty of a few parts in 10⁸; the default 0.01 ppm (k = 1) is of that order and is
//! meant to be overridden by a lab that has its own figure.
//!
//! # From the budget to each statistic
//!
//! Every ISO 230-2 axis statistic is a range or a difference of deviations:
//!
//! * `E`, `M`, `A` (and VDI/DGQ 3441's `P`, `Pa`) compare positions anywhere on the
//!   travel: the length terms enter at `L` = the travel measured (largest minus smallest
//!   target position, an upper bound of the distance between the two extremes), and the
//!   reading terms enter twice (two readings):
//!   `u_c = √((u_rel·L)² + 2·u_read²)`;
//! * `B`, `R` (and `U`, `Ps`) compare readings at one target: the length terms cancel
//!   (`L = 0`), `u_c = √2·u_read`.
//!
//! `u_rel = √Σ u_i²` over the length terms, `u_read = √Σ u_j²` over the reading terms, and
//! `U = k·u_c`. No credit is taken for averaging the five runs (the dead path term drifts
//! rather than scatters), so `U` is an upper estimate in that respect. The Type A part of
//! the statistics — the scatter of the machine itself, in `s` — is the measurand, not a
//! contribution.
//!
//! # Cost
//!
//! A dozen evaluations of the Edlén equation per budget, `O(N)` over the session's rows
//! for the test conditions.

mod sources;

use sources::Span;
pub use sources::{
    BudgetSources, DeclaredConditions, DriftCheck, DriftFinder, Eve, MIN_DRIFT_ROWS, MIN_DRIFT_S,
    RecordedResolution, Resolution,
};

use super::environment::EnvironmentStats;
use errmap_drivers::SessionRow;
use errmap_drivers::edlen::refractive_index;
use serde::{Deserialize, Serialize};

use super::iso230::AxisStats;
use crate::base::HENE_WAVELENGTH_UM;

/// Reference temperature of dimensional measurements (ISO 1), °C.
pub const REFERENCE_TEMP_C: f64 = 20.0;

/// Air conditions used for the sensitivities when a session has no air data: 20 °C,
/// 1013.25 hPa, 50 %RH.
pub const STANDARD_AIR: (f64, f64, f64) = (20.0, 1013.25, 50.0);

/// The budget's inputs: standard uncertainties (k = 1) of the influences, and the few
/// quantities they need. Every field has a documented default ([`Default`]); an info TOML
/// `[uncertainty]` table overrides any of them (unknown keys are an error).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UncertaintyConfig {
    /// Coverage factor `k` of the expanded uncertainty, > 0. Default 2 (about 95 % for a
    /// normal distribution).
    pub k: f64,
    /// Relative standard uncertainty of the laser's vacuum wavelength, ppm. Default 0.02.
    pub wavelength_ppm: f64,
    /// Relative standard uncertainty of the Edlén equation itself, ppm. Default 0.01.
    pub edlen_equation_ppm: f64,
    /// Standard uncertainty of the air temperature sensor, K. Default 0.1.
    pub air_temp_k: f64,
    /// Standard uncertainty of the air pressure sensor, hPa. Default 0.5.
    pub air_pressure_hpa: f64,
    /// Standard uncertainty of the humidity sensor, %RH. Default 3.
    pub air_rh_pct: f64,
    /// Standard uncertainty of the material (scale/part) temperature sensor, K. Default 0.1.
    pub material_temp_k: f64,
    /// Expansion coefficient of the machine's scale or part, ppm/K. Default 11.5 (steel).
    pub expansion_ppm_per_k: f64,
    /// Standard uncertainty of the expansion coefficient, ppm/K. Default 1.
    pub expansion_u_ppm_per_k: f64,
    /// Largest misalignment angle of the beam to the axis, µrad (a bound, not a standard
    /// uncertainty). Default 200.
    pub misalignment_urad: f64,
    /// Dead path (interferometer to the datum), mm. Default 100.
    pub dead_path_mm: f64,
    /// Air temperature drift over the test assumed when the session has no air data, K.
    /// Default 0.5.
    pub air_temp_drift_k: f64,
    /// Air pressure drift over the test assumed when the session has no air data, hPa.
    /// Default 1.
    pub air_pressure_drift_hpa: f64,
    /// Resolution of the measuring device's reading, µm. Default 0.001 (1 nm).
    pub resolution_um: f64,
}

impl Default for UncertaintyConfig {
    fn default() -> Self {
        UncertaintyConfig {
            k: 2.0,
            wavelength_ppm: 0.02,
            edlen_equation_ppm: 0.01,
            air_temp_k: 0.1,
            air_pressure_hpa: 0.5,
            air_rh_pct: 3.0,
            material_temp_k: 0.1,
            expansion_ppm_per_k: 11.5,
            expansion_u_ppm_per_k: 1.0,
            misalignment_urad: 200.0,
            dead_path_mm: 100.0,
            air_temp_drift_k: 0.5,
            air_pressure_drift_hpa: 1.0,
            resolution_um: 0.001,
        }
    }
}

/// Why a budget cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UncertaintyError {
    /// A configuration value is NaN, infinite, negative, or (for `k`) not positive.
    #[error("uncertainty.{key} = {value}: {reason}")]
    Invalid {
        /// The key, as spelt in the info TOML.
        key: &'static str,
        /// The value given.
        value: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A configuration value beyond its physical bound.
    #[error(
        "uncertainty.{key} = {value}: more than {max}, beyond any real instrument (a unit mistake?)"
    )]
    TooLarge {
        /// The key, as spelt in the info TOML.
        key: &'static str,
        /// The value given.
        value: f64,
        /// Its bound.
        max: f64,
    },
    /// The travel is NaN, infinite or negative.
    #[error("travel {0} mm is not a finite length ≥ 0")]
    Travel(f64),
}

impl UncertaintyConfig {
    /// The fields with their TOML keys and their physical upper bounds, in budget order.
    /// The bounds are far beyond any real instrument (issue 28: `air_temp_k =
    /// 9223372036854775807` printed `u_rel = 8819167232000000000 ppm`); each one's reason
    /// is in `docs/robustness.md`.
    fn fields(&self) -> [(&'static str, f64, f64); 14] {
        [
            ("k", self.k, 10.0),
            ("wavelength_ppm", self.wavelength_ppm, 100.0),
            ("edlen_equation_ppm", self.edlen_equation_ppm, 100.0),
            ("air_temp_k", self.air_temp_k, 50.0),
            ("air_pressure_hpa", self.air_pressure_hpa, 500.0),
            ("air_rh_pct", self.air_rh_pct, 100.0),
            ("material_temp_k", self.material_temp_k, 50.0),
            ("expansion_ppm_per_k", self.expansion_ppm_per_k, 1000.0),
            ("expansion_u_ppm_per_k", self.expansion_u_ppm_per_k, 1000.0),
            ("misalignment_urad", self.misalignment_urad, 1e5),
            ("dead_path_mm", self.dead_path_mm, 1e6),
            ("air_temp_drift_k", self.air_temp_drift_k, 150.0),
            (
                "air_pressure_drift_hpa",
                self.air_pressure_drift_hpa,
                1000.0,
            ),
            ("resolution_um", self.resolution_um, 1e6),
        ]
    }

    /// Checks every value: finite, ≥ 0 and within its physical bound, `k` > 0. The error
    /// names the first bad key.
    pub fn validate(&self) -> Result<(), UncertaintyError> {
        for (key, value, max) in self.fields() {
            if !value.is_finite() {
                return Err(UncertaintyError::Invalid {
                    key,
                    value,
                    reason: "not a finite number",
                });
            }
            if value < 0.0 {
                return Err(UncertaintyError::Invalid {
                    key,
                    value,
                    reason: "negative",
                });
            }
            if value > max {
                return Err(UncertaintyError::TooLarge { key, value, max });
            }
        }
        if self.k <= 0.0 {
            return Err(UncertaintyError::Invalid {
                key: "k",
                value: self.k,
                reason: "the coverage factor must be > 0",
            });
        }
        Ok(())
    }
}

/// Sensitivities of the refractive index of air (modified Edlén equation) to its inputs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EdlenSensitivities {
    /// `∂n/∂T`, 1/K.
    pub dn_dt_per_k: f64,
    /// `∂n/∂p`, 1/hPa.
    pub dn_dp_per_hpa: f64,
    /// `∂n/∂RH`, 1/%RH.
    pub dn_drh_per_pct: f64,
}

/// The sensitivities of [`errmap_drivers::edlen::refractive_index`] at the HeNe wavelength
/// and the given air, by central differences (steps 0.01 K, 0.01 hPa, 0.1 %RH: `n` is
/// smooth on these scales and the differences of order 1e-8 keep eight significant digits
/// in double precision).
pub fn edlen_sensitivities(t_c: f64, p_hpa: f64, rh_pct: f64) -> EdlenSensitivities {
    let n = |t: f64, p: f64, rh: f64| refractive_index(HENE_WAVELENGTH_UM, t, p * 100.0, rh);
    let (ht, hp, hrh) = (0.01, 0.01, 0.1);
    EdlenSensitivities {
        dn_dt_per_k: (n(t_c + ht, p_hpa, rh_pct) - n(t_c - ht, p_hpa, rh_pct)) / (2.0 * ht),
        dn_dp_per_hpa: (n(t_c, p_hpa + hp, rh_pct) - n(t_c, p_hpa - hp, rh_pct)) / (2.0 * hp),
        dn_drh_per_pct: (n(t_c, p_hpa, rh_pct + hrh) - n(t_c, p_hpa, rh_pct - hrh)) / (2.0 * hrh),
    }
}

/// Where a group of environment inputs comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// The session's own sensors.
    Sensor,
    /// The conditions the info file declares (no sensor in the session).
    Declared,
    /// Neither: the terms are not evaluated, and the budget says so.
    Missing,
}

/// What the budget needs to know about one test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestConditions {
    /// Mean air temperature, °C (measured, declared midpoint, or the standard air's).
    pub air_temp_c: f64,
    /// Mean air pressure, hPa.
    pub air_pressure_hpa: f64,
    /// Mean relative humidity, %RH.
    pub air_rh_pct: f64,
    /// Where the air values come from.
    pub air: Origin,
    /// Span (max − min) of the refractive index over the test: over the rows with air
    /// data, or over the declared ranges.
    pub n_span: Option<f64>,
    /// Mean material temperature (scale, else part; or the declared midpoint), °C.
    pub material_temp_c: Option<f64>,
    /// Where the material temperature comes from.
    pub material: Origin,
    /// The ranges the info file declares (used where no sensor recorded).
    pub declared: DeclaredConditions,
    /// Travel measured: largest minus smallest target position, mm.
    pub travel_mm: f64,
    /// The resolutions of the reading chain (empty: [`UncertaintyConfig::resolution_um`]).
    pub resolution: Vec<Resolution>,
    /// The environmental variation error, when a drift check or the session measured it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eve: Option<Eve>,
}

impl TestConditions {
    /// The conditions of a session's rows, for a line of the given travel.
    pub fn from_rows(rows: &[SessionRow], travel_mm: f64) -> TestConditions {
        Self::from_environment(&EnvironmentStats::of(rows), travel_mm)
    }

    /// The conditions from a session's environment gathered in one pass (a streamed
    /// session), for a line of the given travel: the mean air (or [`STANDARD_AIR`]
    /// without air data), the span of the refractive index over the session, and the
    /// mean scale temperature (else the part's). No declared conditions, no device
    /// resolution, no drift: see [`TestConditions::with_declared`] and the fields.
    pub fn from_environment(env: &EnvironmentStats, travel_mm: f64) -> TestConditions {
        let mean = |r: &super::environment::Range| r.min_mean_max().map(|(_, m, _)| m);
        let air = match (
            mean(&env.air_temp_c),
            mean(&env.air_pressure_hpa),
            mean(&env.air_rh_pct),
        ) {
            (Some(t), Some(p), Some(h)) if env.n_air.n > 0 => Some((t, p, h)),
            _ => None,
        };
        let (t, p, h) = air.unwrap_or(STANDARD_AIR);
        let material_temp_c = mean(&env.scale_temp_c).or_else(|| mean(&env.part_temp_c));
        let origin = |b: bool| if b { Origin::Sensor } else { Origin::Missing };
        TestConditions {
            air_temp_c: t,
            air_pressure_hpa: p,
            air_rh_pct: h,
            air: origin(air.is_some()),
            n_span: env.n_air.min_mean_max().map(|(lo, _, hi)| hi - lo),
            material_temp_c,
            material: origin(material_temp_c.is_some()),
            declared: DeclaredConditions::default(),
            travel_mm,
            resolution: Vec::new(),
            eve: None,
        }
    }

    /// Fills what the sensors did not record from the declared conditions: the air when
    /// all three of its ranges are declared (the means at their midpoints, the span of `n`
    /// over the box they span), the material temperature when its range is.
    pub fn with_declared(mut self, declared: &DeclaredConditions) -> TestConditions {
        let mid = |s: Span| (s[0] + s[1]) / 2.0;
        if self.air == Origin::Missing
            && let (Some(t), Some(p), Some(h)) = (
                declared.air_temp_c,
                declared.air_pressure_hpa,
                declared.air_rh_pct,
            )
        {
            self.air = Origin::Declared;
            (self.air_temp_c, self.air_pressure_hpa, self.air_rh_pct) = (mid(t), mid(p), mid(h));
            let s = edlen_sensitivities(mid(t), mid(p), mid(h));
            self.n_span = Some(
                s.dn_dt_per_k.abs() * (t[1] - t[0])
                    + s.dn_dp_per_hpa.abs() * (p[1] - p[0])
                    + s.dn_drh_per_pct.abs() * (h[1] - h[0]),
            );
        }
        if self.material == Origin::Missing
            && let Some(m) = declared.material_temp_c
        {
            self.material = Origin::Declared;
            self.material_temp_c = Some(mid(m));
        }
        self.declared = declared.clone();
        self
    }
}

/// How a contribution scales.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Relative, systematic: `u_i` in ppm of the distance compared.
    Length,
    /// Per reading, µm, independent of length.
    Reading,
}

/// One line of the budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Contribution {
    /// Short identifier (`"air_temp"`, …).
    pub id: &'static str,
    /// The influence in words.
    pub name: String,
    /// The input's standard uncertainty (or bound, see the module docs), in `input_unit`.
    pub input: f64,
    /// Unit of `input`.
    pub input_unit: &'static str,
    /// Sensitivity coefficient, in `sensitivity_unit` (1 where there is none).
    pub sensitivity: f64,
    /// Unit of `sensitivity` (empty when dimensionless).
    pub sensitivity_unit: &'static str,
    /// Length or reading term.
    pub kind: Kind,
    /// The contribution `u_i`: ppm for a length term, µm for a reading term.
    pub u: f64,
    /// Where the input comes from, in words.
    pub source: String,
}

impl Contribution {
    /// The contribution in µm at a distance `length_mm` (reading terms: their value).
    pub fn u_um_at(&self, length_mm: f64) -> f64 {
        match self.kind {
            Kind::Length => self.u * length_mm * 1e-3,
            Kind::Reading => self.u,
        }
    }
}

/// The uncertainty budget of one axis (one measured line).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Budget {
    /// The contributions, in the order of the module docs' table.
    pub contributions: Vec<Contribution>,
    /// Influences left out, each with the reason, in words.
    pub not_evaluated: Vec<String>,
    /// Coverage factor.
    pub k: f64,
    /// The test conditions the budget was made for.
    pub conditions: TestConditions,
    /// The Edlén sensitivities used.
    pub sensitivities: EdlenSensitivities,
    /// Combined relative standard uncertainty of the length terms, ppm.
    pub u_rel_ppm: f64,
    /// Combined standard uncertainty of the reading terms, µm.
    pub u_read_um: f64,
    /// The coarsest resolution step of the readings, µm: no expanded uncertainty of a
    /// difference of readings is stated below it.
    pub resolution_floor_um: f64,
}

const SQRT3: f64 = 1.732_050_807_568_877_2;

/// `"info file [uncertainty] KEY"` when the value differs from errmap's default, else
/// `"errmap's default (info file [uncertainty] KEY)"`.
fn config_source(key: &str, value: f64, default: f64) -> String {
    if value == default {
        format!("errmap's default (info file [uncertainty] {key})")
    } else {
        format!("info file [uncertainty] {key}")
    }
}

impl Budget {
    /// The budget for a test under `conditions` (validates `config` and the travel).
    pub fn new(
        config: &UncertaintyConfig,
        conditions: TestConditions,
    ) -> Result<Budget, UncertaintyError> {
        config.validate()?;
        if !(conditions.travel_mm.is_finite() && conditions.travel_mm >= 0.0) {
            return Err(UncertaintyError::Travel(conditions.travel_mm));
        }
        let sens = edlen_sensitivities(
            conditions.air_temp_c,
            conditions.air_pressure_hpa,
            conditions.air_rh_pct,
        );
        let mut not_evaluated = Vec::new();
        let mut contributions =
            length_contributions(config, &conditions, &sens, &mut not_evaluated);
        contributions.extend(reading_contributions(
            config,
            &conditions,
            &mut not_evaluated,
        ));
        let rss = |kind: Kind| {
            contributions
                .iter()
                .filter(|x| x.kind == kind)
                .map(|x| x.u * x.u)
                .sum::<f64>()
                .sqrt()
        };
        let resolution_floor_um = if conditions.resolution.is_empty() {
            config.resolution_um
        } else {
            conditions
                .resolution
                .iter()
                .map(|r| r.step_um)
                .fold(0.0, f64::max)
        };
        Ok(Budget {
            u_rel_ppm: rss(Kind::Length),
            u_read_um: rss(Kind::Reading),
            contributions,
            not_evaluated,
            k: config.k,
            conditions,
            sensitivities: sens,
            resolution_floor_um,
        })
    }

    /// Combined standard uncertainty of a statistic comparing two readings `length_mm`
    /// apart: `√((u_rel·L)² + 2·u_read²)`, µm.
    pub fn u_c_um(&self, length_mm: f64) -> f64 {
        let l = self.u_rel_ppm * length_mm * 1e-3;
        (l * l + 2.0 * self.u_read_um * self.u_read_um).sqrt()
    }

    /// Expanded uncertainty of a statistic comparing two readings `length_mm` apart, µm:
    /// `k·u_c`, and never less than one step of the coarsest resolution.
    pub fn expanded_um(&self, length_mm: f64) -> f64 {
        (self.k * self.u_c_um(length_mm)).max(self.resolution_floor_um)
    }

    /// The expanded uncertainty of each statistic (see the module docs).
    pub fn expanded(&self) -> StatUncertainty {
        let travel = self.conditions.travel_mm;
        StatUncertainty {
            k: self.k,
            travel_mm: travel,
            u_c_travel_um: self.u_c_um(travel),
            u_c_target_um: self.u_c_um(0.0),
            along_travel_um: self.expanded_um(travel),
            at_one_target_um: self.expanded_um(0.0),
            resolution_floor_um: self.resolution_floor_um,
        }
    }
}

/// The expanded uncertainty beside each statistic: one value for the statistics that
/// compare positions along the travel (`E`, `M`, `A`, VDI `P`, `Pa`), one for those that compare
/// readings at one target (`B`, `B̄`, `R`, VDI `U`, `Ps`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatUncertainty {
    /// Coverage factor.
    pub k: f64,
    /// Travel the length terms were evaluated at, mm.
    pub travel_mm: f64,
    /// Combined standard uncertainty along the travel, µm.
    pub u_c_travel_um: f64,
    /// Combined standard uncertainty at one target, µm.
    pub u_c_target_um: f64,
    /// `U` of `E`, `E↑`, `E↓`, `M`, `A`, `A↑`, `A↓`, `P`, `Pa`, µm.
    pub along_travel_um: f64,
    /// `U` of `B`, `B̄`, `R`, `R↑`, `R↓`, `U`, `Ps`, µm.
    pub at_one_target_um: f64,
    /// The floor both are held at: one step of the coarsest resolution, µm.
    pub resolution_floor_um: f64,
}

/// The travel of a line: largest minus smallest target position, mm (0 for no targets).
pub fn travel_mm(stats: &AxisStats) -> f64 {
    let p = stats.targets.iter().map(|t| t.position_mm);
    let hi = p.clone().fold(f64::NEG_INFINITY, f64::max);
    let lo = p.fold(f64::INFINITY, f64::min);
    if hi >= lo { hi - lo } else { 0.0 }
}

/// The budget of one measured line of a session: its conditions from `rows`, its travel
/// from `stats`.
pub fn line_budget(
    config: &UncertaintyConfig,
    rows: &[SessionRow],
    stats: &AxisStats,
) -> Result<(Budget, StatUncertainty), UncertaintyError> {
    line_budget_of(config, &EnvironmentStats::of(rows), stats)
}

/// [`line_budget`] from a session's environment gathered in one pass.
pub fn line_budget_of(
    config: &UncertaintyConfig,
    env: &EnvironmentStats,
    stats: &AxisStats,
) -> Result<(Budget, StatUncertainty), UncertaintyError> {
    let budget = Budget::new(
        config,
        TestConditions::from_environment(env, travel_mm(stats)),
    )?;
    let u = budget.expanded();
    Ok((budget, u))
}

/// [`line_budget_of`] with what is known beyond the environment: the resolutions, the
/// drift and the declared conditions.
pub fn line_budget_with(
    config: &UncertaintyConfig,
    env: &EnvironmentStats,
    stats: &AxisStats,
    sources: &BudgetSources,
) -> Result<(Budget, StatUncertainty), UncertaintyError> {
    let mut conditions =
        TestConditions::from_environment(env, travel_mm(stats)).with_declared(&sources.declared);
    conditions.resolution = sources.resolution.clone();
    conditions.eve = sources.eve.clone();
    let budget = Budget::new(config, conditions)?;
    let u = budget.expanded();
    Ok((budget, u))
}

/// A length term: the input's uncertainty times its sensitivity, in ppm of the length.
fn length(
    (id, name): (&'static str, &str),
    input: (f64, &'static str),
    sensitivity: (f64, &'static str),
    source: String,
) -> Contribution {
    term(
        Kind::Length,
        (id, name.to_string()),
        input,
        sensitivity,
        source,
    )
}

/// A term `u = |c·u(x)|` of either kind.
fn term(
    kind: Kind,
    (id, name): (&'static str, String),
    (input, input_unit): (f64, &'static str),
    (sensitivity, sensitivity_unit): (f64, &'static str),
    source: String,
) -> Contribution {
    Contribution {
        id,
        name,
        input,
        input_unit,
        sensitivity,
        sensitivity_unit,
        kind,
        u: (sensitivity * input).abs(),
        source,
    }
}

/// A declared range's standard uncertainty (rectangular over it) and its words.
fn declared_u(span: Option<Span>, unit: &str, declared: &DeclaredConditions) -> (f64, String) {
    let [lo, hi] = span.unwrap_or([0.0, 0.0]);
    let from = declared
        .source
        .as_deref()
        .map_or_else(String::new, |s| format!(", {s}"));
    (
        (hi - lo) / (2.0 * SQRT3),
        format!(
            "no sensor in the session: the range {lo}…{hi} {unit} the info file declares \
             ([conditions]{from}), rectangular"
        ),
    )
}

/// The length terms (ppm): the wavelength, the Edlén equation and its air inputs, the
/// material's temperature and expansion, the cosine error. Terms without a source go to
/// `missing`.
fn length_contributions(
    c: &UncertaintyConfig,
    cond: &TestConditions,
    sens: &EdlenSensitivities,
    missing: &mut Vec<String>,
) -> Vec<Contribution> {
    let d = UncertaintyConfig::default();
    let theta = c.misalignment_urad * 1e-6;
    let mut out = vec![
        length(
            ("wavelength", "laser vacuum wavelength"),
            (c.wavelength_ppm, "ppm"),
            (1.0, "1"),
            config_source("wavelength_ppm", c.wavelength_ppm, d.wavelength_ppm),
        ),
        length(
            ("edlen", "modified Edlén equation"),
            (c.edlen_equation_ppm, "ppm"),
            (1.0, "1"),
            config_source(
                "edlen_equation_ppm",
                c.edlen_equation_ppm,
                d.edlen_equation_ppm,
            ),
        ),
    ];
    air_contributions(c, cond, sens, &mut out, missing);
    material_contributions(c, cond, &mut out, missing);
    out.push(length(
        ("cosine", "cosine error (misalignment)"),
        (c.misalignment_urad, "µrad"),
        (theta / (4.0 * SQRT3), "ppm/µrad"),
        config_source(
            "misalignment_urad",
            c.misalignment_urad,
            d.misalignment_urad,
        ),
    ));
    out
}

/// The air's terms (temperature, pressure, humidity) through the refractive index: from
/// the session's sensors, a declared range, or named as missing.
fn air_contributions(
    c: &UncertaintyConfig,
    cond: &TestConditions,
    sens: &EdlenSensitivities,
    out: &mut Vec<Contribution>,
    missing: &mut Vec<String>,
) {
    let d = UncertaintyConfig::default();
    let air = [
        (
            ("air_temp", "air temperature"),
            c.air_temp_k,
            d.air_temp_k,
            "air_temp_k",
            cond.declared.air_temp_c,
            ("K", "°C"),
            (sens.dn_dt_per_k * 1e6, "ppm/K"),
        ),
        (
            ("air_pressure", "air pressure"),
            c.air_pressure_hpa,
            d.air_pressure_hpa,
            "air_pressure_hpa",
            cond.declared.air_pressure_hpa,
            ("hPa", "hPa"),
            (sens.dn_dp_per_hpa * 1e6, "ppm/hPa"),
        ),
        (
            ("air_rh", "humidity"),
            c.air_rh_pct,
            d.air_rh_pct,
            "air_rh_pct",
            cond.declared.air_rh_pct,
            ("%RH", "%RH"),
            (sens.dn_drh_per_pct * 1e6, "ppm/%RH"),
        ),
    ];
    for (id, value, default, key, span, (unit, range_unit), s) in air {
        match cond.air {
            Origin::Sensor => out.push(length(
                (id.0, &format!("{} sensor", id.1)),
                (value, unit),
                s,
                format!(
                    "the session's sensor; its standard uncertainty: {}",
                    config_source(key, value, default)
                ),
            )),
            Origin::Declared => {
                let (u, words) = declared_u(span, range_unit, &cond.declared);
                out.push(length((id.0, id.1), (u, unit), s, words));
            }
            Origin::Missing => missing.push(format!(
                "{}: no sensor in the session and no range declared in the info file \
                 ([conditions] {})",
                id.1,
                key.replace("_k", "_c")
            )),
        }
    }
}

/// The material's terms (its temperature, the expansion coefficient): from the session's
/// sensor, a declared range, or named as missing.
fn material_contributions(
    c: &UncertaintyConfig,
    cond: &TestConditions,
    out: &mut Vec<Contribution>,
    missing: &mut Vec<String>,
) {
    let d = UncertaintyConfig::default();
    let d_theta = cond
        .material_temp_c
        .map_or(0.0, |t| (t - REFERENCE_TEMP_C).abs());
    let expansion = |source: String| {
        length(
            ("expansion", "expansion coefficient"),
            (c.expansion_u_ppm_per_k, "ppm/K"),
            (d_theta, "K"),
            source,
        )
    };
    match cond.material {
        Origin::Sensor => {
            out.push(length(
                ("material_temp", "material temperature sensor"),
                (c.material_temp_k, "K"),
                (c.expansion_ppm_per_k, "ppm/K"),
                format!(
                    "the session's sensor; its standard uncertainty: {}",
                    config_source("material_temp_k", c.material_temp_k, d.material_temp_k)
                ),
            ));
            out.push(expansion(format!(
                "the sensor's mean {:.2} °C; u(α): {}",
                cond.material_temp_c.unwrap_or(REFERENCE_TEMP_C),
                config_source(
                    "expansion_u_ppm_per_k",
                    c.expansion_u_ppm_per_k,
                    d.expansion_u_ppm_per_k
                )
            )));
        }
        Origin::Declared => {
            let (u, words) = declared_u(cond.declared.material_temp_c, "°C", &cond.declared);
            out.push(length(
                ("material_temp", "material temperature"),
                (u, "K"),
                (c.expansion_ppm_per_k, "ppm/K"),
                words,
            ));
            out.push(expansion(format!(
                "the declared range's midpoint; u(α): {}",
                config_source(
                    "expansion_u_ppm_per_k",
                    c.expansion_u_ppm_per_k,
                    d.expansion_u_ppm_per_k
                )
            )));
        }
        Origin::Missing => missing.push(
            "material temperature and expansion: no sensor in the session and no range \
             declared in the info file ([conditions] material_temp_c)"
                .to_string(),
        ),
    }
}

/// A reading term (µm).
fn reading(
    id: (&'static str, String),
    input: (f64, &'static str),
    sensitivity: (f64, &'static str),
    source: String,
) -> Contribution {
    term(Kind::Reading, id, input, sensitivity, source)
}

/// The reading terms (µm): the dead path over the air's span of the refractive index, the
/// drift (EVE), and each resolution of the reading chain.
fn reading_contributions(
    c: &UncertaintyConfig,
    cond: &TestConditions,
    missing: &mut Vec<String>,
) -> Vec<Contribution> {
    let d = UncertaintyConfig::default();
    let mut out = Vec::new();
    match cond.n_span {
        Some(n_span) if cond.air != Origin::Missing => out.push(reading(
            ("dead_path", "dead path".into()),
            (c.dead_path_mm, "mm"),
            (n_span / (2.0 * SQRT3) * 1e3, "µm/mm"),
            format!(
                "{}; the span of n over the test from the {}",
                config_source("dead_path_mm", c.dead_path_mm, d.dead_path_mm),
                if cond.air == Origin::Sensor {
                    "session's air sensors"
                } else {
                    "declared air ranges"
                }
            ),
        )),
        _ => missing.push(
            "dead path: the air's variation over the test is unknown (no sensor, no declared \
             range)"
                .to_string(),
        ),
    }
    match &cond.eve {
        Some(eve) => out.push(reading(
            ("eve", "environmental variation error (EVE)".into()),
            (eve.range_um, "µm"),
            (1.0 / (2.0 * SQRT3), ""),
            eve.source.clone(),
        )),
        None => missing.push(
            "environmental variation error (EVE): no drift check declared ([drift_check] \
             eve_um) and no stationary readings before the first run"
                .to_string(),
        ),
    }
    let fallback = [Resolution {
        name: "device".into(),
        step_um: c.resolution_um,
        source: format!(
            "no device description, no stated resolution and no step in the recorded \
             lengths: {}",
            config_source("resolution_um", c.resolution_um, d.resolution_um)
        ),
    }];
    let resolutions = if cond.resolution.is_empty() {
        &fallback[..]
    } else {
        &cond.resolution[..]
    };
    for r in resolutions {
        out.push(reading(
            ("resolution", format!("{} resolution", r.name)),
            (r.step_um, "µm"),
            (1.0 / (2.0 * SQRT3), ""),
            r.source.clone(),
        ));
    }
    out
}
