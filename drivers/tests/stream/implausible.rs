//! Physically impossible sensor values (issue 17): an ENV of −273.15 °C or a MATERIAL
//! temperature of 5 000 °C is a broken sensor. Its values are not used — the rows carry
//! no air (or material) values, the spec's mark of a row without that data — and the
//! problem log names it.

use crate::common::{Stream, env, hello, material, rows, sample};

#[test]
fn an_impossible_env_is_not_used_and_its_rows_carry_no_air_values() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&env(50, 20_000, 101_325, 500));
    s.frame(&sample(100, 0, 0, 0, 0));
    s.frame(&env(150, -273_150, 101_325, 500)); // absolute zero: a broken sensor
    s.frame(&sample(200, 1, 10, 10, 0));
    s.frame(&env(250, 20_000, 101_325, 500)); // plausible again
    s.frame(&sample(300, 2, 20, 20, 0));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0].air_temp_c, Some(20.0));
    assert_eq!(rows[1].air_temp_c, None, "the impossible ENV is not used");
    assert_eq!(rows[1].air_pressure_hpa, None);
    assert_eq!(rows[2].air_temp_c, Some(20.0));
    // Without n_air the laser length is the vacuum one: 10 counts of λ/(F·k) exactly.
    let vacuum_mm = 10.0 * 632.991354e-6 / 16.0; // F = 4, k = 4
    assert!(
        (rows[1].laser_mm - vacuum_mm).abs() < 1e-12,
        "{}",
        rows[1].laser_mm
    );
    assert_eq!(stats.problems.count("implausible_env"), 1);
}

#[test]
fn an_impossible_material_temperature_is_not_used() {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    s.frame(&material(50, &[20_100, 5_000_000]));
    s.frame(&sample(100, 0, 0, 0, 0));
    s.frame(&material(150, &[20_100, 19_900]));
    s.frame(&sample(200, 1, 10, 10, 0));
    let (rows, stats) = rows(&s.bytes);
    assert_eq!(rows[0].scale_temp_c, None);
    assert_eq!(rows[0].part_temp_c, None);
    assert_eq!(rows[1].part_temp_c, Some(19.9));
    assert_eq!(stats.problems.count("implausible_material"), 1);
}
