//! The ledger after a crash (issue 41): a writer that died inside its transaction leaves
//! SQLite's rollback journal, and every command that opens the ledger rolls it back and
//! reads; reads during an add see whole records; a damaged file is named as damaged.
//! And the ledger's own rules on test times, amendment reasons and instants (issue 40).

use std::path::Path;
use std::process::{Command, Output};

use errmap::base::Axis;
use errmap::history::{CLOCK_SKEW_S, format_utc, now_utc};

use crate::history::{
    add, add_ok, assert_whole, model_json, records, scalar, session, stalled_add, write_session,
};
use crate::util::{errmap, stderr, tempdir};

/// `history verify --json`: its output and its document.
pub(super) fn verify(ledger: &str) -> (Output, serde_json::Value) {
    let o = errmap(&["history", "verify", "--ledger", ledger, "--json"]);
    let v = serde_json::from_slice(&o.stdout).unwrap_or(serde_json::Value::Null);
    (o, v)
}

/// `history report --json` into a new folder `dir/name`: its output and its document.
pub(super) fn report(ledger: &str, dir: &Path, name: &str) -> (Output, serde_json::Value) {
    let out = dir.join(name);
    let o = errmap(&[
        "history",
        "report",
        "--ledger",
        ledger,
        "--report",
        out.to_str().expect("utf-8"),
        "--json",
    ]);
    let v = serde_json::from_slice(&o.stdout).unwrap_or(serde_json::Value::Null);
    (o, v)
}

/// A ledger of a few committed records: three monthly X sessions of A, a model of B.
fn small_ledger(dir: &Path) -> String {
    let ledger = dir.join("l.sqlite").display().to_string();
    fill(&ledger, dir);
    ledger
}

/// The records of [`small_ledger`] added to `ledger`.
fn fill(ledger: &str, dir: &Path) {
    let ledger = ledger.to_string();
    for (i, at) in ["2025-01-10", "2025-02-10", "2025-03-10"]
        .iter()
        .enumerate()
    {
        let f = write_session(
            dir,
            &format!("a{i}.csv"),
            &session(Axis::X, &[(0.0, 0.0)], 2.0 + i as f64, 40 + i as u64),
        );
        add_ok(&ledger, &f, "A", &["--at", at]);
    }
    add_ok(
        &ledger,
        &model_json(dir, "b.json", 3.0, 1.0),
        "B",
        &["--at", "2025-03-11"],
    );
}

/// A Python `sqlite3` writer that takes the ledger's write lock, inserts a record and
/// enough line statistics to spill its 4-page cache into the file, and dies without a
/// word (`os._exit`): the journal is left hot beside a file that holds half a transaction.
const SPILL_AND_DIE: &str = r#"
import os, sqlite3, sys
con = sqlite3.connect(sys.argv[1], isolation_level=None)
con.execute("PRAGMA cache_size = 4")
con.execute("BEGIN IMMEDIATE")
cur = con.execute("INSERT INTO record (machine, state, at, kind, added_at, errmap_version) "
                  "VALUES ('P', 'as-found', '2025-06-01T00:00:00Z', 'session', '2025-06-01T00:00:00Z', 'python')")
rid = cur.lastrowid
for i in range(20000):
    con.execute("INSERT INTO line_stat (record, axis, line_1_mm, line_2_mm, parameter, value, u_um) "
                "VALUES (?, 'X', ?, 0, 'E', 1.0, 0.1)", (rid, float(i)))
os._exit(0)
"#;

