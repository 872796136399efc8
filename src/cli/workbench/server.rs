//! The router and its guards: the access token (any non-loopback address), encoded path
//! separators refused, the per-run form token on every POST; the JSON API, the downloads
//! and the live event stream. Pages are in `pages`.

use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use axum::Router;
use axum::body::Body;
use axum::extract::{Path as UrlPath, Query, Request, State};
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use super::docs::{self, DocError, Jobs};
use super::items::Workspace;
use super::live::{Live, LiveError, StartRequest};

/// What `errmap workbench` was given.
#[derive(Debug, Clone)]
pub(crate) struct Config {
    /// The workspace.
    pub dir: PathBuf,
    /// A calibration ledger for the history page (SQLite path or `postgres://…`).
    pub ledger: Option<String>,
    /// `HOST:PORT` (port 0: any free port).
    pub addr: String,
    /// The access token every request must carry (required off loopback).
    pub token: Option<String>,
    /// The errmap binary, which makes the downloads with its own commands.
    pub exe: Option<PathBuf>,
}

/// Why the workbench cannot serve.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ServeError {
    /// Off loopback without an access token.
    #[error(
        "{0} is not a loopback address: give an access token (every request must then carry it)"
    )]
    NeedsToken(String),
    #[error("{addr}: cannot listen: {source}")]
    Bind {
        addr: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{dir}: not a workspace directory: {source}")]
    Workspace {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("the web server failed: {0}")]
    Io(#[from] std::io::Error),
}

pub(crate) struct AppState {
    /// The workspace and the results made from its files.
    pub jobs: Jobs,
    pub ledger: Option<String>,
    pub token: Option<String>,
    /// The per-run form token (in every page; required on every POST).
    pub form_token: String,
    pub exe: Option<PathBuf>,
    pub live: Live,
}

pub(crate) type Shared = Arc<AppState>;

/// Serves the workbench until `stop` is set; `on_bound` gets the real address first.
pub(crate) fn serve(
    config: Config,
    stop: &'static AtomicBool,
    on_bound: impl FnOnce(SocketAddr),
) -> Result<(), ServeError> {
    let addrs: Vec<SocketAddr> = config
        .addr
        .to_socket_addrs()
        .map_err(|source| ServeError::Bind {
            addr: config.addr.clone(),
            source,
        })?
        .collect();
    if config.token.is_none() && !addrs.iter().all(|a| a.ip().is_loopback()) {
        return Err(ServeError::NeedsToken(config.addr));
    }
    let ws = Workspace::new(&config.dir).map_err(|source| ServeError::Workspace {
        dir: config.dir.clone(),
        source,
    })?;
    let state = Arc::new(AppState {
        jobs: Jobs::new(ws),
        ledger: config.ledger,
        token: config.token,
        form_token: form_token(),
        exe: config.exe,
        live: Live::default(),
    });
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_io()
        .enable_time()
        .build()?;
    let serving = Arc::clone(&state);
    rt.block_on(async move {
        let listener =
            std::net::TcpListener::bind(&addrs[..]).map_err(|source| ServeError::Bind {
                addr: config.addr.clone(),
                source,
            })?;
        listener.set_nonblocking(true)?;
        let listener = tokio::net::TcpListener::from_std(listener)?;
        on_bound(listener.local_addr()?);
        warm_up(Arc::clone(&serving))?;
        let app = router(serving);
        axum::serve(listener, app)
            .with_graceful_shutdown(async move {
                while !stop.load(Ordering::SeqCst) {
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
            })
            .await?;
        Ok::<(), ServeError>(())
    })?;
    // A capture still running ends as Stop would end it: its files whole.
    let _ = state.live.stop();
    Ok(())
}

/// Makes the workspace's results once in the background while the pages are served
/// (`Jobs::warm`), and says on stderr when they are made.
fn warm_up(state: Shared) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name("workbench-warm".into())
        .spawn(move || {
            let t = std::time::Instant::now();
            let made = state.jobs.warm();
            eprintln!(
                "workbench: {made} results made in {:.1} s",
                t.elapsed().as_secs_f64()
            );
        })
        .map(drop)
}

/// 128 random bits, hex.
fn form_token() -> String {
    let a: u64 = rand::random();
    let b: u64 = rand::random();
    format!("{a:016x}{b:016x}")
}

pub(crate) fn router(state: Shared) -> Router {
    let pages = super::pages::routes();
    Router::new()
        .merge(pages)
        .route("/favicon.ico", get(favicon))
        .route("/favicon.svg", get(favicon))
        .route("/assets/style.css", get(style))
        .route("/assets/app.js", get(script))
        .route("/api/items", get(api_items))
        .route("/api/table/{*item}", get(api_table))
        .route("/api/diagnose/{*item}", get(api_diagnose))
        .route("/api/circular/{*item}", get(api_circular))
        .route("/api/volumetric/{*item}", get(api_volumetric))
        .route("/api/acceptance/{*item}", get(api_acceptance))
        .route("/api/history", get(api_history))
        .route("/api/live/start", post(live_start))
        .route("/api/live/stop", post(live_stop))
        .route("/api/live/state", get(live_state))
        .route("/api/live/events", get(live_events))
        .route("/download/table/{*item}", get(download_table))
        .route("/download/certificate/{*item}", get(download_certificate))
        .route("/download/export/{*item}", get(download_export))
        .fallback(not_found)
        .layer(middleware::from_fn_with_state(Arc::clone(&state), guard))
        .with_state(state)
}

/// The guards every request passes, in order: the access token, then a plain path, then
/// the form token of a POST.
async fn guard(State(st): State<Shared>, req: Request, next: Next) -> Response {
    let mut set_cookie = None;
    if let Some(token) = &st.token {
        match access(&req, token) {
            Access::Granted => {}
            Access::FromQuery => {
                set_cookie = Some(format!(
                    "errmap_token={token}; Path=/; HttpOnly; SameSite=Strict"
                ));
            }
            Access::Denied => return json_error(401, "an access token is needed"),
        }
    }
    let path = req.uri().path().to_ascii_lowercase();
    if ["%2e", "%2f", "%5c", "%00"]
        .iter()
        .any(|p| path.contains(p))
        || path.split('/').any(|s| s == ".." || s == ".")
    {
        return json_error(
            400,
            "encoded separators and `..` are not part of a workspace path",
        );
    }
    if req.method() == Method::POST {
        let given = req
            .headers()
            .get("x-errmap-form-token")
            .and_then(|v| v.to_str().ok());
        if given != Some(st.form_token.as_str()) {
            return json_error(
                403,
                "a state-changing request carries the page's form token (X-Errmap-Form-Token)",
            );
        }
    } else if req.method() != Method::GET && req.method() != Method::HEAD {
        return json_error(405, "GET or POST only");
    }
    let mut resp = next.run(req).await;
    if let Some(c) = set_cookie.and_then(|c| HeaderValue::from_str(&c).ok()) {
        resp.headers_mut().insert(header::SET_COOKIE, c);
    }
    resp
}

enum Access {
    Granted,
    FromQuery,
    Denied,
}

fn access(req: &Request, token: &str) -> Access {
    let h = req.headers();
    let bearer = h
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    let cookie = h
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|c| c.trim().strip_prefix("errmap_token="))
        .any(|c| c == token);
    if bearer == Some(token) || cookie {
        return Access::Granted;
    }
    let query = req.uri().query().unwrap_or("");
    let from_query = query
        .split('&')
        .filter_map(|kv| kv.strip_prefix("token="))
        .any(|v| v == token);
    if from_query {
        Access::FromQuery
    } else {
        Access::Denied
    }
}

