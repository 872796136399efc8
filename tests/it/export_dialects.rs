//! The FANUC, HEIDENHAIN and TwinCAT CNC (ISG) compensation tables: golden texts, the
//! controllers' limits refused with a clear message, and round trips — each file is read
//! back by an independent parser here, applied with the controller's rule as its
//! documentation states it (FANUC: increments summed from the reference position;
//! HEIDENHAIN and ISG: linear interpolation between points), and the error left at the
//! measured positions is checked against a stated tolerance. Known-answer data: an
//! analytic error curve, and the example of the FANUC parameter manual.

use std::f64::consts::TAU;

use errmap::controller::fanuc::{self, FanucSpec};
use errmap::controller::isg::{self, IsgAxis};
use errmap::controller::{ExportFormat, heidenhain};
use errmap::export::{
    Ends, ExportError, Extrapolation, LineSpec, Sampled, StepFit, sample_line_fit,
};
use errmap::interp::Method;
use errmap::table::{Axis, Grid};

use super::export::table_at as lerp;

pub(crate) const AT: [f64; 3] = [0.0, 200.0, 350.0];

/// The axis' error e = indicated − reference along x, µm: a pitch error and a scale error.
pub(crate) fn truth_x(x: f64) -> f64 {
    6.0 * (TAU * x / 640.0).sin() + 0.004 * x
}

/// max |e''| of [`truth_x`], µm/mm².
pub(crate) const TRUTH_D2: f64 = 6.0 * (TAU / 640.0) * (TAU / 640.0);

/// The error measured moving down: the same curve plus a reversal that grows along x.
pub(crate) fn truth_x_down(x: f64) -> f64 {
    truth_x(x) + 3.0 + 0.002 * x
}

pub(crate) fn measured(positions: &[f64], f: impl Fn(f64) -> f64) -> Sampled {
    Sampled::measured(
        Axis::X,
        AT,
        positions.to_vec(),
        positions.iter().map(|&x| f(x)).collect(),
    )
}

pub(crate) fn grid(lo: f64, hi: f64, h: f64) -> Vec<f64> {
    let n = ((hi - lo) / h).round() as usize;
    (0..=n).map(|i| lo + i as f64 * h).collect()
}

/// A spline through [`truth_x`] mapped every 25 mm over 0–800 mm (and on a 3 × 3 grid
/// in y, z around [`AT`]).
fn spline_of_truth() -> Box<dyn errmap::interp::Interpolator> {
    let g = Grid::from_fn(
        grid(0.0, 800.0, 25.0),
        vec![0.0, 200.0, 400.0],
        vec![200.0, 350.0, 500.0],
        |p| truth_x(p[0]),
    );
    Method::Spline.fit(&g).expect("fits")
}

