//! The rigid-body, first-order model of a three-axis machine (spec `volumetric.md`,
//! ISO 230-1 names): topology, the 18 component errors, the 3 squareness errors, lever
//! arms and the volumetric error vector; and the machine-model TOML file.
//!
//! # Model
//!
//! The topology is the chain from the workpiece (on the base) to the probe, a
//! permutation of `XYZ`: `YXZ` is a moving-bridge CMM (Y on the base, X on Y, Z on X).
//! Axis k at position a carries six components, each zero at a = 0:
//! translations δ_k = (E_Xk, E_Yk, E_Zk) µm and rotations ε_k = (E_Ak, E_Bk, E_Ck) µrad,
//! right-handed about x, y, z. The lever arm of axis k is
//! r_k = Σ_{j after k in the chain} a_j·ê_j + p (mm), p the probe offset, and
//!
//! E(x, y, z; p) = Σ_k [δ_k(a_k) + 1e−3·ε_k(a_k) × r_k] + Δ_sq,
//! Δ_sq = 1e−3·(−E_C0Y·y + E_B0Z·z, −E_A0Z·z, 0) µm,
//!
//! the actual minus the nominal position of the probe point. The positions (x, y, z)
//! are the axis positions: a line table's `x_mm, y_mm, z_mm` are used as they are and
//! the probe offset enters only the lever arms, exactly as the spec writes E(P_i; p).
//!
//! # File (`datasets/volumetric/model.toml`)
//!
//! `topology`, a `[squareness_urad]` table (E_C0Y, E_B0Z, E_A0Z; absent = 0) and a
//! `[components]` table with one entry per non-zero component: either
//! `{ poly = [c1, c2, …], scale_mm = L }`, the polynomial Σ c_d·(a/L)^d (no constant
//! term; `scale_mm` defaults to 1), or `{ positions_mm = […], values = […], method = "…" }`,
//! a table interpolated along the axis by any errmap interpolator (`trilinear` — linear
//! along one axis — by default; `lagrange` takes `degree`). A table must contain 0 with
//! value 0. Unknown keys, misspelt component names and non-finite numbers are errors
//! naming the file and the key.
//!
//! # Scale temperature
//!
//! An optional top-level `scale_alpha_ppm_per_k` (absent: 0, scales that do not expand)
//! is the expansion coefficient of all three axes' scales (steel ≈ 11.5, glass ≈ 8,
//! glass ceramic ≈ 0). The components of the file are the machine **at 20 °C**; with the
//! scales at T, each positioning component gains the scale's expansion,
//!
//! E_kk(a; T) = E_kk(a) + α·(T − 20)·a·1e−3 µm  (α ppm/K, a mm),
//!
//! with the fixed point at the axis' reference position 0. The sign follows the spec's
//! E = actual − nominal: a scale longer than at 20 °C carries the axis further than it
//! indicates. A laser along +k then records e = −u·E ⊃ −α·ΔT·a·1e−3, exactly the
//! `scale_thermal_expansion` signature of `cli-contract.md` (r = −α·ΔT·(x − x0)·1e−3,
//! here x0 = 0) in the recorded error (indicated − reference).

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use serde::Deserialize;

use super::error::{ComponentTableError, UnknownComponent, VolumetricError, config_err};
use crate::base::read_toml;
use crate::interp::{Interpolator, Method, MethodName, MethodSettings, Order};
use crate::table::{ErrorPoint, ErrorTable};

/// Axis letters in index order.
pub(crate) const AXES: [char; 3] = ['X', 'Y', 'Z'];
/// The six kinds of component: translations along X, Y, Z and rotations A, B, C.
const KINDS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// The kinematic chain from the workpiece (base) to the probe: axis indices in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topology(pub [usize; 3]);

impl FromStr for Topology {
    type Err = VolumetricError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let letters: Vec<char> = s.trim().chars().map(|c| c.to_ascii_uppercase()).collect();
        let bad = || VolumetricError::Topology(s.to_string());
        if letters.len() != 3 {
            return Err(bad());
        }
        let mut chain = [0; 3];
        for (slot, c) in chain.iter_mut().zip(&letters) {
            *slot = AXES.iter().position(|a| a == c).ok_or_else(bad)?;
        }
        let mut seen = chain;
        seen.sort_unstable();
        if seen != [0, 1, 2] {
            return Err(bad());
        }
        Ok(Topology(chain))
    }
}

