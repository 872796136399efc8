//! `errmap acceptance {decide, iso10360}` and `errmap volumetric iso10360`: flags,
//! validation into library configuration, and glue. The work is in
//! `errmap::acceptance`, the reports in `errmap::report::acceptance`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Args, Subcommand};
use errmap::acceptance::{
    self, DecisionRule, Mpe, Rule, TestConfig, Tolerances, VirtualConfig, VirtualModel as Model,
    VirtualPlan,
};

/// `--rule`: a rule name from the library's list.
pub(crate) fn rule() -> impl TypedValueParser<Value = Rule> {
    PossibleValuesParser::new(Rule::ALL.map(Rule::name)).try_map(|s| s.parse::<Rule>())
}

/// The decision-rule flags every judging command takes.
#[derive(Debug, Clone, Default, Args)]
pub(crate) struct RuleArgs {
    /// Decision rule: iso14253 (ISO 14253-1:2017 default, guard band U, pass / fail /
    /// indeterminate), simple (ILAC-G8 simple acceptance, w = 0), guard (ILAC-G8
    /// binary statement with guard band w = r·U).
    #[arg(long, value_parser = rule())]
    pub rule: Option<Rule>,
    /// r of the guard rule's w = r·U (≥ 0; default 1).
    #[arg(long, allow_negative_numbers = true, value_parser = super::values::guard_fraction)]
    pub guard_fraction: Option<f64>,
}

impl RuleArgs {
    /// The rule these flags give, over `file`'s (a tolerance file's own rule).
    pub(crate) fn resolve(&self, file: Option<DecisionRule>) -> Result<DecisionRule> {
        let base = file.unwrap_or_default();
        let rule = self.rule.unwrap_or(base.rule);
        let r = self.guard_fraction.unwrap_or(base.guard_fraction);
        match DecisionRule::new(rule, r) {
            // A flag value out of range is a usage error (exit 2, docs/cli.md).
            Err(e) if self.guard_fraction.is_some() => {
                Err(super::guard::usage(format!("--guard-fraction {r}: {e:#}")))
            }
            other => other.context("--guard-fraction"),
        }
    }
}

