//! Renishaw Laser10 / LaserXL linear data, `.rtl` (CRLF text).
//!
//! The layout is taken from the project's import contract, which describes it from public
//! descriptions of the format, and from a public parser written against genuine Laser10
//! files (the Java `RtlParser` of the AxisCorection project on GitHub, read to learn the
//! layout: no code taken); **no genuine `.rtl` file has been read by this reader yet**
//! (see `docs/import.md`). Sections start with a line `NAME::`; inside one, `Key : value`
//! lines are split at the first `:`. Two layouts are accepted, each with a test file of
//! ours (`tests/it/rtl.rs`): the contract's (target positions on the `Targets :` line,
//! deviations straight after `DEVIATIONS::`) and the one genuine files show (`Targets :`
//! alone, the positions on the lines after it; a `Run Target Data:` line opening the
//! deviations; `Version no`, `Filetype`, `Env factor`, `Exp coeff` and `Final Data` lines,
//! which errmap reads past).
//!
//! | section | keys | errmap |
//! |---|---|---|
//! | `HEADER::` | `File type : rtl`, `Owner : Linear` (anything else is refused), `Version no` | — |
//! | `TARGET DATA::` | `Target-count` N, `Targets :` N positions (mm, on that line and/or the next lines), `Flags:` (second field 1 = unidirectional) | target positions |
//! | `RUNS::` | `Run-count` R = the number of passes | — |
//! | `DEVIATIONS::` | an optional `Run Target Data:` line, then `run target deviation`, R·N lines, each pair once; deviation x in µm | e_um = −x, laser_mm = P + x/1000 |
//! | `ENVIRONMENT::` (optional) | `Air temp` °C, `Air press` kPa, `Air humid` %, `Mat temp 1..3` °C: values at the first and the last reading | interpolated over the readings |
//! | `Date Time` | "start" "end" (times of day hh:mm:ss, checked: hours 0–23, minutes and seconds 0–59) | Δt = span / (K − 1) |
//! | `USER-TEXT::` | `Axis` | the axis (else X, with a warning) |
//!
//! A Run-count that disagrees with complete deviations (R' whole runs of N targets
//! listed, R' ≠ R) is blamed on the `Run-count` line; a deviation line that breaks the
//! pattern is blamed on itself.
//!
//! The ISO run is r (unidirectional) or ⌈r/2⌉ (bidirectional: passes out and back); a
//! pass' direction is the order in which it lists its targets. Unknown sections
//! (`EQUIPMENT::`, …) are skipped.

use super::units::HPA_PER_KPA;
use super::{At, Env, ImportSummary, Imported, Reading, assemble, summary_counts};
use crate::base::Axis;
use crate::controller::text::{Text, number};

/// One `Key : value` line of a section.
#[derive(Debug)]
struct Entry<'a> {
    line: usize,
    key: String,
    value: &'a str,
}

/// A section: its name, the line of its title and its lines.
#[derive(Debug)]
struct Section<'a> {
    name: String,
    line: usize,
    lines: Vec<(usize, &'a str)>,
}

impl<'a> Section<'a> {
    fn entries(&self) -> Vec<Entry<'a>> {
        self.lines
            .iter()
            .filter_map(|&(line, l)| {
                l.split_once(':').map(|(k, v)| Entry {
                    line,
                    key: k.trim().to_ascii_lowercase(),
                    value: v.trim(),
                })
            })
            .collect()
    }

    fn get(&self, key: &str) -> Option<Entry<'a>> {
        let key = key.to_ascii_lowercase();
        self.entries().into_iter().find(|e| e.key == key)
    }
}

fn sections<'a>(lines: &[(usize, &'a str)]) -> Vec<Section<'a>> {
    let mut out: Vec<Section<'a>> = Vec::new();
    for (i, &(_, l)) in lines.iter().enumerate() {
        let t = l.trim();
        if let Some(name) = t.strip_suffix("::")
            && !name.contains(':')
        {
            out.push(Section {
                name: name.trim().to_ascii_uppercase(),
                line: i + 1,
                lines: Vec::new(),
            });
        } else if let Some(s) = out.last_mut()
            && !t.is_empty()
        {
            s.lines.push((i + 1, t));
        }
    }
    out
}

