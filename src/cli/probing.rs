//! `errmap acceptance iso10360-5` and `errmap acceptance cmm-certificate`: flags,
//! validation into library configuration, and glue. The work is in
//! `errmap::acceptance::{probing, CmmCertificate}`, the reports by
//! `errmap::report::write_probing_report` and `errmap::report::certificate::write_cmm`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use errmap::acceptance::probing::{self, PerQuantity, ProbingOptions, ProbingResult};
use errmap::acceptance::{self, CmmCertificate};

use super::acceptance::{LengthArgs, RuleArgs, length_config};

/// MPE overrides of the probing test, µm.
#[derive(Debug, Clone, Args)]
pub(crate) struct ProbingMpeArgs {
    /// MPE of the probing form error, µm (overrides [mpe] form_um).
    #[arg(long, allow_negative_numbers = true, value_parser = super::values::limit_um)]
    pub mpe_form: Option<f64>,
    /// MPE of the probing size error, µm (overrides [mpe] size_um).
    #[arg(long, allow_negative_numbers = true, value_parser = super::values::limit_um)]
    pub mpe_size: Option<f64>,
    /// MPE of the multi-stylus location error, µm (overrides [mpe] location_um).
    #[arg(long, allow_negative_numbers = true, value_parser = super::values::limit_um)]
    pub mpe_location: Option<f64>,
}

impl ProbingMpeArgs {
    fn options(&self, rule: &RuleArgs) -> ProbingOptions {
        ProbingOptions {
            mpe: PerQuantity {
                form_um: self.mpe_form,
                size_um: self.mpe_size,
                location_um: self.mpe_location,
            },
            rule: rule.rule,
            guard_fraction: rule.guard_fraction,
        }
    }
}

