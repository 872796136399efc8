//! The server-rendered pages: the figures are text in the page, the charts inline SVG.
//! Each page calls the job of its JSON document (`docs`) and shows its result.

use std::fmt::Write;
use std::sync::Arc;

use axum::Router;
use axum::extract::{Path as UrlPath, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde_json::Value;

use super::charts::{self, Band, DeviationTarget, PALETTE, Pt, Series};
use super::docs::{self, DocError, Reduction};
use super::html::{esc, num, page, table, url_path};
use super::server::{AppState, Params, Shared, blocking};

pub(crate) fn routes() -> Router<Shared> {
    Router::new()
        .route("/", get(workspace))
        .route("/session/{*item}", get(session))
        .route("/table/{*item}", get(error_table))
        .route("/volumetric/{*item}", get(volumetric))
        .route("/circular/{*item}", get(circular))
        .route("/acceptance/{*item}", get(acceptance))
        .route("/history", get(history))
        .route("/live", get(live))
}

fn html(st: &Shared, status: u16, title: &str, body: &str) -> Response {
    (
        StatusCode::from_u16(status).unwrap_or(StatusCode::OK),
        [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
        page(title, &st.form_token, body),
    )
        .into_response()
}

/// A page for a job's result, or the error page in the same style (404 for an item that
/// does not exist, 400 with the command's message for one that cannot be read).
fn result_page(st: &Shared, title: &str, r: Result<String, DocError>) -> Response {
    match r {
        Ok(body) => html(st, 200, title, &body),
        // The page's script reloads it until the result is there.
        Err(DocError::Pending) => html(
            st,
            202,
            title,
            "<p class=\"note\" id=\"pending\">Being computed: the workbench is making this \
             page's result (at start-up it makes the workspace's results once). The page fills \
             in by itself when it is ready.</p>",
        ),
        Err(e) => {
            let heading = if e.status() == 404 {
                "Not found"
            } else {
                title
            };
            html(
                st,
                e.status(),
                heading,
                &super::html::error_box(&e.to_string()),
            )
        }
    }
}

/// The page `title` whose body `body` makes off the async threads (it runs the jobs).
async fn job_page(
    st: Shared,
    title: String,
    body: impl FnOnce(&AppState) -> Result<String, DocError> + Send + 'static,
) -> Response {
    let st2 = Arc::clone(&st);
    let r = blocking(move || super::cache::without_waiting(|| body(&st2))).await;
    result_page(&st, &title, r)
}

async fn workspace(State(st): State<Shared>) -> Response {
    let st2 = Arc::clone(&st);
    let items = blocking(move || Ok(st2.jobs.ws.items()))
        .await
        .unwrap_or_default();
    let rows: Vec<Vec<String>> = items
        .iter()
        .map(|i| {
            let name = match i.kind.page() {
                Some(p) => format!("<a href=\"/{p}/{}\">{}</a>", url_path(&i.id), esc(&i.path)),
                None => esc(&i.path),
            };
            let name = match &i.error {
                Some(e) => format!("{name} <span class=\"error\">{}</span>", esc(e)),
                None => name,
            };
            vec![
                esc(i.kind.label()),
                name,
                esc(i.machine.as_deref().unwrap_or("—")),
                esc(i.axis.as_deref().unwrap_or("—")),
                esc(&i.modified),
                format!("{} B", i.size),
            ]
        })
        .collect();
    let mut body = format!(
        "<p class=\"note\">{} item(s) under <code>{}</code>.</p>",
        items.len(),
        esc(&st.jobs.ws.root().display().to_string())
    );
    body.push_str(&table(
        &["kind", "item", "machine", "axis", "modified (UTC)", "size"],
        &rows,
    ));
    html(&st, 200, "Workspace", &body)
}

async fn session(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    job_page(st, format!("Session {item}"), move |st| {
        let doc = st.jobs.table(&item)?;
        Ok(match &doc.reduced {
            Reduction::Linear(r) => session_body(st, &item, &doc.path, r, &q),
            Reduction::Rotary(r) => super::rotary::body(
                r,
                &item,
                &st.jobs.ws.id_of(&doc.path),
                q.info.as_deref(),
                decoder_stats(&doc.path),
            ),
        })
    })
    .await
}

/// A figure: its name, and its value to `d` decimals with its unit.
fn figure(name: &str, v: f64, d: usize, unit: &str) -> String {
    format!(
        "<div class=\"figure\"><span>{}</span><b>{}</b></div>",
        esc(name),
        esc(&num(v, d, unit))
    )
}

fn session_body(
    st: &AppState,
    id: &str,
    path: &std::path::Path,
    r: &errmap::acquire::Reduced,
    q: &Params,
) -> String {
    let s = &r.summary;
    let mut b = String::new();
    let _ = write!(
        b,
        "<p>Axis <b>{}</b>, {} line(s) × {} target(s); {} rows, {} dwell samples used, {} flagged \
         left out, {} not dwelling. Table <code>{}</code>.</p>",
        esc(s.axis.as_deref().unwrap_or("?")),
        s.lines,
        s.targets,
        s.rows,
        s.used,
        s.flagged,
        s.not_dwelling,
        esc(&st.jobs.ws.id_of(path))
    );
    if let Some(stats) = decoder_stats(path) {
        b.push_str(&stats);
    }
    let u = url_path(id);
    let mut downloads = format!(
        "<h2>Downloads</h2><p class=\"downloads\"><a href=\"/download/table/{u}\">error table (CSV)</a>\
         <a href=\"/download/certificate/{u}{info}\">certificate (PDF)</a></p><p class=\"downloads\">\
         Compensation table: ",
        info = q
            .info
            .as_deref()
            .map(|i| format!("?info={}", url_path(i)))
            .unwrap_or_default()
    );
    for d in errmap::controller::DIALECTS {
        let _ = write!(
            downloads,
            "<a href=\"/download/export/{u}?format={n}\">{n}</a>",
            n = esc(d.name())
        );
    }
    downloads.push_str("</p>");
    for (line, e) in &r.failed {
        let _ = write!(
            b,
            "{}",
            super::html::error_box(&format!("line {line:?}: no ISO 230-2 statistics: {e}"))
        );
    }
    for (k, ((line, stats), exp)) in r.iso.iter().zip(&r.expanded).enumerate() {
        // µm to the decimals the ISO 230-2 report prints this line with.
        let d = errmap::report::iso230_decimals(stats);
        let _ = write!(
            b,
            "<h2>Line {} at ({:.3}, {:.3}) mm</h2><div class=\"figures\">",
            k + 1,
            line.0,
            line.1
        );
        for (name, v) in [
            ("A (accuracy)", stats.a_um),
            ("A↑", stats.a_up_um),
            ("A↓", stats.a_down_um),
            ("E (systematic)", stats.e_um),
            ("M (mean bidirectional)", stats.m_um),
            ("R (repeatability)", stats.r_um),
            ("R↑", stats.r_up_um),
            ("R↓", stats.r_down_um),
            ("B (reversal)", stats.b_um),
            ("B̄ (mean reversal)", stats.mean_reversal_um),
        ] {
            b.push_str(&figure(name, v, d, "µm"));
        }
        let vdi = serde_json::to_value(&stats.vdi).unwrap_or(Value::Null);
        if let Some(o) = vdi.as_object() {
            for (name, v) in o {
                if let Some(x) = v.as_f64() {
                    let (short, unit) = match name.strip_suffix("_um") {
                        Some(n) => (n, "µm"),
                        None => (name.as_str(), ""),
                    };
                    b.push_str(&figure(&format!("VDI 3441 {short}"), x, d, unit));
                }
            }
        }
        b.push_str("</div>");
        let _ = write!(
            b,
            "<p class=\"note\">Expanded uncertainty (k = {:.1}) at the travel of {:.1} mm: see the \
             JSON document for each figure's U.</p>",
            exp.k, exp.travel_mm
        );
        b.push_str(&deviation_chart(stats, k + 1, d));
        let rows: Vec<Vec<String>> = stats
            .targets
            .iter()
            .map(|t| {
                vec![
                    t.target.to_string(),
                    num(t.position_mm, 3, "mm"),
                    num(t.mean_up_um, d, "µm"),
                    num(t.s_up_um, d, "µm"),
                    num(t.mean_down_um, d, "µm"),
                    num(t.s_down_um, d, "µm"),
                    num(t.reversal_um, d, "µm"),
                ]
            })
            .collect();
        b.push_str(&table(
            &["target", "P", "x̄↑", "s↑", "x̄↓", "s↓", "B_i"],
            &rows,
        ));
    }
    b.push_str(&environment(&r.environment));
    b.push_str(&downloads);
    b
}

/// The decoder statistics of a capture directory (its `session.json`), as a line.
fn decoder_stats(table: &std::path::Path) -> Option<String> {
    let json = table.parent()?.join("session.json");
    let text = std::fs::read_to_string(json).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    let d = v.get("decoder")?;
    let n = |k: &str| d.get(k).and_then(Value::as_u64).unwrap_or(0);
    Some(format!(
        "<p>Capture: {} bytes, {} rows; CRC failures {}, resyncs {}, seq gaps {}, flagged samples {}; \
         ended: {}.</p>",
        v.get("bytes").and_then(Value::as_u64).unwrap_or(0),
        n("rows"),
        n("crc_failures"),
        n("resyncs"),
        n("seq_gaps"),
        n("flagged_samples"),
        esc(&v.get("end").map(|e| e.to_string()).unwrap_or_default())
    ))
}

fn environment(e: &errmap::session::EnvironmentStats) -> String {
    let text = errmap::report::environment_text(e);
    format!("<h2>Environment</h2><pre>{}</pre>", esc(&text))
}

/// The ISO 230-2 deviation chart of one line, in the report's style; tips in µm to `d`
/// decimals.
fn deviation_chart(stats: &errmap::session::AxisStats, line: usize, d: usize) -> String {
    let targets: Vec<DeviationTarget> = stats
        .targets
        .iter()
        .map(|t| DeviationTarget {
            target: t.target,
            x: t.position_mm,
            up: (t.mean_up_um, t.s_up_um),
            down: (t.mean_down_um, t.s_down_um),
        })
        .collect();
    charts::xy(
        &format!("Line {line}: positional deviation (ISO 230-2)"),
        "target position P_i / mm",
        "positional deviation x = −e / µm",
        &charts::deviation_series(targets, &|t, name, dir, v| {
            format!(
                "target {} (P = {:.3} mm), {dir}, all runs: {name} = {v:.d$} µm",
                t.target, t.x
            )
        }),
        &[],
    )
}

async fn error_table(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    let title = format!("Error table {item}");
    job_page(st, title, move |st| {
        let id = item;
        let p = st.jobs.ws.resolve(&id)?;
        let t =
            errmap::table::ErrorTable::read(&p).map_err(|e| DocError::Bad(docs::message(&e)))?;
        let tests: String = st
            .jobs
            .ws
            .items()
            .iter()
            .filter(|i| i.kind == super::items::Kind::ErrorTable && i.id != id)
            .map(|i| {
                let sel = if q.test.as_deref() == Some(i.id.as_str()) {
                    " selected"
                } else {
                    ""
                };
                format!("<option{sel}>{}</option>", esc(&i.id))
            })
            .collect();
        let mut b = format!(
            "<p>{} node(s).</p><form method=\"get\">Compare the models on the test points of \
             <select name=\"test\">{tests}</select> <button>Compare</button></form>",
            t.points.len()
        );
        if let Some(test) = q.test.as_deref() {
            b.push_str(&compare_body(&*st.jobs.compare(&id, test)?));
        }
        let rows: Vec<Vec<String>> = t
            .points
            .iter()
            .take(500)
            .map(|p| {
                vec![
                    num(p.x_mm, 3, "mm"),
                    num(p.y_mm, 3, "mm"),
                    num(p.z_mm, 3, "mm"),
                    num(p.e_um, 4, "µm"),
                ]
            })
            .collect();
        b.push_str("<h2>Nodes (the first 500)</h2>");
        b.push_str(&table(&["x", "y", "z", "e"], &rows));
        Ok(b)
    })
    .await
}

/// The comparison of `errmap compare` (its JSON document) as a table and the measured-
/// vs-predicted chart of the recommended model.
fn compare_body(cmp: &docs::CompareDoc) -> String {
    let empty = Vec::new();
    let rows = cmp
        .doc
        .get("rows")
        .and_then(Value::as_array)
        .unwrap_or(&empty);
    let f = |r: &Value, k: &str| r.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN);
    let t: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                esc(r.get("label").and_then(Value::as_str).unwrap_or("")),
                num(f(r, "rms_um"), 4, "µm"),
                num(f(r, "max_abs_um"), 4, "µm"),
                num(f(r, "cv_rms_um"), 4, "µm"),
            ]
        })
        .collect();
    let mut s = String::from("<h2>Model comparison</h2>");
    s.push_str(&table(
        &[
            "model",
            "RMS on the test points",
            "max |error|",
            "cross-validated RMS",
        ],
        &t,
    ));
    let rec = cmp.recommended;
    let Some(best) = rows.get(rec) else {
        return s;
    };
    let label = best.get("label").and_then(Value::as_str).unwrap_or("");
    let _ = write!(s, "<p>Recommended: <b>{}</b>.</p>", esc(label));
    let measured = &cmp.measured_um;
    let predicted: Vec<f64> = best
        .get("predictions")
        .and_then(Value::as_array)
        .map(|a| a.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect())
        .unwrap_or_default();
    if measured.len() == predicted.len() && !measured.is_empty() {
        let pts = measured
            .iter()
            .zip(&predicted)
            .enumerate()
            .map(|(k, (m, p))| Pt {
                x: *m,
                y: *p,
                tip: format!(
                    "test point {}: measured {m:.4} µm, predicted {p:.4} µm",
                    k + 1
                ),
            })
            .collect();
        let (lo, hi) = measured
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let diag = Series {
            name: "predicted = measured".into(),
            colour: PALETTE[9],
            dashed: true,
            markers: false,
            points: vec![
                Pt {
                    x: lo,
                    y: lo,
                    tip: String::new(),
                },
                Pt {
                    x: hi,
                    y: hi,
                    tip: String::new(),
                },
            ],
        };
        s.push_str(
            &charts::xy(
                &format!("Measured vs predicted: {label}"),
                "measured e / µm",
                "predicted e / µm",
                &[
                    Series {
                        name: label.into(),
                        colour: PALETTE[0],
                        dashed: false,
                        markers: true,
                        points: pts,
                    },
                    diag,
                ],
                &[],
            )
            .replace(
                "<polyline points=\"",
                "<polyline data-kind=\"scatter\" points=\"",
            ),
        );
    }
    s
}

