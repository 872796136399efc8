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

use super::docs::{self, DocError};
use super::items::Workspace;
use super::live::{Live, StartRequest};

/// What `errmap workbench` was given.
#[derive(Debug, Clone)]
pub struct Config {
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
pub enum ServeError {
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
    pub ws: Workspace,
    pub ledger: Option<String>,
    pub token: Option<String>,
    /// The per-run form token (in every page; required on every POST).
    pub form_token: String,
    pub exe: Option<PathBuf>,
    pub live: Live,
}

pub(crate) type Shared = Arc<AppState>;

/// Serves the workbench until `stop` is set; `on_bound` gets the real address first.
pub fn serve(
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
        ws,
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
    match r {
        Ok(t) => json_text(t),
        Err(e) => json_error(e.status, &e.message),
    }
}

/// Runs a job off the async threads (the jobs read files and compute).
pub(crate) async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, DocError> + Send + 'static,
) -> Result<T, DocError> {
    tokio::task::spawn_blocking(f).await.unwrap_or_else(|e| {
        Err(DocError {
            status: 500,
            message: format!("the job failed: {e}"),
        })
    })
}

async fn not_found() -> Response {
    json_error(404, "no such page")
}

async fn favicon() -> Response {
    (
        [(header::CONTENT_TYPE, "image/svg+xml")],
        super::html::FAVICON,
    )
        .into_response()
}

async fn style() -> Response {
    (
        [(header::CONTENT_TYPE, "text/css; charset=utf-8")],
        super::html::STYLE,
    )
        .into_response()
}

async fn script() -> Response {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        super::html::SCRIPT,
    )
        .into_response()
}

async fn api_items(State(st): State<Shared>) -> Response {
    let st2 = Arc::clone(&st);
    doc_response(
        blocking(move || docs::text(&serde_json::json!({ "items": st2.ws.items() }))).await,
    )
}

async fn api_table(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    doc_response(blocking(move || docs::table(&st.ws, &item).map(|r| r.2)).await)
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
    let Some(sim) = q.simulated else {
        return json_error(
            400,
            "?simulated=ITEM is needed: the simulated session to diagnose against",
        );
    };
    doc_response(blocking(move || docs::diagnose(&st.ws, &item, &sim).map(|r| r.1)).await)
}

async fn api_circular(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    doc_response(blocking(move || docs::circular(&st.ws, &item).map(|r| r.2)).await)
}

async fn api_volumetric(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    doc_response(
        blocking(move || docs::volumetric(&st.ws, &item, q.topology.as_deref()).map(|r| r.1)).await,
    )
}

async fn api_acceptance(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    let Some(mpe) = q.mpe else {
        return json_error(
            400,
            "?mpe=FORMULA is needed (e.g. 1.5+L/333, µm with L in mm)",
        );
    };
    doc_response(blocking(move || docs::iso10360(&st.ws, &item, &mpe).map(|r| r.1)).await)
}

async fn api_history(State(st): State<Shared>) -> Response {
    let Some(ledger) = st.ledger.clone() else {
        return json_error(404, "no ledger: start the workbench with --ledger");
    };
    doc_response(blocking(move || docs::history(&ledger).map(|h| h.text)).await)
}

async fn live_start(State(st): State<Shared>, body: String) -> Response {
    let req: StartRequest = match serde_json::from_str(&body) {
        Ok(r) => r,
        Err(e) => return json_error(400, &format!("the request: {e}")),
    };
    let st2 = Arc::clone(&st);
    let r = tokio::task::spawn_blocking(move || st2.live.start(&st2.ws, req)).await;
    match r {
        Ok(Ok(session)) => json_text(serde_json::json!({ "session": session }).to_string()),
        Ok(Err((status, m))) => json_error(status, &m),
        Err(e) => json_error(500, &e.to_string()),
    }
}

async fn live_stop(State(st): State<Shared>) -> Response {
    let st2 = Arc::clone(&st);
    match tokio::task::spawn_blocking(move || st2.live.stop()).await {
        Ok(Ok(session)) => json_text(serde_json::json!({ "session": session }).to_string()),
        Ok(Err((status, m))) => json_error(status, &m),
        Err(e) => json_error(500, &e.to_string()),
    }
}

