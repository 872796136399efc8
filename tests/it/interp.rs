//! Known-answer tests for the interpolators (seeded; tolerances stated per test).

use approx::assert_relative_eq;
use errmap::interp::high_weight;
use errmap::interp::natural_second_derivatives;
use errmap::interp::{InterpError, Method, Order};
use errmap::table::{Axis, Grid};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Uneven, strictly increasing nodes in [0, 10].
fn nodes(rng: &mut StdRng, n: usize) -> Vec<f64> {
    let mut v = vec![0.0];
    for _ in 1..n {
        let last = *v.last().expect("non-empty");
        v.push(last + rng.random_range(0.5..2.5));
    }
    v
}

fn poly(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
}

#[test]
fn lagrange_reproduces_polynomials_of_its_degree_exactly() {
    let mut rng = StdRng::seed_from_u64(1);
    for (shape, order) in [
        ([6, 5, 4], [2, 3, 1]),
        ([6, 5, 4], [5, 4, 3]),
        ([7, 3, 4], [3, 2, 0]),
        ([4, 4, 4], [0, 0, 0]),
        ([9, 2, 3], [4, 1, 2]),
        // Degrees 6 and 7 (the small-buffer path's general weights), 9 (the wide buffers).
        ([8, 9, 3], [6, 7, 2]),
        ([10, 3, 3], [9, 2, 1]),
    ] {
        let (xs, ys, zs) = (
            nodes(&mut rng, shape[0]),
            nodes(&mut rng, shape[1]),
            nodes(&mut rng, shape[2]),
        );
        // A sum of products of per-axis polynomials of degree ≤ order on each axis.
        let terms: Vec<[Vec<f64>; 3]> = (0..3)
            .map(|_| {
                [0, 1, 2].map(|a| {
                    (0..=order[a])
                        .map(|_| rng.random_range(-1.0..1.0))
                        .collect()
                })
            })
            .collect();
        let f = |p: [f64; 3]| -> f64 {
            terms
                .iter()
                .map(|t| poly(&t[0], p[0]) * poly(&t[1], p[1]) * poly(&t[2], p[2]))
                .sum()
        };
        let grid = Grid::from_fn(xs.clone(), ys.clone(), zs.clone(), f);
        let model = Method::Lagrange(Order(order))
            .fit(&grid)
            .expect("admissible");
        // Rounding scales with the data, not with a result that may cancel to near zero.
        let scale = grid.values.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for _ in 0..300 {
            // Inside and up to 20 % beyond the ends (extrapolation uses the end window).
            let p = [&xs, &ys, &zs].map(|v| {
                let (lo, hi) = (v[0], v[v.len() - 1]);
                rng.random_range(lo - 0.2 * (hi - lo)..hi + 0.2 * (hi - lo))
            });
            let (got, want) = (model.predict(p), f(p));
            assert!(
                (got - want).abs() <= 1e-9 * scale,
                "order {order:?} at {p:?}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn lagrange_degree_zero_is_nearest_node_and_too_high_is_refused() {
    let grid = Grid::from_fn(vec![0.0, 1.0, 2.0], vec![0.0, 1.0], vec![0.0, 1.0], |p| {
        p[0] * 10.0
    });
    let m = Method::Lagrange(Order([0, 0, 0]))
        .fit(&grid)
        .expect("degree 0 allowed");
    assert_eq!(m.predict([0.4, 0.2, 0.2]), 0.0);
    assert_eq!(m.predict([0.6, 0.2, 0.2]), 10.0);
    assert_eq!(m.predict([1.7, 0.2, 0.2]), 20.0);
    let err = Method::Lagrange(Order([3, 1, 1]))
        .fit(&grid)
        .expect_err("3 nodes carry degree 2 at most");
    assert_eq!(
        err,
        InterpError::OrderTooHigh {
            axis: Axis::X,
            order: 3,
            nodes: 3
        }
    );
    assert!(
        err.to_string().contains("highest admissible degree is 2"),
        "{err}"
    );
}

#[test]
fn lagrange_window_follows_the_query() {
    // Degree 1 on 5 nodes uses the cell around the query: piecewise linear, i.e. trilinear.
    let mut rng = StdRng::seed_from_u64(7);
    let xs = nodes(&mut rng, 5);
    let grid = Grid::from_fn(xs.clone(), vec![0.0, 1.0], vec![0.0, 1.0], |p| {
        (p[0] * 1.3).sin() + p[1]
    });
    let lin = Method::Lagrange(Order([1, 1, 1])).fit(&grid).expect("fits");
    let tri = Method::Trilinear.fit(&grid).expect("fits");
    for _ in 0..100 {
        let p = [
            rng.random_range(xs[0]..xs[4]),
            rng.random_range(0.0..1.0),
            0.5,
        ];
        assert_relative_eq!(lin.predict(p), tri.predict(p), epsilon = 1e-12);
    }
    // Degree 2 near node 2 uses nodes 1..=3: a field that is quadratic there but not
    // elsewhere is reproduced exactly around node 2.
    let q = |x: f64| {
        if (xs[1]..=xs[3]).contains(&x) {
            x * x
        } else {
            100.0
        }
    };
    let grid = Grid::from_fn(xs.clone(), vec![0.0, 1.0], vec![0.0, 1.0], |p| q(p[0]));
    let m = Method::Lagrange(Order([2, 0, 0])).fit(&grid).expect("fits");
    let x = xs[2] + 0.1 * (xs[3] - xs[2]);
    assert_relative_eq!(m.predict([x, 0.0, 0.0]), x * x, epsilon = 1e-9);
}

#[test]
fn trilinear_reproduces_affine_fields_including_extrapolation() {
    let mut rng = StdRng::seed_from_u64(2);
    let (xs, ys, zs) = (nodes(&mut rng, 5), nodes(&mut rng, 3), nodes(&mut rng, 4));
    let f = |p: [f64; 3]| 0.7 - 1.3 * p[0] + 2.1 * p[1] + 0.4 * p[2];
    let grid = Grid::from_fn(xs, ys, zs, f);
    let m = Method::Trilinear.fit(&grid).expect("fits");
    for _ in 0..500 {
        let p = [0, 1, 2].map(|_| rng.random_range(-20.0..30.0));
        assert_relative_eq!(m.predict(p), f(p), epsilon = 1e-9, max_relative = 1e-12);
    }
    // Extrapolation is flagged.
    assert!(m.outside([-1.0, 1.0, 1.0]));
    assert!(!m.outside([1.0, 1.0, 1.0]));
}

#[test]
fn spline_reproduces_linear_fields_everywhere() {
    let mut rng = StdRng::seed_from_u64(3);
    let (xs, ys, zs) = (nodes(&mut rng, 6), nodes(&mut rng, 3), nodes(&mut rng, 2));
    let f = |p: [f64; 3]| -0.2 + 0.9 * p[0] - 1.7 * p[1] + 0.3 * p[2];
    let grid = Grid::from_fn(xs, ys, zs, f);
    let m = Method::Spline.fit(&grid).expect("fits");
    for _ in 0..500 {
        let p = [0, 1, 2].map(|_| rng.random_range(-20.0..30.0));
        assert_relative_eq!(m.predict(p), f(p), epsilon = 1e-9, max_relative = 1e-12);
    }
}

/// Independent reference: the natural cubic spline as 4(n−1) polynomial coefficients
/// solved densely from interpolation, C¹, C² and natural end conditions.
fn dense_natural_spline(x: &[f64], y: &[f64]) -> impl Fn(f64) -> f64 {
    let n = x.len();
    let k = 4 * (n - 1);
    let mut a = DMatrix::<f64>::zeros(k, k);
    let mut b = DVector::<f64>::zeros(k);
    let mut row = 0;
    // Piece i: c0 + c1 t + c2 t² + c3 t³, t = x − x_i.
    for i in 0..n - 1 {
        let h = x[i + 1] - x[i];
        a[(row, 4 * i)] = 1.0;
        b[row] = y[i];
        row += 1;
        for p in 0..4 {
            a[(row, 4 * i + p)] = h.powi(p as i32);
        }
        b[row] = y[i + 1];
        row += 1;
        if i + 1 < n - 1 {
            // C¹: c1 + 2c2 h + 3c3 h² − c1' = 0; C²: 2c2 + 6c3 h − 2c2' = 0.
            a[(row, 4 * i + 1)] = 1.0;
            a[(row, 4 * i + 2)] = 2.0 * h;
            a[(row, 4 * i + 3)] = 3.0 * h * h;
            a[(row, 4 * (i + 1) + 1)] = -1.0;
            row += 1;
            a[(row, 4 * i + 2)] = 2.0;
            a[(row, 4 * i + 3)] = 6.0 * h;
            a[(row, 4 * (i + 1) + 2)] = -2.0;
            row += 1;
        }
    }
    a[(row, 2)] = 2.0;
    row += 1;
    let h = x[n - 1] - x[n - 2];
    a[(row, 4 * (n - 2) + 2)] = 2.0;
    a[(row, 4 * (n - 2) + 3)] = 6.0 * h;
    let c = a.lu().solve(&b).expect("non-singular");
    let x = x.to_vec();
    move |q: f64| {
        let i = x
            .partition_point(|&v| v <= q)
            .saturating_sub(1)
            .min(x.len() - 2);
        let t = q - x[i];
        (0..4).map(|p| c[4 * i + p] * t.powi(p as i32)).sum()
    }
}

#[test]
fn spline_matches_dense_1d_natural_spline_reference() {
    let mut rng = StdRng::seed_from_u64(4);
    for n in [3, 4, 7, 12] {
        let xs = nodes(&mut rng, n);
        let ys: Vec<f64> = xs.iter().map(|_| rng.random_range(-3.0..3.0)).collect();
        let reference = dense_natural_spline(&xs, &ys);
        // Second derivatives from the tridiagonal solver vs the dense fit's 2·c2.
        let m = natural_second_derivatives(&xs, &ys);
        assert_eq!(m[0], 0.0);
        assert_eq!(m[n - 1], 0.0);
        // As a 3-D spline with the field depending on x only, and separably on x·g(y).
        let yv = ys.clone();
        let xv = xs.clone();
        let lookup = move |x: f64| yv[xv.iter().position(|&v| v == x).expect("node")];
        let grid = Grid::from_fn(xs.clone(), vec![0.0, 2.0], vec![0.0, 1.0, 3.0], |p| {
            lookup(p[0]) * (1.0 + p[1])
        });
        let s = Method::Spline.fit(&grid).expect("fits");
        for _ in 0..200 {
            let x = rng.random_range(xs[0]..xs[n - 1]);
            let y = rng.random_range(0.0..2.0);
            let want = reference(x) * (1.0 + y);
            assert_relative_eq!(
                s.predict([x, y, 1.7]),
                want,
                epsilon = 1e-9,
                max_relative = 1e-9
            );
        }
    }
}

#[test]
fn spline_extrapolates_along_the_end_tangent() {
    let xs = vec![0.0, 1.0, 2.5, 3.0, 5.0];
    let ys = [0.0, 2.0, -1.0, 0.5, 1.0];
    let reference = dense_natural_spline(&xs, &ys);
    let grid = Grid::from_fn(xs.clone(), vec![0.0, 1.0], vec![0.0, 1.0], |p| {
        ys[xs.iter().position(|&v| v == p[0]).expect("node")]
    });
    let s = Method::Spline.fit(&grid).expect("fits");
    let h = 1e-6;
    let slope_hi = (reference(5.0) - reference(5.0 - h)) / h;
    let slope_lo = (reference(h) - reference(0.0)) / h;
    assert_relative_eq!(
        s.predict([7.0, 0.5, 0.5]),
        1.0 + 2.0 * slope_hi,
        epsilon = 1e-5
    );
    assert_relative_eq!(s.predict([-1.5, 0.5, 0.5]), -1.5 * slope_lo, epsilon = 1e-5);
}

#[test]
fn fuzzy_weights_are_the_normalised_gaussian_memberships() {
    for sigma in [0.1f64, 0.3, 0.5, 1.0, 3.0] {
        let k = 1.0 / (2.0 * sigma * sigma);
        for u in [-0.5f64, 0.0, 0.1, 0.37, 0.5, 0.8, 1.0, 1.4] {
            let lo: f64 = (-(u * u) / (2.0 * sigma * sigma)).exp();
            let hi: f64 = (-((1.0 - u) * (1.0 - u)) / (2.0 * sigma * sigma)).exp();
            assert_relative_eq!(high_weight(u, k), hi / (lo + hi), epsilon = 1e-12);
            // The low weight is 1 − high: the two sum to one.
            assert_relative_eq!(
                high_weight(u, k) + high_weight(1.0 - u, k),
                1.0,
                epsilon = 1e-12
            );
        }
    }
}

#[test]
fn fuzzy_limits_nearest_corner_and_cell_mean_and_finite_far_away() {
    let mut rng = StdRng::seed_from_u64(5);
    let grid = Grid::from_fn(
        vec![0.0, 20.0, 40.0],
        vec![0.0, 20.0],
        vec![0.0, 20.0],
        |_| rng.random_range(-0.05..0.05),
    );
    let corners: Vec<f64> = (0..8)
        .map(|c| grid.value(c & 1, (c >> 1) & 1, (c >> 2) & 1))
        .collect();
    let sharp = Method::Fuzzy { sigma: 0.01 }.fit(&grid).expect("fits");
    // Near corner (0,0,0) of the first cell: its value.
    assert_relative_eq!(sharp.predict([3.0, 4.0, 2.0]), corners[0], epsilon = 1e-12);
    assert_relative_eq!(
        sharp.predict([17.0, 16.0, 18.0]),
        corners[7],
        epsilon = 1e-12
    );
    let flat = Method::Fuzzy { sigma: 1e4 }.fit(&grid).expect("fits");
    let mean = corners.iter().sum::<f64>() / 8.0;
    assert_relative_eq!(flat.predict([3.0, 4.0, 2.0]), mean, epsilon = 1e-8);
    let default = Method::Fuzzy { sigma: 0.5 }.fit(&grid).expect("fits");
    for p in [[1e9, -1e9, 1e12], [-1e300, 1e300, 0.0], [500.0, 10.0, 10.0]] {
        let v = default.predict(p);
        assert!(v.is_finite(), "{p:?} → {v}");
        assert!(default.outside(p));
    }
    // Far beyond x = 40 all x weight is on the end node x = 40; along y and z (at the
    // nodes y = 0, z = 0) the far side keeps the σ = 0.5 weight 1/(1 + e²).
    let far = default.predict([1e6, 0.0, 0.0]);
    let w_far = high_weight(0.0, 2.0);
    assert_relative_eq!(w_far, 1.0 / (1.0 + 2f64.exp()), epsilon = 1e-12);
    let w = [1.0 - w_far, w_far];
    let mut expected = 0.0;
    for j in 0..2 {
        for k in 0..2 {
            expected += w[j] * w[k] * grid.value(2, j, k);
        }
    }
    assert_relative_eq!(far, expected, epsilon = 1e-12);
    assert!(matches!(
        Method::Fuzzy { sigma: 0.0 }.fit(&grid),
        Err(InterpError::BadSigma { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Interpolating methods return the node value at every node.
    #[test]
    fn prediction_at_a_node_is_the_node_value(seed in 0u64..10_000, nx in 2usize..6, ny in 2usize..5, nz in 2usize..5) {
        let mut rng = StdRng::seed_from_u64(seed);
        let (xs, ys, zs) = (nodes(&mut rng, nx), nodes(&mut rng, ny), nodes(&mut rng, nz));
        let grid = Grid::from_fn(xs, ys, zs, |_| rng.random_range(-5.0..5.0));
        let order = Order([rng.random_range(0..nx), rng.random_range(0..ny), rng.random_range(0..nz)]);
        for method in [Method::Trilinear, Method::Spline, Method::Lagrange(order)] {
            let m = method.fit(&grid).expect("fits");
            for p in grid.points() {
                let got = m.predict(p.position());
                prop_assert!((got - p.e_um).abs() < 1e-9, "{} at {:?}: {} vs {}", method.label(), p.position(), got, p.e_um);
            }
        }
    }
}

/// On evenly spaced nodes (the O(1) cell lookup) trilinear reproduces affine fields,
/// inside the grid and beyond it, and fuzzy gives the corners' mean at cell centres.
#[test]
fn cell_methods_are_exact_on_even_grids() {
    let even = |x0: f64, h: f64, n: usize| (0..n).map(|i| x0 + h * i as f64).collect::<Vec<_>>();
    let f = |p: [f64; 3]| 0.3 + 0.01 * p[0] - 0.02 * p[1] + 0.005 * p[2];
    let (xs, ys, zs) = (
        even(1.2424, 200.0, 5),
        even(1.0, 133.0, 4),
        even(200.0, 150.0, 3),
    );
    let grid = Grid::from_fn(xs.clone(), ys.clone(), zs.clone(), f);
    let mut rng = StdRng::seed_from_u64(3);
    let tri = Method::Trilinear.fit(&grid).expect("fits");
    for _ in 0..500 {
        let p = [
            rng.random_range(-100.0..900.0),
            rng.random_range(-50.0..450.0),
            rng.random_range(150.0..550.0),
        ];
        let (got, want) = (tri.predict(p), f(p));
        assert!(
            (got - want).abs() < 1e-9,
            "trilinear at {p:?}: {got} vs {want}"
        );
    }
    let fuzzy = Method::Fuzzy { sigma: 0.5 }.fit(&grid).expect("fits");
    let mid = |v: &[f64], i: usize| 0.5 * (v[i] + v[i + 1]);
    for (i, j, k) in [(0, 0, 0), (3, 2, 1), (1, 1, 0)] {
        let p = [mid(&xs, i), mid(&ys, j), mid(&zs, k)];
        // Equal weights on the 8 corners: their mean, which for an affine field is f(p).
        assert!((fuzzy.predict(p) - f(p)).abs() < 1e-9, "fuzzy at {p:?}");
    }
}

#[test]
fn uniform_locator_agrees_with_binary_search() {
    use errmap::interp::Locator;
    use errmap::table::interval;
    let mut rng = StdRng::seed_from_u64(11);
    for n in [2usize, 3, 7, 41] {
        let nodes: Vec<f64> = (0..n).map(|i| 1.2424 + i as f64 * 20.0).collect();
        let loc = Locator::new(&nodes);
        for _ in 0..2000 {
            let x = rng.random_range(-100.0..(n as f64) * 20.0 + 100.0);
            let near_node = nodes.iter().any(|v| (v - x).abs() < 1e-9);
            if !near_node {
                assert_eq!(loc.interval(x), interval(&nodes, x), "n {n}, x {x}");
            }
        }
        // Exactly at a node both conventions give the same interpolated value; the cell
        // position is then 0 or 1.
        for &x in &nodes {
            let (i, u) = loc.cell(x).expect("n ≥ 2");
            assert!((nodes[i] + u * (nodes[i + 1] - nodes[i]) - x).abs() < 1e-9);
        }
    }
}
