//! The vocabulary's payload: one [`Effect`] per effect id, its parameters typed and named
//! with their units. A positioning diagnosis, the concealed cases' truth, the simulator's
//! model update and the volumetric campaign's own faults all speak through this one type,
//! so a parameter cannot be missing, misspelt or silently 0. The circular test's effects
//! are a family apart (`circular::effects`), read through the same [`Params`] checks.
//!
//! On disk an effect keeps the contract's shape, `{"id": …, "params": {name: value}}`,
//! the parameters in the order of their names; [`Effect::from_params`] is the way back and
//! refuses a missing, unknown or mistyped parameter by name.

use std::collections::BTreeMap;
use std::fmt;

use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::axis::Axis;
use super::vocabulary::{EffectId, ParamName, ParamName as P};

/// A thermal drift of the readings in time, in one of its two shapes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drift {
    /// `A·(1 − exp(−t/τ))`.
    Exponential { amplitude_um: f64, tau_s: f64 },
    /// `r·t`.
    Linear { rate_um_per_s: f64 },
}

/// One effect of the positioning vocabulary with its parameters (units in the names): a
/// linear axis measured by a laser against its scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Effect {
    /// The scale expands with its temperature about its fixed point `x0_mm`.
    ScaleThermalExpansion { alpha_ppm_per_k: f64, x0_mm: f64 },
    /// The scale reads long or short by `ppm`.
    ScaleFactor { ppm: f64 },
    /// An angular error of the carriage acting over the offset along `offset_axis`:
    /// θ(x) = θ0 + θ1·x.
    Abbe {
        offset_axis: Axis,
        theta0_urad: f64,
        theta1_urad_per_mm: f64,
    },
    /// The reversal (backlash) `b_um`; `b1_um_per_m` when it changes along the axis.
    Reversal { b_um: f64, b1_um_per_m: Option<f64> },
    /// The scale is latched `tau_us` late against the laser.
    LatchDelay { tau_us: f64 },
    /// A periodic error of the scale.
    PeriodicScale {
        amplitude_um: f64,
        period_um: f64,
        phase_rad: f64,
    },
    /// The readings drift in time.
    ThermalDrift(Drift),
    /// Laser dead path not compensated.
    DeadPath { dead_path_mm: f64 },
    /// Air refraction compensation off by `ppm_per_k` of the air temperature's change and
    /// `ppm_per_hpa` of the pressure's; a fit may determine one of the two only.
    Refraction {
        ppm_per_k: Option<f64>,
        ppm_per_hpa: Option<f64>,
    },
    /// Structure in the residual that no vocabulary effect explains, by its RMS.
    Unexplained { rms_um: f64 },
}

/// A parameter's value: a number, or the axis an Abbe offset lies along.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamValue {
    Number(f64),
    Axis(Axis),
}

impl ParamValue {
    /// The number, if this is one.
    pub fn as_f64(self) -> Option<f64> {
        match self {
            ParamValue::Number(v) => Some(v),
            ParamValue::Axis(_) => None,
        }
    }
}

impl Serialize for ParamValue {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ParamValue::Number(v) => s.serialize_f64(*v),
            ParamValue::Axis(a) => a.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for ParamValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Text(String),
        }
        match Raw::deserialize(d)? {
            Raw::Number(v) => Ok(ParamValue::Number(v)),
            Raw::Text(t) => t
                .parse::<Axis>()
                .map(ParamValue::Axis)
                .map_err(serde::de::Error::custom),
        }
    }
}

impl fmt::Display for ParamValue {
    /// As in the JSON: a number in serde_json's shortest form, an axis as `"y"`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Number(v) if v.is_finite() => {
                f.write_str(&serde_json::to_string(v).map_err(|_| fmt::Error)?)
            }
            ParamValue::Number(v) => write!(f, "{v}"),
            ParamValue::Axis(a) => write!(f, "\"{}\"", a.lower()),
        }
    }
}

