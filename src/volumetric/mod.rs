//! Volumetric errors from laser line measurements (spec `volumetric.md`, issue #12): the
//! 21 geometric errors of a three-axis machine (ISO 230-1:2012 names) identified from
//! displacements measured along lines — the displacement method of Zhang et al. (CIRP
//! Annals 37/1, 1988) and its successors — and the error vector anywhere in the volume.
//!
//! | module | does | cost |
//! |---|---|---|
//! | `model` | topology, components, lever arms, E(x, y, z; p), the machine-model TOML | O(18) per point |
//! | `lines` | line tables (CSV/Parquet): read, validate, write | O(rows · lines) |
//! | `basis` | the linear parameterisation (polynomials or tables at knots) with the gauge built in | O(params) per row |
//! | `spline` | tables at knots: knots from the lines, hat functions, the roughness penalty | O(knots) per value |
//! | `smooth` | the penalised fit: REML smoothing per component, posterior covariance, Birge ratio | O(params³) per REML step |
//! | `choice` | the component models compared and their evaluation with the campaign terms | one fit per model tried |
//! | `residual` | the residual's test against the noise, the lines that carry a failing one | O(rows) |
//! | `doc` | `model.json` / `--json` as one typed document, written and read back | O(params²) |
//! | `identify` | least squares, σ bands, identifiability, degree by CV, scale expansion, residual test | SVD O(rows · params²); CV one Cholesky O(params³) per line and degree |
//! | `identifiability` | which line would determine an undetermined component | one small SVD per candidate |
//! | `predict` | along lines (relative to each line's first row) and over a grid | O(params²) per point with σ |
//! | `simulate` | plans (TOML, presets `zhang22`, `rich`), timing, thermal history, simulated line tables | O(rows) |
//! | `compensation` | TwinCAT 3 CNC TF5280 `ISG_CSV` component tables; 1-D positioning profiles for `export` | O(positions · params²) |
//! | `degree` | a degree per component by leave-one-line-out CV (coordinate descent) | ≈ 18·(max − 1) CV fits a sweep |
//! | `observe` | the hook for other observations of the model (artefact features): SVD, identified components, χ² test | as `identify` |
//! | `thermal` | the scale-expansion column, its t-test and its effect | one more SVD of the design |
//!
//! # Model and signs
//!
//! E(x, y, z; p) = Σ_k [δ_k(a_k) + 1e−3·ε_k(a_k) × r_k] + Δ_sq (µm; δ µm, ε µrad, r mm),
//! r_k = Σ_{j after k in the chain} a_j·ê_j + p, Δ_sq = 1e−3·(−E_C0Y·y + E_B0Z·z,
//! −E_A0Z·z, 0). A laser reading along the unit beam u records e = −u·E + c_line + noise
//! (indicated − reference). The table's x_mm, y_mm, z_mm are the axis positions at
//! which the components are evaluated (E(P_i; p) as the spec writes it).
//!
//! # Identification
//!
//! The default component model is a piecewise-linear table at knots with a roughness
//! penalty, the smoothing of each component chosen by REML and the covariance the
//! Bayesian posterior's, inflated by the Birge ratio (`spline`, `smooth`); when its
//! residual fails the test below, rougher tables are tried before anything is called
//! unexplained ([`identify::identify`]). The polynomial basis (`--basis poly`) is
//! described next; its identifiability analysis also decides what the tables determine.
//!
//! Linear least squares: each component a polynomial in ξ = a/L_k without constant term
//! (`basis`), each squareness a constant, one free constant per line. The line constants
//! are eliminated exactly by centring each line's rows (weighted mean); rows are weighted
//! by 1/s_um when every row has `s_um`, otherwise equally; columns are equilibrated to
//! unit norm. The equilibrated design's SVD gives the solution (pseudo-inverse on the
//! determined subspace), the covariance σ₀²·(AᵀWA)⁺ scaled by the residual
//! (σ₀² = χ²/(rows − rank − lines)), and the null space: singular values at or below
//! [`identify::RANK_TOL`] = 1e−8 of the largest count as zero. A component is
//! **identified** when every one of its parameters is orthogonal to the null space
//! (its rows of the orthonormal null basis below [`identify::NULL_TOL`] = 1e−6); then its
//! estimate and σ do not depend on how the undetermined directions are resolved.
//! Unidentified components are reported with `values`/`sigma` null, grouped by the
//! simplest line of a catalogue whose addition determines them (`identifiability`).
//! A straightness component of degree D has the basis ξ²…ξ^max(D,2) (slope removed), so a
//! straightness that no line sees is never "identified as zero".
//!
//! **Degree.** One global degree D (1 = linear, …), or per component (fixed, or
//! `auto-each`: each component's own by the same cross-validation, `degree`); `auto` fits
//! D = 1 … max (default 4) and scores each by leave-one-line-out cross-validation (each
//! held-out line's profile predicted by the other lines, its constant refitted), over the
//! lines every degree can predict, among degrees determining at least what D = 1
//! determines; the degree with the lowest score is chosen (a degree too high widens the σ
//! bands honestly, one too low biases the components without showing in σ).
//!
//! # Gauge
//!
//! Line displacements do not see a rigid rotation ω × P of the whole error field, and a
//! squareness moves points exactly as a linear trend of a straightness does. The
//! convention ([`GAUGE`]): **every straightness component has zero least-squares slope
//! over its axis' range** (the continuous least-squares line over [min(0, a_min),
//! max(0, a_max)], its slope removed, the value at 0 staying 0), and **all linear trends
//! are reported as the three squareness errors of the spec's Δ_sq** — which fixes the
//! global rotation with X as the reference axis (X has no trend in y or z) and Y the
//! reference for Z's trend in y. Positioning and angular components are not affected.
//! A machine described in any other convention maps onto this one as follows, with
//! β_jk the least-squares slope of straightness E_jk over the range, in µm/mm:
//! E_C0Y' = E_C0Y − 1e3·(β_XY + β_YX), E_B0Z' = E_B0Z + 1e3·(β_XZ + β_ZX),
//! E_A0Z' = E_A0Z − 1e3·(β_YZ + β_ZY), E_jk' = E_jk − β_jk·a.
//!
//! # Residual and the scale's temperature
//!
//! When every row has `scale_temp_c`, the scales' expansion during the campaign is
//! fitted jointly with the 21 errors (one more design column, one α for the three
//! scales) and kept when |α̂| > 3σ_α (`thermal`); then the components are those at
//! 20 °C and `residual.effects` carries `scale_thermal_expansion` (`cli-contract.md`'s
//! vocabulary and shape), verdict `missing_physics`. What remains is tested against the
//! noise: with `s_um` on every row, the weighted χ² against its degrees of freedom
//! (Wilson–Hilferty z); without, the lag-1 autocorrelation of the residuals along each
//! line (z = ρ·√n). z > 3.09 (one-sided p < 0.001) adds an `unexplained` effect and
//! makes the verdict `missing_physics`; otherwise the residual is `consistent`. Before
//! that test, a drift of the readings in time (`thermal_drift`) and a single line whose
//! readings scale against the others (`scale_factor`, the line named) are searched for,
//! and fitted jointly with the 21 errors when significant (`campaign`).
//!
//! # References
//!
//! ISO 230-1:2012, *Test code for machine tools — Part 1: Geometric accuracy* (component
//! and squareness names, signs). S. Zhang, J. Ouyang et al., "A displacement method for
//! machine geometry calibration", CIRP Annals 37/1 (1988). ISO 10360-2 (length
//! measurement error along lines).

