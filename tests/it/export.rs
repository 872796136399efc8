//! Compensation-table export: the LinuxCNC and Siemens formats parse back to the model's
//! compensation with the documented signs, limits are refused with a step that fits, and
//! "applying" an exported table to a simulated machine leaves only the fit error plus the
//! controller's linear-interpolation error. Known-answer data only (analytic fields).

use std::f64::consts::TAU;
use std::path::PathBuf;

use errmap::controller::{CompType, ExportFormat, LINUXCNC_MAX_ENTRIES, linuxcnc, siemens};
use errmap::export::{
    ExportError, Extrapolation, FILE_RESOLUTION_MM, LineSpec, Sampled, VolumeSpec, csv,
    sample_line, write_grid,
};
use errmap::interp::{Interpolator, Method, Order};
use errmap::table::{Axis, ErrorTable, Grid};
use proptest::prelude::*;

use super::export_dialects::{
    TRUTH_D2, export_session, grid, hidden_reversal_um, measured, truth_x, truth_x_down,
};

// ---------------------------------------------------------------------------------------
// A known machine and its map
// ---------------------------------------------------------------------------------------

/// The machine's true geometric error, µm: a pitch error, a scale error, a y-dependent
/// term and a z-dependent term. Along x its curvature is bounded by [`TRUTH_D2X_MAX`].
fn truth(p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    6.0 * (TAU * x / 640.0).sin()
        + 0.004 * x
        + 0.5 * (y / 400.0) * (TAU * x / 900.0).cos()
        + 1.5 * ((z - 350.0) / 150.0).powi(2)
}

/// max |∂²e/∂x²| of [`truth`] for 0 ≤ y ≤ 400, µm/mm².
const TRUTH_D2X_MAX: f64 =
    6.0 * (TAU / 640.0) * (TAU / 640.0) + 0.5 * (TAU / 900.0) * (TAU / 900.0);

fn steps(lo: f64, hi: f64, h: f64) -> Vec<f64> {
    let n = ((hi - lo) / h).round() as usize;
    (0..=n).map(|i| lo + i as f64 * h).collect()
}

/// The error table a CMM survey of the machine would give: x every 50 mm over 0–800,
/// y every 100 mm over 0–400, z every 75 mm over 200–500.
fn mapped_grid() -> Grid {
    Grid::from_fn(
        steps(0.0, 800.0, 50.0),
        steps(0.0, 400.0, 100.0),
        steps(200.0, 500.0, 75.0),
        truth,
    )
}

fn spline_model() -> Box<dyn Interpolator> {
    Method::Spline.fit(&mapped_grid()).expect("spline fits")
}

const AT: [f64; 3] = [0.0, 200.0, 350.0];

fn line_x(start_mm: f64, end_mm: f64, step_mm: f64) -> LineSpec {
    LineSpec {
        axis: Axis::X,
        at_mm: AT,
        start_mm,
        end_mm,
        step_mm,
    }
}

fn at_x(x: f64) -> [f64; 3] {
    [x, AT[1], AT[2]]
}

// ---------------------------------------------------------------------------------------
// Independent readers of the two controller formats
// ---------------------------------------------------------------------------------------

/// Reads a LinuxCNC COMP_FILE strictly: every line exactly three numbers.
fn parse_linuxcnc(text: &str) -> Vec<[f64; 3]> {
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|t| {
                    t.parse::<f64>()
                        .unwrap_or_else(|_| panic!("line {}: `{t}` is not a number: {line}", i + 1))
                })
                .collect();
            assert_eq!(
                v.len(),
                3,
                "line {} must be `nominal forward reverse`: {line}",
                i + 1
            );
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[derive(Debug)]
struct SiemensTable {
    values_mm: Vec<f64>,
    step_mm: f64,
    min_mm: f64,
    max_mm: f64,
    modulo: String,
}

impl SiemensTable {
    fn positions(&self) -> Vec<f64> {
        (0..self.values_mm.len())
            .map(|i| self.min_mm + i as f64 * self.step_mm)
            .collect()
    }
}

/// Reads the `$AA_ENC_COMP…[0,…,axis]` assignments of a Siemens EEC program.
fn parse_siemens(text: &str, axis: &str) -> SiemensTable {
    let mut values: Vec<(usize, f64)> = Vec::new();
    let (mut step, mut min, mut max, mut modulo) = (None, None, None, None);
    let scalar = |line: &str, key: &str| -> Option<String> {
        line.strip_prefix(&format!("$AA_ENC_COMP_{key}[0,{axis}]="))
            .map(str::to_string)
    };
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("$AA_ENC_COMP[0,") {
            let (idx, value) = rest.split_once("]=").expect("`]=` in a table entry");
            let (n, ax) = idx.split_once(',').expect("N,axis");
            assert_eq!(ax, axis, "entry for another axis: {line}");
            values.push((
                n.parse().expect("N is an index"),
                value.parse().expect("value is a number"),
            ));
        } else if let Some(v) = scalar(line, "STEP") {
            step = Some(v.parse::<f64>().expect("STEP"));
        } else if let Some(v) = scalar(line, "MIN") {
            min = Some(v.parse::<f64>().expect("MIN"));
        } else if let Some(v) = scalar(line, "MAX") {
            max = Some(v.parse::<f64>().expect("MAX"));
        } else if let Some(v) = scalar(line, "IS_MODULO") {
            modulo = Some(v);
        }
    }
    for (i, (n, _)) in values.iter().enumerate() {
        assert_eq!(
            *n, i,
            "interpolation points are numbered 0, 1, 2, … in order"
        );
    }
    SiemensTable {
        values_mm: values.into_iter().map(|(_, v)| v).collect(),
        step_mm: step.expect("$AA_ENC_COMP_STEP present"),
        min_mm: min.expect("$AA_ENC_COMP_MIN present"),
        max_mm: max.expect("$AA_ENC_COMP_MAX present"),
        modulo: modulo.expect("$AA_ENC_COMP_IS_MODULO present"),
    }
}

