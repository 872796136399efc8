//! The diagnosis report: `report.md` and PNG+SVG charts (residual before/after against
//! position and time, one partial-residual chart per found effect against the covariate it
//! follows, and the broad periodogram). Charts show at most [`MAX_POINTS`] points per
//! series (an evenly spaced subset). O(n).

use std::path::{Path, PathBuf};

use crate::plot::{self, XySeries, XyStyle};

use super::ReportError;
use super::md::Md;
use crate::base::FileOp;
use crate::base::io_err;
use crate::diagnose::{Diagnosis, GroupStat, Verdict};

/// Most points drawn per series.
pub(crate) const MAX_POINTS: usize = 4000;

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
    let mut charts = Charts {
        dir,
        files: Vec::new(),
        figs: Vec::new(),
    };
    residual_charts(d, &mut charts)?;
    effect_charts(d, &mut charts)?;
    periodogram_chart(d, &mut charts)?;
    let Charts {
        mut files, figs, ..
    } = charts;

    let mut md = Md::new();
    markdown(&mut md, d, &figs);
    // The measurement that separates effects these data could not tell apart, ready for
    // `errmap simulate --plan` (one plan file; the first when there are several).
    if let Some(sp) = d.separating_plans.first() {
        let path = dir.join("separating-plan.toml");
        super::write_bytes(&path, sp.plan_toml.as_bytes())?;
        md.nl()
            .heading(
                2,
                format_args!(
                    "Decided by physics: {} rather than {}",
                    sp.chosen.as_str(),
                    sp.other.as_str()
                ),
            )
            .para(format_args!("{}.", sp.basis))
            .line("The measurement that separates them is in `separating-plan.toml`.");
        files.push(path);
    }
    if let Some(m) = &d.static_map {
        md.nl().heading(2, "Static part taken from the recording").line(format_args!(
            "No simulation: the map and the reversal are the recording's own ({} levels, {} of them dwell means per line, target and direction; the dwell map spans {:.3} µm; reversal ē↑ − ē↓ {:.3} µm on average over {} targets, spanning {:.3} µm). The effects above are what is left.",
            m.groups,
            m.dwell_groups,
            m.map_span_um,
            m.mean_reversal_um,
            m.targets_with_reversal,
            m.reversal_span_um
        ));
    }
    if let Some(env) = environment {
        md.nl().raw(env);
    }
    let path = dir.join("report.md");
    super::write_text(&path, md.as_str())?;
    files.insert(0, path);
    Ok(files)
}

/// The charts of a report as they are drawn: the files written and each figure's caption
/// and PNG for the Markdown.
struct Charts<'a> {
    dir: &'a Path,
    files: Vec<PathBuf>,
    figs: Vec<(String, String)>,
}

impl Charts<'_> {
    /// Draws `series` as `stem` (PNG and SVG) with `title` and the axes' labels, and lists
    /// it under `caption`.
    fn add(
        &mut self,
        stem: &str,
        caption: String,
        title: &str,
        [x_label, y_label]: [&str; 2],
        series: &[XySeries],
    ) -> Result<(), ReportError> {
        self.files.extend(plot::xy(
            &self.dir.join(stem),
            title,
            x_label,
            y_label,
            series,
        )?);
        self.figs.push((caption, format!("{stem}.png")));
        Ok(())
    }
}

/// The residual before and after the found effects, against position and against time
/// (none for an empty recording).
fn residual_charts(d: &Diagnosis, charts: &mut Charts) -> Result<(), ReportError> {
    let s = &d.series;
    let all: Vec<usize> = (0..s.x_mm.len()).collect();
    if all.is_empty() {
        return Ok(());
    }
    let ax = d.axis.to_lowercase();
    let against = [
        ("x", "position", format!("{ax} / mm"), &s.x_mm),
        ("time", "time", "t / s".to_string(), &s.t_s),
    ];
    for (stem, what, x_label, x) in against {
        charts.add(
            &format!("residual_vs_{stem}"),
            format!("Residual against {what}"),
            &format!("Residual recorded − simulated against {what}"),
            [&x_label, "residual / µm"],
            &[
                points("before (about its mean)", x, &s.before_um, &all),
                points("after the found effects", x, &s.after_um, &all),
            ],
        )?;
    }
    Ok(())
}

/// One chart per found effect: the residual without the other effects against the
/// covariate the effect follows, with the fitted effect (per group when it has groups).
fn effect_charts(d: &Diagnosis, charts: &mut Charts) -> Result<(), ReportError> {
    let s = &d.series;
    let all: Vec<usize> = (0..s.x_mm.len()).collect();
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
        charts.add(
            &name,
            format!("Effect {}: {}", k + 1, e.id),
            &format!("{}: residual without the other effects", e.id),
            [&e.covariate_label, "partial residual / µm"],
            &series,
        )?;
    }
    Ok(())
}

