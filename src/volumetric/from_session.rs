//! Line tables from captured sessions: an axis-parallel line measured through the board
//! (`capture` → session table) becomes lines of the spec's line table, so captured and
//! simulated campaigns meet in one format.
//!
//! # The mapping
//!
//! A session measures along one axis (its `axis` column); the two other coordinates of
//! each dwell row are the line position the controller's MARK frames carried
//! (`wire-protocol.md`), read in whole micrometres. Every (line position, run, direction)
//! is one line of the table: a run's outward and return passes get their own free
//! constant, so a constant reversal between them cannot bias the components (a reversal
//! that changes along the axis is not a rigid-body error and shows in the residual).
//! Each target of that pass is one row:
//!
//! - the position: the mean scale reading of the target's unflagged dwell samples along
//!   the axis, the line position on the other two;
//! - `e_um`: the mean of their `error_um` — indicated − reference (scale − laser), the
//!   line table's sign, along the beam direction u = +axis;
//! - `t_s` and the temperatures: their means (a temperature only when every sample of the
//!   target has it);
//! - `s_um` is left empty: the dwell samples are correlated in time, so their s/√n
//!   would understate the target's uncertainty, and a target's repeatability is a
//!   run-to-run figure one pass cannot give. Without `s_um`, `identify` scales its σ bands
//!   by the fit's own residual.
//!
//! The probe offset is the one given (the session does not carry it). A pass with fewer
//! than [`super::lines::MIN_TARGETS`] targets is left out and counted; flagged samples
//! and samples outside a dwell do not count. Memory grows with the number of
//! (line, run, direction, target) dwells, not with the number of samples.

use std::collections::BTreeMap;

use super::lines::{Line, LineTable, MIN_TARGETS, Target};
use crate::base::Axis;
use crate::session::{LineKey, line_key};
use errmap_drivers::SessionRow;

/// The sums of one dwell (line, run, direction, target).
#[derive(Debug, Clone, Default)]
struct Dwell {
    n: usize,
    /// First error, µm: sums are of deviations from it (no cancellation).
    e0: f64,
    de: f64,
    scale_mm: f64,
    t_s: f64,
    /// Σ and count of each temperature: scale, air, part.
    temp: [(f64, usize); 3],
}

/// (line position µm, µm; run; direction; target).
type Key = (LineKey, u32, i8, i32);

/// One pass: (axis, line position µm, run, direction).
type Pass = (Axis, LineKey, u32, i8);

/// What the conversion left out, for the summary.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Conversion {
    pub rows: u64,
    pub dwell_rows: u64,
    pub flagged: u64,
    /// Dwell rows without the line position (no MARK line coordinates).
    pub no_line: u64,
    pub lines: usize,
    /// Passes left out for having fewer than three targets.
    pub short_passes: Vec<String>,
}

/// Sessions fed row by row (one or several, each along its own axis).
#[derive(Debug, Clone, Default)]
pub struct SessionLines {
    dwells: BTreeMap<(Axis, Key), Dwell>,
    conv: Conversion,
}

impl SessionLines {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one session row.
    pub fn push(&mut self, r: &SessionRow) {
        self.conv.rows += 1;
        if r.target < 0 || r.run == 0 || r.direction == 0 {
            return;
        }
        self.conv.dwell_rows += 1;
        if r.flags != 0 {
            self.conv.flagged += 1;
            return;
        }
        let axis = Axis::from(r.axis);
        let Some(line) = line_key(r, axis.index()) else {
            self.conv.no_line += 1;
            return;
        };
        let d = self
            .dwells
            .entry((axis, (line, r.run, r.direction, r.target)))
            .or_default();
        if d.n == 0 {
            d.e0 = r.error_um;
        }
        d.n += 1;
        d.de += r.error_um - d.e0;
        d.scale_mm += r.scale_mm;
        d.t_s += r.t_s;
        for (acc, v) in d
            .temp
            .iter_mut()
            .zip([r.scale_temp_c, r.air_temp_c, r.part_temp_c])
        {
            if let Some(v) = v {
                acc.0 += v;
                acc.1 += 1;
            }
        }
    }

