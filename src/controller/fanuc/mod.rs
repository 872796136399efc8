//! The FANUC pitch error compensation renderer ([`table`], [`render`]).
//!
//! # FANUC pitch error compensation
//!
//! Sources: FANUC Series 0i-PB Parameter Manual (B-63980EN/01), description of
//! parameters 3620–3624 (p. 100, the linear-axis and rotary-axis examples), and the FANUC
//! technical report "Series 16i/18i-MA/TA bidirectional pitch error compensation function"
//! (A-77810E, 2000), table (a).
//!
//! Per axis the compensation is a list of *compensation point numbers* shared by all
//! axes; the axis' parameters say which numbers it uses:
//!
//! | parameter | meaning |
//! |---|---|
//! | 3620 | number of the compensation point of the reference position |
//! | 3621 | number of the most negative compensation point (for travel in the + direction) |
//! | 3622 | number of the most positive compensation point (for travel in the + direction) |
//! | 3623 | magnification: each value counts `magnification` detection units |
//! | 3624 | interval between compensation points |
//! | 3605#0 | bidirectional pitch error compensation (1: enabled; 16i/18i and later) |
//! | 3626 | number of the most negative compensation point for travel in the − direction |
//! | 3627 | the compensation (absolute value) at the reference position when the machine moves to it from the direction opposite to the reference return |
//!
//! The points lie every interval h from the reference position r. The value of number N
//! is an **increment**: the compensation output over the section that ends at point
//! r + (N − 3620)·h, so that the section (r − h, r] has number 3620 and the most
//! negative section, starting at r − k·h, has 3620 − k + 1 (the manual's example:
//! reference number 40, interval 50 mm, stroke from −400 mm: 3621 = 40 − 400/50 + 1 =
//! 33). The absolute compensation at a point is the sum of the increments from the
//! reference position, where it is 0 (the example's "pitch error compensation amount
//! (absolute value)" curve passes through 0 at the reference position; its values for
//! numbers 33–40 sum to 0). Values are integers in detection units × 3623.
//!
//! What this module writes, and what it derives:
//!
//! * **The reference offset.** Because the compensation is 0 at the reference position,
//!   the table corrects e(x) − e(r); a constant e(r) is a datum offset that the pitch
//!   error table cannot hold (errmap names it in the file's header).
//! * **Rounding.** The absolute values are rounded to the unit and then differenced, so
//!   the rounding does not accumulate: at every point the table's absolute value is within
//!   half a unit of e − e(r).
//! * **Sign.** The compensation pulses are added to the axis' motion. To place the axis
//!   at x when its scale over-reads by e(x) (errmap's e = indicated − reference), the
//!   motion must go e(x) further, so the absolute compensation is +e(x) − e(r) = −c + c(r)
//!   and the increments are those of e. The manuals consulted do not state the sign in
//!   words: check it on the machine with one point before trusting the whole table.
//! * **Between points.** The parameter manual says the value "is output at the
//!   compensation position corresponding to each section"; whether the pulses are spread
//!   over the section or output at once is not stated in the sources consulted, so the
//!   tests check the table at the points, where both readings agree.
//! * **Bidirectional.** With 3605#0 = 1 a second list (from 3626, as many numbers as the
//!   first) holds the increments for travel in the negative direction, and 3627 the
//!   negative-travel compensation at the reference position. errmap assumes the
//!   reference return is made in the positive direction (parameter 1006#5 ZMI = 0), so
//!   the positive-travel curve is the one that is 0 at the reference position; the
//!   negative-travel curve is written relative to it (3627 = e↓(r) − e↑(r) in units).
//!
//! Limits that are parameters here because they depend on the series and were not found
//! in the sources consulted: the highest compensation point number
//! ([`FANUC_MAX_POINT_NUMBER`] = 1023, the 0i range), the largest value per point
//! ([`FANUC_DEFAULT_MAX_VALUE`] = 7, the range of the older series; newer series accept
//! more) and the magnification range (1–[`FANUC_MAX_MAGNIFICATION`]).
//!
//! # The file
//!
//! The pitch error data in the N/P form of a FANUC data file, one `N<10000 + point
//! number>P<value>` per point between `%` lines, with the parameters as a comment block
//! to enter on the parameter screen. This framing (data number 10000 + point number) is
//! the one FANUC controls commonly punch for pitch error data, but it was not confirmed
//! in the sources consulted: compare it with a file punched from the target control
//! before loading.
//!
//! # Part programs (test plans and volumetric campaigns, [`super::program`])
//!
//! Words used (FANUC Series 0i-MODEL F Operator's Manual, B-64604EN, part II
//! "Programming": "Dwell (G04)", "Inch/metric conversion (G20, G21)", "Feed functions")
//!
//! * `%` opens and closes the file for transfer; `O….` is the program number
//!   ([`PROGRAM_NUMBER`], 1 … 9999; 8000 … 9999 are often edit-protected by parameter 3202).
//! * `G21` mm, `G90` absolute, `G94` feed per minute; `G01 X… F…` a feed move, F in mm/min.
//! * **Every coordinate is written with a decimal point.** Without one, a Fanuc reads the
//!   number in least input increments (IS-B: `X10` is 0.010 mm) unless pocket-calculator
//!   decimal input (parameter 3401#0 DPI) is set, so `X10.000` is the only unambiguous form.
//! * `G04 P…` dwell: **P is an integer number of milliseconds** (decimal point not
//!   permitted; 1 … 99 999 999, i.e. at most 99 999.999 s). `G04 X…` takes seconds with a
//!   decimal point, but X's reading depends on the same DPI parameter on some models and on
//!   G95 (revolutions), while an integer P in G94 is always ms — so errmap writes P, the
//!   dwell rounded to 1 ms. The same table of ranges is in Siemens' ISO-dialect manual for
//!   the 840D (SINUMERIK ISO Milling, 04.07, §3.3.1 "Dwell (G04)"), which mimics Fanuc.
//! * `( … )` comments (upper-case letters and digits are safe on every model); `M30` ends
//!   the program and rewinds.

