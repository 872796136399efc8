//! One test per corruption kind: the decoder reports it, resynchronises, and goes on.

use errmap_drivers::frame::{Frame, encode, encode_raw};
use errmap_drivers::{Event, ProblemKind};

use crate::common::{Stream, decode_chunked, frames_of, hello, sample, text};

fn samples(s: &mut Stream, from: u32, n: u32) {
    for i in from..from + n {
        s.frame(&sample(
            u64::from(i) * 1000,
            i,
            i as i32 * 7,
            i as i32 * 9,
            0,
        ));
    }
}

fn problems(events: &[Event]) -> Vec<ProblemKind> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Problem(p) => Some(p.kind.clone()),
            Event::Frame(_) => None,
        })
        .collect()
}

#[test]
fn bit_flip_is_a_crc_failure_and_following_frames_decode() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 5);
    let (off, len) = s.frames[2];
    // Flip a bit in the payload's t_us (no sync word can appear there).
    s.bytes[off + 7] ^= 0x10;
    let (events, d) = decode_chunked(&s.bytes, &[usize::MAX]);
    let st = d.stats();
    assert_eq!(st.crc_failures, 1);
    assert_eq!(st.resyncs, 1);
    assert_eq!(st.bytes_skipped, len as u64);
    assert_eq!(st.frames.sample, 4);
    assert_eq!((st.seq_gaps, st.frames_lost), (1, 1));
    let seqs: Vec<u16> = frames_of(&events).iter().map(|(q, _)| *q).collect();
    assert_eq!(seqs, vec![0, 1, 3, 4]);
    let kinds = problems(&events);
    assert!(matches!(
        kinds[0],
        ProblemKind::CrcFailure {
            frame_type: 2,
            header_seq: 2,
            ..
        }
    ));
    assert_eq!(kinds[1], ProblemKind::BytesSkipped { bytes: len as u64 });
    assert_eq!(
        kinds[2],
        ProblemKind::SeqGap {
            expected: 2,
            got: 3,
            lost: 1
        }
    );
    // The CRC failure is reported at the damaged frame's offset.
    let crc = st.problems.get("crc_failure").unwrap();
    assert_eq!(crc.first[0].pos.offset, off as u64);
    assert_eq!(crc.first[0].pos.seq, Some(1));
    assert_eq!(crc.first[0].pos.t_us, Some(1000));
}

#[test]
fn garbage_between_frames_is_skipped() {
    let mut s = Stream::new(10);
    samples(&mut s, 0, 2);
    let garbage = [0x00, 0x13, 0xAA, 0x00, 0x55, 0xFF, 0xAA];
    s.raw(&garbage);
    samples(&mut s, 2, 2);
    let (events, d) = decode_chunked(&s.bytes, &[3]);
    let st = d.stats();
    assert_eq!(st.bytes_skipped, garbage.len() as u64);
    assert_eq!(st.resyncs, 1);
    assert_eq!(st.crc_failures, 0);
    assert_eq!(st.frames.sample, 4);
    assert_eq!(st.seq_gaps, 0);
    let skipped = st.problems.get("bytes_skipped").unwrap();
    assert_eq!(
        skipped.first[0].pos.offset,
        s.frames[2].0 as u64 - garbage.len() as u64
    );
    assert_eq!(frames_of(&events).len(), 4);
}

#[test]
fn stream_starting_mid_frame_resyncs() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 3);
    let cut = 5;
    let (events, d) = decode_chunked(&s.bytes[cut..], &[usize::MAX]);
    let st = d.stats();
    assert_eq!(st.frames.sample, 2);
    assert_eq!(st.bytes_skipped, (s.frames[0].1 - cut) as u64);
    assert_eq!(st.resyncs, 1);
    assert_eq!(frames_of(&events)[0].0, 1);
}

