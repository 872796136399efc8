//! Simulated laser campaigns: a volumetric measurement plan (TOML) with presets, the time
//! each line takes, and a line table from a machine model with seeded noise and a
//! per-line laser zero.
//!
//! # Plan file (`datasets/volumetric/plan.toml`)
//!
//! Top level: `seed`, `noise_um` (one-sigma of one reading, default 0.1), `laser_zero_um`
//! (one-sigma of each line's unknown zero, default 5), `runs` (default 1), `feed_mm_s`
//! (default 20), `dwell_s` (settling and averaging at a target, default 4), `setup_s`
//! (aligning the laser to a new line, default 600), and either `preset` with `volume_mm =
//! [[x0, y0, z0], [x1, y1, z1]]`, `targets` (default 11) and `probe_offset_mm` (default
//! 100), or `[[line]]` tables, or both (the preset's lines first). A `[[line]]` has
//! `start_mm`, then `end_mm` or `direction` (normalised) and `length_mm`, and optionally
//! `name`, `targets`, `probe_mm` and `runs`.
//!
//! # Thermal history
//!
//! An optional `[thermal]` table gives the scales' temperature during the campaign,
//! `start_c` at t = 0 approaching `end_c` exponentially with time constant `tau_s`:
//! T(t) = end_c + (start_c − end_c)·exp(−t/τ) (a machine warming up after the shop
//! opens). Each reading then sees the machine model's scale expansion at T(t) (the
//! positioning components gain α·(T − 20)·a·1e−3 µm, α the model's
//! `scale_alpha_ppm_per_k`; [`super::model`]), and every row gets `scale_temp_c`, the
//! mean of T over its runs' reading times. Without `[thermal]` the scales stay at 20 °C
//! and no temperature is written.
//!
//! # Timing
//!
//! Each line starts with `setup_s`; each run moves from target to target at `feed_mm_s`,
//! dwells `dwell_s` and reads at the end of the dwell, then returns to the start. A row is
//! the mean of its runs; its `t_s` the mean reading time and `s_um` = noise/√runs.
//!
//! # Presets
//!
//! * `zhang22` — 22 lines in the spirit of the displacement method of Zhang, Ouyang, Lu,
//!   Hocken, Veale and Donmez (CIRP Annals 37/1, 1988). The paper's exact line list could
//!   not be consulted, so this is our set of 22 chosen to determine all 21 errors for
//!   every topology (checked by the identifiability analysis in the tests): per axis a
//!   line along it through the box's lower corner, and two more with the probe offset along
//!   each other axis (9 lines: positioning and the two rotations seen by Abbe offsets);
//!   per plane both face diagonals, one diagonal with a probe offset across the plane
//!   (rolls) and one half-length diagonal parallel to the first, shifted (separates the
//!   two straightnesses of the plane) (12 lines); and one body diagonal.
//! * `rich` — 43 lines: per axis four lines along it at the four corners of the other two
//!   ranges and two at the centre with probe offsets along the other axes (18); per plane
//!   both face diagonals at the low and the high end of the third axis, two half-length
//!   shifted parallels and one diagonal with a probe offset across the plane (21); the four
//!   body diagonals.

use std::path::Path;

use rand::SeedableRng;
use rand::rngs::StdRng;
use serde::Deserialize;

use super::error::{UnknownPreset, VolumetricError, config_err};
use super::lines::{Line, LineTable, Target};
use super::model::{AXES, Machine};
use crate::base::gaussian;
use crate::base::read_toml;

/// The plan file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanFile {
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "d_noise")]
    pub noise_um: f64,
    #[serde(default = "d_zero")]
    pub laser_zero_um: f64,
    #[serde(default = "d_one")]
    pub runs: u32,
    #[serde(default = "d_feed")]
    pub feed_mm_s: f64,
    #[serde(default = "d_dwell")]
    pub dwell_s: f64,
    #[serde(default = "d_setup")]
    pub setup_s: f64,
    pub preset: Option<String>,
    pub volume_mm: Option<[[f64; 3]; 2]>,
    #[serde(default = "d_targets")]
    pub targets: usize,
    pub probe_offset_mm: Option<f64>,
    #[serde(default, rename = "line")]
    pub lines: Vec<LineSpec>,
    pub thermal: Option<ThermalHistory>,
}

