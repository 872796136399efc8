//! The scale-temperature term of an identification: when every row of a line table has
//! `scale_temp_c`, the expansion of the scales during the campaign is fitted together
//! with the 21 errors and kept only when significant.
//!
//! # Model
//!
//! One coefficient α (ppm/K) for the three axes' scales, fixed point at each axis'
//! reference position 0 (the components are zero there): the positioning components
//! gain α·ΔT·a·1e−3 µm with ΔT = `scale_temp_c` − 20 °C ([`super::model`]), so a reading
//! along u at axis positions P records −1e−3·α·ΔT·(u·P) µm more. That is one more column
//! of the least-squares design, g_i = −1e−3·ΔT_i·(u·P_i), centred per line with the same
//! weights as the others (the line's free constant absorbs its mean) and equilibrated.
//!
//! # What the data determine
//!
//! A temperature constant over the campaign is a scale factor of the three positioning
//! components, indistinguishable from their linear terms: α is determined only by the
//! temperature's *change* between lines that measure along the same axes. If the column
//! lies in the span of the others (its singular value at or below
//! [`super::identify::RANK_TOL`]), α is not determined and the term is not fitted; the
//! components are then as at the campaign's temperatures, which the JSON's `thermal`
//! says.
//!
//! # Test
//!
//! α̂ and its one-sigma σ_α come from the joint fit (covariance scaled by its residual);
//! the term is kept when |α̂| > [`THERMAL_T`]·σ_α (a t-test at 3σ; two-sided p ≈ 0.0027
//! on a rigid campaign, where α̂/σ_α is standard normal). For a single parameter this is
//! the likelihood-ratio (F) test of the fit with and without the column. When kept, the
//! components and squareness are those of the joint fit — the machine **at 20 °C** —
//! and the residual's `effects` carries `scale_thermal_expansion` (`cli-contract.md`'s
//! vocabulary) with `explains_um`, the RMS of the fitted term about each line's mean.

use serde::{Deserialize, Serialize};

use super::lines::LineTable;
use super::model::dot;
use crate::base::Effect;
use crate::base::ParamName;
use crate::diagnose::FoundEffect;

/// The t threshold above which the scale-expansion term is kept.
pub(crate) const THERMAL_T: f64 = 3.0;

/// The design column of α (per ppm/K), µm, before weighting: row order of the table.
pub(crate) struct ThermalColumn {
    /// g_i centred per line (weighted mean removed), unweighted.
    pub centred: Vec<f64>,
    /// Range of `scale_temp_c`, °C.
    pub temp_c: [f64; 2],
    /// Range of `t_s`, if every row has it.
    pub t_s: Option<[f64; 2]>,
}

/// The outcome of the test (JSON `thermal`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThermalTest {
    /// α̂, ppm/K, `None` when the temperatures do not determine it.
    pub alpha_ppm_per_k: Option<f64>,
    pub sigma_ppm_per_k: Option<f64>,
    /// |α̂|/σ_α; `None` when not tested, or when σ_α = 0 and α̂ ≠ 0 (an exact fit:
    /// significant beyond any bound, kept).
    pub t: Option<f64>,
    /// Whether the term is in the reported fit (components at 20 °C).
    pub kept: bool,
    /// Range of `scale_temp_c` over the campaign, °C.
    pub temp_c: [f64; 2],
    pub t_s: Option<[f64; 2]>,
    /// RMS of the fitted term about each line's mean, µm (0 unless kept).
    pub explains_um: f64,
}

/// The column when every row has `scale_temp_c` (else `None`); `w` are the row
/// weights (1/s², or 1).
pub(crate) fn column(table: &LineTable, w: &[f64]) -> Option<ThermalColumn> {
    let all = table.lines.iter().flat_map(|l| &l.targets);
    let temps: Vec<f64> = all.clone().map(|t| t.scale_temp_c).collect::<Option<_>>()?;
    let times: Option<Vec<f64>> = all.map(|t| t.t_s).collect();
    let g: Vec<f64> = table
        .lines
        .iter()
        .flat_map(|line| line.targets.iter().map(move |t| (line.u, t.pos_mm)))
        .zip(&temps)
        .map(|((u, p), temp)| -1e-3 * (temp - 20.0) * dot(u, p))
        .collect();
    let centred = super::identify::centre_per_line(table, w, &g);
    let range = |v: &[f64]| {
        [
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ]
    };
    Some(ThermalColumn {
        centred,
        temp_c: range(&temps),
        t_s: times.as_deref().map(range),
    })
}

/// The `scale_thermal_expansion` effect of a kept term.
pub(crate) fn effect(test: &ThermalTest) -> Option<FoundEffect> {
    let (Some(a), Some(s)) = (test.alpha_ppm_per_k, test.sigma_ppm_per_k) else {
        return None;
    };
    let uncertainty = [(ParamName::AlphaPpmPerK, s), (ParamName::X0Mm, 0.0)].into();
    let time = match test.t_s {
        Some([t0, t1]) => format!(" over t_s {:.2}–{:.2} h", t0 / 3600.0, t1 / 3600.0),
        None => String::new(),
    };
    Some(FoundEffect {
        effect: Effect::ScaleThermalExpansion {
            alpha_ppm_per_k: a,
            x0_mm: 0.0,
        },
        uncertainty,
        where_: format!(
            "the scales of X, Y and Z (positioning E_XX, E_YY, E_ZZ gain α·ΔT·a·1e−3 µm), \
             scale_temp_c {:.2}–{:.2} °C{time}; one α for the three axes, x0_mm fixed at each \
             axis' reference position 0 (not fitted); |α|/σ = {} > {THERMAL_T}; the \
             components are reported at 20 °C",
            test.temp_c[0],
            test.temp_c[1],
            // A kept test without a t is an exact fit (see `ThermalTest::t`).
            super::campaign::t_words(test.t.unwrap_or(f64::INFINITY))
        ),
        explains_um: test.explains_um,
    })
}
