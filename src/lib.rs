//! errmap — measure and model the volumetric error of coordinate measuring machines.
//!
//! The library holds all the work; the `errmap` binary is argument parsing and glue.
//!
//! | module | does |
//! |---|---|
//! | [`table`] | error tables (CSV/Parquet via polars), validation, the rectilinear grid |
//! | [`interp`] | the interpolators: Lagrange m×n×q, trilinear, tricubic spline, fuzzy |
//! | [`cv`] | leave-one-plane-out cross-validation on the fitting table |
//! | [`compare`] | order/method comparison like the paper's Table 2, and its report |
//! | [`experiment`] | the seed-000 simulation (fuzzy vs trilinear vs spline on random errors) |
//! | [`plot`] | PNG/SVG figures with a bundled font |

pub mod compare;
pub mod cv;
pub mod experiment;
pub mod interp;
pub mod plot;
pub mod report;
pub mod table;

pub use errmap_drivers as drivers;
