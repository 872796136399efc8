//! The direction-dependent compensation of one measured line: choose the line `--at`
//! names among a session's lines, and turn its ISO 230-2 mean deviations into the errors
//! a controller compensates, one table per direction of approach.
//!
//! ISO 230-2 states a deviation as `x = reference − indicated`, errmap an error as
//! `e = indicated − reference = −x`; the tables hold errors, so the mean deviations x̄↑ and
//! x̄↓ are negated here, once. Between the measured targets the controller interpolates
//! linearly (a `--step` regrid uses that same rule, [`super::regrid_measured`]).

use crate::base::{Axis, NamesSettings, Setting};

use super::Sampled;

/// One measured line: where it lies and its ISO 230-2 mean deviations per target.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LineMeans {
    /// The line's two other coordinates, mm, in the order of [`other_axes`].
    pub at_mm: (f64, f64),
    /// Target positions along the axis, mm (any order).
    pub positions_mm: Vec<f64>,
    /// Mean deviation approaching in + (x̄↑ = −ē↑), µm, per target.
    pub mean_up_um: Vec<f64>,
    /// Mean deviation approaching in − (x̄↓), µm, per target.
    pub mean_down_um: Vec<f64>,
}

/// The settings of the export stage that its messages name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportSetting {
    /// The coordinates that choose one measured line among a session's lines.
    Line,
    /// How the grid points beyond a line's range are valued ([`super::Ends`]).
    Ends,
    /// The position a controller counts its table's points from.
    Reference,
}

impl Setting for ExportSetting {
    fn words(self) -> &'static str {
        match self {
            ExportSetting::Line => "the line's position",
            ExportSetting::Ends => "the ends",
            ExportSetting::Reference => "the reference position",
        }
    }
}

/// Why no one line could be chosen (the line's position named: [`ExportSetting::Line`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChooseLineError {
    #[error("{}", self.render(&Setting::words))]
    NoMatch {
        /// The lines there are, `y=…,z=…` each.
        known: String,
        /// `; without statistics: …` for lines whose statistics failed, else empty.
        without: String,
    },
    #[error("{}", self.render(&Setting::words))]
    Several { count: usize, a: Axis, b: Axis },
}

impl NamesSettings for ChooseLineError {
    type Setting = ExportSetting;
    fn render(&self, name: &dyn Fn(ExportSetting) -> &'static str) -> String {
        let line = name(ExportSetting::Line);
        match self {
            ChooseLineError::NoMatch { known, without } => format!(
                "no line of the session with ISO 230-2 statistics matches {line} (lines: \
                 {known}{without})"
            ),
            ChooseLineError::Several { count, a, b } => {
                format!("{count} lines match; choose one with {line} {a}=…,{b}=…")
            }
        }
    }
}

/// The two axes other than `axis`, in index order (for X: Y, Z).
pub(crate) fn other_axes(axis: Axis) -> [Axis; 2] {
    match axis {
        Axis::X => [Axis::Y, Axis::Z],
        Axis::Y => [Axis::X, Axis::Z],
        Axis::Z => [Axis::X, Axis::Y],
    }
}

/// Coordinates agree with `--at` to this, mm (1 nm).
pub(crate) const AT_TOL_MM: f64 = 1e-6;

