//! Round steps for compensation tables (issue 14): any step for formats that list every
//! nominal, a round grid with clamped or extrapolated ends for fixed-interval formats,
//! a suggested step that is accepted when given back, negative `--start`. Known answers
//! on an affine field (trilinear reproduces it exactly) and the issue's own commands.

use crate::util::{errmap_in, root};
use std::path::Path;
use std::process::Output;

use errmap::controller::siemens;
use errmap::export::{
    Ends, ExportError, Extrapolation, LineSpec, StepFit, sample_line, sample_line_fit,
};
use errmap::interp::{Interpolator, Method};
use errmap::table::{Axis, Grid};
use proptest::prelude::*;

/// e = 0.01·x + 0.002·y µm on x ∈ [−1000, 1000]: trilinear is exact on it.
fn affine() -> Box<dyn Interpolator> {
    let grid = Grid::from_fn(
        vec![-1000.0, 0.0, 1000.0],
        vec![0.0, 100.0],
        vec![0.0, 1.0],
        |p| 0.01 * p[0] + 0.002 * p[1],
    );
    Method::Trilinear.fit(&grid).expect("fit")
}

fn line(start_mm: f64, end_mm: f64, step_mm: f64) -> LineSpec {
    LineSpec {
        axis: Axis::X,
        at_mm: [0.0, 50.0, 0.5],
        start_mm,
        end_mm,
        step_mm,
    }
}

fn e_true(x: f64) -> f64 {
    0.01 * x + 0.002 * 50.0
}

#[test]
fn any_step_ends_on_the_range_end_for_formats_that_list_every_nominal() {
    let s = sample_line_fit(
        &*affine(),
        &line(1.2424, 800.0, 10.0),
        StepFit::LastShorter,
        Extrapolation::Forbid,
    )
    .expect("10 mm on 798.7576 mm");
    assert_eq!(s.len(), 81);
    assert_eq!(s.positions_mm[0], 1.2424);
    assert_eq!(s.positions_mm[79], 791.2424);
    assert_eq!(s.positions_mm[80], 800.0);
    for (x, e) in s.positions_mm.iter().zip(&s.error_um) {
        assert!((e - e_true(*x)).abs() < 1e-9, "{x}: {e}");
    }
    // A dividing step gives the same points as `sample_line`.
    let a = sample_line_fit(
        &*affine(),
        &line(0.0, 800.0, 40.0),
        StepFit::LastShorter,
        Extrapolation::Allow,
    )
    .expect("ok");
    let b = sample_line(&*affine(), &line(0.0, 800.0, 40.0), Extrapolation::Allow).expect("ok");
    assert_eq!(a, b);
}

#[test]
fn a_round_grid_through_the_reference_clamps_or_extrapolates_its_ends() {
    let l = line(-17.0, 23.0, 10.0);
    let grid = [-25.0, -15.0, -5.0, 5.0, 15.0, 25.0];
    let ex = sample_line_fit(
        &*affine(),
        &l,
        StepFit::Grid {
            reference_mm: 5.0,
            ends: Ends::Extrapolate,
        },
        Extrapolation::Allow,
    )
    .expect("ok");
    assert_eq!(ex.positions_mm, grid);
    for (x, e) in grid.iter().zip(&ex.error_um) {
        assert!((e - e_true(*x)).abs() < 1e-9);
    }
    let cl = sample_line_fit(
        &*affine(),
        &l,
        StepFit::Grid {
            reference_mm: 5.0,
            ends: Ends::Clamp,
        },
        Extrapolation::Allow,
    )
    .expect("ok");
    assert_eq!(cl.positions_mm, grid);
    let want: Vec<f64> = grid.iter().map(|&x| e_true(x.clamp(-17.0, 23.0))).collect();
    for (e, w) in cl.error_um.iter().zip(&want) {
        assert!((e - w).abs() < 1e-9, "{e} vs {w}");
    }
    // Round trip through the Siemens table: the controller's linear interpolation of the
    // extrapolated grid gives −e exactly everywhere in the range (e is affine).
    let text = siemens::render(&ex, "X1", 200).expect("renders");
    let value = |key: &str| -> f64 {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("$AA_ENC_COMP_{key}[0,X1]=")))
            .expect(key)
            .parse()
            .expect("number")
    };
    let (step, min) = (value("STEP"), value("MIN"));
    assert_eq!((step, min), (10.0, -35.0));
    let table: Vec<f64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("$AA_ENC_COMP[0,"))
        .map(|l| l.split_once("]=").expect("=").1.parse().expect("number"))
        .collect();
    for k in 0..=40 {
        let x = -17.0 + f64::from(k);
        let u = (x - min) / step;
        let i = u.floor() as usize;
        let c_mm = table[i] + (u - i as f64) * (table[i + 1] - table[i]);
        assert!((c_mm * 1e3 + e_true(x)).abs() < 2e-3, "x {x}: c {c_mm} mm");
    }
}

