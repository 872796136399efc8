//! A session's environment in one pass: minimum, mean and maximum of the air and material
//! readings and of the refractive index the laser lengths were compensated with (modified
//! Edlén, Birch & Downs 1994, HeNe 633 nm), the rows without air temperature, and the
//! longest scale reading. O(1) memory; fed row by row next to [`super::Reducer`].

use errmap_drivers::SessionRow;

use crate::base::HENE_WAVELENGTH_UM;

/// Minimum, sum and count of one quantity (the mean is sum / n, summed in row order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    pub sum: f64,
    pub n: usize,
}

impl Default for Range {
    fn default() -> Self {
        Range {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            sum: 0.0,
            n: 0,
        }
    }
}

impl Range {
    fn push(&mut self, v: Option<f64>) {
        if let Some(v) = v {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
            self.sum += v;
            self.n += 1;
        }
    }

    /// (min, mean, max), or `None` without a value.
    pub fn min_mean_max(&self) -> Option<(f64, f64, f64)> {
        (self.n > 0).then(|| (self.min, self.sum / self.n as f64, self.max))
    }
}

/// The environment of a session (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnvironmentStats {
    pub air_temp_c: Range,
    pub air_pressure_hpa: Range,
    pub air_rh_pct: Range,
    pub scale_temp_c: Range,
    pub part_temp_c: Range,
    /// n of air at each row with all three air values.
    pub n_air: Range,
    /// Rows without an air temperature.
    pub rows_without_air: usize,
    /// The largest scale reading, mm (0 at least).
    pub max_scale_mm: f64,
}

impl EnvironmentStats {
    /// The statistics of `rows`.
    pub fn of(rows: &[SessionRow]) -> Self {
        let mut s = Self::default();
        rows.iter().for_each(|r| s.push(r));
        s
    }

    /// Adds one row.
    pub fn push(&mut self, r: &SessionRow) {
        self.air_temp_c.push(r.air_temp_c);
        self.air_pressure_hpa.push(r.air_pressure_hpa);
        self.air_rh_pct.push(r.air_rh_pct);
        self.scale_temp_c.push(r.scale_temp_c);
        self.part_temp_c.push(r.part_temp_c);
        self.n_air
            .push(match (r.air_temp_c, r.air_pressure_hpa, r.air_rh_pct) {
                (Some(t), Some(p), Some(h)) => Some(errmap_drivers::edlen::refractive_index(
                    HENE_WAVELENGTH_UM,
                    t,
                    p * 100.0,
                    h,
                )),
                _ => None,
            });
        self.rows_without_air += usize::from(r.air_temp_c.is_none());
        self.max_scale_mm = self.max_scale_mm.max(r.scale_mm);
    }
}