#[test]
fn truncated_tail_is_counted() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 3);
    let keep = s.bytes.len() - 11;
    let (events, d) = decode_chunked(&s.bytes[..keep], &[7]);
    let st = d.stats();
    assert_eq!(st.frames.sample, 2);
    assert_eq!(st.truncated_tail_bytes, (s.frames[2].1 - 11) as u64);
    assert_eq!(st.bytes_skipped, 0);
    assert_eq!(st.resyncs, 0);
    assert_eq!(
        problems(&events),
        vec![ProblemKind::TruncatedTail {
            bytes: (s.frames[2].1 - 11) as u64
        }]
    );
    let tail = st.problems.get("truncated_tail").unwrap();
    assert_eq!(tail.first[0].pos.offset, s.frames[2].0 as u64);
}

#[test]
fn lone_sync_byte_at_end_is_a_truncated_tail() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 1);
    s.raw(&[0xAA]);
    let (_, d) = decode_chunked(&s.bytes, &[usize::MAX]);
    assert_eq!(d.stats().truncated_tail_bytes, 1);
}

#[test]
fn dropped_frames_are_seq_gaps() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 3);
    s.lose(1);
    samples(&mut s, 4, 2);
    s.lose(3);
    samples(&mut s, 9, 1);
    let (events, d) = decode_chunked(&s.bytes, &[usize::MAX]);
    let st = d.stats();
    assert_eq!(st.seq_gaps, 2);
    assert_eq!(st.frames_lost, 4);
    assert_eq!(st.bytes_skipped, 0);
    let lost: Vec<u32> = events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(f) => Some(f.lost_before),
            Event::Problem(_) => None,
        })
        .collect();
    assert_eq!(lost, vec![0, 0, 0, 1, 0, 3]);
    let gap = st.problems.get("seq_gap").unwrap();
    assert_eq!(gap.first[0].pos.seq, Some(4));
    assert_eq!(gap.first[0].pos.offset, s.frames[3].0 as u64);
}

#[test]
fn seq_wrap_is_not_a_gap() {
    let mut s = Stream::new(65_534);
    samples(&mut s, 0, 4);
    let (_, d) = decode_chunked(&s.bytes, &[usize::MAX]);
    assert_eq!(d.stats().seq_gaps, 0);
    assert_eq!(d.stats().frames.sample, 4);
}

#[test]
fn frame_starting_inside_a_rejected_frame_is_found() {
    // A false header claims a 200-byte TEXT frame; the real frames lie inside it. When
    // the false candidate fails its CRC, only its first byte is discarded and the real
    // frames are found.
    let mut s = Stream::new(0);
    s.raw(&[0xAA, 0x55, 0x7E, 200]);
    samples(&mut s, 0, 8);
    let (events, d) = decode_chunked(&s.bytes, &[13]);
    let st = d.stats();
    assert_eq!(st.frames.sample, 8);
    assert_eq!(st.crc_failures, 1);
    assert_eq!(st.bytes_skipped, 4);
    assert_eq!(st.resyncs, 1);
    assert_eq!(st.truncated_tail_bytes, 0);
    assert_eq!(frames_of(&events).len(), 8);
}

#[test]
fn frames_inside_a_candidate_cut_by_the_end_of_capture_are_found() {
    // Same false header, but the capture ends before the 208 bytes it claims: the frames
    // inside are complete and valid, so they are decoded, not counted as a truncated tail.
    let mut s = Stream::new(0);
    s.raw(&[0xAA, 0x55, 0x7E, 200]);
    samples(&mut s, 0, 6);
    let cut = s.bytes[4..20].to_vec();
    s.raw(&cut); // a real truncated frame at the very end
    for chunk in [1, 13, usize::MAX] {
        let (events, d) = decode_chunked(&s.bytes, &[chunk]);
        let st = d.stats();
        assert_eq!(st.frames.sample, 6);
        assert_eq!(st.crc_failures, 0);
        assert_eq!(st.bytes_skipped, 4);
        assert_eq!(st.resyncs, 1);
        assert_eq!(st.truncated_tail_bytes, 16);
        assert_eq!(st.problems.count("abandoned_candidate"), 1);
        assert_eq!(frames_of(&events).len(), 6);
    }
}

