//! `plan --axis a|b|c` (`docs/rotary.md` §5): the cycle in degrees read back from the
//! LinuxCNC program (and through LinuxCNC's `rs274` when it is installed), and the usage
//! errors.

use std::process::Command;

use super::plan_revolution;
use crate::util::{errmap, s, stderr, tempdir};

/// The program's moves ('M', angle) and dwells ('D', s), read here independently.
fn events(ngc: &str, letter: char) -> (Vec<(char, f64)>, Vec<f64>) {
    let (mut ev, mut feeds) = (Vec::new(), Vec::new());
    for l in ngc.lines().filter(|l| !l.starts_with('(')) {
        let w: Vec<&str> = l.split_whitespace().collect();
        let val = |p: char| {
            w.iter()
                .find_map(|x| x.strip_prefix(p)?.parse::<f64>().ok())
        };
        match w.first().copied() {
            Some("G1") => {
                ev.push(('M', val(letter).expect("angle")));
                feeds.push(val('F').expect("feed"));
            }
            Some("G4") => ev.push(('D', val('P').expect("seconds"))),
            _ => {}
        }
    }
    (ev, feeds)
}

#[test]
fn the_iso_cycle_in_degrees_with_overrun_and_dwell() {
    let dir = tempdir();
    let (toml, ngc) = (dir.path().join("p.toml"), dir.path().join("p.ngc"));
    let o = plan_revolution(
        "b",
        &[
            "--targets",
            "9",
            "--runs",
            "2",
            "--dwell-s",
            "1.5",
            "--feed-deg-s",
            "20",
            "--seed",
            "3",
            "--out",
            s(&toml),
            "--program",
            s(&ngc),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t = std::fs::read_to_string(&toml).expect("present");
    assert!(t.contains("axis = \"B\"") && t.contains("runs = 2") && t.contains("overrun_deg = 5"));
    let line = t
        .lines()
        .find(|l| l.starts_with("targets_deg"))
        .expect("present");
    let targets: Vec<f64> = line
        [line.find('[').expect("present") + 1..line.find(']').expect("present")]
        .split(',')
        .map(|v| v.trim().parse().expect("present"))
        .collect();
    assert_eq!(targets.len(), 9);
    assert_eq!((targets[0], targets[8]), (0.0, 360.0), "the closure pair");
    assert!(targets.windows(2).all(|w| w[1] > w[0]));
    assert!(
        targets
            .iter()
            .all(|v| ((v * 1000.0).round() - v * 1000.0).abs() < 1e-6)
    );
    let text = std::fs::read_to_string(&ngc).expect("present");
    assert!(text.contains("G90") && text.contains("G1 B-5.000 F1200"));
    let (ev, feeds) = events(&text, 'B');
    // The move to from − overrun, then the cycle.
    let mut want = vec![('M', -5.0)];
    for _ in 0..2 {
        for &q in &targets {
            want.extend([('M', q), ('D', 1.5)]);
        }
        want.push(('M', 365.0));
        for &q in targets.iter().rev() {
            want.extend([('M', q), ('D', 1.5)]);
        }
        want.push(('M', -5.0));
    }
    assert_eq!(ev.len(), want.len());
    for (g, w) in ev.iter().zip(&want) {
        assert!(g.0 == w.0 && (g.1 - w.1).abs() < 1e-9, "{g:?} vs {w:?}");
    }
    assert!(feeds.iter().all(|&f| f == 1200.0), "60·20 °/min");
    // LinuxCNC's own interpreter when installed (Debian: linuxcnc-uspace).
    let rs274 = std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join("rs274"))
            .find(|p| p.is_file())
    });
    let Some(rs274) = rs274 else {
        eprintln!("SKIP rotary plan through rs274: rs274 (linuxcnc-uspace) is not installed");
        return;
    };
    std::fs::write(dir.path().join("tool.tbl"), "T1 P1 D0 Z0 ;\n").expect("present");
    std::fs::write(dir.path().join("rs274ngc.var"), "").expect("present");
    let out = Command::new(rs274)
        .current_dir(dir.path())
        .args(["-t", "tool.tbl", "-v", "rs274ngc.var", "-g", "p.ngc"])
        .stdin(std::process::Stdio::null())
        .output()
        .expect("runs rs274");
    let canon = String::from_utf8_lossy(&out.stdout);
    // STRAIGHT_FEED(x, y, z, a, b, c, …): B is the fifth.
    let feeds: Vec<f64> = canon
        .lines()
        .filter_map(|l| {
            let a = &l[l.find("STRAIGHT_FEED(")? + 14..];
            a[..a.find(')')?].split(',').nth(4)?.trim().parse().ok()
        })
        .collect();
    let moves: Vec<f64> = want.iter().filter(|e| e.0 == 'M').map(|e| e.1).collect();
    assert_eq!(feeds.len(), moves.len(), "{canon}");
    for (g, w) in feeds.iter().zip(&moves) {
        assert!((g - w).abs() < 1e-3, "{g} vs {w}");
    }
}

