//! The volumetric identification report (`volumetric identify --report DIR`): `report.md`
//! (summary, gauge convention, scale temperature and found effects, component table,
//! squareness, identifiability, degree by cross-validation, residual per line and against
//! time), `model.json` (what `predict` reads) and one
//! figure per identified component with its one-sigma band (`E_XX.png`/`.svg` …).

use std::path::Path;

use super::ReportError;
use super::md::Md;
use crate::base::FileOp;
use crate::base::io_err;
use crate::plot::{XySeries, XyStyle, xy};
use crate::volumetric::{Component, GAUGE, Identification, SQUARENESS};

/// Writes the report into `dir`.
pub fn write_report(id: &Identification, positions: usize, dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let model = dir.join("model.json");
    super::write_json(&model, &id.doc(positions, true))?;

    let mut md = Md::new();
    md.heading(
        1,
        format_args!("Volumetric errors — topology {}", id.topology),
    );
    summary(&mut md, id);
    scale_temperature(&mut md, id);
    found_effects(&mut md, id);
    components(&mut md, id, positions, dir);
    squareness(&mut md, id);
    undetermined(&mut md, id);
    degree_by_cv(&mut md, id);
    residual_per_line(&mut md, id, dir);
    let path = dir.join("report.md");
    super::write_text(&path, md.as_str())?;
    Ok(())
}

/// How the components were modelled, in a phrase.
fn model_words(id: &Identification) -> String {
    match &id.smoothing {
        Some(sm) => format!(
            "Components as tables at knots with a roughness penalty, smoothing by {}{}",
            sm.criterion,
            if sm.relaxed_by < 1.0 {
                format!(
                    ", relaxed by {:.0e} because the REML fit's residual failed the test",
                    sm.relaxed_by
                )
            } else {
                String::new()
            }
        ),
        None => format!(
            "Polynomial degree {}{}",
            id.degree,
            if id.cv.is_empty() {
                ""
            } else {
                " (chosen by leave-one-line-out cross-validation)"
            }
        ),
    }
}

/// The fit in one paragraph, the gauge convention and the residual's verdict.
fn summary(md: &mut Md, id: &Identification) {
    let n_id = id.fit.identified.iter().filter(|f| **f).count();
    md.para(format_args!(
        "{} lines, {} targets. {}. RMS residual {:.4} µm \
         (√(χ²/ν) = {:.3}, ν = {:.1}; rows {}). **{} of 21 errors identified.**",
        id.lines,
        id.targets,
        model_words(id),
        id.rms_residual_um,
        id.sigma0,
        id.dof,
        if id.weighted {
            "weighted by 1/s_um"
        } else {
            "equally weighted"
        },
        n_id
    ));
    md.para(format_args!("**Gauge convention.** {GAUGE}."));
    md.para(format_args!(
        "**Residual.** Verdict `{}`. What remains after the fit{} against the noise: {} test, \
         z = {:.2} ({}; above 3.09 it is an `unexplained` effect). A drift in time or a single \
         bad line is not yet named.",
        id.residual.verdict,
        if id.thermal.as_ref().is_some_and(|t| t.kept) {
            " and the scales' expansion"
        } else {
            ""
        },
        id.residual.test,
        id.residual.z,
        if id.residual.z > crate::volumetric::Z_MISSING {
            "not noise"
        } else {
            "noise"
        }
    ));
}

/// The scales' expansion coefficient, when the campaign recorded their temperature.
fn scale_temperature(md: &mut Md, id: &Identification) {
    let Some(th) = &id.thermal else {
        return;
    };
    let words = match (th.alpha_ppm_per_k, th.sigma_ppm_per_k) {
        (Some(a), Some(s)) if th.kept => format!(
            "α = {a:.3} ± {s:.3} ppm/K (|α|/σ = {:.1} > 3): kept; the components below are \
             **at 20 °C**",
            a.abs() / s
        ),
        (Some(a), Some(s)) => {
            format!("α = {a:.3} ± {s:.3} ppm/K, not significant (|α|/σ ≤ 3): not fitted")
        }
        _ => "α is not determined (the temperature did not change enough between lines \
              along the same axes): not fitted; the positioning components are those at the \
              campaign's temperature"
            .to_string(),
    };
    md.para(format_args!(
        "**Scale temperature.** scale_temp_c {:.2}–{:.2} °C over the campaign; {words}.",
        th.temp_c[0], th.temp_c[1]
    ));
}

/// The effects the residual's analysis named, one row each.
fn found_effects(md: &mut Md, id: &Identification) {
    if id.residual.effects.is_empty() {
        return;
    }
    md.table([
        "effect",
        "parameters",
        "one-sigma",
        "explains (µm)",
        "where",
    ]);
    for e in &id.residual.effects {
        let params: Vec<String> = e
            .effect
            .params_by_name()
            .iter()
            .map(|(k, v)| format!("{k} = {v}"))
            .collect();
        let sig: Vec<String> = e
            .uncertainty_by_name()
            .iter()
            .map(|(k, v)| format!("{k}: {v:.3}"))
            .collect();
        md.row([
            e.id().to_string(),
            params.join(", "),
            sig.join(", "),
            format!("{:.3}", e.explains_um),
            e.where_.to_string(),
        ]);
    }
    md.nl();
}

/// The unit of a component's values.
fn unit(c: &Component) -> &'static str {
    if c.is_rotation() { "µrad" } else { "µm" }
}