/// Why parameters do not make an effect: the one that is missing, unknown or of the wrong
/// kind, by name (`id` is the contract's id, of either family).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EffectParamError {
    #[error("effect `{id}`: parameter `{param}` is missing")]
    Missing { id: &'static str, param: ParamName },
    #[error("effect `{id}`: `{param}` is not one of its parameters ({list})")]
    Unknown {
        id: &'static str,
        param: String,
        list: String,
    },
    #[error("effect `{id}`: `{param}` must be {want}")]
    Kind {
        id: &'static str,
        param: ParamName,
        want: &'static str,
    },
}
/// An effect's parameters as read from a document, with the checks every field needs:
/// known names, numbers where numbers go, an axis where an axis goes.
#[derive(Debug, Clone, Copy)]
pub struct Params<'a> {
    id: &'static str,
    names: &'static [ParamName],
    params: &'a BTreeMap<String, ParamValue>,
}

impl<'a> Params<'a> {
    /// The parameters `params` of the effect `id`, whose parameters are `names`; a name
    /// that is not one of them is refused, listing them.
    pub fn new(
        id: &'static str,
        names: &'static [ParamName],
        params: &'a BTreeMap<String, ParamValue>,
    ) -> Result<Self, EffectParamError> {
        let p = Params { id, names, params };
        p.check_known()?;
        Ok(p)
    }

