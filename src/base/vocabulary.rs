//! The diagnosis vocabulary of `cli-contract.md`, spelt once: the effect ids and their
//! parameter names. The diagnosis (`diagnose`), the simulator's model file and its
//! update from a diagnosis (`sim`), and the synthetic sessions of the tests all name
//! effects and parameters through these enums, so a misspelling is a compile error
//! (in code) or a refused name (in a file), never a silent 0.
//!
//! | id | parameters |
//! |---|---|
//! | `scale_thermal_expansion` | `alpha_ppm_per_k`, `x0_mm` |
//! | `scale_factor` | `ppm` |
//! | `abbe` | `offset_axis`, `theta0_urad`, `theta1_urad_per_mm` |
//! | `reversal` | `b_um`; `b1_um_per_m` when it varies along the axis (b at the travel's middle + b1 per metre) |
//! | `latch_delay` | `tau_us` |
//! | `periodic_scale` | `amplitude_um`, `period_um`, `phase_rad` |
//! | `thermal_drift` | `amplitude_um`, `tau_s` (exponential) or `rate_um_per_s` (linear) |
//! | `dead_path` | `dead_path_mm` |
//! | `refraction` | `ppm_per_k`, `ppm_per_hpa` |
//! | `unexplained` | `rms_um`: structure no vocabulary effect explains |
//!
//! The typed payload is [`Effect`](super::effect::Effect); a result's verdict is
//! [`Verdict`]. The circular test (ISO 230-4) has a vocabulary of its own, a family apart
//! (`circular::effects`: `CircularId`, `CircularEffect`, one file per effect); it names
//! its parameters with the [`ParamName`]s below (`b_um`, `h_um`, `tau_ms`, `p_um`,
//! `amplitude_um`, `period_mm`, `phase_rad`, `bow_um`, `dt_ms`, `ppm`, `urad`).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// An effect of the positioning vocabulary (a linear axis measured by a laser against its
/// scale), by the contract's id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EffectId {
    ScaleThermalExpansion,
    ScaleFactor,
    Abbe,
    Reversal,
    LatchDelay,
    PeriodicScale,
    ThermalDrift,
    DeadPath,
    Refraction,
    /// Structure in the residual that no vocabulary effect explains (the contract allows
    /// a diagnosis its own ids beyond the list).
    Unexplained,
}

impl EffectId {
    /// Every id, in the contract's order.
    pub const ALL: [EffectId; 10] = [
        EffectId::ScaleThermalExpansion,
        EffectId::ScaleFactor,
        EffectId::Abbe,
        EffectId::Reversal,
        EffectId::LatchDelay,
        EffectId::PeriodicScale,
        EffectId::ThermalDrift,
        EffectId::DeadPath,
        EffectId::Refraction,
        EffectId::Unexplained,
    ];

    /// The contract's id.
    pub fn as_str(self) -> &'static str {
        match self {
            EffectId::ScaleThermalExpansion => "scale_thermal_expansion",
            EffectId::ScaleFactor => "scale_factor",
            EffectId::Abbe => "abbe",
            EffectId::Reversal => "reversal",
            EffectId::LatchDelay => "latch_delay",
            EffectId::PeriodicScale => "periodic_scale",
            EffectId::ThermalDrift => "thermal_drift",
            EffectId::DeadPath => "dead_path",
            EffectId::Refraction => "refraction",
            EffectId::Unexplained => "unexplained",
        }
    }

    /// The effect's parameters, by the contract's names (every variant's: a fit reports
    /// those of the variant it chose).
    pub fn param_names(self) -> &'static [ParamName] {
        use ParamName as P;
        match self {
            EffectId::ScaleThermalExpansion => &[P::AlphaPpmPerK, P::X0Mm],
            EffectId::ScaleFactor => &[P::Ppm],
            EffectId::Abbe => &[P::OffsetAxis, P::Theta0Urad, P::Theta1UradPerMm],
            EffectId::Reversal => &[P::BUm, P::B1UmPerM],
            EffectId::LatchDelay => &[P::TauUs],
            EffectId::PeriodicScale => &[P::AmplitudeUm, P::PeriodUm, P::PhaseRad],
            EffectId::ThermalDrift => &[P::AmplitudeUm, P::TauS, P::RateUmPerS],
            EffectId::DeadPath => &[P::DeadPathMm],
            EffectId::Refraction => &[P::PpmPerK, P::PpmPerHpa],
            EffectId::Unexplained => &[P::RmsUm],
        }
    }
}

