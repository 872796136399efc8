//! The CMM verification certificate (`acceptance cmm-certificate`): the ISO 10360-2 length
//! test and the ISO 10360-5 probing test under one decision rule, with the statement of
//! conformity of ISO/IEC 17025:2017 7.8.6.2. Page 1 is the summary (the CMM, the
//! specification, every judged quantity with its verdict, the overall verdict); then each
//! test's results, the statement, the signatures.
//!
//! Symbols are set with their subscripts (`P_{FTU}` is drawn as P with FTU lowered and
//! smaller). One number format per quantity: errors, MPEs, U and zones in µm to 0.001,
//! lengths and coordinates in mm to 0.000001 (the probing report's [`um`] and [`mm6`]).

use std::path::Path;

use super::CertificateError;
use super::flow::{Flow, signatures};
use super::layout::{Align, BODY, GREY, MARGIN, MIN_SIZE};
use super::pdf::{Doc, PAGE_H, PAGE_W, Weight};
use crate::acceptance::CmmCertificate;
use crate::acceptance::TestResult;
use crate::acceptance::probing::{Judged, ProbingResult};
use crate::report::probing::{RESULT_HEADER, mm6, result_rows, symbols, um};

/// The input files, as given (printed where each part's results are).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sources {
    pub length: String,
    pub probing: String,
    pub sphere: String,
}

/// Subscripts are set this much smaller, and lowered by this fraction of the size.
const SUB_SCALE: f32 = 0.7;
const SUB_DROP: f32 = 0.25;

/// `s` split into (text, subscript?) runs at `_{…}`.
fn runs(s: &str) -> Vec<(&str, bool)> {
    let mut out = Vec::new();
    let mut rest = s;
    while let Some(i) = rest.find("_{") {
        if i > 0 {
            out.push((&rest[..i], false));
        }
        let after = &rest[i + 2..];
        let end = after.find('}').unwrap_or(after.len());
        out.push((&after[..end], true));
        rest = after.get(end + 1..).unwrap_or("");
    }
    if !rest.is_empty() {
        out.push((rest, false));
    }
    out
}

fn rich_width(doc: &Doc, s: &str, size: f32, weight: Weight) -> f32 {
    runs(s)
        .iter()
        .map(|&(t, sub)| doc.width(t, if sub { size * SUB_SCALE } else { size }, weight))
        .sum()
}

/// Text with `_{…}` subscripts, its baseline's left end at (x, y).
fn rich(doc: &mut Doc, x: f32, y: f32, size: f32, weight: Weight, s: &str) {
    let mut x = x;
    for (t, sub) in runs(s) {
        let (sz, dy) = if sub {
            (size * SUB_SCALE, -size * SUB_DROP)
        } else {
            (size, 0.0)
        };
        doc.text(x, y + dy, sz, weight, t);
        x += doc.width(t, sz, weight);
    }
}

/// A table whose cells may hold subscripts; otherwise as the certificate's tables (bold
/// header, columns as wide as their widest cell, set smaller until it fits the page).
fn table(flow: &mut Flow, header: &[&str], rows: &[Vec<String>], align: &[Align], size: f32) {
    let pad = 4.0;
    let avail = PAGE_W - 2.0 * MARGIN;
    let mut size = size;
    let widths = loop {
        let w: Vec<f32> = (0..header.len())
            .map(|k| {
                let head = rich_width(&flow.doc, header[k], size, Weight::Bold);
                rows.iter()
                    .map(|r| rich_width(&flow.doc, &r[k], size, Weight::Regular))
                    .fold(head, f32::max)
                    + 2.0 * pad
            })
            .collect();
        if w.iter().sum::<f32>() <= avail || size <= MIN_SIZE {
            break w;
        }
        size = (size - 0.5).max(MIN_SIZE);
    };
    let row_h = size * 1.8;
    let total: f32 = widths.iter().sum();
    flow.need(row_h * (rows.len() as f32 + 1.0).min(6.0));
    let draw = |flow: &mut Flow, cells: Vec<&str>, weight: Weight| {
        flow.need(row_h);
        flow.y -= row_h;
        let mut x = MARGIN;
        for (k, c) in cells.iter().enumerate() {
            let base = flow.y + size * 0.55;
            let cx = match align.get(k).copied().unwrap_or(Align::Left) {
                Align::Left => x + pad,
                Align::Right => x + widths[k] - pad - rich_width(&flow.doc, c, size, weight),
            };
            rich(&mut flow.doc, cx, base, size, weight, c);
            x += widths[k];
        }
        flow.doc.polyline(
            &[(MARGIN, flow.y), (MARGIN + total, flow.y)],
            0.3,
            GREY,
            None,
        );
    };
    draw(flow, header.to_vec(), Weight::Bold);
    for r in rows {
        draw(
            flow,
            r.iter().map(String::as_str).collect(),
            Weight::Regular,
        );
    }
    flow.y -= size;
}

