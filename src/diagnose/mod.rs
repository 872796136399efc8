//! Missing-physics diagnosis: find, name and model what a simulation left out of a
//! recording (`errmap diagnose`, `shared/spec/cli-contract.md`).
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
//! | spectrum (`spectral`) | weighted Lomb–Scargle with a floating mean over the exact x of the moving rows: narrow windows around P, P/2, P/4 and a broad scan of periods 0.5 mm – L/10 | ≤ 2·[`DiagnoseConfig::spectral_budget`] row·frequencies |
//! | fit (`engine`) | weighted least squares on memoised cross products; an ordered Cholesky gives the rank and the dependent columns | O(n·k) per new column, then O(k³) per fit |
//! | select (`select`) | forward BIC with variants, τ profiled jointly, backward BIC, swap moves, leave-one-run-out CV, determinedness and plausibility with restart, ambiguity | O(effects² · k³) fits + O(n·k) per nonlinear trial |
//! | locate ([`locate`]) | weighted group means along x, per line, run, direction, feed, over time; correlations; periodogram peaks; structure left after the model | O(n) |
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
//! A 100 000-row session takes about 1 s in release (`tests/diagnose_perf.rs`).

// Index loops mirror the formulas of the small dense linear algebra (normal equations,
// triangular solves) and read better than iterator chains there.
#![allow(clippy::needless_range_loop)]

mod data;
mod effects;
mod engine;
pub mod locate;
mod select;
mod spectral;
pub mod synth;

use std::collections::BTreeMap;

use errmap_drivers::SessionRow;
use serde::Serialize;

pub use data::Matching;
pub use locate::{Correlation, GroupStat, Locate, SpectralPeak};

use effects::{Kind, Variant};
use select::{FittedTerm, Outcome, Selector, centred_rms};

/// HeNe vacuum wavelength, µm.
pub const HENE_WAVELENGTH_UM: f64 = 0.632_991_354;

/// Grating periods searched when the device's is unknown, µm (each with P/2 and P/4).
pub const COMMON_GRATINGS_UM: [f64; 4] = [20.0, 40.0, 8.0, 4.0];

/// Settings of the diagnosis. [`DiagnoseConfig::validate`] checks the ranges.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseConfig {
    /// Grating period of the scale, µm, from the device HELLO (`grating_period_nm`/1000).
    /// The periodic search looks at P, P/2 and P/4 (±[`Self::period_window_rel`]) and at
    /// the broad periodogram. `None`: every period of [`COMMON_GRATINGS_UM`] with its
    /// halves and quarters. Default `None`. Range > 0.
    pub grating_period_um: Option<f64>,
    /// Most effects reported. Default 4. Range 0..=12.
    pub max_effects: usize,
    /// Smallest BIC improvement for an effect to enter the model, and to stay in it
    /// (backward check). BIC = n·ln(χ²/n) + k·ln n with k the independent parameters
    /// (+1 for a period or a time constant). Default 10 ("very strong" evidence on the
    /// Kass–Raftery scale, on top of the k·ln n penalty). Range ≥ 0.
    pub min_delta_bic: f64,
    /// An alternative effect that fits within this many BIC units of a found one makes
    /// the pair ambiguous (stated in `where` and `ambiguities`). Default 10. Range ≥ 0.
    pub ambiguity_delta_bic: f64,
    /// An effect whose fitted contribution has an RMS below this fraction of the noise σ
    /// is not reported even when significant. Default 0.1 (a tenth of the noise is below
    /// any error budget; smaller but significant structure is left to the report). Range 0..1.
    pub min_effect_fraction_of_noise: f64,
    /// A parameter is determined when its one-sigma uncertainty is at most this fraction
    /// of its magnitude. Default 0.5. Range (0, 10].
    pub max_relative_uncertainty: f64,
    /// Drop effects whose removal does not raise the leave-one-run-out error. Default true.
    pub cv_confirm: bool,
    /// Half-width of the search window around each grating-tied period, relative.
    /// Default 0.0005 (the interpolation error of a scale is locked to its grating).
    /// Range (0, 0.1].
    pub period_window_rel: f64,
    /// Shortest period of the broad periodogram, mm. Default 0.5. Range > 0.
    pub broad_min_period_mm: f64,
    /// Rows used by the periodograms and the nonlinear searches (an evenly spaced subset
    /// when there are more; the final fit uses all rows). Default 2500. Range ≥ 50.
    pub spectral_max_rows: usize,
    /// Bound on rows × frequencies of each periodogram (the grating windows together, and
    /// the broad scan): a scan over more frequencies uses fewer rows (at least 200).
    /// Default 1.2e6 (a few ms in release). Range ≥ 1e4.
    pub spectral_budget: f64,
    /// Laser vacuum wavelength for the refractive index of `dead_path`, µm. Default HeNe.
    pub laser_wavelength_um: f64,
    /// The dead path the simulation already has, mm, when it is known (diagnosing
    /// against a model): a found `dead_path` D is then a correction, and D below −D_model
    /// by more than two of its sigmas would make the beam's dead path negative, which is
    /// not a length, so it is refused. `None` (default): no such bound. Range ≥ 0.
    pub model_dead_path_mm: Option<f64>,
}

