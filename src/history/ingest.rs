//! What an add records of a result: its files' sha256, and its numbers — per line of a
//! session the seven ISO 230-2 statistics errmap's `table` reports, with the expanded
//! uncertainty along the travel; of a volumetric model the 21 components' summary.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use sha2::{Digest, Sha256};

use super::HistoryError;
use crate::base::io_err;
use crate::base::{ConfigError, FileOp};
use crate::session;

/// The squareness components (a value and a σ, µrad).
pub const SQUARENESS: [&str; 3] = ["E_C0Y", "E_B0Z", "E_A0Z"];

/// The 18 component functions in the volumetric contract's order.
pub const FUNCTIONS: [&str; 18] = [
    "E_XX", "E_YX", "E_ZX", "E_AX", "E_BX", "E_CX", "E_XY", "E_YY", "E_ZY", "E_AY", "E_BY", "E_CY",
    "E_XZ", "E_YZ", "E_ZZ", "E_AZ", "E_BZ", "E_CZ",
];

/// The seven session parameters, in report order, and the `table --json` key of each.
pub const PARAMETERS: [&str; 7] = ["E", "E_up", "E_down", "A", "B", "R", "M"];

/// What a source file is to its record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    Result,
    Raw,
    Description,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Result => "result",
            Role::Raw => "raw",
            Role::Description => "description",
        }
    }
}

/// A hashed file.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceFile {
    pub role: Role,
    /// Absolute, as given (not resolved through links).
    pub path: String,
    /// 64 lowercase hex digits.
    pub sha256: String,
    pub bytes: i64,
}

/// One statistic of one line.
#[derive(Debug, Clone, PartialEq)]
pub struct LineStat {
    pub axis: String,
    pub line_mm: (f64, f64),
    pub parameter: &'static str,
    pub value: f64,
    pub u_um: Option<f64>,
}

/// One component of a volumetric model.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentRow {
    pub name: String,
    pub unit: String,
    pub identified: bool,
    pub value: Option<f64>,
    pub sigma: Option<f64>,
    pub range: Option<f64>,
}

/// The numbers of a result.
#[derive(Debug, Clone, PartialEq)]
pub enum Content {
    /// A one-axis session: its axis (`X`, `Y` or `Z`) and 7 statistics per line.
    Session { axis: String, lines: Vec<LineStat> },
    /// A volumetric model's 21 components.
    Volumetric { components: Vec<ComponentRow> },
}

impl Content {
    pub fn kind(&self) -> &'static str {
        match self {
            Content::Session { .. } => "session",
            Content::Volumetric { .. } => "volumetric",
        }
    }

    /// Lines of a session (0 for a model).
    pub fn lines(&self) -> usize {
        match self {
            Content::Session { lines, .. } => lines.len() / PARAMETERS.len(),
            Content::Volumetric { .. } => 0,
        }
    }

    /// `[axis]` for a session, `[]` for a model.
    pub fn axes(&self) -> Vec<String> {
        match self {
            Content::Session { axis, .. } => vec![axis.clone()],
            Content::Volumetric { .. } => Vec::new(),
        }
    }
}

/// A result read for an add: its numbers, its files, and warnings (lines left out).
#[derive(Debug, Clone)]
pub struct Ingested {
    pub content: Content,
    pub sources: Vec<SourceFile>,
    pub warnings: Vec<String>,
}

/// A bad input file as a whole (the shared [`ConfigError`] shape).
fn input(path: &Path, message: impl Into<String>) -> HistoryError {
    ConfigError::file(path, message).into()
}

/// sha256 (lowercase hex) and size of a file, read in 64 KiB blocks.
pub(super) fn sha256_file(path: &Path) -> Result<(String, i64), std::io::Error> {
    let mut f = std::fs::File::open(path)?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut bytes = 0i64;
    loop {
        let n = f.read(&mut buf)?;
        if n == 0 {
            break;
        }
        bytes += n as i64;
        h.update(&buf[..n]);
    }
    Ok((hex(&h.finalize()), bytes))
}