/// The scales' temperature over the campaign (`[thermal]`):
/// T(t) = end_c + (start_c − end_c)·exp(−t/tau_s).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalHistory {
    pub start_c: f64,
    pub end_c: f64,
    pub tau_s: f64,
}

impl ThermalHistory {
    /// The scale temperature at `t_s`, °C.
    pub fn temp_c(&self, t_s: f64) -> f64 {
        self.end_c + (self.start_c - self.end_c) * (-t_s / self.tau_s).exp()
    }
}

fn d_noise() -> f64 {
    0.1
}
fn d_zero() -> f64 {
    5.0
}
fn d_one() -> u32 {
    1
}
fn d_feed() -> f64 {
    20.0
}
fn d_dwell() -> f64 {
    4.0
}
fn d_setup() -> f64 {
    600.0
}
fn d_targets() -> usize {
    11
}

/// One `[[line]]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineSpec {
    pub name: Option<String>,
    pub start_mm: [f64; 3],
    pub end_mm: Option<[f64; 3]>,
    pub direction: Option<[f64; 3]>,
    pub length_mm: Option<f64>,
    pub targets: Option<usize>,
    #[serde(default)]
    pub probe_mm: [f64; 3],
    pub runs: Option<u32>,
}

/// A validated line of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedLine {
    pub name: String,
    pub start_mm: [f64; 3],
    /// Unit direction.
    pub u: [f64; 3],
    pub length_mm: f64,
    pub targets: usize,
    pub probe_mm: [f64; 3],
    pub runs: u32,
}

/// A validated plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub seed: u64,
    pub noise_um: f64,
    pub laser_zero_um: f64,
    pub feed_mm_s: f64,
    pub dwell_s: f64,
    pub setup_s: f64,
    pub lines: Vec<PlannedLine>,
    pub thermal: Option<ThermalHistory>,
}

impl Plan {
    /// The plan's lines as a part program's campaign (`controller::program`):
    /// each line's targets in order, its runs, the plan's feed and dwell.
    pub fn lines_program(&self, title: &str) -> crate::sim::LinesProgram {
        use crate::sim::{LinesProgram, ProgramLine};
        LinesProgram {
            title: title.to_string(),
            lines: self
                .lines
                .iter()
                .map(|l| ProgramLine {
                    name: l.name.clone(),
                    targets_mm: l.target_positions(),
                    runs: l.runs,
                    probe_mm: l.probe_mm,
                })
                .collect(),
            feed_mm_s: self.feed_mm_s,
            dwell_s: self.dwell_s,
        }
    }
}

impl PlannedLine {
    /// The targets in the order they are visited: `targets` points evenly from the start
    /// over the length.
    pub fn target_positions(&self) -> Vec<[f64; 3]> {
        let n = self.targets;
        (0..n)
            .map(|i| {
                let s = self.length_mm * i as f64 / (n - 1) as f64;
                [0, 1, 2].map(|k| self.start_mm[k] + s * self.u[k])
            })
            .collect()
    }
}

fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n > 0.0 && n.is_finite()).then(|| v.map(|c| c / n))
}

/// The smallest extent of a preset's volume along an axis, mm.
pub(crate) const MIN_EXTENT_MM: f64 = 1e-3;

/// The slowest feed of a plan, mm/s.
pub(crate) const MIN_FEED_MM_S: f64 = 1e-3;

impl PlanFile {
    pub fn read(path: &Path) -> Result<Plan, VolumetricError> {
        let f: PlanFile = read_toml::<_, VolumetricError>(path, crate::sim::check_numbers)?;
        f.validate(path)
    }

    pub fn validate(&self, path: &Path) -> Result<Plan, VolumetricError> {
        self.check_scalars(path)?;
        let mut lines = match &self.preset {
            Some(name) => self.preset_lines(path, name)?,
            None => Vec::new(),
        };
        for (i, l) in self.lines.iter().enumerate() {
            let line = self.planned_line(path, i, l, lines.len())?;
            lines.push(line);
        }
        check_lines(path, &lines)?;
        Ok(Plan {
            seed: self.seed,
            noise_um: self.noise_um,
            laser_zero_um: self.laser_zero_um,
            feed_mm_s: self.feed_mm_s,
            dwell_s: self.dwell_s,
            setup_s: self.setup_s,
            lines,
            thermal: self.thermal,
        })
    }

