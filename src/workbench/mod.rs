//! The workbench: errmap in the browser (`errmap workbench`, contract
//! `docs/workbench.md`). A local web application on axum that shows what the command line
//! computes: its pages and JSON documents call the same library jobs as the commands
//! (`acquire::reduce_session` and `report::table_json` for `table`, `circular::diagnose`,
//! `volumetric::identify`, `sim::DiagnoseJob`, `history::Run`, `acceptance`), and its
//! downloads run the binary's own commands. Nothing is computed twice.
//!
//! | module | holds |
//! |---|---|
//! | `items` | the workspace: finding items by content and extension, and the one door to its files (no `..`, no link out) |
//! | `docs` | the JSON documents, each the command's |
//! | `pages` | the server-rendered pages |
//! | `html` | the page shell and HTML escaping |
//! | `charts` | inline SVG charts (deviation chart, polar plot, component bands) with hover values |
//! | `live` | the live capture: a serial port or a simulated board, Server-Sent Events |
//! | `server` | the router, the access token, the per-run form token, the downloads |
//!
//! Safety: bound to a loopback address no token is needed; any other address needs one,
//! and every request without it gets 401. A state-changing request is a POST carrying the
//! per-run token the page was served with. A capture started from the page writes a new
//! session folder (its raw bytes first) and never replaces anything.

mod charts;
mod docs;
mod html;
mod items;
mod live;
mod pages;
mod server;

pub use items::{Item, Kind, Workspace, WorkspaceError};
pub use server::{Config, ServeError, serve};