/// One line with `_{…}` subscripts (it must fit the width: no wrapping).
fn rich_line(flow: &mut Flow, s: &str, size: f32) {
    flow.need(size * 1.6);
    flow.y -= size * 1.6;
    rich(&mut flow.doc, MARGIN, flow.y, size, Weight::Regular, s);
    flow.y -= size * 0.5;
}

fn new_page(flow: &mut Flow) {
    flow.doc.new_page();
    flow.y = PAGE_H - MARGIN;
}

/// The row of the largest |E0| (its MPE and U), if any.
fn worst_e0(t: &TestResult) -> Option<&crate::acceptance::Measurement> {
    t.measurements
        .iter()
        .max_by(|a, b| a.e0_um.abs().total_cmp(&b.e0_um.abs()))
}

fn judged_row(test: &str, sym: &str, name: &str, q: &Judged) -> Vec<String> {
    vec![
        test.to_string(),
        format!("{sym} {name}"),
        um(q.value_um),
        um(q.mpe_um),
        um(q.u_um),
        q.verdict.to_string(),
    ]
}

/// Page 1: who, what, and every judged quantity with its verdict.
fn summary(flow: &mut Flow, c: &CmmCertificate) {
    flow.y -= 16.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        16.0,
        Weight::Bold,
        "CMM verification certificate",
    );
    flow.y -= 14.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        BODY,
        Weight::Regular,
        "ISO 10360-2:2009 length measurement error · ISO 10360-5:2010 probing error · ISO/IEC 17025:2017 7.8.6",
    );
    flow.heading("Summary", 11.0);
    let l = Align::Left;
    let r = Align::Right;
    let fields = vec![
        vec!["CMM".to_string(), c.cmm.clone().unwrap_or_default()],
        vec!["Specification".to_string(), c.specification.clone()],
        vec!["Decision rule".to_string(), rule_name(c)],
    ];
    table(flow, &["field", "value"], &fields, &[l, l], BODY);
    let t2 = &c.iso10360_2;
    let t5 = &c.iso10360_5;
    let mut rows = Vec::new();
    if let Some(m) = worst_e0(t2) {
        rows.push(vec![
            "ISO 10360-2".to_string(),
            format!(
                "E_{{0}} largest |E_{{0}}| (L = {} mm)",
                mm6(m.calibrated_mm)
            ),
            um(m.e0_um),
            um(m.mpe_um),
            um(m.u_um),
            t2.verdict_e0.to_string(),
        ]);
    }
    if let Some(mpl) = t2.mpl_r0_um {
        rows.push(vec![
            "ISO 10360-2".to_string(),
            "R_{0} largest".to_string(),
            um(t2.summary.max_r0_um),
            um(mpl),
            "—".to_string(),
            t2.verdict_r0.map_or("—".into(), |v| v.to_string()),
        ]);
    }
    let sym = symbols(t5.styli.len() > 1);
    rows.push(judged_row("ISO 10360-5", sym[0].0, "form", &t5.form));
    rows.push(judged_row("ISO 10360-5", sym[1].0, "size", &t5.size));
    if let Some(loc) = &t5.location {
        rows.push(vec![
            "ISO 10360-5".to_string(),
            format!("{} location", sym[2].0),
            um(loc.value_um),
            loc.mpe_um.map_or("—".into(), um),
            um(loc.u_um),
            loc.verdict.map_or("not judged".into(), |v| v.to_string()),
        ]);
    }
    table(
        flow,
        &[
            "test",
            "quantity",
            "result / µm",
            "MPE / µm",
            "U / µm",
            "verdict",
        ],
        &rows,
        &[l, l, r, r, r, l],
        BODY,
    );
    flow.paragraph(
        &format!(
            "ISO 10360-2:2009: {}. ISO 10360-5:2010: {}.",
            t2.verdict, t5.verdict
        ),
        BODY,
    );
    flow.heading(&format!("Overall verdict: {}", c.verdict), 12.0);
    flow.paragraph(
        "The results of each test follow; the statement of conformity (ISO/IEC 17025:2017 \
         7.8.6.2) closes the certificate. U is the expanded uncertainty (k = 2).",
        BODY - 1.0,
    );
}

