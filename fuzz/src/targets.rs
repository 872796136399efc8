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
pub(super) enum Target {
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
    /// A positioning test for `errmap import` (API XD `.pos`, Renishaw `.rtl`, and as a
    /// CSV through a fixed column map), read from bytes.
    ImportSession,
    /// A controller table, read from bytes as every dialect's table
    /// ([`controller_formats`]); a zero residual must give the bytes back.
    ControllerTable,
}

impl Target {
    pub(super) const ALL: [Target; 10] = [
        Target::Decoder,
        Target::ErrorTable,
        Target::SessionTable,
        Target::MachineModel,
        Target::Plan,
        Target::VolModel,
        Target::VolPlan,
        Target::LineTable,
        Target::ImportSession,
        Target::ControllerTable,
    ];

    pub(super) fn name(self) -> &'static str {
        match self {
            Target::Decoder => "decoder",
            Target::ErrorTable => "error_table",
            Target::SessionTable => "session_table",
            Target::MachineModel => "machine_model",
            Target::Plan => "plan",
            Target::VolModel => "vol_model",
            Target::VolPlan => "vol_plan",
            Target::LineTable => "line_table",
            Target::ImportSession => "import_session",
            Target::ControllerTable => "controller_table",
        }
    }

    pub(super) fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    fn extension(self) -> &'static str {
        match self {
            Target::Decoder | Target::ImportSession | Target::ControllerTable => "bin",
            Target::ErrorTable | Target::SessionTable | Target::LineTable => "csv",
            Target::MachineModel | Target::Plan | Target::VolModel | Target::VolPlan => "toml",
        }
    }

    /// Runs the target on `data`; panics on a broken promise (see the module docs).
    /// Returns whether the reader accepted the bytes (the decoder: gave a row), which the
    /// corpus test uses to check that every seed reaches past the door.
    pub(super) fn run(self, data: &[u8]) -> bool {
        match self {
            Target::Decoder => decoder::run(data),
            Target::ImportSession => import_session(data),
            Target::ControllerTable => controller_table(data),
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
            Target::Decoder | Target::ImportSession | Target::ControllerTable => {
                unreachable!("these targets read bytes")
            }
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
                    readings <= errmap::volumetric::MAX_READINGS,
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

/// `errmap import` of a positioning test: every row it gives is finite.
fn import_session(data: &[u8]) -> bool {
    use errmap::import::{self, CsvOptions, ImportOptions, SessionFormat};
    let path = std::path::Path::new("fuzz.in");
    let map = import::ColumnMap::parse("target=#1,reference=#2,direction=#3").ok();
    let mut formats = vec![
        SessionFormat::Auto,
        SessionFormat::ApiXd,
        SessionFormat::RenishawRtl,
    ];
    if let Some(map) = map {
        for (delimiter, decimal_comma) in [(',', false), (';', true)] {
            formats.push(SessionFormat::Csv(Box::new(CsvOptions {
                map: map.clone(),
                delimiter,
                decimal_comma,
                length: import::LengthUnit::Inch,
                temperature: import::TempUnit::F,
                pressure: import::PressureUnit::InHg,
                error_units: import::ErrorUnit::Um,
                error_sign: None,
            })));
        }
    }
    let mut accepted = false;
    for format in formats {
        let options = ImportOptions { format, axis: None };
        if let Ok(got) = import::import_session(path, data, &options) {
            accepted = true;
            assert_eq!(got.rows.len(), got.summary.rows, "summary counts the rows");
            got.rows.iter().for_each(session_row_finite);
        }
    }
    accepted
}

/// Every table format of every dialect in the registry (`errmap::controller::DIALECTS`),
/// each with every setting the file does not state (its length unit, LinuxCNC's type),
/// so that a new dialect is fuzzed with no edit here.
pub(super) fn controller_formats() -> Vec<errmap::controller::TableFormat> {
    use errmap::controller::{CompType, DIALECTS, LengthUnit, TableSettings};
    let mut formats = Vec::new();
    for d in DIALECTS {
        for units in [LengthUnit::Mm, LengthUnit::Inch] {
            for comp_type in [CompType::ActualPosition, CompType::Trim] {
                let settings = TableSettings {
                    units: Some(units),
                    comp_type: Some(comp_type),
                    ..TableSettings::new(errmap::base::Axis::X)
                };
                if let Ok(f) = d.table_format(&settings)
                    && !formats.contains(&f)
                {
                    formats.push(f);
                }
            }
        }
    }
    formats
}

/// A controller table read back: finite errors, and a zero residual gives the bytes back.
fn controller_table(data: &[u8]) -> bool {
    let formats = controller_formats();
    let mut accepted = false;
    for f in formats {
        let Ok(t) = errmap::controller::read(data, f) else {
            continue;
        };
        accepted = true;
        for p in &t.points {
            finite("table point", &[p.position_mm, p.e_up_um, p.e_down_um]);
        }
        let axis = t.axis.unwrap_or(errmap::base::Axis::X);
        let zero = errmap::controller::Residual {
            axis,
            positions_mm: t.points.iter().map(|p| p.position_mm).collect(),
            up_um: vec![0.0; t.points.len()],
            down_um: vec![0.0; t.points.len()],
        };
        let u = errmap::controller::update_table(&t, &zero, false)
            .expect("a zero residual updates any table it read");
        assert!(u.bytes == data, "a zero residual changed the file");
        // A residual of 1 µm over the table: the update is written and reads back.
        let one = errmap::controller::Residual {
            up_um: vec![1.0; t.points.len()],
            down_um: vec![-1.0; t.points.len()],
            ..zero
        };
        for bidirectional in [false, true] {
            if let Ok(u) = errmap::controller::update_table(&t, &one, bidirectional) {
                let _ = errmap::controller::read(&u.bytes, f);
            }
        }
    }
    accepted
}