/// Lowercase hex of bytes.
pub(super) fn hex(b: &[u8]) -> String {
    const D: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(b.len() * 2);
    for &x in b {
        s.push(D[(x >> 4) as usize] as char);
        s.push(D[(x & 15) as usize] as char);
    }
    s
}

fn source(role: Role, path: &Path) -> Result<SourceFile, HistoryError> {
    let abs: PathBuf = std::path::absolute(path).map_err(io_err(path, FileOp::Read))?;
    let (sha256, bytes) = sha256_file(path).map_err(io_err(path, FileOp::Read))?;
    Ok(SourceFile {
        role,
        path: abs.display().to_string(),
        sha256,
        bytes,
    })
}

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default()
}

/// Reads RESULT (a session table, a capture's session directory, or a volumetric model),
/// by its name.
pub fn ingest(result: &Path) -> Result<Ingested, HistoryError> {
    if result.is_dir() {
        let table = ["session.parquet", "session.csv"]
            .iter()
            .map(|n| result.join(n))
            .find(|p| p.is_file())
            .ok_or_else(|| {
                input(
                    result,
                    "no session.parquet or session.csv in this directory",
                )
            })?;
        let mut sources = vec![source(Role::Result, &table)?];
        for (name, role) in [("raw.bin", Role::Raw), ("session.json", Role::Description)] {
            let p = result.join(name);
            if p.is_file() {
                sources.push(source(role, &p)?);
            }
        }
        let (content, warnings) = session_content(&table)?;
        return Ok(Ingested {
            content,
            sources,
            warnings,
        });
    }
    if !result.exists() {
        let missing = std::io::Error::from(std::io::ErrorKind::NotFound);
        return Err(io_err(result, FileOp::Read)(missing).into());
    }
    match extension(result).as_str() {
        "csv" | "parquet" => {
            let sources = vec![source(Role::Result, result)?];
            let (content, warnings) = session_content(result)?;
            Ok(Ingested {
                content,
                sources,
                warnings,
            })
        }
        "json" => {
            let sources = vec![source(Role::Result, result)?];
            let content = model_content(result)?;
            Ok(Ingested {
                content,
                sources,
                warnings: Vec::new(),
            })
        }
        _ => Err(input(
            result,
            "not a session table (.csv, .parquet), a capture directory or a volumetric model (.json)",
        )),
    }
}

/// The ISO 230-2 statistics of every line of a one-axis session, as `errmap table`
/// computes them (flagged samples left out), with U along the travel (k = 2).
pub(super) fn session_content(path: &Path) -> Result<(Content, Vec<String>), HistoryError> {
    let mut reducer = session::Reducer::new();
    let mut environment = session::EnvironmentStats::default();
    session::for_each_batch(path, session::BATCH_ROWS, &mut |rows| {
        for r in rows {
            reducer.push(r);
            environment.push(r);
        }
        Ok(())
    })
    .map_err(|e| input(path, e.to_string()))?;
    let (_, summary) = reducer
        .error_table(&path.display().to_string())
        .map_err(|e| input(path, e.to_string()))?;
    let axis = summary.axis.clone().ok_or_else(|| input(path, "no axis"))?;
    let (iso, failed) = reducer.iso_by_line();
    let mut warnings: Vec<String> = failed
        .iter()
        .map(|(l, e)| {
            format!(
                "{}: line at ({}, {}) mm skipped: no ISO 230-2 statistics: {e}",
                path.display(),
                l.0,
                l.1
            )
        })
        .collect();
    if iso.is_empty() {
        return Err(input(
            path,
            "no line with computable ISO 230-2 statistics (every target needs 2 runs in each direction)",
        ));
    }
    let config = session::UncertaintyConfig::default();
    let mut lines = Vec::with_capacity(iso.len() * PARAMETERS.len());
    for (line, s) in &iso {
        let u_um = match session::line_budget_of(&config, &environment, s) {
            Ok((_, u)) if u.along_travel_um.is_finite() => Some(u.along_travel_um),
            Ok(_) => None,
            Err(e) => {
                warnings.push(format!(
                    "{}: line at ({}, {}) mm: no uncertainty: {e}",
                    path.display(),
                    line.0,
                    line.1
                ));
                None
            }
        };
        for (parameter, value) in PARAMETERS.iter().zip(values(s)) {
            if !value.is_finite() {
                return Err(input(
                    path,
                    format!("line {line:?}: {parameter} is not finite"),
                ));
            }
            lines.push(LineStat {
                axis: axis.clone(),
                line_mm: *line,
                parameter,
                value,
                u_um,
            });
        }
    }
    Ok((Content::Session { axis, lines }, warnings))
}