fn limit_problem(e: ExportError, controller: &str) -> String {
    match e {
        ExportError::ControllerLimit {
            controller: c,
            problem,
        } if c == controller => problem,
        other => panic!("expected a {controller} limit, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------
// FANUC
// ---------------------------------------------------------------------------------------

/// A FANUC data file read back: the parameters from the comment block and the values by
/// point number.
struct FanucFile {
    params: Vec<(String, i64)>,
    interval_mm: f64,
    unit_um: f64,
    values: std::collections::BTreeMap<u32, i64>,
}

impl FanucFile {
    fn param(&self, name: &str) -> i64 {
        self.params
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("parameter {name} missing"))
            .1
    }
}

fn parse_fanuc(text: &str) -> FanucFile {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.first(), Some(&"%"), "starts with %");
    assert_eq!(lines.last(), Some(&"%"), "ends with %");
    let mut params = Vec::new();
    let (mut interval_mm, mut unit_um) = (None, None);
    let mut values = std::collections::BTreeMap::new();
    for line in &lines[1..lines.len() - 1] {
        if let Some(c) = line.strip_prefix('(') {
            let c = c.strip_suffix(')').expect("comment closed on its line");
            assert!(
                !c.contains('(') && !c.contains(')'),
                "nested parentheses: {line}"
            );
            assert_eq!(c, c.to_uppercase(), "comments in upper case: {line}");
            if let Some(rest) = c
                .split_once(": ")
                .filter(|(h, _)| h.starts_with("PARAMETERS"))
            {
                for item in rest.1.split_whitespace() {
                    if let Some((k, v)) = item.split_once('=') {
                        if k == "3624" {
                            interval_mm = Some(v.parse::<f64>().expect("3624 in mm"));
                        } else {
                            params.push((k.to_string(), v.parse().expect("integer parameter")));
                        }
                    }
                }
            }
            if let Some(u) = c.split("UNITS OF ").nth(1) {
                unit_um = Some(u.trim_end_matches(" UM").parse::<f64>().expect("unit"));
            }
            continue;
        }
        let rest = line.strip_prefix('N').expect("data line N…P…");
        let (num, val) = rest.split_once('P').expect("P");
        let num: u32 = num.parse().expect("data number");
        assert!(num >= 10000, "pitch data numbers are 10000 + point");
        let prev = values.insert(num - 10000, val.parse::<i64>().expect("integer value"));
        assert!(prev.is_none(), "point {} written twice", num - 10000);
    }
    FanucFile {
        params,
        interval_mm: interval_mm.expect("3624"),
        unit_um: unit_um.expect("unit"),
        values,
    }
}

/// The absolute compensation (units) at point `k` from the reference position (k = 0) of
/// the list starting at `first` whose reference-section number is `reference`: the sum of
/// the increments of the sections between (FANUC parameter manual, 3620–3624).
fn fanuc_absolute(
    values: &std::collections::BTreeMap<u32, i64>,
    offset: i64,
    reference: i64,
    k: i64,
) -> i64 {
    let v = |n: i64| values[&((n + offset) as u32)];
    if k >= 0 {
        (reference + 1..=reference + k).map(v).sum()
    } else {
        -(reference + k + 1..=reference).map(v).sum::<i64>()
    }
}

#[test]
fn fanuc_golden_text() {
    let s = measured(&grid(-20.0, 30.0, 10.0), |x| match x as i64 {
        -20 => 2.4,
        -10 => 1.0,
        0 => 0.6,
        10 => 2.0,
        20 => 4.9,
        _ => 5.2,
    });
    let text = fanuc::render(&s, None, &FanucSpec::default()).expect("renders");
    // Relative to e(0) = 0.6 µm the absolute values round to 2, 0, 0, 1, 4, 5 µm; the
    // increments of the sections ending at −10 … 30 mm are −2, 0, 1, 3, 1, numbered from
    // 3620 − 20/10 + 1 = 0 with the reference section (−10, 0] at 3620 = 1.
    let expected = "%
(FANUC PITCH ERROR COMPENSATION FROM ERRMAP)
(AXIS 1 = X, LINE AT Y 200.0 Z 350.0 MM, 6 POINTS, 0 EXTRAPOLATED)
(PARAMETERS OF AXIS 1: 3605#0=0 3620=1 3621=0 3622=4 3623=1 3624=10.0 MM)
(REFERENCE POSITION 0.0 MM; VALUES ARE INCREMENTS IN UNITS OF 1.0 UM)
(NOT IN THE TABLE: THE ERROR AT THE REFERENCE POSITION, 0.6 UM)
N10000P-2
N10001P0
N10002P1
N10003P3
N10004P1
%
";
    assert_eq!(text, expected);
}

#[test]
fn fanuc_reproduces_the_parameter_manual_example() {
    // FANUC 0i-PB parameter manual (B-63980EN/01) p. 100: reference position 0 at number
    // 40, interval 50 mm, the most negative point at −400 mm → 3621 = 40 − 400/50 + 1 =
    // 33; the values of numbers 33–49 as printed there.
    let book = [2, 1, 1, -2, 0, -1, 0, -1, 2, 1, 0, -1, -1, -2, 0, 1, 2];
    let xs = grid(-400.0, 450.0, 50.0);
    // The absolute curve the values describe (0 at −400 mm, because 33–40 sum to 0).
    let mut e = vec![0.0];
    for v in book {
        e.push(e.last().expect("present") + v as f64);
    }
    assert_eq!(
        e[8], 0.0,
        "the book's curve passes through 0 at the reference"
    );
    let s = Sampled::measured(Axis::X, AT, xs, e);
    let spec = FanucSpec {
        reference_number: Some(40),
        ..FanucSpec::default()
    };
    let t = fanuc::table(&s, None, &spec).expect("fits");
    assert_eq!(
        (t.reference_number, t.negative_number, t.positive_number),
        (40, 33, 49)
    );
    assert_eq!(t.values, book.map(i64::from).to_vec());
    let f = parse_fanuc(&fanuc::render(&s, None, &spec).expect("renders"));
    assert_eq!(f.param("3621"), 33);
    assert_eq!(f.interval_mm, 50.0);
    assert_eq!(f.values.values().copied().collect::<Vec<_>>(), t.values);
}

/// Round trip at the points: the control's absolute compensation (units × unit) added to
/// the motion leaves e − A = e(r), the offset at the reference, within half a unit.
fn fanuc_round_trip(detection_unit_um: f64, magnification: u32, h: f64) -> f64 {
    let xs = grid(-100.0, 700.0, h);
    let s = measured(&xs, truth_x);
    let spec = FanucSpec {
        reference_mm: 0.0,
        detection_unit_um,
        magnification,
        max_value: 100,
        ..FanucSpec::default()
    };
    let f = parse_fanuc(&fanuc::render(&s, None, &spec).expect("renders"));
    assert_eq!(f.unit_um, detection_unit_um * magnification as f64);
    let (r, first) = (f.param("3620"), f.param("3621"));
    let k0 = xs.iter().position(|&x| x == 0.0).expect("present") as i64;
    let e_ref = truth_x(0.0);
    let mut worst: f64 = 0.0;
    for (i, &x) in xs.iter().enumerate() {
        let a = fanuc_absolute(&f.values, 0, r, i as i64 - k0) as f64 * f.unit_um;
        let residual = truth_x(x) - a - e_ref;
        worst = worst.max(residual.abs());
    }
    // Only the numbers 3621..=3622 are written.
    assert_eq!(*f.values.keys().next().expect("present") as i64, first);
    assert_eq!(f.values.len() as i64, f.param("3622") - first + 1);
    worst
}

#[test]
fn fanuc_round_trip_leaves_the_reference_offset_within_half_a_unit() {
    // The raw error spans ≈ 15 µm; the table takes it to e(0) ± unit/2 at every point.
    for (du, mag, h) in [(1.0, 1, 10.0), (0.1, 1, 25.0), (1.0, 2, 20.0)] {
        let worst = fanuc_round_trip(du, mag, h);
        let half = 0.5 * du * mag as f64 + 1e-9;
        assert!(
            worst <= half,
            "unit {du}×{mag}, h {h}: residual {worst} µm > {half}"
        );
    }
}

#[test]
fn fanuc_refuses_what_the_control_cannot_hold() {
    let xs = grid(0.0, 800.0, 10.0);
    let s = measured(&xs, truth_x);
    // Too many point numbers.
    let spec = FanucSpec {
        max_point_number: 50,
        ..FanucSpec::default()
    };
    let p = limit_problem(
        fanuc::table(&s, None, &spec).expect_err("refused"),
        fanuc::LABEL,
    );
    assert!(
        p.contains("up to 80") && p.contains("beyond the control's 50"),
        "{p}"
    );
    // An increment beyond ±7 units: 0.1 µm units over 20 mm need up to ≈ 1.26 µm = 13
    // units; the message names the magnification that fits, and that one is accepted.
    let s = measured(&grid(0.0, 800.0, 20.0), truth_x);
    let fine = FanucSpec {
        detection_unit_um: 0.1,
        ..FanucSpec::default()
    };
    let p = limit_problem(
        fanuc::table(&s, None, &fine).expect_err("refused"),
        fanuc::LABEL,
    );
    let needed: u32 = p
        .split("at least ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no magnification named: {p}"));
    assert!(p.contains("beyond ±7"), "{p}");
    let ok = FanucSpec {
        magnification: needed,
        ..fine
    };
    fanuc::table(&s, None, &ok).expect("the suggested magnification fits");
    let short = FanucSpec {
        magnification: needed - 1,
        ..fine
    };
    assert!(fanuc::table(&s, None, &short).is_err(), "one less does not");
    // The reference position must be a point of the table.
    let off = FanucSpec {
        reference_mm: 5.0,
        ..FanucSpec::default()
    };
    let p = fanuc::table(&s, None, &off)
        .expect_err("refused")
        .to_string();
    assert!(
        p.contains("not one of its points")
            && p.contains("(the ends clamp|extrapolate and the reference position 5)"),
        "{p}"
    );
    let outside = FanucSpec {
        reference_mm: -50.0,
        ..FanucSpec::default()
    };
    let p = fanuc::table(&s, None, &outside).expect_err("refused");
    assert!(
        matches!(p, ExportError::ReferenceOffGrid { outside: true, .. }),
        "{p}"
    );
    // 3620 too small for the 20 points (0…380 mm every 20 mm) below the reference.
    let mid = FanucSpec {
        reference_mm: 400.0,
        reference_number: Some(10),
        ..FanucSpec::default()
    };
    let p = limit_problem(
        fanuc::table(&s, None, &mid).expect_err("refused"),
        fanuc::LABEL,
    );
    assert!(p.contains("at least 19"), "{p}");
    // One interval only: uneven points are refused.
    let mut uneven = xs.clone();
    uneven[3] += 1.0;
    assert!(matches!(
        fanuc::table(&measured(&uneven, truth_x), None, &FanucSpec::default()),
        Err(ExportError::NotEquidistant { index: 3, .. })
    ));
    // Magnification outside 1–100.
    let zero = FanucSpec {
        magnification: 0,
        ..FanucSpec::default()
    };
    assert!(
        limit_problem(
            fanuc::table(&s, None, &zero).expect_err("refused"),
            fanuc::LABEL
        )
        .contains("3623")
    );
}

#[test]
fn fanuc_bidirectional_table_keeps_the_reversal() {
    let xs = grid(-100.0, 500.0, 20.0);
    let up = measured(&xs, truth_x);
    let down = measured(&xs, truth_x_down);
    let spec = FanucSpec {
        max_value: 100,
        ..FanucSpec::default()
    };
    let text = fanuc::render(&up, Some(&down), &spec).expect("renders");
    let f = parse_fanuc(&text);
    assert_eq!(f.param("3605#0"), 1);
    let (r, first, last, neg) = (
        f.param("3620"),
        f.param("3621"),
        f.param("3622"),
        f.param("3626"),
    );
    assert_eq!(neg, last + 1, "the negative list follows the positive one");
    // 3627: the negative-travel compensation at the reference, relative to the
    // positive-travel curve (0 there): e↓(0) − e↑(0) = 3 µm.
    assert_eq!(f.param("3627"), 3);
    let k0 = 5; // −100 + 5·20 = 0
    let e_ref = truth_x(0.0);
    let offset = neg - first;
    for (i, &x) in xs.iter().enumerate() {
        let k = i as i64 - k0;
        let a_up = fanuc_absolute(&f.values, 0, r, k) as f64;
        let a_down = f.param("3627") as f64 + (fanuc_absolute(&f.values, offset, r, k) as f64);
        assert!((truth_x(x) - a_up - e_ref).abs() <= 0.5 + 1e-9, "up at {x}");
        assert!(
            (truth_x_down(x) - a_down - e_ref).abs() <= 0.5 + 1e-9,
            "down at {x}"
        );
    }
    // The two lists differ (the reversal grows by 0.002 µm/mm × 20 mm per section,
    // visible after rounding somewhere along 600 mm).
    let up_vals: Vec<i64> = (first..=last).map(|n| f.values[&(n as u32)]).collect();
    let down_vals: Vec<i64> = (neg..=neg + last - first)
        .map(|n| f.values[&(n as u32)])
        .collect();
    assert_ne!(up_vals, down_vals);
    // Overlapping numbers are refused.
    let clash = FanucSpec {
        negative_start: Some(first as u32 + 3),
        ..spec
    };
    let p = limit_problem(
        fanuc::table(&up, Some(&down), &clash).expect_err("refused"),
        fanuc::LABEL,
    );
    assert!(p.contains("overlap"), "{p}");
}

// ---------------------------------------------------------------------------------------
// HEIDENHAIN
// ---------------------------------------------------------------------------------------

/// A `.COM` table read back: (AXISPOS, value) rows, checking the frame and the numbering.
fn parse_heidenhain(text: &str, name: &str, key: &str) -> (Vec<f64>, Vec<f64>) {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], format!("BEGIN {name} MM"));
    assert_eq!(
        lines[1].split_whitespace().collect::<Vec<_>>(),
        ["NR", "AXISPOS", key]
    );
    assert_eq!(*lines.last().expect("present"), "[END]");
    let (mut xs, mut vs) = (vec![], vec![]);
    for (i, line) in lines[2..lines.len() - 1].iter().enumerate() {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f.len(), 3, "{line}");
        assert_eq!(
            f[0].parse::<usize>().expect("present"),
            i,
            "NR counts from 0"
        );
        assert!(
            f[1].starts_with(['+', '-']) && f[2].starts_with(['+', '-']),
            "{line}"
        );
        xs.push(f[1].parse::<f64>().expect("present"));
        vs.push(f[2].parse::<f64>().expect("present"));
    }
    (xs, vs)
}

