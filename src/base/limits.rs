//! The physical ranges every reader checks its numbers against (issue 17: "physical bounds
//! at the door"). A value outside its range is refused like a NaN, with the file and the
//! row and column (tables) or the key (TOML files): it is a typing or unit mistake, or
//! corrupt data, and would otherwise overflow to inf or NaN inside a fit and reach an
//! output.
//!
//! | quantity | range | why this wide |
//! |---|---|---|
//! | position, length (`_mm`) | ±10⁶ mm | a kilometre: beyond every machine tool and CMM |
//! | error, deviation (`_um`) | ±10⁶ µm | a metre of error is no longer a measurement |
//! | temperature of air, scale or part (`_c`) | −50 … 100 °C | a workshop, a climate chamber, a hot part |
//! | air pressure (`_hpa`) | 300 … 1 300 hPa | from 9 000 m altitude to a deep mine |
//! | relative humidity (`_pct`) | 0 … 100 % | by definition |
//! | time (`_s`) | ±10⁹ s | 31 years |
//! | feed (`_mm_s`) | 0 … 10⁵ mm/s | 100 m/s; the fastest linear axes reach a few m/s |
//! | a tolerance, an MPE's A or B (`_um`) | 10⁻³ … 10⁴ µm | from a nanometre (a laser's resolution) to 10 mm; a limit outside it decides nothing (issue 40 item 5: 10³⁰⁰ µm passed everything) |
//! | an MPE's K (mm per µm, `A+L/K`) | 0.1 … 10⁶ | at most 10 µm more per mm of length (1 %); K = 10⁻³⁰⁰ made the MPE infinite |
//!
//! The ranges are deliberately generous: they catch 1e308, −273.15 °C and mm given as m,
//! never a real measurement. Sums and squares of values inside them stay far from the
//! float range (10⁶ squared times 10⁶ samples is 10¹⁸), so no statistic of an accepted
//! table overflows.

use std::fmt;

/// A closed range of physically possible values of one quantity, with its unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    pub lo: f64,
    pub hi: f64,
    pub unit: &'static str,
    pub what: &'static str,
}

impl Bound {
    /// The range [lo, hi] of `what`, in `unit`.
    pub const fn new(lo: f64, hi: f64, unit: &'static str, what: &'static str) -> Bound {
        Bound { lo, hi, unit, what }
    }

    /// Whether `v` is finite and inside the range.
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite() && self.lo <= v && v <= self.hi
    }

    /// `Ok` inside the range, else why not (its words are for a message).
    pub fn check(&self, v: f64) -> Result<(), OutOfBound> {
        if self.contains(v) {
            Ok(())
        } else if !v.is_finite() {
            Err(OutOfBound::NotFinite { value: v })
        } else {
            Err(OutOfBound::Outside {
                value: v,
                bound: *self,
            })
        }
    }
}

/// A value [`Bound::check`] refused. The caller says where it stood (file, key, row).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum OutOfBound {
    /// NaN or infinite.
    #[error("value {value} is not finite")]
    NotFinite {
        /// The value refused.
        value: f64,
    },
    /// Finite, but beyond the physical range.
    #[error("value {value:e} is outside the physical range of {bound}")]
    Outside {
        /// The value refused.
        value: f64,
        /// The range it left.
        bound: Bound,
    },
}

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({} … {} {})", self.what, self.lo, self.hi, self.unit)
    }
}

/// Positions and lengths, mm.
pub const POSITION_MM: Bound = Bound::new(-1e6, 1e6, "mm", "a position");

/// Errors and deviations, µm.
pub const ERROR_UM: Bound = Bound::new(-1e6, 1e6, "µm", "an error");

/// Air, scale and part temperatures, °C.
pub const TEMPERATURE_C: Bound = Bound::new(-50.0, 100.0, "°C", "a temperature");

/// Air pressure, hPa.
pub const PRESSURE_HPA: Bound = Bound::new(300.0, 1300.0, "hPa", "an air pressure");

/// Relative humidity, %.
pub const HUMIDITY_PCT: Bound = Bound::new(0.0, 100.0, "%", "a relative humidity");

/// Times, s.
pub const TIME_S: Bound = Bound::new(-1e9, 1e9, "s", "a time");

/// Standard (one-sigma) uncertainties of a measured error, µm: from 1 pm (a thousandth of
/// a laser interferometer's 1 nm resolution; below it a weight 1/σ² is no longer a
/// number a fit can use) to a metre.
pub const UNCERTAINTY_UM: Bound = Bound::new(1e-6, 1e6, "µm", "a standard uncertainty");

/// Tolerances and maximum permissible errors (a limit's size, an MPE's A or B), µm.
pub const TOLERANCE_UM: Bound = Bound {
    lo: 1e-3,
    hi: 1e4,
    unit: "µm",
    what: "a tolerance",
};

