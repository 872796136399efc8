//! Frame layer of the acquisition wire protocol, version 1
//! (`docs/wire-protocol.md`, sections "Frames" and "The frame types").
//!
//! A frame on the wire:
//!
//! ```text
//!  offset  0    1    2     3    4..5   6 .. 6+L-1   6+L .. 6+L+1
//!        +----+----+------+----+------+------------+--------------+
//!        | AA | 55 | type | L  | seq  |  payload   | CRC-16 (LE)  |
//!        +----+----+------+----+------+------------+--------------+
//!                   \_________ CRC covers these _________/
//! ```
//!
//! All integers are little-endian, the CRC included. The CRC is CRC-16/CCITT-FALSE
//! (poly 0x1021, init 0xFFFF, no reflection, xorout 0; `crc::CRC_16_IBM_3740` in the `crc`
//! crate), computed with a 16-lane table (slice-by-16, about 1 cycle per byte).
//!
//! This module owns the typed payloads (units in the field names), the encoder used by
//! tests and the simulated device, and [`parse_frame`], the sans-IO single-frame parser
//! the stream [`Decoder`](crate::decoder::Decoder) is built on: given bytes that start at
//! a sync word it answers "a frame", "need more bytes" or a typed [`FrameError`].
//!
//! Cost: parsing is O(L) (one CRC pass and a fixed-size copy); only MATERIAL, RAW_AB and
//! TEXT payloads allocate (their variable-length part).

use crc::{CRC_16_IBM_3740, Crc, Table};
use serde::{Serialize, Serializer};

/// The two sync bytes that start every frame.
pub const SYNC: [u8; 2] = [0xAA, 0x55];
/// Bytes before the payload: sync (2), type (1), length (1), seq (2).
pub const HEADER_LEN: usize = 6;
/// Bytes of the trailing CRC.
pub const CRC_LEN: usize = 2;
/// Largest payload length the protocol allows.
pub const MAX_PAYLOAD_LEN: usize = 240;
/// Largest frame on the wire: 6 + 240 + 2 = 248 bytes.
pub const MAX_FRAME_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;
/// Smallest frame on the wire (a TEXT frame with one byte): 9 bytes.
pub const MIN_FRAME_LEN: usize = HEADER_LEN + 1 + CRC_LEN;

/// Most sensors a MATERIAL frame may carry.
pub const MAX_MATERIAL_SENSORS: usize = 8;
/// Most states a RAW_AB frame may carry.
pub const MAX_RAW_AB_STATES: usize = 229;

const HELLO_LEN: u8 = 32;
const SAMPLE_LEN: u8 = 22;
/// Bytes of one whole SAMPLE frame (header, payload, CRC).
pub const SAMPLE_FRAME_BYTES: usize = HEADER_LEN + SAMPLE_LEN as usize + CRC_LEN;
const ENV_LEN: u8 = 18;
const MARK_LEN: u8 = 26;
const MATERIAL_FIXED_LEN: u8 = 9;
const RAW_AB_FIXED_LEN: u8 = 11;

static CRC16: Crc<u16, Table<16>> = Crc::<u16, Table<16>>::new(&CRC_16_IBM_3740);

/// CRC-16/CCITT-FALSE of `bytes` (check value: `b"123456789"` → `0x29B1`).
pub fn crc16(bytes: &[u8]) -> u16 {
    CRC16.checksum(bytes)
}

/// Errors of the frame layer: why a candidate frame was rejected.
///
/// Every variant except [`FrameError::NoSync`] makes the stream decoder discard the first
/// sync byte and search again (the spec's resync rule).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The bytes do not start with `0xAA 0x55`.
    #[error("no sync word at the start of the frame")]
    NoSync,
    /// The type byte names no frame type of protocol version 1.
    #[error("unknown frame type {0:#04x}")]
    UnknownType(u8),
    /// The length byte is not a length this frame type can have.
    #[error("payload length {len} does not match frame type {frame_type:#04x}")]
    BadLength {
        /// Type byte of the frame.
        frame_type: u8,
        /// Length byte of the frame.
        len: u8,
    },
    /// The CRC carried by the frame differs from the CRC of its bytes.
    #[error("invalid checksum: computed {expected:#06x}, frame carries {got:#06x}")]
    InvalidChecksum {
        /// CRC computed over type, length, seq and payload.
        expected: u16,
        /// CRC carried by the frame.
        got: u16,
    },
    /// A MATERIAL sensor count or RAW_AB state count disagrees with the payload length
    /// (a "length that does not match the type", detected after the CRC passed).
    #[error("frame type {frame_type:#04x}: count {count} does not match payload length {len}")]
    CountMismatch {
        /// Type byte of the frame.
        frame_type: u8,
        /// The count field inside the payload.
        count: u8,
        /// Length byte of the frame.
        len: u8,
    },
}