impl Default for DiagnoseConfig {
    fn default() -> Self {
        DiagnoseConfig {
            grating_period_um: None,
            max_effects: 4,
            min_delta_bic: 10.0,
            ambiguity_delta_bic: 10.0,
            min_effect_fraction_of_noise: 0.1,
            max_relative_uncertainty: 0.5,
            cv_confirm: true,
            period_window_rel: 0.0005,
            broad_min_period_mm: 0.5,
            spectral_max_rows: 2500,
            spectral_budget: 1.2e6,
            laser_wavelength_um: HENE_WAVELENGTH_UM,
            model_dead_path_mm: None,
        }
    }
}

impl DiagnoseConfig {
    /// Checks every setting against its documented range.
    pub fn validate(&self) -> Result<(), DiagnoseError> {
        let bad = |m: String| Err(DiagnoseError::Config(m));
        if let Some(d) = self.model_dead_path_mm
            && !(d.is_finite() && d >= 0.0)
        {
            return bad(format!("model_dead_path_mm = {d} must be a length ≥ 0"));
        }
        if let Some(p) = self.grating_period_um
            && !(p.is_finite() && p > 0.0)
        {
            return bad(format!("grating_period_um = {p} must be positive"));
        }
        if self.max_effects > 12 {
            return bad(format!(
                "max_effects = {} must be at most 12",
                self.max_effects
            ));
        }
        for (name, v) in [
            ("min_delta_bic", self.min_delta_bic),
            ("ambiguity_delta_bic", self.ambiguity_delta_bic),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} = {v} must be ≥ 0"));
            }
        }
        if !(0.0..1.0).contains(&self.min_effect_fraction_of_noise) {
            return bad(format!(
                "min_effect_fraction_of_noise = {} must be in [0, 1)",
                self.min_effect_fraction_of_noise
            ));
        }
        if !(self.max_relative_uncertainty > 0.0 && self.max_relative_uncertainty <= 10.0) {
            return bad(format!(
                "max_relative_uncertainty = {} must be in (0, 10]",
                self.max_relative_uncertainty
            ));
        }
        if !(self.period_window_rel > 0.0 && self.period_window_rel <= 0.1) {
            return bad(format!(
                "period_window_rel = {} must be in (0, 0.1]",
                self.period_window_rel
            ));
        }
        if !(self.broad_min_period_mm.is_finite() && self.broad_min_period_mm > 0.0) {
            return bad(format!(
                "broad_min_period_mm = {} must be positive",
                self.broad_min_period_mm
            ));
        }
        if self.spectral_max_rows < 50 {
            return bad(format!(
                "spectral_max_rows = {} must be at least 50",
                self.spectral_max_rows
            ));
        }
        if !(self.spectral_budget.is_finite() && self.spectral_budget >= 1e4) {
            return bad(format!(
                "spectral_budget = {} must be at least 1e4",
                self.spectral_budget
            ));
        }
        if !(self.laser_wavelength_um > 0.2 && self.laser_wavelength_um < 2.0) {
            return bad(format!(
                "laser_wavelength_um = {} must be a visible or near-infrared wavelength",
                self.laser_wavelength_um
            ));
        }
        Ok(())
    }
}

/// Why a diagnosis could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    /// One of the tables has no rows.
    #[error("the {which} session has no rows")]
    Empty {
        /// "recorded" or "simulated".
        which: &'static str,
    },
    /// No (run, sample) of the recording occurs in the simulation.
    #[error(
        "no row of the recorded session ({recorded} rows) matches the simulated one ({simulated} rows) on (run, sample)"
    )]
    NoMatch {
        /// Recorded rows.
        recorded: usize,
        /// Simulated rows.
        simulated: usize,
    },
    /// Too few usable rows after matching and filtering.
    #[error("only {usable} usable matched rows (at least {needed} needed): {detail}")]
    TooFewRows {
        /// Usable rows.
        usable: usize,
        /// Needed rows.
        needed: usize,
        /// What was left out.
        detail: String,
    },
    /// A setting is outside its range.
    #[error("invalid diagnose setting: {0}")]
    Config(String),
}

