//! The checks a selected term must pass to be reported: the joint final fit with the
//! covariance at the optimum ([`Selector::final_fit`]), the support of a periodic term
//! ([`Selector::periodic_support`]), undetermined or implausible parameters and a negative
//! dead path ([`Selector::first_problem`]), and the sampling lattices behind the
//! quantisation floor ([`Selector::sampling_lattices_mm`], [`lattice_alias`]).
//!
//! Called from `candidates` (the periodic support) and from [`Selector::run`]; calls no
//! other file of `select`.

use crate::base::ParamName as P;
use std::collections::BTreeMap;

use crate::diagnose::effects::{self, Kind, Variant};
use crate::diagnose::engine::{Fit, pinv_sym, solve};
use crate::diagnose::words::fixed;

use super::{FittedTerm, Selector, Term, ids_of};

/// Why a periodic term is not reported as a scale's periodic error
/// ([`Selector::periodic_support`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub(super) enum Unsupported {
    /// The moving rows alone do not carry it: its Δχ² there is below the need.
    #[error("not supported by the moving samples alone (Δχ² = {gain:.1} < {need:.1})")]
    Moving { gain: f64, need: f64 },
    /// Its amplitude in one third of the axis disagrees with the whole.
    #[error(
        "its amplitude is not uniform along the axis ({part_um:.4} ± {sigma_um:.4} µm at {}–{} mm against {whole_um:.4} µm overall)",
        fixed(*.from_mm, 0),
        fixed(*.to_mm, 0)
    )]
    NotUniform {
        part_um: f64,
        sigma_um: f64,
        from_mm: f64,
        to_mm: f64,
        whole_um: f64,
    },
}

/// The sampling pitch (mm) of which `period_mm` is a sub-multiple s/k (k = 1‥64, within
/// 1 %), if any.
pub(super) fn lattice_alias(period_mm: f64, lattices: &[f64]) -> Option<f64> {
    lattices.iter().copied().find(|&s| {
        let k = (s / period_mm).round();
        (1.0..=64.0).contains(&k) && (s / k - period_mm).abs() <= 0.01 * period_mm
    })
}

/// Δχ² a periodic term must reach on the moving rows alone (independent phases), about
/// 5σ for two parameters; raised for wide searches by [`Selector::moving_support_chi2`].
pub(super) const MOVING_SUPPORT_CHI2: f64 = 25.0;

/// Parameters of two effects correlated beyond this (|ρ|) are reported as hard to
/// separate.
const CORRELATED: f64 = 0.95;

