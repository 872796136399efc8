//! Missing-physics diagnosis: find, name and model what a simulation left out of a
//! recording (`errmap diagnose`, `docs/cli.md` and `docs/vocabulary.md`).
//!
//! The residual r = recorded − simulated error is matched on (run, sample) and explained
//! by a free constant plus effects of the contract's vocabulary, each a parametric model
//! in the recorded covariates (position x, direction d, feed v, time t, scale and air
//! temperatures, air pressure, line offsets):
//!
//! | stage | method | cost (n rows, k columns) |
//! |---|---|---|
//! | match (`data`) | hash join on (run, sample); flagged, duplicate, non-finite, other-axis rows counted and left out | O(n) |
//! | noise | σ per run × moving/dwell group from first differences (1.4826·MAD/√2), then from the first model's residuals; weights 1/σ², selection repeated when a σ moves by > 15 % | O(n log n) |
//! | outliers | a first-model residual more than 6 σ from the median of its neighbours in the same dwell or move gets weight 0, and the selection is repeated | O(n log n) |
//! | spectrum (`spectral`) | weighted Lomb–Scargle with a floating mean over the exact x of the moving rows: narrow windows around P, P/2, P/4 and broad scans of periods 0.5 mm – L/10 and 4 P – 0.5 mm; a periodic term needs Δχ² ≥ max(25, 2·ln(N/0.01)) on the moving rows, N the independent frequencies searched | ≤ 2·[`DiagnoseConfig::spectral_budget`] row·frequencies |
//! | fit (`engine`) | weighted least squares on memoised cross products; an ordered Cholesky gives the rank and the dependent columns | O(n·k) per new column, then O(k³) per fit |
//! | select (`select`) | forward BIC with variants, τ profiled jointly, backward BIC, swap moves, leave-one-run-out CV, determinedness and plausibility with restart, ambiguity | O(effects² · k³) fits + O(n·k) per nonlinear trial |
//! | locate (`locate`) | weighted group means along x, per line, run, direction, feed, over time; correlations; periodogram peaks; structure left after the model | O(n) |
//! | report (in the `report` stage: `report/diagnosis.rs`) | Markdown + PNG/SVG charts | O(n) |
//!
//! **Honesty rules.** An effect is reported only when (1) it lowers BIC by at least
//! [`DiagnoseConfig::min_delta_bic`] on top of the others, (2) removing it does not lower
//! the leave-one-run-out cross-validated error, (3) its key parameters are determined
//! (one-sigma ≤ [`DiagnoseConfig::max_relative_uncertainty`] × |value|) and physically
//! possible (a scale's fixed point x0 near the axis), (4) a periodic term is carried by
//! the moving samples alone and has one amplitude along the whole axis, and (5) it
//! explains at least [`DiagnoseConfig::min_effect_fraction_of_noise`] of the noise σ and
//! more than counter quantisation fits by chance. With sampling locked to the counter's
//! grid the quantisation error (uniform over the scale step q found in the recorded
//! readings, σ = q/√12) is constant along a move and differs between moves, so N moves
//! give N independent offsets and an effect with k parameters picks up about
//! (q/√12)·√(k/N) of them by chance; the floor is three times that, at most q/√12, and
//! the whole q/√12 for a period that divides the moving samples' pitch (on a 0.1 µm
//! counter, clean sessions otherwise blamed 0.008–0.018 µm of this on refraction, dead
//! path, Abbe or a 0.6 mm "period"). A
//! refused effect is named in `ambiguities` with the reason, and the selection starts
//! again without it so that a better explanation can take its place. Effects that these
//! data cannot tell apart are named together in `where` and `ambiguities`, with the
//! measurement that would separate them; one of them is reported, with the reason. When
//! nothing in the vocabulary explains a residual that is not noise, the verdict is still
//! `missing_physics`, with one effect `unexplained` that says where the structure is.
//!
//! Uncertainties are the covariance at the optimum scaled by the residual variance; on
//! seeded random draws the standardised errors (estimate − truth)/σ have an RMS of
//! 0.9–1.2 for every parameter (see `tests/diagnose_random.rs`).
//!
//! **Without a simulation** ([`diagnose_recorded`]) the static part is the recording's
//! own: a level per line, target and direction on dwell rows and a straight line per line,
//! direction and 1/40 of the travel on moving rows, absorbed by the within transform of
//! `engine` (joint with the effects, Frisch–Waugh–Lovell); `scale_factor`, `reversal` and
//! `abbe` are that map and are not tested, and the one-sigma values are cluster-robust
//! over dwells and moves (a dwell's samples share its positioning offset, which the map
//! leaves in the residual). [`remove_found`] takes the found effects out of a recording,
//! e.g. for its ISO 230-2 figures without the drift.
//!
//! A 100 000-row session takes about 1 s in release (`tests/diagnose_perf.rs`).
//!
//! **Submodules**, one line each:
//!
//! | module | holds |
//! |---|---|
//! | `config` | [`DiagnoseConfig`]: defaults, ranges, [`COMMON_GRATINGS_UM`] |
//! | `error` | [`DiagnoseError`] |
//! | `outcome` | [`Diagnosis`], [`Verdict`], [`FoundEffect`], [`NoiseGroup`], [`CandidateScore`], [`ReportSeries`], [`EffectSeries`] |
//! | `data` | matching on (run, sample), covariates, noise groups, cross-validation folds |
//! | `engine` | weighted least squares on memoised cross products, ordered Cholesky |
//! | `effects` | the vocabulary as regressors, parameters, the measurement that separates two effects |
//! | `spectral` | weighted Lomb–Scargle periodogram with a floating mean |
//! | `select` | model selection: forward and backward BIC, cross-validation, final checks, ambiguity |
//! | `locate` | where the residual is significant, which covariates it follows |
//! | `explain` | the selection's outcome as a [`Diagnosis`]: `where` texts, ambiguities, chart series |
//! | `words` | numbers and lists in words |
//! | `synth` | seeded synthetic sessions for tests ([`Synth`], [`synthesize`]) |

