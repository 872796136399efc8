//! The ledger: one schema on two databases, SQLite (a file, embedded) and PostgreSQL (a
//! server). Every statement is written once with `?` placeholders; PostgreSQL gets them
//! numbered (`$1`, `$2`, …). The database enforces what the contract promises:
//! append-only (triggers refuse UPDATE, DELETE and, on PostgreSQL, TRUNCATE on every
//! table), one current record per amendment chain (a unique index on `supersedes`), and
//! one add = one transaction that first takes the ledger's write lock (SQLite `BEGIN
//! IMMEDIATE`, PostgreSQL `LOCK TABLE record IN SHARE ROW EXCLUSIVE MODE`), so the
//! duplicate check and the insert see every add that committed before.

use std::path::Path;
use std::time::Duration;

use super::HistoryError;

/// What a database said: SQLite's error or the PostgreSQL server's (or driver's).
#[derive(Debug, thiserror::Error)]
pub enum DbError {
    /// SQLite's error, as its library words it.
    #[error("{0}")]
    Sqlite(#[from] rusqlite::Error),
    /// The PostgreSQL server's message (the driver's own words when the server said none).
    #[error("{}", pg_message(.0))]
    Postgres(#[from] postgres::Error),
    /// An INSERT … RETURNING gave no row.
    #[error("the insert returned no id")]
    NoId,
}

/// How long an add waits for another writer's lock (SQLite's busy timeout; PostgreSQL
/// waits without limit).
pub const LOCK_WAIT: Duration = Duration::from_secs(600);

/// The schema, SQLite dialect.
const SQLITE_SCHEMA: &str = r#"
CREATE TABLE IF NOT EXISTS record (
    id INTEGER PRIMARY KEY,
    machine TEXT NOT NULL,
    site TEXT,
    state TEXT NOT NULL CHECK (state IN ('as-found', 'as-left')),
    at TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN ('session', 'volumetric')),
    supersedes INTEGER REFERENCES record(id),
    reason TEXT,
    added_at TEXT NOT NULL,
    errmap_version TEXT NOT NULL,
    CHECK ((supersedes IS NULL) = (reason IS NULL))
);
CREATE TABLE IF NOT EXISTS source (
    record INTEGER NOT NULL REFERENCES record(id),
    role TEXT NOT NULL CHECK (role IN ('result', 'raw', 'description')),
    path TEXT NOT NULL,
    sha256 TEXT NOT NULL CHECK (length(sha256) = 64),
    bytes INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS line_stat (
    record INTEGER NOT NULL REFERENCES record(id),
    axis TEXT NOT NULL,
    line_1_mm REAL NOT NULL,
    line_2_mm REAL NOT NULL,
    parameter TEXT NOT NULL,
    value REAL NOT NULL,
    u_um REAL
);
CREATE TABLE IF NOT EXISTS component (
    record INTEGER NOT NULL REFERENCES record(id),
    name TEXT NOT NULL,
    unit TEXT NOT NULL,
    identified INTEGER NOT NULL CHECK (identified IN (0, 1)),
    value REAL,
    sigma REAL,
    "range" REAL
);
CREATE INDEX IF NOT EXISTS record_machine ON record(machine);
CREATE UNIQUE INDEX IF NOT EXISTS record_supersedes ON record(supersedes);
CREATE INDEX IF NOT EXISTS source_record ON source(record);
CREATE INDEX IF NOT EXISTS source_sha256 ON source(sha256);
CREATE INDEX IF NOT EXISTS line_stat_record ON line_stat(record);
CREATE INDEX IF NOT EXISTS component_record ON component(record);
"#;

const TABLES: [&str; 4] = ["record", "source", "line_stat", "component"];

fn sqlite_triggers() -> String {
    let mut s = String::new();
    for t in TABLES {
        for (op, lower) in [("UPDATE", "update"), ("DELETE", "delete")] {
            s += &format!(
                "CREATE TRIGGER IF NOT EXISTS {t}_no_{lower} BEFORE {op} ON {t} BEGIN \
                 SELECT RAISE(ABORT, 'the ledger is append-only: {op} on {t} refused'); END;\n"
            );
        }
    }
    s
}

/// The schema, PostgreSQL dialect (created once, under an advisory lock).
fn postgres_schema() -> String {
    let mut s = String::from(
        r#"
CREATE TABLE public.record (
    id bigserial PRIMARY KEY,
    machine text NOT NULL,
    site text,
    state text NOT NULL CHECK (state IN ('as-found', 'as-left')),
    at text NOT NULL,
    kind text NOT NULL CHECK (kind IN ('session', 'volumetric')),
    supersedes bigint REFERENCES public.record(id),
    reason text,
    added_at text NOT NULL,
    errmap_version text NOT NULL,
    CHECK ((supersedes IS NULL) = (reason IS NULL))
);
CREATE TABLE public.source (
    record bigint NOT NULL REFERENCES public.record(id),
    role text NOT NULL CHECK (role IN ('result', 'raw', 'description')),
    path text NOT NULL,
    sha256 text NOT NULL CHECK (length(sha256) = 64),
    bytes bigint NOT NULL
);
CREATE TABLE public.line_stat (
    record bigint NOT NULL REFERENCES public.record(id),
    axis text NOT NULL,
    line_1_mm double precision NOT NULL,
    line_2_mm double precision NOT NULL,
    parameter text NOT NULL,
    value double precision NOT NULL,
    u_um double precision
);
CREATE TABLE public.component (
    record bigint NOT NULL REFERENCES public.record(id),
    name text NOT NULL,
    unit text NOT NULL,
    identified integer NOT NULL CHECK (identified IN (0, 1)),
    value double precision,
    sigma double precision,
    "range" double precision
);
CREATE INDEX record_machine ON public.record(machine);
CREATE UNIQUE INDEX record_supersedes ON public.record(supersedes);
CREATE INDEX source_record ON public.source(record);
CREATE INDEX source_sha256 ON public.source(sha256);
CREATE INDEX line_stat_record ON public.line_stat(record);
CREATE INDEX component_record ON public.component(record);
CREATE FUNCTION public.errmap_append_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    RAISE EXCEPTION 'the ledger is append-only: % on % refused', TG_OP, TG_TABLE_NAME;
END $$;
"#,
    );
    for t in TABLES {
        s += &format!(
            "CREATE TRIGGER {t}_append_only BEFORE UPDATE OR DELETE ON public.{t} \
             FOR EACH ROW EXECUTE FUNCTION public.errmap_append_only();\n\
             CREATE TRIGGER {t}_no_truncate BEFORE TRUNCATE ON public.{t} \
             FOR EACH STATEMENT EXECUTE FUNCTION public.errmap_append_only();\n"
        );
    }
    s
}

/// `?` placeholders → `$1`, `$2`, … (no statement here has a `?` inside a literal).
fn numbered(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len() + 8);
    let mut n = 0;
    for c in sql.chars() {
        if c == '?' {
            n += 1;
            out += &format!("${n}");
        } else {
            out.push(c);
        }
    }
    out
}

/// A value both drivers can bind.
pub trait Param {
    fn sq(&self) -> &dyn rusqlite::ToSql;
    fn pg(&self) -> &(dyn postgres::types::ToSql + Sync);
}

impl<T: rusqlite::ToSql + postgres::types::ToSql + Sync> Param for T {
    fn sq(&self) -> &dyn rusqlite::ToSql {
        self
    }
    fn pg(&self) -> &(dyn postgres::types::ToSql + Sync) {
        self
    }
}

/// A PostgreSQL error with the server's own message (the driver's Display says only
/// "db error").
fn pg_message(e: &postgres::Error) -> String {
    match e.as_db_error() {
        Some(db) => format!("{}: {}", db.severity(), db.message()),
        None => {
            let mut m = e.to_string();
            let mut src = std::error::Error::source(e);
            while let Some(s) = src {
                m = format!("{m}: {s}");
                src = s.source();
            }
            m
        }
    }
}

enum Db {
    Sqlite(rusqlite::Connection),
    Postgres(Box<Pg>),
}

/// A PostgreSQL connection and the statements prepared on it, by SQL text. Preparing
/// once per connection instead of once per execution halves the round trips of every
/// statement (a fill of the benchmark's ledger runs millions); SQLite's connection
/// caches its own (`prepare_cached`).
struct Pg {
    client: postgres::Client,
    stmts: Statements,
}

type Statements = std::collections::HashMap<String, postgres::Statement>;

/// The statement for `sql` (`?` placeholders), prepared on `client` the first time.
fn prepared(
    client: &mut impl postgres::GenericClient,
    stmts: &mut Statements,
    sql: &str,
) -> Result<postgres::Statement, postgres::Error> {
    if let Some(st) = stmts.get(sql) {
        return Ok(st.clone());
    }
    let st = client.prepare(&numbered(sql))?;
    stmts.insert(sql.to_string(), st.clone());
    Ok(st)
}

/// An open ledger.
pub struct Ledger {
    db: Db,
    name: String,
}

impl std::fmt::Debug for Ledger {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ledger").field("name", &self.name).finish()
    }
}

