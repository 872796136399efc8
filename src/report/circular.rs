//! The circular test's report (`circular diagnose --report DIR`): `circular.json` (the
//! diagnosis document), `polar.png`/`.svg` (the trace about the nominal circle, both
//! directions, the least-squares circle, the reversals) and `report.md` (the ISO 230-4
//! numbers, the effects found with their σ, what the test cannot separate, the residual
//! before and after, and the comparison with a volumetric model when given).

use super::md::Md;
use std::path::Path;

use super::ReportError;
use crate::base::FileOp;
use crate::base::io_err;
use crate::circular::nominal_samples;
use crate::circular::{CircularDiagnosis, CircularTest, Sense};
use crate::plot::{PolarChart, PolarTrace, polar};

/// The palette colour of each direction in the polar plot.
pub const CCW_COLOUR: usize = 0;
pub const CW_COLOUR: usize = 3;

/// A round µm-per-division that fits `max_um` in four divisions.
pub(crate) fn um_per_div(max_um: f64) -> f64 {
    let want = (max_um / 3.5).max(1e-3);
    let decade = 10f64.powf(want.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|&v| v >= want)
        .unwrap_or(10.0 * decade)
}

/// The polar chart of a test: each run's nominal samples with the centring removed.
pub fn chart(test: &CircularTest, d: &CircularDiagnosis) -> PolarChart {
    let [c1, c2] = d.setup.centre_offset_um;
    let centred = |(t, dr): (f64, f64)| (t, dr - c1 * t.cos() - c2 * t.sin());
    let mut traces = Vec::new();
    let mut max: f64 = 0.0;
    for run in &test.runs {
        let pts: Vec<(f64, f64)> = nominal_samples(run, &test.meta)
            .into_iter()
            .map(centred)
            .collect();
        max = pts.iter().fold(max, |m, p| m.max(p.1.abs()));
        traces.push(PolarTrace {
            name: run.sense.as_str().to_string(),
            points: pts,
            colour: if run.sense == Sense::Ccw {
                CCW_COLOUR
            } else {
                CW_COLOUR
            },
        });
    }
    let (lo, hi) = test.meta.arc_deg_range();
    let c0 = d.setup.radius_offset_um;
    let lsc = (0..=720)
        .map(|k| ((lo + (hi - lo) * k as f64 / 720.0).to_radians(), c0))
        .collect();
    let mut marks = Vec::new();
    let mut a = (lo / 90.0).ceil() * 90.0;
    while a <= hi + 1e-9 {
        marks.push((a.to_radians(), c0));
        a += 90.0;
    }
    let iso = &d.iso230_4;
    let f = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}"));
    PolarChart {
        title: format!(
            "Circular test {} — R {} mm, F {} mm/min",
            d.plane.as_str(),
            d.radius_mm,
            d.feed_mm_per_min
        ),
        traces,
        lsc,
        marks,
        um_per_div: um_per_div(max.max(c0.abs())),
        notes: vec![
            format!(
                "G ccw {} µm   G cw {} µm   G(b) {} µm   H {} µm",
                f(iso.g_ccw_um),
                f(iso.g_cw_um),
                f(iso.g_b_um),
                f(iso.h_um)
            ),
            format!(
                "D {} µm   F {:.2} … {:.2} µm   (centring removed; + reversals)",
                f(iso.d_um),
                iso.f_min_um,
                iso.f_max_um
            ),
        ],
    }
}

/// Writes the report into `dir`.
pub fn write_report(
    test: &CircularTest,
    d: &CircularDiagnosis,
    dir: &Path,
) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    super::write_json(&dir.join("circular.json"), d)?;
    polar(&dir.join("polar"), &chart(test, d))?;
    super::write_text(&dir.join("report.md"), &markdown(test, d))
}

/// The Markdown report.
pub(crate) fn markdown(test: &CircularTest, d: &CircularDiagnosis) -> String {
    let mut md = Md::new();
    md.heading(
        1,
        format_args!("Circular test (ISO 230-4) — plane {}", d.plane.as_str()),
    )
    .para(format_args!(
        "Trace `{}`: radius {} mm, feed {} mm/min, arc {}° from {}°, directions {}; {} samples \
         fitted.",
        test.trace.display(),
        d.radius_mm,
        d.feed_mm_per_min,
        test.meta.arc_deg,
        test.meta.arc_start_deg,
        d.directions
            .iter()
            .map(|s| s.as_str())
            .collect::<Vec<_>>()
            .join(" and "),
        d.samples_fitted
    ))
    .para("![polar plot](polar.png)");
    iso_numbers(&mut md, d);
    diagnosis(&mut md, d);
    cannot_separate(&mut md, d);
    if let Some(link) = &d.link {
        against_model(&mut md, link);
    }
    md.finish()
}

