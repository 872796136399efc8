//! Every controller dialect of the registry (`controller::DIALECTS`), through the same
//! checks: written → read back → updated in place (one direction and, where the table
//! holds one, both), its limits, the command line's `--format` values and `--help`.
//! A new dialect is tested here without editing this file; its own known answers (a
//! golden text, the manual's examples) are unit tests in its `controller/<dialect>.rs`.

use errmap::base::Axis;
use errmap::controller::{
    self, CompType, ControllerTable, Dialect, LengthUnit, Residual, SettingsError, Spacing,
    TableSetting, TableSettings,
};
use errmap::export::Sampled;

use super::util::{errmap, s, stderr, tempdir};

const POS: [f64; 6] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0];
/// Whole micrometres, 0 at the reference position (FANUC's table is 0 there).
const UP: [f64; 6] = [0.0, -2.0, 3.0, 1.0, -4.0, 2.0];
const DOWN: [f64; 6] = [0.0, -1.0, 5.0, 2.0, -3.0, 4.0];
/// A residual, 0 at the reference position.
const R_UP: [f64; 6] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
const R_DOWN: [f64; 6] = [0.0, -1.0, 1.0, -2.0, 2.0, -3.0];
/// Every dialect writes whole micrometres exactly; this is float noise.
const TOL_UM: f64 = 1e-6;

fn line(e: &[f64]) -> Sampled {
    Sampled::measured(Axis::X, [0.0; 3], POS.to_vec(), e.to_vec())
}

/// The settings every dialect can write and read with (a unit and a LinuxCNC type).
fn settings() -> TableSettings {
    TableSettings {
        units: Some(LengthUnit::Mm),
        comp_type: Some(CompType::Trim),
        ..TableSettings::new(Axis::X)
    }
}

fn read(d: &dyn Dialect, bytes: &[u8]) -> ControllerTable {
    let format = d.table_format(&settings()).expect("settings suffice");
    controller::read(bytes, format).unwrap_or_else(|e| panic!("{} reads back: {e:?}", d.name()))
}

