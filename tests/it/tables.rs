//! Error-table reading and validation: every bad input gets an error naming the file,
//! the row and the column (or the node), and good tables round-trip through CSV and
//! Parquet.

use std::path::PathBuf;

use errmap::table::{ErrorPoint, ErrorTable, TableError};

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, text).expect("write temp file");
    p
}

const GOOD: &str = "x_mm,y_mm,z_mm,e_um\n0,0,0,1\n10,0,0,2\n0,5,0,3\n10,5,0,4\n0,0,7,5\n10,0,7,6\n0,5,7,7\n10,5,7,8\n";

fn read_err(text: &str) -> (TableError, String) {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = write(&dir, "t.csv", text);
    let e = ErrorTable::read(&p)
        .and_then(|t| t.grid().map(|_| t))
        .expect_err("must fail");
    let msg = e.to_string();
    assert!(msg.contains("t.csv"), "message names the file: {msg}");
    (e, msg)
}

#[test]
fn good_table_forms_a_grid() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = write(&dir, "t.csv", GOOD);
    let grid = ErrorTable::read(&p).expect("reads").grid().expect("grid");
    assert_eq!(grid.shape(), [2, 2, 2]);
    assert_eq!(grid.value(1, 1, 1), 8.0);
}

#[test]
fn missing_column_is_named() {
    let (e, msg) = read_err("x_mm,y_mm,e_um\n0,0,1\n");
    assert!(
        matches!(e, TableError::MissingColumn { ref column, .. } if column == "z_mm"),
        "{msg}"
    );
    assert!(msg.contains("z_mm"));
}

#[test]
fn non_numeric_cell_names_row_and_column() {
    let text = GOOD.replace("10,5,0,4", "10,5,0,abc");
    let (e, msg) = read_err(&text);
    assert!(
        matches!(e, TableError::NotNumeric { row: 4, line: 5, ref column, .. } if column == "e_um"),
        "{msg}"
    );
    assert!(
        msg.contains("row 4") && msg.contains("`e_um`") && msg.contains("abc"),
        "{msg}"
    );
}

#[test]
fn nan_and_inf_are_rejected_with_position() {
    for bad in ["NaN", "inf", "-inf"] {
        let text = GOOD.replace("0,5,7,7", &format!("0,5,{bad},7"));
        let (e, msg) = read_err(&text);
        assert!(
            matches!(e, TableError::NonFinite { row: 7, ref column, .. } if column == "z_mm"),
            "{bad}: {msg}"
        );
    }
}

#[test]
fn empty_required_cell_is_rejected() {
    let text = GOOD.replace("10,0,7,6", "10,0,7,");
    let (e, msg) = read_err(&text);
    assert!(
        matches!(e, TableError::EmptyCell { row: 6, ref column, .. } if column == "e_um"),
        "{msg}"
    );
}

#[test]
fn duplicate_node_names_both_rows() {
    let text = format!("{GOOD}10,0,7,9\n");
    let (e, msg) = read_err(&text);
    assert!(
        matches!(
            e,
            TableError::DuplicateNode {
                row: 9,
                first_row: 6,
                ..
            }
        ),
        "{msg}"
    );
    assert!(msg.contains("(10, 0, 7)"), "{msg}");
}

#[test]
fn scattered_nodes_name_the_missing_grid_node() {
    let text = GOOD.replace("10,5,7,8\n", "");
    let (e, msg) = read_err(&text);
    assert!(
        matches!(e, TableError::MissingNode { x, y, z, .. } if (x, y, z) == (10.0, 5.0, 7.0)),
        "{msg}"
    );
    assert!(
        msg.contains("(10, 5, 7)") && msg.contains("7 of 8"),
        "{msg}"
    );
    // Several missing: the first five are named, then an ellipsis.
    let header = "x_mm,y_mm,z_mm,e_um\n";
    let mut rows = String::from(header);
    for (i, x) in [0.0, 10.0, 20.0, 30.0].iter().enumerate() {
        for z in [0.0, 7.0] {
            rows.push_str(&format!("{x},{},{z},1\n", 5 * i));
        }
    }
    // 8 nodes on a 4 × 4 × 2 grid of 32: 24 missing.
    let (e, msg) = read_err(&rows);
    let TableError::MissingNode {
        more,
        present,
        expected,
        ..
    } = &e
    else {
        panic!("{msg}");
    };
    assert_eq!((more.len(), *present, *expected), (4, 8, 32), "{msg}");
    assert!(
        msg.contains(
            "nodes (10, 0, 0), (20, 0, 0), (30, 0, 0), (0, 5, 0), (20, 5, 0), … mm are missing"
        ) && msg.contains("8 of 32"),
        "{msg}"
    );
}

