//! `errmap workbench`: errmap in the browser (contract `docs/workbench.md`). A local web
//! application on axum that shows what the command line computes. It is part of the
//! binary, beside the commands, because it is one more way into the same library jobs:
//! its pages and JSON documents call what the commands call (`acquire::reduce_session`
//! and `report::table_json` for `table`, `circular::diagnose`, `volumetric::identify`,
//! `sim::DiagnoseJob`, `history::Run`, `acceptance`), and its downloads run the binary's
//! own commands. Nothing is computed twice, and nothing twice for the same files: results
//! are kept while their input files are unchanged (`cache`), and the workspace's results
//! are computed once at start-up in the background.
//!
//! | module | holds |
//! |---|---|
//! | `items` | the workspace: finding items by content and extension, and the one door to its files (no `..`, no link out) |
//! | `docs` | the JSON documents, each the command's |
//! | `cache` | results kept by their input files' identity (path, modification time, size) |
//! | `pages` | the server-rendered pages |
//! | `html` | the page shell and HTML escaping |
//! | `rotary` | a rotary session's document and page (″ against °, the closure check) |
//! | `charts` | inline SVG charts (deviation chart, polar plot, component bands) with hover values |
//! | `live` | the live capture: a serial port or a simulated board, Server-Sent Events |
//! | `server` | the router, the access token, the per-run form token, the downloads, the warm-up |
//!
//! Safety: bound to a loopback address no token is needed; any other address needs one,
//! and every request without it gets 401. A state-changing request is a POST carrying the
//! per-run token the page was served with. A capture started from the page writes a new
//! session folder (its raw bytes first) and never replaces anything.
//!
//! The web stack (axum, tokio) is behind the default cargo feature `workbench`: a build
//! with `--no-default-features` has no `workbench` command and compiles none of it.

mod cache;
mod charts;
mod docs;
mod html;
mod items;
mod live;
mod pages;
mod rotary;
mod server;

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use anyhow::Result;
use clap::Args;
use server::{Config, ServeError, serve};

#[derive(Debug, Args)]
pub(crate) struct WorkbenchArgs {
    /// The workspace: everything the workbench lists, opens or captures lies under it.
    #[arg(long, default_value = ".")]
    pub dir: PathBuf,
    /// A calibration ledger (SQLite path or postgres://…) for the history page.
    #[arg(long)]
    pub ledger: Option<String>,
    /// HOST:PORT to listen on (port 0: any free port).
    #[arg(long, default_value = "127.0.0.1:8765", value_parser = super::values::host_port)]
    pub addr: String,
    /// Access token; required when the address is not a loopback address.
    #[arg(long)]
    pub token: Option<String>,
    /// Open the workspace page in the system's browser.
    #[arg(long)]
    pub open: bool,
}

static STOP: AtomicBool = AtomicBool::new(false);

pub(crate) fn workbench_cmd(a: WorkbenchArgs) -> Result<()> {
    super::guard::stop_on_interrupt(&STOP);
    let config = Config {
        dir: a.dir,
        ledger: a.ledger,
        addr: a.addr,
        token: a.token.clone(),
        exe: std::env::current_exe().ok(),
    };
    let open = a.open;
    let token = a.token;
    let r = serve(config, &STOP, |addr| {
        let url = format!("http://{addr}/");
        eprintln!("workbench: {url}");
        if open {
            let with_token = match &token {
                Some(t) => format!("{url}?token={t}"),
                None => url,
            };
            if let Err(e) = std::process::Command::new("xdg-open")
                .arg(&with_token)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
            {
                eprintln!("workbench: cannot open a browser ({e}); open {with_token}");
            }
        }
    });
    match r {
        Ok(()) => Ok(()),
        Err(e @ ServeError::NeedsToken(_)) => {
            Err(super::guard::usage(format!("--addr {e}; add --token")))
        }
        Err(e) => Err(e.into()),
    }
}
