//! `errmap workbench` over HTTP: every route on a loopback port, the JSON documents equal
//! to the commands' `--json` documents for the same inputs, the guards (access token,
//! paths out of the workspace, the form token, one capture at a time), and a live capture
//! from a simulated board whose session equals `errmap replay` of its raw bytes.
//! Shared with `workbench_browser.rs`: the test workspace, the server, the client.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

use super::util::{dataset, errmap, errmap_cmd, json, s, stderr};

/// A running `errmap workbench`, killed when dropped.
pub(super) struct Server {
    child: Child,
    pub addr: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    /// Starts the workbench on `dir` (extra flags after it), reads its address line and
    /// waits until its start-up results are made (so a page answers with its result, not
    /// the page saying it is being computed).
    pub(super) fn start(dir: &Path, extra: &[&str]) -> Server {
        let (server, warm) = Server::start_at_once(dir, extra);
        let made = warm.recv_timeout(Duration::from_secs(300));
        assert!(made.is_ok(), "the start-up results were not made");
        server
    }

    /// Starts the workbench and returns once it listens, with the line that says its
    /// start-up results are made still to come on the receiver (its stderr is read to
    /// the end, so the server never writes into a closed pipe).
    pub(super) fn start_at_once(
        dir: &Path,
        extra: &[&str],
    ) -> (Server, std::sync::mpsc::Receiver<String>) {
        let mut child = errmap_cmd()
            .args(["workbench", "--dir", s(dir), "--addr", "127.0.0.1:0"])
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("starts the workbench");
        let mut line = String::new();
        let mut err = BufReader::new(child.stderr.take().expect("stderr"));
        err.read_line(&mut line).expect("reads the address line");
        let addr = line
            .trim()
            .strip_prefix("workbench: http://")
            .and_then(|a| a.strip_suffix('/'))
            .unwrap_or_else(|| panic!("the address line, not {line:?}"))
            .to_string();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for l in err.lines().map_while(Result::ok) {
                if l.contains("results made") {
                    let _ = tx.send(l);
                }
            }
        });
        (Server { child, addr }, rx)
    }
}

/// One HTTP/1.1 exchange: status, headers (lower-case names), body.
pub(super) struct Reply {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    pub(super) fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    pub(super) fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| panic!("JSON ({e}): {}", self.text()))
    }

    pub(super) fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
}

/// Sends one request (`Connection: close`) and reads the whole reply, within 120 s.
pub(super) fn request(
    addr: &str,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &str,
) -> Reply {
    let mut c = TcpStream::connect(addr).expect("connects");
    c.set_read_timeout(Some(Duration::from_secs(120)))
        .expect("timeout");
    let mut req = format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    req.push_str(&format!("Content-Length: {}\r\n\r\n{body}", body.len()));
    c.write_all(req.as_bytes()).expect("sends");
    read_reply(BufReader::new(c))
}

/// Reads one reply: by its Content-Length, its chunks, or to the end of the stream (a
/// server may keep the connection open whatever the request said).
fn read_reply(mut r: BufReader<TcpStream>) -> Reply {
    let mut head = String::new();
    loop {
        let mut line = String::new();
        if r.read_line(&mut line).expect("reads the reply") == 0 || line == "\r\n" {
            break;
        }
        head.push_str(&line);
    }
    let mut lines = head.lines();
    let status = lines
        .next()
        .and_then(|l| l.split(' ').nth(1))
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("a status line, not {head:?}"));
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let find = |name: &str| {
        headers
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.clone())
    };
    let mut body = Vec::new();
    if let Some(n) = find("content-length").and_then(|v| v.parse::<usize>().ok()) {
        body.resize(n, 0);
        r.read_exact(&mut body).expect("reads the body");
    } else if find("transfer-encoding").is_some_and(|v| v.contains("chunked")) {
        loop {
            let mut size = String::new();
            r.read_line(&mut size).expect("a chunk size");
            let n = usize::from_str_radix(size.trim(), 16).expect("a hex chunk size");
            let mut chunk = vec![0; n + 2];
            r.read_exact(&mut chunk).expect("a chunk");
            if n == 0 {
                break;
            }
            body.extend_from_slice(&chunk[..n]);
        }
    } else {
        r.read_to_end(&mut body).expect("reads the body");
    }
    Reply {
        status,
        headers,
        body,
    }
}

pub(super) fn get(addr: &str, path: &str) -> Reply {
    request(addr, "GET", path, &[], "")
}

/// The per-run form token of a page.
pub(super) fn form_token(addr: &str) -> String {
    let page = get(addr, "/live").text();
    let at = page
        .find("name=\"errmap-form-token\" content=\"")
        .expect("the token meta")
        + 34;
    page[at..at + 32].to_string()
}