/// Errors of the encoder: the frame cannot be put on the wire as it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// A MATERIAL frame needs 1 to 8 sensors.
    #[error("MATERIAL frames carry 1 to 8 sensors, not {0}")]
    SensorCount(usize),
    /// A RAW_AB frame needs 1 to 229 states.
    #[error("RAW_AB frames carry 1 to 229 states, not {0}")]
    StateCount(usize),
    /// A TEXT frame needs 1 to 240 bytes of UTF-8.
    #[error("TEXT frames carry 1 to 240 bytes, not {0}")]
    TextLength(usize),
    /// A raw payload longer than a length byte can say.
    #[error("payload of {0} bytes does not fit a frame")]
    PayloadTooLong(usize),
}

/// Frame type codes of protocol version 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum FrameType {
    /// 0x01, device description.
    Hello = 0x01,
    /// 0x02, both counters latched at one instant.
    Sample = 0x02,
    /// 0x03, air temperature, pressure and humidity.
    Env = 0x03,
    /// 0x04, material temperature sensors.
    Material = 0x04,
    /// 0x05, run structure from the motion controller.
    Mark = 0x05,
    /// 0x06, raw quadrature line states.
    RawAb = 0x06,
    /// 0x7E, device log line.
    Text = 0x7E,
}

impl FrameType {
    /// All frame types, in code order.
    pub const ALL: [FrameType; 7] = [
        FrameType::Hello,
        FrameType::Sample,
        FrameType::Env,
        FrameType::Material,
        FrameType::Mark,
        FrameType::RawAb,
        FrameType::Text,
    ];

    /// The frame type with this code, if any.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0x01 => Some(FrameType::Hello),
            0x02 => Some(FrameType::Sample),
            0x03 => Some(FrameType::Env),
            0x04 => Some(FrameType::Material),
            0x05 => Some(FrameType::Mark),
            0x06 => Some(FrameType::RawAb),
            0x7E => Some(FrameType::Text),
            _ => None,
        }
    }

    /// The type byte on the wire.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// Lower-case name, as used in the decoder statistics (`"raw_ab"`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            FrameType::Hello => "hello",
            FrameType::Sample => "sample",
            FrameType::Env => "env",
            FrameType::Material => "material",
            FrameType::Mark => "mark",
            FrameType::RawAb => "raw_ab",
            FrameType::Text => "text",
        }
    }

    /// Whether `len` is a payload length this type can have (checked from the header
    /// alone, before the frame is complete).
    pub const fn accepts_len(self, len: u8) -> bool {
        match self {
            FrameType::Hello => len == HELLO_LEN,
            FrameType::Sample => len == SAMPLE_LEN,
            FrameType::Env => len == ENV_LEN,
            FrameType::Mark => len == MARK_LEN,
            FrameType::Material => {
                len >= MATERIAL_FIXED_LEN + 4
                    && len <= MATERIAL_FIXED_LEN + 4 * MAX_MATERIAL_SENSORS as u8
                    && (len - MATERIAL_FIXED_LEN) % 4 == 0
            }
            FrameType::RawAb => len > RAW_AB_FIXED_LEN && len as usize <= MAX_PAYLOAD_LEN,
            FrameType::Text => len >= 1 && len as usize <= MAX_PAYLOAD_LEN,
        }
    }
}

/// The measured axis of a HELLO frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Axis {
    /// Code 0.
    X,
    /// Code 1.
    Y,
    /// Code 2.
    Z,
}

impl Axis {
    /// The axis with this HELLO code (0 X, 1 Y, 2 Z).
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            2 => Some(Axis::Z),
            _ => None,
        }
    }

    /// The HELLO code of this axis.
    pub const fn code(self) -> u8 {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// `"X"`, `"Y"` or `"Z"`, as written in the session table.
    pub const fn as_str(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }
}

impl std::fmt::Display for Axis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The 16-byte device id of a HELLO frame: ASCII, NUL-padded. The raw bytes are kept so
/// that a frame re-encodes bit for bit; [`DeviceId::as_string`] gives the text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DeviceId(pub [u8; 16]);

