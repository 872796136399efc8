//! `errmap --help` is a user's command list: the developer commands are hidden (and still
//! run), the export line names every controller dialect `export --format` accepts, and no
//! help text uses an internal name.

use crate::util::errmap;

/// The developer commands: regenerating committed cases and reports, and long captures
/// for benchmarks. Scripts and tests call them; a user's list does not show them.
const DEVELOPER: [&str; 3] = ["gen-concealed", "report-concealed", "gen-capture"];

fn help(args: &[&str]) -> String {
    let o = errmap(args);
    assert!(o.status.success(), "errmap {args:?} exits 0");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The commands `errmap --help` lists, with each one's description (its wrapped lines
/// joined): the lines after `Commands:` indented by two spaces start an entry, deeper
/// indented ones continue it.
fn entries(text: &str) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    let mut lines = text.lines().skip_while(|l| l.trim() != "Commands:").skip(1);
    for line in lines.by_ref() {
        if line.trim().is_empty() {
            break;
        }
        let indent = line.len() - line.trim_start().len();
        if indent == 2 {
            let (name, about) = line.trim().split_once(' ').unwrap_or((line.trim(), ""));
            out.push((name.to_string(), about.trim().to_string()));
        } else if let Some(last) = out.last_mut() {
            last.1.push(' ');
            last.1.push_str(line.trim());
        }
    }
    out
}

/// The values of `--format` in `errmap export --help` (`- name: description` lines).
fn export_formats() -> Vec<String> {
    let text = help(&["export", "--help"]);
    let mut lines = text.lines().skip_while(|l| l.trim() != "--format <FORMAT>");
    let mut out = Vec::new();
    for line in lines.by_ref().skip(1) {
        let t = line.trim();
        if t.starts_with("--") {
            break;
        }
        if let Some((name, _)) = t.strip_prefix("- ").and_then(|r| r.split_once(':')) {
            out.push(name.trim().to_string());
        }
    }
    out
}

#[test]
fn help_lists_no_developer_command_and_they_still_run() {
    let text = help(&["--help"]);
    let listed: Vec<String> = entries(&text).into_iter().map(|(n, _)| n).collect();
    for must in [
        "demo", "fit", "compare", "capture", "table", "diagnose", "export",
    ] {
        assert!(
            listed.iter().any(|n| n == must),
            "{must} is listed: {listed:?}"
        );
    }
    for dev in DEVELOPER {
        assert!(!text.contains(dev), "--help does not list {dev}:\n{text}");
        assert!(
            help(&[dev, "--help"]).contains("Usage: errmap"),
            "{dev} still answers --help"
        );
    }
}

#[test]
fn the_export_line_names_every_dialect_export_writes() {
    // The controller's name each `--format` value writes, as a user knows it: the
    // registry's, and errmap's own two formats.
    let names = |format: &str| match format {
        "csv" => Some("CSV"),
        "grid" => Some("volumetric grid"),
        d => errmap::controller::dialect(d).map(|d| d.controller()),
    };
    let formats = export_formats();
    assert!(
        formats.len() >= 7,
        "export --help lists its formats: {formats:?}"
    );
    let about = entries(&help(&["--help"]))
        .into_iter()
        .find(|(n, _)| n == "export")
        .map(|(_, a)| a)
        .expect("export is listed");
    for f in &formats {
        let name = names(f).unwrap_or_else(|| panic!("a new export format {f}: name it here"));
        assert!(
            about.contains(name),
            "the export line names {name} ({f}): {about}"
        );
    }
}

#[test]
fn no_help_text_uses_an_internal_name() {
    let top = help(&["--help"]);
    let mut pages = vec![("errmap".to_string(), top.clone())];
    for (name, _) in entries(&top) {
        if name != "help" {
            pages.push((name.clone(), help(&[&name, "--help"])));
        }
    }
    for (name, _) in entries(&help(&["volumetric", "--help"])) {
        if name != "help" {
            pages.push((
                format!("volumetric {name}"),
                help(&["volumetric", &name, "--help"]),
            ));
        }
    }
    for (page, text) in pages {
        let lower = text.to_lowercase();
        for internal in ["seed 000", "seed 001", "seed-00", "errmap::", "shared/spec"] {
            assert!(
                !lower.contains(internal),
                "`{page} --help` says {internal:?}:\n{text}"
            );
        }
    }
}

/// The foot of `errmap --help` names every stage of the library, as `src/lib.rs` declares
/// them (`pub mod`), but the two shared leaves `base` and `plot`.
#[test]
fn help_names_every_stage() {
    let text = help(&["--help"]);
    let lib = std::fs::read_to_string(crate::util::root().join("src/lib.rs")).expect("lib.rs");
    let stages: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("pub mod ")?.strip_suffix(';'))
        .filter(|m| !["base", "plot"].contains(m))
        .collect();
    assert!(stages.len() >= 16, "{stages:?}");
    let foot: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("Stages of the pipeline"))
        .filter_map(|l| l.strip_prefix("  ")?.split_whitespace().next())
        .collect();
    for s in &stages {
        assert!(
            foot.contains(s),
            "errmap --help does not name the stage {s}: {text}"
        );
    }
}
