//! RAW_AB frames through the whole decoder: ×4 counts, illegal transitions, carry-over
//! between frames, reset after a seq gap.

use errmap_drivers::decode_all;

use crate::common::{Stream, raw_ab};

// State bytes: bit0 scale A, bit1 scale B, bit2 laser A, bit3 laser B.
// Scale (A,B): (0,0)=0, (1,0)=1, (1,1)=3, (0,1)=2.
const S_FWD: [u8; 4] = [0, 1, 3, 2];
// Laser (A,B) in bits 2–3: (0,0)=0, (1,0)=4, (1,1)=12, (0,1)=8.
const L_FWD: [u8; 4] = [0, 4, 12, 8];

#[test]
fn forward_scale_and_reverse_laser() {
    // Scale forward 8 steps, laser reverse 8 steps, in one frame.
    let states: Vec<u8> = (0..9)
        .map(|i| S_FWD[i % 4] | L_FWD[(4 - i % 4) % 4])
        .collect();
    let mut s = Stream::new(0);
    s.frame(&raw_ab(0, &states));
    let (_, stats, _) = decode_all(&s.bytes);
    assert_eq!(stats.raw_ab.scale_counts, 8);
    assert_eq!(stats.raw_ab.laser_counts, -8);
    assert_eq!(
        (stats.raw_ab.scale_illegal, stats.raw_ab.laser_illegal),
        (0, 0)
    );
}

#[test]
fn illegal_transitions_are_counted_not_guessed() {
    // Scale: 0 → 3 (both lines change) → 2 (+1) ; laser stays still.
    let mut s = Stream::new(0);
    s.frame(&raw_ab(1000, &[0, 3, 2, 2]));
    let (_, stats, _) = decode_all(&s.bytes);
    assert_eq!(stats.raw_ab.scale_illegal, 1);
    assert_eq!(stats.raw_ab.scale_counts, 1);
    assert_eq!(stats.raw_ab.laser_counts, 0);
    let p = stats.problems.get("illegal_transition").unwrap();
    // Reported at the state's own time: t_us + 1 · period (10 µs).
    assert_eq!(p.first[0].pos.t_us, Some(1010));
}

#[test]
fn state_carries_over_between_frames() {
    let mut s = Stream::new(0);
    s.frame(&raw_ab(0, &[0, 1])); // +1
    s.frame(&raw_ab(20, &[3, 2])); // 1 → 3 is +1 (carried over), 3 → 2 +1
    let (_, stats, _) = decode_all(&s.bytes);
    assert_eq!(stats.raw_ab.scale_counts, 3);
    assert_eq!(stats.raw_ab.scale_illegal, 0);
}

#[test]
fn seq_gap_resets_the_state() {
    let mut s = Stream::new(0);
    s.frame(&raw_ab(0, &[0, 1])); // +1, state 1
    s.lose(1);
    // Without the reset 1 → 2 would be illegal; after a gap the first state counts nothing.
    s.frame(&raw_ab(40, &[2, 0]));
    let (_, stats, _) = decode_all(&s.bytes);
    assert_eq!(stats.raw_ab.scale_counts, 1 + 1); // 2 → 0 is +1
    assert_eq!(stats.raw_ab.scale_illegal, 0);
    assert_eq!(stats.seq_gaps, 1);
}

#[test]
fn gap_on_another_frame_type_also_resets() {
    let mut s = Stream::new(0);
    s.frame(&raw_ab(0, &[0, 1]));
    s.lose(2);
    s.frame(&crate::common::sample(5, 0, 0, 0, 0));
    s.frame(&raw_ab(40, &[2, 0]));
    let (_, stats, _) = decode_all(&s.bytes);
    assert_eq!(stats.raw_ab.scale_illegal, 0);
    assert_eq!(stats.raw_ab.scale_counts, 2);
}
