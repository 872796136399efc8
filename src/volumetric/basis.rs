//! The linear parameterisation of the 21 errors that identification fits and prediction
//! evaluates, with the gauge convention built in. Two families ([`BasisKind`]):
//!
//! **Polynomials** (`poly`). Each axis k is mapped onto t = (2a − lo − hi)/(hi − lo) ∈
//! [−1, 1] over its range [lo, hi] (which always contains 0, at t₀). A positioning or
//! angular component of degree D is Σ_{d=1..D} θ_d·(P_d(t) − P_d(t₀)), P_d the Legendre
//! polynomial of degree d (no constant: components are zero at 0). A straightness
//! component of degree D is Σ_{d=2..max(D,2)} θ_d·(P_d(t) − P_d(t₀)): for d ≥ 2, P_d is
//! orthogonal to t on [−1, 1] (uniform weight), so each function already has zero
//! least-squares slope over the range. The span is that of the monomials ξ^d of earlier
//! versions (same fits, same predictions), but the columns stay well conditioned up to
//! the largest degree (12): monomials on a range [0, L] reach a condition number near
//! 10¹⁶ at degree 12 and their fit broke down (issue 40 item 3). A model file written
//! before this change says nothing of `polynomials` and is read with its monomials
//! ([`Polynomials::Monomial`]); the Legendre polynomials are Abramowitz & Stegun,
//! *Handbook of Mathematical Functions* (1964), 22.7.10 (the three-term recurrence).
//!
//! **Tables at knots** (`spline`, [`super::spline`]). Each component is a piecewise-linear
//! table over its axis' knots t_0 < … < t_{K−1} (0 among them): Σ_j v_j·φ_j(a), φ_j the
//! hat function of knot j, v_j the value there — a controller's compensation table. The
//! value at 0 is not a parameter (it is 0). A straightness component is
//! Σ_j v_j·(φ_j(a) − β_j·a), β_j the least-squares slope of φ_j over the range, and its
//! value at the knot farthest from 0 is not a parameter either (the slope removed, that
//! direction is the zero function).
//!
//! Either way every straightness component has zero least-squares slope over its range —
//! **the gauge** — and the three squareness errors are one parameter each and carry all
//! linear trends. See [`super`] for why this makes the solution unique and how to map any
//! other convention onto it.
//!
//! Parameters are laid out component by component (E_XX … E_CZ), then E_C0Y, E_B0Z,
//! E_A0Z.

use serde::{Deserialize, Serialize};

use super::model::{Component, Machine, SQUARENESS, Topology, dot, squareness_effect};
use super::spline;

/// The family of component functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BasisKind {
    /// Polynomials without constant term, degree chosen by cross-validation or fixed.
    Poly,
    /// Piecewise-linear tables at knots with a roughness penalty, smoothing by REML.
    #[default]
    Spline,
}

impl BasisKind {
    pub fn as_str(self) -> &'static str {
        match self {
            BasisKind::Poly => "poly",
            BasisKind::Spline => "spline",
        }
    }
}

impl std::fmt::Display for BasisKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The basis of a fit: ranges, scales, degrees or knots, slopes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Basis {
    pub topology: Topology,
    /// [lo, hi] per axis, mm (0 always inside).
    pub range_mm: [[f64; 2]; 3],
    /// L_k, mm.
    pub scale_mm: [f64; 3],
    /// Degree of each of the 18 components (polynomials; empty for tables at knots).
    pub degrees: Vec<usize>,
    /// Knots of each axis, mm, increasing, 0 among them (tables at knots only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub knots_mm: Option<Box<[Vec<f64>; 3]>>,
    /// The polynomial family of `poly` (a file without the key holds monomials).
    #[serde(default)]
    pub polynomials: Polynomials,
}

/// The functions of a `poly` basis (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Polynomials {
    /// ξ^d, ξ = a/L: model files written before Legendre polynomials (read, never made).
    #[default]
    Monomial,
    /// P_d(t) − P_d(t₀) on the range mapped to [−1, 1]: every basis made now.
    Legendre,
}