#[test]
fn the_divide_rule_accepts_its_own_rounded_suggestion() {
    let model = affine();
    let e = sample_line(&*model, &line(1.2424, 800.0, 3.0), Extrapolation::Allow)
        .expect_err("3 does not divide 798.7576");
    let ExportError::StepDoesNotDivide {
        fitting_step_mm, ..
    } = e
    else {
        panic!("{e}");
    };
    let msg = e.to_string();
    assert!(
        msg.contains("2.991601 mm") && msg.ends_with("(the ends clamp|extrapolate)"),
        "{msg}"
    );
    assert!((fitting_step_mm - 798.7576 / 267.0).abs() < 1e-12);
    let s = sample_line(
        &*model,
        &line(1.2424, 800.0, 2.991601),
        Extrapolation::Allow,
    )
    .expect("the printed suggestion is accepted");
    assert_eq!(s.len(), 268);
    // Exactly equidistant at the typed step; the end within 267 · 0.5 nm.
    for (i, x) in s.positions_mm.iter().enumerate() {
        assert!(
            (x - (1.2424 + i as f64 * 2.991601)).abs() < 1e-8,
            "{i}: {x}"
        );
    }
    assert!((s.positions_mm[267] - 800.0).abs() <= 267.0 * 0.5e-6);
    siemens::render(&s, "X1", 300).expect("Siemens writes it: one STEP");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// LastShorter: strictly increasing from start to end, every interval the step but the
    /// last, which is at most h·(1 + 1/1000): a grid point closer than h/1000 to the end
    /// is replaced by the end (no near-zero interval).
    #[test]
    fn last_shorter_places_any_step(start in -500.0f64..500.0, length in 0.01f64..900.0,
                                    step in 0.01f64..200.0) {
        let model = affine();
        let end = start + length;
        prop_assume!(length / step < 20_000.0);
        let s = sample_line_fit(&*model, &line(start, end, step), StepFit::LastShorter,
                                Extrapolation::Allow).expect("any step");
        let p = &s.positions_mm;
        // The file writes 1e-6 mm; points are snapped to 1e-9 mm.
        prop_assert!((p[0] - start).abs() <= 1e-9, "{} vs {}", p[0], start);
        prop_assert_eq!(*p.last().expect("points"), end);
        let n = p.len();
        for w in p[..n - 1].windows(2) {
            prop_assert!((w[1] - w[0] - step).abs() < 1e-6, "{:?}", w);
        }
        let last = p[n - 1] - p[n - 2];
        prop_assert!(last > 0.0 && last <= step * 1.001 + 1e-6, "last interval {}", last);
        if n > 2 {
            prop_assert!(last > (1e-3 * step).max(1e-6) - 1e-9, "last interval {}", last);
        }
    }

    /// The suggestion for a step that does not divide is accepted when given back as
    /// printed (6 decimals), for any range and step.
    #[test]
    fn suggested_steps_round_trip(start in -500.0f64..500.0, length in 1.0f64..1000.0,
                                  step in 0.05f64..100.0) {
        let model = affine();
        let end = start + length;
        if let Err(ExportError::StepDoesNotDivide { fitting_step_mm, .. }) =
            sample_line(&*model, &line(start, end, step), Extrapolation::Allow)
        {
            let printed: f64 = format!("{fitting_step_mm:.6}").parse().expect("number");
            let s = sample_line(&*model, &line(start, end, printed), Extrapolation::Allow);
            prop_assert!(s.is_ok(), "{} → {:?}", printed, s.err());
        }
    }
}

