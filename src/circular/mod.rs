//! The circular test (telescoping ballbar, ISO 230-4): reading a test, the standard's
//! numbers, the machine errors behind the trace, and a simulator of such tests.
//!
//! | file | holds |
//! |---|---|
//! | [`input`] | the trace (CSV/Parquet through `table`) and its TOML, validated once |
//! | [`iso`] | least-squares circles and G, G(b), H, D, F (ISO 230-4) |
//! | [`effects`] | the circular vocabulary: one file per effect (its signature, its simulated term, its bounds, its words) |
//! | [`signature`] | the samples as the signatures see them, the setup terms, dr(θ) of an effect |
//! | [`diagnose`] | the joint linear fit, significance, identifiability, the result |
//! | `fit` | the least-squares fits on subsets of one set of columns, its products computed once |
//! | [`simulate`] | a machine model (TOML) → a trace and its TOML, from the physics |
//! | [`link`] | the circle an identified volumetric model implies, compared |
//!
//! The format, the quantities, the signatures with their sign conventions and what the
//! test cannot separate are documented in `docs/circular-test.md`. The figures and the
//! Markdown report are in `report::circular`.

pub mod diagnose;
pub mod effects;
mod error;
mod fit;
pub mod input;
pub mod iso;
pub mod link;
pub mod signature;
pub mod simulate;

pub use diagnose::{CircularDiagnosis, CircularFinding, DiagnoseConfig, diagnose};
pub use effects::{CircularEffect, CircularId};
pub use error::CircularError;
pub use input::{CircularTest, MAX_SAMPLES, Plane, Run, Sense, TestMeta, read_test};
pub use iso::{Iso230_4, evaluate};
