//! A probing test of a simulated CMM, for the suite and the demo: the 25 targets of the
//! standard's design on a sphere, each stylus with its own errors.
//!
//! A target is a direction n(θ, φ) in the stylus's frame — θ from the pole (the sphere
//! point the stylus faces, direction w), φ about w from a reference direction u ⟂ w.
//! The probed point is
//!
//!   p = c + (D/2 + s + a·sin θ·cos(k·(φ − φ₀)) + σ·g)·n + o,
//!
//! s the stylus's radial size error (a tip diameter calibrated too small by 2s makes the
//! sphere 2s too large), a, k, φ₀ its lobing (the pretravel of a kinematic probe varies
//! with the direction of approach across the stylus: k = 3 for the usual three-lobed
//! probe, nothing along the stylus at the pole), σ its noise (g a standard normal
//! deviate), o its offset (a stylus whose calibrated position is wrong by o moves every
//! one of its points by o: the multi-stylus location error).

use rand::SeedableRng;
use rand::rngs::StdRng;

use super::read::ProbePoint;
use crate::base::gaussian;

/// The standard's 25 targets (θ, φ) in degrees: 1 at the pole, 4 at 22.5° (φ = 0°, 90°,
/// …), 8 at 45° (φ = 22.5° + 45°·j), 4 at 67.5° (φ = 45° + 90°·j), 8 on the equator
/// (φ = 22.5° + 45°·j): each ring turned 22.5° against the one before.
pub fn standard_targets_deg() -> Vec<(f64, f64)> {
    let mut t = vec![(0.0, 0.0)];
    for (theta, count, phi0) in [
        (22.5, 4, 0.0),
        (45.0, 8, 22.5),
        (67.5, 4, 45.0),
        (90.0, 8, 22.5),
    ] {
        let step = 360.0 / count as f64;
        for j in 0..count {
            t.push((theta, phi0 + step * j as f64));
        }
    }
    t
}

/// One simulated stylus.
#[derive(Debug, Clone, PartialEq)]
pub struct SimStylus {
    pub name: String,
    /// w: the direction from the centre to the pole (normalised when used).
    pub pole: [f64; 3],
    /// s, µm: radial size error.
    pub size_um: f64,
    /// a, µm: lobing amplitude.
    pub lobing_um: f64,
    /// k: lobes per turn.
    pub lobes: u32,
    /// φ₀, degrees: where the first lobe points.
    pub lobing_phase_deg: f64,
    /// σ, µm: noise.
    pub noise_um: f64,
    /// o, µm: the stylus's offset.
    pub offset_um: [f64; 3],
    /// The targets (θ, φ) in degrees; [`standard_targets_deg`] by default.
    pub targets_deg: Vec<(f64, f64)>,
}

impl SimStylus {
    /// A perfect stylus facing `pole`, on the standard's 25 targets.
    pub fn perfect(name: &str, pole: [f64; 3]) -> SimStylus {
        SimStylus {
            name: name.to_string(),
            pole,
            size_um: 0.0,
            lobing_um: 0.0,
            lobes: 3,
            lobing_phase_deg: 0.0,
            noise_um: 0.0,
            offset_um: [0.0; 3],
            targets_deg: standard_targets_deg(),
        }
    }
}