pub(crate) fn json_error(status: u16, message: &str) -> Response {
    let body = serde_json::json!({ "error": message }).to_string();
    (
        StatusCode::from_u16(status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR),
        [(header::CONTENT_TYPE, "application/json")],
        body,
    )
        .into_response()
}

fn json_text(text: String) -> Response {
    ([(header::CONTENT_TYPE, "application/json")], text).into_response()
}

fn doc_response(r: Result<String, DocError>) -> Response {
    r.map_or_else(IntoResponse::into_response, json_text)
}

/// Runs a job off the async threads (the jobs read files and compute).
pub(crate) async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, DocError> + Send + 'static,
) -> Result<T, DocError> {
    tokio::task::spawn_blocking(f)
        .await
        .unwrap_or_else(|e| Err(DocError::Internal(format!("the job failed: {e}"))))
}

/// A document made by `job` off the async threads, as the answer.
async fn document(
    st: Shared,
    job: impl FnOnce(&AppState) -> Result<String, DocError> + Send + 'static,
) -> Response {
    doc_response(blocking(move || job(&st)).await)
}

/// A query parameter a document needs, or the refusal naming it (400).
fn needed(v: Option<String>, what: &str) -> Result<String, DocError> {
    v.ok_or_else(|| DocError::Bad(format!("{what} is needed")))
}

async fn not_found() -> Response {
    json_error(404, "no such page")
}

fn asset(content_type: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body).into_response()
}

async fn favicon() -> Response {
    asset("image/svg+xml", super::html::FAVICON)
}

async fn style() -> Response {
    asset("text/css; charset=utf-8", super::html::STYLE)
}

async fn script() -> Response {
    asset("text/javascript; charset=utf-8", super::html::SCRIPT)
}

async fn api_items(State(st): State<Shared>) -> Response {
    document(st, |st| {
        docs::text(&serde_json::json!({ "items": st.jobs.ws.items() }))
    })
    .await
}