/// A controller's table lookup: linear between entries, the end values held beyond.
pub(crate) fn table_at(xs: &[f64], vs: &[f64], x: f64) -> f64 {
    if x <= xs[0] {
        return vs[0];
    }
    if x >= xs[xs.len() - 1] {
        return vs[vs.len() - 1];
    }
    let i = xs.partition_point(|&p| p <= x) - 1;
    let u = (x - xs[i]) / (xs[i + 1] - xs[i]);
    vs[i] + u * (vs[i + 1] - vs[i])
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Numbers are written at 1e-6 mm; comparisons in mm allow that plus float noise.
const FILE_TOL_MM: f64 = 0.6e-6;

// ---------------------------------------------------------------------------------------
// LinuxCNC
// ---------------------------------------------------------------------------------------

#[test]
fn linuxcnc_lines_are_nominal_forward_reverse_without_header() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 10.0), Extrapolation::Forbid)
        .expect("inside the map");
    for comp_type in [CompType::ActualPosition, CompType::Trim] {
        let text = linuxcnc::render(&s, comp_type, None).expect("81 entries fit");
        let rows = parse_linuxcnc(&text); // also proves: no header, no comments
        assert_eq!(rows.len(), 81);
        assert!(rows.len() <= LINUXCNC_MAX_ENTRIES);
        assert_eq!(rows[0][0], 0.0);
        assert_eq!(rows[80][0], 800.0);
        for w in rows.windows(2) {
            assert!(w[1][0] > w[0][0], "nominals strictly increase: {w:?}");
        }
        for (row, &x) in rows.iter().zip(&s.positions_mm) {
            let c_mm = -model.predict(at_x(x)) * 1e-3;
            let expected = match comp_type {
                // Type 0: the actual position reached when the nominal is commanded.
                CompType::ActualPosition => x + c_mm,
                // Type 1: LinuxCNC's trim, added to the command: −c.
                CompType::Trim => -c_mm,
            };
            assert!((row[0] - x).abs() < FILE_TOL_MM);
            assert!(
                (row[1] - expected).abs() < FILE_TOL_MM,
                "{row:?} vs {expected}"
            );
            assert_eq!(row[1], row[2], "without reverse data forward = reverse");
        }
    }
}

#[test]
fn linuxcnc_type0_and_type1_load_the_same_trims() {
    // usrmotLoadComp turns a type-0 value into the trim `nominal − value`.
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 20.0), Extrapolation::Forbid).expect("ok");
    let t0 = parse_linuxcnc(&linuxcnc::render(&s, CompType::ActualPosition, None).expect("ok"));
    let t1 = parse_linuxcnc(&linuxcnc::render(&s, CompType::Trim, None).expect("ok"));
    for (a, b) in t0.iter().zip(&t1) {
        assert_eq!(a[0], b[0]);
        assert!(
            (a[0] - a[1] - b[1]).abs() < 2.0 * FILE_TOL_MM,
            "{a:?} {b:?}"
        );
    }
}

#[test]
fn linuxcnc_reverse_column_comes_from_the_reverse_line() {
    let model = spline_model();
    let line = line_x(0.0, 800.0, 50.0);
    let fwd = sample_line(&*model, &line, Extrapolation::Forbid).expect("ok");
    // Reverse-direction errors: the forward ones shifted by a 4 µm backlash.
    let mut rev = fwd.clone();
    rev.error_um.iter_mut().for_each(|e| *e -= 4.0);
    let rows = parse_linuxcnc(&linuxcnc::render(&fwd, CompType::Trim, Some(&rev)).expect("ok"));
    for (i, row) in rows.iter().enumerate() {
        assert!((row[1] - fwd.error_um[i] * 1e-3).abs() < FILE_TOL_MM);
        assert!((row[2] - rev.error_um[i] * 1e-3).abs() < FILE_TOL_MM);
        assert!((row[1] - row[2] - 0.004).abs() < 2.0 * FILE_TOL_MM);
    }
    // A reverse line at other positions is refused.
    let other = sample_line(&*model, &line_x(0.0, 750.0, 50.0), Extrapolation::Forbid).expect("ok");
    let e = linuxcnc::render(&fwd, CompType::Trim, Some(&other)).expect_err("mismatch");
    assert!(matches!(e, ExportError::ReverseMismatch { .. }), "{e}");
}

#[test]
fn linuxcnc_refuses_more_than_256_entries_and_names_a_step_that_fits() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 1.0), Extrapolation::Forbid).expect("ok");
    assert_eq!(s.len(), 801);
    let e = linuxcnc::render(&s, CompType::Trim, None).expect_err("801 > 256");
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            ExportError::TooManyEntries {
                controller: linuxcnc::LABEL,
                samples: 801,
                limit: 256,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(msg.contains("256") && msg.contains("801"), "{msg}");
    // 800/255 = 3.137…; the smallest whole-µm step ≥ that dividing 800 mm is 3.2 mm.
    assert!(msg.contains("at least 3.137255 mm"), "{msg}");
    assert!(msg.contains("e.g. 3.2 mm (251 entries)"), "{msg}");
    let s = sample_line(&*model, &line_x(0.0, 800.0, 3.2), Extrapolation::Forbid).expect("ok");
    let rows = parse_linuxcnc(&linuxcnc::render(&s, CompType::Trim, None).expect("fits"));
    assert_eq!(rows.len(), 251);
}

