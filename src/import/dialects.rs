//! The other compensation files errmap writes (`crate::export`), read back: Siemens 840D
//! LEC/MSEC (`%_N_AX_EEC_INI`) and direction-dependent CEC (`%_N_NC_CEC_INI`), HEIDENHAIN
//! `.COM`, TwinCAT CNC (ISG) `kw.ssfk` lists and FANUC pitch error data. Each reader gives
//! the table points in errmap's sign and where each value sits in the text, so that
//! [`super::update`] rewrites the values and nothing else.
//!
//! | file | value v at a point | e (µm) |
//! |---|---|---|
//! | Siemens LEC `$AA_ENC_COMP[e,N,AX]`, CEC `$AN_CEC[t,N]` | c, mm; position MIN + N·STEP | −v·1000 |
//! | HEIDENHAIN `.COM` (`NR AXISPOS <axis>`) | c, mm | −v·1000 |
//! | ISG `kw.ssfk.table[i].pos/neg` (`unit` 1) | c, 0.1 µm | −v/10 |
//! | FANUC `N<10000+n>P<v>` | increments of e in units of detection unit × 3623 | Σ increments from the reference position |
//!
//! These are the layouts errmap writes, documented in the exporters' modules with the
//! sources they come from; files written by a controller or another tool may differ (they
//! are refused at the line that does not fit, never guessed). A FANUC data file needs
//! errmap's parameter comment (3620–3624, 3605#0, 3626, 3627, the reference position and
//! the unit): a punched file from a control does not state them and is refused.

use super::At;
use super::tables::{Field, TablePoint};
use super::text::{Text, decimals, number};
use crate::base::Axis;

/// What a dialect reader found (see [`super::tables::ControllerTable`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Parsed {
    pub axis: Option<Axis>,
    pub points: Vec<TablePoint>,
    pub bidirectional: bool,
    /// The field saying whether the table is direction-dependent (ISG `bilateral`).
    pub bidir_value: Option<Field>,
    /// One value per point and no way to hold a second direction (Siemens LEC, a CEC
    /// table without direction, HEIDENHAIN, an ISG list without `neg`).
    pub one_column: bool,
    pub fanuc: Option<FanucLayout>,
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

fn field_at(start: usize, token: &str) -> Field {
    Field {
        start,
        end: start + token.len(),
        decimals: decimals(token),
    }
}

/// A table point whose up and down values are `up` and `down` (file units `vu`, `vd`).
#[allow(clippy::too_many_arguments)]
fn point(
    line: usize,
    position_mm: f64,
    e_up_um: f64,
    e_down_um: f64,
    vu: f64,
    vd: f64,
    up: Field,
    down: Field,
) -> TablePoint {
    TablePoint {
        line,
        position_mm,
        e_up_um,
        e_down_um,
        position_file: position_mm,
        up_file: vu,
        down_file: vd,
        up,
        down,
    }
}

fn check_point(line: usize, position_mm: f64, e: &[f64]) -> Result<(), At> {
    use crate::base::limits::{ERROR_UM, POSITION_MM};
    POSITION_MM
        .check(position_mm)
        .map_err(|m| At::new(line, format!("position: {m}")))?;
    for &v in e {
        ERROR_UM
            .check(v)
            .map_err(|m| At::new(line, format!("error: {m}")))?;
    }
    Ok(())
}

fn num(line: usize, what: &str, t: &str) -> Result<f64, At> {
    number(t).ok_or_else(|| At::new(line, format!("{what} `{}` is not a number", t.trim())))
}

// ---------------------------------------------------------------------------------------
// Siemens

/// One equidistant Siemens table being read.
#[derive(Default)]
struct SiemensTable {
    /// N → (line, field, value).
    values: std::collections::BTreeMap<usize, (usize, Field, f64)>,
    step: Option<(usize, f64)>,
    min: Option<(usize, f64)>,
    max: Option<(usize, f64)>,
    direction: Option<(usize, i64)>,
    first_line: usize,
}