#[test]
fn verify_and_report_roll_back_a_dead_writers_journal() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    let before = records(&ledger);
    let sources = scalar(&ledger, "SELECT COUNT(*) FROM source");
    let bytes = std::fs::read(&ledger).expect("read ledger");
    let run = Command::new("python3")
        .args(["-c", SPILL_AND_DIE, &ledger])
        .output();
    let Ok(run) = run else {
        eprintln!("SKIPPED verify_and_report_roll_back_a_dead_writers_journal: no python3");
        return;
    };
    assert!(run.status.success(), "{}", stderr(&run));
    let journal = format!("{ledger}-journal");
    assert!(
        std::fs::metadata(&journal).is_ok_and(|m| m.len() > 0),
        "the writer left its journal"
    );
    assert_ne!(
        std::fs::read(&ledger).expect("read ledger"),
        bytes,
        "the spilled cache reached the file: half a transaction is in it"
    );
    let (o, v) = verify(&ledger);
    assert!(o.status.success(), "verify: {}", stderr(&o));
    assert!(!stderr(&o).contains("not a ledger"), "{}", stderr(&o));
    assert_eq!(v["checked"].as_i64(), Some(sources));
    assert_eq!(v["damage"].as_array().map(Vec::len), Some(0), "{v}");
    assert!(!Path::new(&journal).exists(), "the journal was rolled back");
    let (o, r) = report(&ledger, dir.path(), "r1");
    assert!(o.status.success(), "report: {}", stderr(&o));
    assert_eq!(
        r["ledger"]["records"].as_i64(),
        Some(before),
        "{}",
        r["ledger"]
    );
    assert_eq!(
        records(&ledger),
        before,
        "every committed record kept, the dead one gone"
    );
    assert_whole(&ledger);
    assert_eq!(
        scalar(
            &ledger,
            "SELECT COUNT(*) FROM line_stat WHERE u_um = 0.1 AND value = 1.0 AND line_2_mm = 0 AND parameter = 'E' AND line_1_mm > 1000"
        ),
        0
    );
    // The same with the report first, on a second dead writer.
    let run = Command::new("python3")
        .args(["-c", SPILL_AND_DIE, &ledger])
        .output()
        .expect("python3");
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(Path::new(&journal).exists());
    let (o, r) = report(&ledger, dir.path(), "r2");
    assert!(o.status.success(), "report: {}", stderr(&o));
    assert_eq!(r["ledger"]["records"].as_i64(), Some(before));
    let (o, _) = verify(&ledger);
    assert!(o.status.success(), "verify: {}", stderr(&o));
    // And the ledger goes on.
    let f = write_session(
        dir.path(),
        "a9.csv",
        &session(Axis::X, &[(0.0, 0.0)], 9.0, 49),
    );
    add_ok(&ledger, &f, "A", &["--at", "2025-04-10"]);
    assert_eq!(records(&ledger), before + 1);
    assert_whole(&ledger);
}

#[test]
fn a_damaged_ledger_is_named_damaged_with_what_the_check_found() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    // A b-tree page overwritten (page 1, the schema, left whole).
    let mut bytes = std::fs::read(&ledger).expect("read");
    let page = 4096;
    assert!(bytes.len() >= 4 * page, "{} bytes", bytes.len());
    bytes[2 * page..3 * page].fill(0x5a);
    let broken = dir.path().join("broken.sqlite");
    std::fs::write(&broken, &bytes).expect("write");
    let broken = broken.display().to_string();
    let (o, v) = verify(&broken);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("damaged") && !e.contains("not a ledger"), "{e}");
    if let Some(d) = v["damage"].as_array() {
        assert!(!d.is_empty(), "{v}");
    }
    // A file that is no database at all.
    let text = dir.path().join("notes.sqlite");
    std::fs::write(&text, "these are my notes, not a database\n".repeat(200)).expect("write");
    let (o, _) = verify(text.to_str().expect("utf-8"));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("damaged"), "{}", stderr(&o));
}

