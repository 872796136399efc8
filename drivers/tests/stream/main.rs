//! Stream tests of the wire-protocol decoder, compiled into one test binary.
//! Regression tests are named after the problem they pin.

#![allow(clippy::unwrap_used)]

mod common;
mod corruption;
mod implausible;
mod properties;
mod quadrature;
mod session;
mod transport;
