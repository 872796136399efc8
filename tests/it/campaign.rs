//! Issue 17: a seeded black-box campaign against the built binary, the kind that found
//! the panics, hangs, NaN outputs and silently accepted nonsense of the issue, kept as a
//! test so that a rerun finds none of them again.
//!
//! Every run takes errmap's own inputs (`datasets/`, the real records of
//! `util::real_records_dir` when present, and what `errmap` itself writes from them: a
//! simulated session and its raw capture, a Parquet error table, a volumetric line table
//! and its identified model), mutates one of them, or one command-line value, and runs
//! one command on it. The mutations are those of the campaign: a cell made
//! `nan`/`inf`/`1e308`/`-0`/huge/negative/empty/garbage, a duplicated column name, a
//! dropped, repeated or ragged row, a truncated file, flipped bytes, an unknown,
//! misspelt or repeated TOML key, a numeric TOML value made non-finite or out of range,
//! a bad flag value, an output path that is an input, a closed stdout.
//!
//! Every run must: end within the timeout (a hang is a failure), not panic, not die of a
//! signal (SIGPIPE only when stdout was closed on purpose), exit 0, 1 or 2 as
//! `docs/cli.md` says (2 exactly for a bad flag value, never for a data error), name
//! the mutated file or the flag on stderr when it fails, refuse what must be refused
//! (duplicate columns, unknown or repeated keys, non-finite TOML numbers, ragged rows,
//! repeated session samples, an output that is an input — which must stay intact), leave
//! no new output behind after an error, and write no NaN/inf (nor a JSON `null` where a
//! number belongs) into any output or stdout when it succeeds. All failures are collected
//! and reported together; the inputs of each are kept under `target/campaign-failures/`.
//!
//! `ERRMAP_CAMPAIGN_RUNS` (default 240) and `ERRMAP_CAMPAIGN_SEED` (default 17) set the
//! size and the seed; case `i` of a seed is the same on every machine, so a failure is
//! replayed with `ERRMAP_CAMPAIGN_SEED=S ERRMAP_CAMPAIGN_ONLY=i`.
//! `ERRMAP_CAMPAIGN_TIMEOUT` is the per-run limit in seconds (default 60);
//! `ERRMAP_CAMPAIGN_BIN` runs the campaign against another binary (a release build, or an
//! older one for a before/after count).

use crate::util::root;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

pub(crate) mod cases;

use cases::{Case, Expect, Rng, make_case};

/// The binary under test: `ERRMAP_CAMPAIGN_BIN`, else the one this build made.
fn bin() -> PathBuf {
    std::env::var_os("ERRMAP_CAMPAIGN_BIN").map_or_else(
        || PathBuf::from(env!("CARGO_BIN_EXE_errmap")),
        PathBuf::from,
    )
}

