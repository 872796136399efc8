//! Tolerances on ISO 230-2 results (`table --tolerances`, `certificate --tolerances`): the
//! tolerance file of `docs/tolerances.md`, which `history report --tolerances` reads too;
//! every line of a session judged with the expanded uncertainty its certificate prints.
//!
//! ```toml
//! specification = "ACME CMM-X spec AX-12 rev. C"   # required here
//! rule = "iso14253"            # optional: iso14253 | simple | guard (+ guard_fraction)
//! [default]                    # every axis (an [axis.X] entry replaces it)
//! R = 4.0
//! [axis.X]                     # every line of a session along X
//! A = 6.0                      # a number: upper limit only
//! B_mean = { lower = -0.5, upper = 0.5 }
//! [[line]]                     # one line, by its fixed coordinates
//! axis = "X"
//! line_mm = [500.0, 50.0]
//! A = 5.0                      # replaces [axis.X].A on this line
//! [machine.M07]                # per-machine limits: the history's, not used here
//! ```
//!
//! | key | ISO 230-2 value | U that judges it |
//! |---|---|---|
//! | `E`, `E_up`, `E_down`, `M`, `A`, `A_up`, `A_down` | e_um … a_down_um | along the travel |
//! | `R`, `R_up`, `R_down`, `B`, `B_mean` | r_um … mean_reversal_um | at one target |

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::AcceptanceError;
use super::rule::{ConformityVerdict, DecisionRule, Limits, Rule, aggregate};
use crate::base::Axis;
use crate::base::FileOp;
use crate::base::io_err;
use crate::session::AxisStats;
use crate::session::StatUncertainty;

/// How close a `[[line]]`'s `line_mm` must be to a session line's, mm.
pub(crate) const LINE_TOL_MM: f64 = 1e-3;

/// Which U judges a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Span {
    AlongTravel,
    AtOneTarget,
}

/// The parameters, in the order of the outputs: key, `iso230` field, its U.
const PARAMETERS: [(&str, &str, Span); 12] = [
    ("E", "e_um", Span::AlongTravel),
    ("E_up", "e_up_um", Span::AlongTravel),
    ("E_down", "e_down_um", Span::AlongTravel),
    ("M", "m_um", Span::AlongTravel),
    ("A", "a_um", Span::AlongTravel),
    ("A_up", "a_up_um", Span::AlongTravel),
    ("A_down", "a_down_um", Span::AlongTravel),
    ("R", "r_um", Span::AtOneTarget),
    ("R_up", "r_up_um", Span::AtOneTarget),
    ("R_down", "r_down_um", Span::AtOneTarget),
    ("B", "b_um", Span::AtOneTarget),
    ("B_mean", "mean_reversal_um", Span::AtOneTarget),
];

fn value_of(stats: &AxisStats, k: usize) -> f64 {
    let s = stats;
    [
        s.e_um,
        s.e_up_um,
        s.e_down_um,
        s.m_um,
        s.a_um,
        s.a_up_um,
        s.a_down_um,
        s.r_um,
        s.r_up_um,
        s.r_down_um,
        s.b_um,
        s.mean_reversal_um,
    ][k]
}

/// Limits per parameter (index into [`PARAMETERS`]).
type ParamLimits = [Option<Limits>; 12];

/// One `[[line]]`.
#[derive(Debug, Clone, PartialEq)]
struct LineTolerance {
    axis: Axis,
    line_mm: [f64; 2],
    limits: ParamLimits,
    /// Its index in the file (for the error naming it).
    index: usize,
}

/// A parsed tolerance file.
#[derive(Debug, Clone, PartialEq)]
pub struct Tolerances {
    pub path: PathBuf,
    pub specification: String,
    /// The file's rule, if it names one.
    pub rule: Option<DecisionRule>,
    axes: [ParamLimits; 3],
    lines: Vec<LineTolerance>,
}

/// One judged parameter of a line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterVerdict {
    pub parameter: &'static str,
    pub field: &'static str,
    pub value_um: f64,
    pub u_um: f64,
    pub lower_um: Option<f64>,
    pub upper_um: Option<f64>,
    pub acceptance_um: [Option<f64>; 2],
    pub verdict: ConformityVerdict,
}