impl fmt::Display for EffectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// An effect id that is not in the vocabulary.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown effect `{0}` (one of: {list})", list = EffectId::ALL.map(EffectId::as_str).join(", "))]
pub struct UnknownEffect(pub String);

impl FromStr for EffectId {
    type Err = UnknownEffect;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|e| e.as_str() == s)
            .ok_or_else(|| UnknownEffect(s.to_string()))
    }
}

impl Serialize for EffectId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for EffectId {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// What a model's residual says: the model explains it (noise alone), or something is
/// missing. One verdict for every result that tests a residual (the positioning diagnosis,
/// volumetric identification, the circular test).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Verdict {
    /// The residual is explained by noise alone: no effect is reported.
    #[serde(rename = "consistent")]
    Consistent,
    /// The model left something out: at least one effect is reported (a vocabulary
    /// effect, or `unexplained`).
    #[serde(rename = "missing_physics")]
    MissingPhysics,
}

impl Verdict {
    /// The contract's spelling: `consistent` or `missing_physics` (also the JSON value and
    /// the [`Display`](fmt::Display) text).
    pub const fn as_str(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::MissingPhysics => "missing_physics",
        }
    }

    /// The circular test contract's spelling (`circular-test.md`): `consistent` or
    /// `errors_found` (the same verdict: the setup terms and noise do not explain the
    /// trace).
    pub const fn as_circular_str(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::MissingPhysics => "errors_found",
        }
    }

    /// `MissingPhysics` when anything was found, else `Consistent`.
    pub const fn from_found(found: bool) -> Self {
        if found {
            Verdict::MissingPhysics
        } else {
            Verdict::Consistent
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// A parameter of a vocabulary effect, by the contract's name (units in the name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ParamName {
    AlphaPpmPerK,
    X0Mm,
    Ppm,
    OffsetAxis,
    Theta0Urad,
    Theta1UradPerMm,
    BUm,
    /// Change of the reversal along the axis, µm per metre (position-dependent backlash).
    B1UmPerM,
    TauUs,
    AmplitudeUm,
    PeriodUm,
    PhaseRad,
    TauS,
    RateUmPerS,
    DeadPathMm,
    PpmPerK,
    PpmPerHpa,
    /// The RMS of structure no vocabulary effect explains (`unexplained`'s one number).
    RmsUm,
    /// Height of a reversal spike, µm (circular test).
    HUm,
    /// Decay time of a reversal spike, ms.
    TauMs,
    /// Lateral play, µm.
    PUm,
    /// Period of a cyclic error, mm.
    PeriodMm,
    /// Bow of a straightness error at the centre, µm.
    BowUm,
    /// Servo lag difference, ms.
    DtMs,
    /// Squareness, µrad.
    Urad,
    /// Amplitude of a rotary axis' periodic error, ″.
    AmplitudeArcsec,
    /// Phase of a rotary axis' periodic error, ° of the harmonic.
    PhaseDeg,
    /// Order of a rotary axis' periodic error: times per revolution.
    PerRev,
    /// Reversal of a rotary axis, ″.
    BArcsec,
    /// Drift rate of a rotary axis, ″ per second.
    RateArcsecPerS,
}

impl ParamName {
    /// Every parameter name.
    pub const ALL: [ParamName; 30] = [
        ParamName::AlphaPpmPerK,
        ParamName::X0Mm,
        ParamName::Ppm,
        ParamName::OffsetAxis,
        ParamName::Theta0Urad,
        ParamName::Theta1UradPerMm,
        ParamName::BUm,
        ParamName::B1UmPerM,
        ParamName::TauUs,
        ParamName::AmplitudeUm,
        ParamName::PeriodUm,
        ParamName::PhaseRad,
        ParamName::TauS,
        ParamName::RateUmPerS,
        ParamName::DeadPathMm,
        ParamName::PpmPerK,
        ParamName::PpmPerHpa,
        ParamName::RmsUm,
        ParamName::HUm,
        ParamName::TauMs,
        ParamName::PUm,
        ParamName::PeriodMm,
        ParamName::BowUm,
        ParamName::DtMs,
        ParamName::Urad,
        ParamName::AmplitudeArcsec,
        ParamName::PhaseDeg,
        ParamName::PerRev,
        ParamName::BArcsec,
        ParamName::RateArcsecPerS,
    ];

    /// The contract's name.
    pub fn as_str(self) -> &'static str {
        match self {
            ParamName::AlphaPpmPerK => "alpha_ppm_per_k",
            ParamName::X0Mm => "x0_mm",
            ParamName::Ppm => "ppm",
            ParamName::OffsetAxis => "offset_axis",
            ParamName::Theta0Urad => "theta0_urad",
            ParamName::Theta1UradPerMm => "theta1_urad_per_mm",
            ParamName::BUm => "b_um",
            ParamName::B1UmPerM => "b1_um_per_m",
            ParamName::TauUs => "tau_us",
            ParamName::AmplitudeUm => "amplitude_um",
            ParamName::PeriodUm => "period_um",
            ParamName::PhaseRad => "phase_rad",
            ParamName::TauS => "tau_s",
            ParamName::RateUmPerS => "rate_um_per_s",
            ParamName::DeadPathMm => "dead_path_mm",
            ParamName::PpmPerK => "ppm_per_k",
            ParamName::PpmPerHpa => "ppm_per_hpa",
            ParamName::RmsUm => "rms_um",
            ParamName::HUm => "h_um",
            ParamName::TauMs => "tau_ms",
            ParamName::PUm => "p_um",
            ParamName::PeriodMm => "period_mm",
            ParamName::BowUm => "bow_um",
            ParamName::DtMs => "dt_ms",
            ParamName::Urad => "urad",
            ParamName::AmplitudeArcsec => "amplitude_arcsec",
            ParamName::PhaseDeg => "phase_deg",
            ParamName::PerRev => "per_rev",
            ParamName::BArcsec => "b_arcsec",
            ParamName::RateArcsecPerS => "rate_arcsec_per_s",
        }
    }
}