    /// How many parameters were given.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Whether none was given.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Refuses a parameter the effect does not have, listing those it has.
    fn check_known(&self) -> Result<(), EffectParamError> {
        let id = self.id;
        let known = |n: &str| self.names.iter().any(|p| p.as_str() == n);
        if let Some(bad) = self.params.keys().find(|k| !known(k)) {
            return Err(EffectParamError::Unknown {
                id,
                param: bad.clone(),
                list: self
                    .names
                    .iter()
                    .map(|p| p.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        Ok(())
    }

    /// An optional number.
    pub fn opt(&self, name: ParamName) -> Result<Option<f64>, EffectParamError> {
        match self.params.get(name.as_str()) {
            None => Ok(None),
            Some(ParamValue::Number(v)) => Ok(Some(*v)),
            Some(ParamValue::Axis(_)) => Err(EffectParamError::Kind {
                id: self.id,
                param: name,
                want: "a number",
            }),
        }
    }

    /// A required number.
    pub fn num(&self, name: ParamName) -> Result<f64, EffectParamError> {
        self.opt(name)?.ok_or(EffectParamError::Missing {
            id: self.id,
            param: name,
        })
    }

    /// A required axis.
    pub fn axis(&self, name: ParamName) -> Result<Axis, EffectParamError> {
        match self.params.get(name.as_str()) {
            Some(ParamValue::Axis(a)) => Ok(*a),
            Some(ParamValue::Number(_)) => Err(EffectParamError::Kind {
                id: self.id,
                param: name,
                want: "an axis (\"y\" or \"z\")",
            }),
            None => Err(EffectParamError::Missing {
                id: self.id,
                param: name,
            }),
        }
    }

    /// A thermal drift: linear (rate_um_per_s alone) or exponential (amplitude_um and
    /// tau_s), never both.
    fn drift(&self) -> Result<Drift, EffectParamError> {
        Ok(match self.opt(P::RateUmPerS)? {
            Some(rate_um_per_s) if self.len() == 1 => Drift::Linear { rate_um_per_s },
            Some(_) => {
                return Err(EffectParamError::Unknown {
                    id: self.id,
                    param: P::RateUmPerS.as_str().into(),
                    list:
                        "amplitude_um and tau_s (exponential) or rate_um_per_s (linear), not both"
                            .into(),
                });
            }
            None => Drift::Exponential {
                amplitude_um: self.num(P::AmplitudeUm)?,
                tau_s: self.num(P::TauS)?,
            },
        })
    }

    /// A refraction with at least one of its two coefficients.
    fn refraction(&self) -> Result<Effect, EffectParamError> {
        let (k, h) = (self.opt(P::PpmPerK)?, self.opt(P::PpmPerHpa)?);
        if k.is_none() && h.is_none() {
            return Err(EffectParamError::Missing {
                id: self.id,
                param: P::PpmPerK,
            });
        }
        Ok(Effect::Refraction {
            ppm_per_k: k,
            ppm_per_hpa: h,
        })
    }
}

impl Effect {
    /// The vocabulary id.
    pub fn id(&self) -> EffectId {
        match self {
            Effect::ScaleThermalExpansion { .. } => EffectId::ScaleThermalExpansion,
            Effect::ScaleFactor { .. } => EffectId::ScaleFactor,
            Effect::Abbe { .. } => EffectId::Abbe,
            Effect::Reversal { .. } => EffectId::Reversal,
            Effect::LatchDelay { .. } => EffectId::LatchDelay,
            Effect::PeriodicScale { .. } => EffectId::PeriodicScale,
            Effect::ThermalDrift(_) => EffectId::ThermalDrift,
            Effect::DeadPath { .. } => EffectId::DeadPath,
            Effect::Refraction { .. } => EffectId::Refraction,
            Effect::Unexplained { .. } => EffectId::Unexplained,
        }
    }

    /// The parameters this effect carries, in the variant's order.
    pub fn params(&self) -> Vec<(ParamName, ParamValue)> {
        use ParamValue::Number as N;
        let mut out = match *self {
            Effect::ScaleThermalExpansion {
                alpha_ppm_per_k,
                x0_mm,
            } => vec![(P::AlphaPpmPerK, N(alpha_ppm_per_k)), (P::X0Mm, N(x0_mm))],
            Effect::ScaleFactor { ppm } => vec![(P::Ppm, N(ppm))],
            Effect::Abbe {
                offset_axis,
                theta0_urad,
                theta1_urad_per_mm,
            } => vec![
                (P::OffsetAxis, ParamValue::Axis(offset_axis)),
                (P::Theta0Urad, N(theta0_urad)),
                (P::Theta1UradPerMm, N(theta1_urad_per_mm)),
            ],
            Effect::Reversal { b_um, b1_um_per_m } => {
                let mut v = vec![(P::BUm, N(b_um))];
                v.extend(b1_um_per_m.map(|b1| (P::B1UmPerM, N(b1))));
                v
            }
            Effect::LatchDelay { tau_us } => vec![(P::TauUs, N(tau_us))],
            Effect::PeriodicScale {
                amplitude_um,
                period_um,
                phase_rad,
            } => vec![
                (P::AmplitudeUm, N(amplitude_um)),
                (P::PeriodUm, N(period_um)),
                (P::PhaseRad, N(phase_rad)),
            ],
            Effect::ThermalDrift(Drift::Exponential {
                amplitude_um,
                tau_s,
            }) => vec![(P::AmplitudeUm, N(amplitude_um)), (P::TauS, N(tau_s))],
            Effect::ThermalDrift(Drift::Linear { rate_um_per_s }) => {
                vec![(P::RateUmPerS, N(rate_um_per_s))]
            }
            Effect::DeadPath { dead_path_mm } => vec![(P::DeadPathMm, N(dead_path_mm))],
            Effect::Refraction {
                ppm_per_k,
                ppm_per_hpa,
            } => ppm_per_k
                .map(|v| (P::PpmPerK, N(v)))
                .into_iter()
                .chain(ppm_per_hpa.map(|v| (P::PpmPerHpa, N(v))))
                .collect(),
            Effect::Unexplained { rms_um } => vec![(P::RmsUm, N(rms_um))],
        };
        out.shrink_to_fit();
        out
    }

    /// The numeric parameter `name`, if this effect carries it.
    pub fn number(&self, name: ParamName) -> Option<f64> {
        self.params()
            .into_iter()
            .find(|(n, _)| *n == name)
            .and_then(|(_, v)| v.as_f64())
    }

    /// The parameters sorted by name, as they are written (the contract's `params`).
    pub fn params_by_name(&self) -> Vec<(ParamName, ParamValue)> {
        let mut p = self.params();
        p.sort_by_key(|(n, _)| n.as_str());
        p
    }

    /// The effect `id` from its parameters by name. Every parameter of the variant the
    /// names select must be there, none other, numbers as numbers and `offset_axis` as an
    /// axis: anything else is an error naming the parameter.
    pub fn from_params(
        id: EffectId,
        params: &BTreeMap<String, ParamValue>,
    ) -> Result<Effect, EffectParamError> {
        let p = Params::new(id.as_str(), id.param_names(), params)?;
        let opt = |name: ParamName| p.opt(name);
        let num = |name: ParamName| p.num(name);
        Ok(match id {
            EffectId::ScaleThermalExpansion => Effect::ScaleThermalExpansion {
                alpha_ppm_per_k: num(P::AlphaPpmPerK)?,
                x0_mm: num(P::X0Mm)?,
            },
            EffectId::ScaleFactor => Effect::ScaleFactor { ppm: num(P::Ppm)? },
            EffectId::Abbe => Effect::Abbe {
                offset_axis: p.axis(P::OffsetAxis)?,
                theta0_urad: num(P::Theta0Urad)?,
                theta1_urad_per_mm: num(P::Theta1UradPerMm)?,
            },
            EffectId::Reversal => Effect::Reversal {
                b_um: num(P::BUm)?,
                b1_um_per_m: opt(P::B1UmPerM)?,
            },
            EffectId::LatchDelay => Effect::LatchDelay {
                tau_us: num(P::TauUs)?,
            },
            EffectId::PeriodicScale => Effect::PeriodicScale {
                amplitude_um: num(P::AmplitudeUm)?,
                period_um: num(P::PeriodUm)?,
                phase_rad: num(P::PhaseRad)?,
            },
            EffectId::ThermalDrift => Effect::ThermalDrift(p.drift()?),
            EffectId::DeadPath => Effect::DeadPath {
                dead_path_mm: num(P::DeadPathMm)?,
            },
            EffectId::Refraction => p.refraction()?,
            EffectId::Unexplained => Effect::Unexplained {
                rms_um: num(P::RmsUm)?,
            },
        })
    }

    /// The effect from numeric parameters given as pairs (a fit's output).
    pub fn from_numbers(
        id: EffectId,
        numbers: &[(ParamName, f64)],
        offset_axis: Option<Axis>,
    ) -> Result<Effect, EffectParamError> {
        let mut map: BTreeMap<String, ParamValue> = numbers
            .iter()
            .map(|(n, v)| (n.as_str().to_string(), ParamValue::Number(*v)))
            .collect();
        if let Some(a) = offset_axis {
            map.insert(P::OffsetAxis.as_str().into(), ParamValue::Axis(a));
        }
        Effect::from_params(id, &map)
    }

    /// The first parameter that is not a finite number, by name.
    pub fn non_finite(&self) -> Option<(ParamName, f64)> {
        self.params()
            .into_iter()
            .filter_map(|(n, v)| v.as_f64().map(|x| (n, x)))
            .find(|(_, x)| !x.is_finite())
    }
}

/// The contract's `params` object of an effect: its parameters by name.
#[derive(Debug, Clone, Copy)]
pub struct ParamsMap<'a>(pub &'a Effect);

impl Serialize for ParamsMap<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let p = self.0.params_by_name();
        let mut m = s.serialize_map(Some(p.len()))?;
        for (n, v) in &p {
            m.serialize_entry(n.as_str(), v)?;
        }
        m.end()
    }
}

impl Serialize for Effect {
    /// `{"id": …, "params": {…}}`.
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("id", &self.id())?;
        m.serialize_entry("params", &ParamsMap(self))?;
        m.end()
    }
}

