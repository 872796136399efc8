//! The ISO 10360-2 length test predicted from an identified volumetric model: a virtual
//! CMM (in the sense of ISO/TS 15530-4), before and after a compensation table.
//!
//! A test length with probe-point ends P1, P2 (probe offset p) and u = (P2 − P1)/|P2 − P1|
//! is predicted as E = −u·(E(P2; p) − E(P1; p)) µm, E(·) the volumetric error vector
//! (actual − nominal): indicated minus calibrated length, positive when the CMM measures
//! long. It is what `volumetric predict --lines` gives at P2 on a line through P1 and P2,
//! so this module asks the model through [`Predictor::predict_lines`] only; σ is that
//! prediction's one-sigma (identify's covariance, scaled by the residual). A rigid motion
//! of the error field leaves E unchanged, so the identification's gauge does not matter.
//!
//! **After compensation** (`compensated`): the controller subtracts, at the tool point
//! (probe offset 0), the component tables of [`component_tables`] sampled at
//! `n` positions per axis and interpolated linearly. What remains of a test length is
//! E_after = E − E_table with E_table the same projection of the tables' error vector at
//! P1 and P2 with p = 0: the tables' interpolation error and the angular errors times the
//! probe offset, which a table at the tool point cannot represent. Its σ is that of E —
//! after compensation, the model's own uncertainty is what is left to know. A model
//! compensating itself predicts E_after near 0 (issue 40: "0.000 µm"), which says nothing
//! of the machine: what is left is what the model does not know and what the table
//! cannot hold, so [`Compensated::floor_um`] states it, the largest over the lengths of
//! √((2σ)² + q²), 2σ the model's expanded uncertainty of the length and
//! q = [`TABLE_RESOLUTION_UM`] the value step of a controller's table (two entries, each
//! off by up to q/2). A compensated |E| below the floor is "within the floor", not zero.
//!
//! **Default plan** over the model's measured range [lo, hi]: positions `1`–`4` the space
//! diagonals (lo,lo,lo)→(hi,hi,hi), (hi,lo,lo)→(lo,hi,hi), (lo,hi,lo)→(hi,lo,hi),
//! (hi,hi,lo)→(lo,lo,hi); `5`, `6`, `7` through the centre parallel to X, Y, Z; on each, 5
//! lengths L = (0.10, 0.25, 0.40, 0.55, 0.70)·D (D the line's length) centred on its
//! midpoint; 3 repetitions (identical: the prediction has no repeatability).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::AcceptanceError;
use super::mpe::Mpe;
use super::rule::{ConformityVerdict, DecisionRule, Limits, aggregate};
use crate::base::FileOp;
use crate::base::io_err;
use crate::interp::Method;
use crate::volumetric::{
    Component, ComponentFn, ComponentTableError, Line, LineTable, Machine, Predictor, Target,
    Topology, Undetermined,
};
use crate::volumetric::{component_tables, fold_squareness};

/// A gauge end may lie this far outside the model's measured range, mm.
pub(crate) const RANGE_TOL_MM: f64 = 1e-3;
/// The default plan's fractions of the line length.
pub(crate) const FRACTIONS: [f64; 5] = [0.10, 0.25, 0.40, 0.55, 0.70];
/// Positions per axis of the compensation tables by default (as `volumetric export`).
pub const TABLE_POINTS: usize = 21;

/// Where a test length sits on its line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Placement {
    /// Centred on the line's midpoint.
    #[default]
    Centre,
    /// From the line's start.
    Start,
}

/// One position of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedPosition {
    pub id: String,
    pub start_mm: [f64; 3],
    pub end_mm: [f64; 3],
    pub lengths_mm: Vec<f64>,
    pub placement: Placement,
    pub probe_mm: [f64; 3],
}

