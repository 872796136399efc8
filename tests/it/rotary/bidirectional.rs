//! `export --bidirectional` of a rotary session (`docs/rotary.md` §4): LinuxCNC's forward
//! and reverse columns and Fagor 8055's err+ and err−, each direction detrended by its own
//! closure gap, both relative to the mean datum at the reference; checked against a
//! session built analytically with a known reversal and known per-direction errors.

use super::{rotary_csv, rotary_session};
use crate::util::{errmap, json, s, stderr, tempdir};

/// The shared shape of both directions, ″.
pub(super) fn base(t: f64) -> f64 {
    6.0 * t.to_radians().sin() + 2.0 * (2.0 * t.to_radians()).cos() + 4.0
}

/// e moving + and moving −: a reversal of 6″ (±3″ about the shape) and each direction's
/// own ratio error, 20 ppm (25.92″ a revolution) moving +, 10 ppm (12.96″) moving −.
pub(super) fn e(t: f64, d: i8) -> f64 {
    if d > 0 {
        base(t) + 3.0 + 25.92 * t / 360.0
    } else {
        base(t) - 3.0 + 12.96 * t / 360.0
    }
}

/// The compensation the contract gives, ″, computed here by hand: e′↑ = base + 3,
/// e′↓ = base − 3, datum at 0° = (e′↑(0) + e′↓(0))/2 = base(0) = 6, so c↑ = −base + 3
/// and c↓ = −base + 9.
pub(super) fn c(t: f64, d: i8) -> f64 {
    if d > 0 {
        -base(t) + 3.0
    } else {
        -base(t) + 9.0
    }
}

pub(super) fn targets() -> Vec<f64> {
    (0..=12).map(|k| f64::from(k) * 30.0).collect()
}

/// The session: three runs, every reading on the model.
pub(super) fn session(dir: &std::path::Path) -> std::path::PathBuf {
    let csv = rotary_csv(dir, "b.csv", &targets(), 3, &|t, _, d| e(t, d));
    rotary_session(&csv, dir.join("b_session.csv"), "a")
}

fn export(args: &[&str]) -> std::process::Output {
    let mut a = vec!["export"];
    a.extend_from_slice(args);
    errmap(&a)
}

/// `export SESSION --format FORMAT --bidirectional --out OUT --json`, which must succeed;
/// the file's text and the command's output.
fn both_directions(
    session: &std::path::Path,
    format: &str,
    out: &std::path::Path,
) -> (String, std::process::Output) {
    let o = export(&[
        s(session),
        "--format",
        format,
        "--bidirectional",
        "--out",
        s(out),
        "--json",
    ]);
    assert!(o.status.success(), "{format}: {}", stderr(&o));
    (std::fs::read_to_string(out).expect("written"), o)
}