#[test]
fn reads_during_an_add_see_only_whole_records() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    let before = records(&ledger);
    let big: Vec<(f64, f64)> = (0..40).map(|i| (0.0, 10.0 * i as f64)).collect();
    let f = write_session(dir.path(), "k.csv", &session(Axis::Y, &big, 2.0, 77));
    let (mut child, line) = stalled_add(
        &ledger,
        &f,
        &["--machine", "A", "--at", "2025-04-01"],
        &[("ERRMAP_HISTORY_STALL_MS", "4000")],
    );
    assert!(line.contains("row written"), "{line}");
    // The add holds its lock, its record row written and the rest pending.
    let (o, r) = report(&ledger, dir.path(), "during");
    assert!(o.status.success(), "{}", stderr(&o));
    let seen = r["ledger"]["records"].as_i64().expect("records");
    let (o, v) = verify(&ledger);
    assert!(o.status.success(), "{}", stderr(&o));
    let status = child.wait().expect("wait");
    assert!(status.success());
    // A reader saw the ledger before the add or after it, never in between.
    assert!(seen == before || seen == before + 1, "{seen}");
    let per_record = |n: i64| {
        scalar(
            &ledger,
            &format!(
                "SELECT COUNT(*) FROM source WHERE record IN (SELECT id FROM record ORDER BY id LIMIT {n})"
            ),
        )
    };
    let checked = v["checked"].as_i64().expect("checked");
    assert!(
        checked == per_record(before) || checked == per_record(before + 1),
        "{checked}"
    );
    let lines = r["machines"]
        .as_array()
        .expect("machines")
        .iter()
        .find(|m| m["id"] == "A")
        .map(|m| m["records"].as_i64().unwrap_or(0));
    assert_eq!(
        lines,
        Some(3 + seen - before),
        "machine A's records in the report"
    );
    eprintln!(
        "reads during an add: the report saw {} records ({} before the add)",
        seen, before
    );
    assert_eq!(records(&ledger), before + 1);
    assert_whole(&ledger);
}

#[test]
fn test_times_outside_the_window_are_refused_and_never_move_the_report_date() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    let before = records(&ledger);
    let f = write_session(
        dir.path(),
        "w.csv",
        &session(Axis::Z, &[(0.0, 0.0)], 1.0, 60),
    );
    for at in [
        "2999-01-01",
        "9999-12-31",
        "0001-01-01",
        "1969-12-31T23:59:59Z",
    ] {
        // A flag's value outside its range: a usage error (docs/cli.md's one rule).
        let o = add(&ledger, &f, "A", &["--at", at]);
        assert_eq!(o.status.code(), Some(2), "{at}: {}", stderr(&o));
        assert!(stderr(&o).contains("outside the window"), "{}", stderr(&o));
        assert!(stderr(&o).contains(&at[..10]), "{}", stderr(&o));
    }
    let late = format_utc(now_utc() + CLOCK_SKEW_S + 120);
    let o = add(&ledger, &f, "A", &["--at", &late]);
    assert_eq!(o.status.code(), Some(2), "{late}: {}", stderr(&o));
    assert_eq!(records(&ledger), before);
    // Inside the clock skew: taken.
    let soon = format_utc(now_utc() + CLOCK_SKEW_S - 600);
    add_ok(&ledger, &f, "A", &["--at", &soon]);
    let (o, r) = report(&ledger, dir.path(), "r0");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(r["as_of"], soon.as_str());
    // A record dated in the future, written before the ledger refused such dates (here
    // by hand: a copy of record 1 dated 2999): the default date does not move, and
    // verify names it.
    let c = rusqlite::Connection::open(&ledger).expect("open");
    c.execute_batch(
        "INSERT INTO record (machine, site, state, at, kind, added_at, errmap_version) \
         SELECT machine, site, state, '2999-01-01T00:00:00Z', kind, '2025-01-10T00:00:00Z', errmap_version \
         FROM record WHERE id = 1; \
         INSERT INTO source SELECT last_insert_rowid(), role, path, sha256, bytes FROM source WHERE record = 1; \
         INSERT INTO line_stat SELECT (SELECT MAX(id) FROM record), axis, line_1_mm, line_2_mm, parameter, value, u_um \
         FROM line_stat WHERE record = 1;",
    )
    .expect("insert by hand");
    let future = scalar(&ledger, "SELECT MAX(id) FROM record");
    drop(c);
    assert_whole(&ledger);
    let (o, r) = report(&ledger, dir.path(), "r1");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        r["as_of"],
        soon.as_str(),
        "the future record moved the date"
    );
    let (o, v) = verify(&ledger);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let damage = v["damage"].as_array().expect("damage");
    assert_eq!(damage.len(), 1, "{v}");
    assert_eq!(damage[0]["record"].as_i64(), Some(future));
    assert!(stderr(&o).contains("2999-01-01"), "{}", stderr(&o));
    // Amended with its true date, the ledger is sound again.
    let a0 = dir.path().join("a0.csv");
    let future_s = future.to_string();
    add_ok(
        &ledger,
        &a0,
        "A",
        &[
            "--supersede",
            &future_s,
            "--reason",
            "dated 2999 by mistake",
            "--at",
            "2025-01-11",
        ],
    );
    let (o, _) = verify(&ledger);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn an_amendment_needs_a_reason() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    let before = records(&ledger);
    let f = dir.path().join("a1.csv");
    for reason in ["", "   ", "\t"] {
        let o = add(&ledger, &f, "A", &["--supersede", "2", "--reason", reason]);
        // A flag's value: a usage error (docs/cli.md's one rule); the library refuses it
        // too (HistoryError::EmptyReason) for callers other than the command line.
        assert_eq!(o.status.code(), Some(2), "{reason:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("gives its reason"), "{}", stderr(&o));
    }
    assert_eq!(records(&ledger), before);
    add_ok(
        &ledger,
        &f,
        "A",
        &["--supersede", "2", "--reason", "wrong machine"],
    );
}

