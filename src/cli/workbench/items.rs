//! The workspace: the items under `--dir`, found by content and extension as the commands
//! find them, and the one door to its files ([`Workspace::resolve`]): a relative path of
//! normal components only, which after following links still lies under the workspace.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use serde::Serialize;

/// What an item is (the page that shows it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Kind {
    /// A capture directory or a session table.
    Session,
    /// An error table (`x_mm,y_mm,z_mm,e_um`).
    ErrorTable,
    /// Laser line measurements of a volumetric campaign.
    VolumetricLines,
    /// A volumetric model (`volumetric identify --out`).
    VolumetricModel,
    /// A ballbar trace with its TOML beside it.
    CircularTrace,
    /// An ISO 10360-2 length test.
    Iso10360Test,
    /// A laser export (`.pos`, `.rtl`) for `errmap import`.
    ImportedFile,
}

impl Kind {
    /// The words the workspace page shows.
    pub(crate) fn label(self) -> &'static str {
        match self {
            Kind::Session => "session",
            Kind::ErrorTable => "error table",
            Kind::VolumetricLines => "volumetric lines",
            Kind::VolumetricModel => "volumetric model",
            Kind::CircularTrace => "circular trace",
            Kind::Iso10360Test => "ISO 10360 test",
            Kind::ImportedFile => "imported file",
        }
    }

    /// The page that shows it (`/{page}/{id}`), where there is one.
    pub(crate) fn page(self) -> Option<&'static str> {
        match self {
            Kind::Session => Some("session"),
            Kind::ErrorTable => Some("table"),
            Kind::VolumetricLines | Kind::VolumetricModel => Some("volumetric"),
            Kind::CircularTrace => Some("circular"),
            Kind::Iso10360Test => Some("acceptance"),
            Kind::ImportedFile => None,
        }
    }
}

/// One item of the workspace (a row of `GET /api/items`).
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Item {
    /// The path relative to the workspace, `/`-separated: the item's name in URLs.
    pub id: String,
    pub kind: Kind,
    pub name: String,
    pub path: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    /// `YYYY-MM-DDTHH:MM:SSZ`.
    pub modified: String,
    pub size: u64,
    /// Why the item could not be read, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// A path the workspace refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum WorkspaceError {
    /// Not a plain relative path (`..`, absolute, a backslash, a NUL, an encoded separator).
    #[error("`{0}` is not a path inside the workspace")]
    Bad(String),
    /// Nothing there, or it leads out of the workspace.
    #[error("`{0}`: no such item in the workspace")]
    NotFound(String),
}

/// The workspace directory.
#[derive(Debug, Clone)]
pub(crate) struct Workspace {
    root: PathBuf,
}

/// The most entries a scan looks at, and how deep: a workspace is a folder of results.
const MAX_ENTRIES: usize = 20_000;
const MAX_DEPTH: usize = 8;

impl Workspace {
    /// The workspace at `dir` (made absolute, links resolved).
    pub(crate) fn new(dir: &Path) -> std::io::Result<Workspace> {
        Ok(Workspace {
            root: dir.canonicalize()?,
        })
    }

    pub(crate) fn root(&self) -> &Path {
        &self.root
    }

    /// The file or directory `rel` names: normal components only, and after following
    /// links still inside the workspace.
    pub(crate) fn resolve(&self, rel: &str) -> Result<PathBuf, WorkspaceError> {
        let bad = || WorkspaceError::Bad(rel.to_string());
        if rel.is_empty() || rel.contains(['\\', '\0']) || rel.contains('%') {
            return Err(bad());
        }
        let p = Path::new(rel);
        if !p.components().all(|c| matches!(c, Component::Normal(_))) {
            return Err(bad());
        }
        let found = self
            .root
            .join(p)
            .canonicalize()
            .map_err(|_| WorkspaceError::NotFound(rel.to_string()))?;
        if !found.starts_with(&self.root) {
            return Err(WorkspaceError::NotFound(rel.to_string()));
        }
        Ok(found)
    }