fn rule_name(c: &CmmCertificate) -> String {
    match c.guard_fraction {
        Some(r) => format!("{} (r = {r})", c.rule),
        None => c.rule.to_string(),
    }
}

/// The length test: per position the largest |E0| with its MPE and verdict.
fn length_part(flow: &mut Flow, t: &TestResult, source: &str) {
    new_page(flow);
    flow.heading("ISO 10360-2:2009 — length measurement error", 12.0);
    flow.paragraph(
        &format!(
            "Test file: {source}. {} measurements in {} positions, {} test lengths.",
            t.summary.measurements, t.summary.positions, t.summary.gauges,
        ),
        BODY,
    );
    rich_line(
        flow,
        &format!(
            "MPE_{{E0}}(L) = {} µm, L in mm{}.",
            t.mpe.formula,
            t.mpl_r0_um
                .map(|m| format!("; MPL_{{R0}} = {} µm", um(m)))
                .unwrap_or_default()
        ),
        BODY,
    );
    let l = Align::Left;
    let r = Align::Right;
    let rows: Vec<Vec<String>> = t
        .positions
        .iter()
        .map(|p| {
            let worst = t
                .measurements
                .iter()
                .filter(|m| m.position == p.position)
                .max_by(|a, b| a.e0_um.abs().total_cmp(&b.e0_um.abs()));
            vec![
                p.position.clone(),
                um(p.max_abs_e0_um),
                worst.map_or("—".into(), |m| mm6(m.calibrated_mm)),
                worst.map_or("—".into(), |m| um(m.mpe_um)),
                worst.map_or("—".into(), |m| um(m.u_um)),
                p.verdict.to_string(),
            ]
        })
        .collect();
    table(
        flow,
        &[
            "position",
            "largest |E_{0}| / µm",
            "at L / mm",
            "MPE_{E0}(L) / µm",
            "U / µm",
            "verdict",
        ],
        &rows,
        &[l, r, r, r, r, l],
        BODY,
    );
    rich_line(
        flow,
        &format!(
            "E_{{0}} verdict: {}{}; part verdict: {}.",
            t.verdict_e0,
            t.verdict_r0
                .map(|v| format!(", R_{{0}} verdict: {v}"))
                .unwrap_or_default(),
            t.verdict
        ),
        BODY,
    );
    deviations(flow, &t.deviations);
}

fn deviations(flow: &mut Flow, d: &[String]) {
    if d.is_empty() {
        flow.paragraph("Deviations from the standard's design: none.", BODY - 1.0);
    } else {
        flow.paragraph("Deviations from the standard's design:", BODY - 1.0);
        for x in d {
            flow.paragraph(&format!("• {x}"), BODY - 1.0);
        }
    }
}

/// The probing test: the sphere, the three quantities, the styli.
fn probing_part(flow: &mut Flow, t: &ProbingResult, src: &Sources) {
    new_page(flow);
    flow.heading(
        &format!("ISO 10360-5:2010 — probing error ({} test)", t.test),
        12.0,
    );
    flow.paragraph(
        &format!(
            "Points: {}; sphere certificate: {}. {} points, {} stylus/styli.",
            src.probing,
            src.sphere,
            t.points,
            t.styli.len()
        ),
        BODY,
    );
    let l = Align::Left;
    let r = Align::Right;
    let s = &t.sphere;
    flow.heading("Test sphere", 10.0);
    table(
        flow,
        &[
            "id",
            "D_{cal} / mm",
            "U(D) / µm",
            "F_{s} / µm",
            "U(F_{s}) / µm",
        ],
        &[vec![
            s.id.clone().unwrap_or_else(|| "—".into()),
            mm6(s.diameter_mm),
            um(s.u_diameter_um),
            um(s.form_um),
            um(s.u_form_um),
        ]],
        &[l, r, r, r, r],
        BODY,
    );
    flow.heading("Results", 10.0);
    table(
        flow,
        &RESULT_HEADER,
        &result_rows(t),
        &[l, l, r, r, r, l, l],
        BODY,
    );
    flow.paragraph(
        &format!(
            "Least-squares sphere of all points: centre ({}, {}, {}) mm, Ø {} mm, rms {} µm.",
            mm6(t.fit.centre_mm[0]),
            mm6(t.fit.centre_mm[1]),
            mm6(t.fit.centre_mm[2]),
            mm6(t.fit.diameter_mm),
            um(t.fit.rms_um)
        ),
        BODY - 1.0,
    );
    rich_line(
        flow,
        "U of form = √(F_{s}² + U(F_{s})² + U_{t,form}²), of size = √(U(D)² + U_{t,size}²), of location = U_{t,location} (k = 2).",
        BODY - 1.0,
    );
    flow.heading("Styli (own fits; reported, not judged)", 10.0);
    let rows: Vec<Vec<String>> = t
        .styli
        .iter()
        .map(|s| {
            vec![
                s.stylus.clone(),
                s.points.to_string(),
                mm6(s.centre_mm[0]),
                mm6(s.centre_mm[1]),
                mm6(s.centre_mm[2]),
                um(s.form_um),
                um(s.size_um),
            ]
        })
        .collect();
    table(
        flow,
        &[
            "stylus",
            "points",
            "x / mm",
            "y / mm",
            "z / mm",
            "form / µm",
            "size / µm",
        ],
        &rows,
        &[l, r, r, r, r, r, r],
        BODY - 1.0,
    );
    flow.paragraph(&format!("Part verdict: {}.", t.verdict), BODY);
    deviations(flow, &t.deviations);
}

