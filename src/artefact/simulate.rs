//! `artefact simulate`: the forward model of a campaign. Each position's features are
//! placed as stated (R0, t = origin_mm), expanded to the position's temperature from the
//! certificate (else nominal), and moved by the machine's error at the axis positions:
//! X = R0·f(T) + t − E(X − p; p), solved to first order (E evaluated at the nominal
//! X0 = R0·f(T) + t: E varies by ≪ 1 µm over the µm it moves the point), plus Gaussian
//! noise per coordinate.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use rand::SeedableRng;

use super::error::ArtefactError;
use super::files::Campaign;
use super::placement::nominal_rotation;
use crate::base::{FileOp, gaussian, io_err};
use crate::volumetric::Predictor;

/// One simulated measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedFile {
    /// The basename of the position's `file`.
    pub name: String,
    /// (feature id, machine coordinates mm), in the artefact's order.
    pub rows: Vec<(String, [f64; 3])>,
}

/// The machine's error vector (µm) at axis positions `a` with stylus offset `p`.
pub(crate) fn error_vectors(
    model: &Predictor,
    a: &[[f64; 3]],
    p: [f64; 3],
) -> Result<Vec<[f64; 3]>, ArtefactError> {
    model
        .predict_grid(a, p)
        .map(|v| v.into_iter().map(|(e, _)| e).collect())
        .map_err(ArtefactError::from)
}

/// Every position's measurement, `sigma_um` noise per coordinate from `seed`.
pub fn simulate(
    campaign: &Campaign,
    model: &Predictor,
    sigma_um: f64,
    seed: u64,
) -> Result<Vec<SimulatedFile>, ArtefactError> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(campaign.positions.len());
    for pos in &campaign.positions {
        let art = &campaign.artefacts[pos.artefact];
        let r0 = nominal_rotation(&pos.orientation);
        let t = Vector3::from(pos.origin_mm);
        let x0: Vec<Vector3<f64>> = (0..art.features.len())
            .map(|i| r0 * Vector3::from(art.at_temp_mm(i, pos.temp_c)) + t)
            .collect();
        let p = Vector3::from(pos.probe_mm);
        let a: Vec<[f64; 3]> = x0.iter().map(|x| (x - p).into()).collect();
        let e = error_vectors(model, &a, pos.probe_mm)?;
        let rows = x0
            .iter()
            .zip(&e)
            .zip(&art.features)
            .map(|((x, e), f)| {
                let mut v = [0.0; 3];
                for k in 0..3 {
                    v[k] = x[k] - 1e-3 * e[k] + 1e-3 * sigma_um * gaussian(&mut rng);
                }
                (f.id.clone(), v)
            })
            .collect();
        let name = pos
            .file
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| format!("{}.csv", pos.id));
        out.push(SimulatedFile { name, rows });
    }
    Ok(out)
}

/// Writes the files into `dir`, which must not exist (nothing recorded is replaced).
pub fn write_simulated(dir: &Path, files: &[SimulatedFile]) -> Result<Vec<PathBuf>, ArtefactError> {
    if dir.exists() {
        return Err(ArtefactError::Exists {
            path: dir.to_path_buf(),
        });
    }
    std::fs::create_dir(dir).map_err(io_err(dir, FileOp::Write))?;
    let mut written = Vec::new();
    for f in files {
        let mut text = String::from("feature,x_mm,y_mm,z_mm\n");
        for (id, x) in &f.rows {
            text.push_str(&format!("{id},{:.9},{:.9},{:.9}\n", x[0], x[1], x[2]));
        }
        let path = dir.join(&f.name);
        std::fs::write(&path, text).map_err(io_err(&path, FileOp::Write))?;
        written.push(path);
    }
    Ok(written)
}
