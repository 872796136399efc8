//! The artefact file, the campaign file and the measurement CSV (spec `artefact.md`):
//! read, every key checked by name (unknown and misspelt keys refused with their dotted
//! path), every number finite, the measured rows tied to the artefact's features.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::error::ArtefactError;
use crate::base::{ConfigError, FileOp, io_err};

/// The most features of one artefact and rows of one measurement file (a 650-hole plate
/// is the largest known; bounded before anything is allocated per row).
pub const MAX_FEATURES: usize = 100_000;

/// What kind of artefact, and so what a feature observes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    BallPlate,
    HolePlate,
    BallBeam,
    StepGauge,
}

impl Kind {
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::BallPlate => "ball_plate",
            Kind::HolePlate => "hole_plate",
            Kind::BallBeam => "ball_beam",
            Kind::StepGauge => "step_gauge",
        }
    }

    fn parse(s: &str) -> Option<Kind> {
        [
            Kind::BallPlate,
            Kind::HolePlate,
            Kind::BallBeam,
            Kind::StepGauge,
        ]
        .into_iter()
        .find(|k| k.as_str() == s)
    }

    /// Ball beams and step gauges: features along the artefact's x axis.
    pub fn is_1d(self) -> bool {
        matches!(self, Kind::BallBeam | Kind::StepGauge)
    }

    /// The artefact-frame coordinates a feature observes (x, y, z).
    pub fn observes(self) -> [bool; 3] {
        match self {
            Kind::BallPlate | Kind::BallBeam => [true; 3],
            Kind::HolePlate => [true, true, false],
            Kind::StepGauge => [true, false, false],
        }
    }
}

/// One feature (a ball, a hole, a gauge face).
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    pub id: String,
    pub nominal_mm: [f64; 3],
    pub certificate_mm: Option<[f64; 3]>,
    /// Expanded uncertainty (k = 2) of each certified coordinate.
    pub u_um: Option<f64>,
}

/// An artefact file.
#[derive(Debug, Clone, PartialEq)]
pub struct Artefact {
    pub path: PathBuf,
    pub id: String,
    pub kind: Kind,
    pub alpha_ppm_per_k: f64,
    pub reference_temp_c: f64,
    pub features: Vec<Feature>,
}

impl Artefact {
    /// Reference coordinates of feature `i` at T_ref: the certificate's, else nominal.
    pub fn reference_mm(&self, i: usize) -> [f64; 3] {
        let f = &self.features[i];
        f.certificate_mm.unwrap_or(f.nominal_mm)
    }

    /// f(T) = f_ref·(1 + α·(T − T_ref)).
    pub fn at_temp_mm(&self, i: usize, temp_c: f64) -> [f64; 3] {
        let k = 1.0 + 1e-6 * self.alpha_ppm_per_k * (temp_c - self.reference_temp_c);
        self.reference_mm(i).map(|v| v * k)
    }

    /// Certified (every feature has a certificate)?
    pub fn certified(&self) -> bool {
        self.features.iter().all(|f| f.certificate_mm.is_some())
    }

    /// Index of a feature id.
    pub fn feature(&self, id: &str) -> Option<usize> {
        self.features.iter().position(|f| f.id == id)
    }

