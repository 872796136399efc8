//! Every number of a machine-model or plan TOML file, checked against a physical range
//! before the file is used (issue 17). TOML admits `nan` and `inf` as floats, and serde
//! takes them into any `f64` field: one `ppm = nan` gave a whole simulated session of
//! `laser_mm = 0`. Here the file is walked as a TOML tree and every float must be finite
//! and every number inside the range its key's name implies, with the file and the dotted
//! key (`environment.air_temp_c.value`, `targets_mm[3]`) in the message.
//!
//! | key (by name) | range |
//! |---|---|
//! | environment temperature histories (`…temp_c`): value, start, end, mean, table values | −50 … 100 °C ([`TEMPERATURE_C`]) |
//! | `environment.air_pressure_hpa`: the same | 300 … 1 300 hPa ([`PRESSURE_HPA`]) |
//! | `environment.air_rh_pct`: the same | 0 … 100 % ([`HUMIDITY_PCT`]) |
//! | a history's `amplitude` | at most the width of its quantity's range |
//! | `…_mm_s` (feeds) | 0 … 10⁵ mm/s ([`FEED_MM_S`]) |
//! | `…_mm_s2` (accelerations) | 10⁻³ … 10⁷ mm/s² |
//! | `…_hz` (sample rates) | 10⁻³ … 10⁶ Hz |
//! | `…_s` (times) | ±10⁹ s ([`TIME_S`]) |
//! | `…_mm` (positions, lengths) | ±10⁶ mm ([`POSITION_MM`]) |
//! | `…_um` (errors, noise, periods) | ±10⁶ µm ([`ERROR_UM`]) |
//! | every other number (ppm, µrad, coefficients) | ±10⁶ in its unit |
//! | `runs` | 1 … 1 000 |
//! | `targets` (a count) | 1 … 10 000 (finer rules where used: a volumetric line needs 3) |
//! | `degree` | 0 … 31 |
//! | `seed`, `fifo_bytes` | any value of their integer type |
//! | `…_fm` (a laser's wavelength) | 10⁸ … 10¹⁰ fm (100 nm … 10 µm) |
//! | `baud` | 50 … 10⁷ Bd |
//!
//! Integers and floats go through the same rules: `E_XX = 1000000000000000000` is refused
//! like `1e18`.
//!
//! Signs and the finer rules (a period > 0, a dwell ≥ 0, increasing targets) are checked
//! where the values are used ([`super::physics`], the board's plan validation); misspelt
//! keys are refused by serde (`deny_unknown_fields`) before this walk.
//!
//! [`TEMPERATURE_C`]: crate::base::TEMPERATURE_C
//! [`PRESSURE_HPA`]: crate::base::PRESSURE_HPA
//! [`HUMIDITY_PCT`]: crate::base::HUMIDITY_PCT
//! [`FEED_MM_S`]: crate::base::FEED_MM_S
//! [`TIME_S`]: crate::base::TIME_S
//! [`POSITION_MM`]: crate::base::POSITION_MM
//! [`ERROR_UM`]: crate::base::ERROR_UM

use std::path::Path;

use crate::base::{
    Bound, ERROR_UM, FEED_MM_S, HUMIDITY_PCT, POSITION_MM, PRESSURE_HPA, TEMPERATURE_C, TIME_S,
};

use crate::base::ConfigError;

const ACCEL_MM_S2: Bound = Bound {
    lo: 1e-3,
    hi: 1e7,
    unit: "mm/s²",
    what: "an acceleration",
};

const RATE_HZ: Bound = Bound {
    lo: 1e-3,
    hi: 1e6,
    unit: "Hz",
    what: "a sample rate",
};

const COEFFICIENT: Bound = Bound {
    lo: -1e6,
    hi: 1e6,
    unit: "in its unit",
    what: "a model coefficient",
};

/// Runs of a plan, each up and down: as many as `errmap plan` writes
/// ([`crate::sim::testplan::MAX_RUNS`]).
const RUNS: Bound = Bound {
    lo: 1.0,
    hi: 1000.0,
    unit: "runs",
    what: "a number of runs",
};