impl SiemensTable {
    /// (position mm, line, field, value) per point, checked.
    fn points(&self, what: &str, last_line: usize) -> Result<Vec<(f64, usize, Field, f64)>, At> {
        let need = |v: Option<(usize, f64)>, name: &str| {
            v.ok_or_else(|| At::new(last_line, format!("{what}: no {name}")))
        };
        let (sl, step) = need(self.step, "STEP")?;
        let (_, min) = need(self.min, "MIN")?;
        let (xl, max) = need(self.max, "MAX")?;
        if step <= 0.0 || max <= min {
            return Err(At::new(
                sl,
                format!("{what}: STEP {step} mm from {min} to {max} mm is not a table"),
            ));
        }
        let k = (max - min) / step;
        let count = k.round();
        if (k - count).abs() > 1e-6 * count.max(1.0) || count > 1e6 {
            return Err(At::new(
                xl,
                format!(
                    "{what}: MAX − MIN = {} mm is not a whole number of STEP {step} mm",
                    max - min
                ),
            ));
        }
        let count = count as usize + 1;
        if let Some((&n, &(l, ..))) = self.values.iter().find(|(n, _)| **n >= count) {
            return Err(At::new(
                l,
                format!("{what}: point {n} beyond the {count} points MIN…MAX by STEP"),
            ));
        }
        if self.values.len() != count {
            let missing = (0..count)
                .find(|n| !self.values.contains_key(n))
                .unwrap_or(0);
            return Err(At::new(
                xl,
                format!(
                    "{what}: {count} points from MIN to MAX by STEP but {} values (point {missing} is missing)",
                    self.values.len()
                ),
            ));
        }
        Ok(self
            .values
            .iter()
            .map(|(&n, &(l, f, v))| (min + n as f64 * step, l, f, v))
            .collect())
    }
}

/// The axis errmap's comment `; line along <axis> at …` names (Siemens programs).
fn line_axis(t: &str) -> Option<Axis> {
    let rest = t
        .strip_prefix(';')?
        .trim_start()
        .strip_prefix("line along ")?;
    rest.split_whitespace().next()?.parse().ok()
}

/// `NAME[args]=value` → (name, args, value offset in the line, value text).
fn siemens_assignment(l: &str) -> Option<(&str, Vec<&str>, usize, &str)> {
    let (lhs, value) = l.split_once('=')?;
    let (name, rest) = lhs.split_once('[')?;
    let args = rest.strip_suffix(']')?;
    Some((
        name.trim(),
        args.split(',').map(str::trim).collect(),
        lhs.len() + 1,
        value,
    ))
}

impl SiemensTable {
    /// Stores one entry of the table `key`: a point value when `point` (the point number's
    /// argument) is given, else the table parameter `base` (STEP, MIN, …), checked.
    fn take(
        &mut self,
        key: &str,
        line: usize,
        base: &str,
        point: Option<&str>,
        (f, vt): (Field, &str),
    ) -> Result<(), At> {
        match (base, point) {
            ("", Some(arg)) => {
                let n: usize = arg
                    .parse()
                    .map_err(|_| At::new(line, format!("point number `{}` is not a count", arg)))?;
                let v = num(line, "the value", vt)?;
                if self.values.insert(n, (line, f, v)).is_some() {
                    return Err(At::new(
                        line,
                        format!("point {n} of table {key} given twice"),
                    ));
                }
            }
            ("STEP", _) => self.step = Some((line, num(line, "STEP", vt)?)),
            ("MIN", _) => self.min = Some((line, num(line, "MIN", vt)?)),
            ("MAX", _) => self.max = Some((line, num(line, "MAX", vt)?)),
            ("DIRECTION", _) => {
                let d = num(line, "DIRECTION", vt)?;
                if ![-1.0, 0.0, 1.0].contains(&d) {
                    return Err(At::new(line, format!("DIRECTION {d} (−1, 0 or 1)")));
                }
                self.direction = Some((line, d as i64));
            }
            ("IS_MODULO", _) => {
                if num(line, "IS_MODULO", vt)? != 0.0 {
                    return Err(At::new(
                        line,
                        "a modulo (rotary) table: errmap reads linear axes",
                    ));
                }
            }
            ("MULT_BY_TABLE", _) => {
                if num(line, "MULT_BY_TABLE", vt)? != 0.0 {
                    return Err(At::new(
                        line,
                        "a table multiplied by another: not a leadscrew table",
                    ));
                }
            }
            ("INPUT_AXIS", _) | ("OUTPUT_AXIS", _) => {}
            (other, _) => return Err(At::new(line, format!("unknown table entry `{other}`"))),
        }
        Ok(())
    }
}

