//! The JSON documents of the API, each the command's (`errmap table --json`, `circular
//! diagnose --json`, `volumetric identify --json`, `diagnose --json`, `history report
//! --json`, `acceptance iso10360 --json`), made by the same library jobs with the
//! commands' default options. The pages show the same results.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::items::{Workspace, WorkspaceError};

/// Why a document cannot be made: the status and the command's message.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DocError {
    pub status: u16,
    pub message: String,
}

impl DocError {
    pub(crate) fn bad(message: impl Into<String>) -> DocError {
        DocError {
            status: 400,
            message: message.into(),
        }
    }
}

impl From<WorkspaceError> for DocError {
    fn from(e: WorkspaceError) -> DocError {
        let status = match e {
            WorkspaceError::Bad(_) => 400,
            WorkspaceError::NotFound(_) => 404,
        };
        DocError {
            status,
            message: e.to_string(),
        }
    }
}

/// An error and its causes, `: `-separated, each left out when the text before holds it
/// (as the command line prints them).
pub(crate) fn message(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let t = c.to_string();
        if !text.contains(&t) {
            text = format!("{text}: {t}");
        }
        cause = c.source();
    }
    text
}

fn bad(e: impl std::error::Error + 'static) -> DocError {
    DocError::bad(message(&e))
}

/// A document as the command prints it (compact JSON; a NaN or ±inf is a bug reported).
pub(crate) fn text<T: Serialize + ?Sized>(doc: &T) -> Result<String, DocError> {
    crate::report::json_text(Path::new("response"), doc, false).map_err(|e| DocError {
        status: 500,
        message: message(&e),
    })
}

/// The session table of an item (a table file, or a capture directory).
pub(crate) fn session_path(ws: &Workspace, id: &str) -> Result<PathBuf, DocError> {
    let p = ws.resolve(id)?;
    crate::sim::session_file(&p).map_err(bad)
}

/// `errmap table ITEM --json`: the reduction and its document's text.
pub(crate) fn table(
    ws: &Workspace,
    id: &str,
) -> Result<(PathBuf, crate::acquire::Reduced, String), DocError> {
    let path = session_path(ws, id)?;
    let reduced = crate::acquire::reduce_session(&path)
        .map_err(|e| DocError::bad(format!("{}: {}", ws.id_of(&path), message(&e))))?;
    let doc = text(&crate::report::table_json(&reduced, None))?;
    Ok((path, reduced, doc))
}

/// `errmap circular diagnose ITEM --json` (default options).
pub(crate) fn circular(
    ws: &Workspace,
    id: &str,
) -> Result<
    (
        crate::circular::CircularTest,
        crate::circular::CircularDiagnosis,
        String,
    ),
    DocError,
> {
    let p = ws.resolve(id)?;
    let test = crate::circular::read_test(&p).map_err(bad)?;
    let d = crate::circular::diagnose(&test, &crate::circular::DiagnoseConfig::default());
    let doc = text(&d)?;
    Ok((test, d, doc))
}

/// `errmap volumetric identify ITEM --topology T --json` for a lines table (the other
/// options at their defaults), or a model file's document without its fit.
pub(crate) fn volumetric(
    ws: &Workspace,
    id: &str,
    topology: Option<&str>,
) -> Result<(serde_json::Value, String), DocError> {
    use crate::volumetric::{IdentifyConfig, LineTable, identify};
    let p = ws.resolve(id)?;
    if p.extension().is_some_and(|e| e == "json") {
        let text_in = std::fs::read_to_string(&p)
            .map_err(|e| DocError::bad(format!("{id}: cannot read: {e}")))?;
        let mut doc: serde_json::Value = serde_json::from_str(&text_in)
            .map_err(|e| DocError::bad(format!("{id}: not a volumetric model: {e}")))?;
        if let Some(o) = doc.as_object_mut() {
            o.remove("fit");
        }
        let t = text(&doc)?;
        return Ok((doc, t));
    }
    let topology = topology.ok_or_else(|| {
        DocError::bad(
            "the machine's topology is needed to identify lines (?topology=YXZ; \
             `errmap volumetric identify` takes it as --topology)",
        )
    })?;
    let topology = topology
        .parse()
        .map_err(|e: crate::volumetric::VolumetricError| DocError::bad(message(&e)))?;
    let lines = LineTable::read(&p, true).map_err(bad)?;
    let config = IdentifyConfig::new(topology);
    let id_ = identify(&lines, &config).map_err(bad)?;
    let doc = id_.doc(config.positions, false);
    let t = text(&doc)?;
    let value = serde_json::from_str(&t).map_err(|e| DocError::bad(e.to_string()))?;
    Ok((value, t))
}