#[test]
fn heidenhain_golden_text() {
    let s = measured(&[-10.0, 0.0, 10.0], |x| {
        [1.5, 0.0, -2.25][((x + 10.0) / 10.0) as usize]
    });
    let text = heidenhain::render(&s, "X", "X.COM", 256).expect("renders");
    let expected = "BEGIN X.COM MM
NR    AXISPOS           X
0     -10.0             -0.0015
1     +0.0              +0.0
2     +10.0             +0.00225
[END]
";
    assert_eq!(text, expected);
}

#[test]
fn heidenhain_round_trip_between_points_is_within_the_interpolation_bound() {
    let h = 10.0;
    let xs = grid(0.0, 800.0, h);
    let s = measured(&xs, truth_x);
    let (tx, tv) = parse_heidenhain(
        &heidenhain::render(&s, "X", "X.COM", 256).expect("renders"),
        "X.COM",
        "X",
    );
    assert_eq!(tx, xs);
    // The control interpolates c linearly; the axis is left with e + c. At the points
    // only the file's 1 nm rounding remains; between them h²/8·max|e''|.
    let bound = h * h / 8.0 * TRUTH_D2 + 0.001;
    let mut worst: f64 = 0.0;
    let mut x = 0.0;
    while x <= 800.0 {
        worst = worst.max((truth_x(x) + lerp(&tx, &tv, x) * 1e3).abs());
        x += 0.5;
    }
    let raw = (0..=1600)
        .map(|i| truth_x(i as f64 * 0.5).abs())
        .fold(0.0, f64::max);
    assert!(worst <= bound, "residual {worst} µm > {bound} µm");
    assert!(worst < raw / 100.0, "residual {worst} µm vs raw {raw} µm");
}

