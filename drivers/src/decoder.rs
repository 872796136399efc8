//! Sans-IO stream decoder for wire protocol version 1 (`docs/wire-protocol.md`,
//! sections "The link", "Frames" and "Resynchronisation").
//!
//! Bytes go in with [`Decoder::push`] (or [`Decoder::push_with`], which hands events to
//! a closure and allocates nothing per call); frames and typed problems come out as
//! [`Event`]s. [`Decoder::finish`] ends the stream and accounts an incomplete last frame
//! as `truncated_tail_bytes`. The decoder never touches a port or a file.
//!
//! # Algorithm
//! 1. Search for the sync word `0xAA 0x55`; bytes passed over are *skipped*. A maximal
//!    run of skipped bytes is one *resync* (reported as one
//!    [`ProblemKind::BytesSkipped`] when the run ends).
//! 2. At a sync word, [`parse_frame`] decides as early as possible: unknown type after 3
//!    bytes, a length impossible for the type after 4, the CRC (and the MATERIAL/RAW_AB
//!    count fields) once the whole frame is there.
//! 3. On any rejection only the *first sync byte* is discarded and the search restarts at
//!    the next byte, so a valid frame starting inside the rejected one is found.
//! 4. Valid frames update the seq tracking: a seq other than previous + 1 (mod 2^16) is a
//!    gap of `(got − expected) mod 2^16` lost frames.
//!
//! Every decision depends only on the bytes of the candidate, never on how the input was
//! split across `push` calls, so the events are identical for every split.
//!
//! # Buffer cap
//! The decoder parses straight from the caller's slice. Only an undecided frame prefix at
//! the end of a push is copied into an internal fixed buffer of [`BUF_CAP`] = 2 × 248
//! bytes: one incomplete frame (< 248 bytes) plus up to 248 bytes of the next push, which
//! always suffice to decide that frame. Nothing else is buffered; memory is constant.
//!
//! # Cost
//! O(n) over the input for a clean stream (one CRC pass per frame, slice-by-16), no
//! allocation except for the variable parts of MATERIAL, RAW_AB and TEXT frames. A
//! rejected candidate costs at most one extra pass over ≤ 248 bytes.

use crate::frame::{Frame, MAX_FRAME_LEN, Parsed, SYNC, parse_frame};
use crate::problem::{Problem, ProblemKind, StreamPos};
use crate::stats::DecoderStats;

/// Capacity of the internal buffer, bytes (see the module docs).
pub const BUF_CAP: usize = 2 * MAX_FRAME_LEN;

/// A valid frame and where it was in the stream.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedFrame {
    /// Byte offset of the frame's first sync byte in the stream.
    pub offset: u64,
    /// Bytes the frame occupies on the wire (8 + L).
    pub len: usize,
    /// The frame's sequence number.
    pub seq: u16,
    /// Frames lost immediately before this one (0 when the seq followed on, or for the
    /// first frame).
    pub lost_before: u32,
    /// The frame.
    pub frame: Frame,
}

/// What the decoder found.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A valid frame.
    Frame(DecodedFrame),
    /// A problem (the decoder goes on).
    Problem(Problem),
}

/// The sans-IO stream decoder. See the module docs.
#[derive(Clone)]
pub struct Decoder {
    buf: [u8; BUF_CAP],
    buf_len: usize,
    link: Link,
}

/// Decoder state apart from the buffer (a separate struct so scanning the buffer can
/// borrow both).
#[derive(Debug, Clone, Default)]
struct Link {
    /// Stream offset of the first byte not yet decided (= of `buf[0]` when buffered).
    consumed: u64,
    /// Current run of skipped bytes: (start offset, length).
    skip_run: Option<(u64, u64)>,
    last_seq: Option<u16>,
    last_t_us: Option<u64>,
    stats: DecoderStats,
}