#[test]
fn one_current_record_per_machine_axis_state_and_instant() {
    let dir = tempdir();
    let ledger = small_ledger(dir.path());
    let at = ["--at", "2025-03-10"];
    // A second X test of A at the instant of record 3 (date-only times are 00:00Z).
    let x2 = write_session(
        dir.path(),
        "x2.csv",
        &session(Axis::X, &[(0.0, 0.0)], 5.0, 80),
    );
    let o = add(&ledger, &x2, "A", &at);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("record 3") && e.contains("2025-03-10T00:00:00Z"),
        "{e}"
    );
    // With its time of day, it is another test.
    add_ok(&ledger, &x2, "A", &["--at", "2025-03-10T14:00:00Z"]);
    // The as-left test after an adjustment at the same instant, another axis, another
    // machine: taken.
    let x3 = write_session(
        dir.path(),
        "x3.csv",
        &session(Axis::X, &[(0.0, 0.0)], 1.0, 81),
    );
    add_ok(
        &ledger,
        &x3,
        "A",
        &["--at", "2025-03-10", "--state", "as-left"],
    );
    let y = write_session(
        dir.path(),
        "y.csv",
        &session(Axis::Y, &[(0.0, 0.0)], 1.0, 82),
    );
    add_ok(&ledger, &y, "A", &at);
    let x4 = write_session(
        dir.path(),
        "x4.csv",
        &session(Axis::X, &[(0.0, 0.0)], 1.0, 83),
    );
    add_ok(&ledger, &x4, "C", &at);
    // An amendment of record 3 keeps its instant.
    let x5 = write_session(
        dir.path(),
        "x5.csv",
        &session(Axis::X, &[(0.0, 0.0)], 2.5, 84),
    );
    add_ok(
        &ledger,
        &x5,
        "A",
        &[
            "--at",
            "2025-03-10",
            "--supersede",
            "3",
            "--reason",
            "wrong file",
        ],
    );
    // Two models of B at one instant.
    let o = add(
        &ledger,
        &model_json(dir.path(), "b2.json", 4.0, 2.0),
        "B",
        &["--at", "2025-03-11"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("axis XYZ"), "{}", stderr(&o));
    assert_whole(&ledger);
}