#[derive(Debug, Args)]
pub(crate) struct AcceptanceArgs {
    #[command(subcommand)]
    pub command: AcceptanceCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum AcceptanceCommand {
    /// Judge results against limits (CSV: id, value, u, lower, upper).
    Decide(DecideArgs),
    /// ISO 10360-2:2009 length measurement error test from a measured file.
    Iso10360(Iso10360Args),
    /// ISO 10360-5:2010 probing test (25 points per stylus on a calibrated sphere).
    #[command(name = "iso10360-5")]
    Iso10360_5(super::probing::ProbingArgs),
    /// The CMM's verification certificate (PDF): ISO 10360-2 and 10360-5 with a statement
    /// of conformity.
    CmmCertificate(super::probing::CmmCertificateArgs),
    /// A simulated probing test (the example of datasets/acceptance/).
    #[command(hide = true)]
    SimulateProbing(super::probing::SimulateArgs),
}

#[derive(Debug, Args)]
pub(crate) struct DecideArgs {
    /// Results (CSV or Parquet): id, value, u (expanded uncertainty), lower, upper.
    pub values: PathBuf,
    #[command(flatten)]
    pub rule: RuleArgs,
    /// Print the decisions as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct Iso10360Args {
    /// The test (CSV or Parquet, one row per measurement).
    pub test: PathBuf,
    #[command(flatten)]
    pub length: LengthArgs,
    #[command(flatten)]
    pub rule: RuleArgs,
    /// Write report.md, measurements.csv and the E0 chart here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the evaluation (every measurement, E0, R0, the verdicts) as one JSON document
    /// on stdout.
    #[arg(long)]
    pub json: bool,
}

/// How an ISO 10360-2 test is judged (`acceptance iso10360`, `acceptance cmm-certificate`).
#[derive(Debug, Args)]
pub(crate) struct LengthArgs {
    /// MPE_E0(L): `A+L/K`, `min(A+L/K,B)` or `B` (µm, L in mm).
    #[arg(long)]
    pub mpe: String,
    /// Expanded uncertainty of E0: a number or `A+L/K` (µm); a row's u_um wins.
    #[arg(long)]
    pub u_um: Option<String>,
    /// MPL of the repeatability range R0, µm.
    #[arg(long, allow_negative_numbers = true)]
    pub mpl_r0: Option<f64>,
    /// Expanded uncertainty of R0, µm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub u_r0_um: f64,
    /// Repetitions per test length.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=100))]
    pub repetitions: u64,
}

#[derive(Debug, Args)]
pub(crate) struct VirtualArgs {
    /// MODEL.json from `volumetric identify --out` (or a machine-model TOML: the truth).
    #[arg(long)]
    pub model: PathBuf,
    /// Plan (TOML). Without it, the default plan: 7 positions × 5 lengths × 3 repetitions
    /// over the model's measured range.
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// MPE_E0(L): `A+L/K`, `min(A+L/K,B)` or `B` (µm, L in mm).
    #[arg(long)]
    pub mpe: Option<String>,
    /// The test's own expanded uncertainty U_u: a number or `A+L/K` (µm).
    #[arg(long)]
    pub u_um: Option<String>,
    #[command(flatten)]
    pub rule: RuleArgs,
    /// Also predict the test after a compensation table of the model is loaded (what the
    /// table cannot represent remains).
    #[arg(long)]
    pub compensated: bool,
    /// Positions per axis of that table (as `volumetric export --points`).
    #[arg(long, default_value_t = acceptance::VIRTUAL_TABLE_POINTS, value_parser = super::values::at_least_two)]
    pub table_points: usize,
    /// Write report.md, measurements.csv and the chart here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the predicted test (every measurement and the verdicts, before and after
    /// compensation) as one JSON document on stdout.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn acceptance_cmd(a: AcceptanceArgs) -> Result<()> {
    match a.command {
        AcceptanceCommand::Decide(a) => decide_cmd(a),
        AcceptanceCommand::Iso10360(a) => iso10360_cmd(a),
        AcceptanceCommand::Iso10360_5(a) => super::probing::probing_cmd(a),
        AcceptanceCommand::CmmCertificate(a) => super::probing::cmm_certificate_cmd(a),
        AcceptanceCommand::SimulateProbing(a) => super::probing::simulate_cmd(a),
    }
}

fn decide_cmd(a: DecideArgs) -> Result<()> {
    let rule = a.rule.resolve(None)?;
    let r = acceptance::decide_file(&a.values, &rule)?;
    if a.json {
        super::guard::print_json(&r)?;
    } else {
        eprintln!("{}", r.statement);
        for x in &r.results {
            eprintln!(
                "  {:<16} {:>12} U {:>8}  [{}, {}] → {}",
                x.id,
                x.value,
                x.u.map_or("—".into(), |u| u.to_string()),
                x.lower.map_or("—".into(), |v| v.to_string()),
                x.upper.map_or("—".into(), |v| v.to_string()),
                x.verdict
            );
        }
        eprintln!(
            "acceptance decide: {} result(s): {}",
            r.results.len(),
            r.verdict
        );
    }
    Ok(())
}

/// A formula flag (`--u-um`); a value that does not parse or is out of range is a usage
/// error (exit 2), as every bad flag value is (docs/cli.md).
fn formula(option: &str, f: Option<&str>) -> Result<Option<Mpe>> {
    f.map(|f| Mpe::parse(f, option).map_err(|e| super::guard::usage(e.to_string())))
        .transpose()
}

/// The `--mpe` flag: a positive, plausible limit ([`Mpe::parse_limit`]), else exit 2.
fn mpe_flag(f: &str) -> Result<Mpe> {
    Mpe::parse_limit(f, "--mpe").map_err(|e| super::guard::usage(e.to_string()))
}

/// The ISO 10360-2 options as the library's configuration, checked.
pub(crate) fn length_config(a: &LengthArgs, rule: &RuleArgs) -> Result<TestConfig> {
    let mpe = mpe_flag(&a.mpe)?;
    let u = formula("--u-um", a.u_um.as_deref())?;
    if let Some(m) = a.mpl_r0
        && !(m.is_finite() && m >= 0.0)
    {
        return Err(super::guard::usage(format!(
            "--mpl-r0 {m}: must be finite and ≥ 0 µm"
        )));
    }
    if !(a.u_r0_um.is_finite() && a.u_r0_um >= 0.0) {
        return Err(super::guard::usage(format!(
            "--u-r0-um {}: U must be finite and ≥ 0 µm",
            a.u_r0_um
        )));
    }
    Ok(TestConfig {
        mpe,
        u,
        mpl_r0_um: a.mpl_r0,
        u_r0_um: a.u_r0_um,
        repetitions: a.repetitions as usize,
        rule: rule.resolve(None)?,
    })
}

fn iso10360_cmd(a: Iso10360Args) -> Result<()> {
    if let Some(dir) = &a.report {
        super::guard::refuse_aliases(&[("--report", dir)], &[("TEST", &a.test)])?;
    }
    let config = length_config(&a.length, &a.rule)?;
    let r = acceptance::evaluate_file(&a.test, &config)?;
    if let Some(dir) = &a.report {
        let source = a.test.display().to_string();
        super::guard::into_new_dir(dir, |d| {
            errmap::report::write_iso10360_report(d, &source, &r, &config.rule).map_err(Into::into)
        })?;
        eprintln!("acceptance iso10360: report in {}", dir.display());
    }
    if a.json {
        super::guard::print_json(&r)?;
    }
    eprintln!(
        "acceptance iso10360: {} measurements in {} positions, max |E0| {:.3} µm: {}{}",
        r.summary.measurements,
        r.summary.positions,
        r.summary.max_abs_e0_um,
        r.verdict,
        if r.deviations.is_empty() {
            String::new()
        } else {
            format!(
                " ({} deviation(s) from the 7 × 5 × 3 design)",
                r.deviations.len()
            )
        }
    );
    Ok(())
}

pub(crate) fn virtual_cmd(a: VirtualArgs) -> Result<()> {
    let t = virtual_test(&a)?;
    if a.json {
        super::guard::print_json(&t)?;
    }
    eprintln!(
        "volumetric iso10360: {} predicted measurements, max |E| {:.3} µm{}{}",
        t.measurements.len(),
        t.max_abs_e_um,
        t.verdict.map(|v| format!(": {v}")).unwrap_or_default(),
        t.compensated
            .as_ref()
            .map(|c| format!(
                "; after compensation max |E| {:.3} µm (not resolved below ±{:.3} µm: the \
                 model's 2σ and the table's 0.1 µm step){}",
                c.max_abs_e_um,
                c.floor_um,
                c.verdict.map(|v| format!(": {v}")).unwrap_or_default()
            ))
            .unwrap_or_default()
    );
    Ok(())
}

/// What `volumetric iso10360` predicts from the flags (the report written when asked),
/// also the demo's artefact step.
pub(crate) fn virtual_test(a: &VirtualArgs) -> Result<acceptance::VirtualTest> {
    let mut inputs: Vec<(&str, &Path)> = vec![("--model", &a.model)];
    inputs.extend(a.plan.as_deref().map(|p| ("--plan", p)));
    if let Some(dir) = &a.report {
        super::guard::refuse_aliases(&[("--report", dir)], &inputs)?;
    }
    let mpe = a.mpe.as_deref().map(mpe_flag).transpose()?;
    let u = formula("--u-um", a.u_um.as_deref())?;
    let rule = a.rule.resolve(None)?;
    let model = Model::read(&a.model)?;
    let plan = match &a.plan {
        Some(p) => VirtualPlan::read(p, model.volume_mm)?,
        None => VirtualPlan::default_over(model.volume_mm.with_context(|| {
            format!(
                "{}: a machine model has no measured range: give --plan with volume_mm",
                a.model.display()
            )
        })?),
    };
    let config = VirtualConfig {
        mpe,
        u,
        rule,
        compensated: a.compensated.then_some(a.table_points),
    };
    let t = acceptance::predict(&a.model, &model, &plan, &config)?;
    for w in &t.warnings {
        eprintln!("volumetric iso10360: warning: {w}");
    }
    if let Some(dir) = &a.report {
        let source = a.model.display().to_string();
        super::guard::into_new_dir(dir, |d| {
            errmap::report::write_virtual_report(d, &source, &t).map_err(Into::into)
        })?;
        eprintln!("volumetric iso10360: report in {}", dir.display());
    }
    Ok(t)
}

/// `--tolerances` of `table` and `certificate`: the file read before anything is
/// written, and the rule the flags and the file give.
pub(crate) fn tolerances(
    path: Option<&Path>,
    rule: &RuleArgs,
) -> Result<Option<(Tolerances, DecisionRule)>> {
    let Some(p) = path else {
        if rule.rule.is_some() || rule.guard_fraction.is_some() {
            return Err(super::guard::usage(
                "--rule and --guard-fraction need --tolerances TOL.toml",
            ));
        }
        return Ok(None);
    };
    let t = Tolerances::read(p)?;
    let r = rule.resolve(t.rule)?;
    Ok(Some((t, r)))
}