/// The refusal of a `.rtx` dynamic capture.
pub(super) fn refuse_rtx(_bytes: &[u8]) -> At {
    At::new(
        1,
        "a Renishaw dynamic capture (.rtx: samples in time, no targets); errmap imports \
         positioning tests only: export the linear test as .rtl",
    )
}

fn whole(v: f64) -> Option<usize> {
    (v.fract() == 0.0 && (1.0..=1e6).contains(&v)).then_some(v as usize)
}

/// One `run target deviation` line of DEVIATIONS::, numbers checked against the counts.
struct Deviation {
    line: usize,
    run: usize,
    target: usize,
    /// Deviation in µm.
    x: f64,
}

/// ENVIRONMENT::'s first and last values; a reading's value is interpolated between them
/// by its index among the `k_total` readings.
struct Environment {
    air_t: Option<(f64, f64)>,
    air_p: Option<(f64, f64)>,
    air_h: Option<(f64, f64)>,
    mats: Vec<(f64, f64)>,
    k_total: usize,
}

impl Environment {
    /// Reads the optional section's pairs (one number: constant; none: refused).
    fn read(env_sec: Option<&Section>, k_total: usize) -> Result<Environment, At> {
        let pair = |key: &str| -> Result<Option<(f64, f64)>, At> {
            let Some(e) = env_sec.and_then(|s| s.get(key)) else {
                return Ok(None);
            };
            let v: Vec<f64> = e
                .value
                .split_whitespace()
                .filter_map(number)
                .take(2)
                .collect();
            match v.as_slice() {
                [a, b] => Ok(Some((*a, *b))),
                [a] => Ok(Some((*a, *a))),
                _ => Err(At::new(e.line, format!("`{key}` has no numbers"))),
            }
        };
        let air_t = pair("Air temp")?;
        let air_p = pair("Air press")?;
        let air_h = pair("Air humid")?;
        let mats: Vec<(f64, f64)> = (1..=3)
            .map(|i| pair(&format!("Mat temp {i}")))
            .collect::<Result<Vec<_>, _>>()?
            .into_iter()
            .flatten()
            .collect();
        Ok(Environment {
            air_t,
            air_p,
            air_h,
            mats,
            k_total,
        })
    }

    /// The value of a first/last pair at reading `k`, linear in the reading's index.
    fn at(&self, p: Option<(f64, f64)>, k: usize) -> Option<f64> {
        let k_total = self.k_total;
        p.map(|(a, b)| {
            if k_total > 1 {
                a + (b - a) * k as f64 / (k_total - 1) as f64
            } else {
                a
            }
        })
    }

    /// The conditions at reading `k` (air pressure from kPa to hPa, the mean material
    /// temperature as the part's).
    fn env(&self, k: usize) -> Env {
        let mats = &self.mats;
        let part = (!mats.is_empty()).then(|| {
            mats.iter()
                .map(|&m| self.at(Some(m), k).unwrap_or(m.0))
                .sum::<f64>()
                / mats.len() as f64
        });
        Env {
            air_temp_c: self.at(self.air_t, k),
            air_pressure_hpa: self.at(self.air_p, k).map(|v| v * HPA_PER_KPA),
            air_rh_pct: self.at(self.air_h, k),
            scale_temp_c: None,
            part_temp_c: part,
        }
    }
}

/// The section called `name`, if the file has one.
fn section<'s, 'a>(secs: &'s [Section<'a>], name: &str) -> Option<&'s Section<'a>> {
    secs.iter().find(|s| s.name == name)
}