/// Targets of one measured line: as many as `errmap plan` writes
/// ([`crate::sim::testplan::MAX_TARGETS`]); 10⁴ targets is one every 0.1 mm over a metre.
const TARGETS: Bound = Bound {
    lo: 1.0,
    hi: 10_000.0,
    unit: "targets",
    what: "a number of targets",
};

/// The polynomial degree of a component table (the Lagrange method's own limit).
const DEGREE: Bound = Bound {
    lo: 0.0,
    hi: crate::interp::MAX_DEGREE as f64,
    unit: "",
    what: "a polynomial degree",
};

/// A serial line's rate, as `capture --baud` accepts it.
const BAUD: Bound = Bound {
    lo: 50.0,
    hi: 1e7,
    unit: "Bd",
    what: "a baud rate",
};

/// A laser's vacuum wavelength, femtometres: 100 nm … 10 µm, ultraviolet to far infrared.
const WAVELENGTH_FM: Bound = Bound {
    lo: 1e8,
    hi: 1e10,
    unit: "fm",
    what: "a wavelength",
};

/// Keys whose values are counts or seeds, not measurements: their own range (`None`: any
/// value of serde's integer type, as a seed).
fn count_rule(name: &str) -> Option<Option<Bound>> {
    match name {
        "seed" => Some(None),
        "runs" => Some(Some(RUNS)),
        "targets" => Some(Some(TARGETS)),
        "degree" => Some(Some(DEGREE)),
        // The device description: a serial line's rate and a buffer size.
        "baud" => Some(Some(BAUD)),
        "fifo_bytes" => Some(None),
        _ => None,
    }
}

/// The range of the value at `keys` (table keys; array elements carry their array's key).
fn rule(keys: &[&str]) -> Bound {
    let name = keys.last().copied().unwrap_or_default();
    // Environment histories: environment.<quantity>.<field>.
    if keys.first() == Some(&"environment") && keys.len() >= 3 {
        let quantity = keys[1];
        let q = if quantity.ends_with("_hpa") {
            PRESSURE_HPA
        } else if quantity.ends_with("_pct") {
            HUMIDITY_PCT
        } else {
            TEMPERATURE_C
        };
        match name {
            "value" | "start" | "end" | "mean" => return q,
            "amplitude" => {
                let w = q.hi - q.lo;
                return Bound {
                    lo: -w,
                    hi: w,
                    unit: q.unit,
                    what: "a history's amplitude",
                };
            }
            _ => {}
        }
    }
    if name.ends_with("_fm") {
        WAVELENGTH_FM
    } else if name.ends_with("_mm_s") {
        FEED_MM_S
    } else if name.ends_with("_mm_s2") {
        ACCEL_MM_S2
    } else if name.ends_with("_hz") {
        RATE_HZ
    } else if name.ends_with("_s") {
        TIME_S
    } else if name.ends_with("_mm") {
        POSITION_MM
    } else if name.ends_with("_um") {
        ERROR_UM
    } else {
        COEFFICIENT
    }
}

/// Checks every number of the TOML document `text` read from `path` (see the module docs).
/// A value out of range is refused with its dotted key as [`crate::base::Location::Key`],
/// so every reader (the simulator's, the volumetric model's) passes the key on as data.
pub(crate) fn check_numbers(path: &Path, text: &str) -> Result<(), ConfigError> {
    let table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| crate::base::parse_error(path, &e))?;
    let mut keys = Vec::new();
    walk_table(&table, &mut keys).map_err(|(key, problem)| ConfigError::key(path, key, problem))
}

/// An out-of-range value: its dotted key as shown to the user and the problem.
type OutOfRange = (String, String);

fn walk_table<'a>(table: &'a toml::Table, keys: &mut Vec<&'a str>) -> Result<(), OutOfRange> {
    for (k, v) in table {
        keys.push(k);
        walk(v, keys, k.clone())?;
        keys.pop();
    }
    Ok(())
}