fn env_num(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// The inputs every case starts from (absolute paths).
pub(crate) struct Fixtures {
    pub table1: PathBuf,
    pub table2: PathBuf,
    pub table_parquet: PathBuf,
    pub sessions: Vec<PathBuf>,
    pub session_parquet: PathBuf,
    pub raw: PathBuf,
    pub models: Vec<PathBuf>,
    pub plans: Vec<PathBuf>,
    pub vol_model: PathBuf,
    pub vol_plan: PathBuf,
    pub lines: PathBuf,
    pub vol_json: PathBuf,
    pub info: PathBuf,
}

fn errmap_ok(args: &[&str]) {
    let o = Command::new(bin())
        .args(args)
        .output()
        .expect("runs errmap");
    assert!(
        o.status.success(),
        "fixture `errmap {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A TOML from `datasets/` with its relative `table = "…"` made absolute, so that the
/// copy works from anywhere.
fn absolute_tables(src: &Path, dst: &Path) -> PathBuf {
    let text = std::fs::read_to_string(src).expect("read toml");
    let dir = src.parent().expect("parent");
    let out: String = text
        .lines()
        .map(|l| match l.trim_start().strip_prefix("table = \"") {
            Some(rest) => {
                let rel = rest.split('"').next().unwrap_or("");
                format!("table = \"{}\"", dir.join(rel).display())
            }
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dst, out + "\n").expect("write toml");
    dst.to_path_buf()
}

fn fixtures(dir: &Path) -> Fixtures {
    let ds = root().join("datasets");
    let p = |n: &str| dir.join(n);
    let s = |x: &Path| x.display().to_string();
    let model = absolute_tables(&ds.join("sim/model.toml"), &p("model.toml"));
    let physics = absolute_tables(&ds.join("physics/example-model.toml"), &p("physics.toml"));
    // One run instead of two: the same session shape at half the rows.
    let plan_text = std::fs::read_to_string(ds.join("sim/plan.toml"))
        .expect("plan")
        .replace("runs = 2", "runs = 1");
    std::fs::write(p("plan.toml"), plan_text).expect("write plan");
    errmap_ok(&[
        "simulate",
        "--model",
        &s(&model),
        "--plan",
        &s(&p("plan.toml")),
        "--out",
        &s(&p("session.csv")),
        "--raw",
        &s(&p("raw.bin")),
    ]);
    errmap_ok(&[
        "table",
        &s(&p("session.csv")),
        "--out",
        &s(&p("errors.parquet")),
    ]);
    errmap_ok(&[
        "replay",
        &s(&p("raw.bin")),
        "--out",
        &s(&p("session.parquet")),
    ]);
    errmap_ok(&[
        "volumetric",
        "simulate",
        "--model",
        &s(&ds.join("volumetric/model.toml")),
        "--plan",
        &s(&ds.join("volumetric/plan.toml")),
        "--out",
        &s(&p("lines.csv")),
    ]);
    errmap_ok(&[
        "volumetric",
        "identify",
        &s(&p("lines.csv")),
        "--topology",
        "YXZ",
        "--degree",
        "2",
        "--out",
        &s(&p("vmodel.json")),
    ]);
    let mut sessions = vec![p("session.csv")];
    let real = crate::util::real_records_dir();
    for name in ["b02-x.csv", "wk42-z.csv"] {
        if real.join(name).is_file() {
            sessions.push(real.join(name));
        }
    }
    Fixtures {
        table1: ds.join("table1.csv"),
        table2: ds.join("table2.csv"),
        table_parquet: p("errors.parquet"),
        sessions,
        session_parquet: p("session.parquet"),
        raw: p("raw.bin"),
        models: vec![model, physics],
        plans: vec![p("plan.toml"), ds.join("physics/example-plan.toml")],
        vol_model: ds.join("volumetric/model.toml"),
        vol_plan: ds.join("volumetric/plan.toml"),
        lines: p("lines.csv"),
        vol_json: p("vmodel.json"),
        info: ds.join("certificate/example-info.toml"),
    }
}

// ---- running and judging ----

struct Ran {
    code: Option<i32>,
    signal: Option<i32>,
    stdout: Vec<u8>,
    stderr: String,
    timed_out: bool,
}

fn run(case: &Case, dir: &Path, limit: Duration) -> Ran {
    // An address-space cap makes a runaway allocation an abort we see, not a machine
    // brought down; `exec` keeps the pid errmap's.
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg("ulimit -v 6000000 2>/dev/null; exec \"$0\" \"$@\"")
        .arg(bin())
        .args(&case.args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("spawn errmap");
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let reader = if case.closed_stdout {
        drop(out);
        None
    } else {
        Some(std::thread::spawn(move || {
            let mut b = Vec::new();
            let _ = out.read_to_end(&mut b);
            b
        }))
    };
    let err_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = err.read_to_end(&mut b);
        b
    });
    let start = Instant::now();
    let mut timed_out = false;
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if start.elapsed() > limit {
            timed_out = true;
            let _ = child.kill();
            break child.wait().expect("wait");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stdout = reader
        .map(|r| r.join().unwrap_or_default())
        .unwrap_or_default();
    let stderr = String::from_utf8_lossy(&err_reader.join().unwrap_or_default()).into_owned();
    #[cfg(unix)]
    let signal = std::os::unix::process::ExitStatusExt::signal(&status);
    #[cfg(not(unix))]
    let signal = None;
    Ran {
        code: status.code(),
        signal,
        stdout,
        stderr,
        timed_out,
    }
}

/// The non-finite tokens of a text output: `NaN`, `inf`, `infinity` (any case, any sign),
/// as whole tokens.
fn non_finite_token(text: &str) -> Option<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '_'))
        .find(|t| {
            let l = t.to_ascii_lowercase();
            l == "nan" || l == "inf" || l == "infinity"
        })
        .map(str::to_string)
}

/// JSON keys whose value may be `null`: optional fields, absent rather than NaN (the
/// contract's `order` and `cv_rms_um`, a σ only some models have, sensor readings a
/// session may lack, an effect or a bound that does not apply).
const NULLABLE: &[&str] = &[
    "order",
    "cv_rms_um",
    "sigma_um",
    "tau_s",
    "rate_um_per_s",
    "hello",
    "unexplained",
    "air_temp_c",
    "part_temp_c",
    "scale_temp_c",
    "material_temp_c",
    "alpha_ppm_per_k",
    "sigma_ppm_per_k",
    "grating_period_um",
    "max_dead_path_mm",
    "model_dead_path_mm",
    "probe_offset_mm",
    "length_mm",
    "inside_rms_um",
    "interior_rms_um",
    "cv_interior_rms_um",
    "exterior_rms_um",
    "max_abs_z",
    "n_eff",
    "n_span",
    "noise_moving_um",
    "within_1s",
    "within_2s",
    "t_s",
    "static_map",
    "cv_each",
    "thermal",
    "values",
    "value",
    "sigma",
];

/// The path of a `null` where a number belongs, if any.
fn json_null(v: &serde_json::Value, path: &str) -> Option<String> {
    match v {
        serde_json::Value::Null => Some(path.to_string()),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| json_null(x, &format!("{path}[{i}]"))),
        serde_json::Value::Object(o) => o
            .iter()
            .filter(|(k, _)| !NULLABLE.contains(&k.as_str()))
            .find_map(|(k, x)| json_null(x, &format!("{path}.{k}"))),
        _ => None,
    }
}

