//! The decision rules: a result y with expanded uncertainty U against a zone [T_L, T_U].
//!
//! | rule | guard band w | pass | fail | otherwise |
//! |---|---|---|---|---|
//! | [`Rule::Iso14253`] (ISO 14253-1:2017 default) | U | T_L + U ≤ y ≤ T_U − U | y < T_L − U or y > T_U + U | indeterminate |
//! | [`Rule::Simple`] (ILAC-G8:09/2019 4.2.1) | 0 | T_L ≤ y ≤ T_U | — | fail |
//! | [`Rule::Guard`] (ILAC-G8:09/2019 4.2.2, r ≥ 0) | r·U | T_L + w ≤ y ≤ T_U − w | — | fail |
//!
//! An absent limit is unbounded on its side (never 0). Pass limits are inclusive, fail is
//! strictly outside. When 2w exceeds the zone's width nothing can pass (the acceptance
//! zone is empty). The comparisons are made on the acceptance limits T_L + w and T_U − w
//! as computed in f64, so a result printed equal to a limit is judged as that limit.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use super::AcceptanceError;

/// A verdict of conformity (`pass`, `indeterminate`, `fail`) — not `base::Verdict`, which
/// says whether a model explains its residual. Ordered from best to worst, so the
/// aggregate is the maximum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ConformityVerdict {
    Pass,
    Indeterminate,
    Fail,
}

impl ConformityVerdict {
    /// The word the outputs print: `pass`, `indeterminate`, `fail`.
    pub fn as_str(self) -> &'static str {
        match self {
            ConformityVerdict::Pass => "pass",
            ConformityVerdict::Indeterminate => "indeterminate",
            ConformityVerdict::Fail => "fail",
        }
    }
}

impl fmt::Display for ConformityVerdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Several verdicts as one: `fail` if any fails, else `indeterminate` if any is, else
/// `pass`; `None` for none at all.
pub fn aggregate(
    verdicts: impl IntoIterator<Item = ConformityVerdict>,
) -> Option<ConformityVerdict> {
    verdicts.into_iter().max()
}

/// Which rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rule {
    /// ISO 14253-1:2017's default rule: guard band U, three verdicts.
    #[default]
    Iso14253,
    /// ILAC-G8:09/2019 simple acceptance: w = 0, two verdicts.
    Simple,
    /// ILAC-G8:09/2019 binary statement with a guard band w = r·U.
    Guard,
}

impl Rule {
    pub const ALL: [Rule; 3] = [Rule::Iso14253, Rule::Simple, Rule::Guard];

    /// The name the command line, TOML and JSON spell.
    pub fn name(self) -> &'static str {
        match self {
            Rule::Iso14253 => "iso14253",
            Rule::Simple => "simple",
            Rule::Guard => "guard",
        }
    }
}

/// A name that is not one of [`Rule::ALL`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{0}` is not a rule (iso14253, simple, guard)")]
pub struct UnknownRule(pub String);

impl FromStr for Rule {
    type Err = UnknownRule;
    fn from_str(s: &str) -> Result<Rule, UnknownRule> {
        Rule::ALL
            .into_iter()
            .find(|r| r.name() == s.trim())
            .ok_or_else(|| UnknownRule(s.to_string()))
    }
}

/// A specification zone; either limit may be absent, not both.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Limits {
    pub lower: Option<f64>,
    pub upper: Option<f64>,
}

impl Limits {
    /// Checked: at least one limit, finite, lower ≤ upper.
    pub fn new(lower: Option<f64>, upper: Option<f64>) -> Result<Limits, LimitsError> {
        if lower.is_none() && upper.is_none() {
            return Err(LimitsError::Neither);
        }
        for &v in lower.iter().chain(upper.iter()) {
            if !v.is_finite() {
                return Err(LimitsError::NotFinite(v));
            }
            // Plausible sizes only (issue 40 item 5: 1e300 µm certified "pass").
            let hi = crate::base::TOLERANCE_UM.hi;
            if v.abs() > hi {
                return Err(LimitsError::Implausible { value: v, hi });
            }
        }
        if let (Some(lower), Some(upper)) = (lower, upper)
            && lower > upper
        {
            return Err(LimitsError::Crossed { lower, upper });
        }
        Ok(Limits { lower, upper })
    }
}

/// Why two limits do not make a zone.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitsError {
    #[error("neither a lower nor an upper limit")]
    Neither,
    #[error("limit {0} is not finite")]
    NotFinite(f64),
    #[error("limit {value} µm is beyond ±{hi} µm, no plausible tolerance")]
    Implausible { value: f64, hi: f64 },
    #[error("lower limit {lower} is above the upper limit {upper}")]
    Crossed { lower: f64, upper: f64 },
}

