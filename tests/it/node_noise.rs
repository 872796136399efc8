//! Node uncertainty in the models (issue 16): the reduction's effective sample count of
//! correlated dwell samples against the AR(1) formula, the optional `n_eff` column on
//! disk, and the Gaussian process with each node's own uncertainty as heteroscedastic
//! noise, calibrated on held-out nodes of simulated campaigns (mean z² near 1, about
//! 95 % within ±2σ) where the homoscedastic model is not.

use errmap::base::gaussian;
use errmap::interp::{Gp, GpConfig};
use errmap::session::error_table;
use errmap::table::{ErrorPoint, ErrorTable};
use errmap_drivers::{Axis, SessionRow};
use rand::SeedableRng;
use rand::rngs::StdRng;

use crate::util::{reference_row, tempdir};

/// The true error along the line, µm.
fn truth(x: f64) -> f64 {
    2.0 * (x / 150.0).sin() + 0.002 * x
}

/// One line of 21 targets, `runs` runs out and back, `m` samples per dwell every 50 ms.
/// Each dwell's samples carry, scaled by `k(x)`, white noise σ_w and an AR(1) component
/// of lag-1 correlation `rho` and stationary σ `sigma_ar` (a fresh draw per dwell).
fn session(
    seed: u64,
    runs: u32,
    m: usize,
    rho: f64,
    sigma_w: f64,
    sigma_ar: f64,
    k: impl Fn(f64) -> f64,
) -> Vec<SessionRow> {
    let mut rng = StdRng::seed_from_u64(seed);
    let targets: Vec<f64> = (0..21).map(|k| f64::from(k) * 40.0).collect();
    let mut rows = Vec::new();
    let mut t = 0.0;
    let mut sample = 0i64;
    for run in 1..=runs {
        for (d, order) in [
            (1i8, (0..targets.len()).collect::<Vec<_>>()),
            (-1i8, (0..targets.len()).rev().collect::<Vec<_>>()),
        ] {
            for j in order {
                let x = targets[j];
                let (sa, sw) = (k(x) * sigma_ar, k(x) * sigma_w);
                let mut a = sa * gaussian(&mut rng);
                for _ in 0..m {
                    let e = truth(x) + a + sw * gaussian(&mut rng);
                    rows.push(SessionRow {
                        run,
                        sample,
                        t_s: t,
                        ..reference_row(Axis::X, d, j as i32, [x, 0.0, 0.0], x, e)
                    });
                    sample += 1;
                    t += 0.05;
                    a = rho * a + sa * (1.0 - rho * rho).sqrt() * gaussian(&mut rng);
                }
                t += 1.0;
            }
        }
    }
    rows
}

#[test]
fn the_effective_sample_count_follows_the_dwell_autocorrelation() {
    // White noise: n_eff ≈ n (within the scatter of s² over 80 samples and of the
    // session's design effect over 42 repeats), never above it.
    let rows = session(1, 2, 40, 0.0, 0.05, 0.0, |_| 1.0);
    let (t, _) = error_table("white", &rows).expect("reduces");
    for p in &t.points {
        let (n, ne) = (f64::from(p.n.expect("n")), p.n_eff.expect("n_eff"));
        assert!(ne > 0.6 * n && ne <= n, "white: n_eff {ne} of {n}");
    }
    // AR(1) with ρ = 0.7 and no white noise: the variance of the mean of m samples is
    // σ²/m·(1 + 2Σ(1 − k/m)ρ^k), i.e. n_eff ≈ m(1 − ρ)/(1 + ρ) = m/5.67 for long dwells
    // (40 samples: 7.9 per dwell, exactly from the formula). The estimate of ρ about each
    // dwell's mean is biased low for short dwells; by batch means (3 runs) or by the
    // corrected autocorrelation (1 run) n_eff is within the scatter of its estimate.
    let rho: f64 = 0.7;
    let m = 40.0;
    let tau = 1.0
        + 2.0
            * (1..40)
                .map(|k| (1.0 - f64::from(k) / m) * rho.powi(k))
                .sum::<f64>();
    let per_dwell = m / tau;
    for runs in [1u32, 3] {
        let rows = session(2, runs, 40, rho, 0.0, 0.1, |_| 1.0);
        let (t, _) = error_table("ar1", &rows).expect("reduces");
        let want = 2.0 * f64::from(runs) * per_dwell; // runs × 2 directions
        let mean = t
            .points
            .iter()
            .map(|p| p.n_eff.expect("n_eff"))
            .sum::<f64>()
            / t.points.len() as f64;
        println!(
            "AR(1), {runs} run(s): mean n_eff {mean:.1} against {want:.1} (n = {})",
            80 * runs
        );
        assert!(
            (mean / want - 1.0).abs() < 0.25,
            "AR(1), {runs} run(s): mean n_eff {mean} vs {want}"
        );
    }
    let rows = session(2, 3, 40, rho, 0.0, 0.1, |_| 1.0);
    let (t, _) = error_table("ar1", &rows).expect("reduces");
    // On disk and back; a table without the column reads as before.
    let dir = tempdir();
    let path = dir.path().join("nodes.csv");
    t.write(&path).expect("writes");
    let back = ErrorTable::read(&path).expect("reads");
    for (a, b) in t.points.iter().zip(&back.points) {
        let (x, y) = (a.n_eff.expect("n_eff"), b.n_eff.expect("read back"));
        assert!((x - y).abs() <= 1e-9 * x, "{x} vs {y}");
    }
    let text = std::fs::read_to_string(&path).expect("read");
    let header = text.lines().next().expect("header");
    assert!(header.ends_with(",n_eff"), "{header}");
    // A count beyond n is refused with its row and column.
    let bad = text.replacen(
        &format!(
            ",{}\n",
            text.lines()
                .nth(1)
                .expect("row")
                .rsplit(',')
                .next()
                .expect("cell")
        ),
        ",1e9\n",
        1,
    );
    std::fs::write(&path, bad).expect("write");
    let e = ErrorTable::read(&path).expect_err("n_eff > n");
    assert!(
        e.to_string().contains("n_eff") && e.to_string().contains("row 1"),
        "{e}"
    );
}

