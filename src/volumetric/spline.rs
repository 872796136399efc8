//! Components as piecewise-linear tables at knots, with a roughness penalty: the knots,
//! the basis functions, the gauge's slope removal and the penalty matrices.
//!
//! # Knots
//!
//! Per axis k, the knots are the positions a_k at which the lines measure while axis k
//! moves (every target of a line whose beam has a component along k), plus 0 and the ends
//! of the range, thinned so that no two are closer than 1/[`MAX_INTERVALS`] of the range
//! (a knot within that distance of a kept one is dropped; 0 and the ends are always
//! kept). So the table is as fine as the lines resolve — a target is never between two
//! knots unless another target lies closer than the thinning distance — and never finer:
//! between two measured positions nothing determines a component but its neighbours, which
//! is what linear interpolation says. At least three knots per axis (midpoints are added
//! to a range measured at fewer).
//!
//! # Functions
//!
//! φ_j is the hat function of knot j (1 at t_j, 0 at the other knots, linear in between;
//! beyond the end knots the end segment's line is continued). A positioning or angular
//! component is Σ_{j≠z} v_j·φ_j (z the knot at 0). A straightness component is
//! Σ_{j≠z,f} v_j·(φ_j(a) − β_j·a) with β_j the least-squares slope of φ_j over the
//! range (uniform weight, computed exactly per segment) and f the knot farthest from 0: the
//! slope-free functions are the gauge, and without v_f the parameters are independent
//! (Σ_j t_j·φ_j = a has no slope-free part).
//!
//! # Penalty
//!
//! The roughness of a table is the sum of its squared second divided differences in the
//! normalised coordinate ξ = a/L_k, each over its half-interval:
//! R(v) = Σ_i [(v_{i+1} − v_i)/h_i − (v_i − v_{i−1})/h_{i−1}]² / ((h_{i−1} + h_i)/2),
//! the discrete ∫ f''(ξ)² dξ (P. H. C. Eilers and B. D. Marx, "Flexible smoothing with
//! B-splines and penalties", Statistical Science 11(2), 1996, with first-degree B-splines
//! and unequal spacing). Its null space is the straight line through 0 for positioning and
//! angular components (so the smoothest table is linear, as the degree-1 polynomial) and
//! nothing for straightness (the slope is the gauge's). A straightness's linear term has
//! zero second differences, so R sees the reported function exactly.

/// At most this many intervals per axis (the thinning distance is range / this).
pub(crate) const MAX_INTERVALS: usize = 24;

/// Index of the knot at 0 and of the knot farthest from 0.
fn anchors(knots: &[f64]) -> (usize, usize) {
    let z = knots
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or(0, |(i, _)| i);
    let f = knots
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or(0, |(i, _)| i);
    (z, f)
}

/// The knots whose value is a parameter, in parameter order.
pub(crate) fn free_knots(knots: &[f64], straightness: bool) -> Vec<usize> {
    let (z, f) = anchors(knots);
    (0..knots.len())
        .filter(|&j| j != z && !(straightness && j == f))
        .collect()
}

/// Number of parameters of a component on these knots.
pub(crate) fn count(knots: &[f64], straightness: bool) -> usize {
    let fixed = if straightness { 2 } else { 1 };
    knots.len().saturating_sub(fixed)
}

/// The segment of `a` (clamped to the end segments) and the weight of its right knot.
pub(crate) fn segment(knots: &[f64], a: f64) -> (usize, f64) {
    let n = knots.len();
    if n < 2 {
        return (0, 0.0);
    }
    let s = knots[1..n - 1].partition_point(|&t| t <= a);
    let h = knots[s + 1] - knots[s];
    let w = if h > 0.0 { (a - knots[s]) / h } else { 0.0 };
    (s, w)
}

/// Least-squares slope (per mm) of each hat function over [t_0, t_{K−1}], uniform
/// weight: cov(a, φ_j)/var(a), the integrals exact per segment.
pub(crate) fn hat_slopes(knots: &[f64]) -> Vec<f64> {
    let n = knots.len();
    let mut slopes = vec![0.0; n];
    if n < 2 {
        return slopes;
    }
    let (lo, hi) = (knots[0], knots[n - 1]);
    let len = hi - lo;
    if len <= 0.0 {
        return slopes;
    }
    let mean_a = 0.5 * (lo + hi);
    let var_a = len * len / 12.0;
    for s in 0..n - 1 {
        let (t0, t1) = (knots[s], knots[s + 1]);
        let h = t1 - t0;
        // ∫φ_s = ∫φ_{s+1} = h/2; ∫a·φ_s = h(2t0 + t1)/6; ∫a·φ_{s+1} = h(t0 + 2t1)/6.
        let i1_left = h * (2.0 * t0 + t1) / 6.0;
        let i1_right = h * (t0 + 2.0 * t1) / 6.0;
        slopes[s] += (i1_left - mean_a * h / 2.0) / len;
        slopes[s + 1] += (i1_right - mean_a * h / 2.0) / len;
    }
    slopes.iter_mut().for_each(|b| *b /= var_a);
    slopes
}