impl DeviceId {
    /// A device id from text: truncated to 16 bytes, NUL-padded.
    pub fn from_text(text: &str) -> Self {
        let mut raw = [0u8; 16];
        for (dst, src) in raw.iter_mut().zip(text.bytes()) {
            *dst = src;
        }
        DeviceId(raw)
    }

    /// The id up to the first NUL, with invalid UTF-8 replaced.
    pub fn as_string(&self) -> String {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(self.0.len());
        String::from_utf8_lossy(&self.0[..end]).into_owned()
    }
}

impl Serialize for DeviceId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.as_string())
    }
}

/// HELLO (0x01, L = 32): the device description.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Hello {
    /// Protocol version (1).
    pub protocol_version: u8,
    /// Device id, ASCII, NUL-padded.
    pub device_id: DeviceId,
    /// Grating period of the scale, nanometres (e.g. 20 000 for a 20 µm grating).
    pub grating_period_nm: u32,
    /// Scale count resolution, picometres per quadrature edge (e.g. 100 000 = 0.1 µm).
    pub count_resolution_pm: u32,
    /// Laser vacuum wavelength, femtometres (HeNe: 632 991 354).
    pub laser_wavelength_fm: u32,
    /// Optical fold F (2 linear optics, 4 plane mirror).
    pub optical_fold: u8,
    /// Laser edges per fringe k (4 for ×4 decoding).
    pub edges_per_fringe: u8,
    /// Measured axis code (0 X, 1 Y, 2 Z); see [`Hello::axis`].
    pub axis_code: u8,
}

impl Hello {
    /// The measured axis, if the code is one of 0, 1, 2.
    pub const fn axis(&self) -> Option<Axis> {
        Axis::from_code(self.axis_code)
    }
}

/// SAMPLE flags (bit set of the flags byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize)]
#[serde(transparent)]
pub struct SampleFlags(pub u8);

impl SampleFlags {
    /// bit0: laser signal below threshold (laser count not trustworthy).
    pub const BEAM_LOW: u8 = 0x01;
    /// bit1: illegal scale transition since the previous sample.
    pub const SCALE_QUAD_ERR: u8 = 0x02;
    /// bit2: illegal laser transition since the previous sample.
    pub const LASER_QUAD_ERR: u8 = 0x04;
    /// bit3: the board dropped samples.
    pub const OVERRUN: u8 = 0x08;

    /// Whether any bit of `mask` is set.
    pub const fn contains(self, mask: u8) -> bool {
        self.0 & mask != 0
    }

    /// Whether no flag is set (a clean sample).
    pub const fn is_clean(self) -> bool {
        self.0 == 0
    }
}

/// What latched a SAMPLE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Trigger {
    /// Code 0.
    Timer,
    /// Code 1.
    GratingEdge,
    /// Code 2.
    HostRequest,
}

/// SAMPLE (0x02, L = 22): both counters latched at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Sample {
    /// Device clock, microseconds.
    pub t_us: u64,
    /// The device's sample counter (+1 per latched sample since power-up).
    pub index: u32,
    /// Scale counter, wrapping two's complement, counts.
    pub scale_count: i32,
    /// Laser counter, wrapping two's complement, counts.
    pub laser_count: i32,
    /// Flags (see [`SampleFlags`]).
    pub flags: SampleFlags,
    /// Trigger source code (0 timer, 1 grating edge, 2 host request); see
    /// [`Sample::trigger`].
    pub trigger_code: u8,
}

impl Sample {
    /// The trigger source, if the code is known.
    pub const fn trigger(&self) -> Option<Trigger> {
        match self.trigger_code {
            0 => Some(Trigger::Timer),
            1 => Some(Trigger::GratingEdge),
            2 => Some(Trigger::HostRequest),
            _ => None,
        }
    }
}

/// ENV (0x03, L = 18): the air at the beam.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Env {
    /// Device clock, microseconds.
    pub t_us: u64,
    /// Air temperature, milli-°C.
    pub air_temp_mc: i32,
    /// Air pressure, pascal.
    pub pressure_pa: u32,
    /// Relative humidity in 0.1 % steps (per mille).
    pub rh_permille: u16,
}

/// MATERIAL (0x04, L = 9 + 4·N): material temperatures.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Material {
    /// Device clock, microseconds.
    pub t_us: u64,
    /// Sensor temperatures, milli-°C (1 to 8): 0 the scale, 1 the workpiece/table.
    pub temps_mc: Vec<i32>,
}

/// The kind of a MARK.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum MarkKind {
    /// 1: a run starts.
    RunStart,
    /// 2: the run ends.
    RunEnd,
    /// 3: target reached, dwell starts.
    TargetReached,
    /// 4: target left.
    TargetLeft,
    /// 5: direction reversal within the run.
    Reversal,
}

