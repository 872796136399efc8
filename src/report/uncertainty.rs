//! The measurement-uncertainty budget as a table, and the note on which positioning
//! standards errmap evaluates, from the numbers of [`crate::session::Budget`].

use super::md::Md;

use crate::session::{Budget, ContributionKind as Kind, Origin};

/// One row of the budget as printed: influence, input, sensitivity, contribution in its own
/// unit, and the contribution in µm over the travel. Shared by the markdown and the PDF.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BudgetRow {
    /// The influence.
    pub name: String,
    /// The input's standard uncertainty with its unit.
    pub input: String,
    /// The sensitivity coefficient with its unit.
    pub sensitivity: String,
    /// The contribution `u_i` with its unit (ppm or µm).
    pub u: String,
    /// The contribution over the travel, µm.
    pub u_travel_um: String,
    /// Where the input comes from.
    pub source: String,
}

/// The budget's rows, µm to `decimals` places.
pub(crate) fn budget_rows(budget: &Budget, decimals: usize) -> Vec<BudgetRow> {
    let travel = budget.conditions.travel_mm;
    budget
        .contributions
        .iter()
        .map(|c| BudgetRow {
            name: c.name.to_string(),
            input: format!("{} {}", sig(c.input), c.input_unit),
            sensitivity: format!("{} {}", sig(c.sensitivity), c.sensitivity_unit)
                .trim_end()
                .to_string(),
            u: match c.kind {
                Kind::Length => format!("{} ppm", sig(c.u)),
                Kind::Reading => format!("{:.decimals$} µm", c.u),
            },
            u_travel_um: format!("{:.decimals$}", c.u_um_at(travel)),
            source: c.source.clone(),
        })
        .collect()
}

/// The air and material conditions in words, with where they come from.
pub(crate) fn conditions_text(budget: &Budget) -> String {
    let c = &budget.conditions;
    let air = match c.air {
        Origin::Sensor => format!(
            "air from the session's sensors: mean {:.2} °C, {:.2} hPa, {:.1} %RH",
            c.air_temp_c, c.air_pressure_hpa, c.air_rh_pct
        ),
        Origin::Declared => format!(
            "no air sensor: the air conditions the info file declares (sensitivities at their \
             midpoints {:.2} °C, {:.2} hPa, {:.1} %RH)",
            c.air_temp_c, c.air_pressure_hpa, c.air_rh_pct
        ),
        Origin::Missing => format!(
            "no air sensor and no declared air conditions: the laser lengths are taken as \
             written (a laser export's are already compensated by its own software); \
             sensitivities at {} °C, {} hPa, {} %RH",
            c.air_temp_c, c.air_pressure_hpa, c.air_rh_pct
        ),
    };
    let material = match (c.material, c.material_temp_c) {
        (Origin::Sensor, Some(t)) => format!("mean material temperature {t:.2} °C (sensor)"),
        (Origin::Declared, Some(t)) => {
            format!("material temperature {t:.2} °C (midpoint of the declared range)")
        }
        _ => "no material temperature recorded or declared".to_string(),
    };
    format!("{air}; {material}")
}

/// The sentence on what the budget leaves out, empty when nothing.
pub(crate) fn not_evaluated_text(budget: &Budget) -> String {
    if budget.not_evaluated.is_empty() {
        return String::new();
    }
    format!(
        "Not evaluated (no source): {}.",
        budget.not_evaluated.join("; ")
    )
}

/// Four significant digits, without exponent for the magnitudes a budget holds.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let d = (3.0 - v.abs().log10().floor()).clamp(0.0, 12.0) as usize;
    format!("{v:.d$}")
}

/// The budget as a markdown section: the test conditions, the table, the combined and
/// expanded uncertainties.
pub(crate) fn budget_markdown(budget: &Budget, decimals: usize) -> String {
    let c = &budget.conditions;
    let conditions = conditions_text(budget);
    let mut md = Md::new();
    md.heading(4, "Measurement uncertainty (ISO/TR 230-9, GUM)")
        .para(format_args!(
            "Travel {} mm; {conditions}. Length terms in ppm of the distance compared, \
             reading terms in µm; the last column is each term over the travel.",
            c.travel_mm
        ))
        .table_aligned(
            [
                "influence",
                "u(x_i)",
                "sensitivity c_i",
                "u_i",
                "u_i over the travel, µm",
                "source",
            ],
            "lrrrrl",
        );
    for r in budget_rows(budget, decimals) {
        md.row([r.name, r.input, r.sensitivity, r.u, r.u_travel_um, r.source]);
    }
    let u = budget.expanded();
    md.nl().line(format_args!(
        "Combined: u_rel = {} ppm (length terms), u_read = {:.decimals$} µm (reading terms); \
         u_c = √((u_rel·L)² + 2·u_read²) = {:.decimals$} µm over the travel, {:.decimals$} µm \
         at one target; U = k·u_c with k = {}, never below one resolution step ({} µm): \
         {:.decimals$} µm and {:.decimals$} µm. {}",
        sig(budget.u_rel_ppm),
        budget.u_read_um,
        u.u_c_travel_um,
        u.u_c_target_um,
        u.k,
        sig(u.resolution_floor_um),
        u.along_travel_um,
        u.at_one_target_um,
        not_evaluated_text(budget)
    ));
    md.finish()
}

/// Which positioning standards the statistics stand for, and which could not be sourced.
pub(crate) const STANDARDS_NOTE: &str = "Standards: ISO 230-2:2014 (the formulas are those of the \
2006 edition too). GB/T 17421.2-2016 carries ISO 230-2 (its published scope is that of ISO \
230-2:2006: uncertainty per ISO/TR 230-9:2005, Annex A uncertainty, Annex B step cycle), so \
its values are the ISO 230-2 values above. VDI/DGQ 3441 as stated. JIS B 6192 and ASME B5.54's \
positioning accuracy: their definitions could not be sourced for this report, so no values \
are given under their names.";