// ---------------------------------------------------------------- every write point

/// The records up to `last` as text: each one's row and the number and sum of its
/// statistics, sources and components (what a crash must leave unchanged).
fn committed(ledger: &str, last: i64) -> String {
    if ledger.starts_with("postgres") {
        let mut c = postgres::Client::connect(ledger, postgres::NoTls).expect("connect");
        return c
            .query_one(
                "SELECT string_agg(x, ';' ORDER BY id) FROM (SELECT r.id, r.id || ' ' || r.machine || ' ' || r.at || ' ' || r.state || ' ' || \
                 (SELECT COUNT(*) || ' ' || COALESCE(SUM(value), 0) FROM line_stat l WHERE l.record = r.id) || ' ' || \
                 (SELECT COUNT(*) || ' ' || COALESCE(string_agg(sha256, ','), '') FROM source s WHERE s.record = r.id) || ' ' || \
                 (SELECT COUNT(*) || ' ' || COALESCE(SUM(value), 0) FROM component c WHERE c.record = r.id) AS x \
                 FROM record r WHERE r.id <= $1) t",
                &[&last],
            )
            .expect("committed records")
            .get::<_, String>(0);
    }
    let c = rusqlite::Connection::open(ledger).expect("open");
    c.query_row(
        "SELECT group_concat(x, ';') FROM (SELECT r.id || ' ' || r.machine || ' ' || r.at || ' ' || r.state || ' ' || \
         (SELECT COUNT(*) || ' ' || TOTAL(value) FROM line_stat l WHERE l.record = r.id) || ' ' || \
         (SELECT COUNT(*) || ' ' || group_concat(sha256) FROM source s WHERE s.record = r.id) || ' ' || \
         (SELECT COUNT(*) || ' ' || TOTAL(value) FROM component c WHERE c.record = r.id) AS x \
         FROM record r WHERE r.id <= ?1 ORDER BY r.id)",
        [last],
        |r| r.get::<_, String>(0),
    )
    .expect("committed records")
}

/// The child process of [`an_add_stopped_at_every_write_point_leaves_a_sound_ledger`]:
/// errmap's own add, through the library, with the fault VFS stopping the process at
/// write point `ERRMAP_FAULT_STOP_AT`; when the add completes first, it prints how many
/// write points it took.
#[test]
#[ignore = "a child process of an_add_stopped_at_every_write_point_leaves_a_sound_ledger"]
fn fault_child() {
    let var = |k: &str| std::env::var(k).ok();
    let (Some(ledger), Some(result), Some(stop_at)) = (
        var("ERRMAP_FAULT_LEDGER"),
        var("ERRMAP_FAULT_RESULT"),
        var("ERRMAP_FAULT_STOP_AT"),
    ) else {
        eprintln!("fault_child: run by an_add_stopped_at_every_write_point_leaves_a_sound_ledger");
        return;
    };
    use errmap::history::{Ledger, MachineId, NewRecord, State};
    let ingested = errmap::history::ingest(Path::new(&result)).expect("ingest");
    errmap_faultvfs::install(stop_at.parse().expect("a write point"));
    let mut l = Ledger::open(&ledger, true).expect("open");
    let rec = NewRecord {
        machine: MachineId::parse("F").expect("id"),
        site: None,
        state: State::AsFound,
        at: errmap::history::parse_utc("2025-05-01").expect("at"),
        supersede: None,
        content: ingested.content,
        sources: ingested.sources,
    };
    errmap::history::add(&mut l, &rec).expect("add");
    drop(l);
    println!("write points: {}", errmap_faultvfs::points());
}