mod modulo;
mod program;
mod update;
pub use program::{MAX_DWELL_MS, PROGRAM_NUMBER};

use super::TableSetting;
use super::options::{self, OptionError, OptionValue};
use super::program::ProgramSyntax;
use super::read::{At, Field, Parsed, check_point, field_at, num, point};
use super::text::{Text, number};
use super::{
    AxisKind, Dialect, DialectOption, ExportFormat, Limits, SettingsError, Sign, Spacing,
    TableFormat, TableSettings, Value, ValueUnit,
};
use super::{ControllerTable, Residual, Updated};
use crate::base::Axis;
use crate::export::{ExportError, Sampled};

/// How the limit messages name this controller's table.
pub const LABEL: &str = "FANUC pitch error compensation";

/// The highest compensation point number of the FANUC 0i (points 0–1023).
pub const FANUC_MAX_POINT_NUMBER: u32 = 1023;
/// The largest increment per point (in units of detection unit × magnification) accepted
/// by default: ±7, the range of the older series. A parameter.
pub const FANUC_DEFAULT_MAX_VALUE: u32 = 7;
/// The largest magnification (parameter 3623) errmap writes.
pub const FANUC_MAX_MAGNIFICATION: u32 = 100;

/// The axis and the control's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FanucSpec {
    /// The axis number the parameters belong to (1 = first axis), for the header.
    pub axis_number: u32,
    /// Parameter 3620; `None`: the smallest number that fits (the most negative point 0).
    pub reference_number: Option<u32>,
    /// The machine coordinate of the reference position, mm; it must be a table point.
    pub reference_mm: f64,
    /// The detection unit, µm (1 for IS-B, 0.1 for IS-C).
    pub detection_unit_um: f64,
    /// Parameter 3623.
    pub magnification: u32,
    /// The largest |value| per point.
    pub max_value: u32,
    /// The highest compensation point number of the control.
    pub max_point_number: u32,
    /// Parameter 3626 for a bidirectional table; `None`: right after 3622.
    pub negative_start: Option<u32>,
}

impl Default for FanucSpec {
    fn default() -> Self {
        FanucSpec {
            axis_number: 1,
            reference_number: None,
            reference_mm: 0.0,
            detection_unit_um: 1.0,
            magnification: 1,
            max_value: FANUC_DEFAULT_MAX_VALUE,
            max_point_number: FANUC_MAX_POINT_NUMBER,
            negative_start: None,
        }
    }
}

/// FANUC's settings (the command line's flags), in [`FanucSpec`]'s order.
static OPTIONS: [DialectOption; 7] = [
    DialectOption {
        name: "fanuc-reference-number",
        help: "FANUC 3620, the compensation point number of the reference position --reference \
               (default: the smallest that fits, so the most negative point is 0)",
        default: None,
        parse: options::number,
    },
    DialectOption {
        name: "detection-unit-um",
        help: "FANUC detection unit, µm (1 for IS-B, 0.1 for IS-C)",
        default: Some("1"),
        parse: options::positive,
    },
    DialectOption {
        name: "magnification",
        help: "FANUC 3623, the pitch error compensation magnification (1–100)",
        default: Some("1"),
        parse: magnification,
    },
    DialectOption {
        name: "fanuc-max-value",
        help: "FANUC: the largest |value| per compensation point the series accepts",
        default: Some("7"),
        parse: options::from_one,
    },
    DialectOption {
        name: "fanuc-max-point",
        help: "FANUC: the highest compensation point number of the control",
        default: Some("1023"),
        parse: options::number,
    },
    DialectOption {
        name: "fanuc-negative-start",
        help: "FANUC 3626 of a bidirectional table (default: right after 3622)",
        default: None,
        parse: options::number,
    },
    DialectOption {
        name: "detection-unit-deg",
        help: "FANUC rotary axis: the detection unit in degrees (0.001 IS-B, 0.0001 IS-C)",
        default: None,
        parse: options::positive,
    },
];

