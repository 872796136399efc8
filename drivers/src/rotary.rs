//! The rotary reading of the wire protocol: a board that counts an angle encoder (the
//! axis' own reading) against a rotary reference (an angle encoder of a higher class on
//! the same shaft, or an indexer's quadrature output), errmap's extension of
//! `docs/wire-protocol.md` version 1 (`docs/rotary.md`, "Capture"). No frame changes
//! layout; a HELLO whose measured-axis code is 3 (A), 4 (B) or 5 (C) says that the
//! fields are read as follows:
//!
//! | frame field | linear reading | rotary reading |
//! |---|---|---|
//! | HELLO grating period | scale grating, nm | encoder signal periods per revolution (the periodic error's order; informational) |
//! | HELLO count resolution | pm per scale count | encoder counts per revolution |
//! | HELLO laser wavelength | λ_vac, fm | reference signal periods per revolution |
//! | HELLO F, k | fold, edges per fringe | reference counts per signal period = F·k |
//! | SAMPLE scale / laser counter | scale / laser counts | encoder / reference counts |
//! | MARK feed | µm/s | m°/s (millidegrees per second) |
//! | MARK first line position | µm | the target's nominal angle, µ° (microdegrees) |
//! | MARK second line position | µm | unused (0) |
//!
//! Angles: indicated = S·360/N_enc, reference = L·360/(N_ref·F·k), S and L the unwrapped
//! counters **from zero**: a rotary encoder's count is an angle from its reference mark,
//! so the origin is the count 0 (not the first clean sample, as for a linear axis), and
//! the angles are absolute. No air refraction enters an angle; ENV and MATERIAL are
//! recorded as for a linear axis. `error_arcsec` = (indicated − reference)·3600.

use serde::Serialize;

use crate::frame::Hello;
use crate::problem::HelloError;

/// A rotary axis of a HELLO frame (codes 3, 4, 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum RotaryAxis {
    /// Code 3.
    A,
    /// Code 4.
    B,
    /// Code 5.
    C,
}

impl RotaryAxis {
    /// The axis with this HELLO code (3 A, 4 B, 5 C).
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            3 => Some(RotaryAxis::A),
            4 => Some(RotaryAxis::B),
            5 => Some(RotaryAxis::C),
            _ => None,
        }
    }

    /// The HELLO code of this axis.
    pub const fn code(self) -> u8 {
        match self {
            RotaryAxis::A => 3,
            RotaryAxis::B => 4,
            RotaryAxis::C => 5,
        }
    }

    /// `"A"`, `"B"` or `"C"`, as written in the session table.
    pub const fn as_str(self) -> &'static str {
        match self {
            RotaryAxis::A => "A",
            RotaryAxis::B => "B",
            RotaryAxis::C => "C",
        }
    }
}

impl std::fmt::Display for RotaryAxis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Counter scaling of a rotary HELLO (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotaryScaling {
    pub axis: RotaryAxis,
    /// Encoder counts per revolution (N_enc).
    pub encoder_counts_per_rev: u32,
    /// Reference counts per revolution (N_ref·F·k).
    pub reference_counts_per_rev: u64,
}

impl RotaryScaling {
    /// `None` when the HELLO's axis is not rotary; an error when it is but gives no
    /// scaling (zero counts per revolution).
    pub fn from_hello(h: &Hello) -> Option<Result<Self, HelloError>> {
        let axis = RotaryAxis::from_code(h.axis_code)?;
        if h.optical_fold == 0 || h.edges_per_fringe == 0 {
            return Some(Err(HelloError::ZeroDivisor {
                fold: h.optical_fold,
                edges: h.edges_per_fringe,
            }));
        }
        if h.count_resolution_pm == 0 || h.laser_wavelength_fm == 0 {
            return Some(Err(HelloError::ZeroCountsPerRev));
        }
        Some(Ok(RotaryScaling {
            axis,
            encoder_counts_per_rev: h.count_resolution_pm,
            reference_counts_per_rev: u64::from(h.laser_wavelength_fm)
                * u64::from(h.optical_fold)
                * u64::from(h.edges_per_fringe),
        }))
    }

    /// The encoder's angle of `counts` from zero, °.
    pub fn indicated_deg(&self, counts: i64) -> f64 {
        counts as f64 * 360.0 / f64::from(self.encoder_counts_per_rev)
    }

    /// The reference's angle of `counts` from zero, °.
    pub fn reference_deg(&self, counts: i64) -> f64 {
        counts as f64 * 360.0 / self.reference_counts_per_rev as f64
    }

    /// One encoder count, ″.
    pub fn encoder_count_arcsec(&self) -> f64 {
        1_296_000.0 / f64::from(self.encoder_counts_per_rev)
    }

    /// One reference count, ″.
    pub fn reference_count_arcsec(&self) -> f64 {
        1_296_000.0 / self.reference_counts_per_rev as f64
    }
}

/// One row of a rotary session table (`docs/rotary.md`), as a capture decodes it and as
/// errmap's rotary session holds it (`errmap::session::rotary`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RotaryRow {
    pub run: u32,
    pub sample: i64,
    pub t_s: f64,
    pub axis: RotaryAxis,
    /// +1 angle increasing, −1 decreasing, 0 outside a run.
    pub direction: i8,
    /// Target index while dwelling, else −1.
    pub target: i32,
    /// The latest MARK's target angle while dwelling, °; empty while moving.
    pub target_deg: Option<f64>,
    pub indicated_deg: f64,
    pub reference_deg: f64,
    /// (indicated − reference)·3600.
    pub error_arcsec: f64,
    /// The latest MARK's angular feed, °/s; empty before the first MARK.
    pub feed_deg_s: Option<f64>,
    pub air_temp_c: Option<f64>,
    /// MATERIAL sensor 1 (the table), °C.
    pub part_temp_c: Option<f64>,
    /// MATERIAL sensor 0 (the encoder), °C.
    pub scale_temp_c: Option<f64>,
    pub flags: u8,
}