fn sum(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

/// The table's errors at the line's positions, each direction (`down` `None`: not
/// checked); a point a dialect adds beyond the line (Siemens' ends) holds no error.
fn assert_points(d: &dyn Dialect, t: &ControllerTable, up: &[f64], down: Option<&[f64]>) {
    let name = d.name();
    for (i, &x) in POS.iter().enumerate() {
        let Some(p) = t.points.iter().find(|p| (p.position_mm - x).abs() < 1e-9) else {
            panic!("{name}: no point at {x} mm: {:?}", t.points);
        };
        assert!(
            (p.e_up_um - up[i]).abs() <= TOL_UM,
            "{name} at {x} mm: up {} for {}",
            p.e_up_um,
            up[i]
        );
        if let Some(down) = down {
            assert!(
                (p.e_down_um - down[i]).abs() <= TOL_UM,
                "{name} at {x} mm: down {} for {}",
                p.e_down_um,
                down[i]
            );
        }
    }
    for p in t.points.iter().filter(|p| !POS.contains(&p.position_mm)) {
        assert!(
            p.e_up_um == 0.0 && p.e_down_um == 0.0,
            "{name}: an added point holds no error: {p:?}"
        );
    }
    assert!(t.points.len() <= POS.len() + 2, "{name}: {:?}", t.points);
}

/// The residual `up`, `down` at the line's positions, 0 at a point the dialect added
/// (so that no table point is outside the residual's targets).
fn residual_on(t: &ControllerTable, up: &[f64], down: &[f64]) -> Residual {
    let at = |v: &[f64], x: f64| POS.iter().position(|&q| q == x).map_or(0.0, |i| v[i]);
    let positions_mm: Vec<f64> = t.points.iter().map(|p| p.position_mm).collect();
    Residual {
        axis: Axis::X,
        up_um: positions_mm.iter().map(|&x| at(up, x)).collect(),
        down_um: positions_mm.iter().map(|&x| at(down, x)).collect(),
        positions_mm,
    }
}

/// A zero residual gives the file back byte for byte, one direction and (where the
/// table holds two) both.
fn assert_zero_update(d: &dyn Dialect, t: &ControllerTable, bytes: &[u8]) {
    let zero = residual_on(t, &[0.0; 6], &[0.0; 6]);
    for bidir in [false, t.bidirectional] {
        let u = controller::update_table(t, &zero, bidir).expect("zero update");
        assert_eq!(
            u.bytes,
            bytes,
            "{}: a zero residual gives the file back",
            d.name()
        );
        assert_eq!(u.summary.max_change_um, 0.0, "{}", d.name());
    }
}

/// One direction: written, read back as written (the sign and the unit through the
/// dialect's `Value`), updated by a zero residual (the same bytes) and by a known one
/// (read back as e + r at every point, nothing outside).
#[test]
fn every_dialect_writes_reads_back_and_updates_one_direction() {
    for d in controller::DIALECTS {
        let format = d.export_format(&settings(), false).expect("format");
        let bytes = format.render_bytes(&line(&UP), None).expect("renders");
        let t = read(*d, &bytes);
        assert_eq!(t.format.name(), d.name());
        assert_points(*d, &t, &UP, None);
        assert_zero_update(*d, &t, &bytes);
        let u =
            controller::update_table(&t, &residual_on(&t, &R_UP, &R_UP), false).expect("update");
        assert!(u.summary.outside_mm.is_empty(), "{}", d.name());
        assert!(
            (u.summary.max_change_um - 5.0).abs() <= TOL_UM,
            "{}",
            d.name()
        );
        let t2 = read(*d, &u.bytes);
        assert_points(*d, &t2, &sum(&UP, &R_UP), None);
    }
}

/// Both directions, where the dialect's table holds a reverse line: written with the
/// reverse line, read back with both columns, updated per direction. A dialect without
/// one refuses the reverse line on writing, and a two-direction update on its table.
#[test]
fn every_dialect_writes_reads_back_and_updates_both_directions_or_refuses_them() {
    for d in controller::DIALECTS {
        let name = d.name();
        if !d.limits().bidirectional {
            let format = d.export_format(&settings(), false).expect("format");
            assert!(
                format.render_line(&line(&UP), Some(&line(&DOWN))).is_err(),
                "{name}: no reverse line"
            );
            let t = read(*d, &format.render_bytes(&line(&UP), None).expect("renders"));
            let r = residual_on(&t, &R_UP, &R_DOWN);
            let e = controller::update_table(&t, &r, true).expect_err("one direction");
            assert!(e.to_string().contains("one value per point"), "{name}: {e}");
            continue;
        }
        let format = d.export_format(&settings(), true).expect("format");
        let bytes = format
            .render_bytes(&line(&UP), Some(&line(&DOWN)))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let t = read(*d, &bytes);
        assert!(t.bidirectional, "{name}: both directions read back");
        assert_points(*d, &t, &UP, Some(&DOWN));
        assert_zero_update(*d, &t, &bytes);
        let r = residual_on(&t, &R_UP, &R_DOWN);
        let u = controller::update_table(&t, &r, true).expect("update");
        let t2 = read(*d, &u.bytes);
        assert_points(*d, &t2, &sum(&UP, &R_UP), Some(&sum(&DOWN, &R_DOWN)));
    }
}

/// A line of one point more than the dialect's limit is refused; half of it is written.
#[test]
fn every_dialect_refuses_more_points_than_its_limit() {
    for d in controller::DIALECTS {
        let n = d.limits().max_points + 1;
        let positions: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let over = Sampled::measured(Axis::X, [0.0; 3], positions, vec![0.0; n]);
        let format = d.export_format(&settings(), false).expect("format");
        assert!(
            format.render_line(&over, None).is_err(),
            "{}: {n} points refused",
            d.name()
        );
        let mut within = over.clone();
        within.positions_mm.truncate(n / 2);
        within.error_um.truncate(n / 2);
        within.extrapolated.truncate(n / 2);
        format
            .render_line(&within, None)
            .unwrap_or_else(|e| panic!("{}: {} points written: {e}", d.name(), n / 2));
    }
}

/// The flags a dialect's reader needs that its file does not state, as the command line
/// spells them.
fn flags(d: &dyn Dialect) -> Vec<&'static str> {
    let mut s = TableSettings::new(Axis::X);
    let mut out = Vec::new();
    loop {
        match d.table_format(&s) {
            Ok(_) => return out,
            Err(SettingsError::NoUnit { .. }) => {
                s.units = Some(LengthUnit::Mm);
                out.extend(["--units", "mm"]);
            }
            Err(SettingsError::NoCompType) => {
                s.comp_type = Some(CompType::Trim);
                out.extend(["--comp-type", "trim"]);
            }
        }
    }
}

