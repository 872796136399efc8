//! `export` of a rotary session or table as a modulo table, through the command line.

use super::{every_45, rotary_csv, rotary_session};
use crate::util::{errmap, json, s, stderr, tempdir};

#[test]
fn a_rotary_session_exports_a_siemens_modulo_table_with_its_report() {
    let dir = tempdir();
    // 8″ eccentricity and a 30 ppm ratio error (38.88″ at 360).
    let csv = rotary_csv(dir.path(), "r.csv", &every_45(), 3, &|t, _, _| {
        8.0 * t.to_radians().sin() + 30.0 * t * 3.6e-3
    });
    let session = rotary_session(&csv, dir.path().join("s.csv"), "a");
    let table = dir.path().join("t.csv");
    assert!(
        errmap(&["table", s(&session), "--out", s(&table)])
            .status
            .success()
    );
    for input in [&session, &table] {
        let out = dir.path().join("a.spf");
        let _ = std::fs::remove_file(&out);
        let o = errmap(&[
            "export",
            s(input),
            "--format",
            "siemens",
            "--step",
            "45",
            "--out",
            s(&out),
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let j = json(&o);
        assert_eq!(j["format"], "siemens");
        assert_eq!(j["axis"], "A");
        assert_eq!(j["points"], 9);
        assert_eq!(j["step_deg"], 45.0);
        assert!((j["closure_gap_arcsec"].as_f64().expect("present") - 38.88).abs() < 1e-6);
        assert!((j["ratio_ppm"].as_f64().expect("present") - 30.0).abs() < 1e-6);
        assert!(j["max_residual_arcsec"].as_f64().expect("present") < 1e-6);
        assert!(
            j["warnings"][0]
                .as_str()
                .expect("present")
                .contains("correct the ratio")
        );
        let text = std::fs::read_to_string(&out).expect("present");
        assert!(text.contains("$AA_ENC_COMP_IS_MODULO[0,A1]=1"), "{text}");
    }
    let out = dir.path().join("x.ngc");
    for (extra, code) in [
        (&["--format", "linuxcnc", "--method", "trilinear"][..], 2),
        (&["--format", "grid"][..], 2),
        (&["--format", "isg"][..], 2),
        (&["--format", "siemens", "--step", "7"][..], 2),
        (
            &[
                "--format",
                "fanuc",
                "--step",
                "45",
                "--detection-unit-um",
                "2",
            ][..],
            2,
        ),
    ] {
        let mut a = vec!["export", s(&table), "--out", s(&out)];
        a.extend_from_slice(extra);
        let o = errmap(&a);
        assert_eq!(o.status.code(), Some(code), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists());
    }
}
