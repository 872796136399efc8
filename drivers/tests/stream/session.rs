//! End-to-end session tests: frames → rows with exact values.

use errmap_drivers::frame::Axis;
use errmap_drivers::{SessionRow, decode_all};

use crate::common::{LAMBDA_FM, Stream, env, hello, mark, material, rows, sample, text};

/// The spec's modified Edlén equation, written out again here independently of the crate.
fn n_air_spec(lambda_nm: f64, t: f64, p: f64, rh: f64) -> f64 {
    let sigma2 = (1000.0 / lambda_nm).powi(2);
    let ns = 1e-8 * (8342.54 + 2406147.0 / (130.0 - sigma2) + 15998.0 / (38.9 - sigma2));
    let ntp = p * ns / 96095.43 * (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.003661 * t);
    // IAPWS-IF97, eq. 30.
    let n = [
        1167.0521452767,
        -724213.16703206,
        -17.073846940092,
        12020.82470247,
        -3232555.0322333,
        14.91510861353,
        -4823.2657361591,
        405113.40542057,
        -0.23855557567849,
        650.17534844798,
    ];
    let tk = t + 273.15;
    let th = tk + n[8] / (tk - n[9]);
    let a = th * th + n[0] * th + n[1];
    let b = n[2] * th * th + n[3] * th + n[4];
    let c = n[5] * th * th + n[6] * th + n[7];
    let psv_mpa = (2.0 * c / (-b + (b * b - 4.0 * a * c).sqrt())).powi(4);
    let f = rh / 100.0 * psv_mpa * 1e6;
    1.0 + ntp - f * (3.7345 - 0.0401 * sigma2) * 1e-10
}

