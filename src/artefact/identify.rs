//! `artefact identify`: the 21 errors, one placement per position and the artefacts'
//! deviations from the measured feature centres, in one linear least-squares fit about
//! each position's rigid placement (spec `artefact.md`). The components are the
//! volumetric model's (cubic polynomials in its basis, with its gauge), the fit the line
//! fit's pieces through the `volumetric::observe` hook, so the result is a
//! [`crate::volumetric::Identification`] and its `model.json` is `volumetric`'s.
//!
//! Steps: (1) each position is placed rigidly ([`super::placement::checked_placement`]);
//! (2) the design is built with every artefact in its nominal orientation R0 at its
//! stated origin, every feature at its nominal place, and its
//! null space split into directions that move only machine components (those components
//! are undetermined) and directions that also move a self-calibrated artefact (the
//! invariants: the artefact is constrained to carry none of them, the machine all);
//! a self-calibrated artefact's rigid motion is constrained away first (it is the
//! placement's); (3) the same design with the fitted orientations is solved on the
//! complement of the undetermined directions; the covariance is (AᵀWA)⁺ scaled by the
//! Birge ratio² when it exceeds 1; (4) the residual's χ² is tested against its degrees of
//! freedom (Wilson–Hilferty z).

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};
use serde::Serialize;

use super::design::{
    Layout, Row, View, complement, laser_rows, observed_coords, placement_params, position_rows,
    prior_rows, rigid_patterns, weighted,
};
use super::error::ArtefactError;
use super::files::{Campaign, Kind, Measurement};
use super::placement::{Placement, checked_placement, nominal_rotation};
use crate::volumetric::{
    Basis, Component, FitState, Identification, LineTable, ResidualVerdict, Topology, Unidentified,
    Z_MISSING, chi_square_z, decompose_design, identified_components,
};

/// The component degree of the artefact fit (volumetric identify's observability rule).
pub const DEGREE: usize = 3;
/// A null direction "touches" an artefact when its deviation part has at least this
/// share of its norm.
const TOUCH_TOL: f64 = 1e-6;
/// Singular values below this share of the largest are undetermined directions.
pub(crate) const REL_TOL: f64 = 1e-7;
/// A component whose rows in the null basis stay below this is determined (the rest is
/// rounding of the null basis); its rows are then cleared so the stored fit agrees.
const LEAK_TOL: f64 = 1e-3;

/// What `identify` needs besides the campaign.
#[derive(Debug, Clone, Copy)]
pub struct IdentifyOptions {
    pub topology: Topology,
    pub self_calibrate: bool,
    /// Report positions per component (at least 5; 0 added).
    pub positions: usize,
}

/// A fitted placement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedPlacement {
    pub position: String,
    pub rotation: [[f64; 3]; 3],
    pub translation_mm: [f64; 3],
    pub rms_um: f64,
}

/// An invariant of a self-calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Invariant {
    pub kind: &'static str,
    pub components: Vec<String>,
    pub why: String,
}

/// One self-calibrated feature: deviation (actual − reference) and one-sigma, µm; null
/// on coordinates the kind does not observe.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FeatureDeviation {
    pub id: String,
    pub dev_um: [Option<f64>; 3],
    pub sigma_um: [Option<f64>; 3],
}

/// The self-calibration's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelfCalibration {
    pub artefact: String,
    pub features: Vec<FeatureDeviation>,
    pub invariants: Vec<Invariant>,
}

/// An extra position that would determine undetermined components.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Suggestion {
    pub plane: &'static str,
    pub at_mm: f64,
    pub probe_mm: [f64; 3],
}

/// Components the campaign cannot determine.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnidentifiedGroup {
    pub components: Vec<String>,
    pub why: String,
    pub suggest: Vec<Suggestion>,
}

/// A position's share of the residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CarrierPosition {
    pub position: String,
    pub share: f64,
    pub rms_um: f64,
    pub worst_feature: String,
}

/// The residual test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualTest {
    pub verdict: crate::base::Verdict,
    pub z: f64,
    pub chi2: f64,
    pub dof: f64,
    pub carriers: Vec<CarrierPosition>,
}

/// One feature's residual for the maps: its reference position in the artefact frame
/// and the residual (measured − fitted) in the artefact frame, µm (0 where unobserved).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapPoint {
    pub feature: String,
    pub at_mm: [f64; 2],
    pub e_um: [f64; 3],
}

