//! The calibration certificate of a rotary axis (`errmap certificate` on a rotary
//! session, `docs/rotary.md`): the linear certificate's content in angular units. Page 1:
//! who, what, the ISO 230-2 figures in arcseconds with their value in degrees beside, the
//! closure check of 0° and 360°, the traceability; then the per-target results (0 and 360
//! both), the instruments, the uncertainty budget in ″ and the signatures.
//!
//! Numbers: errors in ″ to the place of the second significant digit of U (the GUM,
//! JCGM 100:2008 7.2.6), at least 2 decimals (the contract's minimum), at most 3; angles in
//! ° to 0.001; a figure's value in ° to 7 decimals (0.00036″).

use std::path::Path;

use super::CertificateError;
use super::info::CertificateInfo;
use super::layout::{Align, BODY, Sheet, fixed, second_digit_place};
use super::pdf::Weight;
use crate::base::RotaryAxis;
use crate::session::rotary::{Closure, RotaryBudget, RotaryIso, closure_warning};

/// What the rotary certificate is made of.
#[derive(Debug, Clone, Copy)]
pub struct RotaryCertificate<'a> {
    pub source: &'a str,
    pub axis: RotaryAxis,
    pub iso: &'a RotaryIso,
    pub closure: Option<&'a Closure>,
    pub budget: &'a RotaryBudget,
    pub info: &'a CertificateInfo,
    /// Dwell rows evaluated, and the air temperature range recorded (°C), if any.
    pub dwell_rows: usize,
    pub air_temp_c: Option<(f64, f64)>,
}

/// ″ with the certificate's decimals.
#[derive(Debug, Clone, Copy)]
struct Arcsec(usize);

impl Arcsec {
    fn of(u_arcsec: f64) -> Arcsec {
        Arcsec(second_digit_place(u_arcsec).map_or(2, |d| d.clamp(2, 3) as usize))
    }
    fn f(self, v: f64) -> String {
        fixed(v, self.0)
    }
}

fn blank(v: &Option<String>) -> String {
    v.clone().unwrap_or_default()
}

/// Which U a figure carries (`RotaryBudget`'s docs).
#[derive(Clone, Copy)]
enum Compares {
    OneMean,
    TwoTargets,
    Reversal,
    Repeatability,
}

fn figure_rows(iso: &RotaryIso, b: &RotaryBudget, a: Arcsec) -> Vec<Vec<String>> {
    use Compares::{OneMean, Repeatability, Reversal, TwoTargets};
    let figures: [(&str, &str, f64, Compares); 12] = [
        ("A", "bidirectional accuracy", iso.a_arcsec, TwoTargets),
        (
            "A↑",
            "unidirectional accuracy, +",
            iso.a_up_arcsec,
            TwoTargets,
        ),
        (
            "A↓",
            "unidirectional accuracy, −",
            iso.a_down_arcsec,
            TwoTargets,
        ),
        (
            "E",
            "bidirectional systematic deviation",
            iso.e_arcsec,
            TwoTargets,
        ),
        (
            "E↑",
            "unidirectional systematic deviation, +",
            iso.e_up_arcsec,
            TwoTargets,
        ),
        (
            "E↓",
            "unidirectional systematic deviation, −",
            iso.e_down_arcsec,
            TwoTargets,
        ),
        (
            "M",
            "mean bidirectional positional deviation",
            iso.m_arcsec,
            OneMean,
        ),
        (
            "R",
            "bidirectional repeatability",
            iso.r_arcsec,
            Repeatability,
        ),
        (
            "R↑",
            "unidirectional repeatability, +",
            iso.r_up_arcsec,
            Repeatability,
        ),
        (
            "R↓",
            "unidirectional repeatability, −",
            iso.r_down_arcsec,
            Repeatability,
        ),
        ("B", "reversal value", iso.b_arcsec, Reversal),
        (
            "B̄",
            "mean reversal value",
            iso.mean_reversal_arcsec,
            Reversal,
        ),
    ];
    figures
        .iter()
        .map(|(sym, name, v, compares)| {
            let u = match compares {
                OneMean => Some(b.expanded_arcsec),
                TwoTargets => Some(b.between_targets_arcsec),
                Reversal => Some(b.reversal_arcsec),
                Repeatability => b.repeatability_arcsec,
            };
            vec![
                sym.to_string(),
                name.to_string(),
                a.f(*v),
                fixed(v / 3600.0, 7),
                u.map_or_else(|| "—".into(), |u| a.f(u)),
            ]
        })
        .collect()
}