/// A virtual test's plan.
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualPlan {
    /// `default` or the plan file's path.
    pub source: String,
    pub volume_mm: [[f64; 3]; 2],
    pub repetitions: usize,
    pub positions: Vec<PlannedPosition>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PositionFile {
    id: String,
    start_mm: [f64; 3],
    end_mm: [f64; 3],
    fractions: Option<Vec<f64>>,
    lengths_mm: Option<Vec<f64>>,
    placement: Option<Placement>,
    probe_mm: Option<[f64; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    volume_mm: Option<[[f64; 3]; 2]>,
    repetitions: Option<usize>,
    fractions: Option<Vec<f64>>,
    lengths_mm: Option<Vec<f64>>,
    placement: Option<Placement>,
    probe_mm: Option<[f64; 3]>,
    position: Option<Vec<PositionFile>>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// The 7 default lines over `volume_mm`.
pub fn default_lines(volume_mm: [[f64; 3]; 2]) -> Vec<(String, [f64; 3], [f64; 3])> {
    let [lo, hi] = volume_mm;
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    vec![
        ("1".into(), [lo[0], lo[1], lo[2]], [hi[0], hi[1], hi[2]]),
        ("2".into(), [hi[0], lo[1], lo[2]], [lo[0], hi[1], hi[2]]),
        ("3".into(), [lo[0], hi[1], lo[2]], [hi[0], lo[1], hi[2]]),
        ("4".into(), [hi[0], hi[1], lo[2]], [lo[0], lo[1], hi[2]]),
        ("5".into(), [lo[0], c[1], c[2]], [hi[0], c[1], c[2]]),
        ("6".into(), [c[0], lo[1], c[2]], [c[0], hi[1], c[2]]),
        ("7".into(), [c[0], c[1], lo[2]], [c[0], c[1], hi[2]]),
    ]
}

impl VirtualPlan {
    /// The default plan over `volume_mm`.
    pub fn default_over(volume_mm: [[f64; 3]; 2]) -> VirtualPlan {
        VirtualPlan {
            source: "default".into(),
            volume_mm,
            repetitions: 3,
            positions: default_lines(volume_mm)
                .into_iter()
                .map(|(id, s, e)| {
                    let d = norm(sub(e, s));
                    PlannedPosition {
                        id,
                        start_mm: s,
                        end_mm: e,
                        lengths_mm: FRACTIONS.iter().map(|f| f * d).collect(),
                        placement: Placement::Centre,
                        probe_mm: [0.0; 3],
                    }
                })
                .collect(),
        }
    }

    /// Reads a plan file; `model_volume` is the model's measured range (if it has one).
    pub fn read(
        path: &Path,
        model_volume: Option<[[f64; 3]; 2]>,
    ) -> Result<VirtualPlan, AcceptanceError> {
        let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
        let f: PlanFile = toml::from_str(&text)
            .map_err(|e| AcceptanceError::key(path, "file", e.to_string().trim().to_string()))?;
        let key = |k: &str, p: String| AcceptanceError::key(path, k, p);
        let volume_mm = plan_volume(path, &f, model_volume)?;
        let repetitions = f.repetitions.unwrap_or(3);
        if !(1..=100).contains(&repetitions) {
            return Err(key("repetitions", format!("{repetitions}: 1 … 100")));
        }
        if f.fractions.is_some() && f.lengths_mm.is_some() {
            return Err(key(
                "fractions",
                "and lengths_mm both given: one of them".into(),
            ));
        }
        type Planned<'a> = (String, [f64; 3], [f64; 3], Option<&'a PositionFile>);
        let lines: Vec<Planned> = match &f.position {
            Some(ps) if !ps.is_empty() => ps
                .iter()
                .map(|p| (p.id.clone(), p.start_mm, p.end_mm, Some(p)))
                .collect(),
            _ => default_lines(volume_mm)
                .into_iter()
                .map(|(id, s, e)| (id, s, e, None))
                .collect(),
        };
        let mut positions = Vec::new();
        for (i, line) in lines.into_iter().enumerate() {
            positions.push(planned_position(path, &f, i, line)?);
        }
        Ok(VirtualPlan {
            source: path.display().to_string(),
            volume_mm,
            repetitions,
            positions,
        })
    }
}

/// The plan's volume (its own, else the model's measured range), checked: finite
/// coordinates, lo not above hi.
fn plan_volume(
    path: &Path,
    f: &PlanFile,
    model_volume: Option<[[f64; 3]; 2]>,
) -> Result<[[f64; 3]; 2], AcceptanceError> {
    let key = |k: &str, p: String| AcceptanceError::key(path, k, p);
    let volume_mm = match (f.volume_mm, model_volume) {
        (Some(v), _) => v,
        (None, Some(v)) => v,
        (None, None) => {
            return Err(key(
                "volume_mm",
                "missing: the model has no measured range (a machine model), so the plan \
                 must give volume_mm = [[lo…], [hi…]]"
                    .into(),
            ));
        }
    };
    for v in volume_mm.iter().flatten() {
        if !(v.is_finite() && v.abs() <= 1e6) {
            return Err(key("volume_mm", format!("{v} is not a coordinate")));
        }
    }
    if (0..3).any(|k| volume_mm[0][k] > volume_mm[1][k]) {
        return Err(key("volume_mm", "lo above hi".into()));
    }
    Ok(volume_mm)
}

/// Position `i` (0-based) of the plan: its line (from the file, or a default line when
/// `p` is `None`), its gauge lengths (fractions or lengths, the position's own or the
/// plan's), placement and probe offset, checked.
fn planned_position(
    path: &Path,
    f: &PlanFile,
    i: usize,
    (id, s, e, p): (String, [f64; 3], [f64; 3], Option<&PositionFile>),
) -> Result<PlannedPosition, AcceptanceError> {
    let key = |k: &str, p: String| AcceptanceError::key(path, k, p);
    let k = |name: &str| match p {
        Some(_) => format!("position[{}].{name}", i + 1),
        None => name.to_string(),
    };
    for v in s.iter().chain(&e) {
        if !(v.is_finite() && v.abs() <= 1e6) {
            return Err(key(&k("start_mm"), format!("{v} is not a coordinate")));
        }
    }
    let d = norm(sub(e, s));
    if d <= 1e-6 {
        return Err(key(&k("end_mm"), "the same point as start_mm".into()));
    }
    let (fr, le) = match p {
        Some(p) if p.fractions.is_some() || p.lengths_mm.is_some() => {
            if p.fractions.is_some() && p.lengths_mm.is_some() {
                return Err(key(
                    &k("fractions"),
                    "and lengths_mm both given: one of them".into(),
                ));
            }
            (p.fractions.clone(), p.lengths_mm.clone())
        }
        _ => (f.fractions.clone(), f.lengths_mm.clone()),
    };
    let lengths_mm: Vec<f64> = match (fr, le) {
        (Some(fr), _) => {
            if let Some(x) = fr.iter().find(|x| !(**x > 0.0 && **x <= 1.0)) {
                return Err(key(&k("fractions"), format!("{x} is not in (0, 1]")));
            }
            fr.iter().map(|x| x * d).collect()
        }
        (None, Some(le)) => {
            if let Some(x) = le.iter().find(|x| !(**x > 0.0 && **x <= d + 1e-9)) {
                return Err(key(
                    &k("lengths_mm"),
                    format!("{x} mm is not in (0, {d}] (the line's length)"),
                ));
            }
            le
        }
        (None, None) => FRACTIONS.iter().map(|x| x * d).collect(),
    };
    if lengths_mm.is_empty() {
        return Err(key(&k("lengths_mm"), "no length".into()));
    }
    let probe_mm = p
        .and_then(|p| p.probe_mm)
        .or(f.probe_mm)
        .unwrap_or([0.0; 3]);
    if let Some(v) = probe_mm.iter().find(|v| !(v.is_finite() && v.abs() <= 1e4)) {
        return Err(key(&k("probe_mm"), format!("{v} is not an offset")));
    }
    Ok(PlannedPosition {
        id,
        start_mm: s,
        end_mm: e,
        lengths_mm,
        placement: p
            .and_then(|p| p.placement)
            .or(f.placement)
            .unwrap_or_default(),
        probe_mm,
    })
}

/// How the virtual test is judged (all optional).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VirtualConfig {
    pub mpe: Option<Mpe>,
    /// U_u, the uncertainty of the test itself as a function of L (`--u-um`).
    pub u: Option<Mpe>,
    pub rule: DecisionRule,
    /// Also predict after a compensation table of this many positions per axis.
    pub compensated: Option<usize>,
}

/// One predicted measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VirtualMeasurement {
    pub position: String,
    pub gauge: usize,
    pub repetition: usize,
    pub length_mm: f64,
    pub p1_mm: [f64; 3],
    pub p2_mm: [f64; 3],
    pub probe_mm: [f64; 3],
    pub e_um: f64,
    pub sigma_um: f64,
    pub mpe_um: Option<f64>,
    pub u_um: Option<f64>,
    pub verdict: Option<ConformityVerdict>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VirtualPosition {
    pub position: String,
    pub max_abs_e_um: f64,
    pub sigma_um: f64,
    pub gauge: usize,
    pub verdict: Option<ConformityVerdict>,
}

/// The value step of a controller's compensation table, µm: 0.1 µm, the finest unit of
/// the tables errmap writes (HEIDENHAIN and ISG lists hold 0.1 µm steps; see
/// `docs/import.md`).
pub(crate) const TABLE_RESOLUTION_UM: f64 = 0.1;

/// The test after compensation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Compensated {
    /// Positions per axis of the component tables.
    pub table_points: usize,
    pub measurements: Vec<VirtualMeasurement>,
    pub positions: Vec<VirtualPosition>,
    pub max_abs_e_um: f64,
    /// What the compensation cannot be shown to remove, µm: the largest √((2σ)² + q²)
    /// over the lengths (σ the model's one-sigma of the length, q the table's value step
    /// [`TABLE_RESOLUTION_UM`]). A predicted |E| below it is not evidence of zero error.
    pub floor_um: f64,
    pub verdict: Option<ConformityVerdict>,
}