async fn volumetric(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    let title = format!("Volumetric {item}");
    job_page(st, title, move |st| {
        let (id, topology) = (item, q.topology);
        let form = format!(
            "<form class=\"inline\" method=\"get\">Topology <input name=\"topology\" value=\"{}\" \
             size=\"6\"> <button>Identify</button></form>",
            esc(topology.as_deref().unwrap_or(""))
        );
        match st.jobs.volumetric(&id, topology.as_deref()) {
            Ok(v) => Ok(volumetric_body(&v.doc)),
            Err(e @ DocError::Bad(_)) if topology.is_none() && !id.ends_with(".json") => {
                Ok(format!("<p>{}</p>{form}", esc(&e.to_string())))
            }
            Err(e) => Err(e),
        }
    })
    .await
}

fn volumetric_body(doc: &Value) -> String {
    let mut b = String::new();
    let g = |k: &str| doc.get(k).cloned().unwrap_or(Value::Null);
    let _ = write!(
        b,
        "<p>Topology <b>{}</b>, basis {}, {} line(s), {} target(s); RMS residual <b>{}</b>.</p>",
        esc(g("topology").as_str().unwrap_or("?")),
        esc(&g("basis").to_string()),
        g("lines"),
        g("targets"),
        // The volumetric report's decimals: 4 for the residual and the function
        // components, 3 for the constant (squareness) ones.
        esc(&num(
            g("rms_residual_um").as_f64().unwrap_or(f64::NAN),
            4,
            "µm"
        ))
    );
    let _ = write!(
        b,
        "<h2>Residual test</h2><p>{}</p>",
        esc(&residual_words(&g("residual")))
    );
    if let Some(u) = g("unidentified").as_array().filter(|u| !u.is_empty()) {
        b.push_str("<h2>What the lines cannot determine</h2><ul>");
        for x in u {
            let _ = write!(b, "<li>{}</li>", esc(&x.to_string()));
        }
        b.push_str("</ul>");
    }
    b.push_str("<h2>The 21 components (value ± 1σ)</h2>");
    let mut constants = Vec::new();
    if let Some(comps) = g("components").as_object() {
        for (name, c) in comps {
            let unit = unit_symbol(c.get("unit").and_then(Value::as_str).unwrap_or(""));
            let identified = c
                .get("identified")
                .and_then(Value::as_bool)
                .unwrap_or(false);
            if let Some(pos) = c.get("positions_mm").and_then(Value::as_array) {
                let f = |k: &str| -> Vec<f64> {
                    c.get(k)
                        .and_then(Value::as_array)
                        .map(|a| a.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect())
                        .unwrap_or_default()
                };
                let x: Vec<f64> = pos.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect();
                let (v, s) = (f("values"), f("sigma"));
                if !identified || v.len() != x.len() {
                    constants.push(vec![esc(name), "not identified".into(), String::new()]);
                    continue;
                }
                let band = (s.len() == x.len()).then(|| Band {
                    colour: PALETTE[0],
                    x: x.clone(),
                    lo: v.iter().zip(&s).map(|(a, b)| a - b).collect(),
                    hi: v.iter().zip(&s).map(|(a, b)| a + b).collect(),
                });
                let pts = x
                    .iter()
                    .zip(&v)
                    .enumerate()
                    .map(|(k, (x, y))| Pt {
                        x: *x,
                        y: *y,
                        tip: format!(
                            "{name} at {x:.1} mm: {y:.4} {unit}{}",
                            s.get(k)
                                .map(|s| format!(" ± {s:.4} (1σ)"))
                                .unwrap_or_default()
                        ),
                    })
                    .collect();
                b.push_str(&charts::xy(
                    name,
                    "position along the axis / mm",
                    &format!("{name} / {unit}"),
                    &[Series {
                        name: format!("{name} (band ±1σ)"),
                        colour: PALETTE[0],
                        dashed: false,
                        markers: true,
                        points: pts,
                    }],
                    &band.into_iter().collect::<Vec<_>>(),
                ));
            } else {
                let v = c.get("value").and_then(Value::as_f64);
                let s = c.get("sigma").and_then(Value::as_f64);
                constants.push(vec![
                    esc(name),
                    v.map_or("not identified".into(), |v| num(v, 3, unit)),
                    s.map_or(String::new(), |s| num(s, 3, unit)),
                ]);
            }
        }
    }
    b.push_str("<h2>Constant components</h2>");
    b.push_str(&table(&["component", "value", "σ"], &constants));
    b
}

