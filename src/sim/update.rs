//! Writing what a diagnosis found back into a machine model, so that `simulate`
//! reproduces the recording (`diagnose --model … --out DIR` writes `updated-model.toml`).

use crate::base::{Drift, Effect};

use super::physics::{
    Abbe, LatchDelay, MachineModel, PeriodicScale, Refraction, Reversal, Scale, ScaleFactor,
    ThermalDrift,
};

/// Adds the effects a diagnosis found to a model, so that `simulate` reproduces the
/// recording. Returns a note per effect (what was set, or why it could not be).
///
/// Every effect is matched by its typed parameters: nothing is read by name, so nothing
/// can go missing and become 0. A diagnosis measures against the model's own simulation,
/// so a scale factor, reversal, latch delay or dead path found is added to what the model
/// had; the other terms replace the model's (the diagnosis fits them whole). A refraction
/// coefficient the diagnosis did not determine keeps the model's value.
pub fn apply_found_effects(
    model: &mut MachineModel,
    effects: &[crate::diagnose::FoundEffect],
) -> Vec<String> {
    let mut notes = Vec::new();
    for found in effects {
        let id = found.id();
        match found.effect {
            Effect::ScaleThermalExpansion {
                alpha_ppm_per_k,
                x0_mm,
            } => set_scale(model, alpha_ppm_per_k, x0_mm),
            Effect::ScaleFactor { ppm } => add_scale_factor(model, ppm),
            Effect::Abbe {
                offset_axis,
                theta0_urad,
                theta1_urad_per_mm,
            } => {
                model.abbe = Some(Abbe {
                    enabled: true,
                    offset_axis,
                    theta0_urad,
                    theta1_urad_per_mm,
                });
            }
            Effect::Reversal { b_um, b1_um_per_m } => {
                add_reversal(model, b_um);
                if let Some(b1) = b1_um_per_m {
                    notes.push(format!(
                        "reversal: the model's backlash is one constant, so its change along the axis ({b1:.3} µm/m) is not written (b_um is its value at the middle of the travel)"
                    ));
                }
            }
            Effect::LatchDelay { tau_us } => add_latch_delay(model, tau_us),
            Effect::PeriodicScale {
                amplitude_um,
                period_um,
                phase_rad,
            } => {
                model.periodic_scale = Some(PeriodicScale {
                    enabled: true,
                    amplitude_um,
                    period_um,
                    phase_rad,
                });
            }
            Effect::ThermalDrift(drift) => model.thermal_drift = Some(drift_term(drift)),
            Effect::DeadPath { dead_path_mm } => model.laser.dead_path_mm += dead_path_mm,
            Effect::Refraction {
                ppm_per_k,
                ppm_per_hpa,
            } => set_refraction(model, ppm_per_k, ppm_per_hpa),
            Effect::Unexplained { .. } => {
                notes.push(format!("{id}: no model term for it; not added"));
                continue;
            }
        }
        notes.push(format!("{id}: added"));
    }
    notes
}

/// The scale's thermal expansion, replacing the model's (the diagnosis fits it whole).
fn set_scale(model: &mut MachineModel, alpha_ppm_per_k: f64, x0_mm: f64) {
    model.scale = Some(Scale {
        enabled: true,
        material: "from diagnosis".into(),
        cte_ppm_per_k: alpha_ppm_per_k,
        x0_mm,
    });
}

/// A scale factor found, added to the model's (found against the model's simulation).
fn add_scale_factor(model: &mut MachineModel, ppm: f64) {
    let old = model
        .scale_factor
        .as_ref()
        .filter(|s| s.enabled)
        .map_or(0.0, |s| s.ppm);
    model.scale_factor = Some(ScaleFactor {
        enabled: true,
        ppm: old + ppm,
    });
}

/// A reversal found, added to the model's backlash.
fn add_reversal(model: &mut MachineModel, b_um: f64) {
    let old = model
        .reversal
        .as_ref()
        .filter(|r| r.enabled)
        .map_or(0.0, |r| r.b_um);
    model.reversal = Some(Reversal {
        enabled: true,
        b_um: old + b_um,
    });
}

/// A latch delay found, added to the model's.
fn add_latch_delay(model: &mut MachineModel, tau_us: f64) {
    let old = model
        .latch_delay
        .as_ref()
        .filter(|l| l.enabled)
        .map_or(0.0, |l| l.tau_us);
    model.latch_delay = Some(LatchDelay {
        enabled: true,
        tau_us: old + tau_us,
    });
}

/// The model's thermal drift term for a drift found (exponential or linear).
fn drift_term(drift: Drift) -> ThermalDrift {
    match drift {
        Drift::Exponential {
            amplitude_um,
            tau_s,
        } => ThermalDrift {
            enabled: true,
            amplitude_um,
            tau_s: Some(tau_s),
            rate_um_per_s: 0.0,
        },
        Drift::Linear { rate_um_per_s } => ThermalDrift {
            enabled: true,
            amplitude_um: 0.0,
            tau_s: None,
            rate_um_per_s,
        },
    }
}

/// The refraction terms found; a coefficient the diagnosis did not determine keeps the
/// model's value.
fn set_refraction(model: &mut MachineModel, ppm_per_k: Option<f64>, ppm_per_hpa: Option<f64>) {
    let old = model.refraction.as_ref().filter(|r| r.enabled);
    model.refraction = Some(Refraction {
        enabled: true,
        ppm_per_k: ppm_per_k.or(old.map(|r| r.ppm_per_k)).unwrap_or(0.0),
        ppm_per_hpa: ppm_per_hpa.or(old.map(|r| r.ppm_per_hpa)).unwrap_or(0.0),
    });
}