/// `volumetric iso10360 --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VirtualTest {
    pub standard: &'static str,
    #[serde(rename = "virtual")]
    pub is_virtual: bool,
    pub topology: String,
    pub model_residual: String,
    pub volume_mm: [[f64; 3]; 2],
    pub plan: String,
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub statement: Option<String>,
    pub mpe: Option<Mpe>,
    pub measurements: Vec<VirtualMeasurement>,
    pub positions: Vec<VirtualPosition>,
    pub max_abs_e_um: f64,
    pub verdict: Option<ConformityVerdict>,
    /// Said in the report too: a residual that is not `consistent`.
    pub warnings: Vec<String>,
    pub compensated: Option<Compensated>,
}

/// The model behind a prediction: its predictor and what MODEL.json says of it.
#[derive(Debug)]
pub struct Model {
    pub predictor: Predictor,
    pub topology: String,
    /// identify's residual verdict (`consistent`, `missing_physics`), or `exact` for a
    /// machine model (the truth).
    pub residual: String,
    /// The measured range of each axis, `None` for a machine model.
    pub volume_mm: Option<[[f64; 3]; 2]>,
}

#[derive(Deserialize)]
struct ResidualHead {
    verdict: String,
}

#[derive(Deserialize)]
struct ModelHead {
    residual: Option<ResidualHead>,
}