/// P_1(t) … P_n(t) by the three-term recurrence (d+1)·P_{d+1} = (2d+1)·t·P_d − d·P_{d−1},
/// into `out` from index 1 (`out[0]` = P_0 = 1).
fn legendre(t: f64, n: usize, out: &mut [f64; MAX_LEGENDRE + 1]) {
    out[0] = 1.0;
    if n >= 1 {
        out[1] = t;
    }
    for d in 1..n.min(MAX_LEGENDRE) {
        let df = d as f64;
        out[d + 1] = ((2.0 * df + 1.0) * t * out[d] - df * out[d - 1]) / (df + 1.0);
    }
}

/// The largest polynomial degree a basis evaluates (`volumetric identify` takes 1–12).
const MAX_LEGENDRE: usize = super::identify::MAX_DEGREE;

/// The range of an axis mapped onto [−1, 1]: t of a position, mm.
fn unit_coordinate(range_mm: [f64; 2], a_mm: f64, scale_mm: f64) -> f64 {
    let [lo, hi] = range_mm;
    let half = 0.5 * (hi - lo);
    // An axis that does not move is only ever evaluated at 0.
    let half = if half > 0.0 { half } else { scale_mm };
    (a_mm - 0.5 * (lo + hi)) / half
}

/// L_k per axis: the largest |a| of the range, 1 mm for an axis that does not move.
fn scales(range_mm: [[f64; 2]; 3]) -> [f64; 3] {
    range_mm.map(|[lo, hi]| {
        let l = lo.abs().max(hi.abs());
        if l > 0.0 { l } else { 1.0 }
    })
}

/// Moment E[ξ^n] of the uniform distribution on [lo, hi].
fn moment(lo: f64, hi: f64, n: i32) -> f64 {
    if (hi - lo).abs() < 1e-15 {
        return lo.powi(n);
    }
    (hi.powi(n + 1) - lo.powi(n + 1)) / (f64::from(n + 1) * (hi - lo))
}

/// Least-squares slope of ξ^d on [lo, hi] (uniform weight), 0 on an empty range.
pub(crate) fn ls_slope(lo: f64, hi: f64, d: i32) -> f64 {
    let var = moment(lo, hi, 2) - moment(lo, hi, 1).powi(2);
    if var <= 1e-15 {
        return 0.0;
    }
    (moment(lo, hi, d + 1) - moment(lo, hi, 1) * moment(lo, hi, d)) / var
}

impl Basis {
    /// Polynomials of the given degrees (one per component).
    pub fn new(topology: Topology, range_mm: [[f64; 2]; 3], degrees: Vec<usize>) -> Basis {
        Basis {
            topology,
            range_mm,
            scale_mm: scales(range_mm),
            degrees,
            knots_mm: None,
            polynomials: Polynomials::Legendre,
        }
    }

    /// Tables at the given knots (per axis, increasing, 0 among them, at least 3).
    pub fn tables(topology: Topology, range_mm: [[f64; 2]; 3], knots_mm: [Vec<f64>; 3]) -> Basis {
        Basis {
            topology,
            range_mm,
            scale_mm: scales(range_mm),
            degrees: Vec::new(),
            knots_mm: Some(Box::new(knots_mm)),
            polynomials: Polynomials::Legendre,
        }
    }

    pub fn kind(&self) -> BasisKind {
        if self.knots_mm.is_some() {
            BasisKind::Spline
        } else {
            BasisKind::Poly
        }
    }

    pub fn topology(&self) -> Topology {
        self.topology
    }

    /// Number of parameters of component `c` (0..18), or 1 for a squareness (18..21).
    pub fn count(&self, c: usize) -> usize {
        if c >= 18 {
            return 1;
        }
        let comp = Component::from_index(c);
        if let Some(knots) = &self.knots_mm {
            return spline::count(&knots[comp.axis], comp.is_straightness());
        }
        let d = self.degrees[c];
        if Component::from_index(c).is_straightness() {
            d.max(2) - 1
        } else {
            d
        }
    }

    /// First parameter of component `c` (0..21).
    pub fn offset(&self, c: usize) -> usize {
        (0..c).map(|i| self.count(i)).sum()
    }

    pub fn params(&self, c: usize) -> std::ops::Range<usize> {
        let o = self.offset(c);
        o..o + self.count(c)
    }

    pub fn n_params(&self) -> usize {
        self.offset(21)
    }

