//! `errmap history`: the ledger on SQLite and on a real, throw-away PostgreSQL cluster
//! (the same scenarios on both), the statistics against `errmap table`, and the report's
//! chart and forecast against simulated fleets.
//!
//! The PostgreSQL scenarios need Debian's `postgresql` server binaries
//! (`/usr/lib/postgresql/*/bin`); without them they print why and skip.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Instant;

use errmap::base::Axis;
use errmap::base::gaussian;
use errmap::drivers::SessionRow;
use errmap::history::Tolerances;
use errmap::history::{MachineRows, RawPoint, ReportConfig, machine_report};
use errmap::history::{format_utc, parse_utc};
use rand::SeedableRng;
use rand::rngs::StdRng;

use crate::util::{bin, errmap, errmap_cmd, reference_row, root, stderr, tempdir};

/// A one-axis session: `lines` (the two other coordinates, mm), 6 targets 0…500 mm,
/// 3 runs each way, 2 samples per dwell; the error grows `slope_um_per_m` along the axis,
/// with a reversal of `reversal_um` and noise.
pub(super) fn session(
    axis: Axis,
    lines: &[(f64, f64)],
    slope_um_per_m: f64,
    seed: u64,
) -> Vec<SessionRow> {
    let mut rng = StdRng::seed_from_u64(seed);
    let a = axis.index();
    let mut rows = Vec::new();
    let (mut t, mut sample) = (0.0, 0i64);
    for &(c1, c2) in lines {
        for run in 1..=3u32 {
            for d in [1i8, -1] {
                let order: Vec<usize> = if d > 0 {
                    (0..6).collect()
                } else {
                    (0..6).rev().collect()
                };
                for j in order {
                    let x = j as f64 * 100.0;
                    let mut pos = [c1, c1, c2];
                    let mut k = 0;
                    for (b, slot) in pos.iter_mut().enumerate() {
                        if b == a {
                            *slot = x;
                        } else {
                            *slot = [c1, c2][k];
                            k += 1;
                        }
                    }
                    for _ in 0..2 {
                        let e = slope_um_per_m * x / 1000.0
                            + 0.4 * f64::from(d)
                            + 0.2 * gaussian(&mut rng);
                        rows.push(SessionRow {
                            run,
                            sample,
                            t_s: t,
                            ..reference_row(axis.into(), d, j as i32, pos, x, e)
                        });
                        sample += 1;
                        t += 0.05;
                    }
                }
            }
        }
    }
    rows
}

pub(super) fn write_session(dir: &Path, name: &str, rows: &[SessionRow]) -> PathBuf {
    let p = dir.join(name);
    errmap::session::write_session(&p, rows).expect("write session");
    p
}

/// A volumetric model file with the 21 components (`E_ZY` not identified).
pub(super) fn model_json(dir: &Path, name: &str, squareness_urad: f64, scale: f64) -> PathBuf {
    let mut components = serde_json::Map::new();
    for n in errmap::history::FUNCTIONS {
        let unit = if n.as_bytes()[2].is_ascii_uppercase() && "ABC".contains(&n[2..3]) {
            "urad"
        } else {
            "um"
        };
        let identified = n != "E_ZY";
        components.insert(
            n.to_string(),
            serde_json::json!({"identified": identified, "unit": unit,
                "positions_mm": [0.0, 100.0, 200.0], "values": if identified { serde_json::json!([0.0, 2.0 * scale, -scale]) } else { serde_json::json!([null, null, null]) },
                "sigma": [0.0, 0.1, 0.1]}),
        );
    }
    for n in errmap::history::SQUARENESS {
        components.insert(
            n.to_string(),
            serde_json::json!({"identified": true, "unit": "urad", "value": squareness_urad, "sigma": 0.5}),
        );
    }
    let p = dir.join(name);
    std::fs::write(
        &p,
        serde_json::json!({"topology": "YXZ", "rms_residual_um": 0.1, "components": components, "other": {"x": 1}}).to_string(),
    )
    .expect("write model");
    p
}

// ---------------------------------------------------------------- the two backends

/// A query's one integer, through the database's own driver.
pub(super) fn scalar(ledger: &str, sql: &str) -> i64 {
    if ledger.starts_with("postgres") {
        let mut c = postgres::Client::connect(ledger, postgres::NoTls).expect("connect");
        c.query_one(sql, &[]).expect(sql).get::<_, i64>(0)
    } else {
        let c = rusqlite::Connection::open(ledger).expect("open");
        c.query_row(sql, [], |r| r.get(0)).expect(sql)
    }
}

/// Records in the ledger (0 before its first add made the tables).
pub(super) fn records(ledger: &str) -> i64 {
    if ledger.starts_with("postgres") {
        let mut c = postgres::Client::connect(ledger, postgres::NoTls).expect("connect");
        let exists: bool = c
            .query_one("SELECT to_regclass('public.record') IS NOT NULL", &[])
            .expect("regclass")
            .get(0);
        if !exists {
            return 0;
        }
    } else if !Path::new(ledger).exists() {
        return 0;
    }
    scalar(ledger, "SELECT COUNT(*) FROM record")
}

/// A statement through the database's own driver: Ok(rows) or the database's refusal.
fn execute(ledger: &str, sql: &str) -> Result<u64, String> {
    if ledger.starts_with("postgres") {
        let mut c = postgres::Client::connect(ledger, postgres::NoTls).expect("connect");
        c.execute(sql, &[]).map_err(|e| {
            e.as_db_error()
                .map(|d| d.message().to_string())
                .unwrap_or(e.to_string())
        })
    } else {
        let c = rusqlite::Connection::open(ledger).expect("open");
        c.execute(sql, [])
            .map(|n| n as u64)
            .map_err(|e| e.to_string())
    }
}