/// Is `spec` a PostgreSQL address?
pub fn is_postgres(spec: &str) -> bool {
    spec.starts_with("postgres://") || spec.starts_with("postgresql://")
}

/// The address without its password, for messages.
fn display_name(spec: &str) -> String {
    if !is_postgres(spec) {
        return spec.to_string();
    }
    let (scheme, rest) = spec.split_once("://").unwrap_or(("", spec));
    match rest.split_once('@') {
        Some((user, host)) if user.contains(':') => {
            let u = user.split(':').next().unwrap_or("");
            format!("{scheme}://{u}:***@{host}")
        }
        _ => spec.to_string(),
    }
}

/// One row of `source`.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceRow {
    pub record: i64,
    pub role: String,
    pub path: String,
    pub sha256: String,
}

/// One point of a machine's series as read: the record, its time and state, the axis
/// and parameter, its unit and value.
#[derive(Debug, Clone, PartialEq)]
pub struct RawPoint {
    pub record: i64,
    pub at: String,
    pub state: String,
    pub axis: String,
    pub parameter: String,
    pub unit: String,
    pub value: f64,
}

/// What the report needs of one machine.
#[derive(Debug, Clone, Default)]
pub struct MachineRows {
    /// Its current records.
    pub records: i64,
    /// The latest non-null site of its current records.
    pub site: Option<String>,
    pub points: Vec<RawPoint>,
}

