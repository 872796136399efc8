//! `export --existing` of a rotary axis (`docs/rotary.md`, "Updating a modulo table in
//! use"): the modulo table read back, the residual measured with it active added, every
//! modulo rule kept, per dialect — a round trip with a zero residual gives the file back,
//! and an update equals (within one unit of the file's last digit) the table exported
//! from the sum of the two errors, which is what the rule c_new = c_old − (r′ − r′(R))
//! means for a linear correction.

use errmap::base::RotaryAxis;
use errmap::controller::modulo::{ModuloError, ModuloSpec, modulo_dialects, modulo_table};
use errmap::controller::{Dialect, dialect, update_modulo};

use super::{rotary_csv, rotary_session};
use crate::util::{errmap, s, stderr, tempdir};

fn every_15(f: &dyn Fn(f64) -> f64) -> Vec<(f64, f64)> {
    (0..=24)
        .map(|k| 15.0 * f64::from(k))
        .map(|q| (q, f(q)))
        .collect()
}

/// The error the table in use was made for: eccentricity, a worm order and a 20 ppm ratio.
fn e1(q: f64) -> f64 {
    8.0 * (q + 20.0).to_radians().sin() + 2.0 * (4.0 * q).to_radians().cos() + 20.0 * q * 3.6e-3
}

/// The residual the session measures with that table active (10 ppm of ratio left).
fn er(q: f64) -> f64 {
    4.0 * (3.0 * q).to_radians().sin() + 1.5 + 10.0 * q * 3.6e-3
}

/// The dialect of a modulo table, by name.
type D = &'static dyn Dialect;

fn named(name: &str) -> D {
    dialect(name).expect("a dialect")
}

fn spec(d: D) -> ModuloSpec {
    let mut s = ModuloSpec::new(d, RotaryAxis::A);
    if d.modulo().expect("a modulo table").equidistant() {
        s.step_deg = Some(15.0);
    }
    s
}

/// Each point's (θ °, c moving + ″, c moving − ″) read from a table's text, here,
/// independently of errmap's reader; FANUC's in counts of its unit (c = −Σ v).
fn values(d: D, text: &str) -> Vec<(f64, f64, f64)> {
    let nums = |l: &str| -> Vec<f64> {
        l.split_whitespace()
            .filter_map(|w| w.trim_start_matches('+').parse().ok())
            .collect()
    };
    match d.name() {
        "linuxcnc" => text
            .lines()
            .map(nums)
            .map(|v| (v[0], (v[1] - v[0]) * 3600.0, (v[2] - v[0]) * 3600.0))
            .collect(),
        "siemens" => text
            .lines()
            .filter(|l| l.starts_with("$AA_ENC_COMP[0,"))
            .enumerate()
            .map(|(i, l)| {
                let v: f64 = l
                    .rsplit('=')
                    .next()
                    .and_then(|x| x.parse().ok())
                    .expect("v");
                (15.0 * i as f64, v * 3600.0, v * 3600.0)
            })
            .collect(),
        "fanuc" => {
            let mut sum = 0.0;
            text.lines()
                .filter(|l| l.starts_with('N'))
                .enumerate()
                .map(|(j, l)| {
                    let v: f64 = l.split('P').nth(1).and_then(|x| x.parse().ok()).expect("P");
                    if j > 0 {
                        sum += v;
                    }
                    (15.0 * j as f64, -sum, -sum)
                })
                .collect()
        }
        "heidenhain" => text
            .lines()
            .skip(2)
            .take_while(|l| *l != "[END]")
            .map(nums)
            .map(|v| (v[1], v[2] * 3600.0, v[2] * 3600.0))
            .collect(),
        "fagor-8055" => text
            .split("\r\n")
            .filter(|l| !l.is_empty())
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                let v = |k: usize| w[k].parse::<f64>().expect("number");
                (v(2), v(4) * 3600.0, v(6) * 3600.0)
            })
            .collect(),
        other => panic!("{other}: not read here"),
    }
}

/// One unit of each dialect's last digit, ″ (FANUC: one count).
fn unit(d: D) -> f64 {
    match d.name() {
        "fanuc" => 1.0,
        "fagor-8055" => 1e-4 * 3600.0,
        _ => 1e-6 * 3600.0,
    }
}

/// Every dialect with a modulo table (the five this file reads).
fn all() -> Vec<D> {
    let all: Vec<D> = modulo_dialects().collect();
    assert_eq!(all.len(), 5, "{all:?}");
    all
}