impl MarkKind {
    /// The kind with this code (1..=5).
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(MarkKind::RunStart),
            2 => Some(MarkKind::RunEnd),
            3 => Some(MarkKind::TargetReached),
            4 => Some(MarkKind::TargetLeft),
            5 => Some(MarkKind::Reversal),
            _ => None,
        }
    }

    /// The code on the wire.
    pub const fn code(self) -> u8 {
        match self {
            MarkKind::RunStart => 1,
            MarkKind::RunEnd => 2,
            MarkKind::TargetReached => 3,
            MarkKind::TargetLeft => 4,
            MarkKind::Reversal => 5,
        }
    }
}

/// MARK (0x05, L = 26): run structure from the motion controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Mark {
    /// Device clock, microseconds.
    pub t_us: u64,
    /// Kind code (1..=5); see [`Mark::kind`].
    pub kind_code: u8,
    /// Direction of travel, +1 or −1.
    pub direction: i8,
    /// Run number, from 1.
    pub run: u16,
    /// Target index.
    pub target: u16,
    /// Feed rate, µm/s.
    pub feed_um_s: u32,
    /// Line position along the first other axis, µm (Y when measuring X, X otherwise).
    pub line_first_um: i32,
    /// Line position along the second other axis, µm (Z when measuring X or Y, Y when
    /// measuring Z).
    pub line_second_um: i32,
}

impl Mark {
    /// The kind, if the code is known.
    pub const fn kind(&self) -> Option<MarkKind> {
        MarkKind::from_code(self.kind_code)
    }
}

/// RAW_AB (0x06, L = 11 + n): raw quadrature line states.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RawAb {
    /// Device clock of the first state, microseconds.
    pub t_us: u64,
    /// Time between states, µs.
    pub period_us: u16,
    /// One byte per state (1 to 229): bit0 scale A, bit1 scale B, bit2 laser A,
    /// bit3 laser B.
    pub states: Vec<u8>,
}

/// TEXT (0x7E, L = 1..240): a device log line.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Text {
    /// The line. Invalid UTF-8 from the device is replaced (U+FFFD).
    pub text: String,
    /// Whether the payload was not valid UTF-8 and had to be replaced.
    pub lossy: bool,
}

/// One decoded frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Frame {
    /// 0x01.
    Hello(Hello),
    /// 0x02.
    Sample(Sample),
    /// 0x03.
    Env(Env),
    /// 0x04.
    Material(Material),
    /// 0x05.
    Mark(Mark),
    /// 0x06.
    RawAb(RawAb),
    /// 0x7E.
    Text(Text),
}

impl Frame {
    /// The frame's type.
    pub const fn frame_type(&self) -> FrameType {
        match self {
            Frame::Hello(_) => FrameType::Hello,
            Frame::Sample(_) => FrameType::Sample,
            Frame::Env(_) => FrameType::Env,
            Frame::Material(_) => FrameType::Material,
            Frame::Mark(_) => FrameType::Mark,
            Frame::RawAb(_) => FrameType::RawAb,
            Frame::Text(_) => FrameType::Text,
        }
    }

    /// The device timestamp, µs (HELLO and TEXT carry none).
    pub const fn t_us(&self) -> Option<u64> {
        match self {
            Frame::Hello(_) | Frame::Text(_) => None,
            Frame::Sample(f) => Some(f.t_us),
            Frame::Env(f) => Some(f.t_us),
            Frame::Material(f) => Some(f.t_us),
            Frame::Mark(f) => Some(f.t_us),
            Frame::RawAb(f) => Some(f.t_us),
        }
    }
}

// ---------------------------------------------------------------------------------------
// Encoding

/// Encode `frame` with sequence number `seq` into a new buffer.
pub fn encode(frame: &Frame, seq: u16) -> Result<Vec<u8>, EncodeError> {
    let mut out = Vec::with_capacity(MAX_FRAME_LEN);
    encode_into(frame, seq, &mut out)?;
    Ok(out)
}

/// Append the encoding of `frame` with sequence number `seq` to `out`. On error `out` is
/// left unchanged.
pub fn encode_into(frame: &Frame, seq: u16, out: &mut Vec<u8>) -> Result<(), EncodeError> {
    let mut payload = [0u8; MAX_PAYLOAD_LEN];
    let len = write_payload(frame, &mut payload)?;
    push_frame(frame.frame_type().code(), seq, &payload[..len], out);
    Ok(())
}

