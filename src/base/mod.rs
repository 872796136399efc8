//! Shared leaves used by every stage: the axis, the diagnosis vocabulary, small
//! statistics, the optimisers, physical constants and the shared shape of file and
//! configuration errors. Nothing here imports another module of the crate, so any stage
//! may import it; nothing does I/O but [`error::read_toml`], the one reader of TOML files.
//!
//! | module | holds |
//! |---|---|
//! | `axis` | the one [`Axis`] of the library (error-table columns, messages, indices) and the one [`Direction`] of approach |
//! | `stats` | rms, median, centred rms, peak-to-peak, the Gaussian generator |
//! | `vocabulary` | the diagnosis vocabulary: effect ids and parameter names, spelt once; the one [`Verdict`] |
//! | `effect` | the vocabulary's payload: one typed [`Effect`] per id, in the contract's JSON shape |
//! | `optim` | L-BFGS and golden-section minimisers |
//! | `consts` | physical constants used in more than one stage (the HeNe wavelength) |
//! | `limits` | the physical ranges every reader checks its numbers against |
//! | `setting` | [`Setting`] and [`NamesSettings`]: a stage's messages name its settings in its own words, a caller renders them in its own |
//! | `error` | [`FileError`] and [`ConfigError`] (file, [`Location`], message): the one shape of every stage's file and configuration errors |

mod axis;
mod consts;
mod effect;
mod error;
mod limits;
mod optim;
mod rotary;
mod setting;
mod stats;
mod vocabulary;

pub use axis::{Axis, Direction};
pub use consts::HENE_WAVELENGTH_UM;
pub use effect::{Drift, Effect, EffectParamError, ParamValue, Params, ParamsMap};
pub use error::{ConfigError, FileError, FileOp, Location, io_err, parse_error, read_toml};
pub use limits::{
    Allowed, Bound, ERROR_UM, FEED_MM_S, HUMIDITY_PCT, MPE_K_MM_PER_UM, NotAllowed, OutOfBound,
    POSITION_MM, PRESSURE_HPA, TEMPERATURE_C, TIME_S, TOLERANCE_UM, UNCERTAINTY_UM,
};
pub use optim::{golden, lbfgs};
pub use rotary::{ARCSEC_PER_DEG, ARCSEC_PER_URAD, ParseRotaryAxisError, RotaryAxis};
pub use setting::{NamesSettings, Setting};
pub use stats::{centred_rms, gaussian, median, peak_to_peak, rms};
pub use vocabulary::{EffectId, ParamName, UnknownEffect, Verdict};
