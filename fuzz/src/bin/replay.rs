//! `replay TARGET PATH…`: runs each file (or each file in each directory) through the
//! target, uninstrumented, and names the one that panics. For triage of a crash the
//! fuzzer saved (`fuzz/out/TARGET/default/crashes/`).

#[path = "../targets.rs"]
mod targets;

use std::path::PathBuf;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_default();
    let Some(target) = targets::Target::from_name(&name) else {
        let names = targets::Target::ALL.map(|t| t.name()).join(", ");
        eprintln!("usage: replay TARGET PATH… (TARGET one of: {names})");
        std::process::exit(2);
    };
    let mut files = Vec::new();
    for a in args {
        let p = PathBuf::from(a);
        match std::fs::read_dir(&p) {
            Ok(entries) => files.extend(entries.filter_map(|e| e.ok()).map(|e| e.path())),
            Err(_) => files.push(p),
        }
    }
    files.sort();
    for f in &files {
        let data = match std::fs::read(f) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{}: {e}", f.display());
                std::process::exit(1);
            }
        };
        eprint!("{}: ", f.display()); // named before a panic
        let accepted = target.run(&data);
        eprintln!("{}", if accepted { "accepted" } else { "refused" });
    }
    eprintln!("{} inputs, no panic", files.len());
}
