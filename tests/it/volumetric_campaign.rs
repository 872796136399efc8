//! What the campaign itself did wrong (spec `volumetric.md`, "Line table": the residual
//! examined with the diagnosis vocabulary): a drift of the readings in time is named
//! `thermal_drift` and a single line whose readings scale against the others
//! `scale_factor` with the line in `where`, each fitted jointly with the 21 errors —
//! the rate and the scale recovered within their σ, the components still within theirs —
//! and rigid campaigns raise neither.

use std::path::Path;

use errmap::volumetric::{
    Component, Degree, GaugeTruth, Identification, IdentifyConfig, LineTable, Machine, identify,
    simulate,
};
use rand::SeedableRng;
use rand::rngs::StdRng;

use super::volumetric::{plan_file, random_machine, topo};

fn campaign(t: &str, seed: u64) -> (Machine, LineTable) {
    let mut rng = StdRng::seed_from_u64(seed);
    let m = random_machine(topo(t), &mut rng);
    let plan = plan_file(Some("rich"), seed, 0.1)
        .validate(Path::new("test"))
        .expect("plan");
    let table = simulate(&m, &plan);
    (m, table)
}

fn fit(t: &str, table: &LineTable) -> Identification {
    let mut cfg = IdentifyConfig::new(topo(t));
    cfg.degree = Degree::Fixed(3);
    cfg.basis = errmap::volumetric::BasisKind::Poly;
    identify(table, &cfg).expect("identify")
}

/// Standardised errors of every component at mid-range and the end, and the squareness.
fn component_z(m: &Machine, id: &Identification) -> Vec<f64> {
    let gauge = GaugeTruth::of(m, id.fit.basis.range_mm);
    let mut z = Vec::new();
    for c in Component::all() {
        let end = id.fit.basis.range_mm[c.axis][1];
        for a in [0.5 * end, end] {
            let (v, s) = id.fit.component(c.index(), a).expect("identified");
            z.push((v - gauge.value(m, c, a)) / s);
        }
    }
    for k in 0..3 {
        let (v, s) = id.fit.squareness(k).expect("identified");
        z.push((v - gauge.squareness_urad[k]) / s);
    }
    z
}

fn param(id: &Identification, effect: &str, name: &str) -> (f64, f64) {
    let e = id
        .residual
        .effects
        .iter()
        .find(|e| e.id().as_str() == effect)
        .unwrap_or_else(|| panic!("no {effect} in {:?}", id.residual.effects));
    let v = e.number_named(name).expect("number");
    (v, e.sigma_named(name).expect("a one-sigma"))
}

#[test]
fn a_drift_in_time_is_named_and_fitted_with_the_components() {
    for (t, seed) in [("YXZ", 31u64), ("ZXY", 32)] {
        let (m, mut table) = campaign(t, seed);
        // The readings drift by 60 µm per hour (a laser's long dead path in air that
        // changes fast). Each line takes about a minute and a half and runs one way, so
        // the drift within a line is only partly separable from the positioning slopes.
        let rate = 60.0 / 3600.0;
        for tg in table.lines.iter_mut().flat_map(|l| &mut l.targets) {
            *tg.e_um.as_mut().expect("e") += rate * tg.t_s.expect("t_s");
        }
        let id = fit(t, &table);
        assert_eq!(id.residual.verdict.as_str(), "missing_physics");
        let (v, s) = param(&id, "thermal_drift", "rate_um_per_s");
        assert!((v - rate).abs() < 3.5 * s, "{t}: {v} ± {s} vs {rate}");
        assert!(s < 0.35 * rate, "{t}: σ {s} too wide to name it");
        assert!(
            !id.residual
                .effects
                .iter()
                .any(|e| e.id().as_str() == "unexplained"),
            "{t}: {:?}",
            id.residual.effects
        );
        let z = component_z(&m, &id);
        let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
        assert!(
            rms < 1.6,
            "{t}: components' RMS z {rms} with the drift fitted"
        );
        // Without the term the same components would be biased: check the drift was
        // large enough to matter (the plain rigid residual fails its test).
        let mut no_time = table.clone();
        for tg in no_time.lines.iter_mut().flat_map(|l| &mut l.targets) {
            tg.t_s = None;
        }
        let plain = fit(t, &no_time);
        assert_eq!(plain.residual.verdict.as_str(), "missing_physics", "{t}");
        assert!(
            !plain
                .residual
                .effects
                .iter()
                .any(|e| e.id().as_str() == "thermal_drift"),
            "no t_s, no drift term"
        );
    }
}

#[test]
fn a_single_bad_line_is_named_and_its_scale_fitted() {
    let t = "YXZ";
    let (m, mut table) = campaign(t, 41);
    // The longest line along X alone reads −6 ppm: a beam misaligned by ≈ 3.5 mrad.
    let i = (0..table.lines.len())
        .filter(|&i| {
            let u = table.lines[i].u;
            u[0].abs() > 0.999
        })
        .max_by(|&a, &b| {
            let len = |k: usize| {
                let l = &table.lines[k];
                l.s_mm(l.targets.last().expect("target")).abs()
            };
            len(a).total_cmp(&len(b))
        })
        .expect("an X line");
    let k = -6.0;
    let id_line = table.lines[i].id.clone();
    {
        let l = &mut table.lines[i];
        let p0 = l.targets[0].pos_mm;
        let u = l.u;
        for tg in &mut l.targets {
            let s_mm: f64 = (0..3).map(|j| (tg.pos_mm[j] - p0[j]) * u[j]).sum();
            *tg.e_um.as_mut().expect("e") += k * s_mm * 1e-3;
        }
    }
    let id = fit(t, &table);
    let (v, s) = param(&id, "scale_factor", "ppm");
    assert!((v - k).abs() < 3.5 * s, "{v} ± {s} vs {k}");
    let e = id
        .residual
        .effects
        .iter()
        .find(|e| e.id().as_str() == "scale_factor")
        .expect("effect");
    assert!(
        e.where_.contains(&format!("line {id_line} ")),
        "{}",
        e.where_
    );
    assert!(
        e.where_.contains("mrad"),
        "negative: a cosine error: {}",
        e.where_
    );
    let z = component_z(&m, &id);
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    assert!(
        rms < 1.6,
        "components' RMS z {rms} with the bad line fitted"
    );
}

