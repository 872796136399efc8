//! The rotary axis' effects: a family of its own, typed apart from the positioning and the
//! circular-test vocabularies (`docs/rotary.md` §3). θ the target angle in °, d the
//! direction (±1), t the time since the session's first sample in s; r in ″ adds to
//! e = indicated − reference.
//!
//! | id | cause | r | params |
//! |---|---|---|---|
//! | `eccentricity` | encoder or ring off the axis, run-out | a·sin(θ + φ) | `amplitude_arcsec`, `phase_deg` |
//! | `twice_per_rev` | ring ellipticity, encoder distortion | a·sin(2θ + φ) | `amplitude_arcsec`, `phase_deg` |
//! | `gear_periodic` | worm, gear or pinion, N per revolution (N ≥ 3) | a·sin(Nθ + φ) | `amplitude_arcsec`, `per_rev`, `phase_deg` |
//! | `reversal` | backlash, lost motion | d·b/2 | `b_arcsec` |
//! | `scale_factor` | ratio error (gear, line count, reference) | k·θ·3.6·10⁻³ | `ppm` |
//! | `thermal_drift` | warm-up; follows time | ρ·t or A·(1 − e^(−t/τ)) | `rate_arcsec_per_s` or `amplitude_arcsec`, `tau_s` |

use serde::{Serialize, Serializer};

use crate::base::ParamName;

/// A rotary effect's id, as the contract spells it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RotaryId {
    Eccentricity,
    TwicePerRev,
    GearPeriodic,
    Reversal,
    ScaleFactor,
    ThermalDrift,
}

impl RotaryId {
    pub const ALL: [RotaryId; 6] = [
        RotaryId::Eccentricity,
        RotaryId::TwicePerRev,
        RotaryId::GearPeriodic,
        RotaryId::Reversal,
        RotaryId::ScaleFactor,
        RotaryId::ThermalDrift,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            RotaryId::Eccentricity => "eccentricity",
            RotaryId::TwicePerRev => "twice_per_rev",
            RotaryId::GearPeriodic => "gear_periodic",
            RotaryId::Reversal => "reversal",
            RotaryId::ScaleFactor => "scale_factor",
            RotaryId::ThermalDrift => "thermal_drift",
        }
    }
}

impl Serialize for RotaryId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// The two forms of a rotary axis' drift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RotaryDrift {
    /// r = ρ·t.
    Linear { rate_arcsec_per_s: f64 },
    /// r = A·(1 − e^(−t/τ)).
    Exponential { amplitude_arcsec: f64, tau_s: f64 },
}

/// One rotary effect with its typed parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RotaryEffect {
    Eccentricity {
        amplitude_arcsec: f64,
        phase_deg: f64,
    },
    TwicePerRev {
        amplitude_arcsec: f64,
        phase_deg: f64,
    },
    GearPeriodic {
        amplitude_arcsec: f64,
        per_rev: u32,
        phase_deg: f64,
    },
    Reversal {
        b_arcsec: f64,
    },
    ScaleFactor {
        ppm: f64,
    },
    ThermalDrift(RotaryDrift),
}

/// ″ per degree per ppm: k·θ·3.6·10⁻³.
pub const ARCSEC_PER_DEG_PPM: f64 = 3.6e-3;

impl RotaryEffect {
    pub fn id(&self) -> RotaryId {
        match self {
            RotaryEffect::Eccentricity { .. } => RotaryId::Eccentricity,
            RotaryEffect::TwicePerRev { .. } => RotaryId::TwicePerRev,
            RotaryEffect::GearPeriodic { .. } => RotaryId::GearPeriodic,
            RotaryEffect::Reversal { .. } => RotaryId::Reversal,
            RotaryEffect::ScaleFactor { .. } => RotaryId::ScaleFactor,
            RotaryEffect::ThermalDrift(_) => RotaryId::ThermalDrift,
        }
    }

    /// A periodic effect of order `n` (1, 2 or ≥ 3) with amplitude and phase.
    pub fn harmonic(n: u32, amplitude_arcsec: f64, phase_deg: f64) -> Self {
        match n {
            1 => RotaryEffect::Eccentricity {
                amplitude_arcsec,
                phase_deg,
            },
            2 => RotaryEffect::TwicePerRev {
                amplitude_arcsec,
                phase_deg,
            },
            per_rev => RotaryEffect::GearPeriodic {
                amplitude_arcsec,
                per_rev,
                phase_deg,
            },
        }
    }

