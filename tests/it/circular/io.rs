//! Reading a test: each bad input refused with its file, line and column (or TOML key);
//! a simulated test round-trips through CSV and Parquet.

use errmap::circular::{Plane, read_test};
use errmap::circular::{simulate, write_test};

use crate::util::tempdir;

const META: &str = "plane = \"XY\"\nradius_mm = 100.0\nfeed_mm_per_min = 1000.0\n\
                    arc_start_deg = 0.0\narc_deg = 90.0\novershoot_deg = 0.0\n";

/// A trace of one ccw run over 0..90° in 1° steps, with `edit` applied to its lines.
fn trace(edit: impl Fn(usize, String) -> String) -> String {
    let mut lines = vec!["run,direction,angle_deg,dr_um".to_string()];
    for k in 0..=90 {
        lines.push(format!("1,1,{k}.0,0.5"));
    }
    lines
        .into_iter()
        .enumerate()
        .map(|(i, l)| edit(i + 1, l))
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

/// `t.csv` holding `csv` and `t.toml` beside it holding `meta`, in a fresh directory.
fn files(csv: &str, meta: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempdir();
    let path = dir.path().join("t.csv");
    std::fs::write(&path, csv).expect("test set-up");
    std::fs::write(dir.path().join("t.toml"), meta).expect("test set-up");
    (dir, path)
}

fn refused(csv: &str, meta: &str) -> String {
    let (_dir, path) = files(csv, meta);
    read_test(&path).expect_err("refused").to_string()
}

#[test]
fn bad_traces_are_refused_by_line_and_column() {
    let cases: Vec<(String, String, &str)> = vec![
        (
            trace(|i, l| {
                if i == 1 {
                    "run,direction,angle_deg".into()
                } else {
                    l
                }
            }),
            META.to_string(),
            "t.csv: row 1 (line 2)",
        ),
        (
            trace(|i, l| if i == 5 { "1,1,3.0,inf".into() } else { l }),
            META.to_string(),
            "line 5: column dr_um: inf is not a finite number",
        ),
        (
            trace(|i, l| if i == 7 { "1,1,5.0,0,5".into() } else { l }),
            META.to_string(),
            "t.csv",
        ),
        (
            trace(|i, l| if i == 6 { "1,2,4.0,0.5".into() } else { l }),
            META.to_string(),
            "line 6: column direction: 2 is not +1",
        ),
        (
            trace(|i, l| if i == 9 { "1,-1,7.0,0.5".into() } else { l }),
            META.to_string(),
            "line 9: column direction: changes from ccw to cw",
        ),
        (
            // Line 11 holds 9°: 7.5° after 8° runs backwards in a ccw run.
            trace(|i, l| if i == 11 { "1,1,7.5,0.5".into() } else { l }),
            META.to_string(),
            "line 11: column angle_deg: 7.5 after 8",
        ),
        (
            trace(|_, l| l) + "2,1,0.0,0.1\n2,1,1.0,0.1\n",
            META.to_string(),
            "second ccw run",
        ),
        (
            trace(|_, l| l) + "2,-1,3.0,0.1\n1,1,91.0,0.1\n",
            META.to_string(),
            "column run: run 1 appears again",
        ),
        (
            trace(|i, l| if i > 60 { String::new() } else { l })
                .replace("\n\n", "\n")
                .trim_end()
                .to_string()
                + "\n",
            META.to_string(),
            "line 2: column angle_deg: run 1 covers",
        ),
        (
            trace(|_, l| l),
            META.replace("radius_mm = 100.0", "radius_mm = -1.0"),
            "t.toml: radius_mm:",
        ),
        (
            trace(|_, l| l),
            META.replace("radius_mm", "radius_mn"),
            "t.toml: line 2: column 1: unknown field `radius_mn`",
        ),
        (
            trace(|_, l| l),
            META.replace("feed_mm_per_min = 1000.0\n", ""),
            "missing field `feed_mm_per_min`",
        ),
    ];
    for (csv, meta, want) in cases {
        let msg = refused(&csv, &meta);
        assert!(msg.contains(want), "want `{want}` in `{msg}`");
    }
}

/// The contract asks for strictly monotonic angles, not evenly spaced ones: a ballbar
/// samples at a fixed rate, so the angle step varies with the feed (acceleration at the
/// ends of the overshoot, a servo that hesitates). An uneven but monotonic run is read,
/// every sample kept at its own angle.
#[test]
fn unevenly_spaced_angles_are_read() {
    // Line 10 holds 8°: 7.5° lies between 7° and 9°.
    let csv = trace(|i, l| if i == 10 { "1,1,7.5,0.5".into() } else { l });
    let (_dir, path) = files(&csv, META);
    let test = read_test(&path).expect("an uneven, monotonic run is valid");
    assert_eq!(test.runs.len(), 1);
    let a = &test.runs[0].angle_deg;
    assert_eq!(a.len(), 91);
    assert_eq!((a[7], a[8], a[9]), (7.0, 7.5, 9.0));
}

#[test]
fn t_s_decreasing_is_refused() {
    let csv = trace(|i, l| {
        if i == 1 {
            format!("{l},t_s")
        } else {
            format!("{l},{}", if i == 20 { 0.0 } else { i as f64 })
        }
    });
    let msg = refused(&csv, META);
    assert!(msg.contains("line 20: column t_s"), "{msg}");
}

#[test]
fn a_simulated_test_round_trips_through_csv_and_parquet() {
    let test = simulate(&super::model(Plane::ZX, &[], 0.1, 3)).expect("a test within the bounds");
    let dir = tempdir();
    for name in ["t.csv", "t.parquet"] {
        let path = dir.path().join(name);
        write_test(&test, &path).expect("test set-up");
        let back = read_test(&path).expect("test set-up");
        assert_eq!(back.meta, test.meta);
        assert_eq!(back.runs.len(), 2);
        for (a, b) in back.runs.iter().zip(&test.runs) {
            assert_eq!(a.sense, b.sense);
            assert_eq!(a.angle_deg.len(), b.angle_deg.len());
            let worst = a
                .dr_um
                .iter()
                .zip(&b.dr_um)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "{name}: {worst}");
        }
    }
}
