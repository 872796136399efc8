//! What `identify` reports beyond the fit: the undetermined components grouped by the
//! null directions that move them, with the extra positions that would determine them,
//! and the assembly of the result (placements, deviations, residual test, maps).

use nalgebra::Vector3;

use super::design::{Layout, Row, View, observed_coords, position_rows, prior_rows};
use super::files::{
    Artefact, Campaign, Kind, MeasuredFeature, Measurement, Orientation, Plane, Position,
};
use super::identify::{
    ArtefactIdentification, CarrierPosition, FeatureDeviation, FittedPlacement, IdentifyOptions,
    MapPoint, Observability, ResidualTest, SelfCalibration, Solution, Suggestion,
    UnidentifiedGroup, component_name, model_of, observability, refined_placement,
};
use super::placement::{Placement, nominal_rotation};
use crate::volumetric::{Basis, Z_MISSING, chi_square_z, identified_components};

/// Groups the undetermined components (components moved by the same null directions
/// belong together) and finds the extra positions that determine each group.
pub(crate) fn unidentified_groups(
    campaign: &Campaign,
    meas: &[Measurement],
    basis: &Basis,
    obs: &Observability,
    identified: &[bool],
    range: [[f64; 2]; 3],
) -> Vec<UnidentifiedGroup> {
    let missing: Vec<usize> = (0..21).filter(|&c| !identified[c]).collect();
    if missing.is_empty() {
        return Vec::new();
    }
    // Union of components sharing a null direction.
    let mut group: Vec<usize> = (0..21).collect();
    fn root(g: &mut [usize], i: usize) -> usize {
        let mut r = i;
        while g[r] != r {
            r = g[r];
        }
        g[i] = r;
        r
    }
    for k in 0..obs.null_mo.ncols() {
        let moved: Vec<usize> = missing
            .iter()
            .copied()
            .filter(|&c| {
                basis
                    .params(c)
                    .map(|j| obs.null_mo[(j, k)].powi(2))
                    .sum::<f64>()
                    .sqrt()
                    > 1e-6
            })
            .collect();
        for w in moved.windows(2) {
            let (a, b) = (root(&mut group, w[0]), root(&mut group, w[1]));
            group[a] = b;
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut roots: Vec<usize> = Vec::new();
    for &c in &missing {
        let r = root(&mut group, c);
        match roots.iter().position(|&x| x == r) {
            Some(i) => groups[i].push(c),
            None => {
                roots.push(r);
                groups.push(vec![c]);
            }
        }
    }
    let candidates = candidates(campaign, range);
    let determined: Vec<(Suggestion, Vec<bool>)> = candidates
        .into_iter()
        .filter_map(|(s, pos, m)| with_extra(campaign, meas, basis, pos, m).map(|f| (s, f)))
        .collect();
    groups
        .into_iter()
        .map(|g| UnidentifiedGroup {
            components: g.iter().map(|&c| component_name(c)).collect(),
            why: "the positions move these components only together with others or with the \
                  placements: no combination of the measured features separates them"
                .into(),
            suggest: determined
                .iter()
                .filter(|(_, f)| g.iter().all(|&c| f[c]))
                .map(|(s, _)| s.clone())
                .collect(),
        })
        .collect()
}

/// Extra positions of the campaign's first 2-D artefact: each plane at rotation 0
/// without flip, centred on the middle of the measured range, at the low, middle and
/// high end of the normal axis (tip coordinates), with no stylus offset or one of
/// 100 mm along x or y (the offsets that make the last axis' rotations visible).
fn candidates(
    campaign: &Campaign,
    range: [[f64; 2]; 3],
) -> Vec<(Suggestion, Position, Measurement)> {
    let Some(a) = campaign.artefacts.iter().position(|x| !x.kind.is_1d()) else {
        return Vec::new();
    };
    let art = &campaign.artefacts[a];
    let n = art.features.len() as f64;
    let centroid = (0..art.features.len())
        .map(|i| Vector3::from(art.reference_mm(i)))
        .sum::<Vector3<f64>>()
        / n;
    let mut out = Vec::new();
    for plane in [Plane::XY, Plane::XZ, Plane::YZ] {
        let [i1, i2, nrm] = plane.axes();
        let [lo, hi] = range[nrm];
        let probes = [[0.0; 3], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]];
        for (at, probe) in [lo, 0.5 * (lo + hi), hi]
            .into_iter()
            .flat_map(|at| probes.iter().map(move |p| (at, *p)))
        {
            let orientation = Orientation::Plane {
                plane,
                rotation_deg: 0.0,
                flip: false,
            };
            let r0 = nominal_rotation(&orientation);
            let mut target = Vector3::zeros();
            target[i1] = 0.5 * (range[i1][0] + range[i1][1]) + probe[i1];
            target[i2] = 0.5 * (range[i2][0] + range[i2][1]) + probe[i2];
            target[nrm] = at;
            let t = target - r0 * centroid;
            let rows = (0..art.features.len())
                .map(|i| {
                    let x = r0 * Vector3::from(art.reference_mm(i)) + t;
                    MeasuredFeature {
                        feature: i,
                        row: i + 1,
                        x_mm: x.into(),
                        has_z: true,
                    }
                })
                .collect();
            let pos = Position {
                id: format!("suggested {}", plane.as_str()),
                artefact: a,
                file: "suggested.csv".into(),
                orientation,
                origin_mm: t.into(),
                probe_mm: probe,
                temp_c: art.reference_temp_c,
                sigma_um: campaign.sigma_um,
            };
            let m = Measurement {
                path: "suggested.csv".into(),
                rows,
            };
            let s = Suggestion {
                plane: plane.as_str(),
                at_mm: at,
                probe_mm: probe,
            };
            out.push((s, pos, m));
        }
    }
    out
}

/// The identified flags of the campaign with one more position (its placement as
/// stated), or `None` when nothing could be decided.
fn with_extra(
    campaign: &Campaign,
    meas: &[Measurement],
    basis: &Basis,
    pos: Position,
    m: Measurement,
) -> Option<Vec<bool>> {
    let mut c = campaign.clone();
    c.positions.push(pos);
    let mut all: Vec<Measurement> = meas.to_vec();
    all.push(m);
    let self_cal: Vec<bool> = c.artefacts.iter().map(|_| false).collect();
    let dev_free: Vec<bool> = c.artefacts.iter().map(|a| a.certified()).collect();
    let layout = Layout::new(basis, &c, &dev_free, 0);
    let priors = prior_rows(&c, &layout);
    let mut rows = Vec::new();
    for (k, p) in c.positions.iter().enumerate() {
        let r0 = nominal_rotation(&p.orientation);
        let placed = Placement {
            r: r0,
            t_mm: Vector3::from(p.origin_mm),
        };
        rows.extend(position_rows(
            basis,
            &layout,
            &c,
            k,
            &all[k],
            View::Nominal(&r0),
            &placed,
        ));
    }
    let obs = observability(&c, basis, &layout, &rows, &priors, &self_cal);
    Some(identified_components(basis, &obs.null_mo))
}

/// Unweighted residual of each data row and their RMS, µm.
fn residuals_um(rows: &[Row], sol: &Solution) -> (Vec<f64>, f64) {
    let res_um: Vec<f64> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| sol.res_w[i] * r.sigma_um)
        .collect();
    let rms = (res_um.iter().map(|r| r * r).sum::<f64>() / res_um.len().max(1) as f64).sqrt();
    (res_um, rms)
}