/// One found effect (contract shape).
#[derive(Debug, Clone, Serialize)]
pub struct FoundEffect {
    /// Vocabulary id (or `unexplained` for structure no vocabulary effect explains).
    pub id: String,
    /// Parameters by the contract's names: numbers, and `offset_axis` ("y"/"z") for abbe.
    pub params: BTreeMap<String, serde_json::Value>,
    /// One-sigma uncertainty per numeric parameter (0 for a parameter fixed by the
    /// chosen variant, which `where` then says).
    pub uncertainty: BTreeMap<String, f64>,
    /// Where the mismatch is, in words; also any ambiguity.
    #[serde(rename = "where")]
    pub where_: String,
    /// RMS (about its mean) of the effect's fitted contribution, µm.
    pub explains_um: f64,
}

/// Noise σ of one group of rows.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseGroup {
    /// "run 3, moving".
    pub group: String,
    /// Rows.
    pub rows: usize,
    /// Robust σ, µm.
    pub sigma_um: f64,
}

/// A testable effect's standing against the final model.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateScore {
    /// Effect id (with the offset axis for abbe).
    pub effect: String,
    /// Whether it was reported.
    pub found: bool,
    /// For a found effect: how much BIC rises when it is removed; otherwise how much BIC
    /// changes when it is added (negative: it would help).
    pub delta_bic: f64,
}

/// The diagnosis (contract keys first; the rest are extras).
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// "consistent" or "missing_physics".
    pub verdict: String,
    /// RMS of recorded − simulated, µm.
    pub rms_before_um: f64,
    /// RMS after the constant and the found effects, µm.
    pub rms_after_um: f64,
    /// Same, each run held out in turn (each of 5 time blocks with fewer than 3 runs).
    pub cv_rms_after_um: f64,
    /// Found effects, most important (largest `explains_um`) first.
    pub effects: Vec<FoundEffect>,
    /// RMS of the residual about its mean before the model, µm.
    pub rms_before_centred_um: f64,
    /// Pooled noise σ (RMS of the per-row group σ), µm.
    pub noise_sigma_um: f64,
    /// Noise σ per run × moving/dwell group.
    pub noise_groups: Vec<NoiseGroup>,
    /// Rows matched on (run, sample).
    pub matched_rows: usize,
    /// Rows used in the fits.
    pub used_rows: usize,
    /// Recorded rows with no simulated partner.
    pub only_in_recorded: usize,
    /// Simulated rows with no recorded partner.
    pub only_in_simulated: usize,
    /// Matched rows left out for flags ≠ 0.
    pub flagged_rows: usize,
    /// All matching counts.
    pub matching: Matching,
    /// The measured axis.
    pub axis: String,
    /// Cross-validation folds: "run" or "time block".
    pub cv_folds: String,
    /// Effects these data cannot tell apart from a found one, and effects refused as
    /// undetermined.
    pub ambiguities: Vec<String>,
    /// Limits of this data set, found before any fit (effects not testable, signatures
    /// that coincide).
    pub design_notes: Vec<String>,
    /// Where the residual is significant.
    pub locate: Locate,
    /// Every testable effect against the final model.
    pub candidates: Vec<CandidateScore>,
    /// The selection steps.
    pub selection_log: Vec<String>,
    /// Series for the report's charts (not serialised).
    #[serde(skip)]
    pub series: ReportSeries,
}

/// Per-row series behind the report's charts.
#[derive(Debug, Clone, Default)]
pub struct ReportSeries {
    /// Position along the measured axis, mm.
    pub x_mm: Vec<f64>,
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Residual before the model, about its mean, µm.
    pub before_um: Vec<f64>,
    /// Residual after the model, µm.
    pub after_um: Vec<f64>,
    /// One chart per found effect.
    pub effects: Vec<EffectSeries>,
    /// Broad periodogram: period (mm) and Δχ².
    pub broad_period_mm: Vec<f64>,
    /// Δχ² of the broad periodogram.
    pub broad_power: Vec<f64>,
}

/// The partial residual of one effect against the covariate it follows.
#[derive(Debug, Clone, Default)]
pub struct EffectSeries {
    /// Effect id.
    pub id: String,
    /// Axis label of the covariate.
    pub covariate_label: String,
    /// Covariate per row.
    pub covariate: Vec<f64>,
    /// Residual minus the other effects and the constant, µm.
    pub partial_um: Vec<f64>,
    /// The effect's fitted contribution, µm.
    pub fitted_um: Vec<f64>,
    /// Row groups drawn as separate series (label, rows); empty: one series.
    pub groups: Vec<(String, Vec<usize>)>,
}

