//! Gaussian-process error model: known answers on noiseless and GP-sampled data,
//! Table 1 → Table 2, sampling advice and bad input. Randomness is seeded; every
//! tolerance states its reason.

use std::path::Path;
use std::time::Instant;

use errmap::interp::Interpolator;
use errmap::interp::{Gp, GpConfig, GpError, GpHyper, Kernel};
use errmap::table::{ErrorPoint, ErrorTable, Grid};
use nalgebra::{Cholesky, DMatrix};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn table(name: &str) -> ErrorTable {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("datasets")
        .join(name);
    ErrorTable::read(&path).expect("dataset reads")
}

/// A standard normal deviate (Box–Muller; rand_distr is not a dependency).
fn normal(rng: &mut StdRng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn uniform_point(rng: &mut StdRng, hi: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|a| rng.random_range(0.0..hi[a]))
}

/// Matérn 5/2 correlation at scaled distance r.
fn matern52(r: f64) -> f64 {
    let s = 5f64.sqrt() * r;
    (1.0 + s + s * s / 3.0) * (-s).exp()
}

/// Draws e = mean + f + ε at `positions`, f from a zero-mean Matérn 5/2 GP.
fn sample_gp(
    rng: &mut StdRng,
    positions: &[[f64; 3]],
    ls: [f64; 3],
    signal_sd: f64,
    noise_sd: f64,
    mean: f64,
) -> Vec<ErrorPoint> {
    let n = positions.len();
    let k = DMatrix::from_fn(n, n, |i, j| {
        let r2: f64 = (0..3)
            .map(|a| ((positions[i][a] - positions[j][a]) / ls[a]).powi(2))
            .sum();
        signal_sd * signal_sd * matern52(r2.sqrt()) + if i == j { 1e-9 } else { 0.0 }
    });
    let l = Cholesky::new(k)
        .expect("the prior covariance is positive definite")
        .l();
    let z = nalgebra::DVector::from_fn(n, |_, _| normal(rng));
    let f = l * z;
    positions
        .iter()
        .zip(f.iter())
        .map(|(p, fi)| ErrorPoint::new(p[0], p[1], p[2], mean + fi + noise_sd * normal(rng)))
        .collect()
}

/// The smooth "machine error" of test 1: products of sines and cosines with ~100 mm
/// wavelengths scale, amplitude a few µm.
fn smooth_field(p: [f64; 3]) -> f64 {
    2.0 * (p[0] / 110.0).sin() * (p[1] / 140.0).cos() + 1.5 * (p[2] / 90.0).cos() - 0.5
}

#[test]
fn noiseless_smooth_field_is_recovered_within_its_sigma() {
    let nodes: Vec<f64> = (0..6).map(|i| 100.0 * i as f64).collect();
    let grid = Grid::from_fn(nodes.clone(), nodes.clone(), nodes, smooth_field);
    let points = grid.points();
    let config = GpConfig {
        kernel: Kernel::SquaredExponential,
        restarts: 2,
        seed: 1,
        ..GpConfig::default()
    };
    let start = Instant::now();
    let gp = Gp::fit(&points, &config).expect("fits");
    eprintln!(
        "noiseless 6×6×6 SE fit: {:.1} s, {:?}",
        start.elapsed().as_secs_f64(),
        gp.hyper()
    );
    let h = *gp.hyper();
    // Noiseless data: the fitted noise sits at its floor (1e-6 × data sd plus the 1e-5 σ_f
    // nugget), far below the signal.
    assert!(h.noise_sd_um < 1e-3 * h.signal_sd_um, "{h:?}");

    for p in &points {
        let (mean, sigma) = gp.predict_with_sigma(p.position());
        // At a node the latent σ is about the noise sd (≤ 1e-5 σ_f); 1e-3 σ_f leaves room.
        assert!(sigma <= 1e-3 * h.signal_sd_um, "σ = {sigma} at {p:?}");
        // The mean interpolates up to the nugget: the residual σₙ²αᵢ is of the order of
        // the noise sd (5.5e-5 µm in this fit). 1e-4 µm = 0.1 nm is 4·10⁻⁵ of the field's
        // 2.5 µm amplitude and far below any CMM's resolution.
        assert!(
            (mean - p.e_um).abs() < 1e-4,
            "mean {mean} vs {} at {p:?}",
            p.e_um
        );
        assert!(!gp.outside(p.position()));
    }

    let mut rng = StdRng::seed_from_u64(11);
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        let p = uniform_point(&mut rng, [500.0; 3]);
        let (mean, sigma) = gp.predict_with_sigma(p);
        let z = (mean - smooth_field(p)).abs() / sigma;
        worst = worst.max(z);
        assert!((gp.predict(p) - mean).abs() < 1e-12);
    }
    eprintln!("noiseless field: worst |error|/σ over 200 interior points = {worst:.2}");
    // A calibrated σ would put ~1 in 370 points beyond 3σ; the deterministic field is not
    // a GP sample, so allow a margin: every point within 3.5σ.
    assert!(worst < 3.5, "worst |error|/σ = {worst}");
}

