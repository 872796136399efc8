//! `errmap certificate SESSION [--info INFO.toml] --out certificate.pdf`: the calibration
//! certificate of a session. Glue only: the statistics are `errmap::session`'s, the budget
//! `errmap::session::Budget`'s, the PDF `errmap::report::certificate`'s.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use errmap::report::certificate::{self, CertificateData, CertificateInfo, LineResult};
use errmap::session;

use super::acquisition::session_file;

/// Arguments of `errmap certificate`.
#[derive(Debug, Args)]
pub(crate) struct CertificateArgs {
    /// Session table (CSV/Parquet) or a capture directory holding one.
    pub session: PathBuf,
    /// Info TOML: lab, operator, customer, machine, instruments, date of test, and
    /// uncertainty inputs (unknown keys are an error). Without it the fields are blank.
    #[arg(long)]
    pub info: Option<PathBuf>,
    /// The PDF to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Judge every line against these tolerances (TOML) and add the statement of
    /// conformity. Without it the certificate is unchanged.
    #[arg(long)]
    pub tolerances: Option<PathBuf>,
    #[command(flatten)]
    pub rule: super::acceptance::RuleArgs,
}

pub(crate) fn certificate_cmd(a: CertificateArgs) -> Result<()> {
    if super::rotary::is_rotary_session(&a.session)? {
        return super::rotary::certificate_cmd(a);
    }
    let path = session_file(&a.session)?;
    let mut inputs = vec![("SESSION", path.as_path())];
    inputs.extend(a.info.as_deref().map(|p| ("--info", p)));
    inputs.extend(a.tolerances.as_deref().map(|p| ("--tolerances", p)));
    super::guard::refuse_aliases(&[("--out", &a.out)], &inputs)?;
    let tolerances = super::acceptance::tolerances(a.tolerances.as_deref(), &a.rule)?;
    let info = match &a.info {
        Some(p) => CertificateInfo::read(p)?,
        None => CertificateInfo::default(),
    };
    let rows = session::read_session(&path)?;
    let source = path.display().to_string();
    let (_, summary) = session::error_table(&source, &rows)?;
    let (iso, failed) = session::iso_by_line(&rows);
    for (line, e) in &failed {
        eprintln!("certificate: no ISO 230-2 statistics for line {line:?}: {e}");
    }
    if iso.is_empty() {
        // The real cause, before any tolerance is looked at (a one-run import).
        let why = failed
            .iter()
            .map(|(l, e)| format!("line {l:?}: {e}"))
            .collect::<Vec<_>>()
            .join("; ");
        anyhow::bail!(
            "{}: no line has ISO 230-2 statistics, so there is nothing to certify ({why})",
            path.display()
        );
    }
    let sources = session::BudgetSources::choose(
        errmap::acquire::device_resolutions(&path),
        info.laser.resolution_um,
        &session::RecordedResolution::of(&rows),
        &info.drift_check,
        &session::DriftFinder::of(&rows),
        &info.conditions,
    );
    let environment = session::EnvironmentStats::of(&rows);
    let budgets = iso
        .iter()
        .map(|(_, s)| {
            session::line_budget_with(&info.uncertainty, &environment, s, &sources).map(|(b, _)| b)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let axis = summary.axis.clone().unwrap_or_default();
    let data = CertificateData {
        source: &source,
        axis: &axis,
        rows: &rows,
        lines: iso
            .iter()
            .zip(&budgets)
            .map(|((line_mm, stats), budget)| LineResult {
                line_mm: *line_mm,
                stats,
                budget,
            })
            .collect(),
        info: &info,
    };
    let conformity = match &tolerances {
        Some((t, rule)) => {
            let lines: Vec<_> = data
                .lines
                .iter()
                .map(|l| (l.line_mm, l.stats, l.budget.expanded()))
                .collect();
            Some(t.judge(&axis, &lines, rule)?)
        }
        None => None,
    };
    certificate::write_with(&a.out, &data, conformity.as_ref())
        .with_context(|| format!("certificate of {}", path.display()))?;
    if let Some(c) = &conformity {
        eprintln!(
            "certificate: statement of conformity with {}: {}",
            c.specification, c.verdict
        );
    }
    eprintln!(
        "certificate: {} line(s) of axis {axis} → {}",
        data.lines.len(),
        a.out.display()
    );
    Ok(())
}
