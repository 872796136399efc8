//! The tolerance file (`docs/tolerances.md`, the same file `table` and `certificate` read):
//! upper limits of the seven session parameters (µm), for every machine (`[default]`), one
//! axis of every machine (`[axis.X]`), every axis of one machine (`[machine.ID]`) or one
//! axis of it (`[machine.ID.X]`); the most specific entry wins. The keys that judge one
//! session (`specification`, `rule`, `guard_fraction`, `[[line]]`, and the parameters the
//! history does not track, `A_up`, `A_down`, `R_up`, `R_down`, `B_mean`) are accepted and
//! not used here; a lower limit is not used either.

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

/// Parameters a tolerance file may limit that the history does not track.
const NOT_TRACKED: [&str; 5] = ["A_up", "A_down", "R_up", "R_down", "B_mean"];

/// The message for a key that is no parameter.
const UNKNOWN_PARAMETER: &str =
    "unknown parameter (E, E_up, E_down, A, B, R, M; A_up, A_down, R_up, R_down, B_mean)";

impl Tolerances {
    /// The limit of `parameter` on `machine`'s `axis`, if any.
    pub fn get(&self, machine: &str, axis: &str, parameter: &str) -> Option<f64> {
        let m = Some(machine.to_string());
        let p = parameter.to_string();
        self.limits
            .get(&(m.clone(), Some(axis.to_string()), p.clone()))
            .or_else(|| self.limits.get(&(m, None, p.clone())))
            .or_else(|| self.limits.get(&(None, Some(axis.to_string()), p.clone())))
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
        // A number, or a table with `upper` (and perhaps `lower`, not used here).
        let limit = |key: &str, v: &toml::Value| -> Result<Option<f64>, HistoryError> {
            let v = match v {
                toml::Value::Table(t) => match t.get("upper") {
                    Some(u) => u,
                    None => return Ok(None),
                },
                v => v,
            };
            let x = match v {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => return Err(bad(key, "a tolerance is a number of µm")),
            };
            if !(x.is_finite() && x > 0.0) {
                return Err(bad(key, "a tolerance must be positive and finite"));
            }
            let plausible = crate::base::TOLERANCE_UM;
            if !plausible.contains(x) {
                return Err(bad(
                    key,
                    &format!(
                        "a tolerance of {x} µm is outside the plausible {} … {} µm",
                        plausible.lo, plausible.hi
                    ),
                ));
            }
            Ok(Some(x))
        };
        let table = |key: &str, v: &toml::Value| -> Result<toml::Table, HistoryError> {
            v.as_table()
                .cloned()
                .ok_or_else(|| bad(key, "expected a table"))
        };
        // The parameters of one table into (machine, axis, ·).
        let mut put = |key: &str,
                       body: &toml::Table,
                       m: Option<&String>,
                       a: Option<&str>|
         -> Result<(), HistoryError> {
            for (p, x) in body {
                let key = format!("{key}.{p}");
                if NOT_TRACKED.contains(&p.as_str()) {
                    continue;
                }
                if !PARAMETERS.contains(&p.as_str()) {
                    return Err(bad(&key, UNKNOWN_PARAMETER));
                }
                if let Some(v) = limit(&key, x)? {
                    out.limits
                        .insert((m.cloned(), a.map(str::to_string), p.clone()), v);
                }
            }
            Ok(())
        };
        for (k, v) in &doc {
            match k.as_str() {
                "specification" | "rule" | "guard_fraction" | "line" => {}
                "default" => put(k, &table(k, v)?, None, None)?,
                "axis" => {
                    for (a, body) in table(k, v)? {
                        let key = format!("axis.{a}");
                        let upper = a.to_ascii_uppercase();
                        if !AXES.contains(&upper.as_str()) {
                            return Err(bad(&key, "not an axis (X, Y or Z)"));
                        }
                        put(&key, &table(&key, &body)?, None, Some(&upper))?;
                    }
                }
                "machine" => {
                    for (m, body) in table(k, v)? {
                        let mk = format!("machine.{m}");
                        let body = table(&mk, &body)?;
                        let (axes, params): (toml::Table, toml::Table) = body
                            .into_iter()
                            .partition(|(p, _)| AXES.contains(&p.as_str()));
                        put(&mk, &params, Some(&m), None)?;
                        for (a, x) in axes {
                            let key = format!("{mk}.{a}");
                            put(&key, &table(&key, &x)?, Some(&m), Some(&a))?;
                        }
                    }
                }
                _ => {
                    return Err(bad(
                        k,
                        "unknown key (specification, rule, guard_fraction, default, axis, \
                         line, machine)",
                    ));
                }
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
        // The file `table` and `certificate` read: [axis.X] for every machine, the keys
        // that judge one session accepted, lower limits and untracked parameters unused.
        let t = Tolerances::parse(
            Path::new("tol.toml"),
            "specification = \"S\"\nrule = \"simple\"\n[default]\nR = 4.0\n[axis.X]\n\
             A = 6.0\nB_mean = { lower = -0.5, upper = 0.5 }\nB = { upper = 2.0 }\n\
             [[line]]\naxis = \"X\"\nline_mm = [0.0, 0.0]\nA = 5.0\n[machine.M1.X]\nA = 3.0\n",
        )
        .expect("a value");
        assert_eq!(t.get("M1", "X", "A"), Some(3.0));
        assert_eq!(t.get("M2", "X", "A"), Some(6.0));
        assert_eq!(t.get("M2", "X", "B"), Some(2.0));
        assert_eq!(t.get("M2", "Y", "A"), None);
        assert_eq!(t.get("M2", "Y", "R"), Some(4.0));
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
