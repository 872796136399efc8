//! Inline SVG charts for the pages. Every data point carries `data-tip`, the text the
//! page's script shows when pointing at it (what it is, and its value with its unit);
//! every axis says its unit. The styles are the reports': the ISO 230-2 deviation chart
//! (↑ blue, ↓ red, means solid with markers, x̄ ± 2s dashed) and the ballbar polar plot
//! (the trace magnified about the nominal circle, rings every `µm per division`).

use std::fmt::Write;

use super::html::esc;

/// The Tableau 10 colours the reports use (`plot`'s palette): blue, orange, green, red…
pub(crate) const PALETTE: [&str; 10] = [
    "#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2", "#edc948", "#b07aa1", "#ff9da7",
    "#9c755f", "#bab0ac",
];

/// One point and what pointing at it says.
#[derive(Debug, Clone)]
pub(crate) struct Pt {
    pub x: f64,
    pub y: f64,
    pub tip: String,
}

/// A line of points.
#[derive(Debug, Clone)]
pub(crate) struct Series {
    pub name: String,
    pub colour: &'static str,
    pub dashed: bool,
    pub markers: bool,
    pub points: Vec<Pt>,
}

/// A shaded band between `lo` and `hi` at the same `x`.
#[derive(Debug, Clone)]
pub(crate) struct Band {
    pub colour: &'static str,
    pub x: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

const W: f64 = 760.0;
const H: f64 = 380.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 70.0;

/// Round tick positions covering `[lo, hi]`, about six (the reports' rule).
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    errmap::plot::round_ticks(lo, hi, 6)
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        return (lo - 1.0, hi + 1.0);
    }
    let pad = (hi - lo) * 0.05;
    (lo - pad, hi + pad)
}

fn label(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// An x axis given by the page: its name with its unit, the range shown and the ticks
/// with their labels (angles in degrees, calendar dates).
#[derive(Debug, Clone)]
pub(crate) struct XAxis {
    pub label: String,
    pub range: (f64, f64),
    pub ticks: Vec<(f64, String)>,
}

/// An x–y chart: `series` drawn over `bands`, a legend under the plot.
pub(crate) fn xy(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
) -> String {
    let f = Frame::around(series, bands);
    let ticks = ticks(f.x0, f.x1)
        .into_iter()
        .map(|t| (t, label(t)))
        .collect();
    draw(title, &f, ticks, x_label, y_label, series, bands)
}

/// One target of an ISO 230-2 deviation chart: its number, its position, and per
/// direction the mean deviation and its standard deviation (↑, then ↓).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DeviationTarget {
    pub target: usize,
    pub x: f64,
    pub up: (f64, f64),
    pub down: (f64, f64),
}

/// The six lines of the ISO 230-2 deviation chart (the report's): x̄↑ (blue) and x̄↓ (red)
/// solid with a marker per target, x̄ ± 2s dashed in the same colour, in position order;
/// `tip(target, line, direction, value)` says what each point is.
pub(crate) fn deviation_series(
    mut targets: Vec<DeviationTarget>,
    tip: &dyn Fn(&DeviationTarget, &str, &str, f64) -> String,
) -> Vec<Series> {
    targets.sort_by(|a, b| a.x.total_cmp(&b.x));
    let mut out = Vec::with_capacity(6);
    for (colour, dir, pick, arrow) in [
        (PALETTE[0], "↑ positive approach", 0, "↑"),
        (PALETTE[3], "↓ negative approach", 1, "↓"),
    ] {
        let of = |t: &DeviationTarget| if pick == 0 { t.up } else { t.down };
        for (name, k) in [
            (format!("mean x{arrow}"), 0.0),
            (format!("x̄{arrow} + 2s{arrow}"), 2.0),
            (format!("x̄{arrow} − 2s{arrow}"), -2.0),
        ] {
            let points = targets
                .iter()
                .map(|t| {
                    let (mean, s) = of(t);
                    let y = mean + k * s;
                    Pt {
                        x: t.x,
                        y,
                        tip: tip(t, &name, dir, y),
                    }
                })
                .collect();
            out.push(Series {
                name,
                colour,
                dashed: k != 0.0,
                markers: k == 0.0,
                points,
            });
        }
    }
    out
}