// ---------------------------------------------------------------------------------------
// Siemens
// ---------------------------------------------------------------------------------------

#[test]
fn siemens_program_has_the_documented_keywords_and_a_consistent_table() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 10.0), Extrapolation::Forbid).expect("ok");
    let text = siemens::render(&s, "X1", 200).expect("83 points fit 200");
    let first = text.lines().next().expect("non-empty");
    assert_eq!(first, "%_N_AX_EEC_INI");
    for kw in [
        "CHANDATA(1)",
        "$AA_ENC_COMP[0,0,X1]=",
        "$AA_ENC_COMP_STEP[0,X1]=",
        "$AA_ENC_COMP_MIN[0,X1]=",
        "$AA_ENC_COMP_MAX[0,X1]=",
        "$AA_ENC_COMP_IS_MODULO[0,X1]=0",
        "M17",
    ] {
        assert!(text.contains(kw), "missing `{kw}`:\n{text}");
    }
    assert_eq!(text.lines().last(), Some("M17"));
    let t = parse_siemens(&text, "X1");
    assert_eq!(t.modulo, "0");
    // N = (MAX − MIN)/STEP + 1.
    let n = (t.max_mm - t.min_mm) / t.step_mm + 1.0;
    assert_eq!(n, t.values_mm.len() as f64, "{t:?}");
    assert_eq!(t.values_mm.len(), 81 + 2);
    assert_eq!((t.step_mm, t.min_mm, t.max_mm), (10.0, -10.0, 810.0));
    // First and last values exactly 0.
    assert_eq!(t.values_mm[0], 0.0);
    assert_eq!(t.values_mm[t.values_mm.len() - 1], 0.0);
    // The rest are c = −e in mm, at MIN + N·STEP.
    for (x, v) in t.positions().iter().zip(&t.values_mm).skip(1).take(81) {
        let c_mm = -model.predict(at_x(*x)) * 1e-3;
        assert!((v - c_mm).abs() < FILE_TOL_MM, "at {x}: {v} vs {c_mm}");
    }
    // Values are mm: the largest is a few µm, i.e. a few 0.001.
    let max_abs = t.values_mm.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max_abs > 0.005 && max_abs < 0.02, "{max_abs} mm");
}

#[test]
fn siemens_refuses_tables_over_md38000_and_names_a_step_that_fits() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 10.0), Extrapolation::Forbid).expect("ok");
    let e = siemens::render(&s, "X1", 80).expect_err("83 > 80");
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            ExportError::TooManyEntries {
                controller: siemens::LABEL,
                samples: 81,
                padding: 2,
                limit: 80,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(msg.contains("MD38000") && msg.contains("80"), "{msg}");
    assert!(msg.contains("81 samples + 2 zero end points"), "{msg}");
    // k ≤ 80 − 3 = 77 intervals; the smallest whole-µm step ≥ 800/77 dividing 800 is 12.5.
    assert!(msg.contains("e.g. 12.5 mm (67 entries)"), "{msg}");
    let s = sample_line(&*model, &line_x(0.0, 800.0, 12.5), Extrapolation::Forbid).expect("ok");
    let t = parse_siemens(&siemens::render(&s, "X1", 80).expect("fits"), "X1");
    assert_eq!(t.values_mm.len(), 67);
}

#[test]
fn siemens_refuses_bad_axis_names_and_uneven_samples() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 800.0, 100.0), Extrapolation::Forbid).expect("ok");
    for bad in ["", "X1]=0\nM17", "1X", "X 1"] {
        let e = siemens::render(&s, bad, 200).expect_err("bad name");
        assert!(matches!(e, ExportError::BadAxisName { .. }), "{bad:?}: {e}");
    }
    let mut uneven = s.clone();
    uneven.positions_mm[3] += 7.0;
    let e = siemens::render(&uneven, "X1", 200).expect_err("not equidistant");
    assert!(
        matches!(e, ExportError::NotEquidistant { index: 3, .. }),
        "{e}"
    );
    let e = ExportFormat::Siemens {
        axis_name: "X1".into(),
        max_points: 200,
    }
    .render_line(&s, Some(&s))
    .expect_err("no reverse table");
    assert!(matches!(e, ExportError::ReverseUnsupported { .. }), "{e}");
}

// ---------------------------------------------------------------------------------------
// Round trip: apply the exported table to the simulated machine
// ---------------------------------------------------------------------------------------

