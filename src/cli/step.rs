//! `errmap export --ends/--reference`: where a compensation table's points go.

use errmap::export::{ExportFormat, StepFit};

use super::values::EndsArg;

/// `--ends clamp|extrapolate` → a round grid through `reference_mm`; without it, formats
/// that list every position end on the range end, the others need a dividing step.
pub(crate) fn step_fit(format: &ExportFormat, ends: Option<EndsArg>, reference_mm: f64) -> StepFit {
    match ends {
        Some(e) => StepFit::Grid {
            reference_mm,
            ends: e.into(),
        },
        None if format.allows_uneven() => StepFit::LastShorter,
        None => StepFit::Divide,
    }
}