/// A calendar x axis over `lo`..`hi`, days since 1970-01-01 (UTC), padded: ticks at the
/// first step of 1, 2, 7 or 14 days, 1, 2, 3 or 6 months, or 1, 2, 5, 10, 20, 50… years
/// that gives at most seven, labelled `YYYY-MM-DD`, `YYYY-MM` or `YYYY`.
pub(crate) fn date_axis(label: &str, lo: f64, hi: f64) -> XAxis {
    let (lo, hi) = if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if hi - lo < 2.0 {
        (lo - 1.0, hi + 1.0)
    } else {
        let pad = (hi - lo) * 0.05;
        (lo - pad, hi + pad)
    };
    let mut candidates: Vec<Vec<(f64, String)>> = Vec::new();
    for step in [1.0, 2.0, 7.0, 14.0] {
        let first = (lo / step).ceil() * step;
        let n = ((hi - first) / step).floor() as i64 + 1;
        if (1..=MAX_DATE_TICKS as i64).contains(&n) {
            let date = |t: f64| errmap::history::format_utc(t as i64 * 86_400)[..10].to_string();
            candidates.push(
                (0..n)
                    .map(|k| first + k as f64 * step)
                    .map(|t| (t, date(t)))
                    .collect(),
            );
        }
    }
    candidates.extend(
        [1, 2, 3, 6]
            .into_iter()
            .filter_map(|k| month_ticks(lo, hi, k, false)),
    );
    let mut step = 1;
    while step <= 5000 {
        candidates.extend(month_ticks(lo, hi, step, true));
        // 1, 2, 5, 10, 20, 50, …
        step = if step.to_string().starts_with('2') {
            step * 5 / 2
        } else {
            step * 2
        };
    }
    XAxis {
        label: label.into(),
        range: (lo, hi),
        ticks: candidates
            .into_iter()
            .find(|t| !t.is_empty())
            .unwrap_or_default(),
    }
}

/// The most ticks a date axis takes.
const MAX_DATE_TICKS: usize = 7;

/// Ticks on the first of every `step`-th month (or of January of every `step`-th year)
/// within `lo`..`hi` (days since 1970-01-01), or None past [`MAX_DATE_TICKS`].
fn month_ticks(lo: f64, hi: f64, step: i64, years: bool) -> Option<Vec<(f64, String)>> {
    let start = errmap::history::format_utc((lo.max(0.0).floor() as i64) * 86_400);
    let (mut y, mut m): (i64, i64) = (start[0..4].parse().ok()?, start[5..7].parse().ok()?);
    let mut out = Vec::new();
    loop {
        let t = errmap::history::parse_utc(&format!("{y:04}-{m:02}-01")).ok()? as f64 / 86_400.0;
        if t > hi {
            return Some(out);
        }
        let on_step = if years {
            m == 1 && y % step == 0
        } else {
            (m - 1) % step == 0
        };
        if t >= lo && on_step {
            out.push((
                t,
                if years {
                    format!("{y:04}")
                } else {
                    format!("{y:04}-{m:02}")
                },
            ));
            if out.len() > MAX_DATE_TICKS {
                return None;
            }
        }
        (y, m) = if m == 12 { (y + 1, 1) } else { (y, m + 1) };
    }
}

/// An x–y chart on the x axis `x` (its range and ticks), the y range around the points.
pub(crate) fn xy_on(title: &str, x: &XAxis, y_label: &str, series: &[Series]) -> String {
    let mut f = Frame::around(series, &[]);
    (f.x0, f.x1) = x.range;
    draw(title, &f, x.ticks.clone(), &x.label, y_label, series, &[])
}

fn draw(
    title: &str,
    f: &Frame,
    x_ticks: Vec<(f64, String)>,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
) -> String {
    let mut s = format!(
        "<svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {W} {H}\" \
         width=\"{W}\" height=\"{H}\" role=\"img\" aria-label=\"{t}\">\
         <text x=\"{cx}\" y=\"20\" text-anchor=\"middle\" font-weight=\"600\">{t}</text>",
        t = esc(title),
        cx = W / 2.0
    );
    f.grid(&mut s, &x_ticks);
    axis_labels(&mut s, x_label, y_label);
    for b in bands {
        f.band(&mut s, b);
    }
    for se in series {
        f.line(&mut s, se);
    }
    // The points: those without markers first, so a visible marker is on top where two
    // series meet (pointing at it shows its value).
    for se in series
        .iter()
        .filter(|s| !s.markers)
        .chain(series.iter().filter(|s| s.markers))
    {
        f.points(&mut s, se);
    }
    legend(&mut s, series);
    s.push_str("</svg>");
    s
}