fn walk<'a>(v: &'a toml::Value, keys: &mut Vec<&'a str>, shown: String) -> Result<(), OutOfRange> {
    let number = match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Table(t) => {
            for (k, v) in t {
                keys.push(k);
                walk(v, keys, format!("{shown}.{k}"))?;
                keys.pop();
            }
            None
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                walk(v, keys, format!("{shown}[{i}]"))?;
            }
            None
        }
        _ => None,
    };
    // Integers and floats alike (issue 28: `E_C0Y = 1000000000000000000` written as an
    // integer skipped the check that refuses `1e18`): counts and seeds by their own
    // rule, everything else by its unit.
    if let Some(x) = number {
        let name = keys.last().copied().unwrap_or_default();
        let bound = match count_rule(name) {
            Some(None) => return Ok(()),
            Some(Some(b)) => b,
            None => rule(keys),
        };
        if let Err(problem) = bound.check(x) {
            return Err((shown, problem.to_string()));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) -> Result<(), ConfigError> {
        check_numbers(Path::new("m.toml"), text)
    }

    #[test]
    fn nan_inf_and_out_of_range_values_are_refused_by_key() {
        let e = check("[scale_factor]\nppm = nan\n")
            .expect_err("nan")
            .to_string();
        assert!(
            e.contains("m.toml") && e.contains("scale_factor.ppm"),
            "{e}"
        );
        let e = check("[environment.air_temp_c]\nkind = \"constant\"\nvalue = -273.15\n")
            .expect_err("absolute zero")
            .to_string();
        assert!(
            e.contains("environment.air_temp_c.value") && e.contains("°C"),
            "{e}"
        );
        let e = check("[thermal_drift]\ntau_s = inf\n")
            .expect_err("inf")
            .to_string();
        assert!(e.contains("thermal_drift.tau_s"), "{e}");
        let e = check("targets_mm = [0.0, 1e308]\n")
            .expect_err("far")
            .to_string();
        assert!(e.contains("targets_mm[1]") && e.contains("mm"), "{e}");
        let e = check("sample_hz = 5e-324\n")
            .expect_err("denormal rate")
            .to_string();
        assert!(e.contains("sample_hz"), "{e}");
        let e = check("[environment.air_pressure_hpa]\nkind = \"table\"\nt_s = [0.0, 1.0]\nvalue = [1013.0, 5.0]\n")
            .expect_err("pressure").to_string();
        assert!(e.contains("air_pressure_hpa.value[1]"), "{e}");
    }

    /// Issue 28: an integer skipped the check its float twin fails.
    #[test]
    fn integers_are_checked_like_floats() {
        for v in ["1000000000000000000", "1e18"] {
            let e = check(&format!("[squareness_urad]\nE_C0Y = {v}\n"))
                .expect_err(v)
                .to_string();
            assert!(e.contains("squareness_urad.E_C0Y"), "{e}");
        }
        for bad in [
            "runs = 0\n",
            "targets = 9223372036854775807\n",
            "[[line]]\ntargets = 100000\n",
        ] {
            let e = check(bad).expect_err(bad).to_string();
            assert!(e.contains("runs") || e.contains("targets"), "{e}");
        }
        let e = check("[device]\nlaser_wavelength_fm = 632991354000\n")
            .expect_err("a metre")
            .to_string();
        assert!(e.contains("laser_wavelength_fm"), "{e}");
        check("seed = 18446744073709551615\n").expect_err("beyond i64: TOML's own limit");
        check("seed = 9223372036854775807\n[device]\nlaser_wavelength_fm = 632991354\nbaud = 115200\nfifo_bytes = 4096\n")
            .expect("a device and a seed");
    }

    #[test]
    fn ordinary_models_and_plans_pass() {
        check(
            "noise_um = 0.05\nseed = 7\n[environment.air_temp_c]\nkind = \"cycle\"\nmean = 20.5\n\
             amplitude = 0.4\nperiod_s = 600.0\n[scale_factor]\nppm = -12.0\n",
        )
        .expect("model");
        check(
            "axis = \"X\"\nlines_mm = [[1.0, 200.0]]\ntargets_mm = [0.0, 100.0]\nfeed_mm_s = 120.0\n\
             dwell_s = 0.5\nsample_hz = 50.0\naccel_mm_s2 = 2000.0\nruns = 5\n",
        )
        .expect("plan");
    }
}