async fn circular(State(st): State<Shared>, UrlPath(item): UrlPath<String>) -> Response {
    job_page(st, format!("Circular test {item}"), move |st| {
        let c = st.jobs.circular(&item)?;
        let d = &c.diagnosis;
        let mut b = charts::polar(&c.chart);
        let iso = &d.iso230_4;
        b.push_str("<h2>ISO 230-4</h2><div class=\"figures\">");
        for (name, v) in [
            ("G ccw", iso.g_ccw_um),
            ("G cw", iso.g_cw_um),
            ("G(b)", iso.g_b_um),
            ("H", iso.h_um),
            ("D", iso.d_um),
            ("F max", Some(iso.f_max_um)),
            ("F min", Some(iso.f_min_um)),
        ] {
            // The ballbar report's decimals (its ISO 230-4 table).
            b.push_str(&figure(name, v.unwrap_or(f64::NAN), 3, "µm"));
        }
        let _ = write!(
            b,
            "</div><h2>Diagnosis: {}</h2><p>RMS {} before, {} after (σ of a sample {}).</p>",
            esc(&d.verdict.to_string()),
            esc(&num(d.rms_before_um, 3, "µm")),
            esc(&num(d.rms_after_um, 3, "µm")),
            esc(&num(d.sigma_um, 3, "µm"))
        );
        let doc: Value = serde_json::from_str(&c.text).unwrap_or(Value::Null);
        let rows: Vec<Vec<String>> = doc
            .get("effects")
            .and_then(Value::as_array)
            .map(|a| a.iter().map(|e| vec![esc(&e.to_string())]).collect())
            .unwrap_or_default();
        b.push_str(&table(
            &["effect (value ± σ, as in the JSON document)"],
            &rows,
        ));
        Ok(b)
    })
    .await
}

