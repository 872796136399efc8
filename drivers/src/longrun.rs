//! A long capture for benchmarks and soak tests: the simulated board of [`crate::sim`]
//! measuring line after line, written straight to a writer so that a capture of any length
//! is generated in memory bounded by one line's stream.
//!
//! Each *block* is one complete simulated session along X (HELLO, ENV/MATERIAL once a
//! second, SAMPLE frames at `sample_hz`, MARKs at every run event): 11 targets 0…500 mm,
//! 5 runs out and back. Block `k` measures the line (y, z) = (25·(k mod 8), 25·(⌊k/8⌋ mod 4)) mm
//! with the controller-timing seed `seed + k`, so a long capture revisits 32 lines and
//! every (line, target) group keeps growing — what a day-long drift test looks like to the
//! reduction. The blocks are joined on the wire as one board running for the whole day
//! would send them: one HELLO at the start, and after it every frame re-encoded with the
//! sequence number, clock, sample counter and run number continuing from the block
//! before — so `(run, sample)` stays unique in the session, as `docs/session-table.md` requires.
//!
//! The truth is a smooth, known error field (a linear scale error plus a line-dependent
//! offset), e(x, y, z) = 1 µm/m·x + 0.02·y + 0.01·z µm (x, y, z in mm), so the error table
//! of a generated capture can be checked against it. Cost: one line's simulation per block,
//! ≈ 0.8 MB of frames at the default 1 kHz; no fault injection, no byte-budget drops
//! (4 Mbaud line, 1 MiB FIFO).

use std::io::{self, Write};

use crate::frame::{Axis, Frame, Parsed, encode, parse_frame};
use crate::sim::{Device, Faults, Plan, Truth, TruthQuery, simulate};

/// The known error field of generated captures, µm at (x, y, z) mm.
pub fn long_truth_um(pos_mm: [f64; 3]) -> f64 {
    1e-3 * pos_mm[0] + 0.02 * pos_mm[1] + 0.01 * pos_mm[2]
}

struct Field;

impl Truth for Field {
    fn error_um(&mut self, q: &TruthQuery) -> f64 {
        long_truth_um(q.pos_mm)
    }
}

/// What [`write_long_capture`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct LongCapture {
    /// Bytes written.
    pub bytes: u64,
    /// Blocks (simulated line sessions) written.
    pub blocks: u64,
    /// SAMPLE frames written.
    pub samples: u64,
}

/// The plan of block `k` (see the module docs).
pub fn block_plan(k: u64, seed: u64, sample_hz: f64) -> Plan {
    Plan {
        axis: Axis::X,
        lines_mm: vec![[25.0 * (k % 8) as f64, 25.0 * ((k / 8) % 4) as f64]],
        runs: 5,
        sample_hz,
        seed: seed.wrapping_add(k),
        ..Plan::default()
    }
}

/// Writes blocks (see the module docs) to `out` until at least `min_bytes` are written.
/// `sample_hz` is the board's sample rate (1000 for benchmarks: ~0.8 MB per block).
pub fn write_long_capture<W: Write>(
    out: &mut W,
    min_bytes: u64,
    seed: u64,
    sample_hz: f64,
) -> io::Result<LongCapture> {
    let device = Device {
        baud: 4_000_000,
        fifo_bytes: 1 << 20,
        ..Device::default()
    };
    let mut done = LongCapture {
        bytes: 0,
        blocks: 0,
        samples: 0,
    };
    let bad = |e: String| io::Error::new(io::ErrorKind::InvalidData, e);
    let (mut seq, mut sample_off, mut run_off, mut t_off) = (0u16, 0u32, 0u16, 0u64);
    while done.bytes < min_bytes {
        let plan = block_plan(done.blocks, seed, sample_hz);
        let stream = simulate(&plan, &device, &Faults::default(), &mut Field)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        let (mut last_index, mut last_t) = (0u32, 0u64);
        for f in &stream.frames {
            let Parsed::Frame { mut frame, .. } = parse_frame(&f.bytes) else {
                return Err(bad("the simulated board wrote an invalid frame".into()));
            };
            match &mut frame {
                Frame::Hello(_) if done.blocks > 0 => continue,
                Frame::Hello(_) => {}
                Frame::Sample(x) => {
                    last_index = last_index.max(x.index);
                    x.index += sample_off;
                    last_t = last_t.max(x.t_us);
                    x.t_us += t_off;
                }
                Frame::Mark(m) => {
                    if m.run > 0 {
                        m.run += run_off;
                    }
                    last_t = last_t.max(m.t_us);
                    m.t_us += t_off;
                }
                Frame::Env(e) => {
                    last_t = last_t.max(e.t_us);
                    e.t_us += t_off;
                }
                Frame::Material(m) => {
                    last_t = last_t.max(m.t_us);
                    m.t_us += t_off;
                }
                Frame::RawAb(r) => {
                    last_t = last_t.max(r.t_us);
                    r.t_us += t_off;
                }
                _ => {}
            }
            let bytes = encode(&frame, seq).map_err(|e| bad(e.to_string()))?;
            seq = seq.wrapping_add(1);
            out.write_all(&bytes)?;
            done.bytes += bytes.len() as u64;
        }
        done.samples += stream.truth.iter().filter(|t| t.sent).count() as u64;
        done.blocks += 1;
        sample_off += last_index + 1;
        run_off += plan.runs as u16;
        // The next line starts a second after this one ended, on the same clock.
        t_off += last_t + 1_000_000;
    }
    out.flush()?;
    Ok(done)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode_all;

    #[test]
    fn a_generated_capture_decodes_to_every_sample_it_holds() {
        let mut bytes = Vec::new();
        let made = write_long_capture(&mut bytes, 1, 7, 200.0).expect("in memory");
        assert_eq!(made.blocks, 1);
        assert_eq!(made.bytes, bytes.len() as u64);
        let (rows, stats, hello) = decode_all(&bytes);
        assert!(hello.is_some());
        assert_eq!(stats.crc_failures, 0);
        assert_eq!(rows.len() as u64, made.samples);
        // Dwell rows carry the truth at their position relative to home (the origin).
        for r in rows.iter().filter(|r| r.target >= 0 && r.run > 0) {
            let truth = long_truth_um([r.scale_mm, 0.0, 0.0]) - long_truth_um([0.0; 3]);
            assert!(
                (r.error_um - truth).abs() < 0.2,
                "{} vs {truth}",
                r.error_um
            );
        }
    }
}
