//! The LinuxCNC `COMP_FILE` renderer ([`render`]).
//!
//! # LinuxCNC `COMP_FILE`
//!
//! `[JOINT_n] COMP_FILE = file`, `COMP_FILE_TYPE = 0|1` (LinuxCNC INI documentation,
//! `docs/src/config/ini-config.adoc`, section `[JOINT_<num>]`). One triplet per line,
//! `nominal forward reverse`, in machine units (this module writes mm; an inch machine
//! needs its own conversion), smallest nominal first and strictly increasing; at most
//! 256 triplets per joint (`EMCMOT_COMP_SIZE` in `motion.h`; `EMCMOT_SET_JOINT_COMP` in
//! `command.c` rejects extra entries and non-increasing nominals). The loader stops at
//! the first line that is not three numbers, so the file has no header and no comments.
//! Between nominals the trim is interpolated linearly; the forward column applies while
//! the joint moves in the positive direction, the reverse column while it moves in the
//! negative one. Without direction-dependent data both columns are equal.
//!
//! | type | forward / reverse column | written as |
//! |---|---|---|
//! | 0 ([`CompType::ActualPosition`]) | actual position when moving up / down | N + c |
//! | 1 ([`CompType::Trim`]) | trim added to the command moving up / down | −c = e |
//!
//! # Sign convention
//!
//! **LinuxCNC adds its trim to the position command.** `control.c` computes
//! `motor_pos_cmd = pos_cmd + backlash_filt + motor_offset`, where `backlash_filt`
//! follows the trim interpolated from the table. To reach nominal N on an axis whose
//! scale over-reads by e, the motor must be commanded to N + e, so the trim is
//! −c = e. A type-0 file lists instead the *actual* position reached when N is
//! commanded, N − e = N + c; LinuxCNC turns it into the trim `nominal − value` = e
//! (`usrmotLoadComp` in `src/emc/motion/usrmotintf.cc`), so both file types load the
//! same trims.
//!
//! # Part programs (test plans and volumetric campaigns, [`super::program`])
//!
//! Words used (LinuxCNC G-code reference, `docs/src/gcode/g-code.adoc` and `m-code.adoc`)
//!
//! * `G21` millimetres, `G90` absolute distances, `G94` units-per-minute feed, `G61` exact
//!   path (no blending: every programmed point is reached).
//! * `G1 X… Y… Z… F…` a feed move; `F` in mm/min under `G21 G94`, modal, so it is written
//!   once, on the first move.
//! * `G4 P…` dwell, **P in seconds** (a decimal number; a negative P is an error).
//! * `M64 P n` / `M65 P n` switch motion digital output n on / off *immediately* (as
//!   opposed to `M62/M63`, which change it with the next move). `n` is 0 … num_dio − 1,
//!   num_dio being motmod's parameter (4 by default, 64 at most: `EMCMOT_MAX_DIO` in
//!   `src/emc/motion/emcmotcfg.h`). LinuxCNC's task waits for the motion queue to drain
//!   before it issues an immediate output (`emcTaskCheckPreconditions` in
//!   `src/emc/task/emctaskmain.cc` returns `EMC_TASK_EXEC_WAITING_FOR_MOTION` for
//!   `EMC_MOTION_SET_DOUT` with `now`), so `M64` after a `G1` fires with the axis at rest
//!   on the target — a board wired to that output gets a rising edge at "target reached"
//!   and a falling edge at "target left", the same events as its MARK frames.
//! * `( … )` comments; `M2` ends the program.
//!
//! The program is checked against LinuxCNC's own interpreter (`rs274`, Debian package
//! `linuxcnc-uspace`) by `tests/it/testplan.rs` when that is installed:
//! `rs274 -g plan.ngc` prints the canonical moves (`STRAIGHT_FEED`, `DWELL`).

use std::fmt::Write as _;

use super::Field;
use super::TableSetting;
use super::modulo::{ModuloError, ModuloRead, ModuloSpec, ModuloSyntax, ModuloTable, deg6};
use super::modulo_update as mu;
use super::program::{ProgramError, ProgramKind, ProgramSyntax, iso_move, seconds3};
use super::read::{At, TablePoint, check_point};
use super::text::{Text, number};
use super::update::fixed;
use super::{
    AxisKind, AxisTables, Dialect, Editor, ExportFormat, Limits, Parsed, PointUpdate,
    SettingsError, Sign, Spacing, TableFormat, TableSettings, UpdateStyle, Value, ValueUnit,
};
use crate::export::{ExportError, Sampled, fmt_mm};