/// Test 2's truth: Matérn 5/2 with these length scales, σ_f = 2 µm, σₙ = 0.5 µm, mean
/// 1 µm, on 200 uniform points in a 600 × 1000 × 300 mm box (2.5–4 length scales wide).
const TRUTH_LS_MM: [f64; 3] = [150.0, 400.0, 80.0];
const TRUTH_SIGNAL_UM: f64 = 2.0;
const TRUTH_NOISE_UM: f64 = 0.5;

fn gp_sample_200(seed: u64) -> Vec<ErrorPoint> {
    let mut rng = StdRng::seed_from_u64(seed);
    let box_mm = [600.0, 1000.0, 300.0];
    let positions: Vec<[f64; 3]> = (0..200).map(|_| uniform_point(&mut rng, box_mm)).collect();
    sample_gp(
        &mut rng,
        &positions,
        TRUTH_LS_MM,
        TRUTH_SIGNAL_UM,
        TRUTH_NOISE_UM,
        1.0,
    )
}

/// Tolerances: one realisation pins a length scale only to tens of per cent (the
/// likelihood is flat along the ℓ–σ_f ridge), hence a factor 1.5 for ℓ and σ_f. The
/// noise is identified by ~200 residuals at scales below the point spacing: relative sd
/// ≈ 1/√(2·200) ≈ 5 %, inflated by its trade-off with the length scales, hence 30 %.
/// Over seeds 0–5 (`hyperparameter_recovery_holds_over_seeds`) the ℓ ratios fell in
/// 0.77–1.43, σ_f in 0.76–1.37 and σₙ in 0.84–1.07.
fn assert_recovered(h: &GpHyper, seed: u64) {
    for (a, (fitted, truth)) in h.length_scales_mm.iter().zip(TRUTH_LS_MM).enumerate() {
        assert!(
            (1.0 / 1.5..=1.5).contains(&(fitted / truth)),
            "seed {seed}, axis {a}: fitted {fitted} mm vs true {truth} mm"
        );
    }
    let noise = h.noise_sd_um / TRUTH_NOISE_UM;
    assert!((0.7..=1.3).contains(&noise), "seed {seed}: {h:?}");
    let signal = h.signal_sd_um / TRUTH_SIGNAL_UM;
    assert!((1.0 / 1.5..=1.5).contains(&signal), "seed {seed}: {h:?}");
}

#[test]
fn hyperparameters_are_recovered_from_a_gp_sample() {
    let points = gp_sample_200(0);
    let start = Instant::now();
    let gp = Gp::fit(&points, &GpConfig::default()).expect("fits");
    let secs = start.elapsed().as_secs_f64();
    let h = *gp.hyper();
    eprintln!(
        "200-point Matérn 5/2 fit (default config, 9 starts): {secs:.1} s; {h:?}; lml {:.2}",
        gp.log_marginal_likelihood()
    );
    assert_recovered(&h, 0);
}

