//! Sessions as untidy as real ones (issue 16): outliers get no weight and raise no
//! alarm.

use crate::common::diagnosis_text;
use errmap::diagnose::synth::{Hidden, Synth, SynthNoise, generate};
use errmap::diagnose::{DiagnoseConfig, Diagnosis, diagnose};

fn config() -> DiagnoseConfig {
    DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    }
}

fn untidy(seed: u64, hidden: Vec<Hidden>) -> Synth {
    Synth {
        seed,
        hidden,
        noise: SynthNoise {
            sigma_um: 0.06,
            ..SynthNoise::default()
        }
        .untidy(),
        ..Synth::default()
    }
}

fn run(s: &Synth) -> Diagnosis {
    let out = generate(s);
    match diagnose(&out.recorded, &out.simulated, &config()) {
        Ok(d) => d,
        Err(e) => panic!("diagnose failed: {e}"),
    }
}

/// One sample in 100 an outlier of 30 σ (far more than a real board has): without
/// weights the least squares would chase them; with them the clean session stays
/// consistent and a hidden reversal comes back within 3σ.
#[test]
fn outliers_get_no_weight_and_raise_no_alarm() {
    for seed in [3u64, 4] {
        let mut s = untidy(seed, Vec::new());
        s.noise.outlier_prob = 0.01;
        s.noise.outlier_um = 30.0 * s.noise.sigma_um;
        let d = run(&s);
        assert_eq!(d.verdict, "consistent", "{}", diagnosis_text(&d));
        assert!(
            d.selection_log.iter().any(|l| l.contains("outliers")),
            "the outliers are not stated: {:?}",
            d.selection_log
        );
        s.hidden = vec![Hidden::Reversal { b_um: 0.4 }];
        let d = run(&s);
        let text = diagnosis_text(&d);
        assert_eq!(d.effects.len(), 1, "{text}");
        let e = &d.effects[0];
        assert_eq!(e.id, "reversal", "{text}");
        let b = e.params["b_um"].as_f64().expect("b_um");
        let sd = e.uncertainty["b_um"];
        assert!((b - 0.4).abs() <= 3.0 * sd, "b {b} ± {sd}: {text}");
    }
}
