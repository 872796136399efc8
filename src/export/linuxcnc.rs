//! The LinuxCNC `COMP_FILE` renderer ([`render`]).
//!
//! # LinuxCNC `COMP_FILE`
//!
//! `[JOINT_n] COMP_FILE = file`, `COMP_FILE_TYPE = 0|1` (LinuxCNC INI documentation,
//! `docs/src/config/ini-config.adoc`, section `[JOINT_<num>]`). One triplet per line,
//! `nominal forward reverse`, in machine units (this module writes mm; an inch machine
//! needs its own conversion), smallest nominal first and strictly increasing; at most
//! 256 triplets per joint (`EMCMOT_COMP_SIZE` in `motion.h`; `EMCMOT_SET_JOINT_COMP` in
//! `command.c` rejects extra entries and non-increasing nominals). The loader stops at
//! the first line that is not three numbers, so the file has no header and no comments.
//! Between nominals the trim is interpolated linearly; the forward column applies while
//! the joint moves in the positive direction, the reverse column while it moves in the
//! negative one. Without direction-dependent data both columns are equal.
//!
//! | type | forward / reverse column | written as |
//! |---|---|---|
//! | 0 ([`LinuxCncCompType::ActualPosition`]) | actual position when moving up / down | N + c |
//! | 1 ([`LinuxCncCompType::Trim`]) | trim added to the command moving up / down | −c = e |
//!
//! # Sign convention
//!
//! **LinuxCNC adds its trim to the position command.** `control.c` computes
//! `motor_pos_cmd = pos_cmd + backlash_filt + motor_offset`, where `backlash_filt`
//! follows the trim interpolated from the table. To reach nominal N on an axis whose
//! scale over-reads by e, the motor must be commanded to N + e, so the trim is
//! −c = e. A type-0 file lists instead the *actual* position reached when N is
//! commanded, N − e = N + c; LinuxCNC turns it into the trim `nominal − value` = e
//! (`usrmotLoadComp` in `src/emc/motion/usrmotintf.cc`), so both file types load the
//! same trims.

use super::{Controller, ExportError, Sampled, compensation_um, fmt_mm};

/// LinuxCNC's limit on compensation triplets per joint (`EMCMOT_COMP_SIZE`).
pub const LINUXCNC_MAX_ENTRIES: usize = 256;

/// LinuxCNC `COMP_FILE_TYPE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LinuxCncCompType {
    /// Type 0: the second and third columns are the actual positions reached when the
    /// nominal is commanded (N + c).
    ActualPosition,
    /// Type 1: the columns are the trims LinuxCNC adds to the command (−c = e).
    Trim,
}

impl LinuxCncCompType {
    /// The value for `COMP_FILE_TYPE`.
    pub fn code(self) -> u8 {
        match self {
            LinuxCncCompType::ActualPosition => 0,
            LinuxCncCompType::Trim => 1,
        }
    }
}

/// A LinuxCNC `COMP_FILE`: one `nominal forward reverse` line per sample, mm, no header.
///
/// `reverse` holds direction-dependent errors measured moving in the negative direction,
/// at the same positions; without it both columns come from `forward`. Refuses more
/// than [`LINUXCNC_MAX_ENTRIES`] samples, naming a step that fits.
pub fn render(
    forward: &Sampled,
    comp_type: LinuxCncCompType,
    reverse: Option<&Sampled>,
) -> Result<String, ExportError> {
    let rev = super::paired(forward, reverse)?;
    let n = forward.len();
    if n > LINUXCNC_MAX_ENTRIES {
        return Err(ExportError::TooManyEntries {
            controller: Controller::LinuxCnc,
            samples: n,
            padding: 0,
            limit: LINUXCNC_MAX_ENTRIES,
            length_mm: forward.length_mm(),
        });
    }
    let mut out = String::with_capacity(n * 36);
    let mut previous: Option<f64> = None;
    for i in 0..n {
        let nominal = forward.positions_mm[i];
        let nominal_txt = fmt_mm(nominal);
        // The loader compares the numbers it reads: check them, not the f64s.
        let written: f64 = nominal_txt.parse().unwrap_or(f64::NAN);
        if let Some(prev) = previous
            && written.partial_cmp(&prev) != Some(std::cmp::Ordering::Greater)
        {
            return Err(ExportError::NotIncreasing {
                index: i,
                previous_mm: prev,
                position_mm: written,
            });
        }
        previous = Some(written);
        let c_fwd_mm = compensation_um(forward.error_um[i]) * 1e-3;
        let c_rev_mm = compensation_um(rev.error_um[i]) * 1e-3;
        let (a, b) = match comp_type {
            LinuxCncCompType::ActualPosition => (nominal + c_fwd_mm, nominal + c_rev_mm),
            LinuxCncCompType::Trim => (-c_fwd_mm, -c_rev_mm),
        };
        out.push_str(&format!("{nominal_txt} {} {}\n", fmt_mm(a), fmt_mm(b)));
    }
    Ok(out)
}
