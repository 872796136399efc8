//! Modulo compensation tables (`docs/rotary.md` §4): each controller's rule checked on its
//! written table, the closure gap removed and reported, the reference unmoved, the
//! residual after compensation, and the best placement against a brute-force search.

use errmap::base::RotaryAxis;
use errmap::controller::modulo::{ModuloError, ModuloSpec, modulo_dialects, modulo_table};
use errmap::controller::{Dialect, dialect};

/// The registry's dialect `name`.
fn d(name: &str) -> &'static dyn Dialect {
    dialect(name).expect("a dialect")
}

/// Eccentricity 8″ plus a 20 ppm ratio error (25.92″ over the revolution), every 15°.
fn table() -> Vec<(f64, f64)> {
    (0..=24)
        .map(|k| {
            let q = 15.0 * f64::from(k);
            (
                q,
                8.0 * (q + 20.0).to_radians().sin() + 20.0 * q * 3.6e-3 + 3.0,
            )
        })
        .collect()
}

/// e′ at the targets, detrended here independently: e − g·θ/360.
fn detrended(t: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let g = t[t.len() - 1].1 - t[0].1;
    t.iter().map(|&(q, e)| (q, e - g * q / 360.0)).collect()
}

fn numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == '+'))
        .filter_map(|w| w.parse().ok())
        .collect()
}

#[test]
fn every_dialect_keeps_its_rule_removes_the_gap_and_leaves_the_reference_in_place() {
    let t = table();
    let ep = detrended(&t);
    let all: Vec<&str> = modulo_dialects().map(|d| d.name()).collect();
    assert_eq!(
        all,
        ["linuxcnc", "siemens", "fanuc", "heidenhain", "fagor-8055"]
    );
    for d in modulo_dialects() {
        let mut spec = ModuloSpec::new(d, RotaryAxis::A);
        if d.modulo().expect("a modulo table").equidistant() {
            spec.step_deg = Some(15.0);
        }
        let m = modulo_table(&t, &spec).unwrap_or_else(|e| panic!("{d:?}: {e}"));
        assert!((m.closure_gap_arcsec - 25.92).abs() < 1e-9, "{d:?}");
        assert!((m.ratio_ppm - 20.0).abs() < 1e-9, "{d:?}");
        assert!(m.warnings.iter().any(|w| w.contains("correct the ratio")));
        assert_eq!(m.points, 25, "{d:?}");
        // The reference (0°) is not moved and the ends agree.
        assert!(m.c_arcsec[0].abs() < 1e-12);
        assert!((m.c_arcsec[0] - m.c_arcsec[24]).abs() < 1e-12);
        // c = −(e′ − e′(0)) at the table's points.
        for (k, c) in m.c_arcsec.iter().enumerate() {
            assert!((c + (ep[k].1 - ep[0].1)).abs() < 1e-9, "{d:?} point {k}");
        }
        let lines: Vec<&str> = m.text.lines().collect();
        match d.name() {
            "linuxcnc" => {
                let first = numbers(lines[0]);
                let last = numbers(lines[lines.len() - 1]);
                assert_eq!(first[0], 0.0);
                assert_eq!(last[0], 360.0);
                assert!(((first[1] - first[0]) - (last[1] - last[0])).abs() < 1e-9);
                assert!(lines.len() <= 256);
                assert!(m.max_residual_arcsec < 0.01, "{}", m.max_residual_arcsec);
            }
            "siemens" => {
                let v = |i: usize| {
                    let l = lines
                        .iter()
                        .find(|l| l.starts_with(&format!("$AA_ENC_COMP[0,{i},A1]=")))
                        .expect("point");
                    l.rsplit('=')
                        .next()
                        .and_then(|x| x.parse::<f64>().ok())
                        .expect("value")
                };
                assert_eq!(v(0), v(24), "equal end values");
                assert!(m.text.contains("$AA_ENC_COMP_IS_MODULO[0,A1]=1"));
                assert!(m.text.contains("$AA_ENC_COMP_MIN[0,A1]=0.0"));
                assert!(m.text.contains("$AA_ENC_COMP_MAX[0,A1]=360.0"));
                assert!(!m.text.contains("$AA_ENC_COMP[0,25,"));
            }
            "fanuc" => {
                let v: Vec<i64> = lines
                    .iter()
                    .filter(|l| l.starts_with('N'))
                    .map(|l| l.split('P').nth(1).and_then(|x| x.parse().ok()).expect("P"))
                    .collect();
                assert_eq!(v.len(), 25);
                assert_eq!(v[1..].iter().sum::<i64>(), 0, "a revolution sums to 0");
                assert_eq!(v[0], v[24]);
                assert!(m.text.contains("3620=0 3621=0 3622=24"));
                // Rounded to 0.001° = 3.6″: the residual within half a unit.
                assert!(
                    m.max_residual_arcsec <= 1.8 + 1e-9,
                    "{}",
                    m.max_residual_arcsec
                );
            }
            "heidenhain" => {
                assert!(lines[0].starts_with("BEGIN") && lines[lines.len() - 1] == "[END]");
                let first = numbers(lines[2]);
                let last = numbers(lines[lines.len() - 2]);
                assert_eq!(first[2], last[2], "equal at 0 and 360");
            }
            "fagor-8055" => {
                let e = |l: &str| l.split_whitespace().nth(4).map(str::to_string);
                assert_eq!(
                    e(lines[0]),
                    e(lines[24]),
                    "Fagor: equal first and last errors"
                );
            }
            other => panic!("{other}: no rule checked"),
        }
    }
}