/// Laser length in air from the spec: ΔL · λ_vac / (F · k · n_air), mm (F = k = 4 here).
fn laser_mm_spec(dl: i64, n: f64) -> f64 {
    dl as f64 * (f64::from(LAMBDA_FM) * 1e-12) / (16.0 * n)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[track_caller]
fn assert_close(got: f64, want: f64) {
    assert!(
        close(got, want, 1e-12 * want.abs().max(1.0)),
        "{got} vs {want}"
    );
}

#[track_caller]
fn assert_opt(got: Option<f64>, want: Option<f64>) {
    match (got, want) {
        (Some(g), Some(w)) => assert_close(g, w),
        (None, None) => {}
        _ => panic!("{got:?} vs {want:?}"),
    }
}

const T0: u64 = 1_000_000;

/// HELLO, ENV, MATERIAL, a run with a dwell, a reversal and a run end.
fn session_stream() -> Stream {
    let mut s = Stream::new(100);
    s.frame(&text("boot ok"));
    s.frame(&hello(1)); // measuring Y
    s.frame(&env(T0, 20_500, 100_800, 455));
    s.frame(&material(T0 + 100, &[20_100, 19_800, 21_000]));
    s.frame(&sample(T0 + 200, 7, 1000, 1500, 0)); // origin, before any MARK
    s.frame(&mark(T0 + 1000, 1, 1, 1, 0, 25_000, 150_000, -30_000)); // run 1 starts
    s.frame(&sample(T0 + 2000, 8, 1000 + 200_000, 1500 + 252_700, 0));
    s.frame(&mark(T0 + 3000, 3, 1, 1, 4, 0, 150_000, -30_000)); // target 4 reached
    s.frame(&sample(T0 + 4000, 9, 1000 + 200_001, 1500 + 252_702, 1)); // BEAM_LOW
    s.frame(&mark(T0 + 5000, 4, 1, 1, 4, 25_000, 150_000, -30_000)); // target left
    s.frame(&sample(T0 + 6000, 10, 1000 + 300_000, 1500 + 379_000, 0));
    s.frame(&mark(T0 + 7000, 5, -1, 1, 4, 12_500, 150_000, -30_000)); // reversal
    s.frame(&sample(T0 + 8000, 11, 1000 + 250_000, 1500 + 316_000, 0));
    s.frame(&mark(T0 + 9000, 2, -1, 1, 4, 12_500, 150_000, -30_000)); // run end
    s.frame(&sample(T0 + 10_000, 12, 1000 + 240_000, 1500 + 303_000, 0));
    s
}

struct Want {
    run: u32,
    sample: i64,
    dt_us: u64,
    direction: i8,
    feed: Option<f64>,
    target: i32,
    lines: Option<(f64, f64)>,
    ds: i64,
    dl: i64,
    flags: u8,
}

#[test]
fn end_to_end_rows_have_exact_values() {
    let s = session_stream();
    let (rows, stats, hello_frame) = decode_all(&s.bytes);
    let n = n_air_spec(632.991354, 20.5, 100_800.0, 45.5);
    let wants = [
        Want {
            run: 0,
            sample: 7,
            dt_us: 200,
            direction: 0,
            feed: None,
            target: -1,
            lines: None,
            ds: 0,
            dl: 0,
            flags: 0,
        },
        Want {
            run: 1,
            sample: 8,
            dt_us: 2000,
            direction: 1,
            feed: Some(25.0),
            target: -1,
            lines: Some((150.0, -30.0)),
            ds: 200_000,
            dl: 252_700,
            flags: 0,
        },
        Want {
            run: 1,
            sample: 9,
            dt_us: 4000,
            direction: 1,
            feed: Some(0.0),
            target: 4,
            lines: Some((150.0, -30.0)),
            ds: 200_001,
            dl: 252_702,
            flags: 1,
        },
        Want {
            run: 1,
            sample: 10,
            dt_us: 6000,
            direction: 1,
            feed: Some(25.0),
            target: -1,
            lines: Some((150.0, -30.0)),
            ds: 300_000,
            dl: 379_000,
            flags: 0,
        },
        Want {
            run: 1,
            sample: 11,
            dt_us: 8000,
            direction: -1,
            feed: Some(12.5),
            target: -1,
            lines: Some((150.0, -30.0)),
            ds: 250_000,
            dl: 316_000,
            flags: 0,
        },
        Want {
            run: 0,
            sample: 12,
            dt_us: 10_000,
            direction: 0,
            feed: Some(12.5),
            target: -1,
            lines: Some((150.0, -30.0)),
            ds: 240_000,
            dl: 303_000,
            flags: 0,
        },
    ];
    assert_eq!(rows.len(), wants.len());
    for (row, w) in rows.iter().zip(&wants) {
        assert_eq!(row.run, w.run, "{row:?}");
        assert_eq!(row.sample, w.sample);
        assert_eq!(row.t_s, w.dt_us as f64 / 1e6);
        assert_eq!(row.axis, Axis::Y);
        assert_eq!(row.direction, w.direction, "{row:?}");
        assert_eq!(row.feed_mm_s, w.feed);
        assert_eq!(row.target, w.target, "{row:?}");
        let scale_mm = w.ds as f64 * 50e-6; // 50 000 pm per count
        let laser_mm = laser_mm_spec(w.dl, n);
        assert_close(row.scale_mm, scale_mm);
        assert_close(row.laser_mm, laser_mm);
        assert!(close(row.error_um, (scale_mm - laser_mm) * 1000.0, 1e-9));
        // Measuring Y: line positions are X and Z; y is the scale reading.
        assert_opt(row.x_mm, w.lines.map(|l| l.0));
        assert_opt(row.y_mm, Some(scale_mm));
        assert_opt(row.z_mm, w.lines.map(|l| l.1));
        assert_eq!(row.air_temp_c, Some(20.5));
        assert_eq!(row.air_pressure_hpa, Some(1008.0));
        assert_eq!(row.air_rh_pct, Some(45.5));
        assert_eq!(row.scale_temp_c, Some(20.1));
        assert_eq!(row.part_temp_c, Some(19.8));
        assert_eq!(row.flags, w.flags);
    }
    // The BEAM_LOW row is kept, with its laser length from the latched count.
    assert_eq!(rows[2].flags, 1);
    assert!(rows[2].laser_mm > 0.0);
    assert_eq!(stats.rows, 6);
    assert_eq!(stats.flagged_samples, 1);
    assert_eq!(stats.frames.text, 1);
    assert_eq!(stats.frames.mark, 5);
    assert_eq!(stats.problems.count("flagged_sample"), 1);
    let h = hello_frame.unwrap();
    assert_eq!(h.device_id.as_string(), "SIM-BENCH-01");
}

#[test]
fn rows_are_the_same_for_every_read_split() {
    let s = session_stream();
    let (whole, _) = rows(&s.bytes);
    for chunk in [1, 2, 7, 31, 64, 247, 248, 249] {
        let mut d = errmap_drivers::SessionDecoder::new();
        let mut got: Vec<SessionRow> = Vec::new();
        for c in s.bytes.chunks(chunk) {
            got.extend(d.push(c));
        }
        got.extend(d.finish());
        assert_eq!(got, whole, "chunk {chunk}");
    }
}

#[test]
fn no_env_means_vacuum_index_and_empty_air_columns() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(10, 0, 0, 0, 0));
    s.frame(&sample(20, 1, 100, 1000, 0));
    let (rows, _) = rows(&s.bytes);
    assert_eq!(rows.len(), 2);
    assert_close(rows[1].laser_mm, laser_mm_spec(1000, 1.0));
    assert_eq!(rows[1].air_temp_c, None);
    assert_eq!(rows[1].air_pressure_hpa, None);
    assert_eq!(rows[1].air_rh_pct, None);
    assert_eq!(rows[1].scale_temp_c, None);
    assert_eq!(rows[1].part_temp_c, None);
    // Measuring X with no MARK: y and z unknown, x the scale reading.
    assert_eq!(rows[1].x_mm, Some(rows[1].scale_mm));
    assert_eq!((rows[1].y_mm, rows[1].z_mm), (None, None));
    assert_eq!(rows[0].t_s, 0.0);
}