#[test]
fn linuxcnc_forward_and_reverse_carry_each_directions_correction() {
    let dir = tempdir();
    let session = session(dir.path());
    let out = dir.path().join("a.comp");
    let (text, o) = both_directions(&session, "linuxcnc", &out);
    let rows: Vec<Vec<f64>> = text
        .lines()
        .map(|l| {
            l.split_whitespace()
                .map(|w| w.parse().expect("number"))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 13);
    for (row, t) in rows.iter().zip(targets()) {
        assert_eq!(row[0], t);
        // 6 decimals of a degree: within 0.5e-6° of the hand-computed values.
        assert!(
            (row[1] - (t + c(t, 1) / 3600.0)).abs() <= 0.5e-6 + 1e-12,
            "{row:?}"
        );
        assert!(
            (row[2] - (t + c(t, -1) / 3600.0)).abs() <= 0.5e-6 + 1e-12,
            "{row:?}"
        );
    }
    // Each direction's first and last lines carry equal corrections; the reversal shows.
    let (first, last) = (&rows[0], &rows[12]);
    assert!(((first[1] - first[0]) - (last[1] - last[0])).abs() < 1e-9);
    assert!(((first[2] - first[0]) - (last[2] - last[0])).abs() < 1e-9);
    assert!(((first[2] - first[1]) * 3600.0 - 6.0).abs() < 0.01);
    let j = json(&o);
    let f = |k: &str| j["directions"][k].as_f64().expect(k);
    assert!((f("closure_gap_up_arcsec") - 25.92).abs() < 1e-6);
    assert!((f("closure_gap_down_arcsec") - 12.96).abs() < 1e-6);
    assert!((f("datum_up_arcsec") - 9.0).abs() < 1e-6);
    assert!((f("datum_down_arcsec") - 3.0).abs() < 1e-6);
    assert!((j["datum_offset_arcsec"].as_f64().expect("datum") - 6.0).abs() < 1e-6);
    assert!((j["closure_gap_arcsec"].as_f64().expect("gap") - 19.44).abs() < 1e-6);
    // The residual after compensation: the table's own rounding (0.5e-6° = 0.0018″).
    for k in ["max_residual_up_arcsec", "max_residual_down_arcsec"] {
        assert!(f(k) <= 0.0018 + 1e-9, "{k} {}", f(k));
    }
    assert!(j["max_residual_arcsec"].as_f64().expect("residual") <= 0.0018 + 1e-9);
    assert!(stderr(&o).contains("correct the ratio"));
}

#[test]
fn fagor_err_minus_is_the_reverse_correction() {
    let dir = tempdir();
    let session = session(dir.path());
    let out = dir.path().join("ALA");
    let (text, o) = both_directions(&session, "fagor-8055", &out);
    let lines: Vec<&str> = text.split("\r\n").filter(|l| !l.is_empty()).collect();
    assert_eq!(lines.len(), 13);
    for (l, t) in lines.iter().zip(targets()) {
        let w: Vec<&str> = l.split_whitespace().collect();
        assert_eq!((w[1], w[3], w[5]), ("A", "EA", "EA"), "{l}");
        let v = |k: usize| w[k].parse::<f64>().expect("number");
        assert_eq!(v(2), t);
        assert!((v(4) - c(t, 1) / 3600.0).abs() <= 0.5e-4 + 1e-12, "{l}");
        assert!((v(6) - c(t, -1) / 3600.0).abs() <= 0.5e-4 + 1e-12, "{l}");
    }
    let field = |l: &str, k: usize| l.split_whitespace().nth(k).map(str::to_string);
    assert_eq!(
        field(lines[0], 4),
        field(lines[12], 4),
        "err+ equal at 0 and 360"
    );
    assert_eq!(
        field(lines[0], 6),
        field(lines[12], 6),
        "err− equal at 0 and 360"
    );
    let j = json(&o);
    // 4 decimals of a degree: within 0.18″.
    assert!(
        j["directions"]["max_residual_down_arcsec"]
            .as_f64()
            .expect("r")
            <= 0.18 + 1e-9
    );
}

#[test]
fn one_direction_tables_and_error_tables_are_refused() {
    let dir = tempdir();
    let session = session(dir.path());
    let table = dir.path().join("t.csv");
    assert!(
        errmap(&["table", s(&session), "--out", s(&table)])
            .status
            .success()
    );
    let out = dir.path().join("x.out");
    for (input, format, says) in [
        (
            &session,
            "siemens",
            "one value per point for both directions; the two-direction rotary tables are \
             linuxcnc (forward/reverse) and fagor-8055 (err−)",
        ),
        (&session, "fanuc", "one value per point"),
        (&session, "heidenhain", "one value per point"),
        (&table, "linuxcnc", "needs a rotary session"),
    ] {
        let mut a = vec![s(input), "--format", format, "--bidirectional"];
        if format != "linuxcnc" {
            a.extend_from_slice(&["--step", "30"]);
        }
        a.extend_from_slice(&["--out", s(&out)]);
        let o = export(&a);
        assert_eq!(o.status.code(), Some(2), "{format}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{format}: {}", stderr(&o));
        assert!(!out.exists());
    }
}
