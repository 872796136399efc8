//! Order/method comparison like the paper's Table 2 (seed 001), with cross-validation.
//!
//! Every method (and every admissible Lagrange order, or a given list) is fitted to the
//! error table and evaluated at the test points: RMS and max |error| against the measured
//! errors, per-point predictions, extrapolated points flagged. Independently of the test
//! points, each model gets a leave-one-plane-out cross-validated error on the fitting
//! table ([`crate::cv`]); the recommendation is the lowest cross-validated RMS and never
//! looks at the test points.

use crate::cv::{CvResult, leave_one_plane_out};
use crate::interp::{InterpError, Method, Order, fuzzy, lagrange::admissible_orders};
use crate::table::{ErrorTable, Grid};

/// Highest Lagrange degree per axis tried by default (`--orders all` on a dense grid
/// would otherwise mean thousands of orders).
pub const DEFAULT_MAX_DEGREE: usize = 5;

/// The default model list: trilinear, spline, fuzzy and every admissible Lagrange order.
pub fn default_methods(grid: &Grid, max_degree: usize) -> Vec<Method> {
    let mut m = vec![
        Method::Trilinear,
        Method::Spline,
        Method::Fuzzy {
            sigma: fuzzy::DEFAULT_SIGMA,
        },
        Method::Gp(crate::gp::Kernel::default()),
    ];
    m.extend(
        admissible_orders(grid.shape(), max_degree)
            .into_iter()
            .map(Method::Lagrange),
    );
    m
}

/// One model's results.
#[derive(Debug, Clone)]
pub struct ModelRow {
    pub method: Method,
    /// Against the test points' measured errors, µm.
    pub rms_um: f64,
    pub max_abs_um: f64,
    /// Same, over the test points inside the grid only (None when none is inside).
    pub inside_rms_um: Option<f64>,
    pub cv: CvResult,
    pub predictions: Vec<f64>,
    /// One-sigma uncertainty of each prediction for a measured value, where the method
    /// has one (the Gaussian process).
    pub sigmas: Vec<Option<f64>>,
    /// Fraction of test points whose measured error lies within ±1σ and ±2σ.
    pub within_1s: Option<f64>,
    pub within_2s: Option<f64>,
}

/// Where to measure next, from a Gaussian process fitted to the table.
#[derive(Debug, Clone)]
pub struct SamplingAdvice {
    pub length_scales_mm: [f64; 3],
    /// Median node spacing per axis, mm.
    pub spacing_mm: [f64; 3],
    pub kernel: String,
    pub signal_sd_um: f64,
    pub noise_sd_um: f64,
    /// The largest predictive σ over a lattice of the table's volume now, µm.
    pub max_sigma_um: f64,
    /// The next nodes, in order of how much each reduces the maximum predictive variance.
    pub next_nodes: Vec<[f64; 3]>,
}

/// Number of next nodes the advice proposes.
pub const ADVICE_NODES: usize = 5;

fn sampling_advice(table: &ErrorTable, grid: &Grid) -> Option<SamplingAdvice> {
    let gp = crate::gp::Gp::fit(&table.points, &crate::gp::GpConfig::default()).ok()?;
    let h = gp.hyper();
    let spacing_mm = [0, 1, 2].map(|a| {
        let mut d: Vec<f64> = grid.axis(a).windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        d.get(d.len() / 2).copied().unwrap_or(f64::NAN)
    });
    // Candidates: a 9-point lattice per axis over the table's volume.
    let lattice = |a: usize| -> Vec<f64> {
        let v = grid.axis(a);
        let (lo, hi) = (v[0], v[v.len() - 1]);
        (0..9).map(|k| lo + (hi - lo) * k as f64 / 8.0).collect()
    };
    let (lx, ly, lz) = (lattice(0), lattice(1), lattice(2));
    let mut candidates = Vec::with_capacity(729);
    for &z in &lz {
        for &y in &ly {
            for &x in &lx {
                candidates.push([x, y, z]);
            }
        }
    }
    Some(SamplingAdvice {
        length_scales_mm: h.length_scales_mm,
        spacing_mm,
        kernel: gp.kernel().name().to_string(),
        signal_sd_um: h.signal_sd_um,
        noise_sd_um: h.noise_sd_um,
        max_sigma_um: gp.max_sigma(&candidates),
        next_nodes: gp.next_nodes(&candidates, ADVICE_NODES),
    })
}

/// A paper column found in the test table (`paper_MxNxQ`) and what became of it.
#[derive(Debug, Clone)]
pub struct PaperColumn {
    pub order: Order,
    pub values: Vec<Option<f64>>,
    /// Our predictions for the same order, when it is admissible on the fitting grid.
    pub ours: Option<Vec<f64>>,
    /// Why it cannot be reproduced, when it cannot.
    pub refused: Option<String>,
}

/// The whole comparison.
#[derive(Debug, Clone)]
pub struct Comparison {
    pub fit_source: String,
    pub test: ErrorTable,
    pub grid: Grid,
    pub rows: Vec<ModelRow>,
    pub extrapolated: Vec<bool>,
    /// Index into `rows` of the model with the lowest cross-validated RMS.
    pub recommended: usize,
    pub paper: Vec<PaperColumn>,
    /// Sampling advice (when the Gaussian process is among the methods).
    pub advice: Option<SamplingAdvice>,
}