mod basis;
mod campaign;
mod choice;
mod compensation;
mod degree;
mod doc;
mod error;
mod from_session;
mod identifiability;
mod identify;
mod lines;
mod model;
mod observe;
mod predict;
mod residual;
mod simulate;
mod smooth;
mod spline;
mod thermal;

pub use basis::{Basis, BasisKind, GaugeTruth, Polynomials};
pub use compensation::{
    ComponentTables, axis_positions, component_tables, fold_squareness, positioning_profile,
};
pub use doc::{ComponentDoc, ModelDoc};
pub use error::{
    ComponentTableError, Undetermined, Unfit, UnknownComponent, UnknownPreset, VolumetricError,
};
pub use from_session::SessionLines;
pub use identify::{
    Degree, FitState, Identification, IdentifyConfig, MAX_DEGREE, MAX_REPORT_POSITIONS,
    ResidualVerdict, Unidentified, Z_MISSING, identify,
};
pub use lines::{Line, LineTable, MAX_IDENTIFY_ROWS, Target};
pub use model::{Component, ComponentFn, Machine, SQUARENESS, Topology, squareness_effect};
pub use observe::{chi_square_z, decompose_design, identified_components};
pub use predict::{Prediction, Predictor, write_grid, write_predictions};
pub use simulate::{MAX_READINGS, Plan, PlanFile, PlannedLine, ThermalHistory, preset, simulate};
pub use thermal::ThermalTest;

/// The gauge convention in words (also in the JSON and the report).
pub const GAUGE: &str = "every straightness component has zero least-squares slope over its \
    axis' measured range (value 0 at 0 kept); all linear trends are reported as the squareness \
    errors E_C0Y, E_B0Z, E_A0Z of the spec's Δ_sq, i.e. X is the reference axis (no trend of X \
    in y or z) and Y the reference for Z's trend in y";
