//! The one rule for bad values (`docs/cli.md`, issue 40 item 11), over every command: a
//! flag's value that does not parse, lies outside the flag's own range or is not one of its
//! names is a usage error, exit 2, with the flag named; a value the input file cannot take
//! (an order beyond the table's nodes, a record the ledger does not hold) is the file's,
//! exit 1.
//!
//! [`every_value_flag_of_every_command_is_in_the_table`] reads `--help` of every command
//! and fails when a flag taking a value is neither in [`CASES`] nor a path or free text
//! ([`PATHS_AND_TEXT`]): a new flag joins the table when it is added.

use std::collections::BTreeSet;

use crate::util::{dataset, errmap, root, stderr, tempdir};

/// Per command: a valid command line (`{d}` the datasets, `{o}` a new temporary
/// directory) and flags with a bad value each; every run gives the command line with one
/// flag set (`--flag=value`, replacing the line's own value of that flag).
pub(crate) const CASES: &[(&str, &[(&str, &str)])] = &[
    (
        "fit {d}/table1.csv --method lagrange --order auto --predict {d}/table2.csv",
        &[
            ("method", "foo"),
            ("order", "4x1"),
            ("threads", "abc"),
            ("fuzzy-sigma", "-1"),
            ("max-degree", "32"),
            ("gp-kernel", "rbf"),
        ],
    ),
    (
        "compare {d}/table1.csv --test {d}/table2.csv --report {o}/cmp",
        &[
            ("methods", "foo"),
            ("orders", "4x"),
            ("fuzzy-sigma", "0"),
            ("max-degree", "-1"),
            ("gp-kernel", "rbf"),
        ],
    ),
    (
        "fuzzy-sim",
        &[("seed", "-1"), ("trials", "0"), ("fuzzy-sigma", "1e300")],
    ),
    (
        "serve-sim --model {d}/sim/model.toml",
        &[
            ("speed", "0"),
            ("linger", "-1"),
            ("stall-timeout", "nan"),
            ("garbage", "2"),
            ("bit-flips", "-0.1"),
            ("drop-frames", "1.5"),
            ("beam-loss", "7:5"),
            ("near-wrap", "abc"),
            ("fault-seed", "-1"),
        ],
    ),
    (
        "capture --port /nonexistent --out {o}/cap",
        &[
            ("speed", "0"),
            ("baud", "0"),
            ("format", "xlsx"),
            ("idle-timeout", "nan"),
            ("duration", "-1"),
        ],
    ),
    (
        "table {d}/physics/example-session.parquet --out {o}/t.csv \
         --tolerances {d}/acceptance/tolerances.toml --rule guard",
        &[("rule", "bogus"), ("guard-fraction", "-1")],
    ),
    (
        "bench --history-only",
        &[
            ("points", "0"),
            ("threads", "abc"),
            ("history-machines", "0"),
            ("history-tests", "0"),
        ],
    ),
    (
        "diagnose --recorded {d}/concealed/clean/recorded.parquet --report {o}/dg",
        &[
            ("max-dead-path-mm", "-1"),
            ("grating-period-um", "0"),
            ("max-rows", "0"),
        ],
    ),
    (
        "export {d}/table1.csv --method spline --step 10 --format fanuc --out {o}/e.txt",
        &[
            ("format", "pdf"),
            ("method", "foo"),
            ("order", "axbxc"),
            ("axis", "w"),
            ("at", "q=1"),
            ("step", "0"),
            ("start", "1e9"),
            ("end", "nan"),
            ("ends", "bogus"),
            ("reference", "1e300"),
            ("comp-type", "bogus"),
            ("units", "parsec"),
            ("siemens-axis", "1x"),
            ("siemens-table", "-1"),
            ("fanuc-reference-number", "-5"),
            ("detection-unit-um", "0"),
            ("magnification", "0"),
            ("fanuc-max-value", "0"),
            ("fanuc-max-point", "abc"),
            ("fanuc-negative-start", "abc"),
            ("detection-unit-deg", "0"),
            ("max-points", "1"),
            ("axis-name", "a/b"),
            ("axis-number", "0"),
            ("table-name", ""),
            ("fuzzy-sigma", "-1"),
            ("max-degree", "99"),
            ("gp-kernel", "rbf"),
        ],
    ),
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {o}/p.toml",
        &[
            ("axis", "w"),
            ("from", "1e9"),
            ("to", "nan"),
            ("targets", "1"),
            ("interval", "0"),
            ("runs", "0"),
            ("overrun", "-1"),
            ("dwell-s", "-1"),
            ("feed-mm-s", "0"),
            ("feed-deg-s", "0"),
            ("at", "q=1"),
            ("random-offset", "0.5"),
            ("seed", "-1"),
            ("dialect", "bogus"),
            ("mark-output", "abc"),
        ],
    ),
    (
        "volumetric lines {d}/physics/example-session.parquet --out {o}/l.csv",
        &[("probe", "1,2")],
    ),
    (
        "volumetric identify {d}/table1.csv --topology YXZ",
        &[
            ("topology", "QQQ"),
            ("basis", "bogus"),
            ("degree", "0"),
            ("max-degree", "13"),
            ("component-degree", "E_QQ=3"),
            ("positions", "1"),
        ],
    ),
    (
        "volumetric predict --model {d}/volumetric/model.toml --lines {d}/table1.csv",
        &[("probe", "a,b,c")],
    ),
    (
        "volumetric export --model {d}/volumetric/model.toml --axis-tables {o}/at",
        &[("format", "bogus"), ("at", "1,2"), ("points", "0")],
    ),
    (
        "volumetric program --plan {d}/volumetric/plan.toml --dialect fanuc --out {o}/v.nc",
        &[("dialect", "bogus")],
    ),
    (
        "volumetric iso10360 --model {d}/volumetric/model.toml --plan {d}/volumetric/plan.toml \
         --mpe 2+L/333 --rule guard",
        &[
            ("mpe", "2+L/1e-300"),
            ("u-um", "-1"),
            ("rule", "bogus"),
            ("guard-fraction", "-1"),
            ("table-points", "0"),
        ],
    ),
    (
        "artefact evaluate {d}/artefact/plate.toml {d}/artefact/meas/xy_high.csv",
        &[("model", "QQ"), ("plane", "QQ"), ("temp-c", "1e9")],
    ),
    (
        "artefact simulate {d}/artefact/campaign.toml --model {d}/artefact/machine.toml \
         --out {o}/as",
        &[("sigma-um", "1e300"), ("seed", "abc")],
    ),
    (
        "artefact identify {d}/artefact/campaign.toml --topology YXZ",
        &[("topology", "QQQ"), ("positions", "0")],
    ),
    (
        "certificate {d}/physics/example-session.parquet --out {o}/c.pdf \
         --tolerances {d}/acceptance/tolerances.toml --rule guard",
        &[("rule", "bogus"), ("guard-fraction", "-1")],
    ),
    (
        "import {d}/examples/y-axis-de.csv --out {o}/i.csv",
        &[
            ("format", "bogus"),
            ("axis", "q"),
            ("map", "bogus"),
            ("delimiter", ";;"),
            ("units", "parsec"),
            ("error-units", "parsec"),
            ("error-sign", "bogus"),
            ("comp-type", "bogus"),
        ],
    ),
    (
        "history add {d}/table1.csv --ledger {o}/l.db --machine M",
        &[
            ("machine", "!!"),
            ("state", "bogus"),
            ("at", "2025-13-45"),
            ("at", "0001-01-01"),
            ("at", "9999-12-31"),
            ("supersede", "-3"),
            ("reason", " "),
        ],
    ),
    (
        "history report --ledger {o}/l.db --report {o}/hr",
        &[
            ("machine", "!!"),
            ("as-of", "bogus"),
            ("as-of", "9999-12-31"),
            ("horizon", "-5"),
        ],
    ),
    (
        "acceptance decide {d}/table1.csv --rule guard",
        &[("rule", "bogus"), ("guard-fraction", "-1")],
    ),
    (
        "acceptance iso10360 {d}/acceptance/iso10360-example.csv --mpe 2+L/333 --rule guard",
        &[
            ("mpe", "2+L/1e-300"),
            ("u-um", "abc"),
            ("mpl-r0", "-1"),
            ("u-r0-um", "-1"),
            ("repetitions", "0"),
            ("rule", "bogus"),
            ("guard-fraction", "-1"),
        ],
    ),
    (
        "acceptance iso10360-5 {d}/acceptance/probing-example.csv \
         --sphere {d}/acceptance/probing-sphere.toml --rule guard",
        &[
            ("mpe-form", "-1"),
            ("mpe-size", "nan"),
            ("mpe-location", "1e300"),
            ("rule", "bogus"),
            ("guard-fraction", "-1"),
        ],
    ),
    (
        "acceptance cmm-certificate --length {d}/acceptance/iso10360-example.csv --mpe 2+L/333 \
         --probing {d}/acceptance/probing-example.csv --sphere {d}/acceptance/probing-sphere.toml \
         --specification ISO --rule guard --out {o}/cc.pdf",
        &[
            ("mpe", "2+L/1e-300"),
            ("u-um", "-1"),
            ("mpl-r0", "nan"),
            ("u-r0-um", "-1"),
            ("repetitions", "101"),
            ("mpe-form", "0"),
            ("mpe-size", "-1"),
            ("mpe-location", "nan"),
            ("specification", " "),
            ("cmm", ""),
            ("rule", "bogus"),
            ("guard-fraction", "-1"),
        ],
    ),
    ("workbench --dir {o}", &[("addr", "notanaddr")]),
];