/// A session along x measured at `positions` (mm) with zero error: it leaves a table as
/// it is.
pub(crate) fn zero_session(dir: &std::path::Path, positions: &[f64]) -> std::path::PathBuf {
    let session = dir.join("s.csv");
    let mut sess = String::from(
        "run,sample,t_s,axis,direction,feed_mm_s,target,x_mm,y_mm,z_mm,scale_mm,laser_mm,error_um,flags\n",
    );
    for (k, p) in positions.iter().enumerate() {
        sess.push_str(&format!("1,{k},{k},X,1,,{k},{p},0,0,{p},{p},0,0\n"));
    }
    std::fs::write(&session, sess).expect("session");
    session
}

/// The command line takes every dialect's name: `import --format` reads its table, and
/// `export --existing --format` with a session that leaves no residual writes the file
/// back byte for byte; `--help` lists every dialect.
#[test]
fn every_dialect_through_the_command_line() {
    let dir = tempdir();
    let session = zero_session(dir.path(), &POS);
    for d in controller::DIALECTS {
        let name = d.name();
        let format = d.export_format(&settings(), false).expect("format");
        let bytes = format.render_bytes(&line(&UP), None).expect("renders");
        let f = dir.path().join(format!("{name}.table"));
        std::fs::write(&f, &bytes).expect("write");
        let out = dir.path().join(format!("{name}.csv"));
        let mut args = vec![
            "import",
            s(&f),
            "--format",
            name,
            "--out",
            s(&out),
            "--json",
        ];
        args.extend(flags(*d));
        let o = errmap(&args);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        assert_eq!(json["format"], name);
        let new = dir.path().join(format!("{name}.new"));
        let mut args = vec![
            "export",
            s(&session),
            "--existing",
            s(&f),
            "--format",
            name,
            "--out",
            s(&new),
        ];
        args.extend(flags(*d));
        let o = errmap(&args);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert_eq!(std::fs::read(&new).expect("new"), bytes, "{name}");
    }
    let help = errmap(&["export", "--help"]);
    let text = String::from_utf8_lossy(&help.stdout);
    for n in controller::DIALECTS.iter().map(|d| d.name()) {
        assert!(
            text.contains(&format!("{n}:")),
            "{n} in export --help:\n{text}"
        );
    }
}

/// The help of one flag of `export --help`, its lines joined with single spaces.
fn flag_help(help: &str, flag: &str) -> String {
    let mut lines = help
        .lines()
        .skip_while(|l| !l.trim_start().starts_with(flag));
    let first = lines
        .next()
        .unwrap_or_else(|| panic!("{flag} in export --help"));
    // The help is indented deeper than the next flag's line.
    let rest = lines.take_while(|l| l.trim().is_empty() || l.len() - l.trim_start().len() > 6);
    std::iter::once(first)
        .chain(rest)
        .flat_map(str::split_whitespace)
        .collect::<Vec<_>>()
        .join(" ")
}

