//! errmap — measure and model the volumetric error of coordinate measuring machines.
//!
//! The library holds all the work; the `errmap` binary is argument parsing and glue.
//!
//! | module | does |
//! |---|---|
//! | [`acquire`] | capture, replay and the simulated device (CLI glue over `errmap-drivers`) |
//! | [`session`] | session tables (one row per sample) and their reduction to error tables |
//! | [`table`] | error tables (CSV/Parquet via polars), validation, the rectilinear grid |
//! | [`interp`] | the interpolators: Lagrange m×n×q, trilinear, tricubic spline, fuzzy |
//! | [`concealed`] | the concealed-effect recorded/simulated cases of `datasets/concealed/` |
//! | [`cv`] | leave-one-plane-out cross-validation on the fitting table |
//! | [`bench`] | throughput of the interpolators and the decoder (`errmap bench`, `cargo bench`) |
//! | [`compare`] | order/method comparison like the paper's Table 2, and its report |
//! | [`diagnose`] | missing-physics diagnosis: locate, name and fit what a simulation left out of a recording |
//! | [`experiment`] | the seed-000 simulation (fuzzy vs trilinear vs spline on random errors) |
//! | [`export`] | compensation tables for LinuxCNC and Siemens 840D, CSV lines and volumetric grids |
//! | [`gp`] | Gaussian-process (kriging) error model with prediction uncertainty |
//! | [`iso230`] | ISO 230-2 / VDI/DGQ 3441 positioning statistics for one axis |
//! | [`physics`] | the machine model (TOML) and the physics simulator behind `simulate`, `serve-sim` and the demo |
//! | [`plot`] | PNG/SVG figures with a bundled font |

pub mod acquire;
pub mod bench;
pub mod compare;
pub mod concealed;
pub mod cv;
pub mod diagnose;
pub mod experiment;
pub mod export;
pub use interp::gp;
pub mod interp;
pub mod iso230;
pub mod physics;
pub mod plot;
pub mod report;
pub mod session;
pub mod table;

pub use errmap_drivers as drivers;
