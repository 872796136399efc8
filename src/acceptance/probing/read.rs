//! The two inputs of the probing test: the sphere's certificate with the MPEs and the
//! test's own uncertainty (SPHERE, TOML), and the probed points (POINTS, CSV or Parquet).
//! Each is refused with the file and the key, row, column or option named.

use std::path::Path;

use super::super::decide::text_cell;
use super::super::rule::{DecisionRule, Rule};
use super::super::{AcceptanceError, ProbingSetting, SettingProblem};
use crate::base::FileOp;
use crate::base::{io_err, parse_error};
use crate::table::{column_cells, parse_cell, read_frame, text_or_number_cells};

/// The calibrated test sphere (`[sphere]`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SphereCertificate {
    /// Its identification, printed as given.
    pub id: Option<String>,
    /// D_cal at 20 °C, mm.
    pub diameter_mm: f64,
    /// U(D), k = 2, µm.
    pub u_diameter_um: f64,
    /// F_s, the calibrated form deviation, µm.
    pub form_um: f64,
    /// U(F_s), k = 2, µm.
    pub u_form_um: f64,
}

/// Three values, one per quantity, µm (`[mpe]`, `[uncertainty]`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PerQuantity {
    pub form_um: Option<f64>,
    pub size_um: Option<f64>,
    pub location_um: Option<f64>,
}

/// The SPHERE file.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereFile {
    pub sphere: SphereCertificate,
    /// `[mpe]`, each key optional.
    pub mpe: PerQuantity,
    /// `[uncertainty]`: U_t of each quantity, k = 2 (absent = 0).
    pub uncertainty: PerQuantity,
}

const QUANTITY_KEYS: [&str; 3] = ["form_um", "size_um", "location_um"];

fn number(path: &Path, key: &str, v: &toml::Value) -> Result<f64, AcceptanceError> {
    let x = match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        other => {
            return Err(AcceptanceError::key(
                path,
                key,
                format!("must be a number, not a {}", other.type_str()),
            ));
        }
    };
    if !x.is_finite() {
        return Err(AcceptanceError::key(
            path,
            key,
            format!("{x} is not finite"),
        ));
    }
    Ok(x)
}

/// A table's keys checked against `allowed`; the table itself.
fn table<'a>(
    path: &Path,
    key: &str,
    v: &'a toml::Value,
    allowed: &[&str],
) -> Result<&'a toml::Table, AcceptanceError> {
    let t = v
        .as_table()
        .ok_or_else(|| AcceptanceError::key(path, key, "must be a table"))?;
    if let Some(k) = t.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(AcceptanceError::key(
            path,
            format!("{key}.{k}"),
            format!("unknown key (allowed: {})", allowed.join(", ")),
        ));
    }
    Ok(t)
}

/// `[mpe]` or `[uncertainty]`: each value checked by `ok` (a problem in words, or none).
fn per_quantity(
    path: &Path,
    name: &str,
    v: Option<&toml::Value>,
    ok: fn(f64) -> Option<&'static str>,
) -> Result<PerQuantity, AcceptanceError> {
    let Some(v) = v else {
        return Ok(PerQuantity::default());
    };
    let t = table(path, name, v, &QUANTITY_KEYS)?;
    let mut out = [None; 3];
    for (k, key) in QUANTITY_KEYS.iter().enumerate() {
        if let Some(v) = t.get(*key) {
            let full = format!("{name}.{key}");
            let x = number(path, &full, v)?;
            if let Some(problem) = ok(x) {
                return Err(AcceptanceError::key(path, full, format!("{x}: {problem}")));
            }
            out[k] = Some(x);
        }
    }
    Ok(PerQuantity {
        form_um: out[0],
        size_um: out[1],
        location_um: out[2],
    })
}