impl Model {
    /// Reads MODEL.json (from `identify --out`) or a machine-model TOML.
    pub fn read(path: &Path) -> Result<Model, AcceptanceError> {
        let predictor = Predictor::read(path)?;
        match &predictor {
            Predictor::Machine(m) => Ok(Model {
                topology: m.topology.to_string(),
                residual: "exact".into(),
                volume_mm: None,
                predictor,
            }),
            Predictor::Fit(f) => {
                let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?;
                let head: ModelHead =
                    serde_json::from_str(&text).map_err(|e| AcceptanceError::Model {
                        path: path.to_path_buf(),
                        problem: e.to_string(),
                    })?;
                let r = f.basis.range_mm;
                Ok(Model {
                    topology: f.basis.topology.to_string(),
                    residual: head
                        .residual
                        .map(|r| r.verdict)
                        .unwrap_or_else(|| "unknown".into()),
                    volume_mm: Some([[r[0][0], r[1][0], r[2][0]], [r[0][1], r[1][1], r[2][1]]]),
                    predictor,
                })
            }
        }
    }
}

/// One planned gauge: position index, gauge rank, length and its ends.
struct Planned {
    position: usize,
    gauge: usize,
    length_mm: f64,
    p1: [f64; 3],
    p2: [f64; 3],
    u: [f64; 3],
    probe: [f64; 3],
}

fn planned(plan: &VirtualPlan) -> Vec<Planned> {
    let mut out = Vec::new();
    for (pi, p) in plan.positions.iter().enumerate() {
        let d = sub(p.end_mm, p.start_mm);
        let dl = norm(d);
        let u = [d[0] / dl, d[1] / dl, d[2] / dl];
        let mid = [
            0.5 * (p.start_mm[0] + p.end_mm[0]),
            0.5 * (p.start_mm[1] + p.end_mm[1]),
            0.5 * (p.start_mm[2] + p.end_mm[2]),
        ];
        let mut order: Vec<usize> = (0..p.lengths_mm.len()).collect();
        order.sort_by(|&a, &b| p.lengths_mm[a].total_cmp(&p.lengths_mm[b]));
        for (rank, &j) in order.iter().enumerate() {
            let l = p.lengths_mm[j];
            let (p1, p2) = match p.placement {
                Placement::Centre => (
                    [0, 1, 2].map(|k| mid[k] - 0.5 * l * u[k]),
                    [0, 1, 2].map(|k| mid[k] + 0.5 * l * u[k]),
                ),
                Placement::Start => (p.start_mm, [0, 1, 2].map(|k| p.start_mm[k] + l * u[k])),
            };
            out.push(Planned {
                position: pi,
                gauge: rank + 1,
                length_mm: l,
                p1,
                p2,
                u,
                probe: p.probe_mm,
            });
        }
    }
    out
}

