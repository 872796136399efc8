//! Predictions from an identified model (MODEL.json, written by `identify --out`) or from
//! a machine-model TOML (the truth: σ = 0): along the lines of a line table — each line
//! relative to its first row, e_i = −u·(E(P_i; p) − E(P_0; p)), so the first row predicts
//! 0 — and the error vector E(x, y, z; p) over a grid.
//!
//! A prediction the identified model cannot make (it depends on an undetermined
//! component: its linear functional of the parameters has a component in the design's
//! null space) is `None`, never a number; a grid needing an undetermined component is
//! refused with the components named.

use std::path::Path;

use serde::Serialize;

use super::doc::{DocProblem, ModelDoc};
use super::error::{Undetermined, VolumetricError, config_err};
use super::identify::FitState;
use super::lines::LineTable;
use super::model::{Component, Machine, SQUARENESS, squareness_effect};
use crate::base::FileOp;
use crate::base::io_err;

/// One predicted row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    pub line: String,
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// `None` when the model cannot determine it.
    pub e_um: Option<f64>,
    pub sigma_um: Option<f64>,
}

/// The error vector at a point and its one-sigma, µm.
pub(crate) type VectorPrediction = ([f64; 3], [f64; 3]);

/// What predicts: an identified fit, or a known machine.
#[derive(Debug)]
pub enum Predictor {
    Fit(FitState),
    Machine(Machine),
}

impl Predictor {
    /// Reads MODEL.json (`.json`) or a machine-model TOML (anything else).
    pub fn read(path: &Path) -> Result<Predictor, VolumetricError> {
        let is_json = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if !is_json {
            return Ok(Predictor::Machine(Machine::read(path)?));
        }
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Access))?;
        // The residual is not needed to predict: read past it.
        let doc: ModelDoc<serde::de::IgnoredAny> =
            serde_json::from_str(&text).map_err(|e| config_err(path, "file", e.to_string()))?;
        let fit = doc
            .check()
            .map_err(|p| match p {
                DocProblem::NoFit => VolumetricError::NoFit {
                    path: path.to_path_buf(),
                },
                DocProblem::Bad { key, message } => config_err(path, key, message),
            })?
            .clone();
        Ok(Predictor::Fit(fit))
    }

    /// Each row of `table`, relative to its line's first row.
    pub fn predict_lines(&self, table: &LineTable) -> Vec<Prediction> {
        let mut out = Vec::with_capacity(table.targets());
        for line in &table.lines {
            let p0 = line.targets[0].pos_mm;
            let base = match self {
                Predictor::Fit(f) => f.basis.line_row(p0, line.u, line.probe_mm),
                Predictor::Machine(_) => Vec::new(),
            };
            for t in &line.targets {
                let (e, s) = match self {
                    Predictor::Machine(m) => (
                        Some(
                            m.line_error_um(t.pos_mm, line.u, line.probe_mm)
                                - m.line_error_um(p0, line.u, line.probe_mm),
                        ),
                        Some(0.0),
                    ),
                    Predictor::Fit(f) => {
                        let g: Vec<f64> = f
                            .basis
                            .line_row(t.pos_mm, line.u, line.probe_mm)
                            .iter()
                            .zip(&base)
                            .map(|(a, b)| a - b)
                            .collect();
                        match f.functional(&g) {
                            Some((v, s)) => (Some(v), Some(s)),
                            None => (None, None),
                        }
                    }
                };
                out.push(Prediction {
                    line: line.id.clone(),
                    x_mm: t.pos_mm[0],
                    y_mm: t.pos_mm[1],
                    z_mm: t.pos_mm[2],
                    e_um: e,
                    sigma_um: s,
                });
            }
        }
        out
    }

    /// The error vector and its one-sigma at each point, µm. Errors with the names of the
    /// undetermined components when the identified model cannot give it.
    pub fn predict_grid(
        &self,
        points: &[[f64; 3]],
        probe_mm: [f64; 3],
    ) -> Result<Vec<VectorPrediction>, Undetermined> {
        match self {
            Predictor::Machine(m) => Ok(points
                .iter()
                .map(|&p| (m.error_um(p, probe_mm), [0.0; 3]))
                .collect()),
            Predictor::Fit(f) => {
                if let Some(missing) = grid_blockers(f) {
                    return Err(Undetermined::Vector { missing });
                }
                Ok(grid_vectors(f, points, probe_mm))
            }
        }
    }
}

