//! The campaign's cases: the mutations of issue 17's black-box campaign, and the command
//! that reads each mutated input or flag value.

use std::path::{Path, PathBuf};

use super::Fixtures;

/// xorshift64*, seeded per case by splitmix64 of (seed, case): case `i` of a seed is the
/// same whatever ran before it.
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64, case: u64) -> Self {
        let mut z = seed
            .wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(case.wrapping_mul(0xbf58_476d_1ce4_e5b9))
            .wrapping_add(0x94d0_49bb_1331_11eb);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Rng((z ^ (z >> 31)) | 1)
    }
    /// The generator from a raw state (made odd: never the all-zero state).
    pub(crate) fn from_state(state: u64) -> Self {
        Rng(state | 1)
    }
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }
    fn chance(&mut self, one_in: usize) -> bool {
        self.below(one_in) == 0
    }
}

/// What a run may end with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Expect {
    /// A data mutation: 0 (accepted, with finite outputs) or 1 (refused).
    Data,
    /// Must be refused as bad input: exit 1.
    Refuse,
    /// A bad flag value: exit 2, the flag named.
    Usage,
    /// A flag value at the edge of its domain: 0, 1 or 2.
    Flag,
    /// An output that is an input: refused (1 or 2), the input intact.
    Alias,
}

#[derive(Debug)]
pub(crate) struct Case {
    pub label: String,
    pub args: Vec<String>,
    /// On a nonzero exit stderr names one of these (a file name or a flag).
    pub names: Vec<String>,
    /// Files and directories the run may create.
    pub outputs: Vec<PathBuf>,
    pub expect: Expect,
    pub closed_stdout: bool,
}

impl Case {
    fn new(label: String, args: Vec<String>, name: &str, outputs: Vec<PathBuf>) -> Case {
        Case {
            label,
            args,
            names: vec![name.to_string()],
            outputs,
            expect: Expect::Data,
            closed_stdout: false,
        }
    }
    fn refusing(mut self, refuse: bool) -> Case {
        if refuse {
            self.expect = Expect::Refuse;
        }
        self
    }
}

/// The words of `template`, each `{name}` replaced by its value (after the split, so a
/// path with a space stays one argument).
fn cmd(template: &str, vars: &[(&str, &str)]) -> Vec<String> {
    template
        .split_whitespace()
        .map(|w| {
            vars.iter()
                .fold(w.to_string(), |w, (k, v)| w.replace(&format!("{{{k}}}"), v))
        })
        .collect()
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

// ---- mutations ----

/// Values a cell becomes: non-finite, beyond the float range, denormal, huge, negative,
/// empty, garbage, and the spreadsheet forms that once broke readers.
const CELLS: &str = "nan NaN inf -inf 1e308 -1e308 1.7976931348623157e308 -0 -0.0 -0.000 1e400 \
    5e-324 1e-320 1e12 -1e12 999999999 -1 0 <empty> abc 1,5 <space> 0x10 1e --1 true \"2\" 2e6 \
    -2e6 1e7";

fn cell_value(rng: &mut Rng) -> &'static str {
    let all: Vec<&str> = CELLS.split_whitespace().collect();
    match rng.pick(&all) {
        "<empty>" => "",
        "<space>" => " ",
        v => v,
    }
}

fn join(lines: &[String]) -> String {
    lines.join("\n") + "\n"
}

fn cut(rng: &mut Rng, text: &str) -> (String, String) {
    let at = rng.below(text.len());
    let at = (0..=at)
        .rev()
        .find(|&i| text.is_char_boundary(i))
        .unwrap_or(0);
    (text[..at].to_string(), format!("truncated at byte {at}"))
}

