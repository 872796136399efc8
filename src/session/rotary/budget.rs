//! The measurement uncertainty of a rotary axis' mean deviations, ″ (`docs/rotary.md`,
//! "The rotary certificate"): the GUM's (JCGM 100:2008) combination of standard
//! uncertainties, each with its distribution, expanded with k = 2.
//!
//! | term | from | standard uncertainty |
//! |---|---|---|
//! | the reference instrument | its stated accuracy ±a″ (an XR20-style indexer: ±1″ class) | a/√3 (rectangular) |
//! | its centring on the axis | a stated ±c″, when given | c/√3 (rectangular) |
//! | the reference's count | one count q_ref″ (the device's HELLO) | q_ref/√12 |
//! | the axis encoder's count | one count q_enc″ (the device's HELLO) | q_enc/√12 |
//! | repeatability of a mean | the largest s_i of any target and direction, n the fewest observations | s/√n (type A) |
//!
//! No thermal term: an angle does not change with a uniform temperature change (a ratio
//! of lengths), so the linear budget's expansion terms have no rotary counterpart; a
//! drift during the test shows in the closure check and in the diagnosis instead.

use super::RotaryIso;

/// The reference's accuracy assumed when none is stated: ±1″, an XR20-style indexer's
/// class.
pub const ASSUMED_REFERENCE_ACCURACY_ARCSEC: f64 = 1.0;

/// One term of the budget.
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryTerm {
    pub name: &'static str,
    /// Where its value comes from, in words.
    pub source: String,
    pub distribution: &'static str,
    pub u_arcsec: f64,
}

/// The inputs beyond the session's own numbers.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RotaryBudgetInputs {
    /// The reference's stated accuracy ±a″; `None`: [`ASSUMED_REFERENCE_ACCURACY_ARCSEC`].
    pub reference_accuracy_arcsec: Option<f64>,
    /// The reference's centring on the axis ±c″, if stated.
    pub centring_arcsec: Option<f64>,
    /// One count of the reference and of the axis' encoder, ″ (the device's HELLO).
    pub reference_count_arcsec: Option<f64>,
    pub encoder_count_arcsec: Option<f64>,
}

/// The budget: its terms, u_c and U (k = 2).
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryBudget {
    pub terms: Vec<RotaryTerm>,
    pub combined_arcsec: f64,
    pub expanded_arcsec: f64,
    /// Whether the reference's accuracy was assumed (not stated).
    pub reference_assumed: bool,
}

/// The budget of a mean deviation x̄_i of `iso` with `inputs`.
pub fn rotary_budget(iso: &RotaryIso, inputs: &RotaryBudgetInputs) -> RotaryBudget {
    let sqrt3 = 3f64.sqrt();
    let sqrt12 = 12f64.sqrt();
    let a = inputs
        .reference_accuracy_arcsec
        .unwrap_or(ASSUMED_REFERENCE_ACCURACY_ARCSEC);
    let assumed = inputs.reference_accuracy_arcsec.is_none();
    let mut terms = vec![RotaryTerm {
        name: "reference instrument",
        source: if assumed {
            format!("±{a}″ assumed (an XR20-style indexer's class; not stated)")
        } else {
            format!("±{a}″ stated")
        },
        distribution: "rectangular",
        u_arcsec: a / sqrt3,
    }];
    if let Some(c) = inputs.centring_arcsec {
        terms.push(RotaryTerm {
            name: "reference centring",
            source: format!("±{c}″ stated"),
            distribution: "rectangular",
            u_arcsec: c / sqrt3,
        });
    }
    for (name, q) in [
        ("reference count", inputs.reference_count_arcsec),
        ("axis encoder count", inputs.encoder_count_arcsec),
    ] {
        if let Some(q) = q {
            terms.push(RotaryTerm {
                name,
                source: format!("one count {q:.4}″ (the device's HELLO)"),
                distribution: "rectangular (resolution)",
                u_arcsec: q / sqrt12,
            });
        }
    }
    let (mut s, mut n) = (0.0f64, usize::MAX);
    for t in &iso.targets {
        s = s.max(t.s_up_arcsec).max(t.s_down_arcsec);
        n = n.min(t.n_up).min(t.n_down);
    }
    if n != usize::MAX && n > 0 {
        terms.push(RotaryTerm {
            name: "repeatability of a mean",
            source: format!("largest s = {s:.3}″ over {n} runs"),
            distribution: "normal (type A)",
            u_arcsec: s / (n as f64).sqrt(),
        });
    }
    let combined_arcsec = terms.iter().map(|t| t.u_arcsec.powi(2)).sum::<f64>().sqrt();
    RotaryBudget {
        terms,
        combined_arcsec,
        expanded_arcsec: 2.0 * combined_arcsec,
        reference_assumed: assumed,
    }
}
