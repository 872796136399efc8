//! FANUC's modulo table of a rotary axis ([`crate::controller::modulo`]): pitch error
//! compensation parameters 3620–3625 and the increments of one revolution, which sum to
//! 0, the reference point's equal to the last one's (FANUC 0i-PB parameter manual, as
//! the contract cites it; not read here).

use std::fmt::Write as _;

use super::Fanuc;
use crate::controller::Field;
use crate::controller::modulo::{
    Counts, ModuloChange, ModuloError, ModuloRead, ModuloSpec, ModuloSyntax, ModuloTable, deg6,
};
use crate::controller::modulo_update as mu;

/// FANUC's increments of the absolute curve `abs` (counts): v_j = abs_j − abs_{j−1} for
/// j ≥ 1 (a revolution sums to abs_last − abs_0), v₀ = v_last; each within
/// `--fanuc-max-value`, else the refusal naming a magnification that fits.
fn increments(abs: &[i64], spec: &ModuloSpec) -> Result<Vec<i64>, ModuloError> {
    let mut v: Vec<i64> = vec![0; abs.len()];
    for j in 1..abs.len() {
        v[j] = abs[j] - abs[j - 1];
    }
    v[0] = *v.last().unwrap_or(&0);
    if let Some((point, &value)) = v
        .iter()
        .enumerate()
        .find(|(_, x)| x.unsigned_abs() > u64::from(spec.fanuc_max_value))
    {
        let worst = v.iter().map(|x| x.unsigned_abs()).max().unwrap_or(0) as f64;
        let fits = (worst * f64::from(spec.magnification.max(1))
            / f64::from(spec.fanuc_max_value.max(1)))
        .ceil() as u32;
        return Err(ModuloError::FanucRange {
            value,
            point,
            max: spec.fanuc_max_value,
            fits: fits.max(spec.magnification + 1),
        });
    }
    Ok(v)
}

