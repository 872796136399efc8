//! The diagnosis' integration tests, one binary: synthetic effects recovered within their
//! σ, random campaigns, robustness, the committed concealed cases, and the speed check.

mod common;
mod concealed;
mod effects;
mod gaps;
mod perf;
mod random;
mod robust;
mod rotary;
mod untidy;
#[path = "../it/util.rs"]
mod util;