/// The result.
#[derive(Debug, Clone)]
pub struct ArtefactIdentification {
    pub model: Identification,
    pub placements: Vec<FittedPlacement>,
    pub unidentified: Vec<UnidentifiedGroup>,
    pub self_calibration: Option<SelfCalibration>,
    pub residual: ResidualTest,
    pub rms_residual_um: f64,
    pub features: usize,
    /// Per position (campaign order): the residual map.
    pub maps: Vec<Vec<MapPoint>>,
    /// Per position: the artefact kind (what the map shows).
    pub kinds: Vec<Kind>,
}

/// Axis-position range of every measured feature (0 included, as the line fit's).
fn measured_range(campaign: &Campaign, meas: &[Measurement]) -> [[f64; 2]; 3] {
    let mut r = [[0.0f64; 2]; 3];
    for (pos, m) in campaign.positions.iter().zip(meas) {
        for row in &m.rows {
            for (k, rk) in r.iter_mut().enumerate() {
                let a = row.x_mm[k] - pos.probe_mm[k];
                rk[0] = rk[0].min(a);
                rk[1] = rk[1].max(a);
            }
        }
    }
    r
}

/// Columns scaled to unit norm (zero columns left zero with scale 1).
fn equilibrate(a: &mut DMatrix<f64>) -> Vec<f64> {
    (0..a.ncols())
        .map(|j| {
            let s = a.column(j).norm();
            if s > 0.0 {
                a.column_mut(j).scale_mut(1.0 / s);
                s
            } else {
                1.0
            }
        })
        .collect()
}

/// The observability analysis' outcome.
pub(crate) struct Observability {
    pub invariants: Vec<Invariant>,
    /// Machine-only null directions, equilibrated y-coordinates of the nominal design.
    pub null_mo: DMatrix<f64>,
    pub scale: Vec<f64>,
    pub z: DMatrix<f64>,
}

/// Components with a share of a direction's machine part (equilibrated rows).
fn components_of(basis: &Basis, v: &DVector<f64>) -> Vec<String> {
    let w: Vec<f64> = (0..21)
        .map(|c| basis.params(c).map(|j| v[j] * v[j]).sum::<f64>().sqrt())
        .collect();
    let max = w.iter().cloned().fold(0.0, f64::max);
    (0..21)
        .filter(|&c| max > 0.0 && w[c] > 0.2 * max)
        .map(component_name)
        .collect()
}

pub(crate) fn component_name(c: usize) -> String {
    if c < 18 {
        Component::from_index(c).name()
    } else {
        crate::volumetric::SQUARENESS[c - 18].to_string()
    }
}

/// The self-calibrated artefacts' scale (d ∝ f − f̄) and squareness (the symmetric
/// shear d ∝ (y − ȳ, x − x̄)) patterns, as full-length vectors.
fn known_patterns(campaign: &Campaign, layout: &Layout) -> [DVector<f64>; 2] {
    let mut out = [DVector::zeros(layout.n), DVector::zeros(layout.n)];
    for (a, art) in campaign.artefacts.iter().enumerate() {
        if layout.dev[a].is_none() || art.certified() {
            continue;
        }
        let n = art.features.len() as f64;
        let c = (0..art.features.len())
            .map(|i| Vector3::from(art.reference_mm(i)))
            .sum::<Vector3<f64>>()
            / n;
        for (jj, &k) in observed_coords(art.kind).iter().enumerate() {
            for i in 0..art.features.len() {
                let f = Vector3::from(art.reference_mm(i)) - c;
                if let Some(cc) = layout.dev_col(campaign, a, i, jj) {
                    out[0][cc] = if k < 2 { f[k] } else { 0.0 };
                    out[1][cc] = match k {
                        0 => f[1],
                        1 => f[0],
                        _ => 0.0,
                    };
                }
            }
        }
    }
    out
}