impl fmt::Display for Topology {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for &k in &self.0 {
            write!(f, "{}", AXES[k])?;
        }
        Ok(())
    }
}

/// Written as its letters (`"YXZ"`), read back through [`FromStr`].
impl serde::Serialize for Topology {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for Topology {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

impl Topology {
    /// Position of axis `k` in the chain (0: on the base).
    pub fn place(&self, k: usize) -> usize {
        self.0.iter().position(|&a| a == k).unwrap_or(0)
    }

    /// The axes carried by axis `k` (after it in the chain).
    pub fn after(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        self.0[self.place(k) + 1..].iter().copied()
    }

    /// The last axis of the chain (the one carrying the probe).
    pub fn last(&self) -> usize {
        self.0[2]
    }

    /// Lever arm of axis `k`, mm: r_k = Σ_{j after k} a_j·ê_j + p.
    pub fn lever_arm(&self, k: usize, pos_mm: [f64; 3], probe_mm: [f64; 3]) -> [f64; 3] {
        let mut r = probe_mm;
        for j in self.after(k) {
            r[j] += pos_mm[j];
        }
        r
    }
}

/// One of the 18 component errors: `axis` moves, `kind` 0..3 is a translation along
/// X, Y, Z (µm), 3..6 a rotation about x, y, z (µrad).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Component {
    pub axis: usize,
    pub kind: usize,
}

impl Component {
    /// All 18, in the spec's order: E_XX E_YX E_ZX E_AX E_BX E_CX, E_XY … E_CZ.
    pub fn all() -> impl Iterator<Item = Component> {
        (0..3).flat_map(|axis| (0..6).map(move |kind| Component { axis, kind }))
    }

    /// Index 0..18 in [`Component::all`]'s order.
    pub fn index(self) -> usize {
        self.axis * 6 + self.kind
    }

    pub fn from_index(i: usize) -> Component {
        Component {
            axis: i / 6,
            kind: i % 6,
        }
    }

    /// ISO 230-1 name, e.g. `E_CX` (yaw of X).
    pub fn name(self) -> String {
        format!("E_{}{}", KINDS[self.kind], AXES[self.axis])
    }

    pub fn is_rotation(self) -> bool {
        self.kind >= 3
    }
    pub fn is_positioning(self) -> bool {
        self.kind == self.axis
    }
    pub fn is_straightness(self) -> bool {
        self.kind < 3 && self.kind != self.axis
    }
    pub fn is_roll(self) -> bool {
        self.kind == self.axis + 3
    }

    /// "um" or "urad".
    pub fn unit(self) -> &'static str {
        if self.is_rotation() { "urad" } else { "um" }
    }

    /// Plain-words role: positioning, straightness in y, roll, rotation about z…
    pub fn role(self) -> String {
        let dir = AXES[self.kind % 3].to_ascii_lowercase();
        if self.is_positioning() {
            "positioning".into()
        } else if self.is_straightness() {
            format!("straightness in {dir}")
        } else if self.is_roll() {
            "roll".into()
        } else {
            format!("rotation about {dir}")
        }
    }

    /// The displacement (µm) one unit of this component (1 µm or 1 µrad) causes with
    /// lever arm `r_mm`.
    pub fn unit_effect(self, r_mm: [f64; 3]) -> [f64; 3] {
        if self.kind < 3 {
            let mut e = [0.0; 3];
            e[self.kind] = 1.0;
            e
        } else {
            let mut w = [0.0; 3];
            w[self.kind - 3] = 1e-3;
            cross(w, r_mm)
        }
    }
}

impl FromStr for Component {
    type Err = UnknownComponent;
    fn from_str(s: &str) -> Result<Self, UnknownComponent> {
        Component::all()
            .find(|c| c.name() == s.trim())
            .ok_or_else(|| UnknownComponent(s.to_string()))
    }
}