    /// Reads and checks an artefact file.
    pub fn read(path: &Path) -> Result<Artefact, ArtefactError> {
        let table = read_table(path)?;
        let t = Keys::new(path, "", &table);
        t.only(&[
            "id",
            "kind",
            "alpha_ppm_per_k",
            "reference_temp_c",
            "feature",
        ])?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let id = t.opt_str("id")?.unwrap_or(stem);
        let kind_s = t.req_str("kind")?;
        let kind = Kind::parse(&kind_s).ok_or_else(|| {
            t.err(
                "kind",
                format!(
                    "`{kind_s}` is not an artefact kind (ball_plate, hole_plate, ball_beam, \
                     step_gauge)"
                ),
            )
        })?;
        let alpha_ppm_per_k = t.opt_num("alpha_ppm_per_k")?.unwrap_or(0.0);
        let reference_temp_c = t.opt_num("reference_temp_c")?.unwrap_or(20.0);
        let items = t.array_of_tables("feature")?;
        if items.len() < 3 {
            return Err(t.err("feature", "at least 3 features are needed").into());
        }
        if items.len() > MAX_FEATURES {
            return Err(t
                .err("feature", format!("more than {MAX_FEATURES} features"))
                .into());
        }
        let mut features: Vec<Feature> = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let prefix = format!("feature[{}]", i + 1);
            let f = Keys::new(path, &prefix, item);
            f.only(&["id", "nominal_mm", "certificate_mm", "u_um"])?;
            let fid = f.req_str("id")?;
            if features.iter().any(|g| g.id == fid) {
                return Err(f.err("id", format!("`{fid}` appears twice")).into());
            }
            let nominal_mm = f.req_vec3("nominal_mm")?;
            let certificate_mm = f.opt_vec3("certificate_mm")?;
            let u_um = f.opt_num("u_um")?;
            if certificate_mm.is_some() != u_um.is_some() {
                let missing = if u_um.is_none() {
                    "u_um"
                } else {
                    "certificate_mm"
                };
                return Err(f.err(missing, "certificate_mm and u_um go together").into());
            }
            if let Some(u) = u_um
                && u <= 0.0
            {
                return Err(f.err("u_um", "must be positive").into());
            }
            if kind.is_1d() {
                for (key, v) in [
                    ("nominal_mm", Some(nominal_mm)),
                    ("certificate_mm", certificate_mm),
                ] {
                    if let Some(v) = v
                        && (v[1] != 0.0 || v[2] != 0.0)
                    {
                        return Err(f
                            .err(
                                key,
                                "a 1-D artefact's features lie on its x axis (y = z = 0)",
                            )
                            .into());
                    }
                }
            }
            features.push(Feature {
                id: fid,
                nominal_mm,
                certificate_mm,
                u_um,
            });
        }
        let with = features
            .iter()
            .filter(|f| f.certificate_mm.is_some())
            .count();
        if with != 0 && with != features.len() {
            let first = features
                .iter()
                .position(|f| f.certificate_mm.is_none())
                .unwrap_or(0);
            return Err(ConfigError::key(
                path,
                format!("feature[{}].certificate_mm", first + 1),
                format!(
                    "{with} of {} features have a certificate: on every feature or none",
                    features.len()
                ),
            )
            .into());
        }
        Ok(Artefact {
            path: path.to_path_buf(),
            id,
            kind,
            alpha_ppm_per_k,
            reference_temp_c,
            features,
        })
    }
}

/// The plane of a 2-D artefact in the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plane {
    XY,
    XZ,
    YZ,
}

impl Plane {
    pub fn as_str(self) -> &'static str {
        match self {
            Plane::XY => "XY",
            Plane::XZ => "XZ",
            Plane::YZ => "YZ",
        }
    }

    pub fn parse(s: &str) -> Option<Plane> {
        [Plane::XY, Plane::XZ, Plane::YZ]
            .into_iter()
            .find(|p| p.as_str() == s)
    }

    /// The machine axes of the plane's first and second letter, and its normal.
    pub fn axes(self) -> [usize; 3] {
        match self {
            Plane::XY => [0, 1, 2],
            Plane::XZ => [0, 2, 1],
            Plane::YZ => [1, 2, 0],
        }
    }
}

/// How a position is oriented: a plane (2-D) or a direction (1-D).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Orientation {
    Plane {
        plane: Plane,
        rotation_deg: f64,
        flip: bool,
    },
    Direction([f64; 3]),
}