/// A simulated test: the sphere's true centre and diameter, the styli, the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct SimTest {
    pub centre_mm: [f64; 3],
    pub diameter_mm: f64,
    pub styli: Vec<SimStylus>,
    pub seed: u64,
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// An orthonormal frame (u, v, w) about the pole `w`: u is the machine axis least along
/// w, made perpendicular to it. The same rule places the report's sphere map.
pub fn frame(pole: [f64; 3]) -> [[f64; 3]; 3] {
    let w = unit(pole);
    let k = (0..3)
        .min_by(|&a, &b| w[a].abs().total_cmp(&w[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let d = e[0] * w[0] + e[1] * w[1] + e[2] * w[2];
    let u = unit([e[0] - d * w[0], e[1] - d * w[1], e[2] - d * w[2]]);
    let v = cross(w, u);
    [u, v, w]
}

/// The unit direction of target (θ, φ) (degrees) in `frame`.
pub fn direction(frame: &[[f64; 3]; 3], theta_deg: f64, phi_deg: f64) -> [f64; 3] {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    let [u, v, w] = frame;
    let (a, b, c) = (t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    [
        a * u[0] + b * v[0] + c * w[0],
        a * u[1] + b * v[1] + c * w[1],
        a * u[2] + b * v[2] + c * w[2],
    ]
}

/// The probed points, stylus by stylus, point numbers 1… in target order; rows numbered
/// as a file written in this order would number them.
pub fn simulate(test: &SimTest) -> Vec<ProbePoint> {
    let mut rng = StdRng::seed_from_u64(test.seed);
    let r0 = test.diameter_mm / 2.0;
    let mut out = Vec::new();
    for s in &test.styli {
        let f = frame(s.pole);
        for (j, &(theta, phi)) in s.targets_deg.iter().enumerate() {
            let n = direction(&f, theta, phi);
            let lobe = s.lobing_um
                * theta.to_radians().sin()
                * (f64::from(s.lobes) * (phi - s.lobing_phase_deg).to_radians()).cos();
            let noise = if s.noise_um > 0.0 {
                s.noise_um * gaussian(&mut rng)
            } else {
                0.0
            };
            let rad = r0 + (s.size_um + lobe + noise) * 1e-3;
            let p = [0, 1, 2].map(|k| test.centre_mm[k] + rad * n[k] + s.offset_um[k] * 1e-3);
            out.push(ProbePoint {
                row: out.len() + 1,
                stylus: s.name.clone(),
                point: j + 1,
                p_mm: p,
            });
        }
    }
    out
}

/// The points as a POINTS file (CSV, every number to the last bit).
pub fn to_csv(points: &[ProbePoint]) -> String {
    let mut s = String::from("stylus,point,x_mm,y_mm,z_mm\n");
    for p in points {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            p.stylus, p.point, p.p_mm[0], p.p_mm[1], p.p_mm[2]
        ));
    }
    s
}

/// The example of `datasets/acceptance/`: a Ø 30 mm sphere at (250, 180, −320) mm probed
/// by a star of 5 styli (−Z, ±X, ±Y), each lobing 0.3 µm with 3 lobes, 0.08 µm noise,
/// small size errors, and stylus `+X` off by (0.9, −0.4, 0.3) µm.
pub fn example() -> SimTest {
    let poles = [
        ("-Z", [0.0, 0.0, 1.0]),
        ("+X", [-1.0, 0.0, 0.0]),
        ("-X", [1.0, 0.0, 0.0]),
        ("+Y", [0.0, -1.0, 0.0]),
        ("-Y", [0.0, 1.0, 0.0]),
    ];
    let styli = poles
        .iter()
        .enumerate()
        .map(|(k, (name, pole))| SimStylus {
            size_um: [0.15, -0.1, 0.2, 0.05, -0.05][k],
            lobing_um: 0.3,
            lobing_phase_deg: 10.0 * k as f64,
            noise_um: 0.08,
            offset_um: if *name == "+X" {
                [0.9, -0.4, 0.3]
            } else {
                [0.0; 3]
            },
            ..SimStylus::perfect(name, *pole)
        })
        .collect();
    SimTest {
        centre_mm: [250.0, 180.0, -320.0],
        diameter_mm: 29.99962,
        styli,
        seed: 105,
    }
}

/// The example's sphere certificate, MPEs and U_t: `datasets/acceptance/probing-sphere.toml`.
pub const EXAMPLE_SPHERE: &str = include_str!("../../../datasets/acceptance/probing-sphere.toml");

/// The example test ([`example`]) evaluated with [`EXAMPLE_SPHERE`] and the default rule:
/// what `acceptance iso10360-5 datasets/acceptance/probing-example.csv --sphere
/// datasets/acceptance/probing-sphere.toml` prints (for the demo).
pub fn evaluate_example() -> Result<super::ProbingResult, crate::acceptance::AcceptanceError> {
    let sphere = std::path::Path::new("datasets/acceptance/probing-sphere.toml");
    let file = super::SphereFile::parse(EXAMPLE_SPHERE, sphere)?;
    let config = super::ProbingConfig::resolve(sphere, file, &Default::default())?;
    super::evaluate(
        std::path::Path::new("datasets/acceptance/probing-example.csv"),
        &simulate(&example()),
        &config,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_targets_are_25_on_a_hemisphere_and_the_frame_is_orthonormal() {
        let t = standard_targets_deg();
        assert_eq!(t.len(), 25);
        assert!(t.iter().all(|&(th, _)| (0.0..=90.0).contains(&th)));
        for pole in [[0.0, 0.0, 1.0], [1.0, 1.0, 0.0], [-0.3, 0.2, -0.9]] {
            let [u, v, w] = frame(pole);
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            for (a, b, want) in [
                (u, u, 1.0),
                (v, v, 1.0),
                (w, w, 1.0),
                (u, v, 0.0),
                (u, w, 0.0),
                (v, w, 0.0),
            ] {
                assert!((dot(a, b) - want).abs() < 1e-14);
            }
            let n = direction(&frame(pole), 0.0, 0.0);
            assert!((dot(n, unit(pole)) - 1.0).abs() < 1e-14);
        }
    }
}