    /// Checks the plan's scalars (noise, zero, feed, dwell, set-up, runs) and the thermal
    /// history before any line is made.
    fn check_scalars(&self, path: &Path) -> Result<(), VolumetricError> {
        let scalars = [
            ("noise_um", self.noise_um, true),
            ("laser_zero_um", self.laser_zero_um, true),
            ("feed_mm_s", self.feed_mm_s, false),
            ("dwell_s", self.dwell_s, true),
            ("setup_s", self.setup_s, true),
        ];
        for (key, v, zero_ok) in scalars {
            if !v.is_finite() || v < 0.0 || (!zero_ok && v == 0.0) {
                return Err(config_err(
                    path,
                    key,
                    format!(
                        "{v} must be a finite {} number",
                        if zero_ok { "non-negative" } else { "positive" }
                    ),
                ));
            }
        }
        // A move of 10⁶ mm (the position bound) then takes at most 10⁹ s (the time
        // bound); a feed of 5e-324 mm/s made every time stamp infinite.
        if self.feed_mm_s < MIN_FEED_MM_S {
            return Err(config_err(
                path,
                "feed_mm_s",
                format!(
                    "{:e} mm/s is below the slowest feed, {MIN_FEED_MM_S} mm/s",
                    self.feed_mm_s
                ),
            ));
        }
        if self.runs == 0 {
            return Err(config_err(path, "runs", "at least 1 run"));
        }
        if let Some(th) = &self.thermal {
            for (key, v) in [("thermal.start_c", th.start_c), ("thermal.end_c", th.end_c)] {
                if !(v.is_finite() && (-50.0..=150.0).contains(&v)) {
                    return Err(config_err(
                        path,
                        key,
                        format!("{v} °C: a scale temperature between −50 and 150 °C"),
                    ));
                }
            }
            if !(th.tau_s.is_finite() && th.tau_s > 0.0) {
                return Err(config_err(
                    path,
                    "thermal.tau_s",
                    format!("{} must be a positive time constant in seconds", th.tau_s),
                ));
            }
        }
        Ok(())
    }

    /// The preset's lines in the plan's volume (checked: finite corners at least
    /// `MIN_EXTENT_MM` apart, 3 targets, a finite probe offset).
    fn preset_lines(&self, path: &Path, name: &str) -> Result<Vec<PlannedLine>, VolumetricError> {
        let Some(vol) = self.volume_mm else {
            return Err(config_err(
                path,
                "volume_mm",
                "a preset needs volume_mm = [[x0, y0, z0], [x1, y1, z1]]",
            ));
        };
        // At least a micrometre along each axis: a box 5e-324 mm wide made NaN
        // line directions.
        if vol.iter().flatten().any(|v| !v.is_finite())
            || (0..3).any(|k| vol[1][k] - vol[0][k] < MIN_EXTENT_MM)
        {
            return Err(config_err(
                path,
                "volume_mm",
                "corners must be finite with x1 > x0, y1 > y0, z1 > z0, each at least \
                 0.001 mm apart",
            ));
        }
        if self.targets < 3 {
            return Err(config_err(
                path,
                "targets",
                "a line needs at least 3 targets",
            ));
        }
        let p = self.probe_offset_mm.unwrap_or(100.0);
        if !p.is_finite() {
            return Err(config_err(path, "probe_offset_mm", "not finite"));
        }
        preset(name, vol, self.targets, p, self.runs)
            .map_err(|m| config_err(path, "preset", m.to_string()))
    }