const CURRENT: &str = "NOT EXISTS (SELECT 1 FROM record s WHERE s.supersedes = r.id)";

/// Connects to a PostgreSQL ledger; creates the tables (an add) or starts the read
/// snapshot (a read).
fn open_postgres(spec: &str, name: &str, create: bool) -> Result<postgres::Client, HistoryError> {
    let db = |source: postgres::Error| HistoryError::Db {
        ledger: name.to_string(),
        source: source.into(),
    };
    let mut client =
        postgres::Client::connect(spec, postgres::NoTls).map_err(|e| HistoryError::Connect {
            ledger: name.to_string(),
            source: e.into(),
        })?;
    let exists = |c: &mut postgres::Client| -> Result<bool, postgres::Error> {
        let row = c.query_one("SELECT to_regclass('public.record') IS NOT NULL", &[])?;
        row.try_get::<_, bool>(0)
    };
    if !create {
        // One snapshot for the whole command: the records committed now, whole.
        client
            .batch_execute("BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY")
            .map_err(db)?;
        return match exists(&mut client).map_err(db)? {
            true => Ok(client),
            false => Err(HistoryError::NoLedger(name.to_string())),
        };
    }
    if exists(&mut client).map_err(db)? {
        return Ok(client);
    }
    // Two first adds at once: one creates, the other waits and finds the tables. A
    // session lock, so that the check after it runs in a new transaction that sees the
    // other's commit.
    client
        .execute("SELECT pg_advisory_lock(2705202617)", &[])
        .map_err(db)?;
    let created = (|| -> Result<(), postgres::Error> {
        let mut tx = client.transaction()?;
        let row = tx.query_one("SELECT to_regclass('public.record') IS NOT NULL", &[])?;
        if !row.try_get::<_, bool>(0)? {
            tx.batch_execute(&postgres_schema())?;
        }
        tx.commit()
    })();
    let unlocked = client.execute("SELECT pg_advisory_unlock(2705202617)", &[]);
    created.map_err(|e| HistoryError::Create {
        ledger: name.to_string(),
        source: e.into(),
    })?;
    unlocked.map_err(db)?;
    Ok(client)
}