impl fmt::Display for ParamName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_and_names_round_trip_and_are_distinct() {
        for e in EffectId::ALL {
            assert_eq!(e.as_str().parse::<EffectId>(), Ok(e));
            let json = serde_json::to_string(&e).expect("serialises");
            assert_eq!(json, format!("\"{}\"", e.as_str()));
            assert_eq!(serde_json::from_str::<EffectId>(&json).expect("parses"), e);
        }
        let mut names: Vec<&str> = ParamName::ALL.map(ParamName::as_str).to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), ParamName::ALL.len());
        assert!("scale_facter".parse::<EffectId>().is_err());
    }

    #[test]
    fn verdict_is_spelled_as_in_the_contract() {
        for (v, s) in [
            (Verdict::Consistent, "consistent"),
            (Verdict::MissingPhysics, "missing_physics"),
        ] {
            assert_eq!(
                serde_json::to_string(&v).expect("a unit variant serialises"),
                format!("\"{s}\"")
            );
            assert_eq!(
                serde_json::from_str::<Verdict>(&format!("\"{s}\""))
                    .expect("the contract's spelling parses"),
                v
            );
            assert_eq!(v.to_string(), s);
        }
        assert_eq!(Verdict::from_found(true), Verdict::MissingPhysics);
        assert_eq!(Verdict::from_found(false), Verdict::Consistent);
    }
}