    /// As [`Basis::functions`], into `out` (cleared first).
    pub fn functions_into(&self, c: usize, a_mm: f64, out: &mut Vec<f64>) {
        out.clear();
        let comp = Component::from_index(c);
        let k = comp.axis;
        if let Some(knots) = &self.knots_mm {
            spline::functions_into(&knots[k], comp.is_straightness(), a_mm, out);
            return;
        }
        let l = self.scale_mm[k];
        let first = if comp.is_straightness() { 2 } else { 1 };
        let top = if comp.is_straightness() {
            self.degrees[c].max(2)
        } else {
            self.degrees[c]
        };
        if self.polynomials == Polynomials::Legendre {
            let range = self.range_mm[k];
            let (mut p, mut p0) = ([0.0; MAX_LEGENDRE + 1], [0.0; MAX_LEGENDRE + 1]);
            legendre(unit_coordinate(range, a_mm, l), top, &mut p);
            legendre(unit_coordinate(range, 0.0, l), top, &mut p0);
            out.extend((first..=top.min(MAX_LEGENDRE)).map(|d| p[d] - p0[d]));
            return;
        }
        let xi = a_mm / l;
        if comp.is_straightness() {
            let [lo, hi] = self.range_mm[k].map(|v| v / l);
            out.extend(
                (2..=self.degrees[c].max(2) as i32).map(|d| xi.powi(d) - ls_slope(lo, hi, d) * xi),
            );
        } else {
            out.extend((1..=self.degrees[c] as i32).map(|d| xi.powi(d)));
        }
    }

    /// Values of component `c`'s basis functions at `a_mm`.
    pub fn functions(&self, c: usize, a_mm: f64) -> Vec<f64> {
        let mut out = Vec::new();
        self.functions_into(c, a_mm, &mut out);
        out
    }

    /// ∂E/∂θ at a point: three rows (E_x, E_y, E_z), µm per parameter.
    pub fn effect_rows(&self, pos_mm: [f64; 3], probe_mm: [f64; 3]) -> [Vec<f64>; 3] {
        let n = self.n_params();
        let mut rows = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let topo = self.topology();
        let mut funcs = Vec::new();
        for c in 0..18 {
            let comp = Component::from_index(c);
            let r = topo.lever_arm(comp.axis, pos_mm, probe_mm);
            let eff = comp.unit_effect(r);
            let o = self.offset(c);
            self.functions_into(c, pos_mm[comp.axis], &mut funcs);
            for (j, &f) in funcs.iter().enumerate() {
                for i in 0..3 {
                    rows[i][o + j] += f * eff[i];
                }
            }
        }
        for s in 0..SQUARENESS.len() {
            let eff = squareness_effect(s, pos_mm);
            let o = self.offset(18 + s);
            for i in 0..3 {
                rows[i][o] += eff[i];
            }
        }
        rows
    }

    /// ∂e/∂θ of a laser reading along `u`: e = −u·E.
    pub fn line_row(&self, pos_mm: [f64; 3], u: [f64; 3], probe_mm: [f64; 3]) -> Vec<f64> {
        let [ex, ey, ez] = self.effect_rows(pos_mm, probe_mm);
        (0..ex.len())
            .map(|j| -dot(u, [ex[j], ey[j], ez[j]]))
            .collect()
    }
}

/// A machine's errors expressed in this module's gauge over given axis ranges (what an
/// identification of noise-free lines converges to): straightness components with their
/// least-squares slope over the range removed, the slopes moved into the squareness
/// errors (formulas in [`super`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GaugeTruth {
    /// Least-squares slope over the range of each of the 18 components, µm/mm (nonzero for
    /// straightness components only).
    pub slope_um_per_mm: [f64; 18],
    /// E_C0Y', E_B0Z', E_A0Z', µrad.
    pub squareness_urad: [f64; 3],
}