/// Reads a Renishaw linear `.rtl` (see the module docs).
pub(super) fn read(bytes: &[u8], axis_override: Option<Axis>) -> Result<Imported, At> {
    let text = Text::decode(bytes).map_err(|(l, m)| At::new(l, m))?;
    let lines = text.lines();
    if lines.first().map(|l| l.1.trim()) != Some("HEADER::") {
        return Err(At::new(1, "not a Renishaw file (no `HEADER::` on line 1)"));
    }
    let secs = sections(&lines);
    let header = section(&secs, "HEADER").ok_or_else(|| At::new(1, "no HEADER:: section"))?;
    check_header(header, bytes)?;
    let targets_sec = section(&secs, "TARGET DATA")
        .ok_or_else(|| At::new(lines.len().max(1), "no TARGET DATA:: section"))?;
    let positions = read_targets(targets_sec)?;
    let n = positions.len();
    let unidirectional = targets_sec
        .get("Flags")
        .and_then(|e| e.value.split_whitespace().nth(1).map(|f| f == "1"))
        .unwrap_or(false);
    let runs_sec =
        section(&secs, "RUNS").ok_or_else(|| At::new(lines.len().max(1), "no RUNS:: section"))?;
    let rc = runs_sec
        .get("Run-count")
        .ok_or_else(|| At::new(runs_sec.line, "RUNS:: has no `Run-count`"))?;
    let r = number(rc.value)
        .and_then(whole)
        .ok_or_else(|| At::new(rc.line, format!("Run-count `{}`", rc.value)))?;
    let dev = section(&secs, "DEVIATIONS")
        .ok_or_else(|| At::new(lines.len().max(1), "no DEVIATIONS:: section"))?;
    check_run_count(dev, r, n, rc.line)?;
    let raw = read_deviations(dev, r, n)?;
    if raw.len() != r * n {
        return Err(At::new(
            rc.line,
            format!(
                "{} deviations, Run-count {r} × Target-count {n} = {}",
                raw.len(),
                r * n
            ),
        ));
    }
    // Environment: first and last values, spread over the readings.
    let mut warnings = Vec::new();
    let k_total = raw.len();
    let env_sec = section(&secs, "ENVIRONMENT");
    let environment = Environment::read(env_sec, k_total)?;
    let span = match env_sec.and_then(|s| s.get("Date Time")) {
        Some(e) => span_s(e.value).map_err(|m| At::new(e.line, format!("Date Time: {m}")))?,
        None => None,
    };
    let dt_s = span
        .map(|span| span / (k_total.max(2) - 1) as f64)
        .filter(|d| *d > 0.0)
        .unwrap_or(1.0);
    let readings = to_readings(&raw, &positions, unidirectional, &environment)?;
    let file_axis = section(&secs, "USER-TEXT")
        .and_then(|s| s.get("Axis"))
        .and_then(|e| e.value.trim().parse::<Axis>().ok());
    let (axis, axis_warning) = match (axis_override, file_axis) {
        (Some(a), _) | (None, Some(a)) => (a, None),
        (None, None) => {
            warnings.push("the file states no axis (USER-TEXT:: Axis): taken as X".into());
            (Axis::X, Some(warnings.len() - 1))
        }
    };
    let machine = section(&secs, "USER-TEXT")
        .and_then(|s| s.get("Machine"))
        .map(|e| e.value.to_string());
    let rows = assemble(&readings, axis, [0.0; 3], dt_s);
    let (runs_n, targets_n, directions) = summary_counts(&readings);
    Ok(Imported {
        summary: ImportSummary {
            format: "renishaw-rtl",
            rows: rows.len(),
            runs: Some(runs_n),
            targets: targets_n,
            directions,
            units_in: "mm",
            axis: axis.upper(),
            machine,
            warnings,
            axis_warning,
        },
        rows,
    })
}

/// Accepts a linear `.rtl` HEADER:: only (File type rtl, Owner Linear): anything else is
/// a file this reader would misread, so it is refused before the data.
fn check_header(header: &Section, bytes: &[u8]) -> Result<(), At> {
    if !header
        .get("File type")
        .is_some_and(|e| e.value.eq_ignore_ascii_case("rtl"))
    {
        return Err(refuse_rtx(bytes));
    }
    match header.get("Owner") {
        Some(e) if e.value.eq_ignore_ascii_case("Linear") => Ok(()),
        Some(e) => Err(At::new(
            e.line,
            format!(
                "Owner `{}`: errmap imports linear positioning tests only",
                e.value
            ),
        )),
        None => Err(At::new(header.line, "HEADER:: has no `Owner` (Linear)")),
    }
}

