//! The calibration certificate read as a reader would: the PDF's text extracted with
//! poppler's `pdftotext` and every printed statistic compared with the computed one at the
//! printed precision; every page rendered with `pdftoppm`. When poppler-utils are not
//! installed those tests print a skip message (`.ci/run` installs them when it can).
//! Also the info TOML through the binary, and a real positioning record.

use crate::util::{errmap, real_record, root};
use std::path::Path;
use std::process::Command;

use errmap::report::certificate::{
    self, CertificateData, CertificateInfo, LineResult, axis_rows, certificate_decimals, mm,
    target_rows,
};
use errmap::session::AxisStats;
use errmap::session::{self, read_session};
use errmap::session::{Budget, UncertaintyConfig, line_budget};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn have(tool: &str) -> bool {
    let ok = Command::new(tool)
        .arg("-v")
        .output()
        .is_ok_and(|o| o.status.success() || !o.stderr.is_empty());
    if !ok {
        eprintln!("skipped: `{tool}` (poppler-utils) is not installed");
    }
    ok
}

struct Computed {
    iso: Vec<((f64, f64), AxisStats)>,
    budgets: Vec<Budget>,
    rows: Vec<errmap::drivers::SessionRow>,
}

fn compute(path: &Path) -> Result<Computed, Box<dyn std::error::Error>> {
    let rows = read_session(path)?;
    let (iso, failed) = session::iso_by_line(&rows);
    assert!(failed.is_empty(), "{failed:?}");
    let budgets = iso
        .iter()
        .map(|(_, s)| line_budget(&UncertaintyConfig::default(), &rows, s).map(|(b, _)| b))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Computed { iso, budgets, rows })
}

fn render(c: &Computed, info: &CertificateInfo) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let data = CertificateData {
        source: "test session",
        axis: "X",
        rows: &c.rows,
        lines: c
            .iso
            .iter()
            .zip(&c.budgets)
            .map(|((line_mm, stats), budget)| LineResult {
                line_mm: *line_mm,
                stats,
                budget,
            })
            .collect(),
        info,
    };
    Ok(certificate::render(&data)?)
}

/// Decimals of a printed number.
fn printed_decimals(s: &str) -> i32 {
    s.split_once('.').map_or(0, |(_, f)| f.len() as i32)
}

/// The printed value equals the computed one at the printed precision.
fn agrees(printed: &str, computed: &str, what: &str) {
    if printed == "—" || computed == "—" {
        assert_eq!(printed, computed, "{what}");
        return;
    }
    let p: f64 = printed.parse().unwrap_or(f64::NAN);
    let c: f64 = computed.parse().unwrap_or(f64::NAN);
    let half = 0.5 * 10f64.powi(-printed_decimals(printed)) + 1e-12;
    assert!(
        (p - c).abs() <= half,
        "{what}: printed {printed}, computed {computed}"
    );
    assert_eq!(
        printed_decimals(printed),
        printed_decimals(computed),
        "{what}: precision"
    );
}