pub(super) fn add(ledger: &str, result: &Path, machine: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "history",
        "add",
        result.to_str().expect("utf-8"),
        "--ledger",
        ledger,
        "--machine",
        machine,
    ];
    args.extend_from_slice(extra);
    errmap(&args)
}

pub(super) fn add_ok(
    ledger: &str,
    result: &Path,
    machine: &str,
    extra: &[&str],
) -> serde_json::Value {
    let mut e = extra.to_vec();
    e.push("--json");
    let o = add(ledger, result, machine, &e);
    assert!(
        o.status.success(),
        "add {}: {}",
        result.display(),
        stderr(&o)
    );
    serde_json::from_slice(&o.stdout).expect("add --json")
}

/// Every record is whole: its sources, and 7 statistics per line or 21 components.
pub(super) fn assert_whole(ledger: &str) {
    let records = scalar(ledger, "SELECT COUNT(*) FROM record");
    let with_source = scalar(
        ledger,
        "SELECT COUNT(DISTINCT record) FROM source WHERE role = 'result'",
    );
    assert_eq!(records, with_source, "every record has its result file");
    let partial_sessions = scalar(
        ledger,
        "SELECT COUNT(*) FROM record r WHERE r.kind = 'session' AND \
         ((SELECT COUNT(*) FROM line_stat l WHERE l.record = r.id) = 0 OR \
          (SELECT COUNT(*) FROM line_stat l WHERE l.record = r.id) % 7 <> 0)",
    );
    assert_eq!(
        partial_sessions, 0,
        "a session record without all its statistics"
    );
    let partial_models = scalar(
        ledger,
        "SELECT COUNT(*) FROM record r WHERE r.kind = 'volumetric' AND \
         (SELECT COUNT(*) FROM component c WHERE c.record = r.id) <> 21",
    );
    assert_eq!(
        partial_models, 0,
        "a model record without its 21 components"
    );
    let orphans = scalar(
        ledger,
        "SELECT (SELECT COUNT(*) FROM line_stat l WHERE NOT EXISTS (SELECT 1 FROM record r WHERE r.id = l.record)) \
         + (SELECT COUNT(*) FROM source s WHERE NOT EXISTS (SELECT 1 FROM record r WHERE r.id = s.record))",
    );
    assert_eq!(orphans, 0, "rows of no record");
}

