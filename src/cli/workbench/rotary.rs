//! A rotary session (axis A, B or C; `docs/rotary.md`) in the workbench: the document of
//! `errmap table ROTARY --json` made by the same library calls as the command
//! (`session::rotary::{read_rotary_session, rotary_iso, closure_warning,
//! rotary_error_table}`), and its page: the ISO 230-2 figures in ″ with ° beside, the
//! closure check of 0° and 360°, the deviation chart in ″ against ° over the revolution,
//! the per-target table and the rotary downloads (error table, certificate, the modulo
//! tables of the controllers that have one, `modulo_dialects`).

use std::fmt::Write;
use std::path::Path;

use errmap::base::RotaryAxis;
use errmap::controller::modulo::modulo_dialects;
use errmap::session::rotary::{self, Closure, RotaryIso, RotaryTargetStats};

use super::charts::{self, DeviationTarget, XAxis};
use super::docs::{DocError, message};
use super::html::{esc, num, table, url_path};

/// Decimals of ″ on the page: the rotary ISO 230-2 report's (`table --report`).
const ARCSEC_DECIMALS: usize = 2;
/// Decimals of the ° beside each figure (the report's).
const DEG_DECIMALS: usize = 6;

/// The reduction of a rotary session, as `errmap table` makes it.
#[derive(Debug)]
pub(crate) struct RotaryDoc {
    pub axis: RotaryAxis,
    pub iso: RotaryIso,
    pub closure: Option<Closure>,
    pub warnings: Vec<String>,
    /// Rows of the rotary error table (`--out`).
    pub targets: usize,
    pub dwell_rows: usize,
    pub rows: usize,
}

/// Reads and reduces the rotary session table at `path`; the reduction and the text of
/// `errmap table PATH --json`.
pub(crate) fn reduce(path: &Path, id: &str) -> Result<(RotaryDoc, String), DocError> {
    let bad = |e: rotary::RotaryError| DocError::Bad(format!("{id}: {}", message(&e)));
    let session = rotary::read_rotary_session(path).map_err(bad)?;
    let (iso, closure) = rotary::rotary_iso(path, &session).map_err(bad)?;
    let warnings: Vec<String> = closure
        .as_ref()
        .and_then(rotary::closure_warning)
        .into_iter()
        .collect();
    let targets = rotary::rotary_error_table(&session).len();
    let dwell_rows = session.rows.iter().filter(|r| r.is_dwell()).count();
    let text = super::docs::text(&super::super::rotary::table_json(
        path.display().to_string(),
        session.axis,
        (targets, dwell_rows),
        &iso,
        closure.as_ref(),
        &warnings,
    ))?;
    let doc = RotaryDoc {
        axis: session.axis,
        iso,
        closure,
        warnings,
        targets,
        dwell_rows,
        rows: session.rows.len(),
    };
    Ok((doc, text))
}

/// A figure in ″ with its value in ° beside.
fn figure(name: &str, arcsec: f64) -> String {
    format!(
        "<div class=\"figure\"><span>{}</span><b>{}</b><small>{}</small></div>",
        esc(name),
        esc(&num(arcsec, ARCSEC_DECIMALS, "″")),
        esc(&num(arcsec / 3600.0, DEG_DECIMALS, "°"))
    )
}