/// Names the invariants spanned by `found` ((null direction, deviation pattern) pairs):
/// the scale and the squareness when their patterns (within the constraints so far, `z`)
/// lie in the span and an earlier round has not named them (`named`: what is left of a
/// pattern after its own invariant is constrained is another invariant's), every other
/// dimension `other`.
fn name_invariants(
    campaign: &Campaign,
    basis: &Basis,
    layout: &Layout,
    z: &DMatrix<f64>,
    found: &[(DVector<f64>, DVector<f64>)],
    named: &[&str],
) -> Vec<Invariant> {
    let d = DMatrix::from_columns(&found.iter().map(|f| f.1.clone()).collect::<Vec<_>>());
    let svd = d.clone().svd(true, true);
    let mut out = Vec::new();
    for (kind, p) in ["scale", "squareness"]
        .into_iter()
        .zip(known_patterns(campaign, layout))
    {
        if named.contains(&kind) {
            continue;
        }
        let p = z * (z.transpose() * p);
        if p.norm() < 1e-12 {
            continue;
        }
        let Ok(w) = svd.solve(&p, 1e-10) else {
            continue;
        };
        if (&d * &w - &p).norm() > 0.3 * p.norm() {
            continue;
        }
        let v = found
            .iter()
            .zip(w.iter())
            .fold(DVector::zeros(found[0].0.len()), |acc, (f, c)| {
                acc + &f.0 * *c
            });
        let why = if kind == "scale" {
            "the artefact's scale against the machine's scales: without a traceable length \
             the positions cannot tell them apart"
        } else {
            "the artefact's squareness against the machine's: no rotation of the artefact \
             separates them"
        };
        out.push(Invariant {
            kind,
            components: components_of(basis, &v),
            why: why.into(),
        });
    }
    for (v, _) in found.iter().skip(out.len()) {
        out.push(Invariant {
            kind: "other",
            components: components_of(basis, v),
            why: "a deviation pattern of the artefact that the machine's components reproduce \
                  in every position"
                .into(),
        });
    }
    out
}

/// Decides what the nominal design determines (module doc, step 2).
pub(crate) fn observability(
    campaign: &Campaign,
    basis: &Basis,
    layout: &Layout,
    nominal_rows: &[Row],
    priors: &[(usize, f64)],
    self_cal: &[bool],
) -> Observability {
    let dev_start = layout
        .dev
        .iter()
        .flatten()
        .copied()
        .min()
        .unwrap_or(layout.n);
    let mut constraints: Vec<DVector<f64>> = Vec::new();
    for (a, free) in self_cal.iter().enumerate() {
        if *free {
            constraints.extend(rigid_patterns(campaign, layout, a));
        }
    }
    let (a0, _) = weighted(nominal_rows, priors, layout.n);
    let mut invariants = Vec::new();
    for _round in 0..3 {
        let z = complement(layout.n, dev_start, &constraints);
        let mut az = &a0 * &z;
        let scale = equilibrate(&mut az);
        let (_, _, _, null) = decompose_design(&az, REL_TOL);
        let q = null.ncols();
        let nd = null.rows(dev_start, null.nrows() - dev_start).into_owned();
        let (w_mo, w_inv) = split_null(&nd, q);
        if w_inv.is_empty() || _round == 2 {
            let null_mo = if w_mo.is_empty() {
                DMatrix::zeros(null.nrows(), 0)
            } else {
                clean(basis, &null * DMatrix::from_columns(&w_mo))
            };
            return Observability {
                invariants,
                null_mo,
                scale,
                z,
            };
        }
        let mut found = Vec::new();
        for w in &w_inv {
            let v = &null * w;
            let y: DVector<f64> = DVector::from_fn(v.len(), |i, _| v[i] / scale[i]);
            let x = &z * y;
            let mut pattern = DVector::zeros(layout.n);
            pattern
                .rows_mut(dev_start, layout.n - dev_start)
                .copy_from(&x.rows(dev_start, layout.n - dev_start));
            found.push((v, pattern));
        }
        let named: Vec<&str> = invariants.iter().map(|i: &Invariant| i.kind).collect();
        invariants.extend(name_invariants(campaign, basis, layout, &z, &found, &named));
        constraints.extend(found.into_iter().map(|(_, p)| p));
    }
    unreachable!("the loop returns on its last round")
}