impl Selector<'_> {
    /// The spacing of successive moving samples, mm, one per feed: feed × sample interval.
    /// Along a move at constant speed the samples sit on a lattice of this pitch, so the
    /// scale's counter quantisation — and anything else tied to the counter's grid — is
    /// in phase at every one of them; a periodogram shows that as peaks at the pitch and
    /// its sub-multiples.
    pub(super) fn sampling_lattices_mm(&self) -> Vec<f64> {
        let o = self.obs;
        let mut by_feed: BTreeMap<i64, Vec<f64>> = BTreeMap::new();
        for seg in &o.moves {
            for w in seg.windows(2) {
                let (a, b) = (w[0], w[1]);
                let dx = (o.x[b] - o.x[a]).abs();
                if o.v_feed[b] > 0.0 && dx > 0.0 {
                    by_feed
                        .entry((o.v_feed[b] * 1000.0).round() as i64)
                        .or_default()
                        .push(dx);
                }
            }
        }
        by_feed
            .into_values()
            .filter(|v| v.len() >= 10)
            .map(|mut v| {
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            })
            .collect()
    }

    /// Why a found `dead_path` is not physical: with the model's own dead path D₀ known,
    /// D₀ + D more than two sigmas below zero.
    fn negative_dead_path(&self, f: &FittedTerm) -> Option<String> {
        let d0 = self.cfg.model_dead_path_mm?;
        if f.term.kind != Kind::DeadPath {
            return None;
        }
        let p = f.params.iter().find(|p| p.name == P::DeadPathMm)?;
        (d0 + p.value < -2.0 * p.sigma).then(|| {
            format!(
                "dead_path_mm = {:.1} ± {:.1} on the model's {d0:.1} mm makes the dead path {:.1} mm: \
                 a length cannot be negative",
                p.value,
                p.sigma,
                d0 + p.value
            )
        })
    }

    /// Whether a periodic term (columns `s`, `c`) is supported by the data the way a
    /// periodic scale error is, on `resid` (the residual without it):
    /// - on the moving rows alone, whose positions are independent draws of the phase
    ///   (rows of one dwell share their phase, so unmodelled structure at a few dwell
    ///   positions can mimic a short period): Δχ² ≥ [`Selector::moving_support_chi2`];
    /// - along the axis: its amplitude in each third of the x range agrees with the
    ///   whole (within 3σ or a factor of 2), as a scale's interpolation error does and a
    ///   local bump does not.
    pub(super) fn periodic_support(
        &self,
        resid: &[f64],
        s: &[f64],
        c: &[f64],
    ) -> Result<(), Unsupported> {
        let w = self.engine.w();
        let n = resid.len();
        let whole = small_fit(resid, w, &[s, c], None);
        let amp = whole.coef[1].hypot(whole.coef[2]);
        let moving: Vec<usize> = (0..n).filter(|&k| self.obs.moving[k]).collect();
        if moving.len() >= 50 {
            let base = small_fit(resid, w, &[], Some(&moving)).chi2;
            let with = small_fit(resid, w, &[s, c], Some(&moving));
            let dof = (moving.len() as f64 - 3.0).max(1.0);
            let s2 = (with.chi2 / dof).max(1e-300);
            let gain = (base - with.chi2) / s2;
            let need = self.moving_support_chi2();
            if gain < need {
                return Err(Unsupported::Moving { gain, need });
            }
        }
        let (lo, hi) = self
            .obs
            .x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let third = (hi - lo) / 3.0;
        for part in 0..3 {
            let a = lo + part as f64 * third;
            let b = if part == 2 { hi + 1.0 } else { a + third };
            let rows: Vec<usize> = (0..n)
                .filter(|&k| self.obs.x[k] >= a && self.obs.x[k] < b)
                .collect();
            if rows.len() < 30 {
                continue;
            }
            let f = small_fit(resid, w, &[s, c], Some(&rows));
            let dof = (rows.len() as f64 - 3.0).max(1.0);
            let s2 = (f.chi2 / dof).max(self.cfg.min_variance_factor);
            let (sc, cc) = (f.coef[1], f.coef[2]);
            let ap = sc.hypot(cc).max(1e-300);
            let var = ((sc / ap).powi(2) * f.cov[1][1]
                + 2.0 * (sc / ap) * (cc / ap) * f.cov[1][2]
                + (cc / ap).powi(2) * f.cov[2][2])
                * s2;
            let sd = var.max(0.0).sqrt();
            let tol = 3.0 * sd;
            if ap + tol < 0.5 * amp || ap - tol > 2.0 * amp {
                return Err(Unsupported::NotUniform {
                    part_um: ap,
                    sigma_um: sd,
                    from_mm: a,
                    to_mm: b.min(hi),
                    whole_um: amp,
                });
            }
        }
        Ok(())
    }

    /// The first reason not to report a selected term: a periodic term without support,
    /// an undetermined parameter, an implausible one.
    pub(super) fn first_problem(
        &mut self,
        terms: &[Term],
        fitted: &[FittedTerm],
    ) -> Option<(usize, String)> {
        let cfg = self.cfg;
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        let resid = self.residual(&ids, &fit);
        for (i, f) in fitted.iter().enumerate() {
            if f.term.kind == Kind::Periodic {
                let without: Vec<f64> = resid
                    .iter()
                    .zip(&f.contribution)
                    .map(|(r, c)| r + c)
                    .collect();
                let (s, c) = (
                    self.engine.col(f.term.cols[0]),
                    self.engine.col(f.term.cols[1]),
                );
                if let Err(why) = self.periodic_support(&without, s, c) {
                    return Some((i, why.to_string()));
                }
            }
            let why = effects::undetermined(&f.params, cfg.max_relative_uncertainty)
                .map(|p| {
                    format!(
                        "{} = {:.4} ± {:.4} is not determined (one-sigma above {:.0} % of the value)",
                        p.name,
                        p.value,
                        p.sigma,
                        100.0 * cfg.max_relative_uncertainty
                    )
                })
                .or_else(|| effects::implausible(f.term.kind, &f.params, self.obs))
                .or_else(|| self.negative_dead_path(f));
            if let Some(w) = why {
                return Some((i, w));
            }
        }
        None
    }

    /// Per parameter, the factor (≥ 1) by which the cluster-robust standard error exceeds
    /// the model-based one. Rows of one dwell share the dwell's own positioning offset,
    /// and rows of one move share its counter-quantisation offset, so they are not
    /// independent; the sandwich (JᵀWJ)⁻¹·Σ_c u_c u_cᵀ·(JᵀWJ)⁻¹, u_c = Σ_{k∈c} w_k·J_k·e_k
    /// over these clusters, counts each as one draw (used with a static map, where the
    /// dwell-to-dwell scatter is left in the residual).
    fn cluster_inflation(
        &self,
        ids: &[usize],
        fit: &Fit,
        jac: &[Vec<f64>],
        inv: &[Vec<f64>],
        s2: f64,
    ) -> Vec<f64> {
        let p = jac.len();
        let e = self.residual(ids, fit);
        let w = self.engine.w();
        let cluster = crate::diagnose::data::clusters(self.obs);
        let nc = cluster.iter().copied().max().map_or(0, |m| m + 1);
        let mut u = vec![vec![0.0; p]; nc];
        for (k, &c) in cluster.iter().enumerate() {
            let we = w[k] * e[k];
            for a in 0..p {
                u[c][a] += we * jac[a][k];
            }
        }
        // Small-sample factor of the cluster sandwich: C/(C − 1).
        let scale = nc as f64 / (nc as f64 - 1.0).max(1.0);
        (0..p)
            .map(|a| {
                // (inv·M·inv)_aa = Σ_c (Σ_b inv_ab u_cb)².
                let robust: f64 = u
                    .iter()
                    .map(|uc| {
                        let v: f64 = (0..p).map(|b| inv[a][b] * uc[b]).sum();
                        v * v
                    })
                    .sum::<f64>()
                    * scale;
                let model = inv[a][a] * s2;
                if model > 0.0 && robust > model {
                    (robust / model).sqrt()
                } else {
                    1.0
                }
            })
            .collect()
    }

    /// Joint fit with the covariance of every term's parameters at the optimum.
    pub(super) fn final_fit(&mut self, terms: &[Term]) -> Vec<FittedTerm> {
        let ids = ids_of(terms);
        let fit = self.engine.fit(&ids);
        let n = self.n();
        // Jacobian columns: the linear ones, then one derivative per nonlinear term.
        let mut jac: Vec<Vec<f64>> = ids.iter().map(|&id| self.engine.col(id).to_vec()).collect();
        let mut nl_index: Vec<Option<usize>> = Vec::new();
        let mut offset = 1;
        for t in terms {
            let coef = &fit.coef[offset..offset + t.cols.len()];
            offset += t.cols.len();
            match effects::nonlinear_derivative(&t.variant, coef, self.obs) {
                Some(dcol) => {
                    nl_index.push(Some(jac.len()));
                    jac.push(self.engine.project(dcol));
                }
                None => nl_index.push(None),
            }
        }
        let p = jac.len();
        let w = self.engine.w();
        let mut jtj = vec![vec![0.0; p]; p];
        for a in 0..p {
            for b in a..p {
                let (ja, jb) = (&jac[a], &jac[b]);
                let mut s = 0.0;
                for k in 0..n {
                    s += w[k] * ja[k] * jb[k];
                }
                jtj[a][b] = s;
                jtj[b][a] = s;
            }
        }
        let inv = pinv_sym(&jtj);
        let dof = (n as f64 - p as f64 - self.engine.absorbed() as f64).max(1.0);
        let s2 = (fit.chi2 / dof).max(self.cfg.min_variance_factor);
        let inflate = if self.engine.absorbed() > 0 {
            self.cluster_inflation(&ids, &fit, &jac, &inv, s2)
        } else {
            vec![1.0; p]
        };
        // Parameters of different effects that the data hardly separate.
        let mut owner: Vec<Option<(usize, &'static str)>> = vec![None; p];
        let mut offset = 1;
        for (ti, t) in terms.iter().enumerate() {
            let names = effects::coef_names(t.kind, &t.variant);
            for (q, name) in names.iter().take(t.cols.len()).enumerate() {
                owner[offset + q] = Some((ti, name.as_str()));
            }
            offset += t.cols.len();
            if let (Some(j), Some(name)) = (nl_index[ti], names.get(t.cols.len())) {
                owner[j] = Some((ti, name.as_str()));
            }
        }
        self.correlated.clear();
        for a in 0..p {
            for b in a + 1..p {
                if let (Some((ta, na)), Some((tb, nb))) = (owner[a], owner[b])
                    && ta != tb
                {
                    let d = (inv[a][a] * inv[b][b]).sqrt();
                    let rho = if d > 0.0 { inv[a][b] / d } else { 0.0 };
                    if rho.abs() > CORRELATED
                        && self
                            .correlated
                            .iter()
                            .all(|c| (c.0, c.2) != (terms[ta].kind, terms[tb].kind))
                    {
                        self.correlated
                            .push((terms[ta].kind, na, terms[tb].kind, nb, rho));
                    }
                }
            }
        }
        let mut out = Vec::new();
        let mut offset = 1;
        for (ti, t) in terms.iter().enumerate() {
            let lin: Vec<usize> = (offset..offset + t.cols.len()).collect();
            offset += t.cols.len();
            let mut idx = lin.clone();
            let mut th: Vec<f64> = lin.iter().map(|&i| fit.coef[i]).collect();
            if let Some(j) = nl_index[ti] {
                idx.push(j);
                th.push(match t.variant {
                    Variant::Periodic { period_um } => period_um,
                    Variant::DriftExp { tau_s } => tau_s,
                    _ => 0.0,
                });
            }
            let cov: Vec<Vec<f64>> = idx
                .iter()
                .map(|&a| {
                    idx.iter()
                        .map(|&b| inv[a][b] * s2 * inflate[a] * inflate[b])
                        .collect()
                })
                .collect();
            let params = effects::params(t.kind, &t.variant, &th, &cov);
            let coef: Vec<f64> = lin.iter().map(|&i| fit.coef[i]).collect();
            let contribution = self.engine.predict(&t.cols, &coef);
            out.push(FittedTerm {
                term: t.clone(),
                params,
                contribution,
                notes: Vec::new(),
            });
        }
        out
    }
}

