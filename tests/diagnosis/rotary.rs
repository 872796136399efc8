//! The rotary diagnosis (`docs/rotary.md` §3) on errmap's own rotary simulator: each
//! effect alone within its stated one-sigma, effects combined, a clean axis quiet, and a
//! seeded concealed-effect campaign with its hit rate and false alarms.

use errmap::base::RotaryAxis;
use errmap::diagnose::rotary::{
    RotaryDiagnosis, RotaryDrift, RotaryEffect, RotaryId, RotarySample, diagnose_rotary,
};
use errmap::sim::{RotaryAxisModel, RotaryCycle, simulate_rotary};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn cycle() -> RotaryCycle {
    // Every 15°: m₀ = 24 distinct targets, harmonics up to 12 searched.
    RotaryCycle::revolution(24)
}

fn run(effects: Vec<RotaryEffect>, seed: u64) -> RotaryDiagnosis {
    let model = RotaryAxisModel {
        axis: RotaryAxis::C,
        effects,
        positioning_arcsec: 0.5,
        noise_arcsec: 0.3,
        seed,
    };
    let s = simulate_rotary(&model, &cycle());
    let samples: Vec<RotarySample> = s
        .rows
        .iter()
        .filter(|r| r.is_dwell())
        .map(|r| RotarySample {
            run: r.run,
            direction: r.direction,
            target_deg: r.target_deg.unwrap_or(0.0),
            t_s: r.t_s,
            e_arcsec: r.error_arcsec,
        })
        .collect();
    diagnose_rotary(&samples, false).expect("diagnosable")
}

/// The found effect with the hidden one's id (and order), if any.
fn found<'a>(
    d: &'a RotaryDiagnosis,
    hidden: &RotaryEffect,
) -> Option<&'a errmap::diagnose::rotary::RotaryFinding> {
    d.effects.iter().find(|f| {
        f.effect.id() == hidden.id()
            && f.effect.as_harmonic().map(|h| h.0) == hidden.as_harmonic().map(|h| h.0)
    })
}

/// Main parameter and its σ of a finding, and the hidden value. A drift is judged by its
/// rise over the session: with τ much longer than the session the linear and the
/// exponential forms are the same curve within the noise (either form may be reported),
/// so the found rise must match the hidden one within 20 % (4σ with σ = 5 %).
fn main_param(
    f: &errmap::diagnose::rotary::RotaryFinding,
    hidden: &RotaryEffect,
) -> (f64, f64, f64) {
    if let RotaryEffect::ThermalDrift(_) = hidden {
        let t_end = session_end();
        let (v, truth) = (
            f.effect.r_arcsec(0.0, 1, t_end),
            hidden.r_arcsec(0.0, 1, t_end),
        );
        return (v, 0.05 * truth.abs(), truth);
    }
    let (p, v) = f.effect.params()[0];
    let u = f.uncertainty.iter().find(|x| x.0 == p).map_or(0.0, |x| x.1);
    let truth = hidden
        .params()
        .iter()
        .find(|x| x.0 == p)
        .map_or(f64::NAN, |x| x.1);
    (v, u, truth)
}

/// The time of the cycle's last sample, s.
fn session_end() -> f64 {
    let model = RotaryAxisModel {
        axis: RotaryAxis::C,
        effects: Vec::new(),
        positioning_arcsec: 0.0,
        noise_arcsec: 0.0,
        seed: 0,
    };
    simulate_rotary(&model, &cycle())
        .rows
        .last()
        .map_or(0.0, |r| r.t_s)
}

#[test]
fn each_effect_alone_is_found_within_its_one_sigma_and_nothing_else_is() {
    let cases = [
        RotaryEffect::Eccentricity {
            amplitude_arcsec: 4.0,
            phase_deg: 40.0,
        },
        RotaryEffect::TwicePerRev {
            amplitude_arcsec: 3.0,
            phase_deg: 200.0,
        },
        RotaryEffect::GearPeriodic {
            amplitude_arcsec: 2.5,
            per_rev: 9,
            phase_deg: 100.0,
        },
        RotaryEffect::Reversal { b_arcsec: 3.0 },
        RotaryEffect::ScaleFactor { ppm: 15.0 },
        RotaryEffect::ThermalDrift(RotaryDrift::Linear {
            rate_arcsec_per_s: 0.004,
        }),
    ];
    for (k, hidden) in cases.iter().enumerate() {
        let d = run(vec![*hidden], 100 + k as u64);
        let f = found(&d, hidden).unwrap_or_else(|| panic!("{hidden:?} not found: {d:?}"));
        let (v, u, truth) = main_param(f, hidden);
        assert!(
            (v - truth).abs() <= 4.0 * u,
            "{hidden:?}: {v} ± {u} vs {truth}"
        );
        assert!(u > 0.0 && u < 0.5 * v.abs());
        assert_eq!(d.effects.len(), 1, "{hidden:?} alone: {:?}", d.effects);
        if let Some((_, _, phase)) = hidden.as_harmonic() {
            let p = f.effect.as_harmonic().map_or(f64::NAN, |h| h.2);
            let dp = ((p - phase + 180.0).rem_euclid(360.0) - 180.0).abs();
            assert!(dp < 10.0, "{hidden:?}: phase {p}");
            let sp = f
                .uncertainty
                .iter()
                .find(|x| x.0 == errmap::base::ParamName::PhaseDeg)
                .map_or(0.0, |x| x.1);
            assert!(
                sp > 0.0 && dp <= 4.0 * sp + 1e-9,
                "{hidden:?}: phase {p} ± {sp}"
            );
        }
    }
}