fn closure_rows(c: &Closure, a: Arcsec) -> Vec<Vec<String>> {
    let ok = |d: f64, l: f64| if d.abs() <= l { "within" } else { "beyond" };
    vec![
        vec![
            "+ (angle increasing)".into(),
            a.f(c.diff_up_arcsec),
            a.f(c.limit_up_arcsec),
            ok(c.diff_up_arcsec, c.limit_up_arcsec).into(),
        ],
        vec![
            "− (angle decreasing)".into(),
            a.f(c.diff_down_arcsec),
            a.f(c.limit_down_arcsec),
            ok(c.diff_down_arcsec, c.limit_down_arcsec).into(),
        ],
    ]
}

fn summary(sheet: &mut Sheet, c: &RotaryCertificate, a: Arcsec) {
    let i = c.info;
    sheet.fields(&[
        ("Certificate number".into(), blank(&i.certificate_number)),
        ("Laboratory".into(), blank(&i.lab)),
        ("Customer".into(), blank(&i.customer)),
        ("Machine".into(), blank(&i.machine)),
        ("Axis".into(), format!("{} (rotary)", c.axis)),
        ("Date of test".into(), blank(&i.date_of_test)),
        ("Date of issue".into(), blank(&i.date_of_issue)),
        ("Operator".into(), blank(&i.operator)),
        ("Session".into(), c.source.to_string()),
    ]);
    sheet.heading("Results (ISO 230-2:2014, rotary axis)", 12.0);
    let (l, r) = (Align::Left, Align::Right);
    sheet.table_sized(
        &["", "figure", "value / ″", "value / °", "U (k = 2) / ″"],
        &figure_rows(c.iso, c.budget, a),
        &[l, l, r, r, r],
        BODY,
    );
    sheet.paragraph(
        &format!(
            "Deviation x = −(indicated − reference) at each target, {} targets from {} ° to {} ° \
             ({} dwell rows); 0 ° and 360 ° are evaluated as two targets. U of M is a mean \
             deviation's; A and E compare two targets (√2 times it); B and B̄ compare two \
             means at one angle, where the reference's own error cancels; R carries the \
             counts' U only{}.",
            c.iso.targets.len(),
            c.iso.targets.first().map_or(0.0, |t| t.position_deg),
            c.iso.targets.last().map_or(0.0, |t| t.position_deg),
            c.dwell_rows,
            if c.budget.repeatability_arcsec.is_none() {
                " (none is stated: no count of the reference or the encoder is known)"
            } else {
                ""
            }
        ),
        BODY - 1.0,
    );
    sheet.heading("Closure of the revolution (0 ° and 360 °)", 11.0);
    match c.closure {
        Some(cl) => {
            sheet.table_sized(
                &[
                    "direction",
                    "x̄(360) − x̄(0) / ″",
                    "limit 2·max s / ″",
                    "result",
                ],
                &closure_rows(cl, a),
                &[l, r, r, l],
                BODY,
            );
            let words = closure_warning(cl).unwrap_or_else(|| {
                "consistent: the same physical position agrees within its repeatability".into()
            });
            let weight = if cl.consistent {
                Weight::Regular
            } else {
                Weight::Bold
            };
            sheet.paragraph_weighted(&words, BODY, weight);
        }
        None => sheet.paragraph(
            "No closure pair: the test does not hold both 0 ° and 360 °.",
            BODY,
        ),
    }
    sheet.heading("Traceability", 10.0);
    sheet.paragraph(
        &i.traceability.clone().unwrap_or_else(|| {
            "The angle reference is traceable through its calibration certificate (below); \
             the laboratory states its own traceability in the info file."
                .into()
        }),
        BODY - 1.0,
    );
}

fn targets(sheet: &mut Sheet, c: &RotaryCertificate, a: Arcsec) {
    sheet.new_page();
    sheet.heading("Results per target (″)", 12.0);
    let rows: Vec<Vec<String>> = c
        .iso
        .targets
        .iter()
        .map(|t| {
            vec![
                fixed(t.position_deg, 3),
                format!("{}/{}", t.n_up, t.n_down),
                a.f(t.mean_up_arcsec),
                a.f(t.mean_down_arcsec),
                a.f(t.mean_bidir_arcsec),
                a.f(t.reversal_arcsec),
                a.f(t.repeat_up_arcsec),
                a.f(t.repeat_down_arcsec),
                a.f(t.repeat_bidir_arcsec),
            ]
        })
        .collect();
    let r = Align::Right;
    sheet.table(
        &[
            "target / °",
            "n ↑/↓",
            "x̄↑",
            "x̄↓",
            "x̄",
            "B_{i}",
            "R↑",
            "R↓",
            "R",
        ],
        &rows,
        &[r; 9],
    );
}

