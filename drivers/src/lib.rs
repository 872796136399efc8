//! errmap acquisition drivers: the wire protocol of `docs/wire-protocol.md`
//! (version 1), decoded sans-IO into the session table of `docs/session-table.md`.
//!
//! | module | what | standard / method | cost |
//! |---|---|---|---|
//! | [`frame`] | frame types, typed payloads, encoder, single-frame parser | wire protocol v1, CRC-16/CCITT-FALSE | O(L) per frame |
//! | [`decoder`] | sans-IO stream decoder: sync search, resync, seq tracking | spec resync rule | O(n), buffer ≤ 496 B |
//! | [`session`] | frames → session-table rows | spec "From frames to session-table rows" | O(1) per frame |
//! | [`counter`] | 32-bit counter unwrapping into i64 | signed modular difference | O(1) |
//! | [`quadrature`] | ×4 A-quad-B state machine for RAW_AB | ×4 quadrature decoding | O(1) per state |
//! | [`edlen`] | refractive index of air | modified Edlén (Birch & Downs 1993/94), IAPWS-IF97 | O(1) |
//! | [`stats`] | decoder statistics (spec JSON) and problem log | spec "Decoder statistics" | — |
//! | [`problem`] | typed problems with stream positions | — | — |
//! | [`longrun`] | a long generated capture (benchmarks, soak) | simulated board, line after line | one line's stream in memory |
//! | [`rotary`] | the rotary reading of a HELLO (axis codes 3–5): encoder and reference angles, rotary rows | errmap's extension, `docs/rotary.md` | O(1) |
//! | [`transport`] | byte sources: serial port, reader (replay) | `serialport` | — |
//!
//! Bytes flow `ByteSource → Decoder → SessionBuilder → SessionRow`; nothing below
//! [`transport`] does I/O. [`decode_all`] runs the whole chain over a capture in memory.
//! No input makes any of it panic.

pub mod capture;
pub mod counter;
pub mod decoder;
pub mod edlen;
pub mod frame;
pub mod longrun;
pub mod problem;
pub mod quadrature;
pub mod rotary;
pub mod serve;
pub mod session;
pub mod sim;
pub mod stats;
pub mod transport;

pub use decoder::{DecodedFrame, Decoder, Event};
pub use frame::{Axis, EncodeError, Frame, FrameError, FrameType, Hello, encode, parse_frame};
pub use problem::{Problem, ProblemKind, StreamPos};
pub use session::{SessionBuilder, SessionConfig, SessionDecoder, SessionEvent, SessionRow};
pub use stats::{DecoderStats, ProblemLog};
pub use transport::{ByteSource, ReadOutcome, ReaderSource, SerialSource, TransportError};

/// Decode a whole raw capture: every row that could be decoded, the statistics (with the
/// problem log), and the session's HELLO (the first usable one). Used by replay; live
/// capture pushing the same bytes in any chunks gives the same rows.
pub fn decode_all(bytes: &[u8]) -> (Vec<SessionRow>, DecoderStats, Option<Hello>) {
    decode_with(SessionDecoder::new(), bytes)
}

/// [`decode_all`] with a device description in force from the first byte (the HELLO of
/// an earlier capture of the same device): the SAMPLEs of a capture whose own HELLO is
/// missing or damaged become rows instead of `unconverted_samples`. Refuses a HELLO that
/// gives no scaling.
pub fn decode_all_with_hello(
    bytes: &[u8],
    hello: Hello,
) -> Result<(Vec<SessionRow>, DecoderStats, Option<Hello>), problem::HelloError> {
    Ok(decode_with(SessionDecoder::with_hello(hello)?, bytes))
}

fn decode_with(
    mut d: SessionDecoder,
    bytes: &[u8],
) -> (Vec<SessionRow>, DecoderStats, Option<Hello>) {
    let mut rows = d.push(bytes);
    rows.extend(d.finish());
    let hello = d.hello().copied();
    (rows, d.stats(), hello)
}
