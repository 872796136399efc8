//! Streaming session tables (issue 13): the batched writer gives the bytes of the
//! whole-table writer, the batched reader gives back the rows and names the file's row
//! on bad input, replay streams to the same table as decoding the capture in memory.

use std::path::Path;

use errmap::acquire::replay;
use errmap::drivers::decode_all;
use errmap::drivers::longrun::write_long_capture;
use errmap::session::{
    BATCH_ROWS, SessionWriter, for_each_batch, read_session, read_session_every,
    read_session_thinned, write_session,
};
use errmap::table::TableError;
use errmap_drivers::SessionRow;

fn capture(min_bytes: u64) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_long_capture(&mut bytes, min_bytes, 3, 200.0).expect("in memory");
    bytes
}

fn streamed(path: &Path, rows: &[SessionRow], batch: usize) -> Vec<u8> {
    let mut w = SessionWriter::with_batch(path, batch).expect("create");
    for (i, r) in rows.iter().enumerate() {
        w.push(r.clone()).expect("push");
        if i % 97 == 0 {
            w.flush().expect("flush");
        }
    }
    assert_eq!(w.finish().expect("finish"), rows.len() as u64);
    std::fs::read(path).expect("read back")
}

#[test]
fn streamed_tables_are_byte_identical_to_the_whole_table_writer() {
    let (rows, _, _) = decode_all(&capture(1));
    assert!(rows.len() > 10_000, "{} rows", rows.len());
    let dir = tempfile::tempdir().expect("tempdir");
    for ext in ["csv", "parquet"] {
        let whole = dir.path().join(format!("whole.{ext}"));
        write_session(&whole, &rows).expect("write");
        let whole = std::fs::read(&whole).expect("read");
        // CSV: any batching; Parquet: the writers' own row groups of BATCH_ROWS rows.
        let batches: &[usize] = if ext == "csv" {
            &[1, 777, 1 << 16]
        } else {
            &[1 << 16]
        };
        for &b in batches {
            let got = streamed(&dir.path().join(format!("s{b}.{ext}")), &rows, b);
            assert!(got == whole, "{ext}, batch {b}: bytes differ");
        }
    }
}

#[test]
fn a_parquet_table_in_many_row_groups_reads_back_row_for_row_in_batches() {
    let (rows, _, _) = decode_all(&capture(1));
    let dir = tempfile::tempdir().expect("tempdir");
    for ext in ["csv", "parquet"] {
        let p = dir.path().join(format!("t.{ext}"));
        streamed(&p, &rows, 1000);
        assert_eq!(read_session(&p).expect("read"), rows, "{ext}");
        let mut back = Vec::new();
        let mut sizes = Vec::new();
        let n = for_each_batch(&p, 4096, &mut |b| {
            sizes.push(b.len());
            back.extend_from_slice(b);
            Ok(())
        })
        .expect("batches");
        assert_eq!(n, rows.len() as u64);
        assert!(
            sizes.iter().all(|&s| s <= 4096) && sizes.len() > 1,
            "{sizes:?}"
        );
        assert_eq!(back, rows, "{ext}");
    }
}

/// A repeated (run, sample) inside a later batch, or across two batches, names the
/// file's rows, as the whole-table read does (regression: within a batch the rows used to
/// be counted from the batch's start).
#[test]
fn a_repeated_sample_in_a_batched_read_names_the_files_rows() {
    let (rows, _, _) = decode_all(&capture(1));
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("t.csv");
    // Data row 300 (0-based 299) repeats data row 290 (same batch of 64: rows 257–320),
    // data row 400 repeats data row 10 (an earlier batch).
    for (copy, of) in [(299usize, 289usize), (399, 9)] {
        let mut damaged = rows[..500].to_vec();
        damaged[copy].run = damaged[of].run;
        damaged[copy].sample = damaged[of].sample;
        write_session(&p, &damaged).expect("write");
        let e = for_each_batch(&p, 64, &mut |_| Ok(())).expect_err("repeat");
        match &e {
            TableError::DuplicateSample {
                row,
                line,
                first_row,
                ..
            } => assert_eq!((*row, *line, *first_row), (copy + 1, copy + 2, of + 1)),
            other => panic!("unexpected error {other}"),
        }
        assert_eq!(
            read_session(&p).expect_err("repeat").to_string(),
            e.to_string()
        );
    }
}

