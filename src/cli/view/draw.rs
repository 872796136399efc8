//! Drawing the live view: a [`ViewState`] onto a ratatui frame. Pure (no terminal, no
//! clock): the tests draw onto ratatui's `TestBackend` and read the buffer.
//!
//! Layout: a title line; on the left the current readings, the run/direction/target
//! progress with the current pass's target means, and the decoder's health; on the right
//! the chart of mean error against position at each target, one line per pass.

use errmap::drivers::edlen::refractive_index;
use errmap::drivers::rotary::RotaryAxis;
use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Borders, Chart, Dataset, GraphType, Paragraph};

use super::state::{self, Counter, Reading, Units, ViewState};

/// A health counter stays highlighted this long after it moved, s.
pub(crate) const FRESH_S: f64 = 3.0;

/// The chart's colours, one per pass (cycled).
const PALETTE: [Color; 8] = [
    Color::Cyan,
    Color::Yellow,
    Color::Green,
    Color::Magenta,
    Color::LightBlue,
    Color::LightRed,
    Color::White,
    Color::LightGreen,
];

/// Draws `s`; the chart from `chart` (a paused chart) or from `s`.
pub(crate) fn draw(f: &mut Frame, s: &ViewState, paused: Option<&state::Chart>) {
    let [top, body] = Layout::vertical([Constraint::Length(1), Constraint::Min(0)]).areas(f.area());
    f.render_widget(Paragraph::new(title(s, paused.is_some())), top);
    let [left, right] =
        Layout::horizontal([Constraint::Length(46), Constraint::Min(20)]).areas(body);
    let [readings, progress, health] = Layout::vertical([
        Constraint::Length(9),
        Constraint::Min(6),
        Constraint::Length(10),
    ])
    .areas(left);
    f.render_widget(readings_widget(s), readings);
    f.render_widget(progress_widget(s), progress);
    f.render_widget(health_widget(s), health);
    let live;
    let chart = match paused {
        Some(c) => c,
        None => {
            live = s.chart();
            &live
        }
    };
    draw_chart(f, chart, s.units, paused.is_some(), right);
}

fn title(s: &ViewState, paused: bool) -> Line<'static> {
    let device = s.hello.map_or_else(
        || "no HELLO yet".to_string(),
        |h| {
            let rotary = RotaryAxis::from_code(h.axis_code).map(|a| format!("{a} (rotary)"));
            let axis = h
                .axis()
                .map(|a| a.to_string())
                .or(rotary)
                .unwrap_or_else(|| format!("code {}", h.axis_code));
            format!("device {} · axis {axis}", h.device_id.as_string())
        },
    );
    Line::from(vec![
        Span::styled(
            " errmap capture ",
            Style::new().add_modifier(Modifier::BOLD | Modifier::REVERSED),
        ),
        Span::raw(format!(
            " {device} · {:.1} s · {} · {} rows   ",
            s.elapsed_s,
            human_bytes(s.bytes),
            s.rows
        )),
        Span::styled(
            if paused {
                "q stop · p resume chart"
            } else {
                "q stop · p pause chart"
            },
            Style::new().fg(Color::DarkGray),
        ),
    ])
}

fn human_bytes(b: u64) -> String {
    match b {
        0..1_000 => format!("{b} B"),
        1_000..1_000_000 => format!("{:.1} kB", b as f64 / 1e3),
        _ => format!("{:.1} MB", b as f64 / 1e6),
    }
}

fn opt(v: Option<f64>, prec: usize, unit: &str) -> String {
    v.map_or_else(|| "—".to_string(), |v| format!("{v:.prec$} {unit}"))
}

/// The refractive index the decoder used for this row's laser length: the modified
/// Edlén equation at the row's air values and the HELLO's wavelength, 1 before any ENV.
pub(crate) fn n_air(s: &ViewState, r: &Reading) -> Option<f64> {
    let h = s.hello?;
    match (r.air_temp_c, r.air_pressure_hpa, r.air_rh_pct) {
        (Some(t), Some(p), Some(rh)) => Some(refractive_index(
            f64::from(h.laser_wavelength_fm) / 1e9,
            t,
            p * 100.0,
            rh,
        )),
        _ => Some(1.0),
    }
}