#[test]
fn rigid_campaigns_name_no_drift_and_no_bad_line() {
    let mut alarms = Vec::new();
    for (i, t) in ["YXZ", "XZY", "ZYX", "YZX", "XYZ", "ZXY"]
        .iter()
        .enumerate()
    {
        for draw in 0..2u64 {
            let seed = 500 + 10 * i as u64 + draw;
            let (_, table) = campaign(t, seed);
            let id = fit(t, &table);
            if !id.residual.effects.is_empty() {
                alarms.push(format!("{t} seed {seed}: {:?}", id.residual.effects));
            }
        }
    }
    assert!(alarms.is_empty(), "{alarms:#?}");
}

/// A captured session becomes a line table (`errmap volumetric lines`): one line per
/// (line position, run, direction), each target's position and error the mean of its
/// unflagged dwell samples — checked against the session's rows grouped here by hand —
/// and the table is one `identify` reads.
#[test]
fn a_captured_session_becomes_a_line_table() {
    use std::collections::BTreeMap;
    let session = "datasets/physics/example-session.parquet";
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("lines.csv");
    let o = super::volumetric::errmap(&[
        "volumetric",
        "lines",
        session,
        "--out",
        out.to_str().expect("utf-8"),
        "--probe",
        "0,0,-50",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = LineTable::read(&out, true).expect("a valid line table");
    let rows = errmap::session::read_session(&Path::new(env!("CARGO_MANIFEST_DIR")).join(session))
        .expect("session");
    // By hand: (y, z, run, direction, target) → (Σ error, Σ scale, n).
    type Dwell = (i64, i64, u32, i8, i32);
    let mut by_hand: BTreeMap<Dwell, (f64, f64, usize)> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| r.target >= 0 && r.run > 0 && r.direction != 0 && r.flags == 0)
    {
        let key = (
            (r.y_mm.expect("y") * 1e3).round() as i64,
            (r.z_mm.expect("z") * 1e3).round() as i64,
            r.run,
            r.direction,
            r.target,
        );
        let e = by_hand.entry(key).or_default();
        e.0 += r.error_um;
        e.1 += r.scale_mm;
        e.2 += 1;
    }
    let passes: std::collections::BTreeSet<_> =
        by_hand.keys().map(|k| (k.0, k.1, k.2, k.3)).collect();
    assert_eq!(table.lines.len(), passes.len());
    assert_eq!(table.targets(), by_hand.len());
    let mut matched = 0;
    for line in &table.lines {
        assert_eq!(line.u, [1.0, 0.0, 0.0], "{}", line.id);
        assert_eq!(line.probe_mm, [0.0, 0.0, -50.0]);
        let dir: i8 = if line.id.ends_with('+') { 1 } else { -1 };
        let run: u32 = line.id.split('#').nth(1).expect("run")[..1]
            .parse()
            .expect("run number");
        // In the order of travel.
        let xs: Vec<f64> = line.targets.iter().map(|t| t.pos_mm[0]).collect();
        assert!(
            xs.windows(2).all(|w| (w[1] - w[0]) * f64::from(dir) > 0.0),
            "{}: {xs:?}",
            line.id
        );
        for t in &line.targets {
            let (y, z) = (
                (t.pos_mm[1] * 1e3).round() as i64,
                (t.pos_mm[2] * 1e3).round() as i64,
            );
            let hit = by_hand
                .iter()
                .filter(|(k, v)| {
                    k.0 == y
                        && k.1 == z
                        && k.2 == run
                        && k.3 == dir
                        && (v.1 / v.2 as f64 - t.pos_mm[0]).abs() < 1e-9
                })
                .map(|(_, v)| v.0 / v.2 as f64)
                .collect::<Vec<_>>();
            assert_eq!(hit.len(), 1, "{} at {:?}", line.id, t.pos_mm);
            assert!((hit[0] - t.e_um.expect("e")).abs() < 1e-9);
            assert!(t.s_um.is_none() && t.t_s.is_some());
            matched += 1;
        }
    }
    assert_eq!(matched, by_hand.len());
    // The same table feeds identify: lines along X alone determine E_XX, not E_XY.
    let o = super::volumetric::errmap(&[
        "volumetric",
        "identify",
        out.to_str().expect("utf-8"),
        "--topology",
        "YXZ",
        "--degree",
        "3",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["components"]["E_XX"]["identified"], true);
    assert_eq!(doc["components"]["E_XY"]["identified"], false);
    // A session without dwell rows on a line position is refused, naming the file.
    let empty = dir.path().join("empty.csv");
    std::fs::write(
        &empty,
        "run,sample,t_s,axis,direction,feed_mm_s,target,x_mm,y_mm,z_mm,scale_mm,laser_mm,error_um\n\
         0,1,0.0,X,0,,-1,0.0,,,0.0,0.0,0.0\n",
    )
    .expect("write");
    let o = super::volumetric::errmap(&[
        "volumetric",
        "lines",
        empty.to_str().expect("utf-8"),
        "--out",
        dir.path().join("x.csv").to_str().expect("utf-8"),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("empty.csv") && err.contains("no line"),
        "{err}"
    );
}
