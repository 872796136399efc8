//! Typed problems found in a stream, each with its position (byte offset, seq, t_us), as
//! `docs/wire-protocol.md` ("What the host promises") requires: damage is counted
//! and reported, never silently dropped and never a panic.
//!
//! A problem is not an error: decoding goes on. The stream decoder and the session
//! builder emit them as events and record them in a bounded
//! [`ProblemLog`](crate::stats::ProblemLog).

use serde::Serialize;

use crate::frame::FrameError;

/// Where in the stream a problem was found.
///
/// `offset` is the byte offset in the stream (from the first byte ever pushed) of the
/// problem itself: the first byte of the rejected candidate, of the skipped run, of the
/// truncated tail, or of the valid frame the problem concerns. `seq` and `t_us` are those
/// of the frame the problem concerns when there is one, otherwise of the latest valid
/// frame (respectively timestamped frame) before it; `None` when there is none yet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct StreamPos {
    /// Byte offset in the stream.
    pub offset: u64,
    /// Sequence number (see the type docs for which frame's).
    pub seq: Option<u16>,
    /// Device time, µs (see the type docs for which frame's).
    pub t_us: Option<u64>,
}

/// Which of the two counters of a SAMPLE (or the two line pairs of a RAW_AB).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Counter {
    /// The grating scale.
    Scale,
    /// The laser interferometer.
    Laser,
}

/// Why a HELLO frame cannot be used to scale the counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, thiserror::Error)]
#[serde(rename_all = "snake_case")]
pub enum HelloError {
    /// The axis code is not 0, 1, 2 (linear) or 3, 4, 5 (rotary).
    #[error("measured axis code {0} is not 0 (X), 1 (Y), 2 (Z), 3 (A), 4 (B) or 5 (C)")]
    BadAxis(u8),
    /// The optical fold F or the edges per fringe k is zero.
    #[error("optical fold {fold} or edges per fringe {edges} is zero")]
    ZeroDivisor {
        /// F.
        fold: u8,
        /// k.
        edges: u8,
    },
    /// The laser wavelength is zero.
    #[error("laser wavelength is zero")]
    ZeroWavelength,
    /// A rotary HELLO with zero encoder or reference counts per revolution.
    #[error("a rotary HELLO with zero encoder or reference counts per revolution")]
    ZeroCountsPerRev,
}

/// What went wrong (or what is worth reporting) at a position of the stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "problem", rename_all = "snake_case")]
pub enum ProblemKind {
    /// A complete candidate frame whose CRC did not match; resync follows.
    CrcFailure {
        /// Type byte of the rejected frame.
        frame_type: u8,
        /// Seq field of the rejected frame (not trustworthy).
        header_seq: u16,
        /// CRC computed over the bytes.
        expected: u16,
        /// CRC carried by the frame.
        got: u16,
    },
    /// A sync word followed by an unknown type byte; resync follows.
    UnknownType {
        /// The type byte.
        frame_type: u8,
    },
    /// A length that does not match the frame type (from the header, or a MATERIAL/RAW_AB
    /// count that disagrees with it); resync follows.
    BadLength {
        /// Type byte.
        frame_type: u8,
        /// Length byte.
        len: u8,
        /// The count field, when the mismatch is between count and length.
        count: Option<u8>,
    },
    /// A run of bytes discarded while searching for a frame (one per resync).
    BytesSkipped {
        /// Bytes in the run.
        bytes: u64,
    },
    /// Frames missing between two valid frames, by sequence number.
    SeqGap {
        /// The seq that was expected.
        expected: u16,
        /// The seq that came.
        got: u16,
        /// Frames lost: `got − expected` modulo 2^16.
        lost: u32,
    },
    /// At the end of the capture, an incomplete candidate frame with complete valid
    /// frames inside it (its length byte claimed more bytes than the capture holds): it
    /// is abandoned like a rejected frame, its bytes up to the first inner frame are
    /// skipped, and the inner frames are decoded.
    AbandonedCandidate {
        /// Type byte of the candidate.
        frame_type: u8,
        /// Length byte of the candidate.
        len: u8,
    },
    /// An incomplete frame at the end of the capture.
    TruncatedTail {
        /// Bytes in the incomplete frame.
        bytes: u64,
    },
    /// A TEXT payload that was not valid UTF-8 (kept, with replacement characters).
    InvalidText,
    /// A SAMPLE with flags ≠ 0 (the row is kept and carries the flags).
    FlaggedSample {
        /// The flags byte.
        flags: u8,
    },
    /// A 32-bit counter wrapped (crossed i32::MAX ↔ i32::MIN); unwrapped correctly.
    CounterWrap {
        /// Which counter.
        counter: Counter,
    },
    /// A counter moved further between two samples than a real motion can; applied as
    /// read, but reported.
    CounterJump {
        /// Which counter.
        counter: Counter,
        /// The jump, counts.
        counts: i64,
        /// Sample intervals the jump spans (index difference, at least 1).
        intervals: i64,
    },
    /// The SAMPLE index did not increase (device restart or duplicate frame).
    SampleIndexNotIncreasing {
        /// Unwrapped index before.
        previous: i64,
        /// Unwrapped index now.
        index: i64,
    },
    /// An illegal quadrature transition (both lines changed) in a RAW_AB frame.
    IllegalTransition {
        /// Which line pair.
        counter: Counter,
        /// Previous (A, B) state as bits (bit0 A, bit1 B).
        from: u8,
        /// New (A, B) state.
        to: u8,
    },
    /// A HELLO whose parameters cannot scale the counters (ignored for scaling).
    BadHello {
        /// Why.
        error: HelloError,
    },
    /// A HELLO with a protocol version other than 1 (used anyway).
    UnsupportedVersion {
        /// The version byte.
        version: u8,
    },
    /// A HELLO whose parameters differ from the one in force (the new one is used from
    /// here on).
    HelloChanged,
    /// A MARK with an unknown kind (ignored) or a direction other than ±1 (its sign is
    /// used).
    BadMark {
        /// Kind code.
        kind: u8,
        /// Direction byte.
        direction: i8,
    },
    /// Rows that could not be written because no usable HELLO ever came.
    NoHello {
        /// Rows dropped.
        rows_dropped: u64,
    },
    /// No SAMPLE with flags = 0 before the end (or before the pending-row cap): the first
    /// SAMPLE's counters serve as origin instead.
    NoCleanSample,
    /// An ENV frame with physically impossible air values (outside −50 … 100 °C,
    /// 300 … 1 300 hPa or 0 … 100 % RH): a broken sensor. It is not used: the rows after
    /// it carry no air values and a laser length not compensated for the air, the
    /// spec's mark of a row without air data, until a plausible ENV comes.
    ImplausibleEnv {
        /// Air temperature, milli-°C.
        air_temp_mc: i32,
        /// Pressure, Pa.
        pressure_pa: u32,
        /// Relative humidity, ‰.
        rh_permille: u16,
    },
    /// A MATERIAL frame with a temperature outside −50 … 100 °C: not used (the material
    /// columns stay empty until a plausible MATERIAL comes).
    ImplausibleMaterial {
        /// Sensor index.
        sensor: u8,
        /// Its temperature, milli-°C.
        temp_mc: i32,
    },
}