/// A workspace for the tests, from the repository's datasets: a session table, an error
/// table and its test points, a ballbar trace, an ISO 10360-2 test, volumetric lines, a
/// concealed case's recorded and simulated sessions, and the simulator's model and plan.
pub(super) fn workspace(dir: &Path) -> PathBuf {
    let ws = dir.join("ws");
    for (from, to) in [
        (
            "physics/example-session.parquet",
            "sessions/example.parquet",
        ),
        ("table1.csv", "tables/table1.csv"),
        ("table2.csv", "tables/table2.csv"),
        ("circular/xy.csv", "ballbar/xy.csv"),
        ("circular/xy.toml", "ballbar/xy.toml"),
        ("acceptance/iso10360-example.csv", "cmm/iso10360.csv"),
        (
            "concealed/reversal/recorded.parquet",
            "concealed/recorded.parquet",
        ),
        (
            "concealed/reversal/simulated.parquet",
            "concealed/simulated.parquet",
        ),
        ("sim/model.toml", "sim/model.toml"),
        ("sim/plan.toml", "sim/plan.toml"),
        // The model's error map (`error_map.table = "../table1.csv"`).
        ("table1.csv", "table1.csv"),
    ] {
        let t = ws.join(to);
        std::fs::create_dir_all(t.parent().expect("parent")).expect("mkdir");
        std::fs::copy(dataset(from), &t).unwrap_or_else(|e| panic!("{from}: {e}"));
    }
    std::fs::create_dir(ws.join("volumetric")).expect("mkdir");
    let o = errmap(&[
        "volumetric",
        "simulate",
        "--model",
        s(&dataset("volumetric/model.toml")),
        "--plan",
        s(&dataset("volumetric/plan.toml")),
        "--out",
        s(&ws.join("volumetric/lines.csv")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    ws
}

/// `errmap volumetric identify` of the workspace's lines (topology YXZ), its `--json`.
fn identify_json(ws: &Path) -> Value {
    json(&errmap(&[
        "volumetric",
        "identify",
        s(&ws.join("volumetric/lines.csv")),
        "--topology",
        "YXZ",
        "--json",
    ]))
}

/// The bidirectional axis values E, A, R and B of every line of an ISO 230-2 report
/// (`errmap table --report`), as the report prints them: `(symbol, value)`.
pub(super) fn report_figures(report_md: &str) -> Vec<(String, String)> {
    report_md
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            let (sym, value) = (*cells.get(2)?, *cells.get(5)?);
            ["E", "A", "R", "B"]
                .contains(&sym)
                .then(|| (sym.to_string(), value.to_string()))
        })
        .collect()
}

#[test]
fn every_route_answers_and_the_documents_are_the_commands() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = workspace(dir.path());
    let ledger = dir.path().join("ledger.sqlite");
    let ledger_s = s(&ledger).to_string();
    for (session, at) in [
        ("concealed/simulated.parquet", "2025-01-10"),
        ("concealed/recorded.parquet", "2025-07-10"),
    ] {
        let o = errmap(&[
            "history",
            "add",
            s(&ws.join(session)),
            "--ledger",
            &ledger_s,
            "--machine",
            "M1",
            "--at",
            at,
        ]);
        assert!(o.status.success(), "history add: {}", stderr(&o));
    }
    let srv = Server::start(&ws, &["--ledger", &ledger_s]);
    let a = srv.addr.as_str();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");

    // The items: kinds by content, paths relative to the workspace.
    let items = get(a, "/api/items").json();
    let kind = |id: &str| {
        items["items"]
            .as_array()
            .expect("items")
            .iter()
            .find(|i| i["id"] == id)
            .map(|i| i["kind"].as_str().expect("kind").to_string())
    };
    assert_eq!(kind("sessions/example.parquet").as_deref(), Some("session"));
    assert_eq!(kind("tables/table1.csv").as_deref(), Some("error_table"));
    assert_eq!(kind("ballbar/xy.csv").as_deref(), Some("circular_trace"));
    assert_eq!(kind("cmm/iso10360.csv").as_deref(), Some("iso10360_test"));
    assert_eq!(
        kind("volumetric/lines.csv").as_deref(),
        Some("volumetric_lines")
    );

    // Each document equals the command's, number for number.
    let session = ws.join("sessions/example.parquet");
    let cli = json(&errmap(&[
        "table",
        s(&session),
        "--out",
        s(&out.join("t.csv")),
        "--report",
        s(&out.join("iso230")),
        "--json",
    ]));
    assert_eq!(get(a, "/api/table/sessions/example.parquet").json(), cli);
    let cli = json(&errmap(&[
        "circular",
        "diagnose",
        s(&ws.join("ballbar/xy.csv")),
        "--report",
        s(&out.join("circ")),
        "--json",
    ]));
    assert_eq!(get(a, "/api/circular/ballbar/xy.csv").json(), cli);
    let cli = identify_json(&ws);
    assert_eq!(
        get(a, "/api/volumetric/volumetric/lines.csv?topology=YXZ").json(),
        cli
    );
    let cli = json(&errmap(&[
        "diagnose",
        "--recorded",
        s(&ws.join("concealed/recorded.parquet")),
        "--simulated",
        s(&ws.join("concealed/simulated.parquet")),
        "--report",
        s(&out.join("diag")),
        "--json",
    ]));
    assert_eq!(
        get(
            a,
            "/api/diagnose/concealed/recorded.parquet?simulated=concealed/simulated.parquet"
        )
        .json(),
        cli
    );
    let cli = json(&errmap(&[
        "history",
        "report",
        "--ledger",
        &ledger_s,
        "--report",
        s(&out.join("hist")),
        "--json",
    ]));
    assert_eq!(get(a, "/api/history").json(), cli);
    let cli = json(&errmap(&[
        "acceptance",
        "iso10360",
        s(&ws.join("cmm/iso10360.csv")),
        "--mpe",
        "1.5+L/333",
        "--json",
    ]));
    assert_eq!(
        get(a, "/api/acceptance/cmm/iso10360.csv?mpe=1.5%2BL/333").json(),
        cli
    );

    // Every page: 200, HTML, the figures as text, as the reports print them: the session
    // page's A is the ISO 230-2 report's (its bidirectional column, to its decimals).
    let report = std::fs::read_to_string(out.join("iso230/report.md")).expect("report.md");
    let a_report = report_figures(&report)
        .into_iter()
        .find(|(sym, _)| sym == "A")
        .expect("the report's A row")
        .1;
    let table = get(a, "/api/table/sessions/example.parquet").json();
    let a_um = table["lines"][0]["iso230"]["a_um"].as_f64().expect("A");
    assert!((a_report.parse::<f64>().expect("a number") - a_um).abs() < 1e-3);
    for (path, needle) in [
        ("/", "sessions/example.parquet".to_string()),
        (
            "/session/sessions/example.parquet",
            format!("<b>{a_report} µm</b>"),
        ),
        (
            "/table/tables/table1.csv?test=tables/table2.csv",
            "Recommended".into(),
        ),
        (
            "/volumetric/volumetric/lines.csv?topology=YXZ",
            "E_XX".into(),
        ),
        ("/volumetric/volumetric/lines.csv", "topology".into()),
        ("/circular/ballbar/xy.csv", "G(b)".into()),
        (
            "/acceptance/cmm/iso10360.csv?mpe=1.5%2BL/333",
            "Verdict".into(),
        ),
        ("/history", "M1".into()),
        ("/live", "Start".into()),
    ] {
        let r = get(a, path);
        assert_eq!(r.status, 200, "{path}: {}", r.text());
        assert!(
            r.header("content-type")
                .is_some_and(|c| c.starts_with("text/html")),
            "{path}"
        );
        assert!(r.text().contains(&needle), "{path} lacks {needle}");
    }
    for path in [
        "/favicon.ico",
        "/favicon.svg",
        "/assets/style.css",
        "/assets/app.js",
    ] {
        assert_eq!(get(a, path).status, 200, "{path}");
    }

    // The downloads are the commands' files.
    let csv = get(a, "/download/table/sessions/example.parquet");
    assert_eq!(csv.status, 200, "{}", csv.text());
    assert_eq!(csv.body, std::fs::read(out.join("t.csv")).expect("t.csv"));
    let pdf = get(a, "/download/certificate/sessions/example.parquet");
    assert_eq!(pdf.status, 200, "{}", pdf.text());
    assert!(pdf.body.starts_with(b"%PDF-"));
    let lcnc = get(
        a,
        "/download/export/sessions/example.parquet?format=linuxcnc",
    );
    let o = errmap(&[
        "export",
        s(&session),
        "--format",
        "linuxcnc",
        "--bidirectional",
        "--axis",
        "x",
        "--out",
        s(&out.join("l.txt")),
    ]);
    if o.status.success() {
        assert_eq!(lcnc.status, 200, "{}", lcnc.text());
        assert_eq!(lcnc.body, std::fs::read(out.join("l.txt")).expect("l.txt"));
    } else {
        assert_eq!(lcnc.status, 400);
        assert!(stderr(&o).contains(lcnc.json()["error"].as_str().expect("error")));
    }

    // Not found, malformed, outside.
    assert_eq!(get(a, "/session/nothing.csv").status, 404);
    let missing = get(a, "/api/table/nothing.csv");
    assert_eq!(missing.status, 404);
    assert!(missing.json()["error"].is_string());
    let bad = get(a, "/session/tables/table1.csv");
    assert_eq!(bad.status, 400);
    assert!(bad.text().contains("class=\"error\""));
    for p in [
        "/api/table/..%2f..%2fetc%2fpasswd",
        "/api/table/%2e%2e/x",
        "/session/../../etc/passwd",
        "/api/table/sessions%2fexample.parquet",
    ] {
        let r = get(a, p);
        assert!(matches!(r.status, 400 | 404), "{p}: {}", r.status);
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&ledger, ws.join("out.csv")).expect("symlink");
        assert_eq!(get(a, "/api/table/out.csv").status, 404);
    }
}