/// One position of a campaign.
#[derive(Debug, Clone, PartialEq)]
pub struct Position {
    pub id: String,
    /// Index into [`Campaign::artefacts`].
    pub artefact: usize,
    pub file: PathBuf,
    pub orientation: Orientation,
    pub origin_mm: [f64; 3],
    pub probe_mm: [f64; 3],
    pub temp_c: f64,
    pub sigma_um: f64,
}

/// A campaign file with its artefacts.
#[derive(Debug, Clone, PartialEq)]
pub struct Campaign {
    pub path: PathBuf,
    pub sigma_um: f64,
    pub artefacts: Vec<Artefact>,
    pub positions: Vec<Position>,
}

impl Campaign {
    /// Reads a campaign and the artefact files it names (paths relative to it).
    pub fn read(path: &Path) -> Result<Campaign, ArtefactError> {
        let table = read_table(path)?;
        let t = Keys::new(path, "", &table);
        t.only(&["sigma_um", "position"])?;
        let sigma_um = t.req_num("sigma_um")?;
        if sigma_um <= 0.0 {
            return Err(t.err("sigma_um", "must be positive").into());
        }
        let dir = path.parent().unwrap_or(Path::new(""));
        let items = t.array_of_tables("position")?;
        if items.is_empty() {
            return Err(t.err("position", "at least one position is needed").into());
        }
        let mut artefacts: Vec<Artefact> = Vec::new();
        let mut by_path: BTreeMap<PathBuf, usize> = BTreeMap::new();
        let mut positions: Vec<Position> = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let prefix = format!("position[{}]", i + 1);
            let p = Keys::new(path, &prefix, item);
            p.only(&[
                "id",
                "artefact",
                "file",
                "plane",
                "rotation_deg",
                "flip",
                "origin_mm",
                "probe_mm",
                "temp_c",
                "direction",
                "sigma_um",
            ])?;
            let id = p.req_str("id")?;
            if positions.iter().any(|q| q.id == id) {
                return Err(p.err("id", format!("`{id}` appears twice")).into());
            }
            let apath = dir.join(p.req_str("artefact")?);
            let a = match by_path.get(&apath) {
                Some(&k) => k,
                None => {
                    artefacts.push(Artefact::read(&apath)?);
                    by_path.insert(apath, artefacts.len() - 1);
                    artefacts.len() - 1
                }
            };
            let art = &artefacts[a];
            let orientation = orientation(&p, art.kind)?;
            let sigma = p.opt_num("sigma_um")?.unwrap_or(sigma_um);
            if sigma <= 0.0 {
                return Err(p.err("sigma_um", "must be positive").into());
            }
            positions.push(Position {
                id,
                artefact: a,
                file: dir.join(p.req_str("file")?),
                orientation,
                origin_mm: p.req_vec3("origin_mm")?,
                probe_mm: p.opt_vec3("probe_mm")?.unwrap_or([0.0; 3]),
                temp_c: p.opt_num("temp_c")?.unwrap_or(art.reference_temp_c),
                sigma_um: sigma,
            });
        }
        Ok(Campaign {
            path: path.to_path_buf(),
            sigma_um,
            artefacts,
            positions,
        })
    }
}

/// The orientation keys of a position: plane/rotation_deg/flip for a 2-D artefact,
/// direction (a unit vector) for a 1-D one; the other family is refused.
fn orientation(p: &Keys, kind: Kind) -> Result<Orientation, ArtefactError> {
    if kind.is_1d() {
        for key in ["plane", "rotation_deg", "flip"] {
            if p.has(key) {
                return Err(p
                    .err(
                        key,
                        "a 1-D artefact is placed by `direction`, not by a plane",
                    )
                    .into());
            }
        }
        let d = p.req_vec3("direction")?;
        let n = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (n - 1.0).abs() > 1e-6 {
            return Err(p
                .err("direction", format!("not a unit vector (length {n:.6})"))
                .into());
        }
        return Ok(Orientation::Direction(d));
    }
    if p.has("direction") {
        return Err(p
            .err(
                "direction",
                "a 2-D artefact is placed by plane, rotation_deg and flip",
            )
            .into());
    }
    let s = p.req_str("plane")?;
    let plane =
        Plane::parse(&s).ok_or_else(|| p.err("plane", format!("`{s}` is not XY, XZ or YZ")))?;
    Ok(Orientation::Plane {
        plane,
        rotation_deg: p.opt_num("rotation_deg")?.unwrap_or(0.0),
        flip: p.opt_bool("flip")?.unwrap_or(false),
    })
}