#[test]
fn heidenhain_refuses_what_the_control_cannot_hold() {
    let s = measured(&grid(0.0, 800.0, 2.0), truth_x); // 401 points
    match heidenhain::render(&s, "X", "X.COM", 256).expect_err("refused") {
        e @ ExportError::TooManyEntries { .. } => {
            let m = e.to_string();
            assert!(
                m.contains("HEIDENHAIN") && m.contains("256") && m.contains("401"),
                "{m}"
            );
        }
        other => panic!("{other:?}"),
    }
    let mut uneven = grid(0.0, 100.0, 10.0);
    uneven[4] += 0.5;
    assert!(matches!(
        heidenhain::render(&measured(&uneven, truth_x), "X", "X.COM", 256),
        Err(ExportError::NotEquidistant { index: 4, .. })
    ));
    let s = measured(&grid(0.0, 100.0, 10.0), truth_x);
    for (key, name) in [("X Y", "X.COM"), ("X", "../X.COM"), ("", "X.COM")] {
        let p = limit_problem(
            heidenhain::render(&s, key, name, 256).expect_err("refused"),
            heidenhain::LABEL,
        );
        assert!(p.contains("must be letters"), "{p}");
    }
    let format = ExportFormat::Heidenhain {
        axis_key: "X".into(),
        table_name: "X.COM".into(),
        max_points: 256,
    };
    assert!(matches!(
        format.render_line(&s, Some(&s)),
        Err(ExportError::ReverseUnsupported {
            format: "heidenhain",
            ..
        })
    ));
}

