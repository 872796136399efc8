//! A real LinuxCNC loading errmap's comp files (`docs/rotary.md`): a headless sim
//! configuration (trivkins XA, `[JOINT_1] COMP_FILE` the rotary two-direction export of A,
//! `[JOINT_0] COMP_FILE` a linear export of X) run with a display of our own — a Python
//! script on LinuxCNC's `linuxcnc` module that turns the machine on, homes in place, moves
//! and reads `joint.N.pos-cmd` and `joint.N.motor-pos-cmd` through LinuxCNC's `hal` Python
//! module (full precision; `halcmd getp` prints 7 significant digits). LinuxCNC adds
//! the trim nominal − actual of the direction of travel to the command, so
//! motor-pos-cmd − pos-cmd must be −c/3600 of that direction's column. The same harness
//! with a broken file (two lines swapped) must see LinuxCNC's refusal, so the test can
//! fail. Skipped, saying so, where LinuxCNC (`linuxcnc-uspace`) or its Python module is
//! absent. One run at a time on the machine (`flock`): LinuxCNC's shared memory is global.

use std::path::Path;
use std::process::Command;

use super::bidirectional::{c, session};
use crate::util::{errmap, s, stderr, tempdir};

const UI: &str = r#"#!/usr/bin/python3
import linuxcnc, os, time
out = open(os.environ["ERRMAP_LCNC_OUT"], "w")
s = linuxcnc.stat(); c = linuxcnc.command(); e = linuxcnc.error_channel()
def errors():
    while True:
        m = e.poll()
        if not m: return
        out.write("error %s\n" % (m[1],)); out.flush()
def until(cond, t=30):
    end = time.time() + t
    while time.time() < end:
        s.poll(); errors()
        if cond(): return True
        time.sleep(0.05)
    return False
# Full precision through the hal module (it needs a component of its own); halcmd
# prints 7 significant digits.
import hal
probe = hal.component("errmap_probe"); probe.ready()
def getp(p):
    return float(hal.get_value(p))
try:
    until(lambda: False, 1)
    c.state(linuxcnc.STATE_ESTOP_RESET); c.state(linuxcnc.STATE_ON)
    out.write("on %s\n" % until(lambda: s.task_state == linuxcnc.STATE_ON))
    c.mode(linuxcnc.MODE_MANUAL); c.home(-1)
    out.write("homed %s\n" % until(lambda: all(s.homed[:2])))
    c.mode(linuxcnc.MODE_MDI)
    until(lambda: s.task_mode == linuxcnc.MODE_MDI)
    for move in os.environ["ERRMAP_LCNC_MOVES"].split(";"):
        c.mdi(move); c.wait_complete(60)
        until(lambda: s.inpos, 30)
        time.sleep(0.3)
        v = [getp("joint.%d.%s" % (j, p)) for j in (0, 1) for p in ("pos-cmd", "motor-pos-cmd")]
        out.write("move %s\n" % " ".join("%.9f" % x for x in v)); out.flush()
    errors()
except Exception as ex:
    out.write("exception %r\n" % (ex,))
out.write("done\n"); out.close()
"#;

fn ini(dir: &Path) -> String {
    let joint = |n: usize, kind: &str, lo: f64, hi: f64, v: f64, file: &str| {
        format!(
            "[JOINT_{n}]\nTYPE = {kind}\nMIN_LIMIT = {lo}\nMAX_LIMIT = {hi}\nMAX_VELOCITY = {v}\n\
             MAX_ACCELERATION = {}\nHOME_SEQUENCE = 0\nHOME_SEARCH_VEL = 0\nHOME_LATCH_VEL = 0\n\
             COMP_FILE = {}\nCOMP_FILE_TYPE = 0\n",
            10.0 * v,
            dir.join(file).display()
        )
    };
    format!(
        "[EMC]\nVERSION = 1.1\n[DISPLAY]\nDISPLAY = {}\n[TASK]\nTASK = milltask\nCYCLE_TIME = 0.001\n\
         [RS274NGC]\nPARAMETER_FILE = sim.var\n[EMCIO]\nEMCIO = io\nCYCLE_TIME = 0.100\n\
         [EMCMOT]\nEMCMOT = motmod\nSERVO_PERIOD = 1000000\n\
         [HAL]\nHALFILE = LIB:basic_sim.tcl -no_use_hal_manualtoolchange -no_sim_spindle\n\
         [TRAJ]\nCOORDINATES = XA\nLINEAR_UNITS = mm\nANGULAR_UNITS = degree\nMAX_LINEAR_VELOCITY = 50\n\
         [KINS]\nJOINTS = 2\nKINEMATICS = trivkins coordinates=XA\n\
         [AXIS_X]\nMIN_LIMIT = -1\nMAX_LIMIT = 101\nMAX_VELOCITY = 50\nMAX_ACCELERATION = 500\n\
         [AXIS_A]\nMIN_LIMIT = -1\nMAX_LIMIT = 361\nMAX_VELOCITY = 90\nMAX_ACCELERATION = 900\n{}{}",
        dir.join("ui.py").display(),
        joint(0, "LINEAR", -1.0, 101.0, 50.0, "x.comp"),
        joint(1, "ANGULAR", -1.0, 361.0, 90.0, "a.comp"),
    )
}

/// Why LinuxCNC cannot be run here, if it cannot.
fn unavailable() -> Option<String> {
    if !Path::new("/usr/bin/linuxcnc").exists() {
        return Some("/usr/bin/linuxcnc is absent (Debian's linuxcnc-uspace)".into());
    }
    let module = Command::new("/usr/bin/python3")
        .args(["-c", "import linuxcnc"])
        .output();
    if !module.is_ok_and(|o| o.status.success()) {
        return Some("/usr/bin/python3 has no `linuxcnc` module".into());
    }
    None
}

