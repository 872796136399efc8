//! The probing test of ISO 10360-5:2010 (contacting styli, discrete points), evaluated
//! from a measured file and judged with the rules of [`super::rule`].
//!
//! | module | does | cost |
//! |---|---|---|
//! | `fit` | the least-squares (Gaussian) sphere, exact to 1e-9 mm; the points' singular values | O(n) per iteration, 3–6 iterations |
//! | `read` | SPHERE (the sphere's certificate, `[mpe]`, `[uncertainty]`) and POINTS, refused naming file, key, row, column | O(rows) |
//! | `simulate` | a probing test of a simulated CMM: the 25 targets, tip lobing, size error, noise, stylus offsets | O(points) |
//! | this file | form, size, location; their U and verdicts; deviations from the design; the refusals 3–7 | O(n log n) |
//!
//! **Form** = max r_i − min r_i of the fit's residuals r_i = |p_i − c| − r, judged against
//! [—, MPE_form] with U = √(F_s² + U(F_s)² + U_t,form²) (the sphere's own form enters at
//! its full value). **Size** = 2r − D_cal, against ±MPE_size with U = √(U(D)² +
//! U_t,size²). With several styli, form and size come from the all-points fit (every
//! point of every stylus together), and **location** = the largest of the three per-axis
//! ranges of the styli's own fitted centres, against [—, MPE_location] with U =
//! U_t,location, or reported unjudged without an MPE. `docs/acceptance.md` says which of
//! this was read from the standard and which is assumed.

mod fit;
mod read;
mod simulate;

use std::path::Path;

use serde::Serialize;

use self::fit::singular_values;
pub use self::fit::{FitError, SphereFit, fit_sphere};
pub use self::read::{
    PerQuantity, ProbePoint, ProbingConfig, ProbingOptions, SphereCertificate, SphereFile,
    read_points,
};
pub use self::simulate::{
    EXAMPLE_SPHERE, SimStylus, SimTest, direction, evaluate_example, example, frame, simulate,
    standard_targets_deg, to_csv,
};
use super::AcceptanceError;
use super::rule::{ConformityVerdict, Limits, Rule, aggregate};

/// The standard's name as the outputs print it.
pub const STANDARD: &str = "ISO 10360-5:2010";
/// Points per stylus in the standard's design; fewer are refused.
pub const POINTS_PER_STYLUS: usize = 25;
/// Styli of the standard's multi-stylus test.
pub const MULTI_STYLI: usize = 5;
/// The smallest test sphere the standard allows, mm.
pub const MIN_DIAMETER_MM: f64 = 10.0;
/// Coplanar or collinear: s₃ ≤ this · s₁.
pub const FLAT_RATIO: f64 = 1e-3;
/// A residual beyond this in its own stylus's fit is a point off the sphere, mm.
pub const OFF_SPHERE_MM: f64 = 0.1;
/// A stylus's fitted diameter further than this from D_cal is refused, mm.
pub const DIAMETER_TOL_MM: f64 = 0.1;

/// The sphere's certificate as the JSON prints it.
pub type SphereJson = SphereCertificate;

/// The all-points fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitJson {
    pub centre_mm: [f64; 3],
    pub diameter_mm: f64,
    pub rms_um: f64,
}

/// One stylus's own fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StylusResult {
    pub stylus: String,
    pub points: usize,
    pub centre_mm: [f64; 3],
    pub diameter_mm: f64,
    /// The range of its own fit's residuals, µm.
    pub form_um: f64,
    /// 2r_k − D_cal, µm.
    pub size_um: f64,
}

/// A judged quantity (form, size).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Judged {
    pub value_um: f64,
    pub mpe_um: f64,
    pub u_um: f64,
    /// [T_L + w, T_U − w], null for an absent side.
    pub acceptance_um: [Option<f64>; 2],
    pub verdict: ConformityVerdict,
}

/// The multi-stylus location error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Location {
    pub value_um: f64,
    /// The range of the styli's centres along x, y, z, µm.
    pub axes_um: [f64; 3],
    pub mpe_um: Option<f64>,
    pub u_um: f64,
    pub acceptance_um: Option<[Option<f64>; 2]>,
    pub verdict: Option<ConformityVerdict>,
}

