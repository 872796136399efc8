//! The simulated board: its stream decodes to rows that match the simulated truth within
//! the counters' quantisation, and it respects the line's byte budget.

use errmap_drivers::decode_all;
use errmap_drivers::sim::{Device, Faults, Plan, Truth, TruthQuery, simulate};

struct Linear;
impl Truth for Linear {
    fn error_um(&mut self, q: &TruthQuery) -> f64 {
        // 2 µm per metre of x, plus a y-dependent term and a direction-dependent term.
        0.002 * q.pos_mm[0] + 0.001 * q.pos_mm[1] + 0.3 * f64::from(q.direction)
    }
}

fn small_plan() -> Plan {
    Plan {
        lines_mm: vec![[0.0, 100.0], [250.0, 100.0]],
        targets_mm: vec![0.0, 100.0, 200.0, 300.0],
        runs: 2,
        feed_mm_s: 200.0,
        dwell_s: 0.2,
        sample_hz: 50.0,
        settle_s: 0.1,
        ..Plan::default()
    }
}

#[test]
fn decoded_rows_match_the_truth_within_quantisation() {
    let s = simulate(
        &small_plan(),
        &Device::default(),
        &Faults::default(),
        &mut Linear,
    )
    .expect("simulates");
    assert_eq!(s.overruns, 0, "50 Hz fits in 115200 baud");
    let (rows, stats, hello) = decode_all(&s.bytes());
    assert!(hello.is_some());
    assert_eq!(stats.crc_failures, 0);
    assert_eq!(rows.len(), s.truth.len());
    // The origin is the first sample, at home on the first line (y = 0): truth there is 0.
    let home = s.truth[0].error_um;
    // Scale 0.1 µm and laser λ/8 ≈ 0.079 µm quantisation: at most ~0.09 µm together.
    for (row, t) in rows.iter().zip(&s.truth) {
        assert_eq!(row.sample, i64::from(t.index));
        assert!(
            (row.error_um - (t.error_um - home)).abs() < 0.1,
            "{row:?} vs {t:?}"
        );
        assert!((row.scale_mm - t.pos_mm[0]).abs() < 1e-4 + 1e-9);
        assert_eq!(row.target, t.target);
        assert_eq!(row.run, t.run);
        assert_eq!(row.direction, t.direction);
    }
    // Dwell rows carry the line coordinates from the MARKs.
    let dwell: Vec<_> = rows.iter().filter(|r| r.target >= 0).collect();
    assert!(
        dwell
            .iter()
            .any(|r| r.y_mm == Some(250.0) && r.z_mm == Some(100.0))
    );
    assert!(dwell.iter().all(|r| r.run >= 1 && r.direction != 0));
}

#[test]
fn a_plan_faster_than_the_line_drops_samples_and_flags_overrun() {
    let plan = Plan {
        sample_hz: 2000.0, // 2000 × 30 bytes/s = 60 kB/s > 11.5 kB/s at 115200 baud
        ..small_plan()
    };
    let s =
        simulate(&plan, &Device::default(), &Faults::default(), &mut Linear).expect("simulates");
    assert!(s.overruns > 0);
    // The line never carries more than baud/10 bytes per second.
    let bytes: usize = s.frames.iter().map(|f| f.bytes.len()).sum();
    let last = s.frames.last().expect("frames").line_time_us as f64 * 1e-6;
    assert!(
        bytes as f64 / last <= 11_520.0 * 1.01,
        "{} B/s",
        bytes as f64 / last
    );
    let (rows, stats, _) = decode_all(&s.bytes());
    assert!(stats.flagged_samples > 0);
    assert!(rows.iter().any(|r| r.flags & 0x08 != 0));
    // Lost samples leave holes in the index, never shift later indices.
    let sent: Vec<i64> = s
        .truth
        .iter()
        .filter(|t| t.sent)
        .map(|t| i64::from(t.index))
        .collect();
    assert_eq!(rows.iter().map(|r| r.sample).collect::<Vec<_>>(), sent);
}

#[test]
fn faults_are_counted_and_the_rest_decodes() {
    let faults = Faults {
        garbage_prob: 0.02,
        bit_flip_prob: 0.02,
        drop_prob: 0.01,
        beam_loss_s: Some((1.0, 1.5)),
        counters_near_wrap: Some(1000),
        seed: 9,
    };
    let s = simulate(&small_plan(), &Device::default(), &faults, &mut Linear).expect("simulates");
    let (rows, stats, _) = decode_all(&s.bytes());
    assert!(stats.crc_failures > 0);
    assert!(stats.bytes_skipped > 0);
    assert!(stats.seq_gaps > 0);
    assert!(stats.counter_wraps.scale + stats.counter_wraps.laser > 0);
    assert!(
        rows.iter().any(|r| r.flags & 0x01 != 0),
        "beam loss flagged"
    );
    // Most samples survive and still match the truth where unflagged.
    assert!(rows.len() as f64 > 0.9 * s.truth.len() as f64);
    let home = s.truth[0].error_um;
    // Rows before the first ENV that got through have no air compensation (n = 1), as the
    // spec says; they are recognisable by their empty air columns.
    for row in rows
        .iter()
        .filter(|r| r.flags == 0 && r.air_temp_c.is_some())
    {
        let t = s
            .truth
            .iter()
            .find(|t| i64::from(t.index) == row.sample)
            .expect("truth");
        assert!(
            (row.error_um - (t.error_um - home)).abs() < 0.1,
            "{row:?} vs {t:?}"
        );
    }
}

#[test]
fn runs_cycle_through_the_feeds() {
    let plan = Plan {
        extra_feeds_mm_s: vec![50.0],
        runs: 4,
        ..small_plan()
    };
    let s =
        simulate(&plan, &Device::default(), &Faults::default(), &mut Linear).expect("simulates");
    let (rows, _, _) = decode_all(&s.bytes());
    for run in 1..=4u32 {
        let want = if run % 2 == 1 { 200.0 } else { 50.0 };
        let feeds: Vec<f64> = rows
            .iter()
            .filter(|r| r.run == run)
            .filter_map(|r| r.feed_mm_s)
            .collect();
        assert!(!feeds.is_empty());
        assert!(feeds.iter().all(|f| *f == want), "run {run}: {feeds:?}");
    }
    let bad = Plan {
        extra_feeds_mm_s: vec![0.0],
        ..small_plan()
    };
    assert!(simulate(&bad, &Device::default(), &Faults::default(), &mut Linear).is_err());
}