    /// The line table (`source` names it in messages) and what was left out.
    pub fn finish(mut self, source: &str, probe_mm: [f64; 3]) -> (LineTable, Conversion) {
        // Group the dwells into passes: (axis, line, run, direction).
        let mut passes: BTreeMap<Pass, Vec<Target>> = BTreeMap::new();
        for ((axis, (line, run, dir, _)), d) in &self.dwells {
            let n = d.n as f64;
            let mut pos = [0.0; 3];
            let mut others = (0..3).filter(|&k| k != axis.index());
            pos[axis.index()] = d.scale_mm / n;
            for c in [line.0, line.1] {
                if let Some(k) = others.next() {
                    pos[k] = c as f64 / 1e3;
                }
            }
            let temp = |i: usize| (d.temp[i].1 == d.n).then(|| d.temp[i].0 / n);
            passes
                .entry((*axis, *line, *run, *dir))
                .or_default()
                .push(Target {
                    row: 0,
                    pos_mm: pos,
                    e_um: Some(d.e0 + d.de / n),
                    s_um: None,
                    t_s: Some(d.t_s / n),
                    scale_temp_c: temp(0),
                    air_temp_c: temp(1),
                    part_temp_c: temp(2),
                });
        }
        let mut lines = Vec::new();
        for ((axis, line, run, dir), mut targets) in passes {
            let id = format!(
                "{axis}@{},{}#{run}{}",
                line.0 as f64 / 1e3,
                line.1 as f64 / 1e3,
                if dir > 0 { '+' } else { '-' }
            );
            if targets.len() < MIN_TARGETS {
                self.conv.short_passes.push(id);
                continue;
            }
            // In the order of travel, so the first row is where the pass started.
            let k = axis.index();
            targets.sort_by(|a, b| a.pos_mm[k].total_cmp(&b.pos_mm[k]));
            if dir < 0 {
                targets.reverse();
            }
            let mut u = [0.0; 3];
            u[k] = 1.0;
            lines.push(Line {
                id,
                u,
                probe_mm,
                targets,
            });
        }
        self.conv.lines = lines.len();
        let mut row = 0;
        for t in lines.iter_mut().flat_map(|l| &mut l.targets) {
            row += 1;
            t.row = row;
        }
        (
            LineTable {
                source: source.to_string(),
                lines,
            },
            self.conv,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: u32, dir: i8, target: i32, x: f64, y: Option<f64>, e: f64) -> SessionRow {
        SessionRow {
            run,
            sample: 0,
            t_s: f64::from(target),
            axis: errmap_drivers::Axis::X,
            direction: dir,
            feed_mm_s: Some(10.0),
            target,
            x_mm: Some(x),
            y_mm: y,
            z_mm: Some(50.0),
            scale_mm: x,
            laser_mm: x - e * 1e-3,
            error_um: e,
            air_temp_c: None,
            air_pressure_hpa: None,
            air_rh_pct: None,
            scale_temp_c: Some(20.0 + f64::from(target)),
            part_temp_c: (target != 1).then_some(21.0),
            flags: 0,
        }
    }

    /// Three targets up and three down on y = 100: two lines; the means by hand; a flagged
    /// sample, a dwell without line position and a two-target pass left out and counted.
    #[test]
    fn passes_become_lines_with_the_dwell_means() {
        let mut acc = SessionLines::new();
        for (dir, run) in [(1i8, 1u32), (-1, 1)] {
            for t in 0..3 {
                let x = 100.0 * f64::from(t);
                for k in 0..4 {
                    acc.push(&row(
                        run,
                        dir,
                        t,
                        x,
                        Some(100.0),
                        f64::from(t) + 0.1 * f64::from(k),
                    ));
                }
            }
        }
        let mut flagged = row(1, 1, 0, 0.0, Some(100.0), 99.0);
        flagged.flags = 1;
        acc.push(&flagged);
        acc.push(&row(1, 1, 0, 0.0, None, 99.0));
        acc.push(&row(1, 1, -1, 50.0, Some(100.0), 99.0));
        for t in 0..2 {
            acc.push(&row(2, 1, t, 100.0 * f64::from(t), Some(200.0), 0.0));
        }
        let (table, conv) = acc.finish("s.csv", [0.0, 10.0, 0.0]);
        assert_eq!(table.lines.len(), 2);
        assert_eq!(conv.flagged, 1);
        assert_eq!(conv.no_line, 1);
        assert_eq!(conv.short_passes, vec!["x@200,50#2+".to_string()]);
        let up = &table.lines[1];
        assert_eq!(up.id, "x@100,50#1+");
        let down = &table.lines[0];
        assert_eq!(down.id, "x@100,50#1-");
        assert_eq!(down.targets[0].pos_mm, [200.0, 100.0, 50.0]);
        for (i, t) in up.targets.iter().enumerate() {
            // Mean of i + 0, 0.1, 0.2, 0.3.
            assert!((t.e_um.expect("e") - (i as f64 + 0.15)).abs() < 1e-12);
            assert_eq!(t.pos_mm, [100.0 * i as f64, 100.0, 50.0]);
            assert_eq!(t.scale_temp_c, Some(20.0 + i as f64));
            // Target 1 has no part temperature: none for it, the mean for the others.
            assert_eq!(t.part_temp_c, (i != 1).then_some(21.0));
        }
        assert_eq!(up.probe_mm, [0.0, 10.0, 0.0]);
        let rows: Vec<usize> = table
            .lines
            .iter()
            .flat_map(|l| &l.targets)
            .map(|t| t.row)
            .collect();
        assert_eq!(rows, (1..=6).collect::<Vec<_>>());
    }
}