/// Diagnoses a recording against its simulation; see the module docs.
pub fn diagnose(
    recorded: &[SessionRow],
    simulated: &[SessionRow],
    config: &DiagnoseConfig,
) -> Result<Diagnosis, DiagnoseError> {
    config.validate()?;
    let (obs, matching) = data::build(recorded, simulated)?;
    let groups = data::groups(&obs);
    let (fold, nfolds, fold_kind) = data::folds(&obs);
    let mut sigma = data::noise_from_differences(&obs, &groups);
    data::floor_sigmas(&mut sigma);
    let weights =
        |s: &[f64]| -> Vec<f64> { groups.id.iter().map(|&g| 1.0 / (s[g] * s[g])).collect() };
    let w = weights(&sigma);
    let sw: f64 = w.iter().sum();
    let wmean = obs.r.iter().zip(&w).map(|(r, w)| r * w).sum::<f64>() / sw;
    let y: Vec<f64> = obs.r.iter().map(|r| r - wmean).collect();

    let first = Selector::new(
        &obs,
        config,
        y.clone(),
        w.clone(),
        fold.clone(),
        nfolds,
        None,
    );
    let mut untestable = first.untestable().to_vec();
    let mut out = first.run();
    let resid: Vec<f64> = y.iter().zip(&out.model).map(|(y, m)| y - m).collect();
    let from_resid = data::noise_from_residuals(&resid, &groups);
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
    let changed = sigma
        .iter()
        .zip(&sigma2)
        .any(|(a, b)| (b / a - 1.0).abs() > 0.15);
    let mut w = w;
    if changed {
        sigma = sigma2;
        w = weights(&sigma);
        let spectrum = Some((out.periods.clone(), out.broad.clone(), out.searched_rms));
        let sel = Selector::new(&obs, config, y.clone(), w.clone(), fold, nfolds, spectrum);
        untestable = sel.untestable().to_vec();
        out = sel.run();
        out.log.insert(
            0,
            "noise re-estimated from the first model's residuals (some group changed by > 15 %); selection repeated".into(),
        );
    }
    untestable.sort();
    untestable.dedup();

    Ok(assemble(
        &obs, &matching, &groups, &sigma, &w, &y, out, untestable, fold_kind, config,
    ))
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    obs: &data::Obs,
    matching: &Matching,
    groups: &data::Groups,
    sigma: &[f64],
    w: &[f64],
    y: &[f64],
    out: Outcome,
    untestable: Vec<String>,
    fold_kind: &str,
    config: &DiagnoseConfig,
) -> Diagnosis {
    let n = obs.len();
    let rms = |v: &mut dyn Iterator<Item = f64>| {
        let (s, c) = v.fold((0.0, 0usize), |(s, c), x| (s + x * x, c + 1));
        (s / c.max(1) as f64).sqrt()
    };
    let after: Vec<f64> = y.iter().zip(&out.model).map(|(y, m)| y - m).collect();
    let rms_before = rms(&mut obs.r.iter().copied());
    let r_mean = obs.r.iter().sum::<f64>() / n as f64;
    let rms_before_c = rms(&mut obs.r.iter().map(|r| r - r_mean));
    let rms_after = rms(&mut after.iter().copied());
    let cv_rms = rms(&mut y.iter().zip(&out.cv_pred).map(|(y, p)| y - p));
    let noise_sigma =
        (groups.id.iter().map(|&g| sigma[g] * sigma[g]).sum::<f64>() / n as f64).sqrt();

    // Localisation.
    let s2 = {
        let chi2: f64 = after.iter().zip(w).map(|(e, w)| w * e * e).sum();
        let k = 1 + out.terms.iter().map(|t| t.term.cols.len()).sum::<usize>();
        chi2 / (n as f64 - k as f64).max(1.0)
    };
    let before: Vec<f64> = y.to_vec();
    let peaks: Vec<SpectralPeak> = out
        .periods
        .iter()
        .map(|p| SpectralPeak {
            period_um: p.refined_um.unwrap_or(p.period_um),
            source: p.label.clone(),
            delta_chi2: p.power,
        })
        .collect();
    let loc = locate::locate(
        &locate::Input {
            obs,
            before: &before,
            after: &after,
            w,
            s2,
            noise_sigma,
            peaks,
        },
        config.laser_wavelength_um,
    );

    // Ambiguity statements.
    let mut ambiguities: Vec<String> = Vec::new();
    let mut amb_by_kind: BTreeMap<Kind, Vec<String>> = BTreeMap::new();
    for a in &out.ambiguities {
        let why = if a.delta_bic > select::TIE_BIC {
            format!(
                "it fits better (the alternative raises BIC by {:.1})",
                a.delta_bic
            )
        } else if a.delta_bic >= -select::TIE_BIC {
            "the fits are equally good and it is the simpler explanation (fewer assumptions or covariates)".to_string()
        } else if -a.delta_bic < config.min_delta_bic {
            format!(
                "it was selected first and the alternative is better by only {:.1} (less than the {} an exchange needs)",
                -a.delta_bic, config.min_delta_bic
            )
        } else {
            format!(
                "the selection kept it, although the alternative fits these rows better (BIC lower by {:.1}): \
                 on its path the alternative failed leave-one-run-out cross-validation or the checks on its \
                 parameters; treat the attribution between the two as open",
                -a.delta_bic
            )
        };
        let text = format!(
            "ambiguous: {found} is indistinguishable on these data from {alt} (ΔBIC = {d:+.1}); reported as {found} because {why}; to separate them: {advice}",
            found = a.found.label(obs),
            alt = a.alt.label(obs),
            d = a.delta_bic,
            advice = separation_advice(a.found, a.alt, obs)
        );
        amb_by_kind.entry(a.found).or_default().push(text.clone());
        ambiguities.push(text);
    }
    for &(ka, pa, kb, pb, rho) in &out.correlated {
        let text = format!(
            "hard to separate: {pa} of {} and {pb} of {} are correlated (ρ = {rho:+.3}) on these data, so the split between the two effects rests on little information (their one-sigma values include it); to separate them: {}",
            ka.label(obs),
            kb.label(obs),
            separation_advice(ka, kb, obs)
        );
        amb_by_kind.entry(ka).or_default().push(text.clone());
        amb_by_kind.entry(kb).or_default().push(text.clone());
        ambiguities.push(text);
    }
    ambiguities.extend(out.refused.iter().cloned());

    // Effects.
    let mut effects: Vec<FoundEffect> = out
        .terms
        .iter()
        .map(|f| found_effect(f, obs, &out, amb_by_kind.get(&f.term.kind)))
        .collect();
    effects.sort_by(|a, b| b.explains_um.total_cmp(&a.explains_um));
    if effects.is_empty()
        && let Some(text) = &loc.unexplained
    {
        let mut params = BTreeMap::new();
        params.insert("rms_um".to_string(), serde_json::json!(centred_rms(&after)));
        effects.push(FoundEffect {
            id: "unexplained".into(),
            params,
            uncertainty: BTreeMap::new(),
            where_: format!(
                "{} axis: {text}; no effect of the vocabulary explains it (see the report's localisation)",
                data::axis_label(obs.axis)
            ),
            explains_um: (rms_after * rms_after - noise_sigma * noise_sigma).max(0.0).sqrt(),
        });
    }

    let candidates = out
        .scores
        .iter()
        .map(|(k, d)| CandidateScore {
            effect: k.label(obs),
            found: out.terms.iter().any(|t| t.term.kind == *k),
            delta_bic: *d,
        })
        .collect();

    let mut design_notes = untestable;
    design_notes.extend(out.design.iter().cloned());

    let series = report_series(obs, &before, &after, &out);
    Diagnosis {
        verdict: if effects.is_empty() {
            "consistent"
        } else {
            "missing_physics"
        }
        .into(),
        rms_before_um: rms_before,
        rms_after_um: rms_after,
        cv_rms_after_um: cv_rms,
        effects,
        rms_before_centred_um: rms_before_c,
        noise_sigma_um: noise_sigma,
        noise_groups: groups
            .labels
            .iter()
            .enumerate()
            .map(|(g, l)| NoiseGroup {
                group: l.clone(),
                rows: groups.count[g],
                sigma_um: sigma[g],
            })
            .collect(),
        matched_rows: matching.matched_rows,
        used_rows: matching.used_rows,
        only_in_recorded: matching.only_in_recorded,
        only_in_simulated: matching.only_in_simulated,
        flagged_rows: matching.flagged_rows,
        matching: matching.clone(),
        axis: data::axis_label(obs.axis).into(),
        cv_folds: fold_kind.into(),
        ambiguities,
        design_notes,
        locate: loc,
        candidates,
        selection_log: out.log.clone(),
        series,
    }
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        })
}

