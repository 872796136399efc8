//! The maximum permissible error of ISO 10360-2 as a function of the length L (mm):
//! `A+L/K`, `min(A+L/K,B)` or `B`, A and B in µm, K > 0 (mm per µm). Blanks anywhere are
//! ignored; nothing else parses (no `±`, no units, no other letters). The same grammar
//! gives a length-dependent expanded uncertainty (`--u-um`).
//!
//! Plausible values only (issue 40 item 5: `2+L/1e-300` passed every measurement): A and
//! B at most 10⁴ µm, K within 0.1 … 10⁶ mm/µm (`base::MPE_K_MM_PER_UM`); an MPE
//! ([`Mpe::parse_limit`]) is a limit, so its B is at least 10⁻³ µm and, without B, its A
//! or its slope makes it positive (`base::TOLERANCE_UM`). Each part is refused by name.

use serde::Serialize;

use super::AcceptanceError;

/// A parsed MPE formula.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mpe {
    /// The formula as given (trimmed).
    pub formula: String,
    /// A, µm (`None` for the form `B`).
    pub a_um: Option<f64>,
    /// K, mm/µm (`None` for the form `B`).
    pub k: Option<f64>,
    /// B, µm (`None` for the form `A+L/K`).
    pub b_um: Option<f64>,
}

/// What is wrong with an MPE formula (the formula and where it came from are named by
/// [`AcceptanceError::Formula`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FormulaProblem {
    #[error("empty")]
    Empty,
    #[error("`min(` without its closing `)`")]
    Unclosed,
    #[error("min( needs two arguments, A+L/K and B")]
    MinArguments,
    #[error("`{0}` is not of the form A+L/K")]
    NotLinear(String),
    #[error("{term} `{text}` is not a number")]
    NotNumber { term: &'static str, text: String },
    #[error("{term} `{text}` is not finite")]
    NotFinite { term: &'static str, text: String },
    #[error("{term} = {value} is negative")]
    Negative { term: &'static str, value: f64 },
    #[error("{term} = {value} µm is beyond {limit} µm, no plausible limit")]
    TooLarge {
        term: &'static str,
        value: f64,
        limit: f64,
    },
    #[error(
        "K = {k} is outside {lo} … {hi} mm/µm (K must be > 0; below {lo} the MPE would grow by \
         more than {per_mm} µm per mm of length)",
        per_mm = 1.0 / lo
    )]
    KOutside { k: f64, lo: f64, hi: f64 },
    #[error("B = {b} µm: a maximum permissible error must be at least {least} µm")]
    BelowLeast { b: f64, least: f64 },
}

fn number(s: &str, term: &'static str) -> Result<f64, FormulaProblem> {
    let v: f64 = s.parse().map_err(|_| FormulaProblem::NotNumber {
        term,
        text: s.to_string(),
    })?;
    if !v.is_finite() {
        return Err(FormulaProblem::NotFinite {
            term,
            text: s.to_string(),
        });
    }
    if v < 0.0 {
        return Err(FormulaProblem::Negative { term, value: v });
    }
    if v > crate::base::TOLERANCE_UM.hi {
        return Err(FormulaProblem::TooLarge {
            term,
            value: v,
            limit: crate::base::TOLERANCE_UM.hi,
        });
    }
    Ok(v)
}

/// `A+L/K` → (A, K).
fn linear(s: &str) -> Result<(f64, f64), FormulaProblem> {
    let (a, k) = s
        .split_once("+L/")
        .ok_or_else(|| FormulaProblem::NotLinear(s.to_string()))?;
    let a = number(a, "A")?;
    let k: f64 = k.parse().map_err(|_| FormulaProblem::NotNumber {
        term: "K",
        text: k.to_string(),
    })?;
    let kb = crate::base::MPE_K_MM_PER_UM;
    if !kb.contains(k) {
        return Err(FormulaProblem::KOutside {
            k,
            lo: kb.lo,
            hi: kb.hi,
        });
    }
    Ok((a, k))
}