/// What SQLite's refusal means for the ledger `name`: a journal this process may not
/// roll back, a damaged file (with what SQLite's integrity check finds, when `conn` can
/// still run it), or another failure.
fn sqlite_failure(
    name: &str,
    conn: Option<&rusqlite::Connection>,
    e: rusqlite::Error,
) -> HistoryError {
    use rusqlite::ffi;
    let codes = e.sqlite_error().map(|f| (f.code, f.extended_code));
    match codes {
        Some((_, ffi::SQLITE_READONLY_ROLLBACK | ffi::SQLITE_READONLY_RECOVERY)) => {
            HistoryError::Unrecovered {
                ledger: name.to_string(),
                journal: format!("{name}-journal"),
                source: e.into(),
            }
        }
        Some((rusqlite::ErrorCode::DatabaseCorrupt | rusqlite::ErrorCode::NotADatabase, _)) => {
            let found = conn.map(integrity_check).unwrap_or_default();
            HistoryError::Damaged {
                ledger: name.to_string(),
                source: e.into(),
                found,
            }
        }
        _ => HistoryError::Db {
            ledger: name.to_string(),
            source: e.into(),
        },
    }
}

/// What SQLite's `PRAGMA integrity_check` finds (at most 20 lines), empty when the file
/// is sound or the check itself cannot run.
fn integrity_check(conn: &rusqlite::Connection) -> Vec<String> {
    let run = || -> Result<Vec<String>, rusqlite::Error> {
        let mut st = conn.prepare("PRAGMA integrity_check(20)")?;
        let rows = st.query_map([], |r| r.get::<_, String>(0))?;
        rows.collect()
    };
    match run() {
        Ok(lines) if lines.len() == 1 && lines[0] == "ok" => Vec::new(),
        Ok(lines) => lines,
        Err(e) => vec![format!("the integrity check cannot run: {e}")],
    }
}

impl Ledger {
    /// Opens the ledger `spec` (a file path, or a `postgres://` address). With `create`
    /// (an add), a missing file and missing tables are created; without it (a read) they
    /// are an error, and every read of the returned ledger sees one snapshot: the records
    /// committed when it was opened, whole, whatever adds run meanwhile.
    pub fn open(spec: &str, create: bool) -> Result<Ledger, HistoryError> {
        let name = display_name(spec);
        if is_postgres(spec) {
            let client = open_postgres(spec, &name, create)?;
            return Ok(Ledger {
                db: Db::Postgres(Box::new(Pg {
                    client,
                    stmts: Statements::new(),
                })),
                name,
            });
        }
        let path = Path::new(spec);
        if !create && !path.is_file() {
            return Err(HistoryError::NoLedger(name));
        }
        // Read-write for reads too: a writer that died inside its transaction left its
        // rollback journal, and SQLite rolls it back the first time a connection that may
        // write reads the file, under its exclusive lock, which no add can hold meanwhile.
        // A read-only connection cannot, and refuses the file (SQLITE_READONLY_ROLLBACK).
        use rusqlite::OpenFlags;
        let mut flags = OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        if create {
            flags |= OpenFlags::SQLITE_OPEN_CREATE;
        }
        let conn = rusqlite::Connection::open_with_flags(path, flags)
            .map_err(|e| sqlite_failure(&name, None, e))?;
        let mut ledger = Ledger {
            db: Db::Sqlite(conn),
            name,
        };
        ledger.prepare_sqlite(create)?;
        Ok(ledger)
    }