/// How the limit messages name this controller's table.
pub const LABEL: &str = "LinuxCNC (COMP_FILE triplets per joint, EMCMOT_COMP_SIZE)";

/// The values: the trim −c = e (type 1; type 0 lists N + c), in the machine's length unit.
pub const VALUE: Value = Value {
    sign: Sign::Error,
    unit: ValueUnit::Length,
};

/// LinuxCNC's limit on compensation triplets per joint (`EMCMOT_COMP_SIZE`).
pub const LINUXCNC_MAX_ENTRIES: usize = 256;

/// LinuxCNC `COMP_FILE_TYPE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CompType {
    /// Type 0: the second and third columns are the actual positions reached when the
    /// nominal is commanded (N + c).
    ActualPosition,
    /// Type 1: the columns are the trims LinuxCNC adds to the command (−c = e).
    Trim,
}

impl CompType {
    /// The value for `COMP_FILE_TYPE`.
    pub fn code(self) -> u8 {
        match self {
            CompType::ActualPosition => 0,
            CompType::Trim => 1,
        }
    }
}

/// A LinuxCNC `COMP_FILE`: one `nominal forward reverse` line per sample, mm, no header.
///
/// `reverse` holds direction-dependent errors measured moving in the negative direction,
/// at the same positions; without it both columns come from `forward`. Refuses more
/// than [`LINUXCNC_MAX_ENTRIES`] samples, naming a step that fits.
pub fn render(
    forward: &Sampled,
    comp_type: CompType,
    reverse: Option<&Sampled>,
) -> Result<String, ExportError> {
    let rev = crate::export::paired(forward, reverse)?;
    let n = forward.len();
    if n > LINUXCNC_MAX_ENTRIES {
        // Every nominal is listed: any round step of at least the minimum fits.
        return Err(super::too_many(
            LABEL,
            forward,
            0,
            LINUXCNC_MAX_ENTRIES,
            true,
        ));
    }
    let mut out = String::with_capacity(n * 36);
    let mut previous: Option<f64> = None;
    for i in 0..n {
        let nominal = forward.positions_mm[i];
        let nominal_txt = fmt_mm(nominal);
        // The loader compares the numbers it reads: check them, not the f64s.
        let written: f64 = nominal_txt.parse().unwrap_or(f64::NAN);
        if let Some(prev) = previous
            && written.partial_cmp(&prev) != Some(std::cmp::Ordering::Greater)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: prev,
                position_mm: written,
            });
        }
        previous = Some(written);
        // The trim in mm (VALUE: the table holds e, not c).
        let t_fwd_mm = VALUE.sign.of(forward.error_um[i]) * 1e-3;
        let t_rev_mm = VALUE.sign.of(rev.error_um[i]) * 1e-3;
        let (a, b) = match comp_type {
            CompType::ActualPosition => (nominal - t_fwd_mm, nominal - t_rev_mm),
            CompType::Trim => (t_fwd_mm, t_rev_mm),
        };
        out.push_str(&format!("{nominal_txt} {} {}\n", fmt_mm(a), fmt_mm(b)));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// Reading

pub(crate) fn read(text: &Text, k: f64, comp: CompType) -> Result<Vec<TablePoint>, At> {
    let mut points: Vec<TablePoint> = Vec::new();
    for (i, (off, l)) in text.lines().into_iter().enumerate() {
        let line = i + 1;
        if l.trim().is_empty() {
            continue;
        }
        let t = super::read::tokens(l, off);
        let vals: Vec<Option<f64>> = t.iter().map(|&(s, e)| number(&text.text[s..e])).collect();
        let (3, Some(n), Some(f), Some(r)) = (
            vals.len(),
            vals.first().copied().flatten(),
            vals.get(1).copied().flatten(),
            vals.get(2).copied().flatten(),
        ) else {
            return Err(At::new(
                line,
                format!(
                    "`{}` is not `nominal forward reverse` (three numbers)",
                    l.trim()
                ),
            ));
        };
        super::read::increasing(&points, line, n)?;
        let e = |v: f64| match comp {
            CompType::Trim => VALUE.error_um(v, k),
            CompType::ActualPosition => VALUE.error_um(n - v, k),
        };
        check_point(line, n * k, &[e(f), e(r)])?;
        points.push(TablePoint {
            line,
            position_mm: n * k,
            e_up_um: e(f),
            e_down_um: e(r),
            position_file: n,
            up_file: f,
            down_file: r,
            up: super::read::field(&text.text, t[1]),
            down: super::read::field(&text.text, t[2]),
        });
    }
    if points.len() < 2 {
        return Err(At::new(
            text.lines().len().max(1),
            "fewer than two table points",
        ));
    }
    Ok(points)
}

