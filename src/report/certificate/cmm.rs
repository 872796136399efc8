//! The CMM verification certificate (`acceptance cmm-certificate`): the ISO 10360-2 length
//! test and the ISO 10360-5 probing test under one decision rule, with the statement of
//! conformity of ISO/IEC 17025:2017 7.8.6.2. Page 1 is the summary (the CMM, the
//! specification, every judged quantity with its verdict, the overall verdict); then each
//! test's results, the statement, the signatures.
//!
//! The pages are laid out by the certificates' shared [`super::layout::Sheet`]; symbols
//! are set with their subscripts (`P_{FTU}` is drawn as P with FTU lowered and smaller).
//! One number format per quantity: errors, MPEs, U and zones in µm to the place of the
//! second significant digit of the smallest U stated (1 to 3 decimals), lengths and
//! coordinates in mm to 0.000001 (the probing report's [`mm6`]).

use std::path::Path;

use super::CertificateError;
use super::layout::{Align, BODY, Sheet, fixed, second_digit_place};
use super::pdf::Weight;
use crate::acceptance::CmmCertificate;
use crate::acceptance::TestResult;
use crate::acceptance::probing::{Judged, ProbingResult};
use crate::report::probing::{RESULT_HEADER, mm6, result_rows_in, symbols};

/// The input files, as given (printed where each part's results are).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sources {
    pub length: String,
    pub probing: String,
    pub sphere: String,
}

/// How µm are printed throughout one certificate (one format per quantity): to the place
/// of the second significant digit of the smallest expanded uncertainty stated (the GUM,
/// JCGM 100:2008 7.2.6), between 1 and 3 decimals; 3 decimals when no test states a U.
#[derive(Debug, Clone, Copy)]
struct Um(usize);

impl Um {
    fn of(c: &CmmCertificate) -> Um {
        let t5 = &c.iso10360_5;
        let us = c
            .iso10360_2
            .measurements
            .iter()
            .map(|m| m.u_um)
            .chain([t5.form.u_um, t5.size.u_um])
            .chain(t5.location.as_ref().map(|l| l.u_um));
        let smallest = us
            .filter(|u| u.is_finite() && *u > 0.0)
            .fold(f64::INFINITY, f64::min);
        Um(second_digit_place(smallest).map_or(3, |d| d.clamp(1, 3) as usize))
    }

    fn f(self, v: f64) -> String {
        fixed(v, self.0)
    }
}

/// The row of the largest |E0| (its MPE and U), if any.
fn worst_e0(t: &TestResult) -> Option<&crate::acceptance::Measurement> {
    t.measurements
        .iter()
        .max_by(|a, b| a.e0_um.abs().total_cmp(&b.e0_um.abs()))
}

fn judged_row(test: &str, sym: &str, name: &str, q: &Judged, um: Um) -> Vec<String> {
    vec![
        test.to_string(),
        format!("{sym} {name}"),
        um.f(q.value_um),
        um.f(q.mpe_um),
        um.f(q.u_um),
        q.verdict.to_string(),
    ]
}

