//! Issue 17, inputs and outputs.
//!
//! **The fuzz harness inside `cargo test`**: the targets of `fuzz/` (included by path, the
//! same code the AFL++ binary runs) on the committed corpus, on every input that once
//! broke a reader (`fuzz/regressions/TARGET/`: issue 17's campaign, re-made from
//! errmap's own data, and each crash the fuzzer found), and on a fixed number of seeded
//! mutations of the corpus. Coverage-guided campaigns run in `fuzz/` (`docs/robustness-log.md`, "Fuzzing"); this keeps
//! what they found fixed on every `cargo test`.
//!
//! **Whole outputs**: an error part-way through a command leaves no half-written file, no
//! temporary file and no half-filled new directory.
//!
//! `ERRMAP_FUZZ_MUTATIONS=N` runs N mutations per target instead of the default (a longer
//! uninstrumented campaign without any tool); `ERRMAP_FUZZ_SEED` changes the seed.

#[path = "../../fuzz/src/targets.rs"]
mod targets;

use crate::util::errmap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use targets::Target;

// xorshift64*, the campaign's generator: a small reproducible source for the mutations.
use super::campaign::cases::Rng;

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

/// The files of `dir`, sorted; none when it does not exist.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    v.retain(|p| p.is_file());
    v.sort();
    v
}

fn corpus(t: Target) -> Vec<(PathBuf, Vec<u8>)> {
    files(&fuzz_dir().join("corpus").join(t.name()))
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).expect("reads a corpus file");
            (p, bytes)
        })
        .collect()
}

/// Runs `t` on `data`, turning a panic into an error that names `what` and keeps the
/// input under `target/fuzz-failures/` for `fuzz`'s `replay`.
fn run(t: Target, data: &[u8], what: &str) -> Result<bool, String> {
    catch_unwind(AssertUnwindSafe(|| t.run(data))).map_err(|p| {
        let msg = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-failures");
        let _ = std::fs::create_dir_all(&dir);
        let kept = dir.join(format!("{}-{}", t.name(), what.replace('/', "_")));
        let _ = std::fs::write(&kept, data);
        format!(
            "{} panicked on {what} (kept as {}): {msg}",
            t.name(),
            kept.display()
        )
    })
}

#[test]
fn every_corpus_seed_is_accepted_by_its_reader() {
    // A seed refused at the door only exercises the door; each must reach the parse.
    for t in Target::ALL {
        let seeds = corpus(t);
        assert!(!seeds.is_empty(), "fuzz/corpus/{} is empty", t.name());
        for (p, data) in seeds {
            let accepted =
                run(t, &data, &p.display().to_string()).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                accepted,
                "{}: the {} reader refuses this seed",
                p.display(),
                t.name()
            );
        }
    }
}

/// The controller-table target reads every dialect of the registry; each must also have
/// a seed of its own, or a new dialect's reader is fuzzed from other dialects' bytes only.
#[test]
fn every_dialect_of_the_registry_reads_a_seed_of_the_controller_table_corpus() {
    let seeds = corpus(Target::ControllerTable);
    let formats = targets::controller_formats();
    for d in errmap::controller::DIALECTS {
        let own: Vec<_> = formats.iter().filter(|f| f.name() == d.name()).collect();
        assert!(
            !own.is_empty(),
            "{}: the fuzz target reads no table of it",
            d.name()
        );
        assert!(
            own.iter().any(|f| seeds
                .iter()
                .any(|(_, b)| errmap::controller::read(b, **f).is_ok())),
            "{}: no seed in fuzz/corpus/{}/ is read as its table",
            d.name(),
            Target::ControllerTable.name()
        );
    }
}

