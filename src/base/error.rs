//! The one shape of a file error and of a configuration error, shared by every stage
//! (issue 22): [`FileError`] when the operating system refused a named file, and
//! [`ConfigError`] when the file was read but something in it is wrong, with a
//! [`Location`] saying where (a key, a parser position, a table row, or the whole file).
//!
//! A stage error wraps them (`File(#[from] FileError)`, `Config(#[from] ConfigError)`)
//! instead of re-declaring `Io { path, source }` or `Config { path, key, message }`, so an
//! error crosses from one stage to another as data: the key of a range error found by the
//! simulator's checker reaches a volumetric model's caller as `Location::Key`, never by
//! cutting up a message. [`io_err`] builds the file error, [`read_toml`] reads a TOML file
//! whole and runs a stage's number check over it.
//!
//! The texts are those the stages printed before they shared this module (the
//! robustness campaign and the tests compare them).

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

/// What errmap was doing with the file when the operating system refused, as the message
/// says it. The operation is the caller's to name: a table writer knows it writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileOp {
    /// Any access; the message names no operation (`FILE: REASON`), the OS reason says
    /// enough (`No such file or directory`, `Permission denied`).
    Access,
    /// Reading (`FILE: cannot read: REASON`).
    Read,
    /// Writing or creating, a directory included (`FILE: cannot write: REASON`).
    Write,
}

impl FileOp {
    /// The words between the path and the OS reason, `: ` included.
    fn words(self) -> &'static str {
        match self {
            FileOp::Access => ": ",
            FileOp::Read => ": cannot read: ",
            FileOp::Write => ": cannot write: ",
        }
    }
}

/// The operating system refused an operation on a named file or directory.
#[derive(Debug, thiserror::Error)]
#[error("{}{}{source}", path.display(), op.words())]
pub struct FileError {
    /// The file or directory, as the user named it (or as errmap derived it).
    pub path: PathBuf,
    /// What errmap was doing.
    pub op: FileOp,
    /// The operating system's reason.
    #[source]
    pub source: io::Error,
}

/// A closure that turns an [`io::Error`] on `path` into a [`FileError`], for `map_err`:
/// `std::fs::read_to_string(path).map_err(io_err(path, FileOp::Read))?` (the `?` converts
/// into the stage's error through its `From<FileError>`).
pub fn io_err(path: &Path, op: FileOp) -> impl FnOnce(io::Error) -> FileError + '_ {
    move |source| FileError {
        path: path.to_path_buf(),
        op,
        source,
    }
}

/// Where in a file a [`ConfigError`] lies.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole (it does not parse, a value that belongs to no one key, a
    /// missing section): `FILE: MESSAGE`.
    File,
    /// A key of a TOML or JSON file, dotted and indexed as the file spells it
    /// (`components.E_BX.poly`, `line[3].targets`): `FILE: KEY: MESSAGE`.
    Key(String),
    /// A parser's position in a text file, both 1-based, the column in characters:
    /// `FILE: line L: column C: MESSAGE`.
    Position { line: usize, column: usize },
    /// A data row of a table (1-based, the header not counted), its line in the file, and
    /// the column when one cell is at fault: ``FILE: row R (line L), column `C`: MESSAGE``.
    Row {
        row: usize,
        line: usize,
        column: Option<String>,
    },
}

impl fmt::Display for Location {
    /// The location as it stands between the path and the message, without the colons.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => Ok(()),
            Location::Key(key) => f.write_str(key),
            Location::Position { line, column } => write!(f, "line {line}: column {column}"),
            Location::Row { row, line, column } => {
                write!(f, "row {row} (line {line})")?;
                match column {
                    Some(c) => write!(f, ", column `{c}`"),
                    None => Ok(()),
                }
            }
        }
    }
}

/// A file that was read but holds something wrong: the file, where in it, and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {}{message}", path.display(), located(location))]
pub struct ConfigError {
    /// The file.
    pub path: PathBuf,
    /// Where in the file.
    pub location: Location,
    /// What is wrong, and if possible what would be right.
    pub message: String,
}

/// The location followed by `: `, or nothing for the whole file.
fn located(location: &Location) -> String {
    match location {
        Location::File => String::new(),
        other => format!("{other}: "),
    }
}

impl ConfigError {
    /// A problem of the whole file.
    pub fn file(path: &Path, message: impl Into<String>) -> ConfigError {
        ConfigError {
            path: path.to_path_buf(),
            location: Location::File,
            message: message.into(),
        }
    }

    /// A problem of one key.
    pub fn key(path: &Path, key: impl Into<String>, message: impl Into<String>) -> ConfigError {
        ConfigError {
            path: path.to_path_buf(),
            location: Location::Key(key.into()),
            message: message.into(),
        }
    }

    /// A problem at a parser's line and column.
    pub fn position(
        path: &Path,
        line: usize,
        column: usize,
        message: impl Into<String>,
    ) -> ConfigError {
        ConfigError {
            path: path.to_path_buf(),
            location: Location::Position { line, column },
            message: message.into(),
        }
    }

    /// A problem of a table's data row (`row` 1-based, `line` its line in the file),
    /// optionally of one of its cells.
    pub fn row(
        path: &Path,
        row: usize,
        line: usize,
        column: Option<&str>,
        message: impl Into<String>,
    ) -> ConfigError {
        ConfigError {
            path: path.to_path_buf(),
            location: Location::Row {
                row,
                line,
                column: column.map(str::to_string),
            },
            message: message.into(),
        }
    }