/// The statement of conformity (ISO/IEC 17025:2017 7.8.6.2).
fn statement(flow: &mut Flow, c: &CmmCertificate, src: &Sources) {
    new_page(flow);
    flow.heading("Statement of conformity", 12.0);
    flow.paragraph(
        &format!(
            "Applies to: the results of ISO 10360-2:2009 (length measurement error, test file \
             {}) and of ISO 10360-5:2010 (probing error, points {}, sphere {}) given in this \
             certificate{}, each with its expanded uncertainty U (k = 2).",
            src.length,
            src.probing,
            src.sphere,
            c.cmm
                .as_ref()
                .map(|m| format!(" for the CMM {m}"))
                .unwrap_or_default()
        ),
        BODY,
    );
    flow.paragraph(&format!("Specification: {}", c.specification), BODY);
    flow.paragraph(&c.statement, BODY);
    let l = Align::Left;
    table(
        flow,
        &["part", "verdict"],
        &[
            vec![
                "ISO 10360-2:2009 length measurement error".to_string(),
                c.iso10360_2.verdict.to_string(),
            ],
            vec![
                "ISO 10360-5:2010 probing error".to_string(),
                c.iso10360_5.verdict.to_string(),
            ],
        ],
        &[l, l],
        BODY,
    );
    flow.heading(&format!("Overall verdict: {}", c.verdict), 11.0);
}

/// `CMM verification certificate · page i of n · errmap` at the foot of every page.
fn footers(flow: &mut Flow) {
    let pages = flow.doc.page_count();
    for p in 0..pages {
        let footer = format!(
            "CMM verification certificate · page {} of {pages} · errmap",
            p + 1
        );
        flow.doc.text_on(
            p,
            MARGIN,
            MARGIN / 2.0,
            BODY - 2.0,
            Weight::Regular,
            &footer,
        );
    }
}

/// The certificate as PDF bytes.
pub fn render(c: &CmmCertificate, src: &Sources) -> Result<Vec<u8>, CertificateError> {
    let mut flow = Flow {
        doc: Doc::new("CMM verification certificate (ISO 10360-2, ISO 10360-5)")?,
        y: PAGE_H - MARGIN,
    };
    summary(&mut flow, c);
    length_part(&mut flow, &c.iso10360_2, &src.length);
    probing_part(&mut flow, &c.iso10360_5, src);
    statement(&mut flow, c, src);
    signatures(&mut flow);
    footers(&mut flow);
    Ok(flow.doc.finish()?)
}

/// Writes the certificate to `path` (whole or not at all).
pub fn write(path: &Path, c: &CmmCertificate, src: &Sources) -> Result<(), CertificateError> {
    let bytes = render(c, src)?;
    Ok(crate::report::write_bytes(path, &bytes)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subscripts_split_into_runs() {
        assert_eq!(runs("P_{FTU}"), vec![("P", false), ("FTU", true)]);
        assert_eq!(
            runs("E_{0} largest |E_{0}|"),
            vec![
                ("E", false),
                ("0", true),
                (" largest |E", false),
                ("0", true),
                ("|", false)
            ]
        );
        assert_eq!(runs("plain"), vec![("plain", false)]);
        assert_eq!(runs("x_{open"), vec![("x", false), ("open", true)]);
    }
}