/// One point's residual in the all-points fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Residual {
    pub row: usize,
    pub stylus: String,
    pub point: usize,
    pub r_um: f64,
    /// The probed point (for `residuals.csv` and the map; not in the JSON).
    #[serde(skip)]
    pub p_mm: [f64; 3],
}

/// `acceptance iso10360-5 --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProbingResult {
    pub standard: &'static str,
    /// `single-stylus` or `multi-stylus`.
    pub test: &'static str,
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub statement: String,
    pub sphere: SphereJson,
    pub points: usize,
    pub fit: FitJson,
    pub styli: Vec<StylusResult>,
    pub form: Judged,
    pub size: Judged,
    pub location: Option<Location>,
    pub residuals: Vec<Residual>,
    pub deviations: Vec<String>,
    pub verdict: ConformityVerdict,
}

impl ProbingResult {
    /// Whether any U entering a decision is above 0.
    pub fn u_given(&self) -> bool {
        self.form.u_um > 0.0
            || self.size.u_um > 0.0
            || self
                .location
                .as_ref()
                .is_some_and(|l| l.verdict.is_some() && l.u_um > 0.0)
    }
}

/// Reads SPHERE (and applies `options`), then POINTS, and evaluates the test: every
/// refusal of the contract in its order.
pub fn evaluate_files(
    points: &Path,
    sphere: &Path,
    options: &ProbingOptions,
) -> Result<ProbingResult, AcceptanceError> {
    let config = ProbingConfig::resolve(sphere, SphereFile::read(sphere)?, options)?;
    let rows = read_points(points)?;
    evaluate(points, &rows, &config)
}

/// The styli in first-appearance order, each with the indices of its points.
fn group(points: &[ProbePoint]) -> Vec<(String, Vec<usize>)> {
    let mut styli: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, p) in points.iter().enumerate() {
        match styli.iter_mut().find(|s| s.0 == p.stylus) {
            Some(s) => s.1.push(i),
            None => styli.push((p.stylus.clone(), vec![i])),
        }
    }
    styli
}

/// Refusals 3 and 4: a (stylus, point) pair twice, a stylus with too few points.
fn check_design(
    path: &Path,
    points: &[ProbePoint],
    styli: &[(String, Vec<usize>)],
) -> Result<(), AcceptanceError> {
    let mut seen: std::collections::HashMap<(&str, usize), usize> = Default::default();
    for p in points {
        if let Some(first) = seen.insert((p.stylus.as_str(), p.point), p.row) {
            return Err(AcceptanceError::file(
                path,
                format!(
                    "rows {first} and {} (lines {} and {}): stylus `{}`, point {} is given twice",
                    p.row,
                    first + 1,
                    p.row + 1,
                    p.stylus,
                    p.point
                ),
            ));
        }
    }
    for (name, idx) in styli {
        if idx.len() < POINTS_PER_STYLUS {
            return Err(AcceptanceError::file(
                path,
                format!(
                    "stylus `{name}`: {} point(s), the test needs {POINTS_PER_STYLUS}",
                    idx.len()
                ),
            ));
        }
    }
    Ok(())
}

/// Refusals 5–7 and each stylus's own fit.
fn fit_styli(
    path: &Path,
    points: &[ProbePoint],
    styli: &[(String, Vec<usize>)],
    d_cal_mm: f64,
) -> Result<Vec<SphereFit>, AcceptanceError> {
    let coords = |idx: &[usize]| -> Vec<[f64; 3]> { idx.iter().map(|&i| points[i].p_mm).collect() };
    for (name, idx) in styli {
        let s = singular_values(&coords(idx));
        if s[2].is_nan() || s[2] <= FLAT_RATIO * s[0] {
            return Err(AcceptanceError::file(
                path,
                format!(
                    "stylus `{name}`: the points are coplanar or collinear (singular values \
                     {:.4e}, {:.4e}, {:.4e} mm: s₃ ≤ {FLAT_RATIO}·s₁), no sphere is determined",
                    s[0], s[1], s[2]
                ),
            ));
        }
    }
    let mut fits = Vec::with_capacity(styli.len());
    for (name, idx) in styli {
        let f = fit_sphere(&coords(idx))
            .map_err(|e| AcceptanceError::file(path, format!("stylus `{name}`: {e}")))?;
        fits.push(f);
    }
    for ((name, idx), f) in styli.iter().zip(&fits) {
        let (k, r) = f
            .residuals_mm
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map(|(k, r)| (k, *r))
            .unwrap_or((0, 0.0));
        if r.abs() > OFF_SPHERE_MM {
            let p = &points[idx[k]];
            return Err(AcceptanceError::row(
                path,
                p.row,
                None,
                format!(
                    "stylus `{name}`, point {}: {:.4} mm off its stylus's least-squares sphere \
                     (more than {OFF_SPHERE_MM} mm): not a point of the sphere",
                    p.point, r
                ),
            ));
        }
    }
    for ((name, _), f) in styli.iter().zip(&fits) {
        let d = 2.0 * f.radius_mm;
        if (d - d_cal_mm).abs() > DIAMETER_TOL_MM {
            return Err(AcceptanceError::file(
                path,
                format!(
                    "stylus `{name}`: fitted diameter {d:.5} mm differs from the sphere's \
                     diameter_mm {d_cal_mm} mm by more than {DIAMETER_TOL_MM} mm (another \
                     sphere, or an uncorrected tip radius?)"
                ),
            ));
        }
    }
    Ok(fits)
}