fn readings_widget(s: &ViewState) -> Paragraph<'static> {
    let block = Block::default().borders(Borders::ALL).title(" Readings ");
    let Some(r) = s.latest else {
        return Paragraph::new("waiting for the first sample…").block(block);
    };
    let err_style = if r.flags != 0 {
        Style::new().fg(Color::Red)
    } else {
        Style::new().add_modifier(Modifier::BOLD)
    };
    let rotary = matches!(s.units, Units::Rotary(_));
    let n = if rotary {
        // An angle is a ratio of lengths: no air index enters it.
        "— (an angle needs none)".to_string()
    } else {
        n_air(s, &r).map_or_else(|| "—".to_string(), |n| format!("{n:.8}"))
    };
    let (pos_name, ref_name, mat) = if rotary {
        ("angle     ", "reference ", ("encoder", "table"))
    } else {
        ("position  ", "laser     ", ("scale", "part"))
    };
    // ° and ″ follow the number; mm and µm after a space.
    let (pu, eu) = if rotary {
        ("°".to_string(), "″".to_string())
    } else {
        (" mm".to_string(), " µm".to_string())
    };
    let err_prec = if rotary { 2 } else { 3 };
    let lines = vec![
        Line::from(format!(
            "{pos_name}{:>12.4}{pu}   t {:.2} s",
            r.position, r.t_s
        )),
        Line::from(format!("{ref_name}{:>12.4}{pu}", r.reference)),
        Line::from(vec![
            Span::raw("error     "),
            Span::styled(format!("{:>12.err_prec$}{eu}", r.error), err_style),
            Span::raw(if r.flags != 0 {
                format!("   flags {:#04x}", r.flags)
            } else {
                String::new()
            }),
        ]),
        // A rotary board reports the air's temperature only.
        Line::from(if rotary {
            format!("air       {}", opt(r.air_temp_c, 2, "°C"))
        } else {
            format!(
                "air       {}  {}  {}",
                opt(r.air_temp_c, 2, "°C"),
                opt(r.air_pressure_hpa, 1, "hPa"),
                opt(r.air_rh_pct, 0, "%RH")
            )
        }),
        Line::from(format!("n air     {n}")),
        Line::from(format!(
            "material  {} {}  {} {}",
            mat.0,
            opt(r.scale_temp_c, 2, "°C"),
            mat.1,
            opt(r.part_temp_c, 2, "°C")
        )),
    ];
    Paragraph::new(lines).block(block)
}

fn progress_widget(s: &ViewState) -> Paragraph<'static> {
    let block = Block::default().borders(Borders::ALL).title(" Progress ");
    let Some(r) = s.latest else {
        return Paragraph::new("").block(block);
    };
    let mut lines = Vec::new();
    if r.run == 0 {
        lines.push(Line::from("outside any run"));
    } else {
        let of = s
            .targets_per_pass
            .map_or_else(String::new, |n| format!(" of {n}"));
        let at = if r.target >= 0 {
            format!("dwelling at target {}{of}", r.target + 1)
        } else {
            "moving".to_string()
        };
        lines.push(Line::from(vec![
            Span::styled(
                format!("run {} {}", r.run, state::direction_sign(r.direction)),
                Style::new().add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!("  {at}")),
        ]));
    }
    // The current pass's targets, or the last pass's when between passes.
    if let Some(t) = s.current().or(s.traces.back()) {
        lines.push(Line::from(Span::styled(
            format!(
                "{:<8}{:>12}{:>12}{:>8}",
                t.label(),
                format!("{} {}", position_symbol(s.units), s.units.position()),
                format!("e {}", s.units.error()),
                "n"
            ),
            Style::new().add_modifier(Modifier::UNDERLINED),
        )));
        for (k, m) in t.targets.iter().rev().take(12).rev() {
            lines.push(Line::from(format!(
                "target{:>2}{:>12.3}{:>12.3}{:>8}",
                k + 1,
                m.position(),
                m.error(),
                m.n
            )));
        }
    }
    Paragraph::new(lines).block(block)
}

