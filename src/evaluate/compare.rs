//! Order/method comparison like Table 2 of Zhang Mei, "CMM Measurement Error Model Based on
//! High-order Lagrange Interpolation" (2013), with cross-validation.
//!
//! Every method (and every admissible Lagrange order, or a given list) is fitted to the
//! error table and evaluated at the test points: RMS and max |error| against the measured
//! errors, per-point predictions, extrapolated points flagged. Independently of the test
//! points, each model gets a leave-one-plane-out cross-validated error on the fitting
//! table ([`crate::evaluate::cv`]); the recommendation is the lowest cross-validated RMS and never
//! looks at the test points.

use crate::evaluate::cv::{CvResult, leave_one_out_gp, leave_one_plane_out, rms};
use crate::interp::{InterpError, Interpolator, Method, Order, admissible_orders};
use crate::table::{ErrorTable, Grid};

pub use crate::table::Extent;

/// Highest Lagrange degree per axis tried by default (`--orders all` on a dense grid
/// would otherwise mean thousands of orders).
pub const DEFAULT_MAX_DEGREE: usize = 5;

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
    /// One-sigma uncertainty of each prediction for a measured value: the model's own
    /// (the Gaussian process), or else the cross-validated one ([`CvResult::sigma`]).
    pub sigmas: Vec<Option<f64>>,
    /// Where `sigmas` come from.
    pub sigma_kind: Option<SigmaKind>,
    /// Fraction of test points whose measured error lies within ±1σ and ±2σ.
    pub within_1s: Option<f64>,
    pub within_2s: Option<f64>,
    /// The largest |measured − predicted| / σ over the test points.
    pub max_abs_z: Option<f64>,
}

/// The source of a model's prediction uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SigmaKind {
    /// The model's own predictive σ (Gaussian process: latent σ plus the fitted noise).
    Model,
    /// The method's cross-validated RMS on held-out nodes like the point (interior or
    /// end planes): an empirical, homoscedastic σ for the interpolators.
    CrossValidation,
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

/// Methods (by name) not fitted to a table, each with the reason.
pub type Refusals = Vec<(String, String)>;

/// Number of next nodes the advice proposes.
pub(crate) const ADVICE_NODES: usize = 5;

