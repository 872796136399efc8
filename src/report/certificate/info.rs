//! The certificate's info TOML: who, what, with which instruments, and optional
//! uncertainty inputs. Every table rejects unknown keys, so a misspelt key is an error
//! naming it (with its line and column, from the TOML parser); dates are `YYYY-MM-DD`.
//!
//! ```toml
//! certificate_number = "2026-0142"
//! lab = "Example Metrology Lab"
//! operator = "A. N. Other"
//! customer = "Example Machine Works"
//! machine = "Vertical machining centre VMC-800, serial 4711"
//! date_of_test = "2026-11-30"
//! date_of_issue = "2026-12-02"
//! start_time = "09:12"                 # local time of the test, HH:MM
//! end_time = "10:05"
//! traceability = "…"                   # the lab's statement; a default is built without it
//!
//! [laser]
//! model = "HeNe interferometer"
//! serial = "L-1234"
//! calibrated = "2026-03-01"
//! resolution_um = 0.0791               # used when the session carries no device HELLO
//! setup = "linear optics, beam on the spindle axis, 120 mm dead path"
//!
//! [controller]
//! compensation = "pitch compensation active (table of 2026-05-04)"
//! state = "as found"                   # as found | as left | as found and as left
//!
//! [conditions]                         # ranges, used only where no sensor recorded
//! air_temp_c = [19.5, 20.5]
//! air_pressure_hpa = [990.0, 1030.0]
//! air_rh_pct = [35.0, 60.0]
//! material_temp_c = [19.8, 20.6]
//! source = "room log of the laboratory"
//!
//! [drift_check]                        # EVE, ISO 230-2 Annex A
//! eve_um = 0.3
//! duration_min = 30.0
//!
//! [sensors.air_temperature]
//! serial = "T-1"
//! calibrated = "2026-03-01"
//! # also air_pressure, humidity, material_temperature
//!
//! [uncertainty]          # any key of errmap::session::UncertaintyConfig
//! air_temp_k = 0.05
//! ```

use std::path::Path;

use serde::Deserialize;

use crate::base::io_err;
use crate::base::{ConfigError, FileError, FileOp};
use crate::session::{DeclaredConditions, DriftCheck, UncertaintyConfig, UncertaintyError};

/// One instrument: what it is and when it was calibrated.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Instrument {
    /// Make and model.
    pub model: Option<String>,
    /// Serial number.
    pub serial: Option<String>,
    /// Date of its last calibration, `YYYY-MM-DD`.
    pub calibrated: Option<String>,
}

/// The laser interferometer: the instrument and its set-up.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Laser {
    /// Make and model.
    pub model: Option<String>,
    /// Serial number.
    pub serial: Option<String>,
    /// Date of its last calibration, `YYYY-MM-DD`.
    pub calibrated: Option<String>,
    /// Its stated resolution, µm: used when the session has no device description.
    pub resolution_um: Option<f64>,
    /// The set-up in words (optics, beam path, where the dead path was measured).
    pub setup: Option<String>,
}

impl Laser {
    /// The instrument part.
    pub fn instrument(&self) -> Instrument {
        Instrument {
            model: self.model.clone(),
            serial: self.serial.clone(),
            calibrated: self.calibrated.clone(),
        }
    }
}

/// A rotary axis' angle reference (an XR20-style indexer, an autocollimator with a
/// polygon): the instrument and what its uncertainty budget takes (`docs/rotary.md`).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AngleReference {
    pub model: Option<String>,
    pub serial: Option<String>,
    pub calibrated: Option<String>,
    /// Its stated accuracy ±″ (its calibration or the maker's class).
    pub accuracy_arcsec: Option<f64>,
    /// Its centring on the axis ±″, if assessed.
    pub centring_arcsec: Option<f64>,
}

/// The controller's compensation during the test.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Controller {
    /// The compensation state in words (active, which table; or off).
    pub compensation: Option<String>,
    /// As found, as left, or both.
    pub state: Option<String>,
}

