//! The house rule of `src/` (see `CONTRIBUTING.md`): stages are folders, imports run one
//! way, no source file is over 1 000 lines before its unit tests, and there are at most
//! four integration-test binaries. Read from the source text, like a reviewer would.

use crate::util::root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// What each top-level module of the library may import (`crate::…`), from the leaves
/// up. The list is a DAG, so obeying it means no cycle between top-level modules.
const ALLOWED: &[(&str, &[&str])] = &[
    ("base", &[]),
    ("plot", &[]),
    ("table", &["base"]),
    ("interp", &["table", "base"]),
    ("evaluate", &["interp", "table", "base"]),
    ("export", &["interp", "table", "base"]),
    ("session", &["table", "base"]),
    ("acquire", &["session", "table", "base"]),
    ("diagnose", &["base"]),
    ("sim", &["interp", "table", "session", "diagnose", "base"]),
    (
        "volumetric",
        &["interp", "table", "session", "diagnose", "sim", "base"],
    ),
    (
        "controller",
        &[
            "export",
            "volumetric",
            "sim",
            "session",
            "interp",
            "table",
            "base",
        ],
    ),
    ("import", &["controller", "session", "table", "base"]),
    ("history", &["table", "session", "volumetric", "base"]),
    (
        "acceptance",
        &["base", "table", "interp", "session", "volumetric"],
    ),
    ("circular", &["table", "volumetric", "base"]),
    ("artefact", &["volumetric", "base"]),
    (
        "report",
        &[
            "history",
            "acceptance",
            "artefact",
            "circular",
            "base",
            "plot",
            "table",
            "interp",
            "evaluate",
            "export",
            "controller",
            "session",
            "acquire",
            "diagnose",
            "sim",
            "volumetric",
            "import",
        ],
    ),
    (
        "bench",
        &[
            "history",
            "base",
            "table",
            "interp",
            "evaluate",
            "export",
            "controller",
            "session",
            "acquire",
            "diagnose",
            "sim",
            "volumetric",
        ],
    ),
];

const MAX_LINES: usize = 1000;
const MAX_TEST_BINARIES: usize = 4;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The text before the file's unit tests (`#[cfg(test)]` on a line of its own).
fn before_unit_tests(text: &str) -> Vec<&str> {
    text.lines()
        .take_while(|l| l.trim() != "#[cfg(test)]")
        .collect()
}

/// The top-level module a file of `src/` belongs to (`None` for lib.rs and main.rs).
fn top_module(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).expect("under src");
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

/// Every `crate::name` a line mentions, including the names in `use crate::{a, b::c}`.
fn crate_refs(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut rest = line;
    while let Some(i) = rest.find("crate::") {
        let after = &rest[i + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let name = ident(part.trim());
                if !name.is_empty() {
                    out.push(name);
                }
            }
        } else {
            let name = ident(after);
            if !name.is_empty() {
                out.push(name);
            }
        }
        rest = after;
    }
    out
}

#[test]
fn imports_run_one_way_and_files_stay_small() {
    let src = root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let allowed: BTreeMap<&str, BTreeSet<&str>> = ALLOWED
        .iter()
        .map(|(m, deps)| (*m, deps.iter().copied().collect()))
        .collect();
    let modules: BTreeSet<String> = files.iter().filter_map(|f| top_module(&src, f)).collect();
    let mut problems = Vec::new();
    for m in &modules {
        if m != "cli" && !allowed.contains_key(m.as_str()) {
            problems.push(format!(
                "src/{m}: a top-level module the rule does not know; add it to ALLOWED here and \
                 to the table in CONTRIBUTING.md"
            ));
        }
    }
    for file in &files {
        let text = std::fs::read_to_string(file).expect("source is UTF-8");
        let lines = before_unit_tests(&text);
        let shown = file
            .strip_prefix(root())
            .unwrap_or(file)
            .display()
            .to_string();
        if lines.len() > MAX_LINES {
            problems.push(format!(
                "{shown}: {} lines before the unit tests (at most {MAX_LINES}): split it along a seam",
                lines.len()
            ));
        }
        let Some(me) = top_module(&src, file) else {
            continue;
        };
        if me == "cli" {
            // The binary's own modules may use the whole library; the library cannot
            // name them at all (they are not part of it).
            continue;
        }
        let Some(ok) = allowed.get(me.as_str()) else {
            continue;
        };
        for (n, line) in lines.iter().enumerate() {
            let mut targets = crate_refs(line);
            targets.dedup();
            for target in targets {
                if target == me || !modules.contains(&target) {
                    continue;
                }
                if !ok.contains(target.as_str()) {
                    problems.push(format!(
                        "{shown}:{}: `{me}` imports `{target}`, which the rule does not allow \
                         (`{me}` may import: {})",
                        n + 1,
                        ok.iter().copied().collect::<Vec<_>>().join(", ")
                    ));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_allowed_imports_have_no_cycle() {
    // Depth-first search over ALLOWED: a back edge is a cycle.
    fn visit<'a>(
        m: &'a str,
        graph: &BTreeMap<&'a str, &'a [&'a str]>,
        state: &mut BTreeMap<&'a str, u8>,
        path: &mut Vec<&'a str>,
    ) {
        match state.get(m) {
            Some(2) => return,
            Some(1) => panic!("cycle in ALLOWED: {} -> {m}", path.join(" -> ")),
            _ => {}
        }
        state.insert(m, 1);
        path.push(m);
        for d in graph.get(m).copied().unwrap_or(&[]) {
            visit(d, graph, state, path);
        }
        path.pop();
        state.insert(m, 2);
    }
    let graph: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
    let mut state = BTreeMap::new();
    for m in graph.keys() {
        visit(m, &graph, &mut state, &mut Vec::new());
    }
}

#[test]
fn few_integration_test_binaries() {
    let cargo = std::fs::read_to_string(root().join("Cargo.toml")).expect("Cargo.toml");
    assert!(
        cargo.contains("autotests = false"),
        "Cargo.toml: set `autotests = false` and list the test binaries as [[test]]"
    );
    let n = cargo.lines().filter(|l| l.trim() == "[[test]]").count();
    assert!(
        (1..=MAX_TEST_BINARIES).contains(&n),
        "Cargo.toml declares {n} test binaries (at most {MAX_TEST_BINARIES}: each links polars)"
    );
}

#[test]
fn the_checker_sees_imports() {
    assert_eq!(crate_refs("use crate::table::{Axis, Grid};"), ["table"]);
    assert_eq!(
        crate_refs("use crate::{interp::Method, table, report::x};"),
        ["interp", "table", "report"]
    );
    assert_eq!(
        crate_refs("let g = crate::interp::Gp::fit(crate::table::x);"),
        ["interp", "table"]
    );
    assert!(crate_refs("use super::x; // no crate path").is_empty());
}
