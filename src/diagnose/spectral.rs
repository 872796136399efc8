//! Weighted Lomb–Scargle periodogram of the residual over the exact x positions.
//!
//! For every trial frequency f (cycles per mm) the residual is fitted by c + a·sin(2πfx) +
//! b·cos(2πfx) by weighted least squares and the power is the drop in χ² against the
//! constant alone: the generalised Lomb–Scargle periodogram with a floating mean
//! (Zechmeister & Kürster 2009). The floating mean matters here: the dwell samples of a
//! target share one phase, so without it a sine is partly a constant. The residual is
//! centred (weighted) first. No uniform sampling is assumed.
//!
//! Cost: O(rows · frequencies) with a complex recurrence per row (no trigonometric call
//! inside the loop; exact values are recomputed every 256 steps). Both are bounded: the
//! rows by an evenly spaced subset (`spectral_max_rows`), the frequencies by narrow
//! windows around the grating-tied periods and a broad grid of a few thousand points.

/// One scan: frequencies f0 + k·df, k < nf; returns Δχ² per frequency (`r` is centred
/// with the weights here).
pub(crate) fn scan(x_mm: &[f64], r: &[f64], w: &[f64], f0: f64, df: f64, nf: usize) -> Vec<f64> {
    let n = x_mm.len();
    let tau = std::f64::consts::TAU;
    let wsum: f64 = w.iter().sum();
    if n == 0 || wsum <= 0.0 {
        return vec![0.0; nf];
    }
    let mean = w.iter().zip(r).map(|(w, r)| w * r).sum::<f64>() / wsum;
    let wr: Vec<f64> = w.iter().zip(r).map(|(w, r)| w * (r - mean)).collect();
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
        let (mut ws, mut wc) = (0.0, 0.0);
        for k in 0..n {
            let (c, s) = (zr[k], zi[k]);
            ss += wr[k] * s;
            cc += wr[k] * c;
            ws += w[k] * s;
            wc += w[k] * c;
            c2 += w[k] * (c * c - s * s);
            s2 += w[k] * (2.0 * s * c);
            zr[k] = c * dr[k] - s * di[k];
            zi[k] = c * di[k] + s * dr[k];
        }
        // Centred sums (the floating mean): Σw(s − s̄)² = Σws² − (Σws)²/W, and so on;
        // Σw·r·(s − s̄) = Σw·r·s because the residual is centred.
        let (ms, mc) = (ws / wsum, wc / wsum);
        let sin2 = 0.5 * (wsum - c2) - wsum * ms * ms;
        let cos2 = 0.5 * (wsum + c2) - wsum * mc * mc;
        let sc = 0.5 * s2 - wsum * ms * mc;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A sine of known period on irregular positions peaks at its frequency, with Δχ²
    /// equal to the explained sum of squares.
    #[test]
    fn peak_at_the_true_frequency() {
        let n = 3000;
        let x: Vec<f64> = (0..n)
            .map(|k| 800.0 * ((k as f64 * 0.618_033_988_75).fract()))
            .collect();
        let f_true = 50.0; // 20 µm
        let r: Vec<f64> = x
            .iter()
            .map(|&x| 0.2 * (std::f64::consts::TAU * f_true * x + 0.7).sin() + 0.05)
            .collect();
        let w = vec![1.0; n];
        let df = 1.0 / 1600.0;
        let f0 = f_true - 40.0 * df;
        let p = scan(&x, &r, &w, f0, df, 81);
        let k = peaks(&p, 1, 1)[0];
        assert_eq!(k, 40, "{:?}", &p[35..45]);
        // Explained: n·a²/2 = 3000·0.02 = 60.
        assert!((p[40] - 60.0).abs() < 3.0, "{}", p[40]);
        // Far beyond the recurrence's re-anchoring (256 steps) it is still exact.
        let p2 = scan(&x, &r, &w, f_true - 300.0 * df, df, 301);
        assert!(
            (p2[300] - p[40]).abs() < 1e-6 * p[40],
            "{} vs {}",
            p2[300],
            p[40]
        );
    }
}
