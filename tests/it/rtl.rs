//! The Renishaw `.rtl` reader on both layouts it accepts (issue 40 item 12), with test
//! files written by us: the import contract's (positions on the `Targets :` line,
//! deviations straight after `DEVIATIONS::`) and the one genuine Laser10 files show, as a
//! public parser written against them reads it (`Targets :` alone with the positions on
//! the lines after it, a `Run Target Data:` line opening the deviations, `Version no`,
//! `Filetype`, `Env factor`, `Exp coeff` and `Final Data` lines). Both give the same
//! rows; a wrong Run-count is blamed on its own line, a stray deviation on its line, and
//! an impossible start time ("25:00:00") on the Date Time line (issue 40 item 9).

use std::path::Path;

use errmap::import::{self, ImportOptions, SessionFormat};

/// Targets 0, 25, 50, 75, 100 mm; 4 passes (2 bidirectional runs), deviation x (µm) =
/// 0.5·run − 0.01·position.
const TARGETS: [f64; 5] = [0.0, 25.0, 50.0, 75.0, 100.0];

fn deviation(run: usize, target: usize) -> f64 {
    0.5 * run as f64 - 0.01 * TARGETS[target - 1]
}

/// The targets of pass `run` in the order it visits them: out on odd passes, back on even.
fn order(run: usize) -> Vec<usize> {
    if run % 2 == 1 {
        (1..=5).collect()
    } else {
        (1..=5).rev().collect()
    }
}

/// The deviation lines of 4 passes, out and back.
fn deviations() -> String {
    let mut t = String::new();
    for run in 1..=4usize {
        for tg in order(run) {
            t.push_str(&format!("{run}  {tg}  {:.4}\r\n", deviation(run, tg)));
        }
    }
    t
}

/// The contract's layout.
fn contract(run_count: usize, start: &str) -> String {
    format!(
        "HEADER::\r\nFile type : rtl\r\nOwner : Linear\r\n\r\nTARGET DATA::\r\nTarget-count : 5\r\n\
         Targets : 0 25 50 75 100\r\nFlags: 0 0\r\n\r\nRUNS::\r\nRun-count : {run_count}\r\n\r\n\
         DEVIATIONS::\r\n{}\r\nENVIRONMENT::\r\nAir temp : 20.0 20.4\r\n\
         Date Time : \"03/04/2021 {start}\" \"03/04/2021 10:19:00\"\r\n\r\nUSER-TEXT::\r\nAxis : X\r\n",
        deviations()
    )
}

/// The layout of genuine files.
fn genuine(run_count: usize, start: &str) -> String {
    format!(
        "HEADER::\r\nFile type : rtl\r\nOwner : Linear\r\nVersion no : 2\r\n\r\nTARGET DATA::\r\n\
         Filetype : Linear\r\nTarget-count : 5\r\nFlags : 0 0\r\nTargets :\r\n0.0000  25.0000  50.0000\r\n\
         75.0000  100.0000\r\n\r\nUSER-TEXT::\r\nMachine : mill 7\r\nSerial No : 123\r\nAxis : X\r\n\r\n\
         RUNS::\r\nRun-count : {run_count}\r\n\r\nDEVIATIONS::\r\nRun Target Data:\r\n{}\r\n\
         ENVIRONMENT::\r\nAir temp : 20.0 20.4 20.2\r\nAir press : 101.3 101.3 101.3\r\n\
         Air humid : 45 45 45\r\nMat temp 1 : 20.1 20.3 20.2\r\nEnv factor : 0.9 1.1 1.0\r\n\
         Exp coeff : 11.7\r\nDate Time : \"03/04/2021 {start}\" \"03/04/2021 10:19:00\" \"\"\r\n\
         Final Data : 1 2 3\r\n",
        deviations()
    )
}

fn read(text: &str) -> Result<import::Imported, String> {
    import::import_session(
        Path::new("t.rtl"),
        text.as_bytes(),
        &ImportOptions {
            format: SessionFormat::Auto,
            axis: None,
        },
    )
    .map_err(|e| e.to_string())
}

/// The 1-based line of the first line of `text` that starts with `prefix`.
fn line_of(text: &str, prefix: &str) -> usize {
    text.split("\r\n")
        .position(|l| l.starts_with(prefix))
        .expect("line")
        + 1
}

#[test]
fn both_layouts_read_to_the_same_rows_from_the_files_numbers() {
    for text in [contract(4, "10:00:00"), genuine(4, "10:00:00")] {
        let got = read(&text).expect("rtl");
        assert_eq!(got.summary.format, "renishaw-rtl");
        assert_eq!((got.summary.runs, got.summary.directions), (Some(2), 2));
        assert_eq!(got.rows.len(), 20);
        let mut k = 0;
        for run in 1..=4usize {
            for tg in order(run) {
                let r = &got.rows[k];
                let x = deviation(run, tg);
                assert_eq!(r.run as usize, run.div_ceil(2));
                assert_eq!(r.direction, if run % 2 == 1 { 1 } else { -1 });
                assert_eq!(r.x_mm, Some(TARGETS[tg - 1]));
                assert!((r.error_um + x).abs() < 1e-9, "{} vs {x}", r.error_um);
                k += 1;
            }
        }
        // 19 minutes over 20 readings: Δt = 60 s.
        assert!(
            (got.rows[19].t_s - 1140.0).abs() < 1e-9,
            "{}",
            got.rows[19].t_s
        );
        assert_eq!(got.rows[0].air_temp_c, Some(20.0));
    }
}

#[test]
fn a_wrong_run_count_is_blamed_on_its_own_line() {
    for text in [
        contract(3, "10:00:00"),
        genuine(3, "10:00:00"),
        genuine(6, "10:00:00"),
    ] {
        let e = read(&text).expect_err("refused");
        let line = line_of(&text, "Run-count");
        assert!(e.starts_with(&format!("t.rtl: line {line}:")), "{e}");
        assert!(
            e.contains("Run-count") && e.contains("4 complete run"),
            "{e}"
        );
    }
    // One stray deviation line (run 9) is the line at fault, not the count.
    let text = genuine(4, "10:00:00").replace("3  2  ", "9  2  ");
    let e = read(&text).expect_err("refused");
    let line = line_of(&text, "9  2  ");
    assert!(e.starts_with(&format!("t.rtl: line {line}:")), "{e}");
}

#[test]
fn an_impossible_time_of_day_is_refused_at_the_date_time_line() {
    for text in [contract(4, "25:00:00"), genuine(4, "10:61:00")] {
        let e = read(&text).expect_err("refused");
        let line = line_of(&text, "Date Time");
        assert!(e.starts_with(&format!("t.rtl: line {line}:")), "{e}");
        assert!(e.contains("not a time of day"), "{e}");
    }
    // Past midnight is a time, not an error: 23:50 → 00:09 is 19 minutes.
    let text = contract(4, "23:50:00").replace("10:19:00", "00:09:00");
    let got = read(&text).expect("past midnight");
    assert!((got.rows[19].t_s - 1140.0).abs() < 1e-9);
}
