//! The ISO 230-2 / VDI/DGQ 3441 report section and its deviation chart, from the numbers
//! of [`crate::session::iso230`].

use std::path::{Path, PathBuf};

use super::ReportError;
use super::md::Md;
use crate::base::FileOp;
use crate::base::io_err;
use crate::plot::{self, PlotError, XySeries, XyStyle};
use crate::session::{AxisStats, TargetStats};
use crate::session::{Budget, StatUncertainty};

/// Decimals (of µm) to print a line's statistics with: three significant digits of the
/// smallest non-zero spread the test measured (the axis values `B`, `R`, `E`, `M`, `A` and
/// every `2s_i`), at least 3 (1 nm) and at most 6 (1 pm). A test whose smallest spread is
/// 0.1 µm or more prints 3 decimals; a nanometre-scale record keeps its digits (a 12 nm
/// reversal prints as 0.0120, not 0.012).
pub fn decimals(stats: &AxisStats) -> usize {
    let axis = [stats.b_um, stats.r_um, stats.e_um, stats.m_um, stats.a_um];
    let spreads = stats
        .targets
        .iter()
        .flat_map(|t| [2.0 * t.s_up_um, 2.0 * t.s_down_um]);
    let smallest = axis
        .into_iter()
        .chain(spreads)
        .map(f64::abs)
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !smallest.is_finite() {
        return 3;
    }
    (2.0 - smallest.log10().floor()).clamp(3.0, 6.0) as usize
}

/// A Markdown report section in the layout of a calibration certificate: the sign
/// convention, a per-target table (target; mean ↑ and ↓; reversal `B_i`; `2s` ↑ and ↓;
/// `R` ↑, ↓ and bidirectional), the axis values `E`, `M`, `A`, `R`, `B` with ISO 230-2's
/// symbols, then the VDI/DGQ 3441 values. µm to [`decimals`] places.
pub fn markdown(stats: &AxisStats, axis_name: &str) -> String {
    markdown_with_uncertainty(stats, axis_name, None)
}

/// [`markdown`], with the expanded uncertainty `U` beside each axis value when `u` is given
/// (see [`crate::session::Budget`]).
pub(crate) fn markdown_with_uncertainty(
    stats: &AxisStats,
    axis_name: &str,
    u: Option<&StatUncertainty>,
) -> String {
    let d = decimals(stats);
    let f = |v: f64| format!("{v:.d$}");
    let mut md = Md::new();
    md.heading(
        2,
        format_args!("Positioning accuracy of axis {axis_name} (ISO 230-2)"),
    )
    .para(
        "Positional deviations x = P_ij − P_i (laser − indicated) = −e, µm, where e = indicated \
         − reference is errmap's error. ↑ is an approach in the positive direction, ↓ in the \
         negative one. s uses n − 1.",
    );
    target_table(&mut md, stats, &f);
    md.nl();
    axis_values(&mut md, stats, u, &f);
    vdi_and_notes(&mut md, stats, u, &f);
    md.finish()
}

/// One row per target: its means, reversal, spreads and repeatabilities.
fn target_table(md: &mut Md, stats: &AxisStats, f: &dyn Fn(f64) -> String) {
    let header = [
        "target i", "P_i mm", "n↑", "n↓", "x̄_i↑", "x̄_i↓", "B_i", "2s_i↑", "2s_i↓", "R_i↑", "R_i↓",
        "R_i",
    ];
    md.table_aligned(header, &"r".repeat(header.len()));
    for t in &stats.targets {
        let head = [
            t.target.to_string(),
            t.position_mm.to_string(),
            t.n_up.to_string(),
            t.n_down.to_string(),
        ];
        md.row(head.into_iter().chain(target_values(t, f)));
    }
}

/// A target's values in µm as `f` prints them, in the order of every per-target table:
/// the means ↑ and ↓, the reversal, 2s ↑ and ↓, the repeatabilities ↑, ↓ and bidirectional.
pub(super) fn target_values(t: &TargetStats, f: &dyn Fn(f64) -> String) -> [String; 8] {
    [
        f(t.mean_up_um),
        f(t.mean_down_um),
        f(t.reversal_um),
        f(2.0 * t.s_up_um),
        f(2.0 * t.s_down_um),
        f(t.repeat_up_um),
        f(t.repeat_down_um),
        f(t.repeat_bidir_um),
    ]
}