/// One row per component, drawing each identified one with its one-sigma band.
fn components(md: &mut Md, id: &Identification, positions: usize, dir: &Path) {
    md.heading(2, "Components").table([
        "component",
        "role",
        "identified",
        "max abs value",
        "max σ",
        "unit",
        "figure",
    ]);
    for c in Component::all() {
        let pos = id.positions(c.axis, positions);
        let vals: Option<Vec<(f64, f64)>> = pos
            .iter()
            .map(|&a| id.fit.component(c.index(), a))
            .collect();
        let (v, s, fig) = match &vals {
            Some(v) => {
                let y: Vec<f64> = v.iter().map(|x| x.0).collect();
                (
                    format!("{:.4}", y.iter().fold(0.0f64, |a, b| a.max(b.abs()))),
                    format!("{:.4}", v.iter().fold(0.0f64, |a, b| a.max(b.1))),
                    if component_figure(&c, &pos, v, dir) {
                        format!("[png]({}.png)", c.name())
                    } else {
                        String::new()
                    },
                )
            }
            None => ("—".into(), "—".into(), String::new()),
        };
        md.row([
            c.name(),
            c.role().to_string(),
            if vals.is_some() { "yes" } else { "**no**" }.into(),
            v,
            s,
            unit(&c).into(),
            fig,
        ]);
    }
}

/// Draws one component (value, ±1σ) along its axis; whether the figure was written.
fn component_figure(c: &Component, pos: &[f64], v: &[(f64, f64)], dir: &Path) -> bool {
    let line = |name: &str, y: Vec<f64>, dashed: bool| XySeries {
        name: name.into(),
        x: pos.to_vec(),
        y,
        style: XyStyle::Styled {
            colour: usize::from(dashed),
            dashed,
            markers: false,
        },
    };
    // The band's two edges alike, one legend entry for both.
    let series = vec![
        line(&c.name(), v.iter().map(|x| x.0).collect(), false),
        line("±1σ", v.iter().map(|x| x.0 + x.1).collect(), true),
        line("", v.iter().map(|x| x.0 - x.1).collect(), true),
    ];
    let axis = ['x', 'y', 'z'][c.axis];
    xy(
        &dir.join(c.name()),
        &format!(
            "{} ({} of {})",
            c.name(),
            c.role(),
            axis.to_ascii_uppercase()
        ),
        &format!("{axis} / mm"),
        &format!("{} / {}", c.name(), unit(c)),
        &series,
    )
    .is_ok()
}

/// The three squareness errors.
fn squareness(md: &mut Md, id: &Identification) {
    md.nl()
        .heading(2, "Squareness")
        .table(["error", "value (µrad)", "σ (µrad)"]);
    for (i, name) in SQUARENESS.iter().enumerate() {
        match id.fit.squareness(i) {
            Some((v, s)) => md.row([name.to_string(), format!("{v:.3}"), format!("{s:.3}")]),
            None => md.row([*name, "not identified", "—"]),
        };
    }
}

/// The combinations the lines leave open, and what would measure them.
fn undetermined(md: &mut Md, id: &Identification) {
    md.nl().heading(2, "What the lines cannot determine");
    if id.unidentified.is_empty() {
        md.line("Nothing: the lines determine all 21 errors.");
    } else {
        md.table(["components", "what to measure"]);
        for u in &id.unidentified {
            md.row([u.components.join(", "), u.why.to_string()]);
        }
    }
}

/// The cross-validation that chose the polynomial degree, when it ran.
fn degree_by_cv(md: &mut Md, id: &Identification) {
    if id.cv.is_empty() {
        return;
    }
    md.nl().heading(2, "Degree by cross-validation").table([
        "degree",
        "CV RMS (weighted)",
        "identified",
    ]);
    for s in &id.cv {
        md.row([
            s.degree.to_string(),
            format!("{:.4}", s.cv_rms_um),
            s.identified.to_string(),
        ]);
    }
}

/// The residual against time (a figure, when the lines are timed) and per line.
fn residual_per_line(md: &mut Md, id: &Identification, dir: &Path) {
    md.nl().heading(2, "Residual per line");
    if residual_time_figure(id, dir) {
        md.para(
            "Against the campaign's time: [png](residual_time.png) (a trend from line to \
             line is a drift or a warming scale the fit left out).",
        );
    }
    md.table(["line", "targets", "RMS (µm)", "max abs (µm)", "mean t (s)"]);
    for l in &id.residuals {
        let rms = crate::base::rms(&l.r_um).unwrap_or(0.0);
        let max = l.r_um.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let ts: Vec<f64> = l.t_s.iter().flatten().copied().collect();
        let t = if ts.is_empty() {
            "—".to_string()
        } else {
            format!("{:.0}", ts.iter().sum::<f64>() / ts.len() as f64)
        };
        md.row([
            l.line.to_string(),
            l.r_um.len().to_string(),
            format!("{rms:.4}"),
            format!("{max:.4}"),
            t,
        ]);
    }
}

/// Draws the residual against time: a scale warming or a drift shows as a trend from
/// line to line. Whether the figure was written (not when no line is timed).
fn residual_time_figure(id: &Identification, dir: &Path) -> bool {
    let timed: Vec<(f64, f64)> = id
        .residuals
        .iter()
        .flat_map(|l| l.t_s.iter().zip(&l.r_um))
        .filter_map(|(t, r)| t.map(|t| (t / 3600.0, *r)))
        .collect();
    if timed.is_empty() {
        return false;
    }
    let series = vec![XySeries {
        name: "residual".into(),
        x: timed.iter().map(|p| p.0).collect(),
        y: timed.iter().map(|p| p.1).collect(),
        style: XyStyle::Points,
    }];
    xy(
        &dir.join("residual_time"),
        "Residual against time",
        "t / h",
        "residual / µm",
        &series,
    )
    .is_ok()
}