/// Whether a node sits where the machine vibrates (every third target).
fn noisy(x: f64) -> bool {
    ((x / 40.0).round() as i64) % 3 == 0
}

/// Held-out calibration of a GP on a table: leave-one-out z = (yᵢ − ŷ₋ᵢ)/σ₋ᵢ (σ₋ᵢ
/// includes node i's own noise): mean z² over the noisy nodes, over the quiet ones, and
/// the fraction of all with |z| ≤ 2.
fn calibration(points: &[ErrorPoint], homoscedastic: bool) -> [f64; 3] {
    let config = GpConfig {
        restarts: 2,
        homoscedastic,
        ..GpConfig::default()
    };
    let gp = Gp::fit(points, &config).expect("fits");
    let loo = gp.leave_one_out();
    let (mut sums, mut counts) = ([0.0; 2], [0.0; 2]);
    let mut inside = 0.0;
    for (p, (m, s)) in points.iter().zip(&loo) {
        let z = (p.e_um - m) / s;
        let k = usize::from(!noisy(p.x_mm));
        sums[k] += z * z;
        counts[k] += 1.0;
        if z.abs() <= 2.0 {
            inside += 1.0;
        }
    }
    [
        sums[0] / counts[0],
        sums[1] / counts[1],
        inside / points.len() as f64,
    ]
}

/// Simulated campaigns where every third node sits where the machine vibrates (white
/// noise and an AR(1) component with ρ = 0.9 between samples, 8 times larger there): the
/// homoscedastic GP spreads one σₙ over all nodes, too narrow for the noisy ones and too
/// wide for the quiet ones; with s/√n_eff per node the held-out z are calibrated in both
/// (mean z² near 1). The naive s/√n understates the noisy nodes' uncertainty.
#[test]
fn node_uncertainty_calibrates_the_gaussian_process_on_simulated_campaigns() {
    let seeds = 0u64..8;
    let mut sums = [[0.0; 3]; 3];
    let mut honest = [(0.0, 0.0); 2];
    for seed in seeds.clone() {
        let rows = session(100 + seed, 2, 20, 0.9, 0.01, 0.03, |x| {
            if noisy(x) { 8.0 } else { 1.0 }
        });
        let (t, _) = error_table("campaign", &rows).expect("reduces");
        for p in &t.points {
            let u = p.u_um().expect("u");
            let z = (p.e_um - truth(p.x_mm)) / u;
            let k = usize::from(!noisy(p.x_mm));
            honest[k].0 += z * z;
            honest[k].1 += 1.0;
        }
        let naive: Vec<ErrorPoint> = t
            .points
            .iter()
            .map(|p| ErrorPoint { n_eff: None, ..*p })
            .collect();
        for (k, (pts, homo)) in [(&t.points, true), (&t.points, false), (&naive, false)]
            .into_iter()
            .enumerate()
        {
            let c = calibration(pts, homo);
            for j in 0..3 {
                sums[k][j] += c[j];
            }
        }
    }
    let n = seeds.count() as f64;
    let [before, after, naive] = sums.map(|c| c.map(|v| v / n));
    println!(
        "held-out nodes over {n} campaigns, [mean z² noisy, mean z² quiet, fraction within ±2σ]: \
         homoscedastic {before:.3?}, s/√n_eff {after:.3?}, s/√n {naive:.3?}"
    );
    let honest = honest.map(|(s, n)| s / n);
    println!("node means against the truth, mean ((ē − e)/u)², noisy and quiet: {honest:.3?}");
    // The node uncertainty itself is honest (the truth is known here).
    for z2 in honest {
        assert!(
            (0.6..=1.6).contains(&z2),
            "node means against the truth: {honest:?}"
        );
    }
    for (what, z2) in [("noisy", after[0]), ("quiet", after[1])] {
        assert!((0.6..=1.6).contains(&z2), "{what} nodes: mean z² {z2}");
    }
    assert!(after[2] >= 0.9, "fraction within ±2σ {}", after[2]);
    let worst = |c: [f64; 3]| c[..2].iter().map(|z| z.ln().abs()).fold(0.0, f64::max);
    assert!(
        worst(after) < worst(before) && worst(after) < worst(naive),
        "no better calibrated: {after:?} vs {before:?} and {naive:?}"
    );
}