/// The broad periodogram of the last search, when there was one.
fn periodogram_chart(d: &Diagnosis, charts: &mut Charts) -> Result<(), ReportError> {
    let s = &d.series;
    if s.broad_period_mm.is_empty() {
        return Ok(());
    }
    let idx: Vec<usize> = (0..s.broad_period_mm.len()).collect();
    charts.add(
        "periodogram",
        "Broad periodogram".into(),
        "Broad periodogram of the residual (last search)",
        ["period / mm", "Δχ² of a sine"],
        &[curve(
            "Lomb–Scargle",
            &s.broad_period_mm,
            &s.broad_power,
            &idx,
        )],
    )
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
    let md = std::fs::read_to_string(&path).map_err(io_err(&path, FileOp::Read))?;
    let mut out = Md::new();
    out.raw(md).nl()
        .heading(2, "ISO 230-2 figures with the found effects removed")
        .para("The static part (map and reversal) is the recording's own; the found effects (drift, air, feed, periodic terms) are taken out of every row and the figures computed again.")
        // The label column's header is a single space, which `Md::table` does not write.
        .line("| line (mm) | | B | B̄ | R | R↑ | R↓ | E | M | A |")
        .line("|---|---|---|---|---|---|---|---|---|---|");
    for (label, set) in [
        ("measured", &e.measured),
        ("effects removed", &e.effects_removed),
    ] {
        for f in set {
            let mut cells = vec![
                format!("{}, {}", f.line_mm[0], f.line_mm[1]),
                label.to_string(),
            ];
            cells.extend(
                [
                    f.b_um,
                    f.mean_reversal_um,
                    f.r_um,
                    f.r_up_um,
                    f.r_down_um,
                    f.e_um,
                    f.m_um,
                    f.a_um,
                ]
                .iter()
                .map(|v| format!("{v:.3}")),
            );
            out.row(cells);
        }
    }
    super::write_text(&path, out.as_str())
}

/// A table of group means before and after the found effects, under a bold title; none
/// when there are no groups.
fn table(md: &mut Md, title: &str, rows: &[GroupStat]) {
    if rows.is_empty() {
        return;
    }
    md.nl().para(format_args!("**{title}**")).table([
        "group",
        "rows",
        "mean before µm",
        "z",
        "mean after µm",
        "z after",
    ]);
    for r in rows {
        let flag = if r.z.abs() > 5.0 { " **" } else { "" };
        md.row([
            r.label.to_string(),
            r.rows.to_string(),
            format!("{:+.4}{flag}", r.mean_um),
            format!("{:.1}", r.z),
            format!("{:+.4}", r.mean_after_um),
            format!("{:.1}", r.z_after),
        ]);
    }
}

/// The diagnosis's `report.md` up to its figures, section by section.
fn markdown(md: &mut Md, d: &Diagnosis, figs: &[(String, String)]) {
    md.heading(1, "Missing-physics diagnosis");
    summary(md, d);
    found_effects(md, d);
    if !d.ambiguities.is_empty() {
        md.nl()
            .heading(2, "Ambiguities and refused effects")
            .bullets(&d.ambiguities);
    }
    if !d.design_notes.is_empty() {
        md.nl()
            .heading(2, "Limits of this data set")
            .bullets(&d.design_notes);
    }
    where_significant(md, d);
    model_selection(md, d);
    md.nl().heading(2, "Figures");
    for (title, file) in figs {
        md.para(format_args!("![{title}]({file})"));
    }
}

/// The verdict and the table of RMS, noise and row counts.
fn summary(md: &mut Md, d: &Diagnosis) {
    let verdict = if d.verdict == Verdict::Consistent {
        "**consistent** — the residual is explained by noise alone"
    } else {
        "**missing physics** — the simulation leaves out what follows"
    };
    md.para(format_args!("Verdict: {verdict}."))
        .table(["quantity", "value"]);
    let m = &d.matching;
    let rows = [
        ("measured axis".to_string(), d.axis.to_string()),
        (
            "RMS before (recorded − simulated)".into(),
            format!("{:.4} µm", d.rms_before_um),
        ),
        (
            "RMS before, about its mean".into(),
            format!("{:.4} µm", d.rms_before_centred_um),
        ),
        (
            "RMS after the found effects".into(),
            format!("{:.4} µm", d.rms_after_um),
        ),
        (
            format!("same, cross-validated (each {} held out)", d.cv_folds),
            format!("{:.4} µm", d.cv_rms_after_um),
        ),
        (
            "noise σ (pooled)".into(),
            format!("{:.4} µm", d.noise_sigma_um),
        ),
        (
            "rows: recorded / simulated / matched / used".into(),
            format!(
                "{} / {} / {} / {}",
                m.recorded_rows, m.simulated_rows, m.matched_rows, m.used_rows
            ),
        ),
        (
            "left out: only recorded / only simulated / flagged / duplicate keys / non-finite / other axis".into(),
            format!(
                "{} / {} / {} / {} / {} / {}",
                m.only_in_recorded,
                m.only_in_simulated,
                m.flagged_rows,
                m.duplicate_keys,
                m.non_finite_rows,
                m.other_axis_rows
            ),
        ),
    ];
    for (q, v) in rows {
        md.row([q, v]);
    }
}

