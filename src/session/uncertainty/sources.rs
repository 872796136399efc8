//! Where the budget's inputs come from, each stated in words on the certificate:
//!
//! * **resolution** — the device's own description (a capture's HELLO: one laser count
//!   `λ_vac/(F·k)` and one scale count), else a resolution stated in the info file, else
//!   the quantum the recorded laser lengths are written to ([`recorded_resolution`]);
//! * **air and material** — the session's sensors when they were there, otherwise the
//!   conditions the info file declares (a range per quantity, taken as rectangular),
//!   otherwise nothing: the term is left out and the budget says so;
//! * **EVE** (environmental variation error, ISO 230-2 Annex A) — a drift check declared in
//!   the info file, else the session's own stationary rows before the first run
//!   ([`drift_from_rows`]), else nothing, said so.

use errmap_drivers::SessionRow;
use serde::{Deserialize, Serialize};

/// One resolution in the reading chain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Resolution {
    /// What resolves (`"laser count"`, `"scale count"`, …).
    pub name: String,
    /// One step, µm.
    pub step_um: f64,
    /// Where the step comes from, in words.
    pub source: String,
}

/// A declared range `[lo, hi]` of one quantity (info file `[conditions]`).
pub(crate) type Span = [f64; 2];

/// The conditions an info file declares for a test whose session has no sensor for them.
/// Each is a range the quantity stayed within (a rectangular distribution over it).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeclaredConditions {
    /// Air temperature range, °C.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub air_temp_c: Option<Span>,
    /// Air pressure range, hPa.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub air_pressure_hpa: Option<Span>,
    /// Relative humidity range, %RH.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub air_rh_pct: Option<Span>,
    /// Material (scale/part) temperature range, °C.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material_temp_c: Option<Span>,
    /// Where the declared ranges come from (e.g. "room log of the laboratory"), printed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

impl DeclaredConditions {
    /// The first range that is not `lo ≤ hi` with both finite, as (key, message).
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        for (key, v, lo, hi) in [
            ("air_temp_c", self.air_temp_c, -50.0, 100.0),
            ("air_pressure_hpa", self.air_pressure_hpa, 300.0, 1300.0),
            ("air_rh_pct", self.air_rh_pct, 0.0, 100.0),
            ("material_temp_c", self.material_temp_c, -50.0, 100.0),
        ] {
            if let Some([a, b]) = v
                && !(a.is_finite() && b.is_finite() && a <= b && a >= lo && b <= hi)
            {
                return Err((
                    key,
                    format!("[{a}, {b}] is not a range lo ≤ hi within {lo}…{hi}"),
                ));
            }
        }
        Ok(())
    }
}

/// A drift check's result (info file `[drift_check]`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriftCheck {
    /// EVE: the range (max − min) of the readings over the check, µm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eve_um: Option<f64>,
    /// How long the check ran, min.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration_min: Option<f64>,
    /// When it was made, free text.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub date: Option<String>,
}

/// The EVE the budget uses, and where it came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Eve {
    /// Range of the drift, µm.
    pub range_um: f64,
    /// Where it comes from, in words.
    pub source: String,
}

/// The coarsest step that every recorded laser length is a whole multiple of: 10⁻ᵈ mm or
/// 25.4·10⁻ᵈ mm (a length exported in inches), `d` = 0…6 (1 nm at the finest: a finer
/// last digit says nothing about the instrument). Fed one length at a time (a
/// streamed session); a session whose lengths show no such quantum (a simulation,
/// air-compensated counts) has none.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordedResolution {
    /// Index into the candidates (coarse to fine) of the coarsest that fits every length
    /// so far; past the end: none fits.
    at: usize,
    n: usize,
}

/// The candidate steps, mm, coarse to fine.
fn candidates() -> impl Iterator<Item = f64> {
    (0..=6).flat_map(|d| {
        let dec = 10f64.powi(-d);
        [25.4 * dec, dec]
    })
}

impl RecordedResolution {
    /// The resolution of `rows`' laser lengths.
    pub fn of(rows: &[SessionRow]) -> Self {
        let mut r = Self::default();
        rows.iter().for_each(|x| r.push(x.laser_mm));
        r
    }

    /// Adds one recorded length, mm.
    pub fn push(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        self.n += 1;
        let fits = |q: f64| {
            let n = v / q;
            (n - n.round()).abs() <= 1e-6_f64.max(n.abs() * 1e-12)
        };
        while let Some(q) = candidates().nth(self.at) {
            if fits(q) {
                break;
            }
            self.at += 1;
        }
    }