/// Parameter 3623: a whole number 1 … [`FANUC_MAX_MAGNIFICATION`].
fn magnification(s: &str) -> Result<OptionValue, OptionError> {
    match s.trim().parse::<u32>() {
        Ok(m) if (1..=FANUC_MAX_MAGNIFICATION).contains(&m) => Ok(OptionValue::Number(m)),
        _ => Err(OptionError::new(s, "a magnification from 1 to 100")),
    }
}

impl FanucSpec {
    /// The spec `settings` give: their axis number and reference, and FANUC's own
    /// settings ([`OPTIONS`]; the defaults where none is given).
    pub fn from_settings(s: &TableSettings) -> Self {
        let o = &s.options;
        let d = FanucSpec::default();
        FanucSpec {
            axis_number: s.axis_number(),
            reference_number: o.number(OPTIONS[0].name),
            reference_mm: s.reference_mm,
            detection_unit_um: o.real(OPTIONS[1].name).unwrap_or(d.detection_unit_um),
            magnification: o.number(OPTIONS[2].name).unwrap_or(d.magnification),
            max_value: o.number(OPTIONS[3].name).unwrap_or(d.max_value),
            max_point_number: o.number(OPTIONS[4].name).unwrap_or(d.max_point_number),
            negative_start: o.number(OPTIONS[5].name),
        }
    }
}

/// The negative-direction list of a bidirectional table.
#[derive(Debug, Clone, PartialEq)]
pub struct FanucReverse {
    /// Parameter 3626.
    pub negative_number: u32,
    /// Parameter 3627, in units (detection unit × 3623).
    pub reference_value: i64,
    /// The increments of numbers 3626, 3626 + 1, ….
    pub values: Vec<i64>,
}

/// A pitch error compensation table for one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct FanucTable {
    /// 3620, 3621, 3622, 3623.
    pub reference_number: u32,
    pub negative_number: u32,
    pub positive_number: u32,
    pub magnification: u32,
    /// 3624, mm.
    pub interval_mm: f64,
    /// One unit of a value, µm (detection unit × 3623).
    pub unit_um: f64,
    /// The increments of numbers 3621..=3622.
    pub values: Vec<i64>,
    pub reverse: Option<FanucReverse>,
    /// e at the reference position (forward), µm: the offset the table cannot hold.
    pub reference_error_um: f64,
}

fn limit(problem: String) -> ExportError {
    ExportError::ControllerLimit {
        controller: LABEL,
        problem,
    }
}

/// Absolute values in units, relative to `zero_um`, rounded; then the increments of the
/// numbered sections (index 0: the section before the first point, 0).
fn increments(error_um: &[f64], zero_um: f64, unit_um: f64) -> Result<Vec<i64>, ExportError> {
    let mut q = Vec::with_capacity(error_um.len());
    for &e in error_um {
        let v = ((e - zero_um) / unit_um).round();
        if v.abs() >= i32::MAX as f64 {
            return Err(limit(format!(
                "a compensation of {e} µm is {v} units of {unit_um} µm, beyond any table"
            )));
        }
        q.push(v as i64);
    }
    Ok(q)
}

/// The increments and the negative-direction list at one magnification.
type Lists = (Vec<i64>, Option<FanucReverse>);

/// How the table's points are numbered: 3620 and the first and last numbers of each
/// direction (all within the control's range), and the index of the reference point.
struct Numbering {
    reference_number: u32,
    first: u32,
    last: u32,
    negative_start: u32,
    k0: usize,
}

impl Numbering {
    /// The number of table index `number`'s section: section i (1 ≤ i < n) ends at point
    /// i and has number R + i − k0.
    fn section(&self, number: u32) -> i64 {
        number as i64 - self.reference_number as i64 + self.k0 as i64
    }

    /// The increments of numbers first..=last from the absolute values `q`.
    fn values_of(&self, q: &[i64]) -> Vec<i64> {
        (self.first..=self.last)
            .map(|number| {
                let i = self.section(number);
                if i <= 0 {
                    0
                } else {
                    q[i as usize] - q[i as usize - 1]
                }
            })
            .collect()
    }
}

/// What the value lists are computed from: the two curves, e at the reference position,
/// the numbering and the spec; a separate step so a magnification can be tried in turn.
struct Curves<'a> {
    forward: &'a Sampled,
    rev: &'a Sampled,
    bidirectional: bool,
    e_ref: f64,
    numbering: &'a Numbering,
    spec: &'a FanucSpec,
}

