//! scratch
#[test]
fn scratch() {
    use errmap::base::Effect;
    use errmap::circular::signature::Slot;
    use errmap::circular::*;
    let test = errmap::circular::simulate::simulate(&super::model(
        Plane::XY,
        &[(Effect::Straightness { bow_um: -3.0 }, Slot::A)],
        0.1,
        14,
    ));
    let d = diagnose(&test, &DiagnoseConfig::default());
    eprintln!("sigma {} n {} rms_after {} before {}", d.sigma_um, d.samples_fitted, d.rms_after_um, d.rms_before_um);
    for e in &d.effects {
        eprintln!("{:?} {:?} dchi2 {} explains {}", e.effect, e.axis.slot, e.delta_chi2, e.explains_um);
    }
}
