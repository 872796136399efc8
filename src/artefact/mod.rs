//! Artefact-based error mapping (spec `artefact.md`, issue #36): ball and hole plates,
//! ball beams and step gauges measured by the machine itself in several positions.
//!
//! | module | does | cost |
//! |---|---|---|
//! | `files` | the artefact, campaign and measurement files, read and checked | O(features) |
//! | `placement` | nominal orientations R0, the rigid fit of a position, its bad-input checks | O(features) |
//! | `simulate` | the forward model: positions of artefacts on a machine with the 21 errors | O(features) |
//! | `design` | the linearised design: machine columns (volumetric basis), placements, deviations, priors, constraints | O(rows · unknowns) |
//! | `identify` | observability (null space split into undetermined and invariant), the constrained fit, Birge ratio | SVD O(rows · unknowns²) |
//! | `observe` | undetermined groups with suggested positions, the result's assembly | one observability per candidate |
//! | `doc` | `identify --json` | O(components) |
//! | `evaluate` | a plate's similarity (and distortion) fit, `--against`, a gauge's length errors | O(features) |
//!
//! Frames and signs are the spec's: X = R·f + t − E(a; p), the error of a feature is
//! indicated − reference = −E, as a laser line sees −u·E (`crate::volumetric`).

mod design;
mod doc;
mod error;
mod evaluate;
mod files;
mod identify;
mod observe;
mod placement;
mod simulate;

pub use doc::IdentifyDoc;
pub use error::ArtefactError;
pub use evaluate::{
    Against, Distortion, EvalSettings, Evaluation, Fitted, GaugeEvaluation, GaugeLength, MapFit,
    MapModel, PlateEvaluation, Residual2, evaluate, evaluate_gauge, evaluate_plate, fit_map,
};
pub use files::{
    Artefact, Campaign, Feature, Kind, MAX_FEATURES, MeasuredFeature, Measurement, Orientation,
    Plane, Position,
};
pub use identify::{
    ArtefactIdentification, CarrierPosition, DEGREE, FeatureDeviation, FittedPlacement,
    IdentifyOptions, Invariant, MapPoint, ResidualTest, SelfCalibration, Suggestion,
    UnidentifiedGroup, identify, identify_joint,
};
pub use placement::{
    FEATURE_OFF_MM, PLACEMENT_OFF_DEG, PLACEMENT_OFF_MM, Placement, checked_placement, frame_along,
    nominal_rotation, plane_basis, rigid_fit,
};
pub use simulate::{SimulatedFile, simulate, write_simulated};