impl Curves<'_> {
    /// The lists at a magnification; both relative to the positive-travel curve, which is
    /// 0 at the reference position.
    fn lists(&self, magnification: u32) -> Result<Lists, ExportError> {
        let unit_um = self.spec.detection_unit_um * magnification as f64;
        let values =
            self.numbering
                .values_of(&increments(&self.forward.error_um, self.e_ref, unit_um)?);
        let reverse_table = if self.bidirectional {
            let qd = increments(&self.rev.error_um, self.e_ref, unit_um)?;
            Some(FanucReverse {
                negative_number: self.numbering.negative_start,
                reference_value: qd[self.numbering.k0],
                values: self.numbering.values_of(&qd),
            })
        } else {
            None
        };
        Ok((values, reverse_table))
    }
}

/// The largest |increment| of both lists.
fn worst(l: &Lists) -> u64 {
    l.0.iter()
        .chain(l.1.iter().flat_map(|r| r.values.iter()))
        .map(|v| v.unsigned_abs())
        .max()
        .unwrap_or(0)
}

/// Refuses settings no control takes: a detection unit that is not a length, a
/// magnification beyond errmap's range, a zero largest value or axis number.
fn check_spec(spec: &FanucSpec) -> Result<(), ExportError> {
    if !(spec.detection_unit_um.is_finite() && spec.detection_unit_um > 0.0) {
        return Err(limit(format!(
            "the detection unit {} µm must be a positive length",
            spec.detection_unit_um
        )));
    }
    if !(1..=FANUC_MAX_MAGNIFICATION).contains(&spec.magnification) {
        return Err(limit(format!(
            "magnification (3623) {} is outside 1–{FANUC_MAX_MAGNIFICATION}",
            spec.magnification
        )));
    }
    if spec.max_value == 0 || spec.axis_number == 0 {
        return Err(limit(
            "the largest value per point and the axis number must be at least 1".into(),
        ));
    }
    Ok(())
}

/// The index of the reference position among the table's points (FANUC counts from it),
/// refused when it is not one.
fn reference_index(forward: &Sampled, spec: &FanucSpec, h: f64) -> Result<usize, ExportError> {
    let n = forward.len();
    let (first_mm, last_mm) = (forward.positions_mm[0], forward.positions_mm[n - 1]);
    let r = spec.reference_mm;
    let tol = 1e-9 * (1.0 + r.abs().max(last_mm.abs()).max(first_mm.abs()));
    forward
        .positions_mm
        .iter()
        .position(|&x| (x - r).abs() <= tol.max(1e-7))
        .ok_or(ExportError::ReferenceOffGrid {
            controller: LABEL,
            reference_mm: r,
            outside: r < first_mm || r > last_mm,
            first_mm,
            last_mm,
            step_mm: h,
        })
}

/// Numbers the points from 3620 (given, or the smallest that fits) and checks that the
/// two directions' numbers do not overlap and stay within the control's highest number.
fn number_points(
    forward: &Sampled,
    spec: &FanucSpec,
    k0: usize,
    h: f64,
    bidirectional: bool,
) -> Result<Numbering, ExportError> {
    let n = forward.len();
    let (first_mm, last_mm) = (forward.positions_mm[0], forward.positions_mm[n - 1]);
    // Section i (1 ≤ i < n) ends at point i and has number R + i − k0; with the reference
    // at the first point, number R is the (empty) section before it.
    // Point numbers are worked in u64 so that no flag value can overflow; the control's
    // limit (a u32) is checked below.
    let k0_u = k0 as u64;
    let reference_number = match spec.reference_number.map(u64::from) {
        Some(rn) => {
            if rn + 1 < k0_u {
                return Err(limit(format!(
                    "with the reference position at point {k0} of the table, 3620 = {rn} puts the \
                     most negative point at number {}; set 3620 to at least {}",
                    rn as i64 + 1 - k0 as i64,
                    k0 - 1
                )));
            }
            rn
        }
        None => k0_u.saturating_sub(1),
    };
    let first = (reference_number + 1)
        .saturating_sub(k0_u)
        .min(reference_number);
    let last = reference_number + (n as u64 - 1 - k0_u);
    let span = last - first;
    let negative_start = spec.negative_start.map_or(last + 1, u64::from);
    if bidirectional && negative_start <= last && negative_start + span >= first {
        return Err(limit(format!(
            "the negative-direction numbers {negative_start}–{} (3626) overlap the \
             positive-direction numbers {first}–{last}",
            negative_start + span
        )));
    }
    let top = if bidirectional {
        last.max(negative_start + span)
    } else {
        last
    };
    if top > u64::from(spec.max_point_number) {
        return Err(limit(format!(
            "the table needs compensation point numbers up to {top}, beyond the control's \
             {}: {n} points from {first_mm} to {last_mm} mm every {h} mm{}; use a coarser \
             interval or a smaller 3620",
            spec.max_point_number,
            if bidirectional {
                " in each direction"
            } else {
                ""
            }
        )));
    }
    // All numbers now fit the control's u32 range.
    Ok(Numbering {
        reference_number: reference_number as u32,
        first: first as u32,
        last: last as u32,
        negative_start: negative_start as u32,
        k0,
    })
}