fn rms(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), r| (s + r * r, n + 1));
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// Fits every method and evaluates it. Fails on the first model that cannot be fitted
/// (e.g. an explicitly requested order that the grid does not allow).
pub fn compare(
    table: &ErrorTable,
    grid: &Grid,
    test: &ErrorTable,
    methods: &[Method],
) -> Result<Comparison, InterpError> {
    let pts: Vec<[f64; 3]> = test.points.iter().map(|p| p.position()).collect();
    let extrapolated: Vec<bool> = pts.iter().map(|&p| grid.outside(p)).collect();
    let mut rows = Vec::with_capacity(methods.len());
    for method in methods {
        let model = method.fit(grid)?;
        let mut predictions = vec![0.0; pts.len()];
        model.predict_into(&pts, &mut predictions);
        let resid = || {
            predictions
                .iter()
                .zip(&test.points)
                .map(|(p, t)| p - t.e_um)
        };
        let cv = leave_one_plane_out(grid, method)?;
        let sigmas: Vec<Option<f64>> = pts.iter().map(|&p| model.sigma(p)).collect();
        let within = |k: f64| -> Option<f64> {
            let hits: Vec<bool> = sigmas
                .iter()
                .zip(&predictions)
                .zip(&test.points)
                .filter_map(|((s, p), t)| s.map(|s| (p - t.e_um).abs() <= k * s))
                .collect();
            (!hits.is_empty())
                .then(|| hits.iter().filter(|h| **h).count() as f64 / hits.len() as f64)
        };
        let (within_1s, within_2s) = (within(1.0), within(2.0));
        rows.push(ModelRow {
            method: *method,
            rms_um: rms(resid()).unwrap_or(f64::NAN),
            max_abs_um: resid().fold(0.0, |m, r| m.max(r.abs())),
            inside_rms_um: rms(resid()
                .zip(&extrapolated)
                .filter(|(_, e)| !**e)
                .map(|(r, _)| r)),
            cv,
            predictions,
            sigmas,
            within_1s,
            within_2s,
        });
    }
    let recommended = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.cv.rms_um.is_finite())
        .min_by(|a, b| a.1.cv.rms_um.total_cmp(&b.1.cv.rms_um))
        .map(|(i, _)| i)
        .unwrap_or(0);
    let paper = paper_columns(test, grid);
    let advice = methods
        .iter()
        .any(|m| matches!(m, Method::Gp(_)))
        .then(|| sampling_advice(table, grid))
        .flatten();
    Ok(Comparison {
        fit_source: table.source.clone(),
        test: test.clone(),
        grid: grid.clone(),
        rows,
        extrapolated,
        recommended,
        paper,
        advice,
    })
}

/// Finds `paper_MxNxQ` columns in the test table and reproduces them where the grid allows.
fn paper_columns(test: &ErrorTable, grid: &Grid) -> Vec<PaperColumn> {
    let pts: Vec<[f64; 3]> = test.points.iter().map(|p| p.position()).collect();
    test.extra
        .iter()
        .filter_map(|c| {
            let order: Order = c.name.strip_prefix("paper_")?.parse().ok()?;
            let (ours, refused) = match Method::Lagrange(order).fit(grid) {
                Ok(model) => (Some(pts.iter().map(|&p| model.predict(p)).collect()), None),
                Err(e) => (None, Some(e.to_string())),
            };
            Some(PaperColumn {
                order,
                values: c.values.clone(),
                ours,
                refused,
            })
        })
        .collect()
}

impl Comparison {
    pub fn recommended_row(&self) -> &ModelRow {
        &self.rows[self.recommended]
    }

    /// Rank (1 = best) of a row by a key, among all rows.
    pub fn rank_by(&self, idx: usize, key: impl Fn(&ModelRow) -> f64) -> usize {
        let v = key(&self.rows[idx]);
        1 + self.rows.iter().filter(|r| key(r) < v).count()
    }

    pub fn find(&self, method: &Method) -> Option<usize> {
        self.rows.iter().position(|r| r.method == *method)
    }

