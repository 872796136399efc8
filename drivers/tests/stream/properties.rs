//! Property tests: round trip, random bytes never panic, arbitrary read splits, and a
//! bounded fuzz-style mutation test (runs in CI).

use errmap_drivers::frame::encode;
use errmap_drivers::{Decoder, Event};
use proptest::prelude::*;

use crate::common::{arb_frame, arb_session_frame, decode_chunked, frame_bytes, session_split};

/// The byte accounting every finished decode must satisfy.
fn assert_accounting(events: &[Event], d: &Decoder) {
    let s = d.stats();
    assert_eq!(
        s.bytes,
        frame_bytes(events) + s.bytes_skipped + s.truncated_tail_bytes,
        "bytes = frames + skipped + tail"
    );
    assert_eq!(
        s.frames.total(),
        events
            .iter()
            .filter(|e| matches!(e, Event::Frame(_)))
            .count() as u64
    );
    assert!(s.resyncs <= s.bytes_skipped);
    assert_eq!(s.resyncs == 0, s.bytes_skipped == 0);
    assert!(s.crc_failures <= s.bytes_skipped);
}

/// A mutation of a byte stream.
#[derive(Debug, Clone)]
enum Mutation {
    FlipBit(usize, u8),
    Delete(usize),
    Insert(usize, u8),
    InsertSync(usize),
    Duplicate(usize, usize),
}

fn arb_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(p, b)| Mutation::FlipBit(p, b)),
        any::<usize>().prop_map(Mutation::Delete),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        any::<usize>().prop_map(Mutation::InsertSync),
        (any::<usize>(), 1usize..64).prop_map(|(p, n)| Mutation::Duplicate(p, n)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    let at = |p: usize, len: usize| p % len;
    match *m {
        Mutation::FlipBit(p, b) => {
            let i = at(p, bytes.len());
            bytes[i] ^= 1 << b;
        }
        Mutation::Delete(p) => {
            let i = at(p, bytes.len());
            bytes.remove(i);
        }
        Mutation::Insert(p, v) => {
            let i = at(p, bytes.len() + 1);
            bytes.insert(i, v);
        }
        Mutation::InsertSync(p) => {
            let i = at(p, bytes.len() + 1);
            bytes.splice(i..i, [0xAA, 0x55]);
        }
        Mutation::Duplicate(p, n) => {
            let i = at(p, bytes.len());
            let end = (i + n).min(bytes.len());
            let copy = bytes[i..end].to_vec();
            bytes.splice(end..end, copy);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// encode → decode gives back every frame, in order, with its seq and offset, and no
    /// problem at all.
    #[test]
    fn round_trip(frames in proptest::collection::vec(arb_frame(), 0..30), start in any::<u16>()) {
        let mut bytes = Vec::new();
        let mut expected = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            let seq = start.wrapping_add(i as u16);
            let enc = encode(f, seq).unwrap();
            expected.push(Event::Frame(errmap_drivers::DecodedFrame {
                offset: bytes.len() as u64,
                len: enc.len(),
                seq,
                lost_before: 0,
                frame: f.clone(),
            }));
            bytes.extend(enc);
        }
        let mut d = Decoder::new();
        let mut got = d.push(&bytes);
        got.extend(d.finish());
        prop_assert_eq!(&got, &expected);
        let s = d.stats();
        prop_assert_eq!(s.frames.total(), frames.len() as u64);
        prop_assert_eq!((s.bytes_skipped, s.resyncs, s.crc_failures, s.truncated_tail_bytes), (0, 0, 0, 0));
        prop_assert_eq!((s.seq_gaps, s.frames_lost), (0, 0));
    }

    /// Arbitrary bytes never panic and are fully accounted for.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048), chunk in 1usize..300) {
        let (events, d) = decode_chunked(&bytes, &[chunk]);
        assert_accounting(&events, &d);
        // The session layer too.
        let (rows, stats, _) = errmap_drivers::decode_all(&bytes);
        prop_assert_eq!(rows.len() as u64, stats.rows);
    }

    /// Random bytes rich in sync words and plausible headers never panic either.
    #[test]
    fn sync_rich_bytes_never_panic(
        raw in proptest::collection::vec(any::<u8>(), 0..2048),
        chunk in 1usize..300,
    ) {
        // Most bytes become sync, type or length bytes of plausible headers.
        const ALPHABET: [u8; 8] = [0xAA, 0x55, 0x02, 22, 0x7E, 0x06, 0x04, 13];
        let bytes: Vec<u8> = raw
            .iter()
            .map(|&b| if b < 224 { ALPHABET[usize::from(b) % ALPHABET.len()] } else { b })
            .collect();
        let (events, d) = decode_chunked(&bytes, &[chunk]);
        assert_accounting(&events, &d);
        let _ = errmap_drivers::decode_all(&bytes);
    }

    /// Output is identical however the input is split across pushes (frames, problems,
    /// rows and statistics), for streams with garbage and corruption.
    #[test]
    fn read_splits_do_not_matter(
        frames in proptest::collection::vec(arb_session_frame(), 0..40),
        mutations in proptest::collection::vec(arb_mutation(), 0..6),
        cuts in proptest::collection::vec(any::<usize>(), 0..20),
        chunks in proptest::collection::vec(1usize..64, 1..8),
    ) {
        let mut bytes = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            bytes.extend(encode(f, i as u16).unwrap());
        }
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let (whole, dw) = decode_chunked(&bytes, &[usize::MAX]);
        let (split, ds) = decode_chunked(&bytes, &chunks);
        prop_assert_eq!(&whole, &split);
        prop_assert_eq!(dw.stats(), ds.stats());
        let cuts: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
        let (a, sa) = session_split(&bytes, &[]);
        let (b, sb) = session_split(&bytes, &cuts);
        // Debug text, so that NaN from absurd ENV values compares equal to itself.
        prop_assert_eq!(format!("{a:?}"), format!("{b:?}"));
        prop_assert_eq!(format!("{:?}", sa.stats()), format!("{:?}", sb.stats()));
    }
}

proptest! {
    // Fuzz-style: valid session streams under random mutations, random chunking. Bounded
    // so that it runs in CI in well under a second in debug builds.
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn fuzz_mutated_streams(
        frames in proptest::collection::vec(arb_session_frame(), 1..60),
        mutations in proptest::collection::vec(arb_mutation(), 1..12),
        chunk in 1usize..97,
    ) {
        let mut bytes = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            bytes.extend(encode(f, i as u16).unwrap());
        }
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let (events, d) = decode_chunked(&bytes, &[chunk]);
        assert_accounting(&events, &d);
        let s = d.stats();
        // Every problem is logged with a position inside the stream.
        for (_, summary) in s.problems.iter() {
            for p in &summary.first {
                prop_assert!(p.pos.offset <= s.bytes);
            }
        }
        let (rows, stats, _) = errmap_drivers::decode_all(&bytes);
        prop_assert_eq!(rows.len() as u64, stats.rows);
        prop_assert!(stats.rows <= stats.frames.sample);
    }
}
