//! The circular test's vocabulary (ISO 230-4 ballbar): a family of its own beside the
//! positioning [`Effect`](crate::base::Effect), one file per effect.
//!
//! Each effect is one small type (its parameters, units in the names) with two traits:
//! [`Family`], what the effect is whatever its values — its contract id and parameter
//! names, the slots it may act on, its radial signature's linear columns, its scanned
//! parameter, how a fit's coefficients make it — and [`Term`], what one effect with its
//! values does — its parameters, its simulated axis errors, its plausible bounds, its words.
//! [`CircularId`] names the effects and [`CircularEffect`] holds one; the macro
//! `circular_vocabulary!` below is the registry, a line an effect, and there is no
//! catch-all arm over effects anywhere in `circular/`: a new effect is a compile error
//! where it must be handled.
//!
//! | file | id | acts on | parameters |
//! |---|---|---|---|
//! | [`backlash`] | `backlash` | A or B | `b_um` |
//! | [`reversal_spike`] | `reversal_spike` | A or B | `h_um`, `tau_ms` (scanned) |
//! | [`lateral_play`] | `lateral_play` | A or B (the reversing axis) | `p_um` |
//! | [`cyclic_error`] | `cyclic_error` | A or B | `amplitude_um`, `period_mm` (scanned), `phase_rad` |
//! | [`straightness`] | `straightness` | A or B (the moving axis) | `bow_um` |
//! | [`servo_mismatch`] | `servo_mismatch` | the plane | `dt_ms` |
//! | [`scale_mismatch`] | `scale_mismatch` | the plane | `ppm` |
//! | [`squareness`] | `squareness` | the plane | `urad` |
//!
//! On disk an effect keeps the contract's shape, `{"id": …, "params": {name: value}}`;
//! [`CircularEffect::from_params`] is the way back and refuses a missing, unknown or
//! mistyped parameter by name (the positioning family's [`Params`] checks).

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use nalgebra::DMatrix;
use serde::{Serialize, Serializer};

use super::input::Plane;
use super::signature::{Geometry, Point, Slot};
use crate::base::ParamName;
use crate::base::{EffectParamError, ParamValue, Params};

mod backlash;
mod cyclic_error;
mod lateral_play;
mod reversal_spike;
mod scale_mismatch;
mod servo_mismatch;
mod squareness;
mod straightness;

pub use backlash::Backlash;
pub use cyclic_error::CyclicError;
pub use lateral_play::LateralPlay;
pub use reversal_spike::ReversalSpike;
pub use scale_mismatch::ScaleMismatch;
pub use servo_mismatch::ServoMismatch;
pub use squareness::Squareness;
pub use straightness::Straightness;

/// The largest error term an effect may carry, µm: a ballbar reads about a millimetre
/// either side of its length, so a larger term is a typing error, not a machine.
pub const MAX_TERM_UM: f64 = 1000.0;

impl CircularId {
    /// The contract's id.
    pub fn as_str(self) -> &'static str {
        self.kind().name
    }

    /// The effect's parameters, by the contract's names, in its type's order.
    pub fn param_names(self) -> &'static [ParamName] {
        self.kind().params
    }

    /// The slots it may act on.
    pub fn slots(self) -> &'static [Slot] {
        self.kind().slots
    }
}

impl fmt::Display for CircularId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

impl Serialize for CircularId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// An id that is not in the circular vocabulary.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown circular effect `{0}` (one of: {list})", list = CircularId::ALL.map(CircularId::as_str).join(", "))]
pub struct UnknownCircularEffect(pub String);

impl FromStr for CircularId {
    type Err = UnknownCircularEffect;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|e| e.as_str() == s)
            .ok_or_else(|| UnknownCircularEffect(s.to_string()))
    }
}

