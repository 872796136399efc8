//! Table 1 → Table 2 replay (Zhang Mei 2013): the paper's 4×1×2 column to 1e-4 µm.

use std::path::Path;

use errmap::interp::{InterpError, Method, Order};
use errmap::table::{Axis, ErrorTable};

fn table(name: &str) -> ErrorTable {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("datasets")
        .join(name);
    ErrorTable::read(&path).expect("dataset reads")
}

/// Row 6 of Table 2 prints z = 129.376, but the paper's 0.1049 needs z = 129.3769 like
/// rows 1 and 5 (the printed value gives 0.1048). This test uses 129.3769 for row 6 and
/// checks separately that the printed value gives 0.1048.
#[test]
fn lagrange_4x1x2_reproduces_paper_column_to_1e4_um() {
    let grid = table("table1.csv").grid().expect("Table 1 is a 5×2×3 grid");
    assert_eq!(grid.shape(), [5, 2, 3]);
    let model = Method::Lagrange(Order([4, 1, 2]))
        .fit(&grid)
        .expect("4×1×2 fits");
    let test = table("table2.csv");
    let paper = test
        .extra_column("paper_4x1x2")
        .expect("paper column present");
    assert_eq!(test.points.len(), 7);
    for (row, (p, expected)) in test.points.iter().zip(&paper.values).enumerate() {
        let mut pos = p.position();
        if row == 5 {
            assert_eq!(pos[2], 129.376, "row 6 keeps the printed z");
            pos[2] = 129.3769;
        }
        let expected = expected.expect("paper value present");
        let got = model.predict(pos);
        assert!(
            (got - expected).abs() <= 1e-4 + 1e-12,
            "row {}: ours {got:.6} paper {expected}",
            row + 1
        );
    }
    // The printed z of row 6 gives 0.1048, a last-digit difference.
    let printed = model.predict(test.points[5].position());
    assert!(
        (printed - 0.1048).abs() < 5e-5,
        "printed-z row 6 gives {printed}"
    );
}

#[test]
fn paper_orders_needing_unpublished_nodes_are_refused() {
    let grid = table("table1.csv").grid().expect("grid");
    for (order, axis, needed_nodes) in [
        (Order([2, 4, 4]), Axis::Y, 2),
        (Order([2, 5, 4]), Axis::Y, 2),
        (Order([4, 1, 4]), Axis::Z, 3),
    ] {
        let err = Method::Lagrange(order).fit(&grid).expect_err("must refuse");
        match &err {
            InterpError::OrderTooHigh { axis: a, nodes, .. } => {
                assert_eq!(*a, axis, "{order}");
                assert_eq!(*nodes, needed_nodes, "{order}");
            }
            other => panic!("{order}: unexpected error {other}"),
        }
        let msg = err.to_string();
        assert!(msg.contains("nodes"), "{msg}");
    }
}

/// Every model in `compare` has an uncertainty: the GP its own, the interpolators their
/// cross-validated RMS — the end-plane folds' for extrapolated test points, the interior
/// folds' for the others — recomputed here fold by fold.
#[test]
fn interpolators_get_their_cross_validated_rms_as_sigma() {
    use errmap::evaluate::{SigmaKind, compare};
    let t1 = table("table1.csv");
    let t2 = table("table2.csv");
    let grid = t1.grid().expect("grid");
    let methods = [
        Method::Trilinear,
        Method::Gp(errmap::interp::Kernel::Matern52),
    ];
    let c = compare(&t1, &grid, &t2, &methods).expect("compares");
    let tri = &c.rows[0];
    assert_eq!(tri.sigma_kind, Some(SigmaKind::CrossValidation));
    // The folds by hand: drop each plane, fit trilinear to the rest, predict the plane.
    let (mut inner_sq, mut outer_sq) = (Vec::new(), Vec::new());
    let shape = grid.shape();
    for (a, &n) in shape.iter().enumerate() {
        for plane in 0..n {
            let model = Method::Trilinear
                .fit(&grid.without_plane(a, plane))
                .expect("fold fits");
            let coord = grid.axis(a)[plane];
            for p in t1.points.iter().filter(|p| p.position()[a] == coord) {
                let r2 = (model.predict(p.position()) - p.e_um).powi(2);
                if plane == 0 || plane + 1 == n {
                    outer_sq.push(r2);
                } else {
                    inner_sq.push(r2);
                }
            }
        }
    }
    let rms = |v: &[f64]| (v.iter().sum::<f64>() / v.len() as f64).sqrt();
    let (inner, outer) = (rms(&inner_sq), rms(&outer_sq));
    assert!(outer > inner, "extrapolating is worse: {outer} vs {inner}");
    for (k, s) in tri.sigmas.iter().enumerate() {
        let want = if c.extrapolated[k] { outer } else { inner };
        let got = s.expect("a σ for every point");
        assert!(
            (got - want).abs() < 1e-12,
            "test point {}: {got} vs {want}",
            k + 1
        );
    }
    let gp = &c.rows[1];
    assert_eq!(gp.sigma_kind, Some(SigmaKind::Model));
    assert!(
        gp.sigmas
            .iter()
            .all(|s| s.is_some_and(|s| s > 0.0 && s != inner))
    );
}