/// The evidence for `assert_recovered`'s tolerances: six seeds, 3 starts each (~2 min in
/// debug, hence ignored; run with `--ignored`).
#[test]
#[ignore]
fn hyperparameter_recovery_holds_over_seeds() {
    for seed in 0..6 {
        let config = GpConfig {
            restarts: 2,
            ..GpConfig::default()
        };
        let gp = Gp::fit(&gp_sample_200(seed), &config).expect("fits");
        eprintln!("seed {seed}: {:?}", gp.hyper());
        assert_recovered(gp.hyper(), seed);
    }
}

#[test]
fn scattered_nodes_fit_and_predict() {
    let mut rng = StdRng::seed_from_u64(7);
    let box_mm = [800.0, 400.0, 300.0];
    let field = |p: [f64; 3]| 3.0 * (p[0] / 250.0).sin() + 0.01 * p[1] - (p[2] / 200.0).powi(2);
    let points: Vec<ErrorPoint> = (0..80)
        .map(|_| {
            let p = uniform_point(&mut rng, box_mm);
            ErrorPoint::new(p[0], p[1], p[2], field(p) + 0.05 * normal(&mut rng))
        })
        .collect();
    let gp = Gp::fit(&points, &GpConfig::default()).expect("fits");
    eprintln!("scattered 80 points: {:?}", gp.hyper());
    // Noise 0.05 µm was added; its estimate should be of that order (factor 3: 80 points).
    let noise = gp.hyper().noise_sd_um;
    assert!((0.05 / 3.0..0.15).contains(&noise), "noise {noise}");

    let mut sq = 0.0;
    let mut inside_2sigma = 0;
    let m = 100;
    for _ in 0..m {
        let p = [
            rng.random_range(100.0..700.0),
            rng.random_range(50.0..350.0),
            rng.random_range(50.0..250.0),
        ];
        let (mean, sigma) = gp.predict_with_sigma(p);
        sq += (mean - field(p)).powi(2);
        if (mean - field(p)).abs() <= 2.0 * sigma {
            inside_2sigma += 1;
        }
    }
    let rms = (sq / m as f64).sqrt();
    eprintln!("scattered: interior RMS {rms:.4} µm, {inside_2sigma}/{m} within 2σ");
    // The field spans ~8 µm; 80 points resolve it to a few per cent of that.
    assert!(rms < 0.2, "rms {rms}");
    // 95 % expected within 2σ for a calibrated model; ≥ 85 % allows for the field not
    // being a GP sample and for 100 correlated test points.
    assert!(inside_2sigma >= 85, "{inside_2sigma}/{m} within 2σ");

    // Outside the bounding box of the fitted points (not of `box_mm`).
    let max_x = points.iter().map(|p| p.x_mm).fold(f64::MIN, f64::max);
    assert!(gp.outside([max_x + 1.0, 200.0, 150.0]));
    assert!(!gp.outside([400.0, 200.0, 150.0]));
    // Leaving the data, σ grows, and far beyond every length scale it tends to
    // √(σ_f² + var(m̂)) > σ_f.
    let sigma_at = |x: f64| gp.predict_with_sigma([x, 200.0, 150.0]).1;
    let sigmas: Vec<f64> = [400.0, 1000.0, 3000.0, 30000.0]
        .iter()
        .map(|&x| sigma_at(x))
        .collect();
    let far = sigma_at(1e7);
    eprintln!("scattered: σ at x = 400, 1000, 3000, 30000 mm: {sigmas:?}; at 1e7 mm: {far}");
    assert!(sigmas.windows(2).all(|w| w[1] > w[0]), "{sigmas:?}");
    assert!(far > gp.hyper().signal_sd_um && far >= sigmas[3]);
}