impl std::fmt::Debug for Decoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decoder")
            .field("pending", &&self.buf[..self.buf_len])
            .field("link", &self.link)
            .finish()
    }
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder at the start of a stream.
    pub fn new() -> Self {
        Decoder {
            buf: [0; BUF_CAP],
            buf_len: 0,
            link: Link::default(),
        }
    }

    /// Decode `bytes`, returning the events found.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Event> {
        let mut out = Vec::new();
        self.push_with(bytes, &mut |e| out.push(e));
        out
    }

    /// Decode `bytes`, handing each event to `sink` (no allocation by the decoder itself).
    pub fn push_with<F: FnMut(Event)>(&mut self, bytes: &[u8], sink: &mut F) {
        self.link.stats.bytes += bytes.len() as u64;
        let mut input = bytes;
        // Phase 1: an undecided prefix is buffered; complete it from the input.
        while self.buf_len > 0 && !input.is_empty() {
            let old = self.buf_len;
            let take = input.len().min(BUF_CAP - old);
            if take == 0 {
                // Unreachable: a full buffer always holds a decidable candidate at its
                // start (frames are ≤ 248 bytes). Fail safe: give up one byte.
                self.link.skip(self.link.consumed, 1);
                self.link.consumed += 1;
                self.buf.copy_within(1..old, 0);
                self.buf_len = old - 1;
                continue;
            }
            self.buf[old..old + take].copy_from_slice(&input[..take]);
            self.buf_len = old + take;
            let consumed = self.link.scan(&self.buf[..self.buf_len], sink);
            if consumed >= old {
                // The buffered prefix is decided; go on from the caller's slice.
                input = &input[consumed - old..];
                self.buf_len = 0;
            } else {
                self.buf.copy_within(consumed..self.buf_len, 0);
                self.buf_len -= consumed;
                input = &input[take..];
            }
        }
        // Phase 2: parse straight from the input; buffer only the undecided tail.
        if self.buf_len == 0 && !input.is_empty() {
            let consumed = self.link.scan(input, sink);
            let rest = &input[consumed..];
            // An undecided candidate is shorter than a frame, so it always fits.
            let n = rest.len().min(BUF_CAP);
            self.buf[..n].copy_from_slice(&rest[..n]);
            self.buf_len = n;
        }
    }

    /// End of stream: decode any valid frame lying inside an undecided last candidate
    /// (see [`ProblemKind::AbandonedCandidate`]), report the skipped run in progress, and
    /// account the incomplete last frame as `truncated_tail_bytes`. The decoder stays usable (a later push is decoded
    /// as a continuation of the same stream, with its seq tracking).
    pub fn finish(&mut self) -> Vec<Event> {
        let mut out = Vec::new();
        self.finish_with(&mut |e| out.push(e));
        out
    }

    /// [`Decoder::finish`], handing events to `sink`.
    pub fn finish_with<F: FnMut(Event)>(&mut self, sink: &mut F) {
        // The stream ends inside an undecided candidate. If valid frames lie wholly inside
        // it (a corrupted length byte claiming more than the capture holds), abandon the
        // candidate like a rejected one and decode them; whatever stays undecided after
        // the last of them is the truncated tail.
        while self.buf_len > 0 {
            let buf = &self.buf[..self.buf_len];
            let inner = (1..buf.len()).find(|&p| {
                buf[p] == SYNC[0] && matches!(parse_frame(&buf[p..]), Parsed::Frame { .. })
            });
            let Some(p) = inner else {
                break;
            };
            let offset = self.link.consumed;
            let kind = ProblemKind::AbandonedCandidate {
                frame_type: buf.get(2).copied().unwrap_or(0),
                len: buf.get(3).copied().unwrap_or(0),
            };
            let pos = self.link.pos(offset);
            self.link.problem(pos, kind, sink);
            self.link.skip(offset, p as u64);
            self.link.consumed += p as u64;
            self.buf.copy_within(p..self.buf_len, 0);
            self.buf_len -= p;
            let consumed = self.link.scan(&self.buf[..self.buf_len], sink);
            self.buf.copy_within(consumed..self.buf_len, 0);
            self.buf_len -= consumed;
        }
        self.link.end_skip_run(sink);
        if self.buf_len > 0 {
            let bytes = self.buf_len as u64;
            self.link.stats.truncated_tail_bytes += bytes;
            let pos = self.link.pos(self.link.consumed);
            self.link
                .problem(pos, ProblemKind::TruncatedTail { bytes }, sink);
            self.link.consumed += bytes;
            self.buf_len = 0;
        }
    }

    /// Statistics so far (the link-layer fields; `counter_wraps`, `flagged_samples`,
    /// `raw_ab` and `rows` belong to the session layer and stay 0 here).
    pub fn stats(&self) -> &DecoderStats {
        &self.link.stats
    }

    /// Bytes held undecided in the internal buffer (< 248).
    pub fn pending_len(&self) -> usize {
        self.buf_len
    }

    /// Stream offset of the next undecided byte.
    pub fn stream_offset(&self) -> u64 {
        self.link.consumed
    }

    /// Seq of the latest valid frame.
    pub fn last_seq(&self) -> Option<u16> {
        self.link.last_seq
    }
}

/// Position of the first sync candidate in `data`: an `0xAA` followed by `0x55`, or an
/// `0xAA` as the very last byte (undecided).
fn find_sync(data: &[u8]) -> Option<usize> {
    let mut from = 0;
    while let Some(k) = data.get(from..)?.iter().position(|&b| b == SYNC[0]) {
        let p = from + k;
        match data.get(p + 1) {
            None => return Some(p),
            Some(&b) if b == SYNC[1] => return Some(p),
            Some(_) => from = p + 1,
        }
    }
    None
}

