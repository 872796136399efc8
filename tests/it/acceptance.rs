//! Decisions of conformity and the ISO 10360-2 length test (issue 25): the rules at and
//! around every boundary, `acceptance decide`, tolerances on ISO 230-2 results through
//! `table` and `certificate`, a measured ISO 10360-2 test written from a simulated CMM
//! whose true E0 are known, and the virtual test checked against the projection of the
//! error-vector difference on the gauge direction, before and after compensation.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use errmap::acceptance::default_lines;
use errmap::acceptance::{ConformityVerdict, DecisionRule, Limits, Mpe, Rule, aggregate};
use errmap::volumetric::{IdentifyConfig, Machine, Predictor, identify, simulate};
use rand::SeedableRng;
use rand::rngs::StdRng;
use serde_json::Value;

use super::volumetric::{VOLUME, plan_file, random_machine, topo};
use crate::util::{errmap, json, stderr};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

const E: f64 = 1e-9;

fn verdict(
    rule: DecisionRule,
    y: f64,
    u: f64,
    lo: Option<f64>,
    hi: Option<f64>,
) -> ConformityVerdict {
    rule.decide(y, u, Limits::new(lo, hi).expect("limits"))
        .expect("decides")
        .verdict
}

#[test]
fn iso14253_default_rule_at_and_around_every_boundary() {
    use ConformityVerdict::*;
    let r = DecisionRule::default();
    let (lo, hi, u) = (Some(-6.0), Some(6.0), 0.5);
    // Acceptance limits ±5.5, fail beyond ±6.5; the limits themselves are inclusive for
    // pass and not yet fail.
    for (y, want) in [
        (0.0, Pass),
        (5.5, Pass),
        (5.5 - E, Pass),
        (5.5 + E, Indeterminate),
        (6.0, Indeterminate),
        (6.5 - E, Indeterminate),
        (6.5, Indeterminate),
        (6.5 + E, Fail),
        (-5.5, Pass),
        (-5.5 + E, Pass),
        (-5.5 - E, Indeterminate),
        (-6.0, Indeterminate),
        (-6.5, Indeterminate),
        (-6.5 - E, Fail),
        (1e6, Fail),
    ] {
        assert_eq!(verdict(r, y, u, lo, hi), want, "y = {y}");
    }
    let d = r
        .decide(1.0, u, Limits::new(lo, hi).expect("limits"))
        .expect("decides");
    assert_eq!(d.acceptance, [Some(-5.5), Some(5.5)]);
    // U = 0: no indeterminate zone at all.
    for (y, want) in [(6.0, Pass), (6.0 + E, Fail), (-6.0, Pass), (-6.0 - E, Fail)] {
        assert_eq!(verdict(r, y, 0.0, lo, hi), want, "U = 0, y = {y}");
    }
    // A result equal to the computed acceptance limit passes even when U is not exact in
    // binary (6 − 0.3 is not the literal 5.7).
    let d = r
        .decide(0.0, 0.3, Limits::new(None, Some(6.0)).expect("limits"))
        .expect("decides");
    let a = d.acceptance[1].expect("upper");
    assert_eq!(verdict(r, a, 0.3, None, Some(6.0)), Pass);
    assert_eq!(verdict(r, a + 1e-12, 0.3, None, Some(6.0)), Indeterminate);
}

#[test]
fn simple_and_guard_band_rules_at_and_around_every_boundary() {
    use ConformityVerdict::*;
    let simple = DecisionRule::new(Rule::Simple, 1.0).expect("rule");
    let (lo, hi, u) = (Some(-6.0), Some(6.0), 0.5);
    for (y, want) in [
        (6.0, Pass),
        (6.0 - E, Pass),
        (6.0 + E, Fail),
        (-6.0, Pass),
        (-6.0 - E, Fail),
        (6.5 + E, Fail),
    ] {
        assert_eq!(verdict(simple, y, u, lo, hi), want, "simple, y = {y}");
    }
    // Guard r = 0.5: w = 0.25, acceptance ±5.75, never indeterminate.
    let half = DecisionRule::new(Rule::Guard, 0.5).expect("rule");
    for (y, want) in [
        (5.75, Pass),
        (5.75 - E, Pass),
        (5.75 + E, Fail),
        (-5.75, Pass),
        (-5.75 - E, Fail),
        (6.0, Fail),
    ] {
        assert_eq!(verdict(half, y, u, lo, hi), want, "guard 0.5, y = {y}");
    }
    // r = 1 passes what the default rule passes, and fails its indeterminate zone.
    let one = DecisionRule::new(Rule::Guard, 1.0).expect("rule");
    assert_eq!(verdict(one, 5.5, u, lo, hi), Pass);
    assert_eq!(verdict(one, 5.5 + E, u, lo, hi), Fail);
    // r = 0 is simple acceptance.
    let zero = DecisionRule::new(Rule::Guard, 0.0).expect("rule");
    for y in [6.0, 6.0 + E, -6.0 - E, 0.0] {
        assert_eq!(verdict(zero, y, u, lo, hi), verdict(simple, y, u, lo, hi));
    }
}