/// Encode an arbitrary type byte and payload (no check of type or length against the
/// protocol): for tests of the decoder's rejection paths.
pub fn encode_raw(frame_type: u8, seq: u16, payload: &[u8]) -> Result<Vec<u8>, EncodeError> {
    if payload.len() > usize::from(u8::MAX) {
        return Err(EncodeError::PayloadTooLong(payload.len()));
    }
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len() + CRC_LEN);
    push_frame(frame_type, seq, payload, &mut out);
    Ok(out)
}

fn push_frame(frame_type: u8, seq: u16, payload: &[u8], out: &mut Vec<u8>) {
    let start = out.len();
    out.extend_from_slice(&SYNC);
    out.push(frame_type);
    // Callers guarantee payload.len() <= 255.
    out.push(u8::try_from(payload.len()).unwrap_or(u8::MAX));
    out.extend_from_slice(&seq.to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc16(&out[start + 2..]);
    out.extend_from_slice(&crc.to_le_bytes());
}

/// Little-endian writer into a fixed payload buffer.
struct Writer<'a> {
    buf: &'a mut [u8; MAX_PAYLOAD_LEN],
    len: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        // Payloads written here are at most 240 bytes by construction (checked counts).
        if let Some(dst) = self.buf.get_mut(self.len..self.len + bytes.len()) {
            dst.copy_from_slice(bytes);
            self.len += bytes.len();
        }
    }
}

fn write_payload(frame: &Frame, buf: &mut [u8; MAX_PAYLOAD_LEN]) -> Result<usize, EncodeError> {
    let mut w = Writer { buf, len: 0 };
    match frame {
        Frame::Hello(h) => {
            w.put(&[h.protocol_version]);
            w.put(&h.device_id.0);
            w.put(&h.grating_period_nm.to_le_bytes());
            w.put(&h.count_resolution_pm.to_le_bytes());
            w.put(&h.laser_wavelength_fm.to_le_bytes());
            w.put(&[h.optical_fold, h.edges_per_fringe, h.axis_code]);
        }
        Frame::Sample(s) => {
            w.put(&s.t_us.to_le_bytes());
            w.put(&s.index.to_le_bytes());
            w.put(&s.scale_count.to_le_bytes());
            w.put(&s.laser_count.to_le_bytes());
            w.put(&[s.flags.0, s.trigger_code]);
        }
        Frame::Env(e) => {
            w.put(&e.t_us.to_le_bytes());
            w.put(&e.air_temp_mc.to_le_bytes());
            w.put(&e.pressure_pa.to_le_bytes());
            w.put(&e.rh_permille.to_le_bytes());
        }
        Frame::Material(m) => {
            let n = m.temps_mc.len();
            if !(1..=MAX_MATERIAL_SENSORS).contains(&n) {
                return Err(EncodeError::SensorCount(n));
            }
            w.put(&m.t_us.to_le_bytes());
            w.put(&[n as u8]);
            for t in &m.temps_mc {
                w.put(&t.to_le_bytes());
            }
        }
        Frame::Mark(m) => {
            w.put(&m.t_us.to_le_bytes());
            w.put(&[m.kind_code]);
            w.put(&m.direction.to_le_bytes());
            w.put(&m.run.to_le_bytes());
            w.put(&m.target.to_le_bytes());
            w.put(&m.feed_um_s.to_le_bytes());
            w.put(&m.line_first_um.to_le_bytes());
            w.put(&m.line_second_um.to_le_bytes());
        }
        Frame::RawAb(r) => {
            let n = r.states.len();
            if !(1..=MAX_RAW_AB_STATES).contains(&n) {
                return Err(EncodeError::StateCount(n));
            }
            w.put(&r.t_us.to_le_bytes());
            w.put(&r.period_us.to_le_bytes());
            w.put(&[n as u8]);
            w.put(&r.states);
        }
        Frame::Text(t) => {
            let n = t.text.len();
            if !(1..=MAX_PAYLOAD_LEN).contains(&n) {
                return Err(EncodeError::TextLength(n));
            }
            w.put(t.text.as_bytes());
        }
    }
    Ok(w.len)
}

// ---------------------------------------------------------------------------------------
// Parsing