#[test]
fn a_zero_residual_gives_every_dialects_table_back_unchanged() {
    let zero = every_15(&|_| 0.0);
    for d in all() {
        let old = modulo_table(&every_15(&e1), &spec(d)).expect("table");
        let new = update_modulo(old.text.as_bytes(), &[&zero], &spec(d))
            .unwrap_or_else(|e| panic!("{d:?}: {e}"));
        assert_eq!(new.text, old.text, "{d:?}");
        assert_eq!(new.max_change_arcsec, Some(0.0), "{d:?}");
        assert!(new.max_residual_arcsec < 1e-12, "{d:?}");
    }
    // Two directions, both zero: LinuxCNC's file back (trim as well); Fagor's one table
    // becomes two stated ones, err− = err+, the same compensation.
    for (d, trim) in [
        (named("linuxcnc"), false),
        (named("linuxcnc"), true),
        (named("fagor-8055"), false),
    ] {
        let mut sp = spec(d);
        sp.trim = trim;
        let old = modulo_table(&every_15(&e1), &sp).expect("table");
        let new = update_modulo(old.text.as_bytes(), &[&zero, &zero], &sp).expect("update");
        if d.name() == "linuxcnc" {
            assert_eq!(new.text, old.text, "{d:?} trim {trim}");
        } else {
            let (o, n) = (values(d, &old.text), values(d, &new.text));
            assert!(
                o.iter().zip(&n).all(|(o, n)| o.1 == n.1 && n.2 == n.1),
                "{n:?}"
            );
        }
    }
}

#[test]
fn an_update_adds_the_residual_and_keeps_every_modulo_rule() {
    let residual = every_15(&er);
    let combined = every_15(&|q| e1(q) + er(q));
    for d in all() {
        let sp = spec(d);
        let old = modulo_table(&every_15(&e1), &sp).expect("table");
        let new = update_modulo(old.text.as_bytes(), &[&residual], &sp).expect("update");
        let direct = modulo_table(&combined, &sp).expect("table");
        let (got, want) = (values(d, &new.text), values(d, &direct.text));
        assert_eq!(got.len(), 25, "{d:?}");
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g.0, w.0);
            assert!((g.1 - w.1).abs() <= unit(d) + 1e-9, "{d:?} {g:?} {w:?}");
        }
        // The rules: equal ends, the reference (0°) unmoved, the residual's ratio reported.
        assert_eq!(got[0].1, got[24].1, "{d:?} equal ends");
        assert_eq!(
            got[0].1,
            values(d, &old.text)[0].1,
            "{d:?} reference unmoved"
        );
        assert!((new.closure_gap_arcsec - 12.96).abs() < 1e-9, "{d:?}");
        assert!(new.warnings.iter().any(|w| w.contains("correct the ratio")));
        // What is left: the rounding of the two tables (each within half a unit).
        assert!(
            new.max_residual_arcsec <= unit(d) + 1e-9,
            "{d:?} {}",
            new.max_residual_arcsec
        );
        match d.name() {
            "siemens" => {
                assert!(new.text.contains("$AA_ENC_COMP_IS_MODULO[0,A1]=1"));
                assert!(new.text.contains("$AA_ENC_COMP_MAX[0,A1]=360.0"));
            }
            "fanuc" => {
                let v: Vec<i64> = new
                    .text
                    .lines()
                    .filter(|l| l.starts_with('N'))
                    .map(|l| l.split('P').nth(1).and_then(|x| x.parse().ok()).expect("P"))
                    .collect();
                assert_eq!(v[1..].iter().sum::<i64>(), 0, "a revolution sums to 0");
                assert_eq!(v[0], v[24]);
                assert!(
                    new.text
                        .contains("(3620=0 3621=0 3622=24 3623=1 3624=15.000000 3625=360)")
                );
            }
            "fagor-8055" => {
                assert!(got.iter().all(|p| p.2 == 0.0), "err− stays 0 (one table)");
            }
            _ => {}
        }
    }
}

#[test]
fn a_two_direction_update_gives_each_column_its_own_residual() {
    // The table in use is one correction for both; the session finds a 5″ reversal
    // (±2.5″) on top of er: each column gets its own, the mean datum at 0 kept.
    let up = every_15(&|q| er(q) + 2.5);
    let down = every_15(&|q| er(q) - 2.5);
    for d in [named("linuxcnc"), named("fagor-8055")] {
        let sp = spec(d);
        let old = modulo_table(&every_15(&e1), &sp).expect("table");
        let new = update_modulo(old.text.as_bytes(), &[&up, &down], &sp).expect("update");
        let direct = errmap::controller::modulo::modulo_table_bidirectional(
            &every_15(&|q| e1(q) + er(q) + 2.5),
            &every_15(&|q| e1(q) + er(q) - 2.5),
            &sp,
        )
        .expect("table");
        for (g, w) in values(d, &new.text).iter().zip(values(d, &direct.text)) {
            assert!((g.1 - w.1).abs() <= unit(d) + 1e-9, "{d:?} {g:?} {w:?}");
            assert!((g.2 - w.2).abs() <= unit(d) + 1e-9, "{d:?} {g:?} {w:?}");
        }
        let dirs = new.directions.expect("two directions");
        assert!((dirs.datum_up_arcsec - dirs.datum_down_arcsec - 5.0).abs() < 1e-9);
    }
}

/// The refusal's line, for a table text edited by `edit`.
fn refusal(d: D, sp: &ModuloSpec, edit: &dyn Fn(String) -> String) -> (usize, String) {
    let old = modulo_table(&every_15(&e1), &spec(d)).expect("table");
    let zero = every_15(&|_| 0.0);
    match update_modulo(edit(old.text).as_bytes(), &[&zero], sp) {
        Err(ModuloError::Existing { line, problem }) => (line, problem),
        // Not the step or the axis the spec names: the library's words for the setting.
        Err(ModuloError::Mismatch { line, mismatch }) => {
            (line, mismatch.render(&errmap::base::Setting::words))
        }
        other => panic!("{d:?}: {other:?}"),
    }
}

