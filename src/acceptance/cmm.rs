//! The CMM verification certificate's document: the ISO 10360-2 length test and the
//! ISO 10360-5 probing test, evaluated under one decision rule and joined with a
//! statement of conformity (ISO/IEC 17025:2017 7.8.6.2). The PDF is
//! `report::certificate::write_cmm`'s; this is what it shows and what `--json` prints.

use serde::Serialize;

use super::iso10360::TestResult;
use super::probing::ProbingResult;
use super::rule::{ConformityVerdict, DecisionRule, Rule};

/// `acceptance cmm-certificate --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CmmCertificate {
    pub cmm: Option<String>,
    pub specification: String,
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub statement: String,
    pub iso10360_2: TestResult,
    pub iso10360_5: ProbingResult,
    /// The worse of the two parts.
    pub verdict: ConformityVerdict,
}

/// Whether the length test had any U above 0.
fn length_u_given(t: &TestResult) -> bool {
    t.measurements.iter().any(|m| m.u_um > 0.0)
}

impl CmmCertificate {
    /// Joins two results judged with `rule`.
    pub fn new(
        cmm: Option<String>,
        specification: String,
        rule: &DecisionRule,
        length: TestResult,
        probing: ProbingResult,
    ) -> CmmCertificate {
        let (u2, u5) = (length_u_given(&length), probing.u_given());
        let mut statement = rule.statement(u2 || u5, Some(2.0));
        if u2 != u5 && rule.rule != Rule::Simple {
            statement.push_str(if u2 {
                " The ISO 10360-5 part had no uncertainty (U = 0): it was judged as by simple \
                 acceptance."
            } else {
                " The ISO 10360-2 part had no uncertainty (U = 0): it was judged as by simple \
                 acceptance."
            });
        }
        statement.push_str(&format!(
            " It applies to the results of ISO 10360-2:2009 (each E0 against ±MPE_E0(L) = ±({}) \
             µm{}) and of ISO 10360-5:2010 (form, size{} of the probing test), and the \
             overall verdict is the worse of the two parts'.",
            length.mpe.formula,
            length
                .mpl_r0_um
                .map(|m| format!(", each R0 against MPL_R0 = {m} µm"))
                .unwrap_or_default(),
            if probing
                .location
                .as_ref()
                .is_some_and(|l| l.verdict.is_some())
            {
                ", location"
            } else {
                ""
            }
        ));
        let verdict = length.verdict.max(probing.verdict);
        CmmCertificate {
            cmm,
            specification,
            rule: rule.rule.name(),
            guard_fraction: rule.fraction_shown(),
            statement,
            iso10360_2: length,
            iso10360_5: probing,
            verdict,
        }
    }
}