    /// A new SQLite connection's settings, then the tables (an add) or the read
    /// snapshot and the check that the file holds a ledger (a read).
    fn prepare_sqlite(&mut self, create: bool) -> Result<(), HistoryError> {
        let Db::Sqlite(conn) = &mut self.db else {
            return Ok(());
        };
        let r = (|| -> Result<bool, rusqlite::Error> {
            conn.busy_timeout(LOCK_WAIT)?;
            conn.execute_batch("PRAGMA foreign_keys = ON;")?;
            if create {
                let tx =
                    conn.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
                tx.execute_batch(SQLITE_SCHEMA)?;
                tx.execute_batch(&sqlite_triggers())?;
                tx.commit()?;
                return Ok(true);
            }
            // The snapshot: a read transaction, its shared lock taken by the first read
            // and held until the command ends (an add waits for it to commit).
            conn.execute_batch("BEGIN DEFERRED")?;
            let n: i64 = conn.query_row(
                "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'record'",
                [],
                |r| r.get(0),
            )?;
            Ok(n > 0)
        })();
        match r {
            Ok(true) => Ok(()),
            Ok(false) => Err(HistoryError::NoLedger(self.name.clone())),
            Err(e) => Err(sqlite_failure(&self.name, Some(conn), e)),
        }
    }