fn read_table(path: &Path) -> Result<toml::Table, ArtefactError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Access))?;
    text.parse::<toml::Table>()
        .map_err(|e| crate::base::parse_error(path, &e).into())
}

/// A TOML table with its dotted prefix, for errors that name the key.
struct Keys<'a> {
    path: &'a Path,
    prefix: String,
    t: &'a toml::Table,
}

impl<'a> Keys<'a> {
    fn new(path: &'a Path, prefix: &str, t: &'a toml::Table) -> Keys<'a> {
        Keys {
            path,
            prefix: prefix.to_string(),
            t,
        }
    }

    fn dotted(&self, key: &str) -> String {
        if self.prefix.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.prefix)
        }
    }

    fn err(&self, key: &str, message: impl Into<String>) -> ConfigError {
        ConfigError::key(self.path, self.dotted(key), message)
    }

    fn has(&self, key: &str) -> bool {
        self.t.contains_key(key)
    }

    fn only(&self, known: &[&str]) -> Result<(), ConfigError> {
        match self.t.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => Err(self.err(k, format!("unknown key (known: {})", known.join(", ")))),
            None => Ok(()),
        }
    }

    fn req_str(&self, key: &str) -> Result<String, ConfigError> {
        self.opt_str(key)?
            .ok_or_else(|| self.err(key, "missing (required)"))
    }

    fn opt_str(&self, key: &str) -> Result<Option<String>, ConfigError> {
        match self.t.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) if !s.trim().is_empty() => Ok(Some(s.clone())),
            Some(_) => Err(self.err(key, "must be a non-empty string")),
        }
    }

    fn opt_bool(&self, key: &str) -> Result<Option<bool>, ConfigError> {
        match self.t.get(key) {
            None => Ok(None),
            Some(toml::Value::Boolean(b)) => Ok(Some(*b)),
            Some(_) => Err(self.err(key, "must be true or false")),
        }
    }

    fn number(&self, key: &str, v: &toml::Value) -> Result<f64, ConfigError> {
        let x = match v {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(i) => *i as f64,
            _ => return Err(self.err(key, "must be a number")),
        };
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(key, "must be a finite number"))
        }
    }

    fn req_num(&self, key: &str) -> Result<f64, ConfigError> {
        self.opt_num(key)?
            .ok_or_else(|| self.err(key, "missing (required)"))
    }

    fn opt_num(&self, key: &str) -> Result<Option<f64>, ConfigError> {
        self.t.get(key).map(|v| self.number(key, v)).transpose()
    }

    fn req_vec3(&self, key: &str) -> Result<[f64; 3], ConfigError> {
        self.opt_vec3(key)?
            .ok_or_else(|| self.err(key, "missing (required)"))
    }

    fn opt_vec3(&self, key: &str) -> Result<Option<[f64; 3]>, ConfigError> {
        let Some(v) = self.t.get(key) else {
            return Ok(None);
        };
        let arr = v
            .as_array()
            .filter(|a| a.len() == 3)
            .ok_or_else(|| self.err(key, "must be a list of 3 numbers"))?;
        let mut out = [0.0; 3];
        for (o, x) in out.iter_mut().zip(arr) {
            *o = self.number(key, x)?;
        }
        Ok(Some(out))
    }

    fn array_of_tables(&self, key: &str) -> Result<Vec<&'a toml::Table>, ConfigError> {
        let Some(v) = self.t.get(key) else {
            return Err(self.err(key, "missing (required)"));
        };
        let arr = v
            .as_array()
            .ok_or_else(|| self.err(key, "must be an array of tables ([[…]])"))?;
        arr.iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_table()
                    .ok_or_else(|| self.err(&format!("{key}[{}]", i + 1), "must be a table"))
            })
            .collect()
    }
}