/// Applies a LinuxCNC trim table (mm) and a Siemens table (mm) to the machine along the
/// line and returns the RMS of (raw error, LinuxCNC residual, Siemens residual, fit error)
/// over commanded positions every 0.25 mm in [lo, hi], all µm.
///
/// * LinuxCNC adds the trim to the command: the motor goes to M = N + trim(N); the true
///   position is M − e(M); the indicated position is N; residual = N − true.
/// * Siemens adds c to the actual value: the servo settles where M + c(M) = N; the true
///   position is M − e(M); residual = N − true = e(M) + c(M).
fn apply(
    model: &dyn Interpolator,
    truth: impl Fn([f64; 3]) -> f64,
    lc: &[[f64; 3]],
    sm: &SiemensTable,
    lo: f64,
    hi: f64,
) -> [f64; 4] {
    let lc_x: Vec<f64> = lc.iter().map(|r| r[0]).collect();
    let lc_trim: Vec<f64> = lc.iter().map(|r| r[1]).collect();
    let sm_x = sm.positions();
    let (mut raw, mut lcr, mut smr, mut fit) = (vec![], vec![], vec![], vec![]);
    let mut n = lo;
    while n <= hi + 1e-9 {
        raw.push(truth(at_x(n)));
        let m = n + table_at(&lc_x, &lc_trim, n);
        let true_pos = m - truth(at_x(m)) * 1e-3;
        lcr.push((n - true_pos) * 1e3);
        let mut m = n;
        for _ in 0..8 {
            m = n - table_at(&sm_x, &sm.values_mm, m);
        }
        let true_pos = m - truth(at_x(m)) * 1e-3;
        smr.push((n - true_pos) * 1e3);
        fit.push(model.predict(at_x(n)) - truth(at_x(n)));
        n += 0.25;
    }
    [rms(&raw), rms(&lcr), rms(&smr), rms(&fit)]
}

#[test]
fn round_trip_compensation_leaves_fit_plus_table_interpolation_error() {
    let model = spline_model();
    let step = 10.0;
    let s = sample_line(&*model, &line_x(0.0, 800.0, step), Extrapolation::Forbid).expect("ok");
    let lc = parse_linuxcnc(&linuxcnc::render(&s, CompType::Trim, None).expect("ok"));
    let sm = parse_siemens(&siemens::render(&s, "X1", 200).expect("ok"), "X1");
    let [raw, lc_rms, sm_rms, fit] = apply(&*model, truth, &lc, &sm, 0.0, 800.0);
    // Linear interpolation of the table between entries h apart is off by at most
    // h²/8·max|e''|; the file's 1 nm rounding and the first-order lookup add < 0.002 µm.
    let table_um = step * step / 8.0 * TRUTH_D2X_MAX;
    let budget = fit + table_um + 0.002;
    eprintln!(
        "raw {raw:.4} µm, linuxcnc {lc_rms:.4} µm, siemens {sm_rms:.4} µm, \
         fit {fit:.4} µm, table bound {table_um:.4} µm"
    );
    // Observed: raw 4.796 µm, fit 0.0134 µm, residuals 0.0144 µm (budget 0.0229 µm).
    assert!((4.7..4.9).contains(&raw), "raw RMS {raw} µm");
    assert!(fit < 0.02, "spline fit RMS {fit} µm");
    for (name, r) in [("linuxcnc", lc_rms), ("siemens", sm_rms)] {
        assert!(
            r <= budget,
            "{name}: residual {r} µm > fit {fit} + table {table_um} µm"
        );
        assert!(r < raw / 200.0, "{name}: residual {r} µm vs raw {raw} µm");
    }
}

#[test]
fn round_trip_on_table_1_with_a_coarse_model() {
    // The machine's truth is the paper's Lagrange 4×1×2 field through Table 1; errmap
    // exports a trilinear fit of the same table. The residual is then the trilinear-vs-
    // truth difference (the fit error) plus the 10 mm table interpolation.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/table1.csv");
    let grid = ErrorTable::read(&path)
        .expect("table 1")
        .grid()
        .expect("grid");
    let machine = Method::Lagrange(Order([4, 1, 2]))
        .fit(&grid)
        .expect("lagrange");
    let model = Method::Trilinear.fit(&grid).expect("trilinear");
    let truth = |p: [f64; 3]| machine.predict(p);
    let s = sample_line(&*model, &line_x(10.0, 790.0, 10.0), Extrapolation::Forbid).expect("ok");
    let lc = parse_linuxcnc(&linuxcnc::render(&s, CompType::ActualPosition, None).expect("ok"));
    // Type 0 → LinuxCNC's trim = nominal − actual.
    let lc: Vec<[f64; 3]> = lc
        .iter()
        .map(|r| [r[0], r[0] - r[1], r[0] - r[2]])
        .collect();
    let sm = parse_siemens(&siemens::render(&s, "X1", 200).expect("ok"), "X1");
    let [raw, lc_rms, sm_rms, fit] = apply(&*model, truth, &lc, &sm, 10.0, 790.0);
    eprintln!("table 1: raw {raw:.4} µm, linuxcnc {lc_rms:.4}, siemens {sm_rms:.4}, fit {fit:.4}");
    // The trilinear model is piecewise linear along x with 200 mm cells, so the 10 mm
    // table reproduces it exactly; only the fit error and rounding remain.
    for r in [lc_rms, sm_rms] {
        assert!(
            (r - fit).abs() < 0.01 * fit + 0.002,
            "residual {r} µm vs fit {fit} µm"
        );
        assert!(r < raw, "compensation must help: {r} vs {raw}");
    }
}

// ---------------------------------------------------------------------------------------
// Sign
// ---------------------------------------------------------------------------------------