async fn acceptance(
    State(st): State<Shared>,
    UrlPath(item): UrlPath<String>,
    Query(q): Query<Params>,
) -> Response {
    job_page(st, format!("ISO 10360-2 test {item}"), move |st| {
        let mpe = q.mpe.unwrap_or_default();
        let mut b = format!(
            "<form method=\"get\">MPE of E0 (µm, L in mm) <input name=\"mpe\" value=\"{}\" \
             placeholder=\"1.5+L/333\"> <button>Evaluate</button></form>",
            esc(&mpe)
        );
        if mpe.is_empty() {
            return Ok(b);
        }
        let doc = st.jobs.iso10360(&item, &mpe)?;
        let r = &doc.result;
        let _ = write!(
            b,
            "<h2>Verdict: {}</h2><p>{}</p><p>{} measurement(s) in {} position(s); max |E0| {}, max R0 {}.</p>",
            esc(&r.verdict.to_string()),
            esc(&r.statement),
            r.summary.measurements,
            r.summary.positions,
            esc(&num(r.summary.max_abs_e0_um, 3, "µm")),
            esc(&num(r.summary.max_r0_um, 3, "µm"))
        );
        let rows: Vec<Vec<String>> = r
            .positions
            .iter()
            .map(|p| vec![esc(&p.position), num(p.max_abs_e0_um, 3, "µm"), esc(&p.verdict.to_string())])
            .collect();
        b.push_str(&table(&["position", "max |E0|", "verdict"], &rows));
        Ok(b)
    })
    .await
}