/// The refusal of increments beyond the largest value: which point needs what, and the
/// smallest magnification that would fit (tried in turn: rounding decides it).
fn too_big_error(curves: &Curves, lists: &Lists, too_big: u64, h: f64) -> ExportError {
    let (spec, numbering) = (curves.spec, curves.numbering);
    let (values, reverse_table) = lists;
    let unit_um = spec.detection_unit_um * spec.magnification as f64;
    let (which, j) = values
        .iter()
        .position(|v| v.unsigned_abs() == too_big)
        .map(|j| ("", numbering.first as usize + j))
        .or_else(|| {
            reverse_table.as_ref().and_then(|r| {
                r.values
                    .iter()
                    .position(|v| v.unsigned_abs() == too_big)
                    .map(|j| {
                        (
                            " (negative direction)",
                            numbering.negative_start as usize + j,
                        )
                    })
            })
        })
        .unwrap_or(("", numbering.first as usize));
    let fits = (spec.magnification + 1..=FANUC_MAX_MAGNIFICATION).find(|&m| {
        curves
            .lists(m)
            .is_ok_and(|l| worst(&l) <= spec.max_value as u64)
    });
    let advice = match fits {
        Some(m) => {
            format!("raise the magnification (3623) to at least {m} or use a finer interval")
        }
        None => {
            format!("no magnification up to {FANUC_MAX_MAGNIFICATION} fits: use a finer interval")
        }
    };
    limit(format!(
        "point {j}{which} needs an increment of ±{too_big} units of {unit_um} µm over {h} mm, \
         beyond ±{}; {advice}",
        spec.max_value
    ))
}

/// The table for `forward` (and `reverse`, direction-dependent errors at the same
/// positions, for a bidirectional table). The samples must be equidistant and include
/// the reference position.
pub fn table(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &FanucSpec,
) -> Result<FanucTable, ExportError> {
    let rev = crate::export::paired(forward, reverse)?;
    let h = forward.uniform_step()?;
    check_spec(spec)?;
    let k0 = reference_index(forward, spec, h)?;
    let e_ref = forward.error_um[k0];
    let numbering = number_points(forward, spec, k0, h, reverse.is_some())?;
    let curves = Curves {
        forward,
        rev,
        bidirectional: reverse.is_some(),
        e_ref,
        numbering: &numbering,
        spec,
    };
    let lists = curves.lists(spec.magnification)?;
    let too_big = worst(&lists);
    if too_big > spec.max_value as u64 {
        return Err(too_big_error(&curves, &lists, too_big, h));
    }
    let (values, reverse_table) = lists;
    let unit_um = spec.detection_unit_um * spec.magnification as f64;
    Ok(FanucTable {
        reference_number: numbering.reference_number,
        negative_number: numbering.first,
        positive_number: numbering.last,
        magnification: spec.magnification,
        interval_mm: h,
        unit_um,
        values,
        reverse: reverse_table,
        reference_error_um: e_ref,
    })
}

