//! `errmap bench` and `cargo bench`: throughput of the interpolators, fit times, and the
//! wire decoder's speed, measured here on synthetic data (seeded).
//!
//! Interpolation: a 41×41×41 grid of random errors and 10⁶ random query points inside it,
//! each method at one thread and at all threads. Fit: a 21×21×21 table. Decoder: a
//! synthetic capture of simulated SAMPLE/MARK/ENV frames. Volumetric: `volumetric`. Timings are wall-clock medians
//! of at least 3 repetitions and 0.3 s per measurement; run a release build
//! (`cargo run --release -- bench`).

mod history;
mod volumetric;

pub use history::{HistoryBench, run as run_history};
pub use volumetric::{
    campaign as volumetric_campaign, config as volumetric_config,
    grid_points as volumetric_grid_points,
};

use crate::base::median;
use std::time::Instant;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::interp::{DEFAULT_FUZZY_SIGMA, Method, Order, predict_parallel};
use crate::table::Grid;

/// One interpolation result.
#[derive(Debug, Clone, Serialize)]
pub struct PointsResult {
    pub method: String,
    pub order: Option<[usize; 3]>,
    pub threads: usize,
    pub points_per_s: f64,
}

/// One fit-time result.
#[derive(Debug, Clone, Serialize)]
pub struct FitResult {
    pub method: String,
    pub order: Option<[usize; 3]>,
    pub grid: [usize; 3],
    pub seconds: f64,
}

/// Everything `bench --json` prints.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BenchReport {
    pub grid: [usize; 3],
    pub points: usize,
    pub results: Vec<PointsResult>,
    pub fit: Vec<FitResult>,
    /// Wire decoder alone (frames and statistics), MB/s, one core.
    pub decode_mb_s: f64,
    /// Decoder plus session rows, MB/s, one core.
    pub decode_rows_mb_s: f64,
    pub decode_bytes: usize,
    /// Extra measurements (name → seconds), e.g. the GP fit and the diagnosis.
    pub extra: Vec<(String, f64)>,
    /// Volumetric identification of a 60-line campaign and the 41³ vector map
    /// (`volumetric`).
    pub volumetric: Option<volumetric::VolumetricBench>,
    /// Replay and table on a generated long capture: MB/s and peak RSS (None: the
    /// measurement failed).
    pub stream: Option<crate::acquire::StreamBench>,
    /// The calibration ledger at plant scale, per backend (`history`; filled by the
    /// binary, which owns the ledger's location).
    pub history: Vec<history::HistoryBench>,
}

/// Bench settings.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    pub grid: usize,
    pub points: usize,
    pub fit_grid: usize,
    /// Threads for the parallel runs (0: all cores).
    pub threads: usize,
    pub repeats: usize,
}

impl Default for BenchConfig {
    fn default() -> Self {
        BenchConfig {
            grid: 41,
            points: 1_000_000,
            fit_grid: 21,
            threads: 0,
            repeats: 3,
        }
    }
}

/// Median wall-clock seconds of `f`, over at least `repeats` runs and at least
/// [`MIN_BENCH_S`] in total (a 15 ms run repeated a handful of times is at the mercy of
/// whatever else the machine does; twenty of them are not).
fn time<T>(repeats: usize, mut f: impl FnMut() -> T) -> f64 {
    let start = Instant::now();
    let mut runs = Vec::new();
    while runs.len() < repeats.max(1)
        || (start.elapsed().as_secs_f64() < MIN_BENCH_S && runs.len() < MAX_RUNS)
    {
        let t = Instant::now();
        std::hint::black_box(f());
        runs.push(t.elapsed().as_secs_f64());
    }
    median(&runs)
}

/// Size of the generated capture of the streaming benchmark, MB.
pub const STREAM_BENCH_MB: f64 = 10.0;

/// Least total time spent timing one measurement, s.
const MIN_BENCH_S: f64 = 0.3;
/// Most runs of one measurement.
const MAX_RUNS: usize = 200;

/// An n×n×n grid of 20 mm cells with random errors in [−5, 5] µm (seeded).
pub fn random_grid(n: usize, seed: u64) -> Grid {
    let nodes: Vec<f64> = (0..n).map(|i| i as f64 * 20.0).collect();
    let mut rng = StdRng::seed_from_u64(seed);
    Grid::from_fn(nodes.clone(), nodes.clone(), nodes, |_| {
        rng.random_range(-5.0..5.0)
    })
}

/// `n` random query points inside a grid's box (seeded).
pub fn random_points(grid: &Grid, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = StdRng::seed_from_u64(seed);
    let range = |a: usize| {
        let v = grid.axis(a);
        v[0]..v[v.len() - 1]
    };
    (0..n)
        .map(|_| [0, 1, 2].map(|a| rng.random_range(range(a))))
        .collect()
}