    /// `[[line]]` table `i` (0-based) as a planned line, `n_before` lines already planned
    /// (for its default name): end point, or direction and length; targets and runs.
    fn planned_line(
        &self,
        path: &Path,
        i: usize,
        l: &LineSpec,
        n_before: usize,
    ) -> Result<PlannedLine, VolumetricError> {
        let key = |f: &str| format!("line[{}].{f}", i + 1);
        let all = l
            .start_mm
            .iter()
            .chain(l.end_mm.iter().flatten())
            .chain(l.direction.iter().flatten())
            .chain(l.length_mm.iter())
            .chain(l.probe_mm.iter());
        if all.clone().any(|v| !v.is_finite()) {
            return Err(config_err(path, key("start_mm"), "a value is not finite"));
        }
        let (u, len) = match (l.end_mm, l.direction, l.length_mm) {
            (Some(end), None, None) => {
                let d = [0, 1, 2].map(|k| end[k] - l.start_mm[k]);
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let u =
                    unit(d).ok_or_else(|| config_err(path, key("end_mm"), "end equals start"))?;
                (u, len)
            }
            (None, Some(d), Some(len)) => {
                let u =
                    unit(d).ok_or_else(|| config_err(path, key("direction"), "zero direction"))?;
                if len <= 0.0 {
                    return Err(config_err(
                        path,
                        key("length_mm"),
                        format!("{len} must be positive"),
                    ));
                }
                (u, len)
            }
            _ => {
                return Err(config_err(
                    path,
                    key("end_mm"),
                    "give either end_mm, or direction and length_mm",
                ));
            }
        };
        let targets = l.targets.unwrap_or(self.targets);
        if targets < 3 {
            return Err(config_err(
                path,
                key("targets"),
                format!("{targets}: a line needs at least 3 targets"),
            ));
        }
        let runs = l.runs.unwrap_or(self.runs);
        if runs == 0 {
            return Err(config_err(path, key("runs"), "at least 1 run"));
        }
        Ok(PlannedLine {
            name: l
                .name
                .clone()
                .unwrap_or_else(|| format!("L{}", n_before + 1)),
            start_mm: l.start_mm,
            u,
            length_mm: len,
            targets,
            probe_mm: l.probe_mm,
            runs,
        })
    }
}

/// The most readings (targets × runs, over all lines) a simulated campaign may have:
/// checked before anything is allocated. A real laser campaign has a few thousand (43
/// lines × 50 targets × 5 runs is 10 750); 200 000 is a line table of ~20 MB.
pub const MAX_READINGS: u64 = 200_000;

/// Names of the presets.
pub(crate) const PRESETS: [&str; 2] = ["zhang22", "rich"];
/// Refuses a plan without lines, with more readings than a campaign may have (checked
/// before any target is made) or with a line name used twice.
fn check_lines(path: &Path, lines: &[PlannedLine]) -> Result<(), VolumetricError> {
    if lines.is_empty() {
        return Err(config_err(
            path,
            "line",
            "no lines: give a preset or [[line]] tables",
        ));
    }
    // Before any target is made (issue 28: `targets = 100000` silently made 4.3 M).
    let readings: u64 = lines
        .iter()
        .map(|l| l.targets as u64 * u64::from(l.runs))
        .sum();
    if readings > MAX_READINGS {
        return Err(config_err(
            path,
            "targets",
            format!(
                "{} lines with these targets and runs make {readings} readings, more than \
                 the {MAX_READINGS} a campaign may have",
                lines.len()
            ),
        ));
    }
    let mut names: Vec<&str> = lines.iter().map(|l| l.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(config_err(
            path,
            "line",
            format!("line name `{}` is used twice", w[0]),
        ));
    }
    Ok(())
}

fn e(k: usize, v: f64) -> [f64; 3] {
    let mut x = [0.0; 3];
    x[k] = v;
    x
}

/// A preset's lines being built over the box `lo`–`hi`: the shared settings and the
/// line shapes (along an axis, along a plane's diagonal) every preset is made of.
struct PresetBox {
    lo: [f64; 3],
    hi: [f64; 3],
    mid: [f64; 3],
    targets: usize,
    probe: f64,
    runs: u32,
    out: Vec<PlannedLine>,
}