/// How the test departs from the standard's design.
fn deviations(styli: &[(String, Vec<usize>)], config: &ProbingConfig) -> Vec<String> {
    let mut out = Vec::new();
    let n = styli.len();
    if n != 1 && n != MULTI_STYLI {
        out.push(format!(
            "{n} styli where the standard's test uses 1 (single-stylus) or {MULTI_STYLI} \
             (multi-stylus)"
        ));
    }
    for (name, idx) in styli {
        if idx.len() != POINTS_PER_STYLUS {
            out.push(format!(
                "stylus `{name}`: {} points where the standard asks for {POINTS_PER_STYLUS}",
                idx.len()
            ));
        }
    }
    let d = config.sphere.diameter_mm;
    if d < MIN_DIAMETER_MM {
        out.push(format!(
            "test sphere Ø {d} mm where the standard asks for at least {MIN_DIAMETER_MM} mm"
        ));
    }
    if n == 1 && config.mpe_location_um.is_some() {
        out.push(
            "an MPE for location was given but the test has one stylus: location is not \
             evaluated"
                .to_string(),
        );
    }
    out
}

/// The decision statement: the rule's words, then what each quantity is judged against.
fn statement(config: &ProbingConfig, u_given: bool, multi: bool) -> String {
    let rule = &config.rule;
    let mut s = rule.statement(u_given, Some(2.0));
    s.push_str(&format!(
        " Form is judged against [—, MPE_form = {} µm] with U = √(F_s² + U(F_s)² + U_t,form²) \
         (the sphere's form at its full value); size (2r − D_cal) against ±MPE_size = ±{} µm \
         with U = √(U(D)² + U_t,size²)",
        config.mpe_form_um, config.mpe_size_um
    ));
    match (multi, config.mpe_location_um) {
        (true, Some(m)) => s.push_str(&format!(
            "; location against [—, MPE_location = {m} µm] with U = U_t,location."
        )),
        (true, None) => s.push_str("; location is reported, not judged (no MPE_location given)."),
        (false, _) => s.push('.'),
    }
    if rule.rule == Rule::Iso14253 {
        s.push_str(
            " Pass proves conformity (acceptance test), fail proves nonconformity \
             (reverification), indeterminate proves neither.",
        );
    }
    s
}

fn stylus_results(
    styli: &[(String, Vec<usize>)],
    fits: &[SphereFit],
    d_cal_mm: f64,
) -> Vec<StylusResult> {
    styli
        .iter()
        .zip(fits)
        .map(|((name, idx), f)| StylusResult {
            stylus: name.clone(),
            points: idx.len(),
            centre_mm: f.centre_mm,
            diameter_mm: 2.0 * f.radius_mm,
            form_um: f.form_mm() * 1e3,
            size_um: (2.0 * f.radius_mm - d_cal_mm) * 1e3,
        })
        .collect()
}

