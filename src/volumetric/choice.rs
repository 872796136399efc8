//! The component models an identification chooses between, and their evaluation: the
//! 21 errors of one basis fitted (least squares or penalised), the scale's α tested, the
//! campaign terms selected on top, the residual tested. The selection rule is
//! [`super::identify::identify`]'s.

use nalgebra::DMatrix;

use super::basis::Basis;
use super::campaign;
use super::error::Unfit;
use super::identifiability::suggest;
use super::identify::{
    Design, LineResidual, Solved, Unidentified, augment, decompose, design, identified_flags,
    solve, thermal_fit,
};
use super::lines::LineTable;
use super::model::{Component, Topology};
use super::residual::residual_test;
use super::smooth::{self, Block, Penalty};
use super::spline;
use super::thermal::{self, ThermalTest};
use crate::diagnose::FoundEffect;

/// How a design is solved: least squares on the determined subspace (polynomials) or
/// penalised with the smoothing parameters found by REML (tables at knots).
pub(crate) enum Engine {
    LeastSquares,
    Penalised {
        pen: Penalty,
        /// Rows weighted by a stated σ (s_um): the covariance is not narrowed below it.
        known_noise: bool,
    },
}

impl Engine {
    pub(crate) fn solve(&self, d: &Design, n_lines: usize) -> Result<Solved, Unfit> {
        match self {
            Engine::LeastSquares => solve(d, n_lines),
            Engine::Penalised { pen, known_noise } => {
                pen.fit(d, &pen.lambda, n_lines, *known_noise)
            }
        }
    }

    fn fitter(&self) -> Box<campaign::Fitter<'_>> {
        match self {
            Engine::LeastSquares => Box::new(campaign::least_squares),
            // Campaign terms are scored against the unpenalised tables: a term must stand
            // out from anything the tables could absorb, not only from what the smoothing
            // kept (scoring against the smoothed fit named drifts that were unresolved
            // local features).
            Engine::Penalised { pen, .. } => {
                let f: Box<campaign::Fitter<'_>> =
                    Box::new(move |d: &Design, n: usize| pen.residualiser(d, n, NEAR_LS));
                f
            }
        }
    }
}

/// The factor on REML's λ of the tables campaign terms are scored against: nearly the
/// unpenalised fit (a penalty at rounding level only keeps the factorisation defined).
pub(super) const NEAR_LS: f64 = 1e-6;

/// One component model fitted with the campaign terms on top: what the selection compares.
pub(crate) struct Outcome {
    pub solved: Solved,
    pub thermal: Option<ThermalTest>,
    pub campaign_effects: Vec<FoundEffect>,
    pub residuals: Vec<LineResidual>,
    pub rms_residual_um: f64,
    pub z: f64,
}