/// FANUC: increments of E = e′ − e′(R) in detection units × magnification, rounded as
/// absolute values then differenced (so a revolution sums to 0 exactly); v₀ = v_last.
fn write(t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<f64>, ModuloError> {
    let unit_arcsec = spec.detection_unit_deg * 3600.0 * f64::from(spec.magnification.max(1));
    // E = −c; absolute values rounded.
    let abs: Vec<i64> = t
        .c_arcsec
        .iter()
        .map(|c| (-c / unit_arcsec).round() as i64)
        .collect();
    let v = increments(&abs, spec)?;
    let p = spec.fanuc_reference_number;
    let step = t.step_deg.unwrap_or(0.0);
    let k = v.len().saturating_sub(1) as u32;
    let mut s = String::new();
    let _ = writeln!(s, "%");
    let _ = writeln!(
        s,
        "(errmap: rotary axis {} pitch error, detection unit {} deg, closure gap {:.3} arcsec left out: correct the ratio)",
        spec.axis.upper(),
        spec.detection_unit_deg,
        t.closure_gap_arcsec
    );
    let _ = writeln!(
        s,
        "(3620={p} 3621={p} 3622={} 3623={} 3624={} 3625=360)",
        p + k,
        spec.magnification,
        deg6(step)
    );
    for (j, x) in v.iter().enumerate() {
        let _ = writeln!(s, "N{}P{x}", 10000 + p as usize + j);
    }
    let _ = writeln!(s, "%");
    t.text = s;
    // The compensation the controller applies: −E summed from the increments.
    let mut sum = 0i64;
    Ok(v.iter()
        .enumerate()
        .map(|(j, x)| {
            if j > 0 {
                sum += x;
            }
            -(sum as f64) * unit_arcsec
        })
        .collect())
}

/// `key=value` pairs of FANUC's parameter comment.
fn parameters(body: &str) -> Vec<(u32, &str)> {
    body.trim_matches(|c| c == '(' || c == ')')
        .split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .filter_map(|(k, v)| Some((k.parse().ok()?, v)))
        .collect()
}

impl ModuloSyntax for Fanuc {
    fn equidistant(&self) -> bool {
        true
    }
    fn default_max_points(&self) -> usize {
        1024
    }
    fn render(&self, t: &mut ModuloTable, spec: &ModuloSpec) -> Result<Vec<Vec<f64>>, ModuloError> {
        write(t, spec).map(|c| vec![c])
    }
    fn read(&self, text: &str, spec: &ModuloSpec) -> Result<ModuloRead, ModuloError> {
        let mut params: Option<(usize, Vec<(u32, &str)>)> = None;
        let mut unit_deg = spec.detection_unit_deg;
        let mut increments: Vec<(usize, usize, Field, i64)> = Vec::new();
        for (line, offset, body) in mu::lines(text) {
            if body.contains("3620=") {
                params = Some((line, parameters(body)));
            } else if body.starts_with('(') {
                let words: Vec<&str> = body.split_whitespace().collect();
                if let Some(k) = words.iter().position(|w| *w == "axis") {
                    let a = words.get(k + 1).map_or("", |w| w.trim_end_matches(','));
                    if !a.eq_ignore_ascii_case(spec.axis.upper().to_string().as_str()) {
                        return Err(mu::at(
                            line,
                            format!("the table is for axis {a}, not {}", spec.axis.upper()),
                        ));
                    }
                }
                if let Some(k) = words.iter().position(|w| *w == "unit") {
                    unit_deg = words
                        .get(k + 1)
                        .and_then(|w| w.parse().ok())
                        .unwrap_or(unit_deg);
                }
            } else if let Some(rest) = body.strip_prefix('N') {
                let (n, v) = rest
                    .split_once('P')
                    .ok_or_else(|| mu::at(line, "a FANUC line is `N<number>P<value>`"))?;
                let n: usize = n
                    .parse()
                    .map_err(|_| mu::at(line, format!("`N{n}` is not a point number")))?;
                let value: i64 = v
                    .parse()
                    .map_err(|_| mu::at(line, format!("`P{v}` is not a whole number")))?;
                let start = offset + body.len() - v.len();
                increments.push((n, line, mu::field(start, start + v.len(), v), value));
            }
        }
        let (pline, params) =
            params.ok_or_else(|| mu::at(1, "no parameter comment `(3620=… 3625=360)`"))?;
        let get = |k: u32| -> Result<f64, ModuloError> {
            params
                .iter()
                .find(|p| p.0 == k)
                .and_then(|p| p.1.parse().ok())
                .ok_or_else(|| mu::at(pline, format!("parameter {k} is missing")))
        };
        let (p, magnification, step) = (get(3620)?, get(3623)?, get(3624)?);
        if get(3625)? != 360.0 {
            return Err(mu::at(pline, "3625 is not 360: not a rotary axis' table"));
        }
        if get(3621)? != p || get(3622)? != p + increments.len().saturating_sub(1) as f64 {
            return Err(mu::at(
                pline,
                "3621 and 3622 are not 3620 and 3620 + 360/3624",
            ));
        }
        let unit_arcsec = unit_deg * 3600.0 * magnification.max(1.0);
        let mut t = ModuloRead::default();
        let mut sum = 0i64;
        for (j, &(n, line, f, v)) in increments.iter().enumerate() {
            if n != 10000 + p as usize + j {
                return Err(mu::at(
                    line,
                    format!("point N{n} where N{} was expected", 10000 + p as usize + j),
                ));
            }
            if j > 0 {
                sum += v;
            }
            t.angles.push(j as f64 * step);
            t.lines.push(line);
            t.up.push(f);
            t.down.push(None);
            t.c_up.push(-(sum as f64) * unit_arcsec);
        }
        let last = t.lines.last().copied().unwrap_or(pline);
        if sum != 0 {
            return Err(mu::at(
                last,
                format!("the increments of a revolution sum to {sum}, not 0"),
            ));
        }
        if increments.first().map(|i| i.3) != increments.last().map(|i| i.3) {
            return Err(mu::at(
                t.lines[0],
                "the reference point's value differs from the last point's",
            ));
        }
        t.c_down = t.c_up.clone();
        t.step_line = pline;
        t.counts = Some(Counts {
            unit_arcsec,
            increments: increments.iter().map(|i| (i.2, i.3)).collect(),
        });
        Ok(t)
    }
    /// Unused: its increments are written by [`Self::edits`].
    fn encode(&self, _spec: &ModuloSpec, _q: f64, _c: f64, _field: Field, old: &str) -> String {
        old.to_string()
    }
    /// The absolute curve gets the change of E = −c (the change of c at each point, ″),
    /// rounded, differenced again; v₀ = v_last.
    fn edits(
        &self,
        old: &ModuloRead,
        _text: &str,
        change: &ModuloChange<'_>,
        spec: &ModuloSpec,
    ) -> Result<Vec<(Field, String)>, ModuloError> {
        let Some(f) = &old.counts else {
            return Ok(Vec::new());
        };
        let mut absolute = Vec::with_capacity(change.up.len());
        let mut sum = 0i64;
        for (j, (inc, d)) in f.increments.iter().zip(change.up).enumerate() {
            if j > 0 {
                sum += inc.1;
            }
            absolute.push(sum + (-d / f.unit_arcsec).round() as i64);
        }
        let v = increments(&absolute, spec)?;
        Ok(f.increments
            .iter()
            .zip(&v)
            .filter(|(old, new)| old.1 != **new)
            .map(|(old, new)| (old.0, new.to_string()))
            .collect())
    }
}
