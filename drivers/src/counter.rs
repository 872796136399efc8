//! Unwrapping of the 32-bit wrapping counters of SAMPLE frames into i64
//! (`shared/spec/wire-protocol.md`, "0x02 SAMPLE": "the host unwraps the counters into
//! i64 assuming fewer than 2^31 counts between consecutive samples"; the u32 sample
//! index is unwrapped the same way).
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

/// Unwraps a wrapping i32 counter.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UnwrapI32 {
    last: Option<(i32, i64)>,
}

impl UnwrapI32 {
    /// An unwrapper with no value yet; the first value is taken as is.
    pub const fn new() -> Self {
        UnwrapI32 { last: None }
    }

    /// Feed the next raw value.
    pub fn push(&mut self, raw: i32) -> Unwrapped {
        let out = match self.last {
            None => Unwrapped {
                value: i64::from(raw),
                delta: 0,
                wrapped: false,
            },
            Some((prev_raw, prev)) => {
                let delta = i64::from(raw.wrapping_sub(prev_raw));
                Unwrapped {
                    value: prev + delta,
                    delta,
                    wrapped: i64::from(prev_raw) + delta != i64::from(raw),
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

/// Unwraps a wrapping u32 counter (the SAMPLE index).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UnwrapU32 {
    last: Option<(u32, i64)>,
}

impl UnwrapU32 {
    /// An unwrapper with no value yet; the first value is taken as is.
    pub const fn new() -> Self {
        UnwrapU32 { last: None }
    }

    /// Feed the next raw value.
    pub fn push(&mut self, raw: u32) -> Unwrapped {
        let out = match self.last {
            None => Unwrapped {
                value: i64::from(raw),
                delta: 0,
                wrapped: false,
            },
            Some((prev_raw, prev)) => {
                let delta = i64::from(raw.wrapping_sub(prev_raw) as i32);
                Unwrapped {
                    value: prev + delta,
                    delta,
                    wrapped: i64::from(prev_raw) + delta != i64::from(raw),
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
