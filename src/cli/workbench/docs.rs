//! The JSON documents of the API, each the command's (`errmap table --json`, `circular
//! diagnose --json`, `volumetric identify --json`, `diagnose --json`, `history report
//! --json`, `acceptance iso10360 --json`), made by the same library jobs with the
//! commands' default options. The pages show the same results.
//!
//! [`Jobs`] runs them: each result is kept by the identity of the files it was made from
//! (`cache`), so a page or document asked for again costs a lookup, and
//! [`Jobs::warm`] makes the workspace's results once at start-up.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;

use super::cache::Memo;
use super::items::{Kind, Workspace, WorkspaceError};

/// Why a document cannot be made: the command's message, by the answer it gets.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum DocError {
    /// Bad input (400): the command's message.
    #[error("{0}")]
    Bad(String),
    /// No such item (404).
    #[error("{0}")]
    NotFound(String),
    /// The workbench itself failed (500).
    #[error("{0}")]
    Internal(String),
    /// Being made by another request (the start-up warm-up): a page says so at once
    /// (202) and fills in by itself; never kept, never a document's answer.
    #[error("being computed")]
    Pending,
}

impl DocError {
    /// The HTTP status it is answered with.
    pub(crate) fn status(&self) -> u16 {
        match self {
            DocError::Bad(_) => 400,
            DocError::NotFound(_) => 404,
            DocError::Internal(_) => 500,
            DocError::Pending => 202,
        }
    }
}

impl DocError {
    /// The same answer (status) with another message.
    pub(crate) fn with_message(&self, message: String) -> DocError {
        match self {
            DocError::Bad(_) => DocError::Bad(message),
            DocError::NotFound(_) => DocError::NotFound(message),
            DocError::Internal(_) => DocError::Internal(message),
            DocError::Pending => DocError::Pending,
        }
    }
}

/// A refusal answers `{"error": MESSAGE}` with its status, so a handler returns
/// `Result<Response, DocError>` and `?` does the rest.
impl axum::response::IntoResponse for DocError {
    fn into_response(self) -> axum::response::Response {
        super::server::json_error(self.status(), &self.to_string())
    }
}