/// The Target-count target positions of TARGET DATA:: (`Targets :` and N numbers,
/// possibly continued on the following lines), their number checked.
fn read_targets(targets_sec: &Section) -> Result<Vec<f64>, At> {
    let count = targets_sec
        .get("Target-count")
        .ok_or_else(|| At::new(targets_sec.line, "TARGET DATA:: has no `Target-count`"))?;
    let n = number(count.value)
        .and_then(whole)
        .ok_or_else(|| At::new(count.line, format!("Target-count `{}`", count.value)))?;
    let start = targets_sec
        .lines
        .iter()
        .position(|(_, l)| {
            l.split_once(':')
                .is_some_and(|(k, _)| k.trim().eq_ignore_ascii_case("Targets"))
        })
        .ok_or_else(|| At::new(targets_sec.line, "TARGET DATA:: has no `Targets :`"))?;
    let mut positions: Vec<f64> = Vec::with_capacity(n);
    let mut last_line = targets_sec.lines[start].0;
    for (k, &(line, l)) in targets_sec.lines.iter().enumerate().skip(start) {
        let body = if k == start {
            l.split_once(':').map(|(_, v)| v).unwrap_or("")
        } else if l.contains(':') {
            break;
        } else {
            l
        };
        for tok in body.split_whitespace() {
            let v = number(tok)
                .ok_or_else(|| At::new(line, format!("target position `{tok}` is not a number")))?;
            positions.push(v);
        }
        last_line = line;
        if positions.len() >= n {
            break;
        }
    }
    if positions.len() != n {
        return Err(At::new(
            last_line,
            format!(
                "{} target positions, Target-count says {n}",
                positions.len()
            ),
        ));
    }
    Ok(positions)
}

/// The deviation lines of DEVIATIONS::, the `Run Target Data:` line that opens them in
/// genuine files left out (numbers after its colon, if any, are a deviation).
fn deviation_lines<'a>(dev: &Section<'a>) -> impl Iterator<Item = (usize, &'a str)> {
    dev.lines
        .iter()
        .filter_map(|&(line, l)| match l.split_once(':') {
            Some((k, rest)) if k.trim().eq_ignore_ascii_case("Run Target Data") => {
                let rest = rest.trim();
                (!rest.is_empty()).then_some((line, rest))
            }
            _ => Some((line, l)),
        })
}

/// Refuses a Run-count that the deviations contradict as a whole: every line
/// `run target deviation` with whole numbers, targets within 1..n, the runs 1..R' each
/// complete (R'·n lines) and R' ≠ `r`. The Run-count line is then the wrong one.
fn check_run_count(dev: &Section, r: usize, n: usize, count_line: usize) -> Result<(), At> {
    let mut runs = Vec::new();
    for (_, l) in deviation_lines(dev) {
        let f: Vec<&str> = l.split_whitespace().collect();
        let run = f.first().and_then(|v| number(v)).and_then(whole);
        let target = f.get(1).and_then(|v| number(v)).and_then(whole);
        match (f.len(), run, target) {
            (3, Some(run), Some(t)) if t <= n => runs.push(run),
            _ => return Ok(()),
        }
    }
    let seen = runs.iter().copied().max().unwrap_or(0);
    let complete = (1..=seen).all(|k| runs.iter().filter(|&&x| x == k).count() == n);
    if seen != r && complete && runs.len() == seen * n {
        return Err(At::new(
            count_line,
            format!(
                "Run-count {r}, but DEVIATIONS:: lists {seen} complete run(s) of the {n} targets"
            ),
        ));
    }
    Ok(())
}

