//! A 100 000-row session is diagnosed in under 2 s (release builds only:
//! `cargo test --release --test diagnose_perf -- --nocapture`).

use std::time::Instant;

use errmap::base::{Drift, Effect};
use errmap::diagnose::{DiagnoseConfig, diagnose};
use errmap::diagnose::{Synth, SynthPlan, synthesize as generate};

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "timing is meaningful in release builds only"
)]
fn hundred_thousand_rows_in_under_two_seconds() {
    let s = Synth {
        plan: SynthPlan {
            lines_mm: vec![
                [100.0, 150.0],
                [400.0, 150.0],
                [100.0, 450.0],
                [400.0, 450.0],
            ],
            runs: 11,
            dwell_samples: 80,
            dwell_interval_s: 0.05,
            move_spacing_mm: 3.0,
            ..SynthPlan::default()
        },
        hidden: vec![
            Effect::Reversal {
                b_um: 0.5,
                b1_um_per_m: None,
            },
            Effect::PeriodicScale {
                amplitude_um: 0.1,
                period_um: 10.0,
                phase_rad: 0.4,
            },
            Effect::ThermalDrift(Drift::Exponential {
                amplitude_um: 1.0,
                tau_s: 900.0,
            }),
        ],
        seed: 4,
        ..Synth::default()
    };
    let out = generate(&s).expect("a positioning pair");
    assert!(out.recorded.len() >= 100_000, "{} rows", out.recorded.len());
    for (name, cfg) in [
        (
            "grating 20 µm",
            DiagnoseConfig {
                grating_period_um: Some(20.0),
                ..DiagnoseConfig::default()
            },
        ),
        ("grating unknown", DiagnoseConfig::default()),
    ] {
        let start = Instant::now();
        let d = match diagnose(&out.recorded, &out.simulated, &cfg) {
            Ok(d) => d,
            Err(e) => panic!("{e}"),
        };
        let secs = start.elapsed().as_secs_f64();
        println!(
            "{name}: {} rows in {secs:.3} s: {:?}",
            out.recorded.len(),
            d.effects.iter().map(|e| e.id()).collect::<Vec<_>>()
        );
        assert_eq!(d.effects.len(), 3, "{:?}", d.effects);
        assert!(secs < 2.0, "{name}: {secs} s");
    }
}
