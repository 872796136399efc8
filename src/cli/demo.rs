//! `errmap demo`: the whole pipeline on built-in data into `reports/demo/`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use errmap::evaluate::{self, DEFAULT_MAX_DEGREE};
use errmap::interp::{Method, MethodSettings};
use errmap::table::ErrorTable;

use super::acquisition;
use super::args::DemoArgs;
use super::diagnose::{self, Against};
use super::model::print_summary;

fn write_input(dir: &Path, name: &str, text: &str) -> Result<PathBuf> {
    let p = dir.join(name);
    super::guard::write_file(&p, text.as_bytes())?;
    Ok(p)
}

/// The comparison `errmap compare TABLE --test TEST --report DIR` makes, with the
/// registry's default models.
fn demo_compare(table: &Path, test: &Path, report: &Path) -> Result<()> {
    let fitting = ErrorTable::read(table)?;
    let test_points = ErrorTable::read(test)?;
    let grid = fitting.grid()?;
    let methods = Method::defaults(&grid, DEFAULT_MAX_DEGREE, &MethodSettings::default());
    let comparison = evaluate::compare_where_possible(&fitting, &grid, &test_points, &methods)
        .with_context(|| format!("{}: comparison failed", table.display()))?;
    let command = format!(
        "errmap compare {} --test {} --report {}",
        table.display(),
        test.display(),
        report.display()
    );
    errmap::report::write_compare_report(&comparison, report, &command)?;
    print_summary(&comparison, report);
    Ok(())
}

/// The demo's input files, written under `out/inputs` from the bundled datasets.
struct DemoInputs {
    dir: PathBuf,
    t1: PathBuf,
    t2: PathBuf,
    model: PathBuf,
    plan: PathBuf,
    machine: PathBuf,
}

impl DemoInputs {
    /// Writes Table 1 and 2 of the paper and the simulated board's model, plan and
    /// machine (their table paths made local to the inputs directory).
    fn write(out: &Path) -> Result<DemoInputs> {
        let inputs = out.join("inputs");
        std::fs::create_dir_all(&inputs)
            .with_context(|| format!("cannot create {}", inputs.display()))?;
        let t1 = write_input(
            &inputs,
            "table1.csv",
            include_str!("../../datasets/table1.csv"),
        )?;
        let t2 = write_input(
            &inputs,
            "table2.csv",
            include_str!("../../datasets/table2.csv"),
        )?;
        let model = write_input(
            &inputs,
            "model.toml",
            &include_str!("../../datasets/sim/model.toml")
                .replace("\"../table1.csv\"", "\"table1.csv\""),
        )?;
        let plan = write_input(
            &inputs,
            "plan.toml",
            include_str!("../../datasets/sim/plan.toml"),
        )?;
        let machine = write_input(
            &inputs,
            "machine.toml",
            &include_str!("../../datasets/sim/machine.toml")
                .replace("\"../table1.csv\"", "\"table1.csv\""),
        )?;
        Ok(DemoInputs {
            dir: inputs,
            t1,
            t2,
            model,
            plan,
            machine,
        })
    }
}

/// The whole pipeline on built-in data: the simulated board on a pseudo-terminal →
/// capture → error table (+ ISO 230-2) → comparison against the simulated truth; then the
/// paper's Table 1 → Table 2 comparison; then a simulated volumetric laser campaign.
pub(crate) fn demo(a: DemoArgs) -> Result<()> {
    let inputs = DemoInputs::write(&a.out)?;

    eprintln!("errmap demo [1/6]: simulated board (machine.toml) on a pseudo-terminal → capture");
    let session_dir = a.out.join("session");
    let truth = capture_step(&inputs, &session_dir)?;

    eprintln!("errmap demo [2/6]: session → error table (+ ISO 230-2 report, certificate.pdf)");
    let errors = session_dir.join("errors.csv");
    acquisition::reduce_session(
        &session_dir,
        &errors,
        Some(&session_dir.join("iso230")),
        None,
    )?;
    certificates_step(&a.out, &inputs.dir, &session_dir)?;

    eprintln!("errmap demo [3/6]: fit every method to the captured table, compare with the truth");
    let test = errmap::sim::truth_test_points(&truth, &errors, 40, 11)?;
    let test_path = session_dir.join("truth_points.csv");
    test.write(&test_path)?;
    demo_compare(&errors, &test_path, &a.out.join("capture_comparison"))?;

    eprintln!("errmap demo [4/6]: diagnose the capture against the nominal model (model.toml)");
    let report = a.out.join("diagnosis");
    let d = diagnose::run_diagnosis(
        &session_dir,
        &Against::Model(inputs.model.clone()),
        &report,
        None,
    )?;
    diagnose::print_summary(&d, &report)?;

    eprintln!("errmap demo [5/6]: the Lagrange paper's Table 1 → Table 2 (Zhang Mei 2013)");
    demo_compare(&inputs.t1, &inputs.t2, &a.out.join("table2"))?;

    eprintln!(
        "errmap demo [6/6]: a simulated laser campaign → the 21 volumetric errors → volumetric compensation tables"
    );
    super::volumetric::demo_step(&a.out)?;
    eprintln!("errmap demo: a simulated ballbar test (ISO 230-4) and the errors behind its trace");
    circular_step(&a.out, &inputs.dir)?;
    eprintln!(
        "errmap demo: a CMM's verification: ISO 10360-2 length test, ISO 10360-5 probing test, CMM certificate"
    );
    super::probing::demo_step(&a.out)?;
    eprintln!(
        "errmap demo: the CMM mapped with a ball plate in eight positions (artefact identify) → ISO 10360-2 predicted"
    );
    super::artefact::demo_step(&a.out)?;
    eprintln!(
        "errmap demo: the captured session and the volumetric model in a calibration ledger (history add, report)"
    );
    let volumetric_model = a.out.join("volumetric").join("model.json");
    super::history::demo_step(&a.out, &session_dir, Some(&volumetric_model))?;
    eprintln!("errmap demo: done; reports under {}", a.out.display());
    Ok(())
}

