//! The numbers of a history report: the least-squares trend and its forecast, the EWMA
//! control chart and the moving-range σ, and the Student t distribution they need.
//!
//! * Trend: ordinary least squares of value on time in years, `b = Sxy/Sxx`,
//!   `s² = RSS/(n − 2)`, `σ_b = s/√Sxx` (Draper & Smith, *Applied Regression Analysis*, 1998).
//! * When the line reaches a limit: `t* = t̄ + (tol − ȳ)/b`, its confidence interval by
//!   Fieller's theorem (E. C. Fieller, "Some problems in interval estimation", 1954): the
//!   times `t̄ + u` where `(d − b·u)² ≤ q²·s²·(1/n + u²/Sxx)`, `d = tol − ȳ`, `q` the
//!   two-sided Student quantile; bounded only when `b² − q²s²/Sxx > 0`.
//! * EWMA chart (ISO 7870-6:2016; Lucas & Saccucci, "Exponentially weighted moving
//!   average control schemes", 1990): `z_k = λx_k + (1 − λ)z_{k−1}` with limits
//!   `μ0 ± L·σ·√v_k`; `v_k` adds to the textbook variance the variance of the baseline
//!   mean μ0 (estimated from `m` points), `(1 − (1 − λ)^k)²/m`.
//! * σ from moving ranges: `MR̄/d2`, `d2 = 1.128`, ranges above `D4·MR̄` (`D4 = 3.267`)
//!   screened once (ISO 7870-2:2023, individuals chart).
//! * Student t: the regularised incomplete beta function by its continued fraction
//!   (modified Lentz), `ln Γ` by Lanczos' approximation (g = 7, 9 terms); the quantile by
//!   bisection to 1e-12.

/// EWMA weight λ.
pub(super) const LAMBDA: f64 = 0.4;
/// Width of the EWMA limits in σ.
pub(super) const L_SIGMA: f64 = 6.0;
/// Points of a segment's baseline (they set μ0 and get no chart value).
pub(super) const BASELINE: usize = 5;
/// d2 of a range of two (ISO 7870-2).
pub(super) const D2: f64 = 1.128;
/// D4 of a range of two (ISO 7870-2).
pub(super) const D4: f64 = 3.267;
/// Floor of σ (the parameter's unit).
pub(super) const SIGMA_FLOOR: f64 = 0.001;
/// Days per year of the trend's time axis.
pub(super) const DAYS_PER_YEAR: f64 = 365.25;

fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Continued fraction of the incomplete beta function (modified Lentz).
fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..500 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function I_x(a, b).
pub(super) fn inc_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_cf(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_cf(b, a, 1.0 - x) / b
    }
}

/// P(T ≤ t) for Student's t with `df` degrees of freedom.
pub fn t_cdf(t: f64, df: f64) -> f64 {
    if t.is_nan() {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let tail = 0.5 * inc_beta(df / 2.0, 0.5, df / (df + t * t));
    if t > 0.0 { 1.0 - tail } else { tail }
}

/// The `p` quantile of Student's t with `df` degrees of freedom (0 < p < 1).
pub fn t_quantile(p: f64, df: f64) -> f64 {
    if p == 0.5 {
        return 0.0;
    }
    if p < 0.5 {
        return -t_quantile(1.0 - p, df);
    }
    let mut hi = 1.0;
    while t_cdf(hi, df) < p && hi < 1e12 {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if t_cdf(mid, df) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi.max(1.0) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// A least-squares line through (t years, value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trend {
    pub n: usize,
    /// Mean time (years, on the caller's origin) and mean value.
    pub t_mean: f64,
    pub y_mean: f64,
    /// Σ(t − t̄)².
    pub sxx: f64,
    /// Slope per year.
    pub slope: f64,
    /// Residual standard deviation √(RSS/(n − 2)).
    pub s: f64,
}

impl Trend {
    /// The fit of `points` (t, y): `None` with fewer than 3 points or all at one time.
    pub fn fit(points: &[(f64, f64)]) -> Option<Trend> {
        let n = points.len();
        if n < 3 {
            return None;
        }
        let nf = n as f64;
        let t_mean = points.iter().map(|p| p.0).sum::<f64>() / nf;
        let y_mean = points.iter().map(|p| p.1).sum::<f64>() / nf;
        let sxx: f64 = points.iter().map(|p| (p.0 - t_mean).powi(2)).sum();
        if sxx.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let sxy: f64 = points.iter().map(|p| (p.0 - t_mean) * (p.1 - y_mean)).sum();
        let slope = sxy / sxx;
        let rss: f64 = points
            .iter()
            .map(|p| (p.1 - y_mean - slope * (p.0 - t_mean)).powi(2))
            .sum();
        Some(Trend {
            n,
            t_mean,
            y_mean,
            sxx,
            slope,
            s: (rss / (nf - 2.0)).sqrt(),
        })
    }

    /// The slope's standard uncertainty s/√Sxx.
    pub fn slope_sigma(&self) -> f64 {
        self.s / self.sxx.sqrt()
    }

    /// When the line reaches `tol` (None unless it rises).
    pub fn crossing(&self, tol: f64) -> Option<f64> {
        (self.slope > 0.0).then(|| self.t_mean + (tol - self.y_mean) / self.slope)
    }

    /// Fieller's 95 % interval of the crossing time, `None` when the slope is not
    /// significant (g ≤ 0) or does not rise.
    pub fn crossing_interval(&self, tol: f64) -> Option<(f64, f64)> {
        if self.slope <= 0.0 {
            return None;
        }
        let n = self.n as f64;
        let q = t_quantile(0.975, n - 2.0);
        let d = tol - self.y_mean;
        let qs2 = q * q * self.s * self.s;
        let g = self.slope * self.slope - qs2 / self.sxx;
        if g.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let bd = self.slope * d;
        let disc = (bd * bd - g * (d * d - qs2 / n)).max(0.0).sqrt();
        let (u1, u2) = ((bd - disc) / g, (bd + disc) / g);
        Some((self.t_mean + u1, self.t_mean + u2))
    }

    /// P(the line at `t_h` exceeds `tol`) = 1 − F_{t,n−2}((tol − ŷ_h)/se_h).
    pub fn risk(&self, tol: f64, t_h: f64) -> f64 {
        let n = self.n as f64;
        let y_h = self.y_mean + self.slope * (t_h - self.t_mean);
        let se = self.s * (1.0 / n + (t_h - self.t_mean).powi(2) / self.sxx).sqrt();
        if se > 0.0 {
            1.0 - t_cdf((tol - y_h) / se, n - 2.0)
        } else if y_h > tol {
            1.0
        } else {
            0.0
        }
    }
}

/// σ from the moving ranges of consecutive points inside each of `segments`, screened
/// once at D4·MR̄; floored at [`SIGMA_FLOOR`] (and equal to it when no range exists).
pub(super) fn moving_range_sigma<'a>(segments: impl IntoIterator<Item = &'a [f64]>) -> f64 {
    let ranges: Vec<f64> = segments
        .into_iter()
        .flat_map(|s| s.windows(2).map(|w| (w[1] - w[0]).abs()))
        .collect();
    if ranges.is_empty() {
        return SIGMA_FLOOR;
    }
    let mean = ranges.iter().sum::<f64>() / ranges.len() as f64;
    let kept: Vec<f64> = ranges.iter().copied().filter(|r| *r <= D4 * mean).collect();
    let mean = if kept.is_empty() {
        mean
    } else {
        kept.iter().sum::<f64>() / kept.len() as f64
    };
    (mean / D2).max(SIGMA_FLOOR)
}

/// Which limit an EWMA value crossed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Rule {
    AboveUcl,
    BelowLcl,
}