/// The residual map of one position: each measured feature's residual turned into the
/// artefact frame (`p` the fitted placement), µm. `mine` are the position's data rows.
fn residual_map(
    art: &Artefact,
    meas: &Measurement,
    p: &Placement,
    rows: &[Row],
    mine: &[usize],
    res_um: &[f64],
) -> Vec<MapPoint> {
    let coords = observed_coords(art.kind);
    let mut map: Vec<MapPoint> = meas
        .rows
        .iter()
        .map(|m| {
            let f = art.reference_mm(m.feature);
            MapPoint {
                feature: art.features[m.feature].id.clone(),
                at_mm: [f[0], f[1]],
                e_um: [0.0; 3],
            }
        })
        .collect();
    let ball = matches!(art.kind, Kind::BallPlate | Kind::BallBeam);
    let per = if ball { 3 } else { coords.len() };
    for (n, &i) in mine.iter().enumerate() {
        let r = &rows[i];
        let j = n % per;
        if ball {
            // Machine axis j: turned into the artefact frame.
            for c in 0..3 {
                map[r.meas_row].e_um[c] += p.r[(j, c)] * res_um[i];
            }
        } else {
            map[r.meas_row].e_um[coords[j]] = res_um[i];
        }
    }
    map
}

/// What the result says of one position: its share of the residual, its fitted
/// placement and its residual map.
fn position_result(
    campaign: &Campaign,
    meas: &Measurement,
    k: usize,
    placed: &Placement,
    rows: &[Row],
    res_um: &[f64],
    sol: &Solution,
) -> (CarrierPosition, FittedPlacement, Vec<MapPoint>) {
    let pos = &campaign.positions[k];
    let art = &campaign.artefacts[pos.artefact];
    let mine: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].position == k).collect();
    let rms =
        (mine.iter().map(|&i| res_um[i].powi(2)).sum::<f64>() / mine.len().max(1) as f64).sqrt();
    let share =
        mine.iter().map(|&i| sol.res_w[i].powi(2)).sum::<f64>() / sol.chi2.max(f64::MIN_POSITIVE);
    let map = residual_map(art, meas, placed, rows, &mine, res_um);
    let worst = map
        .iter()
        .max_by(|a, b| norm(a.e_um).total_cmp(&norm(b.e_um)))
        .map(|m| m.feature.clone())
        .unwrap_or_default();
    let carrier = CarrierPosition {
        position: pos.id.clone(),
        share,
        rms_um: rms,
        worst_feature: worst,
    };
    let fitted = FittedPlacement {
        position: pos.id.clone(),
        rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| placed.r[(i, j)])),
        translation_mm: placed.t_mm.into(),
        rms_um: rms,
    };
    (carrier, fitted, map)
}