/// The component's basis functions at `a_mm` into `out` (cleared by the caller).
pub(crate) fn functions_into(knots: &[f64], straightness: bool, a_mm: f64, out: &mut Vec<f64>) {
    let free = free_knots(knots, straightness);
    out.resize(free.len(), 0.0);
    let (s, w) = segment(knots, a_mm);
    let slopes = straightness.then(|| hat_slopes(knots));
    for (slot, &j) in out.iter_mut().zip(&free) {
        let hat = if j == s {
            1.0 - w
        } else if j == s + 1 {
            w
        } else {
            0.0
        };
        *slot = match &slopes {
            Some(b) => hat - b[j] * a_mm,
            None => hat,
        };
    }
}

/// The component's basis as sparse entries: the two hat values (parameter index, value)
/// and, for a straightness, the coefficient of its slope functional Σ_j β_j·v_j (which
/// the caller carries as one more quantity): −a.
pub(crate) fn sparse(knots: &[f64], straightness: bool, a_mm: f64) -> ([(usize, f64); 2], f64) {
    let (z, f) = anchors(knots);
    let (s, w) = segment(knots, a_mm);
    let param = |j: usize| -> Option<usize> {
        if j == z || (straightness && j == f) {
            return None;
        }
        let mut p = j;
        if j > z {
            p -= 1;
        }
        if straightness && j > f {
            p -= 1;
        }
        Some(p)
    };
    let mut entries = [(usize::MAX, 0.0); 2];
    for (slot, (j, v)) in entries.iter_mut().zip([(s, 1.0 - w), (s + 1, w)]) {
        if let Some(p) = param(j) {
            *slot = (p, v);
        }
    }
    (entries, if straightness { -a_mm } else { 0.0 })
}

/// The roughness penalty of a component in its parameters (count × count, row by row),
/// in the normalised coordinate ξ = a/`scale_mm`.
pub(crate) fn penalty(knots: &[f64], straightness: bool, scale_mm: f64) -> Vec<Vec<f64>> {
    let free = free_knots(knots, straightness);
    let m = free.len();
    let mut pos = vec![usize::MAX; knots.len()];
    for (p, &j) in free.iter().enumerate() {
        pos[j] = p;
    }
    let mut s = vec![vec![0.0; m]; m];
    let xi: Vec<f64> = knots.iter().map(|t| t / scale_mm).collect();
    for i in 1..knots.len().saturating_sub(1) {
        let (h0, h1) = (xi[i] - xi[i - 1], xi[i + 1] - xi[i]);
        if h0 <= 0.0 || h1 <= 0.0 {
            continue;
        }
        let w = (2.0 / (h0 + h1)).sqrt();
        let row = [
            (i - 1, w / h0),
            (i, -w * (1.0 / h0 + 1.0 / h1)),
            (i + 1, w / h1),
        ];
        for &(ja, va) in &row {
            for &(jb, vb) in &row {
                let (pa, pb) = (pos[ja], pos[jb]);
                if pa != usize::MAX && pb != usize::MAX {
                    s[pa][pb] += va * vb;
                }
            }
        }
    }
    s
}

/// The rank of [`penalty`]: intervals − 1, less one for the straight line through 0 that
/// a positioning or angular table leaves unpenalised.
pub(crate) fn penalty_rank(knots: &[f64], straightness: bool) -> usize {
    let rows = knots.len().saturating_sub(2);
    let params = count(knots, straightness);
    rows.min(params)
}