/// The environment sensors.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensors {
    /// Air temperature sensor.
    #[serde(default)]
    pub air_temperature: Instrument,
    /// Air pressure sensor.
    #[serde(default)]
    pub air_pressure: Instrument,
    /// Humidity sensor.
    #[serde(default)]
    pub humidity: Instrument,
    /// Material (scale/part) temperature sensor.
    #[serde(default)]
    pub material_temperature: Instrument,
}

/// The fields a certificate carries. All optional: a missing one is printed blank.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CertificateInfo {
    /// Certificate number.
    pub certificate_number: Option<String>,
    /// Calibration laboratory.
    pub lab: Option<String>,
    /// Who made the test.
    pub operator: Option<String>,
    /// For whom.
    pub customer: Option<String>,
    /// The machine tested (make, model, serial).
    pub machine: Option<String>,
    /// Date of the test, `YYYY-MM-DD`.
    pub date_of_test: Option<String>,
    /// Date the certificate is issued, `YYYY-MM-DD` (distinct from the test's).
    pub date_of_issue: Option<String>,
    /// Local start time of the test, `HH:MM`.
    pub start_time: Option<String>,
    /// Local end time of the test, `HH:MM`.
    pub end_time: Option<String>,
    /// The laboratory's traceability statement (a default is printed without it).
    pub traceability: Option<String>,
    /// The laser interferometer and its set-up.
    #[serde(default)]
    pub laser: Laser,
    /// The controller's compensation state.
    #[serde(default)]
    pub controller: Controller,
    /// A rotary axis' angle reference (`[reference]`).
    #[serde(default)]
    pub reference: AngleReference,
    /// Conditions declared for what no sensor recorded.
    #[serde(default)]
    pub conditions: DeclaredConditions,
    /// A drift check's result.
    #[serde(default)]
    pub drift_check: DriftCheck,
    /// The environment sensors.
    #[serde(default)]
    pub sensors: Sensors,
    /// Uncertainty inputs overriding the documented defaults.
    #[serde(default)]
    pub uncertainty: UncertaintyConfig,
}