/// One measured feature: its index in the artefact, its data row, machine coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFeature {
    pub feature: usize,
    /// 1-based data row (on line row + 1).
    pub row: usize,
    pub x_mm: [f64; 3],
    /// False when the file has no z_mm column (a hole plate in `evaluate`).
    pub has_z: bool,
}

/// A measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    pub path: PathBuf,
    pub rows: Vec<MeasuredFeature>,
}

impl Measurement {
    /// Reads `feature,x_mm,y_mm,z_mm` (any order, other columns ignored); `z_mm` may be
    /// absent only when `z_optional`.
    pub fn read(
        path: &Path,
        art: &Artefact,
        z_optional: bool,
    ) -> Result<Measurement, ArtefactError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Access))?;
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| {
                ConfigError::file(path, "empty: a header feature,x_mm,y_mm,z_mm is needed")
            })?
            .split(',')
            .map(|s| s.trim().trim_matches('"').to_string())
            .collect();
        let col = |name: &str| header.iter().position(|h| h == name);
        let mut idx = [0usize; 4];
        for (k, name) in ["feature", "x_mm", "y_mm", "z_mm"].iter().enumerate() {
            match col(name) {
                Some(c) => idx[k] = c,
                None if k == 3 && z_optional => idx[k] = usize::MAX,
                None => {
                    return Err(ConfigError::position(
                        path,
                        1,
                        1,
                        format!("the header has no column `{name}` (feature,x_mm,y_mm,z_mm)"),
                    )
                    .into());
                }
            }
        }
        let mut rows: Vec<MeasuredFeature> = Vec::new();
        let mut seen: BTreeMap<usize, usize> = BTreeMap::new();
        for (r0, line) in lines.enumerate() {
            let row = r0 + 1;
            if line.trim().is_empty() {
                continue;
            }
            if rows.len() >= MAX_FEATURES {
                return Err(
                    ConfigError::file(path, format!("more than {MAX_FEATURES} rows")).into(),
                );
            }
            let cells: Vec<&str> = line
                .split(',')
                .map(|s| s.trim().trim_matches('"'))
                .collect();
            let cell = |k: usize| cells.get(idx[k]).copied();
            let bad = |k: usize, msg: String| {
                ConfigError::row(
                    path,
                    row,
                    row + 1,
                    Some(["feature", "x_mm", "y_mm", "z_mm"][k]),
                    msg,
                )
            };
            let id = cell(0)
                .filter(|s| !s.is_empty())
                .ok_or_else(|| bad(0, "missing".into()))?;
            let feature = art
                .feature(id)
                .ok_or_else(|| bad(0, format!("`{id}` is not a feature of artefact {}", art.id)))?;
            if let Some(first) = seen.insert(feature, row) {
                return Err(bad(0, format!("`{id}` measured twice (first in row {first})")).into());
            }
            let mut x_mm = [0.0; 3];
            let has_z = idx[3] != usize::MAX;
            for (k, xk) in x_mm.iter_mut().enumerate() {
                if k == 2 && !has_z {
                    continue;
                }
                let s = cell(k + 1).ok_or_else(|| bad(k + 1, "missing".into()))?;
                *xk = s
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad(k + 1, format!("`{s}` is not a finite number")))?;
            }
            rows.push(MeasuredFeature {
                feature,
                row,
                x_mm,
                has_z,
            });
        }
        Ok(Measurement {
            path: path.to_path_buf(),
            rows,
        })
    }
}
