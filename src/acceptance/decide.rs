//! `errmap acceptance decide VALUES`: a table of results (`id`, `value`, `u`, `lower`,
//! `upper`; CSV or Parquet), each judged by one rule. `u` is the expanded uncertainty U
//! (an empty cell or no column: no U given, judged with U = 0 and said in the
//! statement); an empty `lower` or `upper` is an absent limit, at least one per row.

use std::path::Path;

use serde::Serialize;

use super::AcceptanceError;
use super::rule::{ConformityVerdict, DecisionRule, Limits, aggregate};
use crate::table::{Cells, column_cells, optional_column_cells, parse_cell, read_frame};

/// One judged result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecidedResult {
    pub id: String,
    pub value: f64,
    /// U as given (`None`: not given, 0 used).
    pub u: Option<f64>,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    /// [T_L + w, T_U − w].
    pub acceptance: [Option<f64>; 2],
    pub verdict: ConformityVerdict,
}

/// `acceptance decide --json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecideReport {
    pub rule: &'static str,
    pub guard_fraction: Option<f64>,
    pub statement: String,
    pub results: Vec<DecidedResult>,
    pub verdict: ConformityVerdict,
}

/// The id cell of row `r0` as text (a number column prints as it reads).
pub(crate) fn text_cell(cells: &Cells, r0: usize) -> Option<String> {
    match cells {
        Cells::Text(v) => v[r0]
            .as_deref()
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_string),
        Cells::Number(v) => v[r0].map(|x| {
            if x.fract() == 0.0 && x.abs() < 1e15 {
                format!("{}", x as i64)
            } else {
                format!("{x}")
            }
        }),
    }
}

/// Judges every row of `path` by `rule`.
pub fn decide_file(path: &Path, rule: &DecisionRule) -> Result<DecideReport, AcceptanceError> {
    let df = read_frame(path)?;
    let ids = column_cells(path, &df, "id")?;
    let values = column_cells(path, &df, "value")?;
    let us = optional_column_cells(path, &df, "u")?;
    let lowers = optional_column_cells(path, &df, "lower")?;
    let uppers = optional_column_cells(path, &df, "upper")?;
    if lowers.is_none() && uppers.is_none() {
        return Err(AcceptanceError::file(
            path,
            "neither a `lower` nor an `upper` column: nothing to judge against",
        ));
    }
    if df.height() == 0 {
        return Err(AcceptanceError::file(path, "no data rows"));
    }
    let mut results = Vec::with_capacity(df.height());
    for r0 in 0..df.height() {
        let row = r0 + 1;
        let id = text_cell(&ids, r0)
            .ok_or_else(|| AcceptanceError::row(path, row, Some("id"), "empty"))?;
        let value = parse_cell(path, &values, r0, "value")?
            .ok_or_else(|| AcceptanceError::row(path, row, Some("value"), "empty"))?;
        let opt = |c: &Option<Cells>, name: &str| -> Result<Option<f64>, AcceptanceError> {
            Ok(match c {
                Some(c) => parse_cell(path, c, r0, name)?,
                None => None,
            })
        };
        let u = opt(&us, "u")?;
        if let Some(u) = u
            && u < 0.0
        {
            return Err(AcceptanceError::row(
                path,
                row,
                Some("u"),
                format!("U = {u} is negative"),
            ));
        }
        let lower = opt(&lowers, "lower")?;
        let upper = opt(&uppers, "upper")?;
        let limits = Limits::new(lower, upper)
            .map_err(|p| AcceptanceError::row(path, row, None, p.to_string()))?;
        let d = rule
            .decide(value, u.unwrap_or(0.0), limits)
            .map_err(|e| AcceptanceError::row(path, row, None, e.to_string()))?;
        results.push(DecidedResult {
            id,
            value,
            u,
            lower,
            upper,
            acceptance: d.acceptance,
            verdict: d.verdict,
        });
    }
    let any_u = results.iter().any(|r| r.u.is_some());
    let mut statement = rule.statement(any_u, None);
    if any_u && results.iter().any(|r| r.u.is_none()) {
        statement.push_str(" Rows without a U were judged with U = 0.");
    }
    Ok(DecideReport {
        rule: rule.rule.name(),
        guard_fraction: rule.fraction_shown(),
        statement,
        verdict: aggregate(results.iter().map(|r| r.verdict)).unwrap_or(ConformityVerdict::Pass),
        results,
    })
}