/// The registry, one name an effect: its type, whose name is also its variant in
/// [`CircularId`] and [`CircularEffect`]. It writes the two enums, [`CircularId::ALL`],
/// [`CircularId::kind`], [`CircularEffect::id`], [`CircularEffect::term`] and
/// `From<T> for CircularEffect`, each `match` exhaustive.
macro_rules! circular_vocabulary {
    ($($t:ident),* $(,)?) => {
        /// An effect of the circular vocabulary, by the contract's id.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum CircularId {
            $($t,)*
        }

        impl CircularId {
            /// Every id, in the contract's order (also the diagnosis' order of candidates).
            pub const ALL: [CircularId; [$(CircularId::$t),*].len()] = [$(CircularId::$t),*];

            /// What the effect is, whatever its values.
            pub fn kind(self) -> Kind {
                match self {
                    $(CircularId::$t => Kind::of::<$t>(),)*
                }
            }
        }

        /// One effect of the circular vocabulary with its parameters.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum CircularEffect {
            $($t($t),)*
        }

        $(impl From<$t> for CircularEffect {
            fn from(e: $t) -> Self {
                CircularEffect::$t(e)
            }
        })*

        impl CircularEffect {
            /// The vocabulary id.
            pub fn id(&self) -> CircularId {
                match self {
                    $(CircularEffect::$t(_) => CircularId::$t,)*
                }
            }

            /// The effect behind its values' trait.
            pub fn term(&self) -> &dyn Term {
                match self {
                    $(CircularEffect::$t(e) => e,)*
                }
            }
        }
    };
}

circular_vocabulary!(
    Backlash,
    ReversalSpike,
    LateralPlay,
    CyclicError,
    Straightness,
    ServoMismatch,
    ScaleMismatch,
    Squareness,
);

impl CircularEffect {
    /// The parameters, in the type's order.
    pub fn params(&self) -> Vec<(ParamName, f64)> {
        self.term().params()
    }

    /// The parameter `name`, if this effect carries it.
    pub fn number(&self, name: ParamName) -> Option<f64> {
        self.params()
            .into_iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v)
    }

    /// The effect `id` from its parameters by name: every one of them, none other, all
    /// numbers; anything else is an error naming the parameter.
    pub fn from_params(
        id: CircularId,
        params: &BTreeMap<String, ParamValue>,
    ) -> Result<CircularEffect, EffectParamError> {
        let kind = id.kind();
        (kind.from_params)(&Params::new(kind.name, kind.params, params)?)
    }

    /// The first parameter outside its plausible bounds, with the problem.
    pub fn check(&self) -> Result<(), (ParamName, String)> {
        for (name, v) in self.params() {
            if !v.is_finite() {
                return Err((name, format!("{v} is not finite")));
            }
        }
        self.term().check()
    }
}

/// What an effect is, whatever its values (implemented by each effect's type).
pub trait Family: Term + Copy + Into<CircularEffect> + 'static {
    /// The contract's id.
    const NAME: &'static str;
    /// The parameters by the contract's names, in the type's order.
    const PARAMS: &'static [ParamName];
    /// The slots it may act on: each axis of the plane, or the plane.
    const SLOTS: &'static [Slot] = &[Slot::A, Slot::B];
    /// Its linear columns: 1, or 2 when a phase is fitted as a pair of coefficients.
    const WIDTH: usize = 1;
    /// With one direction only it cannot be told from another effect: it is then left
    /// out of the fit (and said in `unidentifiable`).
    const NEEDS_BOTH_DIRECTIONS: bool = false;

    /// The scanned (nonlinear) parameter's search on a test sampled so, if it has one.
    fn scan(_sampling: &Sampling) -> Option<Scan> {
        None
    }

    /// The linear columns of its radial signature at a point, for its nonlinear parameter
    /// `nl` (ignored when it has none): the coefficients of these columns are its linear
    /// parameters (see [`Term::linear`]).
    fn columns(slot: Slot, nl: f64, p: &Point, g: &Geometry) -> [f64; 2];

    /// From parameters by name.
    fn from_params(p: &Params<'_>) -> Result<Self, EffectParamError>;

    /// From a fit: its linear coefficients, its nonlinear parameter (0 when none), and the
    /// covariance block of the coefficients then the nonlinear parameter; the effect and
    /// every parameter's one-sigma, in the type's order.
    fn from_fit(coef: &[f64], nl: f64, cov: &DMatrix<f64>) -> (Self, Vec<(ParamName, f64)>);
}

/// What one effect with its values does (object-safe: [`CircularEffect::term`]).
pub trait Term: fmt::Debug {
    /// The parameters, in the type's order.
    fn params(&self) -> Vec<(ParamName, f64)>;

    /// Its nonlinear parameter (0 when none) and the coefficients of [`Family::columns`]:
    /// its radial signature is their dot product.
    fn linear(&self) -> (f64, [f64; 2]);

    /// Its axis errors and servo lags at one sample of the simulator, on `slot`.
    fn simulate(&self, slot: Slot, m: &Motion) -> Contribution;