    /// The relative id of a path under the workspace.
    pub(crate) fn id_of(&self, p: &Path) -> String {
        p.strip_prefix(&self.root)
            .unwrap_or(p)
            .components()
            .map(|c| c.as_os_str().to_string_lossy())
            .collect::<Vec<_>>()
            .join("/")
    }

    /// Every item, in path order. Hidden entries (`.name`) and links leading out are left
    /// out; a capture directory is one item (its raw file, table and JSON are its parts).
    pub(crate) fn items(&self) -> Vec<Item> {
        let mut out = Vec::new();
        let mut seen = 0usize;
        self.walk(&self.root, 0, &mut seen, &mut out);
        out.sort_by(|a, b| a.id.cmp(&b.id));
        out
    }

    fn walk(&self, dir: &Path, depth: usize, seen: &mut usize, out: &mut Vec<Item>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        let mut entries: Vec<_> = entries.flatten().map(|e| e.path()).collect();
        entries.sort();
        let capture = capture_table(dir);
        if let Some(table) = &capture
            && dir != self.root
        {
            out.push(self.item(dir, Kind::Session, Some(table)));
        }
        for p in entries {
            *seen += 1;
            if *seen > MAX_ENTRIES {
                return;
            }
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            if name.as_deref().is_none_or(|n| n.starts_with('.')) {
                continue;
            }
            let Ok(real) = p.canonicalize() else {
                continue;
            };
            if !real.starts_with(&self.root) {
                continue;
            }
            if real.is_dir() {
                if depth < MAX_DEPTH {
                    self.walk(&p, depth + 1, seen, out);
                }
                continue;
            }
            if capture.is_some()
                && matches!(
                    name.as_deref(),
                    Some("session.csv" | "session.parquet" | "session.json" | "raw.bin")
                )
            {
                continue;
            }
            if let Some((kind, error)) = kind_of(&p) {
                let mut item = self.item(&p, kind, None);
                item.error = error;
                out.push(item);
            }
        }
    }

    fn item(&self, p: &Path, kind: Kind, table: Option<&Path>) -> Item {
        let meta = std::fs::metadata(table.unwrap_or(p)).ok();
        let modified = meta
            .as_ref()
            .and_then(|m| m.modified().ok())
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or_else(String::new, |d| {
                errmap::history::format_utc(i64::try_from(d.as_secs()).unwrap_or(0))
            });
        let id = self.id_of(p);
        let axis = match kind {
            Kind::Session => session_axis(table.unwrap_or(p)),
            _ => None,
        };
        Item {
            name: p
                .file_name()
                .map_or_else(|| id.clone(), |n| n.to_string_lossy().into_owned()),
            path: id.clone(),
            id,
            kind,
            machine: None,
            axis,
            modified,
            size: meta.map_or(0, |m| m.len()),
            error: None,
        }
    }
}