/// Why the compensation tables could not be made into a machine.
#[derive(Debug, thiserror::Error)]
enum TableMachineError {
    #[error(transparent)]
    Undetermined(#[from] Undetermined),
    #[error("compensation table of {component}: {source}")]
    Table {
        component: String,
        source: ComponentTableError,
    },
}

/// The compensation tables as a machine (probe offset 0, squareness folded into the
/// straightness as the exported tables carry it).
fn table_machine(
    model: &Model,
    volume_mm: [[f64; 3]; 2],
    n: usize,
) -> Result<Machine, TableMachineError> {
    type Tables = (Topology, [Vec<f64>; 3], [Vec<[f64; 6]>; 3]);
    let (topology, positions, values): Tables = match &model.predictor {
        Predictor::Fit(f) => {
            let t = component_tables(f, n)?;
            (t.topology, t.positions_mm, t.values)
        }
        Predictor::Machine(m) => {
            let mut positions: [Vec<f64>; 3] = Default::default();
            let mut values: [Vec<[f64; 6]>; 3] = Default::default();
            let sq = m.squareness_urad;
            for k in 0..3 {
                let lo = volume_mm[0][k].min(0.0);
                let hi = volume_mm[1][k].max(0.0);
                for i in 0..n.max(2) {
                    let a = lo + (hi - lo) * i as f64 / (n.max(2) - 1) as f64;
                    let mut row = [0.0; 6];
                    for (kind, slot) in row.iter_mut().enumerate() {
                        *slot = m.value(Component { axis: k, kind }, a);
                    }
                    fold_squareness(&mut row, k, sq, a);
                    positions[k].push(a);
                    values[k].push(row);
                }
            }
            (m.topology, positions, values)
        }
    };
    let mut machine = Machine::perfect(topology);
    for k in 0..3 {
        let mut pos = positions[k].clone();
        let mut vals = values[k].clone();
        // Components are zero at 0: the table holds (0, 0) exactly.
        match pos.iter().position(|a| a.abs() < 1e-9) {
            Some(i) => {
                pos[i] = 0.0;
                vals[i] = [0.0; 6];
            }
            None => {
                pos.push(0.0);
                vals.push([0.0; 6]);
            }
        }
        for kind in 0..6 {
            let column: Vec<f64> = vals.iter().map(|r| r[kind]).collect();
            let c = Component { axis: k, kind };
            let f = ComponentFn::table(&pos, &column, Method::Trilinear).map_err(|source| {
                TableMachineError::Table {
                    component: c.name(),
                    source,
                }
            })?;
            machine.set(c, f);
        }
    }
    Ok(machine)
}

fn judge(ms: &mut [VirtualMeasurement], config: &VirtualConfig) -> Result<(), AcceptanceError> {
    let Some(mpe) = &config.mpe else {
        return Ok(());
    };
    for m in ms.iter_mut() {
        let limit = mpe.at(m.length_mm);
        let u_u = config.u.as_ref().map_or(0.0, |u| u.at(m.length_mm));
        let u = ((2.0 * m.sigma_um).powi(2) + u_u * u_u).sqrt();
        let d = config.rule.decide(
            m.e_um,
            u,
            Limits {
                lower: Some(-limit),
                upper: Some(limit),
            },
        )?;
        m.mpe_um = Some(limit);
        m.u_um = Some(u);
        m.verdict = Some(d.verdict);
    }
    Ok(())
}

fn summarise(
    plan: &VirtualPlan,
    ms: &[VirtualMeasurement],
) -> (Vec<VirtualPosition>, f64, Option<ConformityVerdict>) {
    let positions: Vec<VirtualPosition> = plan
        .positions
        .iter()
        .map(|p| {
            let of: Vec<&VirtualMeasurement> = ms.iter().filter(|m| m.position == p.id).collect();
            let worst = of
                .iter()
                .copied()
                .max_by(|a, b| a.e_um.abs().total_cmp(&b.e_um.abs()));
            VirtualPosition {
                position: p.id.clone(),
                max_abs_e_um: worst.map_or(0.0, |m| m.e_um.abs()),
                sigma_um: worst.map_or(0.0, |m| m.sigma_um),
                gauge: worst.map_or(0, |m| m.gauge),
                verdict: aggregate(of.iter().filter_map(|m| m.verdict)),
            }
        })
        .collect();
    let max = ms.iter().map(|m| m.e_um.abs()).fold(0.0, f64::max);
    let verdict = aggregate(ms.iter().filter_map(|m| m.verdict));
    (positions, max, verdict)
}

/// One virtual test being predicted: the model (and its file, for messages), the plan,
/// the configuration and the planned gauges, shared by the steps of `predict`.
struct VirtualRun<'a> {
    model_path: &'a Path,
    model: &'a Model,
    plan: &'a VirtualPlan,
    config: &'a VirtualConfig,
    gauges: Vec<Planned>,
}

