//! Calibration history of a fleet: a ledger of every machine's results over the years,
//! and the report that turns it into trends, control charts and recalibration dates.
//!
//! | module | holds |
//! |---|---|
//! | `ledger` | the database: one schema on SQLite and PostgreSQL, append-only, locked writes, a crashed writer's journal rolled back, one snapshot per read |
//! | `check` | `verify`: the files re-hashed, the ledger's own soundness |
//! | `ingest` | a session's ISO 230-2 statistics or a model's components, and the files' sha256 |
//! | `stats` | trend, Fieller interval, EWMA chart, moving-range σ, Student t |
//! | `report` | series, segments, charts, forecasts, advice and the fleet ranking |
//! | `tolerance` | the tolerance file ([`Tolerances`]) |
//! | `time` | UTC instants as stored ([`parse_utc`], [`format_utc`]) |
//!
//! An add is one transaction ([`add`]); a report reads one machine at a time
//! ([`Run`]), so its memory is bounded by the largest machine, not the ledger.
//! The rules and the maths are in `docs/history.md`.

mod check;
mod ingest;
mod ledger;
mod report;
mod stats;
mod time;
mod tolerance;

use crate::base::{ConfigError, FileError};

use serde::Serialize;

pub use check::{Changed, Missing, Problem, Verification, verify};
pub use ingest::{
    ComponentRow, Content, FUNCTIONS, Ingested, LineStat, PARAMETERS, Role, SQUARENESS, SourceFile,
    ingest,
};
pub use ledger::{DbError, LOCK_WAIT, Ledger, MachineRows, RawPoint, SourceRow, is_postgres};
pub use report::{
    Advice, Alarm, AxisReport, ChartSpec, DEFAULT_HORIZON_DAYS, FleetEntry, Head, LedgerCounts,
    MachineReport, PAIR_WINDOW_S, Pair, ParameterReport, Report, ReportConfig, Run, SeriesPoint,
    machine_report, report,
};
pub use stats::{Trend, t_cdf, t_quantile};
pub use time::{CLOCK_SKEW_S, EARLIEST_S, TimeError, format_utc, latest_at, now_utc, parse_utc};
pub use tolerance::Tolerances;

