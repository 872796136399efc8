//! The diagnosis report: `report.md` and PNG+SVG charts (residual before/after against
//! position and time, one partial-residual chart per found effect against the covariate it
//! follows, and the broad periodogram). Charts show at most [`MAX_POINTS`] points per
//! series (an evenly spaced subset). O(n).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::base::FileOp;
use crate::base::error::io_err;
use crate::plot::{self, XySeries, XyStyle};

use super::ReportError;
use crate::diagnose::{Diagnosis, GroupStat, Verdict};

/// Most points drawn per series.
pub const MAX_POINTS: usize = 4000;

fn thin(idx: &[usize]) -> Vec<usize> {
    if idx.len() <= MAX_POINTS {
        return idx.to_vec();
    }
    (0..MAX_POINTS)
        .map(|k| idx[k * idx.len() / MAX_POINTS])
        .collect()
}

fn pick(v: &[f64], idx: &[usize]) -> Vec<f64> {
    idx.iter().map(|&k| v[k]).collect()
}

fn points(name: &str, x: &[f64], y: &[f64], idx: &[usize]) -> XySeries {
    let idx = thin(idx);
    XySeries {
        name: name.into(),
        x: pick(x, &idx),
        y: pick(y, &idx),
        style: XyStyle::Points,
    }
}

