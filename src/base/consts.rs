//! Physical constants shared by the stages.

/// Vacuum wavelength of the iodine-stabilised-class HeNe laser used by the simulated
/// device and assumed by the diagnosis, micrometres (632.991 354 nm; the HELLO frame's
/// `laser_wavelength_fm` default and `drivers::edlen`'s reference case use the same value).
pub const HENE_WAVELENGTH_UM: f64 = 0.632_991_354;
