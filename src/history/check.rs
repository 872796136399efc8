//! `history verify`: the files every record came from, re-hashed, and the ledger itself
//! checked — SQLite's integrity check of the file, every record whole (its result file,
//! its statistics or components), no row of no record, and no current record dated
//! outside the window the ledger takes (`time::EARLIEST_S`, `time::CLOCK_SKEW_S` after
//! the moment it was added).

use serde::Serialize;

use super::ledger::{Cells, DbError, Ledger};
use super::{HistoryError, ingest, time};

/// A source whose file changed.
#[derive(Debug, Clone, Serialize)]
pub struct Changed {
    pub record: i64,
    pub path: String,
    pub role: String,
    pub expected: String,
    pub actual: String,
}

/// A source whose file is gone (or unreadable).
#[derive(Debug, Clone, Serialize)]
pub struct Missing {
    pub record: i64,
    pub path: String,
    pub role: String,
}

/// Something wrong in the ledger itself: the record it concerns (none for the file as a
/// whole) and what.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Problem {
    pub record: Option<i64>,
    pub problem: String,
}

/// What `history verify --json` prints.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Verification {
    pub checked: u64,
    pub changed: Vec<Changed>,
    pub missing: Vec<Missing>,
    /// What is wrong in the ledger itself (empty for a sound ledger).
    pub damage: Vec<Problem>,
}

impl Verification {
    /// Nothing changed, vanished or damaged.
    pub fn is_sound(&self) -> bool {
        self.changed.is_empty() && self.missing.is_empty() && self.damage.is_empty()
    }
}

/// Checks the ledger, then re-hashes every source of every record (superseded ones too).
pub fn verify(ledger: &mut Ledger) -> Result<Verification, HistoryError> {
    let mut v = Verification {
        damage: damage(ledger)?,
        ..Verification::default()
    };
    ledger.for_each_source(|s| {
        v.checked += 1;
        match ingest::sha256_file(std::path::Path::new(&s.path)) {
            Ok((actual, _)) if actual == s.sha256 => {}
            Ok((actual, _)) => v.changed.push(Changed {
                record: s.record,
                path: s.path,
                role: s.role,
                expected: s.sha256,
                actual,
            }),
            Err(_) => v.missing.push(Missing {
                record: s.record,
                path: s.path,
                role: s.role,
            }),
        }
    })?;
    Ok(v)
}

/// The rules a sound ledger keeps, each a query for the records that break it (at most
/// 100 each) and the words for one.
const RULES: [(&str, &str); 4] = [
    (
        "SELECT r.id FROM record r WHERE NOT EXISTS \
         (SELECT 1 FROM source s WHERE s.record = r.id AND s.role = 'result') ORDER BY r.id LIMIT 100",
        "has no result file",
    ),
    (
        "SELECT r.id FROM record r WHERE r.kind = 'session' AND \
         ((SELECT COUNT(*) FROM line_stat l WHERE l.record = r.id) = 0 OR \
          (SELECT COUNT(*) FROM line_stat l WHERE l.record = r.id) % 7 <> 0) ORDER BY r.id LIMIT 100",
        "a session without all its statistics (7 per line)",
    ),
    (
        "SELECT r.id FROM record r WHERE r.kind = 'volumetric' AND \
         (SELECT COUNT(*) FROM component c WHERE c.record = r.id) <> 21 ORDER BY r.id LIMIT 100",
        "a model without its 21 components",
    ),
    (
        "SELECT DISTINCT x.record FROM (SELECT record FROM source UNION ALL SELECT record FROM line_stat \
         UNION ALL SELECT record FROM component) x WHERE NOT EXISTS \
         (SELECT 1 FROM record r WHERE r.id = x.record) ORDER BY x.record LIMIT 100",
        "rows of a record that does not exist",
    ),
];

/// What is wrong in the ledger itself.
fn damage(ledger: &mut Ledger) -> Result<Vec<Problem>, HistoryError> {
    let mut out: Vec<Problem> = ledger
        .integrity()
        .into_iter()
        .map(|problem| Problem {
            record: None,
            problem: format!("SQLite's integrity check: {problem}"),
        })
        .collect();
    let id = |c: &dyn Cells| -> Result<i64, DbError> { c.i64(0) };
    for (sql, words) in RULES {
        for record in ledger.query(sql, &[], id)? {
            out.push(Problem {
                record: Some(record),
                problem: format!("record {record}: {words}"),
            });
        }
    }
    // Dates: the current records dated before the earliest or after the moment they
    // were added, then the window (with its clock skew) checked on each.
    let earliest = time::format_utc(time::EARLIEST_S);
    let dated = ledger.query(
        "SELECT r.id, r.at, r.added_at FROM record r \
         WHERE NOT EXISTS (SELECT 1 FROM record s WHERE s.supersedes = r.id) \
         AND (r.at < ? OR r.at > r.added_at) ORDER BY r.id LIMIT 10000",
        &[&earliest],
        |c| {
            Ok((
                c.i64(0)?,
                c.text(1)?.unwrap_or_default(),
                c.text(2)?.unwrap_or_default(),
            ))
        },
    )?;
    for (record, at, added_at) in dated.into_iter().take(100) {
        let (Ok(at_s), Ok(added_s)) = (time::parse_utc(&at), time::parse_utc(&added_at)) else {
            out.push(Problem {
                record: Some(record),
                problem: format!(
                    "record {record}: its time {at:?} or {added_at:?} is not in the stored form"
                ),
            });
            continue;
        };
        if at_s < time::EARLIEST_S || at_s > time::latest_at(added_s) {
            out.push(Problem {
                record: Some(record),
                problem: format!(
                    "record {record}: dated {at}, outside the window the ledger takes \
                     ({} … the moment it was added, {added_at}, + {} h): reports ignore it \
                     for their default date; amend it with its true date",
                    time::format_utc(time::EARLIEST_S),
                    time::CLOCK_SKEW_S / 3600
                ),
            });
        }
    }
    Ok(out)
}
