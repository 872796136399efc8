//! The concealed-effect campaign: 64 random tests (seeded), each with 0 to 3 effects the
//! diagnosis is not told about, in random planes; hit rate and false alarms measured.
//!
//! The fewest cases that still prove the claims: every fourth test is a null (16), and
//! with about 95 planted effects all found, the one-sided 95 % lower bound of the hit rate
//! is above 0.95 (0.95⁵⁹ < 0.05: 59 hits in 59 already prove it).

use std::f64::consts::PI;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use errmap::base::Verdict;
use errmap::circular::Slot;
use errmap::circular::simulate;
use errmap::circular::{
    Backlash, CircularEffect, CyclicError, LateralPlay, ReversalSpike, ScaleMismatch,
    ServoMismatch, Squareness, Straightness,
};
use errmap::circular::{DiagnoseConfig, Plane, diagnose};

use super::{main_param, model};

fn signed(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    let v = rng.random_range(lo..hi);
    if rng.random_bool(0.5) { v } else { -v }
}

fn random_effect(rng: &mut StdRng, kind: usize) -> (CircularEffect, Slot) {
    let slot = if rng.random_bool(0.5) {
        Slot::A
    } else {
        Slot::B
    };
    match kind {
        0 => (
            CircularEffect::Backlash(Backlash {
                b_um: signed(rng, 2.0, 8.0),
            }),
            slot,
        ),
        1 => (
            CircularEffect::ReversalSpike(ReversalSpike {
                h_um: signed(rng, 3.0, 8.0),
                tau_ms: rng.random_range(60.0..150.0),
            }),
            slot,
        ),
        2 => (
            CircularEffect::LateralPlay(LateralPlay {
                p_um: signed(rng, 2.0, 6.0),
            }),
            slot,
        ),
        3 => (
            CircularEffect::CyclicError(CyclicError {
                amplitude_um: rng.random_range(0.8..2.0),
                period_mm: rng.random_range(3.0..15.0),
                phase_rad: rng.random_range(-PI..PI),
            }),
            slot,
        ),
        4 => (
            CircularEffect::Straightness(Straightness {
                bow_um: signed(rng, 1.5, 5.0),
            }),
            slot,
        ),
        5 => (
            CircularEffect::ServoMismatch(ServoMismatch {
                dt_ms: signed(rng, 0.2, 1.0),
            }),
            Slot::Plane,
        ),
        6 => (
            CircularEffect::ScaleMismatch(ScaleMismatch {
                ppm: signed(rng, 20.0, 80.0),
            }),
            Slot::Plane,
        ),
        _ => (
            CircularEffect::Squareness(Squareness {
                urad: signed(rng, 20.0, 80.0),
            }),
            Slot::Plane,
        ),
    }
}

#[test]
fn random_concealed_effects_are_found_without_false_alarms() {
    let mut rng = StdRng::seed_from_u64(2026);
    let (mut planted, mut hits, mut false_alarms, mut nulls, mut nulls_clean) = (0, 0, 0, 0, 0);
    let cases = 64;
    for case in 0..cases {
        let plane = Plane::ALL[rng.random_range(0..3)];
        let count = if case % 4 == 3 {
            0
        } else {
            rng.random_range(1..=3)
        };
        let mut effects: Vec<(CircularEffect, Slot)> = Vec::new();
        while effects.len() < count {
            let kind = rng.random_range(0..8);
            let e = random_effect(&mut rng, kind);
            if !effects.iter().any(|(f, s)| f.id() == e.0.id() && *s == e.1) {
                effects.push(e);
            }
        }
        let mut m = model(plane, &effects, 0.2, 5000 + case);
        m.meta.sample_rate_hz = Some(50.0);
        m.centre_offset_um = [rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)];
        let test = simulate(&m).expect("a test within the bounds");
        let d = diagnose(&test, &DiagnoseConfig::default());
        if count == 0 {
            nulls += 1;
            nulls_clean += usize::from(d.verdict == Verdict::Consistent);
        }
        for (e, slot) in &effects {
            planted += 1;
            let (name, truth) = main_param(e);
            let found = d
                .effects
                .iter()
                .find(|f| f.effect.id() == e.id() && f.axis.slot == *slot);
            if let Some(f) = found {
                let got = f.effect.number(name).expect("test set-up");
                if got.signum() == truth.signum() {
                    hits += 1;
                } else {
                    eprintln!("case {case}: {} {name} {got} vs {truth}", e.id());
                }
            } else {
                eprintln!(
                    "case {case}: missed {e:?} {slot:?} among {:?}",
                    d.effects.iter().map(|f| f.effect).collect::<Vec<_>>()
                );
            }
        }
        for f in &d.effects {
            if !effects
                .iter()
                .any(|(e, s)| e.id() == f.effect.id() && *s == f.axis.slot)
            {
                false_alarms += 1;
                eprintln!(
                    "case {case}: false alarm {:?} {:?} (Δχ² {:.0})",
                    f.effect, f.axis.slot, f.delta_chi2
                );
            }
        }
    }
    let hit_rate = hits as f64 / planted as f64;
    eprintln!(
        "circular campaign: {cases} cases, {planted} planted effects, hit rate {:.3}, {false_alarms} \
         false alarms, {nulls_clean}/{nulls} null cases consistent",
        hit_rate
    );
    assert!(
        planted >= 80 && nulls == 16,
        "{planted} planted, {nulls} nulls"
    );
    assert!(hit_rate >= 0.95, "hit rate {hit_rate}");
    assert!(
        false_alarms as f64 <= 0.03 * cases as f64,
        "{false_alarms} false alarms"
    );
    assert!(nulls_clean == nulls, "{nulls_clean}/{nulls}");
}
