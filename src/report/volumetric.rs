//! The volumetric identification report (`volumetric identify --report DIR`): `report.md`
//! (summary, gauge convention, scale temperature and found effects, component table,
//! squareness, identifiability, degree by cross-validation, residual per line and against
//! time), `model.json` (what `predict` reads) and one
//! figure per identified component with its one-sigma band (`E_XX.png`/`.svg` …).

use std::fmt::Write as _;
use std::path::Path;

use super::ReportError;
use crate::base::FileOp;
use crate::base::error::io_err;
use crate::plot::{XySeries, XyStyle, xy};
use crate::volumetric::{Component, GAUGE, Identification, SQUARENESS};

/// Writes the report into `dir`.
pub fn write_report(id: &Identification, positions: usize, dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let model = dir.join("model.json");
    super::write_json(&model, &id.doc(positions, true))?;

    let mut md = String::new();
    let n_id = id.fit.identified.iter().filter(|f| **f).count();
    let _ = writeln!(md, "# Volumetric errors — topology {}\n", id.topology);
    let model = match &id.smoothing {
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
    };
    let _ = writeln!(
        md,
        "{} lines, {} targets. {model}. RMS residual {:.4} µm \
         (√(χ²/ν) = {:.3}, ν = {:.1}; rows {}). **{} of 21 errors identified.**\n",
        id.lines,
        id.targets,
        id.rms_residual_um,
        id.sigma0,
        id.dof,
        if id.weighted {
            "weighted by 1/s_um"
        } else {
            "equally weighted"
        },
        n_id
    );
    let _ = writeln!(md, "**Gauge convention.** {GAUGE}.\n");
    let _ = writeln!(
        md,
        "**Residual.** Verdict `{}`. What remains after the fit{} against the noise: {} test, \
         z = {:.2} ({}; above 3.09 it is an `unexplained` effect). A drift in time or a single \
         bad line is not yet named.\n",
        id.residual.verdict,
        if id.thermal.as_ref().is_some_and(|t| t.kept) {
            " and the scales' expansion"
        } else {
            ""
        },
        id.residual.test,
        id.residual.z,
        if id.residual.z > crate::volumetric::identify::Z_MISSING {
            "not noise"
        } else {
            "noise"
        }
    );
    if let Some(th) = &id.thermal {
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
        let _ = writeln!(
            md,
            "**Scale temperature.** scale_temp_c {:.2}–{:.2} °C over the campaign; {words}.\n",
            th.temp_c[0], th.temp_c[1]
        );
    }
    if !id.residual.effects.is_empty() {
        let _ = writeln!(
            md,
            "| effect | parameters | one-sigma | explains (µm) | where |\n|---|---|---|---|---|"
        );
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
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.3} | {} |",
                e.id(),
                params.join(", "),
                sig.join(", "),
                e.explains_um,
                e.where_
            );
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md, "## Components\n");
    let _ = writeln!(
        md,
        "| component | role | identified | max abs value | max σ | unit | figure |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|");
    for c in Component::all() {
        let pos = id.positions(c.axis, positions);
        let vals: Option<Vec<(f64, f64)>> = pos
            .iter()
            .map(|&a| id.fit.component(c.index(), a))
            .collect();
        let (v, s, fig) = match &vals {
            Some(v) => {
                let stem = dir.join(c.name());
                let y: Vec<f64> = v.iter().map(|x| x.0).collect();
                let series = vec![
                    XySeries {
                        name: c.name(),
                        x: pos.clone(),
                        y: y.clone(),
                        style: XyStyle::Line,
                    },
                    XySeries {
                        name: "+1σ".into(),
                        x: pos.clone(),
                        y: v.iter().map(|x| x.0 + x.1).collect(),
                        style: XyStyle::Line,
                    },
                    XySeries {
                        name: "−1σ".into(),
                        x: pos.clone(),
                        y: v.iter().map(|x| x.0 - x.1).collect(),
                        style: XyStyle::Line,
                    },
                ];
                let axis = ['x', 'y', 'z'][c.axis];
                let drawn = xy(
                    &stem,
                    &format!(
                        "{} ({} of {})",
                        c.name(),
                        c.role(),
                        axis.to_ascii_uppercase()
                    ),
                    &format!("{axis} (mm)"),
                    &format!(
                        "{} ({})",
                        c.name(),
                        if c.is_rotation() { "µrad" } else { "µm" }
                    ),
                    &series,
                )
                .is_ok();
                (
                    format!("{:.4}", y.iter().fold(0.0f64, |a, b| a.max(b.abs()))),
                    format!("{:.4}", v.iter().fold(0.0f64, |a, b| a.max(b.1))),
                    if drawn {
                        format!("[png]({}.png)", c.name())
                    } else {
                        String::new()
                    },
                )
            }
            None => ("—".into(), "—".into(), String::new()),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {v} | {s} | {} | {fig} |",
            c.name(),
            c.role(),
            if vals.is_some() { "yes" } else { "**no**" },
            if c.is_rotation() { "µrad" } else { "µm" }
        );
    }
    let _ = writeln!(
        md,
        "\n## Squareness\n\n| error | value (µrad) | σ (µrad) |\n|---|---|---|"
    );
    for (i, name) in SQUARENESS.iter().enumerate() {
        match id.fit.squareness(i) {
            Some((v, s)) => {
                let _ = writeln!(md, "| {name} | {v:.3} | {s:.3} |");
            }
            None => {
                let _ = writeln!(md, "| {name} | not identified | — |");
            }
        }
    }
    let _ = writeln!(md, "\n## What the lines cannot determine\n");
    if id.unidentified.is_empty() {
        let _ = writeln!(md, "Nothing: the lines determine all 21 errors.");
    } else {
        let _ = writeln!(md, "| components | what to measure |\n|---|---|");
        for u in &id.unidentified {
            let _ = writeln!(md, "| {} | {} |", u.components.join(", "), u.why);
        }
    }
    if !id.cv.is_empty() {
        let _ = writeln!(
            md,
            "\n## Degree by cross-validation\n\n| degree | CV RMS (weighted) | identified |\n|---|---|---|"
        );
        for s in &id.cv {
            let _ = writeln!(
                md,
                "| {} | {:.4} | {} |",
                s.degree, s.cv_rms_um, s.identified
            );
        }
    }
    let _ = writeln!(md, "\n## Residual per line\n");
    // Against time: a scale warming or a drift shows as a trend from line to line.
    let timed: Vec<(f64, f64)> = id
        .residuals
        .iter()
        .flat_map(|l| l.t_s.iter().zip(&l.r_um))
        .filter_map(|(t, r)| t.map(|t| (t / 3600.0, *r)))
        .collect();
    if !timed.is_empty() {
        let series = vec![XySeries {
            name: "residual".into(),
            x: timed.iter().map(|p| p.0).collect(),
            y: timed.iter().map(|p| p.1).collect(),
            style: XyStyle::Points,
        }];
        if xy(
            &dir.join("residual_time"),
            "Residual against time",
            "t (h)",
            "residual (µm)",
            &series,
        )
        .is_ok()
        {
            let _ = writeln!(
                md,
                "Against the campaign's time: [png](residual_time.png) (a trend from line to \
                 line is a drift or a warming scale the fit left out).\n"
            );
        }
    }
    let _ = writeln!(
        md,
        "| line | targets | RMS (µm) | max abs (µm) | mean t (s) |\n|---|---|---|---|---|"
    );
    for l in &id.residuals {
        let rms = crate::base::stats::rms(&l.r_um).unwrap_or(0.0);
        let max = l.r_um.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let ts: Vec<f64> = l.t_s.iter().flatten().copied().collect();
        let t = if ts.is_empty() {
            "—".to_string()
        } else {
            format!("{:.0}", ts.iter().sum::<f64>() / ts.len() as f64)
        };
        let _ = writeln!(
            md,
            "| {} | {} | {rms:.4} | {max:.4} | {t} |",
            l.line,
            l.r_um.len()
        );
    }
    let path = dir.join("report.md");
    super::write_text(&path, &md)?;
    Ok(())
}