async fn history(State(st): State<Shared>) -> Response {
    let Some(ledger) = st.ledger.clone() else {
        return html(
            &st,
            200,
            "Fleet history",
            "<p>No ledger: start the workbench with <code>--ledger LEDGER</code> (a SQLite file or \
             <code>postgres://…</code>).</p>",
        );
    };
    job_page(st, "Fleet history".into(), move |_| {
        docs::history(&ledger).map(|h| history_body(&h))
    })
    .await
}

fn history_body(h: &docs::History) -> String {
    let mut b = format!(
        "<p>As of {}; {} record(s); forecast horizon {} days.</p><h2>Fleet ranking by risk</h2>",
        esc(&h.head.as_of),
        h.head.ledger.records,
        h.head.horizon_days
    );
    let rows: Vec<Vec<String>> = h
        .fleet
        .iter()
        .map(|f| vec![esc(&f.id), format!("{:.3}", f.risk), esc(f.advice.as_str())])
        .collect();
    b.push_str(&table(&["machine", "risk", "advice"], &rows));
    for m in &h.machines {
        let _ = write!(
            b,
            "<h2>{}</h2><p>{} record(s); advice <b>{}</b>{}.</p>",
            esc(&m.id),
            m.records,
            esc(m.advice.as_str()),
            m.recalibrate_by
                .as_deref()
                .map(|d| format!("; recalibrate by {}", esc(d)))
                .unwrap_or_default()
        );
        for a in &m.axes {
            for p in &a.parameters {
                b.push_str(&parameter_chart(&m.id, &a.axis, p));
            }
        }
    }
    b
}

