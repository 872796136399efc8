//! The calibration ledger at plant scale: a fleet of `machines` × `tests` × 3 axes
//! session records (one line each, the seven ISO 230-2 statistics, a sha256), added to a
//! SQLite file or a PostgreSQL database, then reported. Measured: the fill (one
//! transaction per machine), single adds (one transaction each, as `history add` does,
//! without reading a file), the report over the whole fleet (every machine's series,
//! charts, trends and forecasts, serialised as `--json` would print them; no figures),
//! and the report's peak resident memory.

use std::io::Write;
use std::time::Instant;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::base::{gaussian, median};
use crate::history::Tolerances;
use crate::history::{
    self, Content, HistoryError, Ledger, LineStat, MachineId, NewRecord, ReportConfig, Role, Run,
    SourceFile, State,
};

/// What was measured on one backend.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryBench {
    pub backend: String,
    pub machines: usize,
    pub tests: usize,
    pub records: usize,
    /// Filling the ledger, one transaction per machine: seconds and records/s.
    pub fill_s: f64,
    pub fill_records_per_s: f64,
    /// Median of single adds (one transaction each), ms.
    pub add_ms: f64,
    /// The whole fleet's report (JSON serialised, no figures), seconds.
    pub report_s: f64,
    /// Bytes of the report's JSON.
    pub report_json_bytes: u64,
    /// Peak resident memory while reporting, MB (Linux; the process's high-water mark
    /// reset before the report).
    pub report_peak_rss_mb: Option<f64>,
}

/// Counts bytes written.
struct Count(u64);

impl Write for Count {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0 += b.len() as u64;
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn record(machine: &MachineId, axis: &str, t: i64, value: f64, serial: u64) -> NewRecord {
    let stats = ["E", "E_up", "E_down", "A", "B", "R", "M"];
    let factors = [1.0, 0.9, 0.85, 1.3, 0.2, 0.3, 0.8];
    let lines = stats
        .iter()
        .zip(factors)
        .map(|(p, f)| LineStat {
            axis: axis.to_string(),
            line_mm: (0.0, 0.0),
            parameter: p,
            value: value * f,
            u_um: Some(1.2),
        })
        .collect();
    NewRecord {
        machine: machine.clone(),
        site: Some("bench".into()),
        state: State::AsFound,
        at: t,
        supersede: None,
        content: Content::Session {
            axis: axis.to_string(),
            lines,
        },
        sources: vec![SourceFile {
            role: Role::Result,
            path: format!("/bench/{serial}.parquet"),
            sha256: format!("{serial:064x}"),
            bytes: 1000,
        }],
    }
}

/// Resets the kernel's resident high-water mark of this process (Linux ≥ 4.0).
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Fills `ledger_spec` (an empty ledger) and measures.
pub fn run(ledger_spec: &str, machines: usize, tests: usize) -> Result<HistoryBench, HistoryError> {
    let mut ledger = Ledger::open(ledger_spec, true)?;
    let mut rng = StdRng::seed_from_u64(2027);
    let t0 = crate::history::parse_utc("2016-01-04").unwrap_or(0);
    let month = 30 * 86_400;
    let mut serial: u64 = 0;
    let start = Instant::now();
    for m in 0..machines {
        let id = MachineId::parse(&format!("M{m:05}")).unwrap_or_else(|| unreachable!());
        let drift: f64 = rng.random_range(0.0..2.0);
        let mut batch = Vec::with_capacity(tests * 3);
        for t in 0..tests {
            for axis in ["X", "Y", "Z"] {
                serial += 1;
                let v = 8.0 + drift * t as f64 / 12.0 + 0.5 * gaussian(&mut rng);
                batch.push(record(&id, axis, t0 + (3 * t as i64) * month, v, serial));
            }
        }
        history::add_batch(&mut ledger, &batch)?;
    }
    let fill_s = start.elapsed().as_secs_f64();
    let records = machines * tests * 3;
    // Single adds, as `history add` commits them.
    let extra = MachineId::parse("SINGLE").unwrap_or_else(|| unreachable!());
    let mut add_times = Vec::new();
    for k in 0..50 {
        serial += 1;
        let r = record(&extra, "X", t0 + k * month, 9.0, serial);
        let t = Instant::now();
        history::add(&mut ledger, &r)?;
        add_times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let tolerances = Tolerances::parse(
        std::path::Path::new("bench"),
        "[default]\nE = 40.0\nA = 50.0\n",
    )?;
    let rss_reset = reset_peak();
    let start = Instant::now();
    let mut sink = Count(0);
    {
        let mut run = Run::new(
            &mut ledger,
            ReportConfig {
                machine: None,
                tolerances,
                as_of: None,
                horizon_days: 365.0,
            },
        )?;
        let head = run.head().clone();
        let _ = serde_json::to_writer(&mut sink, &head);
        while let Some(m) = run.next_machine()? {
            let _ = serde_json::to_writer(&mut sink, &m);
        }
        let _ = serde_json::to_writer(&mut sink, &run.fleet());
    }
    let report_s = start.elapsed().as_secs_f64();
    let report_peak_rss_mb = if rss_reset {
        crate::acquire::peak_rss_mb()
    } else {
        None
    };
    Ok(HistoryBench {
        backend: ledger.backend().to_string(),
        machines,
        tests,
        records,
        fill_s,
        fill_records_per_s: records as f64 / fill_s,
        add_ms: median(&add_times),
        report_s,
        report_json_bytes: sink.0,
        report_peak_rss_mb,
    })
}

/// The measurements as a Markdown table (empty when there are none).
pub(crate) fn markdown(h: &[HistoryBench]) -> String {
    if h.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\nCalibration ledger (`history`):\n\n| backend | machines × tests × axes | fill, records/s | one add | report (JSON, no figures) | report peak RSS |\n|---|---|---|---|---|---|\n",
    );
    for b in h {
        s.push_str(&format!(
            "| {} | {} × {} × 3 = {} | {:.0} | {:.2} ms | {:.1} s ({:.0} MB of JSON) | {} |\n",
            b.backend,
            b.machines,
            b.tests,
            b.records,
            b.fill_records_per_s,
            b.add_ms,
            b.report_s,
            b.report_json_bytes as f64 / 1e6,
            b.report_peak_rss_mb
                .map_or("—".to_string(), |v| format!("{v:.0} MB"))
        ));
    }
    s
}