    /// (order, amplitude, phase) of a periodic effect.
    pub fn as_harmonic(&self) -> Option<(u32, f64, f64)> {
        match *self {
            RotaryEffect::Eccentricity {
                amplitude_arcsec,
                phase_deg,
            } => Some((1, amplitude_arcsec, phase_deg)),
            RotaryEffect::TwicePerRev {
                amplitude_arcsec,
                phase_deg,
            } => Some((2, amplitude_arcsec, phase_deg)),
            RotaryEffect::GearPeriodic {
                amplitude_arcsec,
                per_rev,
                phase_deg,
            } => Some((per_rev, amplitude_arcsec, phase_deg)),
            _ => None,
        }
    }

    /// r in ″ at angle θ (°), direction d, time t (s since the first sample).
    pub fn r_arcsec(&self, theta_deg: f64, d: i8, t_s: f64) -> f64 {
        if let Some((n, a, phi)) = self.as_harmonic() {
            return a * (f64::from(n) * theta_deg + phi).to_radians().sin();
        }
        match *self {
            RotaryEffect::Reversal { b_arcsec } => f64::from(d) * b_arcsec / 2.0,
            RotaryEffect::ScaleFactor { ppm } => ppm * theta_deg * ARCSEC_PER_DEG_PPM,
            RotaryEffect::ThermalDrift(RotaryDrift::Linear { rate_arcsec_per_s }) => {
                rate_arcsec_per_s * t_s
            }
            RotaryEffect::ThermalDrift(RotaryDrift::Exponential {
                amplitude_arcsec,
                tau_s,
            }) => amplitude_arcsec * (1.0 - (-t_s / tau_s).exp()),
            _ => 0.0,
        }
    }

    /// The parameters by name, in the contract's order.
    pub fn params(&self) -> Vec<(ParamName, f64)> {
        use ParamName as P;
        match *self {
            RotaryEffect::Eccentricity {
                amplitude_arcsec,
                phase_deg,
            }
            | RotaryEffect::TwicePerRev {
                amplitude_arcsec,
                phase_deg,
            } => vec![
                (P::AmplitudeArcsec, amplitude_arcsec),
                (P::PhaseDeg, phase_deg),
            ],
            RotaryEffect::GearPeriodic {
                amplitude_arcsec,
                per_rev,
                phase_deg,
            } => vec![
                (P::AmplitudeArcsec, amplitude_arcsec),
                (P::PerRev, f64::from(per_rev)),
                (P::PhaseDeg, phase_deg),
            ],
            RotaryEffect::Reversal { b_arcsec } => vec![(P::BArcsec, b_arcsec)],
            RotaryEffect::ScaleFactor { ppm } => vec![(P::Ppm, ppm)],
            RotaryEffect::ThermalDrift(RotaryDrift::Linear { rate_arcsec_per_s }) => {
                vec![(P::RateArcsecPerS, rate_arcsec_per_s)]
            }
            RotaryEffect::ThermalDrift(RotaryDrift::Exponential {
                amplitude_arcsec,
                tau_s,
            }) => vec![(P::AmplitudeArcsec, amplitude_arcsec), (P::TauS, tau_s)],
        }
    }

    /// Where the effect shows, in words.
    pub fn words(&self, closure_mismatch: bool) -> String {
        match *self {
            RotaryEffect::Eccentricity { .. } => "once per revolution: the encoder or its ring \
                 mounted off the axis of rotation, or run-out"
                .into(),
            RotaryEffect::TwicePerRev { .. } => "twice per revolution: an elliptic ring or a \
                 distorted encoder"
                .into(),
            RotaryEffect::GearPeriodic { per_rev, .. } => format!(
                "{per_rev} times per revolution: a worm, gear or pinion turning {per_rev} times \
                 per revolution of the axis"
            ),
            RotaryEffect::Reversal { .. } => {
                "between the two directions at every angle: backlash or lost motion".into()
            }
            RotaryEffect::ScaleFactor { ppm } => {
                let mut w = format!(
                    "grows with the angle, {:.2}″ over the revolution: a ratio error (gear \
                     ratio, encoder line count, or the reference's)",
                    ppm * 360.0 * ARCSEC_PER_DEG_PPM
                );
                if closure_mismatch {
                    w.push_str("; correct the axis' ratio, a modulo table cannot");
                }
                w
            }
            RotaryEffect::ThermalDrift(_) => {
                "follows time, not angle: the axis or the reference warming up during the test"
                    .into()
            }
        }
    }
}