/// The table as a FANUC data file (module docs): parameters in a comment block, then
/// `N<10000 + number>P<value>` for every point, positive direction first.
pub fn render(
    forward: &Sampled,
    reverse: Option<&Sampled>,
    spec: &FanucSpec,
) -> Result<String, ExportError> {
    let t = table(forward, reverse, spec)?;
    let axis = forward.axis.to_string().to_uppercase();
    let fixed: Vec<String> = crate::table::Axis::ALL
        .iter()
        .filter(|&&a| a != forward.axis)
        .map(|a| {
            format!(
                "{} {}",
                a.to_string().to_uppercase(),
                crate::export::fmt_fixed(forward.at_mm[a.index()], 4)
            )
        })
        .collect();
    let mut out = String::with_capacity((t.values.len() * 2 + 12) * 14);
    out.push_str("%\n");
    out.push_str("(FANUC PITCH ERROR COMPENSATION FROM ERRMAP)\n");
    out.push_str(&format!(
        "(AXIS {} = {axis}, LINE AT {} MM, {} POINTS, {} EXTRAPOLATED)\n",
        spec.axis_number,
        fixed.join(" "),
        forward.len(),
        forward.extrapolated_count()
    ));
    let (bdp, negative) = match &t.reverse {
        Some(r) => (
            1,
            format!(" 3626={} 3627={}", r.negative_number, r.reference_value),
        ),
        None => (0, String::new()),
    };
    out.push_str(&format!(
        "(PARAMETERS OF AXIS {}: 3605#0={bdp} 3620={} 3621={} 3622={} 3623={} 3624={} MM{negative})\n",
        spec.axis_number,
        t.reference_number,
        t.negative_number,
        t.positive_number,
        t.magnification,
        crate::export::fmt_mm(t.interval_mm)
    ));
    out.push_str(&format!(
        "(REFERENCE POSITION {} MM; VALUES ARE INCREMENTS IN UNITS OF {} UM)\n",
        crate::export::fmt_mm(spec.reference_mm),
        crate::export::fmt_fixed(t.unit_um, 4)
    ));
    out.push_str(&format!(
        "(NOT IN THE TABLE: THE ERROR AT THE REFERENCE POSITION, {} UM)\n",
        crate::export::fmt_fixed(t.reference_error_um, 4)
    ));
    let lists = std::iter::once((t.negative_number, &t.values))
        .chain(t.reverse.as_ref().map(|r| (r.negative_number, &r.values)));
    for (start, vals) in lists {
        for (j, v) in vals.iter().enumerate() {
            out.push_str(&format!("N{}P{v}\n", 10000 + start as usize + j));
        }
    }
    out.push_str("%\n");
    Ok(out)
}

/// Increments with where each sits in the text.
pub type Increments = Vec<(Field, i64)>;

/// A FANUC table as read: the increments and where they sit.
#[derive(Debug, Clone, PartialEq)]
pub struct FanucLayout {
    /// One unit of a value, µm (detection unit × 3623).
    pub unit_um: f64,
    /// The index of the point at the reference position.
    pub reference_index: usize,
    /// The increment ending at point j (j ≥ 1) is `forward[j − 1]`.
    pub forward: Increments,
    /// The negative-travel increments and 3627 (the negative-travel value at the
    /// reference position), when 3605#0 = 1.
    pub reverse: Option<(Increments, (Field, i64))>,
}

// ---------------------------------------------------------------------------------------
// FANUC

/// `key=value` words of errmap's FANUC parameter comment.
fn fanuc_words(l: &str, off: usize) -> Vec<(&str, Field, &str)> {
    let mut out = Vec::new();
    let mut pos = 0;
    for w in l.split(|c: char| c.is_whitespace() || c == '(' || c == ')') {
        let here = l[pos..].find(w).map_or(pos, |x| pos + x);
        pos = here + w.len();
        if let Some((k, v)) = w.split_once('=') {
            let vstart = off + here + k.len() + 1;
            out.push((k, field_at(vstart, v), v));
        }
    }
    out
}

/// What a FANUC data file holds as text: the parameter comment's values, the reference
/// comment's position and unit, and the data lines by point number (N − 10000).
#[derive(Default)]
struct FanucFile {
    params: std::collections::HashMap<String, (usize, Field, f64)>,
    reference_mm: Option<f64>,
    unit_um: Option<f64>,
    data: std::collections::BTreeMap<u64, (usize, Field, i64)>,
    /// The axis the header comment names.
    axis: Option<Axis>,
    /// The last line's number.
    last: usize,
}

impl FanucFile {
    /// Reads the lines between the two `%`, refusing text after the second and a file
    /// without it.
    fn read(lines: &[(usize, &str)]) -> Result<FanucFile, At> {
        let mut file = FanucFile::default();
        let mut closed = false;
        for (i, &(off, l)) in lines.iter().enumerate().skip(1) {
            let line = i + 1;
            let t = l.trim();
            if t.is_empty() {
                continue;
            }
            if closed {
                return Err(At::new(line, "text after the closing `%`"));
            }
            if t == "%" {
                closed = true;
                continue;
            }
            if t.starts_with('(') {
                file.comment(line, off, l, t)?;
                continue;
            }
            file.data_line(line, off, l, t)?;
        }
        file.last = lines.len().max(1);
        if !closed {
            return Err(At::new(file.last, "no closing `%`: the file is cut short"));
        }
        Ok(file)
    }

