//! The identification as a document: `identify --json`, the report's `model.json` and
//! `identify --out` (the same, with the fit `predict` and `export` need). One type for
//! writing and reading, so the file's schema is this struct: it is written through the
//! finiteness guard (`report::finite`: a NaN is an error, never a silent `null`) and read
//! back by deserialising into it plus one [`ModelDoc::check`].
//!
//! Keys are in alphabetical order, as earlier releases wrote them. `basis` says which
//! family the components are (`poly` or `spline`); `smoothing` (tables at knots) the
//! criterion, λ and effective degrees of freedom per component and the Birge ratio;
//! `degree`, `cv`, `cv_each` and `component_degrees` are the polynomial basis'.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::basis::BasisKind;
use super::degree::EachScore;
use super::identify::{
    CvScore, FitState, Identification, ResidualVerdict, Smoothing, Unidentified,
};
use super::model::{Component, SQUARENESS, Topology};
use super::thermal::ThermalTest;

/// One entry of `components`: a function of its axis (18) or a squareness (3). `values`
/// and `sigma` are `null` where the lines do not determine the component.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ComponentDoc {
    Function {
        identified: bool,
        positions_mm: Vec<f64>,
        sigma: Option<Vec<f64>>,
        unit: String,
        values: Option<Vec<f64>>,
    },
    Constant {
        identified: bool,
        sigma: Option<f64>,
        unit: String,
        value: Option<f64>,
    },
}

/// The document. `R` is the residual's type: [`ResidualVerdict`] when written; a reader
/// that only needs the fit may skip it (`serde::de::IgnoredAny`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelDoc<R = ResidualVerdict> {
    pub basis: BasisKind,
    /// Degree of each component (polynomials; absent for tables).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub component_degrees: BTreeMap<String, usize>,
    pub components: BTreeMap<String, ComponentDoc>,
    #[serde(default)]
    pub cv: Vec<CvScore>,
    pub cv_each: Option<EachScore>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub degree: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitState>,
    pub gauge: String,
    pub lines: usize,
    pub residual: R,
    pub rms_residual_um: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub smoothing: Option<Smoothing>,
    pub targets: usize,
    pub thermal: Option<ThermalTest>,
    pub topology: Topology,
    pub unidentified: Vec<Unidentified>,
}

/// What is wrong with a read document: it holds no fit, or a key and the problem.
#[derive(Debug, Clone, PartialEq)]
pub enum DocProblem {
    /// No `fit`: the document is not an identified model.
    NoFit,
    /// A key and what is wrong with it.
    Bad { key: &'static str, message: String },
}

impl<R> ModelDoc<R> {
    /// The fit, checked: present, sizes consistent with its basis (18 degrees or three
    /// knot vectors of at least 3 increasing knots with 0 among them), every number
    /// finite.
    pub fn check(&self) -> Result<&FitState, DocProblem> {
        let problem = |key, message: String| DocProblem::Bad { key, message };
        let fit = self.fit.as_ref().ok_or(DocProblem::NoFit)?;
        let b = &fit.basis;
        match &b.knots_mm {
            Some(knots) => {
                let ok = b.degrees.is_empty()
                    && knots.iter().all(|k| {
                        k.len() >= 3
                            && k.windows(2).all(|w| w[0] < w[1])
                            && k.contains(&0.0)
                            && k.iter().all(|t| t.is_finite())
                    });
                if !ok {
                    return Err(problem(
                        "fit.basis.knots_mm",
                        "each axis needs at least 3 increasing finite knots, 0 among them, and \
                         no degrees"
                            .into(),
                    ));
                }
            }
            None => {
                if b.degrees.len() != 18 || b.degrees.iter().any(|d| *d == 0 || *d > 64) {
                    return Err(problem(
                        "fit.basis.degrees",
                        "18 degrees between 1 and 64".into(),
                    ));
                }
            }
        }
        let n = b.n_params();
        let ok = fit.theta.len() == n
            && fit.column_scale.len() == n
            && fit.identified.len() == 21
            && fit.covariance.len() == n
            && fit.covariance.iter().all(|r| r.len() == n)
            && fit.null_space.len() == n
            && fit.null_space.windows(2).all(|w| w[0].len() == w[1].len())
            && (fit.roughness.is_empty()
                || (fit.roughness.len() == 18
                    && b.knots_mm.is_some()
                    && fit.roughness.iter().all(|q| *q >= 0.0)));
        if !ok {
            return Err(problem(
                "fit",
                format!("inconsistent sizes for {n} parameters"),
            ));
        }
        let finite = fit
            .theta
            .iter()
            .chain(fit.covariance.iter().flatten())
            .chain(fit.null_space.iter().flatten())
            .chain(&fit.column_scale)
            .chain(&fit.roughness)
            .chain(b.range_mm.iter().flatten())
            .all(|v| v.is_finite())
            && fit.column_scale.iter().all(|s| *s > 0.0)
            && b.scale_mm.iter().all(|s| s.is_finite() && *s > 0.0);
        if !finite {
            return Err(problem(
                "fit",
                "non-finite parameter, covariance or scale".into(),
            ));
        }
        Ok(fit)
    }
}

impl Identification {
    /// The document; with `with_fit`, the state `predict` needs (`--out`, `model.json`).
    pub fn doc(&self, positions: usize, with_fit: bool) -> ModelDoc {
        let mut components = BTreeMap::new();
        for c in Component::all() {
            let i = c.index();
            let pos = self.positions(c.axis, positions);
            let vals: Option<Vec<(f64, f64)>> =
                pos.iter().map(|&a| self.fit.component(i, a)).collect();
            components.insert(
                c.name(),
                ComponentDoc::Function {
                    identified: self.fit.identified[i],
                    sigma: vals.as_ref().map(|v| v.iter().map(|x| x.1).collect()),
                    values: vals.as_ref().map(|v| v.iter().map(|x| x.0).collect()),
                    positions_mm: pos,
                    unit: c.unit().to_string(),
                },
            );
        }
        for (i, name) in SQUARENESS.iter().enumerate() {
            let v = self.fit.squareness(i);
            components.insert(
                name.to_string(),
                ComponentDoc::Constant {
                    identified: self.fit.identified[18 + i],
                    unit: "urad".into(),
                    value: v.map(|x| x.0),
                    sigma: v.map(|x| x.1),
                },
            );
        }
        let basis = self.fit.basis.kind();
        ModelDoc {
            basis,
            component_degrees: match basis {
                BasisKind::Poly => Component::all()
                    .map(|c| (c.name(), self.fit.basis.degrees[c.index()]))
                    .collect(),
                BasisKind::Spline => BTreeMap::new(),
            },
            components,
            cv: self.cv.clone(),
            cv_each: self.cv_each.clone(),
            degree: (basis == BasisKind::Poly).then_some(self.degree),
            fit: with_fit.then(|| self.fit.clone()),
            gauge: super::GAUGE.to_string(),
            lines: self.lines,
            residual: self.residual.clone(),
            rms_residual_um: self.rms_residual_um,
            smoothing: self.smoothing.clone(),
            targets: self.targets,
            thermal: self.thermal.clone(),
            topology: self.topology,
            unidentified: self.unidentified.clone(),
        }
    }
}