// ---------------------------------------------------------------------------------------
// TwinCAT CNC (ISG)
// ---------------------------------------------------------------------------------------

/// A `kw.ssfk` list read back: the scalar entries and the setpoint/pos/neg columns.
struct IsgList {
    scalars: std::collections::HashMap<String, String>,
    setpoint: Vec<i64>,
    pos: Vec<i64>,
    neg: Vec<i64>,
}

fn parse_isg(text: &str) -> IsgList {
    let mut scalars = std::collections::HashMap::new();
    let mut cols: [std::collections::BTreeMap<usize, i64>; 3] = Default::default();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let (k, v) = line.split_once(char::is_whitespace).expect("name value");
        let v = v.trim();
        if let Some(rest) = k.strip_prefix("kw.ssfk.table[") {
            let (i, field) = rest.split_once("].").expect("table[i].field");
            let i: usize = i.parse().expect("present");
            let c = ["setpoint", "pos", "neg"]
                .iter()
                .position(|f| *f == field)
                .unwrap_or_else(|| panic!("unknown field {field}"));
            assert!(cols[c].insert(i, v.parse().expect("integer")).is_none());
        } else {
            assert!(
                scalars.insert(k.to_string(), v.to_string()).is_none(),
                "{k} twice"
            );
        }
    }
    let [setpoint, pos, neg] = cols.map(|c| {
        assert!(c.keys().copied().eq(0..c.len()), "indices 0..n");
        c.into_values().collect::<Vec<_>>()
    });
    IsgList {
        scalars,
        setpoint,
        pos,
        neg,
    }
}

fn isg_axis() -> IsgAxis {
    IsgAxis {
        number: 1,
        name: "X".into(),
        max_points: 1500,
    }
}

#[test]
fn isg_golden_text() {
    let xs = vec![-20.0, -19.9306, -19.8667];
    let up = Sampled::measured(Axis::X, AT, xs.clone(), vec![0.0, -2.4, 10.2]);
    let down = Sampled::measured(Axis::X, AT, xs, vec![0.0, -6.7, -8.0]);
    let text = isg::render(&up, Some(&down), &isg_axis()).expect("renders");
    // The documentation's example rows (setpoints −200000, −199306, −198667 × 0.1 µm;
    // pos 0, 24, −102; neg 0, 67, 80) come back from the errors e = −c.
    let expected = "# errmap leadscrew error compensation (LSEC)
# line along x at (0.0, 200.0, 350.0) mm; 3 points, 0 extrapolated
# values: position error actual - setpoint = c = -e (e = indicated - reference), 0.1 um
# activate with P-AXIS-00175 lr_param.ssfk = 1; needs P-COMP-00059 kw.ssfk.max_points > 3
kopf.log_achs_nr                    1
kopf.log_achs_name                  X
kw.ssfk.interval                    0
kw.ssfk.kw_startpos                 -200000
kw.ssfk.kw_nr_max                   3
kw.ssfk.unit                        1
kw.ssfk.bilateral                   1
kw.ssfk.modulo                      0
kw.ssfk.table[0].setpoint           -200000
kw.ssfk.table[1].setpoint           -199306
kw.ssfk.table[2].setpoint           -198667
kw.ssfk.table[0].pos                0
kw.ssfk.table[1].pos                24
kw.ssfk.table[2].pos                -102
kw.ssfk.table[0].neg                0
kw.ssfk.table[1].neg                67
kw.ssfk.table[2].neg                80
";
    assert_eq!(text, expected);
}

