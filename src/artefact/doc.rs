//! `artefact identify --json`: one document, the keys of `artefact.md`.

use std::collections::BTreeMap;

use serde::Serialize;

use super::identify::{
    ArtefactIdentification, FittedPlacement, ResidualTest, SelfCalibration, UnidentifiedGroup,
};
use crate::volumetric::{ComponentDoc, Topology};

/// The identification as `--json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct IdentifyDoc {
    pub topology: Topology,
    pub rms_residual_um: f64,
    pub positions: usize,
    pub features: usize,
    pub components: BTreeMap<String, ComponentDoc>,
    pub unidentified: Vec<UnidentifiedGroup>,
    pub placements: Vec<FittedPlacement>,
    pub self_calibration: Option<SelfCalibration>,
    pub residual: ResidualTest,
}

impl ArtefactIdentification {
    /// The `--json` document; `positions` report positions per component.
    pub fn doc(&self, positions: usize) -> IdentifyDoc {
        IdentifyDoc {
            topology: self.model.topology,
            rms_residual_um: self.rms_residual_um,
            positions: self.placements.len(),
            features: self.features,
            components: self.model.doc(positions, false).components,
            unidentified: self.unidentified.clone(),
            placements: self.placements.clone(),
            self_calibration: self.self_calibration.clone(),
            residual: self.residual.clone(),
        }
    }
}
