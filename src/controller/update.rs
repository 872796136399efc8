//! The recalibration: a controller table already in use, corrected by a session measured
//! with it active, written back in the file's own layout.
//!
//! The session's error is then the **residual** r the table leaves. At each table point Q
//! the new table compensates e_new(Q) = e_table(Q) + r(Q), per direction:
//!
//! * r at a target is the session's error-table mean (what `errmap table` gives); with
//!   `bidirectional`, r⁺ = −x̄↑ and r⁻ = −x̄↓ (ISO 230-2 means over runs; both directions
//!   are needed at every target);
//! * r(Q) is the target's value within 1e-6 mm, else linear between the neighbouring
//!   targets (the controllers' own rule between their points); a point outside the
//!   measured targets keeps its values (r = 0) and is listed in `outside_mm`;
//! * Fagor stores x = −e in file units: err_new = err_old − r/(k·1000); LinuxCNC stores
//!   e (trim) or nominal − e (actual), both in file units.
//!
//! Without `bidirectional` both directions get r and a unidirectional table stays one
//! (err− stays 0, BIDIR stays 0). With it, err+ := err+ − r⁺/(k·1000) and
//! err− := (err− if the table was bidirectional, else err+) − r⁻/(k·1000); an 8065 file
//! gets BIDIR 1.
//!
//! Only the values change: each is rounded to the decimals its field was written with, a
//! right-aligned number stays right-aligned in its padding, a value whose rounded number
//! is unchanged keeps its original text, and everything else (encoding, byte-order mark,
//! line ends, point numbers, every other parameter) is kept byte for byte — so a zero
//! residual gives the file back unchanged. No re-zeroing: a reference point whose value
//! becomes non-zero is written as computed.

use errmap_drivers::SessionRow;
use serde::Serialize;

use super::{ControllerSetting, ControllerTable, Field, ValueUnit};
use crate::base::{Axis, NamesSettings, Setting};
use crate::session::{ReductionError, error_table, iso_by_line};

/// Why an update cannot be made; a refusal of a table per direction names the setting
/// ([`ControllerSetting::Bidirectional`], [`NamesSettings::render`]).
#[derive(Debug, thiserror::Error)]
pub enum UpdateError {
    #[error(transparent)]
    Reduction(#[from] ReductionError),
    #[error("the session has no rows")]
    Empty,
    #[error("the session holds {lines} lines; a controller table is one line")]
    ManyLines { lines: usize },
    #[error("the session has no ISO 230-2 statistics: {reason}")]
    NoStatistics { reason: String },
    #[error("{}", self.render(&Setting::words))]
    MissingDirection {
        position_mm: f64,
        up: usize,
        down: usize,
    },
    #[error("{}", self.render(&Setting::words))]
    OneDirection { format: &'static str },
    #[error(
        "the session measures {session} but the table is for {table}{}",
        if *assumed { " (the file names no axis: it is the table's stated axis, x unless given)" } else { "" }
    )]
    AxisMismatch {
        session: Axis,
        table: Axis,
        /// The file names no axis; `table` is the caller's (or x).
        assumed: bool,
    },
}

impl NamesSettings for UpdateError {
    type Setting = ControllerSetting;
    fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        let bidirectional = name(ControllerSetting::Bidirectional);
        match self {
            UpdateError::MissingDirection {
                position_mm,
                up,
                down,
            } => format!(
                "{bidirectional} needs both directions at every target; the target at \
                 {position_mm} mm has {up} up and {down} down"
            ),
            UpdateError::OneDirection { format } => format!(
                "{bidirectional}: this {format} table holds one value per point for both \
                 directions; export a direction-dependent table from the session instead \
                 (export {bidirectional})"
            ),
            UpdateError::Reduction(_)
            | UpdateError::Empty
            | UpdateError::ManyLines { .. }
            | UpdateError::NoStatistics { .. }
            | UpdateError::AxisMismatch { .. } => self.to_string(),
        }
    }
}

