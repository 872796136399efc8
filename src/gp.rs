//! Gaussian-process (kriging) error model — being written.