/// The self-calibrated artefact's deviations with their one-sigmas, and the invariants.
fn self_calibration_of(
    campaign: &Campaign,
    layout: &Layout,
    sol: &Solution,
    obs: &Observability,
    self_cal: &[bool],
) -> Option<SelfCalibration> {
    let a = self_cal.iter().position(|s| *s)?;
    let art = &campaign.artefacts[a];
    let coords = observed_coords(art.kind);
    let features = (0..art.features.len())
        .map(|i| {
            let mut dev_um = [None; 3];
            let mut sigma_um = [None; 3];
            for (jj, &c) in coords.iter().enumerate() {
                if let Some(cc) = layout.dev_col(campaign, a, i, jj) {
                    dev_um[c] = Some(sol.x[cc]);
                    sigma_um[c] = Some(sol.cov[(cc, cc)].max(0.0).sqrt());
                }
            }
            FeatureDeviation {
                id: art.features[i].id.clone(),
                dev_um,
                sigma_um,
            }
        })
        .collect();
    Some(SelfCalibration {
        artefact: art.id.clone(),
        features,
        invariants: obs.invariants.clone(),
    })
}

/// What `assemble` takes from the fit.
pub(crate) struct Fitted<'a> {
    pub layout: &'a Layout,
    pub placements: &'a [Placement],
    pub rows: &'a [Row],
    pub obs: &'a Observability,
    pub sol: Solution,
    pub identified: Vec<bool>,
    pub unidentified: Vec<UnidentifiedGroup>,
    pub self_cal: &'a [bool],
}

/// Builds the result from the solution: residuals, then each position's carrier share,
/// placement and map, the residual test, the self-calibration, the volumetric model.
pub(crate) fn assemble(
    campaign: &Campaign,
    meas: &[Measurement],
    opts: &IdentifyOptions,
    basis: Basis,
    fit: Fitted,
) -> ArtefactIdentification {
    let np = campaign.positions.len();
    let (res_um, rms_residual_um) = residuals_um(fit.rows, &fit.sol);
    let mut placements = Vec::with_capacity(np);
    let mut maps = Vec::with_capacity(np);
    let mut carriers = Vec::with_capacity(np);
    for (k, pos) in campaign.positions.iter().enumerate() {
        let kind = campaign.artefacts[pos.artefact].kind;
        let placed = refined_placement(kind, &fit.placements[k], fit.layout, k, &fit.sol.x);
        let (carrier, fitted, map) =
            position_result(campaign, &meas[k], k, &placed, fit.rows, &res_um, &fit.sol);
        carriers.push(carrier);
        placements.push(fitted);
        maps.push(map);
    }
    carriers.sort_by(|a, b| b.share.total_cmp(&a.share));
    let z = chi_square_z(fit.sol.chi2, fit.sol.dof);
    let residual = ResidualTest {
        verdict: crate::base::Verdict::from_found(z > Z_MISSING),
        z,
        chi2: fit.sol.chi2,
        dof: fit.sol.dof,
        carriers,
    };
    let self_calibration =
        self_calibration_of(campaign, fit.layout, &fit.sol, fit.obs, fit.self_cal);
    let features: usize = meas.iter().map(|m| m.rows.len()).sum();
    let model = model_of(
        opts,
        basis,
        fit.obs,
        &fit.sol,
        fit.identified,
        &fit.unidentified,
        (np, features),
        rms_residual_um,
    );
    ArtefactIdentification {
        model,
        placements,
        unidentified: fit.unidentified,
        self_calibration,
        residual,
        rms_residual_um,
        features,
        maps,
        kinds: campaign
            .positions
            .iter()
            .map(|p| campaign.artefacts[p.artefact].kind)
            .collect(),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
