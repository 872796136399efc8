//! Decoder throughput on a synthetic capture: `cargo run --release -p errmap-drivers
//! --example throughput`. Prints MB/s for a clean SAMPLE stream, a mixed session stream,
//! and hostile inputs (random bytes, sync-rich noise).

use std::time::Instant;

use errmap_drivers::frame::{DeviceId, Env, Frame, Hello, Sample, SampleFlags, encode_into};
use errmap_drivers::{Decoder, SessionDecoder};

fn clean_stream(bytes: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes + 64);
    let head = [
        Frame::Hello(Hello {
            protocol_version: 1,
            device_id: DeviceId::from_text("throughput"),
            grating_period_nm: 20_000,
            count_resolution_pm: 100_000,
            laser_wavelength_fm: 632_991_354,
            optical_fold: 2,
            edges_per_fringe: 4,
            axis_code: 0,
        }),
        Frame::Env(Env {
            t_us: 0,
            air_temp_mc: 20_000,
            pressure_pa: 101_325,
            rh_permille: 500,
        }),
    ];
    for (seq, f) in head.iter().enumerate() {
        if encode_into(f, seq as u16, &mut out).is_err() {
            return out;
        }
    }
    let mut i: u32 = 0;
    while out.len() < bytes {
        let f = Frame::Sample(Sample {
            t_us: u64::from(i) * 1000,
            index: i,
            scale_count: (i as i32).wrapping_mul(37),
            laser_count: (i as i32).wrapping_mul(41),
            flags: SampleFlags(0),
            trigger_code: 1,
        });
        if encode_into(&f, (i as u16).wrapping_add(2), &mut out).is_err() {
            break;
        }
        i = i.wrapping_add(1);
    }
    out
}

/// xorshift64*, seeded: reproducible noise without a dependency.
fn noise(bytes: usize, alphabet: &[u8]) -> Vec<u8> {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..bytes)
        .map(|_| {
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            let r = x.wrapping_mul(0x2545_F491_4F6C_DD1D);
            if alphabet.is_empty() {
                (r >> 56) as u8
            } else {
                alphabet[(r >> 33) as usize % alphabet.len()]
            }
        })
        .collect()
}

fn time(name: &str, bytes: &[u8], chunk: usize) {
    let start = Instant::now();
    let mut d = Decoder::new();
    let mut frames = 0u64;
    for c in bytes.chunks(chunk) {
        d.push_with(c, &mut |e| {
            if matches!(e, errmap_drivers::Event::Frame(_)) {
                frames += 1;
            }
        });
    }
    d.finish_with(&mut |_| {});
    let s = start.elapsed().as_secs_f64();
    println!(
        "{name:<28} decoder  {:>8.1} MB/s  ({frames} frames)",
        bytes.len() as f64 / s / 1e6
    );
    let start = Instant::now();
    let mut sd = SessionDecoder::new();
    let mut rows = 0u64;
    for c in bytes.chunks(chunk) {
        sd.push_with(c, &mut |e| {
            if matches!(e, errmap_drivers::SessionEvent::Row(_)) {
                rows += 1;
            }
        });
    }
    sd.finish_with(&mut |_| {});
    let s = start.elapsed().as_secs_f64();
    println!(
        "{name:<28} session  {:>8.1} MB/s  ({rows} rows)",
        bytes.len() as f64 / s / 1e6
    );
}

fn main() {
    let n = 64 << 20;
    let clean = clean_stream(n);
    time("clean SAMPLE, 64 KiB reads", &clean, 64 << 10);
    time("clean SAMPLE, 7 B reads", &clean, 7);
    time("random bytes", &noise(n / 4, &[]), 64 << 10);
    time(
        "sync-rich noise",
        &noise(n / 16, &[0xAA, 0x55, 0x02, 22, 0x7E, 0x06, 0x00]),
        64 << 10,
    );
}