    /// The ledger as named in messages (a PostgreSQL password hidden).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// `"sqlite"` or `"postgresql"`.
    pub fn backend(&self) -> &'static str {
        match self.db {
            Db::Sqlite(_) => "sqlite",
            Db::Postgres(_) => "postgresql",
        }
    }

    /// The history error for what the database said: SQLite's corruption is named as
    /// damage, with what its integrity check finds.
    fn fail(&self, source: DbError) -> HistoryError {
        match (source, &self.db) {
            (DbError::Sqlite(e), Db::Sqlite(c)) => sqlite_failure(&self.name, Some(c), e),
            (source, _) => HistoryError::Db {
                ledger: self.name.clone(),
                source,
            },
        }
    }

    /// Runs `f` in one write transaction holding the ledger's write lock; commits when
    /// `f` succeeds, rolls back otherwise.
    pub fn write<T>(
        &mut self,
        f: impl FnOnce(&mut Tx<'_>) -> Result<T, HistoryError>,
    ) -> Result<T, HistoryError> {
        let name = self.name.clone();
        let err = |source: DbError| HistoryError::Db {
            ledger: name.clone(),
            source,
        };
        match &mut self.db {
            Db::Sqlite(c) => {
                let tx = c
                    .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
                    .map_err(|e| err(e.into()))?;
                let mut t = Tx {
                    inner: TxInner::Sqlite(tx),
                    name: name.clone(),
                    statements: 0,
                };
                let v = f(&mut t)?;
                match t.inner {
                    TxInner::Sqlite(tx) => tx.commit().map_err(|e| err(e.into()))?,
                    TxInner::Postgres(..) => unreachable!("a SQLite transaction"),
                }
                Ok(v)
            }
            Db::Postgres(pg) => {
                let Pg { client, stmts } = &mut **pg;
                let mut tx = client.transaction().map_err(|e| err(e.into()))?;
                tx.batch_execute("LOCK TABLE public.record IN SHARE ROW EXCLUSIVE MODE")
                    .map_err(|e| err(e.into()))?;
                let mut t = Tx {
                    inner: TxInner::Postgres(tx, stmts),
                    name: name.clone(),
                    statements: 0,
                };
                let v = f(&mut t)?;
                match t.inner {
                    TxInner::Postgres(tx, _) => tx.commit().map_err(|e| err(e.into()))?,
                    TxInner::Sqlite(_) => unreachable!("a PostgreSQL transaction"),
                }
                Ok(v)
            }
        }
    }

    /// Rows of a query whose columns are all read by `read` (one closure per backend row
    /// type is avoided by reading through [`Cells`]).
    pub(super) fn query<T>(
        &mut self,
        sql: &str,
        params: &[&dyn Param],
        mut read: impl FnMut(&dyn Cells) -> Result<T, DbError>,
    ) -> Result<Vec<T>, HistoryError> {
        let r = match &mut self.db {
            Db::Sqlite(c) => (|| {
                let mut st = c.prepare_cached(sql)?;
                let p: Vec<&dyn rusqlite::ToSql> = params.iter().map(|p| p.sq()).collect();
                let mut rows = st.query(p.as_slice())?;
                let mut out = Vec::new();
                while let Some(row) = rows.next()? {
                    out.push(read(&SqliteRow(row))?);
                }
                Ok(out)
            })(),
            Db::Postgres(pg) => (|| {
                let p: Vec<&(dyn postgres::types::ToSql + Sync)> =
                    params.iter().map(|p| p.pg()).collect();
                let Pg { client, stmts } = &mut **pg;
                let st = prepared(client, stmts, sql)?;
                let rows = client.query(&st, &p)?;
                rows.iter().map(|r| read(&PgRow(r))).collect()
            })(),
        };
        r.map_err(|e| self.fail(e))
    }

    /// Calls `f` on every `source` row, in record order, without holding them all.
    pub fn for_each_source(&mut self, mut f: impl FnMut(SourceRow)) -> Result<(), HistoryError> {
        const SQL: &str =
            "SELECT record, role, path, sha256 FROM source ORDER BY record, role, path";
        let read = |c: &dyn Cells| -> Result<SourceRow, DbError> {
            Ok(SourceRow {
                record: c.i64(0)?,
                role: c.text(1)?.unwrap_or_default(),
                path: c.text(2)?.unwrap_or_default(),
                sha256: c.text(3)?.unwrap_or_default(),
            })
        };
        let r = match &mut self.db {
            Db::Sqlite(c) => (|| {
                let mut st = c.prepare(SQL)?;
                let mut rows = st.query([])?;
                while let Some(row) = rows.next()? {
                    f(read(&SqliteRow(row))?);
                }
                Ok(())
            })(),
            Db::Postgres(pg) => (|| {
                use postgres::fallible_iterator::FallibleIterator;
                let none: [&(dyn postgres::types::ToSql + Sync); 0] = [];
                let mut rows = pg.client.query_raw(SQL, none.iter().copied())?;
                while let Some(row) = rows.next()? {
                    f(read(&PgRow(&row))?);
                }
                Ok(())
            })(),
        };
        r.map_err(|e| self.fail(e))
    }

    /// What SQLite's integrity check finds in the file (nothing on PostgreSQL, whose
    /// server checks its own pages).
    pub fn integrity(&self) -> Vec<String> {
        match &self.db {
            Db::Sqlite(c) => integrity_check(c),
            Db::Postgres(_) => Vec::new(),
        }
    }

    /// (all records, superseded records).
    pub fn counts(&mut self) -> Result<(i64, i64), HistoryError> {
        let all = self.query("SELECT COUNT(*) FROM record", &[], |c| c.i64(0))?;
        let sup = self.query(
            "SELECT COUNT(*) FROM record r WHERE EXISTS (SELECT 1 FROM record s WHERE s.supersedes = r.id)",
            &[],
            |c| c.i64(0),
        )?;
        Ok((
            all.first().copied().unwrap_or(0),
            sup.first().copied().unwrap_or(0),
        ))
    }

    /// The latest `at` of the current records at or before `latest` (seconds), with
    /// its record: a record dated later (in the future when it was added, before the
    /// ledger refused such dates) does not move it.
    pub fn latest_current_at(&mut self, latest: i64) -> Result<Option<i64>, HistoryError> {
        let bound = super::time::format_utc(latest);
        let b: &dyn Param = &bound;
        let v = self.query(
            &format!(
                "SELECT r.id, r.at FROM record r WHERE {CURRENT} AND r.at <= ? \
                 ORDER BY r.at DESC, r.id DESC LIMIT 1"
            ),
            &[b],
            |c| Ok((c.i64(0)?, c.text(1)?.unwrap_or_default())),
        )?;
        match v.into_iter().next() {
            None => Ok(None),
            Some((record, at)) => {
                super::time::parse_utc(&at)
                    .map(Some)
                    .map_err(|source| HistoryError::Stored {
                        ledger: self.name.clone(),
                        record,
                        source,
                    })
            }
        }
    }

    /// The machines of the current records, sorted (byte order).
    pub fn current_machines(&mut self) -> Result<Vec<String>, HistoryError> {
        let mut v = self.query(
            &format!("SELECT DISTINCT r.machine FROM record r WHERE {CURRENT}"),
            &[],
            |c| Ok(c.text(0)?.unwrap_or_default()),
        )?;
        v.sort();
        Ok(v)
    }

    /// Everything the report needs of `machine`'s current records: per record, axis and
    /// parameter the worst line's value (sessions), and the identified components
    /// (models: a squareness' value, a function's range).
    pub fn machine_rows(&mut self, machine: &str) -> Result<MachineRows, HistoryError> {
        let m: &dyn Param = &machine;
        let records = self.query(
            &format!("SELECT COUNT(*) FROM record r WHERE r.machine = ? AND {CURRENT}"),
            &[m],
            |c| c.i64(0),
        )?;
        let site = self.query(
            &format!(
                "SELECT r.site FROM record r WHERE r.machine = ? AND {CURRENT} AND r.site IS NOT NULL \
                 ORDER BY r.at DESC, r.id DESC LIMIT 1"
            ),
            &[m],
            |c| c.text(0),
        )?;
        let mut points = self.query(
            &format!(
                "SELECT r.id, r.at, r.state, l.axis, l.parameter, MAX(l.value) FROM record r \
                 JOIN line_stat l ON l.record = r.id WHERE r.machine = ? AND {CURRENT} \
                 GROUP BY r.id, r.at, r.state, l.axis, l.parameter"
            ),
            &[m],
            |c| {
                Ok(RawPoint {
                    record: c.i64(0)?,
                    at: c.text(1)?.unwrap_or_default(),
                    state: c.text(2)?.unwrap_or_default(),
                    axis: c.text(3)?.unwrap_or_default(),
                    parameter: c.text(4)?.unwrap_or_default(),
                    unit: "um".into(),
                    value: c.f64(5)?.unwrap_or(f64::NAN),
                })
            },
        )?;
        let components = self.query(
            &format!(
                "SELECT r.id, r.at, r.state, c.name, c.unit, c.value, c.\"range\" FROM record r \
                 JOIN component c ON c.record = r.id WHERE r.machine = ? AND {CURRENT} \
                 AND c.identified = 1"
            ),
            &[m],
            |c| {
                let name = c.text(3)?.unwrap_or_default();
                let value = if super::ingest::SQUARENESS.contains(&name.as_str()) {
                    c.f64(5)?
                } else {
                    c.f64(6)?
                };
                Ok(RawPoint {
                    record: c.i64(0)?,
                    at: c.text(1)?.unwrap_or_default(),
                    state: c.text(2)?.unwrap_or_default(),
                    axis: "XYZ".into(),
                    parameter: name,
                    unit: c.text(4)?.unwrap_or_default(),
                    value: value.unwrap_or(f64::NAN),
                })
            },
        )?;
        points.extend(components.into_iter().filter(|p| p.value.is_finite()));
        Ok(MachineRows {
            records: records.first().copied().unwrap_or(0),
            site: site.into_iter().next().flatten(),
            points,
        })
    }
}

