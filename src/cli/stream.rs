//! `gen-capture`: a long simulated raw capture (see `errmap_drivers::longrun`), to measure
//! replay and table throughput and memory on captures of any length.

use std::io::BufWriter;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use errmap::drivers::longrun::write_long_capture;

/// `errmap gen-capture --mb N --out FILE`.
#[derive(Debug, Args)]
pub(crate) struct GenCaptureArgs {
    /// Size of the capture, MB (10⁶ bytes); the last line's session is written whole.
    #[arg(long, default_value_t = 200.0)]
    pub mb: f64,
    /// The raw capture to write (must not exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the controller's timing.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The board's sample rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    pub sample_hz: f64,
}

pub(crate) fn gen_capture(a: GenCaptureArgs) -> Result<()> {
    if !(a.mb.is_finite() && a.mb > 0.0 && a.mb <= 1e6) {
        return Err(super::guard::usage(format!(
            "--mb is a size in MB in (0, 10⁶], not {}",
            a.mb
        )));
    }
    if !(a.sample_hz.is_finite() && a.sample_hz > 0.0 && a.sample_hz <= 1e5) {
        return Err(super::guard::usage(format!(
            "--sample-hz is a rate in (0, 10⁵] Hz, not {}",
            a.sample_hz
        )));
    }
    let file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut out = BufWriter::with_capacity(1 << 20, file);
    let made = write_long_capture(&mut out, (a.mb * 1e6) as u64, a.seed, a.sample_hz)
        .with_context(|| format!("writing {}", a.out.display()))?;
    eprintln!(
        "gen-capture: {} bytes, {} samples in {} line sessions → {}",
        made.bytes,
        made.samples,
        made.blocks,
        a.out.display()
    );
    Ok(())
}