#[test]
fn guards_token_form_token_and_addresses() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::copy(dataset("table1.csv"), dir.path().join("t.csv")).expect("copy");
    // Off loopback without a token: refused, exit 2, nothing served.
    let o = errmap(&["workbench", "--dir", s(dir.path()), "--addr", "0.0.0.0:0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--token"));
    // An address that cannot be bound: exit 1 naming it.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let busy = taken.local_addr().expect("addr").to_string();
    let o = errmap(&["workbench", "--dir", s(dir.path()), "--addr", &busy]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(&busy));

    // With a token every request carries it: 401 and nothing else without it.
    let srv = Server::start(dir.path(), &["--token", "s3cret"]);
    let a = srv.addr.as_str();
    let r = get(a, "/");
    assert_eq!(r.status, 401);
    assert!(!r.text().contains("t.csv"));
    assert_eq!(get(a, "/api/items").status, 401);
    let r = request(
        a,
        "GET",
        "/api/items",
        &[("Authorization", "Bearer s3cret")],
        "",
    );
    assert_eq!(r.status, 200);
    let r = get(a, "/?token=s3cret");
    assert_eq!(r.status, 200);
    let cookie = r.header("set-cookie").expect("a cookie").to_string();
    let cookie = cookie.split(';').next().expect("name=value");
    assert_eq!(
        request(a, "GET", "/api/items", &[("Cookie", cookie)], "").status,
        200
    );
    assert_eq!(get(a, "/?token=wrong").status, 401);

    // POST needs the page's form token (a cross-site form cannot send it).
    let auth = ("Authorization", "Bearer s3cret");
    let page = request(a, "GET", "/live", &[auth], "").text();
    let at = page.find("errmap-form-token\" content=\"").expect("meta") + 28;
    let token = &page[at..at + 32];
    let body = r#"{"model":"none.toml","plan":"none.toml"}"#;
    let r = request(a, "POST", "/api/live/start", &[auth], body);
    assert_eq!(r.status, 403, "{}", r.text());
    let r = request(
        a,
        "POST",
        "/api/live/start",
        &[auth, ("X-Errmap-Form-Token", token)],
        body,
    );
    assert_eq!(r.status, 400, "{}", r.text());
    assert!(
        r.json()["error"]
            .as_str()
            .expect("error")
            .contains("none.toml")
    );
    assert_eq!(
        request(a, "GET", "/api/live/start", &[auth], "").status,
        405
    );
    let r = request(
        a,
        "POST",
        "/api/live/stop",
        &[auth, ("X-Errmap-Form-Token", token)],
        "",
    );
    assert_eq!(r.status, 409);
}