/// The residual a session measured, per target.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    pub axis: Axis,
    pub positions_mm: Vec<f64>,
    /// r moving + (without `bidirectional`: the mean of both directions), µm.
    pub up_um: Vec<f64>,
    /// r moving − (without `bidirectional`: the same as `up_um`), µm.
    pub down_um: Vec<f64>,
}

impl Residual {
    /// From a session (see the module docs).
    pub fn from_session(rows: &[SessionRow], bidirectional: bool) -> Result<Residual, UpdateError> {
        let first = rows.first().ok_or(UpdateError::Empty)?;
        let axis = Axis::from(first.axis);
        if !bidirectional {
            let (table, _) = error_table("session", rows)?;
            let others: Vec<usize> = (0..3).filter(|&i| i != axis.index()).collect();
            let key = |p: &crate::table::ErrorPoint| {
                let c = [p.x_mm, p.y_mm, p.z_mm];
                (c[others[0]], c[others[1]])
            };
            let mut lines: Vec<(f64, f64)> = table.points.iter().map(key).collect();
            lines.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            lines.dedup();
            if lines.len() > 1 {
                return Err(UpdateError::ManyLines { lines: lines.len() });
            }
            let mut pts: Vec<(f64, f64)> = table
                .points
                .iter()
                .map(|p| ([p.x_mm, p.y_mm, p.z_mm][axis.index()], p.e_um))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            return Ok(Residual {
                axis,
                positions_mm: pts.iter().map(|p| p.0).collect(),
                up_um: pts.iter().map(|p| p.1).collect(),
                down_um: pts.iter().map(|p| p.1).collect(),
            });
        }
        let (lines, failed) = iso_by_line(rows);
        let stats = match (lines.as_slice(), failed.as_slice()) {
            ([one], []) => &one.1,
            ([], [(_, e)]) => {
                return Err(UpdateError::NoStatistics {
                    reason: e.to_string(),
                });
            }
            _ => {
                return Err(UpdateError::ManyLines {
                    lines: lines.len() + failed.len(),
                });
            }
        };
        let mut t = stats.targets.clone();
        t.sort_by(|a, b| a.position_mm.total_cmp(&b.position_mm));
        if let Some(bad) = t.iter().find(|s| s.n_up == 0 || s.n_down == 0) {
            return Err(UpdateError::MissingDirection {
                position_mm: bad.position_mm,
                up: bad.n_up,
                down: bad.n_down,
            });
        }
        Ok(Residual {
            axis,
            positions_mm: t.iter().map(|s| s.position_mm).collect(),
            // ISO deviations are x = −e.
            up_um: t.iter().map(|s| -s.mean_up_um).collect(),
            down_um: t.iter().map(|s| -s.mean_down_um).collect(),
        })
    }

    /// r at `q` mm in each direction, or `None` outside the targets.
    pub fn at(&self, q: f64) -> Option<(f64, f64)> {
        let p = &self.positions_mm;
        if let Some(i) = p.iter().position(|&x| (x - q).abs() <= 1e-6) {
            return Some((self.up_um[i], self.down_um[i]));
        }
        let i = p.windows(2).position(|w| w[0] < q && q < w[1])?;
        let f = (q - p[i]) / (p[i + 1] - p[i]);
        let lerp = |v: &[f64]| v[i] + f * (v[i + 1] - v[i]);
        Some((lerp(&self.up_um), lerp(&self.down_um)))
    }
}

/// What `export --existing --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UpdateSummary {
    pub format: &'static str,
    pub points: usize,
    /// 1 or 2: the directions of the table written.
    pub directions: usize,
    /// Table points outside the measured targets (kept as they were), mm.
    pub outside_mm: Vec<f64>,
    /// The largest change of a compensated error, µm.
    pub max_change_um: f64,
    pub warnings: Vec<String>,
}