#[test]
fn table1_to_table2() {
    let fit = table("table1.csv");
    let test = table("table2.csv");
    assert_eq!(fit.points.len(), 30);
    assert_eq!(test.points.len(), 7);
    for kernel in [Kernel::Matern52, Kernel::SquaredExponential] {
        let config = GpConfig {
            kernel,
            ..GpConfig::default()
        };
        let gp = Gp::fit(&fit.points, &config).expect("Table 1 fits");
        eprintln!(
            "Table 1 → 2, {kernel}: {:?}, lml {:.3}",
            gp.hyper(),
            gp.log_marginal_likelihood()
        );
        let mut sq = 0.0;
        let mut inside = 0;
        for (row, p) in test.points.iter().enumerate() {
            let (mean, sigma_latent) = gp.predict_with_sigma(p.position());
            let (_, sigma) = gp.predict_with_sigma_noisy(p.position());
            let z = (p.e_um - mean) / sigma;
            sq += (p.e_um - mean).powi(2);
            if z.abs() <= 2.0 {
                inside += 1;
            }
            eprintln!(
                "  row {}: e {:+.4} mean {:+.4} σ_latent {:.4} σ_measured {:.4} |z| {:.2}{}",
                row + 1,
                p.e_um,
                mean,
                sigma_latent,
                sigma,
                z.abs(),
                if gp.outside(p.position()) {
                    " (extrapolated)"
                } else {
                    ""
                }
            );
        }
        let rms = (sq / test.points.len() as f64).sqrt();
        eprintln!("  {kernel}: RMS {rms:.3} µm, {inside}/7 within ±2σ");
        // The 4×1×2 Lagrange column misses by RMS ≈ 0.5 µm; the GP is in the same class.
        assert!(rms < 0.8, "{kernel}: RMS {rms}");
        // Calibrated σ: ≥ 6 of 7 measured values within ±2σ (including the fitted noise).
        assert!(inside >= 6, "{kernel}: {inside}/7 within ±2σ");
    }
}

#[test]
fn next_nodes_fills_the_gap_first() {
    // A 9×9 grid in the plane z = 0 with a 3×3 hole (x, y ∈ {300, 400, 500}) cut out.
    let coords: Vec<f64> = (0..9).map(|i| 100.0 * i as f64).collect();
    let hole = |v: f64| (300.0..=500.0).contains(&v);
    let mut points = Vec::new();
    for &x in &coords {
        for &y in &coords {
            if !(hole(x) && hole(y)) {
                let e = (x / 300.0).sin() + (y / 250.0).cos();
                points.push(ErrorPoint::new(x, y, 0.0, e));
            }
        }
    }
    let gp = Gp::fit(&points, &GpConfig::default()).expect("fits");
    let near_node = [105.0, 200.0, 0.0];
    let gap = [400.0, 400.0, 0.0];
    let edge_of_gap = [300.0, 400.0, 0.0];
    let candidates = [near_node, edge_of_gap, gap];
    let picks = gp.next_nodes(&candidates, 3);
    eprintln!("next nodes: {picks:?}; hyper {:?}", gp.hyper());
    assert_eq!(picks.len(), 3);
    assert_eq!(
        picks[0], gap,
        "the centre of the hole is the most uncertain"
    );
    assert_eq!(
        picks[2], near_node,
        "a point 5 mm from a node is the least useful"
    );
    let (_, s_gap) = gp.predict_with_sigma(gap);
    assert_eq!(gp.max_sigma(&candidates), s_gap);
    assert_eq!(gp.max_sigma(&[]), 0.0);
    // More picks than candidates: each candidate once.
    assert_eq!(gp.next_nodes(&candidates, 10).len(), 3);
    assert!(gp.next_nodes(&candidates, 0).is_empty());

    // The pseudo-observation matters: of two copies of the gap centre and a point 100 mm
    // from it, the second pick is that point, because the copy's variance collapsed to
    // about the noise when the first copy was added.
    let near_gap = [400.0, 300.0, 0.0];
    let picks = gp.next_nodes(&[gap, gap, near_gap], 2);
    assert_eq!(picks, vec![gap, near_gap]);

    // The planar data (every z = 0) fitted, and the model is constant along z.
    assert!((gp.predict([250.0, 250.0, 40.0]) - gp.predict([250.0, 250.0, 0.0])).abs() < 1e-6);
}

