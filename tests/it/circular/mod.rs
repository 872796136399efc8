//! The circular test (ballbar, ISO 230-4): reading, the ISO numbers, the diagnosis of
//! every effect (known answers in every plane), the random concealed-effect campaign,
//! the polar plot read back, the CLI.

mod bounds;
mod campaign;
mod cli;
mod effects;
mod io;
mod iso;
mod link;
mod plot;

use errmap::base::ParamName;
use errmap::circular::Slot;
use errmap::circular::{
    Backlash, CircularEffect, CyclicError, LateralPlay, ReversalSpike, ScaleMismatch,
    ServoMismatch, Squareness, Straightness,
};
use errmap::circular::{MachineModel, SimEffect};
use errmap::circular::{Plane, Sense, TestMeta};

/// A test setup: R = 50 mm, F = 2000 mm/min, 100 Hz, 360° with 45° overshoot.
pub(crate) fn meta(plane: Plane) -> TestMeta {
    TestMeta {
        plane,
        radius_mm: 50.0,
        feed_mm_per_min: 2000.0,
        arc_start_deg: 0.0,
        arc_deg: 360.0,
        overshoot_deg: 45.0,
        sample_rate_hz: Some(100.0),
        centre_mm: None,
        instrument: None,
        serial: None,
        date: None,
        operator: None,
        note: None,
    }
}

pub(crate) fn model(
    plane: Plane,
    effects: &[(CircularEffect, Slot)],
    noise_um: f64,
    seed: u64,
) -> MachineModel {
    MachineModel {
        meta: meta(plane),
        directions: vec![Sense::Ccw, Sense::Cw],
        centre_offset_um: [4.0, -3.0],
        bar_error_um: 1.5,
        noise_um,
        seed,
        effects: effects
            .iter()
            .map(|&(effect, slot)| SimEffect { effect, slot })
            .collect(),
    }
}

/// The parameter of an effect the tests check, with a name.
pub(crate) fn main_param(e: &CircularEffect) -> (ParamName, f64) {
    match *e {
        CircularEffect::Backlash(Backlash { b_um }) => (ParamName::BUm, b_um),
        CircularEffect::ReversalSpike(ReversalSpike { h_um, .. }) => (ParamName::HUm, h_um),
        CircularEffect::LateralPlay(LateralPlay { p_um }) => (ParamName::PUm, p_um),
        CircularEffect::CyclicError(CyclicError { amplitude_um, .. }) => {
            (ParamName::AmplitudeUm, amplitude_um)
        }
        CircularEffect::Straightness(Straightness { bow_um }) => (ParamName::BowUm, bow_um),
        CircularEffect::ServoMismatch(ServoMismatch { dt_ms }) => (ParamName::DtMs, dt_ms),
        CircularEffect::ScaleMismatch(ScaleMismatch { ppm }) => (ParamName::Ppm, ppm),
        CircularEffect::Squareness(Squareness { urad }) => (ParamName::Urad, urad),
    }
}
