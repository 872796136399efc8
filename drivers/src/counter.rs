//! Unwrapping of the 32-bit wrapping counters of SAMPLE frames into i64
//! (`docs/wire-protocol.md`, "SAMPLE (0x02)": the host extends the counters to
//! i64 on the assumption that consecutive samples differ by fewer than 2^31 counts; the
//! u32 sample index is unwrapped the same way).
//!
//! Each new raw value is taken as the previous one plus the signed 32-bit difference
//! (`raw − prev` mod 2^32, read as i32), so any motion of fewer than 2^31 counts between
//! consecutive samples is recovered exactly. A *wrap* is a step that crosses the raw
//! counter's range boundary (i32::MAX ↔ i32::MIN for the signed counters, u32::MAX ↔ 0
//! for the index). Cost: O(1) per value.

/// One unwrapped value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unwrapped {
    /// The unwrapped value.
    pub value: i64,
    /// Difference from the previous value (0 for the first).
    pub delta: i64,
    /// Whether this step crossed the raw counter's range boundary.
    pub wrapped: bool,
}

/// A raw 32-bit wrapping counter: the signed counts or the unsigned sample index.
pub trait RawCounter: Copy {
    /// The raw value as it reads, widened.
    fn widen(self) -> i64;
    /// `self − prev` mod 2^32, read as a signed 32-bit step.
    fn step_from(self, prev: Self) -> i64;
}

impl RawCounter for i32 {
    fn widen(self) -> i64 {
        i64::from(self)
    }
    fn step_from(self, prev: Self) -> i64 {
        i64::from(self.wrapping_sub(prev))
    }
}

impl RawCounter for u32 {
    fn widen(self) -> i64 {
        i64::from(self)
    }
    fn step_from(self, prev: Self) -> i64 {
        i64::from(self.wrapping_sub(prev) as i32)
    }
}

/// Unwraps a wrapping 32-bit counter (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Unwrap<T> {
    last: Option<(T, i64)>,
}

/// The signed scale and laser counters.
pub type UnwrapI32 = Unwrap<i32>;
/// The SAMPLE index.
pub type UnwrapU32 = Unwrap<u32>;

impl<T: RawCounter> Unwrap<T> {
    /// An unwrapper with no value yet; the first value is taken as is.
    pub const fn new() -> Self {
        Unwrap { last: None }
    }

    /// Feed the next raw value.
    pub fn push(&mut self, raw: T) -> Unwrapped {
        let out = match self.last {
            None => Unwrapped {
                value: raw.widen(),
                delta: 0,
                wrapped: false,
            },
            Some((prev_raw, prev)) => {
                let delta = raw.step_from(prev_raw);
                Unwrapped {
                    value: prev + delta,
                    delta,
                    wrapped: prev_raw.widen() + delta != raw.widen(),
                }
            }
        };
        self.last = Some((raw, out.value));
        out
    }

    /// The latest unwrapped value.
    pub fn value(&self) -> Option<i64> {
        self.last.map(|(_, v)| v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn i32_wraps_both_ways() {
        let mut u = UnwrapI32::new();
        assert_eq!(u.push(i32::MAX - 1).value, i64::from(i32::MAX) - 1);
        let w = u.push(i32::MIN + 2);
        assert_eq!(w.delta, 4);
        assert!(w.wrapped);
        assert_eq!(w.value, i64::from(i32::MAX) + 3);
        let back = u.push(i32::MAX);
        assert_eq!(back.delta, -3);
        assert!(back.wrapped);
        assert_eq!(back.value, i64::from(i32::MAX));
        let no = u.push(0);
        assert!(!no.wrapped);
        assert_eq!(no.value, 0);
    }

    #[test]
    fn u32_index_wraps() {
        let mut u = UnwrapU32::new();
        u.push(u32::MAX);
        let w = u.push(1);
        assert!(w.wrapped);
        assert_eq!(w.delta, 2);
        assert_eq!(w.value, i64::from(u32::MAX) + 2);
    }
}