#[test]
fn isg_round_trip_with_any_step_both_directions() {
    // A model of the truth, sampled every 7 mm over 0–798.7576 mm (the last interval
    // shorter): LSEC lists every setpoint, so no step is refused.
    let model = spline_of_truth();
    let line = LineSpec {
        axis: Axis::X,
        at_mm: AT,
        start_mm: 0.0,
        end_mm: 798.7576,
        step_mm: 7.0,
    };
    let up = sample_line_fit(&*model, &line, StepFit::LastShorter, Extrapolation::Forbid)
        .expect("samples");
    let down = measured(&up.positions_mm, truth_x_down);
    let l = parse_isg(&isg::render(&up, Some(&down), &isg_axis()).expect("renders"));
    assert_eq!(l.scalars["kw.ssfk.bilateral"], "1");
    assert_eq!(l.scalars["kw.ssfk.unit"], "1");
    assert_eq!(l.scalars["kw.ssfk.kw_nr_max"], up.len().to_string());
    assert_eq!(*l.setpoint.last().expect("present"), 7_987_576);
    let xs: Vec<f64> = l.setpoint.iter().map(|&t| t as f64 * 1e-4).collect();
    let to_um = |v: &[i64]| v.iter().map(|&t| t as f64 * 0.1).collect::<Vec<f64>>();
    let (pos, neg) = (to_um(&l.pos), to_um(&l.neg));
    // The control moves the setpoint by −Δs (Δs = actual − setpoint = −e); the axis is
    // left with Δs_true − Δs_table = −e(x) − lerp. Spline fit (< 0.02 µm here), linear
    // interpolation over ≤ 7 mm (h²/8·max|e''|) and 0.05 µm rounding.
    let bound = 0.02 + 49.0 / 8.0 * TRUTH_D2 + 0.05;
    let (mut worst_up, mut worst_down): (f64, f64) = (0.0, 0.0);
    let mut x = 0.0;
    while x <= 798.7576 {
        worst_up = worst_up.max((-truth_x(x) - lerp(&xs, &pos, x)).abs());
        worst_down = worst_down.max((-truth_x_down(x) - lerp(&xs, &neg, x)).abs());
        x += 0.37;
    }
    assert!(worst_up <= bound, "up: {worst_up} µm > {bound}");
    assert!(
        worst_down <= 0.05 + 49.0 / 8.0 * TRUTH_D2,
        "down: {worst_down} µm"
    );
    // The reversal survives: the columns differ by e↓ − e↑ = 3 + 0.002·x µm.
    let mid = xs.len() / 2;
    let reversal = pos[mid] - neg[mid];
    assert!(
        (reversal - (3.0 + 0.002 * xs[mid])).abs() < 0.15,
        "{reversal}"
    );
}

#[test]
fn isg_refuses_what_the_control_cannot_hold() {
    let xs = grid(0.0, 10.0, 1.0);
    let s = measured(&xs, truth_x);
    let small = IsgAxis {
        max_points: 11,
        ..isg_axis()
    };
    // kw_nr_max must be smaller than P-COMP-00059: 11 points need max_points ≥ 12.
    match isg::render(&s, None, &small).expect_err("refused") {
        e @ ExportError::TooManyEntries { limit: 10, .. } => {
            assert!(e.to_string().contains("P-COMP-00059"), "{e}");
        }
        other => panic!("{other:?}"),
    }
    assert!(
        isg::render(
            &s,
            None,
            &IsgAxis {
                max_points: 12,
                ..isg_axis()
            }
        )
        .is_ok()
    );
    // Positions closer than the 0.1 µm the list can write.
    let close = measured(&[0.0, 0.00001, 1.0], truth_x);
    assert!(matches!(
        isg::render(&close, None, &isg_axis()),
        Err(ExportError::NotIncreasing { index: 1, .. })
    ));
    let bad = IsgAxis {
        name: "X AXIS".into(),
        ..isg_axis()
    };
    let p = limit_problem(
        isg::render(&s, None, &bad).expect_err("refused"),
        isg::LABEL,
    );
    assert!(p.contains("axis name"), "{p}");
    // Unilateral: bilateral 0 and neg = pos.
    let l = parse_isg(&isg::render(&s, None, &isg_axis()).expect("present"));
    assert_eq!(l.scalars["kw.ssfk.bilateral"], "0");
    assert_eq!(l.pos, l.neg);
}