impl Rule {
    pub(super) fn as_str(self) -> &'static str {
        match self {
            Rule::AboveUcl => "ewma_above_ucl",
            Rule::BelowLcl => "ewma_below_lcl",
        }
    }
}

/// One charted point: the EWMA and its limits, and the alarm if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ChartPoint {
    pub ewma: f64,
    pub lcl: f64,
    pub ucl: f64,
    pub alarm: Option<Rule>,
}

/// The EWMA chart of one segment: its centre and, per point, the chart value (`None` on
/// the baseline). `None` for a segment of [`BASELINE`] points or fewer.
pub(super) fn ewma_chart(values: &[f64], sigma: f64) -> Option<(f64, Vec<Option<ChartPoint>>)> {
    let m = BASELINE;
    if values.len() <= m {
        return None;
    }
    let mu0 = values[..m].iter().sum::<f64>() / m as f64;
    let mut z = mu0;
    let mut out = vec![None; m];
    let keep = 1.0 - LAMBDA;
    for (k, &x) in values[m..].iter().enumerate() {
        let k = (k + 1) as i32;
        z = LAMBDA * x + keep * z;
        let v = LAMBDA / (2.0 - LAMBDA) * (1.0 - keep.powi(2 * k))
            + (1.0 - keep.powi(k)).powi(2) / m as f64;
        let half = L_SIGMA * sigma * v.sqrt();
        let (lcl, ucl) = (mu0 - half, mu0 + half);
        let alarm = if z > ucl {
            Some(Rule::AboveUcl)
        } else if z < lcl {
            Some(Rule::BelowLcl)
        } else {
            None
        };
        out.push(Some(ChartPoint {
            ewma: z,
            lcl,
            ucl,
            alarm,
        }));
    }
    Some((mu0, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn student_quantiles_match_the_tables() {
        // Two-sided 95 % values of any statistics table.
        for (df, q) in [
            (1.0, 12.7062),
            (2.0, 4.3027),
            (5.0, 2.5706),
            (10.0, 2.2281),
            (30.0, 2.0423),
        ] {
            assert!((t_quantile(0.975, df) - q).abs() < 1e-4, "df {df}");
        }
        assert!((t_cdf(0.0, 7.0) - 0.5).abs() < 1e-15);
        // df = 1 is the Cauchy distribution: F(t) = 1/2 + atan(t)/π.
        for t in [-3.0, -0.5, 0.7, 5.0] {
            let f = 0.5 + f64::atan(t) / std::f64::consts::PI;
            assert!((t_cdf(t, 1.0) - f).abs() < 1e-12);
        }
    }

    #[test]
    fn an_exact_line_has_its_slope_and_crossing() {
        let pts: Vec<(f64, f64)> = (0..6).map(|i| (i as f64, 2.0 + 3.0 * i as f64)).collect();
        let t = Trend::fit(&pts).expect("a value");
        assert!((t.slope - 3.0).abs() < 1e-12 && t.s < 1e-12);
        assert!((t.crossing(20.0).expect("a value") - 6.0).abs() < 1e-12);
        let (lo, hi) = t.crossing_interval(20.0).expect("a value");
        assert!((lo - 6.0).abs() < 1e-9 && (hi - 6.0).abs() < 1e-9);
        assert_eq!(t.risk(20.0, 7.0), 1.0);
        assert_eq!(t.risk(20.0, 5.0), 0.0);
    }

    #[test]
    fn moving_ranges_screen_one_outlier() {
        let s = [1.0, 2.0, 1.0, 2.0, 1.0, 30.0];
        // Ranges 1,1,1,1,29: mean 6.6, 29 > 3.267·6.6 dropped, MR̄ = 1.
        assert!((moving_range_sigma([&s[..]]) - 1.0 / D2).abs() < 1e-12);
    }
}