/// The DEVIATIONS:: lines, each run and target within 1..r / 1..n and each pair once (the
/// caller checks that every pair is there).
fn read_deviations(dev: &Section, r: usize, n: usize) -> Result<Vec<Deviation>, At> {
    let mut seen = vec![false; r * n];
    let mut raw: Vec<Deviation> = Vec::with_capacity(r * n);
    for (line, l) in deviation_lines(dev) {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() != 3 {
            return Err(At::new(
                line,
                format!("`{l}` is not `run target deviation`"),
            ));
        }
        let run = number(f[0]).and_then(whole).filter(|&v| v <= r);
        let target = number(f[1]).and_then(whole).filter(|&v| v <= n);
        let (Some(run), Some(target)) = (run, target) else {
            return Err(At::new(
                line,
                format!("run {} / target {} outside 1..{r} / 1..{n}", f[0], f[1]),
            ));
        };
        let x = number(f[2])
            .ok_or_else(|| At::new(line, format!("deviation `{}` is not a number", f[2])))?;
        let slot = (run - 1) * n + (target - 1);
        if seen[slot] {
            return Err(At::new(
                line,
                format!("run {run}, target {target} appears twice"),
            ));
        }
        seen[slot] = true;
        raw.push(Deviation {
            line,
            run,
            target,
            x,
        });
    }
    Ok(raw)
}

/// The deviations as readings, passes in file order: a run's lines give the order of its
/// targets and so its direction; the ISO run pairs passes out and back unless
/// unidirectional.
fn to_readings(
    raw: &[Deviation],
    positions: &[f64],
    unidirectional: bool,
    environment: &Environment,
) -> Result<Vec<Reading>, At> {
    let n = positions.len();
    let mut readings = Vec::with_capacity(raw.len());
    for (k, d) in raw.iter().enumerate() {
        let (line, run, target, x) = (d.line, d.run, d.target, d.x);
        let order: Vec<usize> = raw
            .iter()
            .filter(|q| q.run == run)
            .map(|q| q.target)
            .collect();
        let first = positions[order[0] - 1];
        let last = positions[order[order.len() - 1] - 1];
        let direction: i8 = if n < 2 || last > first {
            1
        } else if last < first {
            -1
        } else {
            return Err(At::new(
                line,
                format!("run {run} starts and ends at the same position"),
            ));
        };
        let p = positions[target - 1];
        let reading = Reading {
            run: if unidirectional {
                run as u32
            } else {
                run.div_ceil(2) as u32
            },
            direction,
            target_mm: p,
            scale_mm: p,
            laser_mm: p + x / 1000.0,
            error_um: -x,
            flags: 0,
            env: environment.env(k),
        };
        reading.check(line)?;
        readings.push(reading);
    }
    Ok(readings)
}

/// A `Date Time` field whose clock reading is not a time of day.
#[derive(Debug, thiserror::Error)]
#[error("`{0}` is not a time of day (hh:mm:ss, hours 0–23, minutes and seconds 0–59)")]
struct NotTimeOfDay(String);

/// Seconds between the first and the second quoted time of day (`"… hh:mm:ss" "… hh:mm:ss"`),
/// a day added when the second is earlier (a test past midnight). `None` when either
/// has no time of day; an error when one is not a time of day (hours 0–23, minutes and
/// seconds 0–59: "25:00:00" is refused, not read as a day and an hour).
fn span_s(value: &str) -> Result<Option<f64>, NotTimeOfDay> {
    let quoted: Vec<&str> = value.split('"').skip(1).step_by(2).collect();
    let tod = |s: &str| -> Result<Option<f64>, NotTimeOfDay> {
        let Some(t) = s.split_whitespace().find(|w| w.matches(':').count() == 2) else {
            return Ok(None);
        };
        let p: Vec<f64> = t.split(':').filter_map(number).collect();
        match p.as_slice() {
            [h, m, sec]
                if (0.0..24.0).contains(h)
                    && h.fract() == 0.0
                    && (0.0..60.0).contains(m)
                    && m.fract() == 0.0
                    && (0.0..60.0).contains(sec) =>
            {
                Ok(Some(h * 3600.0 + m * 60.0 + sec))
            }
            _ => Err(NotTimeOfDay(t.to_string())),
        }
    };
    let (Some(a), Some(b)) = (quoted.first(), quoted.get(1)) else {
        return Ok(None);
    };
    let (Some(a), Some(b)) = (tod(a)?, tod(b)?) else {
        return Ok(None);
    };
    Ok(Some(if b >= a { b - a } else { b + 86_400.0 - a }))
}
