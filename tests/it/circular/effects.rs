//! Known answers per effect: the simulator's physics (which does not use the fitted
//! signatures) against the signature and its sign convention, and the diagnosis finding
//! each effect alone, on each axis, in each plane, with its parameter inside its σ.

use errmap::base::Verdict;
use errmap::circular::simulate;
use errmap::circular::{
    Backlash, CircularEffect, CyclicError, LateralPlay, ReversalSpike, ScaleMismatch,
    ServoMismatch, Squareness, Straightness,
};
use errmap::circular::{DiagnoseConfig, Plane, diagnose};
use errmap::circular::{Geometry, Slot, dr_um, signature_points as points};

use super::{main_param, model};

/// One example of every effect, on each slot it may take.
pub(super) fn every_effect() -> Vec<(CircularEffect, Slot)> {
    let mut out = Vec::new();
    for slot in [Slot::A, Slot::B] {
        out.push((CircularEffect::Backlash(Backlash { b_um: 6.0 }), slot));
        out.push((
            CircularEffect::ReversalSpike(ReversalSpike {
                h_um: 5.0,
                tau_ms: 60.0,
            }),
            slot,
        ));
        out.push((
            CircularEffect::LateralPlay(LateralPlay { p_um: -4.0 }),
            slot,
        ));
        out.push((
            CircularEffect::CyclicError(CyclicError {
                amplitude_um: 1.5,
                period_mm: 5.0,
                phase_rad: 0.7,
            }),
            slot,
        ));
        out.push((
            CircularEffect::Straightness(Straightness { bow_um: -3.0 }),
            slot,
        ));
    }
    out.push((
        CircularEffect::ServoMismatch(ServoMismatch { dt_ms: 0.4 }),
        Slot::Plane,
    ));
    out.push((
        CircularEffect::ScaleMismatch(ScaleMismatch { ppm: 40.0 }),
        Slot::Plane,
    ));
    out.push((
        CircularEffect::Squareness(Squareness { urad: -60.0 }),
        Slot::Plane,
    ));
    out
}

/// The simulator's noise-free trace minus its setup-only trace equals the signature to
/// first order, in both directions: this pins each signature's sign convention to the
/// physics (e = −(b/2)·sgn v for backlash, e_A = α·q_B for squareness, ...).
#[test]
fn each_signature_is_the_physics_of_its_effect_with_its_sign() {
    for plane in Plane::ALL {
        for (effect, slot) in every_effect() {
            let with = simulate(&model(plane, &[(effect, slot)], 0.0, 1))
                .expect("a test within the bounds");
            let without = simulate(&model(plane, &[], 0.0, 1)).expect("a test within the bounds");
            let g = Geometry::of(&with.meta);
            for (run, base) in with.runs.iter().zip(&without.runs) {
                let pts = points(run, &with.meta);
                let mut worst: f64 = 0.0;
                for (i, p) in pts.iter().enumerate() {
                    // Within a sample of a reversal the instantaneous switch is ambiguous.
                    let near = |off: f64| {
                        let d = (p.theta - off).rem_euclid(std::f64::consts::PI);
                        d.min(std::f64::consts::PI - d) < 0.01
                    };
                    if near(0.0) || near(std::f64::consts::FRAC_PI_2) {
                        continue;
                    }
                    // The spike's physics starts at the run's first reversal.
                    if matches!(effect, CircularEffect::ReversalSpike(_))
                        && run.angle_deg[i].abs() > 360.0
                    {
                        continue;
                    }
                    let sim = run.dr_um[i] - base.dr_um[i];
                    let sig = dr_um(&effect, slot, p, &g);
                    worst = worst.max((sim - sig).abs());
                }
                assert!(
                    worst < 0.02,
                    "{plane:?} {:?} {slot:?} {:?}: physics and signature differ by {worst} µm",
                    effect.id(),
                    run.sense
                );
            }
        }
    }
}

/// Each effect alone is found, once, on its own axis, with its sign, within 4σ, and
/// nothing else is reported.
#[test]
fn each_effect_alone_is_found_on_its_axis_in_every_plane() {
    for plane in Plane::ALL {
        for (k, (effect, slot)) in every_effect().into_iter().enumerate() {
            let test = simulate(&model(plane, &[(effect, slot)], 0.1, 10 + k as u64))
                .expect("a test within the bounds");
            let d = diagnose(&test, &DiagnoseConfig::default());
            let label = slot.label(plane);
            assert_eq!(d.verdict, Verdict::MissingPhysics);
            assert_eq!(
                d.effects.len(),
                1,
                "{plane:?} {} {label}: found {:?}",
                effect.id(),
                d.effects
                    .iter()
                    .map(|e| (e.effect, e.axis.slot.label(plane)))
                    .collect::<Vec<_>>()
            );
            let found = &d.effects[0];
            assert_eq!(found.effect.id(), effect.id());
            assert_eq!(found.axis.slot.label(plane), label);
            let (name, truth) = main_param(&effect);
            let got = found.effect.number(name).expect("test set-up");
            let sigma = found.sigma(name).expect("test set-up");
            assert!(
                (got - truth).abs() < 4.0 * sigma + 0.02 * truth.abs(),
                "{plane:?} {} {label}: {name} = {got} ± {sigma}, truth {truth}: {:?}",
                effect.id(),
                found.effect
            );
            assert!(
                sigma > 0.0 && sigma < 0.2 * truth.abs(),
                "σ {sigma} for {truth}"
            );
            assert!(d.rms_after_um < 0.15, "rms after {}", d.rms_after_um);
        }
    }
}

/// A clean machine (setup terms and noise only) is consistent in every plane.
#[test]
fn a_clean_machine_is_consistent() {
    for plane in Plane::ALL {
        for seed in 0..3 {
            let test =
                simulate(&model(plane, &[], 0.2, 100 + seed)).expect("a test within the bounds");
            let d = diagnose(&test, &DiagnoseConfig::default());
            assert_eq!(d.verdict, Verdict::Consistent, "{:?}", d.effects);
            assert!(d.effects.is_empty());
            assert!((d.setup.radius_offset_um - 1.5).abs() < 0.05);
        }
    }
}
