//! The measurement-uncertainty budget: known answers worked out by hand, the Edlén
//! sensitivities against the equation differentiated by hand, validation, and the budget
//! in `table --json`.

use errmap::drivers::SessionRow;
use errmap::drivers::edlen::{refractive_index, saturation_vapour_pressure_pa};
use errmap::drivers::frame::Axis as WireAxis;
use errmap::session::{
    Budget, DeclaredConditions, Eve, Origin, RecordedResolution, Resolution, TestConditions,
    UncertaintyConfig, UncertaintyError, edlen_sensitivities,
};

const HENE_UM: f64 = 0.632_991_354;

/// A configuration with every term zero, to switch terms on one at a time.
fn zero() -> UncertaintyConfig {
    UncertaintyConfig {
        k: 2.0,
        wavelength_ppm: 0.0,
        edlen_equation_ppm: 0.0,
        air_temp_k: 0.0,
        air_pressure_hpa: 0.0,
        air_rh_pct: 0.0,
        material_temp_k: 0.0,
        expansion_ppm_per_k: 0.0,
        expansion_u_ppm_per_k: 0.0,
        misalignment_urad: 0.0,
        dead_path_mm: 0.0,
        air_temp_drift_k: 0.0,
        air_pressure_drift_hpa: 0.0,
        resolution_um: 0.0,
    }
}

/// Conditions with air sensors (standard air, no span of n) and a material sensor when
/// `material_temp_c` is given.
fn conditions(travel_mm: f64, material_temp_c: Option<f64>) -> TestConditions {
    let mut c = TestConditions::from_environment(&Default::default(), travel_mm);
    c.air = Origin::Sensor;
    c.material_temp_c = material_temp_c;
    c.material = if material_temp_c.is_some() {
        Origin::Sensor
    } else {
        Origin::Missing
    };
    c
}

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:.12}, want {want:.12}"
    );
}

/// By hand: wavelength 0.05 ppm; material sensor 0.1 K × α 10 ppm/K = 1 ppm; expansion
/// coefficient 0.5 ppm/K × |22 − 20| K = 1 ppm; resolution 1 µm → 1/(2√3) µm.
/// u_rel = √(0.05² + 1 + 1) = √2.0025 ppm; over 1000 mm that is √2.0025 µm.
/// u_read² = 1/12 µm². u_c(travel) = √(2.0025 + 2/12) = √2.1691666…, U = 2 u_c;
/// at one target u_c = √(1/6) = 0.408248…, U = 0.816497….
#[test]
fn budget_matches_hand_computation() -> Result<(), UncertaintyError> {
    let cfg = UncertaintyConfig {
        wavelength_ppm: 0.05,
        material_temp_k: 0.1,
        expansion_ppm_per_k: 10.0,
        expansion_u_ppm_per_k: 0.5,
        resolution_um: 1.0,
        ..zero()
    };
    let b = Budget::new(&cfg, conditions(1000.0, Some(22.0)))?;
    close(b.u_rel_ppm, 2.0025f64.sqrt(), 1e-12, "u_rel");
    close(b.u_read_um, 1.0 / 12f64.sqrt(), 1e-12, "u_read");
    let u = b.expanded();
    close(
        u.u_c_travel_um,
        2.169_166_666_666_667f64.sqrt(),
        1e-12,
        "u_c over the travel",
    );
    close(
        u.along_travel_um,
        2.0 * 2.169_166_666_666_667f64.sqrt(),
        1e-12,
        "U over the travel",
    );
    close(
        u.u_c_target_um,
        (1.0f64 / 6.0).sqrt(),
        1e-12,
        "u_c at one target",
    );
    // k·u_c = 0.816… µm is below one step of the 1 µm resolution: U is held at 1 µm.
    close(u.at_one_target_um, 1.0, 1e-12, "U at one target (floor)");
    // Each contribution by itself.
    let by_id = |id: &str| {
        b.contributions
            .iter()
            .find(|c| c.id == id)
            .map(|c| c.u)
            .unwrap_or(f64::NAN)
    };
    close(
        by_id("material_temp"),
        1.0,
        1e-12,
        "material temperature, ppm",
    );
    close(by_id("expansion"), 1.0, 1e-12, "expansion coefficient, ppm");
    close(by_id("wavelength"), 0.05, 1e-15, "wavelength, ppm");
    Ok(())
}

