//! The one axis type of the library.
//!
//! The wire protocol has its own `errmap_drivers::frame::Axis` (a HELLO code, written
//! upper-case in session tables); it converts into this one with `From`. Everything
//! above the decoder — error-table columns, grid indices, messages, CLI flags — uses
//! [`Axis`].

use std::fmt;
use std::str::FromStr;

use errmap_drivers::frame::Axis as WireAxis;

/// One of the machine's three linear axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// 0, 1, 2 for X, Y, Z: the index into `[x, y, z]` arrays.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The error-table column of the coordinate along this axis.
    pub fn column(self) -> &'static str {
        match self {
            Axis::X => "x_mm",
            Axis::Y => "y_mm",
            Axis::Z => "z_mm",
        }
    }

    /// `"x"`, `"y"` or `"z"`.
    pub fn lower(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
        }
    }

    /// `"X"`, `"Y"` or `"Z"`, as the session table writes it.
    pub fn upper(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.lower())
    }
}

/// An axis name that is not x, y or z (either case).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not an axis (use x, y or z)")]
pub struct ParseAxisError(pub String);

impl FromStr for Axis {
    type Err = ParseAxisError;

    /// `x`, `y`, `z` in either case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "x" | "X" => Ok(Axis::X),
            "y" | "Y" => Ok(Axis::Y),
            "z" | "Z" => Ok(Axis::Z),
            other => Err(ParseAxisError(other.to_string())),
        }
    }
}

impl serde::Serialize for Axis {
    /// As `"x"`, `"y"` or `"z"`.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.lower())
    }
}

impl<'de> serde::Deserialize<'de> for Axis {
    /// From `x`, `y` or `z` in either case; anything else is an error naming it.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

impl From<WireAxis> for Axis {
    fn from(a: WireAxis) -> Self {
        match a {
            WireAxis::X => Axis::X,
            WireAxis::Y => Axis::Y,
            WireAxis::Z => Axis::Z,
        }
    }
}

impl From<Axis> for WireAxis {
    fn from(a: Axis) -> Self {
        match a {
            Axis::X => WireAxis::X,
            Axis::Y => WireAxis::Y,
            Axis::Z => WireAxis::Z,
        }
    }
}

/// Direction of approach along an axis: up (+1, towards larger positions) or down (−1).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum Direction {
    /// `↑`: the axis moved in its positive direction to reach the target.
    Up,
    /// `↓`: the axis moved in its negative direction to reach the target.
    Down,
}

impl Direction {
    /// +1 or −1, as the session table's `direction`.
    pub fn sign(self) -> i8 {
        match self {
            Direction::Up => 1,
            Direction::Down => -1,
        }
    }

    /// The arrow ISO 230-2 uses: `↑` or `↓`.
    pub fn arrow(self) -> &'static str {
        match self {
            Direction::Up => "↑",
            Direction::Down => "↓",
        }
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let word = match self {
            Direction::Up => "up (↑)",
            Direction::Down => "down (↓)",
        };
        f.write_str(word)
    }
}