/// Why a history command failed.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The database refused or failed.
    #[error("{ledger}: {source}")]
    Db { ledger: String, source: DbError },
    /// The PostgreSQL server cannot be reached.
    #[error("{ledger}: cannot connect: {source}")]
    Connect { ledger: String, source: DbError },
    /// The tables of a new ledger could not be created.
    #[error("{ledger}: cannot create the tables: {source}")]
    Create { ledger: String, source: DbError },
    /// A writer stopped inside its transaction, and this process may not write the file
    /// to roll its journal back (a read-only file or folder).
    #[error(
        "{ledger}: a writer stopped inside its transaction and left its journal {journal}; \
         nothing committed is lost, and SQLite rolls the unfinished transaction back the \
         next time a process that may write the ledger and its folder opens it — this one \
         may not ({source})"
    )]
    Unrecovered {
        ledger: String,
        journal: String,
        source: DbError,
    },
    /// SQLite finds the file damaged, or it is not a SQLite database.
    #[error("{ledger}: the ledger is damaged ({source}){}", found_text(.found))]
    Damaged {
        ledger: String,
        source: DbError,
        /// What SQLite's integrity check found, when it could run.
        found: Vec<String>,
    },
    /// A stored time is not in the form errmap writes.
    #[error("{ledger}: record {record}: its time is not in the stored form: {source}")]
    Stored {
        ledger: String,
        record: i64,
        source: time::TimeError,
    },
    /// A test time outside the window the ledger takes.
    #[error(
        "{ledger}: the test time {at} is outside the window the ledger takes, {earliest} … \
         {latest} (now + a clock skew of {skew_h} h): nothing was added"
    )]
    OutsideWindow {
        ledger: String,
        at: String,
        earliest: String,
        latest: String,
        skew_h: i64,
    },
    /// An amendment without a reason.
    #[error(
        "{ledger}: the amendment of record {record} gives no reason (ISO/IEC 17025 asks \
         that an amendment says why): nothing was added"
    )]
    EmptyReason { ledger: String, record: i64 },
    /// A second current record of one machine, axis and state at one instant.
    #[error(
        "{ledger}: record {record} already holds {machine} axis {axis} {state} at {at}: one \
         test, one record (a second test that day needs its time of day; a correction \
         amends record {record}); nothing was added"
    )]
    SameInstant {
        ledger: String,
        record: i64,
        machine: String,
        axis: String,
        state: &'static str,
        at: String,
    },
    /// `report` or `verify` on a ledger that does not exist.
    #[error("{0}: no ledger there (`errmap history add` creates one)")]
    NoLedger(String),
    /// The result is already recorded.
    #[error(
        "{ledger}: this result is already in the ledger as record {record} (sha256 {sha256}); \
         nothing was added"
    )]
    Duplicate {
        ledger: String,
        record: i64,
        sha256: String,
    },
    /// The record to supersede does not exist.
    #[error("{ledger}: record {record} to supersede: there is no record {record}")]
    NoSuchRecord { ledger: String, record: i64 },
    /// The record to supersede is already superseded.
    #[error(
        "{ledger}: record {record} to supersede: record {record} is not current (record {by} \
         supersedes it)"
    )]
    NotCurrent {
        ledger: String,
        record: i64,
        by: i64,
    },
    /// A file could not be read.
    #[error(transparent)]
    File(#[from] FileError),
    /// A bad input file (the whole file) or a bad key of the tolerance file.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The machine asked for has no current record.
    #[error("machine {machine}: no current record of this machine in {ledger}")]
    UnknownMachine { ledger: String, machine: String },
}

fn found_text(found: &[String]) -> String {
    match found {
        [] => String::new(),
        f => format!("; SQLite's integrity check found: {}", f.join("; ")),
    }
}

/// `as-found` or `as-left`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum State {
    /// The machine as it was found (a routine test, or before an adjustment).
    #[default]
    AsFound,
    /// After an adjustment or a compensation.
    AsLeft,
}

impl State {
    pub fn as_str(self) -> &'static str {
        match self {
            State::AsFound => "as-found",
            State::AsLeft => "as-left",
        }
    }

    pub fn parse(s: &str) -> Option<State> {
        match s {
            "as-found" => Some(State::AsFound),
            "as-left" => Some(State::AsLeft),
            _ => None,
        }
    }
}

/// A machine identifier: 1–64 characters of `[A-Za-z0-9._-]`.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MachineId(String);

impl MachineId {
    pub fn parse(s: &str) -> Option<MachineId> {
        let ok = (1..=64).contains(&s.len())
            && s.bytes()
                .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'));
        ok.then(|| MachineId(s.to_string()))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// An amendment: the record it replaces and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Supersede {
    pub record: i64,
    pub reason: String,
}

/// What an add records.
#[derive(Debug, Clone)]
pub struct NewRecord {
    pub machine: MachineId,
    pub site: Option<String>,
    pub state: State,
    /// When the test was made, seconds since the epoch, UTC.
    pub at: i64,
    pub supersede: Option<Supersede>,
    pub content: Content,
    pub sources: Vec<SourceFile>,
}

impl NewRecord {
    /// The `result` file's sha256.
    pub fn result_sha256(&self) -> &str {
        self.sources
            .iter()
            .find(|s| s.role == Role::Result)
            .map(|s| s.sha256.as_str())
            .unwrap_or("")
    }
}

/// What `history add --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct Added {
    pub record: i64,
    pub machine: String,
    pub kind: &'static str,
    pub at: String,
    pub state: &'static str,
    pub supersedes: Option<i64>,
    pub sha256: String,
    pub lines: usize,
    pub axes: Vec<String>,
}

