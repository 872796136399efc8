//! A rotary axis in the workbench (`docs/workbench.md`, `docs/rotary.md`): a captured B
//! axis is a session item whose document is `errmap table --json`'s, whose page shows
//! the library's ISO 230-2 figures in ″ (° beside) and its closure check, whose chart is
//! in ″ against ° over the revolution, and whose downloads are the rotary commands'
//! files; a live capture from a simulated rotary board reports ° and ″, and its target
//! means are the dwell means of the session it leaves on disk.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::rotary::{plan_revolution, simulate_capture};
use super::util::{errmap, json, s, stderr};
use super::workbench::{Server, events, form_token, get, request};
use errmap::session::rotary::{read_rotary_session, rotary_iso};

/// A B axis with an eccentricity, a reversal and a ratio error of 8 ppm (about 10″ over
/// the revolution: the closure pair disagrees), with positioning scatter and noise.
const MODEL: &str = "[rotary]\naxis = \"B\"\npositioning_arcsec = 0.5\nnoise_arcsec = 0.3\n\
    seed = 5\n\n[[rotary.effects]]\nid = \"eccentricity\"\namplitude_arcsec = 4.0\n\
    phase_deg = 30.0\n\n[[rotary.effects]]\nid = \"reversal\"\nb_arcsec = 3.0\n\n\
    [[rotary.effects]]\nid = \"scale_factor\"\nppm = 8.0\n";

