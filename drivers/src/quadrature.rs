//! ×4 quadrature (A-quad-B) decoding of the RAW_AB diagnostic frames
//! (`docs/wire-protocol.md`, section "RAW_AB (0x06)").
//!
//! Two square waves 90° apart; every edge of either line is one count:
//!
//! ```text
//!            forward (A leads B)  ───────────────▶       reverse ◀───
//!          ┌───────┐       ┌───────┐
//!   A  ────┘       └───────┘       └───
//!              ┌───────┐       ┌───────┐
//!   B  ────────┘       └───────┘       └
//!
//!  (A,B) (0,0)│(1,0)│(1,1)│(0,1)│(0,0)│(1,0)│ ...
//!  phase   0  │  1  │  2  │  3  │  0  │  1  │
//!  count   0    +1    +1    +1    +1    +1      (reverse order: −1 each)
//! ```
//!
//! Writing the state as the pair (A, B), the phase is 0 for (0,0), 1 for (1,0), 2 for
//! (1,1), 3 for (0,1). A step of +1 phase (mod 4) counts +1, −1 counts −1, no change
//! counts 0, and a change of 2 (both lines changed at once) is an
//! [`IllegalTransition`]: it is counted, no direction is guessed, and the new state is
//! taken as the current one.
//!
//! The first state after [`QuadratureDecoder::new`] or [`QuadratureDecoder::reset`] only
//! sets the state (it counts nothing). The session layer keeps one decoder per line pair
//! across RAW_AB frames and resets both on a seq gap, as the spec asks.
//!
//! Cost: O(1) per state, a table-free phase difference.

/// The levels of the A and B lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct AbState {
    /// Level of line A.
    pub a: bool,
    /// Level of line B.
    pub b: bool,
}

impl AbState {
    /// From two bits: bit0 A, bit1 B.
    pub const fn from_bits(bits: u8) -> Self {
        AbState {
            a: bits & 1 != 0,
            b: bits & 2 != 0,
        }
    }

    /// As two bits: bit0 A, bit1 B.
    pub const fn bits(self) -> u8 {
        (self.a as u8) | ((self.b as u8) << 1)
    }

    /// Quadrature phase 0..=3: (0,0) → 0, (1,0) → 1, (1,1) → 2, (0,1) → 3.
    pub const fn phase(self) -> u8 {
        match (self.a, self.b) {
            (false, false) => 0,
            (true, false) => 1,
            (true, true) => 2,
            (false, true) => 3,
        }
    }
}

impl std::fmt::Display for AbState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "({},{})", u8::from(self.a), u8::from(self.b))
    }
}

/// Both lines changed between two states: the direction is unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("illegal quadrature transition {from} → {to} (both lines changed)")]
pub struct IllegalTransition {
    /// State before.
    pub from: AbState,
    /// State after.
    pub to: AbState,
}

/// ×4 quadrature state machine with a net count and an illegal-transition count.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct QuadratureDecoder {
    state: Option<AbState>,
    count: i64,
    illegal: u64,
}

impl QuadratureDecoder {
    /// A decoder with no state yet.
    pub const fn new() -> Self {
        QuadratureDecoder {
            state: None,
            count: 0,
            illegal: 0,
        }
    }

    /// Feed one state; returns the count step (−1, 0, +1) or the illegal transition
    /// (which is also counted in [`QuadratureDecoder::illegal`]).
    pub fn step(&mut self, next: AbState) -> Result<i8, IllegalTransition> {
        let Some(prev) = self.state.replace(next) else {
            return Ok(0);
        };
        match next.phase().wrapping_sub(prev.phase()) & 3 {
            0 => Ok(0),
            1 => {
                self.count += 1;
                Ok(1)
            }
            3 => {
                self.count -= 1;
                Ok(-1)
            }
            _ => {
                self.illegal += 1;
                Err(IllegalTransition {
                    from: prev,
                    to: next,
                })
            }
        }
    }

    /// Forget the state (after a seq gap): the next state counts nothing. Counts are kept.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// The current state, if any.
    pub const fn state(&self) -> Option<AbState> {
        self.state
    }

    /// Net count since creation.
    pub const fn count(&self) -> i64 {
        self.count
    }

    /// Illegal transitions since creation.
    pub const fn illegal(&self) -> u64 {
        self.illegal
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn st(a: u8, b: u8) -> AbState {
        AbState::from_bits(a | (b << 1))
    }

    #[test]
    fn forward_cycle_counts_plus_one_per_step() {
        let mut q = QuadratureDecoder::new();
        let seq = [st(0, 0), st(1, 0), st(1, 1), st(0, 1), st(0, 0), st(1, 0)];
        let steps: Vec<i8> = seq.iter().map(|&s| q.step(s).unwrap_or(99)).collect();
        assert_eq!(steps, vec![0, 1, 1, 1, 1, 1]);
        assert_eq!(q.count(), 5);
        assert_eq!(q.illegal(), 0);
    }

    #[test]
    fn reverse_cycle_counts_minus_one() {
        let mut q = QuadratureDecoder::new();
        for s in [st(0, 0), st(0, 1), st(1, 1), st(1, 0), st(0, 0)] {
            let _ = q.step(s);
        }
        assert_eq!(q.count(), -4);
    }

    #[test]
    fn no_change_counts_zero_and_illegal_is_named() {
        let mut q = QuadratureDecoder::new();
        assert_eq!(q.step(st(0, 0)), Ok(0));
        assert_eq!(q.step(st(0, 0)), Ok(0));
        assert_eq!(
            q.step(st(1, 1)),
            Err(IllegalTransition {
                from: st(0, 0),
                to: st(1, 1)
            })
        );
        assert_eq!(q.illegal(), 1);
        assert_eq!(q.count(), 0);
        // The illegal state became current: (1,1) → (0,1) is +1.
        assert_eq!(q.step(st(0, 1)), Ok(1));
    }

    #[test]
    fn reset_makes_next_state_count_nothing() {
        let mut q = QuadratureDecoder::new();
        let _ = q.step(st(0, 0));
        q.reset();
        assert_eq!(q.step(st(1, 1)), Ok(0));
        assert_eq!(q.illegal(), 0);
        assert_eq!(q.step(st(0, 1)), Ok(1));
    }

    #[test]
    fn display_names_transition() {
        let e = IllegalTransition {
            from: st(1, 0),
            to: st(0, 1),
        };
        assert_eq!(
            e.to_string(),
            "illegal quadrature transition (1,0) → (0,1) (both lines changed)"
        );
    }
}
