//! Rotary axes (`docs/rotary.md`): sessions, ISO 230-2 in arcseconds with the closure
//! check, bad inputs, and the rest of the rotary pipeline.

mod bad;
mod bidirectional;
mod capture;
mod certificate;
mod existing;
mod export;
mod linuxcnc;
mod modulo;
mod plan;
mod table;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A rotary test as a spreadsheet: `run,direction,target,error` (error = e, indicated −
/// reference, ″), one reading per dwell; `e(θ, run, d)` gives each.
pub(crate) fn rotary_csv(
    dir: &Path,
    name: &str,
    targets: &[f64],
    runs: u32,
    e: &dyn Fn(f64, u32, i8) -> f64,
) -> PathBuf {
    let mut s = String::from("run,direction,target,error\n");
    for run in 1..=runs {
        for &t in targets {
            let _ = writeln!(s, "{run},+1,{t},{:.9}", e(t, run, 1));
        }
        for &t in targets.iter().rev() {
            let _ = writeln!(s, "{run},-1,{t},{:.9}", e(t, run, -1));
        }
    }
    let p = dir.join(name);
    std::fs::write(&p, s).expect("write csv");
    p
}

/// Imports a rotary spreadsheet written by [`rotary_csv`] into a session table.
pub(crate) fn import_rotary(csv: &Path, out: &Path, axis: &str) -> std::process::Output {
    crate::util::errmap(&[
        "import",
        crate::util::s(csv),
        "--format",
        "csv",
        "--axis",
        axis,
        "--map",
        "run=run,direction=direction,target=target,error=error",
        "--error-sign",
        "indicated-minus-reference",
        "--out",
        crate::util::s(out),
    ])
}

/// The nine targets of a revolution every 45°, 0 and 360 both.
pub(crate) fn every_45() -> Vec<f64> {
    (0..=8).map(|k| f64::from(k) * 45.0).collect()
}
