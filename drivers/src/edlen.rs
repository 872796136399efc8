//! Refractive index of air: the modified Edlén equation of Birch and Downs (Metrologia 30,
//! 155 (1993) and its correction, Metrologia 31, 315 (1994)), exactly as
//! `docs/wire-protocol.md` section "The air's refractive index" writes it, with the water
//! vapour saturation pressure from the IAPWS-IF97 saturation equation (region 4, IAPWS
//! Revised Release on IF97, eq. 30).
//!
//! σ = 1/λ_vac in µm⁻¹, t in °C, p in Pa, f the water vapour partial pressure in Pa:
//!
//! ```text
//! (n−1)_s  = [8342.54 + 2406147/(130 − σ²) + 15998/(38.9 − σ²)] · 1e−8
//! (n−1)_tp = p · (n−1)_s / 96095.43 · [1 + 1e−8 · (0.601 − 0.00972 t) · p] / (1 + 0.003661 t)
//! n        = 1 + (n−1)_tp − f · (3.7345 − 0.0401 σ²) · 1e−10
//! f        = RH/100 · p_sv(t)
//! ```
//!
//! Cost: a few dozen flops and one square root per evaluation.

/// Saturation vapour pressure of water over liquid water, Pa, at temperature `t_c` (°C),
/// from the IAPWS-IF97 saturation-pressure equation (valid 273.15 K to 647.096 K; used as
/// is slightly below 0 °C).
pub fn saturation_vapour_pressure_pa(t_c: f64) -> f64 {
    const N: [f64; 10] = [
        0.116_705_214_527_67e4,
        -0.724_213_167_032_06e6,
        -0.170_738_469_400_92e2,
        0.120_208_247_024_70e5,
        -0.323_255_503_223_33e7,
        0.149_151_086_135_30e2,
        -0.482_326_573_615_91e4,
        0.405_113_405_420_57e6,
        -0.238_555_575_678_49,
        0.650_175_348_447_98e3,
    ];
    let t_k = t_c + 273.15;
    let theta = t_k + N[8] / (t_k - N[9]);
    let a = theta * theta + N[0] * theta + N[1];
    let b = N[2] * theta * theta + N[3] * theta + N[4];
    let c = N[5] * theta * theta + N[6] * theta + N[7];
    let x = 2.0 * c / (-b + (b * b - 4.0 * a * c).sqrt());
    x.powi(4) * 1e6
}

/// Refractive index of air by the modified Edlén equation.
///
/// `lambda_vac_um`: vacuum wavelength, µm; `t_c`: air temperature, °C; `p_pa`: pressure,
/// Pa; `rh_pct`: relative humidity, %.
pub fn refractive_index(lambda_vac_um: f64, t_c: f64, p_pa: f64, rh_pct: f64) -> f64 {
    let sigma = 1.0 / lambda_vac_um;
    let s2 = sigma * sigma;
    let n_s = (8342.54 + 2_406_147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2)) * 1e-8;
    let n_tp = p_pa * n_s / 96095.43 * (1.0 + 1e-8 * (0.601 - 0.00972 * t_c) * p_pa)
        / (1.0 + 0.003661 * t_c);
    let f = rh_pct / 100.0 * saturation_vapour_pressure_pa(t_c);
    1.0 + n_tp - f * (3.7345 - 0.0401 * s2) * 1e-10
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spec's check values, to 1e-11 (the values are given to 11 decimals).
    #[test]
    fn spec_check_values() {
        let cases = [
            (0.633, 20.0, 101_325.0, 20.0, 1.000_271_628_94),
            (0.633, 20.0, 101_325.0, 80.0, 1.000_271_118_84),
            (0.632_991_354, 20.0, 101_325.0, 50.0, 1.000_271_373_99),
        ];
        for (l, t, p, rh, want) in cases {
            let n = refractive_index(l, t, p, rh);
            assert!(
                (n - want).abs() < 1e-11,
                "λ {l} t {t} p {p} RH {rh}: {n:.14} vs {want}"
            );
        }
    }

    /// IAPWS-IF97 verification values for the saturation pressure (Table 35):
    /// T = 300 K → 0.353658941e-2 MPa, 500 K → 0.263889776e1 MPa.
    #[test]
    fn iapws_if97_table_35() {
        let p300 = saturation_vapour_pressure_pa(300.0 - 273.15);
        assert!((p300 / 0.353_658_941e4 - 1.0).abs() < 1e-8, "{p300}");
        let p500 = saturation_vapour_pressure_pa(500.0 - 273.15);
        assert!((p500 / 0.263_889_776e7 - 1.0).abs() < 1e-8, "{p500}");
    }
}
