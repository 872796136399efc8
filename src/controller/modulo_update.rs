//! The recalibration of a rotary axis: a modulo table already in use (`export --existing`),
//! corrected by a session measured with it active, written back in the file's own layout
//! (`docs/rotary.md`, "Updating a modulo table in use").
//!
//! The session's error is then the **residual** the table leaves. Each direction d's
//! residual r_d (the rotary error table's e, or e↑ = −x̄↑ and e↓ = −x̄↓ with
//! `--bidirectional`) is detrended by its own closure gap, as [`super::modulo`] does
//! (the gap is a ratio error the table cannot carry: reported), and the table's
//! compensation at each of its points q becomes
//!
//! c_new,d(q) = c_old,d(q) − (r′_d(q) − r̄′(R)),  r̄′(R) the mean of the directions' r′_d(R),
//!
//! so the reference position R keeps its correction (on average over the directions) and
//! the two ends, 0° and 360°, keep equal corrections. Without `--bidirectional` a
//! one-direction table stays one (Fagor's err− stays all 0); LinuxCNC's reverse column
//! gets the same change as its forward one.
//!
//! Every modulo rule is checked on the table read (refused, naming the line, when broken:
//! 0 and 360 first and last, equal end corrections, Siemens `IS_MODULO = 1`, `_MIN` 0,
//! `_MAX` 360, FANUC's increments summing to 0 and v₀ = v_last, the axis and the step) and
//! kept on the result, which is read back through the same checks. Only the values change:
//! each is rounded to the decimals its field was written with (at least 6 for the
//! ° tables, 4 for Fagor), a value whose text does not change keeps it, and everything
//! else is kept byte for byte — so a zero residual gives the file back unchanged.
//! FANUC: the absolute curve A_j = Σ_{1..j} v (detection units × magnification) gets
//! the change of E = −c, rounded as absolute values, and is differenced again, so a
//! revolution still sums to 0 exactly.

use super::modulo::{
    DirectionsSummary, MAX_TARGETS, ModuloChange, ModuloError, ModuloRead, ModuloSpec,
    ModuloSyntax, ModuloTable, check_revolution, detrended, interp,
};
use super::update::{Edit, apply};
use super::{ControllerSetting, Field};
use crate::base::NamesSettings;

/// The refusal of the table in use at `line`.
pub(super) fn at(line: usize, problem: impl Into<String>) -> ModuloError {
    ModuloError::Existing {
        line,
        problem: problem.into(),
    }
}

pub(super) fn mismatch(line: usize, mismatch: TableMismatch) -> ModuloError {
    ModuloError::Mismatch { line, mismatch }
}

/// A table in use that does not fit a setting of the update: the step or the axis it
/// was asked to have (`ModuloError::Mismatch`).
#[derive(Debug, Clone, PartialEq)]
pub enum TableMismatch {
    /// Its `points` are not every `step_deg`.
    Step { step_deg: f64, points: usize },
    /// A Siemens table for the axis `found`, not `expected`.
    SiemensAxis { found: String, expected: String },
    /// A HEIDENHAIN table without the column `key`.
    AxisName { key: String },
}

impl TableMismatch {
    /// The mismatch with the setting called by `name`.
    pub fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        match self {
            TableMismatch::Step { step_deg, points } => format!(
                "the table's points are not every {step_deg}° as {} says ({points} points)",
                name(ControllerSetting::Step)
            ),
            TableMismatch::SiemensAxis { found, expected } => format!(
                "the table is for axis {found}, not {expected} ({})",
                name(ControllerSetting::SiemensAxis)
            ),
            TableMismatch::AxisName { key } => format!(
                "no column {key} (the table is for another axis: {})",
                name(ControllerSetting::AxisName)
            ),
        }
    }
}

impl NamesSettings for ModuloError {
    type Setting = ControllerSetting;
    fn render(&self, name: &dyn Fn(ControllerSetting) -> &'static str) -> String {
        match self {
            ModuloError::Mismatch { line, mismatch } => {
                format!("line {line}: {}", mismatch.render(name))
            }
            // The rest name no setting (a variant added to `modulo.rs` falls here).
            other => other.to_string(),
        }
    }
}