// Index loops mirror the formulas of the small dense linear algebra (normal equations,
// triangular solves) and read better than iterator chains there.
#![allow(clippy::needless_range_loop)]

mod config;
mod data;
mod effects;
mod engine;
mod error;
mod explain;
mod locate;
mod outcome;
pub mod rotary;
mod select;
mod spectral;
mod synth;
mod words;

use errmap_drivers::SessionRow;

pub use config::{COMMON_GRATINGS_UM, DiagnoseConfig};
pub use data::Matching;
pub use error::DiagnoseError;
pub use locate::{Correlation, GroupStat, Locate, SpectralPeak};
pub use outcome::{
    CandidateScore, Diagnosis, EffectSeries, FoundEffect, NoiseGroup, ReportSeries, SeparatingPlan,
    StaticMapSummary, Verdict,
};

pub use synth::{
    Synth, SynthEnv, SynthError, SynthNoise, SynthOutput, SynthPlan, generate as synthesize,
    truth as synth_truth,
};

use select::Selector;

/// The recording with the found effects' fitted contributions taken out of `error_um`
/// (and `laser_mm` moved to match), matched by (run, sample); rows the diagnosis did not
/// use are returned unchanged. After [`diagnose_recorded`] this is the recording without
/// its drift (and the other effects found), e.g. for the ISO 230-2 figures.
pub fn remove_found(recorded: &[SessionRow], d: &Diagnosis) -> Vec<SessionRow> {
    let s = &d.series;
    let mut total: std::collections::HashMap<(u32, i64), f64> = std::collections::HashMap::new();
    for (k, key) in s.keys.iter().enumerate() {
        let c: f64 = s.effects.iter().map(|e| e.fitted_um[k]).sum();
        total.insert(*key, c);
    }
    recorded
        .iter()
        .map(|r| match total.get(&(r.run, r.sample)) {
            Some(c) => SessionRow {
                error_um: r.error_um - c,
                laser_mm: r.laser_mm + c * 1e-3,
                ..r.clone()
            },
            None => r.clone(),
        })
        .collect()
}
// Keeps `super::fixed` working in `locate` and `effects`.
use words::fixed;