fn counter(name: &str, c: Counter, now_s: f64, extra: String) -> Line<'static> {
    let style = match c.changed_at_s {
        Some(t) if now_s - t <= FRESH_S => Style::new()
            .fg(Color::Red)
            .add_modifier(Modifier::BOLD | Modifier::REVERSED),
        _ if c.count > 0 => Style::new().fg(Color::Red).add_modifier(Modifier::BOLD),
        _ => Style::new().fg(Color::Green),
    };
    Line::from(vec![
        Span::raw(format!("{name:<14}")),
        Span::styled(format!("{:>8}", c.count), style),
        Span::raw(extra),
    ])
}

fn health_widget(s: &ViewState) -> Paragraph<'static> {
    let h = &s.health;
    let now = s.elapsed_s;
    let mut lines = vec![
        counter("CRC failures", h.crc_failures, now, String::new()),
        counter(
            "resyncs",
            h.resyncs,
            now,
            format!("  ({} B skipped)", h.bytes_skipped),
        ),
        counter(
            "seq gaps",
            h.seq_gaps,
            now,
            format!("  ({} frames lost)", h.frames_lost),
        ),
        counter("beam low", h.beam_low, now, String::new()),
        counter("overrun", h.overrun, now, String::new()),
        counter("quadrature", h.quadrature, now, String::new()),
        counter("other", h.other, now, String::new()),
    ];
    if let Some((t, what)) = &s.last_problem {
        lines.push(Line::from(Span::styled(
            format!("last: {what} ({:.0} s ago)", (now - t).max(0.0)),
            Style::new().fg(Color::Red),
        )));
    }
    Paragraph::new(lines).block(
        Block::default()
            .borders(Borders::ALL)
            .title(" Decoder health "),
    )
}

fn labels(lo: f64, hi: f64, prec: usize) -> Vec<Span<'static>> {
    [lo, 0.5 * (lo + hi), hi]
        .iter()
        .map(|v| Span::raw(format!("{v:.prec$}")))
        .collect()
}

/// "x" for a linear position, "θ" for an angle.
fn position_symbol(u: Units) -> &'static str {
    match u {
        Units::Linear => "x",
        Units::Rotary(_) => "θ",
    }
}

fn draw_chart(f: &mut Frame, chart: &state::Chart, units: Units, paused: bool, area: Rect) {
    let (eu, pu) = (units.error(), units.position());
    let what = match units {
        Units::Linear => "position",
        Units::Rotary(_) => "angle",
    };
    let title = if paused {
        format!(" error {eu} against {what} {pu} — PAUSED ")
    } else {
        format!(" error {eu} against {what} {pu}, target means per pass ")
    };
    let block = Block::default().borders(Borders::ALL).title(title);
    let Some(((x0, x1), (y0, y1))) = chart.bounds() else {
        f.render_widget(
            Paragraph::new("no target mean yet: the chart starts at the first dwell").block(block),
            area,
        );
        return;
    };
    let datasets: Vec<Dataset> = chart
        .series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            Dataset::default()
                .name(s.label.clone())
                .marker(Marker::Braille)
                .graph_type(GraphType::Line)
                .style(Style::new().fg(PALETTE[k % PALETTE.len()]))
                .data(&s.points)
        })
        .collect();
    let w = Chart::new(datasets)
        .block(block)
        .x_axis(
            Axis::default()
                .title(format!("{} {pu}", position_symbol(units)))
                .bounds([x0, x1])
                .labels(labels(x0, x1, 0)),
        )
        .y_axis(
            Axis::default()
                .title(format!("e {eu}"))
                .bounds([y0, y1])
                .labels(labels(y0, y1, 2)),
        )
        .legend_position(Some(ratatui::widgets::LegendPosition::TopLeft))
        .hidden_legend_constraints((Constraint::Percentage(50), Constraint::Percentage(60)));
    f.render_widget(w, area);
}