/// A line's conformity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LineConformity {
    pub verdict: ConformityVerdict,
    pub parameters: Vec<ParameterVerdict>,
}

/// The session's conformity: the top-level summary and each line's (`None`: no
/// tolerance applies to that line).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Conformity {
    pub specification: String,
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub k: f64,
    pub statement: String,
    pub verdict: ConformityVerdict,
    #[serde(skip)]
    pub axis: String,
    #[serde(skip)]
    pub lines: Vec<((f64, f64), Option<LineConformity>)>,
}

fn limit_of(path: &Path, key: &str, v: &toml::Value) -> Result<Limits, AcceptanceError> {
    let num = |v: &toml::Value, k: &str| -> Result<f64, AcceptanceError> {
        match v {
            toml::Value::Float(f) => Ok(*f),
            toml::Value::Integer(i) => Ok(*i as f64),
            _ => Err(AcceptanceError::key(path, k, "must be a number (µm)")),
        }
    };
    let (lower, upper) = match v {
        toml::Value::Table(t) => {
            let mut lower = None;
            let mut upper = None;
            for (k, v) in t {
                let name = format!("{key}.{k}");
                match k.as_str() {
                    "lower" => lower = Some(num(v, &name)?),
                    "upper" => upper = Some(num(v, &name)?),
                    _ => {
                        return Err(AcceptanceError::key(
                            path,
                            name,
                            "unknown key (a limit has `lower` and/or `upper`)",
                        ));
                    }
                }
            }
            (lower, upper)
        }
        v => (None, Some(num(v, key)?)),
    };
    Limits::new(lower, upper).map_err(|p| AcceptanceError::key(path, key, p.to_string()))
}

/// The parameters of a table (`[axis.X]` or a `[[line]]`), `skip` keys left to the caller.
fn params_of(
    path: &Path,
    prefix: &str,
    t: &toml::Table,
    skip: &[&str],
) -> Result<ParamLimits, AcceptanceError> {
    let mut out: ParamLimits = [None; 12];
    for (k, v) in t {
        if skip.contains(&k.as_str()) {
            continue;
        }
        let name = format!("{prefix}{k}");
        let Some(i) = PARAMETERS.iter().position(|p| p.0 == k) else {
            return Err(AcceptanceError::key(
                path,
                name,
                format!(
                    "unknown key (known: {})",
                    PARAMETERS.map(|p| p.0).join(", ")
                ),
            ));
        };
        let limits = limit_of(path, &name, v)?;
        // Every parameter but the signed mean reversal is a size (≥ 0): its upper limit
        // must be a positive, plausible tolerance (a negative one failed everything).
        if k != "B_mean"
            && let Some(u) = limits.upper
            && u < crate::base::TOLERANCE_UM.lo
        {
            return Err(AcceptanceError::key(
                path,
                name,
                format!(
                    "upper limit {u} µm: {k} is a size, its tolerance must be positive (at least {} µm)",
                    crate::base::TOLERANCE_UM.lo
                ),
            ));
        }
        out[i] = Some(limits);
    }
    Ok(out)
}

fn axis_of(path: &Path, key: &str, s: &str) -> Result<Axis, AcceptanceError> {
    match s {
        "X" | "x" => Ok(Axis::X),
        "Y" | "y" => Ok(Axis::Y),
        "Z" | "z" => Ok(Axis::Z),
        _ => Err(AcceptanceError::key(
            path,
            key,
            format!("`{s}` is not an axis (X, Y or Z)"),
        )),
    }
}
/// `[[line]]` table `i` (0-based): the axis, the line's fixed coordinates and its
/// limits.
fn line_tolerance(
    path: &Path,
    i: usize,
    item: &toml::Value,
) -> Result<LineTolerance, AcceptanceError> {
    let key = format!("line[{}]", i + 1);
    let toml::Value::Table(t) = item else {
        return Err(AcceptanceError::key(path, key, "must be a table"));
    };
    let axis = match t.get("axis") {
        Some(toml::Value::String(s)) => axis_of(path, &format!("{key}.axis"), s)?,
        _ => {
            return Err(AcceptanceError::key(
                path,
                format!("{key}.axis"),
                "missing (X, Y or Z)",
            ));
        }
    };
    let line_mm = match t.get("line_mm") {
        Some(toml::Value::Array(a)) if a.len() == 2 => {
            let mut out = [0.0; 2];
            for (o, v) in out.iter_mut().zip(a) {
                *o = match v {
                    toml::Value::Float(f) if f.is_finite() => *f,
                    toml::Value::Integer(i) => *i as f64,
                    _ => {
                        return Err(AcceptanceError::key(
                            path,
                            format!("{key}.line_mm"),
                            "must be two finite numbers (mm)",
                        ));
                    }
                };
            }
            out
        }
        _ => {
            return Err(AcceptanceError::key(
                path,
                format!("{key}.line_mm"),
                "missing or not two numbers: the line's fixed coordinates \
                 as `table --json` prints them (line_mm)",
            ));
        }
    };
    Ok(LineTolerance {
        axis,
        line_mm,
        limits: params_of(path, &format!("{key}."), t, &["axis", "line_mm"])?,
        index: i + 1,
    })
}

