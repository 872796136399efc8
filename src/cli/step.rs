//! `errmap export --ends/--reference`: where a compensation table's points go.

use errmap::export::{Ends, ExportFormat, StepFit};

/// `--ends clamp|extrapolate` → a round grid through `reference_mm`; without it, formats
/// that list every position end on the range end, the others need a dividing step.
pub fn step_fit(format: &ExportFormat, ends: Option<&str>, reference_mm: f64) -> StepFit {
    match ends {
        Some("clamp") => StepFit::Grid {
            reference_mm,
            ends: Ends::Clamp,
        },
        Some(_) => StepFit::Grid {
            reference_mm,
            ends: Ends::Extrapolate,
        },
        None if format.allows_uneven() => StepFit::LastShorter,
        None => StepFit::Divide,
    }
}
