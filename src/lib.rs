//! errmap — measure and model the volumetric error of coordinate measuring machines.
//!
//! The library holds all the work; the `errmap` binary turns arguments into library
//! types once and calls it. Modules are listed in pipeline order; each imports only the
//! modules above it in this table (`base`, `plot` and `errmap-drivers` import nothing of
//! the crate; nothing but `report`, `bench` and the binary imports `report`). The rule is
//! checked in CI by `tests/it/layers.rs`.
//!
//! | module | stage | does |
//! |---|---|---|
//! | [`base`] | leaf | the one `Axis`, small statistics, constants |
//! | [`plot`] | leaf | PNG/SVG charts with a bundled font |
//! | [`drivers`] | leaf | the wire protocol, decoder, capture loop and simulated board (`errmap-drivers`) |
//! | [`table`] | 3 | error tables (CSV/Parquet via polars), validation, the rectilinear grid |
//! | [`interp`] | 4 | the models: Lagrange m×n×q, trilinear, tricubic spline, fuzzy, Gaussian process |
//! | [`evaluate`] | 5 | cross-validation, the order/method comparison, the seed-000 experiment |
//! | [`export`] | 8 | compensation tables for controllers, CSV lines, volumetric grids |
//! | [`session`] | 2 | session tables (one row per sample), their reduction to error tables, ISO 230-2 |
//! | [`acquire`] | 1 | capture and replay into a session directory |
//! | [`diagnose`] | 7 | what a simulation left out of a recording: locate, name, fit |
//! | [`sim`] | — | the machine model and simulator (the other side of the diagnosis) |
//! | [`volumetric`] | — | the 21 geometric errors from laser lines: model, identification, prediction |
//! | [`report`] | 6 | words, tables and figures on disk for every stage |
//! | [`bench`] | — | throughput of the models and the decoder (`errmap bench`, `cargo bench`) |
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

pub mod base;
pub mod plot;

pub mod table;

pub mod interp;

pub mod evaluate;

pub mod export;

pub mod session;

pub mod acquire;

pub mod diagnose;

pub mod sim;

pub mod volumetric;

pub mod report;

pub mod bench;

pub use errmap_drivers as drivers;

// Transitional paths from the flat layout, kept so that older callers compile.
pub use evaluate::{compare, cv, experiment};
pub use interp::gp;
pub use session::iso230;
pub use sim::{concealed, physics};
