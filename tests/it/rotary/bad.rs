//! Bad rotary inputs refused as the contract says: exit 1 naming file, line and column,
//! exit 2 for a flag that does not fit a rotary axis.

use std::path::Path;

use super::{every_45, import_rotary, rotary_csv, rotary_session};
use crate::util::{errmap, s, stderr, tempdir};

/// A valid rotary session written through import, as text lines to edit.
fn session_lines(dir: &Path) -> Vec<String> {
    let csv = rotary_csv(dir, "ok.csv", &every_45(), 2, &|t, _, d| {
        t * 0.01 + f64::from(d)
    });
    std::fs::read_to_string(rotary_session(&csv, dir.join("ok_session.csv"), "b"))
        .expect("present")
        .lines()
        .map(str::to_string)
        .collect()
}

fn column(lines: &[String], name: &str) -> usize {
    lines[0].split(',').position(|c| c == name).expect(name)
}

fn set(lines: &mut [String], line: usize, col: usize, v: &str) {
    let mut f: Vec<String> = lines[line - 1].split(',').map(str::to_string).collect();
    f[col] = v.to_string();
    lines[line - 1] = f.join(",");
}

/// Runs `table` on the edited session; exit 1 with every `want` in the message.
fn refused(dir: &Path, lines: &[String], want: &[&str]) {
    let p = dir.join("bad.csv");
    std::fs::write(&p, lines.join("\n") + "\n").expect("present");
    let o = errmap(&["table", s(&p), "--out", s(&dir.join("t.csv"))]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("errmap: error: ") && e.contains(s(&p)), "{e}");
    for w in want {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
    assert!(!dir.join("t.csv").exists(), "nothing written on bad input");
}

#[test]
fn an_axis_that_differs_or_is_not_a_b_c_is_refused_at_its_line() {
    let dir = tempdir();
    let mut l = session_lines(dir.path());
    let c = column(&l, "axis");
    set(&mut l, 5, c, "C");
    refused(dir.path(), &l, &["line 5: column axis:", "`C` differs"]);
    let mut l = session_lines(dir.path());
    set(&mut l, 7, c, "Q");
    refused(
        dir.path(),
        &l,
        &["line 7: column axis:", "`Q` is not A, B or C"],
    );
}

#[test]
fn a_target_outside_0_360_is_refused_at_its_first_row() {
    let dir = tempdir();
    let mut l = session_lines(dir.path());
    let c = column(&l, "target_deg");
    set(&mut l, 4, c, "-90");
    refused(dir.path(), &l, &["line 4: column target_deg:", "write 270"]);
}

#[test]
fn one_index_two_angles_and_one_angle_two_indices_name_both_lines() {
    let dir = tempdir();
    let mut l = session_lines(dir.path());
    let c = column(&l, "target_deg");
    // Line 2 is target 0 at 0°; line 3 target 1 at 45°.
    set(&mut l, 3, c, "46");
    let later = l
        .iter()
        .skip(3)
        .position(|x| x.contains(",1,45"))
        .expect("present")
        + 4;
    refused(
        dir.path(),
        &l,
        &[&format!("line {later}: column target_deg:"), "on line 3"],
    );
    let mut l = session_lines(dir.path());
    set(&mut l, 3, c, "0");
    refused(dir.path(), &l, &["line 3: column target:", "on line 2"]);
}

#[test]
fn a_closure_pair_in_different_runs_names_the_run() {
    let dir = tempdir();
    let l = session_lines(dir.path());
    let t = column(&l, "target_deg");
    // Drop run 2's upward 360 dwell.
    let kept: Vec<String> = l
        .iter()
        .filter(|x| {
            let f: Vec<&str> = x.split(',').collect();
            !(f[0] == "2" && f[4] == "1" && f[t].parse::<f64>() == Ok(360.0))
        })
        .cloned()
        .collect();
    assert_eq!(kept.len(), l.len() - 1);
    refused(dir.path(), &kept, &["run 2, direction +", "360"]);
}

#[test]
fn import_refuses_a_target_outside_0_360_and_flags_that_do_not_fit() {
    let dir = tempdir();
    let csv = rotary_csv(dir.path(), "neg.csv", &[-90.0, 0.0, 90.0], 2, &|_, _, _| {
        1.0
    });
    let o = import_rotary(&csv, &dir.path().join("o.csv"), "a");
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("line 2: column target:") && e.contains("write 270"),
        "{e}"
    );
    let good = rotary_csv(dir.path(), "g.csv", &every_45(), 2, &|_, _, _| 1.0);
    let base = |extra: &[&str]| {
        let mut a = vec![
            "import",
            s(&good),
            "--format",
            "csv",
            "--map",
            "run=run,direction=direction,target=target,error=error",
            "--error-sign",
            "indicated-minus-reference",
        ];
        a.extend_from_slice(extra);
        errmap(&a)
    };
    for (extra, want) in [
        (&["--axis", "x", "--units", "deg"][..], "--units deg"),
        (&["--axis", "a", "--units", "mm"][..], "--units mm"),
        (
            &["--axis", "a", "--error-units", "um"][..],
            "--error-units um",
        ),
        (
            &["--axis", "x", "--error-units", "arcsec"][..],
            "--error-units arcsec",
        ),
    ] {
        let o = base(extra);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{extra:?}: {}", stderr(&o));
    }
    let o = base(&["--axis", "a", "--error-units", "urad"]);
    assert!(o.status.success(), "{}", stderr(&o));
}