impl From<WorkspaceError> for DocError {
    fn from(e: WorkspaceError) -> DocError {
        match e {
            WorkspaceError::Bad(_) => DocError::Bad(e.to_string()),
            WorkspaceError::NotFound(_) => DocError::NotFound(e.to_string()),
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
    DocError::Bad(message(&e))
}

/// A document as the command prints it (compact JSON; a NaN or ±inf is a bug reported).
pub(crate) fn text<T: Serialize + ?Sized>(doc: &T) -> Result<String, DocError> {
    errmap::report::json_text(Path::new("response"), doc, false)
        .map_err(|e| DocError::Internal(message(&e)))
}

/// `errmap table ITEM --json`: the reduction and its document's text.
#[derive(Debug)]
pub(crate) struct TableDoc {
    /// The session table read.
    pub path: PathBuf,
    pub reduced: Reduction,
    pub text: String,
}

/// A session's reduction: a linear axis' lines, or a rotary axis (A, B, C) in ″.
#[derive(Debug)]
pub(crate) enum Reduction {
    Linear(Box<errmap::acquire::Reduced>),
    Rotary(Box<super::rotary::RotaryDoc>),
}

/// `errmap circular diagnose ITEM --json`, and the report's polar chart of the trace.
#[derive(Debug)]
pub(crate) struct CircularDoc {
    pub chart: errmap::plot::PolarChart,
    pub diagnosis: errmap::circular::CircularDiagnosis,
    pub text: String,
}

/// `errmap volumetric identify ITEM --json` (or a model file's document).
#[derive(Debug)]
pub(crate) struct VolumetricDoc {
    pub doc: serde_json::Value,
    pub text: String,
}

/// `errmap compare ITEM --test TEST --json`, with what the page's chart needs of it.
#[derive(Debug)]
pub(crate) struct CompareDoc {
    /// The test points' measured errors, µm, in order.
    pub measured_um: Vec<f64>,
    /// Index of the recommended row.
    pub recommended: usize,
    /// The document (the command's `--json`), which the page shows.
    pub doc: serde_json::Value,
}

/// `errmap diagnose --recorded ITEM --simulated ITEM2 --json`.
#[derive(Debug)]
pub(crate) struct DiagnoseDoc {
    pub text: String,
}

/// `errmap acceptance iso10360 ITEM --mpe MPE --json`.
#[derive(Debug)]
pub(crate) struct Iso10360Doc {
    pub result: errmap::acceptance::TestResult,
    pub text: String,
}

/// The document of `errmap history report --json` (all machines, no tolerances, the
/// default horizon), and the reports it holds. Not kept: a ledger may change without
/// its file changing (a PostgreSQL ledger, a SQLite write-ahead log).
#[derive(Debug)]
pub(crate) struct History {
    pub head: errmap::history::Head,
    pub machines: Vec<errmap::history::MachineReport>,
    pub fleet: Vec<errmap::history::FleetEntry>,
    pub text: String,
}

/// The workspace and the results made from its files.
#[derive(Debug)]
pub(crate) struct Jobs {
    pub ws: Workspace,
    tables: Memo<TableDoc>,
    circular: Memo<CircularDoc>,
    volumetric: Memo<VolumetricDoc>,
    compare: Memo<CompareDoc>,
    diagnose: Memo<DiagnoseDoc>,
    iso10360: Memo<Iso10360Doc>,
}

/// The `session.json` beside a session table (the capture's description, which the
/// reduction and the diagnosis read).
fn capture_json(table: &Path) -> PathBuf {
    table.with_file_name("session.json")
}

impl Jobs {
    pub(crate) fn new(ws: Workspace) -> Jobs {
        Jobs {
            ws,
            tables: Memo::default(),
            circular: Memo::default(),
            volumetric: Memo::default(),
            compare: Memo::default(),
            diagnose: Memo::default(),
            iso10360: Memo::default(),
        }
    }

    /// The session table of an item (a table file, or a capture directory).
    pub(crate) fn session_path(&self, id: &str) -> Result<PathBuf, DocError> {
        let p = self.ws.resolve(id)?;
        errmap::sim::session_file(&p).map_err(bad)
    }

    /// `errmap table ITEM --json`.
    pub(crate) fn table(&self, id: &str) -> Result<Arc<TableDoc>, DocError> {
        let path = self.session_path(id)?;
        let key = path.display().to_string();
        self.tables.get(&key, &[&path, &capture_json(&path)], || {
            let id = self.ws.id_of(&path);
            let rotary = errmap::session::rotary::is_rotary(&path)
                .map_err(|e| DocError::Bad(format!("{id}: {}", message(&e))))?;
            if rotary {
                let (doc, text) = super::rotary::reduce(&path, &id)?;
                return Ok(TableDoc {
                    path: path.clone(),
                    reduced: Reduction::Rotary(Box::new(doc)),
                    text,
                });
            }
            let reduced = errmap::acquire::reduce_session(&path)
                .map_err(|e| DocError::Bad(format!("{id}: {}", message(&e))))?;
            let text = text(&errmap::report::table_json(&reduced, None))?;
            Ok(TableDoc {
                path: path.clone(),
                reduced: Reduction::Linear(Box::new(reduced)),
                text,
            })
        })
    }

    /// `errmap circular diagnose ITEM --json` (default options).
    pub(crate) fn circular(&self, id: &str) -> Result<Arc<CircularDoc>, DocError> {
        let p = self.ws.resolve(id)?;
        let meta = errmap::circular::meta_path(&p);
        self.circular
            .get(&p.display().to_string(), &[&p, &meta], || {
                let test = errmap::circular::read_test(&p).map_err(bad)?;
                let diagnosis =
                    errmap::circular::diagnose(&test, &errmap::circular::DiagnoseConfig::default());
                Ok(CircularDoc {
                    chart: errmap::report::circular_chart(&test, &diagnosis),
                    text: text(&diagnosis)?,
                    diagnosis,
                })
            })
    }

    /// `errmap volumetric identify ITEM --topology T --json` for a lines table (the other
    /// options at their defaults), or a model file's document without its fit.
    pub(crate) fn volumetric(
        &self,
        id: &str,
        topology: Option<&str>,
    ) -> Result<Arc<VolumetricDoc>, DocError> {
        let p = self.ws.resolve(id)?;
        if p.extension().is_some_and(|e| e == "json") {
            return self
                .volumetric
                .get(&p.display().to_string(), &[&p], || model_doc(id, &p));
        }
        let topology = topology.ok_or_else(|| {
            DocError::Bad(
                "the machine's topology is needed to identify lines (?topology=YXZ; \
                 `errmap volumetric identify` takes it as --topology)"
                    .into(),
            )
        })?;
        let topology: errmap::volumetric::Topology = topology
            .parse()
            .map_err(|e: errmap::volumetric::VolumetricError| DocError::Bad(message(&e)))?;
        let key = format!("{}?topology={topology}", p.display());
        self.volumetric
            .get(&key, &[&p], || identify_doc(&p, topology))
    }

    /// `errmap diagnose --recorded ITEM --simulated ITEM2 --json` (default options).
    pub(crate) fn diagnose(
        &self,
        recorded: &str,
        simulated: &str,
    ) -> Result<Arc<DiagnoseDoc>, DocError> {
        use errmap::sim::{Against, DiagnoseJob, session_file};
        let job = DiagnoseJob {
            recorded: self.ws.resolve(recorded)?,
            against: Against::Simulated(self.ws.resolve(simulated)?),
            grating_period_um: None,
            max_dead_path_mm: None,
            max_rows: errmap::diagnose::MAX_ROWS,
        };
        let rec = session_file(&job.recorded).map_err(bad)?;
        let Against::Simulated(sim) = &job.against else {
            return Err(DocError::Internal(
                "a diagnosis against a simulation".into(),
            ));
        };
        let sim = session_file(sim).map_err(bad)?;
        let key = format!("{}?simulated={}", rec.display(), sim.display());
        self.diagnose
            .get(&key, &[&rec, &sim, &capture_json(&rec)], || {
                let out = job.run().map_err(bad)?;
                let mut d = out.diagnosis;
                if let Some(t) = &out.thinning {
                    d.design_notes.push(t.note("--max-rows"));
                }
                let text = text(&errmap::report::DiagnoseJson {
                    diagnosis: &d,
                    iso230: None,
                })?;
                Ok(DiagnoseDoc { text })
            })
    }

    /// `errmap acceptance iso10360 ITEM --mpe MPE --json` (the other options at their
    /// defaults).
    pub(crate) fn iso10360(&self, id: &str, mpe: &str) -> Result<Arc<Iso10360Doc>, DocError> {
        use errmap::acceptance::Mpe;
        use errmap::acceptance::{TestConfig, evaluate_file};
        let p = self.ws.resolve(id)?;
        let mpe_v = Mpe::parse(mpe, "mpe").map_err(bad)?;
        let key = format!("{}?mpe={mpe}", p.display());
        self.iso10360.get(&key, &[&p], || {
            let config = TestConfig {
                mpe: mpe_v,
                u: None,
                mpl_r0_um: None,
                u_r0_um: 0.0,
                repetitions: 3,
                rule: Default::default(),
            };
            let result = evaluate_file(&p, &config).map_err(bad)?;
            let text = text(&result)?;
            Ok(Iso10360Doc { result, text })
        })
    }

    /// `errmap compare ITEM --test TEST --json` (the default methods and every admissible
    /// Lagrange order) for a table that is a grid.
    pub(crate) fn compare(&self, id: &str, test: &str) -> Result<Arc<CompareDoc>, DocError> {
        let fit = self.ws.resolve(id)?;
        let test_p = self.ws.resolve(test)?;
        let key = format!("{}?test={}", fit.display(), test_p.display());
        self.compare
            .get(&key, &[&fit, &test_p], || compare_doc(id, &fit, &test_p))
    }

    /// Makes the workspace's results once, cheapest first, so that a page opened later
    /// finds them: every session's table, ballbar diagnosis and volumetric model; the
    /// volumetric lines beside a model, identified with the model's topology; and the
    /// comparison of each error table with each other one of its folder (the fit and test
    /// tables of a campaign sit together), at most [`MAX_WARM_COMPARISONS`]. A page asked
    /// for while its result is being made waits for it rather than making it again.
    /// Returns how many results were made (a refusal is a result too).
    pub(crate) fn warm(&self) -> usize {
        let items = self.ws.items();
        let of = |k: Kind| {
            items
                .iter()
                .filter(move |i| i.kind == k && i.error.is_none())
        };
        let mut made = 0;
        for i in of(Kind::Session) {
            let _ = self.table(&i.id);
            made += 1;
        }
        for i in of(Kind::CircularTrace) {
            let _ = self.circular(&i.id);
            made += 1;
        }
        let mut topologies = Vec::new();
        for i in of(Kind::VolumetricModel) {
            made += 1;
            if let Ok(d) = self.volumetric(&i.id, None)
                && let Some(t) = d.doc.get("topology").and_then(|t| t.as_str())
            {
                topologies.push((folder(&i.id).to_string(), t.to_string()));
            }
        }
        for i in of(Kind::VolumetricLines) {
            for (_, t) in topologies.iter().filter(|(f, _)| f == folder(&i.id)) {
                let _ = self.volumetric(&i.id, Some(t));
                made += 1;
            }
        }
        let tables: Vec<&str> = of(Kind::ErrorTable).map(|i| i.id.as_str()).collect();
        let pairs = tables.iter().flat_map(|a| {
            tables
                .iter()
                .filter(move |b| *b != a && folder(b) == folder(a))
                .map(move |b| (*a, *b))
        });
        for (a, b) in pairs.take(MAX_WARM_COMPARISONS) {
            let _ = self.compare(a, b);
            made += 1;
        }
        made
    }
}

/// The most comparisons [`Jobs::warm`] makes (each fits every model twice).
pub(crate) const MAX_WARM_COMPARISONS: usize = 8;

/// The folder part of an item id (`""` at the top).
fn folder(id: &str) -> &str {
    id.rsplit_once('/').map_or("", |(f, _)| f)
}

/// A model file's document as `volumetric identify --json` prints it (without `fit`).
fn model_doc(id: &str, p: &Path) -> Result<VolumetricDoc, DocError> {
    let text_in =
        std::fs::read_to_string(p).map_err(|e| DocError::Bad(format!("{id}: cannot read: {e}")))?;
    let mut doc: serde_json::Value = serde_json::from_str(&text_in)
        .map_err(|e| DocError::Bad(format!("{id}: not a volumetric model: {e}")))?;
    if let Some(o) = doc.as_object_mut() {
        o.remove("fit");
    }
    let text = text(&doc)?;
    Ok(VolumetricDoc { doc, text })
}

/// `volumetric identify` of a lines table.
fn identify_doc(
    p: &Path,
    topology: errmap::volumetric::Topology,
) -> Result<VolumetricDoc, DocError> {
    use errmap::volumetric::{IdentifyConfig, LineTable, identify};
    let lines = LineTable::read(p, true).map_err(bad)?;
    let config = IdentifyConfig::new(topology);
    let id = identify(&lines, &config).map_err(bad)?;
    let text = text(&id.doc(config.positions, false))?;
    let doc = serde_json::from_str(&text).map_err(|e| DocError::Internal(e.to_string()))?;
    Ok(VolumetricDoc { doc, text })
}

/// `errmap compare` of two tables.
fn compare_doc(id: &str, fit: &Path, test: &Path) -> Result<CompareDoc, DocError> {
    use errmap::interp::{Method, MethodSettings, admissible_orders};
    use errmap::table::ErrorTable;
    let table = ErrorTable::read(fit).map_err(bad)?;
    let test_table = ErrorTable::read(test).map_err(bad)?;
    let grid = table.grid().map_err(bad)?;
    let mut methods: Vec<Method> = Method::defaults(&grid, 0, &MethodSettings::default())
        .into_iter()
        .filter(|m| m.order().is_none())
        .collect();
    methods.extend(
        admissible_orders(grid.shape(), errmap::evaluate::DEFAULT_MAX_DEGREE)
            .into_iter()
            .map(Method::Lagrange),
    );
    let c = errmap::evaluate::compare_where_possible(&table, &grid, &test_table, &methods)
        .map_err(|e| DocError::Bad(format!("{id}: comparison failed: {}", message(&e))))?;
    let text = text(&c.to_json(None))?;
    Ok(CompareDoc {
        measured_um: c.test.points.iter().map(|p| p.e_um).collect(),
        recommended: c.recommended,
        doc: serde_json::from_str(&text).map_err(|e| DocError::Internal(e.to_string()))?,
    })
}

/// `errmap history report --json` of a ledger.
pub(crate) fn history(ledger: &str) -> Result<History, DocError> {
    use errmap::history::{DEFAULT_HORIZON_DAYS, Ledger, ReportConfig, Run};
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
