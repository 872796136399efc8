//! Findings in plain words about a comparison: what the grid's shape, the test points and
//! the cross-validation mean for an engineer deciding how many nodes to measure next time.

use crate::evaluate::{Comparison, SigmaKind};
use crate::interp::Method;
use crate::table::{ErrorTable, Grid};

impl Comparison {
    /// Plain-words findings for an engineer deciding how many nodes to measure next time.
    pub fn findings(&self) -> Vec<String> {
        let mut out = Vec::new();
        self.coverage_findings(&mut out);
        self.ranking_findings(&mut out);
        self.paper_findings(&mut out);
        self.uncertainty_findings(&mut out);
        self.sampling_findings(&mut out);
        out
    }

    /// Where the test points lie, what was not fitted, and what the grid's shape allows.
    fn coverage_findings(&self, out: &mut Vec<String>) {
        let n_test = self.extrapolated.len();
        let outside = self.extrapolated.iter().filter(|e| **e).count();
        let within = if self.grid.is_some() {
            "the fitted grid"
        } else {
            "the box of the fitting nodes"
        };
        if outside > 0 {
            out.push(format!(
                "Only {} of the {} test points lie inside {within}; the other {} are extrapolations, \
                 where every method is guessing beyond the measured nodes.",
                n_test - outside,
                n_test,
                outside
            ));
        } else {
            out.push(format!("All {n_test} test points lie inside {within}."));
        }
        if self.grid.is_none() && !self.refused.is_empty() {
            let names: Vec<&str> = self.refused.iter().map(|(m, _)| m.as_str()).collect();
            out.push(format!(
                "The fitting table is scattered, not a full grid, so only the Gaussian process is fitted; \
                 {} cannot be, as {}. Cross-validation leaves out one node at a time.",
                names.join(", "),
                self.refused[0].1
            ));
        } else {
            for (names, why) in group_by_reason(&self.refused) {
                out.push(format!("Not fitted: {} — {why}.", names.join(", ")));
            }
        }
        if let Some(grid) = &self.grid {
            out.extend(grid_findings(grid, &self.test));
        }
    }

    /// Ties for the best test RMS, and the cross-validation's pick against the test points' best.
    fn ranking_findings(&self, out: &mut Vec<String>) {
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
    }

    /// Where each of the paper's orders ranks, on the test points and by cross-validation.
    fn paper_findings(&self, out: &mut Vec<String>) {
        let n_test = self.extrapolated.len();
        let outside = self.extrapolated.iter().filter(|e| **e).count();
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
    }

    /// How well the models' σ covers the test errors.
    fn uncertainty_findings(&self, out: &mut Vec<String>) {
        for r in &self.rows {
            if r.sigma_kind != Some(SigmaKind::Model) {
                continue;
            }
            if let (Some(w1), Some(w2), Some(z)) = (r.within_1s, r.within_2s, r.max_abs_z) {
                out.push(format!(
                    "{} gives each prediction an uncertainty: {:.0} % of the measured test errors lie within \
                     ±1σ and {:.0} % within ±2σ (a calibrated model: about 68 % and 95 %); the worst lies at \
                     {:.2}σ.",
                    r.method.label(),
                    100.0 * w1,
                    100.0 * w2,
                    z
                ));
            }
        }
        let rec = self.recommended_row();
        if rec.sigma_kind == Some(SigmaKind::CrossValidation)
            && let (Some(w1), Some(w2)) = (rec.within_1s, rec.within_2s)
        {
            out.push(format!(
                "The interpolators have no uncertainty of their own; errmap gives each the RMS of its \
                 cross-validated predictions as one (end planes for extrapolated points, interior planes \
                 otherwise). For the recommended {} that is ±{} µm inside and ±{} µm outside the nodes, \
                 and {:.0} % / {:.0} % of the measured test errors lie within ±1σ / ±2σ.",
                rec.method.label(),
                fmt_opt(rec.cv.interior_rms_um.or(Some(rec.cv.rms_um))),
                fmt_opt(rec.cv.exterior_rms_um.or(Some(rec.cv.rms_um))),
                100.0 * w1,
                100.0 * w2
            ));
        }
    }

    /// Axes the grid does not resolve, and the paper's columns that cannot be reproduced.
    fn sampling_findings(&self, out: &mut Vec<String>) {
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
        let refused: Vec<(String, String)> = self
            .paper
            .iter()
            .filter_map(|p| Some((p.order.to_string(), p.refused.clone()?)))
            .collect();
        for (orders, why) in group_by_reason(&refused) {
            out.push(format!(
                "The paper's {} column{} cannot be reproduced from this table: {}.{}",
                orders.join(", "),
                if orders.len() > 1 { "s" } else { "" },
                why,
                if self.grid.is_some() {
                    " The paper used nodes it did not publish; errmap does not invent them."
                } else {
                    ""
                }
            ));
        }
    }
}

fn fmt_opt(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "—".into(), |v| format!("{v:.3}"))
}

/// What the grid's shape means for the orders and for the test points.
fn grid_findings(grid: &Grid, test: &ErrorTable) -> Vec<String> {
    let mut out = Vec::new();
    let shape = grid.shape();
    let single: Vec<String> = (0..3)
        .filter(|&a| shape[a] == 1)
        .map(|a| format!("{} = {} mm", ["x", "y", "z"][a], grid.axis(a)[0]))
        .collect();
    if !single.is_empty() {
        out.push(format!(
            "The table was measured on a single {} ({}): every model is constant across it, and a \
             point off it is an extrapolation.",
            if single.len() == 2 { "line" } else { "plane" },
            single.join(", ")
        ));
    }
    for (a, name) in ["x", "y", "z"].iter().enumerate() {
        let nodes = grid.axis(a);
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
        let nodes = grid.axis(a);
        let on_nodes = test.points.iter().all(|p| nodes.contains(&p.position()[a]));
        if on_nodes && shape[a] > 1 {
            out.push(format!(
                "Every test point's {name} coordinate is one of the {name} nodes, so the {name} degree \
                 changes no test prediction: models differing only in it tie on the test points, and the \
                 test points say nothing about how well any model interpolates between {name} nodes."
            ));
        }
    }
    out
}

/// Groups (item, reason) pairs by reason, keeping first-seen order.
pub fn group_by_reason(items: &[(String, String)]) -> Vec<(Vec<&str>, &str)> {
    let mut out: Vec<(Vec<&str>, &str)> = Vec::new();
    for (item, why) in items {
        match out.iter_mut().find(|(_, w)| *w == why.as_str()) {
            Some((names, _)) => names.push(item),
            None => out.push((vec![item.as_str()], why.as_str())),
        }
    }
    out
}