#[test]
fn same_seed_same_fit() {
    let points = table("table1.csv").points;
    let config = GpConfig {
        restarts: 3,
        seed: 99,
        ..GpConfig::default()
    };
    let a = Gp::fit(&points, &config).expect("fits");
    let b = Gp::fit(&points, &config).expect("fits");
    assert_eq!(a.hyper(), b.hyper());
    assert_eq!(a.log_marginal_likelihood(), b.log_marginal_likelihood());
}

#[test]
fn bad_input_is_rejected_with_typed_errors() {
    let config = GpConfig::default();
    let p = |x, y, z, e| ErrorPoint::new(x, y, z, e);

    let err = Gp::fit(&[p(0.0, 0.0, 0.0, 1.0), p(1.0, 0.0, 0.0, 2.0)], &config)
        .expect_err("two points are too few");
    assert_eq!(err, GpError::TooFewPoints { got: 2, min: 3 });
    assert_eq!(
        err.to_string(),
        "a Gaussian-process fit needs at least 3 points, got 2"
    );
    assert!(matches!(
        Gp::fit(&[], &config),
        Err(GpError::TooFewPoints { got: 0, .. })
    ));

    let err = Gp::fit(
        &[
            p(0.0, 0.0, 0.0, 1.0),
            p(1.0, 0.0, 0.0, 2.0),
            p(2.0, f64::NAN, 0.0, 2.0),
        ],
        &config,
    )
    .expect_err("NaN coordinate");
    assert!(
        matches!(
            err,
            GpError::NonFinite {
                index: 2,
                field: "y_mm",
                ..
            }
        ),
        "{err:?}"
    );
    assert_eq!(err.to_string(), "points[2]: y_mm = NaN is not finite");

    let err = Gp::fit(
        &[
            p(0.0, 0.0, 0.0, f64::INFINITY),
            p(1.0, 0.0, 0.0, 2.0),
            p(2.0, 0.0, 0.0, 2.0),
        ],
        &config,
    )
    .expect_err("infinite error value");
    assert!(matches!(
        err,
        GpError::NonFinite {
            index: 0,
            field: "e_um",
            ..
        }
    ));

    let err = Gp::fit(
        &[
            p(5.0, 1.0, 2.0, 1.0),
            p(1.0, 0.0, 0.0, 2.0),
            p(2.0, 0.0, 0.0, 2.0),
            p(5.0, 1.0, 2.0, 1.5),
        ],
        &config,
    )
    .expect_err("duplicate position");
    assert_eq!(
        err,
        GpError::DuplicatePosition {
            first: 0,
            second: 3,
            x: 5.0,
            y: 1.0,
            z: 2.0
        }
    );
    assert_eq!(
        err.to_string(),
        "points[0] and points[3] share the position (5, 1, 2) mm; \
         average repeated measurements before fitting"
    );

    // Degenerate but legal: constant data and collinear points still fit.
    let line: Vec<ErrorPoint> = (0..5).map(|i| p(10.0 * i as f64, 3.0, 7.0, 0.25)).collect();
    let gp = Gp::fit(&line, &config).expect("constant data on a line fits");
    assert!((gp.predict([15.0, 3.0, 7.0]) - 0.25).abs() < 1e-6);
}

/// The closed-form leave-one-out predictions equal refitting without each node (same
/// hyperparameters, GLS mean re-estimated), computed independently by conditioning a
/// fresh model on the other nodes.
#[test]
fn leave_one_out_matches_refitting_without_each_node() {
    let mut rng = StdRng::seed_from_u64(11);
    let positions: Vec<[f64; 3]> = (0..30)
        .map(|_| uniform_point(&mut rng, [500.0, 300.0, 200.0]))
        .collect();
    let points = sample_gp(&mut rng, &positions, [150.0, 200.0, 120.0], 2.0, 0.1, 1.0);
    let gp = Gp::fit(&points, &GpConfig::default()).expect("fits");
    let loo = gp.leave_one_out();
    assert_eq!(loo.len(), points.len());
    for (i, &(mean, sigma)) in loo.iter().enumerate() {
        let mut rest = points.clone();
        let held = rest.remove(i);
        let fold = Gp::with_hyper(&rest, gp.kernel(), gp.hyper()).expect("fold conditions");
        let (m, s) = fold.predict_with_sigma_noisy(held.position());
        // Two algebraically equal routes through different factorisations: agreement to
        // 1e-6 µm (values of a few µm, condition numbers up to ~1e6).
        assert!((mean - m).abs() < 1e-6, "node {i}: LOO {mean} vs refit {m}");
        assert!(
            (sigma - s).abs() < 1e-6,
            "node {i}: LOO σ {sigma} vs refit {s}"
        );
    }
    // Held at the fitted hyperparameters, the same data give the same model.
    let again = Gp::with_hyper(&points, gp.kernel(), gp.hyper()).expect("conditions");
    let p = [250.0, 150.0, 100.0];
    assert!((again.predict(p) - gp.predict(p)).abs() < 1e-9);
}

