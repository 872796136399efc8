//! errmap — measure and model the geometric error of coordinate measuring machines and
//! machine tools.
//!
//! ```text
//! board bytes ──acquire──▶ session table ──session──▶ error table ──table──▶ grid
//!                            │      ▲                                        │
//!                            │      └── sim: simulated sessions         interp: a model
//!                            ▼                                               │
//!               diagnose: the named effects            ┌─────────────────────┤
//!               that explain the residual     evaluate: comparison   export: controller tables
//!
//! laser line table ──volumetric──▶ the 21 geometric errors, predictions, compensation tables
//! ballbar trace ──circular──▶ ISO 230-4 numbers, the machine errors behind the trace
//! results ──acceptance──▶ decisions of conformity      records ──history──▶ trends, forecasts
//!
//! report: words and figures for every stage          base, plot: shared leaves
//! ```
//!
//! The library holds all the work; the `errmap` binary (`src/cli/`) turns arguments into
//! library types once and calls it. The modules, in pipeline order:
//!
//! | module | stage | does |
//! |---|---|---|
//! | [`acquire`] | 1 acquisition | capture and replay into a session directory (raw bytes first) |
//! | [`session`] | 2 session | session tables, their reduction to error tables, ISO 230-2 / VDI 3441 statistics |
//! | [`table`] | 3 error table | error tables (CSV/Parquet via polars), cell validation, the grid |
//! | [`interp`] | 4 models | Lagrange m×n×q, trilinear, tricubic spline, fuzzy, Gaussian process; the method registry |
//! | [`evaluate`] | 5 evaluation | cross-validation, the order/method comparison, the fuzzy-interpolation paper's experiment |
//! | [`report`] | 6 report | words, tables and figures on disk for every stage |
//! | [`diagnose`] | 7 diagnosis | what a simulation left out of a recording: locate, name, fit |
//! | [`export`] | 8 export | a model sampled along a line or over a volume; the CSV line and the volumetric grid |
//! | [`controller`] | 8 controllers | one file per controller dialect: its table's writer, reader, in-place update, limits, sign and unit; the dialect registry; the export job |
//! | [`import`] | import | laser exports and spreadsheets into session tables, controller tables into error tables |
//! | [`sim`] | simulator | the machine model and plans, the other side of the diagnosis |
//! | [`circular`] | circular test | the ballbar test (ISO 230-4): the trace, its numbers, the circular effects behind it (their own typed family), a simulator, the link to a volumetric model |
//! | [`volumetric`] | 9 volumetric | the 21 geometric errors from laser line measurements: model, line tables (simulated or from captured sessions), identification, identifiability, the campaign's own faults (scale expansion, drift, a bad line), prediction |
//! | [`history`] | 10 history | the calibration ledger of a fleet (SQLite or PostgreSQL, append-only): trends, EWMA charts, tolerance forecasts, advice |
//! | [`acceptance`] | 10 decisions | conformity with a decision rule (ISO 14253-1, ILAC-G8); tolerances on ISO 230-2 results; the ISO 10360-2 length test measured and predicted from the volumetric model |
//! | [`base`] | shared leaf | the one `Axis`, the diagnosis vocabulary, statistics, optimisers, constants |
//! | [`plot`] | shared leaf | PNG/SVG charts with a bundled font |
//! | [`bench`](mod@bench) | — | throughput of the models and the decoder (`errmap bench`, `cargo bench`) |
//! | [`drivers`] | leaf crate | `errmap-drivers`: wire protocol, decoder, capture loop, simulated board |
//!
//! Imports run one way: `base` and `plot` import nothing of the crate, each stage imports
//! only the stages it builds on, and nothing in the library imports [`report`]. The rule
//! is written out in `CONTRIBUTING.md` and checked by the test `tests/it/layers.rs`.
//!
//! # One example per stage
//!
//! Each stage in a few lines, on the repository's own data (`datasets/`). The examples run
//! as tests (`cargo test --doc`).
//!
//! **sim → acquire.** Simulate the demo's machine through the simulated board, write the
//! raw bytes a capture would have written, and decode them into a session table:
//!
//! ```
//! use std::path::Path;
//! use errmap::sim::{MachineModel, read_plan, simulate_plan};
//!
//! let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/sim");
//! let model = MachineModel::read(&data.join("model.toml"))?;
//! let plan = read_plan(Some(&data.join("plan.toml")))?;
//! let (stream, _truth) =
//!     simulate_plan(&model, &data.join("model.toml"), &plan, &Default::default(), true)?;
//!
//! let dir = tempfile::tempdir()?;
//! let raw = dir.path().join("raw.bin");
//! std::fs::write(&raw, stream.bytes())?;
//! let replayed = errmap::acquire::replay(&raw, &dir.path().join("session.csv"))?;
//! assert!(replayed.rows > 1000);
//! assert_eq!(replayed.stats.crc_failures, 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **session.** Read a session table and reduce it to an error table (one node per line
//! and target, the mean over runs and directions):
//!
//! ```
//! use std::path::Path;
//!
//! let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/physics/example-session.parquet");
//! let rows = errmap::session::read_session(&path)?;
//! let (table, summary) = errmap::session::error_table("example", &rows)?;
//! assert_eq!(summary.rows, rows.len());
//! assert!(!table.points.is_empty());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **table → interp.** Build an error table, check it is a grid, fit a tricubic spline
//! and predict the error at a point:
//!
//! ```
//! use errmap::interp::{Interpolator, Method};
//! use errmap::table::{ErrorPoint, ErrorTable};
//!
//! // A 3×3×3 grid whose error grows along x: e = 0.01·x µm.
//! let mut points = Vec::new();
//! for x in [0.0, 100.0, 200.0] {
//!     for y in [0.0, 50.0, 100.0] {
//!         for z in [0.0, 50.0, 100.0] {
//!             points.push(ErrorPoint::new(x, y, z, 0.01 * x));
//!         }
//!     }
//! }
//! let grid = ErrorTable::from_points("doc example", points).grid()?;
//! let model = Method::Spline.fit(&grid)?;
//! let e_um = model.predict([150.0, 25.0, 75.0]);
//! assert!((e_um - 1.5).abs() < 1e-9);
//! assert!(!model.outside([150.0, 25.0, 75.0]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **evaluate.** Cross-validate a method on the fitting table alone, leaving out one grid
//! plane at a time (trilinear interpolation is exact on an affine field, extrapolation
//! included):
//!
//! ```
//! use errmap::interp::Method;
//! use errmap::table::{ErrorPoint, ErrorTable};
//!
//! let mut points = Vec::new();
//! for x in [0.0, 100.0, 200.0, 300.0] {
//!     for y in [0.0, 100.0, 200.0] {
//!         for z in [0.0, 100.0, 200.0] {
//!             points.push(ErrorPoint::new(x, y, z, 0.01 * x - 0.02 * y + 0.005 * z));
//!         }
//!     }
//! }
//! let grid = ErrorTable::from_points("affine", points).grid()?;
//! let cv = errmap::evaluate::leave_one_plane_out(&grid, &Method::Trilinear)?;
//! assert!(cv.rms_um < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **export.** Sample a model along a line and render a LinuxCNC compensation file
//! (compensation = −error) with the controller stage:
//!
//! ```
//! use std::path::Path;
//! use errmap::base::Axis;
//! use errmap::controller::{CompType, linuxcnc};
//! use errmap::export::{Extrapolation, LineSpec, sample_line};
//! use errmap::interp::Method;
//!
//! let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/table1.csv");
//! let grid = errmap::table::ErrorTable::read(&path)?.grid()?;
//! let model = Method::Spline.fit(&grid)?;
//! let line = LineSpec { axis: Axis::X, at_mm: [0.0, 1.0, 200.0], start_mm: 200.0, end_mm: 800.0, step_mm: 100.0 };
//! let sampled = sample_line(model.as_ref(), &line, Extrapolation::Forbid)?;
//! let text = linuxcnc::render(&sampled, CompType::ActualPosition, None)?;
//! assert_eq!(text.lines().filter(|l| !l.starts_with(';') && !l.trim().is_empty()).count(), 7);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **diagnose.** Find what a simulation left out of a recording: in this committed case
//! the recording carries a backlash the nominal model lacks.
//!
//! ```
//! use std::path::Path;
//! use errmap::diagnose::{DiagnoseConfig, diagnose};
//! use errmap::session::read_session;
//!
//! let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/concealed/reversal");
//! let recorded = read_session(&case.join("recorded.parquet"))?;
//! let simulated = read_session(&case.join("simulated.parquet"))?;
//! let d = diagnose(&recorded, &simulated, &DiagnoseConfig::default())?;
//! assert_eq!(d.effects.len(), 1);
//! assert!(d.rms_after_um < d.rms_before_um / 2.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **volumetric.** Simulate a laser campaign and identify the 21 geometric errors:
//!
//! ```
//! use std::path::Path;
//! use errmap::volumetric::{Degree, IdentifyConfig, Machine, PlanFile, identify, simulate};
//!
//! let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/volumetric");
//! let machine = Machine::read(&data.join("model.toml"))?;
//! let lines = simulate(&machine, &PlanFile::read(&data.join("plan.toml"))?);
//! let mut config = IdentifyConfig::new("YXZ".parse()?);
//! config.degree = Degree::Fixed(3);
//! let id = identify(&lines, &config)?;
//! assert_eq!(id.lines, lines.lines.len());
//! assert!(id.rms_residual_um < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **report.** Every stage's words and figures; here the fuzzy-interpolation paper's
//! simulation, run for two trials and written as Markdown:
//!
//! ```
//! use errmap::evaluate::{FuzzySimConfig, run_fuzzy_sim};
//!
//! let result = run_fuzzy_sim(&FuzzySimConfig { trials: 2, ..FuzzySimConfig::default() })?;
//! let markdown = errmap::report::experiment_markdown(&result);
//! assert!(markdown.starts_with("# Fuzzy vs trilinear vs cubic spline"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **base, plot.** The shared leaves: one `Axis`, statistics, and charts in PNG and SVG
//! with a bundled font:
//!
//! ```
//! use errmap::base::{Axis, rms};
//! use errmap::plot::{XySeries, XyStyle, xy};
//!
//! assert_eq!("y".parse::<Axis>()?, Axis::Y);
//! assert_eq!(rms(&[3.0, 4.0]), Some((12.5f64).sqrt()));
//!
//! let dir = tempfile::tempdir()?;
//! let series = [XySeries { name: "e".into(), x: vec![0.0, 1.0, 2.0], y: vec![0.0, 1.0, 4.0], style: XyStyle::Line }];
//! let files = xy(&dir.path().join("chart"), "error", "x mm", "e µm", &series)?;
//! assert!(files.iter().all(|f| f.is_file()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod acceptance;
pub mod acquire;
pub mod artefact;
pub mod base;
pub mod bench;
pub mod circular;
pub mod controller;
pub mod diagnose;
pub mod evaluate;
pub mod export;
pub mod history;
pub mod import;
pub mod interp;
pub mod plot;
pub mod report;
pub mod session;
pub mod sim;
pub mod table;
pub mod volumetric;

pub use errmap_drivers as drivers;