#[derive(Debug, Args)]
pub(crate) struct ProbingArgs {
    /// The probed points (CSV or Parquet: stylus, point, x_mm, y_mm, z_mm).
    pub points: PathBuf,
    /// The test sphere's certificate, the MPEs and the test's U (TOML).
    #[arg(long)]
    pub sphere: PathBuf,
    #[command(flatten)]
    pub mpe: ProbingMpeArgs,
    #[command(flatten)]
    pub rule: RuleArgs,
    /// Write report.md, residuals.csv and the map of the residuals here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the probing test's evaluation (fits, form, size, location, verdicts) as one
    /// JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

fn summary(r: &ProbingResult) -> String {
    format!(
        "{} points, {} stylus/styli: form {:.3} µm {}, size {:+.3} µm {}{}: {}",
        r.points,
        r.styli.len(),
        r.form.value_um,
        r.form.verdict,
        r.size.value_um,
        r.size.verdict,
        r.location
            .as_ref()
            .map(|l| format!(
                ", location {:.3} µm {}",
                l.value_um,
                l.verdict.map_or("(not judged)".into(), |v| v.to_string())
            ))
            .unwrap_or_default(),
        r.verdict
    )
}

pub(crate) fn probing_cmd(a: ProbingArgs) -> Result<()> {
    if let Some(dir) = &a.report {
        super::guard::refuse_aliases(
            &[("--report", dir)],
            &[("POINTS", &a.points), ("--sphere", &a.sphere)],
        )?;
    }
    let r = probing::evaluate_files(&a.points, &a.sphere, &a.mpe.options(&a.rule))?;
    if let Some(dir) = &a.report {
        let (p, s) = (
            a.points.display().to_string(),
            a.sphere.display().to_string(),
        );
        super::guard::into_new_dir(dir, |d| {
            errmap::report::write_probing_report(d, &p, &s, &r).map_err(Into::into)
        })?;
        eprintln!("acceptance iso10360-5: report in {}", dir.display());
    }
    if a.json {
        super::guard::print_json(&r)?;
    }
    eprintln!("acceptance iso10360-5: {}", summary(&r));
    for d in &r.deviations {
        eprintln!("acceptance iso10360-5: deviation: {d}");
    }
    Ok(())
}

#[derive(Debug, Args)]
pub(crate) struct CmmCertificateArgs {
    /// The ISO 10360-2 test (as `acceptance iso10360` reads it).
    #[arg(long)]
    pub length: PathBuf,
    #[command(flatten)]
    pub length_args: LengthArgs,
    /// The ISO 10360-5 points (as `acceptance iso10360-5` reads them).
    #[arg(long)]
    pub probing: PathBuf,
    /// The test sphere's certificate, the MPEs and the test's U (TOML).
    #[arg(long)]
    pub sphere: PathBuf,
    #[command(flatten)]
    pub mpe: ProbingMpeArgs,
    /// The specification the CMM is judged against (named in the statement).
    #[arg(long, value_parser = super::values::text)]
    pub specification: String,
    /// The CMM (make, model, serial).
    #[arg(long, value_parser = super::values::text)]
    pub cmm: Option<String>,
    #[command(flatten)]
    pub rule: RuleArgs,
    /// The certificate (PDF).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the certificate's content (both tests, the statement of conformity) as one
    /// JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn cmm_certificate_cmd(a: CmmCertificateArgs) -> Result<()> {
    super::guard::refuse_aliases(
        &[("--out", &a.out)],
        &[
            ("--length", &a.length),
            ("--probing", &a.probing),
            ("--sphere", &a.sphere),
        ],
    )?;
    let config = length_config(&a.length_args, &a.rule)?;
    let length = acceptance::evaluate_file(&a.length, &config)?;
    let probing = probing::evaluate_files(&a.probing, &a.sphere, &a.mpe.options(&a.rule))?;
    let cert = CmmCertificate::new(
        a.cmm.clone(),
        a.specification.clone(),
        &config.rule,
        length,
        probing,
    );
    let sources = errmap::report::certificate::CmmSources {
        length: a.length.display().to_string(),
        probing: a.probing.display().to_string(),
        sphere: a.sphere.display().to_string(),
    };
    errmap::report::certificate::write_cmm(&a.out, &cert, &sources)?;
    if a.json {
        super::guard::print_json(&cert)?;
    }
    eprintln!(
        "acceptance cmm-certificate: ISO 10360-2 {}, ISO 10360-5 {}: {}; certificate {}",
        cert.iso10360_2.verdict,
        cert.iso10360_5.verdict,
        cert.verdict,
        a.out.display()
    );
    Ok(())
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    /// Where the points go (CSV).
    #[arg(long)]
    pub out: PathBuf,
}

/// Writes the simulator's example test (`datasets/acceptance/probing-example.csv`).
pub(crate) fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    let points = probing::simulate(&probing::example());
    super::guard::write_file(&a.out, probing::to_csv(&points).as_bytes())?;
    eprintln!(
        "acceptance simulate-probing: {} points in {}",
        points.len(),
        a.out.display()
    );
    Ok(())
}

/// A probing setting's error in the command line's words: the flag that sets it.
pub(crate) fn in_flags(e: &errmap::acceptance::AcceptanceError) -> Option<String> {
    use errmap::acceptance::{AcceptanceError, ProbingSetting as S, SettingProblem as P};
    let AcceptanceError::Setting {
        path,
        setting,
        problem,
    } = e
    else {
        return None;
    };
    let flag = match setting {
        S::MpeForm => "--mpe-form",
        S::MpeSize => "--mpe-size",
        S::MpeLocation => "--mpe-location",
        S::GuardFraction => "--guard-fraction",
    };
    let path = path.display();
    Some(match problem {
        P::Missing => {
            let key = setting.key();
            format!("{path}: {key}: missing: give {flag} or `{key}` in [mpe]")
        }
        P::NotPositive(_) | P::Fraction(_) => format!("{path}: {flag}: {problem}"),
    })
}

