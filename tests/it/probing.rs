//! The ISO 10360-5 probing test and the CMM certificate (issue 37): the least-squares
//! sphere against analytic truths (planted deviations orthogonal to the sphere's own
//! parameters leave the true sphere the least-squares one, so centre, radius, form and
//! every residual are known exactly), each decision rule reaching each of its verdicts on
//! form, size and location, the multi-stylus location from known stylus offsets, the
//! refusals in the contract's order, the report and the certificate's text.

use std::path::{Path, PathBuf};
use std::process::Command;

use errmap::acceptance::probing::fit_sphere;
use errmap::acceptance::probing::{
    PerQuantity, ProbePoint, ProbingConfig, ProbingOptions, SphereFile, evaluate,
};
use errmap::acceptance::probing::{
    SimStylus, SimTest, direction, frame, simulate, standard_targets_deg, to_csv,
};
use errmap::acceptance::{ConformityVerdict, Rule};
use nalgebra::{DMatrix, DVector};
use serde_json::Value;

use crate::util::{dataset, errmap, json, root, s, stderr, tempdir};

type TestResult = Result<(), Box<dyn std::error::Error>>;

const D_CAL: f64 = 29.99962;

/// `raw` with its components along 1, n_x, n_y, n_z removed: planted on the sphere, such
/// deviations leave the true centre and radius the least-squares ones (the gradient
/// −Σδ_i(n_i, 1) vanishes there).
fn orthogonal(raw: &[f64], normals: &[[f64; 3]]) -> Vec<f64> {
    let n = raw.len();
    let b = DMatrix::from_fn(n, 4, |i, j| if j == 3 { 1.0 } else { normals[i][j] });
    let y = DVector::from_column_slice(raw);
    let coef = (b.transpose() * &b)
        .lu()
        .solve(&(b.transpose() * &y))
        .expect("the basis is regular");
    (y - b * coef).iter().copied().collect()
}

/// Points at `targets` (θ, φ in degrees about `pole`) on the sphere (c, r) with a planted
/// lobing `amp_um`·cos(3φ)·sin θ plus a two-lobed term, made orthogonal; returns the points
/// and the deviations actually planted, mm.
fn planted(
    c: [f64; 3],
    r: f64,
    pole: [f64; 3],
    targets: &[(f64, f64)],
    amp_um: f64,
) -> (Vec<[f64; 3]>, Vec<f64>) {
    let f = frame(pole);
    let normals: Vec<[f64; 3]> = targets.iter().map(|&(t, p)| direction(&f, t, p)).collect();
    let raw: Vec<f64> = targets
        .iter()
        .map(|&(t, p)| {
            let (t, p) = (t.to_radians(), p.to_radians());
            amp_um * 1e-3 * (t.sin() * (3.0 * p).cos() + 0.4 * (2.0 * p + 0.3).sin() * t.cos())
        })
        .collect();
    let d = orthogonal(&raw, &normals);
    let pts = normals
        .iter()
        .zip(&d)
        .map(|(n, d)| [0, 1, 2].map(|k| c[k] + (r + d) * n[k]))
        .collect();
    (pts, d)
}

fn range(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
}

/// A 60° cap: 5 rings of 5 points from 0° to 60°.
fn cap_targets() -> Vec<(f64, f64)> {
    let mut t = Vec::new();
    for ring in 0..5 {
        for j in 0..5 {
            t.push((
                12.0 + 12.0 * ring as f64 * 0.8 + 2.0 * j as f64,
                72.0 * j as f64 + 13.0 * ring as f64,
            ));
        }
    }
    t.push((60.0, 5.0));
    t
}