/// The one line among `lines` whose coordinates match every `(axis, value)` of `at`
/// (an empty `at` matches every line; a coordinate along the measured axis matches none).
/// `failed` names lines without statistics, for the message. Returns the line's index.
pub(crate) fn choose_line(
    axis: Axis,
    lines: &[LineMeans],
    at: &[(Axis, f64)],
    failed: &[String],
) -> Result<usize, ChooseLineError> {
    let [a, b] = other_axes(axis);
    let matches = |l: &LineMeans| {
        at.iter().all(|&(k, v)| {
            let c = if k == a {
                l.at_mm.0
            } else if k == b {
                l.at_mm.1
            } else {
                f64::NAN
            };
            (c - v).abs() <= AT_TOL_MM
        })
    };
    let chosen: Vec<usize> = (0..lines.len()).filter(|&i| matches(&lines[i])).collect();
    match chosen.as_slice() {
        [one] => Ok(*one),
        [] => Err(ChooseLineError::NoMatch {
            known: lines
                .iter()
                .map(|l| format!("{a}={},{b}={}", l.at_mm.0, l.at_mm.1))
                .collect::<Vec<_>>()
                .join("; "),
            without: if failed.is_empty() {
                String::new()
            } else {
                format!("; without statistics: {}", failed.join("; "))
            },
        }),
        many => Err(ChooseLineError::Several {
            count: many.len(),
            a,
            b,
        }),
    }
}

/// The forward (approached in +) and reverse (approached in −) error tables of a line,
/// targets in increasing position: errors `e = −x̄`.
pub(crate) fn direction_tables(axis: Axis, line: &LineMeans) -> (Sampled, Sampled) {
    let [a, b] = other_axes(axis);
    let mut at_mm = [0.0; 3];
    at_mm[a.index()] = line.at_mm.0;
    at_mm[b.index()] = line.at_mm.1;
    let mut order: Vec<usize> = (0..line.positions_mm.len()).collect();
    order.sort_by(|&p, &q| line.positions_mm[p].total_cmp(&line.positions_mm[q]));
    let positions: Vec<f64> = order.iter().map(|&i| line.positions_mm[i]).collect();
    let up: Vec<f64> = order.iter().map(|&i| -line.mean_up_um[i]).collect();
    let down: Vec<f64> = order.iter().map(|&i| -line.mean_down_um[i]).collect();
    (
        Sampled::measured(axis, at_mm, positions.clone(), up),
        Sampled::measured(axis, at_mm, positions, down),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(y: f64, z: f64) -> LineMeans {
        LineMeans {
            at_mm: (y, z),
            positions_mm: vec![200.0, 0.0, 100.0],
            mean_up_um: vec![3.0, 1.0, 2.0],
            mean_down_um: vec![-3.0, -1.0, -2.0],
        }
    }

    #[test]
    fn the_line_at_is_chosen_and_the_deviations_become_errors_in_position_order() {
        let lines = [line(0.0, 0.0), line(50.0, 0.0)];
        let i = choose_line(Axis::X, &lines, &[(Axis::Y, 50.0)], &[]).expect("one line");
        assert_eq!(i, 1);
        let l = &lines[i];
        let (fwd, rev) = direction_tables(Axis::X, l);
        assert_eq!(fwd.positions_mm, vec![0.0, 100.0, 200.0]);
        assert_eq!(fwd.error_um, vec![-1.0, -2.0, -3.0], "e = −x̄↑");
        assert_eq!(rev.error_um, vec![1.0, 2.0, 3.0], "e = −x̄↓");
        assert_eq!(fwd.at_mm, [0.0, 50.0, 0.0]);
    }

    #[test]
    fn none_or_several_matching_lines_are_refused_with_the_lines_named() {
        let lines = [line(0.0, 0.0), line(50.0, 0.0)];
        let e = choose_line(Axis::X, &lines, &[(Axis::Z, 0.0)], &[])
            .expect_err("two lines at z = 0")
            .to_string();
        assert!(
            e.contains("2 lines match") && e.contains("the line's position y=…,z=…"),
            "{e}"
        );
        let e = choose_line(
            Axis::X,
            &lines,
            &[(Axis::Y, 7.0)],
            &["(9, 9): few runs".into()],
        )
        .expect_err("none at y = 7")
        .to_string();
        assert!(
            e.contains("y=0,z=0; y=50,z=0") && e.contains("without statistics: (9, 9)"),
            "{e}"
        );
        // A coordinate along the measured axis matches no line.
        assert!(choose_line(Axis::X, &lines[..1], &[(Axis::X, 5.0)], &[]).is_err());
    }
}
