//! errmap — measure and model the volumetric error of coordinate measuring machines.
//!
//! The library holds all the work; the `errmap` binary (`src/cli/`) turns arguments into
//! library types once and calls it. The modules, in pipeline order:
//!
//! | module | stage | does |
//! |---|---|---|
//! | [`acquire`] | 1 acquisition | capture and replay into a session directory (raw bytes first) |
//! | [`session`] | 2 session | session tables, their reduction to error tables, ISO 230-2 / VDI 3441 statistics |
//! | [`table`] | 3 error table | error tables (CSV/Parquet via polars), cell validation, the grid |
//! | [`interp`] | 4 models | Lagrange m×n×q, trilinear, tricubic spline, fuzzy, Gaussian process; the method registry |
//! | [`evaluate`] | 5 evaluation | cross-validation, the order/method comparison, the fuzzy-interpolation paper's experiment |
//! | [`report`] | 6 report | words, tables and figures on disk for every stage |
//! | [`diagnose`] | 7 diagnosis | what a simulation left out of a recording: locate, name, fit |
//! | [`export`] | 8 export | compensation tables for controllers, CSV lines, volumetric grids |
//! | [`sim`] | simulator | the machine model and plans, the other side of the diagnosis |
//! | [`volumetric`] | 9 volumetric | the 21 geometric errors from laser line measurements: model, line tables (simulated or from captured sessions), identification, identifiability, the campaign's own faults (scale expansion, drift, a bad line), prediction |
//! | [`base`] | shared leaf | the one `Axis`, the diagnosis vocabulary, statistics, optimisers, constants |
//! | [`plot`] | shared leaf | PNG/SVG charts with a bundled font |
//! | [`bench`](mod@bench) | — | throughput of the models and the decoder (`errmap bench`, `cargo bench`) |
//! | [`drivers`] | leaf crate | `errmap-drivers`: wire protocol, decoder, capture loop, simulated board |
//!
//! Imports run one way: `base` and `plot` import nothing of the crate, each stage imports
//! only the stages it builds on, and nothing in the library imports [`report`]. The rule
//! is written out in `CONTRIBUTING.md` and checked by the test `tests/it/layers.rs`.
//!
//! # Example
//!
//! Fit a tricubic spline to a small error table and predict the error at a point:
//!
//! ```
//! use errmap::interp::{Interpolator, Method};
//! use errmap::table::{ErrorPoint, ErrorTable};
//!
//! // A 3×3×3 grid whose error grows along x: e = 0.01·x µm.
//! let mut points = Vec::new();
//! for x in [0.0, 100.0, 200.0] {
//!     for y in [0.0, 50.0, 100.0] {
//!         for z in [0.0, 50.0, 100.0] {
//!             points.push(ErrorPoint::new(x, y, z, 0.01 * x));
//!         }
//!     }
//! }
//! let grid = ErrorTable::from_points("doc example", points).grid()?;
//! let model = Method::Spline.fit(&grid)?;
//! let e_um = model.predict([150.0, 25.0, 75.0]);
//! assert!((e_um - 1.5).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod acquire;
pub mod base;
pub mod bench;
pub mod diagnose;
pub mod evaluate;
pub mod export;
pub mod interp;
pub mod plot;
pub mod report;
pub mod session;
pub mod sim;
pub mod table;
pub mod volumetric;

pub use errmap_drivers as drivers;