/// Step 1: the simulated board streams on a pseudo-terminal (10× real time) and the
/// capture records it into `session_dir` (a previous demo's session cleared first);
/// returns the simulation's truth.
fn capture_step(inputs: &DemoInputs, session_dir: &Path) -> Result<errmap::sim::PhysicsTruth> {
    if session_dir.exists() {
        std::fs::remove_dir_all(session_dir).with_context(|| {
            format!(
                "cannot clear the previous demo session {}",
                session_dir.display()
            )
        })?;
    }
    let (stream, truth) =
        errmap::sim::simulate_stream(&inputs.machine, Some(&inputs.plan), &Default::default())?;
    let baud = errmap::sim::MachineModel::read(&inputs.model)?.device.baud;
    eprintln!("  the board on a pseudo-terminal, 10× real time");
    let paths = errmap::acquire::SessionPaths::new(session_dir, "csv");
    let config = errmap::drivers::capture::CaptureConfig {
        idle_timeout: Some(std::time::Duration::from_millis(800)),
        ..Default::default()
    };
    let cap = acquisition::capture_simulated(
        stream,
        10.0,
        baud,
        &paths,
        &config,
        acquisition::Display::Progress,
    )?;
    eprintln!(
        "  captured {} bytes, {} rows, {} CRC failures → {}",
        cap.bytes,
        cap.rows,
        cap.stats.crc_failures,
        session_dir.display()
    );
    Ok(truth)
}

/// Step 2's certificates: the session's calibration certificate, then the same judged
/// against a specification.
fn certificates_step(out: &Path, inputs: &Path, session_dir: &Path) -> Result<()> {
    // The session's calibration certificate, with the fictitious lab fields of the
    // example info file (the machine named as the demo's).
    let info = write_input(
        inputs,
        "certificate-info.toml",
        &include_str!("../../datasets/certificate/example-info.toml").replace(
            "machine = \"Simulated CMM of datasets/physics, X axis\"",
            "machine = \"errmap demo: simulated board (datasets/sim/machine.toml), X axis\"",
        ),
    )?;
    super::certificate::certificate_cmd(super::certificate::CertificateArgs {
        session: session_dir.to_path_buf(),
        info: Some(info.clone()),
        out: out.join("certificate.pdf"),
        tolerances: None,
        rule: Default::default(),
    })?;

    // The same certificate judged against a specification (the Statement of conformity,
    // ISO 14253-1:2017 default rule): the demo's machine has the 0.6 µm reversal the
    // nominal model lacks, against B ≤ 0.5 µm.
    let tolerances = write_input(
        inputs,
        "tolerances.toml",
        include_str!("../../datasets/acceptance/tolerances.toml"),
    )?;
    super::certificate::certificate_cmd(super::certificate::CertificateArgs {
        session: session_dir.to_path_buf(),
        info: Some(info),
        out: out.join("certificate-conformity.pdf"),
        tolerances: Some(tolerances),
        rule: Default::default(),
    })?;
    Ok(())
}

/// The ballbar step: a simulated circular test and its diagnosis under `out/circular`.
fn circular_step(out: &Path, inputs: &Path) -> Result<()> {
    let machine_circ = write_input(
        inputs,
        "circular-machine.toml",
        include_str!("../../datasets/circular/machine.toml"),
    )?;
    let circular_dir = out.join("circular");
    std::fs::create_dir_all(&circular_dir)
        .map_err(|e| anyhow::anyhow!("{}: {e}", circular_dir.display()))?;
    let trace = circular_dir.join("xy.csv");
    super::circular::circular_cmd(super::circular::CircularArgs {
        command: super::circular::CircularCommand::Simulate(super::circular::SimulateArgs {
            model: machine_circ,
            out: trace.clone(),
        }),
    })?;
    super::circular::circular_cmd(super::circular::CircularArgs {
        command: super::circular::CircularCommand::Diagnose(super::circular::DiagnoseArgs {
            trace,
            report: out.join("circular").join("report"),
            json: false,
            overshoot: false,
            model: None,
        }),
    })?;
    Ok(())
}