/// A line through (x, y) sorted by x, thinned.
fn curve(name: &str, x: &[f64], y: &[f64], idx: &[usize]) -> XySeries {
    let mut idx = idx.to_vec();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let idx = thin(&idx);
    XySeries {
        name: name.into(),
        x: pick(x, &idx),
        y: pick(y, &idx),
        style: XyStyle::Line,
    }
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Writes `report.md` and the charts into `dir` (created when missing); returns every
/// file written, `report.md` first. `environment` (the session's air and material
/// temperatures, [`super::environment::environment_summary`]) ends the report when given.
pub fn write_report(
    d: &Diagnosis,
    dir: &Path,
    environment: Option<&str>,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let s = &d.series;
    let ax = d.axis.to_lowercase();
    let mut files: Vec<PathBuf> = Vec::new();
    let mut figs: Vec<(String, String)> = Vec::new();
    let all: Vec<usize> = (0..s.x_mm.len()).collect();

    if !all.is_empty() {
        let stem = dir.join("residual_vs_x");
        let p = plot::xy(
            &stem,
            "Residual recorded − simulated against position",
            &format!("{ax} / mm"),
            "residual / µm",
            &[
                points("before (about its mean)", &s.x_mm, &s.before_um, &all),
                points("after the found effects", &s.x_mm, &s.after_um, &all),
            ],
        )?;
        figs.push((
            "Residual against position".into(),
            "residual_vs_x.png".into(),
        ));
        files.extend(p);
        let stem = dir.join("residual_vs_time");
        let p = plot::xy(
            &stem,
            "Residual recorded − simulated against time",
            "t / s",
            "residual / µm",
            &[
                points("before (about its mean)", &s.t_s, &s.before_um, &all),
                points("after the found effects", &s.t_s, &s.after_um, &all),
            ],
        )?;
        figs.push((
            "Residual against time".into(),
            "residual_vs_time.png".into(),
        ));
        files.extend(p);
    }
    for (k, e) in s.effects.iter().enumerate() {
        let mut series = Vec::new();
        if e.groups.is_empty() {
            series.push(points(
                "partial residual",
                &e.covariate,
                &e.partial_um,
                &all,
            ));
            series.push(curve("fitted effect", &e.covariate, &e.fitted_um, &all));
        } else {
            for (label, idx) in &e.groups {
                series.push(points(
                    &format!("partial residual, {label}"),
                    &e.covariate,
                    &e.partial_um,
                    idx,
                ));
            }
            for (label, idx) in &e.groups {
                series.push(curve(
                    &format!("fitted, {label}"),
                    &e.covariate,
                    &e.fitted_um,
                    idx,
                ));
            }
        }
        let name = format!("effect_{}_{}", k + 1, slug(e.id.as_str()));
        let p = plot::xy(
            &dir.join(&name),
            &format!("{}: residual without the other effects", e.id),
            &e.covariate_label,
            "partial residual / µm",
            &series,
        )?;
        figs.push((format!("Effect {}: {}", k + 1, e.id), format!("{name}.png")));
        files.extend(p);
    }
    if !s.broad_period_mm.is_empty() {
        let idx: Vec<usize> = (0..s.broad_period_mm.len()).collect();
        let p = plot::xy(
            &dir.join("periodogram"),
            "Broad periodogram of the residual (last search)",
            "period / mm",
            "Δχ² of a sine",
            &[curve(
                "Lomb–Scargle",
                &s.broad_period_mm,
                &s.broad_power,
                &idx,
            )],
        )?;
        figs.push(("Broad periodogram".into(), "periodogram.png".into()));
        files.extend(p);
    }

    let mut md = markdown(d, &figs);
    // The measurement that separates effects these data could not tell apart, ready for
    // `errmap simulate --plan` (one plan file; the first when there are several).
    if let Some(sp) = d.separating_plans.first() {
        let path = dir.join("separating-plan.toml");
        super::write_bytes(&path, sp.plan_toml.as_bytes())?;
        md.push_str(&format!(
            "\n## Decided by physics: {} rather than {}\n\n{}.\n\nThe measurement that separates them is in `separating-plan.toml`.\n",
            sp.chosen.as_str(),
            sp.other.as_str(),
            sp.basis
        ));
        files.push(path);
    }
    if let Some(m) = &d.static_map {
        let _ = write!(
            md,
            "\n## Static part taken from the recording\n\nNo simulation: the map and the reversal are the recording's own ({} levels, {} of them dwell means per line, target and direction; the dwell map spans {:.3} µm; reversal ē↑ − ē↓ {:.3} µm on average over {} targets, spanning {:.3} µm). The effects above are what is left.\n",
            m.groups,
            m.dwell_groups,
            m.map_span_um,
            m.mean_reversal_um,
            m.targets_with_reversal,
            m.reversal_span_um
        );
    }
    if let Some(env) = environment {
        md.push('\n');
        md.push_str(env);
    }
    let path = dir.join("report.md");
    super::write_text(&path, &md)?;
    files.insert(0, path);
    Ok(files)
}

/// ISO 230-2 figures of one line, µm.
#[derive(Debug, Clone, serde::Serialize)]
pub struct IsoFigures {
    /// The line's two other coordinates, mm.
    pub line_mm: [f64; 2],
    /// Reversal B and mean reversal B̄.
    pub b_um: f64,
    pub mean_reversal_um: f64,
    /// Repeatability R, R↑, R↓.
    pub r_um: f64,
    pub r_up_um: f64,
    pub r_down_um: f64,
    /// Systematic positional deviation E, mean bidirectional deviation M, accuracy A.
    pub e_um: f64,
    pub m_um: f64,
    pub a_um: f64,
}

/// The ISO 230-2 figures of a recording as measured and with the found effects taken out
/// of it (`diagnose::remove_found`): what the effects beyond the map and the reversal do
/// to the figures (e.g. the repeatability without the drift).
#[derive(Debug, Clone, serde::Serialize)]
pub struct IsoEffect {
    pub measured: Vec<IsoFigures>,
    pub effects_removed: Vec<IsoFigures>,
}

fn iso_figures(rows: &[errmap_drivers::SessionRow]) -> Vec<IsoFigures> {
    let (ok, _) = crate::session::Reducer::of(rows).iso_by_line();
    ok.into_iter()
        .map(|((a, b), s)| IsoFigures {
            line_mm: [a, b],
            b_um: s.b_um,
            mean_reversal_um: s.mean_reversal_um,
            r_um: s.r_um,
            r_up_um: s.r_up_um,
            r_down_um: s.r_down_um,
            e_um: s.e_um,
            m_um: s.m_um,
            a_um: s.a_um,
        })
        .collect()
}

/// [`IsoEffect`] of a recording and its diagnosis.
pub fn iso_effect(recorded: &[errmap_drivers::SessionRow], d: &Diagnosis) -> IsoEffect {
    IsoEffect {
        measured: iso_figures(recorded),
        effects_removed: iso_figures(&crate::diagnose::remove_found(recorded, d)),
    }
}

/// Appends the [`IsoEffect`] table to `dir/report.md`.
pub fn append_iso_effect(dir: &Path, e: &IsoEffect) -> Result<(), ReportError> {
    let path = dir.join("report.md");
    let mut md = std::fs::read_to_string(&path).map_err(io_err(&path, FileOp::Read))?;
    md.push_str("\n## ISO 230-2 figures with the found effects removed\n\n");
    md.push_str("The static part (map and reversal) is the recording's own; the found effects (drift, air, feed, periodic terms) are taken out of every row and the figures computed again.\n\n");
    md.push_str("| line (mm) | | B | B̄ | R | R↑ | R↓ | E | M | A |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (label, set) in [
        ("measured", &e.measured),
        ("effects removed", &e.effects_removed),
    ] {
        for f in set {
            let _ = writeln!(
                md,
                "| {}, {} | {label} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
                f.line_mm[0],
                f.line_mm[1],
                f.b_um,
                f.mean_reversal_um,
                f.r_um,
                f.r_up_um,
                f.r_down_um,
                f.e_um,
                f.m_um,
                f.a_um
            );
        }
    }
    super::write_text(&path, &md)
}

fn table(out: &mut String, title: &str, rows: &[GroupStat]) {
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(out, "\n**{title}**\n");
    let _ = writeln!(
        out,
        "| group | rows | mean before µm | z | mean after µm | z after |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for r in rows {
        let flag = if r.z.abs() > 5.0 { " **" } else { "" };
        let _ = writeln!(
            out,
            "| {} | {} | {:+.4}{flag} | {:.1} | {:+.4} | {:.1} |",
            r.label, r.rows, r.mean_um, r.z, r.mean_after_um, r.z_after
        );
    }
}

fn markdown(d: &Diagnosis, figs: &[(String, String)]) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "# Missing-physics diagnosis\n");
    let verdict = if d.verdict == Verdict::Consistent {
        "**consistent** — the residual is explained by noise alone"
    } else {
        "**missing physics** — the simulation leaves out what follows"
    };
    let _ = writeln!(o, "Verdict: {verdict}.\n");
    let _ = writeln!(o, "| quantity | value |\n|---|---|");
    let _ = writeln!(o, "| measured axis | {} |", d.axis);
    let _ = writeln!(
        o,
        "| RMS before (recorded − simulated) | {:.4} µm |",
        d.rms_before_um
    );
    let _ = writeln!(
        o,
        "| RMS before, about its mean | {:.4} µm |",
        d.rms_before_centred_um
    );
    let _ = writeln!(
        o,
        "| RMS after the found effects | {:.4} µm |",
        d.rms_after_um
    );
    let _ = writeln!(
        o,
        "| same, cross-validated (each {} held out) | {:.4} µm |",
        d.cv_folds, d.cv_rms_after_um
    );
    let _ = writeln!(o, "| noise σ (pooled) | {:.4} µm |", d.noise_sigma_um);
    let m = &d.matching;
    let _ = writeln!(
        o,
        "| rows: recorded / simulated / matched / used | {} / {} / {} / {} |",
        m.recorded_rows, m.simulated_rows, m.matched_rows, m.used_rows
    );
    let _ = writeln!(
        o,
        "| left out: only recorded / only simulated / flagged / duplicate keys / non-finite / other axis | {} / {} / {} / {} / {} / {} |",
        m.only_in_recorded,
        m.only_in_simulated,
        m.flagged_rows,
        m.duplicate_keys,
        m.non_finite_rows,
        m.other_axis_rows
    );

    let _ = writeln!(o, "\n## Found effects\n");
    if d.effects.is_empty() {
        let _ = writeln!(o, "None.");
    }
    for (k, e) in d.effects.iter().enumerate() {
        let _ = writeln!(
            o,
            "### {}. `{}` — explains {:.4} µm RMS\n",
            k + 1,
            e.id(),
            e.explains_um
        );
        for (name, v) in &e.effect.params_by_name() {
            match (v.as_f64(), e.uncertainty.get(name)) {
                (Some(x), Some(s)) if *s > 0.0 => {
                    let _ = writeln!(o, "- {name} = {x:.6} ± {s:.6}");
                }
                (Some(x), _) => {
                    let _ = writeln!(o, "- {name} = {x} (fixed)");
                }
                _ => {
                    let _ = writeln!(o, "- {name} = {v}");
                }
            }
        }
        let _ = writeln!(o, "\nWhere: {}\n", e.where_);
    }
    if !d.ambiguities.is_empty() {
        let _ = writeln!(o, "\n## Ambiguities and refused effects\n");
        for a in &d.ambiguities {
            let _ = writeln!(o, "- {a}");
        }
    }
    if !d.design_notes.is_empty() {
        let _ = writeln!(o, "\n## Limits of this data set\n");
        for a in &d.design_notes {
            let _ = writeln!(o, "- {a}");
        }
    }

    let l = &d.locate;
    let _ = writeln!(o, "\n## Where the residual is significant\n");
    for f in &l.findings {
        let _ = writeln!(o, "- {f}");
    }
    if let Some(u) = &l.unexplained {
        let _ = writeln!(o, "- **left after the model:** {u}");
    }
    let _ = writeln!(
        o,
        "\nGroup means are weighted (1/σ² of the noise groups); z = mean / standard error; ** marks |z| > 5."
    );
    table(&mut o, "Along the axis", &l.along_x);
    table(&mut o, "Per line", &l.per_line);
    table(&mut o, "Per run", &l.per_run);
    table(&mut o, "Per direction", &l.per_direction);
    table(&mut o, "Direction-signed, per feed", &l.per_feed_signed);
    table(&mut o, "Over time", &l.over_time);
    let _ = writeln!(
        o,
        "\n**Correlations**\n\n| covariate | ρ before | ρ after |\n|---|---|---|"
    );
    for c in &l.correlations {
        let _ = writeln!(
            o,
            "| {} | {:+.3} | {:+.3} |",
            c.covariate, c.before, c.after
        );
    }
    let _ = writeln!(
        o,
        "\n**Periodogram peaks** (weighted Lomb–Scargle over the exact positions)\n\n| period µm | searched as | Δχ² |\n|---|---|---|"
    );
    for p in &l.spectral_peaks {
        let _ = writeln!(
            o,
            "| {:.5} | {} | {:.1} |",
            p.period_um, p.source, p.delta_chi2
        );
    }

    let _ = writeln!(o, "\n## Model selection\n");
    let _ = writeln!(
        o,
        "Forward selection by BIC = n·ln(χ²/n) + k·ln n, backward check, leave-one-{}-out cross-validation, then the determinedness rule. ΔBIC of every testable effect against the final model (found: the cost of removing it; not found: the change when adding it):\n",
        d.cv_folds
    );
    let _ = writeln!(o, "| effect | found | ΔBIC |\n|---|---|---|");
    for c in &d.candidates {
        let _ = writeln!(
            o,
            "| {} | {} | {:+.1} |",
            c.label(),
            if c.found { "yes" } else { "no" },
            c.delta_bic
        );
    }
    let _ = writeln!(o);
    for s in &d.selection_log {
        let _ = writeln!(o, "1. {s}");
    }
    let _ = writeln!(
        o,
        "\n**Noise per group**\n\n| group | rows | σ µm |\n|---|---|---|"
    );
    for g in &d.noise_groups {
        let _ = writeln!(o, "| {} | {} | {:.4} |", g.group, g.rows, g.sigma_um);
    }
    let _ = writeln!(o, "\n## Figures\n");
    for (title, file) in figs {
        let _ = writeln!(o, "![{title}]({file})\n");
    }
    o
}