/// Page 1: who, what, and every judged quantity with its verdict.
fn summary(sheet: &mut Sheet, c: &CmmCertificate, um: Um) {
    sheet.heading("Summary", 11.0);
    let l = Align::Left;
    let r = Align::Right;
    sheet.fields(&[
        ("CMM".to_string(), c.cmm.clone().unwrap_or_default()),
        ("Specification".to_string(), c.specification.clone()),
        ("Decision rule".to_string(), rule_name(c)),
    ]);
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
            um.f(m.e0_um),
            um.f(m.mpe_um),
            um.f(m.u_um),
            t2.verdict_e0.to_string(),
        ]);
    }
    if let Some(mpl) = t2.mpl_r0_um {
        rows.push(vec![
            "ISO 10360-2".to_string(),
            "R_{0} largest".to_string(),
            um.f(t2.summary.max_r0_um),
            um.f(mpl),
            "—".to_string(),
            t2.verdict_r0.map_or("—".into(), |v| v.to_string()),
        ]);
    }
    let sym = symbols(t5.styli.len() > 1);
    rows.push(judged_row("ISO 10360-5", sym[0].0, "form", &t5.form, um));
    rows.push(judged_row("ISO 10360-5", sym[1].0, "size", &t5.size, um));
    if let Some(loc) = &t5.location {
        rows.push(vec![
            "ISO 10360-5".to_string(),
            format!("{} location", sym[2].0),
            um.f(loc.value_um),
            loc.mpe_um.map_or("—".into(), |v| um.f(v)),
            um.f(loc.u_um),
            loc.verdict.map_or("not judged".into(), |v| v.to_string()),
        ]);
    }
    sheet.table_sized(
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
    sheet.paragraph(
        &format!(
            "ISO 10360-2:2009: {}. ISO 10360-5:2010: {}.",
            t2.verdict, t5.verdict
        ),
        BODY,
    );
    sheet.paragraph_weighted(
        &format!("Overall verdict: {}", c.verdict),
        12.0,
        Weight::Bold,
    );
    sheet.paragraph(
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
fn length_part(sheet: &mut Sheet, t: &TestResult, source: &str, um: Um) {
    sheet.new_page();
    sheet.heading("ISO 10360-2:2009 — length measurement error", 12.0);
    sheet.paragraph(
        &format!(
            "Test file: {source}. {} measurements in {} positions, {} test lengths.",
            t.summary.measurements, t.summary.positions, t.summary.gauges,
        ),
        BODY,
    );
    sheet.rich_line(
        &format!(
            "MPE_{{E0}}(L) = {} µm, L in mm{}.",
            t.mpe.formula,
            t.mpl_r0_um
                .map(|m| format!("; MPL_{{R0}} = {} µm", um.f(m)))
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
                um.f(p.max_abs_e0_um),
                worst.map_or("—".into(), |m| mm6(m.calibrated_mm)),
                worst.map_or("—".into(), |m| um.f(m.mpe_um)),
                worst.map_or("—".into(), |m| um.f(m.u_um)),
                p.verdict.to_string(),
            ]
        })
        .collect();
    sheet.table_sized(
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
    sheet.rich_line(
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
    deviations(sheet, &t.deviations);
}

fn deviations(sheet: &mut Sheet, d: &[String]) {
    if d.is_empty() {
        sheet.paragraph("Deviations from the standard's design: none.", BODY - 1.0);
    } else {
        sheet.paragraph("Deviations from the standard's design:", BODY - 1.0);
        for x in d {
            sheet.paragraph(&format!("• {x}"), BODY - 1.0);
        }
    }
}

/// The probing test: the sphere, the three quantities, the styli.
fn probing_part(sheet: &mut Sheet, t: &ProbingResult, src: &Sources, um: Um) {
    sheet.new_page();
    sheet.heading(
        &format!("ISO 10360-5:2010 — probing error ({} test)", t.test),
        12.0,
    );
    sheet.paragraph(
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
    sheet.heading("Test sphere", 10.0);
    sheet.table_sized(
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
            um.f(s.u_diameter_um),
            um.f(s.form_um),
            um.f(s.u_form_um),
        ]],
        &[l, r, r, r, r],
        BODY,
    );
    sheet.heading("Results", 10.0);
    sheet.table_sized(
        &RESULT_HEADER,
        &result_rows_in(t, &|v| um.f(v)),
        &[l, l, r, r, r, l, l],
        BODY,
    );
    sheet.paragraph(
        &format!(
            "Least-squares sphere of all points: centre ({}, {}, {}) mm, Ø {} mm, rms {} µm.",
            mm6(t.fit.centre_mm[0]),
            mm6(t.fit.centre_mm[1]),
            mm6(t.fit.centre_mm[2]),
            mm6(t.fit.diameter_mm),
            um.f(t.fit.rms_um)
        ),
        BODY - 1.0,
    );
    sheet.rich_line(
        "U of form = √(F_{s}² + U(F_{s})² + U_{t,form}²), of size = √(U(D)² + U_{t,size}²), of location = U_{t,location} (k = 2).",
        BODY - 1.0,
    );
    sheet.heading("Styli (own fits; reported, not judged)", 10.0);
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
                um.f(s.form_um),
                um.f(s.size_um),
            ]
        })
        .collect();
    sheet.table_sized(
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
    sheet.paragraph(&format!("Part verdict: {}.", t.verdict), BODY);
    deviations(sheet, &t.deviations);
}

/// The statement of conformity (ISO/IEC 17025:2017 7.8.6.2).
fn statement(sheet: &mut Sheet, c: &CmmCertificate, src: &Sources) {
    sheet.new_page();
    sheet.heading("Statement of conformity", 12.0);
    sheet.paragraph(
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
    sheet.paragraph(&format!("Specification: {}", c.specification), BODY);
    sheet.paragraph(&c.statement, BODY);
    let l = Align::Left;
    sheet.table_sized(
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
    sheet.paragraph_weighted(
        &format!("Overall verdict: {}", c.verdict),
        11.0,
        Weight::Bold,
    );
}

/// The certificate as PDF bytes.
pub fn render(c: &CmmCertificate, src: &Sources) -> Result<Vec<u8>, CertificateError> {
    let um = Um::of(c);
    let mut sheet = Sheet::new(
        "CMM verification certificate",
        "ISO 10360-2:2009 length measurement error · ISO 10360-5:2010 probing error · ISO/IEC 17025:2017 7.8.6",
    )?;
    summary(&mut sheet, c, um);
    length_part(&mut sheet, &c.iso10360_2, &src.length, um);
    probing_part(&mut sheet, &c.iso10360_5, src, um);
    statement(&mut sheet, c, src);
    sheet.signatures();
    Ok(sheet.finish("CMM verification certificate")?)
}

/// Writes the certificate to `path` (whole or not at all).
pub fn write(path: &Path, c: &CmmCertificate, src: &Sources) -> Result<(), CertificateError> {
    let bytes = render(c, src)?;
    Ok(crate::report::write_bytes(path, &bytes)?)
}