/// Which table and entry a Siemens assignment sets: (entry after the name's `_`, or ""
/// for a point value; the table's key; the argument holding the point number), refusing
/// names of the other program kind.
fn siemens_target<'l>(
    cec: bool,
    name: &'l str,
    args: &[&str],
    line: usize,
    t: &str,
) -> Result<(&'l str, String, Option<usize>), At> {
    Ok(match (cec, name) {
        (false, "$AA_ENC_COMP") if args.len() == 3 => {
            ("", format!("{},{}", args[0], args[2]), Some(1))
        }
        (false, n) if n.starts_with("$AA_ENC_COMP_") && args.len() == 2 => {
            (&n[13..], format!("{},{}", args[0], args[1]), None)
        }
        (true, "$AN_CEC") if args.len() == 2 => ("", args[0].to_string(), Some(1)),
        (true, n) if n.starts_with("$AN_CEC_") && args.len() == 1 => {
            (&n[8..], args[0].to_string(), None)
        }
        _ => {
            return Err(At::new(
                line,
                format!("`{t}`: not a line of this table program"),
            ));
        }
    })
}

/// A Siemens `%_N_AX_EEC_INI` (one LEC/MSEC table) or `%_N_NC_CEC_INI` (one CEC table
/// without direction, or two for the positive and negative directions).
pub fn read_siemens(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let first = lines.first().map(|l| l.1.trim()).unwrap_or("");
    let cec = match first {
        "%_N_AX_EEC_INI" => false,
        "%_N_NC_CEC_INI" => true,
        _ => {
            return Err(At::new(
                1,
                "not a Siemens compensation program (`%_N_AX_EEC_INI` or `%_N_NC_CEC_INI`)",
            ));
        }
    };
    let mut tables: std::collections::BTreeMap<String, SiemensTable> = Default::default();
    let mut ended = false;
    let mut axis = None;
    for (i, &(off, l)) in lines.iter().enumerate().skip(1) {
        let line = i + 1;
        let t = l.trim();
        if ended && !t.is_empty() {
            return Err(At::new(line, "text after M17 (the end of the program)"));
        }
        if let Some(a) = line_axis(t) {
            axis = Some(a);
        }
        if t.is_empty() || t.starts_with(';') || t == "CHANDATA(1)" {
            continue;
        }
        if t == "M17" || t == "M30" {
            ended = true;
            continue;
        }
        let Some((name, args, voff, value)) = siemens_assignment(l) else {
            return Err(At::new(line, format!("`{t}` is not `$NAME[…]=value`")));
        };
        let (base, key, n_index) = siemens_target(cec, name, &args, line, t)?;
        let table = tables.entry(key.clone()).or_insert_with(|| SiemensTable {
            first_line: line,
            ..Default::default()
        });
        let vt = value.trim();
        let lead = value.len() - value.trim_start().len();
        let f = field_at(off + voff + lead, vt);
        table.take(&key, line, base, n_index.map(|k| args[k]), (f, vt))?;
    }
    let last = lines.len().max(1);
    if !ended {
        return Err(At::new(last, "no M17: the program is cut short"));
    }
    let mut parsed = siemens_points(&tables, cec, last)?;
    parsed.axis = axis;
    if parsed.points.len() < 2 {
        return Err(At::new(last, "a table needs two points"));
    }
    Ok(parsed)
}