#[test]
fn an_add_stopped_at_every_write_point_leaves_a_sound_ledger() {
    let dir = tempdir();
    let base = small_ledger(dir.path());
    let before = records(&base);
    let kept = committed(&base, before);
    let lines: Vec<(f64, f64)> = (0..40).map(|i| (0.0, 10.0 * i as f64)).collect();
    let result = write_session(dir.path(), "f.csv", &session(Axis::Z, &lines, 2.0, 90));
    let exe = std::env::current_exe().expect("the test binary");
    let mut outcomes = std::collections::BTreeMap::<&str, u32>::new();
    let mut n = 1u64;
    let total = loop {
        assert!(n < 1000, "an add of {n} write points?");
        let ledger = dir
            .path()
            .join(format!("f{n}.sqlite"))
            .display()
            .to_string();
        std::fs::copy(&base, &ledger).expect("copy");
        let o = Command::new(&exe)
            .args([
                "history_crash::fault_child",
                "--exact",
                "--ignored",
                "--nocapture",
            ])
            .args(["--test-threads", "1"])
            .env("ERRMAP_FAULT_LEDGER", &ledger)
            .env("ERRMAP_FAULT_RESULT", &result)
            .env("ERRMAP_FAULT_STOP_AT", n.to_string())
            .output()
            .expect("run the child");
        let stopped = o.status.code() == Some(errmap_faultvfs::STOPPED);
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            stopped || o.status.success(),
            "write point {n}: {out}{}",
            stderr(&o)
        );
        // A hot journal: one whose header is complete (SQLite writes the header's magic
        // number only once the journal's records are synced, and no page of the ledger is
        // written before; an empty journal, or one whose magic is still 0, is not hot and
        // is left to the next writer).
        let hot = || {
            std::fs::read(format!("{ledger}-journal"))
                .is_ok_and(|b| b.first().is_some_and(|&m| m != 0))
        };
        let journal = hot();
        // verify, report, another add: each on the ledger as the crash left it.
        let (vo, v) = verify(&ledger);
        assert!(
            vo.status.success(),
            "write point {n}: verify: {}",
            stderr(&vo)
        );
        assert_eq!(v["damage"].as_array().map(Vec::len), Some(0), "{v}");
        assert!(!hot(), "write point {n}: the journal was rolled back");
        let (ro, r) = report(&ledger, dir.path(), &format!("r{n}"));
        assert!(
            ro.status.success(),
            "write point {n}: report: {}",
            stderr(&ro)
        );
        let now = records(&ledger);
        assert_eq!(r["ledger"]["records"].as_i64(), Some(now));
        assert!(
            now == before || now == before + 1,
            "write point {n}: {now} records"
        );
        assert_eq!(
            committed(&ledger, before),
            kept,
            "write point {n}: a committed record changed"
        );
        assert_whole(&ledger);
        let outcome = match (stopped, journal, now > before) {
            (true, true, false) => "stopped with a hot journal: rolled back, the add absent",
            (true, false, false) => "stopped before the journal was hot: the add absent",
            (true, _, true) => "stopped after the commit, the add whole",
            (false, _, true) => "completed",
            (false, _, false) => panic!("write point {n}: the add completed and is absent"),
        };
        *outcomes.entry(outcome).or_default() += 1;
        let g = write_session(
            dir.path(),
            &format!("g{n}.csv"),
            &session(Axis::Y, &[(0.0, 0.0)], 1.0, 1000 + n),
        );
        add_ok(&ledger, &g, "F", &["--at", "2025-06-01"]);
        assert_eq!(records(&ledger), now + 1);
        assert_whole(&ledger);
        if !stopped {
            // (libtest prints the test's name on the same line first)
            let points: u64 = out
                .split("write points: ")
                .nth(1)
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("the child's count: {out}"));
            assert_eq!(points, n - 1, "the add took write points 1 … {}", n - 1);
            break points;
        }
        n += 1;
    };
    eprintln!("an add stopped at each of its {total} write points, then completed: {outcomes:?}");
    assert!(total >= 5, "{total} write points");
    assert_eq!(outcomes.values().sum::<u32>() as u64, total + 1);
}