/// The 21 errors of `basis` (design `d`) fitted by `engine`, the scale's α tested, the
/// campaign terms selected and fitted jointly, the residual tested.
pub(crate) fn evaluate(
    table: &LineTable,
    d: &Design,
    engine: &Engine,
    thermal_col: Option<&thermal::ThermalColumn>,
    row_w: &[f64],
    weighted: bool,
) -> Result<Outcome, Unfit> {
    let n_lines = table.lines.len();
    let plain = engine.solve(d, n_lines)?;
    let (thermal, joint) = match thermal_col {
        Some(col) => {
            let (t, s) = thermal_fit(d, col, n_lines, engine);
            (Some(t), s)
        }
        None => (None, None),
    };
    // The campaign's own terms (a drift, a bad line) on top of the 21 errors and α.
    let thermal_kept = thermal
        .as_ref()
        .filter(|t| t.kept)
        .and(thermal_col)
        .and_then(|c| augment(d, &c.centred));
    let fitter = engine.fitter();
    let (chosen, joint_campaign) =
        campaign::select(table, row_w, thermal_kept.as_ref().unwrap_or(d), &*fitter);
    let extra = joint_campaign.and_then(|dd| {
        let first = dd.a.ncols() - chosen.len();
        engine.solve(&dd, n_lines).ok().map(|s| (first, s))
    });
    let (solved, campaign_effects) = match extra {
        Some((first, s)) => {
            let effects: Vec<_> = chosen
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let j = first + k;
                    campaign::effect(table, c, s.theta[j], s.cov[(j, j)].max(0.0).sqrt())
                })
                .collect();
            (s, effects)
        }
        None => (joint.unwrap_or(plain), Vec::new()),
    };
    // Residuals, unweighted, in line order sorted along the line.
    let mut residuals = Vec::new();
    let mut all_r = Vec::with_capacity(table.targets());
    for (line, rr) in table.lines.iter().zip(&d.line_rows) {
        let mut v: Vec<(f64, Option<f64>, f64)> = line
            .targets
            .iter()
            .zip(rr.clone())
            .map(|(t, i)| (line.s_mm(t), t.t_s, solved.res_w[i] / d.sqrt_w[i]))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        all_r.extend(v.iter().map(|x| x.2));
        residuals.push(LineResidual {
            line: line.id.clone(),
            s_mm: v.iter().map(|x| x.0).collect(),
            t_s: v.iter().map(|x| x.1).collect(),
            r_um: v.iter().map(|x| x.2).collect(),
        });
    }
    let rms_residual_um = crate::base::rms(&all_r).unwrap_or(0.0);
    let z = residual_test(
        &residuals,
        weighted.then_some((solved.chi2, solved.dof)),
        rms_residual_um,
        solved.sigma0,
        "",
    )
    .z;
    Ok(Outcome {
        solved,
        thermal,
        campaign_effects,
        residuals,
        rms_residual_um,
        z,
    })
}

/// Factors by which REML's smoothing parameters are relaxed, in turn, when the residual
/// of the tables at knots fails the test: ever rougher tables, down to nearly the
/// unpenalised table (interpolation of the knots' values).
pub(super) const RELAX: [f64; 6] = [1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-6];
/// How many degrees above the chosen one a polynomial fit whose residual fails the test
/// tries (within [`MAX_DEGREE`]), when the degree was chosen (`auto`, `auto-each`).
pub(super) const RICHER_DEGREES: usize = 4;

/// A component model ready to evaluate.
pub(crate) struct Model {
    pub basis: Basis,
    pub d: Design,
    pub engine: Engine,
    pub identified: Vec<bool>,
    pub unidentified: Vec<Unidentified>,
    pub null_space: Vec<Vec<f64>>,
    /// For tables: the relaxation of REML's λ.
    pub relax: f64,
}