/// A mutated CSV text, what was done, and whether the reader must refuse it.
pub(crate) fn mutate_csv(
    rng: &mut Rng,
    text: &str,
    repeats_refused: bool,
) -> (String, String, bool) {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.len() < 3 {
        return (text.to_string(), "unchanged (too short)".into(), false);
    }
    let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
    let ncol = header.len();
    let row = 1 + rng.below(lines.len() - 1);
    let col = rng.below(ncol);
    let name = header[col].clone();
    match rng.below(14) {
        0..=3 => {
            let v = cell_value(rng);
            let mut cells: Vec<&str> = lines[row].split(',').collect();
            if col < cells.len() {
                cells[col] = v;
            }
            lines[row] = cells.join(",");
            (join(&lines), format!("row {row} {name} = `{v}`"), false)
        }
        4 => {
            // A second column of the same name, its values different from the first's.
            lines[0] = format!("{},{name}", lines[0]);
            for l in lines.iter_mut().skip(1) {
                l.push_str(",7.5");
            }
            (join(&lines), format!("column {name} twice"), true)
        }
        5 => {
            let other = header[(col + 1) % ncol].clone();
            if other == name {
                return (text.to_string(), "unchanged".into(), false);
            }
            let mut h = header.clone();
            h[col] = other.clone();
            lines[0] = h.join(",");
            let label = format!("column {name} renamed {other} (twice)");
            (join(&lines), label, true)
        }
        6 => {
            lines.remove(row);
            (join(&lines), format!("row {row} dropped"), false)
        }
        7 => {
            let l = lines[row].clone();
            lines.insert(row, l);
            (join(&lines), format!("row {row} repeated"), repeats_refused)
        }
        8 => {
            let (t, label) = cut(rng, text);
            (t, label, false)
        }
        9 => {
            // Ragged: a row with a field fewer or one more than the header.
            let mut cells: Vec<&str> = lines[row].split(',').collect();
            let label = if rng.chance(2) && cells.len() > 1 {
                cells.pop();
                format!("row {row} one field short")
            } else {
                cells.push("1");
                format!("row {row} one field long")
            };
            lines[row] = cells.join(",");
            (join(&lines), label, true)
        }
        10 => {
            let mut h = header.clone();
            h[col] = format!("{name}x");
            lines[0] = h.join(",");
            (join(&lines), format!("column {name} misspelt"), false)
        }
        11 => {
            // A whole column scaled: far out of range, negated or zeroed.
            let f = rng.pick(&[1e6, -1.0, 1e300, 0.0]);
            for l in lines.iter_mut().skip(1) {
                let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
                if let Some(c) = cells.get_mut(col)
                    && let Ok(v) = c.parse::<f64>()
                {
                    *c = format!("{}", v * f);
                }
                *l = cells.join(",");
            }
            (join(&lines), format!("column {name} × {f}"), false)
        }
        12 => {
            let a = 1 + rng.below(lines.len() - 1);
            lines.swap(row, a);
            let crlf = rng.chance(2);
            let t = if crlf {
                lines.join("\r\n") + "\r\n\r\n"
            } else {
                join(&lines) + "\n"
            };
            let label = format!("rows {row}, {a} swapped, blank line at end, crlf {crlf}");
            (t, label, false)
        }
        _ => {
            let (b, label) = mutate_bytes(rng, text.as_bytes());
            (String::from_utf8_lossy(&b).into_owned(), label, false)
        }
    }
}

/// Byte-level damage for binary inputs (raw captures, Parquet) and any text.
pub(crate) fn mutate_bytes(rng: &mut Rng, data: &[u8]) -> (Vec<u8>, String) {
    let mut v = data.to_vec();
    let n = v.len().max(1);
    let at = rng.below(n).min(v.len());
    let end = (at + 1 + rng.below(64.min(n))).min(v.len());
    let label = match rng.below(6) {
        0 => {
            let k = 1 + rng.below(4);
            for _ in 0..k {
                let i = rng.below(v.len().max(1));
                if let Some(b) = v.get_mut(i) {
                    *b ^= 1 << rng.below(8);
                }
            }
            format!("{k} bits flipped")
        }
        1 => {
            v.truncate(at);
            format!("truncated at byte {at}")
        }
        2 => {
            v.drain(at..end);
            format!("bytes {at}..{end} removed")
        }
        3 => {
            let piece = v[at..end].to_vec();
            v.splice(at..at, piece);
            format!("bytes {at}..{end} repeated")
        }
        4 => {
            let junk: Vec<u8> = (at..end.max(at + 1)).map(|_| rng.next() as u8).collect();
            let k = junk.len();
            v.splice(at..at, junk);
            format!("{k} random bytes inserted at {at}")
        }
        _ => {
            v[at..end].fill(0);
            format!("bytes {at}..{end} zeroed")
        }
    };
    (v, label)
}

/// Where a TOML line's value lies (after `key =`, before a comment), outside strings;
/// none for headers, comments and blank lines.
fn toml_value_span(line: &str) -> Option<(usize, usize)> {
    let t = line.trim_start();
    if t.is_empty() || t.starts_with('#') || t.starts_with('[') {
        return None;
    }
    let eq = line.find('=')?;
    let mut quoted = false;
    for (i, c) in line.char_indices().filter(|&(i, _)| i > eq) {
        match c {
            '"' => quoted = !quoted,
            '#' if !quoted => return Some((eq + 1, i)),
            _ => {}
        }
    }
    Some((eq + 1, line.len()))
}