fn list(v: &[f64], unit: &str) -> String {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let items: Vec<String> = s.iter().take(6).map(|v| format!("{v}")).collect();
    let more = if s.len() > 6 { ", …" } else { "" };
    format!("{}{more} {unit}", items.join(", "))
}

/// The measurement that would separate two effects, with this data set's reason.
pub(crate) fn separation_advice(a: Kind, b: Kind, obs: &data::Obs) -> String {
    use Kind::*;
    let pair = |p: Kind, q: Kind| (a == p && b == q) || (a == q && b == p);
    let feeds: Vec<f64> = (0..obs.len())
        .filter(|&k| obs.moving[k] && obs.v_feed[k] > 0.0)
        .map(|k| obs.v_feed[k])
        .collect();
    let dwell = obs.moving.iter().filter(|m| !**m).count();
    if pair(ScaleThermal, ScaleFactor) {
        let (lo, hi) = obs.scale_t.as_deref().map_or((f64::NAN, f64::NAN), range);
        return format!(
            "the scale temperature stayed within {lo:.2}–{hi:.2} °C, so α·ΔT acts like a constant pitch error; repeat the measurement with the scale at another temperature (ΔT_scale must change)"
        );
    }
    if pair(LatchDelay, Reversal) {
        return format!(
            "the moving samples were taken at {} and {}, so d·v·τ is a constant times d; measure at a second feed or latch samples while dwelling",
            list(&feeds, "mm/s"),
            if dwell == 0 {
                "there are no dwell samples".to_string()
            } else {
                format!("only {dwell} dwell samples")
            }
        );
    }
    if let (Abbe(i), ScaleFactor) | (ScaleFactor, Abbe(i)) = (a, b) {
        let c = obs.c_names[i as usize];
        let vals: Vec<f64> = obs.lines.iter().map(|l| l[i as usize]).collect();
        return format!(
            "the lines lie at {c} = {}, so c·θ(x) is a constant plus a term in x alone; measure a second line at another {c}",
            list(&vals, "mm")
        );
    }
    if let (Abbe(_), Abbe(_)) = (a, b) {
        return format!(
            "the lines' {} and {} offsets change together; measure lines that differ in {} only and in {} only",
            obs.c_names[0], obs.c_names[1], obs.c_names[0], obs.c_names[1]
        );
    }
    if let (Abbe(i), _) | (_, Abbe(i)) = (a, b) {
        let c = obs.c_names[i as usize];
        return format!(
            "measure more lines at other {c} offsets, so the line-to-line pattern is unique"
        );
    }
    if pair(Refraction, ScaleThermal) {
        return "the air and scale temperatures changed together; record a session where they change independently (e.g. the scale warmed while the room is steady)".into();
    }
    if pair(DeadPath, ThermalDrift)
        || pair(Refraction, ThermalDrift)
        || pair(ScaleThermal, ThermalDrift)
    {
        return "the temperature and the time trend move together; repeat with the machine warmed up (drift gone) or with the air/scale temperature changing at another pace".into();
    }
    if pair(DeadPath, Refraction) || pair(Refraction, ScaleFactor) || pair(DeadPath, Reversal) {
        return "let the air change more (pressure and temperature independently) or measure with a known dead path".into();
    }
    format!(
        "{} follows {} and {} follows {}; a measurement in which these vary independently would separate them",
        a.id(),
        a.follows(obs),
        b.id(),
        b.follows(obs)
    )
}