    /// The key at fault, if the location is a key.
    pub fn key_path(&self) -> Option<&str> {
        match &self.location {
            Location::Key(k) => Some(k),
            _ => None,
        }
    }
}

/// Reads the TOML file at `path` into `T`: read once, parsed (unknown keys refused where
/// `T` says so), then `check` run over the text (the simulator's physical ranges,
/// `sim::check_numbers`, for machine models and plans), so that a value
/// serde would take, such as `nan` or `1e308`, is refused with its key.
///
/// This is the one function in `base` that touches the file system: the errors it
/// returns are this module's, and the checker is the caller's, so it imports no stage.
pub fn read_toml<T, E>(
    path: &Path,
    check: fn(&Path, &str) -> Result<(), ConfigError>,
) -> Result<T, E>
where
    T: serde::de::DeserializeOwned,
    E: From<FileError> + From<ConfigError>,
{
    let text = std::fs::read_to_string(path).map_err(io_err(path, FileOp::Access))?;
    let value = toml::from_str(&text).map_err(|e| parse_error(path, &e))?;
    check(path, &text)?;
    Ok(value)
}

/// toml's own message of a file that does not parse: its line, column, the line quoted
/// and the key (several lines; the trailing newline left out).
pub fn parse_error(path: &Path, e: &toml::de::Error) -> ConfigError {
    ConfigError::file(path, e.to_string().trim_end())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("m.toml")
    }

    #[test]
    fn file_errors_say_what_was_done() {
        let e = |op| io_err(p(), op)(io::Error::from(io::ErrorKind::NotFound)).to_string();
        let reason = io::Error::from(io::ErrorKind::NotFound).to_string();
        assert_eq!(e(FileOp::Access), format!("m.toml: {reason}"));
        assert_eq!(e(FileOp::Read), format!("m.toml: cannot read: {reason}"));
        assert_eq!(e(FileOp::Write), format!("m.toml: cannot write: {reason}"));
    }

    #[test]
    fn every_location_has_its_text() {
        assert_eq!(ConfigError::file(p(), "empty").to_string(), "m.toml: empty");
        assert_eq!(
            ConfigError::key(p(), "components.E_BX.poly", "is not a list").to_string(),
            "m.toml: components.E_BX.poly: is not a list"
        );
        assert_eq!(
            ConfigError::position(p(), 3, 7, "expected `=`").to_string(),
            "m.toml: line 3: column 7: expected `=`"
        );
        assert_eq!(
            ConfigError::row(p(), 4, 5, Some("e_um"), "must be finite").to_string(),
            "m.toml: row 4 (line 5), column `e_um`: must be finite"
        );
        assert_eq!(
            ConfigError::row(p(), 4, 5, None, "too few cells").to_string(),
            "m.toml: row 4 (line 5): too few cells"
        );
    }

    /// Issue 22: a range error of a volumetric model reached its caller by cutting the
    /// simulator's message at `": "`; the key now travels as the location.
    #[test]
    fn a_range_error_of_a_volumetric_model_carries_its_key() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("model.toml");
        let text = "topology = \"YXZ\"\n[components]\nE_XX = { poly = [1.0, 1e308] }\n";
        std::fs::write(&path, text).expect("write");
        match crate::volumetric::Machine::read(&path) {
            Err(crate::volumetric::VolumetricError::Config(ConfigError {
                path: at,
                location: Location::Key(key),
                message,
            })) => {
                assert_eq!(at, path);
                assert_eq!(key, "components.E_XX.poly[1]");
                assert!(message.contains("1e308"), "{message}");
            }
            other => panic!("expected a key error, got {other:?}"),
        }
    }

    /// The simulator's reader of the same file shape names the same key.
    #[test]
    fn a_range_error_of_a_machine_model_carries_its_key() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("model.toml");
        std::fs::write(&path, "[scale_factor]\nppm = nan\n").expect("write");
        match crate::sim::MachineModel::read(&path) {
            Err(crate::sim::SimError::Config(e)) => {
                assert_eq!(e.key_path(), Some("scale_factor.ppm"));
            }
            other => panic!("expected a key error, got {other:?}"),
        }
    }

    #[test]
    fn a_file_that_does_not_parse_is_a_whole_file_error() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("model.toml");
        std::fs::write(&path, "topology = \n").expect("write");
        let e = crate::volumetric::Machine::read(&path).expect_err("no value");
        match &e {
            crate::volumetric::VolumetricError::Config(c) => {
                assert_eq!(c.location, Location::File);
                assert!(!c.message.ends_with('\n'), "{e}");
            }
            other => panic!("expected a config error, got {other:?}"),
        }
        let missing = dir.path().join("absent.toml");
        match crate::volumetric::Machine::read(&missing) {
            Err(crate::volumetric::VolumetricError::File(f)) => {
                assert_eq!(f.path, missing);
                assert_eq!(f.source.kind(), io::ErrorKind::NotFound);
            }
            other => panic!("expected a file error, got {other:?}"),
        }
    }

    #[test]
    fn a_key_is_data_not_text() {
        let e = ConfigError::key(p(), "a: b", "c");
        assert_eq!(e.key_path(), Some("a: b"));
        assert_eq!(ConfigError::file(p(), "a: b").key_path(), None);
    }
}
