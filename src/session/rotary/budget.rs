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
//! # The figures' U
//!
//! | figure | what it compares | U (k = 2) |
//! |---|---|---|
//! | x̄_i, M | one mean deviation against the reference | 2·u_c (every term) |
//! | A, E and their ↑/↓ forms | values at two targets, their terms independent | √2 · 2·u_c |
//! | B, B̄ | x̄↑ − x̄↓ at one angle: the reference's error is the same for both | 2·√(2·(u_counts² + u_A²)), ≥ one count |
//! | R and its ↑/↓ forms | readings at one angle | 2·√(2·u_counts²), ≥ one count; none without a known count |
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

/// The budget: its terms, u_c and U (k = 2) of a mean deviation, and the U of the
/// figures built from two values (module docs, "The figures' U").
#[derive(Debug, Clone, PartialEq)]
pub struct RotaryBudget {
    pub terms: Vec<RotaryTerm>,
    pub combined_arcsec: f64,
    /// U of one mean deviation x̄ (and of M, the largest |x̄|).
    pub expanded_arcsec: f64,
    /// U of a difference of two targets' values (A, E and their one-direction forms):
    /// √2 · U(x̄), the two targets' terms independent.
    pub between_targets_arcsec: f64,
    /// U of a reversal B, B̄ (x̄↑ − x̄↓ at one angle): the reference's own error is the same
    /// for both and cancels; the counts and the two means' repeatability stay.
    pub reversal_arcsec: f64,
    /// U of a repeatability R (readings at one angle): the counts alone, never below one
    /// count; `None` when no count is known (no device data).
    pub repeatability_arcsec: Option<f64>,
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
    let counts_from = terms.len();
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
    let counts = counts_from..terms.len();
    let (mut s, mut n) = (0.0f64, usize::MAX);
    for t in &iso.targets {
        s = s.max(t.s_up_arcsec).max(t.s_down_arcsec);
        n = n.min(t.n_up).min(t.n_down);
    }
    let type_a = terms.len()..terms.len() + usize::from(n != usize::MAX && n > 0);
    if n != usize::MAX && n > 0 {
        terms.push(RotaryTerm {
            name: "repeatability of a mean",
            source: format!("largest s = {s:.3}″ over {n} runs"),
            distribution: "normal (type A)",
            u_arcsec: s / (n as f64).sqrt(),
        });
    }
    let squares = |t: &[RotaryTerm]| t.iter().map(|t| t.u_arcsec.powi(2)).sum::<f64>();
    let combined_arcsec = squares(&terms).sqrt();
    let (u_counts2, u_type_a2) = (squares(&terms[counts]), squares(&terms[type_a]));
    let one_count = [inputs.reference_count_arcsec, inputs.encoder_count_arcsec]
        .into_iter()
        .flatten()
        .reduce(f64::max);
    RotaryBudget {
        terms,
        combined_arcsec,
        expanded_arcsec: 2.0 * combined_arcsec,
        between_targets_arcsec: 2.0 * (2.0 * combined_arcsec.powi(2)).sqrt(),
        reversal_arcsec: (2.0 * (2.0 * (u_counts2 + u_type_a2)).sqrt())
            .max(one_count.unwrap_or(0.0)),
        repeatability_arcsec: one_count.map(|q| (2.0 * (2.0 * u_counts2).sqrt()).max(q)),
        reference_assumed: assumed,
    }
}

#[cfg(test)]
mod tests {
    use super::super::iso::RotaryTargetStats;
    use super::*;

    /// Two targets, s = 0.5″ and 0.3″ over 5 runs each.
    fn iso() -> RotaryIso {
        let target = |k: usize, s: f64| RotaryTargetStats {
            target: k,
            position_deg: 180.0 * k as f64,
            n_up: 5,
            n_down: 5,
            mean_up_arcsec: 0.0,
            mean_down_arcsec: 0.0,
            mean_bidir_arcsec: 0.0,
            reversal_arcsec: 0.0,
            s_up_arcsec: s,
            s_down_arcsec: s,
            repeat_up_arcsec: 4.0 * s,
            repeat_down_arcsec: 4.0 * s,
            repeat_bidir_arcsec: 4.0 * s,
        };
        RotaryIso {
            b_arcsec: 0.0,
            mean_reversal_arcsec: 0.0,
            r_up_arcsec: 0.0,
            r_down_arcsec: 0.0,
            r_arcsec: 0.0,
            e_up_arcsec: 0.0,
            e_down_arcsec: 0.0,
            e_arcsec: 0.0,
            m_arcsec: 0.0,
            a_up_arcsec: 0.0,
            a_down_arcsec: 0.0,
            a_arcsec: 0.0,
            targets: vec![target(0, 0.5), target(1, 0.3)],
        }
    }

    #[test]
    fn each_figure_gets_the_u_of_what_it_compares() {
        let (a, q_ref, q_enc) = (2.0_f64, 0.36_f64, 0.1_f64);
        let b = rotary_budget(
            &iso(),
            &RotaryBudgetInputs {
                reference_accuracy_arcsec: Some(a),
                centring_arcsec: None,
                reference_count_arcsec: Some(q_ref),
                encoder_count_arcsec: Some(q_enc),
            },
        );
        let counts2 = (q_ref * q_ref + q_enc * q_enc) / 12.0;
        let type_a2 = 0.5 * 0.5 / 5.0;
        let mean2 = a * a / 3.0 + counts2 + type_a2;
        approx::assert_relative_eq!(b.expanded_arcsec, 2.0 * mean2.sqrt(), epsilon = 1e-12);
        approx::assert_relative_eq!(
            b.between_targets_arcsec,
            2.0 * (2.0 * mean2).sqrt(),
            epsilon = 1e-12
        );
        // The reference's ±2″ cancels at one angle.
        approx::assert_relative_eq!(
            b.reversal_arcsec,
            2.0 * (2.0 * (counts2 + type_a2)).sqrt(),
            epsilon = 1e-12
        );
        // 2·√(2·counts²) = 0.305″ is below one count (0.36″): the floor holds.
        assert!(2.0 * (2.0 * counts2).sqrt() < q_ref);
        assert_eq!(b.repeatability_arcsec, Some(q_ref));
        assert!(!b.reference_assumed);
        // No count known: R states none, B keeps its type-A part.
        let none = rotary_budget(&iso(), &RotaryBudgetInputs::default());
        assert_eq!(none.repeatability_arcsec, None);
        approx::assert_relative_eq!(
            none.reversal_arcsec,
            2.0 * (2.0 * type_a2).sqrt(),
            epsilon = 1e-12
        );
        assert!(none.reference_assumed);
    }
}