/// The ISO 230-4 numbers of the nominal arc.
fn iso_numbers(md: &mut Md, d: &CircularDiagnosis) {
    let f = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
    let iso = &d.iso230_4;
    md.heading(2, "ISO 230-4 numbers (µm, nominal arc, unfiltered)")
        .table(["quantity", "value"]);
    for (name, v) in [
        ("G ccw (circular deviation)", iso.g_ccw_um),
        ("G cw (circular deviation)", iso.g_cw_um),
        ("G(b) (bi-directional circular deviation)", iso.g_b_um),
        ("H (circular hysteresis)", iso.h_um),
        ("D (mean bi-directional radial deviation)", iso.d_um),
        ("F max (radial deviation)", Some(iso.f_max_um)),
        ("F min (radial deviation)", Some(iso.f_min_um)),
    ] {
        md.row([name.to_string(), f(v)]);
    }
}

/// The verdict, the residual before and after, and the machine errors found.
fn diagnosis(md: &mut Md, d: &CircularDiagnosis) {
    md.nl().heading(
        2,
        format_args!(
            "Diagnosis: {}",
            match d.verdict {
                crate::base::Verdict::Consistent =>
                    "consistent (setup terms and noise explain the trace)",
                crate::base::Verdict::MissingPhysics => "errors found",
            }
        ),
    );
    md.para(format_args!(
        "Residual rms {:.3} µm about the least-squares circle before, {:.3} µm after the setup \
         terms and the effects below (noise σ {:.3} µm).",
        d.rms_before_um, d.rms_after_um, d.sigma_um
    ));
    if d.effects.is_empty() {
        return;
    }
    md.table([
        "effect",
        "axis",
        "parameters (± one-sigma)",
        "explains (µm rms)",
        "where",
    ]);
    for e in &d.effects {
        let params = e
            .effect
            .params()
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4} ± {:.4}", e.sigma(*n).unwrap_or(0.0)))
            .collect::<Vec<_>>()
            .join(", ");
        md.row([
            e.effect.id().to_string(),
            e.axis.slot.label(d.plane).to_string(),
            params,
            format!("{:.3}", e.explains_um),
            e.where_.to_string(),
        ]);
    }
    md.nl();
}

/// The combinations the test leaves open, and the setup terms.
fn cannot_separate(md: &mut Md, d: &CircularDiagnosis) {
    md.heading(2, "What this test cannot separate");
    for u in &d.unidentifiable {
        md.bullet(format_args!("{}: {}", u.ids.join(" / "), u.why));
        for (k, v) in &u.params {
            let s = u.uncertainty.get(k).copied().unwrap_or(0.0);
            md.line(format_args!("  - {k} = {v:.3} ± {s:.3}"));
        }
    }
    md.nl().line(format_args!(
        "Setup (not machine errors): centring offset ({:.3}, {:.3}) µm, radius offset {:.3} µm.",
        d.setup.centre_offset_um[0], d.setup.centre_offset_um[1], d.setup.radius_offset_um
    ));
}

/// The circle a volumetric model implies, term by term against the ballbar's.
fn against_model(md: &mut Md, link: &crate::circular::Link) {
    md.nl()
        .heading(
            2,
            format_args!("Against the volumetric model `{}`", link.model.display()),
        )
        .para(format_args!(
            "The circle the model implies at centre \
             ({}, {}, {}) mm, fitted in this test's conventions (rms after the setup terms \
             {:.3} µm):",
            link.centre_mm[0], link.centre_mm[1], link.centre_mm[2], link.predicted_rms_um
        ))
        .table([
            "term",
            "axis",
            "predicted",
            "ballbar",
            "ballbar − predicted",
        ]);
    for r in &link.rows {
        let measured = match (r.measured, r.measured_sigma) {
            (Some(m), Some(s)) => format!("{m:.3} ± {s:.3}"),
            _ => "not significant".to_string(),
        };
        md.row([
            format!("{} ({})", r.id, r.param),
            r.axis.to_string(),
            format!("{:.3}", r.predicted),
            measured,
            format!("{:.3}", r.difference),
        ]);
    }
}