impl PresetBox {
    /// Adds the line `name` from `start` to `end` with probe offset `p`.
    fn push(&mut self, name: String, start: [f64; 3], end: [f64; 3], p: [f64; 3]) {
        let d = [0, 1, 2].map(|k| end[k] - start[k]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        self.out.push(PlannedLine {
            name,
            start_mm: start,
            u: d.map(|c| c / len),
            length_mm: len,
            targets: self.targets,
            probe_mm: p,
            runs: self.runs,
        });
    }

    /// The ends of the line along axis `k` through `base`, across the whole box.
    fn along(&self, k: usize, base: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let mut s = base;
        let mut t = base;
        s[k] = self.lo[k];
        t[k] = self.hi[k];
        (s, t)
    }

    /// A diagonal of plane (k, j) at third coordinate c (axis l), from fraction f0 to f1
    /// of the diagonal, shifted by `shift` of the k range; `minus` runs j downwards.
    fn diag(
        &self,
        (k, j, l): (usize, usize, usize),
        c: f64,
        minus: bool,
        (f0, f1): (f64, f64),
        shift: f64,
    ) -> ([f64; 3], [f64; 3]) {
        let (lo, hi) = (self.lo, self.hi);
        let mut s = [0.0; 3];
        let mut t = [0.0; 3];
        s[l] = c;
        t[l] = c;
        let (sk, sj) = (hi[k] - lo[k], hi[j] - lo[j]);
        s[k] = lo[k] + shift * sk + f0 * sk;
        t[k] = lo[k] + shift * sk + f1 * sk;
        if minus {
            s[j] = hi[j] - f0 * sj;
            t[j] = hi[j] - f1 * sj;
        } else {
            s[j] = lo[j] + f0 * sj;
            t[j] = lo[j] + f1 * sj;
        }
        (s, t)
    }

    /// `zhang22`: the three axis lines with their probe offsets, three diagonals per
    /// plane (one with a probe offset, one on half the diagonal), one space diagonal.
    fn zhang22(&mut self) {
        let (lo, hi, probe) = (self.lo, self.hi, self.probe);
        for (k, name) in AXES.iter().enumerate() {
            let (s, t) = self.along(k, lo);
            self.push(format!("{name}0"), s, t, [0.0; 3]);
            for j in (0..3).filter(|&j| j != k) {
                self.push(format!("{name}p{}", AXES[j]), s, t, e(j, probe));
            }
        }
        for &(k, j, l) in &PLANES {
            let pl = plane_name(k, j);
            let (s, t) = self.diag((k, j, l), lo[l], false, (0.0, 1.0), 0.0);
            self.push(format!("D{pl}+"), s, t, [0.0; 3]);
            self.push(format!("D{pl}+p{}", AXES[l]), s, t, e(l, probe));
            let (s, t) = self.diag((k, j, l), lo[l], true, (0.0, 1.0), 0.0);
            self.push(format!("D{pl}-"), s, t, [0.0; 3]);
            let (s, t) = self.diag((k, j, l), lo[l], false, (0.0, 0.5), 0.5);
            self.push(format!("D{pl}+s"), s, t, [0.0; 3]);
        }
        self.push("B+++".into(), lo, hi, [0.0; 3]);
    }

    /// `rich`: four lines per axis along the box's edges and two through its middle with
    /// probe offsets, face and mid-plane diagonals per plane, the four space diagonals.
    fn rich(&mut self) {
        let (lo, hi, mid, probe) = (self.lo, self.hi, self.mid, self.probe);
        for (k, name) in AXES.iter().enumerate() {
            let others: Vec<usize> = (0..3).filter(|&j| j != k).collect();
            for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let mut base = lo;
                base[others[0]] = if a == 0 { lo[others[0]] } else { hi[others[0]] };
                base[others[1]] = if b == 0 { lo[others[1]] } else { hi[others[1]] };
                let (s, t) = self.along(k, base);
                self.push(format!("{name}{a}{b}"), s, t, [0.0; 3]);
            }
            for &j in &others {
                let (s, t) = self.along(k, mid);
                self.push(format!("{name}cp{}", AXES[j]), s, t, e(j, probe));
            }
        }
        for &(k, j, l) in &PLANES {
            let pl = plane_name(k, j);
            for (tag, c) in [("lo", lo[l]), ("hi", hi[l])] {
                let (s, t) = self.diag((k, j, l), c, false, (0.0, 1.0), 0.0);
                self.push(format!("D{pl}+{tag}"), s, t, [0.0; 3]);
                let (s, t) = self.diag((k, j, l), c, true, (0.0, 1.0), 0.0);
                self.push(format!("D{pl}-{tag}"), s, t, [0.0; 3]);
            }
            let (s, t) = self.diag((k, j, l), mid[l], false, (0.0, 0.5), 0.5);
            self.push(format!("D{pl}+s1"), s, t, [0.0; 3]);
            let (s, t) = self.diag((k, j, l), mid[l], false, (0.5, 1.0), -0.5);
            self.push(format!("D{pl}+s2"), s, t, [0.0; 3]);
            let (s, t) = self.diag((k, j, l), mid[l], false, (0.0, 1.0), 0.0);
            self.push(format!("D{pl}+p{}", AXES[l]), s, t, e(l, probe));
        }
        for (i, flip) in [[false, false], [true, false], [false, true], [true, true]]
            .iter()
            .enumerate()
        {
            let mut s = lo;
            let mut t = hi;
            if flip[0] {
                s[0] = hi[0];
                t[0] = lo[0];
            }
            if flip[1] {
                s[1] = hi[1];
                t[1] = lo[1];
            }
            self.push(format!("B{}", i + 1), s, t, [0.0; 3]);
        }
    }
}