#[test]
fn fanuc_grid_through_the_reference_from_a_model() {
    // The export path for FANUC: a round step on the grid through the reference position
    // (here 100 mm, not a range end), the range ends clamped.
    let model = spline_of_truth();
    let line = LineSpec {
        axis: Axis::X,
        at_mm: AT,
        start_mm: 3.0,
        end_mm: 798.0,
        step_mm: 20.0,
    };
    let fit = StepFit::Grid {
        reference_mm: 100.0,
        ends: Ends::Clamp,
    };
    let s = sample_line_fit(&*model, &line, fit, Extrapolation::Forbid).expect("samples");
    assert_eq!(
        (s.positions_mm[0], *s.positions_mm.last().expect("present")),
        (0.0, 800.0)
    );
    let spec = FanucSpec {
        reference_mm: 100.0,
        max_value: 100,
        ..FanucSpec::default()
    };
    let t = fanuc::table(&s, None, &spec).expect("fits");
    // 5 points below the reference (0…80 mm) → 3620 = 4, 3621 = 0; 35 above → 3622 = 39.
    assert_eq!(
        (t.reference_number, t.negative_number, t.positive_number),
        (4, 0, 39)
    );
    assert_eq!(t.interval_mm, 20.0);
    assert!((t.reference_error_um - truth_x(100.0)).abs() < 0.02);
}

// ---------------------------------------------------------------------------------------
// `errmap export SESSION --bidirectional` in the new dialects
// ---------------------------------------------------------------------------------------

/// Runs `errmap export <case's recorded session> --bidirectional … --out <dir>/<name>`;
/// returns the exit code, stderr and the file's text.
pub(crate) fn export_session(
    case: &str,
    extra: &[&str],
    dir: &std::path::Path,
) -> (Option<i32>, String, String) {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = dir.join(format!(
        "{case}-{}.txt",
        extra.join("_").replace(['=', ','], "")
    ));
    let session = root.join(format!("datasets/concealed/{case}/recorded.parquet"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_errmap"))
        .arg("export")
        .arg(&session)
        .args(["--bidirectional", "--at", "y=1,z=200", "--out"])
        .arg(&out)
        .args(extra)
        .output()
        .expect("runs");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        std::fs::read_to_string(&out).unwrap_or_default(),
    )
}

/// The hidden reversal of the concealed `reversal` case (truth.json): e↑ − e↓ = b.
pub(crate) fn hidden_reversal_um() -> f64 {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("datasets/concealed/reversal/truth.json"))
            .expect("truth"),
    )
    .expect("json");
    truth["params"]["reversal"]["b_um"].as_f64().expect("b_um")
}

#[test]
fn bidirectional_isg_and_fanuc_tables_carry_the_reversal_of_the_session() {
    let dir = tempfile::tempdir().expect("tempdir");
    let b = hidden_reversal_um();
    for (case, b_um) in [("reversal", b), ("clean", 0.0)] {
        // ISG: bilateral, pos − neg = c↑ − c↓ = e↓ − e↑ = −b at every target (0.1 µm
        // units; tolerance: two roundings of 0.05 µm and the session's noise).
        let (code, err, text) = export_session(case, &["--format", "isg"], dir.path());
        assert_eq!(code, Some(0), "{err}");
        let l = parse_isg(&text);
        assert_eq!(l.scalars["kw.ssfk.bilateral"], "1");
        assert_eq!(l.setpoint.len(), 9, "one entry per target");
        for (i, (p, n)) in l.pos.iter().zip(&l.neg).enumerate() {
            let diff_um = (p - n) as f64 * 0.1;
            assert!(
                (diff_um + b_um).abs() <= 0.15,
                "{case}, target {i}: pos − neg = {diff_um} µm, expected {}",
                -b_um
            );
        }
        // FANUC on a 50 mm grid (the 100 mm targets' means interpolated linearly), 0.1 µm
        // detection unit: 3627 and every point of the negative-travel curve sit −b from
        // the positive one.
        let (code, err, text) = export_session(
            case,
            &[
                "--format",
                "fanuc",
                "--step",
                "50",
                "--detection-unit-um",
                "0.1",
                "--fanuc-max-value",
                "100",
            ],
            dir.path(),
        );
        assert_eq!(code, Some(0), "{err}");
        let f = parse_fanuc(&text);
        assert_eq!(f.param("3605#0"), 1);
        assert_eq!(f.interval_mm, 50.0);
        let (r, first, last, neg) = (
            f.param("3620"),
            f.param("3621"),
            f.param("3622"),
            f.param("3626"),
        );
        assert_eq!(
            (r, first, last, neg),
            (0, 0, 16, 17),
            "0…800 mm every 50 mm"
        );
        let expected_units = -b_um / 0.1;
        assert!(
            (f.param("3627") as f64 - expected_units).abs() <= 1.5,
            "{case}: 3627 = {}",
            f.param("3627")
        );
        for k in 0..=16 {
            let up = fanuc_absolute(&f.values, 0, r, k) as f64;
            let down = f.param("3627") as f64 + fanuc_absolute(&f.values, neg - first, r, k) as f64;
            assert!(
                (down - up - expected_units).abs() <= 1.5,
                "{case} at {} mm: down − up = {} units",
                k * 50,
                down - up
            );
        }
    }
    // HEIDENHAIN has no direction-dependent table here; refused, naming those that do
    // (flags that do not go together: a usage error, exit 2).
    let (code, err, _) = export_session("reversal", &["--format", "heidenhain"], dir.path());
    assert_eq!(code, Some(2));
    assert!(
        err.contains("direction-dependent") && err.contains("fanuc"),
        "{err}"
    );
    // FANUC needs the reference position on its grid: the targets alone are refused
    // when --reference is not one of them, with the way out named.
    let (code, err, _) = export_session(
        "reversal",
        &["--format", "fanuc", "--reference", "30"],
        dir.path(),
    );
    assert_eq!(code, Some(1));
    assert!(
        err.contains("(--ends clamp|extrapolate and --reference 30)"),
        "{err}"
    );
}

