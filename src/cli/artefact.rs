//! `errmap artefact {evaluate, simulate, identify}`: flags into library types, then the
//! calls. The work is in `errmap::artefact`, the report in `errmap::report`.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use errmap::artefact::{
    Artefact, Campaign, Evaluation, IdentifyOptions, MapModel, Measurement, Plane, evaluate,
};

#[derive(Debug, Args)]
pub(crate) struct ArtefactArgs {
    #[command(subcommand)]
    pub command: ArtefactCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum ArtefactCommand {
    /// A plate's best-fit similarity (and distortion) with per-feature residuals, against
    /// an earlier measurement; a gauge's length errors.
    Evaluate(EvaluateArgs),
    /// Simulated measurements of a campaign's positions on a machine with the 21 errors.
    Simulate(SimulateArgs),
    /// The 21 errors, the placements and (self-calibration) the artefact's deviations from
    /// the measured positions.
    Identify(IdentifyArgs),
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    /// The campaign (TOML: positions of artefacts).
    pub campaign: PathBuf,
    /// The machine: a machine-model TOML (as `volumetric simulate` reads) or a MODEL.json.
    #[arg(long)]
    pub model: PathBuf,
    /// A new directory for the measurement files.
    #[arg(long)]
    pub out: PathBuf,
    /// One-sigma of the noise added to each coordinate, µm.
    #[arg(long, default_value_t = 0.0, value_parser = super::values::noise_um)]
    pub sigma_um: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Debug, Args)]
pub(crate) struct IdentifyArgs {
    /// The campaign (TOML: positions of artefacts and their measurement files).
    pub campaign: PathBuf,
    /// Axis stacking (as `volumetric identify`), e.g. YXZ.
    #[arg(long)]
    pub topology: String,
    /// Fit an uncalibrated artefact's deviations too (self-calibration).
    #[arg(long)]
    pub self_calibrate: bool,
    /// Write the identified model (what `volumetric predict`, `iso10360`, `export` read).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write report.md, the JSON, model.json and the residual maps into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the identification as one JSON document.
    #[arg(long)]
    pub json: bool,
    /// Report positions per component.
    #[arg(long, default_value_t = 21, value_parser = super::values::artefact_positions)]
    pub positions: usize,
}

#[derive(Debug, Args)]
pub(crate) struct EvaluateArgs {
    /// The artefact (TOML: kind, features with nominal and certified coordinates).
    pub artefact: PathBuf,
    /// The measurement (CSV: feature,x_mm,y_mm,z_mm).
    pub meas: PathBuf,
    /// An earlier measurement of the same artefact: also fit MEAS onto it.
    #[arg(long)]
    pub against: Option<PathBuf>,
    /// The plate's map: similarity (shift, rotation, scale) or similarity+distortion.
    #[arg(long, default_value = "similarity", value_parser = ["similarity", "similarity+distortion"])]
    pub model: String,
    /// The machine plane of a plate: XY, XZ or YZ.
    #[arg(long, default_value = "XY", value_parser = ["XY", "XZ", "YZ"])]
    pub plane: String,
    /// The artefact's temperature, °C (default: its reference temperature).
    #[arg(long, allow_negative_numbers = true, value_parser = super::values::temperature_c)]
    pub temp_c: Option<f64>,
    /// Write report.md, evaluate.json and the residual map(s) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the evaluation as one JSON document.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn artefact_cmd(a: ArtefactArgs) -> Result<()> {
    match a.command {
        ArtefactCommand::Evaluate(e) => evaluate_cmd(e),
        ArtefactCommand::Simulate(s) => simulate_cmd(s),
        ArtefactCommand::Identify(i) => identify_cmd(i),
    }
}