    /// The step, µm, or `None`.
    pub fn step_um(&self) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        candidates().nth(self.at).map(|q| q * 1000.0)
    }
}

/// Minimum rows of a stationary stretch to count as the session's own drift check.
pub const MIN_DRIFT_ROWS: usize = 10;

/// Minimum duration of that stretch, s.
pub const MIN_DRIFT_S: f64 = 60.0;

/// The session's own drift check, fed row by row: the rows before the first run (run 0),
/// air-compensated and unflagged, while the scale did not move. See [`DriftFinder::eve`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriftFinder {
    done: bool,
    n: usize,
    first_scale_mm: f64,
    scale_span_mm: f64,
    t: [f64; 2],
    e: [f64; 2],
}

impl DriftFinder {
    /// The drift check of `rows`.
    pub fn of(rows: &[SessionRow]) -> Self {
        let mut d = Self::default();
        rows.iter().for_each(|r| d.push(r));
        d
    }

    /// Adds one row (in the session's order).
    pub fn push(&mut self, r: &SessionRow) {
        if r.run > 0 {
            self.done = true;
        }
        if self.done || r.flags != 0 || r.air_temp_c.is_none() || !r.error_um.is_finite() {
            return;
        }
        if self.n == 0 {
            self.first_scale_mm = r.scale_mm;
            self.t = [r.t_s, r.t_s];
            self.e = [r.error_um, r.error_um];
        }
        self.n += 1;
        self.scale_span_mm = self
            .scale_span_mm
            .max((r.scale_mm - self.first_scale_mm).abs());
        self.t[1] = r.t_s;
        self.e = [self.e[0].min(r.error_um), self.e[1].max(r.error_um)];
    }

    /// The range of the error over the stretch, when it has at least [`MIN_DRIFT_ROWS`]
    /// rows over [`MIN_DRIFT_S`] and the scale moved by no more than `scale_step_um`.
    pub fn eve(&self, scale_step_um: f64) -> Option<Eve> {
        let seconds = self.t[1] - self.t[0];
        let still = self.scale_span_mm * 1000.0 <= scale_step_um.max(1e-6);
        (self.n >= MIN_DRIFT_ROWS && seconds >= MIN_DRIFT_S && still).then(|| Eve {
            range_um: self.e[1] - self.e[0],
            source: format!(
                "the session's own {} stationary readings before the first run, over {seconds:.0} s",
                self.n
            ),
        })
    }
}

/// What a budget knows beyond the session's environment: the reading chain's resolutions,
/// the drift, the declared conditions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BudgetSources {
    /// Resolutions (empty: the configuration's `resolution_um`).
    pub resolution: Vec<Resolution>,
    /// The EVE, when known.
    pub eve: Option<Eve>,
    /// Declared conditions.
    pub declared: DeclaredConditions,
}

impl BudgetSources {
    /// The sources in order of preference: the device's own resolutions (a capture's
    /// HELLO), else the laser resolution an info file states, else the step the recorded
    /// lengths are written to; the drift check an info file declares, else the session's
    /// own stationary readings; the declared conditions as given.
    pub fn choose(
        device: Option<Vec<Resolution>>,
        stated_laser_um: Option<f64>,
        recorded: &RecordedResolution,
        drift_check: &DriftCheck,
        drift: &DriftFinder,
        declared: &DeclaredConditions,
    ) -> BudgetSources {
        let resolution = device.unwrap_or_else(|| {
            let stated = stated_laser_um.map(|r| Resolution {
                name: "laser".into(),
                step_um: r,
                source: "stated in the info file ([laser] resolution_um)".into(),
            });
            let seen = || {
                recorded.step_um().map(|r| Resolution {
                    name: "recorded length".into(),
                    step_um: r,
                    source: format!(
                        "no device description: the step the session's laser lengths are \
                         written to ({} nm)",
                        (r * 1e4).round() / 10.0
                    ),
                })
            };
            stated.or_else(seen).into_iter().collect()
        });
        let scale_step = resolution
            .iter()
            .filter(|r| r.name.contains("scale"))
            .map(|r| r.step_um)
            .fold(0.0, f64::max);
        let declared_eve = drift_check.eve_um.map(|e| Eve {
            range_um: e,
            source: format!(
                "the drift check declared in the info file ([drift_check]{}{})",
                drift_check
                    .date
                    .as_deref()
                    .map_or_else(String::new, |d| format!(", {d}")),
                drift_check
                    .duration_min
                    .map_or_else(String::new, |m| format!(", over {m} min"))
            ),
        });
        BudgetSources {
            resolution,
            eve: declared_eve.or_else(|| drift.eve(scale_step)),
            declared: declared.clone(),
        }
    }
}