#[test]
fn line_coordinates_follow_the_measured_axis() {
    for (axis, want) in [
        (0u8, (None, Some(1.0), Some(2.0))),
        (1, (Some(1.0), None, Some(2.0))),
        (2, (Some(1.0), Some(2.0), None)),
    ] {
        let mut s = Stream::new(0);
        s.frame(&hello(axis));
        s.frame(&mark(0, 1, 1, 1, 0, 1000, 1000, 2000));
        s.frame(&sample(10, 0, 40, 0, 0));
        s.frame(&sample(10, 1, 60, 0, 0));
        let (rows, _) = rows(&s.bytes);
        let r = &rows[1];
        let scale = Some(r.scale_mm);
        let got = (r.x_mm, r.y_mm, r.z_mm);
        let want = (want.0.or(scale), want.1.or(scale), want.2.or(scale));
        assert_eq!(got, want, "axis {axis}");
        assert_close(r.scale_mm, 20.0 * 50e-6);
    }
}

#[test]
fn samples_before_hello_are_held_and_written() {
    let mut s = Stream::new(0);
    s.frame(&sample(100, 0, 10, 10, 0));
    s.frame(&sample(200, 1, 20, 30, 0));
    s.frame(&hello(2));
    s.frame(&sample(300, 2, 30, 50, 0));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows.len(), 3);
    assert_eq!(stats.rows, 3);
    assert_eq!(
        rows.iter().map(|r| r.sample).collect::<Vec<_>>(),
        vec![0, 1, 2]
    );
    assert_close(rows[2].scale_mm, 20.0 * 50e-6);
    assert_eq!(rows[0].axis, Axis::Z);
}

#[test]
fn origin_is_the_first_clean_sample() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(100, 0, 5, 7, 1)); // BEAM_LOW before the origin
    s.frame(&sample(200, 1, 10, 10, 0)); // origin
    s.frame(&sample(300, 2, 30, 50, 0));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows.len(), 3);
    assert_close(rows[0].scale_mm, -5.0 * 50e-6);
    assert_close(rows[0].laser_mm, laser_mm_spec(-3, 1.0));
    assert_eq!(rows[0].flags, 1);
    assert_eq!(rows[1].scale_mm, 0.0);
    assert_close(rows[2].laser_mm, laser_mm_spec(40, 1.0));
    assert_eq!(stats.flagged_samples, 1);
}

#[test]
fn no_hello_drops_rows_and_says_so() {
    let mut s = Stream::new(0);
    s.frame(&sample(100, 0, 5, 7, 0));
    s.frame(&sample(200, 1, 6, 8, 0));
    let (rows, stats) = rows(&s.bytes);
    assert!(rows.is_empty());
    let p = stats.problems.get("no_hello").unwrap();
    assert_eq!(
        p.first[0].kind,
        errmap_drivers::ProblemKind::NoHello { rows_dropped: 2 }
    );
}

#[test]
fn all_flagged_falls_back_to_first_sample_as_origin() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(100, 0, 5, 7, 1));
    s.frame(&sample(200, 1, 15, 7, 1));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0].scale_mm, 0.0);
    assert_close(rows[1].scale_mm, 10.0 * 50e-6);
    assert_eq!(stats.problems.count("no_clean_sample"), 1);
}

