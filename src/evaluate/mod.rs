//! Numbers about models: cross-validation on the fitting table, the order/method
//! comparison, and the fuzzy-interpolation paper's experiment. No prose and no files here; the words and
//! figures are in the `report` stage.
//!
//! | module | computes |
//! |---|---|
//! | `cv` | leave-one-plane-out (grids) and leave-one-out (GP) cross-validation |
//! | `compare` | the comparison like the paper's Table 2, the recommendation, sampling advice |
//! | `experiment` | the fuzzy-interpolation paper's simulation (Agbegha, Guo and Bai 2011: fuzzy vs trilinear vs spline on random errors) |

mod compare;
mod cv;
mod experiment;

pub use compare::{
    AUTO_ORDER_MAX_NODES, Comparison, DEFAULT_MAX_DEGREE, Extent, Refusals, SamplingAdvice,
    SigmaKind, auto_order, compare, compare_scattered, compare_where_possible,
};
pub use cv::{CvScheme, leave_one_plane_out};
pub use experiment::{FuzzySimConfig, FuzzySimResult, MethodStats, run as run_fuzzy_sim};