#[test]
fn a_bad_cell_deep_in_a_batched_read_names_the_files_row_and_line() {
    let (rows, _, _) = decode_all(&capture(1));
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("t.csv");
    write_session(&p, &rows[..500]).expect("write");
    let text = std::fs::read_to_string(&p).expect("read");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Data row 300 is line 301; its `laser_mm` (12th column) becomes text.
    let mut cells: Vec<String> = lines[300].split(',').map(str::to_string).collect();
    cells[11] = "oops".into();
    lines[300] = cells.join(",");
    std::fs::write(&p, lines.join("\n") + "\n").expect("write");
    let e = for_each_batch(&p, 64, &mut |_| Ok(())).expect_err("bad cell");
    match e {
        TableError::NotNumeric {
            row, line, column, ..
        } => {
            assert_eq!((row, line, column.as_str()), (300, 301, "laser_mm"));
        }
        other => panic!("unexpected error {other}"),
    }
    let whole = read_session(&p).expect_err("bad cell");
    assert_eq!(
        whole.to_string(),
        for_each_batch(&p, 64, &mut |_| Ok(()))
            .expect_err("bad")
            .to_string()
    );
}

#[test]
fn streamed_replay_writes_the_table_of_the_capture_decoded_in_memory() {
    // Two line sessions back to back, > 1 MiB: several read chunks.
    let bytes = capture(1_500_000);
    let dir = tempfile::tempdir().expect("tempdir");
    let raw = dir.path().join("raw.bin");
    std::fs::write(&raw, &bytes).expect("write raw");
    let (rows, stats, hello) = decode_all(&bytes);
    for ext in ["csv", "parquet"] {
        let out = dir.path().join(format!("replay.{ext}"));
        let r = replay(&raw, &out).expect("replay");
        assert_eq!(r.rows, rows.len() as u64);
        assert_eq!(r.stats, stats);
        assert_eq!(r.hello, hello);
        // CSV: the whole-table writer's bytes. Parquet (more rows than one batch here):
        // the streaming writer's row groups of BATCH_ROWS, as live capture writes them.
        let reference = dir.path().join(format!("reference.{ext}"));
        if ext == "csv" {
            write_session(&reference, &rows).expect("write");
        } else {
            assert!(rows.len() > BATCH_ROWS, "{} rows", rows.len());
            streamed(&reference, &rows, BATCH_ROWS);
        }
        assert!(
            std::fs::read(&out).expect("o") == std::fs::read(&reference).expect("r"),
            "{ext}"
        );
        assert_eq!(read_session(&out).expect("read"), rows, "{ext}");
    }
}

/// Serves a capture in 4 KiB reads; halfway through, reads the session table on disk
/// (what a kill at that moment would leave) and keeps it. A Parquet table has no footer
/// before the end, so only a CSV table is read.
struct Peeking {
    bytes: Vec<u8>,
    at: usize,
    table: std::path::PathBuf,
    seen: Option<Vec<SessionRow>>,
}

impl errmap_drivers::ByteSource for Peeking {
    fn read_bytes(
        &mut self,
        buf: &mut [u8],
    ) -> Result<errmap_drivers::ReadOutcome, errmap_drivers::TransportError> {
        if self.at >= self.bytes.len() {
            return Ok(errmap_drivers::ReadOutcome::Eof);
        }
        let csv = self.table.extension().is_some_and(|e| e == "csv");
        if csv && self.seen.is_none() && self.at >= self.bytes.len() / 2 {
            self.seen = Some(read_session(&self.table).expect("the table mid-capture is valid"));
        }
        let n = buf.len().min(4096).min(self.bytes.len() - self.at);
        buf[..n].copy_from_slice(&self.bytes[self.at..self.at + n]);
        self.at += n;
        Ok(errmap_drivers::ReadOutcome::Data(n))
    }
}

#[test]
fn capture_streams_rows_to_the_table_and_equals_replay_of_its_raw_file() {
    use errmap::acquire::{SessionPaths, capture_session};
    use errmap::drivers::capture::CaptureConfig;
    let bytes = capture(1_500_000);
    let (rows, _, _) = decode_all(&bytes);
    let dir = tempfile::tempdir().expect("tempdir");
    for ext in ["csv", "parquet"] {
        let paths = SessionPaths::new(&dir.path().join(ext), ext);
        let mut source = Peeking {
            bytes: bytes.clone(),
            at: 0,
            table: paths.table.clone(),
            seen: None,
        };
        let config = CaptureConfig {
            fsync_every: std::time::Duration::ZERO,
            ..CaptureConfig::default()
        };
        let stop = std::sync::atomic::AtomicBool::new(false);
        let cap =
            capture_session(&mut source, &paths, &config, &stop, &mut |_| {}).expect("capture");
        assert_eq!(cap.rows, rows.len() as u64);
        let replayed = dir.path().join(format!("replayed.{ext}"));
        replay(&paths.raw, &replayed).expect("replay");
        assert!(
            std::fs::read(&paths.table).expect("t") == std::fs::read(&replayed).expect("r"),
            "{ext}: capture and replay differ"
        );
        if ext == "csv" {
            // Halfway, the CSV on disk held every row decoded so far: a prefix of the
            // session, more than a third of it.
            let seen = source.seen.expect("peeked");
            assert!(
                seen.len() > rows.len() / 3,
                "{} of {}",
                seen.len(),
                rows.len()
            );
            assert_eq!(seen[..], rows[..seen.len()]);
        }
    }
}

