//! The rotary axes A, B and C (rotations about X, Y and Z), and the angle units.
//!
//! Angles are in degrees (`_deg`), angular errors in arcseconds (`_arcsec`,
//! 1″ = 1/3600°), as `docs/rotary.md` says. A rotary axis is never a [`crate::base::Axis`]:
//! the linear pipeline (mm, µm, grids) and the rotary one (°, ″, one revolution) share no
//! table, so the compiler keeps them apart.

use std::fmt;
use std::str::FromStr;

use errmap_drivers::rotary::RotaryAxis as WireRotaryAxis;

/// Arcseconds in one degree.
pub const ARCSEC_PER_DEG: f64 = 3600.0;

/// Arcseconds in one microradian (180·3600/π · 10⁻⁶).
pub const ARCSEC_PER_URAD: f64 = 0.206_264_806_247_096_36;

/// One of the machine's rotary axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RotaryAxis {
    A,
    B,
    C,
}

impl RotaryAxis {
    pub const ALL: [RotaryAxis; 3] = [RotaryAxis::A, RotaryAxis::B, RotaryAxis::C];

    /// `"a"`, `"b"` or `"c"`.
    pub fn lower(self) -> &'static str {
        match self {
            RotaryAxis::A => "a",
            RotaryAxis::B => "b",
            RotaryAxis::C => "c",
        }
    }

    /// `"A"`, `"B"` or `"C"`, as the session table writes it.
    pub fn upper(self) -> &'static str {
        match self {
            RotaryAxis::A => "A",
            RotaryAxis::B => "B",
            RotaryAxis::C => "C",
        }
    }

    /// The rotary error table's angle column: `a_deg`, `b_deg` or `c_deg`.
    pub fn column(self) -> &'static str {
        match self {
            RotaryAxis::A => "a_deg",
            RotaryAxis::B => "b_deg",
            RotaryAxis::C => "c_deg",
        }
    }
}

impl From<WireRotaryAxis> for RotaryAxis {
    fn from(a: WireRotaryAxis) -> Self {
        match a {
            WireRotaryAxis::A => RotaryAxis::A,
            WireRotaryAxis::B => RotaryAxis::B,
            WireRotaryAxis::C => RotaryAxis::C,
        }
    }
}

impl From<RotaryAxis> for WireRotaryAxis {
    fn from(a: RotaryAxis) -> Self {
        match a {
            RotaryAxis::A => WireRotaryAxis::A,
            RotaryAxis::B => WireRotaryAxis::B,
            RotaryAxis::C => WireRotaryAxis::C,
        }
    }
}

impl fmt::Display for RotaryAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.upper())
    }
}

/// A name that is not a, b or c (either case).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a rotary axis (use A, B or C)")]
pub struct ParseRotaryAxisError(pub String);

impl FromStr for RotaryAxis {
    type Err = ParseRotaryAxisError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "a" | "A" => Ok(RotaryAxis::A),
            "b" | "B" => Ok(RotaryAxis::B),
            "c" | "C" => Ok(RotaryAxis::C),
            other => Err(ParseRotaryAxisError(other.to_string())),
        }
    }
}

impl serde::Serialize for RotaryAxis {
    /// As `"A"`, `"B"` or `"C"`.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.upper())
    }
}

impl<'de> serde::Deserialize<'de> for RotaryAxis {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_round_trip_and_a_linear_letter_is_refused() {
        for a in RotaryAxis::ALL {
            assert_eq!(a.lower().parse::<RotaryAxis>(), Ok(a));
            assert_eq!(a.upper().parse::<RotaryAxis>(), Ok(a));
        }
        assert!("x".parse::<RotaryAxis>().is_err());
        // 1 µrad = 180/π · 3600 · 1e-6 arcsec, computed here independently.
        let v = 180.0 / std::f64::consts::PI * 3600.0 * 1e-6;
        assert!((ARCSEC_PER_URAD - v).abs() < 1e-15);
    }
}