#[test]
fn combined_effects_are_found_together_and_a_clean_axis_gives_nothing() {
    let hidden = vec![
        RotaryEffect::Eccentricity {
            amplitude_arcsec: 5.0,
            phase_deg: 300.0,
        },
        RotaryEffect::GearPeriodic {
            amplitude_arcsec: 2.0,
            per_rev: 6,
            phase_deg: 10.0,
        },
        RotaryEffect::Reversal { b_arcsec: 2.0 },
        RotaryEffect::ScaleFactor { ppm: 10.0 },
    ];
    let d = run(hidden.clone(), 7);
    for h in &hidden {
        assert!(found(&d, h).is_some(), "{h:?} missing: {:?}", d.effects);
    }
    assert_eq!(d.effects.len(), hidden.len(), "{:?}", d.effects);
    assert!(d.rms_after_arcsec < d.rms_before_arcsec);
    // Ordered by what each explains.
    assert!(
        d.effects
            .windows(2)
            .all(|w| w[0].explains_arcsec >= w[1].explains_arcsec)
    );
    for seed in 0..10 {
        let d = run(Vec::new(), 1000 + seed);
        assert!(
            d.effects.is_empty(),
            "clean axis, seed {seed}: {:?}",
            d.effects
        );
    }
}

fn random_effect(rng: &mut StdRng, id: RotaryId) -> RotaryEffect {
    let amp = rng.random_range(1.5..6.0);
    let phase = rng.random_range(0.0..360.0);
    match id {
        RotaryId::Eccentricity => RotaryEffect::harmonic(1, amp, phase),
        RotaryId::TwicePerRev => RotaryEffect::harmonic(2, amp, phase),
        RotaryId::GearPeriodic => RotaryEffect::harmonic(rng.random_range(3..=12), amp, phase),
        RotaryId::Reversal => RotaryEffect::Reversal {
            b_arcsec: amp * rng.random_range(-1.0..1.0f64).signum(),
        },
        RotaryId::ScaleFactor => RotaryEffect::ScaleFactor {
            ppm: rng.random_range(6.0..30.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 },
        },
        RotaryId::ThermalDrift => RotaryEffect::ThermalDrift(RotaryDrift::Linear {
            rate_arcsec_per_s: rng.random_range(0.003..0.01),
        }),
    }
}

/// 60 seeded cases, each hiding 0 to 3 distinct effects: the hit rate (hidden effects
/// found with their id, order and main parameter within 4σ) and the false alarms
/// (effects reported that were not hidden).
#[test]
fn concealed_effect_campaign_hit_rate_and_false_alarms() {
    let mut rng = StdRng::seed_from_u64(38);
    let (mut hidden_n, mut hits, mut false_alarms, mut clean_cases, mut clean_alarms) =
        (0, 0, 0, 0, 0);
    for case in 0..60u64 {
        let k = rng.random_range(0..=3usize);
        let mut ids = RotaryId::ALL.to_vec();
        let mut hidden = Vec::new();
        for _ in 0..k {
            let id = ids.remove(rng.random_range(0..ids.len()));
            hidden.push(random_effect(&mut rng, id));
        }
        let d = run(hidden.clone(), 5000 + case);
        for h in &hidden {
            hidden_n += 1;
            if let Some(f) = found(&d, h) {
                let (v, u, truth) = main_param(f, h);
                if (v - truth).abs() <= 4.0 * u {
                    hits += 1;
                }
            }
        }
        let alarms = d
            .effects
            .iter()
            .filter(|f| {
                !hidden
                    .iter()
                    .any(|h| found(&d, h).is_some_and(|g| std::ptr::eq(g, *f)))
            })
            .count();
        false_alarms += alarms;
        if hidden.is_empty() {
            clean_cases += 1;
            clean_alarms += usize::from(alarms > 0);
        }
    }
    let hit_rate = hits as f64 / hidden_n as f64;
    eprintln!(
        "rotary campaign: {hits}/{hidden_n} hidden effects found (hit rate {hit_rate:.3}); \
         {false_alarms} false alarms in 60 cases; {clean_alarms}/{clean_cases} clean cases with any"
    );
    assert!(hit_rate >= 0.9, "hit rate {hit_rate}");
    assert!(false_alarms <= 3, "{false_alarms} false alarms");
    assert_eq!(clean_alarms, 0);
}
