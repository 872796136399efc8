//! Issue 40's remaining reproducers, pinned, and a new seeded black-box campaign over the
//! commands they concern.
//!
//! - Outputs are never inputs, for every file a command writes (item 2): a ledger inside
//!   the report folder, a trace's TOML beside `--out` that is the model read, an
//!   `iso10360` input inside its report folder — each refused with the input intact — and
//!   two outputs on one path (`identify --out R/model.json --report R`, item 11).
//! - No `.txt` table written (item 11).
//! - `diagnose --simulated` against a simulation made with the recording's noise seed
//!   states the recording's own noise, not the near-zero noise of their difference.
//! - The campaign: `ERRMAP_CAMPAIGN40_RUNS` runs (default 60) from seed
//!   `ERRMAP_CAMPAIGN40_SEED` (default 40), each a mutated `.rtl` import, an
//!   `acceptance iso10360` with a drawn `--mpe` and report folder, a `circular simulate`
//!   of a mutated model (sometimes writing beside the model it reads), a bad value of one
//!   flag of one command drawn from `exit_codes::CASES` (exit 2), a `circular diagnose` of
//!   the example trace with one sample mutated or a `volumetric
//!   identify` at a drawn degree 1–12 (sometimes with `--out` inside `--report`). Every
//!   run must exit 0, 1 or 2 (never a panic or a signal), leave every
//!   input byte for byte, and give the exit status its case expects when it has one. The
//!   tally (runs, statuses, slowest run) is printed on stderr (`--nocapture`); time is
//!   reported, not asserted (a debug build on a loaded machine is no measure of speed).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::util::{dataset, errmap, json, root, s, stderr, tempdir};