#[test]
fn a_table_that_is_not_this_axis_modulo_table_is_refused_naming_its_line() {
    let (siemens, fanuc, fagor, heidenhain, linuxcnc) = (
        named("siemens"),
        named("fanuc"),
        named("fagor-8055"),
        named("heidenhain"),
        named("linuxcnc"),
    );
    let same = |d| spec(d);
    let (line, p) = refusal(siemens, &same(siemens), &|t| t.replace(",A1]", ",A2]"));
    assert_eq!(line, 3, "{p}");
    assert!(p.contains("axis A2, not A1"), "{p}");
    let (line, p) = refusal(siemens, &same(siemens), &|t| {
        t.replace("IS_MODULO[0,A1]=1", "IS_MODULO[0,A1]=0")
    });
    assert_eq!(line, 31, "{p}");
    assert!(p.contains("not a modulo table"), "{p}");
    let (line, p) = refusal(fanuc, &same(fanuc), &|t| {
        t.replacen("N10001P", "N10001P1", 1)
    });
    assert!(p.contains("sum to"), "{p}");
    assert_eq!(line, 28, "{p}");
    let (line, p) = refusal(fagor, &same(fagor), &|t| t.replace(" A ", " B "));
    assert_eq!((line, p.contains("axis B, not A")), (1, true), "{p}");
    let (line, p) = refusal(heidenhain, &same(heidenhain), &|t| t.replace("DEG", "MM"));
    assert_eq!((line, p.contains("not a rotary")), (1, true), "{p}");
    // Unequal ends: the last LinuxCNC line's forward value moved by 1e-5°.
    let (line, p) = refusal(linuxcnc, &same(linuxcnc), &|t| {
        let mut lines: Vec<String> = t.lines().map(str::to_string).collect();
        let last = lines.last_mut().expect("line");
        let w: Vec<f64> = last
            .split_whitespace()
            .map(|x| x.parse().expect("n"))
            .collect();
        *last = format!("{:.6} {:.6} {:.6}", w[0], w[1] + 1e-5, w[2]);
        lines.join("\n") + "\n"
    });
    assert_eq!(line, 25, "{p}");
    assert!(p.contains("equal ends"), "{p}");
    // Another step than --step names.
    let mut s30 = spec(heidenhain);
    s30.step_deg = Some(30.0);
    let (_, p) = refusal(heidenhain, &s30, &|t| t);
    assert!(p.contains("not every 30° as the step says"), "{p}");
}

#[test]
fn the_command_line_updates_a_rotary_table_beside_the_old_one() {
    let dir = tempdir();
    let targets: Vec<f64> = (0..=24).map(|k| 15.0 * f64::from(k)).collect();
    let make = |name: &str, f: &dyn Fn(f64) -> f64| {
        let csv = rotary_csv(
            dir.path(),
            &format!("{name}.csv"),
            &targets,
            2,
            &|t, _, _| f(t),
        );
        rotary_session(&csv, dir.path().join(format!("{name}_session.csv")), "a")
    };
    let first = make("first", &e1);
    let zero = make("zero", &|_| 0.0);
    let in_use = dir.path().join("a.spf");
    let o = errmap(&[
        "export",
        s(&first),
        "--format",
        "siemens",
        "--step",
        "15",
        "--out",
        s(&in_use),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&in_use).expect("written");
    // `export` of the session that leaves no residual, updating `table` into `out`.
    let update = |format: &str, table: &std::path::Path, out: &std::path::Path, json: bool| {
        let mut a = vec![
            "export",
            s(&zero),
            "--format",
            format,
            "--existing",
            s(table),
            "--out",
            s(out),
        ];
        if json {
            a.push("--json");
        }
        errmap(&a)
    };
    let new = dir.path().join("b.spf");
    let o = update("siemens", &in_use, &new, true);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&new).expect("written"), before);
    let j = crate::util::json(&o);
    assert_eq!(j["max_change_arcsec"], 0.0);
    // Never over the table in use.
    let o = update("siemens", &in_use, &in_use, false);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("would destroy the input"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&in_use).expect("kept"), before);
    // A table of another axis: the file and the line named, nothing written.
    let other = dir.path().join("c.spf");
    let bad = dir.path().join("bad.spf");
    std::fs::write(
        &bad,
        String::from_utf8(before)
            .expect("text")
            .replace(",A1]", ",B1]"),
    )
    .expect("write");
    let o = update("siemens", &bad, &other, false);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let msg = stderr(&o);
    assert!(
        msg.contains("bad.spf: line 3:") && msg.contains("axis B1, not A1 (--siemens-axis)"),
        "{msg}"
    );
    assert!(!other.exists());
    // LinuxCNC's file does not say its type.
    let o = update("linuxcnc", &in_use, &other, false);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--comp-type"), "{}", stderr(&o));
}
