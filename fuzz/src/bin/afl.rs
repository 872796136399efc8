//! The AFL++ entry point: `afl TARGET`, reading AFL's inputs in persistent mode.

#[path = "../targets.rs"]
mod targets;

fn main() {
    let name = std::env::args().nth(1).unwrap_or_default();
    let Some(target) = targets::Target::from_name(&name) else {
        eprintln!("usage: afl TARGET (one of: {})", names());
        std::process::exit(2);
    };
    afl::fuzz!(|data: &[u8]| {
        target.run(data);
    });
}

fn names() -> String {
    targets::Target::ALL.map(|t| t.name()).join(", ")
}
