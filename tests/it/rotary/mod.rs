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

/// [`import_rotary`] that must succeed: the session table `out` (CSV or Parquet by its
/// extension).
pub(crate) fn rotary_session(csv: &Path, out: PathBuf, axis: &str) -> PathBuf {
    let o = import_rotary(csv, &out, axis);
    assert!(o.status.success(), "{}", crate::util::stderr(&o));
    out
}

/// `errmap plan --axis AXIS` over the whole revolution (0 to 360°), with `extra` flags.
pub(crate) fn plan_revolution(axis: &str, extra: &[&str]) -> std::process::Output {
    let mut a = vec!["plan", "--axis", axis, "--from", "0", "--to", "360"];
    a.extend_from_slice(extra);
    crate::util::errmap(&a)
}

/// `errmap capture --simulate MODEL` (at 500× speed, no live view) into `out`.
pub(crate) fn simulate_capture(model: &Path, out: &Path) -> std::process::Output {
    crate::util::errmap(&[
        "capture",
        "--simulate",
        crate::util::s(model),
        "--speed",
        "500",
        "--out",
        crate::util::s(out),
        "--no-view",
    ])
}

/// The nine targets of a revolution every 45°, 0 and 360 both.
pub(crate) fn every_45() -> Vec<f64> {
    (0..=8).map(|k| f64::from(k) * 45.0).collect()
}
