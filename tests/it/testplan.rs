//! `errmap plan`: ISO 230-2 test plans, their TOML read back by the simulator, and the
//! part programs in each dialect — golden texts, and programs read back by a small
//! G-code reader (and by LinuxCNC's own `rs274` when it is installed) that must visit the
//! plan's targets in the standard test cycle.

use crate::util::{errmap_in, root};
use std::path::{Path, PathBuf};
use std::process::Command;

use errmap::base::Axis;
use errmap::controller::program::{self, ProgramError, ProgramOptions, ProgramSyntax};
use errmap::sim::PlanSpec;

/// The part-program dialect named `name`.
fn d(name: &str) -> &'static dyn ProgramSyntax {
    program::dialect(name).expect("a dialect of the registry")
}
use errmap::sim::{PlanField, Spacing, TestPlan, TestPlanConfig};

/// The outside check's plan: `--axis x --from 0 --to 800 --targets 21 --runs 5
/// --overrun 5 --dwell-s 2 --feed-mm-s 25 --at y=1,z=200 --random-offset 0.1 --seed 7`.
fn outside_check() -> TestPlanConfig {
    TestPlanConfig {
        axis: Axis::X,
        from_mm: 0.0,
        to_mm: 800.0,
        spacing: Spacing::Targets(21),
        runs: 5,
        overrun_mm: 5.0,
        dwell_s: 2.0,
        feed_mm_s: 25.0,
        line_mm: [1.0, 200.0],
        random_offset: 0.1,
        seed: 7,
    }
}

/// 3 targets 0, 50, 100 mm (no offsets), 1 run, for the golden texts.
fn small() -> TestPlan {
    TestPlan::generate(TestPlanConfig {
        to_mm: 100.0,
        spacing: Spacing::Targets(3),
        runs: 1,
        overrun_mm: 2.0,
        dwell_s: 1.5,
        feed_mm_s: 10.0,
        random_offset: 0.0,
        seed: 1,
        ..outside_check()
    })
    .expect("valid plan")
}

#[test]
fn targets_are_spread_with_bounded_seeded_offsets_and_exact_ends() {
    let plan = TestPlan::generate(outside_check()).expect("valid");
    let t = &plan.targets_mm;
    assert_eq!(t.len(), 21);
    assert_eq!(plan.interval_mm, 40.0);
    assert_eq!((t[0], t[20]), (0.0, 800.0));
    let mut largest = 0.0f64;
    for (i, &x) in t.iter().enumerate() {
        let offset = x - 40.0 * i as f64;
        // ±f·p = ±4 mm, plus the 0.5 µm of rounding.
        assert!(offset.abs() <= 4.0 + 5e-4, "target {i} at {x} mm");
        assert!(
            ((x * 1000.0).round() - x * 1000.0).abs() < 1e-6,
            "{x} not whole µm"
        );
        largest = largest.max(offset.abs());
    }
    assert!(t.windows(2).all(|w| w[1] > w[0]));
    // The offsets are used (19 uniform draws in ±4 mm: the largest is above 2 mm).
    assert!(largest > 2.0, "largest offset {largest} mm");
    // Reproducible, and the seed matters.
    assert_eq!(TestPlan::generate(outside_check()).expect("valid"), plan);
    let other = TestPlan::generate(TestPlanConfig {
        seed: 8,
        ..outside_check()
    })
    .expect("valid");
    assert_ne!(other.targets_mm, plan.targets_mm);
    // No offset: the nominal grid exactly.
    let even = TestPlan::generate(TestPlanConfig {
        random_offset: 0.0,
        ..outside_check()
    })
    .expect("valid");
    let nominal: Vec<f64> = (0..21).map(|i| 40.0 * f64::from(i)).collect();
    assert_eq!(even.targets_mm, nominal);
}