/// Extracts the text with `pdftotext -layout` and checks every per-target and axis value
/// of every line, in order, against the statistics computed from the session.
fn check_text(pdf: &[u8], c: &Computed, dir: &Path) -> TestResult {
    let file = dir.join("certificate.pdf");
    std::fs::write(&file, pdf)?;
    let out = Command::new("pdftotext")
        .args(["-layout", "-enc", "UTF-8"])
        .arg(&file)
        .arg("-")
        .output()?;
    assert!(out.status.success(), "pdftotext failed");
    let text = String::from_utf8(out.stdout)?;
    let lines: Vec<Vec<&str>> = text
        .lines()
        .map(|l| l.split_whitespace().collect())
        .collect();
    let mut cursor = 0;
    let mut checked = 0;
    let lines_of: Vec<LineResult> = c
        .iso
        .iter()
        .zip(&c.budgets)
        .map(|((line_mm, stats), budget)| LineResult {
            line_mm: *line_mm,
            stats,
            budget,
        })
        .collect();
    let d = certificate_decimals(&lines_of);
    for ((_, stats), budget) in c.iso.iter().zip(&c.budgets) {
        for want in target_rows(stats, d) {
            // The row that starts with this target's index and position.
            let at = lines[cursor..]
                .iter()
                .position(|t| t.len() == want.len() && t[0] == want[0] && t[1] == want[1])
                .map(|k| k + cursor)
                .ok_or_else(|| format!("no row for target {} in:\n{text}", want[0]))?;
            for (k, (p, w)) in lines[at].iter().zip(&want).enumerate().skip(2) {
                agrees(p, w, &format!("target {} column {k}", want[0]));
                checked += 1;
            }
            cursor = at + 1;
        }
        for want in axis_rows(stats, budget, d) {
            // "E systematic positional deviation 0.0330 0.0246 0.0368 0.0773": the last
            // four tokens are ↑, ↓, bidirectional and U.
            // The symbol may be two words ("Ps max").
            let sym = want[0].split_whitespace().count();
            let name = sym + want[1].split_whitespace().count();
            let at = lines[cursor..]
                .iter()
                .position(|t| {
                    t.len() == name + 4
                        && t[..sym].join(" ") == want[0]
                        && t[sym..name].join(" ") == want[1]
                })
                .map(|k| k + cursor)
                .ok_or_else(|| format!("no row {want:?} in:\n{text}"))?;
            let got = &lines[at][name..];
            for (p, w) in got.iter().zip(&want[2..]) {
                agrees(p, w, &want[1]);
                checked += 1;
            }
            cursor = at + 1;
        }
    }
    let per_line: usize = c
        .iso
        .iter()
        .map(|(_, s)| 8 * s.targets.len() + 12 * 4)
        .sum();
    assert_eq!(checked, per_line, "every value was found and checked");
    // Each page renders.
    let pages = text.matches('\u{c}').count().max(1);
    let png = dir.join("page");
    let st = Command::new("pdftoppm")
        .args(["-r", "40", "-png"])
        .arg(&file)
        .arg(&png)
        .status()?;
    assert!(st.success(), "pdftoppm failed");
    let rendered = std::fs::read_dir(dir)?
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".png"))
        })
        .count();
    assert_eq!(rendered, pages, "one image per page");
    Ok(())
}

#[test]
fn certificate_prints_every_statistic_as_computed() -> TestResult {
    if !(have("pdftotext") && have("pdftoppm")) {
        return Ok(());
    }
    let c = compute(&root().join("datasets/physics/example-session.parquet"))?;
    let pdf = render(&c, &CertificateInfo::default())?;
    assert!(pdf.starts_with(b"%PDF-"));
    check_text(&pdf, &c, tempfile::tempdir()?.path())
}

/// A nanometre-scale record: its values keep their digits (4 decimals of µm, not 3).
#[test]
fn nanometre_record_keeps_its_digits_in_the_certificate() -> TestResult {
    let Some(p) = real_record("psi-fat_sat.csv") else {
        return Ok(());
    };
    let c = compute(&p)?;
    assert_eq!(errmap::report::iso230_decimals(&c.iso[0].1), 4);
    if !(have("pdftotext") && have("pdftoppm")) {
        return Ok(());
    }
    let pdf = render(&c, &CertificateInfo::default())?;
    check_text(&pdf, &c, tempfile::tempdir()?.path())
}