/// The updated file and its summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Updated {
    pub bytes: Vec<u8>,
    pub summary: UpdateSummary,
}

/// `v` with `decimals` decimals and no `-0`.
pub(crate) fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.parse::<f64>() == Ok(0.0) => rest.to_string(),
        _ => s,
    }
}

/// Trailing zeros trimmed, one decimal kept (errmap's own LinuxCNC style).
fn trimmed(mut s: String) -> String {
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.push('0');
        }
    }
    s
}

/// A planned value replacement.
#[derive(Debug)]
pub(crate) struct Edit {
    pub(crate) field: Field,
    pub(crate) text: String,
    /// Right-align in the padding before the field (fixed-width layouts).
    pub(crate) align: bool,
}

/// Applies `edits` to `text`, right-aligning in the padding before each field.
pub(crate) fn apply(text: &str, mut edits: Vec<Edit>) -> String {
    edits.sort_by_key(|e| std::cmp::Reverse(e.field.start));
    let mut out = text.to_string();
    for e in edits {
        let (mut start, end) = (e.field.start, e.field.end);
        let width = end - start;
        let mut new = e.text;
        let padded = e.align && start > 0 && out.as_bytes()[start - 1] == b' ';
        if padded {
            if new.len() < width {
                new = format!("{}{new}", " ".repeat(width - new.len()));
            } else {
                // Take the extra characters from the padding, one space kept.
                let mut extra = new.len() - width;
                while extra > 0 && start >= 2 && &out[start - 2..start] == "  " {
                    start -= 1;
                    extra -= 1;
                }
            }
        }
        out.replace_range(start..end, &new);
    }
    out
}

/// How a column's new values are written: the decimals and whether trailing zeros are
/// trimmed.
#[derive(Debug, Clone, Copy)]
pub struct Digits {
    pub decimals: usize,
    pub trim: bool,
}

impl UpdateStyle {
    /// Fixed-width columns (Fagor, LinuxCNC): each column's decimals, right-aligned.
    pub const ALIGNED: UpdateStyle = UpdateStyle {
        trimmed_decimals: None,
        align: true,
        plus: false,
    };
}

/// How a dialect's values are written by the common update ([`super::Dialect::update_style`]):
/// the default keeps each column's decimals as the file shows them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UpdateStyle {
    /// The values are written at this many decimals with trailing zeros trimmed (the text
    /// shows fewer decimals than the field holds: Siemens, HEIDENHAIN).
    pub trimmed_decimals: Option<usize>,
    /// Fixed-width columns: a new number stays right-aligned in its padding.
    pub align: bool,
    /// A `+` written on positive values is kept (HEIDENHAIN).
    pub plus: bool,
}

/// The file's writing style, read once from the table: the two columns' digits, file
/// units per µm, right-alignment and HEIDENHAIN's `+`.
#[derive(Debug)]
struct Style {
    /// mm per file length unit.
    k: f64,
    up: Digits,
    down: Digits,
    scale_um: f64,
    align: bool,
    plus: bool,
}

impl Style {
    /// The style of `table`: its dialect's [`UpdateStyle`] and the table's own digits.
    fn of(table: &ControllerTable) -> Style {
        let text = &table.text.text;
        let format = table.format;
        let style = format.dialect().update_style();
        // Files written by errmap may trim trailing zeros: keep that style per column.
        let column = |pick: &dyn Fn(&super::TablePoint) -> Field| {
            let d: Vec<usize> = table.points.iter().map(|p| pick(p).decimals).collect();
            let max = d.iter().copied().max().unwrap_or(0);
            match style.trimmed_decimals {
                Some(decimals) => Digits {
                    decimals,
                    trim: true,
                },
                None => Digits {
                    decimals: max,
                    trim: d.iter().any(|&x| x < max),
                },
            }
        };
        // File units per µm of e.
        let scale_um = match format.value().unit {
            ValueUnit::TenthMicrometre => 0.1,
            ValueUnit::Length | ValueUnit::Units => 1000.0,
        };
        Style {
            k: format.units().mm(),
            up: column(&|p| p.up),
            down: column(&|p| p.down),
            scale_um,
            align: style.align,
            plus: style.plus
                && table
                    .points
                    .iter()
                    .any(|p| text[p.up.start..].starts_with('+')),
        }
    }
}

