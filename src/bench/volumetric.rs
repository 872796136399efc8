//! The volumetric benchmark (targets: identification under 1 s, the 41³ map under 0.2 s,
//! one core): identification of a 60-line campaign with 21 targets a line — least squares,
//! one-sigma bands and the identifiability analysis — with the command line's default
//! model (components as tables at knots, smoothing by REML) and with the polynomial basis
//! at a fixed degree 3; and the error vector with its one-sigma at 41³ grid points from
//! each identified model.
//!
//! The campaign (seeded): the `rich` preset over an 800 × 600 × 400 mm volume (43 lines)
//! and 17 lines between random points of the volume, some with a 100 mm probe offset; a
//! random machine of cubic components (a few µm and µrad) and squareness (±20 µrad),
//! 0.1 µm noise, topology YXZ.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::volumetric::Component;
use crate::volumetric::{
    ComponentFn, Degree, FitState, IdentifyConfig, LineTable, Machine, Predictor, Topology,
    identify, simulate,
};
use crate::volumetric::{Plan, PlannedLine, preset};

/// Lines of the benchmark campaign.
pub(crate) const LINES: usize = 60;
/// Targets per line.
pub(crate) const TARGETS: usize = 21;
/// Grid nodes per axis of the predicted vector map.
pub(crate) const GRID: usize = 41;

const VOLUME: [[f64; 3]; 2] = [[0.0, 0.0, 0.0], [800.0, 600.0, 400.0]];

/// What `bench --json` reports under `volumetric`.
#[derive(Debug, Clone, Serialize)]
pub struct VolumetricBench {
    pub lines: usize,
    pub targets_per_line: usize,
    pub targets: usize,
    /// Identification with the default model (tables at knots, REML smoothing), σ and
    /// identifiability, s.
    pub identify_default_s: f64,
    /// Parameters of the default fit.
    pub params_default: usize,
    /// The same with polynomials of a fixed degree 3, s.
    pub identify_poly3_s: f64,
    /// Parameters of the degree-3 fit.
    pub params_poly3: usize,
    pub grid_points: usize,
    /// The error vector and its one-sigma at every grid point from the default model, s.
    pub predict_grid_s: f64,
    /// The same from the degree-3 polynomial model, s.
    pub predict_grid_poly3_s: f64,
}