/// The table points of the program's tables: one table (one column), or in a CEC program
/// two tables of directions 1 and −1 at the same points; anything else is refused.
fn siemens_points(
    tables: &std::collections::BTreeMap<String, SiemensTable>,
    cec: bool,
    last: usize,
) -> Result<Parsed, At> {
    let e = |v: f64| -v * 1000.0;
    let mut parsed = Parsed::default();
    let list: Vec<(&String, &SiemensTable)> = tables.iter().collect();
    match list.as_slice() {
        [(name, t)] => {
            if t.direction.is_some_and(|d| d.1 != 0) {
                return Err(At::new(
                    t.direction.map_or(last, |d| d.0),
                    format!(
                        "table {name} acts in one direction only and its other-direction table is missing"
                    ),
                ));
            }
            for (p, l, f, v) in t.points(&format!("table {name}"), last)? {
                check_point(l, p, &[e(v)])?;
                parsed.points.push(point(l, p, e(v), e(v), v, v, f, f));
            }
            parsed.one_column = true;
        }
        [(na, a), (nb, b)] if cec => {
            let dir = |t: &SiemensTable| t.direction.map_or(0, |d| d.1);
            let (up, down) = match (dir(a), dir(b)) {
                (1, -1) => (a, b),
                (-1, 1) => (b, a),
                _ => {
                    return Err(At::new(
                        b.first_line,
                        format!("tables {na} and {nb}: two tables must be DIRECTION 1 and −1"),
                    ));
                }
            };
            let pu = up.points("the positive-direction table", last)?;
            let pd = down.points("the negative-direction table", last)?;
            if pu.len() != pd.len() || pu.iter().zip(&pd).any(|(x, y)| (x.0 - y.0).abs() > 1e-9) {
                return Err(At::new(
                    down.first_line,
                    "the two direction tables have different points (MIN, MAX, STEP)",
                ));
            }
            for (u, d) in pu.iter().zip(&pd) {
                check_point(u.1, u.0, &[e(u.3), e(d.3)])?;
                parsed
                    .points
                    .push(point(u.1, u.0, e(u.3), e(d.3), u.3, d.3, u.2, d.2));
            }
            parsed.bidirectional = true;
        }
        [] => return Err(At::new(last, "no table values")),
        _ => {
            return Err(At::new(
                list[1].1.first_line,
                format!(
                    "{} tables in one file: errmap reads one axis' table",
                    list.len()
                ),
            ));
        }
    }
    Ok(parsed)
}

// ---------------------------------------------------------------------------------------
// HEIDENHAIN

/// A HEIDENHAIN `.COM` table: `BEGIN <name> MM|INCH`, a column line with `NR`, `AXISPOS`
/// and the compensated axis' column, one row per point, `[END]`.
pub fn read_heidenhain(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let first: Vec<&str> = lines
        .first()
        .map(|l| l.1.split_whitespace().collect())
        .unwrap_or_default();
    let k = match first.as_slice() {
        ["BEGIN", _, "MM"] | ["BEGIN", _] => 1.0,
        ["BEGIN", _, "INCH"] => super::units::MM_PER_INCH,
        _ => return Err(At::new(1, "not a HEIDENHAIN table (`BEGIN <name> MM`)")),
    };
    let header: Vec<&str> = lines
        .get(1)
        .map(|l| l.1.split_whitespace().collect())
        .unwrap_or_default();
    let (inr, ipos, ival) = heidenhain_columns(&header)?;
    let axis = header[ival].parse::<Axis>().ok();
    let mut parsed = Parsed {
        axis,
        one_column: true,
        ..Default::default()
    };
    let mut ended = false;
    for (i, &(off, l)) in lines.iter().enumerate().skip(2) {
        let line = i + 1;
        let t = l.trim();
        if t.is_empty() {
            continue;
        }
        if ended {
            return Err(At::new(line, "text after [END]"));
        }
        if t == "[END]" {
            ended = true;
            continue;
        }
        let toks = token_ranges(l);
        if toks.len() != header.len() {
            return Err(At::new(
                line,
                format!(
                    "{} fields, the column line has {}",
                    toks.len(),
                    header.len()
                ),
            ));
        }
        let tok = |c: usize| &l[toks[c].0..toks[c].1];
        if tok(inr).parse::<u32>().is_err() {
            return Err(At::new(
                line,
                format!("NR `{}` is not a row number", tok(inr)),
            ));
        }
        let p = num(line, "AXISPOS", tok(ipos))? * k;
        let v = num(line, header[ival], tok(ival))?;
        let e = -v * k * 1000.0;
        check_point(line, p, &[e])?;
        if let Some(prev) = parsed.points.last()
            && p <= prev.position_mm
        {
            return Err(At::new(
                line,
                format!(
                    "AXISPOS {p} after {}: the points must increase",
                    prev.position_mm
                ),
            ));
        }
        let f = field_at(off + toks[ival].0, tok(ival));
        let mut pt = point(line, p, e, e, v, v, f, f);
        pt.position_file = p / k;
        parsed.points.push(pt);
    }
    if !ended {
        return Err(At::new(
            lines.len().max(1),
            "no [END]: the table is cut short",
        ));
    }
    if parsed.points.len() < 2 {
        return Err(At::new(lines.len().max(1), "a table needs two points"));
    }
    Ok(parsed)
}