/// The methods benchmarked, at least those the contract names.
pub fn methods() -> Vec<Method> {
    vec![
        Method::Trilinear,
        Method::Spline,
        Method::Lagrange(Order([2, 2, 2])),
        Method::Lagrange(Order([4, 4, 4])),
        Method::Fuzzy {
            sigma: DEFAULT_FUZZY_SIGMA,
        },
    ]
}

/// Runs the interpolation and fit benchmarks, and the decoder benchmark.
pub fn run(config: &BenchConfig) -> BenchReport {
    let grid = random_grid(config.grid, 1);
    let points = random_points(&grid, config.points, 2);
    let mut out = vec![0.0; points.len()];
    let all = if config.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        config.threads
    };
    let mut results = Vec::new();
    for method in methods() {
        let Ok(model) = method.fit(&grid) else {
            continue;
        };
        let mut thread_counts = vec![1];
        if all > 1 {
            thread_counts.push(all);
        }
        for threads in thread_counts {
            let secs = time(config.repeats, || {
                predict_parallel(model.as_ref(), &points, &mut out, threads).is_ok()
            });
            results.push(PointsResult {
                method: method.name().to_string(),
                order: method.order().map(|o| o.0),
                threads,
                points_per_s: points.len() as f64 / secs,
            });
        }
    }
    let fit_grid = random_grid(config.fit_grid, 3);
    let fit = methods()
        .into_iter()
        .map(|method| FitResult {
            method: method.name().to_string(),
            order: method.order().map(|o| o.0),
            grid: fit_grid.shape(),
            seconds: time(config.repeats, || method.fit(&fit_grid).is_ok()),
        })
        .collect();
    let capture = synthetic_capture(400_000);
    let decode = time(config.repeats, || {
        let mut d = errmap_drivers::Decoder::new();
        d.push_with(&capture, &mut |_| {});
        d.finish().len()
    });
    let decode_rows = time(config.repeats, || {
        errmap_drivers::decode_all(&capture).0.len()
    });
    let mut extra = Vec::new();
    if let Some(secs) = gp_fit_seconds(200) {
        extra.push((
            "Gaussian-process fit, 200 scattered nodes (Matérn 5/2, 9 starts)".to_string(),
            secs,
        ));
    }
    if let Some((rows, secs)) = diagnosis_seconds(100_000) {
        extra.push((
            format!("diagnosis of a {rows}-row session (one hidden reversal)"),
            secs,
        ));
    }
    let repeats = config.repeats;
    let volumetric = volumetric::run(&mut |f| time(repeats, &mut *f));
    BenchReport {
        grid: grid.shape(),
        points: points.len(),
        results,
        fit,
        decode_mb_s: capture.len() as f64 / decode / 1e6,
        decode_rows_mb_s: capture.len() as f64 / decode_rows / 1e6,
        decode_bytes: capture.len(),
        extra,
        volumetric,
        stream: crate::acquire::stream_bench(STREAM_BENCH_MB).ok(),
        history: Vec::new(),
    }
}

/// `n` scattered nodes of a smooth field with ±0.05 µm noise in an 800 mm cube (seeded):
/// the Gaussian-process benchmark's data.
pub fn gp_points(n: usize) -> Vec<crate::table::ErrorPoint> {
    let mut rng = StdRng::seed_from_u64(4);
    (0..n)
        .map(|_| {
            let p: [f64; 3] = [0, 1, 2].map(|_| rng.random_range(0.0..800.0));
            let e = 2.0 * (p[0] / 150.0).sin() * (p[1] / 300.0).cos() + 0.01 * p[2];
            crate::table::ErrorPoint::new(p[0], p[1], p[2], e + rng.random_range(-0.05..0.05))
        })
        .collect()
}

/// Time to fit the Gaussian process to `n` scattered nodes of a smooth field.
pub fn gp_fit_seconds(n: usize) -> Option<f64> {
    let points = gp_points(n);
    let t = Instant::now();
    crate::interp::Gp::fit(&points, &crate::interp::GpConfig::default()).ok()?;
    Some(t.elapsed().as_secs_f64())
}