/// `compare` on scattered nodes: the GP is fitted, cross-validated leave-one-out, and its
/// test error and calibration come out sensibly against the exact field.
#[test]
fn compare_on_scattered_nodes_predicts_the_field() {
    use errmap::evaluate::CvScheme;
    use errmap::evaluate::compare_scattered;
    use errmap::interp::Method;
    let mut rng = StdRng::seed_from_u64(5);
    let box_mm = [600.0, 400.0, 300.0];
    let nodes: Vec<ErrorPoint> = (0..90)
        .map(|_| {
            let p = uniform_point(&mut rng, box_mm);
            ErrorPoint::new(p[0], p[1], p[2], smooth_field(p))
        })
        .collect();
    let test: Vec<ErrorPoint> = (0..60)
        .map(|_| {
            let p = [
                rng.random_range(100.0..500.0),
                rng.random_range(80.0..320.0),
                rng.random_range(60.0..240.0),
            ];
            ErrorPoint::new(p[0], p[1], p[2], smooth_field(p))
        })
        .collect();
    let table = ErrorTable::from_points("scattered", nodes);
    let test = ErrorTable::from_points("test", test);
    let methods = [
        Method::Gp(Kernel::Matern52),
        Method::Gp(Kernel::SquaredExponential),
    ];
    let c = compare_scattered(&table, &test, &methods, Vec::new()).expect("compares");
    assert!(c.grid.is_none());
    assert_eq!(c.rows.len(), 2);
    assert!(
        c.extrapolated.iter().all(|e| !e),
        "test points are interior"
    );
    for r in &c.rows {
        assert_eq!(r.cv.scheme, CvScheme::LeaveOneOut);
        assert_eq!(r.cv.folds, 90);
        eprintln!(
            "{}: test RMS {:.4} µm, LOO CV RMS {:.4} µm, within 2σ {:?}",
            r.method.label(),
            r.rms_um,
            r.cv.rms_um,
            r.within_2s
        );
        // The field spans about ±3.5 µm; 90 noiseless nodes pin it to a few per cent.
        assert!(
            r.rms_um < 0.15,
            "{}: test RMS {}",
            r.method.label(),
            r.rms_um
        );
        // Leave-one-out includes the edge nodes (extrapolations), so it is larger than the
        // interior test error, but of the same order: not a number unrelated to it.
        assert!(
            r.cv.rms_um > 0.5 * r.rms_um && r.cv.rms_um < 20.0 * r.rms_um,
            "{}: CV {} vs test {}",
            r.method.label(),
            r.cv.rms_um,
            r.rms_um
        );
    }
    // On an analytic field the squared exponential predicts better, and leave-one-out
    // (on the fitting nodes alone) says so.
    assert_eq!(
        c.recommended_row().method,
        Method::Gp(Kernel::SquaredExponential)
    );
    let advice = c.advice.as_ref().expect("sampling advice");
    assert_eq!(advice.next_nodes.len(), 5);
    // 90 nodes over 3 axes ≈ 4.5 per axis: spacing about extent / 3.5.
    assert!(
        (advice.spacing_mm[0] - 600.0 / 3.48).abs() < 15.0,
        "{:?}",
        advice.spacing_mm
    );
}