/// The demo's CMM verification: the ISO 10360-2 example and the simulated ISO 10360-5
/// test (the files of `reports/iso10360-5/README.md`), each with its report, and the CMM
/// certificate joining them, under `out/acceptance`. The same calls as `acceptance
/// iso10360`, `acceptance iso10360-5` and `acceptance cmm-certificate` with the README's
/// flags.
pub(crate) fn demo_step(out: &std::path::Path) -> Result<CmmCertificate> {
    let dir = out.join("acceptance");
    let inputs = dir.join("inputs");
    std::fs::create_dir_all(&inputs)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", inputs.display()))?;
    let length_file = inputs.join("iso10360-example.csv");
    let points_file = inputs.join("probing-example.csv");
    let sphere_file = inputs.join("probing-sphere.toml");
    super::guard::write_file(
        &length_file,
        include_bytes!("../../datasets/acceptance/iso10360-example.csv"),
    )?;
    let points = probing::simulate(&probing::example());
    super::guard::write_file(&points_file, probing::to_csv(&points).as_bytes())?;
    super::guard::write_file(&sphere_file, probing::EXAMPLE_SPHERE.as_bytes())?;
    let length_args = LengthArgs {
        mpe: "1.5+L/333".into(),
        u_um: Some("0.3+L/2000".into()),
        mpl_r0: Some(1.2),
        u_r0_um: 0.0,
        repetitions: 3,
    };
    let rule = RuleArgs {
        rule: None,
        guard_fraction: None,
    };
    let config = length_config(&length_args, &rule)?;
    let length = acceptance::evaluate_file(&length_file, &config)?;
    let length_report = dir.join("iso10360");
    let source = length_file.display().to_string();
    super::guard::into_new_dir(&length_report, |d| {
        errmap::report::write_iso10360_report(d, &source, &length, &config.rule).map_err(Into::into)
    })?;
    let probing = probing::evaluate_files(&points_file, &sphere_file, &Default::default())?;
    let probing_report = dir.join("iso10360-5");
    let (p, s) = (
        points_file.display().to_string(),
        sphere_file.display().to_string(),
    );
    super::guard::into_new_dir(&probing_report, |d| {
        errmap::report::write_probing_report(d, &p, &s, &probing).map_err(Into::into)
    })?;
    eprintln!("  ISO 10360-5: {}", summary(&probing));
    let cert = CmmCertificate::new(
        Some("ACME CMM-X 10.8.6 S/N 4711 (simulated)".into()),
        "ACME CMM-X data sheet rev. C (fictitious)".into(),
        &config.rule,
        length,
        probing,
    );
    let pdf = dir.join("cmm-certificate.pdf");
    let sources = errmap::report::certificate::CmmSources {
        length: "iso10360-example.csv".into(),
        probing: "probing-example.csv".into(),
        sphere: "probing-sphere.toml".into(),
    };
    errmap::report::certificate::write_cmm(&pdf, &cert, &sources)?;
    eprintln!(
        "  ISO 10360-2 {}, ISO 10360-5 {}: {}; certificate → {}",
        cert.iso10360_2.verdict,
        cert.iso10360_5.verdict,
        cert.verdict,
        pdf.display()
    );
    Ok(cert)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The demo's CMM step judges the committed example test as the library's example call
    /// does, joins it with the ISO 10360-2 example (indeterminate at 990 mm, as
    /// reports/iso10360-5/README.md says) and writes both reports and the certificate.
    #[test]
    fn demo_step_verifies_the_example_cmm() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let cert = demo_step(dir.path())?;
        assert_eq!(
            serde_json::to_value(&cert.iso10360_5)?,
            serde_json::to_value(probing::evaluate_example()?)?
        );
        assert_eq!(cert.iso10360_2.verdict.to_string(), "indeterminate");
        assert_eq!(cert.verdict.to_string(), "indeterminate");
        let a = dir.path().join("acceptance");
        for f in [
            "iso10360/report.md",
            "iso10360-5/report.md",
            "iso10360-5/sphere_map.png",
            "cmm-certificate.pdf",
        ] {
            assert!(a.join(f).is_file(), "{f}");
        }
        let pdf = std::fs::read(a.join("cmm-certificate.pdf"))?;
        assert!(pdf.starts_with(b"%PDF-"));
        Ok(())
    }
}