impl<'de> Deserialize<'de> for Effect {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Raw {
            id: EffectId,
            params: BTreeMap<String, ParamValue>,
        }
        let r = Raw::deserialize(d)?;
        Effect::from_params(r.id, &r.params).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_shape() -> Vec<Effect> {
        vec![
            Effect::ScaleThermalExpansion {
                alpha_ppm_per_k: 11.5,
                x0_mm: 0.0,
            },
            Effect::ScaleFactor { ppm: 3.0 },
            Effect::Abbe {
                offset_axis: Axis::Z,
                theta0_urad: 3.0,
                theta1_urad_per_mm: 0.004,
            },
            Effect::Reversal {
                b_um: 1.0,
                b1_um_per_m: None,
            },
            Effect::Reversal {
                b_um: 1.0,
                b1_um_per_m: Some(-0.5),
            },
            Effect::LatchDelay { tau_us: 6.0 },
            Effect::PeriodicScale {
                amplitude_um: 0.2,
                period_um: 20.0,
                phase_rad: 0.7,
            },
            Effect::ThermalDrift(Drift::Exponential {
                amplitude_um: 1.5,
                tau_s: 400.0,
            }),
            Effect::ThermalDrift(Drift::Linear {
                rate_um_per_s: 1e-3,
            }),
            Effect::DeadPath {
                dead_path_mm: 500.0,
            },
            Effect::Refraction {
                ppm_per_k: Some(0.93),
                ppm_per_hpa: Some(-0.27),
            },
            Effect::Refraction {
                ppm_per_k: None,
                ppm_per_hpa: Some(-0.27),
            },
            Effect::Unexplained { rms_um: 0.4 },
        ]
    }

