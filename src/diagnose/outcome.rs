//! What a diagnosis returns: [`Diagnosis`] (the contract's keys first, then the extras),
//! its [`Verdict`], the [`FoundEffect`]s, and the per-row series behind the report's charts.

use crate::base::vocabulary::EffectId;
use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::data::Matching;
use super::locate::Locate;

/// The `verdict` of `diagnose --json` (`docs/cli.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Verdict {
    /// The residual is explained by noise alone: no effect is reported.
    #[serde(rename = "consistent")]
    Consistent,
    /// The simulation left something out: at least one effect is reported (a vocabulary
    /// effect, or `unexplained`).
    #[serde(rename = "missing_physics")]
    MissingPhysics,
}

impl Verdict {
    /// The contract's spelling: `consistent` or `missing_physics` (also the JSON value and
    /// the [`Display`](fmt::Display) text).
    pub const fn as_str(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::MissingPhysics => "missing_physics",
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// Compares with the contract's spelling, as when `verdict` was a string.
impl PartialEq<&str> for Verdict {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

/// One found effect (contract shape).
#[derive(Debug, Clone, Serialize)]
pub struct FoundEffect {
    /// Vocabulary id (or `unexplained` for structure no vocabulary effect explains).
    pub id: EffectId,
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
#[derive(Debug, Clone, Default)]
pub struct EffectSeries {
    /// Effect id (the vocabulary's, as text).
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

#[cfg(test)]
mod tests {
    use super::Verdict;

    #[test]
    fn verdict_is_spelled_as_in_the_contract() {
        for (v, s) in [
            (Verdict::Consistent, "consistent"),
            (Verdict::MissingPhysics, "missing_physics"),
        ] {
            assert_eq!(
                serde_json::to_string(&v).expect("a unit variant serialises"),
                format!("\"{s}\"")
            );
            assert_eq!(
                serde_json::from_str::<Verdict>(&format!("\"{s}\""))
                    .expect("the contract's spelling parses"),
                v
            );
            assert_eq!(v.to_string(), s);
            assert_eq!(v, s);
        }
        assert_ne!(Verdict::Consistent, "missing_physics");
    }
}
