//! `errmap artefact {evaluate, simulate, identify}`: flags into library types, then the
//! calls. The work is in `errmap::artefact`, the report in `errmap::report`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};

use errmap::artefact::{
    Artefact, ArtefactIdentification, Campaign, EvalSettings, Evaluation, IdentifyDoc,
    IdentifyOptions, MapModel, Measurement, Plane, evaluate,
};
use errmap::volumetric::ModelDoc;

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
    /// Laser lines of the same machine (a line table as `volumetric identify` reads, with
    /// e_um and s_um) fitted jointly with the positions.
    #[arg(long)]
    pub laser: Option<PathBuf>,
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
    let settings = EvalSettings {
        against: old.as_ref(),
        model,
        plane,
        temp_c,
    };
    let ev = evaluate(&art, &meas, &settings)?;
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
    let mut inputs: Vec<(&str, &Path)> = vec![("CAMPAIGN", &a.campaign)];
    inputs.extend(a.laser.as_deref().map(|p| ("--laser", p)));
    super::guard::refuse_aliases(&outputs, &inputs)?;
    let opts = IdentifyOptions {
        topology,
        self_calibrate: a.self_calibrate,
        positions: a.positions,
    };
    let (id, doc, model) = identify_campaign(&a.campaign, a.laser.as_deref(), &opts)?;
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
    print_identify_summary(&doc);
    Ok(())
}

fn print_identify_summary(doc: &IdentifyDoc) {
    eprintln!(
        "{} positions, {} features: RMS residual {:.3} µm, residual {} (z = {:.2})",
        doc.positions, doc.features, doc.rms_residual_um, doc.residual.verdict, doc.residual.z
    );
    for u in &doc.unidentified {
        eprintln!("  not determined: {}", u.components.join(", "));
    }
}

/// `artefact identify`'s work on the campaign file: its measurements read, the
/// identification, its JSON document and the volumetric model document.
fn identify_campaign(
    campaign: &Path,
    laser: Option<&Path>,
    opts: &IdentifyOptions,
) -> Result<(ArtefactIdentification, IdentifyDoc, ModelDoc)> {
    let campaign = Campaign::read(campaign)?;
    let meas: Vec<Measurement> = campaign
        .positions
        .iter()
        .map(|p| Measurement::read(&p.file, &campaign.artefacts[p.artefact], false))
        .collect::<Result<_, _>>()?;
    let lines = match laser {
        Some(p) => Some(errmap::volumetric::LineTable::read(p, true)?),
        None => None,
    };
    let id = errmap::artefact::identify_joint(&campaign, &meas, lines.as_ref(), opts)?;
    let doc = id.doc(opts.positions);
    let model = id.model.doc(opts.positions, true);
    Ok((id, doc, model))
}

/// The demo's CMM mapped the CMM way: the committed eight-position ball-plate campaign
/// (`datasets/artefact/`) written under `out/artefact/inputs`, identified as
/// `artefact identify --topology YXZ --report out/artefact` does, then the ISO 10360-2
/// test predicted from the identified model as `volumetric iso10360 --model` does
/// (`out/artefact/iso10360`).
pub(crate) fn demo_step(out: &Path) -> Result<(IdentifyDoc, errmap::acceptance::VirtualTest)> {
    let dir = out.join("artefact");
    let inputs = dir.join("inputs");
    let meas = inputs.join("meas");
    std::fs::create_dir_all(&meas).with_context(|| format!("cannot create {}", meas.display()))?;
    for (name, text) in DEMO_FILES {
        super::guard::write_file(&inputs.join(name), text.as_bytes())?;
    }
    let campaign = inputs.join("campaign.toml");
    let opts = IdentifyOptions {
        topology: "YXZ".parse().map_err(|e| anyhow::anyhow!("{e}"))?,
        self_calibrate: false,
        positions: 21,
    };
    let (id, doc, model) = identify_campaign(&campaign, None, &opts)?;
    errmap::report::write_artefact_report(&id, &doc, &model, &dir)?;
    eprint!("  {}: ", campaign.display());
    print_identify_summary(&doc);
    eprintln!("  report → {}", dir.join("report.md").display());
    let iso = super::acceptance::virtual_test(&super::acceptance::VirtualArgs {
        model: dir.join("model.json"),
        plan: None,
        mpe: Some("1.5+L/333".into()),
        u_um: None,
        rule: Default::default(),
        compensated: false,
        table_points: errmap::acceptance::VIRTUAL_TABLE_POINTS,
        report: Some(dir.join("iso10360")),
        json: false,
    })?;
    eprintln!(
        "  ISO 10360-2 predicted from the artefact-identified model: {} measurements, max |E| \
         {:.3} µm{}",
        iso.measurements.len(),
        iso.max_abs_e_um,
        iso.verdict.map(|v| format!(": {v}")).unwrap_or_default()
    );
    Ok((doc, iso))
}