/// One point of the common update: the table, the point, the residual there (r⁺, r⁻, µm)
/// and whether both directions are updated (`--bidirectional`).
#[derive(Debug, Clone, Copy)]
pub struct PointUpdate<'a> {
    pub table: &'a ControllerTable,
    pub point: &'a super::TablePoint,
    pub r_up: f64,
    pub r_down: f64,
    pub bidirectional: bool,
}

/// Collects the value replacements and the largest change while the points are walked
/// (a dialect's [`super::Dialect::edit_point`] plans its point's edits on it).
#[derive(Debug)]
pub struct Editor {
    style: Style,
    edits: Vec<Edit>,
    max_change_um: f64,
}

impl Editor {
    /// mm per file length unit.
    pub fn k(&self) -> f64 {
        self.style.k
    }

    /// How the up and the down column's new values are written.
    pub fn digits(&self) -> (Digits, Digits) {
        (self.style.up, self.style.down)
    }

    /// [`Self::edit`] of a field whose value is the one the controller used.
    pub fn rewrite(&mut self, field: Field, old: f64, new: f64, digits: Digits) {
        self.edit(field, old, old, new, digits);
    }

    /// Plans writing `new` over `field` (whose value is `old`) unless it rounds to the same
    /// text; the change is measured from `effective`, the value the controller used before
    /// (err+ for the err− of a table that was one table for both directions).
    pub fn edit(&mut self, field: Field, old: f64, effective: f64, new: f64, digits: Digits) {
        let Digits { decimals, trim } = digits;
        let s = fixed(new, decimals);
        let rounded: f64 = s.parse().unwrap_or(new);
        let old_rounded: f64 = fixed(old, decimals).parse().unwrap_or(old);
        if rounded == old_rounded {
            return;
        }
        self.max_change_um = self
            .max_change_um
            .max((rounded - effective).abs() * self.style.k * self.style.scale_um);
        let mut s = if trim { trimmed(s) } else { s };
        if self.style.plus && !s.starts_with('-') {
            s.insert(0, '+');
        }
        self.edits.push(Edit {
            field,
            text: s,
            align: self.style.align,
        });
    }
}

/// Updates `table` by `residual` (see the module docs), through its dialect's
/// [`super::Dialect::update`].
pub fn update_table(
    table: &ControllerTable,
    residual: &Residual,
    bidirectional: bool,
) -> Result<Updated, UpdateError> {
    check_update(table, residual, bidirectional)?;
    Ok(table
        .format
        .dialect()
        .update(table, residual, bidirectional))
}

