//! What a set of lines cannot determine, and which line would: for each undetermined
//! component, the first line of a catalogue (simplest first) whose addition removes the
//! component from the design's null space.
//!
//! With N the orthonormal null space of the equilibrated design and B the centred,
//! equilibrated rows of a candidate line, the null space after adding the line is
//! N·ker(B·N); the component is determined when its parameters' rows of that basis
//! vanish. The catalogue, over the box the lines span (probe offsets of a quarter of the
//! largest span, at least 50 mm): a line along each axis; along each axis with a probe
//! offset along each other axis; a face diagonal in each plane; a face diagonal with a
//! probe offset across its plane; two parallel face diagonals at different offsets; a
//! body diagonal.

use nalgebra::DMatrix;

use super::basis::Basis;
use super::identify::{NULL_TOL, RANK_TOL, Unidentified, decompose_with};
use super::model::{AXES, Component, SQUARENESS};

/// A candidate line: start, unit direction, length (mm), probe offset.
type CandidateLine = ([f64; 3], [f64; 3], f64, [f64; 3]);

/// A candidate: its words and its lines.
struct Candidate {
    words: String,
    lines: Vec<CandidateLine>,
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

fn catalogue(range: [[f64; 2]; 3]) -> Vec<Candidate> {
    let lo = range.map(|r| r[0]);
    let hi = range.map(|r| r[1]);
    let span: Vec<f64> = (0..3).map(|k| (hi[k] - lo[k]).max(100.0)).collect();
    let hi: [f64; 3] = [0, 1, 2].map(|k| lo[k] + span[k]);
    let mid: [f64; 3] = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let p = (0.25 * span.iter().fold(0.0f64, |a, &b| a.max(b))).max(50.0);
    let mut out = Vec::new();
    let e = |k: usize, v: f64| {
        let mut x = [0.0; 3];
        x[k] = v;
        x
    };
    for k in 0..3 {
        let mut start = mid;
        start[k] = lo[k];
        out.push(Candidate {
            words: format!("a line along {}", AXES[k]),
            lines: vec![(start, e(k, 1.0), span[k], [0.0; 3])],
        });
    }
    for k in 0..3 {
        for j in (0..3).filter(|&j| j != k) {
            let mut start = mid;
            start[k] = lo[k];
            out.push(Candidate {
                words: format!(
                    "a line along {} with a probe offset along {}",
                    AXES[k], AXES[j]
                ),
                lines: vec![(start, e(k, 1.0), span[k], e(j, p))],
            });
        }
    }
    let planes = [(0, 1, 2), (0, 2, 1), (1, 2, 0)];
    let diag = |k: usize, j: usize, frac: f64, shift: f64| {
        let mut start = mid;
        start[k] = lo[k] + shift * span[k];
        start[j] = lo[j];
        let mut d = [0.0; 3];
        d[k] = span[k];
        d[j] = span[j];
        let len = (span[k] * span[k] + span[j] * span[j]).sqrt() * frac;
        (start, unit(d), len)
    };
    for &(k, j, _) in &planes {
        let (s, u, len) = diag(k, j, 1.0, 0.0);
        out.push(Candidate {
            words: format!("a face diagonal in the {}{} plane", AXES[k], AXES[j]),
            lines: vec![(s, u, len, [0.0; 3])],
        });
    }
    for &(k, j, l) in &planes {
        let (s, u, len) = diag(k, j, 1.0, 0.0);
        out.push(Candidate {
            words: format!(
                "a face diagonal in the {}{} plane with a probe offset along {}",
                AXES[k], AXES[j], AXES[l]
            ),
            lines: vec![(s, u, len, e(l, p))],
        });
    }
    for &(k, j, _) in &planes {
        let (s0, u, len) = diag(k, j, 0.5, 0.0);
        let (s1, _, _) = diag(k, j, 0.5, 0.5);
        out.push(Candidate {
            words: format!(
                "two parallel face diagonals in the {}{} plane at different offsets",
                AXES[k], AXES[j]
            ),
            lines: vec![(s0, u, len, [0.0; 3]), (s1, u, len, [0.0; 3])],
        });
    }
    out.push(Candidate {
        words: "a body diagonal".into(),
        lines: vec![(
            lo,
            unit([span[0], span[1], span[2]]),
            (span[0].powi(2) + span[1].powi(2) + span[2].powi(2)).sqrt(),
            [0.0; 3],
        )],
    });
    out
}

/// Centred, equilibrated rows of a candidate's lines (11 targets each).
fn candidate_rows(basis: &Basis, scale: &[f64], c: &Candidate) -> DMatrix<f64> {
    const TARGETS: usize = 11;
    let n = basis.n_params();
    let mut rows = DMatrix::zeros(TARGETS * c.lines.len(), n);
    for (li, &(start, u, len, probe)) in c.lines.iter().enumerate() {
        let g: Vec<Vec<f64>> = (0..TARGETS)
            .map(|i| {
                let s = len * i as f64 / (TARGETS - 1) as f64;
                let pos = [0, 1, 2].map(|k| start[k] + s * u[k]);
                basis.line_row(pos, u, probe)
            })
            .collect();
        for j in 0..n {
            let mean = g.iter().map(|r| r[j]).sum::<f64>() / TARGETS as f64;
            for (i, r) in g.iter().enumerate() {
                rows[(li * TARGETS + i, j)] = (r[j] - mean) / scale[j];
            }
        }
    }
    rows
}

/// Whether component `c` is determined once `rows` are added to a design with null space
/// `null`.
fn determined_with(basis: &Basis, null: &DMatrix<f64>, rows: &DMatrix<f64>, c: usize) -> bool {
    let m = rows * null;
    let norm = rows.norm();
    if norm == 0.0 {
        return false;
    }
    // Directions the candidate sees only at rounding level stay null.
    let dec = decompose_with(&m, Some(RANK_TOL * norm));
    let new_null = null * &dec.null;
    basis.params(c).all(|j| new_null.row(j).norm() <= NULL_TOL)
}

/// The unidentified components grouped by the line that would determine them.
pub(crate) fn suggest(
    basis: &Basis,
    scale: &[f64],
    null: &DMatrix<f64>,
    identified: &[bool],
) -> Vec<Unidentified> {
    let cands = catalogue(basis.range_mm);
    let rows: Vec<DMatrix<f64>> = cands
        .iter()
        .map(|c| candidate_rows(basis, scale, c))
        .collect();
    let mut groups: Vec<Unidentified> = Vec::new();
    for c in (0..21).filter(|&c| !identified[c]) {
        let name = if c < 18 {
            Component::from_index(c).name()
        } else {
            SQUARENESS[c - 18].to_string()
        };
        let why = match (0..cands.len()).find(|&i| determined_with(basis, null, &rows[i], c)) {
            Some(i) => format!(
                "not determined by these lines; add {} (or lines that see it)",
                cands[i].words
            ),
            None => "not determined by these lines, nor by any single added line of the \
                     catalogue: add several kinds (lines along each axis with probe offsets \
                     along the other two, face diagonals at several offsets with probe offsets, \
                     body diagonals)"
                .to_string(),
        };
        match groups.iter_mut().find(|g| g.why == why) {
            Some(g) => g.components.push(name),
            None => groups.push(Unidentified {
                components: vec![name],
                why,
            }),
        }
    }
    groups
}
