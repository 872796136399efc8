//! The deviation chart of a line in ISO 230-2's style, drawn as vector graphics: ↑ blue,
//! ↓ red; means solid with a dot at each target, x̄ ± 2s dashed; targets marked on both
//! edges.

use super::layout::{GREY, INK, MARGIN, Sheet};
use super::pdf::{Doc, PAGE_W, Rgb, Weight};
use crate::session::{AxisStats, TargetStats};

const UP: Rgb = (0.12, 0.47, 0.71);
const DOWN: Rgb = (0.84, 0.15, 0.16);

use crate::plot::round_ticks as ticks;

/// The deviation chart: ↑ blue, ↓ red; means solid with a dot at each target, ±2s dashed.
pub(super) fn chart(flow: &mut Sheet, stats: &AxisStats, axis: &str) {
    let h = 160.0;
    flow.need(h + 70.0);
    flow.y -= 12.0;
    flow.doc.text(
        MARGIN,
        flow.y,
        10.0,
        Weight::Bold,
        &format!("Positional deviation along {axis} (ISO 230-2)"),
    );
    let mut t: Vec<&TargetStats> = stats.targets.iter().collect();
    t.sort_by(|a, b| a.position_mm.total_cmp(&b.position_mm));
    let b = ChartBox::new(&t, flow.y - 10.0, h);
    chart_grid(&mut flow.doc, &b, &t);
    chart_series(&mut flow.doc, &b, &t);
    flow.y = chart_legend(&mut flow.doc, &b);
}

/// The chart's area on the page (points) and the data range it shows.
struct ChartBox {
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    xlo: f64,
    xhi: f64,
    ylo: f64,
    yhi: f64,
}