/// The three squareness errors, µrad, positive as right-handed rotations of the second
/// axis: E_C0Y (Y against X), E_B0Z (Z against X), E_A0Z (Z against Y).
pub const SQUARENESS: [&str; 3] = ["E_C0Y", "E_B0Z", "E_A0Z"];

/// The displacement (µm) of 1 µrad of squareness `i` (order of [`SQUARENESS`]) at `pos`.
pub fn squareness_effect(i: usize, pos_mm: [f64; 3]) -> [f64; 3] {
    match i {
        0 => [-1e-3 * pos_mm[1], 0.0, 0.0],
        1 => [1e-3 * pos_mm[2], 0.0, 0.0],
        _ => [0.0, -1e-3 * pos_mm[2], 0.0],
    }
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A component error as a function of its axis' position.
#[derive(Debug)]
pub enum ComponentFn {
    Zero,
    /// Σ c_d·(a/scale)^d, d = 1, 2, …
    Poly {
        coeffs: Vec<f64>,
        scale_mm: f64,
    },
    /// A table interpolated along the axis by an errmap interpolator.
    Table {
        method: Method,
        interp: Box<dyn Interpolator>,
    },
}

impl ComponentFn {
    pub fn value(&self, a_mm: f64) -> f64 {
        match self {
            ComponentFn::Zero => 0.0,
            ComponentFn::Poly { coeffs, scale_mm } => {
                let xi = a_mm / scale_mm;
                let mut acc = 0.0;
                for c in coeffs.iter().rev() {
                    acc = (acc + c) * xi;
                }
                acc
            }
            ComponentFn::Table { interp, .. } => interp.predict([a_mm, 0.0, 0.0]),
        }
    }

    /// A table of values interpolated by `method` (validated: at least 2 distinct
    /// positions, 0 among them with value 0).
    pub fn table(
        positions_mm: &[f64],
        values: &[f64],
        method: Method,
    ) -> Result<ComponentFn, ComponentTableError> {
        if positions_mm.len() != values.len() {
            return Err(ComponentTableError::Lengths {
                positions: positions_mm.len(),
                values: values.len(),
            });
        }
        let mut pairs: Vec<(f64, f64)> = positions_mm
            .iter()
            .copied()
            .zip(values.iter().copied())
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pairs.windows(2).any(|w| w[0].0 == w[1].0) {
            return Err(ComponentTableError::Repeated);
        }
        if pairs.len() < 2 {
            return Err(ComponentTableError::TooFew);
        }
        let Some(&(_, v0)) = pairs.iter().find(|p| p.0 == 0.0) else {
            return Err(ComponentTableError::NoZero);
        };
        if v0 != 0.0 {
            return Err(ComponentTableError::NotZeroAtZero { value: v0 });
        }
        let points = pairs
            .iter()
            .map(|&(a, v)| ErrorPoint::new(a, 0.0, 0.0, v))
            .collect();
        let grid = ErrorTable::from_points("component table", points)
            .grid()
            .map_err(|e| ComponentTableError::Interpolation(e.to_string()))?;
        let interp = method
            .fit(&grid)
            .map_err(|e| ComponentTableError::Interpolation(e.to_string()))?;
        Ok(ComponentFn::Table { method, interp })
    }
}

/// A machine's 21 geometric errors.
#[derive(Debug)]
pub struct Machine {
    pub topology: Topology,
    /// Indexed by [`Component::index`].
    pub components: Vec<ComponentFn>,
    /// E_C0Y, E_B0Z, E_A0Z, µrad.
    pub squareness_urad: [f64; 3],
    /// Expansion coefficient of the three axes' scales, ppm/K (0: they do not expand).
    pub scale_alpha_ppm_per_k: f64,
}

impl Machine {
    /// A machine with no error at all.
    pub fn perfect(topology: Topology) -> Machine {
        Machine {
            topology,
            components: (0..18).map(|_| ComponentFn::Zero).collect(),
            squareness_urad: [0.0; 3],
            scale_alpha_ppm_per_k: 0.0,
        }
    }

    pub fn set(&mut self, c: Component, f: ComponentFn) {
        self.components[c.index()] = f;
    }

    pub fn value(&self, c: Component, a_mm: f64) -> f64 {
        self.components[c.index()].value(a_mm)
    }

    /// The volumetric error E(x, y, z; p), µm (spec formula).
    pub fn error_um(&self, pos_mm: [f64; 3], probe_mm: [f64; 3]) -> [f64; 3] {
        let mut e = [0.0; 3];
        for c in Component::all() {
            let f = &self.components[c.index()];
            if matches!(f, ComponentFn::Zero) {
                continue;
            }
            let v = f.value(pos_mm[c.axis]);
            let r = self.topology.lever_arm(c.axis, pos_mm, probe_mm);
            let d = c.unit_effect(r);
            for i in 0..3 {
                e[i] += v * d[i];
            }
        }
        for (i, s) in self.squareness_urad.iter().enumerate() {
            let d = squareness_effect(i, pos_mm);
            for k in 0..3 {
                e[k] += s * d[k];
            }
        }
        e
    }

    /// The recorded error of a laser reading along `u` at `pos` (no line constant, no
    /// noise): e = −u·E(pos; p), µm.
    pub fn line_error_um(&self, pos_mm: [f64; 3], u: [f64; 3], probe_mm: [f64; 3]) -> f64 {
        -dot(u, self.error_um(pos_mm, probe_mm))
    }

    /// The error vector with the scales at `scale_temp_c`: E(x, y, z; p) plus
    /// α·(T − 20)·1e−3·(x, y, z) µm (each positioning component's expansion).
    pub fn error_at_um(&self, pos_mm: [f64; 3], probe_mm: [f64; 3], scale_temp_c: f64) -> [f64; 3] {
        let mut e = self.error_um(pos_mm, probe_mm);
        let k = self.scale_alpha_ppm_per_k * (scale_temp_c - 20.0) * 1e-3;
        for (ei, a) in e.iter_mut().zip(pos_mm) {
            *ei += k * a;
        }
        e
    }

    /// The recorded error along `u` with the scales at `scale_temp_c`: −u·E(pos; p, T).
    pub fn line_error_at_um(
        &self,
        pos_mm: [f64; 3],
        u: [f64; 3],
        probe_mm: [f64; 3],
        scale_temp_c: f64,
    ) -> f64 {
        -dot(u, self.error_at_um(pos_mm, probe_mm, scale_temp_c))
    }

    /// Reads and validates a machine-model TOML file.
    pub fn read(path: &Path) -> Result<Machine, VolumetricError> {
        let file: MachineFile = read_toml::<_, VolumetricError>(path, crate::sim::check_numbers)?;
        file.validate(path)
    }
}

/// The machine-model file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineFile {
    topology: String,
    scale_alpha_ppm_per_k: Option<f64>,
    #[serde(default)]
    squareness_urad: BTreeMap<String, f64>,
    #[serde(default)]
    components: BTreeMap<String, ComponentFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ComponentFile {
    poly: Option<Vec<f64>>,
    scale_mm: Option<f64>,
    positions_mm: Option<Vec<f64>>,
    values: Option<Vec<f64>>,
    method: Option<String>,
    degree: Option<usize>,
}

fn finite_all(path: &Path, key: &str, v: &[f64]) -> Result<(), VolumetricError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(config_err(
            path,
            format!("{key}[{i}]"),
            format!("value {} is not finite", v[i]),
        )),
        None => Ok(()),
    }
}