/// K of an MPE `A+L/K`, mm per µm.
pub const MPE_K_MM_PER_UM: Bound = Bound {
    lo: 0.1,
    hi: 1e6,
    unit: "mm/µm",
    what: "K of A+L/K",
};

/// Feeds, mm/s.
pub const FEED_MM_S: Bound = Bound::new(0.0, 1e5, "mm/s", "a feed");

/// Where a setting of a configuration file may lie: not a physical quantity's range (a
/// [`Bound`]) but a setting's own, whose words end the refusal `key = value must be …`.
/// Every one refuses NaN and the infinities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Allowed {
    /// Above zero: "positive".
    Positive,
    /// Zero or above: "≥ 0".
    NonNegative,
    /// lo < v ≤ hi: "in (lo, hi]".
    AboveUpTo(f64, f64),
    /// lo ≤ v < hi: "in [lo, hi)".
    FromBelow(f64, f64),
    /// lo ≤ v ≤ hi: "within lo … hi".
    Within(f64, f64),
}

impl Allowed {
    /// Whether `v` is allowed.
    pub fn contains(self, v: f64) -> bool {
        v.is_finite()
            && match self {
                Allowed::Positive => v > 0.0,
                Allowed::NonNegative => v >= 0.0,
                Allowed::AboveUpTo(lo, hi) => lo < v && v <= hi,
                Allowed::FromBelow(lo, hi) => lo <= v && v < hi,
                Allowed::Within(lo, hi) => lo <= v && v <= hi,
            }
    }

    /// `Ok` when the setting `key` may be `v`, else the refusal naming both.
    pub fn check(self, key: &str, v: f64) -> Result<(), NotAllowed> {
        if self.contains(v) {
            Ok(())
        } else {
            Err(NotAllowed {
                key: key.to_string(),
                value: v,
                allowed: self,
            })
        }
    }
}

impl fmt::Display for Allowed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Allowed::Positive => f.write_str("positive"),
            Allowed::NonNegative => f.write_str("≥ 0"),
            Allowed::AboveUpTo(lo, hi) => write!(f, "in ({lo}, {hi}]"),
            Allowed::FromBelow(lo, hi) => write!(f, "in [{lo}, {hi})"),
            Allowed::Within(lo, hi) => write!(f, "within {lo} … {hi}"),
        }
    }
}

/// A setting [`Allowed::check`] refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key} = {value} must be {allowed}")]
pub struct NotAllowed {
    /// The setting's key.
    pub key: String,
    /// The value refused.
    pub value: f64,
    /// Where it may lie.
    pub allowed: Allowed,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_hold_their_ends_and_refuse_beyond_them() {
        assert!(POSITION_MM.contains(1e6) && POSITION_MM.contains(-1e6));
        assert!(!POSITION_MM.contains(1.000001e6));
        assert!(!POSITION_MM.contains(f64::NAN));
        assert!(TEMPERATURE_C.contains(20.0));
        assert!(!TEMPERATURE_C.contains(-273.15));
        let m = ERROR_UM.check(1e308).expect_err("refused");
        assert_eq!(
            m,
            OutOfBound::Outside {
                value: 1e308,
                bound: ERROR_UM
            }
        );
        let m = m.to_string();
        assert!(m.contains("1e308") && m.contains("µm"), "{m}");
        let m = TIME_S.check(f64::INFINITY).expect_err("refused");
        assert!(matches!(m, OutOfBound::NotFinite { value } if value.is_infinite()));
        assert!(m.to_string().contains("not finite"));
    }

    #[test]
    fn a_setting_is_refused_outside_its_interval_and_the_words_say_which() {
        assert!(Allowed::AboveUpTo(0.0, 10.0).contains(10.0));
        assert!(!Allowed::AboveUpTo(0.0, 10.0).contains(0.0));
        assert!(Allowed::FromBelow(0.0, 1.0).contains(0.0));
        assert!(!Allowed::FromBelow(0.0, 1.0).contains(1.0));
        assert!(Allowed::Within(0.0, 0.1).contains(0.1));
        assert!(!Allowed::Positive.contains(0.0));
        assert!(Allowed::NonNegative.contains(0.0));
        assert!(!Allowed::NonNegative.contains(f64::INFINITY));
        assert!(!Allowed::Within(0.0, 1.0).contains(f64::NAN));
        let e = Allowed::AboveUpTo(0.0, 0.1).check("period_window_rel", 0.5);
        assert_eq!(
            e.expect_err("refused").to_string(),
            "period_window_rel = 0.5 must be in (0, 0.1]"
        );
        let e = Allowed::NonNegative.check("noise_um", -1.0);
        assert_eq!(
            e.expect_err("refused").to_string(),
            "noise_um = -1 must be ≥ 0"
        );
        let e = Allowed::Within(0.0, 0.1).check("outliers.probability", 0.2);
        assert_eq!(
            e.expect_err("refused").to_string(),
            "outliers.probability = 0.2 must be within 0 … 0.1"
        );
    }
}