/// E, E↑, E↓, A, B, R, M of one line, in [`PARAMETERS`] order.
pub(super) fn values(s: &session::AxisStats) -> [f64; 7] {
    [
        s.e_um,
        s.e_up_um,
        s.e_down_um,
        s.a_um,
        s.b_um,
        s.r_um,
        s.m_um,
    ]
}

/// A σ that is one number (squareness) or one per position (functions).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum SigmaJson {
    One(f64),
    Many(serde::de::IgnoredAny),
}

/// The keys of a component this module reads; others are ignored.
#[derive(Debug, Deserialize)]
struct ComponentJson {
    identified: bool,
    unit: String,
    #[serde(default)]
    value: Option<f64>,
    #[serde(default)]
    sigma: Option<SigmaJson>,
    #[serde(default)]
    values: Option<Vec<Option<f64>>>,
}

/// MODEL.json: only `components` is read.
#[derive(Debug, Deserialize)]
struct ModelJson {
    components: BTreeMap<String, ComponentJson>,
}

/// The 21 components of a volumetric model: squareness value and σ, each function's
/// range (max − min of its values with 0 included); nulls where not identified.
pub(super) fn model_content(path: &Path) -> Result<Content, HistoryError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
    let model: ModelJson = serde_json::from_str(&text).map_err(|e| {
        input(
            path,
            format!("line {} column {}: {e}", e.line(), e.column()),
        )
    })?;
    let get = |name: &str| {
        model
            .components
            .get(name)
            .ok_or_else(|| input(path, format!("components: {name} is missing")))
    };
    let mut components = Vec::with_capacity(21);
    for name in SQUARENESS {
        let c = get(name)?;
        let sigma = match &c.sigma {
            Some(SigmaJson::One(s)) => Some(*s),
            _ => None,
        };
        if c.identified
            && (c.value.is_none_or(|v| !v.is_finite()) || sigma.is_none_or(|s| !s.is_finite()))
        {
            return Err(input(
                path,
                format!("components: {name} is identified but has no finite value and sigma"),
            ));
        }
        components.push(ComponentRow {
            name: name.to_string(),
            unit: c.unit.clone(),
            identified: c.identified,
            value: c.identified.then_some(c.value).flatten(),
            sigma: c.identified.then_some(sigma).flatten(),
            range: None,
        });
    }
    for name in FUNCTIONS {
        let c = get(name)?;
        let range = if c.identified {
            let vals = c.values.as_deref().unwrap_or(&[]);
            let mut lo: f64 = 0.0;
            let mut hi: f64 = 0.0;
            for v in vals {
                match v {
                    Some(v) if v.is_finite() => {
                        lo = lo.min(*v);
                        hi = hi.max(*v);
                    }
                    _ => {
                        return Err(input(
                            path,
                            format!("components: {name} is identified but a value is not a number"),
                        ));
                    }
                }
            }
            if vals.is_empty() {
                return Err(input(
                    path,
                    format!("components: {name} is identified but has no values"),
                ));
            }
            Some(hi - lo)
        } else {
            None
        };
        components.push(ComponentRow {
            name: name.to_string(),
            unit: c.unit.clone(),
            identified: c.identified,
            value: None,
            sigma: None,
            range,
        });
    }
    Ok(Content::Volumetric { components })
}