/// Reads Server-Sent Events from `/api/live/events` until `until` holds for one, within
/// `limit`; the events read.
pub(super) fn events(
    addr: &str,
    limit: Duration,
    until: impl Fn(&Value) -> bool,
) -> Vec<(Instant, Value)> {
    let mut c = TcpStream::connect(addr).expect("connects");
    c.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    write!(
        c,
        "GET /api/live/events HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .expect("sends");
    let mut r = BufReader::new(c);
    let start = Instant::now();
    let mut out = Vec::new();
    let mut line = String::new();
    while start.elapsed() < limit {
        line.clear();
        if r.read_line(&mut line).unwrap_or(0) == 0 {
            break;
        }
        if let Some(data) = line.trim_end().strip_prefix("data: ") {
            let v: Value = serde_json::from_str(data).expect("an event's JSON");
            let done = until(&v);
            out.push((Instant::now(), v));
            if done {
                break;
            }
        }
    }
    out
}

#[test]
fn a_live_capture_from_a_simulated_board_equals_the_replay_of_its_bytes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = dir.path().join("ws");
    std::fs::create_dir_all(ws.join("sim")).expect("mkdir");
    for f in ["model.toml", "plan.toml"] {
        std::fs::copy(dataset(&format!("sim/{f}")), ws.join("sim").join(f)).expect("copy");
    }
    std::fs::copy(dataset("table1.csv"), ws.join("table1.csv")).expect("copy");
    let srv = Server::start(&ws, &[]);
    let a = srv.addr.as_str();
    let token = form_token(a);
    let start = |body: &str| {
        request(
            a,
            "POST",
            "/api/live/start",
            &[("X-Errmap-Form-Token", token.as_str())],
            body,
        )
    };
    let body = r#"{"model":"sim/model.toml","plan":"sim/plan.toml","speed":2}"#;
    let r = start(body);
    assert_eq!(r.status, 200, "{}", r.text());
    let session = r.json()["session"].as_str().expect("session").to_string();
    assert_eq!(start(body).status, 409, "one capture at a time");
    // Frames arrive: event after event, numbered, the sample count never going back.
    // (How often: docs/workbench.md, measured; no timing is asserted here.)
    let ev = events(a, Duration::from_secs(30), |v| {
        v["samples"].as_u64() > Some(200)
    });
    assert!(ev.len() >= 3, "{} events", ev.len());
    let last = &ev[ev.len() - 1].1;
    assert!(last["samples"].as_u64() > Some(200), "{last}");
    for w in ev.windows(2) {
        assert_eq!(
            w[1].1["updates"].as_u64(),
            w[0].1["updates"].as_u64().map(|n| n + 1)
        );
        assert!(w[1].1["samples"].as_u64() >= w[0].1["samples"].as_u64());
    }
    let r = request(
        a,
        "POST",
        "/api/live/stop",
        &[("X-Errmap-Form-Token", token.as_str())],
        "",
    );
    assert_eq!(r.status, 200, "{}", r.text());
    assert_eq!(r.json()["session"], session.as_str());
    let state = get(a, "/api/live/state").json();
    assert_eq!(state["state"], "complete", "{state}");
    // The session on disk is what replay makes of its raw bytes.
    let sdir = ws.join(&session);
    let replayed = dir.path().join("replayed.csv");
    let o = errmap(&["replay", s(&sdir.join("raw.bin")), "--out", s(&replayed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let captured = std::fs::read(sdir.join("session.csv")).expect("session.csv");
    assert!(captured.len() > 1000);
    assert_eq!(captured, std::fs::read(&replayed).expect("replayed"));
    assert!(sdir.join("session.json").is_file());
    // The new session is an item of the workspace with its page.
    assert_eq!(get(a, &format!("/session/{session}")).status, 200);
}

#[test]
fn a_page_opened_at_start_up_answers_at_once_and_fills_in() {
    // While the identification of the lines is being made (here for its document, which
    // waits for it), its page answers at once with the page saying so (202), which its
    // script reloads, until the result is there.
    let dir = tempfile::tempdir().expect("tempdir");
    let ws = workspace(dir.path());
    // A model beside the lines makes the warm-up identify them with its topology.
    let o = errmap(&[
        "volumetric",
        "identify",
        s(&ws.join("volumetric/lines.csv")),
        "--topology",
        "YXZ",
        "--out",
        s(&ws.join("volumetric/model.json")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (srv, warm) = Server::start_at_once(&ws, &[]);
    let a = srv.addr.as_str();
    let path = "/volumetric/volumetric/lines.csv?topology=YXZ";
    let doc = {
        let a = a.to_string();
        std::thread::spawn(move || get(&a, "/api/volumetric/volumetric/lines.csv?topology=YXZ"))
    };
    std::thread::sleep(Duration::from_millis(300));
    let start = Instant::now();
    let mut pending = 0;
    let page = loop {
        let r = get(a, path);
        if r.status == 200 {
            break r.text();
        }
        assert_eq!(r.status, 202, "{}", r.text());
        let t = r.text();
        assert!(
            t.contains("id=\"pending\"") && t.contains("Being computed"),
            "{t}"
        );
        pending += 1;
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "never filled in"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(page.contains("E_XX"), "the filled-in page");
    assert!(pending > 0, "the page waited instead of answering at once");
    // The document waited for the same result and equals the command's.
    let cli = identify_json(&ws);
    assert_eq!(doc.join().expect("the document").json(), cli);
    let made = warm
        .recv_timeout(Duration::from_secs(300))
        .expect("warm-up line");
    eprintln!("{pending} pending answer(s) before the page filled in; {made}");
}