/// The common update ([`super::Dialect::update`]'s default): each point's values
/// rewritten by its dialect's [`super::Dialect::edit_point`] in the file's own style.
pub(crate) fn update_values(
    table: &ControllerTable,
    residual: &Residual,
    bidirectional: bool,
) -> Updated {
    let dialect = table.format.dialect();
    let text = &table.text.text;
    let mut outside_mm = Vec::new();
    let mut editor = Editor {
        style: Style::of(table),
        edits: Vec::new(),
        max_change_um: 0.0,
    };
    let becomes_bidirectional = bidirectional && !table.bidirectional;
    for p in &table.points {
        let (r_up, r_down) = match residual.at(p.position_mm) {
            Some(r) => r,
            None => {
                outside_mm.push(p.position_mm);
                (0.0, 0.0)
            }
        };
        // Nothing to add: the point's text stays as it is (a zero residual gives the
        // file back whatever the float arithmetic would round).
        if r_up == 0.0 && r_down == 0.0 && !becomes_bidirectional {
            continue;
        }
        let point = PointUpdate {
            table,
            point: p,
            r_up,
            r_down,
            bidirectional,
        };
        dialect.edit_point(&mut editor, &point);
    }
    let Editor {
        mut edits,
        max_change_um,
        ..
    } = editor;
    if becomes_bidirectional && let Some(f) = table.bidir_value {
        edits.push(Edit {
            field: f,
            text: "1".into(),
            align: false,
        });
        if let Some(c) = table.bidir_comment
            && &text[c.start..c.end] == "No"
        {
            edits.push(Edit {
                field: c,
                text: "Yes".into(),
                align: false,
            });
        }
    }
    let warnings = outside_warning(&outside_mm, residual);
    let new_text = apply(text, edits);
    let directions = if bidirectional || table.bidirectional {
        2
    } else {
        1
    };
    Updated {
        bytes: table.text.encode(&new_text),
        summary: UpdateSummary {
            format: table.format.name(),
            points: table.points.len(),
            directions,
            outside_mm,
            max_change_um,
            warnings,
        },
    }
}

/// Refuses an update the table cannot take: another axis, or two directions into a
/// one-direction table.
fn check_update(
    table: &ControllerTable,
    residual: &Residual,
    bidirectional: bool,
) -> Result<(), UpdateError> {
    // Every dialect: the file's axis, else the one its user stated, else x (as `import`
    // reads such a table).
    let table_axis = table.axis.unwrap_or(Axis::X);
    if table_axis != residual.axis {
        return Err(UpdateError::AxisMismatch {
            session: residual.axis,
            table: table_axis,
            assumed: table.axis.is_none() || table.axis_assumed,
        });
    }
    if bidirectional
        && (table.one_column || table.fanuc.as_ref().is_some_and(|f| f.reverse.is_none()))
    {
        return Err(UpdateError::OneDirection {
            format: table.format.name(),
        });
    }
    Ok(())
}

/// The common plan of one point's new values ([`super::Dialect::edit_point`]'s default),
/// `r` = (r_up, r_down) the residual there: each value is its dialect's [`super::Value`]
/// of e + r in the file's unit (c = −e in mm for Siemens and HEIDENHAIN, in 0.1 µm for
/// ISG); a one-column table has no second value, and a second column that repeats the
/// first (an ISG list with `bilateral` 0) keeps doing so.
pub(crate) fn edit_values(editor: &mut Editor, u: &PointUpdate) {
    let PointUpdate {
        table,
        point: p,
        r_up,
        r_down,
        bidirectional,
    } = *u;
    let k = editor.k();
    let (up_digits, down_digits) = editor.digits();
    let value = |e_um: f64| table.format.value().file(e_um, k);
    editor.rewrite(p.up, p.up_file, value(p.e_up_um + r_up), up_digits);
    if table.one_column {
        return;
    }
    let down_e = if table.bidirectional {
        p.e_down_um + r_down
    } else if bidirectional {
        p.e_up_um + r_down
    } else if p.down_file == p.up_file {
        p.e_up_um + r_up
    } else {
        return;
    };
    editor.rewrite(p.down, p.down_file, value(down_e), down_digits);
}