/// The data ranges of a chart and their place on the drawing.
struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Frame {
    /// The ranges covering every point and band, padded.
    fn around(series: &[Series], bands: &[Band]) -> Frame {
        let (x0, x1) = range(
            series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.x))
                .chain(bands.iter().flat_map(|b| b.x.iter().copied())),
        );
        let (y0, y1) = range(
            series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.y))
                .chain(bands.iter().flat_map(|b| b.lo.iter().chain(&b.hi).copied())),
        );
        Frame { x0, x1, y0, y1 }
    }

    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x0) / (self.x1 - self.x0) * (W - LEFT - RIGHT)
    }

    fn py(&self, y: f64) -> f64 {
        TOP + (self.y1 - y) / (self.y1 - self.y0) * (H - TOP - BOTTOM)
    }

    /// The grid lines and tick labels of both axes.
    fn grid(&self, s: &mut String, x_ticks: &[(f64, String)]) {
        for (t, l) in x_ticks {
            let x = self.px(*t);
            let _ = write!(
                s,
                "<line class=\"grid\" x1=\"{x:.1}\" y1=\"{TOP}\" x2=\"{x:.1}\" y2=\"{yb}\"/>\
                 <text x=\"{x:.1}\" y=\"{ty}\" text-anchor=\"middle\">{l}</text>",
                yb = H - BOTTOM,
                ty = H - BOTTOM + 15.0,
                l = esc(l)
            );
        }
        for t in ticks(self.y0, self.y1) {
            let y = self.py(t);
            let _ = write!(
                s,
                "<line class=\"grid\" x1=\"{LEFT}\" y1=\"{y:.1}\" x2=\"{xr}\" y2=\"{y:.1}\"/>\
                 <text x=\"{tx}\" y=\"{ty:.1}\" text-anchor=\"end\">{l}</text>",
                xr = W - RIGHT,
                tx = LEFT - 6.0,
                ty = y + 4.0,
                l = label(t)
            );
        }
    }

    /// A band, shaded between its upper and lower edges.
    fn band(&self, s: &mut String, b: &Band) {
        let mut d = String::new();
        for (k, (x, hi)) in b.x.iter().zip(&b.hi).enumerate() {
            let _ = write!(
                d,
                "{}{:.1},{:.1} ",
                if k == 0 { "M" } else { "L" },
                self.px(*x),
                self.py(*hi)
            );
        }
        for (x, lo) in b.x.iter().zip(&b.lo).rev() {
            let _ = write!(d, "L{:.1},{:.1} ", self.px(*x), self.py(*lo));
        }
        let _ = write!(
            s,
            "<path d=\"{d}Z\" fill=\"{}\" fill-opacity=\"0.2\" stroke=\"none\"/>",
            b.colour
        );
    }

    /// A series' line through its finite points.
    fn line(&self, s: &mut String, se: &Series) {
        let pts: Vec<String> = se
            .points
            .iter()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .map(|p| format!("{:.1},{:.1}", self.px(p.x), self.py(p.y)))
            .collect();
        let _ = write!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.6\"{}/>",
            pts.join(" "),
            se.colour,
            dash(se.dashed)
        );
    }

    /// A series' points with their tips: visible markers, or invisible targets.
    fn points(&self, s: &mut String, se: &Series) {
        let (r, opacity) = if se.markers { (4.0, "1") } else { (3.0, "0") };
        for p in se
            .points
            .iter()
            .filter(|p| p.x.is_finite() && p.y.is_finite() && !p.tip.is_empty())
        {
            let _ = write!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"{r}\" fill=\"{}\" fill-opacity=\"{opacity}\" \
                 stroke=\"none\" data-tip=\"{}\"/>",
                self.px(p.x),
                self.py(p.y),
                se.colour,
                esc(&p.tip)
            );
        }
    }
}

/// The plot's frame and the axes' names (with their units).
fn axis_labels(s: &mut String, x_label: &str, y_label: &str) {
    let _ = write!(
        s,
        "<rect class=\"axis\" x=\"{LEFT}\" y=\"{TOP}\" width=\"{w}\" height=\"{h}\" fill=\"none\"/>\
         <text x=\"{cx}\" y=\"{xy}\" text-anchor=\"middle\">{xl}</text>\
         <text transform=\"translate(16 {cy}) rotate(-90)\" text-anchor=\"middle\">{yl}</text>",
        w = W - LEFT - RIGHT,
        h = H - TOP - BOTTOM,
        cx = (LEFT + W - RIGHT) / 2.0,
        xy = H - BOTTOM + 34.0,
        cy = (TOP + H - BOTTOM) / 2.0,
        xl = esc(x_label),
        yl = esc(y_label)
    );
}

/// The stroke pattern of a dashed line (nothing for a solid one).
fn dash(dashed: bool) -> &'static str {
    if dashed {
        " stroke-dasharray=\"6 4\""
    } else {
        ""
    }
}