fn instruments(sheet: &mut Sheet, c: &RotaryCertificate) {
    sheet.heading("Instruments and conditions", 11.0);
    let r = &c.info.reference;
    sheet.fields(&[
        (
            "Angle reference".into(),
            [&r.model, &r.serial]
                .iter()
                .filter_map(|v| (*v).clone())
                .collect::<Vec<_>>()
                .join(", "),
        ),
        ("Reference calibrated".into(), blank(&r.calibrated)),
        (
            "Compensation during the test".into(),
            blank(&c.info.controller.compensation),
        ),
        (
            "Air temperature recorded".into(),
            c.air_temp_c.map_or("not recorded".into(), |(lo, hi)| {
                format!("{lo:.2} … {hi:.2} °C")
            }),
        ),
    ]);
}

fn budget(sheet: &mut Sheet, c: &RotaryCertificate, a: Arcsec) {
    sheet.heading("Measurement uncertainty (GUM, ″)", 12.0);
    let mut rows: Vec<Vec<String>> = c
        .budget
        .terms
        .iter()
        .map(|t| {
            vec![
                t.name.to_string(),
                t.source.clone(),
                t.distribution.to_string(),
                fixed(t.u_arcsec, 3),
            ]
        })
        .collect();
    rows.push(vec![
        "combined u_{c}".into(),
        String::new(),
        String::new(),
        fixed(c.budget.combined_arcsec, 3),
    ]);
    rows.push(vec![
        "expanded U (k = 2)".into(),
        "of a mean deviation x̄ and of M".into(),
        String::new(),
        a.f(c.budget.expanded_arcsec),
    ]);
    rows.push(vec![
        "expanded U (k = 2)".into(),
        "of A, E (two targets: √2·U(x̄))".into(),
        String::new(),
        a.f(c.budget.between_targets_arcsec),
    ]);
    rows.push(vec![
        "expanded U (k = 2)".into(),
        "of B, B̄ (counts and repeatability, ×√2)".into(),
        String::new(),
        a.f(c.budget.reversal_arcsec),
    ]);
    rows.push(vec![
        "expanded U (k = 2)".into(),
        "of R (the counts, ×√2)".into(),
        String::new(),
        c.budget
            .repeatability_arcsec
            .map_or_else(|| "not stated".into(), |u| a.f(u)),
    ]);
    let (l, r) = (Align::Left, Align::Right);
    sheet.table(
        &["term", "from", "distribution", "u / ″"],
        &rows,
        &[l, l, l, r],
    );
    sheet.paragraph(
        "No thermal expansion term: an angle does not change with a uniform temperature \
         change. A drift during the test shows in the closure check. The reference's mounting \
         (centring) enters only when stated ([reference] centring_arcsec).",
        BODY - 1.0,
    );
    if c.budget.reference_assumed {
        sheet.paragraph_weighted(
            "The reference's accuracy was not stated: ±1″ (an XR20-style indexer's class) \
             is assumed. State it as [reference] accuracy_arcsec in the info file.",
            BODY,
            Weight::Bold,
        );
    }
}

/// The certificate as PDF bytes.
pub fn render(c: &RotaryCertificate) -> Result<Vec<u8>, CertificateError> {
    let a = Arcsec::of(c.budget.expanded_arcsec);
    let mut sheet = Sheet::new(
        &format!("Calibration certificate: rotary axis {}", c.axis),
        "ISO 230-2:2014, rotary axis · errors in arcseconds (″), angles in degrees (°)",
    )?;
    summary(&mut sheet, c, a);
    targets(&mut sheet, c, a);
    instruments(&mut sheet, c);
    budget(&mut sheet, c, a);
    sheet.signatures();
    Ok(sheet.finish("Rotary axis calibration certificate")?)
}

/// Writes the certificate to `path` (whole or not at all).
pub fn write(path: &Path, c: &RotaryCertificate) -> Result<(), CertificateError> {
    let bytes = render(c)?;
    Ok(crate::report::write_bytes(path, &bytes)?)
}