/// The warning for table points outside the measured targets.
pub(crate) fn outside_warning(outside_mm: &[f64], residual: &Residual) -> Vec<String> {
    if outside_mm.is_empty() {
        return Vec::new();
    }
    let lo = residual.positions_mm.first().copied().unwrap_or(f64::NAN);
    let hi = residual.positions_mm.last().copied().unwrap_or(f64::NAN);
    vec![format!(
        "{} table point(s) outside the measured {lo} … {hi} mm keep their values: {}",
        outside_mm.len(),
        outside_mm
            .iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(", ")
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::{LengthUnit, TableFormat, read};

    const ALX: &str = "      P001          X    0.00000       EX    0.00000        EX    0.00000\r\n      P002          X   10.00000       EX   -0.00127        EX    0.00000\r\n      P003          X   20.00000       EX    0.00200        EX    0.00000\r\n";

    fn residual(up: [f64; 3], down: [f64; 3]) -> Residual {
        Residual {
            axis: Axis::X,
            positions_mm: vec![0.0, 254.0, 508.0],
            up_um: up.to_vec(),
            down_um: down.to_vec(),
        }
    }

    fn fagor() -> ControllerTable {
        read(
            ALX.as_bytes(),
            TableFormat::Fagor8055 {
                units: LengthUnit::Inch,
            },
        )
        .expect("table")
    }

    #[test]
    fn a_zero_residual_gives_the_file_back() {
        let u = update_table(&fagor(), &residual([0.0; 3], [0.0; 3]), false).expect("update");
        assert_eq!(u.bytes, ALX.as_bytes());
        assert_eq!(u.summary.max_change_um, 0.0);
    }

    /// r = +25.4 µm (the axis over-reads by 0.001 in more than the table corrects):
    /// err_new = err_old − 0.001 in, right-aligned in the same padding.
    #[test]
    fn a_residual_is_added_in_the_fagor_sign_and_layout() {
        let u = update_table(&fagor(), &residual([25.4; 3], [25.4; 3]), false).expect("update");
        let text = String::from_utf8(u.bytes).expect("ascii");
        let lines: Vec<&str> = text.split("\r\n").collect();
        assert_eq!(
            lines[0],
            "      P001          X    0.00000       EX   -0.00100        EX    0.00000"
        );
        assert_eq!(
            lines[1],
            "      P002          X   10.00000       EX   -0.00227        EX    0.00000"
        );
        assert_eq!(
            lines[2],
            "      P003          X   20.00000       EX    0.00100        EX    0.00000"
        );
        assert_eq!(text.len(), ALX.len());
        assert!((u.summary.max_change_um - 25.4).abs() < 1e-9);
    }

    /// Between targets the residual is interpolated linearly; both directions when asked,
    /// err− starting from err+ on a unidirectional table.
    #[test]
    fn bidirectional_update_of_a_unidirectional_table() {
        let r = Residual {
            axis: Axis::X,
            positions_mm: vec![0.0, 508.0],
            up_um: vec![0.0, 25.4],
            down_um: vec![-25.4, -25.4],
        };
        let u = update_table(&fagor(), &r, true).expect("update");
        let t = read(
            &u.bytes,
            TableFormat::Fagor8055 {
                units: LengthUnit::Inch,
            },
        )
        .expect("reads back");
        let up: Vec<f64> = t.points.iter().map(|p| p.up_file).collect();
        let down: Vec<f64> = t.points.iter().map(|p| p.down_file).collect();
        assert_eq!(up, [0.0, -0.00177, 0.001]);
        assert_eq!(down, [0.001, -0.00027, 0.003]);
        assert_eq!(u.summary.directions, 2);
    }

    #[test]
    fn points_outside_the_targets_keep_their_values() {
        let r = Residual {
            axis: Axis::X,
            positions_mm: vec![100.0, 300.0],
            up_um: vec![25.4, 25.4],
            down_um: vec![25.4, 25.4],
        };
        let u = update_table(&fagor(), &r, false).expect("update");
        assert_eq!(u.summary.outside_mm, [0.0, 508.0]);
        let text = String::from_utf8(u.bytes).expect("ascii");
        assert!(text.contains("EX   -0.00227"), "{text}");
        assert!(text.contains("EX    0.00200"), "{text}");
    }

    #[test]
    fn the_axis_must_match() {
        let mut r = residual([0.0; 3], [0.0; 3]);
        r.axis = Axis::Y;
        assert!(matches!(
            update_table(&fagor(), &r, false),
            Err(UpdateError::AxisMismatch { .. })
        ));
    }
}
