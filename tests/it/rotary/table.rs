//! ISO 230-2 in arcseconds against figures computed here from the definitions, the
//! closure check, the rotary error table.

use super::{every_45, rotary_csv, rotary_session};
use crate::util::{errmap, json, s, stderr, tempdir};

/// Scatter of run j at target i, ″ (deterministic; 0 and 360 share it).
fn scatter(i: usize, run: u32, d: i8) -> f64 {
    let k = (run as usize * 7 + (i % 8) * 3 + if d > 0 { 0 } else { 2 }) % 5;
    0.4 * (k as f64 - 2.0)
}

fn truth(theta: f64, run: u32, d: i8, ratio_ppm: f64) -> f64 {
    let i = (theta / 45.0).round() as usize;
    12.0 * (theta + 30.0).to_radians().sin()
        + f64::from(d) * 1.5
        + scatter(i, run, d)
        + ratio_ppm * theta * 3.6e-3
}

/// ISO 230-2 figures from the definitions (x = −e), computed independently of errmap.
struct Expected {
    mean_up: Vec<f64>,
    mean_down: Vec<f64>,
    s_up: Vec<f64>,
    s_down: Vec<f64>,
}

fn expected(targets: &[f64], runs: u32, ratio_ppm: f64) -> Expected {
    let stats = |theta: f64, d: i8| {
        let x: Vec<f64> = (1..=runs).map(|j| -truth(theta, j, d, ratio_ppm)).collect();
        let m = x.iter().sum::<f64>() / x.len() as f64;
        let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64;
        (m, v.sqrt())
    };
    let up: Vec<(f64, f64)> = targets.iter().map(|&t| stats(t, 1)).collect();
    let down: Vec<(f64, f64)> = targets.iter().map(|&t| stats(t, -1)).collect();
    Expected {
        mean_up: up.iter().map(|p| p.0).collect(),
        mean_down: down.iter().map(|p| p.0).collect(),
        s_up: up.iter().map(|p| p.1).collect(),
        s_down: down.iter().map(|p| p.1).collect(),
    }
}

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() < 1e-6, "{what}: errmap {a}, expected {b}");
}

fn max(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(f64::NEG_INFINITY, f64::max)
}
fn min(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(f64::INFINITY, f64::min)
}