impl ChartBox {
    /// A box `h` high with its top at `top`, over the targets' positions and their
    /// x̄ ± 2s bands, padded.
    fn new(t: &[&TargetStats], top: f32, h: f32) -> Self {
        let (x0, x1) = (MARGIN + 42.0, PAGE_W - MARGIN - 8.0);
        let (y1, y0) = (top, top - h);
        let bands = |s: &TargetStats| {
            [
                s.mean_up_um + 2.0 * s.s_up_um,
                s.mean_up_um - 2.0 * s.s_up_um,
                s.mean_down_um + 2.0 * s.s_down_um,
                s.mean_down_um - 2.0 * s.s_down_um,
            ]
        };
        let ys: Vec<f64> = t.iter().flat_map(|s| bands(s)).collect();
        let (mut ylo, mut yhi) = (
            ys.iter().copied().fold(f64::INFINITY, f64::min),
            ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let pad = ((yhi - ylo) * 0.08).max(1e-6);
        ylo -= pad;
        yhi += pad;
        let (plo, phi) = (
            t.first().map_or(0.0, |s| s.position_mm),
            t.last().map_or(1.0, |s| s.position_mm),
        );
        let xpad = ((phi - plo) * 0.04).max(1e-6);
        Self {
            x0,
            x1,
            y0,
            y1,
            xlo: plo - xpad,
            xhi: phi + xpad,
            ylo,
            yhi,
        }
    }

    fn px(&self, x: f64) -> f32 {
        self.x0 + ((x - self.xlo) / (self.xhi - self.xlo)) as f32 * (self.x1 - self.x0)
    }

    fn py(&self, y: f64) -> f32 {
        self.y0 + ((y - self.ylo) / (self.yhi - self.ylo)) as f32 * (self.y1 - self.y0)
    }
}

/// The frame, the grid with its labels, a tick at each target along both edges, and
/// the zero line.
fn chart_grid(doc: &mut Doc, b: &ChartBox, t: &[&TargetStats]) {
    let (x0, x1, y0, y1) = (b.x0, b.x1, b.y0, b.y1);
    doc.rect(x0, y0, x1 - x0, y1 - y0, 0.6, INK);
    let yt = ticks(b.ylo, b.yhi, 6);
    let step = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
    let yd = (-step.log10().floor()).max(0.0) as usize;
    for v in &yt {
        let y = b.py(*v);
        doc.polyline(&[(x0, y), (x1, y)], 0.2, (0.85, 0.85, 0.85), None);
        doc.text_right(
            x0 - 3.0,
            y - 2.5,
            7.0,
            Weight::Regular,
            &format!("{v:.yd$}"),
        );
    }
    let xt = ticks(b.xlo, b.xhi, 8);
    let xs = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
    let xd = (-xs.log10().floor()).max(0.0) as usize;
    for v in &xt {
        doc.text_centre(
            b.px(*v),
            y0 - 10.0,
            7.0,
            Weight::Regular,
            &format!("{v:.xd$}"),
        );
    }
    // Targets marked: a tick at each target position along both edges.
    for s in t {
        let x = b.px(s.position_mm);
        doc.polyline(&[(x, y0), (x, y0 + 5.0)], 0.8, INK, None);
        doc.polyline(&[(x, y1), (x, y1 - 5.0)], 0.8, INK, None);
    }
    if b.ylo < 0.0 && b.yhi > 0.0 {
        doc.polyline(&[(x0, b.py(0.0)), (x1, b.py(0.0))], 0.5, GREY, None);
    }
}

/// Per direction: the mean deviations solid with a dot at each target, x̄ ± 2s dashed.
fn chart_series(doc: &mut Doc, b: &ChartBox, t: &[&TargetStats]) {
    let series = |f: &dyn Fn(&TargetStats) -> f64| -> Vec<(f32, f32)> {
        t.iter()
            .map(|s| (b.px(s.position_mm), b.py(f(s))))
            .collect()
    };
    let dash = Some([3.5, 2.5]);
    for (colour, mean, hi, lo) in [
        (
            UP,
            series(&|s| s.mean_up_um),
            series(&|s| s.mean_up_um + 2.0 * s.s_up_um),
            series(&|s| s.mean_up_um - 2.0 * s.s_up_um),
        ),
        (
            DOWN,
            series(&|s| s.mean_down_um),
            series(&|s| s.mean_down_um + 2.0 * s.s_down_um),
            series(&|s| s.mean_down_um - 2.0 * s.s_down_um),
        ),
    ] {
        doc.polyline(&mean, 1.2, colour, None);
        doc.polyline(&hi, 0.8, colour, dash);
        doc.polyline(&lo, 0.8, colour, dash);
        for &(x, y) in &mean {
            doc.dot(x, y, 1.8, colour);
        }
    }
}

/// The axis titles and the legend below the chart; returns where the text continues.
fn chart_legend(doc: &mut Doc, b: &ChartBox) -> f32 {
    let (x0, x1, y0, y1) = (b.x0, b.x1, b.y0, b.y1);
    doc.text_centre(
        (x0 + x1) / 2.0,
        y0 - 21.0,
        7.5,
        Weight::Regular,
        "target position P_i / mm",
    );
    doc.text(MARGIN, y1 + 3.0, 7.5, Weight::Regular, "x / µm");
    let ly = y0 - 34.0;
    let mut lx = x0;
    for (colour, label, dashed) in [
        (UP, "mean x̄↑", false),
        (UP, "x̄↑ ± 2s↑", true),
        (DOWN, "mean x̄↓", false),
        (DOWN, "x̄↓ ± 2s↓", true),
    ] {
        doc.polyline(
            &[(lx, ly + 2.5), (lx + 22.0, ly + 2.5)],
            if dashed { 0.8 } else { 1.2 },
            colour,
            dashed.then_some([3.5, 2.5]),
        );
        doc.text(lx + 26.0, ly, 7.5, Weight::Regular, label);
        lx += 26.0 + doc.width(label, 7.5, Weight::Regular) + 18.0;
    }
    ly - 10.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        assert_eq!(ticks(0.0, 10.0, 5), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        // 0.065 / 6 = 0.0108: the next 1-2-5 step up is 0.02.
        let t = ticks(-0.013, 0.052, 6);
        assert!(t.iter().all(|v| (-0.013..=0.052).contains(v)), "{t:?}");
        assert_eq!(t, vec![0.0, 0.02, 0.04]);
    }
}
