//! The workbench in a real headless Chromium, driven over WebDriver (Debian `chromium` and
//! `chromium-driver`; the test skips with a message without them): every page loads with
//! no console error, a known session's figures appear as text, pointing at a chart's
//! point shows its value, and the live page shows frames arriving from a simulated board
//! and Stop leaves the session `errmap replay` makes of its raw bytes.
//!
//! With `ERRMAP_SCREENSHOTS=DIR` the test writes a screenshot of each page into DIR
//! (`reports/workbench/README.md`).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::util::{errmap, s, stderr};
use super::workbench::{Server, report_figures, request, workspace};

const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// chromedriver and one browser session, both ended when dropped.
struct Browser {
    driver: Child,
    addr: String,
    session: String,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = request(
            &self.addr,
            "DELETE",
            &format!("/session/{}", self.session),
            &[],
            "",
        );
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

fn which(name: &str) -> Option<String> {
    let out = Command::new("sh")
        .args(["-c", &format!("command -v {name}")])
        .output()
        .ok()?;
    let p = String::from_utf8_lossy(&out.stdout).trim().to_string();
    (out.status.success() && !p.is_empty()).then_some(p)
}

impl Browser {
    fn start() -> Option<Browser> {
        let (Some(driver), Some(chromium)) = (which("chromedriver"), which("chromium")) else {
            eprintln!(
                "SKIP: the workbench's browser test needs chromium and chromedriver (apt-get install chromium chromium-driver)"
            );
            return None;
        };
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .expect("a free port")
            .port();
        let child = Command::new(driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starts chromedriver");
        let addr = format!("127.0.0.1:{port}");
        let start = Instant::now();
        while std::net::TcpStream::connect(&addr).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "chromedriver did not start"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": chromium, "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1200,1400"]},
            "goog:loggingPrefs": {"browser": "ALL"}}}});
        let r = request(
            &addr,
            "POST",
            "/session",
            &[("Content-Type", "application/json")],
            &caps.to_string(),
        );
        let session = r.json()["value"]["sessionId"]
            .as_str()
            .unwrap_or_else(|| panic!("a WebDriver session: {}", r.text()))
            .to_string();
        Some(Browser {
            driver: child,
            addr,
            session,
        })
    }

    fn call(&self, method: &str, path: &str, body: Value) -> Value {
        let r = request(
            &self.addr,
            method,
            &format!("/session/{}{path}", self.session),
            &[("Content-Type", "application/json")],
            &body.to_string(),
        );
        let v = r.json();
        assert_eq!(r.status, 200, "{method} {path}: {v}");
        v["value"].clone()
    }

    fn open(&self, url: &str) {
        self.call("POST", "/url", json!({ "url": url }));
    }

    fn script(&self, code: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            json!({ "script": code, "args": [] }),
        )
    }

    /// The console's errors since the last call.
    fn console_errors(&self) -> Vec<String> {
        let v = self.call("POST", "/se/log", json!({ "type": "browser" }));
        v.as_array()
            .into_iter()
            .flatten()
            .filter(|e| e["level"] == "SEVERE")
            .map(|e| e["message"].to_string())
            .collect()
    }

    fn element(&self, css: &str) -> String {
        let v = self.call(
            "POST",
            "/element",
            json!({ "using": "css selector", "value": css }),
        );
        v[ELEMENT].as_str().expect("an element").to_string()
    }

    fn screenshot(&self, dir: Option<&Path>, name: &str) {
        let Some(dir) = dir else { return };
        let v = self.call("GET", "/screenshot", json!({}));
        let png = base64(v.as_str().expect("base64"));
        std::fs::create_dir_all(dir).expect("screenshot dir");
        std::fs::write(dir.join(format!("{name}.png")), png).expect("writes the screenshot");
    }

    /// Opens `url` and waits until it has loaded, within `limit`.
    fn open_loaded(&self, url: &str, limit: Duration) {
        self.open(url);
        assert!(
            self.wait_for("return document.readyState === 'complete'", limit),
            "{url} did not load"
        );
    }

    /// Moves the pointer onto `element` and returns the tip the page then shows.
    fn tip_at(&self, element: &str) -> Value {
        self.call(
            "POST",
            "/actions",
            json!({"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
                "actions": [{"type": "pointerMove", "origin": {ELEMENT: element}, "x": 0, "y": 0, "duration": 0}]}]}),
        );
        assert!(self.wait_for(
            "return !document.getElementById('tip').hidden",
            Duration::from_secs(5)
        ));
        self.script("return document.getElementById('tip').textContent")
    }

    /// On the live page: picks the simulated board's model and plan, its speed, and Start.
    fn start_simulated(&self, model: &str, plan: &str, speed: &str) {
        self.script(&format!(
            "document.getElementById('model').value = '{model}';\
             document.getElementById('plan').value = '{plan}';\
             document.getElementById('speed').value = '{speed}'; return true"
        ));
        let start = self.element("#start");
        self.call("POST", &format!("/element/{start}/click"), json!({}));
    }

    /// Waits until `code` returns true, within `limit`.
    fn wait_for(&self, code: &str, limit: Duration) -> bool {
        let start = Instant::now();
        while start.elapsed() < limit {
            if self.script(code) == json!(true) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        false
    }
}