/// The column line's NR, AXISPOS and single value column (indices), refusing a BACKLASH
/// column, whose meaning errmap's sources leave open, and more than one axis.
fn heidenhain_columns(header: &[&str]) -> Result<(usize, usize, usize), At> {
    if header.contains(&"BACKLASH") {
        return Err(At::new(
            2,
            "a BACKLASH column: whether it holds the negative-direction value or its difference \
             is not documented in the sources errmap follows",
        ));
    }
    let (Some(inr), Some(ipos)) = (
        header.iter().position(|&h| h == "NR"),
        header.iter().position(|&h| h == "AXISPOS"),
    ) else {
        return Err(At::new(2, "the column line needs NR and AXISPOS"));
    };
    let values: Vec<usize> = (0..header.len())
        .filter(|&i| i != inr && i != ipos)
        .collect();
    let [ival] = values.as_slice() else {
        return Err(At::new(
            2,
            format!(
                "{} value columns: errmap reads one compensated axis",
                values.len()
            ),
        ));
    };
    Ok((inr, ipos, *ival))
}

/// The byte ranges of the whitespace-separated tokens of `l` (the value's range is where
/// an update writes).
fn token_ranges(l: &str) -> Vec<(usize, usize)> {
    let mut toks = Vec::new();
    let mut start = None;
    for (j, c) in l.char_indices().chain(std::iter::once((l.len(), ' '))) {
        match (c.is_whitespace(), start) {
            (true, Some(s)) => {
                toks.push((s, j));
                start = None;
            }
            (false, None) => start = Some(j),
            _ => {}
        }
    }
    toks
}

// ---------------------------------------------------------------------------------------
// ISG

/// An ISG list value: its line, where it sits and its text.
type IsgEntry = (usize, Field, String);

/// An ISG list's `name value` pairs by name, with the last line (for "missing" messages).
struct IsgKeys {
    keys: std::collections::HashMap<String, IsgEntry>,
    last: usize,
}

impl IsgKeys {
    /// Collects the `name value` lines (comments skipped), refusing a malformed line and a
    /// name given twice.
    fn read(lines: &[(usize, &str)]) -> Result<IsgKeys, At> {
        let mut keys: std::collections::HashMap<String, IsgEntry> = Default::default();
        for (i, &(off, l)) in lines.iter().enumerate() {
            let line = i + 1;
            let body = l.split("/*").next().unwrap_or("");
            let t = body.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let mut it = t.split_whitespace();
            let (Some(key), Some(value), None) = (it.next(), it.next(), it.next()) else {
                return Err(At::new(line, format!("`{t}` is not `name value`")));
            };
            let start = off + body.find(key).unwrap_or(0) + key.len();
            let vstart = start + l[start - off..].find(value).unwrap_or(0);
            if keys
                .insert(
                    key.to_string(),
                    (line, field_at(vstart, value), value.to_string()),
                )
                .is_some()
            {
                return Err(At::new(line, format!("{key} given twice")));
            }
        }
        Ok(IsgKeys {
            keys,
            last: lines.len().max(1),
        })
    }

    /// The whole-number value of `key`, if given.
    fn int(&self, key: &str) -> Result<Option<(usize, Field, i64)>, At> {
        match self.keys.get(key) {
            None => Ok(None),
            Some((l, f, v)) => {
                let x = number(v)
                    .filter(|x| x.fract() == 0.0 && x.abs() < 1e15)
                    .ok_or_else(|| At::new(*l, format!("{key} `{v}` is not a whole number")))?;
                Ok(Some((*l, *f, x as i64)))
            }
        }
    }

    /// The whole-number value of a key every leadscrew list has.
    fn need(&self, key: &str) -> Result<(usize, Field, i64), At> {
        self.int(key)?.ok_or_else(|| {
            At::new(
                self.last,
                format!("no {key}: not a leadscrew compensation list"),
            )
        })
    }

    /// Refuses a table entry beyond the `n` entries of kw_nr_max (the first one by line).
    fn check_entries(&self, n: usize) -> Result<(), At> {
        let beyond = self
            .keys
            .iter()
            .filter(|(key, _)| {
                key.strip_prefix("kw.ssfk.table[").is_some_and(|rest| {
                    rest.split(']')
                        .next()
                        .and_then(|s| s.parse::<usize>().ok())
                        .is_none_or(|i| i >= n)
                })
            })
            .min_by_key(|(_, (l, ..))| *l);
        if let Some((key, (l, ..))) = beyond {
            return Err(At::new(
                *l,
                format!("{key}: beyond the kw_nr_max {n} entries"),
            ));
        }
        Ok(())
    }
}