/// `export --help` says the common settings as the registry's dialects read them: each
/// controller that reads one, in its own words, and no other; `--bidirectional` names the
/// two-direction formats and `--ends` every format. What `--ends` says holds: a step that
/// does not divide the range is refused exactly by the formats of one interval.
#[test]
fn export_help_is_made_from_the_registry_and_says_what_happens() {
    let help = errmap(&["export", "--help"]);
    let text = String::from_utf8_lossy(&help.stdout);
    for (setting, flag) in [
        (TableSetting::AxisName, "--axis-name"),
        (TableSetting::AxisNumber, "--axis-number"),
        (TableSetting::MaxPoints, "--max-points"),
        (TableSetting::TableName, "--table-name"),
        (TableSetting::Units, "--units"),
        (TableSetting::CompType, "--comp-type"),
    ] {
        let h = flag_help(&text, flag);
        let readers = controller::readers_of(setting);
        assert!(!readers.is_empty(), "{flag}: some dialect reads it");
        for d in controller::DIALECTS {
            let words = readers.iter().find(|(r, _)| r.name() == d.name());
            match words {
                Some((_, w)) => {
                    let w = w.split_whitespace().collect::<Vec<_>>().join(" ");
                    assert!(h.contains(d.controller()), "{flag} names {}: {h}", d.name());
                    assert!(h.contains(&w), "{flag} says `{w}`: {h}");
                }
                None => assert!(
                    !h.contains(&format!("{}:", d.controller())),
                    "{flag} does not name {}: {h}",
                    d.name()
                ),
            }
        }
    }
    let bidirectional = flag_help(&text, "--bidirectional");
    let ends = flag_help(&text, "--ends");
    let table1 = super::util::root().join("datasets/table1.csv");
    let dir = tempdir();
    for d in controller::DIALECTS {
        let n = d.name();
        let two = d.limits().bidirectional;
        let listed = |t: &str| t.split([' ', ',', ':', '.']).any(|w| w == n);
        assert_eq!(
            listed(&bidirectional),
            two,
            "{n} in --bidirectional: {bidirectional}"
        );
        assert!(listed(&ends), "{n} in --ends: {ends}");
        // 7 mm does not divide table 1's range along x (1.2424 … 800 mm).
        let out = dir.path().join(format!("{n}.step7"));
        let mut args = vec![
            "export",
            s(&table1),
            "--method",
            "trilinear",
            "--step",
            "7",
            "--format",
            n,
            "--out",
            s(&out),
        ];
        args.extend(flags(*d));
        let o = errmap(&args);
        let one_interval = d.limits().spacing == Spacing::Equidistant;
        assert_eq!(!o.status.success(), one_interval, "{n}: {}", stderr(&o));
        if one_interval {
            assert!(
                stderr(&o).contains("does not divide"),
                "{n}: {}",
                stderr(&o)
            );
        }
    }
}

/// `docs/cli.md`'s rows of `export` and `import` name every dialect of the registry, as
/// `--format` spells it; with a rotary table, `export`'s row names every dialect with a
/// modulo table.
#[test]
fn docs_cli_names_every_dialect_where_it_lists_them() {
    let text = std::fs::read_to_string(super::util::root().join("docs/cli.md")).expect("docs");
    let row = |command: &str| {
        text.lines()
            .find(|l| l.starts_with(&format!("| `errmap {command} ")))
            .unwrap_or_else(|| panic!("docs/cli.md has a row for `errmap {command}`"))
            .to_string()
    };
    for command in ["export", "import"] {
        let r = row(command);
        for d in controller::DIALECTS {
            assert!(
                r.contains(&format!("`{}`", d.name())),
                "docs/cli.md's `{command}` row leaves out {}",
                d.name()
            );
        }
    }
    let rotary = row("export");
    let rotary = &rotary[rotary.find("rotary").expect("the rotary clause")..];
    for d in errmap::controller::modulo::modulo_dialects() {
        assert!(
            rotary.contains(&format!("`{}`", d.name())),
            "docs/cli.md's rotary clause leaves out {}",
            d.name()
        );
    }
}