/// Each found effect: what it explains, its parameters (± one sigma) and where it acts.
fn found_effects(md: &mut Md, d: &Diagnosis) {
    md.nl().heading(2, "Found effects");
    if d.effects.is_empty() {
        md.line("None.");
    }
    for (k, e) in d.effects.iter().enumerate() {
        md.heading(
            3,
            format_args!(
                "{}. `{}` — explains {:.4} µm RMS",
                k + 1,
                e.id(),
                e.explains_um
            ),
        );
        for (name, v) in &e.effect.params_by_name() {
            match (v.as_f64(), e.uncertainty.get(name)) {
                (Some(x), Some(s)) if *s > 0.0 => {
                    md.bullet(format_args!("{name} = {x:.6} ± {s:.6}"))
                }
                (Some(x), _) => md.bullet(format_args!("{name} = {x} (fixed)")),
                _ => md.bullet(format_args!("{name} = {v}")),
            };
        }
        md.nl().para(format_args!("Where: {}", e.where_));
    }
}

/// Where the residual is significant: the findings, the group tables, the correlations
/// and the periodogram's peaks.
fn where_significant(md: &mut Md, d: &Diagnosis) {
    let l = &d.locate;
    md.nl()
        .heading(2, "Where the residual is significant")
        .bullets(&l.findings);
    if let Some(u) = &l.unexplained {
        md.bullet(format_args!("**left after the model:** {u}"));
    }
    md.nl().line(
        "Group means are weighted (1/σ² of the noise groups); z = mean / standard error; ** marks |z| > 5.",
    );
    table(md, "Along the axis", &l.along_x);
    table(md, "Per line", &l.per_line);
    table(md, "Per run", &l.per_run);
    table(md, "Per direction", &l.per_direction);
    table(md, "Direction-signed, per feed", &l.per_feed_signed);
    table(md, "Over time", &l.over_time);
    md.nl()
        .para("**Correlations**")
        .table(["covariate", "ρ before", "ρ after"]);
    for c in &l.correlations {
        md.row([
            c.covariate.to_string(),
            format!("{:+.3}", c.before),
            format!("{:+.3}", c.after),
        ]);
    }
    md.nl()
        .para("**Periodogram peaks** (weighted Lomb–Scargle over the exact positions)")
        .table(["period µm", "searched as", "Δχ²"]);
    for p in &l.spectral_peaks {
        md.row([
            format!("{:.5}", p.period_um),
            p.source.to_string(),
            format!("{:.1}", p.delta_chi2),
        ]);
    }
}

/// How the effects were selected: ΔBIC of every candidate, the selection's log and the
/// noise per group.
fn model_selection(md: &mut Md, d: &Diagnosis) {
    md.nl().heading(2, "Model selection").para(format_args!(
        "Forward selection by BIC = n·ln(χ²/n) + k·ln n, backward check, leave-one-{}-out cross-validation, then the determinedness rule. ΔBIC of every testable effect against the final model (found: the cost of removing it; not found: the change when adding it):",
        d.cv_folds
    ));
    md.table(["effect", "found", "ΔBIC"]);
    for c in &d.candidates {
        md.row([
            c.label(),
            if c.found { "yes" } else { "no" }.into(),
            format!("{:+.1}", c.delta_bic),
        ]);
    }
    md.nl();
    for s in &d.selection_log {
        // Markdown numbers a list of `1.` items itself.
        md.line(format_args!("1. {s}"));
    }
    md.nl()
        .para("**Noise per group**")
        .table(["group", "rows", "σ µm"]);
    for g in &d.noise_groups {
        md.row([
            g.group.to_string(),
            g.rows.to_string(),
            format!("{:.4}", g.sigma_um),
        ]);
    }
}
