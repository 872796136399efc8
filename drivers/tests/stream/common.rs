//! Helpers shared by the stream tests: frame builders, a stream builder that numbers
//! frames, chunked decoding, and proptest strategies for valid frames.

use errmap_drivers::frame::{
    DeviceId, Env, Frame, Hello, Mark, Material, RawAb, Sample, SampleFlags, Text, encode,
};
use errmap_drivers::{Decoder, Event, SessionDecoder, SessionEvent};
use proptest::prelude::*;

pub(crate) const LAMBDA_FM: u32 = 632_991_354;

pub(crate) fn hello(axis: u8) -> Frame {
    Frame::Hello(Hello {
        protocol_version: 1,
        device_id: DeviceId::from_text("SIM-BENCH-01"),
        grating_period_nm: 20_000,
        count_resolution_pm: 50_000,
        laser_wavelength_fm: LAMBDA_FM,
        optical_fold: 4,
        edges_per_fringe: 4,
        axis_code: axis,
    })
}

pub(crate) fn sample(t_us: u64, index: u32, scale: i32, laser: i32, flags: u8) -> Frame {
    Frame::Sample(Sample {
        t_us,
        index,
        scale_count: scale,
        laser_count: laser,
        flags: SampleFlags(flags),
        trigger_code: 1,
    })
}

pub(crate) fn env(t_us: u64, air_temp_mc: i32, pressure_pa: u32, rh_permille: u16) -> Frame {
    Frame::Env(Env {
        t_us,
        air_temp_mc,
        pressure_pa,
        rh_permille,
    })
}

pub(crate) fn material(t_us: u64, temps_mc: &[i32]) -> Frame {
    Frame::Material(Material {
        t_us,
        temps_mc: temps_mc.to_vec(),
    })
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn mark(
    t_us: u64,
    kind: u8,
    direction: i8,
    run: u16,
    target: u16,
    feed_um_s: u32,
    line_first_um: i32,
    line_second_um: i32,
) -> Frame {
    Frame::Mark(Mark {
        t_us,
        kind_code: kind,
        direction,
        run,
        target,
        feed_um_s,
        line_first_um,
        line_second_um,
    })
}

pub(crate) fn raw_ab(t_us: u64, states: &[u8]) -> Frame {
    Frame::RawAb(RawAb {
        t_us,
        period_us: 10,
        states: states.to_vec(),
    })
}

pub(crate) fn text(s: &str) -> Frame {
    Frame::Text(Text {
        text: s.to_owned(),
        lossy: false,
    })
}

/// Builds a byte stream, numbering frames with consecutive seqs.
#[derive(Debug, Default)]
pub(crate) struct Stream {
    pub bytes: Vec<u8>,
    pub seq: u16,
    /// (offset, length) of every frame pushed.
    pub frames: Vec<(usize, usize)>,
}

impl Stream {
    pub(crate) fn new(start_seq: u16) -> Self {
        Stream {
            seq: start_seq,
            ..Stream::default()
        }
    }

    pub(crate) fn frame(&mut self, f: &Frame) -> &mut Self {
        let bytes = encode(f, self.seq).expect("valid test frame");
        self.frames.push((self.bytes.len(), bytes.len()));
        self.bytes.extend_from_slice(&bytes);
        self.seq = self.seq.wrapping_add(1);
        self
    }

    /// Pretend `n` frames were sent but lost.
    pub(crate) fn lose(&mut self, n: u16) -> &mut Self {
        self.seq = self.seq.wrapping_add(n);
        self
    }

    pub(crate) fn raw(&mut self, bytes: &[u8]) -> &mut Self {
        self.bytes.extend_from_slice(bytes);
        self
    }
}

/// Decode `bytes` pushed in chunks of the given sizes (cycled; 0 means 1), then finish.
pub(crate) fn decode_chunked(bytes: &[u8], chunks: &[usize]) -> (Vec<Event>, Decoder) {
    let mut d = Decoder::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    let mut i = 0;
    while !rest.is_empty() {
        let n = chunks
            .get(i % chunks.len().max(1))
            .copied()
            .unwrap_or(rest.len());
        let n = n.clamp(1, rest.len());
        out.extend(d.push(&rest[..n]));
        rest = &rest[n..];
        i += 1;
    }
    out.extend(d.finish());
    (out, d)
}

/// Session-decode `bytes` split at the given cut points (sorted, deduplicated here).
pub(crate) fn session_split(bytes: &[u8], cuts: &[usize]) -> (Vec<SessionEvent>, SessionDecoder) {
    let mut cuts: Vec<usize> = cuts.iter().map(|&c| c.min(bytes.len())).collect();
    cuts.sort_unstable();
    cuts.dedup();
    let mut d = SessionDecoder::new();
    let mut out = Vec::new();
    let mut start = 0;
    for c in cuts.into_iter().chain(std::iter::once(bytes.len())) {
        d.push_with(&bytes[start..c], &mut |e| out.push(e));
        start = c;
    }
    d.finish_with(&mut |e| out.push(e));
    (out, d)
}

/// Rows of a session decode of the whole stream at once.
pub(crate) fn rows(
    bytes: &[u8],
) -> (
    Vec<errmap_drivers::SessionRow>,
    errmap_drivers::DecoderStats,
) {
    let (rows, stats, _) = errmap_drivers::decode_all(bytes);
    (rows, stats)
}

/// The frames (with seq) among events.
pub(crate) fn frames_of(events: &[Event]) -> Vec<(u16, Frame)> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(f) => Some((f.seq, f.frame.clone())),
            Event::Problem(_) => None,
        })
        .collect()
}

