//! Decoder statistics, serialised exactly as `docs/wire-protocol.md` section
//! "Decoder statistics" lists them, plus a bounded log of problem positions kept beside it.
//!
//! [`DecoderStats`] serialises to precisely the spec's keys, in the spec's order; the
//! [`ProblemLog`] (count and first [`ProblemLog::FIRST_N`] positions of every problem
//! kind) is a `#[serde(skip)]` field, serialised on its own where a report wants it (the
//! capture session JSON), so the spec shape stays exact.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::frame::FrameType;
use crate::problem::Problem;

/// Valid frames per type.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct FrameCounts {
    /// HELLO frames.
    pub hello: u64,
    /// SAMPLE frames.
    pub sample: u64,
    /// ENV frames.
    pub env: u64,
    /// MATERIAL frames.
    pub material: u64,
    /// MARK frames.
    pub mark: u64,
    /// RAW_AB frames.
    pub raw_ab: u64,
    /// TEXT frames.
    pub text: u64,
}

impl FrameCounts {
    /// Count one frame of type `t`.
    pub fn count(&mut self, t: FrameType) {
        let slot = match t {
            FrameType::Hello => &mut self.hello,
            FrameType::Sample => &mut self.sample,
            FrameType::Env => &mut self.env,
            FrameType::Material => &mut self.material,
            FrameType::Mark => &mut self.mark,
            FrameType::RawAb => &mut self.raw_ab,
            FrameType::Text => &mut self.text,
        };
        *slot += 1;
    }

    /// All valid frames.
    pub const fn total(&self) -> u64 {
        self.hello + self.sample + self.env + self.material + self.mark + self.raw_ab + self.text
    }
}

/// Wraps of the two 32-bit SAMPLE counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct CounterWraps {
    /// Scale counter wraps.
    pub scale: u64,
    /// Laser counter wraps.
    pub laser: u64,
}

/// Totals of the RAW_AB quadrature decoding.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RawAbStats {
    /// Net scale counts (+1 forward step, −1 reverse).
    pub scale_counts: i64,
    /// Net laser counts.
    pub laser_counts: i64,
    /// Illegal scale transitions.
    pub scale_illegal: u64,
    /// Illegal laser transitions.
    pub laser_illegal: u64,
}

/// Count and first positions of one problem kind.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ProblemSummary {
    /// How many times it occurred.
    pub count: u64,
    /// The first [`ProblemLog::FIRST_N`] occurrences, in stream order.
    pub first: Vec<Problem>,
}

/// Bounded log of problems: per kind, a count and the first few occurrences.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
#[serde(transparent)]
pub struct ProblemLog {
    kinds: BTreeMap<&'static str, ProblemSummary>,
}

impl ProblemLog {
    /// Occurrences kept per kind.
    pub const FIRST_N: usize = 5;

    /// Record one problem.
    pub fn record(&mut self, p: &Problem) {
        let entry = self.kinds.entry(p.kind.name()).or_default();
        entry.count += 1;
        if entry.first.len() < Self::FIRST_N {
            entry.first.push(p.clone());
        }
    }

    /// The summary of a kind by name (see [`ProblemKind::name`](crate::problem::ProblemKind::name)).
    pub fn get(&self, kind: &str) -> Option<&ProblemSummary> {
        self.kinds.get(kind)
    }

    /// How many problems of a kind were recorded.
    pub fn count(&self, kind: &str) -> u64 {
        self.kinds.get(kind).map_or(0, |s| s.count)
    }

    /// Every kind with its summary, by name.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, &ProblemSummary)> {
        self.kinds.iter().map(|(k, v)| (*k, v))
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// Add another log (counts summed; first occurrences merged by byte offset).
    pub fn merge(&mut self, other: &ProblemLog) {
        for (k, v) in &other.kinds {
            let entry = self.kinds.entry(k).or_default();
            entry.count += v.count;
            entry.first.extend(v.first.iter().cloned());
            entry.first.sort_by_key(|p| p.pos.offset);
            entry.first.truncate(Self::FIRST_N);
        }
    }
}

