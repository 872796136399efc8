//! The `errmap` binary; everything it does is in [`cli`].

/// `eprintln!` for the whole binary (it shadows std's in every module below): the same
/// text, but a closed or failing stderr is ignored where std's panics (exit 101; issue
/// 28: `errmap table … 2>&1 | true`). What goes to stderr is for a person; when nobody
/// reads it, the command still does its work and ends with its usual status.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `eprint!` likewise.
macro_rules! eprint {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($arg)*);
    }};
}

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