/// The benchmark campaign: the machine and its simulated line table (seeded).
pub fn campaign(seed: u64) -> (Machine, LineTable) {
    let mut rng = StdRng::seed_from_u64(seed);
    let topology = Topology([1, 0, 2]);
    let mut m = Machine::perfect(topology);
    for c in Component::all() {
        let amp = if c.is_straightness() { 1.5 } else { 3.0 };
        m.set(
            c,
            ComponentFn::Poly {
                coeffs: (0..3).map(|_| amp * rng.random_range(-1.0..1.0)).collect(),
                scale_mm: VOLUME[1][c.axis],
            },
        );
    }
    m.squareness_urad = [0, 1, 2].map(|_| rng.random_range(-20.0..20.0));
    let mut lines = preset("rich", VOLUME, TARGETS, 100.0, 1).unwrap_or_default();
    while lines.len() < LINES {
        let a: [f64; 3] = [0, 1, 2].map(|k| rng.random_range(VOLUME[0][k]..VOLUME[1][k]));
        let b: [f64; 3] = [0, 1, 2].map(|k| rng.random_range(VOLUME[0][k]..VOLUME[1][k]));
        let d = [0, 1, 2].map(|k| b[k] - a[k]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len < 200.0 {
            continue;
        }
        let mut probe = [0.0; 3];
        if lines.len() % 2 == 0 {
            probe[lines.len() % 3] = 100.0;
        }
        lines.push(PlannedLine {
            name: format!("R{}", lines.len() + 1),
            start_mm: a,
            u: d.map(|c| c / len),
            length_mm: len,
            targets: TARGETS,
            probe_mm: probe,
            runs: 1,
        });
    }
    let plan = Plan {
        seed,
        noise_um: 0.1,
        laser_zero_um: 5.0,
        feed_mm_s: 20.0,
        dwell_s: 4.0,
        setup_s: 600.0,
        lines,
        thermal: None,
    };
    let table = simulate(&m, &plan);
    (m, table)
}

/// The 41³ grid over the campaign's volume.
pub fn grid_points() -> Vec<[f64; 3]> {
    let node = |k: usize, i: usize| {
        VOLUME[0][k] + (VOLUME[1][k] - VOLUME[0][k]) * i as f64 / (GRID - 1) as f64
    };
    let mut out = Vec::with_capacity(GRID * GRID * GRID);
    for i in 0..GRID {
        for j in 0..GRID {
            for k in 0..GRID {
                out.push([node(0, i), node(1, j), node(2, k)]);
            }
        }
    }
    out
}

/// The identification config of the benchmark (`degree`: `None` for auto).
pub fn config(degree: Option<usize>) -> IdentifyConfig {
    let mut c = IdentifyConfig::new(Topology([1, 0, 2]));
    if let Some(d) = degree {
        c.degree = Degree::Fixed(d);
        c.basis = crate::volumetric::BasisKind::Poly;
    }
    c
}

/// Runs the volumetric benchmark; `time` measures a closure (median seconds).
pub(crate) fn run(time: &mut dyn FnMut(&mut dyn FnMut()) -> f64) -> Option<VolumetricBench> {
    let (_, table) = campaign(1);
    let default = config(None);
    let fixed = config(Some(3));
    let id_default = identify(&table, &default).ok()?;
    let id_poly3 = identify(&table, &fixed).ok()?;
    let identify_default_s = time(&mut || {
        std::hint::black_box(identify(&table, &default).is_ok());
    });
    let identify_poly3_s = time(&mut || {
        std::hint::black_box(identify(&table, &fixed).is_ok());
    });
    let points = grid_points();
    let mut map_time = |fit: &FitState| {
        let model = Predictor::Fit(fit.clone());
        time(&mut || {
            std::hint::black_box(model.predict_grid(&points, [0.0; 3]).is_ok());
        })
    };
    let predict_grid_s = map_time(&id_default.fit);
    let predict_grid_poly3_s = map_time(&id_poly3.fit);
    Some(VolumetricBench {
        lines: table.lines.len(),
        targets_per_line: TARGETS,
        targets: table.targets(),
        identify_default_s,
        params_default: params(&id_default.fit),
        identify_poly3_s,
        params_poly3: params(&id_poly3.fit),
        grid_points: points.len(),
        predict_grid_s,
        predict_grid_poly3_s,
    })
}

fn params(f: &FitState) -> usize {
    f.theta.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_campaign_is_60_lines_of_21_targets_and_determines_everything() {
        let (m, table) = campaign(1);
        assert_eq!(table.lines.len(), LINES);
        assert!(table.lines.iter().all(|l| l.targets.len() == TARGETS));
        let t = std::time::Instant::now();
        let id = identify(&table, &config(Some(3))).expect("identify");
        let fit_s = t.elapsed().as_secs_f64();
        assert!(id.fit.identified.iter().all(|f| *f));
        assert_eq!(id.residual.verdict, crate::base::Verdict::Consistent);
        let points = grid_points();
        assert_eq!(points.len(), GRID * GRID * GRID);
        let t = std::time::Instant::now();
        let map = Predictor::Fit(id.fit.clone())
            .predict_grid(&points, [0.0; 3])
            .expect("map");
        let map_s = t.elapsed().as_secs_f64();
        // Against the truth in the fit's gauge (the machine's field up to the rigid
        // rotation line displacements cannot see): every 97th point, every axis.
        let gauge = crate::volumetric::GaugeTruth::of(&m, id.fit.basis.range_mm);
        let topo = m.topology;
        let mut z2 = Vec::new();
        for (p, (e, s)) in points.iter().zip(&map).step_by(97) {
            let mut want = [0.0; 3];
            for c in Component::all() {
                let v = gauge.value(&m, c, p[c.axis]);
                let d = c.unit_effect(topo.lever_arm(c.axis, *p, [0.0; 3]));
                for i in 0..3 {
                    want[i] += v * d[i];
                }
            }
            for (q, sq) in gauge.squareness_urad.iter().enumerate() {
                let d = crate::volumetric::squareness_effect(q, *p);
                for i in 0..3 {
                    want[i] += sq * d[i];
                }
            }
            for i in 0..3 {
                if s[i] > 1e-9 {
                    z2.push(((e[i] - want[i]) / s[i]).powi(2));
                } else {
                    assert!((e[i] - want[i]).abs() < 1e-9, "{p:?}");
                }
            }
        }
        let rms_z = (z2.iter().sum::<f64>() / z2.len() as f64).sqrt();
        assert!((0.3..2.0).contains(&rms_z), "RMS z of the map {rms_z}");
        eprintln!("identify (degree 3) {fit_s:.3} s, vector map {map_s:.3} s");
    }
}