fn closest(name: &str, names: &[String]) -> String {
    let score = |a: &str| {
        a.chars()
            .zip(name.chars())
            .filter(|(x, y)| x.eq_ignore_ascii_case(y))
            .count()
    };
    names
        .iter()
        .max_by_key(|n| score(n))
        .map(|n| format!(" (did you mean `{n}`?)"))
        .unwrap_or_default()
}

impl MachineFile {
    fn validate(self, path: &Path) -> Result<Machine, VolumetricError> {
        let topology: Topology = self
            .topology
            .parse()
            .map_err(|e: VolumetricError| config_err(path, "topology", e.to_string()))?;
        let mut m = Machine::perfect(topology);
        if let Some(a) = self.scale_alpha_ppm_per_k {
            if !(a.is_finite() && a.abs() <= 1000.0) {
                return Err(config_err(
                    path,
                    "scale_alpha_ppm_per_k",
                    format!("{a} must be a finite coefficient within ±1000 ppm/K"),
                ));
            }
            m.scale_alpha_ppm_per_k = a;
        }
        for (key, v) in &self.squareness_urad {
            let Some(i) = SQUARENESS.iter().position(|s| s == key) else {
                let names: Vec<String> = SQUARENESS.iter().map(|s| s.to_string()).collect();
                return Err(config_err(
                    path,
                    format!("squareness_urad.{key}"),
                    format!(
                        "unknown squareness `{key}`{} — the three are E_C0Y, E_B0Z, E_A0Z",
                        closest(key, &names)
                    ),
                ));
            };
            finite_all(path, &format!("squareness_urad.{key}"), &[*v])?;
            m.squareness_urad[i] = *v;
        }
        let names: Vec<String> = Component::all().map(Component::name).collect();
        for (key, spec) in self.components {
            let k = format!("components.{key}");
            let c: Component = key.parse().map_err(|_| {
                config_err(
                    path,
                    &k,
                    format!(
                        "unknown component `{key}`{} — ISO 230-1 names E_XX … E_CZ (translation \
                         X/Y/Z or rotation A/B/C, then the moving axis)",
                        closest(&key, &names)
                    ),
                )
            })?;
            let f = match (&spec.poly, &spec.positions_mm, &spec.values) {
                (Some(poly), None, None) => {
                    if spec.method.is_some() || spec.degree.is_some() {
                        return Err(config_err(
                            path,
                            &k,
                            "`method` and `degree` apply to a table, not to `poly`",
                        ));
                    }
                    finite_all(path, &format!("{k}.poly"), poly)?;
                    let scale_mm = spec.scale_mm.unwrap_or(1.0);
                    // Positions are divided by it: 5e-324 made every error vector NaN.
                    if !(scale_mm.is_finite() && scale_mm >= 1e-3) {
                        return Err(config_err(
                            path,
                            format!("{k}.scale_mm"),
                            format!("{scale_mm:e} must be a length of at least 0.001 mm"),
                        ));
                    }
                    ComponentFn::Poly {
                        coeffs: poly.clone(),
                        scale_mm,
                    }
                }
                (None, Some(pos), Some(val)) => {
                    if spec.scale_mm.is_some() {
                        return Err(config_err(path, &k, "`scale_mm` applies to `poly` only"));
                    }
                    finite_all(path, &format!("{k}.positions_mm"), pos)?;
                    finite_all(path, &format!("{k}.values"), val)?;
                    let name: MethodName = spec
                        .method
                        .as_deref()
                        .unwrap_or("trilinear")
                        .parse()
                        .map_err(|e: crate::interp::UnknownMethod| {
                            config_err(path, format!("{k}.method"), e.to_string())
                        })?;
                    let order = spec.degree.map(|d| Order([d, 0, 0]));
                    let method = Method::from_name(name, order, &MethodSettings::default())
                        .map_err(|e| config_err(path, format!("{k}.method"), e.to_string()))?;
                    ComponentFn::table(pos, val, method)
                        .map_err(|e| config_err(path, &k, e.to_string()))?
                }
                _ => {
                    return Err(config_err(
                        path,
                        &k,
                        "give either `poly = [c1, c2, …]` or both `positions_mm` and `values`",
                    ));
                }
            };
            m.set(c, f);
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order() {
        let names: Vec<String> = Component::all().map(Component::name).collect();
        assert_eq!(
            &names[..6],
            ["E_XX", "E_YX", "E_ZX", "E_AX", "E_BX", "E_CX"]
        );
        assert_eq!(names[17], "E_CZ");
        for n in &names {
            assert_eq!(
                &n.parse::<Component>().map(Component::name).ok(),
                &Some(n.clone())
            );
        }
    }

    #[test]
    fn topology_parses_permutations_only() {
        assert_eq!("yxz".parse::<Topology>().ok(), Some(Topology([1, 0, 2])));
        for bad in ["XXZ", "XY", "XYZW", "ABC", ""] {
            assert!(bad.parse::<Topology>().is_err(), "{bad}");
        }
    }
}