// ---------------------------------------------------------------- PostgreSQL

/// An add on PostgreSQL stopped after each statement of its transaction, its client
/// killed (`kill -9`) or its server crashed (`pg_ctl stop -m immediate`, then restarted:
/// recovery from the write-ahead log); each followed by verify, report and another add.
#[test]
fn postgresql_add_killed_at_every_statement_client_or_server() {
    let cluster = match crate::history::Cluster::start() {
        Ok(c) => c,
        Err(why) => {
            eprintln!(
                "SKIPPED postgresql_add_killed_at_every_statement_client_or_server: no PostgreSQL server to start ({why})"
            );
            return;
        }
    };
    let dir = tempdir();
    let ledger = cluster.create_db("crash");
    fill(&ledger, dir.path());
    let lines: Vec<(f64, f64)> = (0..10).map(|i| (0.0, 10.0 * i as f64)).collect();
    let mut tried = Vec::new();
    for (k, kill) in ["client", "server"].into_iter().enumerate() {
        let f = write_session(
            dir.path(),
            &format!("f-{kill}.csv"),
            &session(Axis::Z, &lines, 2.0, 95 + k as u64),
        );
        let at = format!("2025-05-0{}", k + 1);
        let mut n = 1u64;
        loop {
            assert!(n < 100, "{n} statements?");
            let before = records(&ledger);
            // (ids are a sequence with gaps on PostgreSQL: a killed add used one)
            let last = scalar(&ledger, "SELECT COALESCE(MAX(id), 0) FROM record");
            let kept = committed(&ledger, last);
            let stall_at = n.to_string();
            let (mut child, line) = stalled_add(
                &ledger,
                &f,
                &["--machine", "F", "--at", &at],
                &[
                    ("ERRMAP_HISTORY_STALL_AT", stall_at.as_str()),
                    ("ERRMAP_HISTORY_STALL_MS", "60000"),
                ],
            );
            let stalled = line.contains(&format!("statement {n} done"));
            if stalled {
                if kill == "server" {
                    cluster.crash_and_restart();
                }
                let _ = child.kill();
            }
            let status = child.wait().expect("wait");
            let now = records(&ledger);
            if stalled {
                assert_eq!(
                    now, before,
                    "{kill} killed after statement {n}: the add is absent"
                );
            } else {
                assert!(status.success(), "{line}");
                assert_eq!(now, before + 1);
            }
            assert_eq!(
                committed(&ledger, last),
                kept,
                "{kill} killed after statement {n}"
            );
            let (vo, v) = verify(&ledger);
            assert!(
                vo.status.success(),
                "{kill} at {n}: verify: {}",
                stderr(&vo)
            );
            assert_eq!(v["damage"].as_array().map(Vec::len), Some(0), "{v}");
            let (ro, r) = report(&ledger, dir.path(), &format!("r-{kill}-{n}"));
            assert!(
                ro.status.success(),
                "{kill} at {n}: report: {}",
                stderr(&ro)
            );
            assert_eq!(r["ledger"]["records"].as_i64(), Some(now));
            assert_whole(&ledger);
            let g = write_session(
                dir.path(),
                &format!("g-{kill}-{n}.csv"),
                &session(Axis::Y, &[(0.0, 0.0)], 1.0, 2000 + 100 * k as u64 + n),
            );
            add_ok(&ledger, &g, &format!("G{k}-{n}"), &["--at", "2025-06-01"]);
            assert_eq!(records(&ledger), now + 1);
            assert_whole(&ledger);
            if !stalled {
                tried.push((kill, n - 1));
                break;
            }
            n += 1;
        }
    }
    eprintln!(
        "PostgreSQL: an add killed after each of its statements: {tried:?} (kill, statements)"
    );
    assert!(tried.iter().all(|&(_, s)| s >= 5), "{tried:?}");
}