    /// Its plausible bounds (finiteness is checked for every parameter before): the first
    /// parameter outside, with the problem.
    fn check(&self) -> Result<(), (ParamName, String)>;

    /// Where and what it is in words, for a found effect.
    fn words(&self, w: &Wording) -> String;
}

/// What an effect is, whatever its values: the constants and functions of its
/// [`Family`], looked up by [`CircularId::kind`].
#[derive(Clone, Copy)]
pub struct Kind {
    pub name: &'static str,
    pub params: &'static [ParamName],
    pub slots: &'static [Slot],
    pub width: usize,
    pub needs_both_directions: bool,
    pub scan: fn(&Sampling) -> Option<Scan>,
    pub columns: fn(Slot, f64, &Point, &Geometry) -> [f64; 2],
    from_params: fn(&Params<'_>) -> Result<CircularEffect, EffectParamError>,
    pub from_fit: FromFit,
}

/// [`Family::from_fit`] of an effect, its result as a [`CircularEffect`].
pub(crate) type FromFit = fn(&[f64], f64, &DMatrix<f64>) -> (CircularEffect, Vec<(ParamName, f64)>);

impl fmt::Debug for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Kind").field("name", &self.name).finish()
    }
}

impl Kind {
    fn of<T: Family>() -> Kind {
        Kind {
            name: T::NAME,
            params: T::PARAMS,
            slots: T::SLOTS,
            width: T::WIDTH,
            needs_both_directions: T::NEEDS_BOTH_DIRECTIONS,
            scan: T::scan,
            columns: T::columns,
            from_params: |p| T::from_params(p).map(Into::into),
            from_fit: |coef, nl, cov| {
                let (e, sd) = T::from_fit(coef, nl, cov);
                (e.into(), sd)
            },
        }
    }
}

/// The one-sigma of entry `i` of a covariance block.
pub(crate) fn sd(cov: &DMatrix<f64>, i: usize) -> f64 {
    cov[(i, i)].max(0.0).sqrt()
}

/// Refuses `|v| > max` for parameter `name`.
pub(crate) fn within(
    name: ParamName,
    v: f64,
    max: f64,
    unit: &str,
) -> Result<(), (ParamName, String)> {
    if v.abs() > max {
        return Err((
            name,
            format!("{v} is outside the plausible range ±{max} {unit}"),
        ));
    }
    Ok(())
}

/// Refuses `v` outside (0, max] for parameter `name`.
pub(crate) fn positive(
    name: ParamName,
    v: f64,
    max: f64,
    unit: &str,
) -> Result<(), (ParamName, String)> {
    if v <= 0.0 {
        return Err((name, format!("{v} must be > 0")));
    }
    if v > max {
        return Err((name, format!("{v} is above the plausible {max} {unit}")));
    }
    Ok(())
}

/// The sign of x (0 at 0).
pub(crate) fn sgn(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// How a test is sampled, for the search of a scanned parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sampling {
    /// The median angular step of the samples, rad.
    pub dtheta_rad: f64,
    /// ω = v/R, rad/s.
    pub omega_rad_per_s: f64,
    pub radius_mm: f64,
}

/// The search of a scanned parameter, in a coordinate u where it is scanned uniformly.
#[derive(Debug, Clone, Copy)]
pub struct Scan {
    /// The range of u.
    pub lo: f64,
    pub hi: f64,
    /// The scan's step in u.
    pub step: f64,
    /// The refinement searches ± this many steps about the best scanned u.
    pub reach: f64,
    /// Scan on the joint fit of every candidate (else on the residual of the linear ones).
    pub joint: bool,
    /// A scan on the residual may average this many consecutive samples (the shortest
    /// period searched still spans eight averaged samples); 1: every sample.
    pub stride: usize,
    /// The parameter before any scan.
    pub start: f64,
    /// u → the parameter, and back.
    pub to_nl: fn(f64) -> f64,
    pub from_nl: fn(f64) -> f64,
}

/// Where the simulator is at one sample of a run: what an effect's physics needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// The commanded angle, rad.
    pub theta: f64,
    /// +1 ccw, −1 cw.
    pub s: f64,
    /// The time since the run started, s, and its starting angle, rad.
    pub t: f64,
    pub start: f64,
    /// ω, rad/s, and the radius, mm.
    pub omega: f64,
    pub radius_mm: f64,
    /// The commanded positions of A and B from the centre, mm.
    pub q_mm: [f64; 2],
    /// The signs of the velocities of A and B.
    pub v_sign: [f64; 2],
}

