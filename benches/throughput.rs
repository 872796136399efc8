//! `cargo bench`: the same measurements as `errmap bench` (interpolation points/s per
//! method and thread count on a 41³ grid with 10⁶ points, fit times on 21³, and the wire
//! decoder's MB/s), printed as a table.

fn main() {
    // `cargo bench -- --quick` for a short run.
    let quick = std::env::args().any(|a| a == "--quick");
    let config = errmap::bench::BenchConfig {
        points: if quick { 100_000 } else { 1_000_000 },
        repeats: if quick { 1 } else { 3 },
        ..Default::default()
    };
    print!("{}", errmap::bench::markdown(&errmap::bench::run(&config)));
}