/// The location error of several styli's centres, judged when an MPE is given.
fn location(
    styli: &[StylusResult],
    config: &ProbingConfig,
) -> Result<Option<Location>, AcceptanceError> {
    if styli.len() < 2 {
        return Ok(None);
    }
    let mut axes_um = [0.0; 3];
    for (k, a) in axes_um.iter_mut().enumerate() {
        let hi = styli
            .iter()
            .map(|s| s.centre_mm[k])
            .fold(f64::MIN, f64::max);
        let lo = styli
            .iter()
            .map(|s| s.centre_mm[k])
            .fold(f64::MAX, f64::min);
        *a = (hi - lo) * 1e3;
    }
    let value_um = axes_um.iter().copied().fold(0.0, f64::max);
    let u_um = config.u_test[2];
    let (acceptance_um, verdict) = match config.mpe_location_um {
        Some(m) => {
            let d = config.rule.decide(
                value_um,
                u_um,
                Limits {
                    lower: None,
                    upper: Some(m),
                },
            )?;
            (Some(d.acceptance), Some(d.verdict))
        }
        None => (None, None),
    };
    Ok(Some(Location {
        value_um,
        axes_um,
        mpe_um: config.mpe_location_um,
        u_um,
        acceptance_um,
        verdict,
    }))
}

/// Evaluates the points of `path` (already read) with `config`: refusals 3–7, then the
/// fits, the quantities and their verdicts.
pub fn evaluate(
    path: &Path,
    points: &[ProbePoint],
    config: &ProbingConfig,
) -> Result<ProbingResult, AcceptanceError> {
    if points.is_empty() {
        return Err(AcceptanceError::file(path, "no data rows"));
    }
    let styli = group(points);
    check_design(path, points, &styli)?;
    let d_cal = config.sphere.diameter_mm;
    let fits = fit_styli(path, points, &styli, d_cal)?;
    let all: Vec<[f64; 3]> = points.iter().map(|p| p.p_mm).collect();
    let whole = fit_sphere(&all)
        .map_err(|e| AcceptanceError::file(path, format!("all points together: {e}")))?;
    let sph = &config.sphere;
    let [ut_form, ut_size, _] = config.u_test;
    let rule = &config.rule;
    let form_um = whole.form_mm() * 1e3;
    let u_form = (sph.form_um.powi(2) + sph.u_form_um.powi(2) + ut_form.powi(2)).sqrt();
    let df = rule.decide(
        form_um,
        u_form,
        Limits {
            lower: None,
            upper: Some(config.mpe_form_um),
        },
    )?;
    let size_um = (2.0 * whole.radius_mm - d_cal) * 1e3;
    let u_size = (sph.u_diameter_um.powi(2) + ut_size.powi(2)).sqrt();
    let m = config.mpe_size_um;
    let ds = rule.decide(
        size_um,
        u_size,
        Limits {
            lower: Some(-m),
            upper: Some(m),
        },
    )?;
    let styli_results = stylus_results(&styli, &fits, d_cal);
    let location = location(&styli_results, config)?;
    let form = Judged {
        value_um: form_um,
        mpe_um: config.mpe_form_um,
        u_um: u_form,
        acceptance_um: df.acceptance,
        verdict: df.verdict,
    };
    let size = Judged {
        value_um: size_um,
        mpe_um: m,
        u_um: u_size,
        acceptance_um: ds.acceptance,
        verdict: ds.verdict,
    };
    let verdict = aggregate(
        [form.verdict, size.verdict]
            .into_iter()
            .chain(location.as_ref().and_then(|l| l.verdict)),
    )
    .unwrap_or(ConformityVerdict::Pass);
    let multi = styli.len() > 1;
    let u_given = u_form > 0.0
        || u_size > 0.0
        || (location.as_ref().is_some_and(|l| l.verdict.is_some()) && config.u_test[2] > 0.0);
    let residuals = points
        .iter()
        .zip(&whole.residuals_mm)
        .map(|(p, r)| Residual {
            row: p.row,
            stylus: p.stylus.clone(),
            point: p.point,
            r_um: r * 1e3,
            p_mm: p.p_mm,
        })
        .collect();
    Ok(ProbingResult {
        standard: STANDARD,
        test: if multi {
            "multi-stylus"
        } else {
            "single-stylus"
        },
        rule: rule.rule.name(),
        guard_fraction: rule.fraction_shown(),
        statement: statement(config, u_given, multi),
        sphere: sph.clone(),
        points: points.len(),
        fit: FitJson {
            centre_mm: whole.centre_mm,
            diameter_mm: 2.0 * whole.radius_mm,
            rms_um: whole.rms_mm() * 1e3,
        },
        styli: styli_results,
        form,
        size,
        location,
        residuals,
        deviations: deviations(&styli, config),
        verdict,
    })
}