/// HeNe vacuum wavelength, µm (the one constant of `base::consts`).
pub use crate::base::HENE_WAVELENGTH_UM;

/// Most rows of a recording `errmap diagnose` holds by default (`--max-rows`): longer
/// sessions are thinned uniformly in time to every 2ᵏ-th device sample
/// (`session::read_session_thinned`), which bounds its memory whatever the capture's
/// length. A diagnosis holds about 1.15 kB per row (the recorded and simulated rows, the
/// matched residual and covariates, the candidate effects' columns): measured on a
/// generated 43 MB capture (1 435 944 rows) thinned to 179 493 rows, 226 MB peak RSS
/// recorded-only and 212 MB against a simulated table; so 150 000 rows stay near 200 MB,
/// under the 256 MB of issue #13. That is 12.5 minutes of samples at 200 Hz: an ISO 230-2
/// session is not thinned, an overnight drift test is. The effects diagnose seeks change
/// over minutes (drift, air, temperatures) or with position, and keep their signatures in a
/// thinned session; only the noise estimate uses fewer samples.
pub const MAX_ROWS: usize = 150_000;

/// Diagnoses a recording against its simulation; see the module docs.
pub fn diagnose(
    recorded: &[SessionRow],
    simulated: &[SessionRow],
    config: &DiagnoseConfig,
) -> Result<Diagnosis, DiagnoseError> {
    config.validate()?;
    let (obs, matching) = data::build(recorded, simulated)?;
    run(obs, matching, config, None)
}

/// Diagnoses a recording without a simulation or a model: the static part is taken from
/// the recording itself — the mean error per line, target and direction on dwell rows, and
/// a straight line per line, direction and 1/40 of the travel on moving rows (the error map and the
/// reversal) — and the effects that change with time, air, material temperature, feed or
/// short periods are sought in what is left. The map's levels are nuisance parameters
/// fitted jointly with the effects (the within transform of `engine`), so an effect's
/// parameters and σ are those of a joint fit. Effects that are functions of line,
/// target and direction alone (`scale_factor`, `reversal`, `abbe`) are the map itself and
/// are not tested; [`Diagnosis::static_map`] describes the map. `rms_before_um` is the
/// RMS about the map.
pub fn diagnose_recorded(
    recorded: &[SessionRow],
    config: &DiagnoseConfig,
) -> Result<Diagnosis, DiagnoseError> {
    config.validate()?;
    let zero: Vec<SessionRow> = recorded
        .iter()
        .map(|r| SessionRow {
            error_um: 0.0,
            laser_mm: r.scale_mm,
            ..r.clone()
        })
        .collect();
    let (mut obs, matching) = data::build(recorded, &zero)?;
    let (groups, summary) = data::static_map(&obs);
    let ones = vec![1.0; obs.len()];
    groups.apply(&mut obs.r, &ones);
    let mut d = run(obs, matching, config, Some(groups))?;
    d.static_map = Some(summary);
    Ok(d)
}