/// Decoder statistics in the exact JSON shape of the spec:
///
/// ```json
/// {"bytes": 0, "frames": {"hello": 0, "sample": 0, "env": 0, "material": 0, "mark": 0,
///  "raw_ab": 0, "text": 0}, "crc_failures": 0, "resyncs": 0, "bytes_skipped": 0,
///  "seq_gaps": 0, "frames_lost": 0, "counter_wraps": {"scale": 0, "laser": 0},
///  "flagged_samples": 0, "truncated_tail_bytes": 0, "raw_ab": {"scale_counts": 0,
///  "laser_counts": 0, "scale_illegal": 0, "laser_illegal": 0}, "rows": 0}
/// ```
///
/// Definitions (see also `drivers/README.md`): `bytes` = every byte pushed;
/// `bytes == frame bytes + bytes_skipped + truncated_tail_bytes` after `finish`.
/// `resyncs` = maximal runs of skipped bytes (one per loss of alignment, including
/// garbage before the first frame). `crc_failures` = complete candidates with a good
/// header whose CRC failed. `frames_lost` = sum over gaps of (got − expected) mod 2^16.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DecoderStats {
    /// Bytes pushed into the decoder.
    pub bytes: u64,
    /// Valid frames per type.
    pub frames: FrameCounts,
    /// Candidates rejected for a bad CRC.
    pub crc_failures: u64,
    /// Times the decoder lost alignment and searched again.
    pub resyncs: u64,
    /// Bytes discarded while searching.
    pub bytes_skipped: u64,
    /// Gaps in the seq numbers of valid frames.
    pub seq_gaps: u64,
    /// Frames missing in those gaps.
    pub frames_lost: u64,
    /// Wraps of the SAMPLE counters.
    pub counter_wraps: CounterWraps,
    /// SAMPLEs with flags ≠ 0.
    pub flagged_samples: u64,
    /// Bytes of an incomplete frame at the end of the capture.
    pub truncated_tail_bytes: u64,
    /// RAW_AB quadrature totals.
    pub raw_ab: RawAbStats,
    /// Session rows written.
    pub rows: u64,
    /// SAMPLEs that could not be converted to rows because no usable HELLO (device
    /// description) was in force: the capture started after the HELLO, or the HELLO was
    /// damaged. Serialised only when not 0, so the spec's JSON is unchanged for every
    /// capture that lost nothing (`unconverted_samples` is an extension of the spec).
    #[serde(skip_serializing_if = "is_zero")]
    pub unconverted_samples: u64,
    /// Problem counts and first positions (not part of the spec JSON; serialise it on its
    /// own).
    #[serde(skip)]
    pub problems: ProblemLog,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

impl DecoderStats {
    /// Field-wise sum of two partial statistics (the link layer's and the session
    /// layer's).
    pub fn merged(&self, other: &DecoderStats) -> DecoderStats {
        let mut problems = self.problems.clone();
        problems.merge(&other.problems);
        DecoderStats {
            bytes: self.bytes + other.bytes,
            frames: FrameCounts {
                hello: self.frames.hello + other.frames.hello,
                sample: self.frames.sample + other.frames.sample,
                env: self.frames.env + other.frames.env,
                material: self.frames.material + other.frames.material,
                mark: self.frames.mark + other.frames.mark,
                raw_ab: self.frames.raw_ab + other.frames.raw_ab,
                text: self.frames.text + other.frames.text,
            },
            crc_failures: self.crc_failures + other.crc_failures,
            resyncs: self.resyncs + other.resyncs,
            bytes_skipped: self.bytes_skipped + other.bytes_skipped,
            seq_gaps: self.seq_gaps + other.seq_gaps,
            frames_lost: self.frames_lost + other.frames_lost,
            counter_wraps: CounterWraps {
                scale: self.counter_wraps.scale + other.counter_wraps.scale,
                laser: self.counter_wraps.laser + other.counter_wraps.laser,
            },
            flagged_samples: self.flagged_samples + other.flagged_samples,
            truncated_tail_bytes: self.truncated_tail_bytes + other.truncated_tail_bytes,
            raw_ab: RawAbStats {
                scale_counts: self.raw_ab.scale_counts + other.raw_ab.scale_counts,
                laser_counts: self.raw_ab.laser_counts + other.raw_ab.laser_counts,
                scale_illegal: self.raw_ab.scale_illegal + other.raw_ab.scale_illegal,
                laser_illegal: self.raw_ab.laser_illegal + other.raw_ab.laser_illegal,
            },
            rows: self.rows + other.rows,
            unconverted_samples: self.unconverted_samples + other.unconverted_samples,
            problems,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn json_shape_is_exactly_the_spec() {
        let json = serde_json::to_string(&DecoderStats::default()).unwrap();
        assert_eq!(
            json,
            concat!(
                r#"{"bytes":0,"frames":{"hello":0,"sample":0,"env":0,"material":0,"mark":0,"#,
                r#""raw_ab":0,"text":0},"crc_failures":0,"resyncs":0,"bytes_skipped":0,"#,
                r#""seq_gaps":0,"frames_lost":0,"counter_wraps":{"scale":0,"laser":0},"#,
                r#""flagged_samples":0,"truncated_tail_bytes":0,"raw_ab":{"scale_counts":0,"#,
                r#""laser_counts":0,"scale_illegal":0,"laser_illegal":0},"rows":0}"#
            )
        );
    }
}
