//! Writing what a diagnosis found back into a machine model, so that `simulate`
//! reproduces the recording (`diagnose --model … --out DIR` writes `updated-model.toml`).

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
        let num = |k: &str| e.params.get(k).and_then(serde_json::Value::as_f64);
        let need = |k: &str| num(k).unwrap_or(0.0);
        match e.id.as_str() {
            "scale_thermal_expansion" => {
                model.scale = Some(Scale {
                    enabled: true,
                    material: "from diagnosis".into(),
                    cte_ppm_per_k: need("alpha_ppm_per_k"),
                    x0_mm: need("x0_mm"),
                });
            }
            "scale_factor" => {
                let old = model
                    .scale_factor
                    .as_ref()
                    .filter(|s| s.enabled)
                    .map_or(0.0, |s| s.ppm);
                model.scale_factor = Some(ScaleFactor {
                    enabled: true,
                    ppm: old + need("ppm"),
                });
            }
            "abbe" => {
                let axis = e
                    .params
                    .get("offset_axis")
                    .and_then(serde_json::Value::as_str)
                    .unwrap_or("z")
                    .to_string();
                model.abbe = Some(Abbe {
                    enabled: true,
                    offset_axis: axis,
                    theta0_urad: need("theta0_urad"),
                    theta1_urad_per_mm: need("theta1_urad_per_mm"),
                });
            }
            "reversal" => {
                let old = model
                    .reversal
                    .as_ref()
                    .filter(|r| r.enabled)
                    .map_or(0.0, |r| r.b_um);
                model.reversal = Some(Reversal {
                    enabled: true,
                    b_um: old + need("b_um"),
                });
            }
            "latch_delay" => {
                let old = model
                    .latch_delay
                    .as_ref()
                    .filter(|l| l.enabled)
                    .map_or(0.0, |l| l.tau_us);
                model.latch_delay = Some(LatchDelay {
                    enabled: true,
                    tau_us: old + need("tau_us"),
                });
            }
            "periodic_scale" => {
                model.periodic_scale = Some(PeriodicScale {
                    enabled: true,
                    amplitude_um: need("amplitude_um"),
                    period_um: need("period_um"),
                    phase_rad: need("phase_rad"),
                });
            }
            "thermal_drift" => {
                model.thermal_drift = Some(ThermalDrift {
                    enabled: true,
                    amplitude_um: need("amplitude_um"),
                    tau_s: num("tau_s"),
                    rate_um_per_s: need("rate_um_per_s"),
                });
            }
            "dead_path" => model.laser.dead_path_mm += need("dead_path_mm"),
            "refraction" => {
                model.refraction = Some(Refraction {
                    enabled: true,
                    ppm_per_k: need("ppm_per_k"),
                    ppm_per_hpa: need("ppm_per_hpa"),
                });
            }
            other => {
                notes.push(format!("{other}: no model term for it; not added"));
                continue;
            }
        }
        notes.push(format!("{}: added", e.id));
    }
    notes
}