impl Link {
    /// Decide as much of `data` (whose first byte is at stream offset `self.consumed`) as
    /// possible; return the number of bytes decided. The rest is an undecided candidate.
    fn scan<F: FnMut(Event)>(&mut self, data: &[u8], sink: &mut F) -> usize {
        let base = self.consumed;
        let mut i = 0;
        while i < data.len() {
            let rest = &data[i..];
            let Some(p) = find_sync(rest) else {
                self.skip(base + i as u64, rest.len() as u64);
                i = data.len();
                break;
            };
            if p > 0 {
                self.skip(base + i as u64, p as u64);
                i += p;
            }
            let offset = base + i as u64;
            match parse_frame(&data[i..]) {
                Parsed::Incomplete { .. } => break,
                Parsed::Frame { seq, frame, len } => {
                    self.accept(offset, len, seq, frame, sink);
                    i += len;
                }
                Parsed::Invalid(e) => {
                    let cand = &data[i..];
                    let header_seq = match (cand.get(4), cand.get(5)) {
                        (Some(&lo), Some(&hi)) => u16::from_le_bytes([lo, hi]),
                        _ => 0,
                    };
                    let frame_type = cand.get(2).copied().unwrap_or(0);
                    if let Some(kind) = ProblemKind::from_frame_error(e, header_seq, frame_type) {
                        if matches!(kind, ProblemKind::CrcFailure { .. }) {
                            self.stats.crc_failures += 1;
                        }
                        let pos = self.pos(offset);
                        self.problem(pos, kind, sink);
                    }
                    // Resync rule: discard the first sync byte only.
                    self.skip(offset, 1);
                    i += 1;
                }
            }
        }
        self.consumed = base + i as u64;
        i
    }

    fn skip(&mut self, offset: u64, n: u64) {
        if n == 0 {
            return;
        }
        self.stats.bytes_skipped += n;
        match &mut self.skip_run {
            Some((_, len)) => *len += n,
            None => {
                self.stats.resyncs += 1;
                self.skip_run = Some((offset, n));
            }
        }
    }

    fn end_skip_run<F: FnMut(Event)>(&mut self, sink: &mut F) {
        if let Some((start, bytes)) = self.skip_run.take() {
            let pos = self.pos(start);
            self.problem(pos, ProblemKind::BytesSkipped { bytes }, sink);
        }
    }

    fn accept<F: FnMut(Event)>(
        &mut self,
        offset: u64,
        len: usize,
        seq: u16,
        frame: Frame,
        sink: &mut F,
    ) {
        self.end_skip_run(sink);
        if let Some(t) = frame.t_us() {
            self.last_t_us = Some(t);
        }
        let mut lost_before = 0;
        if let Some(prev) = self.last_seq {
            let expected = prev.wrapping_add(1);
            if seq != expected {
                lost_before = u32::from(seq.wrapping_sub(expected));
                self.stats.seq_gaps += 1;
                self.stats.frames_lost += u64::from(lost_before);
                let pos = StreamPos {
                    offset,
                    seq: Some(seq),
                    t_us: self.last_t_us,
                };
                self.problem(
                    pos,
                    ProblemKind::SeqGap {
                        expected,
                        got: seq,
                        lost: lost_before,
                    },
                    sink,
                );
            }
        }
        self.last_seq = Some(seq);
        self.stats.frames.count(frame.frame_type());
        if let Frame::Text(t) = &frame {
            if t.lossy {
                let pos = self.pos(offset);
                self.problem(pos, ProblemKind::InvalidText, sink);
            }
        }
        sink(Event::Frame(DecodedFrame {
            offset,
            len,
            seq,
            lost_before,
            frame,
        }));
    }

    fn pos(&self, offset: u64) -> StreamPos {
        StreamPos {
            offset,
            seq: self.last_seq,
            t_us: self.last_t_us,
        }
    }

    fn problem<F: FnMut(Event)>(&mut self, pos: StreamPos, kind: ProblemKind, sink: &mut F) {
        let p = Problem { pos, kind };
        self.stats.problems.record(&p);
        sink(Event::Problem(p));
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::frame::{Sample, SampleFlags, encode};

    fn sample(i: u32) -> Frame {
        Frame::Sample(Sample {
            t_us: u64::from(i) * 1000,
            index: i,
            scale_count: i as i32 * 10,
            laser_count: i as i32 * 12,
            flags: SampleFlags(0),
            trigger_code: 1,
        })
    }

    #[test]
    fn find_sync_cases() {
        assert_eq!(find_sync(&[]), None);
        assert_eq!(find_sync(&[1, 2, 3]), None);
        assert_eq!(find_sync(&[1, 0xAA]), Some(1));
        assert_eq!(find_sync(&[0xAA, 0xAA, 0x55]), Some(1));
        assert_eq!(find_sync(&[0xAA, 0x00, 0x55]), None);
    }

    #[test]
    fn one_byte_at_a_time_buffers_little() {
        let mut bytes = Vec::new();
        for i in 0..10 {
            bytes.extend(encode(&sample(i), i as u16).unwrap());
        }
        let mut d = Decoder::new();
        let mut frames = 0;
        for b in &bytes {
            for e in d.push(std::slice::from_ref(b)) {
                if matches!(e, Event::Frame(_)) {
                    frames += 1;
                }
            }
            assert!(d.pending_len() < MAX_FRAME_LEN);
        }
        assert_eq!(frames, 10);
        assert!(d.finish().is_empty());
        assert_eq!(d.stats().bytes, bytes.len() as u64);
    }
}