#[test]
fn error_k_times_x_gets_compensation_minus_k_times_x() {
    let k = 0.02; // µm per mm: the scale over-reads by 20 ppm
    let grid = Grid::from_fn(
        steps(0.0, 500.0, 100.0),
        vec![0.0, 100.0],
        vec![0.0, 100.0],
        |p| k * p[0],
    );
    let model = Method::Trilinear.fit(&grid).expect("fit");
    let line = LineSpec {
        axis: Axis::X,
        at_mm: [0.0, 50.0, 50.0],
        start_mm: 0.0,
        end_mm: 500.0,
        step_mm: 50.0,
    };
    let s = sample_line(&*model, &line, Extrapolation::Forbid).expect("ok");
    for (x, c) in s.positions_mm.iter().zip(s.comp_um()) {
        assert!(
            (c + k * x).abs() < 1e-12,
            "c({x}) = {c}, expected {}",
            -k * x
        );
    }
    let t0 = parse_linuxcnc(&linuxcnc::render(&s, CompType::ActualPosition, None).expect("ok"));
    let t1 = parse_linuxcnc(&linuxcnc::render(&s, CompType::Trim, None).expect("ok"));
    let sm = parse_siemens(&siemens::render(&s, "X1", 200).expect("ok"), "X1");
    for (i, &x) in s.positions_mm.iter().enumerate() {
        let c_mm = -k * x * 1e-3;
        // Actual position falls short of nominal by k·x; the trim commands k·x further;
        // Siemens adds −k·x to the actual value.
        assert!((t0[i][1] - (x + c_mm)).abs() < FILE_TOL_MM);
        assert!((t1[i][1] - (-c_mm)).abs() < FILE_TOL_MM);
        assert!((sm.values_mm[i + 1] - c_mm).abs() < FILE_TOL_MM);
    }
    assert!(t1[10][1] > 0.0 && sm.values_mm[11] < 0.0);
}

// ---------------------------------------------------------------------------------------
// Bad requests and extrapolation
// ---------------------------------------------------------------------------------------

#[test]
fn bad_steps_and_ranges_are_refused() {
    let model = spline_model();
    for step in [0.0, -10.0, f64::NAN, f64::INFINITY] {
        let e = sample_line(&*model, &line_x(0.0, 800.0, step), Extrapolation::Allow)
            .expect_err("bad step");
        assert!(matches!(e, ExportError::BadStep { .. }), "{step}: {e}");
    }
    for (a, b) in [(800.0, 0.0), (100.0, 100.0)] {
        let e = sample_line(&*model, &line_x(a, b, 10.0), Extrapolation::Allow)
            .expect_err("empty range");
        assert!(matches!(e, ExportError::EmptyRange { .. }), "{e}");
    }
    let e = sample_line(&*model, &line_x(0.0, 800.0, 30.0), Extrapolation::Allow)
        .expect_err("30 does not divide 800");
    let msg = e.to_string();
    assert!(matches!(e, ExportError::StepDoesNotDivide { .. }), "{e}");
    assert!(msg.contains("29.62963"), "names 800/27: {msg}");
    let e = sample_line(&*model, &line_x(0.0, 800.0, 1e-6), Extrapolation::Allow)
        .expect_err("8e8 points");
    assert!(matches!(e, ExportError::TooManyPoints { .. }), "{e}");
    let mut line = line_x(0.0, 800.0, 10.0);
    line.at_mm[1] = f64::NAN;
    let e = sample_line(&*model, &line, Extrapolation::Allow).expect_err("NaN y");
    assert!(
        matches!(e, ExportError::NonFiniteCoordinate { axis: Axis::Y, .. }),
        "{e}"
    );
    // The line's own axis entry of `at_mm` is ignored.
    line.at_mm = [f64::NAN, 200.0, 350.0];
    sample_line(&*model, &line, Extrapolation::Allow).expect("x entry ignored");
}

#[test]
fn extrapolated_positions_are_flagged_or_refused_with_the_mapped_range() {
    let model = spline_model();
    let line = line_x(0.0, 900.0, 10.0);
    let s = sample_line(&*model, &line, Extrapolation::Allow).expect("allowed");
    assert_eq!(s.extrapolated_count(), 10);
    for (x, f) in s.positions_mm.iter().zip(&s.extrapolated) {
        assert_eq!(*f, *x > 800.0, "flag at {x}");
    }
    let e = sample_line(&*model, &line, Extrapolation::Forbid).expect_err("forbidden");
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            ExportError::OutsideMappedRange {
                outside: 10,
                total: 91,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        msg.contains("x 0.0–800.0 mm, y 0.0–400.0 mm, z 200.0–500.0 mm"),
        "names the mapped range: {msg}"
    );
    assert!(
        msg.contains("(810.0, 200.0, 350.0) mm"),
        "names the first: {msg}"
    );
    // A line that misses the volume altogether.
    let mut off = line_x(0.0, 800.0, 10.0);
    off.at_mm[1] = 1000.0;
    let e = sample_line(&*model, &off, Extrapolation::Forbid).expect_err("off the map");
    assert!(e.to_string().contains("none of the 81 positions"), "{e}");
    // The mapped range is found for uneven, non-zero-based nodes too (Table 1).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/table1.csv");
    let grid = ErrorTable::read(&path)
        .expect("table 1")
        .grid()
        .expect("grid");
    let t1 = Method::Spline.fit(&grid).expect("fit");
    let e = sample_line(&*t1, &line_x(0.0, 800.0, 10.0), Extrapolation::Forbid)
        .expect_err("x = 0 is below 1.2424");
    assert!(e.to_string().contains("x 1.2424–800.0 mm"), "{e}");
}

// ---------------------------------------------------------------------------------------
// CSV and the volumetric grid
// ---------------------------------------------------------------------------------------