    /// Takes the parameter and reference-position comments (other comments are notes).
    fn comment(&mut self, line: usize, off: usize, l: &str, t: &str) -> Result<(), At> {
        if let Some(rest) = t.strip_prefix("(AXIS ") {
            // `(AXIS <number> = <letter>, LINE AT …)`: the letter is the line's axis.
            self.axis = rest
                .split_once('=')
                .and_then(|(_, r)| r.split(',').next())
                .and_then(|a| a.trim().parse().ok());
        } else if t.starts_with("(PARAMETERS OF AXIS") {
            for (k, f, v) in fanuc_words(l, off) {
                let x = num(line, &format!("parameter {k}"), v.trim_end_matches("MM"))?;
                self.params.insert(k.to_string(), (line, f, x));
            }
        } else if let Some(rest) = t.strip_prefix("(REFERENCE POSITION ") {
            let w: Vec<&str> = rest.split_whitespace().collect();
            self.reference_mm = Some(num(
                line,
                "the reference position",
                w.first().copied().unwrap_or(""),
            )?);
            let u = w
                .iter()
                .position(|&x| x == "OF")
                .and_then(|j| w.get(j + 1))
                .copied()
                .unwrap_or("");
            self.unit_um = Some(num(line, "the unit", u)?);
        }
        Ok(())
    }

    /// Takes one `N<10000 + n>P<value>` line, refusing other numbers and repeats.
    fn data_line(&mut self, line: usize, off: usize, l: &str, t: &str) -> Result<(), At> {
        let parsed = t.strip_prefix('N').and_then(|r| r.split_once('P'));
        let Some((nt, vt)) = parsed else {
            return Err(At::new(line, format!("`{t}` is not `N<number>P<value>`")));
        };
        let n: u64 = nt
            .parse()
            .map_err(|_| At::new(line, format!("data number `{nt}` is not a number")))?;
        let v = number(vt)
            .filter(|v| v.fract() == 0.0 && v.abs() < 1e9)
            .ok_or_else(|| At::new(line, format!("value `{vt}` is not a whole number")))?;
        let vstart = off + l.find('P').unwrap_or(0) + 1;
        if n < 10000 {
            return Err(At::new(
                line,
                format!("data number {n}: pitch error data are 10000 + point number"),
            ));
        }
        if self
            .data
            .insert(n - 10000, (line, field_at(vstart, vt), v as i64))
            .is_some()
        {
            return Err(At::new(line, format!("point {} given twice", n - 10000)));
        }
        Ok(())
    }

    /// The parameter `k`, which errmap's comment always names.
    fn param(&self, k: &str) -> Result<(usize, Field, f64), At> {
        self.params.get(k).copied().ok_or_else(|| {
            At::new(
                1,
                format!(
                    "parameter {k} is not in the file: errmap reads the FANUC files it writes \
                     (their parameter comment names 3620–3624)"
                ),
            )
        })
    }

    /// The parameter `k` as a point number.
    fn point_number(&self, k: &str) -> Result<u64, At> {
        let (l, _, x) = self.param(k)?;
        if x.fract() == 0.0 && (0.0..1e6).contains(&x) {
            Ok(x as u64)
        } else {
            Err(At::new(l, format!("{k} = {x} is not a point number")))
        }
    }

    /// The `span + 1` increments from point `from`, each one required.
    fn take(&self, from: u64, span: u64) -> Result<Increments, At> {
        (from..=from + span)
            .map(|n| {
                self.data.get(&n).map(|&(_, f, v)| (f, v)).ok_or_else(|| {
                    At::new(self.last, format!("point {n} (N{}) is missing", 10000 + n))
                })
            })
            .collect()
    }
}

