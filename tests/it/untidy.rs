//! The untidy terms of the simulator (issue 16): latch-timing jitter on the board,
//! coloured noise and outliers in the machine model. Each is checked against its
//! definition (the timer lattice, the Ornstein–Uhlenbeck autocorrelation exp(−Δt/τ) and
//! variance σ², the outlier rate p), and the model file refuses bad values by key.

use crate::util::root;

use errmap::sim::{ColouredNoise, MachineModel, Outliers, simulate_plan};
use errmap_drivers::frame::Axis as WireAxis;
use errmap_drivers::sim::{Faults, Plan, Truth, TruthQuery};

fn quiet() -> MachineModel {
    MachineModel {
        seed: 7,
        ..MachineModel::default()
    }
}

fn dwell_query(t_s: f64) -> TruthQuery {
    TruthQuery {
        t_s,
        pos_mm: [100.0, 0.0, 0.0],
        direction: 1,
        feed_mm_s: 0.0,
        speed_mm_s: 0.0,
        run: 1,
        target: 0,
    }
}

/// The noise a model adds at `n` latches every `dt` seconds (its noiseless error is 0).
fn noise_series(m: &MachineModel, n: usize, dt: f64) -> Vec<f64> {
    let path = root().join("model.toml");
    let mut truth = m.truth(&path, WireAxis::X, n as f64 * dt).expect("truth");
    (0..n)
        .map(|k| truth.error_um(&dwell_query(k as f64 * dt)))
        .collect()
}

fn autocorrelation(v: &[f64], lag: usize) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let c0: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
    let ck: f64 = v
        .iter()
        .zip(&v[lag..])
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum();
    ck / c0
}

#[test]
fn coloured_noise_has_the_ornstein_uhlenbeck_variance_and_autocorrelation() {
    let mut m = quiet();
    m.coloured_noise = Some(ColouredNoise {
        enabled: true,
        sigma_um: 0.04,
        tau_s: 2.0,
    });
    // 400 correlation times: the sample variance is within a few % of σ².
    let v = noise_series(&m, 80_000, 0.01);
    let sd = (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    assert!((sd / 0.04 - 1.0).abs() < 0.1, "sd {sd}");
    for lag in [10usize, 100, 200] {
        let want = (-(lag as f64) * 0.01 / 2.0).exp();
        let got = autocorrelation(&v, lag);
        assert!((got - want).abs() < 0.06, "lag {lag}: {got} vs {want}");
    }
    // Switched off, the same model adds nothing.
    m.coloured_noise.as_mut().expect("set").enabled = false;
    assert!(noise_series(&m, 100, 0.01).iter().all(|&x| x == 0.0));
}

#[test]
fn outliers_come_at_their_rate_and_size() {
    let mut m = quiet();
    m.outliers = Some(Outliers {
        enabled: true,
        probability: 0.01,
        sigma_um: 2.0,
    });
    let v = noise_series(&m, 50_000, 0.01);
    let hits: Vec<f64> = v.iter().copied().filter(|&x| x != 0.0).collect();
    let rate = hits.len() as f64 / v.len() as f64;
    // Binomial: 500 ± 22 expected.
    assert!((rate - 0.01).abs() < 0.0015, "rate {rate}");
    let sd = (hits.iter().map(|x| x * x).sum::<f64>() / hits.len() as f64).sqrt();
    assert!((sd / 2.0 - 1.0).abs() < 0.12, "size sd {sd}");
}

#[test]
fn a_jittering_board_latches_off_the_timer_lattice_by_less_than_its_jitter() {
    let plan = Plan {
        runs: 1,
        targets_mm: vec![0.0, 50.0, 100.0],
        ..Plan::default()
    };
    let path = root().join("model.toml");
    let dt_us = 1e6 / plan.sample_hz;
    let offsets = |jitter: f64| -> Vec<f64> {
        let mut m = quiet();
        m.device.latch_jitter_us = jitter;
        let (stream, _) =
            simulate_plan(&m, &path, &plan, &Faults::default(), false).expect("simulates");
        stream
            .truth
            .iter()
            .map(|s| {
                let us = s.t_s * 1e6;
                us - (us / dt_us).floor() * dt_us
            })
            .collect()
    };
    let exact = offsets(0.0);
    assert!(exact.iter().all(|&o| o < 1e-3 || dt_us - o < 1e-3));
    let late = offsets(200.0);
    assert!(late.iter().all(|&o| o < 200.0 + 1e-3), "beyond the jitter");
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    // Uniform on [0, 200) µs: mean 100 µs.
    assert!((mean - 100.0).abs() < 10.0, "mean latency {mean}");
}

#[test]
fn bad_untidy_terms_are_refused_by_key() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.toml");
    for (text, key) in [
        (
            "[outliers]\nprobability = 0.5\nsigma_um = 1.0\n",
            "outliers.probability",
        ),
        (
            "[coloured_noise]\nsigma_um = 0.01\ntau_s = 0.0\n",
            "coloured_noise.tau_s",
        ),
        (
            "[coloured_noise]\nsigma_um = -0.01\ntau_s = 10.0\n",
            "coloured_noise.sigma_um",
        ),
        ("[outliers]\nprobability = 0.01\nsize_um = 1.0\n", "size_um"),
    ] {
        std::fs::write(&bad, text).expect("write");
        let e = MachineModel::read(&bad).expect_err(text);
        assert!(
            e.to_string().contains(key) && e.to_string().contains("bad.toml"),
            "{text}: {e}"
        );
    }
    // Jitter beyond a quarter of the sample period is refused when simulating.
    let mut m = quiet();
    m.device.latch_jitter_us = 5000.0;
    let e = simulate_plan(
        &m,
        &root().join("model.toml"),
        &Plan::default(),
        &Faults::default(),
        false,
    )
    .expect_err("jitter of half a period");
    assert!(e.to_string().contains("latch_jitter_us"), "{e}");
    // The example model documents every term and parses.
    let ex = MachineModel::read(&root().join("datasets/physics/example-model.toml"))
        .expect("example parses");
    assert!(ex.coloured_noise.is_some() && ex.outliers.is_some());
}