impl RotaryRow {
    /// A dwell row, used by every evaluation: run ≥ 1, direction ±1, target ≥ 0, no flag.
    pub fn is_dwell(&self) -> bool {
        self.run >= 1 && self.direction != 0 && self.target >= 0 && self.flags == 0
    }
}

/// The angle a MARK's first line position carries on a rotary board, °.
pub fn mark_target_deg(line_first_udeg: i32) -> f64 {
    f64::from(line_first_udeg) / 1e6
}

/// The angular feed a MARK carries on a rotary board, °/s.
pub fn mark_feed_deg_s(feed_mdeg_s: u32) -> f64 {
    f64::from(feed_mdeg_s) / 1000.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{DeviceId, Frame, Mark, MarkKind, Sample, SampleFlags, encode};
    use crate::session::{SessionDecoder, SessionEvent};

    fn hello(code: u8) -> Hello {
        Hello {
            protocol_version: 1,
            device_id: DeviceId::from_text("rot"),
            grating_period_nm: 1024,
            count_resolution_pm: 1 << 20,
            laser_wavelength_fm: 9000,
            optical_fold: 1,
            edges_per_fringe: 4,
            axis_code: code,
        }
    }

    #[test]
    fn a_rotary_hello_reads_the_counters_as_angles_from_zero() {
        let mut bytes = encode(&Frame::Hello(hello(4)), 0).expect("hello");
        let mark = Mark {
            t_us: 5,
            kind_code: MarkKind::TargetReached.code(),
            direction: -1,
            run: 2,
            target: 3,
            feed_um_s: 12_500,
            line_first_um: 90_000_000,
            line_second_um: 0,
        };
        bytes.extend(encode(&Frame::Mark(mark), 1).expect("mark"));
        // A quarter revolution on the encoder (2²⁰/4 counts); the reference 1″ short:
        // 36 000 counts a revolution, 9 000 a quarter, one count = 36″.
        let sample = Sample {
            t_us: 10,
            index: 0,
            scale_count: 1 << 18,
            laser_count: 8_999,
            flags: SampleFlags(0),
            trigger_code: 0,
        };
        bytes.extend(encode(&Frame::Sample(sample), 2).expect("sample"));
        let mut rows = Vec::new();
        let mut d = SessionDecoder::new();
        d.push_with(&bytes, &mut |e| {
            if let SessionEvent::Rotary(r) = e {
                rows.push(r);
            }
        });
        assert_eq!(rows.len(), 1);
        let r = &rows[0];
        assert_eq!(r.axis, RotaryAxis::B);
        assert_eq!(r.indicated_deg, 90.0);
        assert!((r.reference_deg - (90.0 - 0.01)).abs() < 1e-12);
        assert!((r.error_arcsec - 36.0).abs() < 1e-9);
        // Target index and angle between MARK kinds 3 and 4 (run 0: no run started).
        assert_eq!((r.run, r.target, r.target_deg), (0, 3, Some(90.0)));
        assert_eq!(r.feed_deg_s, Some(12.5));
        assert!(d.builder().converts());
    }

    #[test]
    fn a_rotary_hello_without_counts_gives_no_scaling() {
        let mut h = hello(5);
        h.count_resolution_pm = 0;
        assert_eq!(
            RotaryScaling::from_hello(&h),
            Some(Err(HelloError::ZeroCountsPerRev))
        );
        assert_eq!(RotaryScaling::from_hello(&hello(2)), None);
        assert_eq!(
            RotaryScaling::from_hello(&hello(3)).map(|s| s.map(|s| s.reference_counts_per_rev)),
            Some(Ok(36_000))
        );
    }
}