#[test]
fn every_input_that_once_broke_a_reader_replays_without_a_panic() {
    let mut failures = Vec::new();
    let mut n = 0;
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(fuzz_dir().join("regressions"))
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    dirs.sort();
    for dir in dirs {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let t = Target::from_name(&name)
            .unwrap_or_else(|| panic!("fuzz/regressions/{name}: no such target"));
        for p in files(&dir) {
            let data = std::fs::read(&p).expect("reads a regression input");
            n += 1;
            if let Err(e) = run(t, &data, &p.display().to_string()) {
                failures.push(e);
            }
        }
    }
    assert!(n > 0, "fuzz/regressions/ holds no input");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Text a table or TOML mutation splices in: the values and tokens that broke readers
/// before (issue 17's campaign), and structure characters.
const TOKENS: [&str; 22] = [
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "-0",
    "4.9e-324",
    "",
    ",",
    "\n",
    "\"",
    "=",
    "[",
    "]",
    "x_mm",
    "e_um",
    "99999999999999999999",
    // Integers that overflowed counts or skipped range checks (issue 28).
    "9223372036854775807",
    "1000000000000000000",
    "-1",
    "0",
    "1e-9",
];

/// One mutation of `data`: a few byte edits, token splices, cuts or line repeats.
fn mutate(rng: &mut Rng, data: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = data.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(v.len() + 1);
        match rng.below(8) {
            0 if !v.is_empty() => {
                let i = at.min(v.len() - 1);
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = at.min(v.len() - 1);
                v[i] = rng.next() as u8;
            }
            2 => {
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                v.splice(at..at, t.iter().copied());
            }
            3 => {
                // replace a field (up to the next separator) by a token
                let end = v[at..]
                    .iter()
                    .position(|b| matches!(b, b',' | b'\n' | b' '))
                    .map_or(v.len(), |k| at + k);
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                v.splice(at..end, t.iter().copied());
            }
            4 => v.truncate(at),
            5 => {
                let len = rng.below(64).min(v.len() - at);
                v.drain(at..at + len);
            }
            6 => {
                // repeat a line (duplicate rows, keys and columns)
                let start = v[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |k| k + 1);
                let end = v[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(v.len(), |k| at + k + 1);
                let line = v[start..end].to_vec();
                v.splice(end..end, line);
            }
            _ if !other.is_empty() => {
                // splice a piece of another seed
                let s = rng.below(other.len());
                let len = rng.below(128).min(other.len() - s);
                v.splice(at..at, other[s..s + len].iter().copied());
            }
            _ => {}
        }
    }
    v
}

#[test]
fn seeded_mutations_of_the_corpus_do_not_panic() {
    let per_target: usize = std::env::var("ERRMAP_FUZZ_MUTATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(150);
    let seed: u64 = std::env::var("ERRMAP_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(17);
    let mut failures = Vec::new();
    for t in Target::ALL {
        let seeds = corpus(t);
        assert!(!seeds.is_empty(), "fuzz/corpus/{} is empty", t.name());
        let mut rng = Rng::from_state(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        for i in 0..per_target {
            let (_, data) = &seeds[rng.below(seeds.len())];
            let (_, other) = &seeds[rng.below(seeds.len())];
            let input = mutate(&mut rng, data, other);
            if let Err(e) = run(t, &input, &format!("mutation-{seed}-{i}")) {
                failures.push(e);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---- whole outputs ----

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("reads the directory")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn gen_concealed_failing_part_way_leaves_no_output_directory() {
    // The first case's directory is made before the bad --table1 is read: before the
    // fix, `out/abbe/` stayed behind after the error.
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("t1.csv");
    std::fs::write(&bad, "x_mm,y_mm,z_mm,e_um\n0,0,0,nan\n").expect("write");
    let out = dir.path().join("cases");
    let o = errmap(&[
        "gen-concealed",
        "--out",
        &out.display().to_string(),
        "--table1",
        &bad.display().to_string(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("t1.csv"), "names the table: {e}");
    assert_eq!(
        names(dir.path()),
        ["t1.csv"],
        "no output and no temporary directory"
    );
}

#[test]
fn a_report_file_that_cannot_be_replaced_leaves_no_temporary_file() {
    // fuzzy-sim's report.md is in the way as a directory: the write fails at the rename,
    // the temporary file beside it is removed and what was there is untouched.
    let dir = tempfile::tempdir().expect("tempdir");
    let report = dir.path().join("r");
    std::fs::create_dir_all(report.join("report.md")).expect("mkdir");
    std::fs::write(report.join("report.md").join("mine.txt"), "mine").expect("write");
    let o = errmap(&[
        "fuzzy-sim",
        "--trials",
        "2",
        "--report",
        &report.display().to_string(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("report.md"), "names the file: {e}");
    assert_eq!(names(&report), ["report.md"], "no temporary file left");
    assert_eq!(names(&report.join("report.md")), ["mine.txt"]);
}

#[test]
fn a_new_iso_report_directory_appears_whole_with_its_figures() {
    // The happy path of the same mechanism: the ISO 230-2 report of `table --report`
    // lands under its name (not the temporary one) with the report and its charts.
    let dir = tempfile::tempdir().expect("tempdir");
    let session = dir.path().join("s.csv");
    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        "axis = \"X\"\nlines_mm = [[1.0, 200.0]]\ntargets_mm = [0.0, 400.0, 800.0]\nruns = 2\n\
         feed_mm_s = 1000.0\ndwell_s = 0.05\nsample_hz = 200.0\nsettle_s = 0.01\naccel_mm_s2 = 10000.0\n",
    )
    .expect("write");
    let o = errmap(&[
        "simulate",
        "--model",
        "datasets/sim/model.toml",
        "--plan",
        &plan.display().to_string(),
        "--out",
        &session.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = dir.path().join("iso");
    let o = errmap(&[
        "table",
        &session.display().to_string(),
        "--out",
        &dir.path().join("t.csv").display().to_string(),
        "--report",
        &report.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(report.join("report.md")).expect("report.md");
    assert!(md.contains("![line 1](line1.png)"), "{md}");
    assert!(report.join("line1.png").exists());
    assert_eq!(names(dir.path()), ["iso", "plan.toml", "s.csv", "t.csv"]);
}