/// The session table of a capture directory (`session.json` and a table beside it).
pub(crate) fn capture_table(dir: &Path) -> Option<PathBuf> {
    if !dir.join("session.json").is_file() {
        return None;
    }
    ["session.parquet", "session.csv"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
}

/// The kind of a file by extension and content; `None` for what the workbench does not
/// show. A file that cannot be read is listed with its error.
fn kind_of(p: &Path) -> Option<(Kind, Option<String>)> {
    let ext = p.extension()?.to_string_lossy().to_ascii_lowercase();
    match ext.as_str() {
        "pos" | "rtl" => Some((Kind::ImportedFile, None)),
        "csv" => match head(p, 4096) {
            Ok(text) => {
                let first = text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .trim_start_matches('\u{feff}');
                let cols: Vec<&str> = first.split(',').map(str::trim).collect();
                kind_of_columns(p, &cols).map(|k| (k, None))
            }
            Err(e) => Some((Kind::ErrorTable, Some(e.to_string()))),
        },
        "parquet" => match parquet_columns(p) {
            Ok(cols) => {
                let cols: Vec<&str> = cols.iter().map(String::as_str).collect();
                kind_of_columns(p, &cols).map(|k| (k, None))
            }
            Err(e) => Some((Kind::Session, Some(e.to_string()))),
        },
        "json" => {
            let text = head(p, 1 << 16).ok()?;
            let model = text.contains("\"components\"") && text.contains("\"topology\"");
            model.then_some((Kind::VolumetricModel, None))
        }
        _ => None,
    }
}

fn kind_of_columns(p: &Path, cols: &[&str]) -> Option<Kind> {
    let has = |c: &str| cols.contains(&c);
    let error = has("error_um") || has("error_arcsec");
    if has("laser_mm") || (has("run") && has("target") && error) {
        Some(Kind::Session)
    } else if has("line") && has("ux") && has("e_um") {
        Some(Kind::VolumetricLines)
    } else if has("angle_deg") && has("dr_um") {
        p.with_extension("toml")
            .is_file()
            .then_some(Kind::CircularTrace)
    } else if has("nominal_mm") && has("measured_mm") {
        Some(Kind::Iso10360Test)
    } else if has("x_mm") && has("y_mm") && has("z_mm") && has("e_um") {
        Some(Kind::ErrorTable)
    } else {
        None
    }
}

/// Why a file's kind could not be told (the item is listed with it).
#[derive(Debug, thiserror::Error)]
pub(crate) enum ScanError {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Parquet(#[from] polars::prelude::PolarsError),
}

/// The first `n` bytes of a file as text.
fn head(p: &Path, n: u64) -> Result<String, ScanError> {
    let f = std::fs::File::open(p)?;
    let mut buf = Vec::new();
    f.take(n).read_to_end(&mut buf)?;
    Ok(String::from_utf8_lossy(&buf).into_owned())
}

/// The column names of a Parquet file (its footer only).
fn parquet_columns(p: &Path) -> Result<Vec<String>, ScanError> {
    use polars::prelude::{ParquetReader, SerReader};
    let f = std::fs::File::open(p)?;
    let schema = ParquetReader::new(f).schema()?;
    Ok(schema.iter_names().map(|n| n.to_string()).collect())
}

/// The axis of a session table: the `axis` column of its first data row (CSV), if any.
fn session_axis(table: &Path) -> Option<String> {
    if table.extension()?.to_str()? != "csv" {
        return None;
    }
    let text = head(table, 4096).ok()?;
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next()?.split(',').collect();
    let k = cols.iter().position(|c| *c == "axis")?;
    let v = lines.next()?.split(',').nth(k)?.trim().to_string();
    (!v.is_empty()).then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_plain_paths_inside_resolve() {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::create_dir(dir.path().join("a")).expect("mkdir");
        std::fs::write(dir.path().join("a/t.csv"), "x_mm,y_mm,z_mm,e_um\n").expect("write");
        let outside = tempfile::tempdir().expect("tempdir");
        std::fs::write(outside.path().join("secret.csv"), "x").expect("write");
        #[cfg(unix)]
        std::os::unix::fs::symlink(
            outside.path().join("secret.csv"),
            dir.path().join("a/link.csv"),
        )
        .expect("symlink");
        let ws = Workspace::new(dir.path()).expect("workspace");
        assert!(ws.resolve("a/t.csv").is_ok());
        for bad in [
            "../x",
            "a/../a/t.csv",
            "/etc/passwd",
            "a\\t.csv",
            "a/%2e%2e/x",
            "",
            "./a",
        ] {
            assert!(
                matches!(ws.resolve(bad), Err(WorkspaceError::Bad(_))),
                "{bad} was accepted"
            );
        }
        #[cfg(unix)]
        assert_eq!(
            ws.resolve("a/link.csv"),
            Err(WorkspaceError::NotFound("a/link.csv".into()))
        );
        assert_eq!(
            ws.resolve("a/none.csv"),
            Err(WorkspaceError::NotFound("a/none.csv".into()))
        );
        let items = ws.items();
        assert_eq!(items.len(), 1, "{items:?}");
        assert_eq!(
            (items[0].id.as_str(), items[0].kind),
            ("a/t.csv", Kind::ErrorTable)
        );
    }
}