/// Least-squares slope of `f` over [lo, hi] (Simpson's rule, 2000 intervals).
fn numeric_slope(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    const N: usize = 2000;
    if hi <= lo {
        return 0.0;
    }
    let h = (hi - lo) / N as f64;
    let (mut w_sum, mut m1, mut m2, mut mf, mut mxf) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..=N {
        let w = if i == 0 || i == N {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let a = lo + h * i as f64;
        let v = f(a);
        w_sum += w;
        m1 += w * a;
        m2 += w * a * a;
        mf += w * v;
        mxf += w * a * v;
    }
    let (m1, m2, mf, mxf) = (m1 / w_sum, m2 / w_sum, mf / w_sum, mxf / w_sum);
    (mxf - m1 * mf) / (m2 - m1 * m1)
}

impl GaugeTruth {
    pub fn of(machine: &Machine, range_mm: [[f64; 2]; 3]) -> GaugeTruth {
        let mut slope = [0.0; 18];
        for c in Component::all().filter(|c| c.is_straightness()) {
            let [lo, hi] = range_mm[c.axis];
            slope[c.index()] = numeric_slope(|a| machine.value(c, a), lo, hi);
        }
        let b = |kind: usize, axis: usize| slope[Component { axis, kind }.index()];
        let [c0y, b0z, a0z] = machine.squareness_urad;
        GaugeTruth {
            slope_um_per_mm: slope,
            squareness_urad: [
                c0y - 1e3 * (b(0, 1) + b(1, 0)),
                b0z + 1e3 * (b(0, 2) + b(2, 0)),
                a0z - 1e3 * (b(1, 2) + b(2, 1)),
            ],
        }
    }

    /// Component `c` of `machine` at `a_mm` in the gauge.
    pub fn value(&self, machine: &Machine, c: Component, a_mm: f64) -> f64 {
        machine.value(c, a_mm) - self.slope_um_per_mm[c.index()] * a_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ls_slope_known_answers() {
        // ξ² on [0, 1]: slope 1 (mean of a symmetric distribution × 2); ξ on any range: 1.
        assert!((ls_slope(0.0, 1.0, 2) - 1.0).abs() < 1e-12);
        assert!((ls_slope(-0.3, 0.8, 1) - 1.0).abs() < 1e-12);
        // ξ³ on [−1, 1]: cov(ξ, ξ³)/var ξ = (1/5)/(1/3) = 0.6.
        assert!((ls_slope(-1.0, 1.0, 3) - 0.6).abs() < 1e-12);
    }

    #[test]
    fn legendre_functions_vanish_at_zero_and_straightness_has_no_slope() {
        // P_2 = (3t² − 1)/2, P_3 = (5t³ − 3t)/2 (Abramowitz & Stegun 22.3.8).
        let mut p = [0.0; MAX_LEGENDRE + 1];
        legendre(0.5, 3, &mut p);
        assert!((p[2] - (3.0 * 0.25 - 1.0) / 2.0).abs() < 1e-15);
        assert!((p[3] - (5.0 * 0.125 - 1.5) / 2.0).abs() < 1e-15);
        let b = Basis::new(
            "YXZ".parse().expect("topology"),
            [[0.0, 800.0], [-100.0, 500.0], [0.0, 0.0]],
            vec![12; 18],
        );
        // E_YX (straightness of x, index 1) and E_XX (positioning, 0) along x.
        for c in [0, 1] {
            assert!(b.functions(c, 0.0).iter().all(|v| *v == 0.0));
        }
        let n = 2000;
        let xs: Vec<f64> = (0..=n)
            .map(|i| 800.0 * f64::from(i) / f64::from(n))
            .collect();
        let fs: Vec<Vec<f64>> = xs.iter().map(|&x| b.functions(1, x)).collect();
        assert_eq!(fs[0].len(), 11);
        let mx = xs.iter().sum::<f64>() / xs.len() as f64;
        for j in 0..11 {
            let mf = fs.iter().map(|f| f[j]).sum::<f64>() / xs.len() as f64;
            let cov: f64 = xs
                .iter()
                .zip(&fs)
                .map(|(x, f)| (x - mx) * (f[j] - mf))
                .sum();
            let var: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
            // Trapezoid sums of orthogonal polynomials: zero to the quadrature's error.
            assert!(
                (cov / var).abs() < 1e-5,
                "degree {} slope {}",
                j + 2,
                cov / var
            );
        }
        // An axis that does not move: every function 0 at its only position.
        assert!(b.functions(12, 0.0).iter().all(|v| *v == 0.0));
    }
}
