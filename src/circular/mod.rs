//! The circular test (telescoping ballbar, ISO 230-4): reading a test, the standard's
//! numbers, the machine errors behind the trace, and a simulator of such tests.
//!
//! | file | holds |
//! |---|---|
//! | `input` | the trace (CSV/Parquet through `table`) and its TOML, validated once |
//! | `iso` | least-squares circles and G, G(b), H, D, F (ISO 230-4) |
//! | `effects` | the circular vocabulary: one file per effect (its signature, its simulated term, its bounds, its words) |
//! | `signature` | the samples as the signatures see them, the setup terms, dr(θ) of an effect |
//! | `diagnose` | the joint linear fit, significance, identifiability, the result |
//! | `fit` | the least-squares fits on subsets of one set of columns, its products computed once |
//! | `simulate` | a machine model (TOML) → a trace and its TOML, from the physics |
//! | `link` | the circle an identified volumetric model implies, compared |
//!
//! The format, the quantities, the signatures with their sign conventions and what the
//! test cannot separate are documented in `docs/circular-test.md`. The figures and the
//! Markdown report are in `report::circular`.

mod diagnose;
mod effects;
mod error;
mod fit;
mod input;
mod iso;
mod link;
mod signature;
mod simulate;

pub use diagnose::{
    CircularDiagnosis, CircularFinding, DiagnoseConfig, Setup, Unidentifiable, diagnose,
};
pub use effects::{
    Backlash, CircularEffect, CircularId, CyclicError, Family, LateralPlay, MAX_TERM_UM,
    ReversalSpike, ScaleMismatch, ServoMismatch, Squareness, Straightness, Term,
    UnknownCircularEffect,
};
pub use error::CircularError;
pub use input::{CircularTest, MAX_SAMPLES, Plane, Run, Sense, TestMeta, meta_path, read_test};
pub use iso::{Iso230_4, Lsc, evaluate, nominal_samples};
pub use link::{Link, LinkProblem, LinkRow, link};
pub use signature::{Geometry, Slot, dr_um, points as signature_points};
pub use simulate::{MachineModel, SimEffect, SimSetup, simulate, write_test};