/// The axis values E, M, A, R, B and B̄, with U beside each when it is given.
fn axis_values(
    md: &mut Md,
    stats: &AxisStats,
    u: Option<&StatUncertainty>,
    f: &dyn Fn(f64) -> String,
) {
    let mut header = vec![
        "axis value".to_string(),
        "symbol".into(),
        "↑".into(),
        "↓".into(),
        "bidirectional".into(),
    ];
    let mut align = String::from("llrrr");
    if let Some(u) = u {
        header.push(format!("U (k = {})", u.k));
        align.push('r');
    }
    md.table_aligned(header, &align);
    let travel = |u: &StatUncertainty| u.along_travel_um;
    let target = |u: &StatUncertainty| u.at_one_target_um;
    type Row<'a> = (
        &'a str,
        &'a str,
        Option<f64>,
        Option<f64>,
        f64,
        &'a dyn Fn(&StatUncertainty) -> f64,
    );
    let rows: [Row; 6] = [
        (
            "systematic positional deviation",
            "E",
            Some(stats.e_up_um),
            Some(stats.e_down_um),
            stats.e_um,
            &travel,
        ),
        (
            "mean bidirectional positional deviation",
            "M",
            None,
            None,
            stats.m_um,
            &travel,
        ),
        (
            "accuracy of positioning",
            "A",
            Some(stats.a_up_um),
            Some(stats.a_down_um),
            stats.a_um,
            &travel,
        ),
        (
            "repeatability of positioning",
            "R",
            Some(stats.r_up_um),
            Some(stats.r_down_um),
            stats.r_um,
            &target,
        ),
        ("reversal value", "B", None, None, stats.b_um, &target),
        (
            "mean reversal value",
            "B̄",
            None,
            None,
            stats.mean_reversal_um,
            &target,
        ),
    ];
    let cell = |v: Option<f64>| v.map_or_else(|| "—".to_string(), f);
    for (name, symbol, up, down, bi, which) in rows {
        let mut cells = vec![
            name.to_string(),
            symbol.to_string(),
            cell(up),
            cell(down),
            f(bi),
        ];
        if let Some(u) = u {
            cells.push(f(which(u)));
        }
        md.row(cells);
    }
}

/// The VDI/DGQ 3441 values, the expanded uncertainty in words, and a note when the test
/// has fewer runs than the standard's cycle.
fn vdi_and_notes(
    md: &mut Md,
    stats: &AxisStats,
    u: Option<&StatUncertainty>,
    f: &dyn Fn(f64) -> String,
) {
    let v = &stats.vdi;
    md.nl().line(format_args!(
        "VDI/DGQ 3441 (±3s scatter, Ps_i = 6 (s_i↑ + s_i↓)/2, U_i = |B_i|): position \
         uncertainty P = {} µm, position deviation Pa = {} µm, position scatter \
         Ps max = {} µm (mean {} µm), reversal span U max = {} µm (mean {} µm).",
        f(v.p_um),
        f(v.pa_um),
        f(v.ps_max_um),
        f(v.ps_mean_um),
        f(v.u_max_um),
        f(v.u_mean_um)
    ));
    if let Some(u) = u {
        md.nl().line(format_args!(
            "Expanded uncertainty (k = {}): U = {} µm for E, M, A, P and Pa (over the {} mm \
             travel), U = {} µm for R, B, Ps and U (at one target).",
            u.k,
            f(u.along_travel_um),
            u.travel_mm,
            f(u.at_one_target_um)
        ));
    }
    let n_min = stats
        .targets
        .iter()
        .map(|t| t.n_up.min(t.n_down))
        .min()
        .unwrap_or(0);
    if n_min < 5 {
        md.nl().line(format_args!(
            "Note: at least one target has fewer than the 5 runs per direction of ISO 230-2's \
             standard test cycle (fewest: {n_min})."
        ));
    }
}