fn sphere_table(
    path: &Path,
    v: Option<&toml::Value>,
) -> Result<SphereCertificate, AcceptanceError> {
    let v = v.ok_or_else(|| {
        AcceptanceError::key(path, "sphere", "missing: the sphere's certificate table")
    })?;
    let allowed = ["id", "diameter_mm", "u_diameter_um", "form_um", "u_form_um"];
    let t = table(path, "sphere", v, &allowed)?;
    let id = match t.get("id") {
        None => None,
        Some(toml::Value::String(s)) => Some(s.clone()),
        Some(other) => {
            return Err(AcceptanceError::key(
                path,
                "sphere.id",
                format!("must be text, not a {}", other.type_str()),
            ));
        }
    };
    let get = |key: &str, required: bool| -> Result<f64, AcceptanceError> {
        let full = format!("sphere.{key}");
        match t.get(key) {
            Some(v) => {
                let x = number(path, &full, v)?;
                if x < 0.0 {
                    return Err(AcceptanceError::key(path, full, format!("{x} is negative")));
                }
                Ok(x)
            }
            None if required => Err(AcceptanceError::key(path, full, "missing (required)")),
            None => Ok(0.0),
        }
    };
    let diameter_mm = get("diameter_mm", true)?;
    if diameter_mm <= 0.0 {
        return Err(AcceptanceError::key(
            path,
            "sphere.diameter_mm",
            format!("{diameter_mm} mm: a diameter must be > 0"),
        ));
    }
    Ok(SphereCertificate {
        id,
        diameter_mm,
        u_diameter_um: get("u_diameter_um", true)?,
        form_um: get("form_um", true)?,
        u_form_um: get("u_form_um", false)?,
    })
}

impl SphereFile {
    /// Parses SPHERE text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<SphereFile, AcceptanceError> {
        let doc: toml::Table = toml::from_str(text).map_err(|e| parse_error(path, &e))?;
        let top = ["sphere", "mpe", "uncertainty"];
        if let Some(k) = doc.keys().find(|k| !top.contains(&k.as_str())) {
            return Err(AcceptanceError::key(
                path,
                k.clone(),
                "unknown table or key (allowed: [sphere], [mpe], [uncertainty])",
            ));
        }
        let sphere = sphere_table(path, doc.get("sphere"))?;
        let mpe = per_quantity(path, "mpe", doc.get("mpe"), |x| {
            (x <= 0.0).then_some("an MPE must be > 0 µm")
        })?;
        let uncertainty = per_quantity(path, "uncertainty", doc.get("uncertainty"), |x| {
            (x < 0.0).then_some("an expanded uncertainty must be ≥ 0 µm")
        })?;
        Ok(SphereFile {
            sphere,
            mpe,
            uncertainty,
        })
    }

    /// Reads and checks a SPHERE file.
    pub fn read(path: &Path) -> Result<SphereFile, AcceptanceError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        Self::parse(&text, path)
    }
}

/// What the command line adds to the SPHERE file.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProbingOptions {
    /// `--mpe-form`, `--mpe-size`, `--mpe-location` (µm): each overrides its `[mpe]` key.
    pub mpe: PerQuantity,
    /// `--rule` (default ISO 14253-1).
    pub rule: Option<Rule>,
    /// `--guard-fraction` (default 1).
    pub guard_fraction: Option<f64>,
}

/// How a probing test is judged: the sphere, the MPEs in force, U_t and the rule.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbingConfig {
    pub sphere: SphereCertificate,
    pub mpe_form_um: f64,
    pub mpe_size_um: f64,
    pub mpe_location_um: Option<f64>,
    /// U_t of form, size and location (0 when absent).
    pub u_test: [f64; 3],
    pub rule: DecisionRule,
}

impl ProbingConfig {
    /// The SPHERE file with the options over it, checked in the contract's order (an
    /// option's MPE, an MPE given nowhere, the guard fraction); `path` (SPHERE) is named.
    pub fn resolve(
        path: &Path,
        file: SphereFile,
        options: &ProbingOptions,
    ) -> Result<ProbingConfig, AcceptanceError> {
        let setting = |setting, problem| AcceptanceError::Setting {
            path: path.to_path_buf(),
            setting,
            problem,
        };
        let opt = [
            (ProbingSetting::MpeForm, options.mpe.form_um),
            (ProbingSetting::MpeSize, options.mpe.size_um),
            (ProbingSetting::MpeLocation, options.mpe.location_um),
        ];
        for (which, v) in opt {
            if let Some(x) = v
                && !(x.is_finite() && x > 0.0)
            {
                return Err(setting(which, SettingProblem::NotPositive(x)));
            }
        }
        let form = options.mpe.form_um.or(file.mpe.form_um);
        let size = options.mpe.size_um.or(file.mpe.size_um);
        let (Some(mpe_form_um), Some(mpe_size_um)) = (form, size) else {
            let which = if form.is_none() {
                ProbingSetting::MpeForm
            } else {
                ProbingSetting::MpeSize
            };
            return Err(setting(which, SettingProblem::Missing));
        };
        let r = options.guard_fraction.unwrap_or(1.0);
        let rule = DecisionRule::new(options.rule.unwrap_or_default(), r)
            .map_err(|_| setting(ProbingSetting::GuardFraction, SettingProblem::Fraction(r)))?;
        let u = file.uncertainty;
        Ok(ProbingConfig {
            sphere: file.sphere,
            mpe_form_um,
            mpe_size_um,
            mpe_location_um: options.mpe.location_um.or(file.mpe.location_um),
            u_test: [
                u.form_um.unwrap_or(0.0),
                u.size_um.unwrap_or(0.0),
                u.location_um.unwrap_or(0.0),
            ],
            rule,
        })
    }
}