/// Knots for one axis from the positions measured while it moves, within `range`.
pub(crate) fn knots(measured_mm: &[f64], range: [f64; 2]) -> Vec<f64> {
    let [lo, hi] = range;
    let span = hi - lo;
    if span <= 0.0 {
        // An axis that never moves: nominal knots, whose columns stay zero.
        return vec![0.0, 0.5, 1.0];
    }
    let gap = span / MAX_INTERVALS as f64;
    let fixed = |a: f64| a == lo || a == hi || a == 0.0;
    let mut cand: Vec<f64> = measured_mm
        .iter()
        .copied()
        .filter(|a| a.is_finite() && *a >= lo && *a <= hi)
        .chain([lo, 0.0, hi])
        .collect();
    cand.sort_by(f64::total_cmp);
    cand.dedup_by(|a, b| (*a - *b).abs() < 1e-6 * span);
    // Keep the fixed knots, then the others greedily, never within `gap` of a kept one.
    let mut kept: Vec<f64> = cand.iter().copied().filter(|a| fixed(*a)).collect();
    for &a in cand.iter().filter(|a| !fixed(**a)) {
        if kept.iter().all(|k| (k - a).abs() >= gap * (1.0 - 1e-9)) {
            kept.push(a);
        }
    }
    kept.sort_by(f64::total_cmp);
    kept.dedup_by(|a, b| (*a - *b).abs() < 1e-9 * span);
    while kept.len() < 3 {
        // Split the widest interval.
        let i = (0..kept.len() - 1)
            .max_by(|&a, &b| (kept[a + 1] - kept[a]).total_cmp(&(kept[b + 1] - kept[b])))
            .unwrap_or(0);
        kept.insert(i + 1, 0.5 * (kept[i] + kept[i + 1]));
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hat's slope against a direct Simpson sum; the slopes of t_j·φ_j add to 1 (the
    /// line a = Σ t_j φ_j has slope 1).
    #[test]
    fn hat_slopes_are_least_squares_slopes() {
        let knots = [-100.0, 0.0, 50.0, 200.0, 400.0];
        let b = hat_slopes(&knots);
        let sum: f64 = b.iter().zip(&knots).map(|(bj, t)| bj * t).sum();
        assert!((sum - 1.0).abs() < 1e-12, "{sum}");
        // φ_2 by a fine Riemann sum of cov(a, φ)/var(a).
        let n = 200_000;
        let (lo, hi) = (knots[0], knots[4]);
        let (mut ma, mut mf, mut maf, mut maa) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let a = lo + (hi - lo) * (i as f64 + 0.5) / n as f64;
            let (s, w) = segment(&knots, a);
            let f = if s == 2 {
                1.0 - w
            } else if s + 1 == 2 {
                w
            } else {
                0.0
            };
            ma += a;
            mf += f;
            maf += a * f;
            maa += a * a;
        }
        let nf = n as f64;
        let slope = (maf / nf - ma / nf * mf / nf) / (maa / nf - (ma / nf).powi(2));
        assert!((slope - b[2]).abs() < 1e-8, "{slope} vs {}", b[2]);
    }

    /// The penalty vanishes on a straight line through 0 (positioning) and on nothing
    /// else; the sparse form equals the dense functions.
    #[test]
    fn penalty_null_space_and_sparse_form() {
        let knots = [0.0, 100.0, 250.0, 300.0, 500.0];
        let s = penalty(&knots, false, 500.0);
        let line: Vec<f64> = free_knots(&knots, false)
            .iter()
            .map(|&j| knots[j])
            .collect();
        for row in &s {
            let v: f64 = row.iter().zip(&line).map(|(a, b)| a * b).sum();
            assert!(v.abs() < 1e-9);
        }
        assert_eq!(penalty_rank(&knots, false), 3);
        assert_eq!(penalty_rank(&knots, true), 3);
        for straight in [false, true] {
            let b = hat_slopes(&knots);
            let free = free_knots(&knots, straight);
            for a in [0.0, 37.0, 250.0, 499.0, 520.0] {
                let mut dense = Vec::new();
                functions_into(&knots, straight, a, &mut dense);
                let (entries, slope) = sparse(&knots, straight, a);
                // A straightness carries −a·β_j in every function; the slope entry is −a.
                let mut rebuilt: Vec<f64> = free.iter().map(|&j| slope * b[j]).collect();
                for (p, v) in entries {
                    if p != usize::MAX {
                        rebuilt[p] += v;
                    }
                }
                for (x, y) in dense.iter().zip(&rebuilt) {
                    assert!((x - y).abs() < 1e-12, "{a}: {dense:?} vs {rebuilt:?}");
                }
            }
        }
    }

    #[test]
    fn knots_keep_the_measured_positions_and_thin_the_dense_ones() {
        let k = knots(&[0.0, 100.0, 200.0, 300.0, 150.0], [0.0, 300.0]);
        assert_eq!(k, vec![0.0, 100.0, 150.0, 200.0, 300.0]);
        // Dense positions: no two knots closer than the thinning distance, every measured
        // position within it of a knot (the table is as fine as the lines resolve), at most
        // MAX_INTERVALS intervals. Positions every 1 mm cannot be spaced by exactly 12.5 mm,
        // so the greedy thinning keeps 13 mm steps (23 intervals); positions on a grid of half
        // the distance give exactly MAX_INTERVALS intervals.
        let gap = 300.0 / MAX_INTERVALS as f64;
        let dense: Vec<f64> = (0..=300).map(f64::from).collect();
        let k = knots(&dense, [0.0, 300.0]);
        assert!(
            k.windows(2).all(|w| w[1] - w[0] >= gap * (1.0 - 1e-9)),
            "{k:?}"
        );
        assert!(
            dense.iter().all(|a| k.iter().any(|t| (t - a).abs() < gap)),
            "{k:?}"
        );
        assert!(k.len() <= MAX_INTERVALS + 1);
        let half: Vec<f64> = (0..=2 * MAX_INTERVALS)
            .map(|i| 0.5 * gap * i as f64)
            .collect();
        let k = knots(&half, [0.0, 300.0]);
        assert_eq!(k.len(), MAX_INTERVALS + 1, "{k:?}");
        assert!(
            k.iter()
                .enumerate()
                .all(|(i, t)| (t - gap * i as f64).abs() < 1e-9)
        );
        assert_eq!(knots(&[], [-50.0, 80.0]), vec![-50.0, 0.0, 80.0]);
        assert_eq!(knots(&[], [0.0, 80.0]), vec![0.0, 40.0, 80.0]);
    }
}