/// Largest |residual| over the targets of a table at the points `idx` (independent).
fn residual(ep: &[(f64, f64)], idx: &[usize]) -> f64 {
    ep.iter()
        .map(|&(q, e)| {
            let j = idx
                .iter()
                .position(|&i| ep[i].0 >= q)
                .unwrap_or(idx.len() - 1)
                .max(1);
            let (a, b) = (ep[idx[j - 1]], ep[idx[j]]);
            let c = a.1 + (b.1 - a.1) * (q - a.0) / (b.0 - a.0);
            (e - c).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_best_placement_matches_a_brute_force_search() {
    // Eleven uneven targets, a budget of 6 points: every 4-subset of the 9 inner ones.
    let q = [
        0.0, 30.0, 70.0, 100.0, 150.0, 170.0, 200.0, 250.0, 290.0, 330.0, 360.0,
    ];
    let t: Vec<(f64, f64)> = q
        .iter()
        .map(|&q: &f64| {
            (
                q,
                6.0 * (q.to_radians() * 3.0).sin() + 2.0 * (q.to_radians()).cos(),
            )
        })
        .collect();
    let ep = detrended(&t);
    let mut best = f64::INFINITY;
    for mask in 0u32..(1 << 9) {
        if mask.count_ones() > 4 {
            continue;
        }
        let mut idx = vec![0];
        idx.extend((0..9).filter(|b| mask & (1 << b) != 0).map(|b| b + 1));
        idx.push(10);
        best = best.min(residual(&ep, &idx));
    }
    let mut spec = ModuloSpec::new(d("linuxcnc"), RotaryAxis::B);
    spec.max_points = Some(6);
    let m = modulo_table(&t, &spec).expect("table");
    assert!(m.points <= 6 && m.points_deg[0] == 0.0 && m.points_deg[m.points - 1] == 360.0);
    assert!(
        (m.max_residual_arcsec - best).abs() < 1e-9,
        "{} vs {best}",
        m.max_residual_arcsec
    );
}

#[test]
fn a_table_that_does_not_fit_is_refused_with_the_reason() {
    let t = table();
    let spec = |d| ModuloSpec::new(d, RotaryAxis::C);
    let mut s = spec(d("siemens"));
    s.step_deg = Some(7.0);
    assert!(matches!(
        modulo_table(&t, &s),
        Err(ModuloError::Step { .. })
    ));
    let e = modulo_table(&t, &s).expect_err("refused").to_string();
    assert!(e.contains("try"), "{e}");
    let no_zero: Vec<(f64, f64)> = t[1..].to_vec();
    assert_eq!(
        modulo_table(&no_zero, &spec(d("linuxcnc"))),
        Err(ModuloError::NoZero)
    );
    let half: Vec<(f64, f64)> = t.iter().copied().filter(|p| p.0 <= 180.0).collect();
    assert!(matches!(
        modulo_table(&half, &spec(d("linuxcnc"))),
        Err(ModuloError::Gap { .. })
    ));
    let mut r = spec(d("heidenhain"));
    r.step_deg = Some(15.0);
    r.reference_deg = 7.0;
    assert!(matches!(
        modulo_table(&t, &r),
        Err(ModuloError::Reference { .. })
    ));
    // The finest admissible step within Siemens' 200 points: 360/k, k + 1 ≤ 200, a whole
    // multiple of 0.001°: k = 192 (1.875°).
    let m = modulo_table(&t, &spec(d("siemens"))).expect("table");
    assert_eq!(m.step_deg, Some(1.875));
    assert_eq!(m.points, 193);
}

#[test]
fn a_one_direction_table_refuses_two_directions_naming_those_that_hold_both() {
    let t = table();
    let e = errmap::controller::modulo::modulo_table_bidirectional(
        &t,
        &t,
        &ModuloSpec::new(d("siemens"), RotaryAxis::C),
    )
    .expect_err("one value per point");
    assert_eq!(
        e.to_string(),
        "siemens modulo tables hold one value per point for both directions (two-direction \
         tables: linuxcnc forward/reverse, fagor-8055 err−)"
    );
    // A dialect without a modulo table is refused by name.
    let isg = ModuloSpec::new(d("isg"), RotaryAxis::C);
    assert_eq!(
        modulo_table(&t, &isg),
        Err(ModuloError::NoModulo { format: "isg" })
    );
}