impl Selector<'_> {
    /// Every vocabulary parameter of the selected effects, fitted jointly: a term chosen
    /// in a reduced variant (x0 = 0, θ0 or θ1 alone, one air column of refraction) is
    /// refitted in its full variant with all the others, and the parameters the selection
    /// left out come back with their one-sigma (not subject to the determinedness rule:
    /// "consistent with zero" is an answer). The reduced variant stays, with the reason
    /// in the term's notes, when the full one is not independent of the other terms or
    /// would leave a selected parameter undetermined. Selection and ΔBIC are unchanged.
    pub(super) fn complete(&mut self, terms: &[Term]) -> (Vec<Term>, Vec<FittedTerm>) {
        let mut terms = terms.to_vec();
        let mut notes: Vec<Vec<String>> = vec![Vec::new(); terms.len()];
        let mut added: Vec<Vec<P>> = vec![Vec::new(); terms.len()];
        for i in 0..terms.len() {
            let (kind, variant) = (terms[i].kind, terms[i].variant.clone());
            let Some(full) = full_variant(kind, &variant) else {
                continue;
            };
            let selected = effects::coef_names(kind, &variant);
            let missing: Vec<P> = effects::coef_names(kind, &full)
                .into_iter()
                .filter(|p| !selected.contains(p))
                .collect();
            let names = missing
                .iter()
                .map(|p| p.as_str())
                .collect::<Vec<_>>()
                .join(", ");
            let Some((_, cols)) = effects::static_variants(kind, &self.cols)
                .into_iter()
                .find(|(v, _)| *v == full)
            else {
                notes[i].push(format!(
                    "{names} not fitted: {}",
                    match kind {
                        Kind::ScaleThermal =>
                            "the scale temperature did not change, so x0 acts like a constant",
                        Kind::Refraction =>
                            "the other air column did not change during the session",
                        _ => "its column is not available on these data",
                    }
                ));
                continue;
            };
            let mut trial = terms.clone();
            trial[i] = Term {
                kind,
                variant: full,
                cols,
            };
            let fit = self.engine.fit(&ids_of(&trial));
            if !fit.independent.iter().all(|&b| b) {
                notes[i].push(format!(
                    "{names} not fitted: its signature is not independent of the other terms on these data"
                ));
                continue;
            }
            let fitted = self.final_fit(&trial);
            let kept: Vec<_> = fitted[i]
                .params
                .iter()
                .filter(|p| selected.contains(&p.name))
                .cloned()
                .collect();
            if let Some(p) = effects::undetermined(&kept, self.cfg.max_relative_uncertainty) {
                notes[i].push(format!(
                    "{names} not fitted: fitted jointly it would leave {} undetermined ({:.4} ± {:.4})",
                    p.name, p.value, p.sigma
                ));
                continue;
            }
            terms = trial;
            added[i] = missing;
        }
        let mut fitted = self.final_fit(&terms);
        for ((f, n), a) in fitted.iter_mut().zip(notes).zip(added) {
            for p in &mut f.params {
                if a.contains(&p.name) {
                    p.key = false;
                }
            }
            f.notes = n;
        }
        (terms, fitted)
    }
}