#[test]
fn regridding_a_measured_line_interpolates_linearly_and_flags_the_ends() {
    let s = Sampled::measured(Axis::X, AT, vec![0.0, 100.0, 200.0], vec![1.0, 3.0, -1.0]);
    let fit = StepFit::Grid {
        reference_mm: 30.0,
        ends: Ends::Extrapolate,
    };
    let g = errmap::export::regrid_measured(&s, 40.0, fit).expect("regrids");
    assert_eq!(
        g.positions_mm,
        vec![-10.0, 30.0, 70.0, 110.0, 150.0, 190.0, 230.0]
    );
    let expected = [0.8, 1.6, 2.4, 2.6, 1.0, -0.6, -2.2];
    for (v, e) in g.error_um.iter().zip(expected) {
        assert!((v - e).abs() < 1e-12, "{v} vs {e}");
    }
    assert_eq!(
        g.extrapolated,
        [true, false, false, false, false, false, true]
    );
    let clamp = StepFit::Grid {
        reference_mm: 30.0,
        ends: Ends::Clamp,
    };
    let g = errmap::export::regrid_measured(&s, 40.0, clamp).expect("regrids");
    assert_eq!((g.error_um[0], g.error_um[6]), (1.0, -1.0));
    assert!(g.extrapolated.iter().all(|&x| !x));
}

#[test]
fn fanuc_point_numbers_near_the_u32_limit_are_refused_not_overflowed() {
    let s = measured(&grid(0.0, 100.0, 10.0), truth_x);
    for spec in [
        FanucSpec {
            reference_number: Some(u32::MAX),
            max_value: 100,
            ..FanucSpec::default()
        },
        FanucSpec {
            negative_start: Some(u32::MAX),
            max_value: 100,
            max_point_number: u32::MAX,
            ..FanucSpec::default()
        },
    ] {
        let p = limit_problem(
            fanuc::table(&s, Some(&s), &spec).expect_err("refused"),
            fanuc::LABEL,
        );
        assert!(p.contains("compensation point numbers up to"), "{p}");
    }
}

/// Every dialect's settings (the command line's `--siemens-axis`, `--fanuc-*`, …) parse
/// their defaults, the defaults are FANUC's and Siemens' documented ones, and a given
/// value reaches the dialect's table.
#[test]
fn dialect_options_default_and_reach_the_table() {
    use errmap::controller::{self, OptionValue, TableSettings};
    let names: Vec<&str> = controller::dialect_options()
        .iter()
        .map(|o| o.name)
        .collect();
    for must in [
        "siemens-axis",
        "siemens-table",
        "fanuc-reference-number",
        "detection-unit-um",
        "magnification",
        "fanuc-max-value",
        "fanuc-max-point",
        "fanuc-negative-start",
    ] {
        assert!(names.contains(&must), "{must} in {names:?}");
    }
    for o in controller::dialect_options() {
        if let Some(d) = o.default {
            assert!((o.parse)(d).is_ok(), "{}'s default {d}", o.name);
        }
    }
    let s = TableSettings::new(errmap::base::Axis::Y);
    assert_eq!(
        FanucSpec::from_settings(&s),
        FanucSpec {
            axis_number: 2,
            ..FanucSpec::default()
        }
    );
    let siemens = controller::dialect("siemens").expect("registered");
    match siemens.export_format(&s, false).expect("settings suffice") {
        controller::ExportFormat::Siemens { axis_name, .. } => assert_eq!(axis_name, "X1"),
        other => panic!("{other:?}"),
    }
    let mut given = TableSettings::new(errmap::base::Axis::X);
    given
        .options
        .set("fanuc-max-value", OptionValue::Number(32767));
    given.options.set("siemens-table", OptionValue::Count(4));
    assert_eq!(FanucSpec::from_settings(&given).max_value, 32767);
    match siemens
        .export_format(&given, true)
        .expect("settings suffice")
    {
        controller::ExportFormat::SiemensCec { first_table, .. } => assert_eq!(first_table, 4),
        other => panic!("{other:?}"),
    }
    let bad = controller::dialect_options()
        .into_iter()
        .find(|o| o.name == "siemens-axis")
        .expect("declared");
    assert!(
        (bad.parse)("1X").is_err(),
        "a Siemens axis starts with a letter"
    );
}