fn run(
    obs: data::Obs,
    matching: Matching,
    config: &DiagnoseConfig,
    static_map: Option<engine::MapGroups>,
) -> Result<Diagnosis, DiagnoseError> {
    let groups = data::groups(&obs);
    let (fold, nfolds, fold_kind) = data::folds(&obs);
    let mut sigma = data::noise_from_differences(&obs, &groups);
    data::floor_sigmas(&mut sigma);
    // A residual quieter than the recording alone: the simulation shares its noise (the
    // same seed); the recording's own noise is the floor of every group's σ.
    let shared = data::shared_noise_floor(&obs, &groups, &sigma);
    let floor_shared = |s: &mut [f64]| {
        if let Some(f) = shared {
            s.iter_mut().for_each(|v| *v = v.max(f));
        }
    };
    floor_shared(&mut sigma);
    let shared_config;
    let config = if shared.is_some() {
        shared_config = DiagnoseConfig {
            min_variance_factor: 1.0,
            ..config.clone()
        };
        &shared_config
    } else {
        config
    };
    let weights =
        |s: &[f64]| -> Vec<f64> { groups.id.iter().map(|&g| 1.0 / (s[g] * s[g])).collect() };
    let w = weights(&sigma);
    let sw: f64 = w.iter().sum();
    let wmean = obs.r.iter().zip(&w).map(|(r, w)| r * w).sum::<f64>() / sw;
    // Relative to the static map, when there is one (see `engine`).
    let centred = |w: &[f64]| -> Vec<f64> {
        let y: Vec<f64> = obs.r.iter().map(|r| r - wmean).collect();
        let mut y = y;
        if let Some(m) = &static_map {
            m.apply(&mut y, w);
        }
        y
    };
    let mut y = centred(&w);

    let first = Selector::new(
        &obs,
        config,
        y.clone(),
        w.clone(),
        fold.clone(),
        nfolds,
        None,
        static_map.clone(),
    );
    let mut untestable = first.untestable().to_vec();
    let mut out = first.run();
    let resid: Vec<f64> = y.iter().zip(&out.model).map(|(y, m)| y - m).collect();
    let mut sigma2 = noise_after_first_model(&groups, &resid, &sigma);
    floor_shared(&mut sigma2);
    let changed = sigma
        .iter()
        .zip(&sigma2)
        .any(|(a, b)| (b / a - 1.0).abs() > 0.15);
    // Outliers (single samples far from their neighbours after the first model) get no
    // weight: least squares would otherwise bend the model, or invent an effect, to
    // reach them.
    let spikes = data::outliers(&obs, &groups, &resid, &sigma2);
    let n_spikes = spikes.iter().filter(|&&o| o).count();
    let mut w = w;
    if changed || n_spikes > 0 {
        if changed {
            sigma = sigma2;
        }
        w = weights(&sigma);
        for (wk, &o) in w.iter_mut().zip(&spikes) {
            if o {
                *wk = 0.0;
            }
        }
        y = centred(&w);
        let spectrum = Some((out.periods.clone(), out.broad.clone(), out.searched_rms));
        let sel = Selector::new(
            &obs,
            config,
            y.clone(),
            w.clone(),
            fold,
            nfolds,
            spectrum,
            static_map,
        );
        untestable = sel.untestable().to_vec();
        out = sel.run();
    }
    log_passes(&mut out.log, changed, n_spikes, shared);
    untestable.sort();
    untestable.dedup();
    if let Some(e) = non_finite(&out.terms) {
        return Err(e);
    }

    let d = explain::assemble(
        &obs, &matching, &groups, &sigma, &w, &y, out, untestable, fold_kind, config,
    )?;
    // Parameters computed while assembling (the `unexplained` RMS) are checked too.
    match non_finite_param(&d.effects) {
        Some(e) => Err(e),
        None => Ok(d),
    }
}

/// Each group's σ after the first model: the smaller of the recording's own (`sigma`) and
/// the first model's residual scatter, floored as every σ is.
fn noise_after_first_model(groups: &data::Groups, resid: &[f64], sigma: &[f64]) -> Vec<f64> {
    let from_resid = data::noise_from_residuals(resid, groups);
    let mut sigma2: Vec<f64> = sigma
        .iter()
        .zip(&from_resid)
        .map(|(&a, &b)| {
            if b.is_finite() && b > 0.0 {
                a.min(b)
            } else {
                a
            }
        })
        .collect();
    data::floor_sigmas(&mut sigma2);
    sigma2
}