/// Adds one record in one transaction: the amendment or duplicate check, then the
/// record, its sources and its numbers. Nothing is written when any step fails.
pub fn add(ledger: &mut Ledger, rec: &NewRecord) -> Result<Added, HistoryError> {
    let name = ledger.name().to_string();
    let id = ledger.write(|tx| insert(tx, &name, rec))?;
    Ok(Added {
        record: id,
        machine: rec.machine.as_str().to_string(),
        kind: rec.content.kind(),
        at: time::format_utc(rec.at),
        state: rec.state.as_str(),
        supersedes: rec.supersede.as_ref().map(|s| s.record),
        sha256: rec.result_sha256().to_string(),
        lines: rec.content.lines(),
        axes: rec.content.axes(),
    })
}

/// Adds many records in one transaction (the benchmark's way of filling a large ledger;
/// each record is checked as [`add`] checks it).
pub fn add_batch(ledger: &mut Ledger, recs: &[NewRecord]) -> Result<Vec<i64>, HistoryError> {
    let name = ledger.name().to_string();
    ledger.write(|tx| recs.iter().map(|r| insert(tx, &name, r)).collect())
}

/// What an add refuses before it writes: a time outside the window, an amendment
/// without a reason or of a record that is not current, a result already recorded, and
/// a second current record of one machine, axis and state at one instant.
fn check_new(tx: &mut ledger::Tx<'_>, ledger: &str, rec: &NewRecord) -> Result<(), HistoryError> {
    let latest = time::latest_at(time::now_utc());
    if rec.at < time::EARLIEST_S || rec.at > latest {
        return Err(HistoryError::OutsideWindow {
            ledger: ledger.to_string(),
            at: time::format_utc(rec.at),
            earliest: time::format_utc(time::EARLIEST_S),
            latest: time::format_utc(latest),
            skew_h: time::CLOCK_SKEW_S / 3600,
        });
    }
    let sha = rec.result_sha256().to_string();
    match &rec.supersede {
        Some(s) => {
            if s.reason.trim().is_empty() {
                return Err(HistoryError::EmptyReason {
                    ledger: ledger.to_string(),
                    record: s.record,
                });
            }
            let exists = tx.query_i64("SELECT id FROM record WHERE id = ?", &[&s.record])?;
            if exists.is_none() {
                return Err(HistoryError::NoSuchRecord {
                    ledger: ledger.to_string(),
                    record: s.record,
                });
            }
            if let Some(by) = tx.query_i64(
                "SELECT MIN(id) FROM record WHERE supersedes = ?",
                &[&s.record],
            )? {
                return Err(HistoryError::NotCurrent {
                    ledger: ledger.to_string(),
                    record: s.record,
                    by,
                });
            }
        }
        None => {
            if let Some(record) = tx.query_i64(
                "SELECT MIN(record) FROM source WHERE role = 'result' AND sha256 = ?",
                &[&sha],
            )? {
                return Err(HistoryError::Duplicate {
                    ledger: ledger.to_string(),
                    record,
                    sha256: sha,
                });
            }
        }
    }
    same_instant(tx, ledger, rec)
}

/// Refuses a second current record of the machine, axis (`XYZ` for a model) and state
/// at the instant of `rec` (the record it amends left out).
fn same_instant(
    tx: &mut ledger::Tx<'_>,
    ledger: &str,
    rec: &NewRecord,
) -> Result<(), HistoryError> {
    let at = time::format_utc(rec.at);
    let amended = rec.supersede.as_ref().map_or(0, |s| s.record);
    let axis = rec
        .content
        .axes()
        .into_iter()
        .next()
        .unwrap_or_else(|| "XYZ".to_string());
    let found = tx.query_i64(
        "SELECT MIN(r.id) FROM record r WHERE r.machine = ? AND r.state = ? AND r.at = ? \
         AND r.kind = ? AND r.id <> ? \
         AND NOT EXISTS (SELECT 1 FROM record s WHERE s.supersedes = r.id) \
         AND (r.kind = 'volumetric' OR EXISTS \
              (SELECT 1 FROM line_stat l WHERE l.record = r.id AND l.axis = ?))",
        &[
            &rec.machine.as_str(),
            &rec.state.as_str(),
            &at,
            &rec.content.kind(),
            &amended,
            &axis,
        ],
    )?;
    match found {
        None => Ok(()),
        Some(record) => Err(HistoryError::SameInstant {
            ledger: ledger.to_string(),
            record,
            machine: rec.machine.as_str().to_string(),
            axis,
            state: rec.state.as_str(),
            at,
        }),
    }
}