impl Mpe {
    /// Parses `formula`; `option` names the flag or key in the error.
    pub fn parse(formula: &str, option: &str) -> Result<Mpe, AcceptanceError> {
        let err = |problem: FormulaProblem| AcceptanceError::Formula {
            option: option.to_string(),
            formula: formula.to_string(),
            problem,
        };
        let s: String = formula.chars().filter(|c| !c.is_whitespace()).collect();
        if s.is_empty() {
            return Err(err(FormulaProblem::Empty));
        }
        let (a_um, k, b_um) = if let Some(inner) = s.strip_prefix("min(") {
            let inner = inner
                .strip_suffix(')')
                .ok_or_else(|| err(FormulaProblem::Unclosed))?;
            let (lin, b) = inner
                .split_once(',')
                .ok_or_else(|| err(FormulaProblem::MinArguments))?;
            let (a, k) = linear(lin).map_err(err)?;
            (Some(a), Some(k), Some(number(b, "B").map_err(err)?))
        } else if s.contains('L') {
            let (a, k) = linear(&s).map_err(err)?;
            (Some(a), Some(k), None)
        } else {
            (None, None, Some(number(&s, "B").map_err(err)?))
        };
        Ok(Mpe {
            formula: formula.trim().to_string(),
            a_um,
            k,
            b_um,
        })
    }

    /// Parses an MPE: as [`Mpe::parse`], and positive, a limit being a limit: B (when
    /// given) at least 10⁻³ µm (`base::TOLERANCE_UM`).
    pub fn parse_limit(formula: &str, option: &str) -> Result<Mpe, AcceptanceError> {
        let m = Mpe::parse(formula, option)?;
        if let Some(b) = m.b_um
            && b < crate::base::TOLERANCE_UM.lo
        {
            return Err(AcceptanceError::Formula {
                option: option.to_string(),
                formula: formula.to_string(),
                problem: FormulaProblem::BelowLeast {
                    b,
                    least: crate::base::TOLERANCE_UM.lo,
                },
            });
        }
        Ok(m)
    }

    /// A constant (the form `B`).
    pub fn constant(b_um: f64) -> Mpe {
        Mpe {
            formula: format!("{b_um}"),
            a_um: None,
            k: None,
            b_um: Some(b_um),
        }
    }

    /// The value at length `l_mm`, µm.
    pub fn at(&self, l_mm: f64) -> f64 {
        let lin = match (self.a_um, self.k) {
            (Some(a), Some(k)) => Some(a + l_mm / k),
            _ => None,
        };
        match (lin, self.b_um) {
            (Some(v), Some(b)) => v.min(b),
            (Some(v), None) => v,
            (None, Some(b)) => b,
            (None, None) => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_three_forms_and_their_values() {
        let m = Mpe::parse(" 1.5 + L / 333 ", "mpe").expect("parses");
        assert_eq!((m.a_um, m.k, m.b_um), (Some(1.5), Some(333.0), None));
        assert!((m.at(666.0) - 3.5).abs() < 1e-12);
        let m = Mpe::parse("min(2+L/100, 5)", "mpe").expect("parses");
        assert_eq!(m.at(100.0), 3.0);
        assert_eq!(m.at(1000.0), 5.0);
        let m = Mpe::parse("4", "mpe").expect("parses");
        assert_eq!(m.at(1e3), 4.0);
        for bad in [
            "",
            "A+L/K",
            "1.5+L/0",
            "1.5+L/-3",
            "1.5+x/3",
            "min(1+L/3)",
            "min(1+L/3,2",
            "1.5 µm",
            "nan",
            "inf",
            "-2",
            "1.5+L/3+1",
            "max(1+L/3,2)",
            "1,5+L/3",
            "2+L/1e-300",
            "1e308+L/333",
            "2e4",
            "min(2+L/333,1e5)",
        ] {
            assert!(Mpe::parse(bad, "mpe").is_err(), "{bad} parsed");
        }
    }
}