/// A workspace holding the rotary model, a rotary plan (every 45°, 2 runs) and the
/// capture of the model's board (its default cycle: every 15°, 5 runs) in `rot/cap`.
pub(super) fn rotary_workspace(dir: &Path) -> PathBuf {
    let ws = dir.join("ws");
    std::fs::create_dir_all(ws.join("rot")).expect("mkdir");
    let model = ws.join("rot/rotary-model.toml");
    std::fs::write(&model, MODEL).expect("model");
    let o = plan_revolution(
        "b",
        &[
            "--interval",
            "45",
            "--runs",
            "2",
            "--out",
            s(&ws.join("rot/rotary-plan.toml")),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = simulate_capture(&model, &ws.join("rot/cap"));
    assert!(o.status.success(), "{}", stderr(&o));
    ws
}

#[test]
fn a_rotary_session_is_a_page_in_arcseconds_with_the_rotary_downloads() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = rotary_workspace(dir.path());
    let srv = Server::start(&ws, &[]);
    let a = srv.addr.as_str();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");

    let items = get(a, "/api/items").json();
    let cap = items["items"]
        .as_array()
        .expect("items")
        .iter()
        .find(|i| i["id"] == "rot/cap")
        .expect("the capture is an item")
        .clone();
    assert_eq!(
        (cap["kind"].as_str(), cap["axis"].as_str()),
        (Some("session"), Some("B"))
    );

    // The document is the command's.
    let cli = json(&errmap(&[
        "table",
        s(&ws.join("rot/cap")),
        "--out",
        s(&out.join("t.csv")),
        "--json",
    ]));
    assert_eq!(get(a, "/api/table/rot/cap").json(), cli);

    // The page shows the library's figures in ″ with ° beside, and the closure check.
    let table = ws.join("rot/cap/session.csv");
    let session = read_rotary_session(&table).expect("a rotary session");
    let (iso, closure) = rotary_iso(&table, &session).expect("ISO 230-2");
    let closure = closure.expect("0 and 360 are both measured");
    assert!(
        !closure.consistent,
        "8 ppm over a revolution breaks the closure"
    );
    let page = get(a, "/session/rot/cap");
    assert_eq!(page.status, 200);
    let page = page.text();
    for (name, v) in [
        ("A", iso.a_arcsec),
        ("E", iso.e_arcsec),
        ("M", iso.m_arcsec),
        ("R", iso.r_arcsec),
        ("B", iso.b_arcsec),
        ("B̄", iso.mean_reversal_arcsec),
    ] {
        let shown = format!("<b>{v:.2}″</b><small>{:.6}°</small>", v / 3600.0);
        assert!(page.contains(&shown), "{name}: {shown} not in the page");
    }
    for v in [closure.diff_up_arcsec, closure.limit_down_arcsec] {
        assert!(page.contains(&format!("<td>{v:.2}″</td>")), "closure {v}");
    }
    assert!(page.contains("Closure consistent: <b>no</b>") && page.contains("closure_mismatch"));
    // The chart: ″ against ° over the whole revolution, a tip at every mean.
    assert!(page.contains("target angle θ_i / °") && page.contains("x = −e / ″"));
    assert!(page.contains(">0°</text>") && page.contains(">360°</text>"));
    for t in &iso.targets {
        let tip = format!(
            "target {} (θ = {:.4}°), ↑ positive approach, all runs: mean x↑ = {:.2}″",
            t.target, t.position_deg, t.mean_up_arcsec
        );
        assert!(page.contains(&tip), "{tip}");
    }
    assert!(!page.contains("µm"), "a rotary page has no length unit");

    // The downloads are the rotary commands' files.
    let dl = get(a, "/download/table/rot/cap");
    assert_eq!(dl.status, 200, "{}", dl.text());
    assert_eq!(dl.body, std::fs::read(out.join("t.csv")).expect("t.csv"));
    assert!(dl.text().starts_with("b_deg,e_arcsec,n,s_arcsec"));
    let dl = get(a, "/download/certificate/rot/cap");
    assert_eq!(dl.status, 200, "{}", dl.text());
    assert!(dl.body.starts_with(b"%PDF"));
    for format in ["siemens", "fanuc", "linuxcnc"] {
        let dl = get(a, &format!("/download/export/rot/cap?format={format}"));
        assert_eq!(dl.status, 200, "{format}: {}", dl.text());
        let f = out.join(format!("{format}.txt"));
        let o = errmap(&[
            "export",
            s(&ws.join("rot/cap")),
            "--format",
            format,
            "--out",
            s(&f),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(dl.body, std::fs::read(&f).expect("export"), "{format}");
    }
    let dl = get(a, "/download/export/rot/cap?format=isg");
    assert_eq!(dl.status, 400);
    assert!(
        dl.json()["error"]
            .as_str()
            .is_some_and(|e| e.contains("modulo"))
    );
}

#[test]
fn a_live_rotary_capture_reports_degrees_and_arcseconds() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = rotary_workspace(dir.path());
    let srv = Server::start(&ws, &[]);
    let a = srv.addr.as_str();
    let token = form_token(a);
    let body = r#"{"model":"rot/rotary-model.toml","plan":"rot/rotary-plan.toml","speed":40}"#;
    let r = request(
        a,
        "POST",
        "/api/live/start",
        &[("X-Errmap-Form-Token", token.as_str())],
        body,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let session = r.json()["session"].as_str().expect("session").to_string();
    // The events carry the rotary readings in ° and ″, never mm or µm.
    let ev = events(a, Duration::from_secs(30), |v| {
        v["targets"].as_array().is_some_and(|t| t.len() >= 3)
    });
    let last = &ev.last().expect("events").1;
    assert_eq!(last["rotary_axis"], "B", "{last}");
    let angle = last["angle_deg"].as_f64().expect("an angle");
    assert!((-10.0..=370.0).contains(&angle), "{angle}");
    assert!(last["error_arcsec"].as_f64().is_some() && last["error_um"].is_null());
    // The board ends after its plan; the last snapshot holds every pass's target means.
    let start = Instant::now();
    let state = loop {
        let st = get(a, "/api/live/state").json();
        if st["state"] != "running" {
            break st;
        }
        assert!(start.elapsed() < Duration::from_secs(90), "still running");
        std::thread::sleep(Duration::from_millis(200));
    };
    assert_eq!(state["state"], "complete", "{state}");
    // Each target mean is the mean of that dwell's rows in the session on disk.
    let rot = read_rotary_session(&ws.join(&session).join("session.csv")).expect("rotary");
    let mut dwell: BTreeMap<(u32, i8, i32), (f64, f64, u64)> = BTreeMap::new();
    for r in rot.rows.iter().filter(|r| r.target >= 0 && r.flags == 0) {
        let e = dwell.entry((r.run, r.direction, r.target)).or_default();
        (e.0, e.1, e.2) = (e.0 + r.indicated_deg, e.1 + r.error_arcsec, e.2 + 1);
    }
    let rows = state["targets"].as_array().expect("targets");
    // 2 runs × 2 directions × 9 targets (0 to 360 every 45°).
    assert_eq!(rows.len(), 36);
    assert_eq!(rows.len(), dwell.len());
    for t in rows {
        let f = |k: &str| t[k].as_f64().unwrap_or_else(|| panic!("{k} in {t}"));
        assert!(
            t.get("position_mm").is_none() && t.get("error_um").is_none(),
            "{t}"
        );
        let key = (
            t["run"].as_u64().expect("run") as u32,
            t["direction"].as_i64().expect("direction") as i8,
            t["target"].as_i64().expect("target") as i32,
        );
        let (deg, arcsec, n) = dwell[&key];
        assert_eq!(t["n"].as_u64(), Some(n), "{t}");
        assert!((f("position_deg") - deg / n as f64).abs() < 1e-9, "{t}");
        assert!((f("error_arcsec") - arcsec / n as f64).abs() < 1e-9, "{t}");
    }
}