/// Sampling advice from a Gaussian process fitted with the default configuration: `gp`
/// when the caller has one, else fitted here to the table.
fn sampling_advice(
    table: &ErrorTable,
    extent: &Extent,
    gp: Option<crate::interp::Gp>,
) -> Option<SamplingAdvice> {
    let gp = match gp {
        Some(gp) => gp,
        None => crate::interp::Gp::fit(&table.points, &crate::interp::GpConfig::default()).ok()?,
    };
    let h = gp.hyper();
    // Candidates: a 9-point lattice per axis over the table's volume.
    let lattice = |a: usize| -> Vec<f64> {
        let [lo, hi] = extent.bounds[a];
        if hi > lo {
            (0..9).map(|k| lo + (hi - lo) * k as f64 / 8.0).collect()
        } else {
            vec![lo]
        }
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
        spacing_mm: extent.spacing_mm,
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
    /// Number of fitting nodes.
    pub fit_nodes: usize,
    pub test: ErrorTable,
    /// The fitting grid; `None` for a scattered table (Gaussian process only).
    pub grid: Option<Grid>,
    /// Box and spacing of the fitting nodes.
    pub extent: Extent,
    /// Methods (by name) that cannot be fitted to this table, with the reason
    /// (scattered tables).
    pub refused: Refusals,
    pub rows: Vec<ModelRow>,
    pub extrapolated: Vec<bool>,
    /// Index into `rows` of the model with the lowest cross-validated RMS.
    pub recommended: usize,
    pub paper: Vec<PaperColumn>,
    /// Sampling advice (when the Gaussian process is among the methods).
    pub advice: Option<SamplingAdvice>,
}

/// Fits every method and evaluates it. Fails on the first model that cannot be fitted
/// (e.g. an explicitly requested order that the grid does not allow).
pub fn compare(
    table: &ErrorTable,
    grid: &Grid,
    test: &ErrorTable,
    methods: &[Method],
) -> Result<Comparison, InterpError> {
    compare_grid(table, grid, test, methods, false)
}

/// [`compare`] for a default list of methods: a method that cannot be fitted to this grid
/// (or to a cross-validation fold of it; e.g. the Gaussian process on fewer than 3 nodes)
/// is listed in [`Comparison::refused`] with the reason instead of failing the whole
/// comparison. Fails only when no method can be fitted.
pub fn compare_where_possible(
    table: &ErrorTable,
    grid: &Grid,
    test: &ErrorTable,
    methods: &[Method],
) -> Result<Comparison, InterpError> {
    compare_grid(table, grid, test, methods, true)
}

fn compare_grid(
    table: &ErrorTable,
    grid: &Grid,
    test: &ErrorTable,
    methods: &[Method],
    lenient: bool,
) -> Result<Comparison, InterpError> {
    let extent = Extent::of_grid(grid);
    let mut rows = Vec::with_capacity(methods.len());
    let mut refused = Refusals::new();
    for method in methods {
        let fitted = method.fit(grid).and_then(|model| {
            let cv = leave_one_plane_out(grid, method).map_err(|e| match e {
                InterpError::Gp(why) if lenient => {
                    InterpError::Gp(format!("{why} (in a cross-validation fold)"))
                }
                e => e,
            })?;
            Ok((model, cv))
        });
        match fitted {
            Ok((model, cv)) => rows.push(ModelRow::evaluate(*method, model.as_ref(), cv, test)),
            Err(e) if lenient => refused.push((method.label(), e.to_string())),
            Err(e) => return Err(e),
        }
    }
    if rows.is_empty() {
        let why = refused.first().map(|r| r.1.clone()).unwrap_or_default();
        return Err(InterpError::NothingFits { why });
    }
    let advice = rows
        .iter()
        .any(|r| matches!(r.method, Method::Gp(_)))
        .then(|| sampling_advice(table, &extent, None))
        .flatten();
    Ok(Comparison::assemble(
        table,
        Some(grid),
        extent,
        test,
        rows,
        refused,
        advice,
    ))
}

/// [`compare`] for a scattered table (nodes not on a full rectilinear grid): only the
/// methods that accept scattered nodes (the Gaussian process) are fitted, each
/// cross-validated leave-one-out ([`leave_one_out_gp`]). `refused` lists the methods the
/// caller left out, each with the reason (which should name a missing grid node).
pub fn compare_scattered(
    table: &ErrorTable,
    test: &ErrorTable,
    methods: &[Method],
    refused: Refusals,
) -> Result<Comparison, InterpError> {
    let extent = Extent::of_points(table);
    let values: Vec<f64> = table.points.iter().map(|p| p.e_um).collect();
    let mut rows = Vec::new();
    // The default-kernel model, kept for the sampling advice (which would fit it again).
    let mut default_gp = None;
    for method in methods {
        let Method::Gp(kernel) = *method else {
            return Err(InterpError::NeedsGrid {
                method: method.name(),
            });
        };
        let config = crate::interp::GpConfig {
            kernel,
            ..crate::interp::GpConfig::default()
        };
        let gp = crate::interp::Gp::fit(&table.points, &config)
            .map_err(|e| InterpError::Gp(e.to_string()))?;
        let cv = leave_one_out_gp(&gp, &values);
        rows.push(ModelRow::evaluate(*method, &gp, cv, test));
        if config == crate::interp::GpConfig::default() {
            default_gp = Some(gp);
        }
    }
    if rows.is_empty() {
        return Err(InterpError::Gp(
            "no Gaussian-process model to compare".into(),
        ));
    }
    let advice = sampling_advice(table, &extent, default_gp);
    Ok(Comparison::assemble(
        table, None, extent, test, rows, refused, advice,
    ))
}

impl ModelRow {
    /// A fitted model's predictions at the test points, their errors and calibration.
    fn evaluate(
        method: Method,
        model: &dyn Interpolator,
        cv: CvResult,
        test: &ErrorTable,
    ) -> ModelRow {
        let pts: Vec<[f64; 3]> = test.points.iter().map(|p| p.position()).collect();
        let mut predictions = vec![0.0; pts.len()];
        model.predict_into(&pts, &mut predictions);
        let own: Vec<Option<f64>> = pts.iter().map(|&p| model.sigma(p)).collect();
        let (sigmas, sigma_kind) = if own.iter().any(Option::is_some) {
            (own, Some(SigmaKind::Model))
        } else {
            let cv_sigmas: Vec<Option<f64>> =
                pts.iter().map(|&p| cv.sigma(model.outside(p))).collect();
            let kind = cv_sigmas
                .iter()
                .any(Option::is_some)
                .then_some(SigmaKind::CrossValidation);
            (cv_sigmas, kind)
        };
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
        // A σ of 0 (a table of exact zeros cross-validates to 0) gives no z: 0/0 or
        // r/0 would be NaN or inf in the report.
        let max_abs_z = sigmas
            .iter()
            .zip(&predictions)
            .zip(&test.points)
            .filter_map(|((s, p), t)| s.filter(|s| *s > 0.0).map(|s| (p - t.e_um).abs() / s))
            .reduce(f64::max);
        let resid: Vec<f64> = predictions
            .iter()
            .zip(&test.points)
            .map(|(p, t)| p - t.e_um)
            .collect();
        let inside: Vec<f64> = resid
            .iter()
            .zip(&pts)
            .filter(|(_, p)| !model.outside(**p))
            .map(|(r, _)| *r)
            .collect();
        ModelRow {
            method,
            rms_um: rms(&resid).unwrap_or(f64::NAN),
            max_abs_um: resid.iter().fold(0.0, |m, r| m.max(r.abs())),
            inside_rms_um: rms(&inside),
            cv,
            predictions,
            sigmas,
            sigma_kind,
            within_1s,
            within_2s,
            max_abs_z,
        }
    }
}

impl Comparison {
    /// Ranks the rows by cross-validation and adds the paper columns.
    fn assemble(
        table: &ErrorTable,
        grid: Option<&Grid>,
        extent: Extent,
        test: &ErrorTable,
        rows: Vec<ModelRow>,
        refused: Refusals,
        advice: Option<SamplingAdvice>,
    ) -> Comparison {
        let extrapolated: Vec<bool> = test
            .points
            .iter()
            .map(|p| extent.outside(p.position()))
            .collect();
        let recommended = rows
            .iter()
            .enumerate()
            .filter(|(_, r)| r.cv.rms_um.is_finite())
            .min_by(|a, b| a.1.cv.rms_um.total_cmp(&b.1.cv.rms_um))
            .map(|(i, _)| i)
            .unwrap_or(0);
        let paper = paper_columns(test, grid);
        Comparison {
            fit_source: table.source.clone(),
            fit_nodes: table.points.len(),
            test: test.clone(),
            grid: grid.cloned(),
            extent,
            refused,
            rows,
            extrapolated,
            recommended,
            paper,
            advice,
        }
    }
}

/// Finds `paper_MxNxQ` columns in the test table and reproduces them where the grid allows.
fn paper_columns(test: &ErrorTable, grid: Option<&Grid>) -> Vec<PaperColumn> {
    let pts: Vec<[f64; 3]> = test.points.iter().map(|p| p.position()).collect();
    test.extra
        .iter()
        .filter_map(|c| {
            let order: Order = c.name.strip_prefix("paper_")?.parse().ok()?;
            let fitted = match grid {
                Some(grid) => Method::Lagrange(order).fit(grid),
                None => Err(InterpError::NeedsGrid { method: "lagrange" }),
            };
            let (ours, refused) = match fitted {
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
}

/// The most grid nodes [`auto_order`] accepts: it fits every admissible order (up to 64)
/// once per grid plane, so its cost grows faster than the square of the nodes (minutes
/// at 10⁶). Larger grids are refused with [`InterpError::TooLargeForAuto`].
pub const AUTO_ORDER_MAX_NODES: usize = 50_000;

/// The Lagrange order with the lowest leave-one-plane-out CV RMS among every admissible
/// order up to `max_degree` per axis (`--orders auto`); ties go to the lower total degree.
/// Refuses grids of more than [`AUTO_ORDER_MAX_NODES`] nodes.
pub fn auto_order(grid: &Grid, max_degree: usize) -> Result<(Order, CvResult), InterpError> {
    let nodes = grid.values.len();
    if nodes > AUTO_ORDER_MAX_NODES {
        return Err(InterpError::TooLargeForAuto {
            nodes,
            max: AUTO_ORDER_MAX_NODES,
        });
    }
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
