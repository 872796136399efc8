//! What a diagnosis returns: [`Diagnosis`] (the contract's keys first, then the extras),
//! its [`Verdict`], the [`FoundEffect`]s, and the per-row series behind the report's charts.

use crate::base::Axis;
use crate::base::{Effect, ParamValue, ParamsMap};
use crate::base::{EffectId, ParamName};
use std::collections::BTreeMap;

use serde::Serialize;

use super::data::Matching;
use super::locate::Locate;

pub use crate::base::Verdict;

/// One found effect: the typed effect, the one-sigma of each numeric parameter, where the
/// mismatch is and how much it explains. Written in the contract's shape,
/// `{"id", "params", "uncertainty", "where", "explains_um"}`.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundEffect {
    /// The effect with its fitted parameters.
    pub effect: Effect,
    /// One-sigma uncertainty per numeric parameter (0 for a parameter fixed by the
    /// chosen variant, which `where` then says).
    pub uncertainty: BTreeMap<ParamName, f64>,
    /// Where the mismatch is, in words; also any ambiguity.
    pub where_: String,
    /// RMS (about its mean) of the effect's fitted contribution, µm.
    pub explains_um: f64,
}

impl FoundEffect {
    /// The vocabulary id.
    pub fn id(&self) -> EffectId {
        self.effect.id()
    }

    /// The numeric parameter `name`, if the effect carries it.
    pub fn number(&self, name: ParamName) -> Option<f64> {
        self.effect.number(name)
    }

    /// The one-sigma of `name`, if given.
    pub fn sigma(&self, name: ParamName) -> Option<f64> {
        self.uncertainty.get(&name).copied()
    }

    /// A parameter by the contract's spelling (for a name read from a file or a test).
    pub fn param_named(&self, name: &str) -> Option<ParamValue> {
        self.effect
            .params()
            .into_iter()
            .find(|(n, _)| n.as_str() == name)
            .map(|(_, v)| v)
    }

    /// A numeric parameter by the contract's spelling.
    pub fn number_named(&self, name: &str) -> Option<f64> {
        self.param_named(name).and_then(ParamValue::as_f64)
    }

    /// A one-sigma by the contract's spelling.
    pub fn sigma_named(&self, name: &str) -> Option<f64> {
        self.uncertainty
            .iter()
            .find(|(n, _)| n.as_str() == name)
            .map(|(_, v)| *v)
    }

    /// The one-sigmas in the order of their names, as written.
    pub fn uncertainty_by_name(&self) -> Vec<(ParamName, f64)> {
        let mut u: Vec<(ParamName, f64)> = self.uncertainty.iter().map(|(k, v)| (*k, *v)).collect();
        u.sort_by_key(|(n, _)| n.as_str());
        u
    }
}

impl Serialize for FoundEffect {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let uncertainty: BTreeMap<&str, f64> = self
            .uncertainty
            .iter()
            .map(|(k, v)| (k.as_str(), *v))
            .collect();
        let mut st = s.serialize_struct("FoundEffect", 5)?;
        st.serialize_field("id", &self.effect.id())?;
        st.serialize_field("params", &ParamsMap(&self.effect))?;
        st.serialize_field("uncertainty", &uncertainty)?;
        st.serialize_field("where", &self.where_)?;
        st.serialize_field("explains_um", &self.explains_um)?;
        st.end()
    }
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
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateScore {
    /// The effect.
    pub effect: EffectId,
    /// For abbe: the axis its offset lies along (the vocabulary tests one per axis).
    pub offset_axis: Option<Axis>,
    /// Whether it was reported.
    pub found: bool,
    /// For a found effect: how much BIC rises when it is removed; otherwise how much BIC
    /// changes when it is added (negative: it would help).
    pub delta_bic: f64,
}

impl CandidateScore {
    /// The effect as reports name it: the id, with the offset axis for abbe.
    pub fn label(&self) -> String {
        effect_label(self.effect, self.offset_axis)
    }
}

/// An effect as messages and reports name it: its id, with the axis an Abbe offset lies
/// along (`abbe (offset along y)`).
pub(super) fn effect_label(effect: EffectId, offset_axis: Option<Axis>) -> String {
    match offset_axis {
        Some(a) => format!("{effect} (offset along {})", a.lower()),
        None => effect.to_string(),
    }
}

impl Serialize for CandidateScore {
    /// `{"effect": label, "found", "delta_bic"}`: the label, as the report's table shows it.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("CandidateScore", 3)?;
        st.serialize_field("effect", &self.label())?;
        st.serialize_field("found", &self.found)?;
        st.serialize_field("delta_bic", &self.delta_bic)?;
        st.end()
    }
}

/// The diagnosis (contract keys first; the rest are extras).
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// [`Verdict::Consistent`] or [`Verdict::MissingPhysics`].
    pub verdict: Verdict,
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
    /// The static part taken from the recording itself (`diagnose_recorded`; None when
    /// diagnosed against a simulation).
    pub static_map: Option<StaticMapSummary>,
    /// Choices between effects these data cannot tell apart, made on physical grounds,
    /// each with the measurement that separates them as a ready plan.
    pub separating_plans: Vec<SeparatingPlan>,
    /// Series for the report's charts (not serialised).
    #[serde(skip)]
    pub series: ReportSeries,
}

/// The static map a recording-only diagnosis takes from the recording: the mean error per
/// line, target and direction (dwell rows) and per line, direction and 1/40 of the travel
/// (moving rows).
#[derive(Debug, Clone, Serialize)]
pub struct StaticMapSummary {
    /// Groups (map levels) in all.
    pub groups: usize,
    /// Groups of dwell rows (line × target × direction).
    pub dwell_groups: usize,
    /// Peak to peak of the dwell groups' mean errors, µm.
    pub map_span_um: f64,
    /// Mean over targets of the reversal ē↑ − ē↓ (the vocabulary's b), µm.
    pub mean_reversal_um: f64,
    /// Peak to peak of the reversal over the targets, µm.
    pub reversal_span_um: f64,
    /// Targets approached in both directions.
    pub targets_with_reversal: usize,
}

/// A choice between two effects made on physical grounds, and the measurement that
/// would separate them.
#[derive(Debug, Clone, Serialize)]
pub struct SeparatingPlan {
    /// The effect reported.
    pub chosen: EffectId,
    /// The effect it could not be told apart from.
    pub other: EffectId,
    /// The basis of the choice, in words.
    pub basis: String,
    /// The separating measurement as a plan file (TOML: `errmap simulate --plan`,
    /// `errmap plan`); the report writes it as `separating-plan.toml`.
    pub plan_toml: String,
}

/// Per-row series behind the report's charts.
#[derive(Debug, Clone, Default)]
pub struct ReportSeries {
    /// (run, sample) of every row: its key in the recording.
    pub keys: Vec<(u32, i64)>,
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
#[derive(Debug, Clone)]
pub struct EffectSeries {
    /// The effect.
    pub id: EffectId,
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
