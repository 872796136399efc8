//! Numbers about models: cross-validation on the fitting table, the order/method
//! comparison, and the seed-000 experiment. No prose and no files here; the words and
//! figures are in the `report` stage.
//!
//! | module | computes |
//! |---|---|
//! | [`cv`] | leave-one-plane-out (grids) and leave-one-out (GP) cross-validation |
//! | [`compare`] | the comparison like the paper's Table 2, the recommendation, sampling advice |
//! | [`experiment`] | seed 000's simulation (fuzzy vs trilinear vs spline on random errors) |

pub mod compare;
pub mod cv;
pub mod experiment;