async fn api_table(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    document(st, move |st| Ok(st.jobs.table(&item)?.text.clone())).await
}

#[derive(Debug, Deserialize)]
pub(crate) struct Params {
    pub simulated: Option<String>,
    pub topology: Option<String>,
    pub mpe: Option<String>,
    pub format: Option<String>,
    pub info: Option<String>,
    pub tolerances: Option<String>,
    pub test: Option<String>,
}

async fn api_diagnose(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    document(st, move |st| {
        let sim = needed(
            q.simulated,
            "?simulated=ITEM: the simulated session to diagnose against",
        )?;
        Ok(st.jobs.diagnose(&item, &sim)?.text.clone())
    })
    .await
}

async fn api_circular(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    document(st, move |st| Ok(st.jobs.circular(&item)?.text.clone())).await
}

async fn api_volumetric(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    document(st, move |st| {
        Ok(st
            .jobs
            .volumetric(&item, q.topology.as_deref())?
            .text
            .clone())
    })
    .await
}

async fn api_acceptance(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    document(st, move |st| {
        let mpe = needed(q.mpe, "?mpe=FORMULA (e.g. 1.5+L/333, µm with L in mm)")?;
        Ok(st.jobs.iso10360(&item, &mpe)?.text.clone())
    })
    .await
}

async fn api_history(State(st): State<Shared>) -> Response {
    let Some(ledger) = st.ledger.clone() else {
        return json_error(404, "no ledger: start the workbench with --ledger");
    };
    document(st, move |_| docs::history(&ledger).map(|h| h.text)).await
}

/// The answer to a start or stop: the session's id, or the refusal.
async fn live_answer(
    st: Shared,
    act: impl FnOnce(&AppState) -> Result<String, LiveError> + Send + 'static,
) -> Response {
    match tokio::task::spawn_blocking(move || act(&st)).await {
        Ok(Ok(session)) => json_text(serde_json::json!({ "session": session }).to_string()),
        Ok(Err(e)) => json_error(e.status(), &docs::message(&e)),
        Err(e) => json_error(500, &e.to_string()),
    }
}

async fn live_start(State(st): State<Shared>, body: String) -> Response {
    let req: StartRequest = match serde_json::from_str(&body) {
        Ok(r) => r,
        Err(e) => return json_error(400, &format!("the request: {e}")),
    };
    live_answer(st, move |st| st.live.start(&st.jobs.ws, req)).await
}

async fn live_stop(State(st): State<Shared>) -> Response {
    live_answer(st, |st| st.live.stop()).await
}

async fn live_state(State(st): State<Shared>) -> Response {
    doc_response(docs::text(&st.live.snapshot()))
}

/// How often the event stream sends the live snapshot.
pub(crate) const EVENT_PERIOD: Duration = Duration::from_millis(250);