/// `circular simulate` of the example machine into `dir/name.csv`.
fn circular_model(dir: &Path, edit: Option<(&str, &str)>) -> PathBuf {
    let mut text =
        std::fs::read_to_string(root().join("datasets/circular/machine.toml")).expect("model");
    if let Some((from, to)) = edit {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    let p = dir.join("m.toml");
    std::fs::write(&p, text).expect("write");
    p
}

/// `errmap COMMAND… --model M --plan P --out OUT`, which must succeed.
fn simulate(command: &[&str], model: &Path, plan: &Path, out: &Path) {
    let mut args = command.to_vec();
    args.extend(["--model", s(model), "--plan", s(plan), "--out", s(out)]);
    let o = errmap(&args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
}

/// The example volumetric campaign simulated into `dir/lines.csv`.
fn line_table(dir: &Path) -> PathBuf {
    let lines = dir.join("lines.csv");
    let (model, plan) = (
        dataset("volumetric/model.toml"),
        dataset("volumetric/plan.toml"),
    );
    simulate(&["volumetric", "simulate"], &model, &plan, &lines);
    lines
}

#[test]
fn every_file_a_command_writes_is_checked_against_its_inputs() {
    let dir = tempdir();
    // circular simulate --model m.toml --out m.csv: the trace's TOML would be m.toml.
    let model = circular_model(dir.path(), None);
    let before = std::fs::read(&model).expect("read");
    let o = errmap(&[
        "circular",
        "simulate",
        "--model",
        s(&model),
        "--out",
        s(&dir.path().join("m.csv")),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--model"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&model).expect("read"),
        before,
        "the model is intact"
    );
    assert!(!dir.path().join("m.csv").exists());

    // acceptance iso10360 R/measurements.csv --report R: the report writes that file.
    let r = dir.path().join("R");
    std::fs::create_dir(&r).expect("mkdir");
    let input = r.join("measurements.csv");
    std::fs::copy(dataset("acceptance/iso10360-example.csv"), &input).expect("copy");
    let before = std::fs::read(&input).expect("read");
    let o = errmap(&[
        "acceptance",
        "iso10360",
        s(&input),
        "--mpe",
        "2+L/333",
        "--report",
        s(&r),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("measurements.csv") && e.contains("TEST"), "{e}");
    assert_eq!(std::fs::read(&input).expect("read"), before);
    assert!(
        !r.join("report.md").exists(),
        "nothing of the report written"
    );
    // The same test with the report beside its input is written.
    let o = errmap(&[
        "acceptance",
        "iso10360",
        s(&input),
        "--mpe",
        "2+L/333",
        "--report",
        s(&dir.path().join("R2")),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(dir.path().join("R2/measurements.csv").is_file());

    // history report --ledger R/report.md --report R: the ledger would be replaced.
    let h = dir.path().join("H");
    std::fs::create_dir(&h).expect("mkdir");
    let session = dir.path().join("session.csv");
    simulate(
        &["simulate"],
        &dataset("sim/model.toml"),
        &dataset("sim/plan.toml"),
        &session,
    );
    let ledger = h.join("report.md");
    let o = errmap(&[
        "history",
        "add",
        s(&session),
        "--ledger",
        s(&ledger),
        "--machine",
        "M1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&ledger).expect("ledger");
    let o = errmap(&[
        "history",
        "report",
        "--ledger",
        s(&ledger),
        "--report",
        s(&h),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--ledger"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&ledger).expect("ledger"),
        before,
        "the ledger is intact"
    );
}

#[test]
fn two_outputs_on_one_path_and_txt_tables_are_refused() {
    let dir = tempdir();
    let lines = line_table(dir.path());
    let r = dir.path().join("R");
    let o = errmap(&[
        "volumetric",
        "identify",
        s(&lines),
        "--topology",
        "YXZ",
        "--degree",
        "2",
        "--out",
        s(&r.join("model.json")),
        "--report",
        s(&r),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("--out") && e.contains("--report"), "{e}");
    assert!(!r.exists(), "nothing written");
    // A table is CSV or Parquet: a .txt output is refused, and nothing is written.
    let txt = dir.path().join("t.txt");
    let o = errmap(&[
        "table",
        s(&dataset("concealed/clean/recorded.parquet")),
        "--out",
        s(&txt),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("t.txt"), "{}", stderr(&o));
    assert!(!txt.exists());
}

/// A "recording" simulated with the simulation's own noise seed: recorded − simulated
/// has no noise left, and the diagnosis used to state that near-zero σ as the
/// measurement's. It now states at least the recording's own noise (0.5 µm here).
#[test]
fn a_simulation_sharing_the_recordings_noise_does_not_shrink_its_sigma() {
    let dir = tempdir();
    let text = std::fs::read_to_string(dataset("sim/model.toml")).expect("model");
    let table = dataset("table1.csv");
    let base = text
        .replace("noise_um = 0.05", "noise_um = 0.5")
        .replace("\"../table1.csv\"", &format!("{:?}", s(&table)));
    assert!(base.contains("noise_um = 0.5"));
    let recorded_model = format!("{base}\n[reversal]\nenabled = true\nb_um = 3.0\n");
    let (rm, sm) = (dir.path().join("rec.toml"), dir.path().join("sim.toml"));
    std::fs::write(&rm, recorded_model).expect("write");
    std::fs::write(&sm, &base).expect("write");
    let mut sessions = Vec::new();
    for (m, name) in [(&rm, "rec.csv"), (&sm, "sim.csv")] {
        let out = dir.path().join(name);
        simulate(&["simulate"], m, &dataset("sim/plan.toml"), &out);
        sessions.push(out);
    }
    let o = errmap(&[
        "diagnose",
        "--recorded",
        s(&sessions[0]),
        "--simulated",
        s(&sessions[1]),
        "--report",
        s(&dir.path().join("D")),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let d = json(&o);
    let sigma = d["noise_sigma_um"].as_f64().expect("σ");
    assert!(
        (0.35..0.7).contains(&sigma),
        "noise σ {sigma} µm, the recording's own is 0.5 µm"
    );
    // The reversal is still found, with a σ of the recording's noise, not of nothing.
    let rev = d["effects"]
        .as_array()
        .expect("effects")
        .iter()
        .find(|e| e["id"] == "reversal")
        .expect("reversal found");
    let b = rev["params"]["b_um"].as_f64().expect("b");
    let sb = rev["uncertainty"]["b_um"].as_f64().expect("σ b");
    assert!((b - 3.0).abs() < 5.0 * sb + 0.05, "b {b} ± {sb}");
    assert!(sb > 1e-3, "σ of b {sb} µm: the recording's noise");
}

// ---------------------------------------------------------------------------------------
// The campaign.

/// An ISG `kw.ssfk` list that says `bilateral 1` but lacks the negative-direction
/// entries (`table[i].neg`) is a contradiction, refused with the file and the key's line,
/// not read as a bidirectional table (issue 40 item 9); one `neg` missing is refused too,
/// and the list with every `neg` present is read.
#[test]
fn an_isg_list_bilateral_without_its_negative_entries_is_refused() {
    let dir = tempdir();
    let (table, list) = (dir.path().join("t.csv"), dir.path().join("x.lis"));
    simulate(
        &["simulate"],
        &dataset("sim/model.toml"),
        &dataset("sim/plan.toml"),
        &dir.path().join("s.csv"),
    );
    let o = errmap(&["table", s(&dir.path().join("s.csv")), "--out", s(&table)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = errmap(&[
        "export",
        s(&table),
        "--format",
        "isg",
        "--method",
        "trilinear",
        "--step",
        "100",
        "--out",
        s(&list),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&list).expect("list");
    assert!(
        text.contains("kw.ssfk.bilateral                   0"),
        "{text}"
    );
    let bilateral = text.replace(
        "kw.ssfk.bilateral                   0",
        "kw.ssfk.bilateral                   1",
    );
    let import = |name: &str, body: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, body).expect("write");
        let out = dir.path().join(format!("{name}.csv"));
        (errmap(&["import", s(&p), "--out", s(&out)]), out)
    };
    let without_neg: String = bilateral
        .lines()
        .filter(|l| !l.contains("].neg"))
        .map(|l| format!("{l}\n"))
        .collect();
    let without_one: String = bilateral
        .lines()
        .filter(|l| !l.starts_with("kw.ssfk.table[4].neg"))
        .map(|l| format!("{l}\n"))
        .collect();
    for (name, body) in [("none.lis", &without_neg), ("one.lis", &without_one)] {
        let (o, out) = import(name, body);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{name}: {e}");
        assert!(
            e.contains(name) && e.contains("bilateral") && e.contains("table[i].neg"),
            "{name}: {e}"
        );
        assert!(!out.exists(), "{name}: nothing written");
    }
    // Every neg present: a bidirectional table, read.
    let (o, out) = import("both.lis", &bilateral);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.is_file());
    // bilateral 0 without neg entries: one table for both directions, read.
    let (o, _) = import(
        "uni.lis",
        &without_neg.replace(
            "kw.ssfk.bilateral                   1",
            "kw.ssfk.bilateral                   0",
        ),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// One run: its arguments, the files that must stay byte for byte, and the exit status
/// expected when the case decides one.
struct Case {
    what: String,
    args: Vec<String>,
    inputs: Vec<PathBuf>,
    expect: Option<i32>,
}

fn env_num(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// An `.rtl` of either layout, one of its lines mutated.
fn rtl_case(rng: &mut StdRng, dir: &Path) -> Case {
    let genuine = rng.random_bool(0.5);
    let mut lines: Vec<String> = if genuine {
        vec![
            "HEADER::",
            "File type : rtl",
            "Owner : Linear",
            "Version no : 2",
            "",
            "TARGET DATA::",
            "Filetype : Linear",
            "Target-count : 3",
            "Flags : 0 0",
            "Targets :",
            "0.0000  50.0000",
            "100.0000",
            "",
            "RUNS::",
            "Run-count : 2",
            "",
            "DEVIATIONS::",
            "Run Target Data:",
            "1  1  0.5",
            "1  2  1.0",
            "1  3  1.5",
            "2  3  1.6",
            "2  2  1.1",
            "2  1  0.6",
            "",
            "ENVIRONMENT::",
            "Air temp : 20.0 20.2",
            "Env factor : 1 1",
            "Exp coeff : 11.7",
            "Date Time : \"01/01/2021 10:00:00\" \"01/01/2021 10:05:00\"",
            "Final Data : 1",
        ]
    } else {
        vec![
            "HEADER::",
            "File type : rtl",
            "Owner : Linear",
            "",
            "TARGET DATA::",
            "Target-count : 3",
            "Targets : 0 50 100",
            "Flags: 0 0",
            "",
            "RUNS::",
            "Run-count : 2",
            "",
            "DEVIATIONS::",
            "1 1 0.5",
            "1 2 1.0",
            "1 3 1.5",
            "2 3 1.6",
            "2 2 1.1",
            "2 1 0.6",
            "",
            "ENVIRONMENT::",
            "Date Time : \"01/01/2021 10:00:00\" \"01/01/2021 10:05:00\"",
        ]
    }
    .into_iter()
    .map(String::from)
    .collect();
    let k = rng.random_range(0..lines.len());
    let mutation = rng.random_range(0..6);
    let original = lines[k].clone();
    lines[k] = match mutation {
        0 => original.replace('1', "1e300"),
        1 => original.replace(':', ""),
        2 => String::new(),
        3 => original.replace("10:00:00", "25:00:00").replace("2", "9"),
        4 => format!("{original} {original}"),
        _ => original.clone(),
    };
    let path = dir.join("t.rtl");
    std::fs::write(&path, lines.join("\r\n") + "\r\n").expect("write");
    Case {
        what: format!("rtl genuine={genuine} line {k} mutation {mutation}"),
        args: vec![
            "import".into(),
            s(&path).into(),
            "--out".into(),
            s(&dir.join("s.csv")).into(),
        ],
        inputs: vec![path],
        expect: (mutation == 5).then_some(0),
    }
}

/// `acceptance iso10360` with a drawn MPE (plausible or not) and report folder (beside
/// the input, or the input's own folder with the input named as a report file).
fn iso10360_case(rng: &mut StdRng, dir: &Path) -> Case {
    const MPES: [(&str, Option<i32>); 8] = [
        ("2+L/333", None),
        ("min(2+L/333,5)", None),
        ("3", None),
        ("2+L/1e-300", Some(2)),
        ("1e308+L/333", Some(2)),
        ("0", Some(2)),
        ("-1", Some(2)),
        ("2+L/", Some(2)),
    ];
    let (mpe, code) = MPES[rng.random_range(0..MPES.len())];
    let r = dir.join("R");
    std::fs::create_dir_all(&r).expect("mkdir");
    let inside = rng.random_bool(0.4);
    let input = if inside {
        r.join("measurements.csv")
    } else {
        dir.join("m.csv")
    };
    std::fs::copy(dataset("acceptance/iso10360-example.csv"), &input).expect("copy");
    Case {
        what: format!("iso10360 --mpe {mpe} input inside report {inside}"),
        args: vec![
            "acceptance".into(),
            "iso10360".into(),
            s(&input).into(),
            "--mpe".into(),
            mpe.into(),
            "--report".into(),
            s(&r).into(),
        ],
        inputs: vec![input],
        expect: code.or(inside.then_some(1)),
    }
}

/// `circular simulate` of the example machine with one number drawn over 18 decades,
/// sometimes writing its trace beside the model it reads (the TOML would replace it).
fn circular_case(rng: &mut StdRng, dir: &Path) -> Case {
    const KEYS: [&str; 4] = [
        "radius_mm = 100.0",
        "feed_mm_per_min = 1000.0",
        "sample_rate_hz = 100.0",
        "noise_um = 0.15",
    ];
    let key = KEYS[rng.random_range(0..KEYS.len())];
    let value = 10f64.powf(rng.random_range(-6.0..12.0));
    let name = key.split(" = ").next().unwrap_or(key);
    let model = circular_model(dir, Some((key, &format!("{name} = {value:e}"))));
    let alias = rng.random_bool(0.25);
    let out = if alias {
        dir.join("m.csv")
    } else {
        dir.join("trace.csv")
    };
    Case {
        what: format!("circular simulate {name} = {value:e} beside model {alias}"),
        args: vec![
            "circular".into(),
            "simulate".into(),
            "--model".into(),
            s(&model).into(),
            "--out".into(),
            s(&out).into(),
        ],
        inputs: vec![model],
        expect: alias.then_some(1),
    }
}

/// `volumetric identify` of the example campaign at a drawn degree 1–12 (polynomials),
/// sometimes with `--out` inside `--report` (two outputs on one path).
fn identify_case(rng: &mut StdRng, dir: &Path, lines: &Path) -> Case {
    let degree = rng.random_range(1..=12);
    let clash = rng.random_bool(0.25);
    let r = dir.join("R");
    let out = if clash {
        r.join("model.json")
    } else {
        dir.join("model.json")
    };
    Case {
        what: format!("identify --degree {degree} out inside report {clash}"),
        args: vec![
            "volumetric".into(),
            "identify".into(),
            s(lines).into(),
            "--topology".into(),
            "YXZ".into(),
            "--degree".into(),
            degree.to_string(),
            "--out".into(),
            s(&out).into(),
            "--report".into(),
            s(&r).into(),
        ],
        inputs: vec![lines.to_path_buf()],
        expect: Some(if clash { 2 } else { 0 }),
    }
}

/// One bad flag value of one command, drawn from `exit_codes::CASES`: a usage error.
fn flag_case(rng: &mut StdRng, dir: &Path) -> Case {
    let (line, flags) =
        crate::exit_codes::CASES[rng.random_range(0..crate::exit_codes::CASES.len())];
    let (flag, value) = flags[rng.random_range(0..flags.len())];
    let d = root().join("datasets");
    let args = crate::exit_codes::with_flag(line, s(&d), s(dir), flag, value);
    Case {
        what: format!(
            "--{flag}={value} of `{}`",
            line.split(" {").next().unwrap_or(line)
        ),
        args,
        inputs: Vec::new(),
        expect: Some(2),
    }
}

/// `circular diagnose` of the example trace with one sample's `dr_um` mutated (or not).
fn diagnose_case(rng: &mut StdRng, dir: &Path) -> Case {
    let text = std::fs::read_to_string(root().join("datasets/circular/xy.csv")).expect("trace");
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let col = lines[0]
        .split(',')
        .position(|c| c == "dr_um")
        .expect("dr_um column");
    let row = rng.random_range(1..lines.len());
    const VALUES: [&str; 5] = ["NaN", "1e300", "", "-2e4", "keep"];
    let value = VALUES[rng.random_range(0..VALUES.len())];
    if value != "keep" {
        let mut cells: Vec<String> = lines[row].split(',').map(String::from).collect();
        cells[col] = value.to_string();
        lines[row] = cells.join(",");
    }
    let trace = dir.join("xy.csv");
    std::fs::write(&trace, lines.join("\n") + "\n").expect("write");
    std::fs::copy(
        root().join("datasets/circular/xy.toml"),
        dir.join("xy.toml"),
    )
    .expect("copy");
    Case {
        what: format!("circular diagnose dr_um = {value:?} at row {row}"),
        args: vec![
            "circular".into(),
            "diagnose".into(),
            s(&trace).into(),
            "--report".into(),
            s(&dir.join("R")).into(),
        ],
        inputs: vec![trace, dir.join("xy.toml")],
        expect: Some(if value == "keep" { 0 } else { 1 }),
    }
}

#[test]
fn a_seeded_campaign_over_issue_40s_commands_finds_no_panic_and_loses_no_input() {
    let runs = env_num("ERRMAP_CAMPAIGN40_RUNS", 60);
    let seed = env_num("ERRMAP_CAMPAIGN40_SEED", 40);
    let mut rng = StdRng::seed_from_u64(seed);
    let base = tempdir();
    let lines = line_table(base.path());
    let mut statuses: BTreeMap<i32, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut slowest = (Duration::ZERO, String::new());
    for i in 0..runs {
        let dir = base.path().join(format!("run{i}"));
        std::fs::create_dir(&dir).expect("mkdir");
        // Identification and diagnosis are the slow commands: one run in twelve each.
        let case = match rng.random_range(0..12) {
            0..=2 => rtl_case(&mut rng, &dir),
            3..=4 => iso10360_case(&mut rng, &dir),
            5..=6 => circular_case(&mut rng, &dir),
            7..=9 => flag_case(&mut rng, &dir),
            10 => diagnose_case(&mut rng, &dir),
            _ => identify_case(&mut rng, &dir, &lines),
        };
        let kept: Vec<Vec<u8>> = case
            .inputs
            .iter()
            .map(|p| std::fs::read(p).expect("input"))
            .collect();
        let args: Vec<&str> = case.args.iter().map(String::as_str).collect();
        let t = Instant::now();
        let o = errmap(&args);
        let took = t.elapsed();
        if took > slowest.0 {
            slowest = (took, case.what.clone());
        }
        let e = stderr(&o);
        let code = o.status.code();
        *statuses.entry(code.unwrap_or(-1)).or_default() += 1;
        let mut wrong = Vec::new();
        if !matches!(code, Some(0..=2)) {
            wrong.push(format!("exit {:?}", o.status));
        }
        if e.contains("panicked") {
            wrong.push("a panic".into());
        }
        if let (Some(want), Some(got)) = (case.expect, code)
            && want != got
        {
            wrong.push(format!("exit {got}, expected {want}"));
        }
        for (p, bytes) in case.inputs.iter().zip(&kept) {
            if std::fs::read(p).ok().as_ref() != Some(bytes) {
                wrong.push(format!("input {} changed", p.display()));
            }
        }
        if !wrong.is_empty() {
            failures.push(format!(
                "run {i} ({}): {}; stderr: {e}",
                case.what,
                wrong.join(", ")
            ));
        }
    }
    eprintln!(
        "campaign40 seed {seed}: {runs} runs, exit statuses {statuses:?}, panics 0 unless \
         listed below, slowest {:.1} s ({})",
        slowest.0.as_secs_f64(),
        slowest.1
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
