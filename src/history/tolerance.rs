//! The tolerance file: upper limits of the seven session parameters (µm), for every
//! machine (`[default]`), every axis of one machine (`[machine.ID]`) or one axis of it
//! (`[machine.ID.X]`); the most specific entry wins.

use std::collections::BTreeMap;
use std::path::Path;

use super::HistoryError;
use super::ingest::PARAMETERS;
use crate::base::io_err;
use crate::base::{ConfigError, FileOp};

/// Upper limits by (machine or none, axis or none, parameter).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tolerances {
    limits: BTreeMap<(Option<String>, Option<String>, String), f64>,
}

const AXES: [&str; 3] = ["X", "Y", "Z"];

impl Tolerances {
    /// The limit of `parameter` on `machine`'s `axis`, if any.
    pub fn get(&self, machine: &str, axis: &str, parameter: &str) -> Option<f64> {
        let m = Some(machine.to_string());
        let p = parameter.to_string();
        self.limits
            .get(&(m.clone(), Some(axis.to_string()), p.clone()))
            .or_else(|| self.limits.get(&(m, None, p.clone())))
            .or_else(|| self.limits.get(&(None, None, p)))
            .copied()
    }

    /// Reads and checks a tolerance file.
    pub fn read(path: &Path) -> Result<Tolerances, HistoryError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        Tolerances::parse(path, &text)
    }

    /// Parses the text of `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Tolerances, HistoryError> {
        let bad =
            |key: &str, message: &str| HistoryError::from(ConfigError::key(path, key, message));
        let doc: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            let key = match e.span() {
                Some(span) => {
                    let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                    format!("line {line}")
                }
                None => "TOML".to_string(),
            };
            bad(&key, e.message())
        })?;
        let mut out = Tolerances::default();
        let limit = |key: &str, v: &toml::Value| -> Result<f64, HistoryError> {
            let x = match v {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => return Err(bad(key, "a tolerance is a number of µm")),
            };
            if !(x.is_finite() && x > 0.0) {
                return Err(bad(key, "a tolerance must be positive and finite"));
            }
            Ok(x)
        };
        let table = |key: &str, v: &toml::Value| -> Result<toml::Table, HistoryError> {
            v.as_table()
                .cloned()
                .ok_or_else(|| bad(key, "expected a table"))
        };
        for (k, v) in &doc {
            match k.as_str() {
                "default" => {
                    for (p, x) in table(k, v)? {
                        let key = format!("default.{p}");
                        if !PARAMETERS.contains(&p.as_str()) {
                            return Err(bad(
                                &key,
                                "unknown parameter (E, E_up, E_down, A, B, R, M)",
                            ));
                        }
                        out.limits.insert((None, None, p), limit(&key, &x)?);
                    }
                }
                "machine" => {
                    for (m, body) in table(k, v)? {
                        let mk = format!("machine.{m}");
                        for (p, x) in table(&mk, &body)? {
                            let key = format!("{mk}.{p}");
                            if AXES.contains(&p.as_str()) {
                                for (q, y) in table(&key, &x)? {
                                    let key = format!("{key}.{q}");
                                    if !PARAMETERS.contains(&q.as_str()) {
                                        return Err(bad(
                                            &key,
                                            "unknown parameter (E, E_up, E_down, A, B, R, M)",
                                        ));
                                    }
                                    out.limits.insert(
                                        (Some(m.clone()), Some(p.clone()), q),
                                        limit(&key, &y)?,
                                    );
                                }
                            } else if PARAMETERS.contains(&p.as_str()) {
                                out.limits
                                    .insert((Some(m.clone()), None, p), limit(&key, &x)?);
                            } else {
                                return Err(bad(
                                    &key,
                                    "unknown key (an axis X, Y, Z or a parameter E, E_up, E_down, A, B, R, M)",
                                ));
                            }
                        }
                    }
                }
                _ => return Err(bad(k, "unknown key (default or machine)")),
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_most_specific_entry_wins_and_typos_are_named() {
        let t = Tolerances::parse(
            Path::new("tol.toml"),
            "[default]\nE = 40.0\nB = 20\n[machine.M07]\nB = 12.0\n[machine.M07.X]\nE = 30.0\n",
        )
        .expect("a value");
        assert_eq!(t.get("M07", "X", "E"), Some(30.0));
        assert_eq!(t.get("M07", "Y", "E"), Some(40.0));
        assert_eq!(t.get("M07", "Y", "B"), Some(12.0));
        assert_eq!(t.get("M08", "Z", "B"), Some(20.0));
        assert_eq!(t.get("M08", "Z", "R"), None);
        for (text, key) in [
            ("[default]\nEE = 1.0\n", "default.EE"),
            ("[machine.M1.W]\nE = 1.0\n", "machine.M1.W"),
            ("[machine.M1.X]\nE = -1.0\n", "machine.M1.X.E"),
            ("[defaults]\nE = 1.0\n", "defaults"),
        ] {
            let e = Tolerances::parse(Path::new("tol.toml"), text)
                .expect_err("an error")
                .to_string();
            assert!(e.starts_with(&format!("tol.toml: {key}:")), "{e}");
        }
    }
}