/// The page of a rotary session: `id` the item, `table_id` its session table's item,
/// `info` the certificate's info file when the page was given one.
pub(crate) fn body(
    d: &RotaryDoc,
    id: &str,
    table_id: &str,
    info: Option<&str>,
    capture: Option<String>,
) -> String {
    let iso = &d.iso;
    let mut b = format!(
        "<p>Rotary axis <b>{}</b>: {} target(s) over the revolution, {} rows, {} dwell rows \
         used (each dwell's mean is one observation). Deviations x = −e, in arcseconds (″) \
         with degrees (°) beside. Table <code>{}</code>.</p>",
        d.axis,
        d.targets,
        d.rows,
        d.dwell_rows,
        esc(table_id)
    );
    if let Some(c) = capture {
        b.push_str(&c);
    }
    b.push_str("<h2>ISO 230-2 (″)</h2><div class=\"figures\">");
    for (name, v) in [
        ("A (accuracy)", iso.a_arcsec),
        ("A↑", iso.a_up_arcsec),
        ("A↓", iso.a_down_arcsec),
        ("E (systematic)", iso.e_arcsec),
        ("E↑", iso.e_up_arcsec),
        ("E↓", iso.e_down_arcsec),
        ("M (mean bidirectional)", iso.m_arcsec),
        ("R (repeatability)", iso.r_arcsec),
        ("R↑", iso.r_up_arcsec),
        ("R↓", iso.r_down_arcsec),
        ("B (reversal)", iso.b_arcsec),
        ("B̄ (mean reversal)", iso.mean_reversal_arcsec),
    ] {
        b.push_str(&figure(name, v));
    }
    b.push_str("</div>");
    b.push_str(&closure_section(d.closure.as_ref(), &d.warnings));
    b.push_str(&chart(d.axis, &iso.targets));
    let rows: Vec<Vec<String>> = iso
        .targets
        .iter()
        .map(|t| {
            let a = |v: f64| num(v, ARCSEC_DECIMALS, "″");
            vec![
                t.target.to_string(),
                num(t.position_deg, 4, "°"),
                a(t.mean_up_arcsec),
                a(t.s_up_arcsec),
                a(t.mean_down_arcsec),
                a(t.s_down_arcsec),
                a(t.mean_bidir_arcsec),
                a(t.reversal_arcsec),
                a(t.repeat_bidir_arcsec),
            ]
        })
        .collect();
    b.push_str(&table(
        &["target", "θ", "x̄↑", "s↑", "x̄↓", "s↓", "x̄", "B_i", "R_i"],
        &rows,
    ));
    b.push_str(&downloads(id, info));
    b
}

/// The closure check of 0° and 360°, and its warning.
fn closure_section(c: Option<&Closure>, warnings: &[String]) -> String {
    let Some(c) = c else {
        return "<h2>Closure (0° = 360°)</h2><p>No closure pair: the test has not both 0° and \
                360°.</p>"
            .into();
    };
    let a = |v: f64| num(v, ARCSEC_DECIMALS, "″");
    let mut s = String::from("<h2>Closure (0° = 360°)</h2>");
    s.push_str(&table(
        &["direction", "x̄(360°) − x̄(0°)", "limit 2·max(s)"],
        &[
            vec!["↑".into(), a(c.diff_up_arcsec), a(c.limit_up_arcsec)],
            vec!["↓".into(), a(c.diff_down_arcsec), a(c.limit_down_arcsec)],
        ],
    ));
    let _ = write!(
        s,
        "<p id=\"closure\">Closure consistent: <b>{}</b>.</p>",
        if c.consistent { "yes" } else { "no" }
    );
    for w in warnings {
        s.push_str(&super::html::error_box(&format!("Warning: {w}")));
    }
    s
}

/// The ISO 230-2 deviation chart of a rotary axis in the linear chart's style: ″ against
/// the target angle over the revolution, x̄↑ (blue) and x̄↓ (red) with x̄ ± 2s dashed.
fn chart(axis: RotaryAxis, targets: &[RotaryTargetStats]) -> String {
    let targets: Vec<DeviationTarget> = targets
        .iter()
        .map(|t| DeviationTarget {
            target: t.target,
            x: t.position_deg,
            up: (t.mean_up_arcsec, t.s_up_arcsec),
            down: (t.mean_down_arcsec, t.s_down_arcsec),
        })
        .collect();
    let ticks = (0..=8)
        .map(|k| (f64::from(k) * 45.0, format!("{}°", k * 45)))
        .collect();
    charts::xy_on(
        &format!("Axis {axis}: angular positional deviation (ISO 230-2)"),
        &XAxis {
            label: "target angle θ_i / °".into(),
            range: (-10.0, 370.0),
            ticks,
        },
        "positional deviation x = −e / ″",
        &charts::deviation_series(targets, &|t, name, dir, v| {
            format!(
                "target {} (θ = {:.4}°), {dir}, all runs: {name} = {v:.d$}″",
                t.target,
                t.x,
                d = ARCSEC_DECIMALS
            )
        }),
    )
}

/// The rotary downloads: the rotary error table, the rotary certificate and each
/// controller's modulo table.
fn downloads(id: &str, info: Option<&str>) -> String {
    let u = url_path(id);
    let mut s = format!(
        "<h2>Downloads</h2><p class=\"downloads\"><a href=\"/download/table/{u}\">rotary error \
         table (CSV)</a><a href=\"/download/certificate/{u}{info}\">certificate (PDF)</a></p>\
         <p class=\"downloads\">Modulo compensation table: ",
        info = info
            .map(|i| format!("?info={}", url_path(i)))
            .unwrap_or_default()
    );
    for d in modulo_dialects().map(|d| d.name()) {
        let _ = write!(s, "<a href=\"/download/export/{u}?format={d}\">{d}</a>");
    }
    s.push_str("</p>");
    s
}