/// A table measured on one line (y and z fixed) is a grid with single-node axes: every
/// method is constant along them and interpolates along x; a single node is refused.
#[test]
fn a_single_line_is_a_grid_and_a_single_node_is_refused() {
    use errmap::interp::{Method, Order};
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "line.csv",
        "x_mm,y_mm,z_mm,e_um\n0,5,7,1\n100,5,7,3\n200,5,7,2\n300,5,7,6\n",
    );
    let table = ErrorTable::read(&path).expect("reads");
    let grid = table.grid().expect("a line is a grid");
    assert_eq!(grid.shape(), [4, 1, 1]);
    for method in [
        Method::Trilinear,
        Method::Spline,
        Method::Lagrange(Order([3, 0, 0])),
    ] {
        let m = method.fit(&grid).expect("fits");
        // Through the nodes, and linear between the first two for trilinear.
        assert!(
            (m.predict([100.0, 5.0, 7.0]) - 3.0).abs() < 1e-12,
            "{}",
            method.label()
        );
        assert!(
            m.outside([100.0, 6.0, 7.0]),
            "off the line is an extrapolation"
        );
        assert!(!m.outside([150.0, 5.0, 7.0]));
    }
    let tri = Method::Trilinear.fit(&grid).expect("fits");
    assert!((tri.predict([50.0, 5.0, 7.0]) - 2.0).abs() < 1e-12);
    // Higher degree than the line's 4 nodes allow, or any degree across the line: refused.
    assert!(Method::Lagrange(Order([4, 0, 0])).fit(&grid).is_err());
    assert!(Method::Lagrange(Order([1, 1, 0])).fit(&grid).is_err());

    let (e, msg) = read_err("x_mm,y_mm,z_mm,e_um\n0,0,0,1\n");
    assert!(
        matches!(e, TableError::TooFewNodes { count: 1, .. }),
        "{msg}"
    );
}

#[test]
fn empty_table_and_missing_file_and_bad_extension() {
    let (e, _) = read_err("x_mm,y_mm,z_mm,e_um\n");
    assert!(matches!(e, TableError::Empty { .. }), "{e}");
    let e = ErrorTable::read(std::path::Path::new("/nonexistent/t.csv")).expect_err("missing");
    assert!(matches!(e, TableError::File(_)) && e.to_string().contains("/nonexistent/t.csv"));
    let e = ErrorTable::read(std::path::Path::new("t.xlsx")).expect_err("extension");
    assert!(matches!(e, TableError::Extension { .. }));
}

#[test]
fn malformed_csv_is_an_error_not_a_panic() {
    let (e, msg) = read_err("x_mm,y_mm,z_mm,e_um\n0,0,0,1,7,8\n\"unterminated\n");
    assert!(
        matches!(
            e,
            TableError::Format { .. }
                | TableError::NotNumeric { .. }
                | TableError::TooFewNodes { .. }
        ),
        "{msg}"
    );
}

#[test]
fn csv_and_parquet_round_trip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut pts = vec![
        ErrorPoint::new(1.2424, 1.0, 200.0, -8.5e-5),
        ErrorPoint::new(800.0, 400.0, 500.0, 0.051548),
    ];
    pts[0].n = Some(10);
    pts[0].s_um = Some(0.25);
    let t = ErrorTable::from_points("memory", pts.clone());
    for name in ["rt.csv", "rt.parquet"] {
        let p = dir.path().join(name);
        t.write(&p).expect("writes");
        let back = ErrorTable::read(&p).expect("reads back");
        assert_eq!(back.points, pts, "{name}");
    }
}

#[test]
fn extra_columns_are_kept_and_ignored() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = write(
        &dir,
        "t.csv",
        "x_mm,y_mm,z_mm,e_um,note,paper_4x1x2\n0,0,0,1,hello,0.5\n",
    );
    let t = ErrorTable::read(&p).expect("reads");
    assert_eq!(
        t.extra_column("paper_4x1x2").expect("kept").values,
        vec![Some(0.5)]
    );
}