#[test]
fn the_fit_finds_analytic_spheres_with_planted_lobing_to_a_nanometre() {
    type Case = (&'static str, [f64; 3], f64, [f64; 3], Vec<(f64, f64)>);
    let cases: [Case; 3] = [
        (
            "hemisphere",
            [10.0, -5.0, 2.0],
            12.5,
            [0.0, 0.0, 1.0],
            standard_targets_deg(),
        ),
        (
            "60° cap",
            [0.0, 0.0, 0.0],
            15.0,
            [0.3, -0.2, 1.0],
            cap_targets(),
        ),
        (
            "far from the origin",
            [1500.0, -800.0, 600.0],
            14.9998,
            [1.0, 1.0, 0.2],
            standard_targets_deg(),
        ),
    ];
    for (name, c, r, pole, targets) in cases {
        let (pts, d) = planted(c, r, pole, &targets, 0.8);
        let f = fit_sphere(&pts).expect("fits");
        for (got, want) in f.centre_mm.iter().zip(c) {
            assert!(
                (got - want).abs() < 1e-9,
                "{name}: centre {:?}",
                f.centre_mm
            );
        }
        assert!(
            (f.radius_mm - r).abs() < 1e-9,
            "{name}: radius {}",
            f.radius_mm
        );
        assert!((f.form_mm() - range(&d)).abs() < 1e-9, "{name}: form");
        for (got, want) in f.residuals_mm.iter().zip(&d) {
            assert!(
                (got - want).abs() < 1e-9,
                "{name}: residual {got} vs {want}"
            );
        }
        assert!(range(&d) > 1e-3, "{name}: the planted form is not trivial");
    }
}

fn sphere_toml(d_mm: f64, extra: &str) -> String {
    format!(
        "[sphere]\nid = \"test sphere\"\ndiameter_mm = {d_mm}\nu_diameter_um = 0.1\nform_um = \
         0.06\nu_form_um = 0.03\n{extra}"
    )
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn points_of(stylus: &str, pts: &[[f64; 3]]) -> Vec<ProbePoint> {
    pts.iter()
        .enumerate()
        .map(|(i, p)| ProbePoint {
            row: i + 1,
            stylus: stylus.into(),
            point: i + 1,
            p_mm: *p,
        })
        .collect()
}

#[test]
fn the_command_reports_the_planted_form_size_and_residuals() -> TestResult {
    let dir = tempdir();
    let (c, size_um) = ([300.0, 200.0, -100.0], 0.7);
    let r = D_CAL / 2.0 + size_um * 1e-3 / 2.0;
    let (pts, d) = planted(c, r, [0.0, 0.0, 1.0], &standard_targets_deg(), 0.6);
    let csv = write(dir.path(), "p.csv", &to_csv(&points_of("T1", &pts)));
    let sph = write(
        dir.path(),
        "s.toml",
        &sphere_toml(
            D_CAL,
            "[mpe]\nform_um = 1.9\nsize_um = 1.4\n[uncertainty]\nform_um = 0.1\nsize_um = 0.2\n",
        ),
    );
    let o = errmap(&[
        "acceptance",
        "iso10360-5",
        s(&csv),
        "--sphere",
        s(&sph),
        "--json",
    ]);
    let j = json(&o);
    assert_eq!(j["standard"], "ISO 10360-5:2010");
    assert_eq!(j["test"], "single-stylus");
    assert_eq!(j["points"], 25);
    assert!(j["location"].is_null());
    assert_eq!(j["deviations"].as_array().map(Vec::len), Some(0));
    let num = |v: &Value| v.as_f64().expect("number");
    assert!((num(&j["form"]["value_um"]) - range(&d) * 1e3).abs() < 1e-6);
    assert!((num(&j["size"]["value_um"]) - size_um).abs() < 1e-6);
    assert!((num(&j["fit"]["diameter_mm"]) - 2.0 * r).abs() < 1e-9);
    for k in 0..3 {
        assert!((num(&j["fit"]["centre_mm"][k]) - c[k]).abs() < 1e-9);
    }
    let u_form = (0.06f64.powi(2) + 0.03f64.powi(2) + 0.1f64.powi(2)).sqrt();
    let u_size = (0.1f64.powi(2) + 0.2f64.powi(2)).sqrt();
    assert!((num(&j["form"]["u_um"]) - u_form).abs() < 1e-12);
    assert!((num(&j["size"]["u_um"]) - u_size).abs() < 1e-12);
    assert!(j["form"]["acceptance_um"][0].is_null());
    assert!((num(&j["form"]["acceptance_um"][1]) - (1.9 - u_form)).abs() < 1e-12);
    assert!((num(&j["size"]["acceptance_um"][0]) - (-1.4 + u_size)).abs() < 1e-12);
    let res = j["residuals"].as_array().expect("residuals");
    assert_eq!(res.len(), 25);
    for (k, (x, want)) in res.iter().zip(&d).enumerate() {
        assert_eq!(x["row"], k + 1);
        assert_eq!(x["point"], k + 1);
        assert_eq!(x["stylus"], "T1");
        assert!((num(&x["r_um"]) - want * 1e3).abs() < 1e-6);
    }
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / 25.0).sqrt() * 1e3;
    assert!((num(&j["fit"]["rms_um"]) - rms).abs() < 1e-6);
    assert_eq!(j["verdict"], "pass");
    assert!(j["guard_fraction"].is_null());
    assert!(
        j["statement"]
            .as_str()
            .is_some_and(|t| t.starts_with("Decision rule: ISO 14253-1:2017 default rule"))
    );
    Ok(())
}

/// One stylus on the standard's targets with form `form_um` (planted, exact) and size
/// error `size_um`, judged with `mpe` and `rule`.
fn judged(
    form_um: f64,
    size_um: f64,
    mpe: [f64; 2],
    rule: Rule,
    r: f64,
) -> (ConformityVerdict, ConformityVerdict, [f64; 2]) {
    let radius = D_CAL / 2.0 + size_um * 1e-3 / 2.0;
    let (pts, d) = planted(
        [0.0; 3],
        radius,
        [0.0, 0.0, 1.0],
        &standard_targets_deg(),
        1.0,
    );
    let scale = form_um * 1e-3 / range(&d);
    let f = frame([0.0, 0.0, 1.0]);
    let pts: Vec<[f64; 3]> = pts
        .iter()
        .zip(&d)
        .zip(standard_targets_deg())
        .map(|((_, dev), (t, p))| {
            let n = direction(&f, t, p);
            [0, 1, 2].map(|k| (radius + dev * scale) * n[k])
        })
        .collect();
    let path = Path::new("p.csv");
    let file = SphereFile::parse(
        &sphere_toml(D_CAL, "[uncertainty]\nform_um = 0.1\n"),
        Path::new("s.toml"),
    )
    .expect("sphere");
    let options = ProbingOptions {
        mpe: PerQuantity {
            form_um: Some(mpe[0]),
            size_um: Some(mpe[1]),
            location_um: None,
        },
        rule: Some(rule),
        guard_fraction: Some(r),
    };
    let config = ProbingConfig::resolve(Path::new("s.toml"), file, &options).expect("config");
    let out = evaluate(path, &points_of("A", &pts), &config).expect("evaluates");
    assert!(
        (out.form.value_um - form_um).abs() < 1e-6,
        "form {}",
        out.form.value_um
    );
    assert!(
        (out.size.value_um - size_um).abs() < 1e-6,
        "size {}",
        out.size.value_um
    );
    (
        out.form.verdict,
        out.size.verdict,
        [out.form.u_um, out.size.u_um],
    )
}

#[test]
fn every_rule_reaches_each_of_its_verdicts_on_form_and_size() {
    use ConformityVerdict::*;
    let (form, size) = (1.5, -0.6);
    let (_, _, [uf, us]) = judged(form, size, [9.0, 9.0], Rule::Simple, 1.0);
    let e = 0.01;
    // ISO 14253-1: pass inside MPE − U, fail beyond MPE + U, indeterminate between.
    for (mf, want) in [
        (form + uf + e, Pass),
        (form, Indeterminate),
        (form - uf - e, Fail),
    ] {
        assert_eq!(
            judged(form, size, [mf, 9.0], Rule::Iso14253, 1.0).0,
            want,
            "form, MPE {mf}"
        );
    }
    let ms = size.abs();
    for (m, want) in [
        (ms + us + e, Pass),
        (ms, Indeterminate),
        (ms - us - e, Fail),
    ] {
        assert_eq!(
            judged(form, size, [9.0, m], Rule::Iso14253, 1.0).1,
            want,
            "size, MPE {m}"
        );
    }
    // Simple acceptance: the MPE itself.
    for (mf, want) in [(form + e, Pass), (form - e, Fail)] {
        assert_eq!(judged(form, size, [mf, 9.0], Rule::Simple, 1.0).0, want);
    }
    for (m, want) in [(ms + e, Pass), (ms - e, Fail)] {
        assert_eq!(judged(form, size, [9.0, m], Rule::Simple, 1.0).1, want);
    }
    // Guard band w = 0.5·U: binary.
    for (mf, want) in [(form + 0.5 * uf + e, Pass), (form + 0.5 * uf - e, Fail)] {
        assert_eq!(judged(form, size, [mf, 9.0], Rule::Guard, 0.5).0, want);
    }
    for (m, want) in [(ms + 0.5 * us + e, Pass), (ms + 0.5 * us - e, Fail)] {
        assert_eq!(judged(form, size, [9.0, m], Rule::Guard, 0.5).1, want);
    }
}

/// Five styli (a star) on a perfect sphere, stylus k shifted by `offsets[k]` µm and sized
/// `sizes[k]` µm too large.
fn star(offsets: [[f64; 3]; 5], sizes: [f64; 5]) -> SimTest {
    let poles = [
        [0.0, 0.0, 1.0],
        [-1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    SimTest {
        centre_mm: [120.0, -40.0, 75.0],
        diameter_mm: D_CAL,
        styli: (0..5)
            .map(|k| SimStylus {
                offset_um: offsets[k],
                size_um: sizes[k] / 2.0,
                ..SimStylus::perfect(&format!("S{}", k + 1), poles[k])
            })
            .collect(),
        seed: 1,
    }
}

#[test]
fn the_multi_stylus_location_is_the_range_of_the_styli_centres() -> TestResult {
    let dir = tempdir();
    let offsets = [
        [0.0; 3],
        [0.8, -0.3, 0.1],
        [-0.4, 0.2, 0.0],
        [0.1, 0.9, -0.2],
        [0.0, -0.5, 0.6],
    ];
    let sizes = [0.0, 0.3, -0.2, 0.1, 0.0];
    let test = star(offsets, sizes);
    let csv = write(dir.path(), "p.csv", &to_csv(&simulate(&test)));
    let sph = write(
        dir.path(),
        "s.toml",
        &sphere_toml(D_CAL, "[uncertainty]\nlocation_um = 0.3\n"),
    );
    let run = |mpe_loc: &str, rule: &str| {
        json(&errmap(&[
            "acceptance",
            "iso10360-5",
            s(&csv),
            "--sphere",
            s(&sph),
            "--mpe-form",
            "5",
            "--mpe-size",
            "5",
            "--mpe-location",
            mpe_loc,
            "--rule",
            rule,
            "--json",
        ]))
    };
    let j = run("3", "iso14253");
    assert_eq!(j["test"], "multi-stylus");
    assert_eq!(j["points"], 125);
    let want: Vec<f64> = (0..3)
        .map(|k| {
            let v: Vec<f64> = offsets.iter().map(|o| o[k]).collect();
            range(&v)
        })
        .collect();
    let loc = &j["location"];
    for k in 0..3 {
        assert!(
            (loc["axes_um"][k].as_f64().expect("axis") - want[k]).abs() < 1e-6,
            "axis {k}"
        );
    }
    let value = want.iter().copied().fold(0.0, f64::max);
    assert!((loc["value_um"].as_f64().expect("value") - value).abs() < 1e-6);
    assert_eq!(loc["u_um"], 0.3);
    for (k, st) in j["styli"].as_array().expect("styli").iter().enumerate() {
        assert_eq!(st["stylus"], format!("S{}", k + 1));
        assert_eq!(st["points"], 25);
        for a in 0..3 {
            let c = st["centre_mm"][a].as_f64().expect("centre");
            assert!((c - (test.centre_mm[a] + offsets[k][a] * 1e-3)).abs() < 1e-9);
        }
        assert!((st["size_um"].as_f64().expect("size") - sizes[k]).abs() < 1e-6);
        assert!(st["form_um"].as_f64().expect("form") < 1e-6);
    }
    // The offsets and sizes show in the all-points fit as form.
    assert!(j["form"]["value_um"].as_f64().expect("form") > 0.3);
    use ConformityVerdict::*;
    for (mpe, rule, verdict) in [
        (value + 0.3 + 0.01, "iso14253", Pass),
        (value, "iso14253", Indeterminate),
        (value - 0.3 - 0.01, "iso14253", Fail),
        (value + 0.01, "simple", Pass),
        (value - 0.01, "simple", Fail),
        (value + 0.3 + 0.01, "guard", Pass),
        (value + 0.3 - 0.01, "guard", Fail),
    ] {
        let j = run(&mpe.to_string(), rule);
        assert_eq!(
            j["location"]["verdict"],
            verdict.as_str(),
            "{rule}, MPE {mpe}"
        );
        if verdict == Fail {
            assert_eq!(j["verdict"], "fail");
        }
    }
    // Without an MPE: reported, not judged.
    let o = errmap(&[
        "acceptance",
        "iso10360-5",
        s(&csv),
        "--sphere",
        s(&sph),
        "--mpe-form",
        "5",
        "--mpe-size",
        "5",
        "--json",
    ]);
    let j = json(&o);
    assert!(j["location"]["verdict"].is_null() && j["location"]["mpe_um"].is_null());
    assert!(j["location"]["acceptance_um"].is_null());
    Ok(())
}

#[test]
fn departures_from_the_design_are_listed_not_refused() -> TestResult {
    let dir = tempdir();
    let mut test = star([[0.0; 3]; 5], [0.0; 5]);
    test.styli.truncate(3);
    test.styli[0].targets_deg.push((30.0, 200.0));
    test.diameter_mm = 8.0;
    let csv = write(dir.path(), "p.csv", &to_csv(&simulate(&test)));
    let sph = write(
        dir.path(),
        "s.toml",
        &sphere_toml(8.0, "[mpe]\nform_um = 2\nsize_um = 2\n"),
    );
    let j = json(&errmap(&[
        "acceptance",
        "iso10360-5",
        s(&csv),
        "--sphere",
        s(&sph),
        "--json",
    ]));
    let dev: Vec<String> = j["deviations"]
        .as_array()
        .expect("list")
        .iter()
        .map(|v| v.as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(dev.len(), 3, "{dev:?}");
    assert!(dev[0].contains("3 styli"));
    assert!(dev[1].contains("`S1`") && dev[1].contains("26 points"));
    assert!(dev[2].contains("Ø 8 mm"));
    // One stylus with an MPE for location: said, and location stays null.
    test.styli.truncate(1);
    test.styli[0].targets_deg = cap_targets();
    test.diameter_mm = D_CAL;
    let csv = write(dir.path(), "q.csv", &to_csv(&simulate(&test)));
    let sph = write(
        dir.path(),
        "t.toml",
        &sphere_toml(D_CAL, "[mpe]\nform_um = 2\nsize_um = 2\nlocation_um = 3\n"),
    );
    let j = json(&errmap(&[
        "acceptance",
        "iso10360-5",
        s(&csv),
        "--sphere",
        s(&sph),
        "--json",
    ]));
    assert!(j["location"].is_null());
    let dev = j["deviations"].as_array().expect("list");
    assert_eq!(dev.len(), 2, "{dev:?}");
    assert!(dev[1].as_str().is_some_and(|t| t.contains("one stylus")));
    Ok(())
}

/// Runs the command and returns (exit code, stderr).
fn refused(args: &[&str]) -> (Option<i32>, String) {
    let o = errmap(args);
    (o.status.code(), stderr(&o))
}

#[test]
fn refusals_name_what_is_wrong_in_the_contracts_order() -> TestResult {
    let dir = tempdir();
    let p = dir.path();
    let good_pts = to_csv(&simulate(&star([[0.0; 3]; 5], [0.0; 5])));
    let good = sphere_toml(D_CAL, "[mpe]\nform_um = 2\nsize_um = 2\n");
    let lines: Vec<&str> = good_pts.lines().collect();
    let with_line = |row: usize, text: &str| -> String {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        l[row] = text.to_string();
        l.join("\n") + "\n"
    };
    let pts = write(p, "p.csv", &good_pts);
    let sph = write(p, "s.toml", &good);
    let run = |pts: &Path, sph: &Path, extra: &[&str]| {
        let mut a = vec!["acceptance", "iso10360-5", s(pts), "--sphere", s(sph)];
        a.extend_from_slice(extra);
        refused(&a)
    };
    let cases: Vec<(PathBuf, PathBuf, Vec<&str>, Vec<&str>)> = vec![
        // 1. SPHERE, then the options — even when POINTS is bad too.
        (
            write(p, "bad1.csv", "stylus,point\n"),
            write(p, "s1.toml", &good.replace("form_um = 0.06\n", "")),
            vec![],
            vec!["s1.toml", "sphere.form_um", "missing"],
        ),
        (
            pts.clone(),
            write(p, "s2.toml", &format!("{good}colour = 1\n")),
            vec![],
            vec!["s2.toml", "mpe.colour", "unknown"],
        ),
        (
            pts.clone(),
            write(
                p,
                "s3.toml",
                &good.replace("diameter_mm = 29.99962", "diameter_mm = 0"),
            ),
            vec![],
            vec!["s3.toml", "sphere.diameter_mm"],
        ),
        (
            pts.clone(),
            write(
                p,
                "s4.toml",
                &good.replace("u_diameter_um = 0.1", "u_diameter_um = -0.1"),
            ),
            vec![],
            vec!["s4.toml", "sphere.u_diameter_um", "negative"],
        ),
        (
            pts.clone(),
            write(p, "s5.toml", &good.replace("size_um = 2", "size_um = 0")),
            vec![],
            vec!["s5.toml", "mpe.size_um"],
        ),
        (
            pts.clone(),
            write(
                p,
                "s6.toml",
                &good.replace("u_form_um = 0.03", "u_form_um = inf"),
            ),
            vec![],
            vec!["s6.toml", "sphere.u_form_um", "not finite"],
        ),
        // A bad --mpe-form or --guard-fraction is the flag's, exit 2 (tests/it/exit_codes.rs).
        (
            pts.clone(),
            write(p, "s7.toml", &sphere_toml(D_CAL, "")),
            vec!["--mpe-form", "2"],
            vec!["s7.toml", "mpe.size_um", "--mpe-size"],
        ),
        // 2. POINTS: columns first, then row by row.
        (
            write(p, "c.csv", &good_pts.replace("z_mm", "zz")),
            sph.clone(),
            vec![],
            vec!["c.csv", "column `z_mm`"],
        ),
        (
            write(p, "n.csv", &with_line(3, "S1,3,NaN,0,0")),
            sph.clone(),
            vec![],
            vec!["n.csv", "row 3 (line 4)", "x_mm"],
        ),
        (
            write(p, "e.csv", &with_line(5, "S1,5,1,,2")),
            sph.clone(),
            vec![],
            vec!["e.csv", "row 5 (line 6)", "y_mm", "empty"],
        ),
        (
            write(p, "z.csv", &with_line(2, "S1,0,1,2,3")),
            sph.clone(),
            vec![],
            vec!["z.csv", "row 2 (line 3)", "point"],
        ),
        (
            write(p, "f.csv", &with_line(2, "S1,2.5,1,2,3")),
            sph.clone(),
            vec![],
            vec!["f.csv", "row 2 (line 3)", "point"],
        ),
        (
            write(p, "s.csv", &with_line(4, ",4,1,2,3")),
            sph.clone(),
            vec![],
            vec!["s.csv", "row 4 (line 5)", "stylus", "empty"],
        ),
        // 3. A pair twice: both rows.
        (
            write(
                p,
                "d.csv",
                &with_line(30, &lines[30].replace("S2,5,", "S2,3,")),
            ),
            sph.clone(),
            vec![],
            vec!["d.csv", "rows 28 and 30", "`S2`", "point 3"],
        ),
        // 4. Too few points.
        (
            write(
                p,
                "few.csv",
                &(lines[..25].join("\n") + "\n" + &lines[26..].join("\n") + "\n"),
            ),
            sph.clone(),
            vec![],
            vec!["few.csv", "stylus `S1`", "24 point"],
        ),
    ];
    for (pts, sph, extra, needles) in &cases {
        let (code, e) = run(pts, sph, extra);
        assert_eq!(code, Some(1), "{needles:?}: {e}");
        for n in needles {
            assert!(e.contains(n), "{n:?} not in: {e}");
        }
        assert!(!e.contains("panicked"), "{e}");
    }
    // 5. Coplanar: 25 points on a circle.
    let flat: Vec<[f64; 3]> = (0..25)
        .map(|i| {
            let t = i as f64 * 0.25;
            [15.0 * t.cos(), 15.0 * t.sin(), 0.0]
        })
        .collect();
    let f = write(p, "flat.csv", &to_csv(&points_of("F", &flat)));
    let (code, e) = run(&f, &sph, &[]);
    assert_eq!(code, Some(1));
    assert!(
        e.contains("flat.csv") && e.contains("stylus `F`") && e.contains("coplanar"),
        "{e}"
    );
    // 6. A point off the sphere: the row of the largest residual.
    let mut pts6 = simulate(&star([[0.0; 3]; 5], [0.0; 5]));
    pts6[40].p_mm[0] += 0.15;
    pts6[41].p_mm[0] += 0.4;
    let f = write(p, "off.csv", &to_csv(&pts6));
    let (code, e) = run(&f, &sph, &[]);
    assert_eq!(code, Some(1));
    assert!(
        e.contains("off.csv: row 42 (line 43)") && e.contains("`S2`"),
        "{e}"
    );
    // 7. A stylus's diameter far from the certificate's.
    let mut test = star([[0.0; 3]; 5], [0.0; 5]);
    test.styli[3].size_um = 100.0;
    let f = write(p, "big.csv", &to_csv(&simulate(&test)));
    let (code, e) = run(&f, &sph, &[]);
    assert_eq!(code, Some(1));
    assert!(
        e.contains("big.csv") && e.contains("stylus `S4`") && e.contains("diameter_mm"),
        "{e}"
    );
    // A usage error is exit 2.
    let (code, _) = run(&pts, &sph, &["--rule", "strict"]);
    assert_eq!(code, Some(2));
    Ok(())
}

#[test]
fn the_report_holds_the_verdict_the_residuals_and_the_map() -> TestResult {
    let dir = tempdir();
    let out = dir.path().join("r");
    let o = errmap(&[
        "acceptance",
        "iso10360-5",
        s(&dataset("acceptance/probing-example.csv")),
        "--sphere",
        s(&dataset("acceptance/probing-sphere.toml")),
        "--report",
        s(&out),
        "--json",
    ]);
    let j = json(&o);
    let md = std::fs::read_to_string(out.join("report.md"))?;
    assert!(md.contains(&format!(
        "**Verdict: {}**",
        j["verdict"].as_str().unwrap_or("?")
    )));
    assert!(md.contains(j["statement"].as_str().unwrap_or("?")));
    assert!(md.contains("![residuals on the sphere"));
    let csv = std::fs::read_to_string(out.join("residuals.csv"))?;
    let mut l = csv.lines();
    assert_eq!(l.next(), Some("row,stylus,point,x_mm,y_mm,z_mm,r_um"));
    let rows: Vec<&str> = l.collect();
    assert_eq!(rows.len(), 125);
    let first: Vec<&str> = rows[0].split(',').collect();
    assert_eq!(first[..3], ["1", "-Z", "1"]);
    let r0: f64 = first[6].parse()?;
    assert!((r0 - j["residuals"][0]["r_um"].as_f64().unwrap_or(f64::NAN)).abs() < 1e-6);
    // The map: one disc per stylus; red dots outside, blue inside.
    let img = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(
        out.join("sphere_map.png"),
    )?));
    let mut reader = img.read_info()?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf)?;
    assert_eq!((info.width, info.height), errmap::plot::sphere_size(5, 2));
    let step = info.line_size / info.width as usize;
    let px = |red: bool| {
        buf.chunks(step)
            .filter(|c| {
                if red {
                    c[0] > 180 && c[1] < 130 && c[2] < 130
                } else {
                    c[2] > 150 && c[0] < 130
                }
            })
            .count()
    };
    assert!(
        px(true) > 500 && px(false) > 500,
        "red {} blue {}",
        px(true),
        px(false)
    );
    assert!(out.join("sphere_map.svg").is_file());
    Ok(())
}

#[test]
fn the_committed_example_and_report_are_the_simulators_and_current() -> TestResult {
    let dir = tempdir();
    let p = dir.path().join("p.csv");
    let o = errmap(&["acceptance", "simulate-probing", "--out", s(&p)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&p)?,
        std::fs::read_to_string(dataset("acceptance/probing-example.csv"))?
    );
    // The demo's library call gives the command's document.
    let lib = serde_json::to_value(errmap::acceptance::probing::evaluate_example()?)?;
    let cli = json(&errmap(&[
        "acceptance",
        "iso10360-5",
        "datasets/acceptance/probing-example.csv",
        "--sphere",
        "datasets/acceptance/probing-sphere.toml",
        "--json",
    ]));
    assert_eq!(lib, cli);
    let committed = root().join("reports/iso10360-5");
    let out = dir.path().join("r");
    let o = errmap(&[
        "acceptance",
        "iso10360-5",
        "datasets/acceptance/probing-example.csv",
        "--sphere",
        "datasets/acceptance/probing-sphere.toml",
        "--report",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["report.md", "residuals.csv"] {
        assert_eq!(
            std::fs::read_to_string(out.join(f))?,
            std::fs::read_to_string(committed.join(f))?,
            "reports/iso10360-5/{f} is stale: regenerate it (reports/iso10360-5/README.md)"
        );
    }
    Ok(())
}

#[test]
fn the_cmm_certificate_joins_both_tests_under_one_rule() -> TestResult {
    let dir = tempdir();
    let pdf = dir.path().join("cmm.pdf");
    let base = [
        "acceptance",
        "cmm-certificate",
        "--length",
        "datasets/acceptance/iso10360-example.csv",
        "--mpe",
        "1.5+L/333",
        "--u-um",
        "0.3+L/2000",
        "--mpl-r0",
        "1.2",
        "--probing",
        "datasets/acceptance/probing-example.csv",
        "--sphere",
        "datasets/acceptance/probing-sphere.toml",
        "--specification",
        "ACME CMM-X data sheet rev. C",
        "--cmm",
        "ACME CMM-X S/N 4711",
    ];
    let mut args = base.to_vec();
    args.extend(["--out", s(&pdf), "--json"]);
    let j = json(&errmap(&args));
    for key in [
        "cmm",
        "specification",
        "rule",
        "guard_fraction",
        "statement",
        "iso10360_2",
        "iso10360_5",
        "verdict",
    ] {
        assert!(j.get(key).is_some(), "{key}");
    }
    assert_eq!(j["iso10360_2"]["standard"], "ISO 10360-2:2009");
    assert_eq!(j["iso10360_5"]["standard"], "ISO 10360-5:2010");
    let v2 = j["iso10360_2"]["verdict"]
        .as_str()
        .unwrap_or("?")
        .to_string();
    let v5 = j["iso10360_5"]["verdict"]
        .as_str()
        .unwrap_or("?")
        .to_string();
    let rank = |v: &str| {
        ["pass", "indeterminate", "fail"]
            .iter()
            .position(|x| *x == v)
    };
    assert_eq!(
        rank(j["verdict"].as_str().unwrap_or("?")),
        rank(&v2).max(rank(&v5))
    );
    assert_eq!(v2, "indeterminate", "the example's documented verdict");
    // Each part equals its own command's document.
    let one = json(&errmap(&[
        "acceptance",
        "iso10360-5",
        "datasets/acceptance/probing-example.csv",
        "--sphere",
        "datasets/acceptance/probing-sphere.toml",
        "--json",
    ]));
    assert_eq!(one, j["iso10360_5"]);
    // A bad input of either part is refused as that command refuses it.
    let mut bad_sphere = base.to_vec();
    let t = dir.path().join("s.toml");
    std::fs::write(&t, "[sphere]\ndiameter_mm = 30\n")?;
    assert_eq!(bad_sphere[12], "--sphere");
    bad_sphere[13] = s(&t);
    let out2 = dir.path().join("x.pdf");
    bad_sphere.extend(["--out", s(&out2)]);
    let (code, e) = refused(&bad_sphere);
    assert_eq!(code, Some(1));
    assert!(
        e.contains("s.toml") && e.contains("sphere.u_diameter_um"),
        "{e}"
    );
    assert!(!out2.exists(), "no certificate from a refused input");
    if Command::new("pdftotext").arg("-v").output().is_err() {
        eprintln!(
            "skipped: `pdftotext` (poppler-utils) is not installed; the certificate's text is not checked"
        );
        return Ok(());
    }
    let t = Command::new("pdftotext")
        .arg("-layout")
        .arg(&pdf)
        .arg("-")
        .output()?;
    let text = String::from_utf8(t.stdout)?;
    let page1 = text.split('\u{c}').next().unwrap_or("");
    for needle in [
        "CMM verification certificate",
        "Summary",
        "ACME CMM-X S/N 4711",
        "Overall verdict: indeterminate",
    ] {
        assert!(page1.contains(needle), "page 1 lacks {needle:?}");
    }
    for needle in [
        "Statement of conformity",
        "ISO 10360-2:2009",
        "ISO 10360-5:2010",
        "Specification: ACME CMM-X data sheet rev. C",
        "Decision rule: ISO 14253-1:2017 default rule",
        "indeterminate",
        "pass",
        "acceptance zone",
        "ceramic Ø30 S/N 0815",
    ] {
        assert!(text.contains(needle), "{needle:?} missing");
    }
    // One format for every µm value: the place of the second significant digit of the
    // smallest U stated (GUM 7.2.6), 1 to 3 decimals.
    let p5 = &j["iso10360_5"];
    let smallest_u = j["iso10360_2"]["measurements"]
        .as_array()
        .ok_or("measurements")?
        .iter()
        .map(|m| &m["u_um"])
        .chain([
            &p5["form"]["u_um"],
            &p5["size"]["u_um"],
            &p5["location"]["u_um"],
        ])
        .filter_map(Value::as_f64)
        .filter(|u| *u > 0.0)
        .fold(f64::INFINITY, f64::min);
    let d = (1 - smallest_u.log10().floor() as i64).clamp(1, 3) as usize;
    let form = format!(
        "{:.d$}",
        p5["form"]["value_um"].as_f64().unwrap_or(f64::NAN)
    );
    assert!(
        text.contains(&format!(" {form} ")),
        "the form {form} is printed to {d} decimals (smallest U {smallest_u} µm)"
    );
    Ok(())
}