fn evaluate_cmd(a: EvaluateArgs) -> Result<()> {
    let model = MapModel::parse(&a.model).unwrap_or(MapModel::Similarity);
    let plane = Plane::parse(&a.plane).unwrap_or(Plane::XY);
    let art = Artefact::read(&a.artefact)?;
    let z_optional = !art.kind.is_1d();
    let meas = Measurement::read(&a.meas, &art, z_optional)?;
    let old = match &a.against {
        Some(p) => Some(Measurement::read(p, &art, z_optional)?),
        None => None,
    };
    let temp_c = a.temp_c.unwrap_or(art.reference_temp_c);
    let ev = evaluate(&art, &meas, old.as_ref(), model, plane, temp_c)?;
    if let Some(dir) = &a.report {
        super::guard::into_new_dir(dir, |d| {
            Ok(errmap::report::write_evaluation_report(&ev, d)?)
        })?;
    }
    if a.json {
        return super::guard::print_json(&ev);
    }
    match &ev {
        Evaluation::Plate(p) => {
            let f = &p.fitted.fit;
            eprintln!(
                "{} ({}), {} features in {}, {}: shift {:+.2} {:+.2} µm, rotation {:+.2} µrad, \
                 scale {:+.3} ppm",
                p.artefact,
                p.kind,
                p.features,
                p.plane,
                p.model,
                f.shift_um[0],
                f.shift_um[1],
                f.rotation_urad,
                f.scale_ppm
            );
            if let Some(d) = f.distortion {
                eprintln!("  distortion {:.3} ppm along {:.1}°", d.q_ppm, d.angle_deg);
            }
            eprintln!(
                "  residual RMS {:.2} µm, largest {:.2} µm",
                p.fitted.rms_um, p.fitted.max_um
            );
            if let Some(ag) = &p.against {
                eprintln!(
                    "  against {} ({} common features): RMS {:.2} µm, largest {:.2} µm",
                    ag.file, ag.features, ag.fitted.rms_um, ag.fitted.max_um
                );
            }
        }
        Evaluation::Gauge(g) => {
            eprintln!(
                "{} ({}), {} features: length error {:+.2} … {:+.2} µm",
                g.artefact, g.kind, g.features, g.e_min_um, g.e_max_um
            );
            for l in &g.lengths {
                eprintln!(
                    "  {:>10} {:10.3} mm {:+8.2} µm",
                    l.feature, l.length_mm, l.e_um
                );
            }
        }
    }
    Ok(())
}

fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    let campaign = Campaign::read(&a.campaign)?;
    let model = errmap::volumetric::Predictor::read(&a.model)?;
    let files = errmap::artefact::simulate(&campaign, &model, a.sigma_um, a.seed)?;
    let written = errmap::artefact::write_simulated(&a.out, &files)?;
    eprintln!(
        "{} positions simulated into {}",
        written.len(),
        a.out.display()
    );
    Ok(())
}

fn identify_cmd(a: IdentifyArgs) -> Result<()> {
    let topology: errmap::volumetric::Topology = a
        .topology
        .parse()
        .map_err(|e| super::guard::usage(format!("--topology: {e}")))?;
    let outputs: Vec<(&str, &std::path::Path)> = [("--out", &a.out), ("--report", &a.report)]
        .into_iter()
        .filter_map(|(f, p)| p.as_deref().map(|p| (f, p)))
        .collect();
    super::guard::refuse_aliases(&outputs, &[("CAMPAIGN", &a.campaign)])?;
    let campaign = Campaign::read(&a.campaign)?;
    let meas: Vec<Measurement> = campaign
        .positions
        .iter()
        .map(|p| Measurement::read(&p.file, &campaign.artefacts[p.artefact], false))
        .collect::<Result<_, _>>()?;
    let opts = IdentifyOptions {
        topology,
        self_calibrate: a.self_calibrate,
        positions: a.positions,
    };
    let id = errmap::artefact::identify(&campaign, &meas, &opts)?;
    let doc = id.doc(opts.positions);
    let model = id.model.doc(opts.positions, true);
    if let Some(out) = &a.out {
        errmap::report::check_json(out, &model)?;
        let text = errmap::report::json_text(out, &model, true)?;
        super::guard::write_file(out, text.as_bytes())?;
    }
    if let Some(dir) = &a.report {
        super::guard::into_new_dir(dir, |d| {
            Ok(errmap::report::write_artefact_report(&id, &doc, &model, d)?)
        })?;
    }
    if a.json {
        return super::guard::print_json(&doc);
    }
    eprintln!(
        "{} positions, {} features: RMS residual {:.3} µm, residual {} (z = {:.2})",
        doc.positions, doc.features, doc.rms_residual_um, doc.residual.verdict, doc.residual.z
    );
    for u in &doc.unidentified {
        eprintln!("  not determined: {}", u.components.join(", "));
    }
    Ok(())
}
