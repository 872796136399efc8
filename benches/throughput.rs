//! `cargo bench` (divan): the interpolators' points per second on a 41³ grid with 10⁶
//! random points inside it, one thread and all threads; fit times on 21³; the Gaussian
//! process on 200 scattered nodes; the wire decoder's bytes per second. The same data as
//! `errmap bench` (`src/bench.rs`), measured by divan's sampler instead of medians.
//! Volumetric: identification of a 60-line, 21-targets-per-line campaign (with σ and
//! identifiability; degree by cross-validation, and degree 3) and the error vector with σ
//! at 41³ points (`errmap::bench::volumetric`). `cargo bench -- points` runs only the
//! evaluation group, `cargo bench -- volumetric` only the volumetric ones.
//! `cargo bench -- sphere`: the least-squares sphere of an ISO 10360-5 multi-stylus test
//! (125 points, the simulator's example).

use std::sync::LazyLock;

use divan::counter::{BytesCount, ItemsCount};
use divan::{Bencher, black_box};
use errmap::bench::{gp_points, random_grid, random_points, synthetic_capture};
use errmap::interp::{DEFAULT_FUZZY_SIGMA, Method, Order, predict_parallel};
use errmap::interp::{Gp, GpConfig};
use errmap::table::Grid;

fn main() {
    divan::main();
}

/// The least-squares sphere of 5 × 25 probed points (goal: under 1 ms).
#[divan::bench(sample_count = 100)]
fn sphere_fit_125_points(bencher: Bencher) {
    use errmap::acceptance::probing::fit_sphere;
    use errmap::acceptance::probing::{example, simulate};
    let points: Vec<[f64; 3]> = simulate(&example()).iter().map(|p| p.p_mm).collect();
    bencher
        .counter(ItemsCount::new(points.len()))
        .bench_local(|| fit_sphere(black_box(&points)).expect("the example fits"));
}

/// The evaluation grid and query points, made once.
static DATA: LazyLock<(Grid, Vec<[f64; 3]>)> = LazyLock::new(|| {
    let grid = random_grid(41, 1);
    let points = random_points(&grid, 1_000_000, 2);
    (grid, points)
});

/// Points per second of `method` on `threads` threads (0: all cores).
fn evaluate(bencher: Bencher, method: Method, threads: usize) {
    let (grid, points) = &*DATA;
    let model = method
        .fit(grid)
        .expect("the benchmark grid fits every method");
    let mut out = vec![0.0; points.len()];
    bencher
        .counter(ItemsCount::new(points.len()))
        .bench_local(|| {
            predict_parallel(model.as_ref(), black_box(points), &mut out, threads)
                .expect("thread pool");
        });
}

const FUZZY: Method = Method::Fuzzy {
    sigma: DEFAULT_FUZZY_SIGMA,
};

#[divan::bench_group(sample_count = 20)]
mod points_one_thread {
    use super::*;

    #[divan::bench]
    fn trilinear(b: Bencher) {
        evaluate(b, Method::Trilinear, 1);
    }

    #[divan::bench]
    fn spline(b: Bencher) {
        evaluate(b, Method::Spline, 1);
    }

    #[divan::bench]
    fn lagrange_2x2x2(b: Bencher) {
        evaluate(b, Method::Lagrange(Order([2, 2, 2])), 1);
    }

    #[divan::bench]
    fn lagrange_4x4x4(b: Bencher) {
        evaluate(b, Method::Lagrange(Order([4, 4, 4])), 1);
    }

    #[divan::bench]
    fn fuzzy(b: Bencher) {
        evaluate(b, FUZZY, 1);
    }
}

#[divan::bench_group(sample_count = 20)]
mod points_all_threads {
    use super::*;

    #[divan::bench]
    fn trilinear(b: Bencher) {
        evaluate(b, Method::Trilinear, 0);
    }

    #[divan::bench]
    fn spline(b: Bencher) {
        evaluate(b, Method::Spline, 0);
    }

    #[divan::bench]
    fn lagrange_4x4x4(b: Bencher) {
        evaluate(b, Method::Lagrange(Order([4, 4, 4])), 0);
    }
}

/// Fit time on a 21³ table.
#[divan::bench(args = [21])]
fn fit_spline(b: Bencher, n: usize) {
    let grid = random_grid(n, 3);
    b.bench_local(|| Method::Spline.fit(black_box(&grid)).is_ok());
}

/// Gaussian-process fit (maximum likelihood, 9 starts) on 200 scattered nodes.
#[divan::bench(sample_count = 3, args = [200])]
fn gp_fit(b: Bencher, n: usize) {
    let points = gp_points(n);
    b.bench_local(|| Gp::fit(black_box(&points), &GpConfig::default()).is_ok());
}

/// The wire decoder alone (frames and statistics), bytes per second.
#[divan::bench(sample_count = 10)]
fn decode_frames(b: Bencher) {
    let capture = synthetic_capture(400_000);
    b.counter(BytesCount::new(capture.len())).bench_local(|| {
        let mut d = errmap_drivers::Decoder::new();
        d.push_with(black_box(&capture), &mut |_| {});
        d.finish().len()
    });
}

/// Frames to session rows (Edlén per ENV, unwrapping, row assembly), bytes per second.
#[divan::bench(sample_count = 10)]
fn decode_rows(b: Bencher) {
    let capture = synthetic_capture(400_000);
    b.counter(BytesCount::new(capture.len()))
        .bench_local(|| errmap_drivers::decode_all(black_box(&capture)).0.len());
}

/// Volumetric identification with the command line's default model (components as tables
/// at knots, smoothing by REML), with σ and identifiability.
#[divan::bench(sample_count = 5)]
fn volumetric_identify_default(b: Bencher) {
    let (_, table) = errmap::bench::volumetric_campaign(1);
    let config = errmap::bench::volumetric_config(None);
    b.bench_local(|| errmap::volumetric::identify(black_box(&table), &config).is_ok());
}

/// Volumetric identification with polynomials of a fixed degree 3.
#[divan::bench(sample_count = 5)]
fn volumetric_identify_degree3(b: Bencher) {
    let (_, table) = errmap::bench::volumetric_campaign(1);
    let config = errmap::bench::volumetric_config(Some(3));
    b.bench_local(|| errmap::volumetric::identify(black_box(&table), &config).is_ok());
}

/// The error vector with σ at 41³ points from the default model, points per second.
#[divan::bench(sample_count = 5)]
fn volumetric_vector_map(b: Bencher) {
    let (_, table) = errmap::bench::volumetric_campaign(1);
    let id = errmap::volumetric::identify(&table, &errmap::bench::volumetric_config(None))
        .expect("the benchmark campaign identifies");
    let model = errmap::volumetric::Predictor::Fit(id.fit);
    let points = errmap::bench::volumetric_grid_points();
    b.counter(ItemsCount::new(points.len()))
        .bench_local(|| model.predict_grid(black_box(&points), [0.0; 3]).is_ok());
}