/// One probed point as read.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbePoint {
    /// 1-based data row.
    pub row: usize,
    pub stylus: String,
    /// The target number, ≥ 1.
    pub point: usize,
    /// The surface point, tip radius corrected, mm.
    pub p_mm: [f64; 3],
}

/// The largest target number accepted (a bound, not a design rule).
pub(crate) const MAX_POINT: f64 = 1e6;

/// Reads POINTS: every column present first, then every row (refusals 2 of the contract).
pub fn read_points(path: &Path) -> Result<Vec<ProbePoint>, AcceptanceError> {
    let df = read_frame(path)?;
    for name in ["stylus", "point", "x_mm", "y_mm", "z_mm"] {
        if df.column(name).is_err() {
            return Err(AcceptanceError::file(
                path,
                format!("column `{name}` is missing (columns: stylus, point, x_mm, y_mm, z_mm)"),
            ));
        }
    }
    let stylus = text_or_number_cells(path, &df, "stylus")?;
    let point = column_cells(path, &df, "point")?;
    let xyz = [
        column_cells(path, &df, "x_mm")?,
        column_cells(path, &df, "y_mm")?,
        column_cells(path, &df, "z_mm")?,
    ];
    if df.height() == 0 {
        return Err(AcceptanceError::file(path, "no data rows"));
    }
    let mut out = Vec::with_capacity(df.height());
    for r0 in 0..df.height() {
        let row = r0 + 1;
        let s = text_cell(&stylus, r0)
            .ok_or_else(|| AcceptanceError::row(path, row, Some("stylus"), "empty"))?;
        let n = parse_cell(path, &point, r0, "point")?
            .ok_or_else(|| AcceptanceError::row(path, row, Some("point"), "empty"))?;
        if !(n >= 1.0 && n.fract() == 0.0 && n <= MAX_POINT) {
            return Err(AcceptanceError::row(
                path,
                row,
                Some("point"),
                format!("{n} is not a point number (an integer ≥ 1)"),
            ));
        }
        let mut p = [0.0; 3];
        for (k, name) in ["x_mm", "y_mm", "z_mm"].iter().enumerate() {
            p[k] = parse_cell(path, &xyz[k], r0, name)?
                .ok_or_else(|| AcceptanceError::row(path, row, Some(name), "empty"))?;
        }
        out.push(ProbePoint {
            row,
            stylus: s,
            point: n as usize,
            p_mm: p,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SphereFile, AcceptanceError> {
        SphereFile::parse(text, Path::new("s.toml"))
    }

    #[test]
    fn sphere_files_name_the_key_at_fault() {
        let ok = "[sphere]\ndiameter_mm = 30\nu_diameter_um = 0.1\nform_um = 0.05\n";
        let f = parse(ok).expect("parses");
        assert_eq!(f.sphere.u_form_um, 0.0);
        assert_eq!(f.mpe, PerQuantity::default());
        for (bad, key) in [
            ("", "sphere"),
            (
                "[sphere]\ndiameter_mm = 30\nform_um = 0.05\n",
                "sphere.u_diameter_um",
            ),
            (&format!("{ok}colour = 1\n"), "sphere.colour"),
            (&format!("{ok}[mpe]\nform_um = 0\n"), "mpe.form_um"),
            (&format!("{ok}[mpe]\nshape_um = 1\n"), "mpe.shape_um"),
            (
                &format!("{ok}[uncertainty]\nsize_um = -0.1\n"),
                "uncertainty.size_um",
            ),
            (&format!("{ok}[extra]\n"), "extra"),
            (&ok.replace("30", "-30"), "sphere.diameter_mm"),
            (&ok.replace("30", "nan"), "sphere.diameter_mm"),
            (&ok.replace("30", "\"30\""), "sphere.diameter_mm"),
        ] {
            let e = parse(bad).expect_err(bad).to_string();
            assert!(e.starts_with(&format!("s.toml: {key}: ")), "{bad}: {e}");
        }
    }
}