/// Why an info file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum InfoError {
    /// The file cannot be read.
    #[error(transparent)]
    Read(#[from] FileError),
    /// Not valid TOML, or a key that does not exist, or a value of the wrong type (the
    /// whole file: the parser's message names the line, column and key), or a value of
    /// the right type that is not acceptable (at its key).
    #[error(transparent)]
    Config(#[from] ConfigError),
}

/// A date or time in the info file that is not one.
#[derive(Debug, thiserror::Error)]
enum CalendarError {
    #[error("`{0}` is not a time HH:MM")]
    Time(String),
    #[error("`{0}` is not a date YYYY-MM-DD")]
    Date(String),
    #[error("`{text}`: month {month} does not exist")]
    Month { text: String, month: u32 },
    #[error("`{text}`: day {day} does not exist in month {month}")]
    Day { text: String, day: u32, month: u32 },
}

/// A time as `HH:MM`.
fn check_time(s: &str) -> Result<(), CalendarError> {
    let ok = s.len() == 5
        && s.as_bytes()[2] == b':'
        && s[..2].parse::<u32>().is_ok_and(|h| h < 24)
        && s[3..].parse::<u32>().is_ok_and(|m| m < 60);
    if ok {
        Ok(())
    } else {
        Err(CalendarError::Time(s.to_string()))
    }
}

/// A date as `YYYY-MM-DD` with a real month and a day that exists in it (leap years
/// included).
fn check_date(s: &str) -> Result<(), CalendarError> {
    let bad = || CalendarError::Date(s.to_string());
    let parts: Vec<&str> = s.split('-').collect();
    if parts.len() != 3
        || parts[0].len() != 4
        || parts[1].len() != 2
        || parts[2].len() != 2
        || !parts.iter().all(|p| p.bytes().all(|b| b.is_ascii_digit()))
    {
        return Err(bad());
    }
    let num = |p: &str| p.parse::<u32>().map_err(|_| bad());
    let (y, m, d) = (num(parts[0])?, num(parts[1])?, num(parts[2])?);
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let days = match m {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if leap => 29,
        2 => 28,
        _ => {
            return Err(CalendarError::Month {
                text: s.to_string(),
                month: m,
            });
        }
    };
    if d == 0 || d > days {
        return Err(CalendarError::Day {
            text: s.to_string(),
            day: d,
            month: m,
        });
    }
    Ok(())
}

impl CertificateInfo {
    /// Parses and validates info TOML text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<CertificateInfo, InfoError> {
        let info: CertificateInfo =
            toml::from_str(text).map_err(|e| crate::base::parse_error(path, &e))?;
        let invalid =
            |key: &str, message: String| InfoError::from(ConfigError::key(path, key, message));
        let s = &info.sensors;
        let dates = [
            ("date_of_test", &info.date_of_test),
            ("date_of_issue", &info.date_of_issue),
            ("laser.calibrated", &info.laser.calibrated),
            ("reference.calibrated", &info.reference.calibrated),
            (
                "sensors.air_temperature.calibrated",
                &s.air_temperature.calibrated,
            ),
            (
                "sensors.air_pressure.calibrated",
                &s.air_pressure.calibrated,
            ),
            ("sensors.humidity.calibrated", &s.humidity.calibrated),
            (
                "sensors.material_temperature.calibrated",
                &s.material_temperature.calibrated,
            ),
        ];
        for (key, value) in dates {
            if let Some(v) = value {
                check_date(v).map_err(|e| invalid(key, e.to_string()))?;
            }
        }
        for (key, value) in [
            ("start_time", &info.start_time),
            ("end_time", &info.end_time),
        ] {
            if let Some(v) = value {
                check_time(v).map_err(|e| invalid(key, e.to_string()))?;
            }
        }
        for (key, value) in [
            ("reference.accuracy_arcsec", info.reference.accuracy_arcsec),
            ("reference.centring_arcsec", info.reference.centring_arcsec),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0 && v <= 3600.0)
            {
                return Err(invalid(key, format!("{v}: an angle in ″, 0 < v ≤ 3600")));
            }
        }
        if let Some(r) = info.laser.resolution_um
            && !(r.is_finite() && r > 0.0 && r <= 1000.0)
        {
            return Err(invalid(
                "laser.resolution_um",
                format!("{r}: not a resolution > 0 and ≤ 1000 µm"),
            ));
        }
        if let Some(e) = info.drift_check.eve_um
            && !(e.is_finite() && (0.0..=1e6).contains(&e))
        {
            return Err(invalid(
                "drift_check.eve_um",
                format!("{e}: not a range ≥ 0 and ≤ 10⁶ µm"),
            ));
        }
        info.conditions
            .check()
            .map_err(|(key, m)| invalid(&format!("conditions.{key}"), m))?;
        info.uncertainty.validate().map_err(|e| match e {
            UncertaintyError::Invalid { key, value, reason } => {
                invalid(&format!("uncertainty.{key}"), format!("{value}: {reason}"))
            }
            UncertaintyError::TooLarge { key, value, max } => invalid(
                &format!("uncertainty.{key}"),
                format!("{value}: more than {max}, beyond any real instrument (a unit mistake?)"),
            ),
            other => invalid("uncertainty", other.to_string()),
        })?;
        Ok(info)
    }

    /// Reads and validates an info file.
    pub fn read(path: &Path) -> Result<CertificateInfo, InfoError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        Self::parse(&text, path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_are_checked_for_existence() {
        assert!(check_date("2024-02-29").is_ok());
        assert!(check_date("2023-02-29").is_err());
        assert!(check_date("2000-02-29").is_ok());
        assert!(check_date("1900-02-29").is_err());
        assert!(check_date("2026-13-01").is_err());
        assert!(check_date("2026-04-31").is_err());
        assert!(check_date("26-04-01").is_err());
        assert!(check_date("2026-4-01").is_err());
        assert!(check_time("09:05").is_ok());
        assert!(check_time("24:00").is_err());
        assert!(check_time("9:05").is_err());
    }
}
