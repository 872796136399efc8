//! Issue 40's reproducers for the circular test, pinned: a size that would abort or run
//! for minutes is refused before anything is allocated, and an implausible number is
//! refused by its key, each with exit 1 and the file named.

use std::path::Path;

use crate::util::{errmap, s, stderr, tempdir};

/// The example machine (datasets/circular/machine.toml) with `from` replaced by `to`.
fn machine_with(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/circular/machine.toml"
    ))
    .expect("the example machine");
    assert!(text.contains(from), "`{from}` is in the example machine");
    text.replace(from, to)
}

/// `circular simulate` of `model` fails with exit 1, its message naming the model file
/// and every one of `words`.
fn refused(dir: &Path, model: &str, words: &[&str]) {
    let path = dir.join("m.toml");
    std::fs::write(&path, model).expect("test set-up");
    let out = dir.join("t.csv");
    let o = errmap(&[
        "circular",
        "simulate",
        "--model",
        s(&path),
        "--out",
        s(&out),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(s(&path)), "{err}");
    for w in words {
        assert!(err.contains(w), "`{w}` in: {err}");
    }
    assert!(!out.exists(), "nothing written");
}

/// Issue 40 item 1: a feed of 10⁻³ mm/min made 4.7·10⁹ samples a run and aborted after
/// allocating 37.7 GB; now the count is computed and refused first.
#[test]
fn a_crawling_feed_is_refused_before_its_samples_are_allocated() {
    let dir = tempdir();
    let model = machine_with("feed_mm_per_min = 1000.0", "feed_mm_per_min = 1e-3");
    refused(
        dir.path(),
        &model,
        &["test.sample_rate_hz", "samples", "500000"],
    );
}

/// Issue 40 item 1: a sample rate of 1 MHz ran past 20 s; it is now above the plausible
/// rate, and a rate inside it that still makes too many samples is refused by the count.
#[test]
fn a_megahertz_sample_rate_is_refused_and_so_is_a_count_too_large_at_a_plausible_rate() {
    let dir = tempdir();
    let model = machine_with("sample_rate_hz = 100.0", "sample_rate_hz = 1e6");
    refused(dir.path(), &model, &["sample_rate_hz", "10000"]);
    // 10 kHz at 100 mm/min round 100 mm: 2 × 4.7·10⁶ samples.
    let model = machine_with("sample_rate_hz = 100.0", "sample_rate_hz = 10000.0")
        .replace("feed_mm_per_min = 1000.0", "feed_mm_per_min = 100.0");
    refused(dir.path(), &model, &["test.sample_rate_hz", "9.4"]);
}

/// Issue 40 item 6: radius 10⁷ mm, feed 10¹², sample rate 10⁹ Hz, simulated noise 10⁹ µm
/// and an effect of 10⁹ µm were accepted; each is refused by its key.
#[test]
fn implausible_radius_feed_rate_noise_and_effect_are_refused_by_key() {
    let dir = tempdir();
    for (from, to, key) in [
        ("radius_mm = 100.0", "radius_mm = 1e7", "radius_mm"),
        (
            "feed_mm_per_min = 1000.0",
            "feed_mm_per_min = 1e12",
            "feed_mm_per_min",
        ),
        (
            "sample_rate_hz = 100.0",
            "sample_rate_hz = 1e9",
            "sample_rate_hz",
        ),
        ("noise_um = 0.15", "noise_um = 1e9", "setup.noise_um"),
        ("b_um = 5.0", "b_um = 1e9", "effect[0].params.b_um"),
        ("tau_ms = 80.0", "tau_ms = 1e9", "effect[1].params.tau_ms"),
        ("urad = 40.0", "urad = 1e9", "effect[3].params.urad"),
    ] {
        refused(dir.path(), &machine_with(from, to), &[key, "plausible"]);
    }
}

/// `circular diagnose` of the trace `csv` beside the example's TOML fails with exit 1; its
/// message.
fn diagnose_refused(dir: &Path, csv: &str) -> String {
    let trace = dir.join("t.csv");
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/datasets/circular/xy.toml"),
        dir.join("t.toml"),
    )
    .expect("test set-up");
    std::fs::write(&trace, csv).expect("test set-up");
    let o = errmap(&[
        "circular",
        "diagnose",
        s(&trace),
        "--report",
        s(&dir.join("r")),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(s(&trace)), "{err}");
    err
}

/// Issue 40 item 6: a trace's dr of 10⁹ µm was diagnosed; it is refused by line and
/// column.
#[test]
fn a_radial_deviation_of_a_kilometre_is_refused_by_line_and_column() {
    let dir = tempdir();
    let csv = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/circular/xy.csv"
    ))
    .expect("the example trace");
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let dr = header.iter().position(|h| *h == "dr_um").expect("dr_um");
    let mut row: Vec<String> = lines[5].split(',').map(str::to_string).collect();
    row[dr] = "1e9".into();
    lines[5] = row.join(",");
    let err = diagnose_refused(dir.path(), &(lines.join("\n") + "\n"));
    assert!(
        err.contains("line 6") && err.contains("dr_um") && err.contains("plausible"),
        "{err}"
    );
}

/// Issue 40 item 10: a trace of more than 500 000 samples is refused before its rows are
/// read (the diagnosis costs about 40 µs a sample in the test profile).
#[test]
fn a_trace_of_more_samples_than_a_test_may_have_is_refused() {
    let dir = tempdir();
    let mut text = String::from("run,direction,angle_deg,dr_um\n");
    for i in 0..500_001 {
        text.push_str(&format!("1,1,{},0\n", f64::from(i) * 1e-3));
    }
    let err = diagnose_refused(dir.path(), &text);
    assert!(
        err.contains("500001 rows") && err.contains("500000"),
        "{err}"
    );
}