/// Time to diagnose a simulated session of about `rows` rows (the concealed cases' plan at
/// a higher sample rate, one hidden reversal). Returns the row count and the seconds.
pub fn diagnosis_seconds(rows: usize) -> Option<(usize, f64)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let table1 = root.join("datasets/table1.csv");
    if !table1.is_file() {
        return None;
    }
    let base = crate::sim::concealed_plan();
    // The plan gives ~13 000 rows at 20 Hz; scale the rate for the requested size.
    let plan = errmap_drivers::sim::Plan {
        sample_hz: 20.0 * rows as f64 / 13_000.0,
        ..base
    };
    let nominal = crate::sim::concealed_nominal(&table1, 1);
    let mut hidden = nominal.clone();
    hidden.reversal = Some(crate::sim::Reversal {
        enabled: true,
        b_um: 1.0,
    });
    let model_path = root.join("datasets/model.toml");
    let recorded = crate::sim::simulate_session(&hidden, &model_path, &plan, true).ok()?;
    let simulated = crate::sim::simulate_rows(&nominal, &model_path, &recorded).ok()?;
    let t = Instant::now();
    crate::diagnose::diagnose(
        &recorded,
        &simulated,
        &crate::diagnose::DiagnoseConfig::default(),
    )
    .ok()?;
    Some((recorded.len(), t.elapsed().as_secs_f64()))
}

/// A synthetic capture of about `samples` SAMPLE frames with MARK/ENV/MATERIAL frames
/// interleaved, from the simulated board (a fast plan, no byte-budget drops).
pub fn synthetic_capture(samples: usize) -> Vec<u8> {
    use errmap_drivers::sim::{Device, Faults, Plan, Truth, TruthQuery, simulate};
    struct Flat;
    impl Truth for Flat {
        fn error_um(&mut self, q: &TruthQuery) -> f64 {
            0.001 * q.pos_mm[0]
        }
    }
    let plan = Plan {
        runs: 4,
        sample_hz: 1000.0,
        ..Plan::default()
    };
    let device = Device {
        baud: 4_000_000,
        fifo_bytes: 1 << 20,
        ..Device::default()
    };
    let mut out = Vec::new();
    let mut seed = 0;
    while out.len() < samples * 30 {
        let p = Plan {
            seed,
            ..plan.clone()
        };
        match simulate(&p, &device, &Faults::default(), &mut Flat) {
            Ok(s) => out.extend(s.bytes()),
            Err(_) => break,
        }
        seed += 1;
    }
    out
}

/// The report as a markdown table (for the README and `bench` without --json).
pub fn markdown(r: &BenchReport) -> String {
    let mut s = format!(
        "Grid {}×{}×{}, {} random points inside it.\n\n| method | threads | points/s |\n|---|---|---|\n",
        r.grid[0], r.grid[1], r.grid[2], r.points
    );
    for x in &r.results {
        let label = match x.order {
            Some(o) => format!("{} {}×{}×{}", x.method, o[0], o[1], o[2]),
            None => x.method.clone(),
        };
        s.push_str(&format!(
            "| {label} | {} | {:.2} M |\n",
            x.threads,
            x.points_per_s / 1e6
        ));
    }
    s.push_str("\n| fit | grid | seconds |\n|---|---|---|\n");
    for f in &r.fit {
        let label = match f.order {
            Some(o) => format!("{} {}×{}×{}", f.method, o[0], o[1], o[2]),
            None => f.method.clone(),
        };
        s.push_str(&format!(
            "| {label} | {}×{}×{} | {:.4} |\n",
            f.grid[0], f.grid[1], f.grid[2], f.seconds
        ));
    }
    s.push_str(&format!(
        "\nWire decoder on a {:.1} MB synthetic capture, one core: {:.0} MB/s (frames), {:.0} MB/s (frames → session rows).\n",
        r.decode_bytes as f64 / 1e6,
        r.decode_mb_s,
        r.decode_rows_mb_s
    ));
    for (name, secs) in &r.extra {
        s.push_str(&format!("\n{name}: {secs:.3} s\n"));
    }
    if let Some(v) = &r.volumetric {
        s.push_str(&format!(
            "\nVolumetric, one core: identification of {} lines × {} targets with σ and \
             identifiability {:.3} s (tables at knots, REML; {} parameters) and {:.3} s \
             (polynomials of degree 3; {} parameters); the error vector with σ at {} grid \
             points {:.3} s from the first model, {:.3} s from the second.\n",
            v.lines,
            v.targets_per_line,
            v.identify_default_s,
            v.params_default,
            v.identify_poly3_s,
            v.params_poly3,
            v.grid_points,
            v.predict_grid_s,
            v.predict_grid_poly3_s
        ));
    }
    if let Some(b) = &r.stream {
        let mb = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.0} MB"));
        s.push_str(&format!(
            "\nStreaming on a {:.1} MB generated capture ({} rows): replay → Parquet {:.1} MB/s, peak RSS {}; table {:.1} MB/s, peak RSS {}.\n",
            b.capture_bytes as f64 / 1e6,
            b.rows,
            b.replay_mb_s,
            mb(b.replay_peak_rss_mb),
            b.table_mb_s,
            mb(b.table_peak_rss_mb)
        ));
    }
    s.push_str(&history::markdown(&r.history));
    s
}