/// The variant of a kind that fits every vocabulary parameter, when `v` is a reduced one.
fn full_variant(kind: Kind, v: &Variant) -> Option<Variant> {
    match (kind, v) {
        (Kind::ScaleThermal, Variant::X0Fixed) => Some(Variant::X0Free),
        (Kind::Abbe(_), Variant::AbbeTheta0 | Variant::AbbeTheta1) => Some(Variant::AbbeFull),
        (Kind::Refraction, Variant::RefrT | Variant::RefrP) => Some(Variant::RefrBoth),
        _ => None,
    }
}

/// Weighted fit of `y` by a constant and `cols` on the rows `rows` (all rows: None).
fn small_fit(y: &[f64], w: &[f64], cols: &[&[f64]], rows: Option<&[usize]>) -> Fit {
    let k = cols.len() + 1;
    let mut g = vec![vec![0.0; k]; k];
    let mut gy = vec![0.0; k];
    let mut yy = 0.0;
    let mut row = vec![0.0; k];
    let mut add = |r: usize| {
        row[0] = 1.0;
        for (c, col) in cols.iter().enumerate() {
            row[c + 1] = col[r];
        }
        for a in 0..k {
            let wa = w[r] * row[a];
            gy[a] += wa * y[r];
            for b in a..k {
                g[a][b] += wa * row[b];
            }
        }
        yy += w[r] * y[r] * y[r];
    };
    match rows {
        Some(idx) => idx.iter().for_each(|&r| add(r)),
        None => (0..y.len()).for_each(add),
    }
    for a in 0..k {
        for b in 0..a {
            g[a][b] = g[b][a];
        }
    }
    solve(&g, &gy, yy)
}

#[cfg(test)]
mod lattice_tests {
    use super::lattice_alias;

    #[test]
    fn sub_multiples_of_the_sampling_pitch_are_aliases() {
        // 120 mm/s at 50 Hz: a 2.4 mm pitch; 60 mm/s: 1.2 mm.
        let pitches = [2.4, 1.2];
        assert_eq!(lattice_alias(0.6, &pitches), Some(2.4));
        assert_eq!(lattice_alias(0.599_97, &pitches), Some(2.4));
        assert_eq!(lattice_alias(1.2, &pitches), Some(2.4));
        assert_eq!(lattice_alias(0.7, &pitches), None);
        assert_eq!(lattice_alias(5.0, &pitches), None);
        assert_eq!(lattice_alias(0.6, &[]), None);
    }
}