/// The error table computed the plain way, two passes over the rows in memory: per
/// (line µm, target) the mean and sample standard deviation of the unflagged dwell errors
/// (rows without air values left out when any row has them), the node's coordinate along
/// the axis the mean scale reading per target rounded to 0.1 µm.
fn two_pass(rows: &[SessionRow]) -> Vec<([f64; 3], f64, usize, Option<f64>)> {
    use std::collections::BTreeMap;
    let air = |r: &SessionRow| {
        r.air_temp_c.is_some() && r.air_pressure_hpa.is_some() && r.air_rh_pct.is_some()
    };
    let any_air = rows.iter().any(air);
    let a = errmap::base::Axis::from(rows[0].axis).index();
    let mut groups: BTreeMap<(i64, i64, i32), Vec<f64>> = BTreeMap::new();
    let mut along: BTreeMap<i32, Vec<f64>> = BTreeMap::new();
    for r in rows {
        if r.target < 0 || r.run == 0 || r.flags != 0 || (any_air && !air(r)) {
            continue;
        }
        let c = [r.x_mm, r.y_mm, r.z_mm];
        let o: Vec<Option<f64>> = (0..3).filter(|&b| b != a).map(|b| c[b]).collect();
        let (Some(c1), Some(c2)) = (o[0], o[1]) else {
            continue;
        };
        let key = (
            (c1 * 1e3).round() as i64,
            (c2 * 1e3).round() as i64,
            r.target,
        );
        groups.entry(key).or_default().push(r.error_um);
        along.entry(r.target).or_default().push(r.scale_mm);
    }
    groups
        .iter()
        .map(|(&(c1, c2, t), e)| {
            let p = &along[&t];
            let at = (p.iter().sum::<f64>() / p.len() as f64 * 1e4).round() / 1e4;
            let mut others = [c1 as f64 / 1e3, c2 as f64 / 1e3].into_iter();
            let pos: [f64; 3] = std::array::from_fn(|b| {
                if b == a {
                    at
                } else {
                    others.next().unwrap_or(0.0)
                }
            });
            let n = e.len();
            let mean = e.iter().sum::<f64>() / n as f64;
            let s = (n > 1).then(|| {
                (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
            });
            (pos, mean, n, s)
        })
        .collect()
}

fn sessions() -> Vec<std::path::PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = vec![root.join("datasets/physics/example-session.parquet")];
    let real = crate::util::real_records_dir();
    if let Ok(dir) = std::fs::read_dir(&real) {
        let mut csv: Vec<_> = dir
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "csv"))
            .collect();
        csv.sort();
        out.extend(csv);
    }
    out
}

#[test]
fn the_streamed_reduction_matches_the_two_pass_error_table_on_recorded_sessions() {
    use errmap::session::{Reducer, iso_by_line};
    let mut checked = 0;
    for path in sessions() {
        let rows = read_session(&path).expect("session");
        let mut red = Reducer::new();
        for_each_batch(&path, 1000, &mut |b| {
            b.iter().for_each(|r| red.push(r));
            Ok(())
        })
        .expect("batches");
        let name = path.display().to_string();
        let (table, summary) = red.error_table(&name).expect("reduces");
        let want = two_pass(&rows);
        assert_eq!(table.points.len(), want.len(), "{name}");
        assert_eq!(
            summary.used,
            want.iter().map(|w| w.2).sum::<usize>(),
            "{name}"
        );
        let mut points = table.points.clone();
        points.sort_by(|p, q| {
            (p.y_mm, p.z_mm, p.x_mm)
                .partial_cmp(&(q.y_mm, q.z_mm, q.x_mm))
                .expect("finite")
        });
        let mut want = want;
        want.sort_by(|p, q| {
            (p.0[1], p.0[2], p.0[0])
                .partial_cmp(&(q.0[1], q.0[2], q.0[0]))
                .expect("finite")
        });
        for (p, (pos, mean, n, s)) in points.iter().zip(&want) {
            assert_eq!([p.x_mm, p.y_mm, p.z_mm], *pos, "{name}");
            assert_eq!(p.n, Some(*n as u32), "{name}");
            let tol = 1e-12 * (1.0 + mean.abs());
            assert!((p.e_um - mean).abs() <= tol, "{name}: {} vs {mean}", p.e_um);
            match (p.s_um, s) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() <= 1e-9 * (1.0 + b), "{name}: s {a} vs {b}")
                }
                (a, b) => assert_eq!(a, *b, "{name}"),
            }
        }
        // ISO 230-2 statistics: streamed in batches = computed on the rows in memory.
        let (ok, failed) = red.iso_by_line();
        let (ok_all, failed_all) = iso_by_line(&rows);
        assert_eq!(format!("{ok:?}"), format!("{ok_all:?}"), "{name}");
        assert_eq!(failed.len(), failed_all.len(), "{name}");
        checked += 1;
    }
    assert!(checked >= 1);
}