/// Clears the rows of components the null basis only grazes (below [`LEAK_TOL`]) and
/// re-orthonormalises it.
fn clean(basis: &Basis, mut null: DMatrix<f64>) -> DMatrix<f64> {
    for c in 0..21 {
        let w: f64 = basis
            .params(c)
            .map(|j| null.row(j).norm_squared())
            .sum::<f64>()
            .sqrt();
        if w <= LEAK_TOL {
            for j in basis.params(c) {
                null.row_mut(j).fill(0.0);
            }
        }
    }
    let svd = null.clone().svd(true, false);
    let u = svd.u.unwrap_or_else(|| DMatrix::zeros(null.nrows(), 0));
    let cols: Vec<DVector<f64>> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > 1e-6)
        .map(|k| u.column(k).into_owned())
        .collect();
    if cols.is_empty() {
        DMatrix::zeros(null.nrows(), 0)
    } else {
        DMatrix::from_columns(&cols)
    }
}

/// Splits a null basis by its deviation part `nd` (rows: deviation coordinates): the
/// combinations with none (machine-only) and those with some (invariants).
fn split_null(nd: &DMatrix<f64>, q: usize) -> (Vec<DVector<f64>>, Vec<DVector<f64>>) {
    if q == 0 {
        return (Vec::new(), Vec::new());
    }
    if nd.nrows() == 0 {
        return ((0..q).map(|i| unit(q, i)).collect(), Vec::new());
    }
    let g = nd.transpose() * nd;
    let e = g.symmetric_eigen();
    let (mut mo, mut inv) = (Vec::new(), Vec::new());
    for i in 0..q {
        let w = e.eigenvectors.column(i).into_owned();
        if e.eigenvalues[i].max(0.0).sqrt() > TOUCH_TOL {
            inv.push(w);
        } else {
            mo.push(w);
        }
    }
    (mo, inv)
}

fn unit(n: usize, i: usize) -> DVector<f64> {
    let mut v = DVector::zeros(n);
    v[i] = 1.0;
    v
}

/// Identifies the campaign. `meas` are the positions' measurements in campaign order.
pub fn identify(
    campaign: &Campaign,
    meas: &[Measurement],
    opts: &IdentifyOptions,
) -> Result<ArtefactIdentification, ArtefactError> {
    identify_joint(campaign, meas, None, opts)
}

/// A laser line table a joint fit can weigh: every target with its reading and its
/// one-sigma (the fit weighs the laser against the artefact by them).
fn check_lines(table: &LineTable) -> Result<(), ArtefactError> {
    for line in &table.lines {
        if let Some(t) = line
            .targets
            .iter()
            .find(|t| t.e_um.is_none() || t.s_um.is_none())
        {
            return Err(ArtefactError::Fit {
                file: table.source.clone().into(),
                message: format!(
                    "line {}, data row {}: a joint fit needs e_um and s_um on every target \
                     (the laser is weighed against the artefact by its one-sigma)",
                    line.id, t.row
                ),
            });
        }
    }
    Ok(())
}

/// The laser lines' shares of the residual, as the positions' (`first` the number of
/// the first line's rows' position).
fn line_carriers(
    table: &LineTable,
    rows: &[Row],
    sol: &Solution,
    first: usize,
) -> Vec<CarrierPosition> {
    table
        .lines
        .iter()
        .enumerate()
        .map(|(l, line)| {
            let mine: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i].position == first + l)
                .collect();
            let res = |i: usize| sol.res_w[i] * rows[i].sigma_um;
            let rms = (mine.iter().map(|&i| res(i).powi(2)).sum::<f64>()
                / mine.len().max(1) as f64)
                .sqrt();
            let worst = mine
                .iter()
                .max_by(|&&a, &&b| res(a).abs().total_cmp(&res(b).abs()))
                .map(|&i| format!("target {}", line.targets[rows[i].meas_row].row))
                .unwrap_or_default();
            CarrierPosition {
                position: format!("laser {}", line.id),
                share: mine.iter().map(|&i| sol.res_w[i].powi(2)).sum::<f64>()
                    / sol.chi2.max(f64::MIN_POSITIVE),
                rms_um: rms,
                worst_feature: worst,
            }
        })
        .collect()
}