/// Server-Sent Events: the live snapshot every [`EVENT_PERIOD`], as event `state`.
async fn live_events(State(st): State<Shared>) -> Response {
    use futures_util::stream;
    let events = stream::unfold((st, 0u64), |(st, n)| async move {
        if n > 0 {
            tokio::time::sleep(EVENT_PERIOD).await;
        }
        let mut s = st.live.snapshot();
        s.updates = n + 1;
        let data = serde_json::to_string(&s).unwrap_or_else(|_| "{}".into());
        let chunk = format!("event: state\ndata: {data}\n\n");
        Some((Ok::<_, std::convert::Infallible>(chunk), (st, n + 1)))
    });
    (
        [
            (header::CONTENT_TYPE, "text/event-stream"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        Body::from_stream(events),
    )
        .into_response()
}

/// Why a download could not be made.
#[derive(Debug, thiserror::Error)]
pub(crate) enum DownloadError {
    /// The private directory the command writes into.
    #[error("{path}: cannot create the download's directory: {source}")]
    TempDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The errmap binary could not be run.
    #[error("{exe}: cannot run: {source}")]
    Run {
        exe: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The command refused (its own message, a bad input: 400).
    #[error("{0}")]
    Refused(String),
    /// The command succeeded but its file cannot be read.
    #[error("{path}: cannot read the command's output: {source}")]
    Output {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl DownloadError {
    fn status(&self) -> u16 {
        match self {
            DownloadError::Refused(_) => 400,
            _ => 500,
        }
    }
}

/// Runs `errmap ARGS… --out TMP/NAME` and answers with the file it wrote.
async fn by_command(
    st: Shared,
    args: Vec<String>,
    name: String,
    content_type: &'static str,
) -> Response {
    let Some(exe) = st.exe.clone() else {
        return json_error(
            404,
            "downloads need the errmap binary (run `errmap workbench`)",
        );
    };
    let r = tokio::task::spawn_blocking(move || run_command(&exe, &args, &name)).await;
    match r {
        Ok(Ok((bytes, file))) => (
            [
                (header::CONTENT_TYPE, content_type.to_string()),
                (
                    header::CONTENT_DISPOSITION,
                    format!("attachment; filename=\"{}\"", file.replace('"', "")),
                ),
            ],
            bytes,
        )
            .into_response(),
        Ok(Err(e)) => json_error(e.status(), &docs::message(&e)),
        Err(e) => json_error(500, &e.to_string()),
    }
}

fn run_command(
    exe: &std::path::Path,
    args: &[String],
    name: &str,
) -> Result<(Vec<u8>, String), DownloadError> {
    let tmp = std::env::temp_dir().join(format!("errmap-workbench-{}", form_token()));
    std::fs::create_dir(&tmp).map_err(|source| DownloadError::TempDir {
        path: tmp.clone(),
        source,
    })?;
    let out = tmp.join(name);
    let result = std::process::Command::new(exe)
        .args(args)
        .arg("--out")
        .arg(&out)
        .stdin(std::process::Stdio::null())
        .output();
    let bytes = std::fs::read(&out);
    let _ = std::fs::remove_dir_all(&tmp);
    let o = result.map_err(|source| DownloadError::Run {
        exe: exe.to_path_buf(),
        source,
    })?;
    if !o.status.success() {
        let text = String::from_utf8_lossy(&o.stderr);
        let line = text
            .lines()
            .find(|l| l.starts_with("errmap: error:") || l.starts_with("error:"))
            .unwrap_or(text.trim());
        return Err(DownloadError::Refused(
            line.trim_start_matches("errmap: error: ").to_string(),
        ));
    }
    let bytes = bytes.map_err(|source| DownloadError::Output { path: out, source })?;
    Ok((bytes, name.to_string()))
}

fn stem(item: &str) -> String {
    item.trim_end_matches('/')
        .rsplit('/')
        .next()
        .unwrap_or("session")
        .split('.')
        .next()
        .unwrap_or("session")
        .to_string()
}

/// The session table of a download's item, as the command's argument, and whether it is
/// a rotary session.
fn session_arg(st: &Shared, item: &str) -> Result<(String, bool), DocError> {
    let p = st.jobs.session_path(item)?;
    let rotary = errmap::session::rotary::is_rotary(&p)
        .map_err(|e| DocError::Bad(format!("{item}: {}", docs::message(&e))))?;
    Ok((p.display().to_string(), rotary))
}

async fn download_table(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
) -> Result<Response, DocError> {
    let (session, _) = session_arg(&st, &item)?;
    let name = format!("{}-errors.csv", stem(&item));
    Ok(by_command(
        st,
        vec!["table".into(), session],
        name,
        "text/csv; charset=utf-8",
    )
    .await)
}

async fn download_certificate(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Result<Response, DocError> {
    let (session, _) = session_arg(&st, &item)?;
    let mut args = vec!["certificate".to_string(), session];
    for (flag, v) in [("--info", &q.info), ("--tolerances", &q.tolerances)] {
        if let Some(id) = v.as_deref().filter(|v| !v.is_empty()) {
            let p = st.jobs.ws.resolve(id).map_err(|e| {
                let status = DocError::from(e);
                status.with_message(format!("{flag}: {id}"))
            })?;
            args.extend([flag.to_string(), p.display().to_string()]);
        }
    }
    let name = format!("{}-certificate.pdf", stem(&item));
    Ok(by_command(st, args, name, "application/pdf").await)
}

/// `errmap export`: a linear session with `--bidirectional --axis AXIS`, a rotary one as
/// its controller's modulo table (one value per point, the axis from the session).
async fn download_export(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Result<Response, DocError> {
    let (session, rotary) = session_arg(&st, &item)?;
    let known = |f: &str| {
        if rotary {
            errmap::controller::modulo::modulo_dialect(f).is_some()
        } else {
            errmap::controller::DIALECTS.iter().any(|d| d.name() == f)
        }
    };
    let Some(format) = q.format.filter(|f| known(f)) else {
        return Err(DocError::Bad(if rotary {
            format!(
                "?format= one of the controllers with a modulo table: {}",
                errmap::controller::modulo::modulo_names()
            )
        } else {
            "?format= one of the controller dialects".into()
        }));
    };
    let mut args = vec![
        "export".to_string(),
        session,
        "--format".into(),
        format.clone(),
    ];
    if !rotary {
        let axis = st
            .jobs
            .ws
            .items()
            .into_iter()
            .find(|i| i.id == item)
            .and_then(|i| i.axis)
            .unwrap_or_else(|| "x".into())
            .to_ascii_lowercase();
        args.extend(["--bidirectional".into(), "--axis".into(), axis]);
    }
    let name = format!("{}-{format}.txt", stem(&item));
    Ok(by_command(st, args, name, "text/plain; charset=utf-8").await)
}