/// The whitespace-separated words of `line` (starting at byte `offset` of the text) with
/// their byte ranges in the text.
pub(super) fn words(line: &str, offset: usize) -> Vec<(Field, &str)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, ch) in line
        .char_indices()
        .chain(std::iter::once((line.len(), ' ')))
    {
        match (ch.is_whitespace(), start) {
            (true, Some(s)) => {
                let w = &line[s..i];
                out.push((field(offset + s, offset + i, w), w));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    out
}

pub(super) fn field(start: usize, end: usize, w: &str) -> Field {
    Field {
        start,
        end,
        decimals: w.split_once('.').map_or(0, |(_, d)| d.len()),
    }
}

pub(super) fn number(line: usize, w: &str, what: &str) -> Result<f64, ModuloError> {
    w.trim_start_matches('+')
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| at(line, format!("{what} `{w}` is not a number")))
}

/// The text's lines with their 1-based numbers and byte offsets (line ends dropped).
pub(super) fn lines(text: &str) -> Vec<(usize, usize, &str)> {
    let mut out = Vec::new();
    let mut offset = 0;
    for (k, l) in text.split_inclusive('\n').enumerate() {
        let body = l.trim_end_matches(['\n', '\r']);
        out.push((k + 1, offset, body));
        offset += l.len();
    }
    out
}

/// Reads the modulo table `text` of `spec`'s dialect and checks its rules.
fn read(text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
    let mut t = spec.syntax()?.read(text, spec)?;
    check_read(&mut t, spec)?;
    Ok(t)
}

/// The rules every modulo table keeps: 0 first, 360 last, increasing, equal ends, the
/// step `--step` names, at most [`MAX_TARGETS`] points.
fn check_read(t: &mut ModuloRead, spec: &ModuloSpec) -> Result<(), ModuloError> {
    let n = t.angles.len();
    let last = *t.lines.last().unwrap_or(&1);
    if n < 2 {
        return Err(at(last, "fewer than two points: not a modulo table"));
    }
    if n > MAX_TARGETS {
        return Err(at(
            t.lines[MAX_TARGETS],
            format!("more than {MAX_TARGETS} points"),
        ));
    }
    if t.angles[0].abs() > 1e-9 {
        return Err(at(
            t.lines[0],
            format!("the first point is at {}°, not 0°", t.angles[0]),
        ));
    }
    if (t.angles[n - 1] - 360.0).abs() > 1e-9 {
        return Err(at(
            t.lines[n - 1],
            format!(
                "the last point is at {}°, not 360°: not a modulo table",
                t.angles[n - 1]
            ),
        ));
    }
    if let Some(k) = (1..n).find(|&k| t.angles[k] <= t.angles[k - 1]) {
        return Err(at(t.lines[k], "the angles do not increase"));
    }
    for (c, what) in [(&t.c_up, "moving +"), (&t.c_down, "moving −")] {
        if (c[0] - c[n - 1]).abs() > 1e-6 {
            return Err(at(
                t.lines[n - 1],
                format!(
                    "the corrections at 0° and 360° differ ({what}: {:.4}″ and {:.4}″): a \
                     modulo table has equal ends",
                    c[0],
                    c[n - 1]
                ),
            ));
        }
    }
    if let Some(s) = spec.step_deg {
        let k = (360.0 / s).round() as usize;
        let bad = (n != k + 1)
            .then_some(1)
            .or_else(|| (0..n).find(|&j| (t.angles[j] - j as f64 * s).abs() > 1e-6));
        if let Some(j) = bad {
            return Err(mismatch(
                if j == 1 { t.step_line } else { t.lines[j] },
                TableMismatch::Step {
                    step_deg: s,
                    points: n,
                },
            ));
        }
    }
    Ok(())
}

/// The common update's new value texts ([`ModuloSyntax::edits`]): each point's value(s)
/// through the dialect's encoder, a value that reads as the same number left alone; the
/// moving − column is written where the result holds two directions or the column
/// repeats moving + ([`ModuloRead::repeats`]).
pub(super) fn value_edits<M: ModuloSyntax + ?Sized>(
    m: &M,
    old: &ModuloRead,
    text: &str,
    change: &ModuloChange<'_>,
    spec: &ModuloSpec,
) -> Vec<(Field, String)> {
    let same = |a: &str, b: &str| {
        a.trim_start_matches('+').parse::<f64>().ok()
            == b.trim_start_matches('+').parse::<f64>().ok()
    };
    let mut edits = Vec::new();
    let mut edit = |f: Field, c: f64, q: f64| {
        let old_text = &text[f.start..f.end];
        let new = m.encode(spec, q, c, f, old_text);
        if !same(old_text, &new) {
            edits.push((f, new));
        }
    };
    for k in 0..old.angles.len() {
        let q = old.angles[k];
        edit(old.up[k], old.c_up[k] + change.up[k], q);
        if let Some(f) = old.down[k].filter(|_| change.two || old.repeats) {
            edit(f, old.c_down[k] + change.down[k], q);
        }
    }
    edits
}

/// The modulo table in use (`bytes`) updated by the residual `series` measured with it
/// active: one series (both directions) or two (moving +, moving −); see the module docs.
pub fn update_modulo(
    bytes: &[u8],
    series: &[&[(f64, f64)]],
    spec: &ModuloSpec,
) -> Result<ModuloTable, ModuloError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        at(line, "not text (UTF-8 or ASCII)")
    })?;
    for s in series {
        check_revolution(s)?;
    }
    let m = spec.syntax()?;
    if series.len() == 2 && m.equidistant() {
        return Err(ModuloError::OneDirection {
            format: spec.dialect.name(),
        });
    }
    let old = read(text, spec)?;
    let r = spec.reference_deg;
    if !old.angles.iter().any(|a| (a - r).abs() <= 1e-9) {
        return Err(ModuloError::Reference {
            reference_deg: r,
            hint: "one of the table's points".into(),
        });
    }
    let (v, gaps): (Vec<Vec<(f64, f64)>>, Vec<f64>) = series.iter().map(|s| detrended(s)).unzip();
    let datums: Vec<f64> = v.iter().map(|v| interp(v, r)).collect();
    let datum = datums.iter().sum::<f64>() / datums.len() as f64;
    let delta = |v: &[(f64, f64)]| -> Vec<f64> {
        old.angles
            .iter()
            .map(|&q| -(interp(v, q) - datum))
            .collect()
    };
    let (d_up, d_down) = (delta(&v[0]), delta(&v[v.len() - 1]));
    let change = ModuloChange {
        up: &d_up,
        down: &d_down,
        two: series.len() == 2 || old.two,
    };
    let align = !m.equidistant();
    let edits = m
        .edits(&old, text, &change, spec)?
        .into_iter()
        .map(|(field, text)| Edit { field, text, align })
        .collect();
    let new_text = apply(text, edits);
    let new = read(&new_text, spec)?;
    summary(spec, &old, new, new_text, &v, &gaps, &datums)
}

