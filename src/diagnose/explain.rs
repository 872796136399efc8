//! The selection's outcome in the contract's terms: [`assemble`] builds the [`Diagnosis`]
//! (RMS before and after, noise groups, localisation, ambiguity statements, candidate
//! scores), each found effect's parameters and `where` text, and the per-row series behind
//! the report's charts.

use crate::base::Effect;
use crate::base::ParamName as P;
use std::collections::BTreeMap;

use super::data::{self, Matching};
use super::effects::{self, Kind, Variant, separation_advice};
use super::locate::{self, SpectralPeak};
use super::outcome::{
    CandidateScore, Diagnosis, EffectSeries, FoundEffect, NoiseGroup, ReportSeries, SeparatingPlan,
    Verdict,
};
use super::select::{self, FittedTerm, Outcome, centred_rms};
use super::words::{fixed, fmt_sig, list, range};
use super::{DiagnoseConfig, DiagnoseError, HENE_WAVELENGTH_UM};

#[allow(clippy::too_many_arguments)]
pub(super) fn assemble(
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
) -> Result<Diagnosis, DiagnoseError> {
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
    let loc = locate::locate(
        &locate::Input {
            obs,
            before: &before,
            after: &after,
            w,
            s2,
            noise_sigma,
            peaks: spectral_peaks(&out),
        },
        config.laser_wavelength_um,
    );

    // Ambiguity statements.
    let (mut ambiguities, amb_by_kind) = ambiguity_statements(obs, &out, config);
    ambiguities.extend(out.refused.iter().cloned());

    // Effects.
    let mut effects: Vec<FoundEffect> = out
        .terms
        .iter()
        .map(|f| found_effect(f, obs, &out, amb_by_kind.get(&f.term.kind)))
        .collect::<Result<_, _>>()?;
    effects.sort_by(|a, b| b.explains_um.total_cmp(&a.explains_um));
    if effects.is_empty()
        && let Some(text) = &loc.unexplained
    {
        effects.push(FoundEffect {
            effect: Effect::Unexplained {
                rms_um: centred_rms(&after),
            },
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
            effect: k.id(),
            offset_axis: k.offset_axis(obs),
            found: out.terms.iter().any(|t| t.term.kind == *k),
            delta_bic: *d,
        })
        .collect();

    let mut design_notes = untestable;
    design_notes.extend(out.design.iter().cloned());

    let series = report_series(obs, &before, &after, &out);
    Ok(Diagnosis {
        verdict: if effects.is_empty() {
            Verdict::Consistent
        } else {
            Verdict::MissingPhysics
        },
        rms_before_um: rms_before,
        rms_after_um: rms_after,
        cv_rms_after_um: cv_rms,
        effects,
        rms_before_centred_um: rms_before_c,
        noise_sigma_um: noise_sigma,
        noise_groups: noise_groups(groups, sigma),
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
        static_map: None,
        separating_plans: separating_plans(&out),
        selection_log: out.log.clone(),
        series,
    })
}

/// The spectral peaks the selection saw, for the localisation's periodic search.
fn spectral_peaks(out: &Outcome) -> Vec<SpectralPeak> {
    out.periods
        .iter()
        .map(|p| SpectralPeak {
            period_um: p.refined_um.unwrap_or(p.period_um),
            source: p.label.clone(),
            delta_chi2: p.power,
        })
        .collect()
}

/// The statements on effects the data cannot tell apart (exchangeable and strongly
/// correlated pairs), all of them and by the effect they concern (each effect's `where`
/// repeats its own).
fn ambiguity_statements(
    obs: &data::Obs,
    out: &Outcome,
    config: &DiagnoseConfig,
) -> (Vec<String>, BTreeMap<Kind, Vec<String>>) {
    let mut ambiguities: Vec<String> = Vec::new();
    let mut amb_by_kind: BTreeMap<Kind, Vec<String>> = BTreeMap::new();
    for a in &out.ambiguities {
        let decided = out
            .decisions
            .iter()
            .find(|d| d.chosen == a.found && d.other == a.alt);
        let why = if let Some(d) = decided {
            format!(
                "of physics, not of the fit: {}; the separating measurement is written as a plan (separating-plan.toml)",
                d.basis
            )
        } else if a.delta_bic > select::TIE_BIC {
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
    (ambiguities, amb_by_kind)
}

/// The noise groups with their row counts and σ, as the diagnosis reports them.
fn noise_groups(groups: &data::Groups, sigma: &[f64]) -> Vec<NoiseGroup> {
    groups
        .labels
        .iter()
        .enumerate()
        .map(|(g, l)| NoiseGroup {
            group: l.clone(),
            rows: groups.count[g],
            sigma_um: sigma[g],
        })
        .collect()
}

/// The measurements that would separate the physics-decided pairs, as written plans.
fn separating_plans(out: &Outcome) -> Vec<SeparatingPlan> {
    out.decisions
        .iter()
        .map(|d| SeparatingPlan {
            chosen: d.chosen.id(),
            other: d.other.id(),
            basis: d.basis.clone(),
            plan_toml: d.plan_toml.clone(),
        })
        .collect()
}

fn found_effect(
    f: &FittedTerm,
    obs: &data::Obs,
    out: &Outcome,
    amb: Option<&Vec<String>>,
) -> Result<FoundEffect, DiagnoseError> {
    let offset_axis = match f.term.kind {
        Kind::Abbe(i) => Some(obs.c_axes[i as usize]),
        _ => None,
    };
    let numbers: Vec<(P, f64)> = f.params.iter().map(|p| (p.name, p.value)).collect();
    let uncertainty = f
        .params
        .iter()
        .map(|p| (p.name, if p.fitted { p.sigma } else { 0.0 }))
        .collect();
    let mut text = where_text(f, obs, out);
    for z in zero_statements(f) {
        text.push_str("; ");
        text.push_str(&z);
    }
    for n in &f.notes {
        text.push_str("; ");
        text.push_str(n);
    }
    if let Some(a) = amb {
        for s in a {
            text.push_str("; ");
            text.push_str(s);
        }
    }
    Ok(FoundEffect {
        effect: Effect::from_numbers(f.term.kind.id(), &numbers, offset_axis)?,
        uncertainty,
        where_: text,
        explains_um: centred_rms(&f.contribution),
    })
}

/// A fitted parameter within two of its sigmas of zero, in words, with what zero means for
/// the set-up (e.g. "ppm_per_hpa = −0.002 ± 0.010 ppm/hPa, consistent with zero: the
/// pressure is compensated correctly"). A period, phase or time constant has no
/// meaningful zero and is not tested.
fn zero_statements(f: &FittedTerm) -> Vec<String> {
    f.params
        .iter()
        .filter(|p| p.fitted && p.sigma.is_finite() && p.sigma > 0.0)
        .filter(|p| p.value.abs() <= 2.0 * p.sigma)
        .filter_map(|p| {
            let (unit, meaning) = match p.name {
                P::PpmPerHpa => ("ppm/hPa", "the pressure is compensated correctly"),
                P::PpmPerK => ("ppm/K", "the air temperature is compensated correctly"),
                P::X0Mm => ("mm", "the scale's fixed point is at the axis zero"),
                P::Theta0Urad => ("µrad", "no angular error at the axis zero"),
                P::Theta1UradPerMm => ("µrad/mm", "the angle does not change along the axis"),
                P::AlphaPpmPerK => ("ppm/K", "no expansion with the scale temperature"),
                _ => return None,
            };
            let d = decimals(p.sigma);
            Some(format!(
                "{} = {} ± {} {unit}, consistent with zero: {meaning}",
                p.name,
                fixed(p.value, d),
                fixed(p.sigma, d)
            ))
        })
        .collect()
}

/// Decimals that show two significant digits of `sigma`.
fn decimals(sigma: f64) -> usize {
    (1 - sigma.abs().log10().floor() as i32).clamp(0, 8) as usize
}

/// What `where_text` says about every effect: the effect, the data, and the ranges and
/// the row where the effect is largest, shared by the per-kind sentences.
struct Where<'a> {
    f: &'a FittedTerm,
    obs: &'a data::Obs,
    out: &'a Outcome,
    axl: String,
    xlo: f64,
    xhi: f64,
}

impl Where<'_> {
    /// The fitted value of parameter `name` (0 when the term has none).
    fn pv(&self, name: P) -> f64 {
        self.f
            .params
            .iter()
            .find(|p| p.name == name)
            .map_or(0.0, |p| p.value)
    }

    /// The reversal's sentence: the ±b/2 step, where it applies, and its change along the
    /// axis when the linear variant was chosen.
    fn reversal(&self, v: &Variant) -> String {
        let (obs, axl, xlo, xhi) = (self.obs, &self.axl, self.xlo, self.xhi);
        let pv = |name: P| self.pv(name);
        let along = if matches!(v, Variant::ReversalLinear) {
            let xm = effects::reversal_centre_mm(obs);
            let b = |x: f64| pv(P::BUm) + pv(P::B1UmPerM) * (x - xm) * 1e-3;
            format!(
                "; the reversal changes along the axis (position-dependent backlash, linear fits better than a constant by BIC): b = {:.3} µm at {axl} = {} mm, {:.3} µm at {} mm, {:.3} µm at {} mm (b_um is its value at the middle of the travel, b1_um_per_m its change per metre)",
                b(xlo),
                fixed(xlo, 0),
                b(xm),
                fixed(xm, 0),
                b(xhi),
                fixed(xhi, 0)
            )
        } else {
            String::new()
        };
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
            "opposite in the + and − directions (±b/2 = ±{:.3} µm) on every row, {rows}{feed}; follows the direction of travel{along}",
            pv(P::BUm) / 2.0
        )
    }

    /// The latch delay's sentence: the step at the first feeds, and the speed it follows.
    fn latch(&self, v: &Variant) -> String {
        let obs = self.obs;
        let pv = |name: P| self.pv(name);
        let mut feeds: Vec<f64> = (0..obs.len())
            .filter(|&k| obs.moving[k] && obs.v_feed[k] > 0.0)
            .map(|k| obs.v_feed[k])
            .collect();
        feeds.sort_by(f64::total_cmp);
        feeds.dedup();
        let at: Vec<String> = feeds
            .iter()
            .take(4)
            .map(|v| format!("±{:.3} µm at {v} mm/s", v * pv(P::TauUs) * 1e-3))
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

    /// The periodic error's sentence: its period, whether the grating explains it, its
    /// amplitude.
    fn periodic(&self, period_um: f64) -> String {
        let (out, axl) = (self.out, &self.axl);
        let period_um = &period_um;
        let pv = |name: P| self.pv(name);
        let tied = out
            .periods
            .iter()
            .filter(|p| {
                (p.refined_um.unwrap_or(p.period_um) - period_um).abs() < 3.0 * p.step_um.max(1e-9)
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
            pv(P::AmplitudeUm)
        )
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
    let w = Where {
        f,
        obs,
        out,
        axl: axl.clone(),
        xlo,
        xhi,
    };
    let pv = |name: P| w.pv(name);
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
            pv(P::Ppm) * (xhi - xlo) * 1e-3,
            f.term.kind.follows(obs)
        ),
        (Kind::ScaleThermal, v) => {
            let (tl, th) = obs.scale_t.as_deref().map_or((f64::NAN, f64::NAN), range);
            let x0 = if matches!(v, Variant::X0Free) {
                format!("x0 = {} mm fitted", fmt_sig(pv(P::X0Mm)))
            } else {
                "x0 fixed at 0 mm (a free x0 is not supported by the data)".into()
            };
            format!(
                "follows the scale temperature times position, −α·(T_scale − 20)·({axl} − x0), with the scale at {tl:.2}–{th:.2} °C; {pp:.3} µm peak to peak, largest at {axl} ≈ {:.0} mm, t ≈ {:.0} s; {x0}",
                obs.x[kmax], obs.t[kmax]
            )
        }
        (Kind::Abbe(i), v) => {
            let cn = obs.c_axes[*i as usize].lower();
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
        (Kind::Reversal, v) => w.reversal(v),
        (Kind::LatchDelay, v) => w.latch(v),
        (Kind::Periodic, Variant::Periodic { period_um }) => w.periodic(*period_um),
        (Kind::ThermalDrift, Variant::DriftExp { tau_s }) => format!(
            "follows time, not position: rises by {:.3} µm over t {tlo:.0}–{thi:.0} s, exponential with τ = {tau_s:.0} s (an exponential fits better than a linear drift by BIC)",
            pv(P::AmplitudeUm) * (1.0 - (-(thi - obs.t0) / tau_s).exp())
        ),
        (Kind::ThermalDrift, _) => format!(
            "follows time, not position: a linear drift of {:.3} µm over t {tlo:.0}–{thi:.0} s (a time constant is not determined by these data)",
            pv(P::RateUmPerS) * (thi - tlo)
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
                            obs.c_axes[0].lower(),
                            line[0],
                            obs.c_axes[1].lower(),
                            line[1]
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
            id: f.term.kind.id(),
            covariate_label: label,
            covariate: cov,
            partial_um: partial,
            fitted_um: f.contribution.clone(),
            groups,
        });
    }
    ReportSeries {
        keys: obs
            .run
            .iter()
            .copied()
            .zip(obs.sample.iter().copied())
            .collect(),
        x_mm: obs.x.clone(),
        t_s: obs.t.clone(),
        before_um: before.to_vec(),
        after_um: after.to_vec(),
        effects,
        broad_period_mm: out.broad.period_mm.clone(),
        broad_power: out.broad.power.clone(),
    }
}