#[test]
fn an_interval_splits_the_range_into_equal_intervals_no_longer_than_it() {
    let plan = TestPlan::generate(TestPlanConfig {
        spacing: Spacing::Interval(30.0),
        random_offset: 0.0,
        ..outside_check()
    })
    .expect("valid");
    // 800 / 30 = 26.7 → 27 intervals of 29.630 mm, 28 targets.
    assert_eq!(plan.targets_mm.len(), 28);
    assert!((plan.interval_mm - 800.0 / 27.0).abs() < 1e-12);
    assert_eq!(plan.targets_mm[27], 800.0);
    assert_eq!(plan.targets_mm[1], 29.63);
    // An interval that divides the range gives exactly that interval.
    let plan = TestPlan::generate(TestPlanConfig {
        spacing: Spacing::Interval(40.0),
        ..outside_check()
    })
    .expect("valid");
    assert_eq!(plan.targets_mm.len(), 21);
}

#[test]
fn bad_inputs_are_refused_naming_the_field() {
    let cases: Vec<(PlanField, TestPlanConfig)> = vec![
        (
            PlanField::ToMm,
            TestPlanConfig {
                to_mm: 0.0,
                ..outside_check()
            },
        ),
        (
            PlanField::FromMm,
            TestPlanConfig {
                from_mm: f64::NAN,
                ..outside_check()
            },
        ),
        (
            PlanField::Targets,
            TestPlanConfig {
                spacing: Spacing::Targets(1),
                ..outside_check()
            },
        ),
        (
            PlanField::Interval,
            TestPlanConfig {
                spacing: Spacing::Interval(-3.0),
                ..outside_check()
            },
        ),
        (
            PlanField::RandomOffset,
            TestPlanConfig {
                random_offset: 0.5,
                ..outside_check()
            },
        ),
        (
            PlanField::RandomOffset,
            TestPlanConfig {
                random_offset: -0.1,
                ..outside_check()
            },
        ),
        (
            PlanField::FeedMmS,
            TestPlanConfig {
                feed_mm_s: f64::INFINITY,
                ..outside_check()
            },
        ),
        (
            PlanField::DwellS,
            TestPlanConfig {
                dwell_s: 0.0,
                ..outside_check()
            },
        ),
        (
            PlanField::OverrunMm,
            TestPlanConfig {
                overrun_mm: -1.0,
                ..outside_check()
            },
        ),
        (
            PlanField::Runs,
            TestPlanConfig {
                runs: 0,
                ..outside_check()
            },
        ),
        (
            PlanField::LineMm,
            TestPlanConfig {
                line_mm: [f64::NAN, 0.0],
                ..outside_check()
            },
        ),
    ];
    for (field, config) in cases {
        let e = TestPlan::generate(config.clone()).expect_err(field.name());
        assert_eq!(e.field, field, "{config:?}: {e}");
        assert!(e.to_string().starts_with(field.name()), "{e}");
    }
    // The library's words name the fields; the command line names its flags instead.
    let e = TestPlan::generate(TestPlanConfig {
        to_mm: 0.0,
        ..outside_check()
    })
    .expect_err("empty range");
    assert_eq!(
        e.to_string(),
        "to_mm: the range 0 … 0 mm is empty: from_mm must be less than to_mm"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let o = errmap_in(
        dir.path(),
        &[
            "plan",
            "--axis",
            "x",
            "--from",
            "5",
            "--to",
            "1",
            "--targets",
            "3",
            "--out",
            "p.toml",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("--to: the range 5 … 1 mm is empty: --from must be less than --to"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn the_plan_toml_reads_back_and_the_simulated_session_stops_at_its_targets() {
    let dir = tempfile::tempdir().expect("tempdir");
    let plan = TestPlan::generate(TestPlanConfig {
        spacing: Spacing::Targets(6),
        runs: 2,
        feed_mm_s: 400.0,
        dwell_s: 0.2,
        ..outside_check()
    })
    .expect("valid");
    let path = dir.path().join("plan.toml");
    std::fs::write(&path, plan.toml()).expect("write");
    let spec = PlanSpec::read(&path).expect("PlanSpec reads the generated plan");
    assert_eq!(spec.targets_mm, plan.targets_mm, "targets exactly");
    assert_eq!(spec.lines_mm, vec![[1.0, 200.0]]);
    assert_eq!((spec.runs, spec.dwell_s, spec.feed_mm_s), (2, 0.2, 400.0));
    assert_eq!(spec.overrun_mm, 5.0);
    let sim_plan = spec.plan(&path).expect("plan");

    let model = errmap::sim::concealed_nominal(&root().join("datasets/table1.csv"), 1);
    let rows = errmap::sim::simulate_session(
        &model,
        &root().join("datasets/model.toml"),
        &sim_plan,
        false,
    )
    .expect("simulates");
    // Every (run, direction, target) has dwell rows, at the plan's target (the scale
    // reading, 0.1 µm counts), in the cycle's order.
    let mut visits: Vec<(u32, i8, i32)> = Vec::new();
    for r in rows.iter().filter(|r| r.target >= 0) {
        let t = plan.targets_mm[r.target as usize];
        assert!(
            (r.scale_mm - t).abs() < 1e-3,
            "run {} dir {} target {}: scale {} mm vs {t} mm",
            r.run,
            r.direction,
            r.target,
            r.scale_mm
        );
        assert!((r.y_mm.unwrap_or(f64::NAN) - 1.0).abs() < 1e-3);
        assert!((r.z_mm.unwrap_or(f64::NAN) - 200.0).abs() < 1e-3);
        let key = (r.run, r.direction, r.target);
        if visits.last() != Some(&key) {
            visits.push(key);
        }
    }
    let mut expected = Vec::new();
    for run in 1..=2 {
        expected.extend((0..6).map(|i| (run, 1, i)));
        expected.extend((0..6).rev().map(|i| (run, -1, i)));
    }
    assert_eq!(visits, expected);
}

#[test]
fn plan_files_with_a_bad_overrun_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("plan.toml");
    std::fs::write(
        &path,
        "axis = \"X\"\nlines_mm = [[0.0, 0.0]]\ntargets_mm = [0.0, 10.0]\noverrun_mm = -2.0\n",
    )
    .expect("write");
    let e = PlanSpec::read(&path)
        .expect("parses")
        .plan(&path)
        .expect_err("negative overrun");
    let m = e.to_string();
    assert!(m.contains("plan.toml") && m.contains("overrun_mm"), "{m}");
}

// ---- golden texts ---------------------------------------------------------------------

const GOLDEN_LINUXCNC: &str = "\
(errmap ISO 230-2 standard test cycle along X, linuxcnc dialect)
(3 targets 0.000 to 100.000 mm, 1 run up and down, dwell 1.500 s)
(line Y1.000 Z200.000; feed 600 mm/min; seed 1)
(CHECK the travel -2.000 to 102.000 mm overrun 2.000 mm and a clear path to the start point)
(digital output 2 is on while the axis dwells at a target)
G21 G90 G94 G61
G1 X-2.000 Y1.000 Z200.000 F600
(run 1 of 1)
G1 X0.000
M64 P2
G4 P1.500
M65 P2
G1 X50.000
M64 P2
G4 P1.500
M65 P2
G1 X100.000
M64 P2
G4 P1.500
M65 P2
(overrun above the last target, reversal)
G1 X102.000
G1 X100.000
M64 P2
G4 P1.500
M65 P2
G1 X50.000
M64 P2
G4 P1.500
M65 P2
G1 X0.000
M64 P2
G4 P1.500
M65 P2
(overrun below the first target, reversal)
G1 X-2.000
M2
";

const GOLDEN_FANUC: &str = "\
%
O0230 (ERRMAP ISO 230-2)
(ERRMAP ISO 230-2 STANDARD TEST CYCLE ALONG X, FANUC DIALECT)
(3 TARGETS 0.000 TO 100.000 MM, 1 RUN UP AND DOWN, DWELL 1.500 S)
(LINE Y1.000 Z200.000 FEED 600 MM/MIN SEED 1)
(CHECK THE TRAVEL -2.000 TO 102.000 MM OVERRUN 2.000 MM AND A CLEAR PATH TO THE START POINT)
G21 G90 G94
G01 X-2.000 Y1.000 Z200.000 F600
(RUN 1 OF 1)
G01 X0.000
G04 P1500
G01 X50.000
G04 P1500
G01 X100.000
G04 P1500
(OVERRUN ABOVE THE LAST TARGET, REVERSAL)
G01 X102.000
G01 X100.000
G04 P1500
G01 X50.000
G04 P1500
G01 X0.000
G04 P1500
(OVERRUN BELOW THE FIRST TARGET, REVERSAL)
G01 X-2.000
M30
%
";

const GOLDEN_SIEMENS: &str = "\
; errmap ISO 230-2 standard test cycle along X, siemens dialect
; 3 targets 0.000 to 100.000 mm, 1 run up and down, dwell 1.500 s
; line Y1.000 Z200.000; feed 600 mm/min; seed 1
; CHECK the travel -2.000 to 102.000 mm (overrun 2.000 mm) and a clear path to the start point
G71 G90 G94 G60
G1 X-2.000 Y1.000 Z200.000 F600
; run 1 of 1
G1 X0.000
G4 F1.500
G1 X50.000
G4 F1.500
G1 X100.000
G4 F1.500
; overrun above the last target, reversal
G1 X102.000
G1 X100.000
G4 F1.500
G1 X50.000
G4 F1.500
G1 X0.000
G4 F1.500
; overrun below the first target, reversal
G1 X-2.000
M30
";

const GOLDEN_HEIDENHAIN: &str = "\
0 BEGIN PGM ERRMAP_ISO230 MM
1 ; errmap ISO 230-2 standard test cycle along X, heidenhain dialect
2 ; 3 targets 0.000 to 100.000 mm, 1 run up and down, dwell 1.500 s
3 ; line Y1.000 Z200.000; feed 600 mm/min; seed 1
4 ; CHECK the travel -2.000 to 102.000 mm (overrun 2.000 mm) and a clear path to the start point
5 L X-2.000 Y+1.000 Z+200.000 R0 F600
6 ; run 1 of 1
7 L X+0.000 R0
8 CYCL DEF 9.0 DWELL TIME
9 CYCL DEF 9.1 DWELL 1.500
10 L X+50.000 R0
11 CYCL DEF 9.0 DWELL TIME
12 CYCL DEF 9.1 DWELL 1.500
13 L X+100.000 R0
14 CYCL DEF 9.0 DWELL TIME
15 CYCL DEF 9.1 DWELL 1.500
16 ; overrun above the last target, reversal
17 L X+102.000 R0
18 L X+100.000 R0
19 CYCL DEF 9.0 DWELL TIME
20 CYCL DEF 9.1 DWELL 1.500
21 L X+50.000 R0
22 CYCL DEF 9.0 DWELL TIME
23 CYCL DEF 9.1 DWELL 1.500
24 L X+0.000 R0
25 CYCL DEF 9.0 DWELL TIME
26 CYCL DEF 9.1 DWELL 1.500
27 ; overrun below the first target, reversal
28 L X-2.000 R0
29 M30
30 END PGM ERRMAP_ISO230 MM
";

#[test]
fn golden_programs_in_each_dialect() {
    let plan = small();
    let marks = ProgramOptions {
        mark_output: Some(2),
    };
    let none = ProgramOptions::default();
    let cases = [
        (d("linuxcnc"), &marks, GOLDEN_LINUXCNC),
        (d("fanuc"), &none, GOLDEN_FANUC),
        (d("siemens"), &none, GOLDEN_SIEMENS),
        (d("heidenhain"), &none, GOLDEN_HEIDENHAIN),
    ];
    for (dialect, options, golden) in cases {
        let text = program::render(&plan, dialect, options).expect("renders");
        assert_eq!(text, golden, "{dialect}");
    }
}

#[test]
fn dialect_limits_are_refused_with_the_flag() {
    let plan = small();
    let marks = ProgramOptions {
        mark_output: Some(0),
    };
    for d in [d("fanuc"), d("siemens"), d("heidenhain")] {
        let e = program::render(&plan, d, &marks).expect_err("no marks");
        assert_eq!(e, ProgramError::MarkOutputUnsupported { dialect: d.name() });
        // The library names its setting in its own words; the command line says the flag
        // (`a_refused_program_setting_is_named_by_its_flag`).
        assert!(e.to_string().starts_with("the mark output: "), "{e}");
    }
    let e = program::render(
        &plan,
        d("linuxcnc"),
        &ProgramOptions {
            mark_output: Some(64),
        },
    )
    .expect_err("64 outputs at most");
    assert!(
        matches!(
            e,
            ProgramError::MarkOutputRange {
                index: 64,
                max: 63,
                ..
            }
        ),
        "{e}"
    );
    let long = TestPlan::generate(TestPlanConfig {
        dwell_s: 3600.5,
        ..small().config
    })
    .expect("valid");
    let e = program::render(&long, d("heidenhain"), &ProgramOptions::default())
        .expect_err("cycle 9 stops at 3600 s");
    assert!(
        e.to_string().starts_with("the dwell: 3600.5 s is beyond"),
        "{e}"
    );
    assert!(program::render(&long, d("fanuc"), &ProgramOptions::default()).is_ok());
    let short = TestPlan::generate(TestPlanConfig {
        dwell_s: 0.0004,
        ..small().config
    })
    .expect("valid");
    let e = program::render(&short, d("fanuc"), &ProgramOptions::default())
        .expect_err("G04 P counts ms");
    assert!(matches!(e, ProgramError::DwellTooShort { .. }), "{e}");
    let far = TestPlan::generate(TestPlanConfig {
        line_mm: [1.0, 123_456.0],
        ..small().config
    })
    .expect("valid");
    let e = program::render(&far, d("siemens"), &ProgramOptions::default()).expect_err("8 digits");
    assert!(matches!(e, ProgramError::CoordinateTooLarge { .. }), "{e}");
}

/// The program's refusals of a mark output or a dwell reach the user naming the flag
/// (`cli/flags.rs` says the library's `ControllerSetting` as `--mark-output`, `--dwell-s`).
#[test]
fn a_refused_program_setting_is_named_by_its_flag() {
    let dir = tempfile::tempdir().expect("tempdir");
    let plan = |extra: &[&str]| {
        let base = "plan --axis x --from 0 --to 100 --targets 5 --out p.toml --program p.txt";
        let mut args: Vec<&str> = base.split(' ').collect();
        args.extend_from_slice(extra);
        let o = errmap_in(dir.path(), &args);
        assert_eq!(o.status.code(), Some(1), "{extra:?}");
        assert!(
            !dir.path().join("p.txt").exists(),
            "{extra:?}: nothing written"
        );
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = plan(&["--dialect", "fanuc", "--mark-output", "0"]);
    assert!(
        e.contains("errmap: error: --mark-output: the fanuc program has no digital-output MARKs"),
        "{e}"
    );
    let e = plan(&["--dialect", "heidenhain", "--dwell-s", "3600.5"]);
    assert!(
        e.contains(
            "errmap: error: --dwell-s: 3600.5 s is beyond the heidenhain dwell limit of 3600 s"
        ),
        "{e}"
    );
}

// ---- reading the programs back --------------------------------------------------------

/// What a program does, as far as the test cycle is concerned.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    /// A feed move to this point (mm), at this feed (mm/min).
    Feed([f64; 3], f64),
    /// A dwell (s), and whether the MARK output was on during it.
    Dwell(f64, bool),
}

/// A word `letter` + number from a block, if present.
fn word(block: &[(char, f64)], letter: char) -> Option<f64> {
    block.iter().find(|(l, _)| *l == letter).map(|(_, v)| *v)
}

/// Splits `G1 X1.5 F600` into letter/number words (comments removed); panics on
/// anything else, so an unexpected word fails the test.
fn words(line: &str, comment_open: char, comment_close: Option<char>) -> Vec<(char, f64)> {
    let mut text = String::new();
    let mut in_comment = false;
    for c in line.chars() {
        match comment_close {
            Some(close) => {
                if c == comment_open {
                    in_comment = true;
                } else if c == close {
                    in_comment = false;
                } else if !in_comment {
                    text.push(c);
                }
            }
            None => {
                if c == comment_open {
                    break;
                }
                text.push(c);
            }
        }
    }
    let text: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(letter) = chars.next() {
        assert!(
            letter.is_ascii_alphabetic(),
            "`{line}`: unexpected {letter}"
        );
        let mut num = String::new();
        while let Some(&c) = chars.peek() {
            if c.is_ascii_digit() || c == '.' || c == '-' || c == '+' {
                num.push(c);
                chars.next();
            } else {
                break;
            }
        }
        let v: f64 = num
            .parse()
            .unwrap_or_else(|_| panic!("`{line}`: `{letter}{num}` is not a word"));
        out.push((letter.to_ascii_uppercase(), v));
    }
    out
}

/// Runs a LinuxCNC program through a reader of the words errmap emits: G21 G90 G94 G61
/// (required before any move), G1 X Y Z F, G4 P, M64/M65 P, M2.
fn read_linuxcnc(text: &str, mark: u32) -> Vec<Event> {
    let mut pos = [f64::NAN; 3];
    let (mut feed, mut modes_set, mut out_on, mut ended) = (f64::NAN, false, false, false);
    let mut events = Vec::new();
    for line in text.lines() {
        let block = words(line, '(', Some(')'));
        if block.is_empty() {
            continue;
        }
        assert!(!ended, "block after M2: {line}");
        let gs: Vec<f64> = block
            .iter()
            .filter(|(l, _)| *l == 'G')
            .map(|(_, v)| *v)
            .collect();
        match (gs.as_slice(), word(&block, 'M')) {
            ([21.0, 90.0, 94.0, 61.0], None) => modes_set = true,
            ([1.0], None) => {
                assert!(modes_set, "move before G21 G90 G94 G61");
                for (i, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                    if let Some(v) = word(&block, l) {
                        pos[i] = v;
                    }
                }
                if let Some(f) = word(&block, 'F') {
                    feed = f;
                }
                assert!(pos.iter().all(|v| v.is_finite()) && feed > 0.0, "{line}");
                events.push(Event::Feed(pos, feed));
            }
            ([4.0], None) => events.push(Event::Dwell(word(&block, 'P').expect("G4 P"), out_on)),
            ([], Some(64.0)) => {
                assert_eq!(word(&block, 'P'), Some(f64::from(mark)));
                out_on = true;
            }
            ([], Some(65.0)) => {
                assert_eq!(word(&block, 'P'), Some(f64::from(mark)));
                out_on = false;
            }
            ([], Some(2.0)) => ended = true,
            _ => panic!("unexpected block `{line}`"),
        }
    }
    assert!(ended, "no M2");
    events
}

/// The tested-axis moves and dwells of any dialect, read with its own syntax.
fn read_axis_events(text: &str, dialect: &dyn ProgramSyntax) -> Vec<(char, f64)> {
    let mut out = Vec::new();
    for line in text.lines() {
        let body = match dialect.name() {
            "heidenhain" => line.split_once(' ').map_or("", |(_, b)| b),
            _ => line,
        };
        if body.starts_with(';') || body.starts_with('(') || body.starts_with('%') {
            continue;
        }
        match dialect.name() {
            "heidenhain" => {
                if let Some(rest) = body.strip_prefix("L X") {
                    let x = rest.split_whitespace().next().expect("X value");
                    out.push(('M', x.parse().expect("number")));
                } else if let Some(t) = body.strip_prefix("CYCL DEF 9.1 DWELL ") {
                    out.push(('D', t.parse().expect("seconds")));
                }
            }
            _ => {
                let b = words(
                    body,
                    if dialect.name() == "siemens" {
                        ';'
                    } else {
                        '('
                    },
                    (dialect.name() != "siemens").then_some(')'),
                );
                let g = word(&b, 'G');
                match (dialect.name(), g) {
                    (_, Some(1.0)) => out.push(('M', word(&b, 'X').expect("X"))),
                    ("fanuc", Some(4.0)) => {
                        out.push(('D', word(&b, 'P').expect("P ms") / 1000.0));
                    }
                    ("siemens", Some(4.0)) => out.push(('D', word(&b, 'F').expect("F s"))),
                    ("linuxcnc", Some(4.0)) => out.push(('D', word(&b, 'P').expect("P s"))),
                    _ => {}
                }
            }
        }
    }
    out
}

/// The standard test cycle written out from the targets alone (not from `cycle()`).
fn expected_axis_events(plan: &TestPlan) -> Vec<(char, f64)> {
    let c = &plan.config;
    let t = &plan.targets_mm;
    let below = ((t[0] - c.overrun_mm) * 1000.0).round() / 1000.0;
    let above = ((t[t.len() - 1] + c.overrun_mm) * 1000.0).round() / 1000.0;
    let mut e = vec![('M', below)];
    for _ in 0..c.runs {
        for &x in t {
            e.push(('M', x));
            e.push(('D', c.dwell_s));
        }
        e.push(('M', above));
        for &x in t.iter().rev() {
            e.push(('M', x));
            e.push(('D', c.dwell_s));
        }
        e.push(('M', below));
    }
    e
}

#[test]
fn the_linuxcnc_program_runs_the_iso_cycle_through_the_plans_targets() {
    let plan = TestPlan::generate(outside_check()).expect("valid");
    let text = program::render(
        &plan,
        d("linuxcnc"),
        &ProgramOptions {
            mark_output: Some(0),
        },
    )
    .expect("renders");
    let events = read_linuxcnc(&text, 0);
    let t = &plan.targets_mm;
    // Start: all three axes to P_1 − o on the line, at 25 mm/s = 1500 mm/min.
    assert_eq!(events[0], Event::Feed([-5.0, 1.0, 200.0], 1500.0));
    let mut x = -5.0;
    let mut k = 1;
    let mut next = |events: &[Event]| {
        let e = events[k].clone();
        k += 1;
        e
    };
    for run in 1..=5 {
        // Up: every target approached from below, then the dwell with the output on.
        for (i, &target) in t.iter().enumerate() {
            let Event::Feed(p, f) = next(&events) else {
                panic!("run {run} up target {i}: expected a move");
            };
            assert_eq!((p, f), ([target, 1.0, 200.0], 1500.0));
            assert!(p[0] > x, "run {run} target {i} approached from below");
            x = p[0];
            assert_eq!(next(&events), Event::Dwell(2.0, true));
        }
        // Past the last by the overrun, then down from above.
        assert_eq!(next(&events), Event::Feed([805.0, 1.0, 200.0], 1500.0));
        x = 805.0;
        for (i, &target) in t.iter().enumerate().rev() {
            let Event::Feed(p, _) = next(&events) else {
                panic!("run {run} down target {i}: expected a move");
            };
            assert_eq!(p[0], target);
            assert!(p[0] < x, "run {run} target {i} approached from above");
            x = p[0];
            assert_eq!(next(&events), Event::Dwell(2.0, true));
        }
        // Below the first by the overrun, so the next run approaches it from below.
        assert_eq!(next(&events), Event::Feed([-5.0, 1.0, 200.0], 1500.0));
        x = -5.0;
    }
    assert_eq!(k, events.len(), "nothing after the 5th run");
    // 21 targets × 2 directions × 5 runs dwells, all with the MARK output on.
    let dwells = events
        .iter()
        .filter(|e| matches!(e, Event::Dwell(2.0, true)))
        .count();
    assert_eq!(dwells, 210);
}

#[test]
fn every_dialect_moves_through_the_same_cycle() {
    let plan = TestPlan::generate(TestPlanConfig {
        spacing: Spacing::Targets(7),
        runs: 2,
        ..outside_check()
    })
    .expect("valid");
    let expected = expected_axis_events(&plan);
    for d in program::dialects() {
        let text = program::render(&plan, d, &ProgramOptions::default()).expect("renders");
        assert_eq!(read_axis_events(&text, d), expected, "{d}");
    }
}

/// Runs LinuxCNC's standalone interpreter when it is installed (Debian:
/// `apt-get install linuxcnc-uspace`, then `rs274 -t tool.tbl -v rs274ngc.var -g plan.ngc`),
/// and checks its canonical moves and dwells against the cycle.
#[test]
fn linuxcncs_own_interpreter_agrees_when_installed() {
    let Some(rs274) = which("rs274") else {
        eprintln!(
            "SKIP linuxcncs_own_interpreter_agrees_when_installed: rs274 (Debian package \
             linuxcnc-uspace) is not installed"
        );
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let plan = TestPlan::generate(TestPlanConfig {
        spacing: Spacing::Targets(5),
        runs: 2,
        ..outside_check()
    })
    .expect("valid");
    let text = program::render(&plan, d("linuxcnc"), &ProgramOptions::default()).expect("renders");
    std::fs::write(dir.path().join("plan.ngc"), text).expect("write");
    std::fs::write(dir.path().join("tool.tbl"), "T1 P1 D0 Z0 ;\n").expect("write");
    std::fs::write(dir.path().join("rs274ngc.var"), "").expect("write");
    let out = Command::new(rs274)
        .current_dir(dir.path())
        .args(["-t", "tool.tbl", "-v", "rs274ngc.var", "-g", "plan.ngc"])
        .stdin(std::process::Stdio::null())
        .output()
        .expect("runs rs274");
    let canon = String::from_utf8_lossy(&out.stdout);
    let mut events = Vec::new();
    for line in canon.lines() {
        let args = |name: &str| -> Option<Vec<f64>> {
            let start = line.find(name)? + name.len();
            let end = line[start..].find(')')? + start;
            Some(
                line[start..end]
                    .split(',')
                    .filter_map(|v| v.trim().parse().ok())
                    .collect(),
            )
        };
        if let Some(a) = args("STRAIGHT_FEED(") {
            events.push(('M', a[0]));
        } else if let Some(a) = args("DWELL(") {
            events.push(('D', a[0]));
        }
    }
    let expected = expected_axis_events(&plan);
    assert_eq!(events.len(), expected.len(), "rs274 output:\n{canon}");
    for (k, (got, want)) in events.iter().zip(&expected).enumerate() {
        assert!(
            got.0 == want.0 && (got.1 - want.1).abs() < 1e-3,
            "event {k}: {got:?} vs {want:?}"
        );
    }
}

fn which(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?
        .to_str()?
        .split(':')
        .map(|d| Path::new(d).join(program))
        .find(|p| p.is_file())
}

// ---- the command ----------------------------------------------------------------------

#[test]
fn errmap_plan_as_the_outside_checks_call_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let o = errmap_in(
        dir.path(),
        &[
            "plan",
            "--axis",
            "x",
            "--from",
            "0",
            "--to",
            "800",
            "--targets",
            "21",
            "--runs",
            "5",
            "--overrun",
            "5",
            "--dwell-s",
            "2",
            "--feed-mm-s",
            "25",
            "--at",
            "y=1,z=200",
            "--random-offset",
            "0.1",
            "--seed",
            "7",
            "--out",
            "plan.toml",
            "--program",
            "plan.ngc",
            "--dialect",
            "linuxcnc",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let spec = PlanSpec::read(&dir.path().join("plan.toml")).expect("reads");
    let plan = TestPlan::generate(outside_check()).expect("valid");
    assert_eq!(spec.targets_mm, plan.targets_mm);
    let ngc = std::fs::read_to_string(dir.path().join("plan.ngc")).expect("program");
    let lib = program::render(&plan, d("linuxcnc"), &ProgramOptions::default()).expect("ok");
    assert_eq!(ngc, lib);

    // --interval instead of --targets, a negative --from, another dialect.
    let o = errmap_in(
        dir.path(),
        &[
            "plan",
            "--axis",
            "y",
            "--from",
            "-20",
            "--to",
            "380",
            "--interval",
            "50",
            "--at",
            "x=10,z=5",
            "--out",
            "y.toml",
            "--program",
            "y.h",
            "--dialect",
            "heidenhain",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let spec = PlanSpec::read(&dir.path().join("y.toml")).expect("reads");
    assert_eq!(spec.targets_mm.len(), 9);
    assert_eq!((spec.targets_mm[0], spec.targets_mm[8]), (-20.0, 380.0));
    assert_eq!(spec.lines_mm, vec![[10.0, 5.0]]);

    // A bad value exits 1 naming the flag.
    let o = errmap_in(
        dir.path(),
        &[
            "plan",
            "--axis",
            "x",
            "--from",
            "0",
            "--to",
            "800",
            "--targets",
            "21",
            "--random-offset",
            "0.6",
            "--out",
            "bad.toml",
        ],
    );
    // A bad flag value is a usage error (issue 17).
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--random-offset"));
    assert!(!dir.path().join("bad.toml").exists());
}