/// The numeric literals of `s[from..to]` outside strings: byte ranges.
fn numbers_in(s: &str, from: usize, to: usize) -> Vec<(usize, usize)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut quoted) = (from, false);
    while i < to {
        let c = b[i];
        if c == b'"' {
            quoted = !quoted;
            i += 1;
            continue;
        }
        let signed = (c == b'-' || c == b'+') && i + 1 < to && b[i + 1].is_ascii_digit();
        let after_word = i > from && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if !quoted && (c.is_ascii_digit() || signed) && !after_word {
            let mut j = i + 1;
            while j < to && (b[j].is_ascii_alphanumeric() || b"._+-".contains(&b[j])) {
                j += 1;
            }
            if s[i..j].replace('_', "").parse::<f64>().is_ok() {
                out.push((i, j));
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// What a number in a TOML file becomes; the first seven must be refused wherever a
/// number is read (non-finite, or not a number at all).
const TOML_VALUES: [&str; 16] = [
    "nan", "inf", "-inf", "+inf", "\"12\"", "true", "[]", "1e308", "-1e308", "-1", "0", "-0.0",
    "5e-324", "1e12", "-1e12", "1e300",
];

/// A mutated TOML (or JSON) text, what was done, and whether the loader must refuse it.
pub(crate) fn mutate_toml(rng: &mut Rng, text: &str, json: bool) -> (String, String, bool) {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let span = |l: &str| match json {
        true => l.find(':').map(|c| (c + 1, l.len())),
        false => toml_value_span(l),
    };
    let keyed: Vec<usize> = (0..lines.len())
        .filter(|&i| span(&lines[i]).is_some())
        .collect();
    if keyed.is_empty() {
        let (b, l) = mutate_bytes(rng, text.as_bytes());
        return (String::from_utf8_lossy(&b).into_owned(), l, false);
    }
    let i = keyed[rng.below(keyed.len())];
    let line = lines[i].clone();
    let key = line
        .split(['=', ':'])
        .next()
        .unwrap_or("")
        .trim()
        .to_string();
    match rng.below(if json { 4 } else { 8 }) {
        0 | 1 => {
            let (a, b) = span(&line).unwrap_or((0, 0));
            let nums = numbers_in(&line, a, b);
            if nums.is_empty() {
                return (
                    text.to_string(),
                    format!("unchanged ({key}: no number)"),
                    false,
                );
            }
            let (from, to) = nums[rng.below(nums.len())];
            let k = rng.below(TOML_VALUES.len());
            let v = match json {
                true => rng.pick(&[
                    "NaN", "1e308", "-1e308", "-1", "0", "1e400", "null", "\"x\"",
                ]),
                false => TOML_VALUES[k],
            };
            lines[i] = format!("{}{v}{}", &line[..from], &line[to..]);
            let label = format!("{key}: `{}` → `{v}`", &line[from..to]);
            (join(&lines), label, !json && k < 7)
        }
        2 => {
            lines.remove(i);
            (join(&lines), format!("line `{key}` deleted"), false)
        }
        3 => {
            let (b, l) = mutate_bytes(rng, text.as_bytes());
            (String::from_utf8_lossy(&b).into_owned(), l, false)
        }
        4 => {
            lines[i] = line.replacen(&key, &format!("{key}_x"), 1);
            (join(&lines), format!("key {key} misspelt {key}_x"), true)
        }
        5 => {
            lines.insert(i + 1, "bogus_key = 1".into());
            (join(&lines), format!("unknown key after {key}"), true)
        }
        6 => {
            lines.insert(i + 1, line.clone());
            (join(&lines), format!("key {key} repeated"), true)
        }
        _ => {
            let (t, label) = cut(rng, text);
            (t, label, false)
        }
    }
}

// ---- cases ----

/// A command over an error table `t` and its points `p`; `m` is the mutated one, for
/// the commands that read one table.
/// `k` (0..12) chooses the command: 11 reads the table as grid points only.
#[allow(clippy::too_many_arguments)]
fn table_command(
    rng: &mut Rng,
    k: usize,
    f: &Fixtures,
    t: &str,
    p: &str,
    m: &str,
    d: &Path,
) -> Case {
    let (out, rep) = (d.join("out.csv"), d.join("rep"));
    let method = rng.pick(&["trilinear", "spline", "fuzzy", "gp", "gp-se", "lagrange"]);
    let line_format = rng.pick(&["linuxcnc", "csv", "siemens", "fanuc", "heidenhain", "isg"]);
    let vars = [
        ("t", t),
        ("p", p),
        ("m", m),
        ("method", method),
        ("format", line_format),
        ("out", &s(&out)),
        ("rep", &s(&rep)),
        ("vj", &s(&f.vol_json)),
    ];
    let (template, outs) = match k {
        0..=5 => {
            let order = match method {
                "lagrange" => rng.pick(&[" --order 2x1x1", " --order auto"]),
                _ => "",
            };
            let json = rng.pick(&["", " --json"]);
            let t =
                format!("fit {{t}} --method {{method}} --predict {{p}} --out {{out}}{order}{json}");
            (t, vec![out])
        }
        6 => (
            "compare {t} --test {p} --methods trilinear,spline,lagrange --orders 2x1x1 \
             --report {rep} --json"
                .into(),
            vec![rep],
        ),
        7..=9 => (
            "export {m} --method spline --format {format} --at y=1,z=200 --step 50 --out {out}"
                .into(),
            vec![out],
        ),
        10 => (
            "export {m} --method trilinear --format grid --step 100 --out {out}".into(),
            vec![out],
        ),
        _ => (
            "volumetric predict --model {vj} --grid {m} --out {out}".into(),
            vec![out],
        ),
    };
    Case::new(String::new(), cmd(&template, &vars), "", outs)
}

/// A command over a session table `t`.
fn session_command(rng: &mut Rng, f: &Fixtures, t: &str, d: &Path) -> Case {
    let (out, rep, pdf) = (d.join("out.csv"), d.join("rep"), d.join("out.pdf"));
    let format = rng.pick(&["linuxcnc", "siemens", "fanuc", "isg"]);
    let json = rng.pick(&["", " --json"]);
    let vars = [
        ("t", t),
        ("out", &s(&out)),
        ("rep", &s(&rep)),
        ("pdf", &s(&pdf)),
        ("model", &s(&f.models[0])),
        ("format", format),
    ];
    let (template, outs) = match rng.below(24) {
        0..=11 => (format!("table {{t}} --out {{out}}{json}"), vec![out]),
        12 | 13 => (
            "table {t} --out {out} --report {rep}".into(),
            vec![out, rep],
        ),
        14 => (
            "diagnose --recorded {t} --model {model} --report {rep} --json".into(),
            vec![rep],
        ),
        15 => (
            "diagnose --recorded {t} --report {rep} --json".into(),
            vec![rep],
        ),
        16..=18 => ("certificate {t} --out {pdf}".into(), vec![pdf]),
        19..=21 => (
            "export {t} --bidirectional --format {format} --out {out}".into(),
            vec![out],
        ),
        _ => ("volumetric lines {t} --out {out}".into(), vec![out]),
    };
    Case::new(String::new(), cmd(&template, &vars), "", outs)
}

/// A case whose mutated input is the text file `base` written as `name`.
fn text_case(
    rng: &mut Rng,
    d: &Path,
    base: &Path,
    name: &str,
    mutate: impl FnOnce(&mut Rng, &str) -> (String, String, bool),
) -> (PathBuf, String, bool) {
    let text = std::fs::read_to_string(base).expect("read fixture");
    let (t, what, refuse) = mutate(rng, &text);
    let p = d.join(name);
    std::fs::write(&p, t).expect("write input");
    (p, what, refuse)
}

/// One case of the campaign: a mutated input or flag, and the command that reads it.
pub(crate) fn make_case(rng: &mut Rng, f: &Fixtures, d: &Path) -> Case {
    let binary = |rng: &mut Rng, base: &Path, name: &str| {
        let (b, what) = mutate_bytes(rng, &std::fs::read(base).expect("read fixture"));
        let p = d.join(name);
        std::fs::write(&p, b).expect("write input");
        (s(&p), what)
    };
    let out = s(&d.join("out.csv"));
    let rep = s(&d.join("rep"));
    let kind = rng.below(100);
    let (mut case, label, name) = match kind {
        // Error tables and test points (CSV).
        0..=17 => {
            let points = rng.chance(4);
            let base = if points { &f.table2 } else { &f.table1 };
            let name = "m-table.csv";
            // Points may repeat (predictions, volumetric grid points); nodes may not.
            let k = rng.below(12);
            let repeats_refused = !points && k != 11;
            let (m, what, refuse) =
                text_case(rng, d, base, name, |r, t| mutate_csv(r, t, repeats_refused));
            let m = s(&m);
            let (t1, t2) = (s(&f.table1), s(&f.table2));
            let (t, p) = if points { (&t1, &m) } else { (&m, &t2) };
            let case = table_command(rng, k, f, t, p, &m, d).refusing(refuse);
            (case, format!("table: {what}"), name)
        }
        // Error tables (Parquet).
        18..=21 => {
            let (m, what) = binary(rng, &f.table_parquet, "m-table.parquet");
            let t2 = s(&f.table2);
            let args = cmd(
                "fit {m} --method trilinear --predict {p} --out {out}",
                &[("m", &m), ("p", &t2), ("out", &out)],
            );
            let case = Case::new(String::new(), args, "", vec![d.join("out.csv")]);
            (case, format!("parquet table: {what}"), "m-table.parquet")
        }
        // Session tables (CSV).
        22..=45 => {
            let base = &f.sessions[rng.below(f.sessions.len())];
            let name = "m-session.csv";
            let (m, what, refuse) = text_case(rng, d, base, name, |r, t| mutate_csv(r, t, true));
            let case = session_command(rng, f, &s(&m), d).refusing(refuse);
            let base = base.file_name().unwrap_or_default().to_string_lossy();
            (case, format!("session {base}: {what}"), name)
        }
        // Session tables (Parquet).
        46..=48 => {
            let (m, what) = binary(rng, &f.session_parquet, "m-session.parquet");
            let args = cmd("table {m} --out {out}", &[("m", &m), ("out", &out)]);
            let case = Case::new(String::new(), args, "", vec![d.join("out.csv")]);
            (
                case,
                format!("parquet session: {what}"),
                "m-session.parquet",
            )
        }
        // Raw captures.
        49..=56 => {
            let (m, what) = binary(rng, &f.raw, "m-raw.bin");
            let o = d.join(rng.pick(&["out.csv", "out.csv", "out.parquet"]));
            let json = rng.pick(&["", " --json"]);
            let args = cmd(
                &format!("replay {{m}} --out {{o}}{json}"),
                &[("m", &m), ("o", &s(&o))],
            );
            (
                Case::new(String::new(), args, "", vec![o]),
                format!("raw: {what}"),
                "m-raw.bin",
            )
        }
        // Machine models.
        57..=66 => {
            let k = rng.below(f.models.len());
            let name = "m-model.toml";
            let (m, what, refuse) =
                text_case(rng, d, &f.models[k], name, |r, t| mutate_toml(r, t, false));
            let vars = [
                ("m", s(&m)),
                ("plan", s(&f.plans[k])),
                ("s", s(&f.sessions[0])),
                ("out", out.clone()),
                ("rep", rep.clone()),
            ];
            let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
            let case = if rng.chance(12) {
                let t = "diagnose --recorded {s} --model {m} --report {rep} --json";
                Case::new(String::new(), cmd(t, &vars), "", vec![d.join("rep")])
            } else {
                let t = "simulate --model {m} --plan {plan} --out {out}";
                Case::new(String::new(), cmd(t, &vars), "", vec![d.join("out.csv")])
            };
            (case.refusing(refuse), format!("model: {what}"), name)
        }
        // Measurement plans.
        67..=73 => {
            let k = rng.below(f.plans.len());
            let name = "m-plan.toml";
            let (m, what, refuse) =
                text_case(rng, d, &f.plans[k], name, |r, t| mutate_toml(r, t, false));
            let args = cmd(
                "simulate --model {model} --plan {m} --out {out}",
                &[("model", &s(&f.models[k])), ("m", &s(&m)), ("out", &out)],
            );
            let case = Case::new(String::new(), args, "", vec![d.join("out.csv")]);
            (case.refusing(refuse), format!("plan: {what}"), name)
        }
        // Volumetric machine models and plans.
        74..=79 => {
            let model = rng.chance(2);
            let (base, name) = match model {
                true => (&f.vol_model, "m-vmodel.toml"),
                false => (&f.vol_plan, "m-vplan.toml"),
            };
            let (m, what, refuse) = text_case(rng, d, base, name, |r, t| mutate_toml(r, t, false));
            let (vm, vp) = match model {
                true => (s(&m), s(&f.vol_plan)),
                false => (s(&f.vol_model), s(&m)),
            };
            let ngc = d.join("out.ngc");
            let vars = [
                ("vm", vm.as_str()),
                ("vp", vp.as_str()),
                ("t2", &s(&f.table2)),
                ("out", &out),
                ("ngc", &s(&ngc)),
            ];
            let (t, o) = match (model, rng.chance(3)) {
                (true, true) => (
                    "volumetric predict --model {vm} --grid {t2} --out {out}",
                    d.join("out.csv"),
                ),
                (false, true) => ("volumetric program --plan {vp} --out {ngc}", ngc.clone()),
                _ => (
                    "volumetric simulate --model {vm} --plan {vp} --out {out}",
                    d.join("out.csv"),
                ),
            };
            let case = Case::new(String::new(), cmd(t, &vars), "", vec![o]);
            (case.refusing(refuse), format!("volumetric: {what}"), name)
        }
        // Volumetric line tables.
        80..=84 => {
            let name = "m-lines.csv";
            let (m, what, refuse) =
                text_case(rng, d, &f.lines, name, |r, t| mutate_csv(r, t, false));
            let o = d.join("out.json");
            let vars = [("m", s(&m)), ("vj", s(&f.vol_json)), ("o", s(&o))];
            let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
            let t = match rng.chance(3) {
                true => "volumetric predict --model {vj} --lines {m} --json",
                false => "volumetric identify {m} --topology YXZ --degree 2 --out {o} --json",
            };
            let case = Case::new(String::new(), cmd(t, &vars), "", vec![o]);
            (case.refusing(refuse), format!("lines: {what}"), name)
        }
        // Identified volumetric models (JSON).
        85..=86 => {
            let name = "m-vmodel.json";
            let (m, what, _) = text_case(rng, d, &f.vol_json, name, |r, t| mutate_toml(r, t, true));
            let ax = d.join("axes");
            let vars = [
                ("m", s(&m)),
                ("t2", s(&f.table2)),
                ("out", out),
                ("ax", s(&ax)),
            ];
            let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
            let case = match rng.chance(2) {
                true => Case::new(
                    String::new(),
                    cmd(
                        "volumetric predict --model {m} --grid {t2} --out {out}",
                        &vars,
                    ),
                    "",
                    vec![d.join("out.csv")],
                ),
                false => Case::new(
                    String::new(),
                    cmd("volumetric export --model {m} --axis-tables {ax}", &vars),
                    "",
                    vec![ax],
                ),
            };
            (case, format!("volumetric json: {what}"), name)
        }
        // Certificate info.
        87 => {
            let name = "m-info.toml";
            let (m, what, refuse) =
                text_case(rng, d, &f.info, name, |r, t| mutate_toml(r, t, false));
            let pdf = d.join("out.pdf");
            let session = s(&f.sessions[f.sessions.len() - 1]);
            let args = cmd(
                "certificate {s} --info {m} --out {pdf}",
                &[("s", &session), ("m", &s(&m)), ("pdf", &s(&pdf))],
            );
            let case = Case::new(String::new(), args, "", vec![pdf]);
            (case.refusing(refuse), format!("info: {what}"), name)
        }
        88..=90 => return alias_case(rng, f, d),
        91 => return closed_stdout_case(rng, f, d),
        _ => return flag_case(rng, f, d),
    };
    case.label = label;
    case.names = vec![name.to_string()];
    case
}

fn alias_case(rng: &mut Rng, f: &Fixtures, d: &Path) -> Case {
    let copy = |src: &Path, name: &str| {
        let p = d.join(name);
        std::fs::copy(src, &p).expect("copy input");
        s(&p)
    };
    let k = rng.below(10);
    let victim = match k {
        0 => copy(&f.sessions[0], "in.csv"),
        9 => copy(&f.sessions[f.sessions.len() - 1], "in.csv"),
        1 | 3 | 6 => copy(&f.table1, "in.csv"),
        2 => copy(&f.table2, "in.csv"),
        4 => copy(&f.raw, "in.bin"),
        5 => copy(&f.plans[0], "in.toml"),
        8 => copy(&f.vol_plan, "in.toml"),
        _ => copy(&f.lines, "in.csv"),
    };
    // The output under another name: a symbolic link to the input.
    let link = s(&d.join("link"));
    #[cfg(unix)]
    let through_link = rng.chance(2);
    #[cfg(not(unix))]
    let through_link = false;
    #[cfg(unix)]
    if through_link {
        std::os::unix::fs::symlink(&victim, &link).expect("symlink");
    }
    let o = if through_link { link } else { victim.clone() };
    let model = d.join("model.toml");
    if k == 6 {
        // A model whose error table is the victim, given again as --raw.
        let text = std::fs::read_to_string(&f.models[0]).expect("model");
        let text: Vec<String> = text
            .lines()
            .map(|l| match l.starts_with("table = ") {
                true => format!("table = \"{victim}\""),
                false => l.to_string(),
            })
            .collect();
        std::fs::write(&model, text.join("\n")).expect("write model");
    }
    let vars = [
        ("v", victim.as_str()),
        ("o", &o),
        ("t1", &s(&f.table1)),
        ("t2", &s(&f.table2)),
        ("model", &s(&f.models[0])),
        ("m6", &s(&model)),
        ("plan", &s(&f.plans[0])),
        ("vmodel", &s(&f.vol_model)),
        ("out", &s(&d.join("out.csv"))),
    ];
    let template = match k {
        0 => "table {v} --out {o}",
        1 => "fit {v} --method spline --predict {t2} --out {o}",
        2 => "fit {t1} --method spline --predict {v} --out {o}",
        3 => "export {v} --method spline --format csv --at y=1,z=200 --step 50 --out {o}",
        4 => "replay {v} --out {o}",
        5 => "simulate --model {model} --plan {v} --out {o}",
        6 => "simulate --model {m6} --plan {plan} --out {out} --raw {o}",
        7 => "volumetric identify {v} --topology YXZ --degree 2 --out {o}",
        8 => "volumetric simulate --model {vmodel} --plan {v} --out {o}",
        _ => "certificate {v} --out {o}",
    };
    let link_words = if through_link {
        " (through a symlink)"
    } else {
        ""
    };
    Case {
        label: format!("alias: {template}{link_words}"),
        args: cmd(template, &vars),
        names: vec!["--out".into(), "--raw".into()],
        outputs: vec![],
        expect: Expect::Alias,
        closed_stdout: false,
    }
}

fn closed_stdout_case(rng: &mut Rng, f: &Fixtures, d: &Path) -> Case {
    let out = d.join("out.csv");
    let vars = [
        ("t1", s(&f.table1)),
        ("t2", s(&f.table2)),
        ("s", s(&f.sessions[0])),
        ("raw", s(&f.raw)),
        ("vj", s(&f.vol_json)),
        ("l", s(&f.lines)),
        ("out", s(&out)),
    ];
    let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let template = rng.pick(&[
        "fit {t1} --method spline --predict {t2} --json",
        "table {s} --out {out} --json",
        "replay {raw} --out {out} --json",
        "volumetric predict --model {vj} --lines {l} --json",
        "volumetric identify {l} --topology YXZ --degree 2 --json",
    ]);
    Case {
        label: format!("stdout closed: {template}"),
        args: cmd(template, &vars),
        names: vec![],
        outputs: vec![out],
        expect: Expect::Data,
        closed_stdout: true,
    }
}

/// Each row: `command | flag | values outside its domain | values at its edge`, the
/// values separated by spaces (`''` is the empty value). The command's placeholders:
/// `{t1}` `{t2}` error tables, `{s}` a session, `{m}` a model, `{l}` a line table, `{vj}`
/// an identified model, `{out}` `{rep}` outputs.
const FLAGS: &str = "
fit {t1} --method spline --predict {t2} --out {out} | --threads | -1 abc 1.5 '' | 0 100000 4294967296
fit {t1} --method fuzzy --predict {t2} --out {out} | --fuzzy-sigma | 0 -1 nan inf abc 1e9 | 1e-9 100
fit {t1} --method lagrange --order auto --predict {t2} --out {out} | --max-degree | -1 abc | 0 1 50 100000
fit {t1} --method lagrange --predict {t2} --out {out} | --order | axbxc 4x1 -1x1x1 1.5x1x1 '' x 1x1x1x1 nanxnanxnan | 0x0x0 9x9x9 1000x1x1 auto 4x1x2
fit {t1} --predict {t2} --out {out} | --method | bogus '' spline,trilinear |
fit {t1} --method gp --predict {t2} --out {out} | --gp-kernel | bogus '' |
compare {t1} --test {t2} --report {rep} | --methods | bogus trilinear,bogus '' | spline,spline
compare {t1} --test {t2} --methods lagrange --report {rep} | --orders | 4x1 bogus 2x1x1,, -1x1x1 | 9x9x9 0x0x0
export {t1} --method spline --format linuxcnc --at y=1,z=200 --out {out} | --step | 0 -1 nan inf abc 1e7 | 1e-9 0.001 1000 799
export {t1} --method spline --format linuxcnc --step 50 --out {out} | --at | y=1,y=2 q=1 y=nan y=inf y =1 y=1;z=2 y=1e308 | x=5 y=1e6,z=0 ,,,
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} | --axis | w '' | z
export {t1} --method spline --at y=1,z=200 --step 50 --out {out} | --format | bogus '' |
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} | --comp-type | bogus |
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} | --start | nan inf -inf abc 1e308 -1e308 | -1e6 800 1e6
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} | --end | nan inf abc 1e308 | 0 -5
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --ends clamp --out {out} | --reference | nan inf abc 1e308 | -1e6 3
export {t1} --method spline --format siemens --at y=1,z=200 --step 50 --out {out} | --siemens-axis | '' X\\n1 | Y1
export {t1} --method spline --format linuxcnc --at y=1,z=200 --step 50 --out {out} | --max-points | 0 1 -1 | 2 3
export {t1} --method spline --format fanuc --at y=1,z=200 --step 50 --out {out} | --detection-unit-um | 0 -1 nan | 1e-3 1e6
export {t1} --method spline --format fanuc --at y=1,z=200 --step 50 --out {out} | --magnification | -1 abc | 0 4294967295
diagnose --recorded {s} --report {rep} | --grating-period-um | 0 -1 nan inf abc |
diagnose --recorded {s} --report {rep} | --max-dead-path-mm | 0 -1 nan inf |
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --from | nan inf -inf abc 1e308 | 100 -1e6
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --to | nan inf abc 1e308 | 0
plan --axis x --from 0 --to 100 --out {out} | --targets | -1 abc | 0 1 100000 1000000000
plan --axis x --from 0 --to 100 --out {out} | --interval | 0 -1 nan inf | 1e-9 1000
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --runs | -1 abc | 0 1000000
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --overrun | -1 nan inf | 0 1e6
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --dwell-s | -1 nan inf | 0 1e9
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --feed-mm-s | 0 -1 nan inf | 1e-9 1e6
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --at | y=1,y=2 q=1 y=nan | x=5
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --random-offset | 0.5 -0.1 nan inf | 0 0.49
plan --axis x --from 0 --to 100 --targets 5 --out {out} | --dialect | bogus | fanuc
plan --from 0 --to 100 --targets 5 --out {out} | --axis | w '' |
volumetric identify {l} --degree 2 | --topology | XXZ ABC '' XY XYZX | xyz ZYX
volumetric identify {l} --topology YXZ | --degree | -1 abc '' 0 1000 | 1 auto-each 12
volumetric identify {l} --topology YXZ --degree auto | --max-degree | -1 abc 0 1000 | 1 5
volumetric identify {l} --topology YXZ --degree 2 | --component-degree | E_QQ=2 E_XX= E_XX=-1 E_XX=abc == E_XX=1000 | E_XX=9
volumetric identify {l} --topology YXZ --degree 2 | --positions | -1 abc | 0 1 1000000
volumetric predict --model {vj} --grid {t2} --out {out} | --probe | 1,2 nan,0,0 a,b,c 1,2,3,4 inf,0,0 1e308,0,0 | 1e6,0,0
volumetric export --model {vj} --axis-tables {rep} | --at | 1,2 nan,0,0 x | 1e6,0,0
volumetric export --model {vj} --axis-tables {rep} | --points | -1 abc 0 1 | 2 100000
volumetric export --model {vj} --axis-tables {rep} | --format | bogus | siemens
volumetric lines {s} --out {out} | --probe | 1,2 nan,0,0 |
capture --port /nonexistent/port --out {rep} | --baud | 0 1 -1 abc |
capture --port /nonexistent/port --out {rep} | --duration | -1 nan inf |
capture --port /nonexistent/port --out {rep} | --idle-timeout | -1 nan |
capture --port /nonexistent/port --out {rep} | --format | bogus |
serve-sim --model {m} --stall-timeout 1 | --speed | 0 -1 nan inf 1e-300 |
serve-sim --model {m} --stall-timeout 1 | --linger | -1 nan |
";