/// Says at the head of the selection log why the selection ran twice (noise re-estimated,
/// outliers given no weight) and when the residual shares the recording's noise.
fn log_passes(log: &mut Vec<String>, changed: bool, n_spikes: usize, shared: Option<f64>) {
    if changed {
        log.insert(
            0,
            "noise re-estimated from the first model's residuals (some group changed by > 15 %); selection repeated".into(),
        );
    }
    if n_spikes > 0 {
        log.insert(
            0,
            format!(
                "{n_spikes} sample(s) more than {} σ from their neighbours after the first model (outliers) given no weight; selection repeated",
                data::OUTLIER_SIGMAS
            ),
        );
    }
    if let Some(f) = shared {
        log.insert(
            0,
            format!(
                "the residual is quieter than the recording alone (its own noise on dwells {f:.4} µm): \
                 the simulation reproduces the recording's noise (the same noise seed?), so every \
                 group's σ is at least the recording's own"
            ),
        );
    }
}

/// The first parameter of `effects` that is not finite.
fn non_finite_param(effects: &[FoundEffect]) -> Option<DiagnoseError> {
    effects.iter().find_map(|e| {
        let (name, value) = e.effect.non_finite()?;
        Some(DiagnoseError::NonFinite {
            effect: e.id().as_str().to_string(),
            param: name.as_str().to_string(),
            value,
        })
    })
}

/// The first fitted parameter (or σ of a fitted one) that is not finite, as the error.
fn non_finite(terms: &[select::FittedTerm]) -> Option<DiagnoseError> {
    terms.iter().find_map(|f| {
        f.params.iter().find_map(|p| {
            let bad = [p.value, if p.fitted { p.sigma } else { 0.0 }]
                .into_iter()
                .find(|v| !v.is_finite())?;
            Some(DiagnoseError::NonFinite {
                effect: f.term.kind.id().as_str().to_string(),
                param: p.name.as_str().to_string(),
                value: bad,
            })
        })
    })
}

#[cfg(test)]
mod non_finite_tests {
    use super::effects::{Kind, Param, Variant};
    use super::select::{FittedTerm, Term};
    use super::*;
    use crate::base::ParamName;
    use std::collections::BTreeMap;

    fn term(value: f64, sigma: f64, fitted: bool) -> FittedTerm {
        FittedTerm {
            term: Term {
                kind: Kind::ScaleFactor,
                variant: Variant::Single,
                cols: vec![0],
            },
            params: vec![Param {
                name: ParamName::Ppm,
                value,
                sigma,
                fitted,
                key: true,
            }],
            contribution: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// A NaN value or σ of a fitted parameter is an error naming the effect and the
    /// parameter; a finite one, or the σ of a fixed parameter, is not.
    #[test]
    fn a_non_finite_parameter_is_a_bug_reported_not_written() {
        assert!(non_finite(&[term(3.0, 0.1, true)]).is_none());
        assert!(non_finite(&[term(3.0, f64::NAN, false)]).is_none());
        for t in [term(f64::NAN, 0.1, true), term(3.0, f64::INFINITY, true)] {
            let e = non_finite(&[t]).expect("refused").to_string();
            assert!(
                e.contains("scale_factor") && e.contains("ppm") && e.contains("bug"),
                "{e}"
            );
        }
    }

    /// A parameter assembled after the fit (the `unexplained` RMS) is refused the same
    /// way when it is not finite.
    #[test]
    fn a_non_finite_parameter_assembled_after_the_fit_is_a_bug_reported_not_written() {
        let effect = |v: f64| FoundEffect {
            effect: crate::base::Effect::Unexplained { rms_um: v },
            uncertainty: BTreeMap::new(),
            where_: String::new(),
            explains_um: 1.0,
        };
        assert!(non_finite_param(&[effect(2.0)]).is_none());
        let e = non_finite_param(&[effect(2.0), effect(f64::NAN)])
            .expect("refused")
            .to_string();
        assert!(e.contains("unexplained") && e.contains("rms_um"), "{e}");
    }
}
