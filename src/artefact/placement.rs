//! Placements X = R·f + t: the nominal orientation R0 of a position (spec `artefact.md`,
//! Frames), the rigid best fit of a position before the joint fit, and the checks of
//! bad input it makes (a feature 0.5 mm off, a position 10° / 50 mm off).

use nalgebra::{Matrix3, Vector3};

use super::error::ArtefactError;
use super::files::{Artefact, Campaign, Kind, Measurement, Orientation, Plane, Position};
use crate::base::ConfigError;

/// A feature further than this from where the others put it is bad input, mm.
pub const FEATURE_OFF_MM: f64 = 0.5;
/// A position further than these from its stated placement is bad input.
pub const PLACEMENT_OFF_DEG: f64 = 10.0;
pub const PLACEMENT_OFF_MM: f64 = 50.0;

/// A placement: X = R·f + t (t in mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    pub r: Matrix3<f64>,
    pub t_mm: Vector3<f64>,
}

impl Placement {
    pub fn apply(&self, f: [f64; 3]) -> [f64; 3] {
        let x = self.r * Vector3::from(f) + self.t_mm;
        [x[0], x[1], x[2]]
    }
}

/// Rotation about z by `deg` (right-handed).
fn rz(deg: f64) -> Matrix3<f64> {
    let (s, c) = deg.to_radians().sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

fn columns(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Matrix3<f64> {
    Matrix3::from_columns(&[Vector3::from(a), Vector3::from(b), Vector3::from(c)])
}

/// The plane's basis B: the artefact's x, y, z axes in machine axes.
pub fn plane_basis(plane: Plane) -> Matrix3<f64> {
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    match plane {
        Plane::XY => columns(x, y, z),
        Plane::XZ => columns(x, z, [0.0, -1.0, 0.0]),
        Plane::YZ => columns(y, z, x),
    }
}

/// R0 = B(plane)·Rz(rotation)·F, or for a 1-D artefact a rotation whose first column is
/// the direction (the rest immaterial).
pub fn nominal_rotation(o: &Orientation) -> Matrix3<f64> {
    match *o {
        Orientation::Plane {
            plane,
            rotation_deg,
            flip,
        } => {
            let f = if flip {
                Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
            } else {
                Matrix3::identity()
            };
            plane_basis(plane) * rz(rotation_deg) * f
        }
        Orientation::Direction(d) => frame_along(Vector3::from(d)),
    }
}

/// An orthonormal right-handed frame whose first column is the unit vector `u`.
pub fn frame_along(u: Vector3<f64>) -> Matrix3<f64> {
    let u = u.normalize();
    let helper = if u[2].abs() < 0.9 {
        Vector3::z()
    } else {
        Vector3::x()
    };
    let v = helper.cross(&u).normalize();
    let w = u.cross(&v);
    Matrix3::from_columns(&[u, v, w])
}

/// Angle of a rotation matrix, degrees.
pub(crate) fn angle_deg(r: &Matrix3<f64>) -> f64 {
    ((r.trace() - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// The rigid least-squares placement of points `f` (artefact frame) onto `x` (machine):
/// ball plates by the SVD of the cross-covariance (Kabsch); hole plates rotate about the
/// stated normal only (their normal coordinate is not observed); 1-D artefacts take the
/// least-squares line's direction, turned from the stated frame by the smallest rotation.
pub fn rigid_fit(kind: Kind, r0: &Matrix3<f64>, f: &[[f64; 3]], x: &[[f64; 3]]) -> Placement {
    let n = f.len() as f64;
    let fc = f.iter().map(|v| Vector3::from(*v)).sum::<Vector3<f64>>() / n;
    let xc = x.iter().map(|v| Vector3::from(*v)).sum::<Vector3<f64>>() / n;
    let r = match kind {
        Kind::BallPlate => {
            let mut h = Matrix3::zeros();
            for (a, b) in f.iter().zip(x) {
                h += (Vector3::from(*a) - fc) * (Vector3::from(*b) - xc).transpose();
            }
            let svd = h.svd(true, true);
            let (u, vt) = (svd.u.unwrap_or_default(), svd.v_t.unwrap_or_default());
            let d = (vt.transpose() * u.transpose()).determinant().signum();
            vt.transpose() * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose()
        }
        Kind::HolePlate => {
            // In the stated frame: x' = R0ᵀ·x; fit the rotation about z' in (x', y').
            let (mut sc, mut ss) = (0.0, 0.0);
            for (a, b) in f.iter().zip(x) {
                let p = Vector3::from(*a) - fc;
                let q = r0.transpose() * (Vector3::from(*b) - xc);
                sc += p[0] * q[0] + p[1] * q[1];
                ss += p[0] * q[1] - p[1] * q[0];
            }
            r0 * rz(ss.atan2(sc).to_degrees())
        }
        Kind::BallBeam | Kind::StepGauge => {
            let mut c = Matrix3::zeros();
            for b in x {
                let d = Vector3::from(*b) - xc;
                c += d * d.transpose();
            }
            let eig = c.symmetric_eigen();
            let k = eig.eigenvalues.imax();
            let mut u: Vector3<f64> = eig.eigenvectors.column(k).into();
            // Oriented as the gauge's x runs.
            let mut s = 0.0;
            for (a, b) in f.iter().zip(x) {
                s += (a[0] - fc[0]) * u.dot(&(Vector3::from(*b) - xc));
            }
            if s < 0.0 {
                u = -u;
            }
            let u0: Vector3<f64> = r0.column(0).into();
            let axis = u0.cross(&u);
            let turn = match nalgebra::Unit::try_new(axis, 1e-15) {
                Some(ax) => {
                    nalgebra::Rotation3::from_axis_angle(&ax, u0.dot(&u).clamp(-1.0, 1.0).acos())
                }
                None => nalgebra::Rotation3::identity(),
            };
            turn.matrix() * r0
        }
    };
    // A hole plate's normal translation and a gauge's are not observed: the centroid
    // puts them where the measured coordinates are.
    let t_mm = xc - r * fc;
    Placement { r, t_mm }
}

/// What a feature observes in machine axes: the unit directions (artefact x, y, z
/// columns of R for the kind's observed coordinates; machine axes for ball artefacts).
pub(crate) fn observed_directions(kind: Kind, r: &Matrix3<f64>) -> Vec<[f64; 3]> {
    match kind {
        Kind::BallPlate | Kind::BallBeam => {
            vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        }
        Kind::HolePlate => (0..2).map(|k| col(r, k)).collect(),
        Kind::StepGauge => vec![col(r, 0)],
    }
}

pub(crate) fn col(r: &Matrix3<f64>, k: usize) -> [f64; 3] {
    [r[(0, k)], r[(1, k)], r[(2, k)]]
}

/// The part of `d` a kind observes (hole plates: in-plane; gauges: along).
fn observed_offset(kind: Kind, r: &Matrix3<f64>, d: Vector3<f64>) -> f64 {
    observed_directions(kind, r)
        .iter()
        .map(|u| Vector3::from(*u).dot(&d).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// A position's measured features in the artefact frame at the position's temperature,
/// and in the machine.
pub(crate) fn pairs(
    art: &Artefact,
    pos: &Position,
    meas: &Measurement,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let f = meas
        .rows
        .iter()
        .map(|m| art.at_temp_mm(m.feature, pos.temp_c))
        .collect();
    let x = meas.rows.iter().map(|m| m.x_mm).collect();
    (f, x)
}

/// The rigid placement of one position, after the checks: at least 3 features, none
/// more than [`FEATURE_OFF_MM`] from where the others put it (left-one-out refit of the
/// worst), the placement within [`PLACEMENT_OFF_DEG`] / [`PLACEMENT_OFF_MM`] of the
/// stated one.
pub fn checked_placement(
    campaign: &Campaign,
    k: usize,
    meas: &Measurement,
) -> Result<Placement, ArtefactError> {
    let pos = &campaign.positions[k];
    let art = &campaign.artefacts[pos.artefact];
    let key = |name: &str| format!("position[{}].{name}", k + 1);
    if meas.rows.len() < 3 {
        return Err(ConfigError::file(
            &meas.path,
            format!(
                "{} measured features: a position needs at least 3",
                meas.rows.len()
            ),
        )
        .into());
    }
    let r0 = nominal_rotation(&pos.orientation);
    let (f, x) = pairs(art, pos, meas);
    let p = rigid_fit(art.kind, &r0, &f, &x);
    let off = |pl: &Placement, i: usize| {
        let d = Vector3::from(x[i]) - Vector3::from(pl.apply(f[i]));
        observed_offset(art.kind, &pl.r, d)
    };
    let worst = (0..f.len())
        .max_by(|&a, &b| off(&p, a).total_cmp(&off(&p, b)))
        .unwrap_or(0);
    if off(&p, worst) > FEATURE_OFF_MM / 2.0 && f.len() > 3 {
        let keep: Vec<usize> = (0..f.len()).filter(|&i| i != worst).collect();
        let fk: Vec<[f64; 3]> = keep.iter().map(|&i| f[i]).collect();
        let xk: Vec<[f64; 3]> = keep.iter().map(|&i| x[i]).collect();
        let q = rigid_fit(art.kind, &r0, &fk, &xk);
        let d = off(&q, worst);
        if d > FEATURE_OFF_MM {
            let m = &meas.rows[worst];
            return Err(ConfigError::row(
                &meas.path,
                m.row,
                m.row + 1,
                Some("feature"),
                format!(
                    "feature `{}` is {d:.3} mm from where the position's other features put it \
                     (more than {FEATURE_OFF_MM} mm)",
                    art.features[m.feature].id
                ),
            )
            .into());
        }
    }
    let turn = angle_deg(&(p.r * r0.transpose()));
    if turn > PLACEMENT_OFF_DEG {
        return Err(ConfigError::key(
            &campaign.path,
            key(if art.kind.is_1d() {
                "direction"
            } else {
                "rotation_deg"
            }),
            format!(
                "the measured features put position `{}` {turn:.1}° from its stated \
                 orientation (more than {PLACEMENT_OFF_DEG}°)",
                pos.id
            ),
        )
        .into());
    }
    // Where the stated origin is, along what the kind observes.
    let shift = observed_offset(art.kind, &p.r, p.t_mm - Vector3::from(pos.origin_mm));
    if shift > PLACEMENT_OFF_MM {
        return Err(ConfigError::key(
            &campaign.path,
            key("origin_mm"),
            format!(
                "the measured features put position `{}`'s origin {shift:.1} mm from \
                 origin_mm (more than {PLACEMENT_OFF_MM} mm)",
                pos.id
            ),
        )
        .into());
    }
    Ok(p)
}