fn rows_of(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// A polynomial model of degrees `degs` with its identifiability.
pub(crate) fn poly_model(
    table: &LineTable,
    topology: Topology,
    range: [[f64; 2]; 3],
    sqrt_w: &[f64],
    degs: Vec<usize>,
) -> Model {
    let basis = Basis::new(topology, range, degs);
    let d = design(table, &basis, sqrt_w);
    let null = decompose(&d.a).null;
    let identified = identified_flags(&basis, &null);
    let unidentified = suggest(&basis, &d.scale, &null, &identified);
    Model {
        null_space: rows_of(&null),
        basis,
        d,
        engine: Engine::LeastSquares,
        identified,
        unidentified,
        relax: 1.0,
    }
}

/// Positions each axis is measured at while it moves (targets of lines with a beam
/// component along it).
fn measured_positions(table: &LineTable) -> [Vec<f64>; 3] {
    let mut out: [Vec<f64>; 3] = Default::default();
    for line in &table.lines {
        for (k, pos) in out.iter_mut().enumerate() {
            let first = line.targets[0].pos_mm[k];
            if line
                .targets
                .iter()
                .any(|t| (t.pos_mm[k] - first).abs() > 1e-6)
            {
                pos.extend(line.targets.iter().map(|t| t.pos_mm[k]));
            }
        }
    }
    out
}

/// The tables-at-knots model: knots from the lines ([`super::spline`]), identifiability as
/// the cubic polynomials', the penalties of the determined components, REML's λ (with the
/// scale-expansion column in the design when the table has temperatures).
pub(crate) fn spline_model(
    table: &LineTable,
    topology: Topology,
    range: [[f64; 2]; 3],
    sqrt_w: &[f64],
    thermal_col: Option<&thermal::ThermalColumn>,
    weighted: bool,
) -> Model {
    let cubic = poly_model(table, topology, range, sqrt_w, vec![3; 18]);
    let measured = measured_positions(table);
    let knots = [0, 1, 2].map(|k| spline::knots(&measured[k], range[k]));
    let basis = Basis::tables(topology, range, knots);
    let d = design(table, &basis, sqrt_w);
    let mut blocks = Vec::new();
    for c in (0..18).filter(|&c| cubic.identified[c]) {
        let comp = Component::from_index(c);
        let kn = &basis
            .knots_mm
            .as_ref()
            .map_or(&[][..], |k| &k[comp.axis][..]);
        let raw = spline::penalty(kn, comp.is_straightness(), basis.scale_mm[comp.axis]);
        let start = basis.offset(c);
        let m = raw.len();
        let s = DMatrix::from_fn(m, m, |i, j| {
            raw[i][j] / (d.scale[start + i] * d.scale[start + j])
        });
        blocks.push(Block {
            component: c,
            start,
            s,
            rank: spline::penalty_rank(kn, comp.is_straightness()),
        });
    }
    let g = d.a.transpose() * &d.a;
    let lambda: Vec<f64> = blocks
        .iter()
        .map(|b| {
            let m = b.s.nrows();
            let tg: f64 = (0..m).map(|i| g[(b.start + i, b.start + i)]).sum();
            let ts = b.s.trace();
            if ts > 0.0 && tg > 0.0 { tg / ts } else { 1.0 }
        })
        .collect();
    let null = if cubic.identified.iter().all(|f| *f) {
        DMatrix::zeros(basis.n_params(), 0)
    } else {
        smooth::null_directions(&g, &blocks, &lambda)
    };
    let mut pen = Penalty {
        blocks,
        lambda,
        null,
    };
    let n_lines = table.lines.len();
    let with_alpha = thermal_col.and_then(|c| augment(&d, &c.centred));
    pen.lambda = pen.reml(with_alpha.as_ref().unwrap_or(&d), n_lines);
    let flags = identified_flags(&basis, &pen.null);
    let identified: Vec<bool> = flags
        .iter()
        .zip(&cubic.identified)
        .map(|(a, b)| *a && *b)
        .collect();
    Model {
        null_space: rows_of(&pen.null),
        basis,
        d,
        engine: Engine::Penalised {
            pen,
            known_noise: weighted,
        },
        identified,
        unidentified: cubic.unidentified,
        relax: 1.0,
    }
}

/// The same tables with REML's λ times `relax`.
pub(crate) fn relaxed(m: &Model, relax: f64) -> Option<Model> {
    let Engine::Penalised { pen, known_noise } = &m.engine else {
        return None;
    };
    let mut pen = pen.clone();
    let base = pen.lambda.iter().map(|l| l / m.relax * relax).collect();
    pen.lambda = base;
    Some(Model {
        basis: m.basis.clone(),
        d: Design {
            a: m.d.a.clone(),
            e: m.d.e.clone(),
            line_rows: m.d.line_rows.clone(),
            sqrt_w: m.d.sqrt_w.clone(),
            scale: m.d.scale.clone(),
        },
        engine: Engine::Penalised {
            pen,
            known_noise: *known_noise,
        },
        identified: m.identified.clone(),
        unidentified: m.unidentified.clone(),
        null_space: m.null_space.clone(),
        relax,
    })
}