/// Cosine error by itself: θ = 1 mrad → θ²/(4√3) = 1e-6/6.9282… = 0.144338 ppm, so
/// 0.144338 µm over 1 m and nothing at one target.
#[test]
fn cosine_term_is_one_sided_rectangular() -> Result<(), UncertaintyError> {
    let cfg = UncertaintyConfig {
        misalignment_urad: 1000.0,
        ..zero()
    };
    let b = Budget::new(&cfg, conditions(1000.0, None))?;
    close(b.u_rel_ppm, 0.144_337_567_297_406, 1e-12, "u_rel");
    close(
        b.u_c_um(1000.0),
        0.144_337_567_297_406,
        1e-12,
        "u_c over 1 m",
    );
    close(b.u_c_um(0.0), 0.0, 1e-15, "at one target");
    Ok(())
}

/// No material temperature recorded or declared: neither the sensor term nor the
/// expansion term is invented; the budget lists them as not evaluated.
#[test]
fn no_material_temperature_is_not_invented() -> Result<(), UncertaintyError> {
    let cfg = UncertaintyConfig {
        material_temp_k: 0.2,
        expansion_ppm_per_k: 11.5,
        expansion_u_ppm_per_k: 1.0,
        ..zero()
    };
    let b = Budget::new(&cfg, conditions(500.0, None))?;
    close(b.u_rel_ppm, 0.0, 1e-15, "no material term");
    assert!(
        b.not_evaluated
            .iter()
            .any(|m| m.contains("material temperature")),
        "{:?}",
        b.not_evaluated
    );
    // Declared 19…21 °C: u(θ) = 2/(2√3) K, α·u(θ) = 11.5/√3 ppm; the midpoint is 20 °C,
    // so the expansion term is 0.
    let declared = DeclaredConditions {
        material_temp_c: Some([19.0, 21.0]),
        ..Default::default()
    };
    let b = Budget::new(&cfg, conditions(500.0, None).with_declared(&declared))?;
    close(b.u_rel_ppm, 11.5 / 3f64.sqrt(), 1e-12, "declared range");
    Ok(())
}

/// A session with no sensor at all (an imported sheet): no air term, no dead path, no
/// material term is invented; each is listed with its reason.
#[test]
fn a_session_without_sensors_gets_no_invented_sensors() -> Result<(), UncertaintyError> {
    let c = TestConditions::from_environment(&Default::default(), 100.0);
    assert_eq!((c.air, c.material), (Origin::Missing, Origin::Missing));
    let b = Budget::new(&UncertaintyConfig::default(), c)?;
    for id in [
        "air_temp",
        "air_pressure",
        "air_rh",
        "material_temp",
        "dead_path",
    ] {
        assert!(b.contributions.iter().all(|x| x.id != id), "{id} invented");
    }
    let text = b.not_evaluated.join("; ");
    for what in [
        "air temperature",
        "air pressure",
        "humidity",
        "dead path",
        "EVE",
    ] {
        assert!(text.contains(what), "{what} missing from {text}");
    }
    Ok(())
}

/// The GUM by hand with every source stated: a capture's laser count λ/8 = 0.0791 µm and
/// scale count 0.1 µm, a drift check of EVE 0.3 µm, and air declared as 19…21 °C,
/// 1000…1020 hPa, 40…60 %RH (rectangular). Reading terms r/√12 each; the air terms
/// |∂n/∂x|·w/(2√3) at the midpoints; u_c at one target = √2·u_read; U = 2·u_c.
#[test]
fn budget_with_stated_sources_matches_hand_computation() -> Result<(), UncertaintyError> {
    let declared = DeclaredConditions {
        air_temp_c: Some([19.0, 21.0]),
        air_pressure_hpa: Some([1000.0, 1020.0]),
        air_rh_pct: Some([40.0, 60.0]),
        ..Default::default()
    };
    let mut c =
        TestConditions::from_environment(&Default::default(), 1000.0).with_declared(&declared);
    assert_eq!(c.air, Origin::Declared);
    c.resolution = vec![
        Resolution {
            name: "laser count".into(),
            step_um: 0.079_123_919_25,
            source: "HELLO".into(),
        },
        Resolution {
            name: "scale count".into(),
            step_um: 0.1,
            source: "HELLO".into(),
        },
    ];
    c.eve = Some(Eve {
        range_um: 0.3,
        source: "drift check".into(),
    });
    let cfg = UncertaintyConfig {
        air_temp_k: 0.0, // sensor figures are not used for declared air
        ..zero()
    };
    let b = Budget::new(&cfg, c)?;
    let s = edlen_sensitivities(20.0, 1010.0, 50.0);
    let rect = |w: f64| w / (2.0 * 3f64.sqrt());
    let u_t = s.dn_dt_per_k.abs() * 1e6 * rect(2.0);
    let u_p = s.dn_dp_per_hpa.abs() * 1e6 * rect(20.0);
    let u_h = s.dn_drh_per_pct.abs() * 1e6 * rect(20.0);
    close(
        b.u_rel_ppm,
        (u_t * u_t + u_p * u_p + u_h * u_h).sqrt(),
        1e-12,
        "u_rel",
    );
    let u_read = ((0.079_123_919_25f64.powi(2) + 0.01 + 0.09) / 12.0).sqrt();
    close(b.u_read_um, u_read, 1e-12, "u_read");
    let u = b.expanded();
    close(
        u.at_one_target_um,
        2.0 * 2f64.sqrt() * u_read,
        1e-12,
        "U(R)",
    );
    assert!(u.at_one_target_um > 0.065, "{}", u.at_one_target_um);
    // Every contribution says where it comes from.
    assert!(b.contributions.iter().all(|x| !x.source.is_empty()));
    Ok(())
}

