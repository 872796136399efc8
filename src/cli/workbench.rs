//! `errmap workbench`: flags into `errmap::workbench::Config`, the address line on
//! stderr, and a graceful stop on SIGINT/SIGTERM. The work is in `errmap::workbench`.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use anyhow::Result;
use clap::Args;
use errmap::workbench::{Config, ServeError, serve};

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