#[test]
fn line_csv_reads_back_as_an_errmap_points_table() {
    let model = spline_model();
    let s = sample_line(&*model, &line_x(0.0, 900.0, 50.0), Extrapolation::Allow).expect("ok");
    let text = csv(&s);
    assert!(text.starts_with("x_mm,y_mm,z_mm,e_um,comp_um,extrapolated\n"));
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("line.csv");
    std::fs::write(&p, &text).expect("write");
    let t = ErrorTable::read_points(&p).expect("valid points table");
    assert_eq!(t.points.len(), s.len());
    let comp = t.extra_column("comp_um").expect("comp_um kept");
    for (i, pt) in t.points.iter().enumerate() {
        assert_eq!(pt.position(), s.point(i));
        assert_eq!(pt.e_um, s.error_um[i]);
        assert_eq!(comp.values[i], Some(-s.error_um[i]));
    }
    let flags: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap_or(""))
        .collect();
    assert_eq!(flags.iter().filter(|f| **f == "true").count(), 2);
    assert_eq!(
        ExportFormat::Csv.render_line(&s, None).expect("csv"),
        text,
        "render_line dispatches"
    );
    assert!(matches!(
        ExportFormat::Grid.render_line(&s, None),
        Err(ExportError::GridNeedsVolume)
    ));
}

#[test]
fn volumetric_grid_writes_csv_and_parquet_that_read_back_as_error_tables() {
    let model = spline_model();
    let spec = VolumeSpec {
        lo_mm: [0.0, 0.0, 200.0],
        hi_mm: [800.0, 400.0, 500.0],
        spacing_mm: 100.0,
    };
    let dir = tempfile::tempdir().expect("tempdir");
    for name in ["vol.csv", "vol.parquet"] {
        let p = dir.path().join(name);
        let rows = write_grid(&*model, &spec, Extrapolation::Forbid, &p).expect("writes");
        assert_eq!(rows, 9 * 5 * 4);
        let table = ErrorTable::read(&p).expect("reads back");
        let grid = table.grid().expect("a rectilinear grid");
        assert_eq!(grid.shape(), [9, 5, 4]);
        let comp = table.extra_column("comp_um").expect("comp_um");
        for (i, pt) in table.points.iter().enumerate() {
            let e = model.predict(pt.position());
            assert!((pt.e_um - e).abs() < 1e-12, "{name}: {pt:?} vs {e}");
            assert_eq!(comp.values[i], Some(-pt.e_um));
        }
    }
    // A single plane (lo == hi on z) is allowed for a volume.
    let plane = VolumeSpec {
        lo_mm: [0.0, 0.0, 350.0],
        hi_mm: [800.0, 400.0, 350.0],
        spacing_mm: 200.0,
    };
    let p = dir.path().join("plane.csv");
    assert_eq!(
        write_grid(&*model, &plane, Extrapolation::Forbid, &p).expect("plane"),
        5 * 3
    );
    // Beyond the map: refused when forbidden, flagged otherwise.
    let big = VolumeSpec {
        hi_mm: [900.0, 400.0, 500.0],
        ..spec
    };
    let p = dir.path().join("big.csv");
    let e = write_grid(&*model, &big, Extrapolation::Forbid, &p).expect_err("outside");
    assert!(e.to_string().contains("x 0.0–800.0 mm"), "{e}");
    assert!(!p.exists(), "nothing written on refusal");
    write_grid(&*model, &big, Extrapolation::Allow, &p).expect("flagged");
    let text = std::fs::read_to_string(&p).expect("read");
    let flagged = text.lines().filter(|l| l.ends_with(",true")).count();
    assert_eq!(flagged, 5 * 4, "the x = 900 plane is flagged");
    let e = write_grid(
        &*model,
        &spec,
        Extrapolation::Allow,
        &dir.path().join("v.xlsx"),
    )
    .expect_err("extension");
    assert!(matches!(e, ExportError::Table(_)), "{e}");
}

