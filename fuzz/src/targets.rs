//! The fuzz targets: one function per reader, bytes in, and a panic for every broken
//! promise. Shared by the AFL++ binary (`fuzz/src/bin/afl.rs`), the corpus replayer
//! (`fuzz/src/bin/replay.rs`) and the workspace's own test `tests/it/robust_io.rs`
//! (included there by path), so that a crash found by the fuzzer replays in
//! `cargo test` unchanged.
//!
//! What a target promises besides "no panic":
//! - every reader either refuses the bytes with an error or returns values that are all
//!   finite (the readers refuse NaN, inf and out-of-range cells at the door);
//! - the decoder gives the same rows whatever chunks the bytes arrive in (live capture
//!   and replay agree), and every row it gives is finite.
//!
//! The table and TOML readers take a path, so a target writes the bytes to a file of its
//! own (per process and target, in the temporary directory) and reads that.

use std::path::PathBuf;

#[path = "decoder.rs"]
mod decoder;

use decoder::session_row_finite;

/// A fuzz target: its name (the corpus folder `fuzz/corpus/NAME/`) and the file
/// extension its bytes are written with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// The wire-protocol session decoder (a raw capture).
    Decoder,
    /// An error table (CSV), read and checked for a grid.
    ErrorTable,
    /// A session table (CSV), read and reduced to an error table.
    SessionTable,
    /// A simulator machine model (TOML).
    MachineModel,
    /// A simulator test plan (TOML), read and expanded to its targets.
    Plan,
    /// A volumetric machine model (TOML).
    VolModel,
    /// A volumetric plan (TOML).
    VolPlan,
    /// A volumetric line table (CSV), read both with and without the error column.
    LineTable,
}

impl Target {
    pub const ALL: [Target; 8] = [
        Target::Decoder,
        Target::ErrorTable,
        Target::SessionTable,
        Target::MachineModel,
        Target::Plan,
        Target::VolModel,
        Target::VolPlan,
        Target::LineTable,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::Decoder => "decoder",
            Target::ErrorTable => "error_table",
            Target::SessionTable => "session_table",
            Target::MachineModel => "machine_model",
            Target::Plan => "plan",
            Target::VolModel => "vol_model",
            Target::VolPlan => "vol_plan",
            Target::LineTable => "line_table",
        }
    }

    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    fn extension(self) -> &'static str {
        match self {
            Target::Decoder => "bin",
            Target::ErrorTable | Target::SessionTable | Target::LineTable => "csv",
            Target::MachineModel | Target::Plan | Target::VolModel | Target::VolPlan => "toml",
        }
    }

    /// Runs the target on `data`; panics on a broken promise (see the module docs).
    /// Returns whether the reader accepted the bytes (the decoder: gave a row), which the
    /// corpus test uses to check that every seed reaches past the door.
    pub fn run(self, data: &[u8]) -> bool {
        match self {
            Target::Decoder => decoder::run(data),
            _ => {
                let path = self.scratch();
                if std::fs::write(&path, data).is_err() {
                    return false; // a full temporary directory is not a finding
                }
                let accepted = self.read(&path);
                let _ = std::fs::remove_file(&path);
                accepted
            }
        }
    }

    /// A file of this process and thread to write the bytes to for `self` (the
    /// workspace's test runs targets on several threads at once).
    fn scratch(self) -> PathBuf {
        let thread = format!("{:?}", std::thread::current().id());
        let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
        std::env::temp_dir().join(format!(
            "errmap-fuzz-{}-{thread}-{}.{}",
            std::process::id(),
            self.name(),
            self.extension()
        ))
    }

    fn read(self, path: &std::path::Path) -> bool {
        match self {
            Target::Decoder => unreachable!("the decoder reads bytes"),
            Target::ErrorTable => {
                if let Ok(t) = errmap::table::ErrorTable::read_points(path) {
                    for p in &t.points {
                        finite("query points", &[p.x_mm, p.y_mm, p.z_mm]);
                    }
                }
                let Ok(t) = errmap::table::ErrorTable::read(path) else {
                    return false;
                };
                for p in &t.points {
                    finite("error table", &[p.x_mm, p.y_mm, p.z_mm, p.e_um]);
                }
                let _ = t.grid();
                true
            }
            Target::SessionTable => {
                let Ok(rows) = errmap::session::read_session(path) else {
                    return false;
                };
                rows.iter().for_each(session_row_finite);
                if let Ok((t, _)) = errmap::session::error_table("fuzz", &rows) {
                    for p in &t.points {
                        finite("reduced table", &[p.x_mm, p.y_mm, p.z_mm, p.e_um]);
                    }
                }
                true
            }
            Target::MachineModel => errmap::sim::MachineModel::read(path).is_ok(),
            Target::Plan => errmap::sim::PlanSpec::read(path).is_ok_and(|s| s.plan(path).is_ok()),
            Target::VolModel => errmap::volumetric::Machine::read(path).is_ok(),
            Target::VolPlan => {
                let Ok(plan) = errmap::volumetric::PlanFile::read(path) else {
                    return false;
                };
                // Issue 28: `targets = 100000` was accepted, 4.3 M readings made.
                let readings: u64 = plan
                    .lines
                    .iter()
                    .map(|l| l.targets as u64 * u64::from(l.runs))
                    .sum();
                assert!(
                    readings <= errmap::volumetric::simulate::MAX_READINGS,
                    "a plan of {readings} readings accepted"
                );
                true
            }
            Target::LineTable => {
                let mut accepted = false;
                for require_e in [true, false] {
                    let Ok(t) = errmap::volumetric::LineTable::read(path, require_e) else {
                        continue;
                    };
                    accepted = true;
                    for l in &t.lines {
                        finite("line direction", &l.u);
                        finite("line probe", &l.probe_mm);
                        for p in &l.targets {
                            finite("line target", &p.pos_mm);
                            finite("line error", &p.e_um.into_iter().collect::<Vec<_>>());
                        }
                    }
                }
                accepted
            }
        }
    }
}

use decoder::finite;
