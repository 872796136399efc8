//! Weighted Lomb–Scargle periodogram of the residual over the exact x positions.
//!
//! For every trial frequency f (cycles per mm) the residual is fitted by a·sin(2πfx) +
//! b·cos(2πfx) by weighted least squares and the power is the drop in χ² (the generalised
//! Lomb–Scargle of Zechmeister & Kürster 2009, without the floating mean: the residual is
//! centred and, for the broad scan, detrended first). No uniform sampling is assumed.
//!
//! Cost: O(rows · frequencies) with a complex recurrence per row (no trigonometric call
//! inside the loop; exact values are recomputed every 256 steps). Both are bounded: the
//! rows by an evenly spaced subset (`spectral_max_rows`), the frequencies by narrow
//! windows around the grating-tied periods and a broad grid of a few thousand points.

/// One scan: frequencies f0 + k·df, k < nf; returns Δχ² per frequency.
pub(crate) fn scan(x_mm: &[f64], r: &[f64], w: &[f64], f0: f64, df: f64, nf: usize) -> Vec<f64> {
    let n = x_mm.len();
    let tau = std::f64::consts::TAU;
    let wr: Vec<f64> = w.iter().zip(r).map(|(w, r)| w * r).collect();
    let wsum: f64 = w.iter().sum();
    let mut zr = vec![0.0; n];
    let mut zi = vec![0.0; n];
    let mut dr = vec![0.0; n];
    let mut di = vec![0.0; n];
    for k in 0..n {
        let (s, c) = (tau * df * x_mm[k]).sin_cos();
        dr[k] = c;
        di[k] = s;
    }
    let mut out = Vec::with_capacity(nf);
    for j in 0..nf {
        if j % 256 == 0 {
            let f = f0 + j as f64 * df;
            for k in 0..n {
                let (s, c) = (tau * f * x_mm[k]).sin_cos();
                zr[k] = c;
                zi[k] = s;
            }
        }
        let (mut ss, mut cc, mut c2, mut s2) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..n {
            let (c, s) = (zr[k], zi[k]);
            ss += wr[k] * s;
            cc += wr[k] * c;
            c2 += w[k] * (c * c - s * s);
            s2 += w[k] * (2.0 * s * c);
            zr[k] = c * dr[k] - s * di[k];
            zi[k] = c * di[k] + s * dr[k];
        }
        let sin2 = 0.5 * (wsum - c2);
        let cos2 = 0.5 * (wsum + c2);
        let sc = 0.5 * s2;
        let det = sin2 * cos2 - sc * sc;
        let p = if det > 1e-12 * wsum * wsum {
            (ss * ss * cos2 - 2.0 * ss * cc * sc + cc * cc * sin2) / det
        } else {
            0.0
        };
        out.push(p.max(0.0));
    }
    out
}

/// An evenly spaced subset of at most `max` row indices.
pub(crate) fn subset(n: usize, max: usize) -> Vec<usize> {
    if n <= max || max == 0 {
        return (0..n).collect();
    }
    (0..max).map(|k| k * n / max).collect()
}

/// The local maxima of a scan, best first, at least `sep` bins apart.
pub(crate) fn peaks(power: &[f64], sep: usize, count: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..power.len()).collect();
    idx.sort_by(|&a, &b| power[b].total_cmp(&power[a]));
    let mut out: Vec<usize> = Vec::new();
    for i in idx {
        if out.len() >= count {
            break;
        }
        if out.iter().all(|&j| j.abs_diff(i) > sep) {
            out.push(i);
        }
    }
    out
}