#[test]
fn samples_built_by_hand_are_checked() {
    let s = Sampled {
        axis: Axis::X,
        at_mm: AT,
        positions_mm: vec![0.0, 10.0, 10.0],
        error_um: vec![1.0, 2.0, 3.0],
        extrapolated: vec![false; 3],
    };
    let e = linuxcnc::render(&s, CompType::Trim, None).expect_err("repeated nominal");
    assert!(
        matches!(e, ExportError::NotIncreasing { index: 2, .. }),
        "{e}"
    );
    let s = Sampled {
        positions_mm: vec![0.0, 10.0],
        error_um: vec![1.0],
        ..s
    };
    let e = linuxcnc::render(&s, CompType::Trim, None).expect_err("lengths");
    assert!(matches!(e, ExportError::LengthMismatch { .. }), "{e}");
    let s = Sampled {
        positions_mm: vec![0.0, 10.0],
        error_um: vec![1.0, f64::NAN],
        extrapolated: vec![false; 2],
        ..s
    };
    let e = siemens::render(&s, "X1", 200).expect_err("NaN");
    assert!(
        matches!(e, ExportError::NonFiniteSample { index: 1, .. }),
        "{e}"
    );
    let s = Sampled {
        positions_mm: vec![0.0, 10.0 / 3.0],
        error_um: vec![1.0, 1.0],
        ..s
    };
    let e = siemens::render(&s, "X1", 200).expect_err("step 3.333…");
    assert!(matches!(e, ExportError::StepNotRepresentable { .. }), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any step either divides the range (positions start…end, strictly increasing, one
    /// per step) or is refused with a typed error; nothing panics.
    #[test]
    fn sample_line_never_panics(start in -500.0f64..500.0, length in 0.001f64..1000.0,
                                step in 0.01f64..200.0, k in 1usize..300) {
        let grid = Grid::from_fn(vec![-1000.0, 1000.0], vec![0.0, 1.0], vec![0.0, 1.0], |p| 0.01 * p[0]);
        let model = Method::Trilinear.fit(&grid).expect("fit");
        let end = start + length;
        match sample_line(&*model, &line_x(start, end, step), Extrapolation::Allow) {
            Ok(s) => {
                // Positions are snapped to the nanometre (`snap`).
                prop_assert!((s.positions_mm[0] - start).abs() <= 1e-9,
                    "first {} for start {}", s.positions_mm[0], start);
                // The step divides the range, or is the range over k rounded to the file
                // resolution (the suggestion given back): then the end moves by at most
                // k · 0.5e-6 mm (found by this test after that rule came in: step 0.01 mm
                // over 131.39324 mm ends at 131.39).
                let last = *s.positions_mm.last().expect("non-empty");
                let k = (s.len() - 1) as f64;
                prop_assert!((last - end).abs() <= k * 0.5 * FILE_RESOLUTION_MM + 1e-9,
                    "last {} for end {}", last, end);
                prop_assert!(s.positions_mm.windows(2).all(|w| w[1] > w[0]));
                prop_assert_eq!(s.len(), (length / step).round() as usize + 1);
            }
            Err(e) => prop_assert!(matches!(
                e,
                ExportError::StepDoesNotDivide { .. } | ExportError::TooManyPoints { .. }
            ), "{}", e),
        }
        // A step that divides the length by construction is always accepted.
        let s = sample_line(&*model, &line_x(start, end, length / k as f64), Extrapolation::Allow);
        prop_assert!(s.is_ok(), "{:?}", s.err());
        let s = s.expect("ok");
        prop_assert_eq!(s.len(), k + 1);
        prop_assert!(s.positions_mm.windows(2).all(|w| w[1] > w[0]));
    }
}

/// `export SESSION --bidirectional`: LinuxCNC's forward and reverse columns come from the
/// session's per-direction means, so on the concealed case with a hidden 1 µm reversal
/// (truth.json) the two trims differ by b at every target, and on the clean case by
/// nothing but noise. Other formats, and an ambiguous line, are refused.
#[test]
fn bidirectional_linuxcnc_table_carries_the_reversal_of_the_session() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    let run = |case: &str, extra: &[&str]| {
        let out = dir.path().join(format!("{case}.comp"));
        let session = root.join(format!("datasets/concealed/{case}/recorded.parquet"));
        let mut args = vec![
            "export".to_string(),
            session.display().to_string(),
            "--bidirectional".into(),
            "--out".into(),
            out.display().to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_errmap"))
            .args(&args)
            .output()
            .expect("runs");
        (o, out)
    };
    let line = [
        "--format",
        "linuxcnc",
        "--comp-type",
        "trim",
        "--at",
        "y=1,z=200",
    ];
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("datasets/concealed/reversal/truth.json"))
            .expect("truth"),
    )
    .expect("json");
    let b_um = truth["params"]["reversal"]["b_um"].as_f64().expect("b_um");
    for (case, expected_um) in [("reversal", b_um), ("clean", 0.0)] {
        let (o, out) = run(case, &line);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let rows = parse_linuxcnc(&std::fs::read_to_string(&out).expect("written"));
        assert_eq!(rows.len(), 9, "{case}: one triplet per target");
        for [nominal, forward, reverse] in rows {
            // Type 1 columns are the trims e (mm); e↑ − e↓ = b for the d·b/2 reversal.
            let diff_um = (forward - reverse) * 1e3;
            assert!(
                (diff_um - expected_um).abs() < 0.05,
                "{case} at {nominal} mm: forward − reverse = {diff_um} µm, expected {expected_um}"
            );
        }
    }
    // A format without direction tables with --bidirectional: a usage error (issue 17).
    let (o, _) = run("reversal", &["--format", "heidenhain", "--at", "y=1,z=200"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("direction-dependent"));
    let (o, _) = run("reversal", &["--format", "linuxcnc"]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    // The library names the line's position; the command line says its flag.
    assert!(
        e.contains("4 lines match; choose one with --at y=…,z=…"),
        "{e}"
    );
    let (o, _) = run("reversal", &["--format", "linuxcnc", "--method", "spline"]);
    assert_eq!(o.status.code(), Some(2), "--bidirectional takes no model");
}

// ---------------------------------------------------------------------------------------
// SINUMERIK direction-dependent compensation (two CEC tables, K3 §4.4.4); the helpers
// (an analytic error curve, the concealed sessions) are those of `export_dialects`
// ---------------------------------------------------------------------------------------

/// One CEC table read back from a `%_N_NC_CEC_INI` program.
#[derive(Debug, Default)]
struct CecTable {
    values_mm: Vec<f64>,
    input: String,
    output: String,
    step_mm: f64,
    min_mm: f64,
    max_mm: f64,
    direction: i32,
}

fn parse_cec(text: &str) -> std::collections::BTreeMap<usize, CecTable> {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "%_N_NC_CEC_INI");
    assert_eq!(*lines.last().expect("lines"), "M17");
    let mut tables: std::collections::BTreeMap<usize, CecTable> = Default::default();
    let mut points: std::collections::BTreeMap<(usize, usize), f64> = Default::default();
    for line in lines.iter().filter(|l| l.starts_with('$')) {
        let (lhs, v) = line.split_once('=').expect("assignment");
        let (name, idx) = lhs.trim_end_matches(']').split_once('[').expect("index");
        let ix: Vec<usize> = idx.split(',').map(|t| t.parse().expect("index")).collect();
        let t = tables.entry(ix[0]).or_default();
        match name {
            "$AN_CEC" => {
                points.insert((ix[0], ix[1]), v.parse().expect("mm"));
            }
            "$AN_CEC_INPUT_AXIS" => t.input = v.into(),
            "$AN_CEC_OUTPUT_AXIS" => t.output = v.into(),
            "$AN_CEC_STEP" => t.step_mm = v.parse().expect("mm"),
            "$AN_CEC_MIN" => t.min_mm = v.parse().expect("mm"),
            "$AN_CEC_MAX" => t.max_mm = v.parse().expect("mm"),
            "$AN_CEC_DIRECTION" => t.direction = v.parse().expect("±1"),
            "$AN_CEC_MULT_BY_TABLE" | "$AN_CEC_IS_MODULO" => assert_eq!(v, "0"),
            other => panic!("unexpected {other}"),
        }
    }
    for ((t, n), v) in points {
        let table = tables.get_mut(&t).expect("table");
        assert_eq!(table.values_mm.len(), n, "points in order from 0");
        table.values_mm.push(v);
    }
    tables
}

#[test]
fn siemens_direction_dependent_tables_round_trip_both_directions() {
    let h = 10.0;
    let xs = grid(0.0, 400.0, h);
    let up = measured(&xs, truth_x);
    let down = measured(&xs, truth_x_down);
    let format = ExportFormat::SiemensCec {
        axis_number: 2,
        first_table: 4,
        max_points: 200,
    };
    let tables = parse_cec(&format.render_line(&up, Some(&down)).expect("renders"));
    assert_eq!(tables.keys().copied().collect::<Vec<_>>(), [4, 5]);
    for (t, truth, direction) in [(4, truth_x as fn(f64) -> f64, 1), (5, truth_x_down, -1)] {
        let c = &tables[&t];
        assert_eq!((c.input.as_str(), c.output.as_str()), ("(AX2)", "(AX2)"));
        assert_eq!(c.direction, direction);
        // MIN + (points − 1)·STEP = MAX, padded with 0 one step beyond each end.
        let n = c.values_mm.len();
        assert_eq!((c.min_mm, c.max_mm, c.step_mm, n), (-10.0, 410.0, 10.0, 43));
        assert_eq!((c.values_mm[0], c.values_mm[n - 1]), (0.0, 0.0));
        let tx: Vec<f64> = (0..n).map(|i| c.min_mm + i as f64 * c.step_mm).collect();
        // LEC sign: the table corrects the actual value, residual e + c; linear between
        // points, so ≤ h²/8·max|e''| plus the file's 1 nm.
        let bound = h * h / 8.0 * TRUTH_D2 + 0.001;
        let mut x = 0.0;
        while x <= 400.0 {
            let r = truth(x) + table_at(&tx, &c.values_mm, x) * 1e3;
            assert!(
                r.abs() <= bound,
                "table {t} at {x}: residual {r} µm > {bound}"
            );
            x += 0.5;
        }
    }
    // The reversal survives: c↑ − c↓ = e↓ − e↑ = 3 + 0.002·x µm.
    for (i, &x) in xs.iter().enumerate() {
        let d = (tables[&4].values_mm[i + 1] - tables[&5].values_mm[i + 1]) * 1e3;
        assert!((d - (3.0 + 0.002 * x)).abs() < 0.002, "at {x}: {d} µm");
    }
    // MD18342 too small: 41 samples + 2 zero points > 42.
    let small = ExportFormat::SiemensCec {
        axis_number: 2,
        first_table: 0,
        max_points: 42,
    };
    match small.render_line(&up, Some(&down)).expect_err("refused") {
        ExportError::TooManyEntries {
            controller: siemens::LABEL,
            samples: 41,
            padding: 2,
            limit: 42,
            ..
        } => {}
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        format.render_line(&up, None),
        Err(ExportError::ReverseMismatch { .. })
    ));
    let last = ExportFormat::SiemensCec {
        axis_number: 2,
        first_table: usize::MAX,
        max_points: 200,
    };
    assert!(matches!(
        last.render_line(&up, Some(&down)),
        Err(ExportError::ControllerLimit {
            controller: siemens::LABEL,
            ..
        })
    ));
}

#[test]
fn bidirectional_siemens_program_carries_the_reversal_of_the_session() {
    let dir = tempfile::tempdir().expect("tempdir");
    let b = hidden_reversal_um();
    for (case, b_um) in [("reversal", b), ("clean", 0.0)] {
        let (code, err, text) = export_session(case, &["--format", "siemens"], dir.path());
        assert_eq!(code, Some(0), "{err}");
        let tables = parse_cec(&text);
        let (up, down) = (&tables[&0], &tables[&1]);
        assert_eq!((up.direction, down.direction), (1, -1));
        assert_eq!(up.values_mm.len(), 11, "9 targets + 2 zero points");
        for i in 1..=9 {
            // c↑ − c↓ = e↓ − e↑ = −b.
            let d_um = (up.values_mm[i] - down.values_mm[i]) * 1e3;
            assert!((d_um + b_um).abs() < 0.05, "{case}, target {i}: {d_um} µm");
        }
    }
}
