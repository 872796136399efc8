//! Shared leaves used by every stage: the axis, the diagnosis vocabulary, small
//! statistics, the optimisers and physical constants. Nothing here does I/O and nothing
//! here imports another module of the crate, so any stage may import it.
//!
//! | module | holds |
//! |---|---|
//! | [`axis`] | the one [`Axis`] of the library (error-table columns, messages, indices) and the one [`Direction`] of approach |
//! | [`stats`] | rms, median, centred rms, peak-to-peak, the Gaussian generator |
//! | [`vocabulary`] | the diagnosis vocabulary: effect ids and parameter names, spelt once; the one [`Verdict`] |
//! | [`effect`] | the vocabulary's payload: one typed [`Effect`] per id, in the contract's JSON shape |
//! | [`optim`] | L-BFGS and golden-section minimisers |
//! | [`consts`] | physical constants used in more than one stage (the HeNe wavelength) |
//! | [`limits`] | the physical ranges every reader checks its numbers against |

pub mod axis;
pub mod consts;
pub mod effect;
pub mod limits;
pub mod optim;
pub mod stats;
pub mod vocabulary;

pub use axis::{Axis, Direction};
pub use effect::{Drift, Effect, ParamValue};
pub use vocabulary::{EffectId, ParamName, Verdict};