#[test]
fn one_sided_zones_and_zones_too_narrow_to_pass() {
    use ConformityVerdict::*;
    let r = DecisionRule::default();
    // Upper limit only: the other side is unbounded, not 0.
    assert_eq!(verdict(r, -1e5, 0.5, None, Some(6.0)), Pass);
    assert_eq!(verdict(r, 5.5 + E, 0.5, None, Some(6.0)), Indeterminate);
    let d = r
        .decide(0.0, 0.5, Limits::new(None, Some(6.0)).expect("limits"))
        .expect("decides");
    assert_eq!(d.acceptance, [None, Some(5.5)]);
    // Lower limit only.
    assert_eq!(verdict(r, 1e5, 0.5, Some(-0.5), None), Pass);
    assert_eq!(verdict(r, 0.0, 0.5, Some(-0.5), None), Pass);
    assert_eq!(verdict(r, 0.0 - E, 0.5, Some(-0.5), None), Indeterminate);
    assert_eq!(verdict(r, -1.0 - E, 0.5, Some(-0.5), None), Fail);
    // 2U > T_U − T_L: nothing can pass, only indeterminate or fail.
    for (y, want) in [(0.0, Indeterminate), (0.9, Indeterminate), (0.9 + E, Fail)] {
        assert_eq!(verdict(r, y, 0.5, Some(-0.4), Some(0.4)), want, "y = {y}");
    }
    let guard = DecisionRule::new(Rule::Guard, 1.0).expect("rule");
    assert_eq!(verdict(guard, 0.0, 0.5, Some(-0.4), Some(0.4)), Fail);
    let simple = DecisionRule::new(Rule::Simple, 1.0).expect("rule");
    assert_eq!(verdict(simple, 0.0, 0.5, Some(-0.4), Some(0.4)), Pass);
}

#[test]
fn bad_rule_inputs_are_refused_and_verdicts_aggregate_to_the_worst() {
    let r = DecisionRule::default();
    let lim = Limits::new(None, Some(1.0)).expect("limits");
    assert!(r.decide(0.0, -0.1, lim).is_err());
    assert!(r.decide(0.0, f64::NAN, lim).is_err());
    assert!(r.decide(0.0, f64::INFINITY, lim).is_err());
    assert!(r.decide(f64::NAN, 0.1, lim).is_err());
    assert!(DecisionRule::new(Rule::Guard, -0.1).is_err());
    assert!(DecisionRule::new(Rule::Guard, f64::NAN).is_err());
    assert!(Limits::new(Some(1.0), Some(0.0)).is_err());
    assert!(Limits::new(None, None).is_err());
    assert!(Limits::new(Some(f64::NAN), None).is_err());
    use ConformityVerdict::*;
    assert_eq!(aggregate([Pass, Indeterminate, Pass]), Some(Indeterminate));
    assert_eq!(aggregate([Pass, Fail, Indeterminate]), Some(Fail));
    assert_eq!(aggregate([Pass, Pass]), Some(Pass));
    assert_eq!(aggregate([]), None);
    // The statements begin as ISO/IEC 17025 readers are told to expect.
    assert!(
        r.statement(true, Some(2.0))
            .starts_with("Decision rule: ISO 14253-1:2017 default rule")
    );
    let simple = DecisionRule::new(Rule::Simple, 1.0).expect("rule");
    assert!(
        simple
            .statement(true, None)
            .starts_with("Decision rule: ILAC-G8:09/2019 simple acceptance (w = 0)")
    );
    let g = DecisionRule::new(Rule::Guard, 0.5).expect("rule");
    assert!(g.statement(true, None).starts_with(
        "Decision rule: ILAC-G8:09/2019 binary statement with guard band w = r·U (r = 0.5)"
    ));
    assert!(
        r.statement(false, None)
            .contains("No measurement uncertainty was given")
    );
}