/// Deviation chart in the style of ISO 230-2 certificates: one colour per direction
/// (↑ blue, ↓ red), the mean deviations `x̄_i↑`, `x̄_i↓` solid with a marker at each
/// target, their `x̄ ± 2s` limits dashed in the same colour; written to `<stem>.png` and
/// `<stem>.svg` (see [`plot::xy`]). Targets are drawn in order of position. Returns the
/// two paths, PNG first.
pub fn plot(stats: &AxisStats, stem: &Path, title: &str) -> Result<Vec<PathBuf>, PlotError> {
    let mut t: Vec<&TargetStats> = stats.targets.iter().collect();
    t.sort_by(|a, b| a.position_mm.total_cmp(&b.position_mm));
    let x: Vec<f64> = t.iter().map(|s| s.position_mm).collect();
    // Palette indices: 0 is blue, 3 is red (Tableau 10).
    let line =
        |name: &str, colour: usize, dashed: bool, f: &dyn Fn(&TargetStats) -> f64| XySeries {
            name: name.to_owned(),
            x: x.clone(),
            y: t.iter().map(|s| f(s)).collect(),
            style: XyStyle::Styled {
                colour,
                dashed,
                markers: !dashed,
            },
        };
    // Plain "mean x" rather than x̄: the combining macron does not render in the PNG.
    let series = [
        line("mean x↑ (positive approach)", 0, false, &|s| s.mean_up_um),
        line("mean x↑ + 2s↑", 0, true, &|s| {
            s.mean_up_um + 2.0 * s.s_up_um
        }),
        line("mean x↑ − 2s↑", 0, true, &|s| {
            s.mean_up_um - 2.0 * s.s_up_um
        }),
        line("mean x↓ (negative approach)", 3, false, &|s| {
            s.mean_down_um
        }),
        line("mean x↓ + 2s↓", 3, true, &|s| {
            s.mean_down_um + 2.0 * s.s_down_um
        }),
        line("mean x↓ − 2s↓", 3, true, &|s| {
            s.mean_down_um - 2.0 * s.s_down_um
        }),
    ];
    plot::xy(
        stem,
        title,
        "target position P_i / mm",
        "positional deviation x = −e / µm",
        &series,
    )
}

/// Writes the ISO 230-2 report of a session into `dir` (created when missing):
/// `report.md` with the environment and a section per line (with the uncertainty budget of
/// `budgets[k]` for line `k` when given), and a deviation chart per line
/// (`lineN.png`/`.svg`). `source` names the session; returns the path of
/// `report.md`.
pub fn write_session_report(
    source: &str,
    axis: &str,
    environment: &str,
    iso: &[((f64, f64), AxisStats)],
    budgets: &[Budget],
    dir: &Path,
) -> Result<PathBuf, ReportError> {
    std::fs::create_dir_all(dir).map_err(io_err(dir, FileOp::Write))?;
    let mut md = Md::new();
    md.heading(1, "ISO 230-2 positioning statistics")
        .para(format_args!(
            "Session: `{source}`; axis {axis}; {} line(s).",
            iso.len()
        ))
        .line(environment);
    for (k, (line, stats)) in iso.iter().enumerate() {
        md.heading(
            2,
            format_args!("Line {} at ({}, {}) mm", k + 1, line.0, line.1),
        );
        let budget = budgets.get(k);
        let u = budget.map(Budget::expanded);
        // The section's own headings go one level down, under the line's.
        md.raw(
            markdown_with_uncertainty(stats, axis, u.as_ref())
                .replace("\n## ", "\n### ")
                .replacen("## ", "### ", 1),
        );
        if let Some(b) = budget {
            md.nl()
                .raw(super::uncertainty::budget_markdown(b, decimals(stats)));
        }
        let stem = dir.join(format!("line{}", k + 1));
        plot(
            stats,
            &stem,
            &format!("Axis {axis}, line ({}, {}) mm", line.0, line.1),
        )?;
        md.nl()
            .para(format_args!("![line {}](line{}.png)", k + 1, k + 1));
    }
    remove_stale_line_figures(dir, iso.len())?;
    let p = dir.join("report.md");
    super::write_text(&p, md.as_str())?;
    Ok(p)
}

/// A report folder used again for a session with fewer lines: the figures of the lines
/// this report no longer has (`lineN.png`/`.svg`, N past `lines`) are the report's own
/// earlier output, and would be read as this session's. Only those names are removed.
fn remove_stale_line_figures(dir: &Path, lines: usize) -> Result<(), ReportError> {
    for n in lines + 1.. {
        let mut any = false;
        for ext in ["png", "svg"] {
            let f = dir.join(format!("line{n}.{ext}"));
            if f.is_file() {
                std::fs::remove_file(&f).map_err(io_err(&f, FileOp::Write))?;
                any = true;
            }
        }
        if !any {
            return Ok(());
        }
    }
    Ok(())
}