#[test]
fn info_fields_are_printed_and_a_misspelt_key_is_an_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let info = dir.path().join("info.toml");
    std::fs::write(
        &info,
        "lab = \"Example Metrology Lab\"\noperator = \"A. N. Other\"\ndate_of_test = \"2026-11-30\"\n\
         [laser]\nserial = \"L-1234\"\ncalibrated = \"2026-03-01\"\n[uncertainty]\nair_temp_k = 0.05\n",
    )?;
    let out = dir.path().join("c.pdf");
    let o = errmap(&[
        "certificate",
        "datasets/physics/example-session.parquet",
        "--info",
        info.to_str().ok_or("utf8")?,
        "--out",
        out.to_str().ok_or("utf8")?,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    if have("pdftotext") {
        let t = Command::new("pdftotext").arg(&out).arg("-").output()?;
        let text = String::from_utf8(t.stdout)?;
        for s in [
            "Example Metrology Lab",
            "A. N. Other",
            "2026-11-30",
            "L-1234",
        ] {
            assert!(text.contains(s), "{s:?} missing");
        }
    }
    // A misspelt key, a bad date, a negative uncertainty: exit 1 naming file and key.
    for (body, key) in [
        ("operater = \"x\"\n", "operater"),
        ("[laser]\nserail = \"x\"\n", "serail"),
        ("date_of_test = \"2026-02-30\"\n", "date_of_test"),
        (
            "[uncertainty]\nair_temp_k = -1.0\n",
            "uncertainty.air_temp_k",
        ),
    ] {
        std::fs::write(&info, body)?;
        let o = errmap(&[
            "certificate",
            "datasets/physics/example-session.parquet",
            "--info",
            info.to_str().ok_or("utf8")?,
            "--out",
            out.to_str().ok_or("utf8")?,
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{body}: {e}");
        assert!(e.contains(key) && e.contains("info.toml"), "{body}: {e}");
    }
    Ok(())
}

/// Real ecmc test records against the values their own reports print (mm there, µm
/// here, to the report's print precision): B, M and A, and the report's
/// "R = max(R_fwd, R_bwd)" — which is max(R↑, R↓), not ISO 230-2's R (the record's R and E
/// are known to be computed wrongly: see the converted data set's README).
#[test]
fn real_records_match_the_values_their_reports_print() -> TestResult {
    // (file, B, M, A, max(R↑, R↓), tolerance = half the report's last digit)
    let cases = [
        ("b02-x.csv", 33.58, 93.65, 135.27, 28.31, 0.005),
        ("psi-fat_sat.csv", 0.0122, 0.0277, 0.08881, 0.0629, 0.00005),
    ];
    for (name, b, m, a, r_uni, tol) in cases {
        let Some(p) = real_record(name) else {
            continue;
        };
        let c = compute(&p)?;
        assert_eq!(c.iso.len(), 1, "{name}");
        let s = &c.iso[0].1;
        for (got, want, what) in [
            (s.b_um, b, "B"),
            (s.m_um, m, "M"),
            (s.a_um, a, "A"),
            (s.r_up_um.max(s.r_down_um), r_uni, "max(R↑, R↓)"),
        ] {
            assert!(
                (got - want).abs() <= tol + 1e-9,
                "{name} {what}: {got} vs {want}"
            );
        }
        // Positions print without float noise.
        for (row, t) in target_rows(s, 4).iter().zip(&s.targets) {
            assert_eq!(row[1], mm(t.position_mm));
            assert!(printed_decimals(&row[1]) <= 4, "{}", row[1]);
        }
    }
    Ok(())
}

/// The text of a PDF (`pdftotext -layout`), without the line naming the session file (a
/// path that depends on where the command ran).
fn pdf_text(pdf: &Path) -> Result<String, Box<dyn std::error::Error>> {
    let t = Command::new("pdftotext")
        .arg("-layout")
        .arg(pdf)
        .arg("-")
        .output()?;
    assert!(t.status.success(), "pdftotext {}", pdf.display());
    Ok(String::from_utf8(t.stdout)?
        .lines()
        .filter(|l| !l.trim_start().starts_with("Session "))
        .collect::<Vec<_>>()
        .join("\n"))
}

/// The committed example certificates are what today's code prints: regenerated with the
/// commands of `reports/certificate/README.md`, their text equals the committed PDFs'
/// (a change to the statistics, the budget or the layout must regenerate them).
#[test]
fn committed_certificates_are_not_stale() -> TestResult {
    if !have("pdftotext") {
        return Ok(());
    }
    let dir = tempfile::tempdir()?;
    let mut cases = vec![(
        "reports/certificate/example-session.pdf",
        vec![
            "datasets/physics/example-session.parquet".to_string(),
            "--info".into(),
            "datasets/certificate/example-info.toml".into(),
        ],
    )];
    if let Some(p) = real_record("psi-fat_sat.csv") {
        cases.push((
            "reports/certificate/psi-fat_sat.pdf",
            vec![p.to_str().ok_or("utf8")?.to_string()],
        ));
    }
    for (committed, args) in cases {
        let out = dir.path().join("c.pdf");
        let mut a: Vec<&str> = vec!["certificate"];
        a.extend(args.iter().map(String::as_str));
        a.extend(["--out", out.to_str().ok_or("utf8")?]);
        let o = errmap(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (now, then) = (pdf_text(&out)?, pdf_text(&root().join(committed))?);
        if now != then {
            let first = now
                .lines()
                .zip(then.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            panic!(
                "{committed} is stale (regenerate it, reports/certificate/README.md); first \
                 difference at text line {first}:\n now: {:?}\n committed: {:?}",
                now.lines().nth(first),
                then.lines().nth(first)
            );
        }
    }
    Ok(())
}

/// pdftotext of a PDF file, or `None` (skipping) without poppler.
fn text_of(pdf: &Path) -> Option<String> {
    if !have("pdftotext") {
        return None;
    }
    let t = Command::new("pdftotext").arg(pdf).arg("-").output().ok()?;
    String::from_utf8(t.stdout).ok()
}

/// What a laboratory's certificate has, read from the PDF's text: the coverage sentence,
/// the traceability statement, an issue date apart from the test date, lines named by
/// coordinates, the test parameters, the laser set-up and the controller's state, B̄, the
/// budget's sources; the session named by its file only (no path leaves the repository).
#[test]
fn certificate_has_what_a_laboratory_certificate_has() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("c.pdf");
    let o = errmap(&[
        "certificate",
        "datasets/physics/example-session.parquet",
        "--info",
        "datasets/certificate/example-info.toml",
        "--out",
        out.to_str().ok_or("utf8")?,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Some(text) = text_of(&out) else {
        return Ok(());
    };
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    for s in [
        "k = 2, which for a normal distribution corresponds to a coverage probability of approximately 95 %",
        "Traceability",
        "Date of issue 2026-12-02",
        "2026-11-30, 09:10 to 09:55",
        "y = 1 mm, z = 200 mm",
        "Test parameters",
        "Feed",
        "Dwell at a target",
        "Overrun beyond the end targets",
        "Targets P_i / mm 0, 100, 200, 300, 400, 500, 600, 700, 800",
        "Laser set-up linear optics",
        "Controller compensation",
        "As found / as left as found",
        "Expansion coefficient used 11.5 ppm/K",
        "B\u{304}",
        "laser resolution 0.0791 µm (stated in the info file ([laser] resolution_um))",
        "Session example-session.parquet",
    ] {
        assert!(flat.contains(s), "{s:?} missing from:\n{flat}");
    }
    assert!(
        !flat.contains("(1, 200)") && !flat.contains("datasets/physics/"),
        "{flat}"
    );
    // Page 1 is the summary: the results and the coverage sentence come before the test
    // parameters.
    let page1 = text.split('\u{c}').next().unwrap_or_default();
    assert!(page1.contains("Results") && page1.contains("approximately 95 %"));
    Ok(())
}

/// A capture directory's HELLO (λ/8 laser count, 0.1 µm scale count) sets the budget's
/// resolutions: U(R) of every line is at least 0.065 µm and the certificate says the
/// HELLO is its source. Fewer than 5 runs is stated.
#[test]
fn capture_resolution_reaches_the_certificate() -> TestResult {
    let dir = tempfile::tempdir()?;
    let cap = dir.path().join("capture");
    std::fs::create_dir(&cap)?;
    std::fs::copy(
        root().join("datasets/physics/example-session.parquet"),
        cap.join("session.parquet"),
    )?;
    std::fs::write(
        cap.join("session.json"),
        r#"{"hello": {"protocol_version": 1, "device_id": "SIM", "grating_period_nm": 20000,
        "count_resolution_pm": 100000, "laser_wavelength_fm": 632991354, "optical_fold": 2,
        "edges_per_fringe": 4, "axis": "X"}}"#,
    )?;
    let out = dir.path().join("c.pdf");
    let o = errmap(&[
        "certificate",
        cap.to_str().ok_or("utf8")?,
        "--out",
        out.to_str().ok_or("utf8")?,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Some(text) = text_of(&out) else {
        return Ok(());
    };
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("the device's HELLO: λ_vac/(F·k) = 632.991354 nm/(2·4)"),
        "{flat}"
    );
    assert!(flat.contains("scale count resolution 100000 pm"), "{flat}");
    // "… U = 1.2345 µm over the 800 mm travel (E, M, A, P, Pa), 0.1041 µm at one target"
    let mut seen = 0;
    for part in flat.split(" µm at one target") {
        if let Some(v) = part.rsplit(' ').next().and_then(|v| v.parse::<f64>().ok()) {
            assert!(v >= 0.065, "U(R) {v} below the laser count's");
            seen += 1;
        }
    }
    assert!(seen >= 4, "{flat}");
    Ok(())
}

/// An imported record with no sensors says where its environment terms come from and
/// invents no sensor.
#[test]
fn certificate_without_sensors_says_where_its_environment_comes_from() -> TestResult {
    let Some(p) = real_record("psi-fat_sat.csv") else {
        return Ok(());
    };
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("c.pdf");
    let o = errmap(&[
        "certificate",
        p.to_str().ok_or("utf8")?,
        "--out",
        out.to_str().ok_or("utf8")?,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Some(text) = text_of(&out) else {
        return Ok(());
    };
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("no air sensor and no declared air conditions"),
        "{flat}"
    );
    assert!(
        flat.contains("Not evaluated (no source): air temperature"),
        "{flat}"
    );
    assert!(!flat.contains("air temperature sensor 0.1000 K"), "{flat}");
    assert!(!flat.contains("../shared"), "{flat}");
    Ok(())
}
