//! The linear parameterisation of the 21 errors that identification fits and prediction
//! evaluates, with the gauge convention built in. Two families ([`BasisKind`]):
//!
//! **Polynomials** (`poly`). Each axis k is normalised, ξ = a/L_k with L_k the largest
//! |a| of its range (the range always contains 0). A positioning or angular component of
//! degree D is Σ_{d=1..D} θ_d·ξ^d (no constant: components are zero at 0). A straightness
//! component of degree D is Σ_{d=2..max(D,2)} θ_d·(ξ^d − β_d·ξ), where β_d is the
//! least-squares slope of ξ^d over the axis' range [lo, hi] (continuous, uniform weight).
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
}
