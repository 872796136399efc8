//! The ISO 230-2 / VDI/DGQ 3441 report section and its deviation chart, from the numbers
//! of [`crate::session::iso230`].

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::ReportError;
use crate::plot::{self, PlotError, XySeries, XyStyle};
use crate::session::iso230::{AxisStats, TargetStats};

/// A Markdown report section: the sign convention, a per-target table and the axis
/// values with ISO 230-2's symbols, then the VDI/DGQ 3441 values. µm to 3 decimals.
pub fn markdown(stats: &AxisStats, axis_name: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Positioning accuracy of axis {axis_name} (ISO 230-2)\n"
    );
    let _ = writeln!(
        s,
        "Positional deviations x = P_ij − P_i (laser − indicated) = −e, µm, where e = indicated \
         − reference is errmap's error. ↑ is an approach in the positive direction, ↓ in the \
         negative one. s uses n − 1.\n"
    );
    let header = [
        "i", "P_i mm", "n↑", "n↓", "x̄_i↑", "x̄_i↓", "x̄_i", "B_i", "s_i↑", "s_i↓", "R_i↑", "R_i↓",
        "R_i",
    ];
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let _ = writeln!(s, "|{}", "---:|".repeat(header.len()));
    for t in &stats.targets {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            t.target,
            t.position_mm,
            t.n_up,
            t.n_down,
            t.mean_up_um,
            t.mean_down_um,
            t.mean_bidir_um,
            t.reversal_um,
            t.s_up_um,
            t.s_down_um,
            t.repeat_up_um,
            t.repeat_down_um,
            t.repeat_bidir_um
        );
    }

    let _ = writeln!(s, "\n| axis value | symbol | ↑ | ↓ | bidirectional |");
    let _ = writeln!(s, "|---|---|---:|---:|---:|");
    let rows = [
        (
            "accuracy of positioning",
            "A",
            Some(stats.a_up_um),
            Some(stats.a_down_um),
            stats.a_um,
        ),
        (
            "repeatability of positioning",
            "R",
            Some(stats.r_up_um),
            Some(stats.r_down_um),
            stats.r_um,
        ),
        (
            "systematic positional deviation",
            "E",
            Some(stats.e_up_um),
            Some(stats.e_down_um),
            stats.e_um,
        ),
        (
            "mean bidirectional positional deviation",
            "M",
            None,
            None,
            stats.m_um,
        ),
        ("reversal value", "B", None, None, stats.b_um),
        (
            "mean reversal value",
            "B̄",
            None,
            None,
            stats.mean_reversal_um,
        ),
    ];
    let cell = |v: Option<f64>| v.map_or_else(|| "—".to_string(), |v| format!("{v:.3}"));
    for (name, symbol, up, down, bi) in rows {
        let _ = writeln!(
            s,
            "| {name} | {symbol} | {} | {} | {bi:.3} |",
            cell(up),
            cell(down)
        );
    }

    let v = &stats.vdi;
    let _ = writeln!(
        s,
        "\nVDI/DGQ 3441 (±3s scatter, Ps_i = 6 (s_i↑ + s_i↓)/2, U_i = |B_i|): position \
         uncertainty P = {:.3} µm, position deviation Pa = {:.3} µm, position scatter \
         Ps max = {:.3} µm (mean {:.3} µm), reversal span U max = {:.3} µm (mean {:.3} µm).",
        v.p_um, v.pa_um, v.ps_max_um, v.ps_mean_um, v.u_max_um, v.u_mean_um
    );
    let n_min = stats
        .targets
        .iter()
        .map(|t| t.n_up.min(t.n_down))
        .min()
        .unwrap_or(0);
    if n_min < 5 {
        let _ = writeln!(
            s,
            "\nNote: at least one target has fewer than the 5 runs per direction of ISO 230-2's \
             standard test cycle (fewest: {n_min})."
        );
    }
    s
}

/// Deviation chart as calibration labs draw it: mean deviation `x̄_i↑` and `x̄_i↓` against
/// target position, each with its `x̄ ± 2s` limits as separate lines, written to
/// `<stem>.png` and `<stem>.svg` (see [`plot::xy`]). Targets are drawn in order of
/// position. Returns the two paths, PNG first.
pub fn plot(stats: &AxisStats, stem: &Path, title: &str) -> Result<Vec<PathBuf>, PlotError> {
    let mut t: Vec<&TargetStats> = stats.targets.iter().collect();
    t.sort_by(|a, b| a.position_mm.total_cmp(&b.position_mm));
    let x: Vec<f64> = t.iter().map(|s| s.position_mm).collect();
    let line = |name: &str, f: &dyn Fn(&TargetStats) -> f64| XySeries {
        name: name.to_owned(),
        x: x.clone(),
        y: t.iter().map(|s| f(s)).collect(),
        style: XyStyle::Line,
    };
    // Plain "mean x" rather than x̄: the combining macron does not render in the PNG.
    let series = [
        line("mean x↑ (positive approach)", &|s| s.mean_up_um),
        line("mean x↓ (negative approach)", &|s| s.mean_down_um),
        line("mean x↑ + 2s↑", &|s| s.mean_up_um + 2.0 * s.s_up_um),
        line("mean x↑ − 2s↑", &|s| s.mean_up_um - 2.0 * s.s_up_um),
        line("mean x↓ + 2s↓", &|s| s.mean_down_um + 2.0 * s.s_down_um),
        line("mean x↓ − 2s↓", &|s| {
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
/// `report.md` with the environment and a section per line, and a deviation chart per
/// line (`lineN.png`/`.svg`). `source` names the session; returns the path of
/// `report.md`.
pub fn write_session_report(
    source: &str,
    axis: &str,
    environment: &str,
    iso: &[((f64, f64), AxisStats)],
    dir: &Path,
) -> Result<PathBuf, ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut md = format!(
        "# ISO 230-2 positioning statistics\n\nSession: `{source}`; axis {axis}; {} line(s).\n\n",
        iso.len()
    );
    md.push_str(environment);
    md.push('\n');
    for (k, (line, stats)) in iso.iter().enumerate() {
        let _ = write!(md, "## Line {} at ({}, {}) mm\n\n", k + 1, line.0, line.1);
        md.push_str(
            &markdown(stats, axis)
                .replace("\n## ", "\n### ")
                .replacen("## ", "### ", 1),
        );
        let stem = dir.join(format!("line{}", k + 1));
        plot(
            stats,
            &stem,
            &format!("Axis {axis}, line ({}, {}) mm", line.0, line.1),
        )?;
        let _ = write!(md, "\n![line {}](line{}.png)\n\n", k + 1, k + 1);
    }
    let p = dir.join("report.md");
    std::fs::write(&p, md).map_err(|source| ReportError::Io {
        path: p.clone(),
        source,
    })?;
    Ok(p)
}
