//! The artefact reports: `artefact identify --report DIR` (report.md with the components
//! and their bands, the placements, the observability, the residual test, one residual
//! map per position; identify.json; model.json) and `artefact evaluate --report DIR`
//! (report.md and the plate's residual map).

use std::fmt::Write as _;
use std::path::Path;

use super::history::display_unit;
use super::{ReportError, write_json, write_text};
use crate::artefact::{ArtefactIdentification, Evaluation, IdentifyDoc, Kind};
use crate::base::{FileOp, io_err};
use crate::plot::{Arrow, ArrowMap, arrow_map};
use crate::volumetric::{ComponentDoc, ModelDoc};

/// The file stem of position `k`'s residual map.
fn map_stem(k: usize, id: &str) -> String {
    let safe: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("residual_{:02}_{safe}", k + 1)
}

/// Writes report.md, identify.json, model.json and the residual maps into `dir`.
pub fn write_report(
    id: &ArtefactIdentification,
    doc: &IdentifyDoc,
    model: &ModelDoc,
    dir: &Path,
) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    write_json(&dir.join("identify.json"), doc)?;
    write_json(&dir.join("model.json"), model)?;
    let mut md = String::new();
    let _ = writeln!(md, "# Artefact identification\n");
    let _ = writeln!(
        md,
        "{} positions, {} features, topology {}. RMS residual {:.3} µm. Residual test: {} \
         (χ² = {:.1} on {:.0} degrees of freedom, z = {:.2}).\n",
        doc.positions,
        doc.features,
        doc.topology,
        doc.rms_residual_um,
        doc.residual.verdict,
        doc.residual.chi2,
        doc.residual.dof,
        doc.residual.z
    );
    components_table(&mut md, doc);
    observability_section(&mut md, doc);
    let _ = writeln!(md, "## Placements (X = R·f + t)\n");
    let _ = writeln!(
        md,
        "| position | t, mm | R (rows) | RMS, µm |\n|---|---|---|---|"
    );
    for p in &doc.placements {
        let r = p
            .rotation
            .iter()
            .map(|row| format!("[{:+.6} {:+.6} {:+.6}]", row[0], row[1], row[2]))
            .collect::<Vec<_>>()
            .join(" ");
        let _ = writeln!(
            md,
            "| {} | {:.4}, {:.4}, {:.4} | {r} | {:.3} |",
            p.position, p.translation_mm[0], p.translation_mm[1], p.translation_mm[2], p.rms_um
        );
    }
    let _ = writeln!(md, "\n## Residual by position\n");
    let _ = writeln!(
        md,
        "| position | share of χ² | RMS, µm | worst feature |\n|---|---|---|---|"
    );
    for c in &doc.residual.carriers {
        let _ = writeln!(
            md,
            "| {} | {:.1} % | {:.3} | {} |",
            c.position,
            100.0 * c.share,
            c.rms_um,
            c.worst_feature
        );
    }
    let _ = writeln!(
        md,
        "\n## Residual maps\n\nMeasured − fitted at each feature, in the artefact's frame, \
         magnified (the key arrow of each map gives its scale).\n"
    );
    for (k, p) in doc.placements.iter().enumerate() {
        let stem = map_stem(k, &p.position);
        let arrows: Vec<Arrow> = id.maps[k]
            .iter()
            .map(|m| Arrow {
                x_mm: m.at_mm[0],
                y_mm: m.at_mm[1],
                dx_um: m.e_um[0],
                dy_um: if id.kinds[k] == Kind::StepGauge {
                    0.0
                } else {
                    m.e_um[1]
                },
            })
            .collect();
        arrow_map(
            &dir.join(&stem),
            &ArrowMap {
                title: format!("Residuals of position {}", p.position),
                notes: vec![format!(
                    "measured − fitted, artefact frame; RMS {:.3} µm",
                    p.rms_um
                )],
                x_label: "artefact x, mm".into(),
                y_label: "artefact y, mm".into(),
                arrows,
            },
        )?;
        let _ = writeln!(md, "![{}]({stem}.png)\n", p.position);
    }
    write_text(&dir.join("report.md"), &md)
}

fn components_table(md: &mut String, doc: &IdentifyDoc) {
    let _ = writeln!(
        md,
        "## Components\n\nLargest |value| over the measured range with the one-sigma there \
         (cubic polynomials in the volumetric model's basis and gauge; model.json holds every \
         position); `> 2σ` says whether that value stands out of its own noise (a component \
         that does not is consistent with zero on this campaign).\n\n\
         | component | unit | largest value | σ there | > 2σ |\n|---|---|---|---|---|"
    );
    let beyond = |v: f64, s: f64| if v.abs() > 2.0 * s { "yes" } else { "no" };
    for (name, c) in &doc.components {
        match c {
            ComponentDoc::Function {
                unit,
                values: Some(v),
                sigma: Some(s),
                ..
            } => {
                let k = (0..v.len())
                    .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
                    .unwrap_or(0);
                let _ = writeln!(
                    md,
                    "| {name} | {} | {:+.3} | {:.3} | {} |",
                    display_unit(unit),
                    v[k],
                    s[k],
                    beyond(v[k], s[k])
                );
            }
            ComponentDoc::Constant {
                unit,
                value: Some(v),
                sigma: Some(s),
                ..
            } => {
                let _ = writeln!(
                    md,
                    "| {name} | {} | {v:+.3} | {s:.3} | {} |",
                    display_unit(unit),
                    beyond(*v, *s)
                );
            }
            ComponentDoc::Function { unit, .. } | ComponentDoc::Constant { unit, .. } => {
                let _ = writeln!(
                    md,
                    "| {name} | {} | not determined | — | — |",
                    display_unit(unit)
                );
            }
        }
    }
    md.push('\n');
}

