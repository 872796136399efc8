//! The certificate's **Statement of conformity** (ISO/IEC 17025:2017 7.8.6): the results
//! it applies to, the specification, the decision rule in words, per line a table —
//! parameter, limits, value, U, acceptance zone, verdict — and the overall verdict.

use super::layout::{Align, BODY, Decimals, Sheet, fixed, zone_words};
use super::{CertificateData, line_name, session_name};
use crate::acceptance::Conformity;

/// Draws the section.
pub(super) fn section(flow: &mut Sheet, data: &CertificateData, c: &Conformity, dec: Decimals) {
    let num = |v: f64| fixed(v, dec.um);
    flow.heading("Statement of conformity", 12.0);
    let lines = data.line_names();
    flow.paragraph(
        &format!(
            "Applies to: the ISO 230-2 results of axis {} on line(s) {lines} given in the axis \
             tables of this certificate (session {}), each with the expanded uncertainty U \
             (k = {}) printed beside it.",
            data.axis,
            session_name(data.source),
            c.k
        ),
        BODY,
    );
    flow.paragraph(&format!("Specification: {}", c.specification), BODY);
    flow.paragraph(&c.statement, BODY);
    let l = Align::Left;
    let r = Align::Right;
    for (k, (line_mm, lc)) in c.lines.iter().enumerate() {
        flow.heading(
            &format!("Line {}: {}", k + 1, line_name(data.axis, *line_mm)),
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
                    zone_words([p.lower_um, p.upper_um], &num),
                    num(p.value_um),
                    num(p.u_um),
                    zone_words(p.acceptance_um, &num),
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
        );
        flow.paragraph(&format!("Line verdict: {}", lc.verdict), BODY);
    }
    flow.paragraph(&format!("Overall verdict: {}", c.verdict), BODY + 2.0);
}