/// The fit's parameters and covariance extended by one quantity per straightness table
/// (its slope functional Σ_j β_j·v_j), C stored contiguously (m × m), with where each
/// component's parameters start and which extra quantity carries its slope.
struct Extended {
    /// The number of quantities: the fit's parameters and the slope quantities.
    m: usize,
    theta: Vec<f64>,
    cov: Vec<f64>,
    offsets: Vec<usize>,
    slot: Vec<Option<usize>>,
}

impl Extended {
    /// Builds the extension once per grid (see `grid_vectors`).
    fn of(f: &FitState) -> Extended {
        let n = f.theta.len();
        let offsets: Vec<usize> = (0..21).map(|c| f.basis.offset(c)).collect();
        // Tables: one extra quantity per straightness component, Σ_j β_j·v_j.
        let straight: Vec<usize> = match &f.basis.knots_mm {
            Some(_) => (0..18)
                .filter(|&c| Component::from_index(c).is_straightness())
                .collect(),
            None => Vec::new(),
        };
        let m = n + straight.len();
        let mut t_rows: Vec<Vec<f64>> = Vec::new();
        if let Some(knots) = &f.basis.knots_mm {
            for &c in &straight {
                let comp = Component::from_index(c);
                let kn = &knots[comp.axis];
                let b = crate::volumetric::spline::hat_slopes(kn);
                let mut row = vec![0.0; n];
                for (p, &j) in crate::volumetric::spline::free_knots(kn, true)
                    .iter()
                    .enumerate()
                {
                    row[offsets[c] + p] = b[j];
                }
                t_rows.push(row);
            }
        }
        let mut theta = f.theta.clone();
        theta.extend(
            t_rows
                .iter()
                .map(|r| r.iter().zip(&f.theta).map(|(a, b)| a * b).sum::<f64>()),
        );
        let mut cov = vec![0.0; m * m];
        for i in 0..n {
            cov[i * m..i * m + n].copy_from_slice(&f.covariance[i]);
        }
        // C·tᵀ for each extra row, then t·C·t'ᵀ.
        let ct: Vec<Vec<f64>> = t_rows
            .iter()
            .map(|t| {
                (0..n)
                    .map(|i| f.covariance[i].iter().zip(t).map(|(a, b)| a * b).sum())
                    .collect()
            })
            .collect();
        for (s, cts) in ct.iter().enumerate() {
            for i in 0..n {
                cov[i * m + n + s] = cts[i];
                cov[(n + s) * m + i] = cts[i];
            }
            for (s2, t2) in t_rows.iter().enumerate() {
                cov[(n + s) * m + n + s2] = cts.iter().zip(t2).map(|(a, b)| a * b).sum();
            }
        }
        let slot: Vec<Option<usize>> = (0..18)
            .map(|c| straight.iter().position(|&x| x == c).map(|s| n + s))
            .collect();
        Extended {
            m,
            theta,
            cov,
            offsets,
            slot,
        }
    }

    /// g·θ and √(gᵀ C g) over the non-zero entries `idx` of the row `g`.
    fn value_sd(&self, g: &[f64], idx: &[usize]) -> (f64, f64) {
        let (m, theta, cov) = (self.m, &self.theta, &self.cov);
        let mut val = 0.0;
        let mut var = 0.0;
        for (a, &ka) in idx.iter().enumerate() {
            val += g[ka] * theta[ka];
            let row = &cov[ka * m..ka * m + m];
            let mut acc = 0.5 * row[ka] * g[ka];
            for &kb in &idx[a + 1..] {
                acc += row[kb] * g[kb];
            }
            var += 2.0 * g[ka] * acc;
        }
        (val, var.max(0.0).sqrt())
    }
}

/// One point's three effect rows and their non-zero entries: buffers reused over the
/// grid (no allocation per point).
struct GridRows {
    funcs: Vec<f64>,
    rows: [Vec<f64>; 3],
    nz: [Vec<usize>; 3],
    entries: Vec<(usize, f64)>,
}