/// Repeatability-type figures never get a U below one step of the coarsest resolution:
/// the laser count alone gives k·√2·r/√12 = 0.0646 µm < r = 0.0791 µm, so U = r.
#[test]
fn resolution_floor_holds_u_at_one_step() -> Result<(), UncertaintyError> {
    let mut c = conditions(0.0, None);
    c.resolution = vec![Resolution {
        name: "laser count".into(),
        step_um: 0.0791,
        source: "HELLO".into(),
    }];
    let b = Budget::new(&zero(), c)?;
    let u = b.expanded();
    close(
        u.u_c_target_um * 2.0,
        2.0 * 2f64.sqrt() * 0.0791 / 12f64.sqrt(),
        1e-12,
        "k·u_c",
    );
    close(u.at_one_target_um, 0.0791, 1e-15, "held at one step");
    Ok(())
}

/// The step of recorded lengths: inches to 6 decimals (25.4 nm), mm to 3 decimals (1 µm),
/// and none for unquantised numbers.
#[test]
fn recorded_resolution_finds_the_written_step() {
    let of = |v: &[f64]| {
        let mut r = RecordedResolution::default();
        v.iter().for_each(|x| r.push(*x));
        r.step_um()
    };
    let inch = [0.000_055, -4.999_953, 129.999_871].map(|v| v * 25.4);
    let got = of(&inch).unwrap_or(f64::NAN);
    close(got, 0.0254, 1e-12, "inch export");
    close(
        of(&[1.001, 2.5, -3.125]).unwrap_or(f64::NAN),
        1.0,
        1e-12,
        "mm to 3 decimals",
    );
    assert_eq!(of(&[0.123_456_789_1, 1.0 / 3.0]), None);
}

/// The sensitivities against the modified Edlén equation differentiated by hand, at
/// RH = 0 (where the water term vanishes for T and p), and the humidity sensitivity,
/// which is exact because n is linear in RH.
#[test]
fn edlen_sensitivities_match_the_equation_differentiated_by_hand() {
    let s2 = 1.0 / (HENE_UM * HENE_UM);
    let n_s = (8342.54 + 2_406_147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2)) * 1e-8;
    for (t, p_hpa) in [(20.0, 1013.25), (23.5, 960.0), (18.0, 1040.0)] {
        let p = p_hpa * 100.0;
        let den = 1.0 + 0.003661 * t;
        let num = 1.0 + 1e-8 * (0.601 - 0.00972 * t) * p;
        // ∂/∂p of p·n_s/96095.43·num/den, per Pa; ×100 per hPa.
        let dn_dp = n_s / 96095.43 * (1.0 + 2e-8 * (0.601 - 0.00972 * t) * p) / den * 100.0;
        // ∂/∂t: quotient rule on num/den.
        let dn_dt = p * n_s / 96095.43 * ((-0.00972e-8 * p) * den - num * 0.003661) / (den * den);
        let s = edlen_sensitivities(t, p_hpa, 0.0);
        close(s.dn_dp_per_hpa, dn_dp, 1e-14, "∂n/∂p");
        close(s.dn_dt_per_k, dn_dt, 1e-13, "∂n/∂T");
        let dn_drh = -saturation_vapour_pressure_pa(t) / 100.0 * (3.7345 - 0.0401 * s2) * 1e-10;
        close(
            edlen_sensitivities(t, p_hpa, 50.0).dn_drh_per_pct,
            dn_drh,
            1e-15,
            "∂n/∂RH",
        );
    }
    // The rules of thumb of laser calibration: about −0.95 ppm/K (−0.93 dry, the water
    // term adds −0.03 at 50 %RH), +0.27 ppm/hPa, −0.0085 ppm/%RH at 20 °C, 1013 hPa.
    let s = edlen_sensitivities(20.0, 1013.25, 50.0);
    assert!((s.dn_dt_per_k * 1e6 + 0.95).abs() < 0.02, "{s:?}");
    let dry = edlen_sensitivities(20.0, 1013.25, 0.0);
    assert!((dry.dn_dt_per_k * 1e6 + 0.93).abs() < 0.01, "{dry:?}");
    assert!((s.dn_dp_per_hpa * 1e6 - 0.268).abs() < 0.005, "{s:?}");
    assert!((s.dn_drh_per_pct * 1e6 + 0.0085).abs() < 0.0005, "{s:?}");
}

