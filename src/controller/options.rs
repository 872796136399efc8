//! The settings a dialect declares for its own tables ([`DialectOption`]): each has a
//! name, a help line, a default and a parser, and the command line makes one flag of
//! each (`--siemens-axis`, `--fanuc-max-value`, …) from the registry, so a new dialect's
//! settings need no edit outside its file. The parsed values travel in
//! [`TableSettings::options`](super::TableSettings) by name, each already of its type.

use std::collections::BTreeMap;

use super::DIALECTS;

/// One setting of a dialect's tables.
#[derive(Debug, Clone, Copy)]
pub struct DialectOption {
    /// The setting's name, a flag's name without `--` (the dialect's name first where the
    /// setting is the dialect's alone: `siemens-axis`).
    pub name: &'static str,
    /// One line for `--help`.
    pub help: &'static str,
    /// The value when none is given (parsed by `parse`); `None`: no value.
    pub default: Option<&'static str>,
    /// The value from its text, or why it is not one.
    pub parse: fn(&str) -> Result<OptionValue, OptionError>,
}

/// A setting's value, typed.
#[derive(Debug, Clone, PartialEq)]
pub enum OptionValue {
    Text(String),
    Count(usize),
    Number(u32),
    Real(f64),
}

/// A value a setting does not take.
#[derive(Debug, thiserror::Error)]
pub enum OptionError {
    #[error("`{value}` is not {expected}")]
    NotA {
        value: String,
        expected: &'static str,
    },
    /// What the dialect's writer says of the value (a Siemens axis name).
    #[error(transparent)]
    Refused(#[from] crate::export::ExportError),
}

impl OptionError {
    pub fn new(value: &str, expected: &'static str) -> Self {
        OptionError::NotA {
            value: value.to_string(),
            expected,
        }
    }
}

/// A whole number ≥ 0 (a table number).
pub(crate) fn count(s: &str) -> Result<OptionValue, OptionError> {
    s.trim()
        .parse()
        .map(OptionValue::Count)
        .map_err(|_| OptionError::new(s, "a whole number ≥ 0"))
}

/// A whole number ≥ 0 that fits 32 bits (a parameter of the control).
pub(crate) fn number(s: &str) -> Result<OptionValue, OptionError> {
    s.trim()
        .parse()
        .map(OptionValue::Number)
        .map_err(|_| OptionError::new(s, "a whole number from 0 to 4294967295"))
}

/// A whole number ≥ 1 that fits 32 bits (a parameter that counts: a magnification, the
/// largest value per point).
pub(crate) fn from_one(s: &str) -> Result<OptionValue, OptionError> {
    match s.trim().parse::<u32>() {
        Ok(v) if v >= 1 => Ok(OptionValue::Number(v)),
        _ => Err(OptionError::new(s, "a whole number from 1 to 4294967295")),
    }
}

/// A finite number > 0.
pub(crate) fn positive(s: &str) -> Result<OptionValue, OptionError> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(OptionValue::Real(v)),
        _ => Err(OptionError::new(s, "a finite number > 0")),
    }
}

/// Every dialect's settings, in the registry's order, each name once.
pub fn dialect_options() -> Vec<&'static DialectOption> {
    let mut out: Vec<&'static DialectOption> = Vec::new();
    for o in DIALECTS.iter().flat_map(|d| d.options()) {
        if !out.iter().any(|x| x.name == o.name) {
            out.push(o);
        }
    }
    out
}

/// The settings' values by name: the defaults, and what was given.
#[derive(Debug, Clone, PartialEq)]
pub struct DialectOptions(BTreeMap<&'static str, OptionValue>);

impl Default for DialectOptions {
    /// Every setting's default.
    fn default() -> Self {
        let mut values = BTreeMap::new();
        for o in dialect_options() {
            if let Some(v) = o.default.and_then(|d| (o.parse)(d).ok()) {
                values.insert(o.name, v);
            }
        }
        DialectOptions(values)
    }
}

impl DialectOptions {
    /// Sets `name` to `value` (a name no dialect declares is kept and never read).
    pub fn set(&mut self, name: &'static str, value: OptionValue) {
        self.0.insert(name, value);
    }

    pub fn text(&self, name: &str) -> Option<&str> {
        match self.0.get(name) {
            Some(OptionValue::Text(t)) => Some(t),
            _ => None,
        }
    }

    pub fn count(&self, name: &str) -> Option<usize> {
        match self.0.get(name) {
            Some(OptionValue::Count(n)) => Some(*n),
            _ => None,
        }
    }

    pub fn number(&self, name: &str) -> Option<u32> {
        match self.0.get(name) {
            Some(OptionValue::Number(n)) => Some(*n),
            _ => None,
        }
    }

    pub fn real(&self, name: &str) -> Option<f64> {
        match self.0.get(name) {
            Some(OptionValue::Real(v)) => Some(*v),
            _ => None,
        }
    }
}