fn insert(tx: &mut ledger::Tx<'_>, ledger: &str, rec: &NewRecord) -> Result<i64, HistoryError> {
    check_new(tx, ledger, rec)?;
    let at = time::format_utc(rec.at);
    let added_at = time::format_utc(time::now_utc());
    let supersedes = rec.supersede.as_ref().map(|s| s.record);
    let reason = rec.supersede.as_ref().map(|s| s.reason.clone());
    let id = tx
        .query_i64(
            "INSERT INTO record (machine, site, state, at, kind, supersedes, reason, added_at, errmap_version) \
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
            &[
                &rec.machine.as_str(),
                &rec.site,
                &rec.state.as_str(),
                &at,
                &rec.content.kind(),
                &supersedes,
                &reason,
                &added_at,
                &env!("CARGO_PKG_VERSION"),
            ],
        )?
        .ok_or_else(|| HistoryError::Db {
            ledger: ledger.to_string(),
            source: DbError::NoId,
        })?;
    stall(id);
    for s in &rec.sources {
        tx.exec(
            "INSERT INTO source (record, role, path, sha256, bytes) VALUES (?, ?, ?, ?, ?)",
            &[&id, &s.role.as_str(), &s.path, &s.sha256, &s.bytes],
        )?;
    }
    match &rec.content {
        Content::Session { lines, .. } => {
            // Many rows a statement (one round trip to a server instead of one a row),
            // at most 64 so that SQLite's limit of 999 parameters is never reached.
            for chunk in lines.chunks(64) {
                let mut sql = String::from(
                    "INSERT INTO line_stat (record, axis, line_1_mm, line_2_mm, parameter, value, u_um) VALUES ",
                );
                let mut params: Vec<&dyn ledger::Param> = Vec::with_capacity(7 * chunk.len());
                for (i, l) in chunk.iter().enumerate() {
                    sql.push_str(if i == 0 { "" } else { ", " });
                    sql.push_str("(?, ?, ?, ?, ?, ?, ?)");
                    params.extend_from_slice(&[
                        &id,
                        &l.axis,
                        &l.line_mm.0,
                        &l.line_mm.1,
                        &l.parameter,
                        &l.value,
                        &l.u_um,
                    ]);
                }
                tx.exec(&sql, &params)?;
            }
        }
        Content::Volumetric { components } => {
            for c in components {
                tx.exec(
                    "INSERT INTO component (record, name, unit, identified, value, sigma, \"range\") \
                     VALUES (?, ?, ?, ?, ?, ?, ?)",
                    &[
                        &id,
                        &c.name,
                        &c.unit,
                        &i32::from(c.identified),
                        &c.value,
                        &c.sigma,
                        &c.range,
                    ],
                )?;
            }
        }
    }
    Ok(id)
}

/// The crash tests' seam: with `ERRMAP_HISTORY_STALL_MS` set (and no
/// `ERRMAP_HISTORY_STALL_AT`, which stalls after a given statement), an add says on
/// stderr that its record row is written and waits that long before the rest of the
/// record, so that a test can kill it inside its transaction. Unset (always, outside the
/// tests), nothing.
fn stall(id: i64) {
    if std::env::var_os("ERRMAP_HISTORY_STALL_AT").is_some() {
        return;
    }
    if let Some(ms) = std::env::var("ERRMAP_HISTORY_STALL_MS")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
    {
        eprintln!("history add: record {id} row written, the rest pending (stall {ms} ms)");
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}