/// What is wrong with a successful run's outputs: a NaN/inf token in a text output, a
/// `null` number in a JSON one.
fn bad_output(path: &Path, bytes: &[u8]) -> Option<String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ![
        "csv", "json", "md", "toml", "txt", "tbl", "ngc", "com", "ssfk", "mpf", "",
    ]
    .contains(&ext)
    {
        return None;
    }
    let text = std::str::from_utf8(bytes).ok()?;
    if let Some(t) = non_finite_token(text) {
        return Some(format!("{} holds `{t}`", path.display()));
    }
    let json = ext == "json" || (ext.is_empty() && text.trim_start().starts_with('{'));
    if json
        && let Ok(v) = serde_json::from_str::<serde_json::Value>(text)
        && let Some(p) = json_null(&v, "")
    {
        return Some(format!("{} has null at {p}", path.display()));
    }
    None
}

fn walk(p: &Path, out: &mut Vec<PathBuf>) {
    if p.is_dir() {
        for e in std::fs::read_dir(p).into_iter().flatten().flatten() {
            walk(&e.path(), out);
        }
    } else if p.exists() {
        out.push(p.to_path_buf());
    }
}

/// The failures of one run, in words; none when it behaved.
fn judge(case: &Case, ran: &Ran, dir: &Path, kept: &[(PathBuf, Vec<u8>)]) -> Vec<String> {
    let mut bad = Vec::new();
    let first = ran
        .stderr
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .chars()
        .take(200)
        .collect::<String>();
    if ran.timed_out {
        bad.push("hang (killed at the timeout)".to_string());
        return bad;
    }
    if ran.code == Some(101) || ran.stderr.contains("panicked at") {
        let at = ran
            .stderr
            .lines()
            .find(|l| l.contains("panicked at"))
            .unwrap_or(&first);
        bad.push(format!("panic: {at}"));
        return bad;
    }
    if let Some(sig) = ran.signal {
        if !(case.closed_stdout && sig == 13) {
            bad.push(format!("killed by signal {sig}: {first}"));
        }
        return bad;
    }
    let code = ran.code.unwrap_or(-1);
    let allowed: &[i32] = match (case.expect, case.closed_stdout) {
        (_, true) => &[0, 141],
        (Expect::Data, _) => &[0, 1],
        (Expect::Refuse, _) => &[1],
        (Expect::Usage, _) => &[2],
        (Expect::Flag, _) => &[0, 1, 2],
        (Expect::Alias, _) => &[1, 2],
    };
    if !allowed.contains(&code) {
        let what = match (code, case.expect) {
            (0, Expect::Refuse | Expect::Alias) => "silently accepted",
            (2, _) => "exit 2 for a data error",
            (1, Expect::Usage) => "exit 1 for a bad flag value",
            (0, Expect::Usage) => "bad flag value accepted",
            _ => "unexpected exit code",
        };
        bad.push(format!("{what} (exit {code}): {first}"));
    }
    if code != 0
        && code != 141
        && !case.names.is_empty()
        && !case.names.iter().any(|n| ran.stderr.contains(n.as_str()))
    {
        bad.push(format!("message names none of {:?}: {first}", case.names));
    }
    for (p, bytes) in kept {
        if std::fs::read(p).ok().as_deref() != Some(bytes.as_slice()) {
            bad.push(format!("input {} changed", p.display()));
        }
    }
    if code == 0 {
        if let Some(b) = bad_output(Path::new("<stdout>"), &ran.stdout) {
            bad.push(b);
        }
        let mut files = Vec::new();
        for o in &case.outputs {
            walk(o, &mut files);
        }
        if let Some(b) = files
            .iter()
            .find_map(|p| bad_output(p, &std::fs::read(p).unwrap_or_default()))
        {
            bad.push(format!("non-finite output: {b}"));
        }
    } else if !case.closed_stdout {
        if let Some(o) = case.outputs.iter().find(|o| o.exists()) {
            bad.push(format!("output {} left after the error", o.display()));
        }
        let mut files = Vec::new();
        walk(dir, &mut files);
        let temporary = |p: &&PathBuf| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().contains(".tmp"))
        };
        if let Some(t) = files.iter().find(temporary) {
            bad.push(format!("temporary file {} left", t.display()));
        }
    }
    bad
}