fn flag_case(rng: &mut Rng, f: &Fixtures, d: &Path) -> Case {
    let rows: Vec<Vec<&str>> = FLAGS
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    let row = &rows[rng.below(rows.len())];
    let (template, flag) = (row[0], row[1]);
    let bad: Vec<&str> = row[2].split_whitespace().collect();
    let edge: Vec<&str> = row[3].split_whitespace().collect();
    let use_edge = !edge.is_empty() && rng.chance(3);
    let value = match rng.pick(if use_edge { &edge } else { &bad }) {
        "''" => String::new(),
        v => v.replace("\\n", "\n"),
    };
    let session = s(&f.sessions[f.sessions.len() - 1]);
    let vars = [
        ("t1", s(&f.table1)),
        ("t2", s(&f.table2)),
        ("s", session),
        ("m", s(&f.models[0])),
        ("l", s(&f.lines)),
        ("vj", s(&f.vol_json)),
        ("out", s(&d.join("out.csv"))),
        ("rep", s(&d.join("rep"))),
    ];
    let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let mut args = cmd(template, &vars);
    // A value at the edge may fail for what it does to the data: the message then names
    // the flag or an input file.
    let mut names = vec![flag.to_string()];
    if use_edge {
        names.extend(args.iter().filter_map(|a| {
            let p = Path::new(a);
            p.is_file()
                .then(|| p.file_name().unwrap_or_default().to_string_lossy().into())
        }));
    }
    // `--flag=value` keeps values such as `-1` and `` a value, not a flag or nothing.
    args.push(format!("{flag}={value}"));
    Case {
        label: format!(
            "flag {flag}={value:?}{}",
            if use_edge { " (edge)" } else { "" }
        ),
        args,
        names,
        outputs: vec![d.join("out.csv"), d.join("rep")],
        expect: if use_edge {
            Expect::Flag
        } else {
            Expect::Usage
        },
        closed_stdout: false,
    }
}