/// The statistics of a session are those `errmap table --json` reports, line by line.
fn scenario_statistics(ledger: &str, dir: &Path) {
    let s = write_session(
        dir,
        "y.csv",
        &session(
            Axis::Y,
            &[(0.0, 0.0), (300.0, 0.0), (300.0, 200.0)],
            12.0,
            1,
        ),
    );
    let added = add_ok(
        ledger,
        &s,
        "M1",
        &["--at", "2026-01-05T09:30:00+01:00", "--site", "hall 2"],
    );
    assert_eq!(added["lines"], 3);
    assert_eq!(added["axes"], serde_json::json!(["Y"]));
    assert_eq!(added["at"], "2026-01-05T08:30:00Z");
    let o = errmap(&[
        "table",
        s.to_str().expect("utf-8"),
        "--out",
        dir.join("t.csv").to_str().expect("utf-8"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table: serde_json::Value = serde_json::from_slice(&o.stdout).expect("table --json");
    let keys = [
        ("E", "e_um"),
        ("E_up", "e_up_um"),
        ("E_down", "e_down_um"),
        ("A", "a_um"),
        ("B", "b_um"),
        ("R", "r_um"),
        ("M", "m_um"),
    ];
    let lines = table["lines"].as_array().expect("lines");
    assert_eq!(lines.len(), 3);
    let id = added["record"].as_i64().expect("id");
    for l in lines {
        let (c1, c2) = (
            l["line_mm"][0].as_f64().expect("c1"),
            l["line_mm"][1].as_f64().expect("c2"),
        );
        for (p, k) in keys {
            let cond = format!(
                "FROM line_stat WHERE record = {id} AND axis = 'Y' AND parameter = '{p}' \
                 AND abs(line_1_mm - ({c1})) < 1e-9 AND abs(line_2_mm - ({c2})) < 1e-9"
            );
            // Compared in integer nanometres through SQL, then to 1e-9 µm via the value.
            let want = l["iso230"][k].as_f64().expect("stat");
            let got_nm = scalar(
                ledger,
                &format!("SELECT CAST(ROUND(CAST(value * 1e6 AS numeric)) AS bigint) {cond}"),
            );
            assert_eq!(got_nm, (want * 1e6).round() as i64, "{p} of line {c1},{c2}");
            let u = l["uncertainty"]["expanded"]["along_travel_um"]
                .as_f64()
                .expect("U");
            let got_u = scalar(
                ledger,
                &format!("SELECT CAST(ROUND(CAST(u_um * 1e6 AS numeric)) AS bigint) {cond}"),
            );
            assert_eq!(got_u, (u * 1e6).round() as i64, "U of line {c1},{c2}");
        }
    }
    // A model: 21 components, the functions' range with 0 included.
    let m = model_json(dir, "model.json", 12.5, 1.0);
    let added = add_ok(ledger, &m, "M1", &["--at", "2026-01-06"]);
    assert_eq!(added["kind"], "volumetric");
    assert_eq!(added["lines"], 0);
    let id = added["record"].as_i64().expect("id");
    assert_eq!(
        scalar(
            ledger,
            &format!("SELECT COUNT(*) FROM component WHERE record = {id}")
        ),
        21
    );
    assert_eq!(
        scalar(
            ledger,
            &format!(
                "SELECT CAST(ROUND(CAST(\"range\" * 1000 AS numeric)) AS bigint) FROM component WHERE record = {id} AND name = 'E_XX'"
            )
        ),
        3000,
        "range of [0, 2, -1] is 3"
    );
    assert_eq!(
        scalar(
            ledger,
            &format!(
                "SELECT COUNT(*) FROM component WHERE record = {id} AND name = 'E_ZY' AND identified = 0 AND \"range\" IS NULL"
            )
        ),
        1
    );
    // Bad inputs record nothing.
    let before = scalar(ledger, "SELECT COUNT(*) FROM record");
    let mixed: Vec<SessionRow> = session(Axis::X, &[(0.0, 0.0)], 1.0, 2)
        .into_iter()
        .chain(
            session(Axis::Z, &[(0.0, 0.0)], 1.0, 3)
                .into_iter()
                .map(|mut r| {
                    r.run += 3;
                    r
                }),
        )
        .collect();
    let bad = write_session(dir, "mixed.csv", &mixed);
    let o = add(ledger, &bad, "M1", &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("more than one axis"), "{}", stderr(&o));
    std::fs::write(dir.join("notes.txt"), "x").expect("write");
    assert_eq!(
        add(ledger, &dir.join("notes.txt"), "M1", &[]).status.code(),
        Some(1)
    );
    assert_eq!(
        add(ledger, &s, "M1", &["--at", "yesterday"]).status.code(),
        Some(2)
    );
    assert_eq!(scalar(ledger, "SELECT COUNT(*) FROM record"), before);
}

/// UPDATE and DELETE through the database itself fail on every table.
fn scenario_append_only(ledger: &str, dir: &Path) {
    let s = write_session(dir, "x.csv", &session(Axis::X, &[(0.0, 0.0)], 5.0, 4));
    add_ok(ledger, &s, "M2", &[]);
    add_ok(ledger, &model_json(dir, "m.json", 3.0, 1.0), "M2", &[]);
    let count = |t: &str| scalar(ledger, &format!("SELECT COUNT(*) FROM {t}"));
    for (table, column) in [
        ("record", "machine"),
        ("source", "path"),
        ("line_stat", "axis"),
        ("component", "name"),
    ] {
        let before = count(table);
        assert!(before > 0);
        let e = execute(ledger, &format!("UPDATE {table} SET {column} = 'changed'"))
            .expect_err("an UPDATE must fail");
        assert!(e.contains("append-only"), "{table}: {e}");
        let e = execute(ledger, &format!("DELETE FROM {table}")).expect_err("a DELETE must fail");
        assert!(e.contains("append-only"), "{table}: {e}");
        if ledger.starts_with("postgres") {
            let e = execute(ledger, &format!("TRUNCATE {table} CASCADE"))
                .expect_err("a TRUNCATE must fail");
            assert!(e.contains("append-only"), "{table}: {e}");
        }
        assert_eq!(count(table), before, "{table} unchanged");
    }
    assert_eq!(
        scalar(
            ledger,
            "SELECT COUNT(*) FROM record WHERE machine = 'changed'"
        ),
        0
    );
}

/// Duplicates are refused naming the record; an amendment supersedes once, with its reason.
fn scenario_supersede(ledger: &str, dir: &Path) {
    let s = write_session(dir, "z.csv", &session(Axis::Z, &[(10.0, 20.0)], 3.0, 5));
    let first = add_ok(ledger, &s, "M3", &["--at", "2026-02-01"]);
    let n = first["record"].as_i64().expect("id");
    let o = add(ledger, &s, "M4", &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(&format!("record {n}")),
        "{}",
        stderr(&o)
    );
    let o = add(
        ledger,
        &s,
        "M3",
        &["--supersede", "999999", "--reason", "typo"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("999999"), "{}", stderr(&o));
    assert_eq!(
        add(ledger, &s, "M3", &["--supersede", &n.to_string()])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        add(ledger, &s, "M3", &["--reason", "x"]).status.code(),
        Some(2)
    );
    assert_eq!(add(ledger, &s, "M 3", &[]).status.code(), Some(2));
    let amended = add_ok(
        ledger,
        &s,
        "M3",
        &[
            "--at",
            "2026-02-02",
            "--supersede",
            &n.to_string(),
            "--reason",
            "wrong day",
        ],
    );
    assert_eq!(amended["supersedes"], n);
    let m = amended["record"].as_i64().expect("id");
    assert_eq!(
        scalar(
            ledger,
            &format!("SELECT COUNT(*) FROM record WHERE id = {m} AND reason = 'wrong day'")
        ),
        1
    );
    let o = add(
        ledger,
        &s,
        "M3",
        &["--supersede", &n.to_string(), "--reason", "again"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(&format!("record {m} supersedes it")),
        "{}",
        stderr(&o)
    );
    // Only the current record enters the report; both stay in the ledger.
    let out = dir.join("rep-supersede");
    let o = errmap(&[
        "history",
        "report",
        "--ledger",
        ledger,
        "--machine",
        "M3",
        "--report",
        out.to_str().expect("utf-8"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("report");
    assert_eq!(r["machines"].as_array().map(Vec::len), Some(1));
    let series = &r["machines"][0]["axes"][0]["parameters"][0]["series"];
    assert_eq!(series.as_array().map(Vec::len), Some(1));
    assert_eq!(series[0]["record"], m);
    assert_eq!(series[0]["at"], "2026-02-02T00:00:00Z");
    assert!(r["ledger"]["superseded"].as_i64() >= Some(1));
    assert_eq!(
        errmap(&[
            "history",
            "report",
            "--ledger",
            ledger,
            "--machine",
            "NOPE",
            "--report",
            out.to_str().expect("utf-8")
        ])
        .status
        .code(),
        Some(1)
    );
}

/// Adds from many processes at once: none lost, none doubled; the same file from several
/// processes is accepted once.
fn scenario_concurrency(ledger: &str, dir: &Path) {
    let before = records(ledger);
    let files: Vec<PathBuf> = (0..24)
        .map(|i| {
            write_session(
                dir,
                &format!("c{i}.csv"),
                &session(
                    Axis::X,
                    &[(0.0, 0.0), (0.0, 100.0)],
                    1.0 + i as f64,
                    100 + i,
                ),
            )
        })
        .collect();
    let shared = write_session(dir, "shared.csv", &session(Axis::X, &[(0.0, 0.0)], 7.0, 99));
    let mut children = Vec::new();
    for chunk in files.chunks(4) {
        let script: Vec<String> = chunk
            .iter()
            .map(|f| {
                // One test, one instant: each its own time.
                let i = files.iter().position(|g| g == f).unwrap_or(0);
                format!(
                    "'{}' history add '{}' --ledger '{ledger}' --machine C{} --at 2025-01-{:02} || exit 1",
                    bin(),
                    f.display(),
                    chunk.len(),
                    i + 1
                )
            })
            .collect();
        children.push(
            Command::new("sh")
                .arg("-c")
                .arg(script.join("; "))
                .stderr(Stdio::piped())
                .spawn()
                .expect("spawn"),
        );
    }
    let same: Vec<_> = (0..5)
        .map(|_| {
            errmap_cmd()
                .args([
                    "history",
                    "add",
                    shared.to_str().expect("utf-8"),
                    "--ledger",
                    ledger,
                    "--machine",
                    "S",
                ])
                .stderr(Stdio::piped())
                .spawn()
                .expect("spawn")
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().expect("wait");
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let outcomes: Vec<Output> = same
        .into_iter()
        .map(|c| c.wait_with_output().expect("wait"))
        .collect();
    let ok = outcomes.iter().filter(|o| o.status.success()).count();
    assert_eq!(ok, 1, "the same file from 5 processes is recorded once");
    for o in outcomes.iter().filter(|o| !o.status.success()) {
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(o).contains("already in the ledger"), "{}", stderr(o));
    }
    assert_eq!(scalar(ledger, "SELECT COUNT(*) FROM record") - before, 25);
    assert_eq!(
        scalar(
            ledger,
            "SELECT COUNT(*) FROM (SELECT sha256 FROM source WHERE role = 'result' GROUP BY sha256 HAVING COUNT(*) > 1) d"
        ),
        0
    );
    assert_whole(ledger);
}

/// `history add FILE --ledger L EXTRA…` with the crash seam's variables `env`, started;
/// returns the child and the first line it wrote on stderr (the seam's "… pending").
pub(super) fn stalled_add(
    ledger: &str,
    f: &Path,
    extra: &[&str],
    env: &[(&str, &str)],
) -> (std::process::Child, String) {
    let mut child = errmap_cmd()
        .args([
            "history",
            "add",
            f.to_str().expect("utf-8"),
            "--ledger",
            ledger,
        ])
        .args(extra)
        .envs(env.iter().copied())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let mut line = String::new();
    BufReader::new(child.stderr.take().expect("stderr"))
        .read_line(&mut line)
        .expect("read");
    (child, line)
}

/// kill -9 inside an add's transaction, and at random moments: the count is whole.
fn scenario_crash(ledger: &str, dir: &Path) {
    let big: Vec<(f64, f64)> = (0..40).map(|i| (0.0, 10.0 * i as f64)).collect();
    add_ok(
        ledger,
        &write_session(
            dir,
            "k-first.csv",
            &session(Axis::X, &[(0.0, 0.0)], 2.0, 499),
        ),
        "K",
        &["--at", "2025-02-01"],
    );
    let before = records(ledger);
    // Inside the transaction, for certain: the record row is written, the rest pending.
    let f = write_session(dir, "k0.csv", &session(Axis::X, &big, 2.0, 500));
    let (mut child, line) = stalled_add(
        ledger,
        &f,
        &["--machine", "K", "--at", "2025-02-02"],
        &[("ERRMAP_HISTORY_STALL_MS", "30000")],
    );
    assert!(line.contains("row written"), "{line}");
    child.kill().expect("kill -9");
    child.wait().expect("wait");
    assert_eq!(
        scalar(ledger, "SELECT COUNT(*) FROM record"),
        before,
        "the killed add left nothing"
    );
    assert_whole(ledger);
    // At random moments of whole adds (timed on a first, complete one).
    let t0 = Instant::now();
    add_ok(
        ledger,
        &write_session(dir, "k1.csv", &session(Axis::X, &big, 2.5, 501)),
        "K",
        &["--at", "2025-02-03"],
    );
    let whole = t0.elapsed();
    let mut killed_before = 0;
    let mut finished = 0;
    for i in 0..8u64 {
        let f = write_session(
            dir,
            &format!("k{}.csv", i + 2),
            &session(Axis::X, &big, 3.0 + i as f64, 502 + i),
        );
        let n0 = scalar(ledger, "SELECT COUNT(*) FROM record");
        let at = format!("2025-03-{:02}", i + 1);
        let mut child = errmap_cmd()
            .args([
                "history",
                "add",
                f.to_str().expect("utf-8"),
                "--ledger",
                ledger,
                "--machine",
                "K",
                "--at",
                &at,
            ])
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn");
        std::thread::sleep(whole.mul_f64((i as f64 + 0.5) / 8.0));
        let _ = child.kill();
        child.wait().expect("wait");
        let n1 = scalar(ledger, "SELECT COUNT(*) FROM record");
        assert!(n1 == n0 || n1 == n0 + 1, "{n0} → {n1}");
        if n1 == n0 {
            killed_before += 1
        } else {
            finished += 1
        }
        assert_whole(ledger);
        if !ledger.starts_with("postgres") {
            let c = rusqlite::Connection::open(ledger).expect("open");
            let ok: String = c
                .query_row("PRAGMA integrity_check", [], |r| r.get(0))
                .expect("check");
            assert_eq!(ok, "ok");
        }
    }
    eprintln!(
        "crash scenario: {killed_before} adds killed before their commit, {finished} finished"
    );
    // The ledger goes on.
    add_ok(
        ledger,
        &write_session(dir, "k-after.csv", &session(Axis::X, &big, 9.0, 600)),
        "K",
        &["--at", "2025-04-01"],
    );
    assert_whole(ledger);
}

/// verify names the changed and the vanished files.
fn scenario_verify(ledger: &str, dir: &Path) {
    let a = write_session(dir, "va.csv", &session(Axis::Y, &[(0.0, 0.0)], 1.0, 700));
    let b = model_json(dir, "vb.json", 1.0, 2.0);
    add_ok(ledger, &a, "V", &[]);
    add_ok(ledger, &b, "V", &[]);
    let o = errmap(&["history", "verify", "--ledger", ledger, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut text = std::fs::read_to_string(&a).expect("read");
    text.push('\n');
    std::fs::write(&a, text).expect("tamper");
    std::fs::remove_file(&b).expect("remove");
    let o = errmap(&["history", "verify", "--ledger", ledger, "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("verify --json");
    let changed = v["changed"].as_array().expect("changed");
    assert_eq!(changed.len(), 1);
    assert_eq!(
        changed[0]["path"],
        std::path::absolute(&a).expect("abs").display().to_string()
    );
    assert_ne!(changed[0]["expected"], changed[0]["actual"]);
    let missing = v["missing"].as_array().expect("missing");
    assert_eq!(missing.len(), 1);
    assert_eq!(missing[0]["role"], "result");
    assert!(stderr(&o).contains(&a.display().to_string()) && stderr(&o).contains("missing"));
    assert_eq!(
        v["checked"].as_i64(),
        Some(scalar(ledger, "SELECT COUNT(*) FROM source"))
    );
}

/// A small fleet with history: three machines, monthly tests, one drifting, one adjusted.
fn fleet_ledger(ledger: &str, dir: &Path) {
    let mut k = 0;
    for (i, (machine, slope0, drift)) in [("F1", 5.0, 0.0), ("F2", 5.0, 1.5), ("F3", 8.0, 0.3)]
        .into_iter()
        .enumerate()
    {
        for month in 0..8 {
            let at = format!("2025-{:02}-10", month + 1);
            let slope = slope0 + drift * month as f64;
            let f = write_session(
                dir,
                &format!("f{k}.csv"),
                &session(Axis::X, &[(0.0, 0.0)], slope, 1000 + k),
            );
            k += 1;
            add_ok(ledger, &f, machine, &["--at", &at, "--site", "plant A"]);
            if machine == "F3" && month == 5 {
                let f = write_session(
                    dir,
                    &format!("f{k}.csv"),
                    &session(Axis::X, &[(0.0, 0.0)], 1.0, 1000 + k),
                );
                k += 1;
                add_ok(
                    ledger,
                    &f,
                    machine,
                    &["--at", "2025-06-12", "--state", "as-left"],
                );
            }
        }
        add_ok(
            ledger,
            &model_json(dir, &format!("{machine}.json"), 4.0 + i as f64, 1.0),
            machine,
            &["--at", "2025-08-20"],
        );
    }
    std::fs::write(
        dir.join("tol.toml"),
        "[default]\nE = 14.0\nA = 20.0\n[machine.F2.X]\nE = 12.0\n",
    )
    .expect("tol");
}

fn fleet_report(ledger: &str, dir: &Path, name: &str) -> serde_json::Value {
    let out = dir.join(name);
    let o = errmap(&[
        "history",
        "report",
        "--ledger",
        ledger,
        "--tolerances",
        dir.join("tol.toml").to_str().expect("utf-8"),
        "--report",
        out.to_str().expect("utf-8"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["report.md", "fleet.svg", "F1.svg", "F2.png"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    serde_json::from_slice(&o.stdout).expect("report --json")
}

/// Equal JSON documents, numbers to 1e-9 relative, record ids aside.
fn same_json(a: &serde_json::Value, b: &serde_json::Value, at: &str) {
    use serde_json::Value::*;
    match (a, b) {
        (Number(x), Number(y)) => {
            let (x, y) = (x.as_f64().expect("x"), y.as_f64().expect("y"));
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1e-300),
                "{at}: {x} vs {y}"
            );
        }
        (Array(x), Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: lengths");
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                same_json(p, q, &format!("{at}[{i}]"));
            }
        }
        (Object(x), Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "{at}: keys"
            );
            for (k, v) in x {
                if k != "record" {
                    same_json(v, &y[k], &format!("{at}.{k}"));
                }
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

fn check_fleet(r: &serde_json::Value) {
    let machines = r["machines"].as_array().expect("machines");
    assert_eq!(
        machines
            .iter()
            .map(|m| m["id"].as_str().unwrap_or(""))
            .collect::<Vec<_>>(),
        ["F1", "F2", "F3"]
    );
    let f2 = &machines[1];
    assert_eq!(f2["site"], "plant A");
    assert_eq!(f2["axes"][0]["axis"], "X");
    assert_eq!(f2["axes"][1]["axis"], "XYZ");
    let e = &f2["axes"][0]["parameters"][0];
    assert_eq!(e["name"], "E");
    assert_eq!(e["tolerance"].as_f64(), Some(12.0));
    assert!(
        e["rate_per_year"].as_f64().expect("rate") > 5.0,
        "F2 drifts: {}",
        e["rate_per_year"]
    );
    assert_eq!(
        r["fleet"][0]["id"], "F2",
        "the drifting machine ranks first"
    );
    // F3 was adjusted: its series splits, the as-left pairs with the as-found before it.
    let e3 = &machines[2]["axes"][0]["parameters"][0];
    assert_eq!(e3["pairs"].as_array().map(Vec::len), Some(1));
    assert_eq!(e3["pairs"][0]["as_found_at"], "2025-06-10T00:00:00Z");
    assert_eq!(e3["trend_from"], "2025-06-12T00:00:00Z");
    assert_eq!(e3["trend_n"], 3);
    let xyz = &machines[0]["axes"][1]["parameters"];
    let names: Vec<&str> = xyz
        .as_array()
        .expect("xyz")
        .iter()
        .map(|p| p["name"].as_str().unwrap_or(""))
        .collect();
    assert_eq!(&names[..4], ["E_C0Y", "E_B0Z", "E_A0Z", "E_XX"]);
    assert!(
        !names.contains(&"E_ZY"),
        "an unidentified component has no series"
    );
}

fn all_scenarios(ledger_for: &mut dyn FnMut(&str) -> String, dir: &Path) -> serde_json::Value {
    let sub = |n: &str| {
        let d = dir.join(n);
        std::fs::create_dir_all(&d).expect("dir");
        d
    };
    scenario_statistics(&ledger_for("stats"), &sub("stats"));
    scenario_append_only(&ledger_for("append"), &sub("append"));
    scenario_supersede(&ledger_for("supersede"), &sub("supersede"));
    scenario_concurrency(&ledger_for("concurrency"), &sub("concurrency"));
    scenario_crash(&ledger_for("crash"), &sub("crash"));
    scenario_verify(&ledger_for("verify"), &sub("verify"));
    let fleet = ledger_for("fleet");
    let d = sub("fleet");
    fleet_ledger(&fleet, &d);
    let r = fleet_report(&fleet, &d, "report");
    check_fleet(&r);
    readme_figure(&d.join("report"));
    r
}

/// With `ERRMAP_README_FIGURES=DIR`, the drifting machine's chart (F2) is copied to
/// `DIR/F2.png`: the README's picture of a machine's history comes from this fleet
/// (`ERRMAP_README_FIGURES=reports/history cargo test --test it sqlite_ledger`).
fn readme_figure(report: &Path) {
    let Some(dir) = std::env::var_os("ERRMAP_README_FIGURES") else {
        return;
    };
    let dir = root().join(dir);
    std::fs::create_dir_all(&dir).expect("figure dir");
    std::fs::copy(report.join("F2.png"), dir.join("F2.png")).expect("copy F2.png");
}

#[test]
fn sqlite_ledger_scenarios() {
    let dir = tempdir();
    let root = dir.path().to_path_buf();
    let r = all_scenarios(
        &mut |n| root.join(format!("{n}.sqlite")).display().to_string(),
        dir.path(),
    );
    std::fs::write(
        std::env::temp_dir().join(format!(
            "errmap-history-sqlite-report-{}.json",
            std::process::id()
        )),
        r.to_string(),
    )
    .expect("keep");
    // report and verify on a missing ledger.
    let missing = root.join("none.sqlite");
    assert_eq!(
        errmap(&[
            "history",
            "verify",
            "--ledger",
            missing.to_str().expect("utf-8")
        ])
        .status
        .code(),
        Some(1)
    );
    assert!(!missing.exists());
}

// ---------------------------------------------------------------- PostgreSQL

/// A throw-away PostgreSQL cluster: initdb in a temp dir, loopback only, a free port;
/// stopped when dropped.
pub(super) struct Cluster {
    bin: PathBuf,
    dir: tempfile::TempDir,
    port: u16,
    as_postgres: bool,
}

impl Cluster {
    pub(super) fn cmd(&self, tool: &str) -> Command {
        let exe = self.bin.join(tool);
        if self.as_postgres {
            let mut c = Command::new("runuser");
            c.args(["-u", "postgres", "--"]).arg(exe);
            c
        } else {
            Command::new(exe)
        }
    }

    /// Starts one, or says why it cannot.
    pub(super) fn start() -> Result<Cluster, String> {
        let mut bins: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
            .map_err(|_| {
                "no /usr/lib/postgresql (Debian's postgresql package is not installed)".to_string()
            })?
            .filter_map(|e| e.ok().map(|e| e.path().join("bin")))
            .filter(|b| b.join("initdb").is_file() && b.join("pg_ctl").is_file())
            .collect();
        bins.sort_by_key(|b| {
            b.parent()
                .and_then(|v| v.file_name())
                .and_then(|v| v.to_str())
                .and_then(|v| v.parse::<u32>().ok())
                .unwrap_or(0)
        });
        let bin = bins
            .pop()
            .ok_or("no initdb under /usr/lib/postgresql/*/bin")?;
        let uid = Command::new("id")
            .arg("-u")
            .output()
            .map_err(|e| e.to_string())?;
        let as_postgres = String::from_utf8_lossy(&uid.stdout).trim() == "0";
        let dir = tempfile::Builder::new()
            .prefix("errmap-pg-")
            .tempdir()
            .map_err(|e| e.to_string())?;
        if as_postgres {
            let o = Command::new("chown")
                .args(["postgres:postgres"])
                .arg(dir.path())
                .output()
                .map_err(|e| e.to_string())?;
            if !o.status.success() {
                return Err(format!(
                    "cannot give the cluster's directory to the postgres user: {}",
                    stderr(&o)
                ));
            }
        }
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| e.to_string())?
            .port();
        let c = Cluster {
            bin,
            dir,
            port,
            as_postgres,
        };
        let data = c.dir.path().join("data");
        let o = c
            .cmd("initdb")
            .arg("-D")
            .arg(&data)
            .args(["-A", "trust", "-U", "postgres", "-E", "UTF8", "--no-sync"])
            .output()
            .map_err(|e| e.to_string())?;
        if !o.status.success() {
            return Err(format!("initdb failed: {}", stderr(&o)));
        }
        c.pg_start()?;
        Ok(c)
    }

    /// Starts the server on its data directory (after `start`'s initdb, or after a crash).
    fn pg_start(&self) -> Result<(), String> {
        let opts = format!(
            "-c listen_addresses=127.0.0.1 -p {} -k {} -c fsync=on",
            self.port,
            self.dir.path().display()
        );
        let o = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .args(["-o", &opts, "-l"])
            .arg(self.dir.path().join("log"))
            .args(["-w", "-t", "60", "start"])
            .output()
            .map_err(|e| e.to_string())?;
        if !o.status.success() {
            let log = std::fs::read_to_string(self.dir.path().join("log")).unwrap_or_default();
            return Err(format!("the server did not start: {}{log}", stderr(&o)));
        }
        Ok(())
    }

    /// Stops the server as a crash does (`pg_ctl stop -m immediate`: no checkpoint, every
    /// backend killed, recovery from the write-ahead log at the next start), then starts it.
    pub(super) fn crash_and_restart(&self) {
        let o = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .args(["-m", "immediate", "-w", "stop"])
            .output()
            .expect("pg_ctl stop");
        assert!(o.status.success(), "pg_ctl stop: {}", stderr(&o));
        self.pg_start().expect("the server restarts after a crash");
    }

    pub(super) fn url(&self, db: &str) -> String {
        format!("postgres://postgres@127.0.0.1:{}/{db}", self.port)
    }

    pub(super) fn create_db(&self, db: &str) -> String {
        let mut c =
            postgres::Client::connect(&self.url("postgres"), postgres::NoTls).expect("connect");
        c.batch_execute(&format!("CREATE DATABASE {db}"))
            .expect("create database");
        self.url(db)
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .args(["-m", "immediate", "-w", "stop"])
            .output();
    }
}

#[test]
fn postgresql_ledger_scenarios_match_sqlite() {
    let cluster = match Cluster::start() {
        Ok(c) => c,
        Err(why) => {
            eprintln!(
                "SKIPPED postgresql_ledger_scenarios_match_sqlite: no PostgreSQL server to start ({why})"
            );
            return;
        }
    };
    let dir = tempdir();
    let pg = all_scenarios(&mut |n| cluster.create_db(n), dir.path());
    // The same fleet on SQLite gives the same report.
    let sq_dir = dir.path().join("sqlite-fleet");
    std::fs::create_dir_all(&sq_dir).expect("dir");
    let sq = sq_dir.join("fleet.sqlite").display().to_string();
    fleet_ledger(&sq, &sq_dir);
    let r = fleet_report(&sq, &sq_dir, "report");
    same_json(&pg, &r, "report");
    // A missing ledger.
    let o = errmap(&["history", "verify", "--ledger", &cluster.url("postgres")]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no ledger"), "{}", stderr(&o));
}

// ---------------------------------------------------------------- the chart and the forecast

const MONTH_S: i64 = 30 * 86_400;

/// Points of one axis: (time s, value, as-left).
type AxisSeries<'a> = (&'a str, Vec<(i64, f64, bool)>);

fn rows_of(series: &[AxisSeries<'_>]) -> MachineRows {
    let mut points = Vec::new();
    let mut id = 0;
    for (axis, s) in series {
        for &(t, v, as_left) in s {
            id += 1;
            points.push(RawPoint {
                record: id,
                at: format_utc(t),
                state: if as_left { "as-left" } else { "as-found" }.into(),
                axis: axis.to_string(),
                parameter: "E".into(),
                unit: "um".into(),
                value: v,
            });
        }
    }
    MachineRows {
        records: id,
        site: None,
        points,
    }
}

fn config(tol: Option<f64>) -> ReportConfig {
    let tolerances = match tol {
        Some(t) => {
            Tolerances::parse(Path::new("t.toml"), &format!("[default]\nE = {t}\n")).expect("tol")
        }
        None => Tolerances::default(),
    };
    ReportConfig {
        machine: None,
        tolerances,
        as_of: None,
        horizon_days: 365.0,
    }
}

fn t0() -> i64 {
    parse_utc("2020-01-01").expect("t0")
}

/// 1 000 stable machines (3 axes × 40 monthly tests of Gaussian noise): the chart almost
/// never alarms. The measured rate is printed; the assertion bounds it at 1e-4 per charted
/// point (a fleet of 2 000 machines would then see at most about 20 false alarms in ten years).
#[test]
fn a_stable_fleet_gives_almost_no_false_alarm() {
    let mut rng = StdRng::seed_from_u64(27);
    let (mut alarms, mut charted, mut machines_alarmed) = (0usize, 0usize, 0usize);
    for m in 0..1000 {
        let series: Vec<AxisSeries<'_>> = ["X", "Y", "Z"]
            .iter()
            .map(|a| {
                (
                    *a,
                    (0..40)
                        .map(|k| (t0() + k * MONTH_S, 10.0 + 0.5 * gaussian(&mut rng), false))
                        .collect(),
                )
            })
            .collect();
        let r = machine_report(
            "test",
            &format!("S{m}"),
            rows_of(&series),
            &config(None),
            t0() + 40 * MONTH_S,
        )
        .expect("report");
        let a: usize = r.axes.iter().map(|a| a.parameters[0].alarms.len()).sum();
        charted += r
            .axes
            .iter()
            .map(|a| {
                a.parameters[0]
                    .series
                    .iter()
                    .filter(|p| p.ewma.is_some())
                    .count()
            })
            .sum::<usize>();
        alarms += a;
        machines_alarmed += usize::from(a > 0);
    }
    assert_eq!(charted, 1000 * 3 * 35);
    let rate = alarms as f64 / charted as f64;
    eprintln!(
        "stable fleet: {alarms} alarms in {charted} charted points (rate {rate:.2e}), {machines_alarmed} of 1000 machines"
    );
    assert!(rate <= 1e-4, "false-alarm rate {rate}");
}

/// A crash-sized step (10 σ) on one axis alarms at the first or second test after it.
#[test]
fn a_ten_sigma_step_alarms_within_two_tests() {
    let mut rng = StdRng::seed_from_u64(7);
    for trial in 0..50 {
        let step_at = 12 + trial % 10;
        let series: Vec<AxisSeries<'_>> = ["X", "Y", "Z"]
            .iter()
            .map(|a| {
                let s = (0..30)
                    .map(|k| {
                        let step = if *a == "Y" && k >= step_at {
                            10.0 * 0.5
                        } else {
                            0.0
                        };
                        (
                            t0() + k as i64 * MONTH_S,
                            10.0 + step + 0.5 * gaussian(&mut rng),
                            false,
                        )
                    })
                    .collect();
                (*a, s)
            })
            .collect();
        let r =
            machine_report("test", "STEP", rows_of(&series), &config(None), t0()).expect("report");
        let y = &r.axes[1].parameters[0];
        let first = y
            .series
            .iter()
            .position(|p| y.alarms.first().is_some_and(|a| a.record == p.record));
        assert!(
            matches!(first, Some(i) if i == step_at || i == step_at + 1),
            "trial {trial}: step at {step_at}, first alarm at {first:?}"
        );
        assert_eq!(y.alarms[0].rule, "ewma_above_ucl");
        assert!(
            r.axes[0].parameters[0].alarms.is_empty() && r.axes[2].parameters[0].alarms.is_empty()
        );
    }
}

/// A simulated drift of 2 µm/year from 10 µm towards a 30 µm tolerance crosses it 10
/// years after the start: the 95 % Fieller interval holds that date in about 95 % of
/// 400 simulated machines, and the rate's 95 % interval holds 2 µm/year about as often.
#[test]
fn the_forecast_interval_covers_a_simulated_drift() {
    let mut rng = StdRng::seed_from_u64(2617);
    let year_s = 365.25 * 86_400.0;
    let truth = format_utc(t0() + (10.0 * year_s) as i64)[..10].to_string();
    let (mut covered, mut bounded, mut rate_in) = (0, 0, 0);
    let n = 400;
    let q = errmap::history::t_quantile(0.975, 14.0);
    for m in 0..n {
        // 16 quarterly tests over 3.75 years.
        let s: Vec<(i64, f64, bool)> = (0..16)
            .map(|k| {
                let t = t0() + (k as f64 * 0.25 * year_s) as i64;
                (
                    t,
                    10.0 + 2.0 * (k as f64 * 0.25) + 0.5 * gaussian(&mut rng),
                    false,
                )
            })
            .collect();
        let r = machine_report(
            "test",
            &format!("D{m}"),
            rows_of(&[("X", s)]),
            &config(Some(30.0)),
            t0() + (3.75 * year_s) as i64,
        )
        .expect("report");
        let p = &r.axes[0].parameters[0];
        let rate = p.rate_per_year.expect("rate");
        if (rate - 2.0).abs() <= q * p.rate_sigma.expect("σ") {
            rate_in += 1;
        }
        if let Some([Some(lo), Some(hi)]) = &p.exceeds_interval {
            bounded += 1;
            if lo.as_str() <= truth.as_str() && truth.as_str() <= hi.as_str() {
                covered += 1;
            }
            assert!(
                lo.as_str() <= p.exceeds_tolerance_at.as_deref().expect("date")
                    && p.exceeds_tolerance_at.as_deref().expect("date") <= hi.as_str()
            );
        }
        assert!(p.risk.is_some_and(|r| (0.0..=1.0).contains(&r)));
    }
    let coverage = covered as f64 / n as f64;
    eprintln!(
        "drift forecast: interval bounded {bounded}/{n}, covers the true date {covered}/{n} ({coverage:.3}); rate within t(0.975, 14)·σ {rate_in}/{n}"
    );
    assert_eq!(
        bounded, n,
        "a 2 µm/year drift with 0.5 µm noise is significant"
    );
    assert!((0.92..=0.98).contains(&coverage), "coverage {coverage}");
    assert!((0.92..=0.98).contains(&(rate_in as f64 / n as f64)));
}

/// Advice in the contract's order, and the risk's limits.
#[test]
fn advice_follows_the_first_rule_that_applies() {
    let year = 365 * 86_400;
    let line = |b: f64, start: f64| -> Vec<(i64, f64, bool)> {
        (0..8)
            .map(|k| {
                (
                    t0() + k * year / 4,
                    start + b * k as f64 / 4.0 + 0.01 * ((k * 7 % 5) as f64 - 2.0),
                    false,
                )
            })
            .collect()
    };
    let advice = |s: Vec<(i64, f64, bool)>, tol: f64| {
        let as_of = s.last().map(|p| p.0).unwrap_or(0);
        machine_report("test", "A", rows_of(&[("X", s)]), &config(Some(tol)), as_of)
            .expect("report")
    };
    let r = advice(line(1.0, 10.0), 11.0);
    assert_eq!(r.advice.as_str(), "out_of_tolerance");
    let r = advice(line(1.0, 10.0), 12.5);
    assert_eq!(r.advice.as_str(), "recalibrate");
    assert!(r.recalibrate_by.is_some());
    assert!(r.risk > 0.99);
    let r = advice(line(0.0, 10.0), 30.0);
    assert_eq!(r.advice.as_str(), "ok");
    assert!(r.risk < 1e-6);
}