#[test]
fn the_streaming_benchmark_reduces_a_generated_capture_to_its_known_nodes() {
    // One line session (~3.3 MB at 1 kHz): one line × 11 targets.
    let b = errmap::acquire::stream_bench(1.0).expect("bench");
    assert!(b.capture_bytes >= 1_000_000);
    assert!(b.rows > 100_000, "{} rows", b.rows);
    assert_eq!(b.nodes, 11);
    assert!(b.replay_mb_s > 0.0 && b.table_mb_s > 0.0);
}

fn replay_peak_rss_mb(dir: &Path, mb: f64) -> (f64, u64) {
    let bin = env!("CARGO_BIN_EXE_errmap");
    let raw = dir.join(format!("raw-{mb}.bin"));
    let o = std::process::Command::new(bin)
        .args(["gen-capture", "--mb", &mb.to_string(), "--out"])
        .arg(&raw)
        .output()
        .expect("gen-capture runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = std::process::Command::new(bin)
        .arg("replay")
        .arg(&raw)
        .arg("--out")
        .arg(dir.join(format!("t-{mb}.parquet")))
        .arg("--json")
        .output()
        .expect("replay runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    (
        v["peak_rss_mb"].as_f64().expect("peak_rss_mb (Linux)"),
        v["rows"].as_u64().expect("rows"),
    )
}

/// Regression for issue 13 (replay held every row: 2.6 GB for a 200 MB capture): a capture
/// six times longer replays in about the same memory.
#[test]
fn replay_memory_does_not_grow_with_the_capture() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (small_mb, small_rows) = replay_peak_rss_mb(dir.path(), 3.0);
    let (large_mb, large_rows) = replay_peak_rss_mb(dir.path(), 18.0);
    assert!(
        large_rows >= 5 * small_rows,
        "{large_rows} vs {small_rows} rows"
    );
    // Holding the rows would add ≥ 168 B per row: ≥ 80 MB for the extra ~500 000 rows.
    assert!(
        large_mb < small_mb + 30.0,
        "peak RSS {large_mb:.0} MB for {large_rows} rows vs {small_mb:.0} MB for {small_rows}"
    );
}

/// A session thinned to a row budget keeps every 2ᵏ-th device sample, the smallest such
/// stride within the budget, and the same samples as a read of every stride-th sample.
#[test]
fn a_session_thinned_to_a_budget_keeps_every_power_of_two_th_sample() {
    let (rows, _, _) = decode_all(&capture(1));
    let n = rows.len();
    assert!(n > 10_000, "{n} rows");
    let dir = tempfile::tempdir().expect("tempdir");
    for ext in ["csv", "parquet"] {
        let path = dir.path().join(format!("s.{ext}"));
        write_session(&path, &rows).expect("write");
        // Within the budget: everything.
        let all = read_session_thinned(&path, n).expect("read");
        assert_eq!((all.stride, all.total, all.rows.len()), (1, n as u64, n));
        // A third of it: the stride is the first power of two that fits.
        let budget = n / 3;
        let t = read_session_thinned(&path, budget).expect("read");
        let expect_kept = |s: i64| rows.iter().filter(|r| r.sample % s == 0).count();
        let mut stride = 1;
        while expect_kept(stride) > budget {
            stride *= 2;
        }
        assert_eq!(t.stride, stride, "{ext}");
        assert_eq!(t.stride, 4, "{ext}: {n} rows in thirds");
        assert_eq!(t.total, n as u64);
        assert!(t.rows.len() <= budget && t.rows.len() == expect_kept(stride));
        let expected: Vec<SessionRow> = rows
            .iter()
            .filter(|r| r.sample % stride == 0)
            .cloned()
            .collect();
        assert!(t.rows == expected, "{ext}: thinned rows differ");
        let (every, total) = read_session_every(&path, stride).expect("read");
        assert!(every == expected && total == n as u64);
    }
}