/// Column access common to both drivers' rows.
pub(super) trait Cells {
    fn i64(&self, i: usize) -> Result<i64, DbError>;
    fn f64(&self, i: usize) -> Result<Option<f64>, DbError>;
    fn text(&self, i: usize) -> Result<Option<String>, DbError>;
}

struct SqliteRow<'a, 'b>(&'a rusqlite::Row<'b>);

impl Cells for SqliteRow<'_, '_> {
    fn i64(&self, i: usize) -> Result<i64, DbError> {
        Ok(self.0.get(i)?)
    }
    fn f64(&self, i: usize) -> Result<Option<f64>, DbError> {
        Ok(self.0.get(i)?)
    }
    fn text(&self, i: usize) -> Result<Option<String>, DbError> {
        Ok(self.0.get(i)?)
    }
}

struct PgRow<'a>(&'a postgres::Row);

impl Cells for PgRow<'_> {
    fn i64(&self, i: usize) -> Result<i64, DbError> {
        Ok(self.0.try_get(i)?)
    }
    fn f64(&self, i: usize) -> Result<Option<f64>, DbError> {
        Ok(self.0.try_get(i)?)
    }
    fn text(&self, i: usize) -> Result<Option<String>, DbError> {
        Ok(self.0.try_get(i)?)
    }
}