impl ProblemKind {
    /// Short snake_case name of the kind, used as key in the problem log.
    pub const fn name(&self) -> &'static str {
        match self {
            ProblemKind::CrcFailure { .. } => "crc_failure",
            ProblemKind::UnknownType { .. } => "unknown_type",
            ProblemKind::BadLength { .. } => "bad_length",
            ProblemKind::BytesSkipped { .. } => "bytes_skipped",
            ProblemKind::SeqGap { .. } => "seq_gap",
            ProblemKind::AbandonedCandidate { .. } => "abandoned_candidate",
            ProblemKind::TruncatedTail { .. } => "truncated_tail",
            ProblemKind::InvalidText => "invalid_text",
            ProblemKind::FlaggedSample { .. } => "flagged_sample",
            ProblemKind::CounterWrap { .. } => "counter_wrap",
            ProblemKind::CounterJump { .. } => "counter_jump",
            ProblemKind::SampleIndexNotIncreasing { .. } => "sample_index_not_increasing",
            ProblemKind::IllegalTransition { .. } => "illegal_transition",
            ProblemKind::BadHello { .. } => "bad_hello",
            ProblemKind::UnsupportedVersion { .. } => "unsupported_version",
            ProblemKind::HelloChanged => "hello_changed",
            ProblemKind::BadMark { .. } => "bad_mark",
            ProblemKind::NoHello { .. } => "no_hello",
            ProblemKind::NoCleanSample => "no_clean_sample",
            ProblemKind::ImplausibleEnv { .. } => "implausible_env",
            ProblemKind::ImplausibleMaterial { .. } => "implausible_material",
        }
    }

    /// The problem for a rejected candidate frame (`header_seq` is the seq field of the
    /// candidate, only meaningful for CRC failures).
    pub fn from_frame_error(e: FrameError, header_seq: u16, frame_type: u8) -> Option<Self> {
        match e {
            FrameError::NoSync => None,
            FrameError::UnknownType(t) => Some(ProblemKind::UnknownType { frame_type: t }),
            FrameError::BadLength { frame_type, len } => Some(ProblemKind::BadLength {
                frame_type,
                len,
                count: None,
            }),
            FrameError::CountMismatch {
                frame_type,
                count,
                len,
            } => Some(ProblemKind::BadLength {
                frame_type,
                len,
                count: Some(count),
            }),
            FrameError::InvalidChecksum { expected, got } => Some(ProblemKind::CrcFailure {
                frame_type,
                header_seq,
                expected,
                got,
            }),
        }
    }
}

/// A problem and where it was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Problem {
    /// Position in the stream.
    #[serde(flatten)]
    pub pos: StreamPos,
    /// What.
    #[serde(flatten)]
    pub kind: ProblemKind,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} at byte {}", self.kind.name(), self.pos.offset)?;
        if let Some(seq) = self.pos.seq {
            write!(f, ", seq {seq}")?;
        }
        if let Some(t) = self.pos.t_us {
            write!(f, ", t {t} µs")?;
        }
        Ok(())
    }
}
