//! Decisions of conformity, and the CMM length-measurement test of ISO 10360-2, measured
//! and predicted (issue 25).
//!
//! | module | does | cost |
//! |---|---|---|
//! | `rule` | the decision rules: ISO 14253-1:2017 default rule, ILAC-G8:09/2019 simple acceptance and binary guard band; one-sided zones; aggregation; the rule in words | O(1) per result |
//! | `decide` | `acceptance decide`: a CSV of results judged one by one | O(rows) |
//! | `mpe` | the MPE formula `A+L/K`, `min(A+L/K,B)`, `B` | O(1) |
//! | `tolerance` | tolerances on ISO 230-2 results (TOML) and the per-line judgement | O(lines · 12) |
//! | `iso10360` | ISO 10360-2:2009 from a measured file: E0, R0, MPE(L), verdicts, deviations from the 7 × 5 × 3 design | O(rows log rows) |
//! | [`probing`] | ISO 10360-5:2010's probing test from a measured file: the least-squares sphere, form, size, multi-stylus location, verdicts; and a simulator of the test | O(points) |
//! | `cmm` | the CMM verification certificate's document: ISO 10360-2 and 10360-5 joined under one rule | O(1) |
//! | `predicted` | the same test predicted from an identified volumetric model (a virtual CMM), before and after compensation | O(gauges · params²) |
//!
//! # The rules
//!
//! A result y with expanded uncertainty U is judged against a zone [T_L, T_U] whose limits
//! may be absent (that side unbounded). A guard band w moves each present limit inward:
//! acceptance zone [T_L + w, T_U − w], limits included. ISO 14253-1:2017's default rule
//! takes w = U and says `fail` only outside [T_L − U, T_U + U], `indeterminate` between;
//! ILAC-G8 simple acceptance takes w = 0, its binary guard-band rule w = r·U; both say
//! `pass` or `fail`. Several verdicts aggregate to the worst (`fail` > `indeterminate` >
//! `pass`).
//!
//! # Sources
//!
//! ISO 14253-1:2017, *Geometrical product specifications (GPS) — Inspection by
//! measurement of workpieces and measuring equipment — Part 1: Decision rules for
//! verifying conformity or nonconformity with specifications*; ILAC-G8:09/2019,
//! *Guidelines on Decision Rules and Statements of Conformity* (4.2.1 simple acceptance,
//! 4.2.2 binary statement with guard band); ISO/IEC 17025:2017 7.8.6 (the statement of
//! conformity names the rule); ISO 10360-2:2009, *Acceptance and reverification tests for
//! coordinate measuring machines (CMM) — Part 2: CMMs used for measuring linear
//! dimensions*. The standards' own texts were not at hand: `docs/acceptance.md` says
//! which clauses were read from secondary sources and what was assumed.

mod cmm;
mod decide;
mod error;
mod iso10360;
mod mpe;
mod predicted;
pub mod probing;
mod rule;
mod tolerance;

pub use cmm::CmmCertificate;
pub use decide::{DecideReport, DecidedResult, decide_file};
pub use error::{AcceptanceError, ProbingSetting, SettingProblem};
pub use iso10360::{
    Counts, Gauge, Measurement, Position, Summary, TestConfig, TestResult, evaluate_file,
};
pub use mpe::{FormulaProblem, Mpe};
pub use predicted::{
    Compensated, Model as VirtualModel, Placement, PlannedPosition,
    TABLE_POINTS as VIRTUAL_TABLE_POINTS, VirtualConfig, VirtualMeasurement, VirtualPlan,
    VirtualPosition, VirtualTest, default_lines, predict,
};
pub use rule::{
    ConformityVerdict, Decision, DecisionRule, Limits, LimitsError, Rule, UnknownRule, aggregate,
};
pub use tolerance::{Conformity, LineConformity, ParameterVerdict, Tolerances};