// ---- the issue's commands ---------------------------------------------------------------

fn export(dir: &Path, extra: &[&str]) -> Output {
    let table = root().join("datasets/table1.csv");
    let mut args = vec![
        "export",
        table.to_str().expect("utf-8 path"),
        "--method",
        "lagrange",
        "--order",
        "4x1x2",
        "--axis",
        "x",
        "--at",
        "y=1,z=200",
    ];
    args.extend_from_slice(extra);
    errmap_in(dir, &args)
}

#[test]
fn the_issues_export_with_a_round_step_is_accepted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let o = export(
        dir.path(),
        &["--step", "10", "--format", "linuxcnc", "--out", "x.comp"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.path().join("x.comp")).expect("written");
    let nominals: Vec<f64> = text
        .lines()
        .map(|l| {
            l.split_whitespace()
                .next()
                .expect("nominal")
                .parse()
                .expect("number")
        })
        .collect();
    assert_eq!(nominals.len(), 81);
    assert_eq!(
        (nominals[0], nominals[79], nominals[80]),
        (1.2424, 791.2424, 800.0)
    );

    // Siemens: refused with a suggestion, which is accepted given back.
    let o = export(
        dir.path(),
        &[
            "--step",
            "3",
            "--format",
            "siemens",
            "--max-points",
            "300",
            "--out",
            "x.mpf",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let msg = String::from_utf8_lossy(&o.stderr).to_string();
    // The library's "the ends" said as the flag.
    assert!(msg.contains("(--ends clamp|extrapolate)"), "{msg}");
    let suggested = msg
        .split("that does is ")
        .nth(1)
        .and_then(|r| r.split(" mm").next())
        .expect("a suggested step")
        .to_string();
    assert_eq!(suggested, "2.991601");
    let o = export(
        dir.path(),
        &[
            "--step",
            &suggested,
            "--format",
            "siemens",
            "--max-points",
            "300",
            "--out",
            "x.mpf",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // Siemens on the round grid from 0 with the ends clamped: MIN/MAX on multiples of 10.
    let o = export(
        dir.path(),
        &[
            "--step", "10", "--ends", "clamp", "--format", "siemens", "--out", "g.mpf",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.path().join("g.mpf")).expect("written");
    assert!(text.contains("$AA_ENC_COMP_MIN[0,X1]=-10.0"), "{text}");
    assert!(text.contains("$AA_ENC_COMP_MAX[0,X1]=810.0"), "{text}");
    assert!(text.contains("$AA_ENC_COMP_STEP[0,X1]=10.0"), "{text}");

    // A negative --start is a number, not a flag.
    let o = export(
        dir.path(),
        &[
            "--step",
            "10",
            "--start",
            "-20",
            "--ends",
            "extrapolate",
            "--reference",
            "5",
            "--format",
            "linuxcnc",
            "--out",
            "n.comp",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.path().join("n.comp")).expect("written");
    let first: f64 = text
        .split_whitespace()
        .next()
        .expect("nominal")
        .parse()
        .expect("number");
    assert_eq!(first, -25.0);
    assert!(
        text.lines().last().expect("rows").starts_with("805.0 "),
        "{text}"
    );
}

/// Regression (found by `last_shorter_places_any_step`): a range shorter than a
/// thousandth of the step kept only its end; both ends are points.
#[test]
fn a_range_shorter_than_the_gap_keeps_both_ends() {
    let model = affine();
    let s = sample_line_fit(
        &*model,
        &line(0.0, 0.01, 110.69532037259171),
        StepFit::LastShorter,
        Extrapolation::Allow,
    )
    .expect("any step");
    assert_eq!(s.positions_mm, vec![0.0, 0.01]);
}
