//! Numbers about models: cross-validation on the fitting table, the order/method
//! comparison, and the fuzzy-interpolation paper's experiment. No prose and no files here; the words and
//! figures are in the `report` stage.
//!
//! | module | computes |
//! |---|---|
//! | [`cv`] | leave-one-plane-out (grids) and leave-one-out (GP) cross-validation |
//! | [`compare`] | the comparison like the paper's Table 2, the recommendation, sampling advice |
//! | [`experiment`] | the fuzzy-interpolation paper's simulation (Agbegha, Guo and Bai 2011: fuzzy vs trilinear vs spline on random errors) |

pub mod compare;
pub mod cv;
pub mod experiment;