impl GridRows {
    /// Empty buffers for rows of `m` entries.
    fn new(m: usize) -> GridRows {
        GridRows {
            funcs: Vec::new(),
            rows: [vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            nz: [Vec::new(), Vec::new(), Vec::new()],
            entries: Vec::new(),
        }
    }

    /// Fills the rows for point `p` (probe offset `probe_mm`): every component's basis
    /// functions times its unit effect there, then the squareness terms.
    fn fill(&mut self, f: &FitState, ext: &Extended, p: [f64; 3], probe_mm: [f64; 3]) {
        let topo = f.basis.topology();
        let GridRows {
            funcs,
            rows,
            nz,
            entries,
        } = self;
        for v in nz.iter_mut() {
            v.clear();
        }
        for (c, &off) in ext.offsets.iter().enumerate().take(18) {
            let comp = Component::from_index(c);
            let eff = comp.unit_effect(topo.lever_arm(comp.axis, p, probe_mm));
            entries.clear();
            match &f.basis.knots_mm {
                Some(knots) => {
                    let (hats, slope) = crate::volumetric::spline::sparse(
                        &knots[comp.axis],
                        comp.is_straightness(),
                        p[comp.axis],
                    );
                    entries.extend(
                        hats.iter()
                            .filter(|(j, v)| *j != usize::MAX && *v != 0.0)
                            .map(|(j, v)| (off + j, *v)),
                    );
                    if let Some(k) = ext.slot[c] {
                        entries.push((k, slope));
                    }
                }
                None => {
                    f.basis.functions_into(c, p[comp.axis], funcs);
                    entries.extend(funcs.iter().enumerate().map(|(j, b)| (off + j, *b)));
                }
            }
            for &(k, b) in entries.iter() {
                for i in 0..3 {
                    rows[i][k] = b * eff[i];
                    if eff[i] != 0.0 {
                        nz[i].push(k);
                    }
                }
            }
        }
        for s in 0..SQUARENESS.len() {
            let eff = squareness_effect(s, p);
            let k = ext.offsets[18 + s];
            for i in 0..3 {
                rows[i][k] = eff[i];
                if eff[i] != 0.0 {
                    nz[i].push(k);
                }
            }
        }
    }
}

/// The error vector and its one-sigma at many points from a fit whose 21 errors are all
/// determined (so every linear functional of the parameters is): E_i = g_i·θ and
/// σ_i² = g_iᵀ C g_i, with g_i the point's effect row for direction i. A row is sparse —
/// a translation component moves one direction, a rotation two; a table at knots has two
/// non-zero hat functions at a point, and a straightness table's slope term is carried as
/// one more quantity (its slope functional, with its variance and covariances added to C
/// once) — so the quadratic form runs over the row's non-zero entries only, on a
/// contiguous copy of C; no allocation per point. Cost O(points · nnz²).
fn grid_vectors(f: &FitState, points: &[[f64; 3]], probe_mm: [f64; 3]) -> Vec<VectorPrediction> {
    let ext = Extended::of(f);
    let mut buf = GridRows::new(ext.m);
    points
        .iter()
        .map(|&p| {
            buf.fill(f, &ext, p, probe_mm);
            let mut v = [0.0; 3];
            let mut sd = [0.0; 3];
            for i in 0..3 {
                (v[i], sd[i]) = ext.value_sd(&buf.rows[i], &buf.nz[i]);
            }
            (v, sd)
        })
        .collect()
}

/// The undetermined components, named, if any.
fn grid_blockers(f: &FitState) -> Option<String> {
    let names: Vec<String> = (0..21)
        .filter(|&c| !f.identified[c])
        .map(|c| {
            if c < 18 {
                Component::from_index(c).name()
            } else {
                SQUARENESS[c - 18].to_string()
            }
        })
        .collect();
    (!names.is_empty()).then(|| names.join(", "))
}

/// Writes line predictions as CSV/Parquet: `line,x_mm,y_mm,z_mm,e_um,sigma_um`.
pub fn write_predictions(path: &Path, preds: &[Prediction]) -> Result<(), VolumetricError> {
    use polars::prelude::*;
    let f = |g: &dyn Fn(&Prediction) -> f64| preds.iter().map(g).collect::<Vec<f64>>();
    let o = |g: &dyn Fn(&Prediction) -> Option<f64>| preds.iter().map(g).collect::<Vec<_>>();
    let cols = vec![
        Column::new(
            "line".into(),
            preds
                .iter()
                .map(|p| p.line.clone())
                .collect::<Vec<String>>(),
        ),
        Column::new("x_mm".into(), f(&|p| p.x_mm)),
        Column::new("y_mm".into(), f(&|p| p.y_mm)),
        Column::new("z_mm".into(), f(&|p| p.z_mm)),
        Column::new("e_um".into(), o(&|p| p.e_um)),
        Column::new("sigma_um".into(), o(&|p| p.sigma_um)),
    ];
    let mut df =
        DataFrame::new(preds.len(), cols).map_err(|e| crate::table::format_err(path, e))?;
    Ok(crate::table::write_frame(path, &mut df)?)
}

/// Writes the error vector over a grid: `x_mm,y_mm,z_mm,ex_um,ey_um,ez_um` (the spec's
/// columns; each component is an error table for `fit`, `compare`, `export`).
pub fn write_grid(
    path: &Path,
    points: &[[f64; 3]],
    errors: &[VectorPrediction],
) -> Result<(), VolumetricError> {
    use polars::prelude::*;
    let p = |k: usize| points.iter().map(|q| q[k]).collect::<Vec<f64>>();
    let e = |k: usize| errors.iter().map(|q| q.0[k]).collect::<Vec<f64>>();
    let cols = vec![
        Column::new("x_mm".into(), p(0)),
        Column::new("y_mm".into(), p(1)),
        Column::new("z_mm".into(), p(2)),
        Column::new("ex_um".into(), e(0)),
        Column::new("ey_um".into(), e(1)),
        Column::new("ez_um".into(), e(2)),
    ];
    let mut df =
        DataFrame::new(points.len(), cols).map_err(|e| crate::table::format_err(path, e))?;
    Ok(crate::table::write_frame(path, &mut df)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumetric::model::ComponentFn;
    use crate::volumetric::simulate::{Plan, preset};
    use crate::volumetric::{IdentifyConfig, Topology, identify, simulate};

    #[test]
    fn the_grid_fast_path_equals_the_functional_of_every_point() {
        let topo = Topology([2, 0, 1]);
        let mut m = Machine::perfect(topo);
        for (i, c) in Component::all().enumerate() {
            let s = if i % 2 == 0 { 1.0 } else { -1.0 };
            m.set(
                c,
                ComponentFn::Poly {
                    coeffs: vec![s * 0.5, 0.3 * s],
                    scale_mm: 500.0,
                },
            );
        }
        m.squareness_urad = [4.0, -3.0, 2.0];
        let vol = [[0.0, 0.0, 0.0], [500.0, 400.0, 300.0]];
        let plan = Plan {
            seed: 3,
            noise_um: 0.1,
            laser_zero_um: 1.0,
            feed_mm_s: 20.0,
            dwell_s: 4.0,
            setup_s: 60.0,
            lines: preset("rich", vol, 7, 80.0, 1).expect("preset"),
            thermal: None,
        };
        let table = simulate(&m, &plan);
        // Polynomials, and tables at knots (sparse hats plus the straightness slopes).
        for basis in [
            crate::volumetric::BasisKind::Poly,
            crate::volumetric::BasisKind::Spline,
        ] {
            let mut cfg = IdentifyConfig::new(topo);
            cfg.degree = crate::volumetric::Degree::Fixed(2);
            cfg.basis = basis;
            let id = identify(&table, &cfg).expect("identify");
            let points = [[0.0, 0.0, 0.0], [500.0, 400.0, 300.0], [123.0, 321.0, 77.0]];
            for probe in [[0.0; 3], [10.0, -20.0, 30.0]] {
                let fast = grid_vectors(&id.fit, &points, probe);
                for (p, (v, s)) in points.iter().zip(&fast) {
                    let rows = id.fit.basis.effect_rows(*p, probe);
                    for i in 0..3 {
                        let (a, b) = id.fit.functional(&rows[i]).expect("determined");
                        // A determined, smooth machine: σ of a fraction of a µm, and the
                        // fast path equal to the functional to rounding.
                        assert!(b < 1.0, "{basis}: σ {b} at {p:?}");
                        assert!(
                            (v[i] - a).abs() < 1e-9 * (1.0 + a.abs())
                                && (s[i] - b).abs() < 1e-9 * (1.0 + b.abs()),
                            "{basis}: {} vs {a}, {} vs {b}",
                            v[i],
                            s[i]
                        );
                    }
                }
            }
        }
    }
}