fn base64(text: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let clean: Vec<u8> = text
        .bytes()
        .filter(|c| *c != b'=' && !c.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut n = 0u32;
        for (k, c) in chunk.iter().enumerate() {
            n |= u32::from(val(*c)) << (18 - 6 * k);
        }
        let bytes = n.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    out
}

#[test]
fn the_pages_in_a_real_browser() {
    let Some(b) = Browser::start() else { return };
    let shots = std::env::var_os("ERRMAP_SCREENSHOTS").map(std::path::PathBuf::from);
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = workspace(dir.path());
    let ledger = dir.path().join("ledger.sqlite");
    for (machine, session, at) in [
        ("M1", "concealed/simulated.parquet", "2025-01-10"),
        ("M1", "concealed/recorded.parquet", "2025-07-10"),
        ("M2", "sessions/example.parquet", "2025-03-01"),
    ] {
        let o = errmap(&[
            "history",
            "add",
            s(&ws.join(session)),
            "--ledger",
            s(&ledger),
            "--machine",
            machine,
            "--at",
            at,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let srv = Server::start(&ws, &["--ledger", s(&ledger)]);
    let base = format!("http://{}", srv.addr);

    // Every page loads with no console error (the favicon included).
    for (name, path) in [
        ("workspace", "/"),
        ("session", "/session/sessions/example.parquet"),
        ("table", "/table/tables/table1.csv?test=tables/table2.csv"),
        (
            "volumetric",
            "/volumetric/volumetric/lines.csv?topology=YXZ",
        ),
        ("circular", "/circular/ballbar/xy.csv"),
        ("acceptance", "/acceptance/cmm/iso10360.csv?mpe=1.5%2BL/333"),
        ("history", "/history"),
    ] {
        b.open_loaded(&format!("{base}{path}"), Duration::from_secs(60));
        // Give the favicon request time to finish and log.
        std::thread::sleep(Duration::from_millis(300));
        let errors = b.console_errors();
        assert!(errors.is_empty(), "{path}: {errors:?}");
        b.screenshot(shots.as_deref(), name);
    }

    // The history's charts are on calendar dates, not day numbers.
    b.open(&format!("{base}/history"));
    let text = b
        .script("return document.body.innerText")
        .as_str()
        .expect("text")
        .to_string();
    assert!(!text.contains("days since"), "{text}");
    let ticks = b.script(
        "return Array.from(document.querySelectorAll('svg.chart text')).map(t => t.textContent)         .filter(t => /^\\d{4}(-\\d{2}){0,2}$/.test(t)).length",
    );
    assert!(ticks.as_u64() > Some(2), "date ticks: {ticks}");

    // A known session's figures appear as text, as its ISO 230-2 report prints them.
    let o = errmap(&[
        "table",
        s(&ws.join("sessions/example.parquet")),
        "--out",
        s(&dir.path().join("t.csv")),
        "--report",
        s(&dir.path().join("iso230")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = std::fs::read_to_string(dir.path().join("iso230/report.md")).expect("report.md");
    let figures = report_figures(&report);
    assert!(figures.len() >= 4, "{figures:?}");
    b.open(&format!("{base}/session/sessions/example.parquet"));
    let text = b
        .script("return document.body.innerText")
        .as_str()
        .expect("text")
        .to_string();
    for (sym, v) in &figures {
        assert!(
            text.contains(&format!("{v} µm")),
            "{sym} {v} µm not in the page"
        );
    }

    // Pointing at a chart's point shows its value.
    let point = b.element("svg.chart circle[data-tip]");
    // What lies on top at the point's centre (a marker may cover another series' point).
    let tip_of_point = b.script(
        "const c = document.querySelector('svg.chart circle[data-tip]');\
         c.scrollIntoView({block: 'center'}); const r = c.getBoundingClientRect();\
         return document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2).getAttribute('data-tip')",
    );
    assert_eq!(
        b.script("return document.getElementById('tip').hidden"),
        json!(true)
    );
    let shown = b.tip_at(&point);
    assert_eq!(shown, tip_of_point);
    let shown = shown.as_str().expect("tip text");
    assert!(shown.contains("target") && shown.contains("µm"), "{shown}");
    b.screenshot(shots.as_deref(), "session-tooltip");

    // The live page: frames arrive from a simulated board; Stop leaves the replay's session.
    b.open_loaded(&format!("{base}/live"), Duration::from_secs(20));
    b.start_simulated("sim/model.toml", "sim/plan.toml", "2");
    assert!(
        b.wait_for(
            "return parseInt(document.getElementById('samples').textContent) > 300",
            Duration::from_secs(40)
        ),
        "no frames arrived: {}",
        b.script("return document.getElementById('live').innerText")
    );
    let updates = |b: &Browser| {
        b.script("return parseInt(document.getElementById('frames').textContent)")
            .as_i64()
            .unwrap_or(0)
    };
    let (u0, t0) = (updates(&b), Instant::now());
    std::thread::sleep(Duration::from_secs(2));
    let rate = (updates(&b) - u0) as f64 / t0.elapsed().as_secs_f64();
    assert!(rate >= 2.0, "{rate} updates/s");
    b.screenshot(shots.as_deref(), "live");
    let stop = b.element("#stop");
    b.call("POST", &format!("/element/{stop}/click"), json!({}));
    assert!(b.wait_for(
        "return document.getElementById('state').textContent === 'complete'",
        Duration::from_secs(30)
    ));
    let errors = b.console_errors();
    assert!(errors.is_empty(), "/live: {errors:?}");
    let session = b
        .script("return document.querySelector('#session a').textContent")
        .as_str()
        .expect("the session's link")
        .to_string();
    let sdir = ws.join(&session);
    let replayed = dir.path().join("replayed.csv");
    let o = errmap(&["replay", s(&sdir.join("raw.bin")), "--out", s(&replayed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(sdir.join("session.csv")).expect("session.csv"),
        std::fs::read(&replayed).expect("replayed")
    );
}

/// A rotary session's page in the browser: the library's figures in ″ with ° beside,
/// pointing at the chart shows a value in ″ at its angle; the live page shows a rotary
/// board's readings and target means in ° and ″.
#[test]
fn a_rotary_session_and_a_rotary_capture_in_a_real_browser() {
    use errmap::session::rotary::{read_rotary_session, rotary_iso};
    let Some(b) = Browser::start() else { return };
    let shots = std::env::var_os("ERRMAP_SCREENSHOTS").map(std::path::PathBuf::from);
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = super::workbench_rotary::rotary_workspace(dir.path());
    let srv = Server::start(&ws, &[]);
    let base = format!("http://{}", srv.addr);
    b.open_loaded(&format!("{base}/session/rot/cap"), Duration::from_secs(60));
    std::thread::sleep(Duration::from_millis(300));
    let errors = b.console_errors();
    assert!(errors.is_empty(), "{errors:?}");
    b.screenshot(shots.as_deref(), "rotary-session");
    let text = b
        .script("return document.body.innerText")
        .as_str()
        .expect("text")
        .to_string();
    let table = ws.join("rot/cap/session.csv");
    let session = read_rotary_session(&table).expect("rotary");
    let (iso, closure) = rotary_iso(&table, &session).expect("ISO 230-2");
    for v in [
        iso.a_arcsec,
        iso.a_up_arcsec,
        iso.a_down_arcsec,
        iso.e_arcsec,
        iso.e_up_arcsec,
        iso.e_down_arcsec,
        iso.m_arcsec,
        iso.r_arcsec,
        iso.r_up_arcsec,
        iso.r_down_arcsec,
        iso.b_arcsec,
        iso.mean_reversal_arcsec,
    ] {
        for shown in [format!("{v:.2}″"), format!("{:.6}°", v / 3600.0)] {
            assert!(text.contains(&shown), "{shown} not in the page");
        }
    }
    let c = closure.expect("closure");
    assert!(text.contains(&format!("{:.2}″", c.diff_down_arcsec)));
    // Pointing at a chart's point shows its value in ″ at its angle.
    let point = b.element("svg.chart circle[data-tip]");
    let shown = b.tip_at(&point);
    let shown = shown.as_str().expect("tip");
    assert!(shown.contains("θ =") && shown.contains('″'), "{shown}");
    b.screenshot(shots.as_deref(), "rotary-session-tooltip");

    // The live page with a simulated rotary board.
    b.open_loaded(&format!("{base}/live"), Duration::from_secs(20));
    b.start_simulated("rot/rotary-model.toml", "rot/rotary-plan.toml", "5");
    assert!(
        b.wait_for(
            "return document.querySelectorAll('#targets tr').length >= 4",
            Duration::from_secs(40)
        ),
        "no target means: {}",
        b.script("return document.getElementById('live').innerText")
    );
    let field = |id: &str| {
        b.script(&format!(
            "return document.getElementById('{id}').textContent"
        ))
        .as_str()
        .expect("text")
        .to_string()
    };
    assert_eq!(field("position-label"), "axis B angle");
    assert!(field("position").ends_with('°'), "{}", field("position"));
    assert!(field("reading").ends_with('″'), "{}", field("reading"));
    let rows = field("targets");
    assert!(
        rows.contains('″') && rows.contains('°') && !rows.contains("µm"),
        "{rows}"
    );
    b.screenshot(shots.as_deref(), "live-rotary");
    let stop = b.element("#stop");
    b.call("POST", &format!("/element/{stop}/click"), json!({}));
    assert!(b.wait_for(
        "return document.getElementById('state').textContent === 'complete'",
        Duration::from_secs(30)
    ));
    let errors = b.console_errors();
    assert!(errors.is_empty(), "/live: {errors:?}");
}
