use errmap::diagnose::synth::{Synth, generate};
use errmap::diagnose::{DiagnoseConfig, diagnose};
#[test]
fn dbg() {
    let s = Synth {
        seed: 77,
        ..Synth::default()
    };
    let mut out = generate(&s);
    for r in &mut out.recorded {
        let x = r.x_mm.unwrap_or(0.0);
        r.error_um += 0.4 * (-((x - 400.0) / 40.0).powi(2)).exp();
    }
    let cfg = DiagnoseConfig {
        grating_period_um: Some(20.0),
        ..DiagnoseConfig::default()
    };
    let d = diagnose(&out.recorded, &out.simulated, &cfg).unwrap();
    println!(
        "{} {:.4} -> {:.4}",
        d.verdict, d.rms_before_centred_um, d.rms_after_um
    );
    for e in &d.effects {
        println!(
            "{} {:?} ± {:?}\n   {}",
            e.id, e.params, e.uncertainty, e.where_
        );
    }
    for l in d
        .selection_log
        .iter()
        .chain(&d.ambiguities)
        .chain(&d.locate.findings)
    {
        println!("  {l}");
    }
    println!("unexplained: {:?}", d.locate.unexplained);
}