/// The three planes as (k, j, l): the plane's two axes and the third.
const PLANES: [(usize, usize, usize); 3] = [(0, 1, 2), (0, 2, 1), (1, 2, 0)];

/// A plane's name from its two axes ("XY").
fn plane_name(k: usize, j: usize) -> String {
    format!("{}{}", AXES[k], AXES[j])
}

/// The lines of a preset over the box `vol`.
pub fn preset(
    name: &str,
    vol: [[f64; 3]; 2],
    targets: usize,
    probe: f64,
    runs: u32,
) -> Result<Vec<PlannedLine>, UnknownPreset> {
    let [lo, hi] = vol;
    let mid: [f64; 3] = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let mut b = PresetBox {
        lo,
        hi,
        mid,
        targets,
        probe,
        runs,
        out: Vec::new(),
    };
    match name {
        "zhang22" => b.zhang22(),
        "rich" => b.rich(),
        other => {
            return Err(UnknownPreset {
                name: other.to_string(),
                known: PRESETS.to_vec(),
            });
        }
    }
    Ok(b.out)
}

/// Simulates the campaign: a line table with e_um = −u·E + the line's zero + noise, the
/// mean of the runs at each target, t_s from the plan's timing; with a `[thermal]`
/// history, E at each reading's scale temperature and `scale_temp_c` on every row.
pub fn simulate(machine: &Machine, plan: &Plan) -> LineTable {
    let mut rng = StdRng::seed_from_u64(plan.seed);
    let mut t = 0.0;
    let mut lines = Vec::with_capacity(plan.lines.len());
    for pl in &plan.lines {
        t += plan.setup_s;
        let zero = plan.laser_zero_um * gaussian(&mut rng);
        let n = pl.targets;
        let pos = pl.target_positions();
        let step_s = pl.length_mm / (n - 1) as f64 / plan.feed_mm_s;
        let mut sum_e = vec![0.0; n];
        let mut sum_t = vec![0.0; n];
        let mut sum_temp = vec![0.0; n];
        for _ in 0..pl.runs {
            for i in 0..n {
                if i > 0 {
                    t += step_s;
                }
                t += plan.dwell_s;
                sum_t[i] += t;
                sum_e[i] += plan.noise_um * gaussian(&mut rng);
                if let Some(th) = &plan.thermal {
                    let temp = th.temp_c(t);
                    sum_temp[i] += temp;
                    // The scale's expansion alone: the rest of the model is added below.
                    sum_e[i] += machine.line_error_at_um(pos[i], pl.u, pl.probe_mm, temp)
                        - machine.line_error_um(pos[i], pl.u, pl.probe_mm);
                }
            }
            t += pl.length_mm / plan.feed_mm_s;
        }
        let runs = f64::from(pl.runs);
        let targets = pos
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let mut tg = Target::new(
                    p,
                    machine.line_error_um(p, pl.u, pl.probe_mm) + zero + sum_e[i] / runs,
                );
                tg.s_um = (plan.noise_um > 0.0).then(|| plan.noise_um / runs.sqrt());
                tg.t_s = Some(sum_t[i] / runs);
                tg.scale_temp_c = plan.thermal.map(|_| sum_temp[i] / runs);
                tg
            })
            .collect();
        lines.push(Line {
            id: pl.name.clone(),
            u: pl.u,
            probe_mm: pl.probe_mm,
            targets,
        });
    }
    LineTable {
        source: "simulated campaign".into(),
        lines,
    }
}
