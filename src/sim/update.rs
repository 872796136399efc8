//! Writing what a diagnosis found back into a machine model, so that `simulate`
//! reproduces the recording (`diagnose --model … --out DIR` writes `updated-model.toml`).

use crate::base::Axis;
use crate::base::vocabulary::{EffectId, ParamName as P};

use super::physics::{
    Abbe, LatchDelay, MachineModel, PeriodicScale, Refraction, Reversal, Scale, ScaleFactor,
    ThermalDrift,
};

/// Adds the effects a diagnosis found to a model, so that `simulate` reproduces the
/// recording. Returns a note per effect (what was set, or why it could not be).
pub fn apply_found_effects(
    model: &mut MachineModel,
    effects: &[crate::diagnose::FoundEffect],
) -> Vec<String> {
    let mut notes = Vec::new();
    for e in effects {
        let num = |k: P| e.params.get(k.as_str()).and_then(serde_json::Value::as_f64);
        let need = |k: P| num(k).unwrap_or(0.0);
        match e.id {
            EffectId::ScaleThermalExpansion => {
                model.scale = Some(Scale {
                    enabled: true,
                    material: "from diagnosis".into(),
                    cte_ppm_per_k: need(P::AlphaPpmPerK),
                    x0_mm: need(P::X0Mm),
                });
            }
            EffectId::ScaleFactor => {
                let old = model
                    .scale_factor
                    .as_ref()
                    .filter(|s| s.enabled)
                    .map_or(0.0, |s| s.ppm);
                model.scale_factor = Some(ScaleFactor {
                    enabled: true,
                    ppm: old + need(P::Ppm),
                });
            }
            EffectId::Abbe => {
                // The diagnosis writes the offset axis as text ("y" or "z").
                let axis = e
                    .params
                    .get(P::OffsetAxis.as_str())
                    .and_then(serde_json::Value::as_str)
                    .and_then(|a| a.parse::<Axis>().ok())
                    .unwrap_or(Axis::Z);
                model.abbe = Some(Abbe {
                    enabled: true,
                    offset_axis: axis,
                    theta0_urad: need(P::Theta0Urad),
                    theta1_urad_per_mm: need(P::Theta1UradPerMm),
                });
            }
            EffectId::Reversal => {
                let old = model
                    .reversal
                    .as_ref()
                    .filter(|r| r.enabled)
                    .map_or(0.0, |r| r.b_um);
                model.reversal = Some(Reversal {
                    enabled: true,
                    b_um: old + need(P::BUm),
                });
                if let Some(b1) = num(P::B1UmPerM) {
                    notes.push(format!(
                        "reversal: the model's backlash is one constant, so its change along the axis ({b1:.3} µm/m) is not written (b_um is its value at the middle of the travel)"
                    ));
                }
            }
            EffectId::LatchDelay => {
                let old = model
                    .latch_delay
                    .as_ref()
                    .filter(|l| l.enabled)
                    .map_or(0.0, |l| l.tau_us);
                model.latch_delay = Some(LatchDelay {
                    enabled: true,
                    tau_us: old + need(P::TauUs),
                });
            }
            EffectId::PeriodicScale => {
                model.periodic_scale = Some(PeriodicScale {
                    enabled: true,
                    amplitude_um: need(P::AmplitudeUm),
                    period_um: need(P::PeriodUm),
                    phase_rad: need(P::PhaseRad),
                });
            }
            EffectId::ThermalDrift => {
                model.thermal_drift = Some(ThermalDrift {
                    enabled: true,
                    amplitude_um: need(P::AmplitudeUm),
                    tau_s: num(P::TauS),
                    rate_um_per_s: need(P::RateUmPerS),
                });
            }
            EffectId::DeadPath => model.laser.dead_path_mm += need(P::DeadPathMm),
            EffectId::Refraction => {
                model.refraction = Some(Refraction {
                    enabled: true,
                    ppm_per_k: need(P::PpmPerK),
                    ppm_per_hpa: need(P::PpmPerHpa),
                });
            }
            EffectId::Unexplained => {
                notes.push(format!("{}: no model term for it; not added", e.id));
                continue;
            }
        }
        notes.push(format!("{}: added", e.id));
    }
    notes
}