/// What [`parse_frame`] found at the start of its input.
#[derive(Debug, Clone, PartialEq)]
pub enum Parsed {
    /// A valid frame of `len` bytes.
    Frame {
        /// The frame's sequence number.
        seq: u16,
        /// The decoded payload.
        frame: Frame,
        /// Bytes the frame occupies on the wire.
        len: usize,
    },
    /// The bytes so far are a valid prefix; at least `needed` bytes in total are required
    /// before a decision.
    Incomplete {
        /// Total bytes needed for the next decision (not the number still missing).
        needed: usize,
    },
    /// Not a valid frame (the stream decoder then discards the first sync byte).
    Invalid(FrameError),
}

/// Parse one frame from bytes that start at a sync word. Decides as early as it can:
/// an unknown type after 3 bytes, an impossible length after 4, and the CRC and payload
/// counts once the whole frame is there.
///
/// Never panics, whatever the input.
pub fn parse_frame(bytes: &[u8]) -> Parsed {
    match bytes {
        [] => return Parsed::Incomplete { needed: 2 },
        [a] if *a == SYNC[0] => return Parsed::Incomplete { needed: 2 },
        [a, b, ..] if *a == SYNC[0] && *b == SYNC[1] => {}
        _ => return Parsed::Invalid(FrameError::NoSync),
    }
    let Some(&type_code) = bytes.get(2) else {
        return Parsed::Incomplete { needed: 3 };
    };
    let Some(frame_type) = FrameType::from_code(type_code) else {
        return Parsed::Invalid(FrameError::UnknownType(type_code));
    };
    let Some(&len) = bytes.get(3) else {
        return Parsed::Incomplete { needed: 4 };
    };
    if !frame_type.accepts_len(len) {
        return Parsed::Invalid(FrameError::BadLength {
            frame_type: type_code,
            len,
        });
    }
    let payload_end = HEADER_LEN + usize::from(len);
    let total = payload_end + CRC_LEN;
    let Some(frame_bytes) = bytes.get(..total) else {
        return Parsed::Incomplete { needed: total };
    };
    let expected = crc16(&frame_bytes[2..payload_end]);
    let got = u16::from_le_bytes([frame_bytes[payload_end], frame_bytes[payload_end + 1]]);
    if expected != got {
        return Parsed::Invalid(FrameError::InvalidChecksum { expected, got });
    }
    let seq = u16::from_le_bytes([frame_bytes[4], frame_bytes[5]]);
    match parse_payload(frame_type, &frame_bytes[HEADER_LEN..payload_end]) {
        Ok(frame) => Parsed::Frame {
            seq,
            frame,
            len: total,
        },
        Err(e) => Parsed::Invalid(e),
    }
}

/// Little-endian reader over a payload; every read is bounds-checked.
struct Reader<'a> {
    rest: &'a [u8],
    frame_type: u8,
    len: u8,
}

impl<'a> Reader<'a> {
    fn new(frame_type: FrameType, payload: &'a [u8]) -> Self {
        Reader {
            rest: payload,
            frame_type: frame_type.code(),
            len: u8::try_from(payload.len()).unwrap_or(u8::MAX),
        }
    }

    fn short(&self) -> FrameError {
        FrameError::BadLength {
            frame_type: self.frame_type,
            len: self.len,
        }
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], FrameError> {
        let (head, tail) = self.rest.split_first_chunk::<N>().ok_or(self.short())?;
        self.rest = tail;
        Ok(*head)
    }

    fn u8(&mut self) -> Result<u8, FrameError> {
        Ok(self.take::<1>()?[0])
    }
    fn i8(&mut self) -> Result<i8, FrameError> {
        Ok(i8::from_le_bytes(self.take()?))
    }
    fn u16(&mut self) -> Result<u16, FrameError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    fn u32(&mut self) -> Result<u32, FrameError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn i32(&mut self) -> Result<i32, FrameError> {
        Ok(i32::from_le_bytes(self.take()?))
    }
    fn u64(&mut self) -> Result<u64, FrameError> {
        Ok(u64::from_le_bytes(self.take()?))
    }

    /// The rest must have exactly `count` bytes per item.
    fn count_matches(&self, count: u8, item: usize) -> Result<(), FrameError> {
        if self.rest.len() == usize::from(count) * item {
            Ok(())
        } else {
            Err(FrameError::CountMismatch {
                frame_type: self.frame_type,
                count,
                len: self.len,
            })
        }
    }

    fn end(&self) -> Result<(), FrameError> {
        if self.rest.is_empty() {
            Ok(())
        } else {
            Err(self.short())
        }
    }
}