#[test]
fn iso_230_2_in_arcsec_matches_the_definitions_with_0_and_360_both_evaluated() {
    let dir = tempdir();
    let targets = every_45();
    let csv = rotary_csv(dir.path(), "a.csv", &targets, 5, &|t, j, d| {
        truth(t, j, d, 0.0)
    });
    let session = rotary_session(&csv, dir.path().join("a.csv.session.csv"), "a");
    let table = dir.path().join("a_table.csv");
    let o = errmap(&["table", s(&session), "--out", s(&table), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["summary"]["kind"], "rotary");
    assert_eq!(j["summary"]["axis"], "A");
    let line = &j["lines"][0];
    assert_eq!(line["axis"], "A");
    let iso = &line["iso230"];
    let x = expected(&targets, 5, 0.0);
    let m = targets.len();
    assert_eq!(
        iso["targets"].as_array().map(Vec::len),
        Some(m),
        "0 and 360 both"
    );
    for i in 0..m {
        let t = &iso["targets"][i];
        close(
            t["position_deg"].as_f64().expect("present"),
            targets[i],
            "position",
        );
        close(
            t["mean_up_arcsec"].as_f64().expect("present"),
            x.mean_up[i],
            "x̄↑",
        );
        close(
            t["mean_down_arcsec"].as_f64().expect("present"),
            x.mean_down[i],
            "x̄↓",
        );
        close(t["s_up_arcsec"].as_f64().expect("present"), x.s_up[i], "s↑");
        close(
            t["reversal_arcsec"].as_f64().expect("present"),
            x.mean_up[i] - x.mean_down[i],
            "B_i",
        );
    }
    let b: Vec<f64> = (0..m).map(|i| x.mean_up[i] - x.mean_down[i]).collect();
    let r_i: Vec<f64> = (0..m)
        .map(|i| {
            (2.0 * x.s_up[i] + 2.0 * x.s_down[i] + b[i].abs())
                .max(4.0 * x.s_up[i])
                .max(4.0 * x.s_down[i])
        })
        .collect();
    let both = || x.mean_up.iter().chain(&x.mean_down).copied();
    let bi: Vec<f64> = (0..m)
        .map(|i| (x.mean_up[i] + x.mean_down[i]) / 2.0)
        .collect();
    let a_hi = max((0..m).flat_map(|i| {
        [
            x.mean_up[i] + 2.0 * x.s_up[i],
            x.mean_down[i] + 2.0 * x.s_down[i],
        ]
    }));
    let a_lo = min((0..m).flat_map(|i| {
        [
            x.mean_up[i] - 2.0 * x.s_up[i],
            x.mean_down[i] - 2.0 * x.s_down[i],
        ]
    }));
    close(
        iso["b_arcsec"].as_f64().expect("present"),
        max(b.iter().map(|v| v.abs())),
        "B",
    );
    close(
        iso["mean_reversal_arcsec"].as_f64().expect("present"),
        b.iter().sum::<f64>() / m as f64,
        "B̄",
    );
    close(
        iso["r_arcsec"].as_f64().expect("present"),
        max(r_i.iter().copied()),
        "R",
    );
    close(
        iso["e_arcsec"].as_f64().expect("present"),
        max(both()) - min(both()),
        "E",
    );
    close(
        iso["m_arcsec"].as_f64().expect("present"),
        max(bi.iter().copied()) - min(bi.iter().copied()),
        "M",
    );
    close(iso["a_arcsec"].as_f64().expect("present"), a_hi - a_lo, "A");
    // 0 and 360 carry the same errors here: the closure agrees exactly.
    let c = &line["closure"];
    close(
        c["diff_up_arcsec"].as_f64().expect("present"),
        0.0,
        "closure ↑",
    );
    assert_eq!(c["consistent"], true);
    assert_eq!(j["warnings"].as_array().map(Vec::len), Some(0));
    // The rotary error table: a_deg, e_arcsec (mean of both directions), n, s_arcsec.
    let text = std::fs::read_to_string(&table).expect("present");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("a_deg,e_arcsec,n,s_arcsec"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("present")).collect())
        .collect();
    assert_eq!(rows.len(), m);
    for (i, r) in rows.iter().enumerate() {
        close(r[0], targets[i], "a_deg");
        close(r[1], -bi[i], "e_arcsec = −x̄_i with balanced runs");
        assert_eq!(r[2], 10.0);
    }
}

#[test]
fn a_ratio_error_breaks_the_closure_with_a_named_warning() {
    let dir = tempdir();
    let targets = every_45();
    let csv = rotary_csv(dir.path(), "c.csv", &targets, 5, &|t, j, d| {
        truth(t, j, d, 40.0)
    });
    let session = rotary_session(&csv, dir.path().join("c.parquet"), "c");
    let o = errmap(&[
        "table",
        s(&session),
        "--out",
        s(&dir.path().join("t.csv")),
        "--report",
        s(&dir.path().join("rep")),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    let c = &j["lines"][0]["closure"];
    // 40 ppm of a revolution: 360·3600·40e-6 = 51.84″, x = −e.
    close(
        c["diff_up_arcsec"].as_f64().expect("present"),
        -51.84,
        "closure ↑",
    );
    close(
        c["diff_down_arcsec"].as_f64().expect("present"),
        -51.84,
        "closure ↓",
    );
    let x = expected(&targets, 5, 40.0);
    close(
        c["limit_up_arcsec"].as_f64().expect("present"),
        2.0 * x.s_up[0].max(x.s_up[8]),
        "limit ↑",
    );
    assert_eq!(c["consistent"], false);
    let w = j["warnings"][0].as_str().expect("present");
    assert!(
        w.starts_with("closure_mismatch:") && w.contains("ratio") && w.contains("drift"),
        "{w}"
    );
    assert!(stderr(&o).contains("closure_mismatch:"));
    let report = std::fs::read_to_string(dir.path().join("rep/report.md")).expect("present");
    assert!(report.contains("closure_mismatch:") && report.contains('″'));
}