/// Whether a series shows on the chart: a marker at one finite point, or a line through
/// two (a line series with fewer points draws nothing).
fn drawn(se: &Series) -> bool {
    let finite = se
        .points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .count();
    finite >= if se.markers { 1 } else { 2 }
}

/// The legend: the series drawn, and only those.
fn legend(s: &mut String, series: &[Series]) {
    let mut x = LEFT;
    let y = H - 14.0;
    for se in series.iter().filter(|se| drawn(se)) {
        let _ = write!(
            s,
            "<line x1=\"{x}\" y1=\"{y0}\" x2=\"{x2}\" y2=\"{y0}\" stroke=\"{c}\" stroke-width=\"2\"{d}/>\
             <text x=\"{tx}\" y=\"{y}\">{n}</text>",
            y0 = y - 4.0,
            x2 = x + 22.0,
            c = se.colour,
            d = dash(se.dashed),
            tx = x + 26.0,
            n = esc(&se.name)
        );
        // About 7.5 px a character at 12 px: wide capitals (EWMA) do not run into the next key.
        x += 40.0 + 7.5 * se.name.chars().count() as f64;
    }
}

/// The points of a polar trace, `(angle, dr)` pairs, placed by `at` (an SVG points list).
fn polar_points(points: &[(f64, f64)], at: &dyn Fn(f64, f64) -> (f64, f64)) -> String {
    points
        .iter()
        .map(|(t, dr)| {
            let (x, y) = at(*t, *dr);
            format!("{x:.1},{y:.1}")
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The polar plot of a ballbar test (the report's chart, [`errmap::plot::PolarChart`]),
/// with a tip on every `step`-th sample.
pub(crate) fn polar(chart: &errmap::plot::PolarChart) -> String {
    const SIZE: f64 = 560.0;
    let (cx, cy, r_px) = (SIZE / 2.0, SIZE / 2.0 + 36.0, 150.0);
    let k = 25.0 / chart.um_per_div;
    let at = |t: f64, dr: f64| {
        let r = (r_px + dr * k).max(0.0);
        (cx + r * t.cos(), cy - r * t.sin())
    };
    let mut s = format!(
        "<svg class=\"chart polar\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {SIZE} {h}\" \
         width=\"{SIZE}\" height=\"{h}\" role=\"img\" aria-label=\"{t}\">\
         <text x=\"{cx}\" y=\"18\" text-anchor=\"middle\" font-weight=\"600\">{t}</text>",
        h = SIZE + 90.0,
        t = esc(&chart.title)
    );
    for ring in -4i32..=4 {
        let r = r_px + f64::from(ring) * 25.0;
        let style = if ring == 0 {
            "stroke=\"#57606a\""
        } else {
            "class=\"grid\""
        };
        let _ = write!(
            s,
            "<circle cx=\"{cx}\" cy=\"{cy}\" r=\"{r}\" fill=\"none\" {style}/>"
        );
    }
    for deg in (0..360).step_by(30) {
        let t = f64::from(deg).to_radians();
        let (x, y) = at(t, 4.0 * chart.um_per_div);
        let (lx, ly) = at(t, 5.0 * chart.um_per_div);
        let _ = write!(
            s,
            "<line class=\"grid\" x1=\"{cx}\" y1=\"{cy}\" x2=\"{x:.1}\" y2=\"{y:.1}\"/>\
             <text x=\"{lx:.1}\" y=\"{ly:.1}\" text-anchor=\"middle\">{deg}°</text>"
        );
    }
    let _ = write!(
        s,
        "<polyline points=\"{}\" fill=\"none\" stroke=\"#888\" stroke-dasharray=\"5 4\"/>",
        polar_points(&chart.lsc, &at)
    );
    let mut names = Vec::new();
    for tr in &chart.traces {
        let colour = PALETTE[tr.colour % PALETTE.len()];
        names.push((tr.name.clone(), colour));
        let _ = write!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.4\"/>",
            polar_points(&tr.points, &at)
        );
        let step = (tr.points.len() / 72).max(1);
        for (t, dr) in tr.points.iter().step_by(step) {
            let (x, y) = at(*t, *dr);
            let tip = format!(
                "{} at {:.1}°: dr = {:.3} µm (centring removed)",
                tr.name,
                t.to_degrees().rem_euclid(360.0),
                dr
            );
            let _ = write!(
                s,
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"3.5\" fill=\"{colour}\" fill-opacity=\"0.01\" \
                 data-tip=\"{}\"/>",
                esc(&tip)
            );
        }
    }
    for (t, dr) in &chart.marks {
        let (x, y) = at(*t, *dr);
        let _ = write!(
            s,
            "<path d=\"M{a:.1},{b:.1}L{c:.1},{d:.1}M{a:.1},{d:.1}L{c:.1},{b:.1}\" stroke=\"#000\"/>",
            a = x - 4.0,
            b = y - 4.0,
            c = x + 4.0,
            d = y + 4.0
        );
    }
    let mut lx = 12.0;
    for (name, colour) in &names {
        let _ = write!(
            s,
            "<line x1=\"{lx}\" y1=\"{y}\" x2=\"{x2}\" y2=\"{y}\" stroke=\"{colour}\" stroke-width=\"2\"/>\
             <text x=\"{tx}\" y=\"{ty}\">{n}</text>",
            y = SIZE + 52.0,
            x2 = lx + 20.0,
            tx = lx + 24.0,
            ty = SIZE + 56.0,
            n = esc(name)
        );
        lx += 70.0;
    }
    let _ = write!(
        s,
        "<text x=\"{x}\" y=\"{y}\" text-anchor=\"end\">{u} µm per division; nominal circle \
         solid grey, least-squares circle dashed</text></svg>",
        x = SIZE - 10.0,
        y = SIZE + 80.0,
        u = label(chart.um_per_div)
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn date_axes_tick_at_calendar_steps() {
        let day = |d: &str| errmap::history::parse_utc(d).expect("a date") as f64 / 86_400.0;
        let labels = |a: &XAxis| a.ticks.iter().map(|t| t.1.clone()).collect::<Vec<_>>();
        // Three days: every day.
        let a = date_axis("d", day("2025-03-01"), day("2025-03-04"));
        assert_eq!(
            labels(&a),
            ["2025-03-01", "2025-03-02", "2025-03-03", "2025-03-04"]
        );
        // Half a year: the first of every month, each tick at its date.
        let a = date_axis("d", day("2025-01-20"), day("2025-07-10"));
        assert_eq!(
            labels(&a),
            [
                "2025-02", "2025-03", "2025-04", "2025-05", "2025-06", "2025-07"
            ]
        );
        assert_eq!(a.ticks[0].0, day("2025-02-01"));
        // Thirty years: every five years, on the first of January.
        let a = date_axis("d", day("1995-06-01"), day("2025-06-01"));
        assert_eq!(
            labels(&a),
            ["1995", "2000", "2005", "2010", "2015", "2020", "2025"]
        );
        assert!(
            a.ticks
                .iter()
                .all(|t| (a.range.0..=a.range.1).contains(&t.0))
        );
    }

    #[test]
    fn the_legend_lists_only_what_is_drawn() {
        let pt = |x: f64, y: f64| Pt {
            x,
            y,
            tip: "p".into(),
        };
        let s = |name: &str, markers, points| Series {
            name: name.into(),
            colour: PALETTE[0],
            dashed: false,
            markers,
            points,
        };
        let svg = xy(
            "t",
            "x",
            "y",
            &[
                s("value", true, vec![pt(0.0, 1.0)]),
                s("EWMA", false, vec![pt(0.0, 1.0)]),
                s("UCL", false, vec![]),
                s("LCL", false, vec![pt(0.0, 1.0), pt(1.0, 2.0)]),
            ],
            &[],
        );
        assert!(svg.contains(">value</text>") && svg.contains(">LCL</text>"));
        assert!(!svg.contains(">EWMA</text>") && !svg.contains(">UCL</text>"));
    }

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 800.0), vec![0.0, 200.0, 400.0, 600.0, 800.0]);
        let t = ticks(-0.37, 0.52);
        assert_eq!(t.first().copied(), Some(-0.2));
        assert!(
            t.iter()
                .all(|v| (*v * 10.0 - (*v * 10.0).round()).abs() < 1e-9)
        );
    }

    #[test]
    fn every_point_carries_its_tip() {
        let s = xy(
            "t",
            "P / mm",
            "x / µm",
            &[Series {
                name: "a".into(),
                colour: PALETTE[0],
                dashed: false,
                markers: true,
                points: vec![
                    Pt {
                        x: 0.0,
                        y: 1.0,
                        tip: "first <1>".into(),
                    },
                    Pt {
                        x: 1.0,
                        y: 2.0,
                        tip: "second".into(),
                    },
                ],
            }],
            &[],
        );
        assert_eq!(s.matches("data-tip=").count(), 2);
        assert!(s.contains("data-tip=\"first &lt;1&gt;\""));
        assert!(s.contains("P / mm") && s.contains("x / µm"));
    }
}
