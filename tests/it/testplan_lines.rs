//! `errmap volumetric program`: a volumetric plan's lines as a part program in each
//! dialect, read back by a small reader that must find every target of the plan visited
//! in order, with its dwell, and a programmed stop before each line.

use crate::util::root;

use errmap::controller::program::{self, ProgramError, ProgramSyntax};

/// The part-program dialect named `name`.
fn d(name: &str) -> &'static dyn ProgramSyntax {
    program::dialect(name).expect("a dialect of the registry")
}

/// A lines program read back: the position at every dwell, the position at every
/// programmed stop, the dwell times (s). ISO dialects: modal `G1/G01 X Y Z`, `G4 P s` /
/// `G04 P ms` / `G4 F s`, `M0`/`M00`; HEIDENHAIN: numbered blocks, `L X± Y± Z± R0`,
/// `CYCL DEF 9.1 DWELL s`, `STOP`.
fn read_lines_program(
    text: &str,
    dialect: &dyn ProgramSyntax,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<f64>) {
    let mut at = [f64::NAN; 3];
    let (mut dwells, mut stops, mut times) = (vec![], vec![], vec![]);
    for (i, raw) in text.lines().enumerate() {
        let line = if dialect.name() == "heidenhain" {
            let (n, rest) = raw.split_once(' ').expect("numbered block");
            assert_eq!(n.parse::<usize>().expect("block number"), i);
            rest
        } else {
            raw
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("G1" | "G01" | "L") => {
                for w in &words[1..] {
                    let k = match &w[..1] {
                        "X" => 0,
                        "Y" => 1,
                        "Z" => 2,
                        _ => continue,
                    };
                    at[k] = w[1..].parse().expect("coordinate");
                }
            }
            Some("G4" | "G04") => {
                let v: f64 = words[1][1..].parse().expect("dwell");
                times.push(if words[0] == "G04" { v / 1000.0 } else { v });
                dwells.push(at);
            }
            Some("CYCL") if words.get(2) == Some(&"9.1") => {
                times.push(words[4].parse().expect("dwell"));
                dwells.push(at);
            }
            Some("M0" | "M00" | "STOP") => stops.push(at),
            _ => {}
        }
    }
    (dwells, stops, times)
}

#[test]
fn volumetric_plan_program_visits_every_line_target_in_order() {
    use errmap::controller::program::render_lines;
    use errmap::sim::LinesProgram;
    use errmap::volumetric::PlanFile;
    let path = root().join("datasets/volumetric/plan.toml");
    let plan = PlanFile::read(&path).expect("the dataset's plan");
    let program = plan.lines_program("plan.toml");
    // The plan file's own extra line, computed here from its TOML: 17 targets from
    // (0, 300, 200) to (800, 300, 200), the plan's 2 runs.
    let extra = program.lines.last().expect("lines");
    assert_eq!((extra.name.as_str(), extra.runs), ("extra-X", 2));
    let by_hand: Vec<[f64; 3]> = (0..17).map(|i| [50.0 * i as f64, 300.0, 200.0]).collect();
    assert_eq!(extra.targets_mm.len(), 17);
    for (p, q) in extra.targets_mm.iter().zip(&by_hand) {
        assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-9), "{p:?} vs {q:?}");
    }
    let expected: Vec<[f64; 3]> = program
        .lines
        .iter()
        .flat_map(|l| (0..l.runs).flat_map(move |_| l.targets_mm.iter().copied()))
        .collect();
    for dialect in program::dialects() {
        let text = render_lines(&program, dialect).expect("renders");
        let (dwells, stops, times) = read_lines_program(&text, dialect);
        assert_eq!(
            dwells.len(),
            expected.len(),
            "{dialect}: one dwell per visit"
        );
        for (i, (d, e)) in dwells.iter().zip(&expected).enumerate() {
            assert!(
                (0..3).all(|k| (d[k] - e[k]).abs() <= 0.0005),
                "{dialect}: visit {i} at {d:?}, the plan's target is {e:?}"
            );
        }
        assert!(
            times.iter().all(|&t| (t - plan.dwell_s).abs() < 1e-9),
            "{dialect}"
        );
        // One stop per line, with the axes on that line's first target.
        assert_eq!(stops.len(), program.lines.len(), "{dialect}");
        for (s, l) in stops.iter().zip(&program.lines) {
            assert!(
                (0..3).all(|k| (s[k] - l.targets_mm[0][k]).abs() <= 0.0005),
                "{dialect}"
            );
        }
    }
    let empty = LinesProgram {
        lines: vec![],
        ..program.clone()
    };
    assert_eq!(
        render_lines(&empty, d("linuxcnc")),
        Err(ProgramError::EmptyCampaign)
    );
    let long = LinesProgram {
        dwell_s: 4000.0,
        ..program
    };
    assert!(matches!(
        render_lines(&long, d("heidenhain")),
        Err(ProgramError::DwellTooLong { .. })
    ));
}

#[test]
fn volumetric_program_command_writes_the_dialect() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("lines.nc");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_errmap"))
        .args(["volumetric", "program", "--plan"])
        .arg(root().join("datasets/volumetric/plan.toml"))
        .args(["--dialect", "fanuc", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).expect("written");
    let (dwells, stops, _) = read_lines_program(&text, d("fanuc"));
    // The rich preset's 43 lines and the extra line; 2 runs of 11 (and 17) targets.
    assert_eq!(stops.len(), 44);
    assert_eq!(dwells.len(), 43 * 2 * 11 + 2 * 17);
    assert!(text.starts_with("%\nO0230") && text.ends_with("M30\n%\n"));
}
