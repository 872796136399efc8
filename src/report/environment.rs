//! A session's environment in words and a table, for every report about a session.

use errmap_drivers::SessionRow;

use super::md::Md;
use crate::session::{EnvironmentStats, Range};

/// The environment of a session in words and a table (markdown): air and material
/// temperatures over the session, the refraction compensation the laser lengths used, and
/// what normalisation to the 20 °C reference temperature (ISO 1) would mean.
pub fn environment_summary(rows: &[SessionRow]) -> String {
    environment_text(&EnvironmentStats::of(rows))
}

/// [`environment_summary`] from statistics gathered row by row.
pub fn environment_text(e: &EnvironmentStats) -> String {
    let mut md = Md::new();
    md.heading(2, "Environment")
        .table(["quantity", "min", "mean", "max"]);
    let items: [(&str, &Range); 5] = [
        ("air temperature °C", &e.air_temp_c),
        ("air pressure hPa", &e.air_pressure_hpa),
        ("relative humidity %", &e.air_rh_pct),
        ("scale temperature °C", &e.scale_temp_c),
        ("part/table temperature °C", &e.part_temp_c),
    ];
    for (name, f) in items {
        match f.min_mean_max() {
            Some((lo, m, hi)) => md.row([
                name.to_string(),
                format!("{lo:.3}"),
                format!("{m:.3}"),
                format!("{hi:.3}"),
            ]),
            None => md.row([name, "—", "—", "—"]),
        };
    }
    md.nl();
    match e.n_air.min_mean_max() {
        Some((lo, m, hi)) => md.line(format_args!(
            "Refraction: every laser length was compensated with the modified Edlén equation \
             (Birch & Downs 1994) at the row's own air temperature, pressure and humidity (HeNe \
             633 nm): n − 1 from {:.3} to {:.3} ppm (mean {:.3} ppm), a {:.3} ppm span.",
            (lo - 1.0) * 1e6,
            (hi - 1.0) * 1e6,
            (m - 1.0) * 1e6,
            (hi - lo) * 1e6
        )),
        None => {
            md.line("Refraction: no air data; laser lengths are in vacuum wavelengths (n = 1).")
        }
    };
    let uncompensated = e.rows_without_air;
    if uncompensated > 0 {
        md.nl().line(format_args!(
            "{uncompensated} rows came before the first ENV frame and carry no air compensation (n = 1)."
        ));
    }
    if let Some((_, m, _)) = e.scale_temp_c.min_mean_max() {
        let len = e.max_scale_mm;
        md.nl().line(format_args!(
            "Normalisation to 20 °C (ISO 1): the errors above are as measured, not normalised. \
             The scale was on average {:+.3} K from 20 °C; for a steel scale (11.5 ppm/K) that is \
             {:+.3} µm over the {:.0} mm travel — the size of the correction a normalisation would \
             apply, and why a thermal model of the scale belongs in the machine model.",
            m - 20.0,
            -11.5 * (m - 20.0) * len * 1e-3,
            len
        ));
    }
    md.finish()
}