#[test]
fn frame_embedded_in_a_corrupted_frame_is_found() {
    // A TEXT frame whose payload is a complete SAMPLE frame; the outer CRC is damaged.
    let inner = encode(&sample(5, 5, 5, 5, 0), 77).unwrap();
    let mut outer = encode_raw(0x7E, 76, &inner).unwrap();
    let n = outer.len();
    outer[n - 1] ^= 0xFF;
    let (events, d) = decode_chunked(&outer, &[usize::MAX]);
    let f = frames_of(&events);
    assert_eq!(f.len(), 1);
    assert_eq!(f[0].0, 77);
    let st = d.stats();
    assert_eq!(st.crc_failures, 1);
    // The outer header (6 bytes) before the inner frame and the outer CRC after it.
    assert_eq!(st.bytes_skipped, 8);
    assert_eq!(st.resyncs, 2);
    // Intact, the outer TEXT frame is one valid frame and the inner one is payload.
    let mut intact = encode_raw(0x7E, 76, &inner).unwrap();
    intact.extend(encode(&text("after"), 77).unwrap());
    let (events, _) = decode_chunked(&intact, &[usize::MAX]);
    assert_eq!(frames_of(&events).len(), 2);
}

#[test]
fn unknown_type_and_bad_length_resync() {
    let mut s = Stream::new(0);
    samples(&mut s, 0, 1);
    s.raw(&[0xAA, 0x55, 0x09, 4, 0, 0]);
    samples(&mut s, 1, 1);
    s.raw(&[0xAA, 0x55, 0x02, 21]);
    samples(&mut s, 2, 1);
    let (events, d) = decode_chunked(&s.bytes, &[1]);
    let st = d.stats();
    assert_eq!(st.frames.sample, 3);
    assert_eq!(st.crc_failures, 0);
    assert_eq!(st.bytes_skipped, 10);
    assert_eq!(st.resyncs, 2);
    let kinds = problems(&events);
    assert!(kinds.contains(&ProblemKind::UnknownType { frame_type: 9 }));
    assert!(kinds.contains(&ProblemKind::BadLength {
        frame_type: 2,
        len: 21,
        count: None
    }));
}

#[test]
fn material_count_not_matching_length_is_rejected() {
    // L = 17 (two sensors) but N = 3, with a valid CRC.
    let mut p = vec![0u8; 17];
    p[8] = 3;
    let mut bytes = encode_raw(0x04, 0, &p).unwrap();
    bytes.extend(encode(&hello(0), 1).unwrap());
    let (events, d) = decode_chunked(&bytes, &[usize::MAX]);
    assert_eq!(d.stats().frames.material, 0);
    assert_eq!(d.stats().frames.hello, 1);
    assert!(problems(&events).contains(&ProblemKind::BadLength {
        frame_type: 4,
        len: 17,
        count: Some(3)
    }));
}

#[test]
fn raw_ab_count_not_matching_length_is_rejected() {
    let mut p = vec![0u8; 15];
    p[10] = 3; // L = 15 means 4 states
    let bytes = encode_raw(0x06, 0, &p).unwrap();
    let (_, d) = decode_chunked(&bytes, &[usize::MAX]);
    assert_eq!(d.stats().frames.raw_ab, 0);
    assert_eq!(d.stats().problems.count("bad_length"), 1);
}

#[test]
fn invalid_utf8_text_is_kept_and_reported() {
    let bytes = encode_raw(0x7E, 0, &[b'h', 0xC3, b'i']).unwrap();
    let (events, d) = decode_chunked(&bytes, &[usize::MAX]);
    assert_eq!(d.stats().frames.text, 1);
    assert_eq!(d.stats().problems.count("invalid_text"), 1);
    assert!(matches!(&frames_of(&events)[0].1, Frame::Text(t) if t.lossy));
}