impl VirtualRun<'_> {
    /// An error about the model, naming its file.
    fn err(&self, problem: String) -> AcceptanceError {
        AcceptanceError::Model {
            path: self.model_path.to_path_buf(),
            problem,
        }
    }

    /// Refuses a gauge end outside the model's measured range (an extrapolation the
    /// model's σ does not cover).
    fn check_in_range(&self) -> Result<(), AcceptanceError> {
        let Some([lo, hi]) = self.model.volume_mm else {
            return Ok(());
        };
        for g in &self.gauges {
            for (end, p) in [("P1", g.p1), ("P2", g.p2)] {
                if let Some(k) =
                    (0..3).find(|&k| p[k] < lo[k] - RANGE_TOL_MM || p[k] > hi[k] + RANGE_TOL_MM)
                {
                    return Err(self.err(format!(
                        "position `{}`, gauge {}: end {end} = ({}, {}, {}) mm is outside the \
                         model's measured range of {} [{}, {}] mm",
                        self.plan.positions[g.position].id,
                        g.gauge,
                        p[0],
                        p[1],
                        p[2],
                        ["x", "y", "z"][k],
                        lo[k],
                        hi[k]
                    )));
                }
            }
        }
        Ok(())
    }

    /// Each gauge's predicted error and one-sigma (P2's along the gauge, the line through
    /// P1 and P2 with P1 as its zero), refused when the model cannot predict it.
    fn predict_gauges(&self) -> Result<Vec<(f64, f64)>, AcceptanceError> {
        let gauges = &self.gauges;
        let target = |p: [f64; 3]| Target {
            row: 0,
            pos_mm: p,
            e_um: None,
            s_um: None,
            t_s: None,
            scale_temp_c: None,
            air_temp_c: None,
            part_temp_c: None,
        };
        let table = LineTable {
            source: "ISO 10360-2 plan".into(),
            lines: gauges
                .iter()
                .enumerate()
                .map(|(i, g)| Line {
                    id: i.to_string(),
                    u: g.u,
                    probe_mm: g.probe,
                    targets: vec![target(g.p1), target(g.p2)],
                })
                .collect(),
        };
        let preds = self.model.predictor.predict_lines(&table);
        let mut base = Vec::with_capacity(gauges.len());
        for (i, g) in gauges.iter().enumerate() {
            let p = &preds[2 * i + 1];
            match (p.e_um, p.sigma_um) {
                (Some(e), Some(s)) if e.is_finite() && s.is_finite() => base.push((e, s)),
                _ => {
                    let why = self
                        .model
                        .predictor
                        .predict_grid(&[g.p1, g.p2], g.probe)
                        .err()
                        .map_or_else(
                            || "a component the lines did not determine".into(),
                            |e| e.to_string(),
                        );
                    return Err(self.err(format!(
                        "position `{}`, gauge {} cannot be predicted: {why}",
                        self.plan.positions[g.position].id, g.gauge
                    )));
                }
            }
        }
        Ok(base)
    }

    /// The plan's measurements (every repetition of every gauge) with the gauges'
    /// predicted (e, σ) `values`, not judged yet.
    fn expand(&self, values: &[(f64, f64)]) -> Vec<VirtualMeasurement> {
        let plan = self.plan;
        let mut out = Vec::new();
        for (g, &(e, s)) in self.gauges.iter().zip(values) {
            for r in 1..=plan.repetitions {
                out.push(VirtualMeasurement {
                    position: plan.positions[g.position].id.clone(),
                    gauge: g.gauge,
                    repetition: r,
                    length_mm: g.length_mm,
                    p1_mm: g.p1,
                    p2_mm: g.p2,
                    probe_mm: g.probe,
                    e_um: e,
                    sigma_um: s,
                    mpe_um: None,
                    u_um: None,
                    verdict: None,
                })
            }
        }
        out
    }

    /// The test again after compensation by the model's table at `n` points per axis:
    /// each gauge's error less what the table corrects between its ends.
    fn compensated(&self, n: usize, base: &[(f64, f64)]) -> Result<Compensated, AcceptanceError> {
        let (plan, config) = (self.plan, self.config);
        let tab =
            table_machine(self.model, plan.volume_mm, n).map_err(|p| self.err(p.to_string()))?;
        let after: Vec<(f64, f64)> = self
            .gauges
            .iter()
            .zip(base)
            .map(|(g, &(e, s))| {
                let t =
                    tab.line_error_um(g.p2, g.u, [0.0; 3]) - tab.line_error_um(g.p1, g.u, [0.0; 3]);
                (e - t, s)
            })
            .collect();
        let mut ms = self.expand(&after);
        judge(&mut ms, config)?;
        let (positions, max_abs_e_um, verdict) = summarise(plan, &ms);
        let floor_um = after
            .iter()
            .map(|&(_, s)| (4.0 * s * s + TABLE_RESOLUTION_UM * TABLE_RESOLUTION_UM).sqrt())
            .fold(0.0, f64::max);
        Ok(Compensated {
            table_points: n,
            measurements: ms,
            positions,
            max_abs_e_um,
            floor_um,
            verdict,
        })
    }
}