#[test]
fn a_rotary_plan_refuses_what_does_not_fit_with_exit_2() {
    let dir = tempdir();
    let out = dir.path().join("p.toml");
    for (extra, want) in [
        (&["--from", "-10", "--to", "350"][..], "0 ≤ from < to ≤ 360"),
        (&["--from", "0", "--to", "400"][..], "0 ≤ from < to ≤ 360"),
        (
            &["--from", "0", "--to", "360", "--feed-mm-s", "5"][..],
            "--feed-mm-s",
        ),
        (&["--from", "0", "--to", "360", "--at", "y=1"][..], "--at"),
    ] {
        let mut a = vec!["plan", "--axis", "c", "--targets", "5", "--out", s(&out)];
        a.extend_from_slice(extra);
        let o = errmap(&a);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists());
    }
}

/// The rotary cycle through each dialect's program syntax: moves and dwells read back
/// with that dialect's words, in the order of the cycle, every move at 60·feed °/min.
#[test]
fn a_rotary_plan_is_a_part_program_in_every_dialect() {
    let dir = tempdir();
    // (dialect, move word, dwell word, dwell unit in s, opening, closing)
    let cases = [
        ("fanuc", "G01", "G04", 1e-3, "O", "M30"),
        ("siemens", "G1", "G4", 1.0, "G71 G90 G94", "M30"),
        (
            "heidenhain",
            "L",
            "CYCL DEF 9.1 DWELL",
            1.0,
            "BEGIN PGM",
            "END PGM",
        ),
        ("linuxcnc", "G1", "G4", 1.0, "G21 G90", "M2"),
    ];
    for (dialect, mv, dw, unit_s, first, last) in cases {
        let (toml, prog) = (dir.path().join("p.toml"), dir.path().join(dialect));
        let o = plan_revolution(
            "c",
            &[
                "--interval",
                "90",
                "--runs",
                "2",
                "--dwell-s",
                "1.5",
                "--feed-deg-s",
                "4",
                "--random-offset",
                "0",
                "--out",
                s(&toml),
                "--program",
                s(&prog),
                "--dialect",
                dialect,
            ],
        );
        assert!(o.status.success(), "{dialect}: {}", stderr(&o));
        let text = std::fs::read_to_string(&prog).expect("program");
        let mut blocks: Vec<String> = text.lines().map(String::from).collect();
        if dialect == "heidenhain" {
            // Every block numbered from 0, in order.
            for (i, b) in blocks.iter_mut().enumerate() {
                let rest = b
                    .strip_prefix(&format!("{i} "))
                    .unwrap_or_else(|| panic!("block {i} unnumbered: {b}"));
                *b = rest.to_string();
            }
        }
        assert!(
            blocks.iter().any(|b| b.contains(first)),
            "{dialect}: {first}"
        );
        assert!(blocks.iter().any(|b| b.contains(last)), "{dialect}: {last}");
        let mut ev = Vec::new();
        for b in &blocks {
            let w: Vec<&str> = b.split_whitespace().collect();
            let word = |p: &str| {
                w.iter()
                    .find_map(|x| x.strip_prefix(p)?.parse::<f64>().ok())
            };
            if b.starts_with(&format!("{mv} C")) {
                ev.push(('M', word("C").expect("angle")));
                assert_eq!(word("F"), Some(240.0), "{dialect}: 60·4 °/min in {b}");
                assert!(
                    !b.contains('X') && !b.contains('Y') && !b.contains('Z'),
                    "{b}"
                );
            } else if let Some(rest) = b.strip_prefix(dw) {
                let v: f64 = rest
                    .trim()
                    .trim_start_matches(['P', 'F'])
                    .parse()
                    .expect("dwell");
                ev.push(('D', v * unit_s));
            }
        }
        let mut want = vec![('M', -5.0)];
        let targets = [0.0, 90.0, 180.0, 270.0, 360.0];
        for _ in 0..2 {
            for t in targets {
                want.extend([('M', t), ('D', 1.5)]);
            }
            want.push(('M', 365.0));
            for t in targets.iter().rev() {
                want.extend([('M', *t), ('D', 1.5)]);
            }
            want.push(('M', -5.0));
        }
        assert_eq!(ev, want, "{dialect}");
    }
    // A dwell FANUC cannot write (G04 P in whole ms, at least 1 ms) is refused, nothing
    // written.
    let prog = dir.path().join("short.nc");
    let o = plan_revolution(
        "b",
        &[
            "--targets",
            "5",
            "--dwell-s",
            "0.0001",
            "--out",
            s(&dir.path().join("short.toml")),
            "--program",
            s(&prog),
            "--dialect",
            "fanuc",
        ],
    );
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("dwell"), "{}", stderr(&o));
    assert!(!prog.exists() && !dir.path().join("short.toml").exists());
}