/// `v` with `d` decimals, without a minus sign on a value that rounds to zero.
pub(crate) fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

fn fmt_sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{v:.digits$}")
}

fn found_effect(
    f: &FittedTerm,
    obs: &data::Obs,
    out: &Outcome,
    amb: Option<&Vec<String>>,
) -> FoundEffect {
    let mut params = BTreeMap::new();
    let mut uncertainty = BTreeMap::new();
    if let Kind::Abbe(i) = f.term.kind {
        params.insert(
            "offset_axis".to_string(),
            serde_json::Value::String(obs.c_names[i as usize].to_string()),
        );
    }
    for p in &f.params {
        params.insert(p.name.to_string(), serde_json::json!(p.value));
        uncertainty.insert(p.name.to_string(), if p.fitted { p.sigma } else { 0.0 });
    }
    let mut text = where_text(f, obs, out);
    if let Some(a) = amb {
        for s in a {
            text.push_str("; ");
            text.push_str(s);
        }
    }
    FoundEffect {
        id: f.term.kind.id().into(),
        params,
        uncertainty,
        where_: text,
        explains_um: centred_rms(&f.contribution),
    }
}

fn where_text(f: &FittedTerm, obs: &data::Obs, out: &Outcome) -> String {
    let ax = data::axis_label(obs.axis);
    let axl = ax.to_lowercase();
    let (xlo, xhi) = range(&obs.x);
    let (tlo, thi) = range(&obs.t);
    let mut runs: Vec<u32> = obs.run.iter().copied().filter(|&r| r > 0).collect();
    runs.sort_unstable();
    runs.dedup();
    let runs_s = match (runs.first(), runs.last()) {
        (Some(a), Some(b)) if a != b => format!("runs {a}–{b}"),
        (Some(a), _) => format!("run {a}"),
        _ => "outside any run".to_string(),
    };
    let c = &f.contribution;
    let (clo, chi) = range(c);
    let pp = chi - clo;
    // Where the effect is largest (deviation from its mean).
    let m = c.iter().sum::<f64>() / c.len().max(1) as f64;
    let kmax = (0..c.len())
        .max_by(|&a, &b| (c[a] - m).abs().total_cmp(&(c[b] - m).abs()))
        .unwrap_or(0);
    let pv = |name: &str| {
        f.params
            .iter()
            .find(|p| p.name == name)
            .map_or(0.0, |p| p.value)
    };
    let lines_s = if obs.lines.len() > 1 {
        if obs.lines.len() == 2 {
            "both lines".to_string()
        } else {
            format!("all {} lines", obs.lines.len())
        }
    } else {
        "the single line".to_string()
    };
    let head = format!(
        "{ax} axis, {axl} {}–{} mm, {lines_s}, {runs_s}, t {tlo:.0}–{thi:.0} s",
        fixed(xlo, 1),
        fixed(xhi, 1)
    );
    let body = match (&f.term.kind, &f.term.variant) {
        (Kind::ScaleFactor, _) => format!(
            "grows linearly along {axl} ({:+.3} µm from {axl} = {xlo:.0} to {xhi:.0} mm), the same in every run, line and direction; follows {}",
            pv("ppm") * (xhi - xlo) * 1e-3,
            f.term.kind.follows(obs)
        ),
        (Kind::ScaleThermal, v) => {
            let (tl, th) = obs.scale_t.as_deref().map_or((f64::NAN, f64::NAN), range);
            let x0 = if matches!(v, Variant::X0Free) {
                format!("x0 = {} mm fitted", fmt_sig(pv("x0_mm")))
            } else {
                "x0 fixed at 0 mm (a free x0 is not supported by the data)".into()
            };
            format!(
                "follows the scale temperature times position, −α·(T_scale − 20)·({axl} − x0), with the scale at {tl:.2}–{th:.2} °C; {pp:.3} µm peak to peak, largest at {axl} ≈ {:.0} mm, t ≈ {:.0} s; {x0}",
                obs.x[kmax], obs.t[kmax]
            )
        }
        (Kind::Abbe(i), v) => {
            let cn = obs.c_names[*i as usize];
            let vals: Vec<f64> = obs.lines.iter().map(|l| l[*i as usize]).collect();
            let fixed = match v {
                Variant::AbbeTheta0 => "; θ1 fixed at 0 (not supported by the data)",
                Variant::AbbeTheta1 => "; θ0 fixed at 0 (not supported by the data)",
                _ => "",
            };
            format!(
                "differs between the lines in proportion to their {cn} offset ({}), θ(x) = θ0 + θ1·{axl}; {pp:.3} µm peak to peak, largest at {axl} ≈ {:.0} mm on the line at {cn} = {}{fixed}",
                list(&vals, "mm"),
                obs.x[kmax],
                obs.c[*i as usize].as_ref().map_or(f64::NAN, |v| v[kmax])
            )
        }
        (Kind::Reversal, _) => {
            let dwell = obs.moving.iter().any(|m| !m);
            let mut feeds: Vec<f64> = obs.v_feed.iter().copied().filter(|v| *v > 0.0).collect();
            feeds.sort_by(f64::total_cmp);
            feeds.dedup();
            let rows = if dwell {
                "dwelling and moving"
            } else {
                "on every moving sample"
            };
            let feed = match feeds.len() {
                0 => String::new(),
                1 => format!(", at the single feed of {} mm/s", feeds[0]),
                _ => ", the same at every feed".to_string(),
            };
            format!(
                "opposite in the + and − directions (±b/2 = ±{:.3} µm) on every row, {rows}{feed}; follows the direction of travel",
                pv("b_um") / 2.0
            )
        }
        (Kind::LatchDelay, v) => {
            let mut feeds: Vec<f64> = (0..obs.len())
                .filter(|&k| obs.moving[k] && obs.v_feed[k] > 0.0)
                .map(|k| obs.v_feed[k])
                .collect();
            feeds.sort_by(f64::total_cmp);
            feeds.dedup();
            let at: Vec<String> = feeds
                .iter()
                .take(4)
                .map(|v| format!("±{:.3} µm at {v} mm/s", v * pv("tau_us") * 1e-3))
                .collect();
            let how = if matches!(v, Variant::LatchMeasured) {
                "; v is the carriage speed measured from successive samples, which fits better than the commanded feed (accelerations)"
            } else {
                ""
            };
            format!(
                "on moving samples only, opposite in the two directions and proportional to the feed ({}), absent while dwelling; follows direction × speed{how}",
                at.join(", ")
            )
        }
        (Kind::Periodic, Variant::Periodic { period_um }) => {
            let tied = out
                .periods
                .iter()
                .filter(|p| {
                    (p.refined_um.unwrap_or(p.period_um) - period_um).abs()
                        < 3.0 * p.step_um.max(1e-9)
                })
                .map(|p| p.label.clone())
                .next()
                .unwrap_or_else(|| "found by the broad periodogram".into());
            let tied = if tied.contains("grating") {
                tied
            } else {
                "not tied to the grating period: found by the broad periodogram".into()
            };
            format!(
                "periodic along {axl} with a period of {} µm ({tied}) and an amplitude of {:.3} µm, all along the axis in every run and direction; follows the phase of {axl} within the period",
                fmt_sig(*period_um),
                pv("amplitude_um")
            )
        }
        (Kind::ThermalDrift, Variant::DriftExp { tau_s }) => format!(
            "follows time, not position: rises by {:.3} µm over t {tlo:.0}–{thi:.0} s, exponential with τ = {tau_s:.0} s (an exponential fits better than a linear drift by BIC)",
            pv("amplitude_um") * (1.0 - (-(thi - obs.t0) / tau_s).exp())
        ),
        (Kind::ThermalDrift, _) => format!(
            "follows time, not position: a linear drift of {:.3} µm over t {tlo:.0}–{thi:.0} s (a time constant is not determined by these data)",
            pv("rate_um_per_s") * (thi - tlo)
        ),
        (Kind::DeadPath, _) => {
            let (al, ah) = obs.air_t.as_deref().map_or((f64::NAN, f64::NAN), range);
            let (pl, ph) = obs.air_p.as_deref().map_or((f64::NAN, f64::NAN), range);
            format!(
                "follows the air refractive index, not position (air {al:.2}–{ah:.2} °C, {pl:.1}–{ph:.1} hPa): {pp:.3} µm peak to peak over time, the same all along the axis"
            )
        }
        (Kind::Refraction, _) => {
            let (al, ah) = obs.air_t.as_deref().map_or((f64::NAN, f64::NAN), range);
            let (pl, ph) = obs.air_p.as_deref().map_or((f64::NAN, f64::NAN), range);
            format!(
                "proportional to position times the air's change from its mean (air {al:.2}–{ah:.2} °C, {pl:.1}–{ph:.1} hPa): {pp:.3} µm peak to peak, largest at {axl} ≈ {:.0} mm, t ≈ {:.0} s",
                obs.x[kmax], obs.t[kmax]
            )
        }
        (k, _) => format!("follows {}", k.follows(obs)),
    };
    format!("{head}; {body}")
}