/// Runs the configuration in `dir` through `moves`; the display's report lines.
fn run(dir: &Path, moves: &str) -> Vec<String> {
    let report = dir.join("out.txt");
    let _ = std::fs::remove_file(&report);
    let mut cmd = Command::new("flock");
    cmd.args([
        "/tmp/errmap-linuxcnc-test.lock",
        "timeout",
        "180",
        "linuxcnc",
    ])
    .arg(dir.join("t.ini"))
    .current_dir(dir)
    .env("HOME", dir)
    .env("ERRMAP_LCNC_OUT", &report)
    .env("ERRMAP_LCNC_MOVES", moves)
    .env("RTAPI_FIFO_PATH", dir.join("fifo").join(".rtapi_fifo"));
    // rtapi_app refuses to run as root without a user to fall back to.
    let uid = Command::new("id").arg("-u").output().map(|o| o.stdout);
    if uid.is_ok_and(|u| u.trim_ascii() == b"0") {
        cmd.env("RTAPI_UID", "65534");
    }
    let o = cmd.output().expect("linuxcnc runs");
    let text = std::fs::read_to_string(&report).unwrap_or_default();
    let logs: String = ["linuxcnc_print.txt", "linuxcnc_debug.txt"]
        .iter()
        .filter_map(|f| std::fs::read_to_string(dir.join(f)).ok())
        .collect();
    assert!(
        text.ends_with("done\n"),
        "LinuxCNC did not run the display to its end ({:?}): {text}\n{}\n{logs}",
        o.status,
        String::from_utf8_lossy(&o.stdout)
    );
    text.lines().map(str::to_string).collect()
}

/// motor-pos-cmd − pos-cmd of (X, A) after each move.
fn trims(report: &[String]) -> Vec<(f64, f64, f64, f64)> {
    report
        .iter()
        .filter_map(|l| l.strip_prefix("move "))
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|x| x.parse().expect("number")).collect();
            (v[0], v[1] - v[0], v[2], v[3] - v[2])
        })
        .collect()
}

#[test]
fn linuxcnc_loads_the_rotary_and_linear_comp_files_and_applies_them() {
    if let Some(why) = unavailable() {
        eprintln!("skipped: {why}");
        return;
    }
    let dir = tempdir();
    let d = dir.path();
    let a_comp = d.join("a.comp");
    let o = errmap(&[
        "export",
        s(&session(d)),
        "--format",
        "linuxcnc",
        "--bidirectional",
        "--out",
        s(&a_comp),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // X: errmap's linear writer, e = 4 µm · sin(x/16 mm) every 10 mm.
    let positions_mm: Vec<f64> = (0..=10).map(|k| 10.0 * f64::from(k)).collect();
    let e_x_um = |x: f64| 4.0 * (x / 16.0).sin();
    let sampled = errmap::export::Sampled {
        axis: errmap::base::Axis::X,
        at_mm: [0.0; 3],
        error_um: positions_mm.iter().map(|&x| e_x_um(x)).collect(),
        extrapolated: vec![false; positions_mm.len()],
        positions_mm,
    };
    let x_text = errmap::controller::linuxcnc::render(
        &sampled,
        errmap::controller::CompType::ActualPosition,
        None,
    )
    .expect("fits");
    std::fs::write(d.join("x.comp"), x_text).expect("write");
    std::fs::write(d.join("t.ini"), ini(d)).expect("write");
    std::fs::write(d.join("ui.py"), UI).expect("write");
    let fifo = d.join("fifo");
    std::fs::create_dir(&fifo).expect("fifo dir");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    std::fs::set_permissions(&fifo, std::fs::Permissions::from_mode(0o777)).expect("chmod");
    std::fs::set_permissions(d.join("ui.py"), std::fs::Permissions::from_mode(0o755))
        .expect("chmod");

    // Up to 90° (forward column), down to 30° (reverse), up to 360, down to 0.
    let report = run(d, "G0 X0 A0;G0 X50 A90;G0 X30 A30;G0 X70 A360;G0 A0");
    assert!(report.contains(&"on True".into()) && report.contains(&"homed True".into()));
    assert!(!report.iter().any(|l| l.starts_with("error")), "{report:?}");
    let t = trims(&report);
    assert_eq!(t.len(), 5, "{report:?}");
    // LinuxCNC's trim is −c/3600 of the direction of travel (the analytic c, to the
    // file's 6 decimals), and e of X in mm.
    for (k, a, d) in [(1, 90.0, 1), (2, 30.0, -1), (3, 360.0, 1), (4, 0.0, -1)] {
        assert_eq!(t[k].2, a);
        assert!(
            (t[k].3 + c(a, d) / 3600.0).abs() < 1e-6,
            "A {a} {d}: {:?}",
            t[k]
        );
    }
    for (k, x) in [(1, 50.0), (2, 30.0), (3, 70.0)] {
        assert!(
            (t[k].1 - e_x_um(x) / 1000.0).abs() < 1e-6,
            "X {x}: {:?}",
            t[k]
        );
    }

    // The same harness sees LinuxCNC refuse a broken file: two lines swapped.
    let good = std::fs::read_to_string(&a_comp).expect("read");
    let mut lines: Vec<&str> = good.lines().collect();
    lines.swap(3, 4);
    std::fs::write(&a_comp, lines.join("\n") + "\n").expect("write");
    let report = run(d, "G0 X0 A0");
    assert!(
        report
            .iter()
            .any(|l| l.starts_with("error joint 1: compensation values must increase")),
        "{report:?}"
    );
}