#[test]
fn decide_prints_every_result_in_file_order_and_refuses_bad_rows() -> TestResult {
    let dir = tempfile::tempdir()?;
    let v = write(
        dir.path(),
        "v.csv",
        "id,value,u,lower,upper\nA,5.5,0.5,,6\nB,5.6,0.5,,6\nC,6.6,0.5,,6\nB_mean,-0.1,0.1,-0.5,0.5\n",
    );
    let d = json(&errmap(&["acceptance", "decide", &s(&v), "--json"]));
    assert_eq!(d["rule"], "iso14253");
    assert_eq!(d["guard_fraction"], Value::Null);
    let ids: Vec<&str> = d["results"]
        .as_array()
        .ok_or("results")?
        .iter()
        .filter_map(|r| r["id"].as_str())
        .collect();
    assert_eq!(ids, ["A", "B", "C", "B_mean"]);
    let verdicts: Vec<&str> = d["results"]
        .as_array()
        .ok_or("results")?
        .iter()
        .filter_map(|r| r["verdict"].as_str())
        .collect();
    assert_eq!(verdicts, ["pass", "indeterminate", "fail", "pass"]);
    assert_eq!(d["results"][0]["lower"], Value::Null);
    assert_eq!(
        d["results"][0]["acceptance"],
        serde_json::json!([null, 5.5])
    );
    assert_eq!(
        d["results"][3]["acceptance"],
        serde_json::json!([-0.4, 0.4])
    );
    assert_eq!(d["verdict"], "fail");
    let g = json(&errmap(&[
        "acceptance",
        "decide",
        &s(&v),
        "--rule",
        "guard",
        "--guard-fraction",
        "0.2",
        "--json",
    ]));
    assert_eq!(g["guard_fraction"], 0.2);
    assert_eq!(g["results"][1]["verdict"], "pass"); // 5.6 ≤ 6 − 0.1
    // Bad input: exit 1 naming the file and the row.
    for (body, needle) in [
        (
            "id,value,u,lower,upper\nA,1,0.1,,2\nB,1,0.1,3,2\n",
            "row 2 (line 3)",
        ),
        ("id,value,u,lower,upper\nA,1,0.1,,\n", "row 1 (line 2)"),
        ("id,value,u,lower,upper\nA,1,-0.1,,2\n", "row 1 (line 2)"),
        ("id,value,u,lower,upper\nA,1,0.1,,2\nB,x,0.1,,2\n", "row 2"),
        ("id,value,u\nA,1,0.1\n", "neither"),
    ] {
        let p = write(dir.path(), "bad.csv", body);
        let o = errmap(&["acceptance", "decide", &s(&p), "--json"]);
        assert_eq!(o.status.code(), Some(1), "{body}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("bad.csv") && e.contains(needle), "{body}: {e}");
        assert!(o.stdout.is_empty());
    }
    let o = errmap(&[
        "acceptance",
        "decide",
        &s(&v),
        "--rule",
        "guard",
        "--guard-fraction",
        "-1",
    ]);
    // A flag value out of range: a usage error (docs/cli.md's one rule).
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = errmap(&["acceptance", "decide", &s(&v), "--rule", "strict"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    Ok(())
}

const SESSION: &str = "datasets/physics/example-session.parquet";

/// `table --info` builds the budget from the info file as `certificate` does: a declared
/// drift check enters as the EVE reading term EVE/(2√3) with the info file as its source,
/// and the combined uncertainty at one target changes by exactly that term.
#[test]
fn table_info_enters_the_declared_drift_check_into_the_budget() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = |n: &str| dir.path().join(n).display().to_string();
    let plain = json(&errmap(&[
        "table",
        SESSION,
        "--out",
        &d("t0.csv"),
        "--json",
    ]));
    let info = write(
        dir.path(),
        "info.toml",
        "[drift_check]\neve_um = 3.0\nduration_min = 30.0\n",
    );
    let with = json(&errmap(&[
        "table",
        SESSION,
        "--out",
        &d("t1.csv"),
        "--info",
        &s(&info),
        "--json",
    ]));
    let eve = |doc: &Value| -> Option<Value> {
        doc["lines"][0]["uncertainty"]["budget"]["contributions"]
            .as_array()?
            .iter()
            .find(|c| c["id"] == "eve")
            .cloned()
    };
    let e = eve(&with).ok_or("no EVE term with --info")?;
    let want = 3.0 / (2.0 * 3f64.sqrt());
    let u = e["u"].as_f64().ok_or("u")?;
    assert!((u - want).abs() < 1e-12, "EVE term {u}, want {want}");
    assert!(
        e["source"].as_str().unwrap_or("").contains("info file"),
        "{e}"
    );
    // Without the info file the EVE, if any, comes from the session's own stationary
    // readings, never from a declared check.
    if let Some(p) = eve(&plain) {
        assert!(
            !p["source"].as_str().unwrap_or("").contains("info file"),
            "{p}"
        );
    }
    let at = |doc: &Value| doc["lines"][0]["uncertainty"]["expanded"]["u_c_target_um"].as_f64();
    let (u0, u1) = (at(&plain).ok_or("u_c")?, at(&with).ok_or("u_c")?);
    let u_plain_eve = eve(&plain).and_then(|p| p["u"].as_f64()).unwrap_or(0.0);
    // u_c at one target = √(2·Σ reading terms²) (two readings): replacing one reading
    // term changes u_c² by 2·Δ(u²).
    let du2 = u1 * u1 - u0 * u0;
    let want_du2 = 2.0 * (want * want - u_plain_eve * u_plain_eve);
    assert!(
        (du2 - want_du2).abs() < 1e-9 * want_du2.abs().max(1.0),
        "u_c {u0} → {u1}: Δu_c² {du2}, want {want_du2}"
    );
    Ok(())
}

#[test]
fn table_tolerances_judge_every_line_with_the_certificates_u() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = |n: &str| dir.path().join(n).display().to_string();
    // The lines' values without tolerances.
    let plain = json(&errmap(&[
        "table",
        SESSION,
        "--out",
        &d("t0.csv"),
        "--json",
    ]));
    assert!(plain.get("conformity").is_none());
    let tol = write(
        dir.path(),
        "tol.toml",
        "specification = \"test spec rev. A\"\n[axis.X]\nA = 12.0\nE = 10.0\nR = 1.5\n\
         B_mean = { lower = -0.5, upper = 0.5 }\n[[line]]\naxis = \"X\"\nline_mm = [1.0, 500.0]\nE = 5.0\n",
    );
    let doc = json(&errmap(&[
        "table",
        SESSION,
        "--out",
        &d("t.csv"),
        "--tolerances",
        &s(&tol),
        "--json",
    ]));
    let c = &doc["conformity"];
    assert_eq!(c["specification"], "test spec rev. A");
    assert_eq!(c["rule"], "iso14253");
    assert_eq!(c["k"], 2.0);
    assert!(
        c["statement"]
            .as_str()
            .ok_or("statement")?
            .starts_with("Decision rule: ISO 14253-1:2017 default rule")
    );
    let lines = doc["lines"].as_array().ok_or("lines")?;
    let mut worst = ConformityVerdict::Pass;
    for (k, line) in lines.iter().enumerate() {
        // Same numbers as without tolerances.
        assert_eq!(line["iso230"], plain["lines"][k]["iso230"]);
        let params = line["conformity"]["parameters"]
            .as_array()
            .ok_or("params")?;
        let names: Vec<&str> = params
            .iter()
            .filter_map(|p| p["parameter"].as_str())
            .collect();
        assert_eq!(names, ["E", "A", "R", "B_mean"], "key order");
        let on_500 = line["line_mm"] == serde_json::json!([1.0, 500.0]);
        let mut line_worst = ConformityVerdict::Pass;
        for p in params {
            let field = p["field"].as_str().ok_or("field")?;
            let value = line["iso230"][field].as_f64().ok_or("value")?;
            assert_eq!(p["value_um"].as_f64(), Some(value));
            let u = match field {
                "e_um" | "a_um" => line["uncertainty"]["expanded"]["along_travel_um"].as_f64(),
                _ => line["uncertainty"]["expanded"]["at_one_target_um"].as_f64(),
            }
            .ok_or("u")?;
            assert_eq!(p["u_um"].as_f64(), Some(u));
            let (lo, hi) = match field {
                "e_um" if on_500 => (None, Some(5.0)),
                "e_um" => (None, Some(10.0)),
                "a_um" => (None, Some(12.0)),
                "r_um" => (None, Some(1.5)),
                _ => (Some(-0.5), Some(0.5)),
            };
            // The verdict computed here from the definitions.
            let want = if lo.is_none_or(|l| value >= l + u) && hi.is_none_or(|h| value <= h - u) {
                ConformityVerdict::Pass
            } else if lo.is_some_and(|l| value < l - u) || hi.is_some_and(|h| value > h + u) {
                ConformityVerdict::Fail
            } else {
                ConformityVerdict::Indeterminate
            };
            assert_eq!(
                p["verdict"],
                want.as_str(),
                "{field} on {}",
                line["line_mm"]
            );
            line_worst = line_worst.max(want);
        }
        assert_eq!(line["conformity"]["verdict"], line_worst.as_str());
        worst = worst.max(line_worst);
    }
    assert_eq!(c["verdict"], worst.as_str());
    // The dataset's lines give more than one verdict, so the test can tell them apart.
    let distinct: std::collections::BTreeSet<String> = lines
        .iter()
        .flat_map(|l| {
            l["conformity"]["parameters"]
                .as_array()
                .cloned()
                .unwrap_or_default()
        })
        .filter_map(|p| p["verdict"].as_str().map(str::to_string))
        .collect();
    assert!(distinct.len() >= 2, "{distinct:?}");
    // The error table itself is the same with and without tolerances.
    assert_eq!(std::fs::read(d("t.csv"))?, std::fs::read(d("t0.csv"))?);
    // Bad tolerance files: exit 1 naming the file and the key.
    for (body, key) in [
        ("[axis.X]\nA = 1\n", "specification"),
        ("specification = \"s\"\n[axis.X]\nQ = 1\n", "axis.X.Q"),
        ("specification = \"s\"\n[axis.W]\nA = 1\n", "axis.W"),
        (
            "specification = \"s\"\n[axis.X]\nA = { lower = 2, upper = 1 }\n",
            "axis.X.A",
        ),
        ("specification = \"s\"\n[axis.X]\nA = nan\n", "axis.X.A"),
        ("specification = \"s\"\n[axis.Y]\nA = 1\n", "no tolerance"),
        (
            "specification = \"s\"\n[[line]]\naxis = \"X\"\nline_mm = [9, 9]\nA = 1\n",
            "line[1]",
        ),
        (
            "specification = \"s\"\nrule = \"loose\"\n[axis.X]\nA = 1\n",
            "rule",
        ),
        (
            "specification = \"s\"\nspecfication = \"t\"\n[axis.X]\nA = 1\n",
            "specfication",
        ),
    ] {
        let p = write(dir.path(), "bad.toml", body);
        let o = errmap(&[
            "table",
            SESSION,
            "--out",
            &d("t2.csv"),
            "--tolerances",
            &s(&p),
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(1), "{body}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("bad.toml") && e.contains(key), "{body}: {e}");
    }
    // --rule without --tolerances is a usage error.
    let o = errmap(&["table", SESSION, "--out", &d("t3.csv"), "--rule", "simple"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    Ok(())
}

#[test]
fn the_certificate_gains_its_statement_only_with_tolerances() -> TestResult {
    let dir = tempfile::tempdir()?;
    let d = |n: &str| dir.path().join(n).display().to_string();
    let o = errmap(&["certificate", SESSION, "--out", &d("a.pdf")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = errmap(&["certificate", SESSION, "--out", &d("b.pdf")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = std::fs::read(d("a.pdf"))?;
    assert_eq!(
        a,
        std::fs::read(d("b.pdf"))?,
        "the certificate is reproducible"
    );
    let tol =
        s(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/acceptance/tolerances.toml"));
    let o = errmap(&[
        "certificate",
        SESSION,
        "--out",
        &d("c.pdf"),
        "--tolerances",
        &tol,
        "--rule",
        "simple",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c = std::fs::read(d("c.pdf"))?;
    assert!(c.len() > a.len() && c != a);
    let have = Command::new("pdftotext").arg("-v").output().is_ok();
    if !have {
        eprintln!("skipped: `pdftotext` (poppler-utils) is not installed");
        return Ok(());
    }
    let t = Command::new("pdftotext")
        .arg(d("c.pdf"))
        .arg("-")
        .output()?;
    let text = String::from_utf8(t.stdout)?;
    for needle in [
        "Statement of conformity",
        "Specification:",
        "Decision rule: ILAC-G8:09/2019 simple acceptance (w = 0)",
        "acceptance zone",
        "Overall verdict:",
    ] {
        assert!(text.contains(needle), "{needle:?} missing");
    }
    let t = Command::new("pdftotext")
        .arg(d("a.pdf"))
        .arg("-")
        .output()?;
    assert!(!String::from_utf8(t.stdout)?.contains("Statement of conformity"));
    Ok(())
}

/// A simulated CMM's ISO 10360-2 test: the default positions over `VOLUME`, 5 lengths
/// each, 3 repetitions; measured = calibrated + (true E0 + noise)/1000, the true E0 the
/// projection −u·(E(P2) − E(P1)) of the machine's error vectors. Returns the CSV text
/// and, per row, the true E0 + noise, µm.
fn simulated_test(m: &Machine, rep_noise: &[f64]) -> (String, Vec<(String, f64, f64)>) {
    let mut csv = String::from(
        "position,x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,nominal_mm,calibrated_mm,measured_mm,repetition\n",
    );
    let mut truth = Vec::new();
    let mut k = 0;
    for (id, a, b) in default_lines([[0.0; 3], VOLUME[1]]) {
        let d = [0, 1, 2].map(|i| b[i] - a[i]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let u = d.map(|c| c / len);
        for (j, f) in [0.1, 0.25, 0.4, 0.55, 0.7].iter().enumerate() {
            let nominal = (f * len / 10.0).round() * 10.0;
            // A calibrated gauge a few tenths of a µm off its nominal length.
            let calibrated = nominal + 1e-4 * (j as f64 - 2.0);
            let p1 = [0, 1, 2].map(|i| a[i] + 0.1 * len * u[i]);
            let p2 = [0, 1, 2].map(|i| p1[i] + calibrated * u[i]);
            let e1 = m.error_um(p1, [0.0; 3]);
            let e2 = m.error_um(p2, [0.0; 3]);
            let e_true = -(0..3).map(|i| u[i] * (e2[i] - e1[i])).sum::<f64>();
            for rep in 1..=3 {
                let e0 = e_true + rep_noise[k % rep_noise.len()];
                k += 1;
                let measured = calibrated + e0 * 1e-3;
                let _ = writeln!(
                    csv,
                    "{id},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{nominal},{calibrated:.7},{measured:.10},{rep}",
                    p1[0], p1[1], p1[2], p2[0], p2[1], p2[2]
                );
                truth.push((id.clone(), calibrated, e0));
            }
        }
    }
    (csv, truth)
}

fn csv_without_rows(csv: &str, drop: &[usize]) -> String {
    csv.lines()
        .enumerate()
        .filter(|(i, _)| *i == 0 || !drop.contains(i))
        .map(|(_, l)| format!("{l}\n"))
        .collect()
}

#[test]
fn a_simulated_cmms_iso10360_test_gives_its_known_e0_r0_and_verdicts() -> TestResult {
    let mut rng = StdRng::seed_from_u64(25);
    let m = random_machine(topo("YXZ"), &mut rng);
    let noise: Vec<f64> = (0..105)
        .map(|i| 0.15 * errmap::base::gaussian(&mut rng) + if i % 50 == 7 { 1.0 } else { 0.0 })
        .collect();
    let (csv, truth) = simulated_test(&m, &noise);
    let dir = tempfile::tempdir()?;
    let test = write(dir.path(), "test.csv", &csv);
    let mpe = Mpe::parse("min(1.0 + L/400, 3.0)", "--mpe")?;
    let u = 0.3;
    // Independent verdicts from the truth; the data must hold all three.
    let want: Vec<ConformityVerdict> = truth
        .iter()
        .map(|(_, l, e0)| {
            let limit = mpe.at(*l);
            if e0.abs() <= limit - u {
                ConformityVerdict::Pass
            } else if e0.abs() > limit + u {
                ConformityVerdict::Fail
            } else {
                ConformityVerdict::Indeterminate
            }
        })
        .collect();
    for v in [ConformityVerdict::Pass, ConformityVerdict::Fail] {
        assert!(want.contains(&v), "the simulated test holds no {v}");
    }
    let report = dir.path().join("report");
    let doc = json(&errmap(&[
        "acceptance",
        "iso10360",
        &s(&test),
        "--mpe",
        "min(1.0 + L/400, 3.0)",
        "--u-um",
        "0.3",
        "--mpl-r0",
        "1.0",
        "--report",
        &s(&report),
        "--json",
    ]));
    assert_eq!(doc["standard"], "ISO 10360-2:2009");
    assert_eq!(
        doc["mpe"],
        serde_json::json!({"formula": "min(1.0 + L/400, 3.0)", "a_um": 1.0, "k": 400.0, "b_um": 3.0})
    );
    let ms = doc["measurements"].as_array().ok_or("measurements")?;
    assert_eq!(ms.len(), 105);
    for (k, (m, (pos, l, e0))) in ms.iter().zip(&truth).enumerate() {
        assert_eq!(m["row"], k + 1);
        assert_eq!(m["position"], pos.as_str());
        assert_eq!(m["repetition"], k % 3 + 1);
        assert_eq!(m["gauge"], (k / 3) % 5 + 1);
        assert!(
            (m["e0_um"].as_f64().ok_or("e0")? - e0).abs() < 1e-4,
            "row {}",
            k + 1
        );
        assert!((m["mpe_um"].as_f64().ok_or("mpe")? - mpe.at(*l)).abs() < 1e-9);
        assert_eq!(m["u_um"], 0.3);
        assert_eq!(m["verdict"], want[k].as_str(), "row {}", k + 1);
    }
    let gauges = doc["gauges"].as_array().ok_or("gauges")?;
    assert_eq!(gauges.len(), 35);
    let mut r0_fail = false;
    for (g, chunk) in gauges.iter().zip(truth.chunks(3)) {
        let e: Vec<f64> = chunk.iter().map(|t| t.2).collect();
        let r0 =
            e.iter().copied().fold(f64::MIN, f64::max) - e.iter().copied().fold(f64::MAX, f64::min);
        assert!((g["r0_um"].as_f64().ok_or("r0")? - r0).abs() < 1e-4);
        assert_eq!(g["rows"].as_array().map(Vec::len), Some(3));
        let v = if r0 <= 1.0 { "pass" } else { "fail" };
        r0_fail |= v == "fail";
        assert_eq!(g["verdict_r0"], v);
    }
    assert!(r0_fail, "the injected 1 µm outliers make an R0 fail");
    assert_eq!(doc["verdict_r0"], "fail");
    assert_eq!(doc["verdict"], "fail");
    assert_eq!(doc["deviations"], serde_json::json!([]));
    assert_eq!(doc["summary"]["positions"], 7);
    let counts = &doc["summary"]["counts"];
    for v in [
        ConformityVerdict::Pass,
        ConformityVerdict::Indeterminate,
        ConformityVerdict::Fail,
    ] {
        assert_eq!(counts[v.as_str()], want.iter().filter(|w| **w == v).count());
    }
    for f in [
        "report.md",
        "measurements.csv",
        "e0_vs_length.png",
        "e0_vs_length.svg",
    ] {
        assert!(report.join(f).is_file(), "{f}");
    }
    let md = std::fs::read_to_string(report.join("report.md"))?;
    assert!(md.contains("**Verdict: fail**") && md.contains("Decision rule: ISO 14253-1:2017"));

    // Six positions, one of them with four lengths: evaluated, the deviations named.
    let short: Vec<usize> = (91..=105).chain(4..=6).collect();
    let p = write(dir.path(), "short.csv", &csv_without_rows(&csv, &short));
    let doc = json(&errmap(&[
        "acceptance",
        "iso10360",
        &s(&p),
        "--mpe",
        "2+L/300",
        "--json",
    ]));
    let dev = doc["deviations"].to_string();
    assert!(
        dev.contains("6 position(s)") && dev.contains("position `1`: 4 test length(s)"),
        "{dev}"
    );
    assert!(
        doc["statement"]
            .as_str()
            .ok_or("statement")?
            .contains("No measurement uncertainty")
    );
    Ok(())
}

#[test]
fn bad_iso10360_files_exit_1_naming_file_and_rows() -> TestResult {
    let m = Machine::perfect(topo("YXZ"));
    let (csv, _) = simulated_test(&m, &[0.0]);
    let dir = tempfile::tempdir()?;
    let run = |name: &str, body: &str, mpe: &str| -> (Option<i32>, String) {
        let p = write(dir.path(), name, body);
        let o = errmap(&["acceptance", "iso10360", &s(&p), "--mpe", mpe, "--json"]);
        assert!(o.stdout.is_empty());
        (o.status.code(), stderr(&o))
    };
    // A missing repetition: the file, position, length and the rows present.
    let (c, e) = run("miss.csv", &csv_without_rows(&csv, &[3]), "2+L/300");
    assert_eq!(c, Some(1), "{e}");
    assert!(
        e.contains("miss.csv")
            && e.contains("position `1`")
            && e.contains("missing 3")
            && e.contains("rows 1, 2"),
        "{e}"
    );
    // A repeated repetition: both rows.
    let dup: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| if i == 3 { l.replace(",3", ",2") } else { l.to_string() } + "\n")
        .collect();
    let (c, e) = run("dup.csv", &dup, "2+L/300");
    assert_eq!(c, Some(1), "{e}");
    assert!(
        e.contains("rows 2 and 3") && e.contains("repetition 2"),
        "{e}"
    );
    // End points that do not match the calibrated length: the row.
    let moved: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 5 {
                let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                f[4] = format!("{}", f[4].parse::<f64>().unwrap_or(0.0) + 5.0);
                f.join(",") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let (c, e) = run("moved.csv", &moved, "2+L/300");
    assert_eq!(c, Some(1), "{e}");
    assert!(
        e.contains("moved.csv: row 5 (line 6)") && e.contains("apart"),
        "{e}"
    );
    // Measured 2 mm off the calibrated length: the row and the column.
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let mut f: Vec<String> = lines[7].split(',').map(str::to_string).collect();
    f[9] = format!("{}", f[8].parse::<f64>().unwrap_or(0.0) + 2.0);
    lines[7] = f.join(",");
    let (c, e) = run("off.csv", &(lines.join("\n") + "\n"), "2+L/300");
    assert_eq!(c, Some(1), "{e}");
    assert!(
        e.contains("row 7 (line 8)") && e.contains("measured_mm"),
        "{e}"
    );
    // Both column sets, and neither.
    let both: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l},ux,uy,uz\n")
            } else {
                format!("{l},1,0,0\n")
            }
        })
        .collect();
    let (c, e) = run("both.csv", &both, "2+L/300");
    assert_eq!(c, Some(1), "{e}");
    assert!(
        e.contains("both.csv") && e.contains("give one of them"),
        "{e}"
    );
    // An unparsable or implausible MPE: a bad flag value, exit 2 (docs/cli.md). Issue 40
    // item 5: `2+L/1e-300` passed all 105 measurements, a zero MPE failed them all.
    for (bad, part) in [
        ("2+L", ""),
        ("2 + L/0", "K"),
        ("two", ""),
        ("max(1+L/3,2)", ""),
        ("2+L/300 µm", ""),
        ("2+L/1e-300", "K"),
        ("1e308+L/333", "A"),
        ("0", "B"),
        ("min(2+L/333,-1)", "B"),
    ] {
        let (c, e) = run("ok.csv", &csv, bad);
        assert_eq!(c, Some(2), "{bad}: {e}");
        assert!(e.contains("--mpe") && e.contains(part), "{bad}: {e}");
    }
    Ok(())
}

/// `volumetric iso10360` against an independent computation: each test length's E is the
/// projection of the model's error-vector difference on the gauge direction (from the
/// grid prediction), and lies within a few σ of the simulated machine's truth.
#[test]
fn the_virtual_test_is_the_projection_of_the_error_vector_difference() -> TestResult {
    let mut rng = StdRng::seed_from_u64(2510);
    let topology = topo("YXZ");
    let truth = random_machine(topology, &mut rng);
    let plan = plan_file(Some("rich"), 9, 0.1).validate(Path::new("test"))?;
    let table = simulate(&truth, &plan);
    let mut cfg = IdentifyConfig::new(topology);
    cfg.degree = errmap::volumetric::Degree::Fixed(3);
    let id = identify(&table, &cfg)?;
    let dir = tempfile::tempdir()?;
    let model = dir.path().join("model.json");
    std::fs::write(&model, serde_json::to_string(&id.doc(9, true))?)?;
    let doc = json(&errmap(&[
        "volumetric",
        "iso10360",
        "--model",
        &s(&model),
        "--mpe",
        "1.5+L/250",
        "--compensated",
        "--report",
        &s(&dir.path().join("virtual")),
        "--json",
    ]));
    assert_eq!(doc["virtual"], true);
    assert_eq!(doc["plan"], "default");
    assert_eq!(doc["model_residual"], "consistent");
    let vol = &doc["volume_mm"];
    let lo: Vec<f64> = (0..3).filter_map(|k| vol[0][k].as_f64()).collect();
    let hi: Vec<f64> = (0..3).filter_map(|k| vol[1][k].as_f64()).collect();
    assert_eq!(lo, [0.0; 3]);
    assert_eq!(hi, VOLUME[1]);
    let predictor = Predictor::read(&model)?;
    let ms = doc["measurements"].as_array().ok_or("measurements")?;
    assert_eq!(ms.len(), 105);
    let mut worst_z: f64 = 0.0;
    for m in ms {
        let p = |k: &str| -> [f64; 3] { [0, 1, 2].map(|i| m[k][i].as_f64().unwrap_or(f64::NAN)) };
        let (p1, p2) = (p("p1_mm"), p("p2_mm"));
        let d = [0, 1, 2].map(|i| p2[i] - p1[i]);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert!((l - m["length_mm"].as_f64().ok_or("L")?).abs() < 1e-9);
        let u = d.map(|c| c / l);
        let v = predictor.predict_grid(&[p1, p2], [0.0; 3])?;
        let e_model = -(0..3).map(|i| u[i] * (v[1].0[i] - v[0].0[i])).sum::<f64>();
        let e = m["e_um"].as_f64().ok_or("e")?;
        assert!((e - e_model).abs() < 1e-9, "{e} against {e_model}");
        let t1 = truth.error_um(p1, [0.0; 3]);
        let t2 = truth.error_um(p2, [0.0; 3]);
        let e_true = -(0..3).map(|i| u[i] * (t2[i] - t1[i])).sum::<f64>();
        let sigma = m["sigma_um"].as_f64().ok_or("sigma")?;
        assert!(sigma > 0.0);
        worst_z = worst_z.max((e - e_true).abs() / sigma);
        // The verdict from its definition: U = 2σ.
        let limit = 1.5 + l / 250.0;
        let want = if e.abs() <= limit - 2.0 * sigma {
            "pass"
        } else if e.abs() > limit + 2.0 * sigma {
            "fail"
        } else {
            "indeterminate"
        };
        assert_eq!(m["verdict"], want);
    }
    assert!(
        worst_z < 5.0,
        "the prediction is {worst_z:.2} σ from the truth"
    );
    // Position 1, gauge 1: 10 % of the space diagonal centred on its midpoint.
    let diag = (VOLUME[1][0].powi(2) + VOLUME[1][1].powi(2) + VOLUME[1][2].powi(2)).sqrt();
    assert!((ms[0]["length_mm"].as_f64().ok_or("L")? - 0.1 * diag).abs() < 1e-9);
    assert!((ms[0]["p1_mm"][0].as_f64().ok_or("x")? - (400.0 - 0.05 * 800.0)).abs() < 1e-9);
    // After a 21-point compensation table of a cubic model, only the table's
    // interpolation error remains: far below the error it corrects.
    let c = &doc["compensated"];
    let before = doc["max_abs_e_um"].as_f64().ok_or("max")?;
    let after = c["max_abs_e_um"].as_f64().ok_or("after")?;
    assert!(before > 1.0 && after < 0.05 * before, "{before} → {after}");
    // What is left is stated, not 0: the largest √((2σ)² + 0.1²) over the lengths
    // (issue 40: the model compensating itself reported 0.000 µm).
    let floor = c["measurements"]
        .as_array()
        .ok_or("after")?
        .iter()
        .map(|m| {
            let s = m["sigma_um"].as_f64().unwrap_or(f64::NAN);
            (4.0 * s * s + 0.01).sqrt()
        })
        .fold(0.0, f64::max);
    let stated = c["floor_um"].as_f64().ok_or("floor")?;
    assert!(
        (stated - floor).abs() < 1e-12 && stated > 0.1,
        "{stated} vs {floor}"
    );
    assert!(dir.path().join("virtual/report.md").is_file());
    assert!(dir.path().join("virtual/e_vs_length.svg").is_file());
    Ok(())
}

/// A machine whose components are linear: the compensation table reproduces it exactly,
/// so after compensation only the angular errors times the probe offset remain —
/// computed here from the machine as E(P; p) − E(P; 0).
#[test]
fn after_compensation_only_the_probe_offsets_abbe_terms_remain() -> TestResult {
    let dir = tempfile::tempdir()?;
    let mut toml = String::from(
        "topology = \"YXZ\"\n[squareness_urad]\nE_C0Y = 8.0\nE_B0Z = -5.0\nE_A0Z = 3.0\n[components]\n",
    );
    let names = ["X", "Y", "Z", "A", "B", "C"];
    for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
        for (j, n) in names.iter().enumerate() {
            let c = 0.002 * (1.0 + j as f64) * if (j + k) % 2 == 0 { 1.0 } else { -1.0 };
            let _ = writeln!(toml, "E_{n}{axis} = {{ poly = [{c}] }}");
        }
    }
    let model = write(dir.path(), "machine.toml", &toml);
    let machine = Machine::read(&model)?;
    let probe = [20.0, -30.0, -100.0];
    let plan = write(
        dir.path(),
        "plan.toml",
        "volume_mm = [[0, 0, 0], [600, 500, 400]]\nprobe_mm = [20.0, -30.0, -100.0]\nplacement = \"start\"\n",
    );
    let doc = json(&errmap(&[
        "volumetric",
        "iso10360",
        "--model",
        &s(&model),
        "--plan",
        &s(&plan),
        "--compensated",
        "--json",
    ]));
    assert_eq!(doc["model_residual"], "exact");
    assert_eq!(doc["verdict"], Value::Null);
    // An exact model (σ = 0) leaves the table's 0.1 µm step.
    assert_eq!(doc["compensated"]["floor_um"], 0.1);
    let before = doc["measurements"].as_array().ok_or("before")?;
    let after = doc["compensated"]["measurements"]
        .as_array()
        .ok_or("after")?;
    assert_eq!(before.len(), 105);
    let mut abbe_seen: f64 = 0.0;
    for (b, a) in before.iter().zip(after) {
        let p = |k: &str| -> [f64; 3] { [0, 1, 2].map(|i| b[k][i].as_f64().unwrap_or(f64::NAN)) };
        let (p1, p2) = (p("p1_mm"), p("p2_mm"));
        let d = [0, 1, 2].map(|i| p2[i] - p1[i]);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let u = d.map(|c| c / l);
        let proj =
            |e2: [f64; 3], e1: [f64; 3]| -(0..3).map(|i| u[i] * (e2[i] - e1[i])).sum::<f64>();
        let e_full = proj(machine.error_um(p2, probe), machine.error_um(p1, probe));
        assert!((b["e_um"].as_f64().ok_or("e")? - e_full).abs() < 1e-9);
        assert_eq!(b["sigma_um"], 0.0);
        let abbe = e_full
            - proj(
                machine.error_um(p2, [0.0; 3]),
                machine.error_um(p1, [0.0; 3]),
            );
        let got = a["e_um"].as_f64().ok_or("after")?;
        assert!((got - abbe).abs() < 1e-7, "{got} against {abbe}");
        abbe_seen = abbe_seen.max(abbe.abs());
    }
    assert!(abbe_seen > 0.1, "the probe offset must matter: {abbe_seen}");
    // A machine model has no measured range: the default plan needs volume_mm.
    let o = errmap(&["volumetric", "iso10360", "--model", &s(&model)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    Ok(())
}

#[test]
fn virtual_plans_refuse_unknown_keys_and_gauges_outside_the_model() -> TestResult {
    let dir = tempfile::tempdir()?;
    let model =
        s(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/volumetric/model.toml"));
    for (body, needle) in [
        (
            "volume_mm = [[0, 0, 0], [600, 500, 400]]\nfractons = [0.1]\n",
            "fractons",
        ),
        (
            "volume_mm = [[0, 0, 0], [600, 500, 400]]\nfractions = [0.1, 1.5]\n",
            "fractions",
        ),
        (
            "volume_mm = [[0, 0, 0], [600, 500, 400]]\n[[position]]\nid = \"a\"\nstart_mm = [0, 0, 0]\nend_mm = [0, 0, 0]\n",
            "position[1].end_mm",
        ),
    ] {
        let p = write(dir.path(), "plan.toml", body);
        let o = errmap(&[
            "volumetric",
            "iso10360",
            "--model",
            &model,
            "--plan",
            &s(&p),
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(1), "{body}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("plan.toml") && e.contains(needle), "{body}: {e}");
    }
    // An identified model: a gauge end beyond its measured range is refused, named.
    let mut rng = StdRng::seed_from_u64(3);
    let truth = random_machine(topo("YXZ"), &mut rng);
    let table = simulate(
        &truth,
        &plan_file(Some("rich"), 4, 0.1).validate(Path::new("test"))?,
    );
    let mut cfg = IdentifyConfig::new(topo("YXZ"));
    cfg.degree = errmap::volumetric::Degree::Fixed(2);
    let id = identify(&table, &cfg)?;
    let json_model = dir.path().join("model.json");
    std::fs::write(&json_model, serde_json::to_string(&id.doc(5, true))?)?;
    let p = write(
        dir.path(),
        "far.toml",
        "[[position]]\nid = \"far\"\nstart_mm = [0, 0, 0]\nend_mm = [900, 0, 0]\nlengths_mm = [100, 850]\nplacement = \"start\"\n",
    );
    let o = errmap(&[
        "volumetric",
        "iso10360",
        "--model",
        &s(&json_model),
        "--plan",
        &s(&p),
        "--mpe",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("model.json") && e.contains("position `far`, gauge 2") && e.contains("outside"),
        "{e}"
    );
    let o = errmap(&[
        "volumetric",
        "iso10360",
        "--model",
        &s(&json_model),
        "--mpe",
        "1+L/",
    ]);
    // A flag value that does not parse: exit 2 (docs/cli.md's one rule).
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--mpe"));
    Ok(())
}

proptest::proptest! {
    /// Any text given as an MPE parses or is refused; it never panics. A well-formed
    /// formula gives its definition's value at any length.
    #[test]
    fn mpe_formulas_never_panic_and_evaluate_as_written(
        text in "\\PC{0,24}",
        a in 0.0f64..20.0,
        k in 1.0f64..2000.0,
        b in 0.0f64..50.0,
        l in 0.0f64..5000.0,
    ) {
        let _ = Mpe::parse(&text, "--mpe");
        let m = Mpe::parse(&format!("{a} + L/{k}"), "--mpe").expect("A+L/K");
        proptest::prop_assert!((m.at(l) - (a + l / k)).abs() <= 1e-9 * (1.0 + a + l / k));
        let m = Mpe::parse(&format!("min({a}+L/{k},{b})"), "--mpe").expect("min");
        proptest::prop_assert!((m.at(l) - (a + l / k).min(b)).abs() <= 1e-9 * (1.0 + b));
    }
}