/// The committed campaign, its plate, the machine it was simulated on and its eight
/// measurement files, by their paths relative to the campaign.
const DEMO_FILES: [(&str, &str); 11] = [
    (
        "campaign.toml",
        include_str!("../../datasets/artefact/campaign.toml"),
    ),
    (
        "plate.toml",
        include_str!("../../datasets/artefact/plate.toml"),
    ),
    (
        "machine.toml",
        include_str!("../../datasets/artefact/machine.toml"),
    ),
    (
        "meas/xy_low.csv",
        include_str!("../../datasets/artefact/meas/xy_low.csv"),
    ),
    (
        "meas/xy_high.csv",
        include_str!("../../datasets/artefact/meas/xy_high.csv"),
    ),
    (
        "meas/xy_turned.csv",
        include_str!("../../datasets/artefact/meas/xy_turned.csv"),
    ),
    (
        "meas/xz_front.csv",
        include_str!("../../datasets/artefact/meas/xz_front.csv"),
    ),
    (
        "meas/xz_back.csv",
        include_str!("../../datasets/artefact/meas/xz_back.csv"),
    ),
    (
        "meas/yz_left.csv",
        include_str!("../../datasets/artefact/meas/yz_left.csv"),
    ),
    (
        "meas/yz_right.csv",
        include_str!("../../datasets/artefact/meas/yz_right.csv"),
    ),
    (
        "meas/xy_stylus.csv",
        include_str!("../../datasets/artefact/meas/xy_stylus.csv"),
    ),
];

#[cfg(test)]
mod tests {
    use super::*;
    use errmap::volumetric::{Component, GaugeTruth, Machine};

    /// The demo's artefact step against the machine the committed measurements were
    /// simulated on (datasets/artefact/machine.toml, 0.2 µm noise): every component within
    /// 4 σ of the truth under the volumetric gauge, and every predicted ISO 10360-2 length
    /// error within 4 σ of the machine's own, E = −u·(E(p2) − E(p1)).
    #[test]
    fn demo_step_identifies_the_committed_campaign_and_predicts_iso10360() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let (doc, iso) = demo_step(dir.path())?;
        let truth = Machine::read(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/artefact/machine.toml"),
        )?;
        assert!(doc.unidentified.is_empty(), "{:?}", doc.unidentified.len());
        assert_eq!(doc.positions, 8);
        assert_eq!(doc.features, 200);
        assert_eq!(doc.residual.verdict.to_string(), "consistent");
        let v = serde_json::to_value(&doc)?;
        let range = ["E_XX", "E_YY", "E_ZZ"].map(|c| {
            let p = &v["components"][c]["positions_mm"];
            let n = p.as_array().map_or(0, Vec::len);
            [
                p[0].as_f64().unwrap_or(0.0),
                p[n - 1].as_f64().unwrap_or(0.0),
            ]
        });
        let gauge = GaugeTruth::of(&truth, range);
        let mut checked = 0;
        for c in Component::all() {
            let e = &v["components"][c.name()];
            let at = e["positions_mm"].as_array().expect("positions");
            for (i, a) in at.iter().enumerate() {
                let a = a.as_f64().expect("position");
                let (est, sig) = (e["values"][i].as_f64(), e["sigma"][i].as_f64());
                let (est, sig) = (est.expect("value"), sig.expect("sigma"));
                let t = gauge.value(&truth, c, a);
                assert!(
                    (est - t).abs() <= 4.0 * sig,
                    "{} at {a}: {est} vs {t} (σ {sig})",
                    c.name()
                );
            }
            checked += 1;
        }
        for (i, name) in ["E_C0Y", "E_B0Z", "E_A0Z"].iter().enumerate() {
            let e = &v["components"][*name];
            let (est, sig) = (e["value"].as_f64(), e["sigma"].as_f64());
            let (est, sig) = (est.expect("value"), sig.expect("sigma"));
            let t = gauge.squareness_urad[i];
            assert!((est - t).abs() <= 4.0 * sig, "{name}: {est} vs {t} ({sig})");
            checked += 1;
        }
        assert_eq!(checked, 21);
        assert!(iso.measurements.len() >= 35, "{}", iso.measurements.len());
        for m in &iso.measurements {
            let d: [f64; 3] = std::array::from_fn(|i| m.p2_mm[i] - m.p1_mm[i]);
            let l = d.iter().map(|x| x * x).sum::<f64>().sqrt();
            let (t1, t2) = (
                truth.error_um(m.p1_mm, m.probe_mm),
                truth.error_um(m.p2_mm, m.probe_mm),
            );
            let e_true = -(0..3).map(|i| d[i] / l * (t2[i] - t1[i])).sum::<f64>();
            assert!(
                (m.e_um - e_true).abs() <= 4.0 * m.sigma_um,
                "{} gauge {}: {} vs {e_true} (σ {})",
                m.position,
                m.gauge,
                m.e_um,
                m.sigma_um
            );
        }
        let a = dir.path().join("artefact");
        let mut files = vec![
            "report.md".to_string(),
            "identify.json".into(),
            "model.json".into(),
            "iso10360/report.md".into(),
        ];
        files.extend(
            doc.placements
                .iter()
                .enumerate()
                .map(|(k, p)| format!("residual_{:02}_{}.png", k + 1, p.position)),
        );
        for f in &files {
            assert!(a.join(f).is_file(), "{f}");
        }
        let md = std::fs::read_to_string(a.join("report.md"))?;
        assert!(
            md.contains("![XY_stylus](residual_08_XY_stylus.png)"),
            "{md}"
        );
        Ok(())
    }
}