enum TxInner<'a> {
    Sqlite(rusqlite::Transaction<'a>),
    Postgres(postgres::Transaction<'a>, &'a mut Statements),
}

/// A write transaction of [`Ledger::write`].
pub struct Tx<'a> {
    inner: TxInner<'a>,
    name: String,
    /// Statements run so far (the crash tests' seam counts them).
    statements: u32,
}

impl std::fmt::Debug for Tx<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tx").field("ledger", &self.name).finish()
    }
}

impl Tx<'_> {
    fn done(&mut self, r: Result<Option<i64>, DbError>) -> Result<Option<i64>, HistoryError> {
        self.statements += 1;
        stall_after(self.statements);
        r.map_err(|source| HistoryError::Db {
            ledger: self.name.clone(),
            source,
        })
    }

    /// Executes one statement.
    pub fn exec(&mut self, sql: &str, params: &[&dyn Param]) -> Result<(), HistoryError> {
        let r = match &mut self.inner {
            TxInner::Sqlite(t) => (|| {
                let mut st = t.prepare_cached(sql)?;
                let p: Vec<&dyn rusqlite::ToSql> = params.iter().map(|p| p.sq()).collect();
                st.execute(p.as_slice())?;
                Ok(None)
            })(),
            TxInner::Postgres(t, stmts) => (|| {
                let p: Vec<&(dyn postgres::types::ToSql + Sync)> =
                    params.iter().map(|p| p.pg()).collect();
                let st = prepared(t, stmts, sql)?;
                t.execute(&st, &p)?;
                Ok(None)
            })(),
        };
        self.done(r).map(|_| ())
    }

    /// The first column of the first row, an integer, or `None` (no row, or NULL).
    pub fn query_i64(
        &mut self,
        sql: &str,
        params: &[&dyn Param],
    ) -> Result<Option<i64>, HistoryError> {
        let r = match &mut self.inner {
            TxInner::Sqlite(t) => (|| {
                let mut st = t.prepare_cached(sql)?;
                let p: Vec<&dyn rusqlite::ToSql> = params.iter().map(|p| p.sq()).collect();
                let mut rows = st.query(p.as_slice())?;
                match rows.next()? {
                    Some(row) => Ok(row.get::<_, Option<i64>>(0)?),
                    None => Ok(None),
                }
            })(),
            TxInner::Postgres(t, stmts) => (|| {
                let p: Vec<&(dyn postgres::types::ToSql + Sync)> =
                    params.iter().map(|p| p.pg()).collect();
                let st = prepared(t, stmts, sql)?;
                let rows = t.query(&st, &p)?;
                match rows.first() {
                    Some(row) => Ok(row.try_get::<_, Option<i64>>(0)?),
                    None => Ok(None),
                }
            })(),
        };
        self.done(r)
    }
}

/// The crash tests' seam: with `ERRMAP_HISTORY_STALL_AT=N` and `ERRMAP_HISTORY_STALL_MS`
/// set, an add says on stderr that the N-th statement of its transaction is done and
/// waits that long before the next, so that a test can kill the client or the server
/// there. Unset (always, outside the tests), nothing.
fn stall_after(statement: u32) {
    let var = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u64>().ok());
    let (at, ms) = (
        var("ERRMAP_HISTORY_STALL_AT"),
        var("ERRMAP_HISTORY_STALL_MS"),
    );
    if let (Some(at), Some(ms)) = (at, ms) {
        if at != u64::from(statement) {
            return;
        }
        eprintln!("history add: statement {statement} done, the rest pending (stall {ms} ms)");
        std::thread::sleep(Duration::from_millis(ms));
    }
}