// ---------------------------------------------------------------------------------------
// The dialect

/// The type of a LinuxCNC table format (trim for any other format: only LinuxCNC's
/// own formats reach this dialect's reader and update).
fn comp_type(format: TableFormat) -> CompType {
    match format {
        TableFormat::LinuxCnc { comp_type, .. } => comp_type,
        _ => CompType::Trim,
    }
}

/// LinuxCNC's `COMP_FILE` ([`super::DIALECTS`]).
#[derive(Debug, Clone, Copy)]
pub struct LinuxCnc;

impl Dialect for LinuxCnc {
    fn modulo(&self) -> Option<&dyn ModuloSyntax> {
        Some(self)
    }
    fn program(&self) -> Option<&dyn ProgramSyntax> {
        Some(self)
    }
    fn axis_tables(&self) -> Option<AxisTables> {
        Some(AxisTables {
            format: |_| ExportFormat::LinuxCnc {
                comp_type: CompType::ActualPosition,
            },
            extension: "comp",
            about: "A LinuxCNC COMP_FILE of type 0 (the positions actually reached)",
            summary: "LinuxCNC COMP_FILE type 0",
        })
    }
    fn name(&self) -> &'static str {
        "linuxcnc"
    }
    fn controller(&self) -> &'static str {
        "LinuxCNC"
    }
    fn about(&self) -> &'static str {
        "LinuxCNC compensation file (a line)"
    }
    fn limits(&self) -> Limits {
        Limits {
            max_points: LINUXCNC_MAX_ENTRIES,
            spacing: Spacing::Listed,
            bidirectional: true,
            value: VALUE,
            axes: &[AxisKind::Linear],
        }
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![
            (
                TableSetting::CompType,
                "COMP_FILE_TYPE (needed to read a table: its file does not state it)".into(),
            ),
            (
                TableSetting::Units,
                "the unit of a table read (default mm)".into(),
            ),
        ]
    }
    fn detect(&self, _bytes: &[u8], _text: &Text) -> bool {
        false
    }
    fn detects_by_content(&self) -> bool {
        false
    }
    fn table_format(&self, s: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(TableFormat::LinuxCnc {
            comp_type: s.comp_type.ok_or(SettingsError::NoCompType)?,
            units: s.units.unwrap_or_default(),
        })
    }
    fn export_format(&self, s: &TableSettings, _: bool) -> Result<ExportFormat, SettingsError> {
        Ok(ExportFormat::LinuxCnc {
            comp_type: s.comp_type.unwrap_or(CompType::ActualPosition),
        })
    }
    fn read(&self, text: &Text, format: TableFormat) -> Result<Parsed, At> {
        let points = read(text, format.units().mm(), comp_type(format))?;
        Ok(Parsed {
            bidirectional: points.iter().any(|p| p.e_up_um != p.e_down_um),
            points,
            ..Parsed::default()
        })
    }
    fn update_style(&self) -> UpdateStyle {
        UpdateStyle::ALIGNED
    }
    /// The trim e + r, or the actual position N − (e + r), in the file's unit.
    fn edit_point(&self, editor: &mut Editor, u: &PointUpdate) {
        let (p, k) = (u.point, editor.k());
        let (up_digits, down_digits) = editor.digits();
        let value = |e_um: f64| match comp_type(u.table.format) {
            CompType::Trim => VALUE.file(e_um, k),
            CompType::ActualPosition => p.position_file - VALUE.file(e_um, k),
        };
        editor.rewrite(p.up, p.up_file, value(p.e_up_um + u.r_up), up_digits);
        let down = value(p.e_down_um + u.r_down);
        editor.rewrite(p.down, p.down_file, down, down_digits);
    }
}

// ---------------------------------------------------------------------------------------
// Part programs

