//! The rotary certificate (`docs/rotary.md`, "The rotary certificate"): the PDF read back
//! with poppler's `pdftotext`; its ISO figures, both closure differences and the expanded
//! uncertainty compared with `table --json` and with the budget computed here by hand.

use std::process::Command;

use super::{rotary_csv, rotary_session};
use crate::util::{errmap, json, s, stderr, tempdir};

fn pdftotext(pdf: &std::path::Path) -> Option<String> {
    let o = Command::new("pdftotext")
        .args(["-layout", s(pdf), "-"])
        .output()
        .ok()?;
    o.status
        .success()
        .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
}

/// Every 30°, 0 and 360 both; e = 3·sin θ + d·1 plus a run-dependent 0.2″ scatter.
fn session(dir: &std::path::Path, ratio_ppm: f64) -> std::path::PathBuf {
    let targets: Vec<f64> = (0..=12).map(|k| f64::from(k) * 30.0).collect();
    let csv = rotary_csv(
        dir,
        &format!("r{ratio_ppm}.csv"),
        &targets,
        5,
        &|t, run, d| {
            3.0 * t.to_radians().sin()
                + f64::from(d)
                + 0.2 * (f64::from(run) * 1.7 + t / 50.0).sin()
                + ratio_ppm * t * 3.6e-3
        },
    );
    rotary_session(&csv, dir.join(format!("r{ratio_ppm}.session.csv")), "b")
}

#[test]
fn the_certificate_prints_the_figures_the_closure_and_an_honest_budget_in_arcsec() {
    let dir = tempdir();
    let session = session(dir.path(), 0.0);
    let info = dir.path().join("info.toml");
    std::fs::write(
        &info,
        "certificate_number = \"R-1\"\n[reference]\nmodel = \"XR20-style\"\naccuracy_arcsec = 1.0\n",
    )
    .expect("info");
    let pdf = dir.path().join("c.pdf");
    let o = errmap(&[
        "certificate",
        s(&session),
        "--info",
        s(&info),
        "--out",
        s(&pdf),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("assumed"), "{}", stderr(&o));
    let Some(text) = pdftotext(&pdf) else {
        eprintln!("SKIP the rotary certificate's text: pdftotext (poppler-utils) not installed");
        return;
    };
    let t = errmap(&[
        "table",
        s(&session),
        "--out",
        s(&dir.path().join("t.csv")),
        "--json",
    ]);
    let j = json(&t);
    let iso = &j["lines"][0]["iso230"];
    // U by hand: ±1″ rectangular and the largest s over √n (no HELLO: no count terms).
    let targets = iso["targets"].as_array().expect("targets");
    assert_eq!(targets.len(), 13, "0 and 360 both");
    let s_max = targets
        .iter()
        .flat_map(|t| [t["s_up_arcsec"].as_f64(), t["s_down_arcsec"].as_f64()])
        .flatten()
        .fold(0.0, f64::max);
    let u = 2.0 * ((1.0f64 / 3.0) + s_max * s_max / 5.0).sqrt();
    let line = |start: &str| {
        text.lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no line `{start}` in\n{text}"))
    };
    let numbers = |l: &str| -> Vec<f64> {
        l.split_whitespace()
            .filter_map(|w| w.replace('−', "-").parse().ok())
            .collect()
    };
    // A and E compare two targets: √2·U(x̄); M is one mean deviation: U(x̄).
    for (sym, name, key, u) in [
        ("A ", "bidirectional accuracy", "a_arcsec", 2f64.sqrt() * u),
        (
            "E ",
            "bidirectional systematic",
            "e_arcsec",
            2f64.sqrt() * u,
        ),
        ("M ", "mean bidirectional", "m_arcsec", u),
    ] {
        let l = line(&format!("{sym}{name}"));
        let v = numbers(&l);
        let want = iso[key].as_f64().expect("figure");
        // value ″, value °, U ″.
        assert!((v[0] - want).abs() <= 0.005 + 1e-9, "{l}: {want}");
        assert!(
            (v[1] - want / 3600.0).abs() < 1e-7,
            "{l}: {}",
            want / 3600.0
        );
        assert!((v[2] - u).abs() <= 0.005 + 1e-9, "{l}: U {u}");
    }
    let r = numbers(&line("R bidirectional repeatability"));
    assert!((r[0] - iso["r_arcsec"].as_f64().expect("R")).abs() <= 0.005 + 1e-9);
    // No HELLO, so no count is known: R states no U (value ″ and ° only).
    assert_eq!(r.len(), 2, "R carries no U without a count: {r:?}");
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(flat.contains("no count of the reference or the encoder is known"));
    // B compares two means at one angle: the reference cancels, the two means'
    // repeatability stays: 2·√(2·s²/n).
    let b = numbers(&line("B reversal value"));
    let u_b = 2.0 * (2.0 * s_max * s_max / 5.0).sqrt();
    assert!((b[0] - iso["b_arcsec"].as_f64().expect("B")).abs() <= 0.005 + 1e-9);
    assert!((b[2] - u_b).abs() <= 0.005 + 1e-9, "B: {b:?} U {u_b}");
    let closure = &j["lines"][0]["closure"];
    for (start, key) in [
        ("+ (angle", "diff_up_arcsec"),
        ("− (angle", "diff_down_arcsec"),
    ] {
        let v = numbers(&line(start));
        let want = closure[key].as_f64().expect("diff");
        assert!(
            (v[0] - want).abs() <= 0.005 + 1e-9,
            "{start}: {v:?} vs {want}"
        );
    }
    assert!(text.contains("consistent: the same physical position"));
    assert!(text.contains("360.000") && text.contains("0.000"));
    assert!(text.contains("rotary axis B") && text.contains("R-1"));
    let l = line("expanded U (k = 2)");
    let printed = *numbers(&l).last().expect("U");
    assert!((printed - u).abs() <= 0.005 + 1e-9, "{l}: {u}");
}

#[test]
fn a_ratio_error_is_named_an_unstated_reference_is_assumed_and_tolerances_refused() {
    let dir = tempdir();
    // 20 ppm: 25.9″ over the revolution, far beyond 0/360's repeatability.
    let session = session(dir.path(), 20.0);
    let pdf = dir.path().join("c.pdf");
    let o = errmap(&["certificate", s(&session), "--out", s(&pdf)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("closure_mismatch"), "{}", stderr(&o));
    assert!(stderr(&o).contains("±1″ assumed"), "{}", stderr(&o));
    if let Some(text) = pdftotext(&pdf) {
        assert!(
            text.contains("closure_mismatch") && text.contains("beyond"),
            "{text}"
        );
        assert!(text.contains("is assumed"), "{text}");
    }
    let o = errmap(&[
        "certificate",
        s(&session),
        "--out",
        s(&dir.path().join("t.pdf")),
        "--tolerances",
        s(&session),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