#[test]
fn a_seeded_black_box_campaign_finds_no_panic_hang_nan_or_silent_acceptance() {
    let runs = env_num("ERRMAP_CAMPAIGN_RUNS", 240) as usize;
    let seed = env_num("ERRMAP_CAMPAIGN_SEED", 17);
    let only = std::env::var("ERRMAP_CAMPAIGN_ONLY")
        .ok()
        .and_then(|v| v.parse::<usize>().ok());
    let limit = Duration::from_secs(env_num("ERRMAP_CAMPAIGN_TIMEOUT", 60));
    let tmp = tempfile::tempdir().expect("tempdir");
    let f = fixtures(tmp.path());
    let keep_dir = root().join("target/campaign-failures");
    let next = AtomicUsize::new(only.unwrap_or(0));
    let end = only.map_or(runs, |i| i + 1);
    let failures: Mutex<Vec<(usize, String)>> = Mutex::new(Vec::new());
    let tally: Mutex<std::collections::BTreeMap<String, usize>> = Mutex::new(Default::default());
    let workers = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .min(2);
    let start = Instant::now();
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= end {
                        break;
                    }
                    let dir = tmp.path().join(format!("case-{i}"));
                    std::fs::create_dir_all(&dir).expect("case dir");
                    let mut rng = Rng::new(seed, i as u64);
                    let case = make_case(&mut rng, &f, &dir);
                    // What must survive the run byte for byte: every input in the case
                    // directory (aliases included).
                    let mut inputs = Vec::new();
                    walk(&dir, &mut inputs);
                    let kept: Vec<(PathBuf, Vec<u8>)> = inputs
                        .into_iter()
                        .filter(|p| !p.is_symlink())
                        .map(|p| {
                            let b = std::fs::read(&p).unwrap_or_default();
                            (p, b)
                        })
                        .collect();
                    let ran = run(&case, &dir, limit);
                    let bad = judge(&case, &ran, &dir, &kept);
                    let code = ran
                        .code
                        .map_or_else(|| format!("signal {:?}", ran.signal), |c| c.to_string());
                    *tally
                        .lock()
                        .expect("tally")
                        .entry(format!("exit {code}"))
                        .or_default() += 1;
                    if bad.is_empty() {
                        let _ = std::fs::remove_dir_all(&dir);
                    } else {
                        let keep = keep_dir.join(format!("seed-{seed}-case-{i}"));
                        let _ = std::fs::remove_dir_all(&keep);
                        let _ = std::fs::create_dir_all(&keep);
                        for (p, b) in &kept {
                            if let Some(n) = p.file_name() {
                                let _ = std::fs::write(keep.join(n), b);
                            }
                        }
                        let cmd = format!("errmap {}", case.args.join(" "));
                        let _ = std::fs::write(
                            keep.join("command.txt"),
                            format!("{}\n{cmd}\n", case.label),
                        );
                        let mut fl = failures.lock().expect("failures");
                        for b in bad {
                            fl.push((i, format!("[{}] {b}\n      {cmd}", case.label)));
                        }
                    }
                }
            });
        }
    });
    let mut failures = failures.into_inner().expect("failures");
    failures.sort();
    let tally = tally.into_inner().expect("tally");
    eprintln!(
        "campaign: seed {seed}, {} runs in {:.1} s, {tally:?}, {} failures",
        end - only.unwrap_or(0),
        start.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "{} of the campaign's runs failed (seed {seed}; inputs kept in {}):\n{}",
        failures.len(),
        keep_dir.display(),
        failures
            .iter()
            .map(|(i, f)| format!("  case {i}: {f}"))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// What the campaign once found, pinned: the command (placeholders as in the flag
/// table: `{t1}` `{t2}` error tables, `{s}` a real session, `{l}` a line table, `{vj}` an
/// identified model, `{vp}` a volumetric plan, `{out}`), the exit code, and the words
/// stderr must hold.
const FIXED: &[(&str, i32, &[&str])] = &[
    // A panic (point-count overflow) in a debug build.
    (
        "export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} --start=-1e308",
        2,
        &["--start"],
    ),
    // Non-finite and unbounded coordinates were numbers to clap, then exit 1 or worse.
    (
        "export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --ends clamp --out {out} --reference=inf",
        2,
        &["--reference"],
    ),
    (
        "export {t1} --method spline --format linuxcnc --step 50 --out {out} --at=y=1,y=2",
        2,
        &["--at", "twice"],
    ),
    (
        "plan --axis x --from 0 --to 100 --out {out} --interval=nan",
        2,
        &["--interval"],
    ),
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {out} --random-offset=0.5",
        2,
        &["--random-offset"],
    ),
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {out} --at=y=nan",
        2,
        &["--at"],
    ),
    // Volumetric flag strings were parsed after clap: exit 1.
    (
        "volumetric predict --model {vj} --grid {t2} --out {out} --probe=nan,0,0",
        2,
        &["--probe"],
    ),
    (
        "volumetric export --model {vj} --axis-tables {out} --at=1,2",
        2,
        &["--at"],
    ),
    (
        "volumetric identify {l} --topology YXZ --component-degree=E_XX=-1",
        2,
        &["--component-degree"],
    ),
    ("volumetric identify {l} --topology XXZ", 2, &["--topology"]),
    (
        "volumetric export --model {vj} --axis-tables {out} --points=1",
        2,
        &["--points"],
    ),
    // A hang: degree 40 ran for minutes.
    (
        "volumetric identify {l} --topology YXZ --degree=40",
        2,
        &["--degree"],
    ),
    // Data loss: the certificate and the volumetric outputs overwrote their inputs.
    ("certificate {s} --out {s}", 1, &["--out", "SESSION"]),
    (
        "volumetric identify {l} --topology YXZ --degree 2 --out {l}",
        1,
        &["--out", "LINES"],
    ),
    (
        "volumetric simulate --model {vm} --plan {vp} --out {vp}",
        1,
        &["--out", "--plan"],
    ),
    (
        "volumetric program --plan {vp} --out {vp}",
        1,
        &["--out", "--plan"],
    ),
    (
        "volumetric predict --model {vj} --grid {t2} --out {vj}",
        1,
        &["--out", "--model"],
    ),
    // Flags that do not go together were reported as data errors: exit 1.
    (
        "export {s} --bidirectional --format csv --out {out}",
        2,
        &["--bidirectional"],
    ),
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {out} --at x=5",
        2,
        &["--at"],
    ),
    ("fit {t1} --method lagrange --predict {t2}", 2, &["--order"]),
    ("volumetric predict --model {vj} --grid {t2}", 2, &["--out"]),
    // An export error that named no file.
    (
        "export {one} --method trilinear --format linuxcnc --at y=1,z=200 --step 50 --out {out}",
        1,
        &["one-x.csv"],
    ),
    // A bad Siemens axis name was found only after the table: exit 1.
    (
        "export {t1} --method spline --format siemens --at y=1,z=200 --step 50 --out {out} --siemens-axis=1X",
        2,
        &["--siemens-axis"],
    ),
    // `--methods spline,spline` leaked a polars error about a temporary file.
    (
        "compare {t1} --test {t2} --methods spline,spline --report {rep}",
        0,
        &[],
    ),
    // A damaged Parquet page: a panic inside polars' decoder.
    (
        "fit {damaged} --method trilinear --predict {t2} --out {out}",
        1,
        &["damaged-page.parquet", "damaged Parquet"],
    ),
    // Volumetric inputs beyond the physical bounds gave NaN/inf outputs (caught only by
    // the writers' guard, as a bug that named no input).
    (
        "volumetric predict --model {vj} --lines {far} --json",
        1,
        &["far-lines.csv", "y_mm", "physical range"],
    ),
    // Seed 13: a one-sigma of 1e-320 µm made the weights inf and the identification's
    // JSON (stdout and --out) carry nulls where NaNs had been.
    (
        "volumetric identify {tinys} --topology YXZ --degree 2 --out {out} --json",
        1,
        &["tiny-s-lines.csv", "s_um", "physical range"],
    ),
    (
        "volumetric predict --model {huge} --grid {t2} --out {out}",
        1,
        &["huge-coefficient.toml", "E_XX"],
    ),
    (
        "volumetric predict --model {tiny} --grid {t2} --out {out}",
        1,
        &["tiny-scale.toml", "scale_mm"],
    ),
    (
        "volumetric simulate --model {vm} --plan {slow} --out {out}",
        1,
        &["slow-plan.toml", "feed_mm_s"],
    ),
    (
        "volumetric simulate --model {vm} --plan {flat} --out {out}",
        1,
        &["flat-plan.toml", "volume_mm"],
    ),
    // Table 1 with every error 0: σ = 0 gave z = inf in compare's JSON (a bug message,
    // and the report directory was left behind).
    (
        "compare {zero} --test {t2} --methods trilinear,spline --report {rep2} --json",
        0,
        &[],
    ),
    // Seeds 17 and 19: a Parquet footer with flipped bits panicked in polars' Thrift
    // decoder (`thrift bool field`).
    (
        "fit {footer} --method trilinear --predict {t2} --out {out}",
        1,
        &["damaged-footer.parquet", "damaged Parquet"],
    ),
    // Seed 29: two flipped bits in a session table gave a frame whose `y_mm` held no
    // value for 2 845 rows (an index panic in the cell reader). A debug build's polars
    // asserts in its page decoder first: either way an error naming the damage.
    (
        "table {column} --out {out}",
        1,
        &["damaged-column.parquet", "damaged"],
    ),
    // Seed 47: a session whose rows are all outside any run has lines without
    // coordinates; the diagnosis report printed them as `y = NaN mm` (refused as a bug).
    // Issue 28: no line was measured, so there is nothing to diagnose: refused.
    (
        "diagnose --recorded {outside} --model {model} --report {rep3} --json",
        1,
        &["outside-runs.csv", "inside a run"],
    ),
    (
        "diagnose --recorded {interleaved} --model {model} --report {rep3} --json",
        1,
        &["interleaved.csv", "change axis"],
    ),
    // Issue 28: two outputs on one path; plan's out-of-range flags exited 1; line
    // positions on the line's own axis or empty; unbounded counts and integers that skipped
    // the range checks; an output under a missing directory made the tree.
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {out} --program {out}",
        2,
        &["--out", "--program"],
    ),
    (
        "plan --axis x --from 0 --to 100 --out {out} --targets=1",
        2,
        &["--targets"],
    ),
    (
        "plan --axis x --from 800 --to 0 --targets 5 --out {out}",
        2,
        &["--to"],
    ),
    (
        "plan --axis x --from 0 --to 100 --out {out} --interval=1e-12",
        2,
        &["--interval"],
    ),
    (
        "export {t1} --method trilinear --format csv --step 50 --out {out} --at=x=5",
        2,
        &["--at", "axis of the line"],
    ),
    (
        // Seed 72, case 7550: a model's grating period of 0 reached the diagnosis, whose
        // refusal named the session instead of the model.
        "diagnose --recorded {s} --model {nograting} --report {rep3} --json",
        1,
        &["no-grating.toml", "grating_period_nm"],
    ),
    (
        // Seed 71, case 1226: the refusal named --at only, not the --axis it clashes with.
        "export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} --axis=z",
        2,
        &["--axis", "--at"],
    ),
    (
        "export {t1} --method trilinear --format csv --step 50 --out {out} --at=,,,",
        2,
        &["--at"],
    ),
    (
        "volumetric identify {l} --topology YXZ --positions=1000000000",
        2,
        &["--positions"],
    ),
    (
        "volumetric simulate --model {vm} --plan {bigt} --out {out}",
        1,
        &["big-targets.toml", "targets"],
    ),
    (
        "volumetric simulate --model {vm} --plan {hugeint} --out {out}",
        1,
        &["huge-int-targets.toml", "targets"],
    ),
    (
        "volumetric simulate --model {intm} --plan {vp} --out {out}",
        1,
        &["int-coefficient.toml", "E_C0Y"],
    ),
    (
        "volumetric predict --model {intm} --grid {t2} --out {out}",
        1,
        &["int-coefficient.toml", "E_C0Y"],
    ),
    (
        "plan --axis x --from 0 --to 100 --targets 5 --out {missing}",
        1,
        &["no-such-dir"],
    ),
    // A model whose error table is missing named only the table.
    (
        "simulate --model {lost} --plan {plan} --out {out}",
        1,
        &["lost-table.toml", "error_map.table", "no-such-table.csv"],
    ),
];