/// LinuxCNC's largest number of motion digital outputs (`EMCMOT_MAX_DIO`).
pub const MAX_DIO: u32 = 64;

impl ProgramSyntax for LinuxCnc {
    fn name(&self) -> &'static str {
        Dialect::name(self)
    }
    fn extension(&self) -> &'static str {
        "ngc"
    }
    fn comment(&self, text: &str) -> String {
        format!("({})", text.replace(['(', ')'], ""))
    }
    fn setup(&self) -> Option<&'static str> {
        Some("G21 G90 G94 G61")
    }
    fn feed_move(&self, axes: &[(&str, f64)], feed: Option<&str>) -> String {
        iso_move("G1", axes, feed)
    }
    fn dwell(&self, dwell_s: f64) -> Result<Vec<String>, ProgramError> {
        Ok(vec![format!("G4 P{}", seconds3(dwell_s))])
    }
    fn stop(&self) -> &'static str {
        "M0"
    }
    fn end(&self, _: ProgramKind) -> Vec<String> {
        vec!["M2".into()]
    }
    fn mark_outputs(&self) -> Option<u32> {
        Some(MAX_DIO)
    }
    fn output(&self, n: u32, on: bool) -> String {
        format!("{} P{n}", if on { "M64" } else { "M65" })
    }
}

// ---------------------------------------------------------------------------------------
// The modulo table of a rotary axis ([`super::modulo`])

/// A LinuxCNC column's value of correction `c` ″ at `q` °: the trim −c or the actual
/// position q + c, the correction put on the file's `decimals` grid before q is added
/// (so the two ends' equal corrections give equal texts, 0 + x and 360 + x).
fn modulo_value(q: f64, c: f64, trim: bool, decimals: usize) -> f64 {
    let scale = 10f64.powi(decimals as i32);
    let c_deg = (c / 3600.0 * scale).round() / scale;
    if trim { -c_deg } else { q + c_deg }
}

impl ModuloSyntax for LinuxCnc {
    fn equidistant(&self) -> bool {
        false
    }
    fn default_max_points(&self) -> usize {
        LINUXCNC_MAX_ENTRIES
    }
    fn direction_columns(&self) -> Option<&'static str> {
        Some("forward/reverse")
    }
    /// `COMP_FILE_TYPE` is not in the file.
    fn needs_comp_type(&self) -> bool {
        true
    }
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
        let mut s = String::new();
        let c = &t.c_arcsec;
        let down = t.c_down_arcsec.as_ref().unwrap_or(c);
        let value = |q: f64, c: f64| modulo_value(q, c, spec.trim, 6);
        for ((q, c), c_down) in t.points_deg.iter().zip(c).zip(down) {
            let (fwd, rev) = (value(*q, *c), value(*q, *c_down));
            let _ = writeln!(s, "{} {} {}", deg6(*q), deg6(fwd), deg6(rev));
        }
        Ok(t.written(s))
    }
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
        let mut t = ModuloRead::default();
        for (line, offset, body) in mu::lines(text) {
            let w = mu::words(body, offset);
            if w.is_empty() || w[0].1.starts_with('#') {
                continue;
            }
            if w.len() != 3 {
                return Err(mu::at(
                    line,
                    "a LinuxCNC comp line is `nominal forward reverse`",
                ));
            }
            let q = mu::number(line, w[0].1, "nominal")?;
            let decode = |v: f64| {
                if spec.trim {
                    -v * 3600.0
                } else {
                    (v - q) * 3600.0
                }
            };
            t.angles.push(q);
            t.lines.push(line);
            t.c_up.push(decode(mu::number(line, w[1].1, "forward")?));
            t.c_down.push(decode(mu::number(line, w[2].1, "reverse")?));
            t.up.push(w[1].0);
            t.down.push(Some(w[2].0));
        }
        t.two = t
            .c_up
            .iter()
            .zip(&t.c_down)
            .any(|(a, b)| (a - b).abs() > 1e-9);
        t.repeats = true;
        t.step_line = t.lines.get(1).copied().unwrap_or(1);
        Ok(t)
    }
    fn encode(&self, spec: &ModuloSpec, q: f64, c: f64, field: Field, _old: &str) -> String {
        let dec = field.decimals.max(6);
        fixed(modulo_value(q, c, spec.trim, dec), dec)
    }
}