/// A TwinCAT CNC (ISG) compensation value list: `name value` lines (`#` comment lines,
/// `/* … */` after a value), `kw.ssfk.unit` 1 (0.1 µm), points from `interval` and
/// `kw_startpos` or each `table[i].setpoint`, `table[i].pos` (and `neg`).
pub fn read_isg(text: &Text) -> Result<Parsed, At> {
    let lines = text.lines();
    let keys = IsgKeys::read(&lines)?;
    let last = keys.last;
    let (ul, _, unit) = keys.need("kw.ssfk.unit")?;
    if unit != 1 {
        return Err(At::new(
            ul,
            format!(
                "kw.ssfk.unit {unit}: errmap reads lists in 0.1 µm (unit 1), not drive increments"
            ),
        ));
    }
    if let Some((l, _, m)) = keys.int("kw.ssfk.modulo")?
        && m != 0
    {
        return Err(At::new(l, "a modulo axis' list: errmap reads linear axes"));
    }
    let (nl, _, count) = keys.need("kw.ssfk.kw_nr_max")?;
    if !(2..=1_000_000).contains(&count) {
        return Err(At::new(
            nl,
            format!("kw_nr_max {count}: a table needs two points"),
        ));
    }
    let n = count as usize;
    let bil = keys.int("kw.ssfk.bilateral")?;
    let bilateral = match bil {
        None => false,
        Some((_, _, 0)) => false,
        Some((_, _, 1)) => true,
        Some((l, _, b)) => return Err(At::new(l, format!("bilateral {b} (0 or 1)"))),
    };
    let interval = keys.int("kw.ssfk.interval")?.map_or(0, |x| x.2);
    let start = keys.int("kw.ssfk.kw_startpos")?.map(|x| x.2);
    // Every table entry must be within kw_nr_max (the first one that is not is named).
    keys.check_entries(n)?;
    let has_neg = (0..n).all(|i| keys.keys.contains_key(&format!("kw.ssfk.table[{i}].neg")));
    if bilateral && !has_neg {
        return Err(At::new(
            last,
            "a bilateral list needs table[i].neg for every point",
        ));
    }
    let axis = keys
        .keys
        .get("kopf.log_achs_name")
        .and_then(|(_, _, v)| v.parse::<Axis>().ok());
    let mut parsed = Parsed {
        axis,
        bidirectional: bilateral,
        bidir_value: bil.map(|b| b.1),
        one_column: !has_neg,
        ..Default::default()
    };
    for i in 0..n {
        let at = |what: &str| -> Result<(usize, Field, i64), At> {
            keys.int(&format!("kw.ssfk.table[{i}].{what}"))?
                .ok_or_else(|| {
                    At::new(
                        nl,
                        format!("kw_nr_max {n} but kw.ssfk.table[{i}].{what} is missing"),
                    )
                })
        };
        let p01 = if interval == 0 {
            at("setpoint")?.2
        } else {
            let Some(s) = start else {
                return Err(At::new(last, "an interval without kw_startpos"));
            };
            s + i as i64 * interval
        };
        let (line, uf, u) = at("pos")?;
        let (df, d) = if has_neg {
            at("neg").map(|x| (x.1, x.2))?
        } else {
            (uf, u)
        };
        let p = p01 as f64 * 1e-4;
        let e = |v: i64| -(v as f64) / 10.0;
        let e_down = if bilateral { e(d) } else { e(u) };
        check_point(line, p, &[e(u), e(d)])?;
        if let Some(prev) = parsed.points.last()
            && p <= prev.position_mm
        {
            return Err(At::new(
                line,
                format!(
                    "point {i} at {p} mm after {} mm: the points must increase",
                    prev.position_mm
                ),
            ));
        }
        parsed
            .points
            .push(point(line, p, e(u), e_down, u as f64, d as f64, uf, df));
    }
    Ok(parsed)
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
pub fn read_fanuc(text: &Text) -> Result<Parsed, At> {
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