/// Flags whose value is a path, a URL or free text: any text is a value, and a wrong
/// one is a file that cannot be read or written (exit 1, named).
const PATHS_AND_TEXT: [&str; 37] = [
    "against",
    "axis-tables",
    "dir",
    "existing",
    "grid",
    "hello-from",
    "history-postgres",
    "info",
    "ledger",
    "length",
    "lines",
    "model",
    "out",
    "plan",
    "port",
    "predict",
    "probing",
    "program",
    "raw",
    "recorded",
    "report",
    "simulate",
    "simulated",
    "site",
    "sphere",
    "test",
    "token",
    "tolerances",
    "truth-out",
    "twincat",
    // `model` of artefact evaluate is a name (in CASES); of the other commands a path.
    "campaign",
    "laser",
    "table",
    "result",
    "artefact",
    "meas",
    "file",
];

/// The command line of `line` with `--flag=value`, placeholders filled.
pub(crate) fn with_flag(line: &str, d: &str, o: &str, flag: &str, value: &str) -> Vec<String> {
    let line = line.replace("{d}", d).replace("{o}", o);
    let mut args: Vec<String> = Vec::new();
    let mut words = line.split_whitespace();
    let own = format!("--{flag}");
    while let Some(w) = words.next() {
        if w == own {
            words.next();
        } else {
            args.push(w.to_string());
        }
    }
    args.push(format!("--{flag}={value}"));
    args
}