/// `errmap diagnose --recorded ITEM --simulated ITEM2 --json` (default options).
pub(crate) fn diagnose(
    ws: &Workspace,
    recorded: &str,
    simulated: &str,
) -> Result<(crate::diagnose::Diagnosis, String), DocError> {
    use crate::sim::{Against, DiagnoseJob};
    let job = DiagnoseJob {
        recorded: ws.resolve(recorded)?,
        against: Against::Simulated(ws.resolve(simulated)?),
        grating_period_um: None,
        max_dead_path_mm: None,
        max_rows: crate::diagnose::MAX_ROWS,
    };
    let out = job.run().map_err(bad)?;
    let mut d = out.diagnosis;
    if let Some(t) = &out.thinning {
        d.design_notes.push(t.note("--max-rows"));
    }
    let t = text(&crate::report::DiagnoseJson {
        diagnosis: &d,
        iso230: None,
    })?;
    Ok((d, t))
}

/// The document of `errmap history report --json` (all machines, no tolerances, the
/// default horizon), and the reports it holds.
pub(crate) struct History {
    pub head: crate::history::Head,
    pub machines: Vec<crate::history::MachineReport>,
    pub fleet: Vec<crate::history::FleetEntry>,
    pub text: String,
}

pub(crate) fn history(ledger: &str) -> Result<History, DocError> {
    use crate::history::{DEFAULT_HORIZON_DAYS, Ledger, ReportConfig, Run};
    let mut l = Ledger::open(ledger, false).map_err(bad)?;
    let config = ReportConfig {
        machine: None,
        tolerances: Default::default(),
        as_of: None,
        horizon_days: DEFAULT_HORIZON_DAYS,
    };
    let mut run = Run::new(&mut l, config).map_err(bad)?;
    let head = run.head().clone();
    let mut machines = Vec::new();
    while let Some(m) = run.next_machine().map_err(bad)? {
        machines.push(m);
    }
    let fleet = run.fleet();
    // The command streams `head` with "machines" and "fleet" added after its own keys.
    let head_text = text(&head)?;
    let machines_text = text(&machines)?;
    let fleet_text = text(&fleet)?;
    let text = format!(
        "{},\"machines\":{machines_text},\"fleet\":{fleet_text}}}",
        &head_text[..head_text.len() - 1]
    );
    Ok(History {
        head,
        machines,
        fleet,
        text,
    })
}

/// `errmap acceptance iso10360 ITEM --mpe MPE --json` (the other options at their
/// defaults).
pub(crate) fn iso10360(
    ws: &Workspace,
    id: &str,
    mpe: &str,
) -> Result<(crate::acceptance::TestResult, String), DocError> {
    use crate::acceptance::Mpe;
    use crate::acceptance::{TestConfig, evaluate_file};
    let p = ws.resolve(id)?;
    let mpe = Mpe::parse(mpe, "mpe").map_err(bad)?;
    let config = TestConfig {
        mpe,
        u: None,
        mpl_r0_um: None,
        u_r0_um: 0.0,
        repetitions: 3,
        rule: Default::default(),
    };
    let r = evaluate_file(&p, &config).map_err(bad)?;
    let t = text(&r)?;
    Ok((r, t))
}

/// `errmap compare ITEM --test TEST --json` (the default methods and every admissible
/// Lagrange order) for a table that is a grid.
pub(crate) fn compare(
    ws: &Workspace,
    id: &str,
    test: &str,
) -> Result<(crate::evaluate::Comparison, String), DocError> {
    use crate::interp::{Method, MethodSettings, admissible_orders};
    use crate::table::ErrorTable;
    let table = ErrorTable::read(&ws.resolve(id)?).map_err(bad)?;
    let test_table = ErrorTable::read(&ws.resolve(test)?).map_err(bad)?;
    let grid = table.grid().map_err(bad)?;
    let mut methods: Vec<Method> = Method::defaults(&grid, 0, &MethodSettings::default())
        .into_iter()
        .filter(|m| m.order().is_none())
        .collect();
    methods.extend(
        admissible_orders(grid.shape(), crate::evaluate::DEFAULT_MAX_DEGREE)
            .into_iter()
            .map(Method::Lagrange),
    );
    let c = crate::evaluate::compare_where_possible(&table, &grid, &test_table, &methods)
        .map_err(|e| DocError::bad(format!("{id}: comparison failed: {}", message(&e))))?;
    let t = text(&c.to_json(None))?;
    Ok((c, t))
}