/// Sum of the lengths of the valid frames among events.
pub(crate) fn frame_bytes(events: &[Event]) -> u64 {
    events
        .iter()
        .map(|e| match e {
            Event::Frame(f) => f.len as u64,
            Event::Problem(_) => 0,
        })
        .sum()
}

/// Every valid frame of protocol version 1.
pub(crate) fn arb_frame() -> impl Strategy<Value = Frame> {
    let hello = (
        any::<u8>(),
        any::<[u8; 16]>(),
        any::<u32>(),
        any::<u32>(),
        any::<u32>(),
        any::<u8>(),
        any::<u8>(),
        any::<u8>(),
    )
        .prop_map(|(v, id, g, r, l, f, k, a)| {
            Frame::Hello(Hello {
                protocol_version: v,
                device_id: DeviceId(id),
                grating_period_nm: g,
                count_resolution_pm: r,
                laser_wavelength_fm: l,
                optical_fold: f,
                edges_per_fringe: k,
                axis_code: a,
            })
        });
    let sample = (
        any::<u64>(),
        any::<u32>(),
        any::<i32>(),
        any::<i32>(),
        any::<u8>(),
        any::<u8>(),
    )
        .prop_map(|(t, i, s, l, f, tr)| {
            Frame::Sample(Sample {
                t_us: t,
                index: i,
                scale_count: s,
                laser_count: l,
                flags: SampleFlags(f),
                trigger_code: tr,
            })
        });
    let env = (any::<u64>(), any::<i32>(), any::<u32>(), any::<u16>())
        .prop_map(|(t, a, p, h)| env(t, a, p, h));
    let material = (any::<u64>(), proptest::collection::vec(any::<i32>(), 1..=8))
        .prop_map(|(t, v)| material(t, &v));
    let mark = (
        any::<u64>(),
        any::<u8>(),
        any::<i8>(),
        any::<u16>(),
        any::<u16>(),
        any::<u32>(),
        any::<i32>(),
        any::<i32>(),
    )
        .prop_map(|(t, k, d, r, g, f, a, b)| mark(t, k, d, r, g, f, a, b));
    let raw = (
        any::<u64>(),
        any::<u16>(),
        proptest::collection::vec(any::<u8>(), 1..=229),
    )
        .prop_map(|(t, p, s)| {
            Frame::RawAb(RawAb {
                t_us: t,
                period_us: p,
                states: s,
            })
        });
    let text = "\\PC{1,60}".prop_map(|s| text(&s));
    prop_oneof![hello, sample, env, material, mark, raw, text]
}

/// Session-like frames (mostly SAMPLEs with a plausible HELLO), for stream-level tests.
pub(crate) fn arb_session_frame() -> impl Strategy<Value = Frame> {
    prop_oneof![
        8 => (any::<u32>(), -100_000i32..100_000, -100_000i32..100_000, prop_oneof![3 => Just(0u8), 1 => any::<u8>()])
            .prop_map(|(i, s, l, f)| sample(u64::from(i) * 1000, i, s, l, f)),
        1 => (0u8..3).prop_map(hello),
        1 => (any::<u32>(), 15_000i32..25_000, 90_000u32..110_000, 0u16..1000)
            .prop_map(|(t, a, p, h)| env(u64::from(t), a, p, h)),
        1 => (1u8..=5, prop_oneof![Just(1i8), Just(-1i8)], 0u16..4, 0u16..10)
            .prop_map(|(k, d, r, g)| mark(0, k, d, r, g, 10_000, 1000, -2000)),
        1 => proptest::collection::vec(0u8..16, 1..40).prop_map(|s| raw_ab(0, &s)),
        1 => Just(material(5, &[20_000, 20_100])),
    ]
}
