//! One sampled line as CSV ([`render`]): `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`, the
//! columns of the [`grid`](super::grid) export too.

use super::{Sampled, compensation_um};

/// One line as CSV, `x_mm,y_mm,z_mm,e_um,comp_um,extrapolated`, the same columns as
/// the [`grid`](super::grid) export; numbers in Rust's shortest round-trip form.
pub fn render(s: &Sampled) -> String {
    let mut out = String::with_capacity(48 + s.len() * 64);
    out.push_str("x_mm,y_mm,z_mm,e_um,comp_um,extrapolated\n");
    for (i, (&e, &x)) in s.error_um.iter().zip(&s.extrapolated).enumerate() {
        let p = s.point(i);
        out.push_str(&format!(
            "{},{},{},{},{},{}\n",
            p[0],
            p[1],
            p[2],
            e,
            compensation_um(e),
            x
        ));
    }
    out
}