/// Identifies the campaign and, when given, laser lines of the same machine in one fit
/// (issue #36 item 1's joint fit): the lines' targets are rows of the same design, each
/// line with its free constant, so what the positions leave undetermined or invariant
/// (the plate's scale against the machine's) a line along an axis can determine.
pub fn identify_joint(
    campaign: &Campaign,
    meas: &[Measurement],
    lines: Option<&LineTable>,
    opts: &IdentifyOptions,
) -> Result<ArtefactIdentification, ArtefactError> {
    if let Some(t) = lines {
        check_lines(t)?;
    }
    let placements: Vec<Placement> = (0..campaign.positions.len())
        .map(|k| checked_placement(campaign, k, &meas[k]))
        .collect::<Result<_, _>>()?;
    let mut range = measured_range(campaign, meas);
    for t in lines.iter().flat_map(|t| &t.lines).flat_map(|l| &l.targets) {
        for (k, rk) in range.iter_mut().enumerate() {
            rk[0] = rk[0].min(t.pos_mm[k]);
            rk[1] = rk[1].max(t.pos_mm[k]);
        }
    }
    let basis = Basis::new(opts.topology, range, vec![DEGREE; 18]);
    let self_cal: Vec<bool> = campaign
        .artefacts
        .iter()
        .map(|a| opts.self_calibrate && !a.certified())
        .collect();
    let dev_free: Vec<bool> = campaign
        .artefacts
        .iter()
        .zip(&self_cal)
        .map(|(a, s)| *s || a.certified())
        .collect();
    let n_lines = lines.map_or(0, |t| t.lines.len());
    let layout = Layout::new(&basis, campaign, &dev_free, n_lines);
    let priors = prior_rows(campaign, &layout);
    let mut nominal = Vec::new();
    let mut rows = Vec::new();
    for (k, pos) in campaign.positions.iter().enumerate() {
        // The nominal geometry is the plan's: R0 at the stated origin. Positions stated at
        // the same place then share it exactly, as the invariants assume; their fitted
        // translations differ by the machine's errors (µm), which would lift each
        // invariant to ~10⁻⁶ relative, where the rank rule cannot tell it from a weakly
        // determined direction.
        let r0 = nominal_rotation(&pos.orientation);
        let stated = Placement {
            r: r0,
            t_mm: Vector3::from(pos.origin_mm),
        };
        nominal.extend(position_rows(
            &basis,
            &layout,
            campaign,
            k,
            &meas[k],
            View::Nominal(&r0),
            &stated,
        ));
        rows.extend(position_rows(
            &basis,
            &layout,
            campaign,
            k,
            &meas[k],
            View::Fitted,
            &placements[k],
        ));
    }
    let np = campaign.positions.len();
    if let Some(t) = lines {
        let laser = laser_rows(&basis, &layout, t, np);
        nominal.extend(laser.iter().cloned());
        rows.extend(laser);
    }
    let obs = observability(campaign, &basis, &layout, &nominal, &priors, &self_cal);
    let solved = solve(&rows, &priors, &layout, &obs).ok_or_else(|| ArtefactError::Fit {
        file: campaign.path.clone(),
        message: format!(
            "{} observed coordinates cannot carry the fit (no degrees of freedom left)",
            rows.len()
        ),
    })?;
    let laser_carriers = lines.map(|t| line_carriers(t, &rows, &solved, np));
    let identified = identified_components(&basis, &obs.null_mo);
    let unidentified =
        super::observe::unidentified_groups(campaign, meas, &basis, &obs, &identified, range);
    let fit = super::observe::Fitted {
        layout: &layout,
        placements: &placements,
        rows: &rows,
        obs: &obs,
        sol: solved,
        identified,
        unidentified,
        self_cal: &self_cal,
    };
    let mut id = super::observe::assemble(campaign, meas, opts, basis, fit);
    if let Some(c) = laser_carriers {
        id.residual.carriers.extend(c);
        id.residual
            .carriers
            .sort_by(|a, b| b.share.total_cmp(&a.share));
    }
    Ok(id)
}

/// The solution in the unknowns' own coordinates.
pub(crate) struct Solution {
    pub x: DVector<f64>,
    pub cov: DMatrix<f64>,
    /// Weighted residual per row (data rows, then priors).
    pub res_w: DVector<f64>,
    pub chi2: f64,
    pub dof: f64,
    pub birge: f64,
}