    /// Index of the row with the lowest RMS on the test points.
    pub fn best_on_test(&self) -> usize {
        self.rows
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.rms_um.total_cmp(&b.1.rms_um))
            .map(|(i, _)| i)
            .unwrap_or(0)
    }

    /// Plain-words findings for an engineer deciding how many nodes to measure next time.
    pub fn findings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let shape = self.grid.shape();
        let n_test = self.extrapolated.len();
        let outside = self.extrapolated.iter().filter(|e| **e).count();
        out.push(format!(
            "Only {} of the {} test points lie inside the fitted grid; the other {} are extrapolations, \
             where every method is guessing beyond the measured nodes.",
            n_test - outside,
            n_test,
            outside
        ));
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            let nodes = self.grid.axis(a);
            if shape[a] == 2 {
                out.push(format!(
                    "{name} has only 2 nodes ({} and {} mm): no {name} degree above 1 is possible, any \
                     curvature along {name} is invisible to every method, and leaving one {name} plane out \
                     leaves a model that is constant along {name}. Measure at least 3–5 {name} positions next time.",
                    nodes[0], nodes[1]
                ));
            }
        }
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            let nodes = self.grid.axis(a);
            let on_nodes = self
                .test
                .points
                .iter()
                .all(|p| nodes.contains(&p.position()[a]));
            if on_nodes && shape[a] > 1 {
                out.push(format!(
                    "Every test point's {name} coordinate is one of the {name} nodes, so the {name} degree \
                     changes no test prediction: models differing only in it tie on the test points, and the \
                     test points say nothing about how well any model interpolates between {name} nodes."
                ));
            }
        }
        let rec = self.recommended_row();
        let best_idx = self.best_on_test();
        let best = &self.rows[best_idx];
        let ties: Vec<String> = self
            .rows
            .iter()
            .enumerate()
            .filter(|(i, r)| {
                *i != best_idx && (r.rms_um - best.rms_um).abs() <= 1e-9 * best.rms_um.max(1.0)
            })
            .map(|(_, r)| r.method.label())
            .collect();
        if !ties.is_empty() {
            out.push(format!(
                "{} models tie for the lowest test RMS ({:.4} µm): {}, {}.",
                ties.len() + 1,
                best.rms_um,
                best.method.label(),
                ties.join(", ")
            ));
        }
        out.push(format!(
            "Cross-validation on the fitting table recommends {} (CV RMS {:.3} µm). On the test points the \
             best model is {} (RMS {:.3} µm); the recommended model scores {:.3} µm there, rank {} of {}.",
            rec.method.label(),
            rec.cv.rms_um,
            best.method.label(),
            best.rms_um,
            rec.rms_um,
            self.rank_by(self.recommended, |r| r.rms_um),
            self.rows.len()
        ));
        for p in &self.paper {
            let Some(idx) = self.find(&Method::Lagrange(p.order)) else {
                continue;
            };
            let r = &self.rows[idx];
            out.push(format!(
                "The paper's {} is rank {} of {} on the test points (RMS {:.3} µm) but rank {} of {} by \
                 cross-validation (CV RMS {:.3} µm{}). A ranking on {} test points — {} of them extrapolated — \
                 is not a sound basis for choosing an order.",
                r.method.label(),
                self.rank_by(idx, |r| r.rms_um),
                self.rows.len(),
                r.rms_um,
                self.rank_by(idx, |r| r.cv.rms_um),
                self.rows.len(),
                r.cv.rms_um,
                if r.cv.capped_folds > 0 {
                    format!(
                        "; in {} of {} folds the degree had to be lowered because the remaining nodes \
                         could not carry it — a global polynomial through every node has no spare node to check it",
                        r.cv.capped_folds, r.cv.folds
                    )
                } else {
                    String::new()
                },
                n_test,
                outside
            ));
        }
        for r in &self.rows {
            if let (Some(w1), Some(w2)) = (r.within_1s, r.within_2s) {
                out.push(format!(
                    "{} gives each prediction an uncertainty: {:.0} % of the measured test errors lie within \
                     ±1σ and {:.0} % within ±2σ (a calibrated model: about 68 % and 95 %).",
                    r.method.label(),
                    100.0 * w1,
                    100.0 * w2
                ));
            }
        }
        if let Some(a) = &self.advice {
            for (k, name) in ["x", "y", "z"].iter().enumerate() {
                let (l, d) = (a.length_scales_mm[k], a.spacing_mm[k]);
                if d.is_finite() && d > l {
                    out.push(format!(
                        "The error's fitted correlation length along {name} ({l:.0} mm) is shorter than the node \
                         spacing ({d:.0} mm): the grid does not resolve the error along {name}, so no {name} order \
                         can be trusted between nodes. Halve the {name} spacing."
                    ));
                }
            }
        }
        for p in &self.paper {
            if let Some(why) = &p.refused {
                out.push(format!(
                    "The paper's {} column cannot be reproduced from this table: {}. The paper used nodes it \
                     did not publish; errmap does not invent them.",
                    p.order, why
                ));
            }
        }
        out
    }
}

/// The Lagrange order with the lowest leave-one-plane-out CV RMS among every admissible
/// order up to `max_degree` per axis (`--orders auto`); ties go to the lower total degree.
pub fn auto_order(grid: &Grid, max_degree: usize) -> Result<(Order, CvResult), InterpError> {
    let mut best: Option<(Order, CvResult)> = None;
    for order in admissible_orders(grid.shape(), max_degree) {
        let cv = leave_one_plane_out(grid, &Method::Lagrange(order))?;
        let better = match &best {
            None => true,
            Some((_, b)) => cv.rms_um < b.rms_um,
        };
        if better && cv.rms_um.is_finite() {
            best = Some((order, cv));
        }
    }
    best.ok_or(InterpError::EmptyAxis {
        axis: crate::table::Axis::X,
    })
}