fn observability_section(md: &mut String, doc: &IdentifyDoc) {
    let _ = writeln!(md, "## Observability\n");
    if doc.unidentified.is_empty() {
        let _ = writeln!(md, "The positions determine every component.\n");
    }
    for u in &doc.unidentified {
        let _ = writeln!(
            md,
            "- Not determined: {} — {}",
            u.components.join(", "),
            u.why
        );
        if u.suggest.is_empty() {
            let _ = writeln!(
                md,
                "  - no single extra position of the plate determines them"
            );
        }
        for s in &u.suggest {
            let _ = writeln!(
                md,
                "  - an extra position would: the plate in {} at {:.1} mm (stylus {:?} mm)",
                s.plane, s.at_mm, s.probe_mm
            );
        }
    }
    if let Some(sc) = &doc.self_calibration {
        let _ = writeln!(
            md,
            "\nSelf-calibration of {}: deviations of {} features (rigid motion removed).",
            sc.artefact,
            sc.features.len()
        );
        for i in &sc.invariants {
            let _ = writeln!(
                md,
                "- Invariant ({}): {} — carried by {}",
                i.kind,
                i.why,
                i.components.join(", ")
            );
        }
    }
    md.push('\n');
}

/// `artefact evaluate --report DIR`: report.md and the plate's residual map
/// (residuals.png/svg; with `--against`, against.png/svg too).
pub fn write_evaluation_report(ev: &Evaluation, dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    write_json(&dir.join("evaluate.json"), ev)?;
    let mut md = String::new();
    match ev {
        Evaluation::Plate(p) => {
            let f = &p.fitted.fit;
            let _ = writeln!(
                md,
                "# Plate evaluation: {}\n\n{} ({}), {} features in {}, model {}, {:.2} °C.\n\n\
                 | shift x, µm | shift y, µm | rotation, µrad | scale, ppm | RMS, µm | largest, µm |\n\
                 |---|---|---|---|---|---|\n| {:+.2} | {:+.2} | {:+.2} | {:+.3} | {:.3} | {:.3} |\n",
                p.artefact,
                p.artefact,
                p.kind,
                p.features,
                p.plane,
                p.model,
                p.temp_c,
                f.shift_um[0],
                f.shift_um[1],
                f.rotation_urad,
                f.scale_ppm,
                p.fitted.rms_um,
                p.fitted.max_um
            );
            if let Some(d) = f.distortion {
                let _ = writeln!(
                    md,
                    "Distortion: {:.3} ppm along {:.1}°.\n",
                    d.q_ppm, d.angle_deg
                );
            }
            plate_map(dir, "residuals", &p.fitted, p.plane, "measured − fitted")?;
            let _ = writeln!(md, "![residuals](residuals.png)\n");
            if let Some(a) = &p.against {
                let _ = writeln!(
                    md,
                    "Against {} ({} common features): RMS {:.3} µm, largest {:.3} µm.\n\n\
                     ![against](against.png)\n",
                    a.file, a.features, a.fitted.rms_um, a.fitted.max_um
                );
                plate_map(
                    dir,
                    "against",
                    &a.fitted,
                    p.plane,
                    "this − the earlier measurement, fitted",
                )?;
            }
        }
        Evaluation::Gauge(g) => {
            let _ = writeln!(
                md,
                "# Gauge evaluation: {}\n\n| feature | length, mm | error, µm |\n|---|---|---|",
                g.artefact
            );
            for l in &g.lengths {
                let _ = writeln!(
                    md,
                    "| {} | {:.3} | {:+.3} |",
                    l.feature, l.length_mm, l.e_um
                );
            }
        }
    }
    write_text(&dir.join("report.md"), &md)
}

fn plate_map(
    dir: &Path,
    stem: &str,
    f: &crate::artefact::Fitted,
    plane: &str,
    what: &str,
) -> Result<(), ReportError> {
    // Arrows at the fitted features' places: the residuals carry their coordinates only
    // by id, so the places are recomputed by the caller's order (same as residuals).
    let arrows: Vec<Arrow> = f
        .residuals
        .iter()
        .zip(&f.places_mm)
        .map(|(r, p)| Arrow {
            x_mm: p[0],
            y_mm: p[1],
            dx_um: r.e1_um,
            dy_um: r.e2_um,
        })
        .collect();
    let mut a = plane.chars();
    let (c1, c2) = (a.next().unwrap_or('X'), a.next().unwrap_or('Y'));
    arrow_map(
        &dir.join(stem),
        &ArrowMap {
            title: format!("Plate residuals ({what})"),
            notes: vec![format!(
                "RMS {:.3} µm, largest {:.3} µm",
                f.rms_um, f.max_um
            )],
            x_label: format!("{c1}, mm"),
            y_label: format!("{c2}, mm"),
            arrows,
        },
    )?;
    Ok(())
}