impl Tolerances {
    /// Reads and checks a tolerance file.
    pub fn read(path: &Path) -> Result<Tolerances, AcceptanceError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        Tolerances::parse(&text, path)
    }

    /// Parses the text of a tolerance file read from `path`.
    pub fn parse(text: &str, path: &Path) -> Result<Tolerances, AcceptanceError> {
        let doc: toml::Table = toml::from_str(text)
            .map_err(|e| AcceptanceError::key(path, "file", e.to_string().trim().to_string()))?;
        let mut specification = None;
        let mut rule_name = None;
        let mut fraction = None;
        let mut axes: [ParamLimits; 3] = [[None; 12]; 3];
        let mut default: ParamLimits = [None; 12];
        let mut lines = Vec::new();
        for (k, v) in &doc {
            match (k.as_str(), v) {
                ("specification", toml::Value::String(s)) if !s.trim().is_empty() => {
                    specification = Some(s.trim().to_string())
                }
                ("specification", _) => {
                    return Err(AcceptanceError::key(path, k, "must be a non-empty string"));
                }
                ("rule", toml::Value::String(s)) => {
                    rule_name = Some(
                        s.parse::<Rule>()
                            .map_err(|p| AcceptanceError::key(path, k, p.to_string()))?,
                    )
                }
                ("guard_fraction", toml::Value::Float(f)) => fraction = Some(*f),
                ("guard_fraction", toml::Value::Integer(i)) => fraction = Some(*i as f64),
                ("axis", toml::Value::Table(t)) => {
                    for (a, v) in t {
                        let key = format!("axis.{a}");
                        let axis = axis_of(path, &key, a)?;
                        let toml::Value::Table(t) = v else {
                            return Err(AcceptanceError::key(path, key, "must be a table"));
                        };
                        axes[axis.index()] = params_of(path, &format!("{key}."), t, &[])?;
                    }
                }
                ("line", toml::Value::Array(items)) => {
                    for (i, item) in items.iter().enumerate() {
                        lines.push(line_tolerance(path, i, item)?);
                    }
                }
                ("default", toml::Value::Table(t)) => {
                    default = params_of(path, "default.", t, &[])?;
                }
                // Per-machine limits are the history's (`history report --tolerances`); a
                // session names no machine, so they do not judge it.
                ("machine", toml::Value::Table(_)) => {}
                ("axis" | "line" | "rule" | "guard_fraction" | "default" | "machine", _) => {
                    return Err(AcceptanceError::key(path, k, "has the wrong type"));
                }
                _ => {
                    return Err(AcceptanceError::key(
                        path,
                        k,
                        "unknown key (known: specification, rule, guard_fraction, default, \
                         axis, line, machine)",
                    ));
                }
            }
        }
        for limits in &mut axes {
            for (l, d) in limits.iter_mut().zip(default) {
                if l.is_none() {
                    *l = d;
                }
            }
        }
        let specification = specification.ok_or_else(|| {
            AcceptanceError::key(
                path,
                "specification",
                "missing: name the specification the limits come from",
            )
        })?;
        let rule = match (rule_name, fraction) {
            (Some(r), f) => Some(
                DecisionRule::new(r, f.unwrap_or(1.0))
                    .map_err(|e| AcceptanceError::key(path, "guard_fraction", e.to_string()))?,
            ),
            (None, Some(_)) => {
                return Err(AcceptanceError::key(
                    path,
                    "guard_fraction",
                    "given without `rule = \"guard\"`",
                ));
            }
            (None, None) => None,
        };
        Ok(Tolerances {
            path: path.to_path_buf(),
            specification,
            rule,
            axes,
            lines,
        })
    }

    /// Judges each line of a session along `axis` (`X`, `Y`, `Z`): `lines` pairs each
    /// line's fixed coordinates and statistics with the expanded uncertainties its
    /// certificate prints. Errors: a `[[line]]` matching no line, no tolerance for any
    /// line.
    pub fn judge(
        &self,
        axis: &str,
        lines: &[((f64, f64), &AxisStats, StatUncertainty)],
        rule: &DecisionRule,
    ) -> Result<Conformity, AcceptanceError> {
        let session_axis = axis_of(&self.path, "axis", axis.trim()).ok();
        for lt in &self.lines {
            let hit = Some(lt.axis) == session_axis
                && lines.iter().any(|(l, _, _)| {
                    (l.0 - lt.line_mm[0]).abs() <= LINE_TOL_MM
                        && (l.1 - lt.line_mm[1]).abs() <= LINE_TOL_MM
                });
            if !hit {
                return Err(AcceptanceError::key(
                    &self.path,
                    format!("line[{}]", lt.index),
                    format!(
                        "axis {} at line_mm = [{}, {}] matches no line of the session (axis {}, \
                         lines {})",
                        lt.axis.upper(),
                        lt.line_mm[0],
                        lt.line_mm[1],
                        if axis.is_empty() { "unknown" } else { axis },
                        lines
                            .iter()
                            .map(|(l, _, _)| format!("[{}, {}]", l.0, l.1))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        let mut judged = Vec::with_capacity(lines.len());
        let mut k = 2.0;
        for &((l0, l1), stats, ref u) in lines {
            k = u.k;
            let mut limits: ParamLimits = match session_axis {
                Some(a) => self.axes[a.index()],
                None => [None; 12],
            };
            for lt in &self.lines {
                if Some(lt.axis) == session_axis
                    && (l0 - lt.line_mm[0]).abs() <= LINE_TOL_MM
                    && (l1 - lt.line_mm[1]).abs() <= LINE_TOL_MM
                {
                    for (slot, l) in limits.iter_mut().zip(lt.limits) {
                        if l.is_some() {
                            *slot = l;
                        }
                    }
                }
            }
            let mut parameters = Vec::new();
            for (i, (key, field, span)) in PARAMETERS.iter().enumerate() {
                let Some(lim) = limits[i] else { continue };
                let u_um = match span {
                    Span::AlongTravel => u.along_travel_um,
                    Span::AtOneTarget => u.at_one_target_um,
                };
                let value_um = value_of(stats, i);
                let d = rule.decide(value_um, u_um, lim).map_err(|e| {
                    AcceptanceError::key(&self.path, *key, format!("line ({l0}, {l1}): {e}"))
                })?;
                parameters.push(ParameterVerdict {
                    parameter: key,
                    field,
                    value_um,
                    u_um,
                    lower_um: lim.lower,
                    upper_um: lim.upper,
                    acceptance_um: d.acceptance,
                    verdict: d.verdict,
                });
            }
            let conformity =
                aggregate(parameters.iter().map(|p| p.verdict)).map(|verdict| LineConformity {
                    verdict,
                    parameters,
                });
            judged.push(((l0, l1), conformity));
        }
        let Some(verdict) = aggregate(
            judged
                .iter()
                .filter_map(|(_, c)| c.as_ref().map(|c| c.verdict)),
        ) else {
            return Err(AcceptanceError::key(
                &self.path,
                "axis",
                format!(
                    "no tolerance applies to any line of the session (axis {})",
                    if axis.is_empty() { "unknown" } else { axis }
                ),
            ));
        };
        Ok(Conformity {
            specification: self.specification.clone(),
            rule: rule.rule.name(),
            guard_fraction: rule.fraction_shown(),
            k,
            statement: rule.statement(true, Some(k)),
            verdict,
            axis: axis.to_string(),
            lines: judged,
        })
    }
}