/// Decode a payload of a known type. Checks exact lengths and, for MATERIAL and RAW_AB,
/// that the count field agrees with the length.
pub fn parse_payload(frame_type: FrameType, payload: &[u8]) -> Result<Frame, FrameError> {
    let mut r = Reader::new(frame_type, payload);
    if !frame_type.accepts_len(r.len) || payload.len() > MAX_PAYLOAD_LEN {
        return Err(r.short());
    }
    let frame = match frame_type {
        FrameType::Hello => Frame::Hello(Hello {
            protocol_version: r.u8()?,
            device_id: DeviceId(r.take::<16>()?),
            grating_period_nm: r.u32()?,
            count_resolution_pm: r.u32()?,
            laser_wavelength_fm: r.u32()?,
            optical_fold: r.u8()?,
            edges_per_fringe: r.u8()?,
            axis_code: r.u8()?,
        }),
        FrameType::Sample => Frame::Sample(Sample {
            t_us: r.u64()?,
            index: r.u32()?,
            scale_count: r.i32()?,
            laser_count: r.i32()?,
            flags: SampleFlags(r.u8()?),
            trigger_code: r.u8()?,
        }),
        FrameType::Env => Frame::Env(Env {
            t_us: r.u64()?,
            air_temp_mc: r.i32()?,
            pressure_pa: r.u32()?,
            rh_permille: r.u16()?,
        }),
        FrameType::Material => {
            let t_us = r.u64()?;
            let n = r.u8()?;
            if n == 0 || usize::from(n) > MAX_MATERIAL_SENSORS {
                return Err(FrameError::CountMismatch {
                    frame_type: frame_type.code(),
                    count: n,
                    len: r.len,
                });
            }
            r.count_matches(n, 4)?;
            let mut temps_mc = Vec::with_capacity(usize::from(n));
            for _ in 0..n {
                temps_mc.push(r.i32()?);
            }
            Frame::Material(Material { t_us, temps_mc })
        }
        FrameType::Mark => Frame::Mark(Mark {
            t_us: r.u64()?,
            kind_code: r.u8()?,
            direction: r.i8()?,
            run: r.u16()?,
            target: r.u16()?,
            feed_um_s: r.u32()?,
            line_first_um: r.i32()?,
            line_second_um: r.i32()?,
        }),
        FrameType::RawAb => {
            let t_us = r.u64()?;
            let period_us = r.u16()?;
            let n = r.u8()?;
            if n == 0 || usize::from(n) > MAX_RAW_AB_STATES {
                return Err(FrameError::CountMismatch {
                    frame_type: frame_type.code(),
                    count: n,
                    len: r.len,
                });
            }
            r.count_matches(n, 1)?;
            let states = r.rest.to_vec();
            r.rest = &[];
            Frame::RawAb(RawAb {
                t_us,
                period_us,
                states,
            })
        }
        FrameType::Text => {
            let (text, lossy) = match std::str::from_utf8(r.rest) {
                Ok(s) => (s.to_owned(), false),
                Err(_) => (String::from_utf8_lossy(r.rest).into_owned(), true),
            };
            r.rest = &[];
            Frame::Text(Text { text, lossy })
        }
    };
    r.end()?;
    Ok(frame)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn crc_check_value() {
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn fixed_lengths_match_spec() {
        let h = Frame::Hello(Hello {
            protocol_version: 1,
            device_id: DeviceId::from_text("bench"),
            grating_period_nm: 20_000,
            count_resolution_pm: 100_000,
            laser_wavelength_fm: 632_991_354,
            optical_fold: 2,
            edges_per_fringe: 4,
            axis_code: 0,
        });
        assert_eq!(encode(&h, 0).unwrap().len(), 8 + 32);
        let s = Frame::Sample(Sample {
            t_us: 1,
            index: 2,
            scale_count: 3,
            laser_count: 4,
            flags: SampleFlags(0),
            trigger_code: 1,
        });
        assert_eq!(encode(&s, 0).unwrap().len(), 8 + 22);
        let e = Frame::Env(Env {
            t_us: 1,
            air_temp_mc: 20_000,
            pressure_pa: 101_325,
            rh_permille: 500,
        });
        assert_eq!(encode(&e, 0).unwrap().len(), 8 + 18);
        let m = Frame::Mark(Mark {
            t_us: 1,
            kind_code: 1,
            direction: -1,
            run: 1,
            target: 0,
            feed_um_s: 10_000,
            line_first_um: -5,
            line_second_um: 7,
        });
        assert_eq!(encode(&m, 0).unwrap().len(), 8 + 26);
    }

    #[test]
    fn known_sample_bytes() {
        // Hand-assembled SAMPLE, checked field by field against the spec's table.
        let s = Frame::Sample(Sample {
            t_us: 0x0102_0304_0506_0708,
            index: 0x0A0B_0C0D,
            scale_count: -2,
            laser_count: 0x1122_3344,
            flags: SampleFlags(SampleFlags::BEAM_LOW),
            trigger_code: 2,
        });
        let bytes = encode(&s, 0xBEEF).unwrap();
        let mut want = vec![0xAA, 0x55, 0x02, 22, 0xEF, 0xBE];
        want.extend_from_slice(&[8, 7, 6, 5, 4, 3, 2, 1]);
        want.extend_from_slice(&[0x0D, 0x0C, 0x0B, 0x0A]);
        want.extend_from_slice(&[0xFE, 0xFF, 0xFF, 0xFF]);
        want.extend_from_slice(&[0x44, 0x33, 0x22, 0x11]);
        want.extend_from_slice(&[0x01, 0x02]);
        let crc = crc16(&want[2..]);
        want.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(bytes, want);
        assert_eq!(
            parse_frame(&bytes),
            Parsed::Frame {
                seq: 0xBEEF,
                frame: s,
                len: 30
            }
        );
    }

    #[test]
    fn accepted_lengths() {
        let material: Vec<u8> = (0..=255u8)
            .filter(|&l| FrameType::Material.accepts_len(l))
            .collect();
        assert_eq!(material, vec![13, 17, 21, 25, 29, 33, 37, 41]);
        assert!(FrameType::RawAb.accepts_len(12));
        assert!(FrameType::RawAb.accepts_len(240));
        assert!(!FrameType::RawAb.accepts_len(11));
        assert!(!FrameType::RawAb.accepts_len(241));
        assert!(!FrameType::Text.accepts_len(0));
        assert!(FrameType::Text.accepts_len(240));
        assert!(!FrameType::Text.accepts_len(241));
    }

    #[test]
    fn count_mismatch_is_rejected_after_crc() {
        // MATERIAL with L = 13 (one sensor) but N = 2.
        let mut p = vec![0u8; 13];
        p[8] = 2;
        let bytes = encode_raw(0x04, 0, &p).unwrap();
        assert!(matches!(
            parse_frame(&bytes),
            Parsed::Invalid(FrameError::CountMismatch { count: 2, .. })
        ));
        // RAW_AB with L = 14 (3 states) but n = 2.
        let mut p = vec![0u8; 14];
        p[10] = 2;
        let bytes = encode_raw(0x06, 0, &p).unwrap();
        assert!(matches!(
            parse_frame(&bytes),
            Parsed::Invalid(FrameError::CountMismatch { count: 2, .. })
        ));
    }

    #[test]
    fn early_decisions() {
        assert_eq!(parse_frame(&[]), Parsed::Incomplete { needed: 2 });
        assert_eq!(parse_frame(&[0xAA]), Parsed::Incomplete { needed: 2 });
        assert_eq!(
            parse_frame(&[0xAA, 0x00]),
            Parsed::Invalid(FrameError::NoSync)
        );
        assert_eq!(
            parse_frame(&[0xAA, 0x55, 0x07]),
            Parsed::Invalid(FrameError::UnknownType(7))
        );
        assert_eq!(
            parse_frame(&[0xAA, 0x55, 0x02, 21]),
            Parsed::Invalid(FrameError::BadLength {
                frame_type: 2,
                len: 21
            })
        );
        assert_eq!(
            parse_frame(&[0xAA, 0x55, 0x02, 22]),
            Parsed::Incomplete { needed: 30 }
        );
    }

    #[test]
    fn invalid_utf8_text_is_kept_lossy() {
        let bytes = encode_raw(0x7E, 3, &[b'o', b'k', 0xFF]).unwrap();
        match parse_frame(&bytes) {
            Parsed::Frame {
                frame: Frame::Text(t),
                ..
            } => {
                assert!(t.lossy);
                assert!(t.text.starts_with("ok"));
            }
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn encoder_rejects_bad_counts() {
        let m = Frame::Material(Material {
            t_us: 0,
            temps_mc: vec![],
        });
        assert_eq!(encode(&m, 0), Err(EncodeError::SensorCount(0)));
        let r = Frame::RawAb(RawAb {
            t_us: 0,
            period_us: 1,
            states: vec![0; 230],
        });
        assert_eq!(encode(&r, 0), Err(EncodeError::StateCount(230)));
        let t = Frame::Text(Text {
            text: String::new(),
            lossy: false,
        });
        assert_eq!(encode(&t, 0), Err(EncodeError::TextLength(0)));
    }
}