async fn live_state(State(st): State<Shared>) -> Response {
    doc_response(docs::text(&st.live.snapshot()))
}

/// Server-Sent Events: the live snapshot four times a second, as event `state`.
async fn live_events(State(st): State<Shared>) -> Response {
    use futures_util::stream;
    let events = stream::unfold((st, 0u64), |(st, n)| async move {
        if n > 0 {
            tokio::time::sleep(Duration::from_millis(250)).await;
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
        Ok(Err(m)) => json_error(400, &m),
        Err(e) => json_error(500, &e.to_string()),
    }
}

fn run_command(
    exe: &std::path::Path,
    args: &[String],
    name: &str,
) -> Result<(Vec<u8>, String), String> {
    let tmp = std::env::temp_dir().join(format!("errmap-workbench-{}", form_token()));
    std::fs::create_dir(&tmp).map_err(|e| format!("{}: {e}", tmp.display()))?;
    let out = tmp.join(name);
    let result = std::process::Command::new(exe)
        .args(args)
        .arg("--out")
        .arg(&out)
        .stdin(std::process::Stdio::null())
        .output();
    let bytes = std::fs::read(&out);
    let _ = std::fs::remove_dir_all(&tmp);
    let o = result.map_err(|e| format!("{}: {e}", exe.display()))?;
    if !o.status.success() {
        let text = String::from_utf8_lossy(&o.stderr);
        let line = text
            .lines()
            .find(|l| l.starts_with("errmap: error:") || l.starts_with("error:"))
            .unwrap_or(text.trim());
        return Err(line.trim_start_matches("errmap: error: ").to_string());
    }
    Ok((bytes.map_err(|e| e.to_string())?, name.to_string()))
}

fn session_arg(st: &Shared, item: &str) -> Result<String, DocError> {
    docs::session_path(&st.ws, item).map(|p| p.display().to_string())
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

async fn download_table(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    let session = match session_arg(&st, &item) {
        Ok(s) => s,
        Err(e) => return json_error(e.status, &e.message),
    };
    let name = format!("{}-errors.csv", stem(&item));
    by_command(
        st,
        vec!["table".into(), session],
        name,
        "text/csv; charset=utf-8",
    )
    .await
}

async fn download_certificate(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    let session = match session_arg(&st, &item) {
        Ok(s) => s,
        Err(e) => return json_error(e.status, &e.message),
    };
    let mut args = vec!["certificate".to_string(), session];
    for (flag, v) in [("--info", &q.info), ("--tolerances", &q.tolerances)] {
        if let Some(id) = v.as_deref().filter(|v| !v.is_empty()) {
            match st.ws.resolve(id) {
                Ok(p) => args.extend([flag.to_string(), p.display().to_string()]),
                Err(e) => return json_error(DocError::from(e).status, &format!("{flag}: {id}")),
            }
        }
    }
    let name = format!("{}-certificate.pdf", stem(&item));
    by_command(st, args, name, "application/pdf").await
}

async fn download_export(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    let session = match session_arg(&st, &item) {
        Ok(s) => s,
        Err(e) => return json_error(e.status, &e.message),
    };
    let Some(format) = q.format.filter(|f| {
        crate::controller::DIALECTS
            .iter()
            .any(|d| d.name() == f.as_str())
    }) else {
        return json_error(400, "?format= one of the controller dialects");
    };
    let axis = st
        .ws
        .items()
        .into_iter()
        .find(|i| i.id == item)
        .and_then(|i| i.axis)
        .unwrap_or_else(|| "x".into())
        .to_ascii_lowercase();
    let args = vec![
        "export".to_string(),
        session,
        "--format".into(),
        format.clone(),
        "--bidirectional".into(),
        "--axis".into(),
        axis,
    ];
    let name = format!("{}-{format}.txt", stem(&item));
    by_command(st, args, name, "text/plain; charset=utf-8").await
}