fn row(t_c: f64, scale_temp_c: Option<f64>) -> SessionRow {
    SessionRow {
        run: 1,
        sample: 0,
        t_s: 0.0,
        axis: WireAxis::X,
        direction: 1,
        feed_mm_s: None,
        target: 0,
        x_mm: Some(0.0),
        y_mm: Some(0.0),
        z_mm: Some(0.0),
        scale_mm: 0.0,
        laser_mm: 0.0,
        error_um: 0.0,
        air_temp_c: Some(t_c),
        air_pressure_hpa: Some(1000.0),
        air_rh_pct: Some(40.0),
        scale_temp_c,
        part_temp_c: Some(99.0),
        flags: 0,
    }
}

/// With air data the dead path term uses the span of n over the rows: air at 20 and
/// 21 °C → Δn = n(20) − n(21); u = L_d·Δn/(2√3). The sensitivities are taken at the mean
/// air (20.5 °C), and the material temperature is the scale's (not the part's).
#[test]
fn dead_path_uses_the_sessions_span_of_n() -> Result<(), UncertaintyError> {
    let rows = [row(20.0, Some(21.0)), row(21.0, Some(23.0))];
    let c = TestConditions::from_rows(&rows, 800.0);
    assert_eq!(c.air, Origin::Sensor);
    close(c.air_temp_c, 20.5, 1e-12, "mean air temperature");
    assert_eq!(c.material_temp_c, Some(22.0));
    let dn = refractive_index(HENE_UM, 20.0, 100_000.0, 40.0)
        - refractive_index(HENE_UM, 21.0, 100_000.0, 40.0);
    close(c.n_span.unwrap_or(f64::NAN), dn, 1e-15, "span of n");
    let cfg = UncertaintyConfig {
        dead_path_mm: 250.0,
        ..zero()
    };
    let b = Budget::new(&cfg, c)?;
    let want_um = 250.0 * dn / (2.0 * 3f64.sqrt()) * 1e3;
    close(b.u_read_um, want_um, 1e-12, "dead path, µm");
    // A reading term: the same over the travel as at one target, counted twice.
    close(b.u_c_um(800.0), 2f64.sqrt() * want_um, 1e-12, "u_c");
    Ok(())
}

#[test]
fn bad_configuration_names_the_key() {
    let cases = [
        (
            UncertaintyConfig {
                air_temp_k: -0.1,
                ..UncertaintyConfig::default()
            },
            "air_temp_k",
        ),
        (
            UncertaintyConfig {
                resolution_um: f64::NAN,
                ..UncertaintyConfig::default()
            },
            "resolution_um",
        ),
        (
            UncertaintyConfig {
                k: 0.0,
                ..UncertaintyConfig::default()
            },
            "k",
        ),
    ];
    for (cfg, key) in cases {
        match cfg.validate() {
            Err(UncertaintyError::Invalid { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{key}: {other:?}"),
        }
        assert!(Budget::new(&cfg, conditions(1.0, None)).is_err());
    }
    assert!(UncertaintyConfig::default().validate().is_ok());
    assert!(matches!(
        Budget::new(&UncertaintyConfig::default(), conditions(f64::NAN, None)),
        Err(UncertaintyError::Travel(_))
    ));
    assert!(matches!(
        Budget::new(&UncertaintyConfig::default(), conditions(-1.0, None)),
        Err(UncertaintyError::Travel(_))
    ));
}

/// A misspelt key in the `[uncertainty]` table is an error naming it.
#[test]
fn unknown_uncertainty_key_is_an_error() {
    let err = toml::from_str::<UncertaintyConfig>("air_temp_kk = 0.1\n")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("air_temp_kk"), "{err}");
    let ok: UncertaintyConfig = toml::from_str("air_temp_k = 0.2\n").unwrap_or_default();
    assert_eq!(ok.air_temp_k, 0.2);
    assert_eq!(ok.k, 2.0, "other keys keep their defaults");
}