/// The decision statement of a virtual test: the rule's, and what predicted E is judged
/// against with which U.
fn virtual_statement(config: &VirtualConfig) -> Option<String> {
    config.mpe.as_ref().map(|m| {
        format!(
            "{} Predicted E (the geometric part of E0 only: no probing error, repeatability or \
             thermal state) is judged against ±MPE_E0(L) = ±({}) µm with U = √((2σ)² + U_u²), \
             σ the model's one-sigma{}.",
            config.rule.statement(true, Some(2.0)),
            m.formula,
            match &config.u {
                Some(u) => format!(" and U_u = {} µm the test's own", u.formula),
                None => ", U_u = 0".into(),
            }
        )
    })
}

/// Predicts the test of `plan` from `model` (read from `model_path`, named in errors).
pub fn predict(
    model_path: &Path,
    model: &Model,
    plan: &VirtualPlan,
    config: &VirtualConfig,
) -> Result<VirtualTest, AcceptanceError> {
    let run = VirtualRun {
        model_path,
        model,
        plan,
        config,
        gauges: planned(plan),
    };
    run.check_in_range()?;
    let base = run.predict_gauges()?;
    let mut measurements = run.expand(&base);
    judge(&mut measurements, config)?;
    let (positions, max_abs_e_um, verdict) = summarise(plan, &measurements);
    let compensated = match config.compensated {
        None => None,
        Some(n) => Some(run.compensated(n, &base)?),
    };
    let mut warnings = Vec::new();
    if model.residual != "consistent" && model.residual != "exact" {
        warnings.push(format!(
            "the model's residual is `{}`, not consistent with the noise: σ covers the \
             parameters' uncertainty only, not what the model leaves out, so the predicted \
             E and its U understate the real test's spread",
            model.residual
        ));
    }
    let statement = virtual_statement(config);
    Ok(VirtualTest {
        standard: super::iso10360::STANDARD,
        is_virtual: true,
        topology: model.topology.clone(),
        model_residual: model.residual.clone(),
        volume_mm: plan.volume_mm,
        plan: plan.source.clone(),
        rule: config.rule.rule.name(),
        guard_fraction: config.rule.fraction_shown(),
        statement,
        mpe: config.mpe.clone(),
        measurements,
        positions,
        max_abs_e_um,
        verdict,
        warnings,
        compensated,
    })
}
