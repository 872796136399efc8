//! ISO 230-4 numbers on analytic traces, against values computed here independently.

use errmap::circular::{CircularTest, Plane, Run, Sense, evaluate};

fn run(sense: Sense, f: impl Fn(f64) -> f64) -> Run {
    let n = 3600;
    let angles: Vec<f64> = (0..=n)
        .map(|k| -45.0 + 450.0 * k as f64 / n as f64)
        .map(|a| {
            if sense == Sense::Ccw {
                a
            } else {
                405.0 - (a + 45.0)
            }
        })
        .collect();
    Run {
        id: if sense == Sense::Ccw { 1 } else { 2 },
        sense,
        first_line: 2,
        dr_um: angles.iter().map(|a| f(a.to_radians())).collect(),
        angle_deg: angles,
        t_s: None,
    }
}

/// An oval (2 cos 2θ) with a centring offset and a radius offset per direction: G is the
/// oval's 4 µm in each run, D the mean radius offset, F the raw extremes, H the largest
/// difference between the runs.
#[test]
fn g_d_f_h_of_an_analytic_oval() {
    let ccw = run(Sense::Ccw, |t| 1.0 + 2.0 * (2.0 * t).cos() + 3.0 * t.cos());
    let cw = run(Sense::Cw, |t| 3.0 + 2.0 * (2.0 * t).cos() + 3.0 * t.cos());
    let test = CircularTest {
        trace: "analytic".into(),
        meta: super::meta(Plane::XY),
        runs: vec![ccw, cw],
    };
    let iso = evaluate(&test);
    let close = |v: Option<f64>, want: f64| (v.expect("test set-up") - want).abs() < 0.01;
    assert!(close(iso.g_ccw_um, 4.0), "{:?}", iso.g_ccw_um);
    assert!(close(iso.g_cw_um, 4.0));
    // One circle of both: the radius offsets 1 and 3 spread it by 2 more.
    assert!(close(iso.g_b_um, 6.0), "{:?}", iso.g_b_um);
    assert!(close(iso.d_um, 2.0), "{:?}", iso.d_um);
    assert!(close(iso.h_um, 2.0), "{:?}", iso.h_um);
    // Raw: max of 3 + 2cos2θ + 3cosθ is 8 at 0°, min of 1 + 2cos2θ + 3cosθ is at
    // cos θ = −3/8: 1 + 2(2·9/64 − 1) − 9/8.
    assert!((iso.f_max_um - 8.0).abs() < 1e-6);
    let fmin = 1.0 + 2.0 * (2.0 * 9.0 / 64.0 - 1.0) - 9.0 / 8.0;
    assert!(
        (iso.f_min_um - fmin).abs() < 1e-3,
        "{} vs {fmin}",
        iso.f_min_um
    );
}

/// A one-direction test: the quantities needing both directions are null.
#[test]
fn one_direction_leaves_the_bidirectional_numbers_null() {
    let test = CircularTest {
        trace: "analytic".into(),
        meta: super::meta(Plane::YZ),
        runs: vec![run(Sense::Cw, |t| (3.0 * t).sin())],
    };
    let iso = evaluate(&test);
    assert!(iso.g_ccw_um.is_none() && iso.g_b_um.is_none() && iso.h_um.is_none());
    assert!(iso.d_um.is_none());
    assert!((iso.g_cw_um.expect("test set-up") - 2.0).abs() < 1e-3);
    let json = serde_json::to_value(iso).expect("test set-up");
    assert!(json["G_ccw_um"].is_null() && json["G_cw_um"].is_number());
}
