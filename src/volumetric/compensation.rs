//! What controllers with compensation need from an identification: the component tables
//! of a volumetric compensation (sampled per axis; `controller::isg` writes them as
//! Beckhoff TwinCAT 3 CNC TF5280's `ISG_CSV` parameter file, and says what of that
//! format is sourced), and each axis' positioning error as a 1-D profile for the
//! single-axis controller tables (the `controller` stage, which the binary drives).
//!
//! # What of the ISG file is *not* sourced, and how the tables avoid it
//!
//! The pages consulted show position errors only by example (`Y0A Z0A X0B`, location
//! errors of rotary axes); the name the kernel gives a **squareness** of linear axes is
//! not in them, nor is the format of the `Chain` parameter. So the file carries no
//! squareness column: each squareness is written into the straightness it is
//! indistinguishable from in the first-order model (the spec's Δ_sq moves points exactly
//! as a linear straightness of the second axis),
//!
//! E_XY(y) += −1e−3·E_C0Y·y,  E_XZ(z) += +1e−3·E_B0Z·z,  E_YZ(z) += −1e−3·E_A0Z·z  (µm),
//!
//! which reproduces the error vector E(x, y, z) exactly (a test checks it) whatever
//! position-error names the controller uses; the `Chain` (the topology) is stated in a
//! comment for the integrator to configure. The sign is ISO 230-1's (actual − nominal),
//! as errmap's; the controller compensates by subtracting it (its `negate` parameter
//! flips it, should a commissioning test show otherwise).
//!
//! # Positioning profiles
//!
//! The 1-D profile of axis k is what a laser along k through `at_mm` (probe offset 0)
//! records without a line constant, e(a) = −ê_k·E(P(a)) with P(a) = `at_mm` whose
//! coordinate k is replaced by a — errmap's error convention (indicated − reference),
//! which the `export` stage renders for LinuxCNC, SINUMERIK or CSV. At `at_mm` = 0 it is
//! −E_kk(a), zero at a = 0.

use super::error::Undetermined;
use super::identify::FitState;
use super::model::{AXES, Component, SQUARENESS, Topology};

/// Sampled component tables, one per axis, errmap units (µm, µrad), squareness folded in.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentTables {
    pub topology: Topology,
    /// Positions per axis, mm.
    pub positions_mm: [Vec<f64>; 3],
    /// Per axis, per position, the six components E_X… E_C of that axis (µm, µrad).
    pub values: [Vec<[f64; 6]>; 3],
    /// Per axis, the largest one-sigma of each of the six (µm, µrad).
    pub max_sigma: [[f64; 6]; 3],
}

/// `n` (≥ 2) evenly spaced positions over axis `k`'s identified range.
pub fn axis_positions(fit: &FitState, k: usize, n: usize) -> Vec<f64> {
    let [lo, hi] = fit.basis.range_mm[k];
    let n = n.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

fn undetermined(fit: &FitState) -> Vec<String> {
    (0..21)
        .filter(|&c| !fit.identified[c])
        .map(|c| {
            if c < 18 {
                Component::from_index(c).name()
            } else {
                SQUARENESS[c - 18].to_string()
            }
        })
        .collect()
}

/// The component tables at `n` positions per axis, the squareness folded into the
/// straightness of Y (in x) and Z (in x and y). Errors naming the components the lines
/// did not determine.
pub fn component_tables(fit: &FitState, n: usize) -> Result<ComponentTables, Undetermined> {
    let missing = undetermined(fit);
    if !missing.is_empty() {
        return Err(Undetermined::Compensation {
            components: missing,
        });
    }
    let sq: Vec<f64> = (0..3)
        .map(|i| fit.squareness(i).map_or(0.0, |v| v.0))
        .collect();
    let mut positions_mm: [Vec<f64>; 3] = Default::default();
    let mut values: [Vec<[f64; 6]>; 3] = Default::default();
    let mut max_sigma = [[0.0f64; 6]; 3];
    for k in 0..3 {
        positions_mm[k] = axis_positions(fit, k, n);
        for &a in &positions_mm[k] {
            let mut row = [0.0; 6];
            for (kind, slot) in row.iter_mut().enumerate() {
                let c = Component { axis: k, kind };
                let (v, s) =
                    fit.component(c.index(), a)
                        .ok_or_else(|| Undetermined::Component {
                            component: c.name(),
                        })?;
                *slot = v;
                max_sigma[k][kind] = max_sigma[k][kind].max(s);
            }
            fold_squareness(&mut row, k, [sq[0], sq[1], sq[2]], a);
            values[k].push(row);
        }
    }
    Ok(ComponentTables {
        topology: fit.basis.topology(),
        positions_mm,
        values,
        max_sigma,
    })
}

/// Folds the squareness errors `sq_urad` (E_C0Y, E_B0Z, E_A0Z) into the straightness
/// columns of a table row of axis `axis` at position `a_mm`, as the exported tables carry
/// them: Δ_sq = 1e−3·(−E_C0Y·y + E_B0Z·z, −E_A0Z·z, 0) as straightness of Y and Z.
pub fn fold_squareness(row: &mut [f64; 6], axis: usize, sq_urad: [f64; 3], a_mm: f64) {
    match axis {
        1 => row[0] += -1e-3 * sq_urad[0] * a_mm,
        2 => {
            row[0] += 1e-3 * sq_urad[1] * a_mm;
            row[1] += -1e-3 * sq_urad[2] * a_mm;
        }
        _ => {}
    }
}

/// The positioning profile of axis `k` through `at_mm` (probe offset 0) at `positions`:
/// e = −ê_k·E(P) and its one-sigma, µm (errmap's indicated − reference).
pub fn positioning_profile(
    fit: &FitState,
    k: usize,
    at_mm: [f64; 3],
    positions: &[f64],
) -> Result<Vec<(f64, f64)>, Undetermined> {
    positions
        .iter()
        .map(|&a| {
            let mut p = at_mm;
            p[k] = a;
            let rows = fit.basis.effect_rows(p, [0.0; 3]);
            let g: Vec<f64> = rows[k].iter().map(|v| -v).collect();
            fit.functional(&g).ok_or(Undetermined::Positioning {
                axis: AXES[k],
                at_mm: a,
            })
        })
        .collect()
}