/// Solves the fitted design on the complement of the machine-only null directions.
fn solve(
    rows: &[Row],
    priors: &[(usize, f64)],
    layout: &Layout,
    obs: &Observability,
) -> Option<Solution> {
    let (a, b) = weighted(rows, priors, layout.n);
    // The undetermined directions, in the unscaled coordinates y of x = Z·y.
    let null_y: Vec<DVector<f64>> = (0..obs.null_mo.ncols())
        .map(|k| DVector::from_fn(obs.z.ncols(), |i, _| obs.null_mo[(i, k)] / obs.scale[i]))
        .collect();
    let p = complement(obs.z.ncols(), 0, &null_y);
    let t = &obs.z * &p;
    let mut at = &a * &t;
    let scale = equilibrate(&mut at);
    let (v, sv, u, _) = decompose_design(&at, REL_TOL);
    let rank = sv.len();
    let m = at.nrows();
    if m <= rank {
        return None;
    }
    let utb = u.transpose() * &b;
    let coef = DVector::from_fn(rank, |k, _| utb[k] / sv[k]);
    let y_eq = &v * coef;
    let res_w = &b - &at * &y_eq;
    let chi2 = res_w.norm_squared();
    let dof = (m - rank) as f64;
    let birge = (chi2 / dof).sqrt();
    let vs = DMatrix::from_fn(v.nrows(), rank, |i, k| v[(i, k)] / sv[k]);
    let cov_eq = &vs * vs.transpose() * birge.powi(2).max(1.0);
    let back = DMatrix::from_fn(t.nrows(), t.ncols(), |i, j| t[(i, j)] / scale[j]);
    let x = &back * y_eq;
    let cov = &back * cov_eq * back.transpose();
    Some(Solution {
        x,
        cov,
        res_w,
        chi2,
        dof,
        birge,
    })
}

/// The fitted placement of position `k`: R = R̂·Rot(ω), t = t̂ + δt.
pub(crate) fn refined_placement(
    kind: Kind,
    p: &Placement,
    layout: &Layout,
    k: usize,
    x: &DVector<f64>,
) -> Placement {
    let (rot, tr) = placement_params(kind, &p.r);
    let (o, _) = layout.place[k];
    let mut omega = Vector3::zeros();
    for (q, w) in rot.iter().enumerate() {
        omega += Vector3::from(*w) * (1e-6 * x[o + q]);
    }
    let mut t = p.t_mm;
    for (q, v) in tr.iter().enumerate() {
        t += Vector3::from(*v) * (1e-3 * x[o + rot.len() + q]);
    }
    let r: Matrix3<f64> = p.r * Rotation3::from_scaled_axis(omega).into_inner();
    Placement { r, t_mm: t }
}

/// The residual verdict in `volumetric`'s shape for `model.json`.
pub(crate) fn model_verdict(z: f64) -> ResidualVerdict {
    ResidualVerdict {
        verdict: crate::base::Verdict::from_found(z > Z_MISSING),
        effects: Vec::new(),
        test: "chi-square".into(),
        z,
        carriers: Vec::new(),
    }
}

/// The volumetric model of the fit.
#[allow(clippy::too_many_arguments)]
pub(crate) fn model_of(
    opts: &IdentifyOptions,
    basis: Basis,
    obs: &Observability,
    sol: &Solution,
    identified: Vec<bool>,
    unidentified: &[UnidentifiedGroup],
    counts: (usize, usize),
    rms_residual_um: f64,
) -> Identification {
    let n_m = basis.n_params();
    let z = chi_square_z(sol.chi2, sol.dof);
    Identification {
        topology: opts.topology,
        degree: DEGREE,
        cv: Vec::new(),
        fit: FitState {
            theta: (0..n_m).map(|i| sol.x[i]).collect(),
            covariance: (0..n_m)
                .map(|i| (0..n_m).map(|j| sol.cov[(i, j)]).collect())
                .collect(),
            null_space: (0..n_m)
                .map(|i| {
                    (0..obs.null_mo.ncols())
                        .map(|k| obs.null_mo[(i, k)])
                        .collect()
                })
                .collect(),
            column_scale: obs.scale[..n_m].to_vec(),
            identified,
            roughness: Vec::new(),
            basis,
        },
        lines: counts.0,
        targets: counts.1,
        rms_residual_um,
        sigma0: sol.birge,
        dof: sol.dof,
        weighted: true,
        residuals: Vec::new(),
        residual: model_verdict(z),
        unidentified: unidentified
            .iter()
            .map(|g| Unidentified {
                components: g.components.clone(),
                why: g.why.clone(),
            })
            .collect(),
        thermal: None,
        cv_each: None,
        smoothing: None,
    }
}
