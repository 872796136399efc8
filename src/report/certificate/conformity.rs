//! The certificate's **Statement of conformity** (ISO/IEC 17025:2017 7.8.6): the results
//! it applies to, the specification, the decision rule in words, per line a table —
//! parameter, limits, value, U, acceptance zone, verdict — and the overall verdict.

use super::{Align, BODY, CertificateData, Flow, MARGIN, PAGE_H, mm};
use crate::acceptance::tolerance::Conformity;

fn num(v: f64) -> String {
    format!("{v:.2}")
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_string(), num)
}

/// The zone [lo, hi] in words: `≤ 6.00`, `≥ −0.50`, `−0.50 … 0.50`.
fn zone(lo: Option<f64>, hi: Option<f64>) -> String {
    match (lo, hi) {
        (Some(l), Some(h)) if l > h => "empty (nothing can pass)".into(),
        (Some(l), Some(h)) => format!("{} … {}", num(l), num(h)),
        (None, Some(h)) => format!("≤ {}", num(h)),
        (Some(l), None) => format!("≥ {}", num(l)),
        (None, None) => "—".into(),
    }
}

/// Draws the section on a new page.
pub(super) fn section(flow: &mut Flow, data: &CertificateData, c: &Conformity) {
    flow.doc.new_page();
    flow.y = PAGE_H - MARGIN;
    flow.heading("Statement of conformity", 12.0);
    let lines = data
        .lines
        .iter()
        .map(|x| format!("({}, {}) mm", mm(x.line_mm.0), mm(x.line_mm.1)))
        .collect::<Vec<_>>()
        .join("; ");
    flow.paragraph(
        &format!(
            "Applies to: the ISO 230-2 results of axis {} on line(s) {lines} given in the axis \
             tables of this certificate (session {}), each with the expanded uncertainty U \
             (k = {}) printed beside it.",
            data.axis, data.source, c.k
        ),
        BODY,
    );
    flow.paragraph(&format!("Specification: {}", c.specification), BODY);
    flow.paragraph(&c.statement, BODY);
    let l = Align::Left;
    let r = Align::Right;
    for (k, (line_mm, lc)) in c.lines.iter().enumerate() {
        flow.heading(
            &format!(
                "Line {} at ({}, {}) mm",
                k + 1,
                mm(line_mm.0),
                mm(line_mm.1)
            ),
            10.0,
        );
        let Some(lc) = lc else {
            flow.paragraph("No tolerance applies to this line: not judged.", BODY);
            continue;
        };
        let rows: Vec<Vec<String>> = lc
            .parameters
            .iter()
            .map(|p| {
                vec![
                    p.parameter.to_string(),
                    zone(p.lower_um, p.upper_um),
                    num(p.value_um),
                    num(p.u_um),
                    zone(p.acceptance_um[0], p.acceptance_um[1]),
                    p.verdict.as_str().to_string(),
                ]
            })
            .collect();
        flow.table(
            &[
                "parameter",
                "limits / µm",
                "value / µm",
                "U / µm",
                "acceptance zone / µm",
                "verdict",
            ],
            &rows,
            &[l, l, r, r, l, l],
            BODY - 1.0,
        );
        flow.paragraph(&format!("Line verdict: {}", lc.verdict), BODY);
    }
    flow.heading(&format!("Overall verdict: {}", c.verdict), 11.0);
    let _ = opt;
}