#[test]
fn every_bad_flag_value_of_every_command_exits_2_naming_the_flag() {
    let dir = tempdir();
    let d = root().join("datasets");
    let (d, o) = (
        d.to_str().expect("utf8"),
        dir.path().to_str().expect("utf8"),
    );
    let mut wrong = Vec::new();
    let mut runs = 0;
    for (line, flags) in CASES {
        for (flag, value) in *flags {
            let args = with_flag(line, d, o, flag, value);
            let refs: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = errmap(&refs);
            runs += 1;
            let e = stderr(&out);
            if out.status.code() != Some(2) || !e.contains(&format!("--{flag}")) {
                wrong.push(format!(
                    "{}: exit {:?}: {}",
                    args.join(" "),
                    out.status.code(),
                    e.lines().next().unwrap_or("")
                ));
            }
        }
    }
    assert!(runs >= 152, "{runs} runs");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // Nothing of any refused run was written.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .expect("read")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// A value inside the flag's own range that the input cannot take is the input's: exit 1,
/// the file named.
#[test]
fn a_value_the_input_cannot_take_is_the_files_exit_1() {
    let dir = tempdir();
    let t1 = dataset("table1.csv");
    let t2 = dataset("table2.csv");
    let (t1, t2) = (t1.to_str().expect("utf8"), t2.to_str().expect("utf8"));
    // table1 has 5 nodes along x: degree 9 is inside 0 … 31 but beyond the table.
    let o = errmap(&[
        "fit",
        t1,
        "--method",
        "lagrange",
        "--order",
        "9x1x1",
        "--predict",
        t2,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("table1.csv") && e.contains("degree 9"), "{e}");
    // A record number the ledger does not hold.
    let session = dataset("physics/example-session.parquet");
    let ledger = dir.path().join("l.db");
    let o = errmap(&[
        "history",
        "add",
        session.to_str().expect("utf8"),
        "--ledger",
        ledger.to_str().expect("utf8"),
        "--machine",
        "M",
        "--supersede",
        "7",
        "--reason",
        "wrong file",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no record 7"), "{}", stderr(&o));
}

/// Every flag that takes a value, in every command's `--help`.
fn value_flags(path: &mut Vec<String>, out: &mut BTreeSet<(String, String)>) {
    let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
    args.push("--help");
    let help = String::from_utf8_lossy(&errmap(&args).stdout).to_string();
    let subs: Vec<String> = help
        .split_once("Commands:")
        .map(|(_, rest)| rest.split("Options:").next().unwrap_or(""))
        .unwrap_or("")
        .lines()
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| *n != "help")
        .map(str::to_string)
        .collect();
    if !subs.is_empty() {
        for s in subs {
            path.push(s);
            value_flags(path, out);
            path.pop();
        }
        return;
    }
    for l in help.lines() {
        for w in l.split_whitespace().collect::<Vec<_>>().windows(2) {
            if let Some(flag) = w[0].strip_prefix("--")
                && w[1].starts_with('<')
            {
                out.insert((path.join(" "), flag.to_string()));
            }
        }
    }
}

#[test]
fn every_value_flag_of_every_command_is_in_the_table() {
    let mut flags = BTreeSet::new();
    value_flags(&mut Vec::new(), &mut flags);
    assert!(flags.len() > 150, "{} flags", flags.len());
    let covered: BTreeSet<(String, String)> = CASES
        .iter()
        .flat_map(|(line, fs)| {
            // The command's words: those before the first argument that is a flag or a
            // file.
            let cmd: Vec<&str> = line
                .split_whitespace()
                .take_while(|w| !w.starts_with("--") && !w.contains('{'))
                .collect();
            fs.iter().map(move |(f, _)| (cmd.join(" "), f.to_string()))
        })
        .collect();
    let missing: Vec<String> = flags
        .iter()
        .filter(|(cmd, f)| !covered.contains(&(cmd.clone(), f.clone())))
        .filter(|(cmd, f)| {
            !PATHS_AND_TEXT.contains(&f.as_str()) || (cmd == "artefact evaluate" && f == "model")
        })
        .map(|(cmd, f)| format!("{cmd} --{f}"))
        .collect();
    assert!(missing.is_empty(), "not in CASES: {}", missing.join(", "));
}