#[test]
fn counter_wrap_near_i32_max_unwraps() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(0, 0, i32::MAX - 10, i32::MIN + 3, 0));
    s.frame(&sample(1, 1, i32::MIN + 5, i32::MAX - 3, 0)); // +16 and −7 counts
    s.frame(&sample(2, 2, i32::MIN + 100, i32::MAX - 1000, 0));
    s.frame(&sample(3, 3, i32::MAX - 20, i32::MIN + 1, 0)); // back over the boundary
    let (rows, stats) = rows(&s.bytes);
    assert_close(rows[1].scale_mm, 16.0 * 50e-6);
    assert_close(rows[1].laser_mm, laser_mm_spec(-7, 1.0));
    assert_close(rows[2].scale_mm, 111.0 * 50e-6);
    assert_close(rows[2].laser_mm, laser_mm_spec(-1004, 1.0));
    assert_close(rows[3].scale_mm, -10.0 * 50e-6);
    assert_close(rows[3].laser_mm, laser_mm_spec(-2, 1.0));
    assert_eq!(stats.counter_wraps.scale, 2);
    assert_eq!(stats.counter_wraps.laser, 2);
    assert_eq!(stats.problems.count("counter_wrap"), 4);
}

#[test]
fn many_wraps_accumulate() {
    // 3 full turns of the scale counter in steps of 2^30 counts: unwraps to 3·2^32.
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    let step: i64 = 1 << 30;
    for i in 0..=12u32 {
        let raw = (i64::from(i) * step) as i32; // truncating: the wire counter wraps
        s.frame(&sample(u64::from(i), i, raw, 0, 0));
    }
    let cfg = errmap_drivers::SessionConfig {
        max_counts_per_sample: 1 << 31,
        ..Default::default()
    };
    let mut d = errmap_drivers::SessionDecoder::with_config(cfg);
    let mut rows = d.push(&s.bytes);
    rows.extend(d.finish());
    assert_close(rows[12].scale_mm, 3.0 * 4_294_967_296.0 * 50e-6);
    assert_eq!(d.stats().counter_wraps.scale, 3);
    assert_eq!(d.stats().problems.count("counter_jump"), 0);
}

#[test]
fn implausible_counter_jump_is_reported() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(0, 0, 0, 0, 0));
    s.frame(&sample(1, 1, 1 << 26, 0, 0));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows.len(), 2);
    assert_eq!(stats.problems.count("counter_jump"), 1);
}

#[test]
fn sample_index_is_unwrapped() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&sample(0, u32::MAX - 1, 0, 0, 0));
    s.frame(&sample(1, u32::MAX, 0, 0, 0));
    s.frame(&sample(2, 0, 0, 0, 0));
    s.frame(&sample(3, 2, 0, 0, 0)); // index 1 lost
    let (rows, _) = rows(&s.bytes);
    let idx: Vec<i64> = rows.iter().map(|r| r.sample).collect();
    let base = i64::from(u32::MAX);
    assert_eq!(idx, vec![base - 1, base, base + 1, base + 3]);
}

#[test]
fn t_s_counts_from_the_first_timestamped_frame() {
    let mut s = Stream::new(0);
    s.frame(&text("hi"));
    s.frame(&hello(0));
    s.frame(&mark(5_000_000, 2, 1, 0, 0, 0, 0, 0));
    s.frame(&sample(5_250_000, 0, 0, 0, 0));
    let (rows, _) = rows(&s.bytes);
    assert_eq!(rows[0].t_s, 0.25);
}

#[test]
fn stats_json_has_exactly_the_spec_shape() {
    let s = session_stream();
    let (_, stats, _) = decode_all(&s.bytes);
    let v = serde_json::to_value(&stats).unwrap();
    let keys = |v: &serde_json::Value| -> Vec<String> {
        let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    let mut top = vec![
        "bytes",
        "frames",
        "crc_failures",
        "resyncs",
        "bytes_skipped",
        "seq_gaps",
        "frames_lost",
        "counter_wraps",
        "flagged_samples",
        "truncated_tail_bytes",
        "raw_ab",
        "rows",
    ];
    top.sort_unstable();
    assert_eq!(keys(&v), top);
    let mut frames = vec![
        "hello", "sample", "env", "material", "mark", "raw_ab", "text",
    ];
    frames.sort_unstable();
    assert_eq!(keys(&v["frames"]), frames);
    assert_eq!(keys(&v["counter_wraps"]), vec!["laser", "scale"]);
    let mut raw = vec![
        "scale_counts",
        "laser_counts",
        "scale_illegal",
        "laser_illegal",
    ];
    raw.sort_unstable();
    assert_eq!(keys(&v["raw_ab"]), raw);
    assert_eq!(v["bytes"], s.bytes.len());
    assert_eq!(v["rows"], 6);
    assert_eq!(v["frames"]["sample"], 6);
    // The problem log serialises on its own.
    let p = serde_json::to_value(&stats.problems).unwrap();
    assert_eq!(p["flagged_sample"]["count"], 1);
    assert_eq!(p["flagged_sample"]["first"][0]["flags"], 1);
}