/// A CSV text with `edit` applied to every line after the header.
fn data_rows(text: &str, edit: impl Fn(&str) -> String) -> String {
    let mut out: Vec<String> = Vec::new();
    for (i, l) in text.lines().enumerate() {
        out.push(if i == 0 { l.to_string() } else { edit(l) });
    }
    out.join("\n") + "\n"
}

#[test]
fn what_the_campaign_found_stays_fixed() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let f = fixtures(tmp.path());
    let d = tmp.path();
    // Inputs that a run could destroy are copies.
    let copy = |src: &Path, name: &str| {
        let p = d.join(name);
        std::fs::copy(src, &p).expect("copy");
        p
    };
    let session = copy(&f.sessions[f.sessions.len() - 1], "s.csv");
    let lines = copy(&f.lines, "l.csv");
    let vj = copy(&f.vol_json, "vj.json");
    let vp = copy(&f.vol_plan, "vp.toml");
    // Table 1's nodes at its first x only: a line along x has no length.
    let t1 = std::fs::read_to_string(&f.table1).expect("table1");
    let one_x: String = t1
        .lines()
        .filter(|l| l.starts_with("x_mm") || l.starts_with("1.2424,"))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(d.join("one-x.csv"), one_x + "\n").expect("write");
    let mut far: Vec<String> = std::fs::read_to_string(&f.lines)
        .expect("lines")
        .lines()
        .map(str::to_string)
        .collect();
    let mut cells: Vec<String> = far[2].split(',').map(str::to_string).collect();
    cells[2] = "1.7976931348623157e308".into();
    far[2] = cells.join(",");
    std::fs::write(d.join("far-lines.csv"), far.join("\n") + "\n").expect("write");
    // A one-sigma of 1e-320 µm: its weight 1/σ is inf.
    let mut tiny_s: Vec<String> = std::fs::read_to_string(&f.lines)
        .expect("lines")
        .lines()
        .map(str::to_string)
        .collect();
    let s_col = tiny_s[0]
        .split(',')
        .position(|c| c == "s_um")
        .expect("the line table has s_um");
    let mut cells: Vec<String> = tiny_s[3].split(',').map(str::to_string).collect();
    cells[s_col] = "1e-320".into();
    tiny_s[3] = cells.join(",");
    std::fs::write(d.join("tiny-s-lines.csv"), tiny_s.join("\n") + "\n").expect("write");
    let model = |poly: &str| format!("topology = \"YXZ\"\n[components]\nE_XX = {{ {poly} }}\n");
    std::fs::write(d.join("huge-coefficient.toml"), model("poly = [1e308]")).expect("write");
    std::fs::write(
        d.join("tiny-scale.toml"),
        model("poly = [1.0], scale_mm = 5e-324"),
    )
    .expect("write");
    let plan = std::fs::read_to_string(&f.vol_plan).expect("plan");
    let slow = plan.replace("feed_mm_s = 20.0", "feed_mm_s = 5e-324");
    assert_ne!(slow, plan);
    std::fs::write(d.join("slow-plan.toml"), slow).expect("write");
    let zero = data_rows(&t1, |l| match l.rsplit_once(',') {
        Some((head, _)) => format!("{head},0"),
        None => l.to_string(),
    });
    std::fs::write(d.join("zero.csv"), zero).expect("write");
    let flat = plan.replace("[800.0, 600.0, 400.0]", "[800.0, 5e-324, 400.0]");
    assert_ne!(flat, plan);
    std::fs::write(d.join("flat-plan.toml"), flat).expect("write");
    // Every row outside any run (run = 0): no MARK gives the line's coordinates.
    let session_text = std::fs::read_to_string(&f.sessions[0]).expect("session");
    let outside = data_rows(&session_text, |l| match l.split_once(',') {
        Some((_, rest)) => format!("0,{rest}"),
        None => l.to_string(),
    });
    std::fs::write(d.join("outside-runs.csv"), outside).expect("write");
    // Rows alternating between axes X and Y.
    let header: Vec<&str> = session_text
        .lines()
        .next()
        .expect("header")
        .split(',')
        .collect();
    let axis_col = header.iter().position(|c| *c == "axis").expect("axis");
    let flip = std::cell::Cell::new(false);
    let interleaved = data_rows(&session_text, |l| {
        flip.set(!flip.get());
        let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
        if flip.get() {
            let other = if cells[axis_col].eq_ignore_ascii_case("x") {
                "Y"
            } else {
                "X"
            };
            cells[axis_col] = other.into();
        }
        cells.join(",")
    });
    std::fs::write(d.join("interleaved.csv"), interleaved).expect("write");
    let bigt = plan.replace("targets = 11", "targets = 5000");
    assert_ne!(bigt, plan);
    std::fs::write(d.join("big-targets.toml"), bigt).expect("write");
    let hugeint = plan.replace("targets = 11", "targets = 9223372036854775807");
    std::fs::write(d.join("huge-int-targets.toml"), hugeint).expect("write");
    let vmodel = std::fs::read_to_string(&f.vol_model).expect("model");
    let intm = vmodel.replace("E_C0Y = 8.0", "E_C0Y = 1000000000000000000");
    assert_ne!(intm, vmodel);
    std::fs::write(d.join("int-coefficient.toml"), intm).expect("write");
    let model = std::fs::read_to_string(&f.models[0]).expect("model");
    let no_grating = model.replace("grating_period_nm = 20000", "grating_period_nm = 0");
    assert_ne!(no_grating, model);
    std::fs::write(d.join("no-grating.toml"), no_grating).expect("write");
    let lost = "[error_map]\ntable = \"no-such-table.csv\"\nmethod = \"spline\"\n";
    std::fs::write(d.join("lost-table.toml"), lost).expect("write");
    let vars = [
        ("t1", f.table1.clone()),
        ("t2", f.table2.clone()),
        ("s", session.clone()),
        ("l", lines.clone()),
        ("vj", vj.clone()),
        ("vm", f.vol_model.clone()),
        ("vp", vp.clone()),
        ("one", d.join("one-x.csv")),
        ("far", d.join("far-lines.csv")),
        ("tinys", d.join("tiny-s-lines.csv")),
        ("huge", d.join("huge-coefficient.toml")),
        ("tiny", d.join("tiny-scale.toml")),
        ("slow", d.join("slow-plan.toml")),
        ("flat", d.join("flat-plan.toml")),
        ("zero", d.join("zero.csv")),
        ("lost", d.join("lost-table.toml")),
        ("bigt", d.join("big-targets.toml")),
        ("hugeint", d.join("huge-int-targets.toml")),
        ("intm", d.join("int-coefficient.toml")),
        ("nograting", d.join("no-grating.toml")),
        ("missing", d.join("no-such-dir/p.toml")),
        ("plan", f.plans[0].clone()),
        ("damaged", root().join("tests/it/data/damaged-page.parquet")),
        (
            "column",
            root().join("tests/it/data/damaged-column.parquet"),
        ),
        ("outside", d.join("outside-runs.csv")),
        ("interleaved", d.join("interleaved.csv")),
        ("model", f.models[0].clone()),
        ("rep3", d.join("rep3")),
        (
            "footer",
            root().join("tests/it/data/damaged-footer.parquet"),
        ),
        ("rep", d.join("rep")),
        ("rep2", d.join("rep2")),
        ("out", d.join("out.csv")),
    ];
    let before: Vec<Vec<u8>> = [&session, &lines, &vj, &vp]
        .iter()
        .map(|p| std::fs::read(p).expect("read"))
        .collect();
    let mut bad = Vec::new();
    for &(template, code, words) in FIXED {
        let args: Vec<String> = template
            .split_whitespace()
            .map(|w| {
                vars.iter().fold(w.to_string(), |w, (k, v)| {
                    w.replace(&format!("{{{k}}}"), &v.display().to_string())
                })
            })
            .collect();
        let o = Command::new(bin())
            .args(&args)
            .output()
            .expect("runs errmap");
        let e = String::from_utf8_lossy(&o.stderr);
        let fine = o.status.code() == Some(code) && !e.contains("panicked");
        if !fine || !words.iter().all(|w| e.contains(w)) {
            bad.push(format!(
                "{template}: exit {:?}, {}",
                o.status.code(),
                e.trim()
            ));
        }
    }
    for (p, b) in [&session, &lines, &vj, &vp].iter().zip(&before) {
        if std::fs::read(p).ok().as_ref() != Some(b) {
            bad.push(format!("{} changed", p.display()));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Seed 19: a line table whose errors are all exactly 0 left no residual, so every
/// campaign term had σ = 0 and t = inf — a drift "found" with |ρ|/σ = inf, written into
/// the identification's JSON. Nothing is left to explain: no effect, no `inf`.
#[test]
fn a_line_table_of_exact_zeros_identifies_no_campaign_term() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let f = fixtures(tmp.path());
    let text = std::fs::read_to_string(&f.lines).expect("lines");
    let mut rows = text.lines();
    let header = rows.next().expect("header");
    let e_col = header
        .split(',')
        .position(|c| c == "e_um")
        .expect("the line table has e_um");
    let zeros: Vec<String> = std::iter::once(header.to_string())
        .chain(rows.map(|r| {
            let mut cells: Vec<&str> = r.split(',').collect();
            cells[e_col] = "0";
            cells.join(",")
        }))
        .collect();
    let lines = tmp.path().join("zero-lines.csv");
    std::fs::write(&lines, zeros.join("\n") + "\n").expect("write");
    let out = tmp.path().join("model.json");
    let o = Command::new(env!("CARGO_BIN_EXE_errmap"))
        .args(["volumetric", "identify"])
        .arg(&lines)
        .args(["--topology", "YXZ", "--degree", "2", "--json", "--out"])
        .arg(&out)
        .output()
        .expect("runs errmap");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let written = std::fs::read_to_string(&out).expect("model written");
    for (what, text) in [
        ("stdout", stdout.as_ref()),
        ("model.json", written.as_str()),
    ] {
        assert!(!text.contains("inf"), "{what} holds `inf`: {text}");
    }
    let doc: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    let effects = doc["residual"]["effects"].as_array().map_or(0, Vec::len);
    assert_eq!(
        effects, 0,
        "effects found in exact zeros: {}",
        doc["residual"]
    );
}