/// A FANUC pitch error data file as errmap writes it (`crate::export::fanuc`): `%`, the
/// parameter comments, `N<10000 + number>P<increment>` lines, `%`.
pub fn read(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    if lines.first().map(|l| l.1.trim()) != Some("%") {
        return Err(At::new(1, "not a FANUC data file (first line `%`)"));
    }
    let file = FanucFile::read(&lines)?;
    let (params, data, last) = (&file.params, &file.data, file.last);
    let r_num = file.point_number("3620")?;
    let first = file.point_number("3621")?;
    let lastn = file.point_number("3622")?;
    let (hl, _, h) = file.param("3624")?;
    let (Some(r_mm), Some(unit)) = (file.reference_mm, file.unit_um) else {
        return Err(At::new(
            1,
            "no `(REFERENCE POSITION … UNITS OF … UM)` comment",
        ));
    };
    if h <= 0.0 || unit <= 0.0 {
        return Err(At::new(hl, "3624 and the unit must be positive"));
    }
    if lastn < first || !(first.saturating_sub(1) <= r_num && r_num <= lastn) {
        return Err(At::new(
            hl,
            format!(
                "3620 = {r_num} is not within 3621 − 1 = {} … 3622 = {lastn}",
                first as i64 - 1
            ),
        ));
    }
    let bidir = params.get("3605#0").is_some_and(|x| x.2 == 1.0);
    let span = lastn - first;
    let forward = file.take(first, span)?;
    let reverse = if bidir {
        let s = file.point_number("3626")?;
        let (l3627, f3627, v3627) = file.param("3627")?;
        if v3627.fract() != 0.0 {
            return Err(At::new(l3627, "3627 is not a whole number"));
        }
        Some((file.take(s, span)?, (f3627, v3627 as i64)))
    } else {
        None
    };
    let used = forward.len() * if bidir { 2 } else { 1 };
    if data.len() != used {
        let extra = data
            .iter()
            .find(|(n, _)| {
                !(first..=lastn).contains(*n)
                    && !params
                        .get("3626")
                        .is_some_and(|s| bidir && (s.2 as u64..=s.2 as u64 + span).contains(*n))
            })
            .map_or(last, |(_, x)| x.0);
        return Err(At::new(
            extra,
            format!("{} data lines, the parameters name {used}", data.len()),
        ));
    }
    let k0 = (r_num + 1 - first) as usize;
    let absolute = |inc: &[(Field, i64)], at_ref: i64| -> Vec<i64> {
        let mut a = vec![0i64; inc.len() + 1];
        for j in 1..a.len() {
            a[j] = a[j - 1] + inc[j - 1].1;
        }
        let shift = at_ref - a[k0];
        a.iter().map(|x| x + shift).collect()
    };
    let up = absolute(&forward, 0);
    let down = match &reverse {
        Some((inc, (_, r))) => absolute(inc, *r),
        None => up.clone(),
    };
    let mut parsed = Parsed {
        axis: file.axis,
        bidirectional: bidir,
        ..Default::default()
    };
    for j in 0..up.len() {
        let pos = r_mm + (first as f64 - 1.0 + j as f64 - r_num as f64) * h;
        let line = if j == 0 {
            data.get(&first).map_or(1, |x| x.0)
        } else {
            data.get(&(first + j as u64 - 1)).map_or(1, |x| x.0)
        };
        let (eu, ed) = (up[j] as f64 * unit, down[j] as f64 * unit);
        check_point(line, pos, &[eu, ed])?;
        let dummy = Field {
            start: 0,
            end: 0,
            decimals: 0,
        };
        parsed.points.push(point(
            line,
            pos,
            eu,
            ed,
            up[j] as f64,
            down[j] as f64,
            dummy,
            dummy,
        ));
    }
    parsed.fanuc = Some(FanucLayout {
        unit_um: unit,
        reference_index: k0,
        forward,
        reverse,
    });
    Ok(parsed)
}

// ---------------------------------------------------------------------------------------
// The dialect

/// FANUC pitch error compensation data ([`super::DIALECTS`]).
#[derive(Debug, Clone, Copy)]
pub struct Fanuc;

/// The values: increments of e in units of detection unit × 3623.
pub const VALUE: Value = Value {
    sign: Sign::Error,
    unit: ValueUnit::Units,
};

impl Dialect for Fanuc {
    fn modulo(&self) -> Option<&dyn crate::controller::modulo::ModuloSyntax> {
        Some(self)
    }
    fn program(&self) -> Option<&dyn ProgramSyntax> {
        Some(self)
    }
    fn options(&self) -> &'static [DialectOption] {
        &OPTIONS
    }
    fn name(&self) -> &'static str {
        "fanuc"
    }
    fn controller(&self) -> &'static str {
        "FANUC"
    }
    fn about(&self) -> &'static str {
        "FANUC pitch error compensation: parameters and N/P data (a line)"
    }
    fn limits(&self) -> Limits {
        Limits {
            max_points: FANUC_MAX_POINT_NUMBER as usize + 1,
            spacing: Spacing::Equidistant,
            bidirectional: true,
            value: VALUE,
            axes: &[AxisKind::Linear],
        }
    }
    fn reads(&self) -> Vec<(TableSetting, String)> {
        vec![(
            TableSetting::AxisNumber,
            "the axis of parameters 3620–3627".into(),
        )]
    }
    fn detect(&self, _bytes: &[u8], text: &Text) -> bool {
        let lines = text.lines();
        lines.first().map(|l| l.1.trim()) == Some("%")
            && lines
                .iter()
                .take(10)
                .any(|(_, l)| l.trim_start().starts_with("(FANUC PITCH ERROR"))
    }
    fn table_format(&self, _: &TableSettings) -> Result<TableFormat, SettingsError> {
        Ok(TableFormat::Fanuc)
    }
    fn read(&self, text: &Text, _: TableFormat) -> Result<Parsed, At> {
        read(text)
    }
    fn update(&self, table: &ControllerTable, residual: &Residual, bidirectional: bool) -> Updated {
        match &table.fanuc {
            Some(layout) => update::update(table, layout, residual, bidirectional),
            None => crate::controller::update::update_values(table, residual, bidirectional),
        }
    }
    fn export_format(&self, s: &TableSettings, _: bool) -> Result<ExportFormat, SettingsError> {
        Ok(ExportFormat::Fanuc {
            spec: FanucSpec::from_settings(s),
        })
    }
}