/// One parameter's EWMA chart and its line, to the history report's 3 decimals.
fn parameter_chart(machine: &str, axis: &str, p: &errmap::history::ParameterReport) -> String {
    let unit = unit_symbol(&p.unit);
    let day = |at: &str| errmap::history::parse_utc(at).map_or(f64::NAN, |t| t as f64 / 86_400.0);
    let line = |name: &str,
                colour,
                dashed,
                markers,
                f: &dyn Fn(&errmap::history::SeriesPoint) -> Option<f64>| Series {
        name: name.into(),
        colour,
        dashed,
        markers,
        points: p
            .series
            .iter()
            .filter_map(|s| {
                f(s).map(|v| Pt {
                    x: day(&s.at),
                    y: v,
                    tip: format!(
                        "{} record {} ({}): {name} {v:.3} {}",
                        s.at, s.record, s.state, unit
                    ),
                })
            })
            .collect(),
    };
    let series = [
        line("value", PALETTE[0], false, true, &|s| Some(s.value)),
        line("EWMA", PALETTE[1], false, false, &|s| s.ewma),
        line("UCL", PALETTE[3], true, false, &|s| s.ucl),
        line("LCL", PALETTE[3], true, false, &|s| s.lcl),
    ];
    let (lo, hi) = p
        .series
        .iter()
        .map(|s| day(&s.at))
        .filter(|d| d.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| {
            (a.min(d), b.max(d))
        });
    let chart = charts::xy_on(
        &format!("{machine} {axis} {} (EWMA chart)", p.name),
        &charts::date_axis("date of the record (UTC)", lo, hi),
        &format!("{} / {}", p.name, unit),
        &series,
    );
    let trend = match (p.rate_per_year, p.rate_sigma) {
        (Some(r), Some(s)) => format!("trend {r:.3} ± {s:.3} {}/year", unit),
        (Some(r), None) => format!("trend {r:.3} {}/year", unit),
        _ => "no trend".into(),
    };
    let forecast = p
        .exceeds_tolerance_at
        .as_deref()
        .map(|d| format!("; forecast to exceed the tolerance on {d}"))
        .unwrap_or_default();
    format!(
        "{chart}<p>{}: last {}; {trend}{forecast}; {} alarm(s).</p>",
        esc(&p.name),
        esc(&num(p.last, 3, unit)),
        p.alarms.len()
    )
}