fn report_series(obs: &data::Obs, before: &[f64], after: &[f64], out: &Outcome) -> ReportSeries {
    let n = obs.len();
    let mut effects = Vec::new();
    for f in &out.terms {
        let partial: Vec<f64> = (0..n).map(|k| after[k] + f.contribution[k]).collect();
        let ax = data::axis_label(obs.axis).to_lowercase();
        let mut groups = Vec::new();
        let (label, cov): (String, Vec<f64>) = match (&f.term.kind, &f.term.variant) {
            (Kind::ScaleFactor, _) => (format!("{ax} / mm"), obs.x.clone()),
            (Kind::ScaleThermal, _) => (
                format!("(T_scale − 20 °C)·{ax} / K·mm"),
                (0..n)
                    .map(|k| obs.scale_t.as_ref().map_or(0.0, |t| t[k] - 20.0) * obs.x[k])
                    .collect(),
            ),
            (Kind::Abbe(_), _) => {
                for (l, line) in obs.lines.iter().enumerate() {
                    let idx: Vec<usize> = (0..n).filter(|&k| obs.line[k] == l).collect();
                    groups.push((
                        format!(
                            "{} = {}, {} = {}",
                            obs.c_names[0], line[0], obs.c_names[1], line[1]
                        ),
                        idx,
                    ));
                }
                (format!("{ax} / mm"), obs.x.clone())
            }
            (Kind::Reversal, _) => {
                for (d, name) in [(1.0, "direction +"), (-1.0, "direction −")] {
                    groups.push((
                        name.to_string(),
                        (0..n).filter(|&k| obs.d[k] == d).collect(),
                    ));
                }
                (format!("{ax} / mm"), obs.x.clone())
            }
            (Kind::LatchDelay, Variant::LatchMeasured) => (
                "direction × measured speed / mm/s".into(),
                (0..n).map(|k| obs.d[k] * obs.v_meas[k]).collect(),
            ),
            (Kind::LatchDelay, _) => (
                "direction × feed / mm/s".into(),
                (0..n).map(|k| obs.d[k] * obs.v_feed[k]).collect(),
            ),
            (Kind::Periodic, Variant::Periodic { period_um }) => (
                format!("{ax} modulo the period ({} µm) / µm", fmt_sig(*period_um)),
                obs.x
                    .iter()
                    .map(|x| (x * 1000.0).rem_euclid(*period_um))
                    .collect(),
            ),
            (Kind::DeadPath, _) => (
                "air refractive index change (n − n0)·10⁶".into(),
                effects::index_change_ppm(obs, HENE_WAVELENGTH_UM).unwrap_or_else(|| vec![0.0; n]),
            ),
            (Kind::Refraction, _) => ("fitted refraction term / µm".into(), f.contribution.clone()),
            _ => ("t / s".into(), obs.t.clone()),
        };
        effects.push(EffectSeries {
            id: f.term.kind.id().into(),
            covariate_label: label,
            covariate: cov,
            partial_um: partial,
            fitted_um: f.contribution.clone(),
            groups,
        });
    }
    ReportSeries {
        x_mm: obs.x.clone(),
        t_s: obs.t.clone(),
        before_um: before.to_vec(),
        after_um: after.to_vec(),
        effects,
        broad_period_mm: out.broad.period_mm.clone(),
        broad_power: out.broad.power.clone(),
    }
}