/// A rule with its guard-band fraction (used by [`Rule::Guard`] only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecisionRule {
    pub rule: Rule,
    /// r of w = r·U, ≥ 0 (1 by default).
    pub guard_fraction: f64,
}

impl Default for DecisionRule {
    fn default() -> Self {
        DecisionRule {
            rule: Rule::Iso14253,
            guard_fraction: 1.0,
        }
    }
}

/// One judged result: the acceptance zone used and the verdict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Decision {
    /// [T_L + w, T_U − w], `None` on a side without a limit.
    pub acceptance: [Option<f64>; 2],
    pub verdict: ConformityVerdict,
}

impl DecisionRule {
    /// Checked: r finite and ≥ 0.
    pub fn new(rule: Rule, guard_fraction: f64) -> Result<DecisionRule, AcceptanceError> {
        if !(guard_fraction.is_finite() && guard_fraction >= 0.0) {
            return Err(AcceptanceError::value(
                "guard fraction",
                format!("r = {guard_fraction} must be finite and ≥ 0"),
            ));
        }
        Ok(DecisionRule {
            rule,
            guard_fraction,
        })
    }

    /// The guard fraction as the JSON shows it: `Some(r)` for the guard rule only.
    pub fn fraction_shown(&self) -> Option<f64> {
        (self.rule == Rule::Guard).then_some(self.guard_fraction)
    }

    /// The guard band for an expanded uncertainty `u`.
    pub fn guard_band(&self, u: f64) -> f64 {
        match self.rule {
            Rule::Iso14253 => u,
            Rule::Simple => 0.0,
            Rule::Guard => self.guard_fraction * u,
        }
    }

    /// Judges `y` with expanded uncertainty `u` against `limits`. Errors: U negative or
    /// not finite, y not finite.
    pub fn decide(&self, y: f64, u: f64, limits: Limits) -> Result<Decision, AcceptanceError> {
        if !(u.is_finite() && u >= 0.0) {
            return Err(AcceptanceError::value(
                "expanded uncertainty",
                format!("U = {u} must be finite and ≥ 0"),
            ));
        }
        if !y.is_finite() {
            return Err(AcceptanceError::value(
                "result",
                format!("{y} is not finite"),
            ));
        }
        let w = self.guard_band(u);
        let acc_lo = limits.lower.map(|t| t + w);
        let acc_hi = limits.upper.map(|t| t - w);
        let inside = acc_lo.is_none_or(|a| a <= y) && acc_hi.is_none_or(|a| y <= a);
        let verdict = if inside {
            ConformityVerdict::Pass
        } else {
            match self.rule {
                Rule::Simple | Rule::Guard => ConformityVerdict::Fail,
                Rule::Iso14253 => {
                    let below = limits.lower.is_some_and(|t| y < t - u);
                    let above = limits.upper.is_some_and(|t| y > t + u);
                    if below || above {
                        ConformityVerdict::Fail
                    } else {
                        ConformityVerdict::Indeterminate
                    }
                }
            }
        };
        Ok(Decision {
            acceptance: [acc_lo, acc_hi],
            verdict,
        })
    }

    /// The rule in words (ISO/IEC 17025:2017 7.8.6.2 c). `u_given`: whether the results
    /// came with an expanded uncertainty; `k` its coverage factor, when known.
    pub fn statement(&self, u_given: bool, k: Option<f64>) -> String {
        let k_text = k.map(|k| format!(" (k = {k})")).unwrap_or_default();
        let mut s = match self.rule {
            Rule::Iso14253 => format!(
                "Decision rule: ISO 14253-1:2017 default rule. Conformity (pass) is stated when \
                 the result lies inside the specification zone reduced at each limit by its \
                 expanded uncertainty U{k_text}; nonconformity (fail) when it lies outside the \
                 zone enlarged by U; otherwise neither can be proven (indeterminate). Limits \
                 belong to the acceptance zone."
            ),
            Rule::Simple => "Decision rule: ILAC-G8:09/2019 simple acceptance (w = 0). Pass \
                 when the result lies inside the specification zone, limits included; fail \
                 otherwise. The uncertainty is not used: a result close to a limit may be \
                 accepted or rejected wrongly with a probability of up to 50 %."
                .to_string(),
            Rule::Guard => format!(
                "Decision rule: ILAC-G8:09/2019 binary statement with guard band w = r·U \
                 (r = {}). Pass when the result lies inside the specification zone reduced \
                 by w at each limit (limits included), U the expanded uncertainty{k_text}; \
                 fail otherwise.",
                self.guard_fraction
            ),
        };
        if !u_given {
            s.push_str(
                " No measurement uncertainty was given: U = 0 was used, so the guard band is \
                 zero and the decision is that of simple acceptance.",
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for r in Rule::ALL {
            assert_eq!(r.name().parse::<Rule>(), Ok(r));
        }
        assert!("ISO14253".parse::<Rule>().is_err());
    }
}
