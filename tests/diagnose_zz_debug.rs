use errmap::diagnose::{DiagnoseConfig, diagnose, write_report};
use errmap::session::read_session;
use std::path::Path;
#[test]
fn dbg() {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/concealed/two_effects");
    let rec = read_session(&d.join("recorded.parquet")).unwrap();
    let sim = read_session(&d.join("simulated.parquet")).unwrap();
    let diag = diagnose(
        &rec,
        &sim,
        &DiagnoseConfig {
            grating_period_um: Some(20.0),
            ..DiagnoseConfig::default()
        },
    )
    .unwrap();
    let files = write_report(&diag, Path::new("/tmp/dbg/report")).unwrap();
    println!("{files:?}");
}