impl Motion {
    /// The slot's own axis: its position (mm), its velocity's sign and where it reverses
    /// (θ = offset + kπ).
    pub fn axis(&self, slot: Slot) -> (f64, f64, f64) {
        match slot {
            Slot::A => (self.q_mm[0], self.v_sign[0], 0.0),
            Slot::B | Slot::Plane => (self.q_mm[1], self.v_sign[1], PI / 2.0),
        }
    }

    /// The time (s) the run last passed a reversal of the axis whose reversals lie at
    /// `offset` + kπ, `None` before the first one (the run started from rest).
    pub fn last_reversal(&self, offset: f64) -> Option<f64> {
        let (theta, s) = (self.theta, self.s);
        let travelled = (s * (theta - offset)).rem_euclid(PI);
        let at = theta - s * travelled;
        ((at - self.start) * s >= 0.0).then(|| (at - self.start) * s / self.omega)
    }
}

/// What an effect adds at one sample: axis errors (µm) and servo lags (ms) of A and B.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Contribution {
    pub a_um: f64,
    pub b_um: f64,
    pub lag_a_ms: f64,
    pub lag_b_ms: f64,
}

impl Contribution {
    /// An error `own_um` of the slot's axis and `other_um` of the other one.
    pub fn axes(slot: Slot, own_um: f64, other_um: f64) -> Contribution {
        let (a_um, b_um) = match slot {
            Slot::A => (own_um, other_um),
            Slot::B | Slot::Plane => (other_um, own_um),
        };
        Contribution {
            a_um,
            b_um,
            ..Contribution::default()
        }
    }
}

/// What the words of a found effect need.
#[derive(Debug, Clone, PartialEq)]
pub struct Wording {
    pub plane: Plane,
    /// The label of its slot and of the other axis.
    pub name: String,
    pub other: String,
    /// Its axis' reversal angles inside the nominal arc, as a list in degrees.
    pub reversals: String,
    /// Whether the test ran in both directions.
    pub both: bool,
}

impl Wording {
    /// The plane's axis at 0° (A) and at 90° (B), by their letters.
    pub fn a(&self) -> String {
        Slot::A.label(self.plane)
    }

    pub fn b(&self) -> String {
        Slot::B.label(self.plane)
    }

    /// (first, second): A and B when `v` ≥ 0, else B and A.
    pub fn ordered(&self, v: f64) -> (String, String) {
        if v >= 0.0 {
            (self.a(), self.b())
        } else {
            (self.b(), self.a())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_every_parameter_is_a_declared_name() {
        for id in CircularId::ALL {
            assert_eq!(id.as_str().parse::<CircularId>(), Ok(id));
            let names = id.param_names();
            let map: BTreeMap<String, ParamValue> = names
                .iter()
                .map(|n| (n.as_str().to_string(), ParamValue::Number(1.5)))
                .collect();
            let e = CircularEffect::from_params(id, &map).expect("every parameter given");
            assert_eq!(e.id(), id);
            let got: Vec<ParamName> = e.params().into_iter().map(|(n, _)| n).collect();
            assert_eq!(got, names, "{id}");
            assert!(e.params().iter().all(|(_, v)| *v == 1.5), "{id}");
        }
        assert!("scale_factor".parse::<CircularId>().is_err());
    }

    #[test]
    fn a_missing_unknown_or_mistyped_parameter_is_named() {
        let parse = |id: CircularId, pairs: &[(&str, ParamValue)]| {
            let map = pairs
                .iter()
                .map(|(k, v)| (k.to_string(), *v))
                .collect::<BTreeMap<_, _>>();
            CircularEffect::from_params(id, &map).map_err(|e| e.to_string())
        };
        let e = parse(
            CircularId::ReversalSpike,
            &[("h_um", ParamValue::Number(1.0))],
        )
        .expect_err("tau missing");
        assert!(e.contains("tau_ms") && e.contains("missing"), "{e}");
        let e = parse(CircularId::Backlash, &[("b_mu", ParamValue::Number(1.0))])
            .expect_err("misspelt");
        assert!(e.contains("`b_mu`") && e.contains("(b_um)"), "{e}");
        let e = parse(
            CircularId::Squareness,
            &[("urad", ParamValue::Axis(crate::base::Axis::Y))],
        )
        .expect_err("an axis");
        assert!(e.contains("urad") && e.contains("number"), "{e}");
    }
}