/// What the update reports: the residual's closure gaps, the change at the points and
/// the residual left at the targets (the change interpolated between points).
fn summary(
    spec: &ModuloSpec,
    old: &ModuloRead,
    new: ModuloRead,
    text: String,
    v: &[Vec<(f64, f64)>],
    gaps: &[f64],
    datums: &[f64],
) -> Result<ModuloTable, ModuloError> {
    let datum = datums.iter().sum::<f64>() / datums.len() as f64;
    let change = |c_new: &[f64], c_old: &[f64]| -> Vec<(f64, f64)> {
        old.angles
            .iter()
            .zip(c_new.iter().zip(c_old))
            .map(|(&q, (a, b))| (q, a - b))
            .collect()
    };
    let changes = [
        change(&new.c_up, &old.c_up),
        change(&new.c_down, &old.c_down),
    ];
    let max_change = changes
        .iter()
        .flatten()
        .map(|c| c.1.abs())
        .fold(0.0, f64::max);
    let residuals: Vec<f64> = v
        .iter()
        .enumerate()
        .map(|(d, v)| {
            v.iter()
                .map(|&(q, e)| (e - datum + interp(&changes[d], q)).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let g = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let mut warnings = Vec::new();
    if g.abs() > 1e-9 {
        warnings.push(format!(
            "the residual's closure gap {g:.3}″ ({:.3} ppm) is left out of the table: a modulo \
             table cannot carry a ratio error; correct the ratio",
            g / 1.296
        ));
    }
    let directions = match (gaps, datums, residuals.as_slice()) {
        ([gu, gd], [du, dd], [ru, rd]) => Some(DirectionsSummary {
            closure_gap_up_arcsec: *gu,
            closure_gap_down_arcsec: *gd,
            datum_up_arcsec: *du,
            datum_down_arcsec: *dd,
            max_residual_up_arcsec: *ru,
            max_residual_down_arcsec: *rd,
        }),
        _ => None,
    };
    Ok(ModuloTable {
        text,
        format: spec.dialect.name(),
        axis: spec.axis,
        points: new.angles.len(),
        step_deg: spec.syntax()?.equidistant().then(|| new.angles[1]),
        reference_deg: spec.reference_deg,
        closure_gap_arcsec: g,
        ratio_ppm: g / 1.296,
        datum_offset_arcsec: datum,
        max_residual_arcsec: residuals.iter().copied().fold(0.0, f64::max),
        max_change_arcsec: Some(max_change),
        c_down_arcsec: (new.two || new.repeats).then(|| new.c_down.clone()),
        c_arcsec: new.c_up,
        points_deg: new.angles,
        directions,
        warnings,
    })
}
