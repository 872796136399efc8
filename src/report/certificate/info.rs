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
//!
//! [laser]
//! model = "HeNe interferometer"
//! serial = "L-1234"
//! calibrated = "2026-03-01"
//!
//! [sensors.air_temperature]
//! serial = "T-1"
//! calibrated = "2026-03-01"
//! # also air_pressure, humidity, material_temperature
//!
//! [uncertainty]          # any key of errmap::session::uncertainty::UncertaintyConfig
//! air_temp_k = 0.05
//! ```

use std::path::Path;

use serde::Deserialize;

use crate::base::io_err;
use crate::base::{ConfigError, FileError, FileOp};
use crate::session::uncertainty::{UncertaintyConfig, UncertaintyError};

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
    /// The laser interferometer.
    #[serde(default)]
    pub laser: Instrument,
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

/// A date as `YYYY-MM-DD` with a real month and a day that exists in it (leap years
/// included).
fn check_date(s: &str) -> Result<(), String> {
    let bad = || format!("`{s}` is not a date YYYY-MM-DD");
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
        _ => return Err(format!("`{s}`: month {m} does not exist")),
    };
    if d == 0 || d > days {
        return Err(format!("`{s}`: day {d} does not exist in month {m}"));
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
            ("laser.calibrated", &info.laser.calibrated),
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
                check_date(v).map_err(|m| invalid(key, m))?;
            }
        }
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
    }
}