/// A unit as a page prints it: the JSON documents spell µ in ASCII (`um`, `urad`).
fn unit_symbol(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        other => other,
    }
}

/// The volumetric residual test in words: the test, its verdict and z, and the effects it
/// names (the `residual` object of `volumetric identify --json`).
fn residual_words(r: &Value) -> String {
    let test = r.get("test").and_then(Value::as_str).unwrap_or("residual");
    let verdict = r
        .get("verdict")
        .and_then(Value::as_str)
        .unwrap_or("not run");
    let mut s = format!("{test} test: {verdict}");
    if let Some(z) = r.get("z").and_then(Value::as_f64) {
        let _ = write!(s, " (z = {z:.2})");
    }
    if let Some(effects) = r
        .get("effects")
        .and_then(Value::as_array)
        .filter(|e| !e.is_empty())
    {
        let named: Vec<String> = effects.iter().map(|e| e.to_string()).collect();
        let _ = write!(s, "; effects: {}", named.join(", "));
    }
    s.push('.');
    s
}

async fn live(State(st): State<Shared>) -> Response {
    let st2 = Arc::clone(&st);
    let toml = blocking(move || Ok(walk_toml(&st2.jobs.ws)))
        .await
        .unwrap_or_default();
    let options = |pick: &dyn Fn(&str) -> bool| {
        toml.iter()
            .filter(|t| pick(t))
            .map(|t| format!("<option>{}</option>", esc(t)))
            .collect::<String>()
    };
    let body = format!(
        "<div id=\"live\"><p><label><input type=\"radio\" name=\"source\" value=\"sim\" checked> \
         Simulated board: model <select id=\"model\">{models}</select> plan <select id=\"plan\">{plans}</select> \
         speed <input id=\"speed\" value=\"1\" size=\"4\">× real time</label></p>\
         <p><label><input type=\"radio\" name=\"source\" value=\"port\"> Serial port \
         <input id=\"port\" placeholder=\"/dev/ttyUSB0\"></label></p>\
         <p><button id=\"start\">Start</button><button id=\"stop\" disabled>Stop</button> \
         <span id=\"live-message\"></span></p>\
         <div class=\"live-grid\">\
         <div class=\"figure\"><span>state</span><b id=\"state\">idle</b></div>\
         <div class=\"figure\"><span>session</span><b id=\"session\">—</b></div>\
         <div class=\"figure\"><span>updates received</span><b id=\"frames\">0</b></div>\
         <div class=\"figure\"><span>bytes written</span><b id=\"bytes\">0 B</b></div>\
         <div class=\"figure\"><span>samples</span><b id=\"samples\">0</b></div>\
         <div class=\"figure\"><span>run</span><b id=\"run\">—</b></div>\
         <div class=\"figure\"><span>target</span><b id=\"target\">—</b></div>\
         <div class=\"figure\"><span id=\"position-label\">scale position</span><b id=\"position\">—</b></div>\
         <div class=\"figure\"><span>error reading</span><b id=\"reading\">—</b></div>\
         </div><p>Decoder health: <span id=\"health\">—</span></p>\
         <h2>Error at each target per pass (mean of its dwell samples)</h2>\
         <table><thead><tr><th>run</th><th>dir</th><th>target</th><th>position</th><th>error</th><th>samples</th></tr></thead>\
         <tbody id=\"targets\"></tbody></table></div>",
        models = options(&|t| t.contains("model")),
        plans = options(&|t| t.contains("plan")),
    );
    html(&st, 200, "Live capture", &body)
}

/// The TOML files of the workspace (machine models and plans for the simulated board).
fn walk_toml(ws: &super::items::Workspace) -> Vec<String> {
    fn walk(dir: &std::path::Path, depth: usize, out: &mut Vec<std::path::PathBuf>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        let mut v: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        v.sort();
        for p in v {
            let hidden = p
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if hidden || out.len() > 500 {
                continue;
            }
            if p.is_dir() && depth < 4 {
                walk(&p, depth + 1, out);
            } else if p.extension().is_some_and(|e| e == "toml") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(ws.root(), 0, &mut out);
    out.into_iter()
        .filter(|p| ws.resolve(&ws.id_of(p)).is_ok())
        .map(|p| ws.id_of(&p))
        .collect()
}