    #[test]
    fn every_shape_round_trips_through_the_contract_json() {
        for e in every_shape() {
            let json = serde_json::to_string(&e).expect("serialises");
            let back: Effect = serde_json::from_str(&json).expect(&json);
            assert_eq!(back, e, "{json}");
        }
    }

    #[test]
    fn the_json_is_the_contract_shape_with_names_in_order() {
        let abbe = Effect::Abbe {
            offset_axis: Axis::Z,
            theta0_urad: 3.0,
            theta1_urad_per_mm: 0.004,
        };
        assert_eq!(
            serde_json::to_string(&abbe).expect("serialises"),
            r#"{"id":"abbe","params":{"offset_axis":"z","theta0_urad":3.0,"theta1_urad_per_mm":0.004}}"#
        );
        let drift = Effect::ThermalDrift(Drift::Exponential {
            amplitude_um: 1.5,
            tau_s: 400.0,
        });
        assert_eq!(
            serde_json::to_string(&drift).expect("serialises"),
            r#"{"id":"thermal_drift","params":{"amplitude_um":1.5,"tau_s":400.0}}"#
        );
    }

    #[test]
    fn a_missing_unknown_or_mistyped_parameter_is_named_never_zero() {
        let parse = |s: &str| serde_json::from_str::<Effect>(s).map_err(|e| e.to_string());
        let e = parse(r#"{"id":"abbe","params":{"theta0_urad":3.0,"theta1_urad_per_mm":0.0}}"#)
            .expect_err("offset axis missing");
        assert!(e.contains("offset_axis") && e.contains("missing"), "{e}");
        let e = parse(r#"{"id":"scale_factor","params":{"pmm":3.0}}"#).expect_err("misspelt");
        assert!(e.contains("`pmm`"), "{e}");
        let e = parse(r#"{"id":"latch_delay","params":{"tau_us":"z"}}"#).expect_err("an axis");
        assert!(e.contains("tau_us") && e.contains("number"), "{e}");
        let e =
            parse(r#"{"id":"thermal_drift","params":{"amplitude_um":1.0,"rate_um_per_s":1.0}}"#)
                .expect_err("two shapes at once");
        assert!(e.contains("not both"), "{e}");
        let e = parse(r#"{"id":"refraction","params":{}}"#).expect_err("nothing fitted");
        assert!(e.contains("missing"), "{e}");
    }

    #[test]
    fn every_parameter_an_effect_carries_is_one_its_id_declares() {
        for e in every_shape() {
            for (n, _) in e.params() {
                assert!(e.id().param_names().contains(&n), "{} carries {n}", e.id());
            }
        }
    }

    #[test]
    fn display_of_a_value_is_its_json() {
        assert_eq!(ParamValue::Number(2.0).to_string(), "2.0");
        assert_eq!(ParamValue::Number(1e-7).to_string(), "1e-7");
        assert_eq!(ParamValue::Axis(Axis::Y).to_string(), "\"y\"");
    }
}
