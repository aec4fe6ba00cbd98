//! What the detail layer may allocate during one decode.
//!
//! How many levels a layer holds is known only once its streams are read (a few bytes
//! can code a dense block), so no estimate from the header alone is both an upper bound
//! and close: the worst case, every block's 64 levels, would refuse flat files that
//! need almost nothing. Instead the layer's allocations take their bytes from what the
//! budget leaves after the rest of the decode, each before it is made, and give them
//! back when freed; the layer's peak then stays within the budget by construction.

use std::sync::atomic::{AtomicU64, Ordering};

use caoen_base::budget::OverBudget;

use crate::CodecError;

/// Bytes the detail layer may hold at once during one decode, shared by the tiles read
/// in parallel.
#[derive(Debug)]
pub struct LayerBudget {
    /// What the layer may hold.
    allowed: u64,
    /// What it holds now.
    held: AtomicU64,
    /// The most it held.
    peak: AtomicU64,
    /// The rest of the decode's estimate and the budget, for the message.
    base: u64,
    budget: u64,
    /// The decode, for the message.
    what: String,
}

impl LayerBudget {
    /// No limit: for callers that bound the layer otherwise (the encoder reads back
    /// what it wrote).
    pub fn unlimited() -> Self {
        LayerBudget::new(0, u64::MAX, String::new())
    }

    /// The layer of a decode described by `what` whose other needs are estimated at
    /// `base` bytes, within `budget` bytes in all.
    pub fn new(base: u64, budget: u64, what: String) -> Self {
        LayerBudget {
            allowed: budget.saturating_sub(base),
            held: AtomicU64::new(0),
            peak: AtomicU64::new(0),
            base,
            budget,
            what,
        }
    }

    /// Takes `bytes` before they are allocated, or refuses if the layer would then
    /// hold more than it may.
    pub fn take(&self, bytes: u64) -> Result<(), CodecError> {
        let held = self
            .held
            .fetch_add(bytes, Ordering::SeqCst)
            .saturating_add(bytes);
        if held > self.allowed {
            self.held.fetch_sub(bytes, Ordering::SeqCst);
            return Err(CodecError::Memory(OverBudget {
                what: format!("{} with its detail layer", self.what),
                need: self.base.saturating_add(held),
                budget: self.budget,
            }));
        }
        self.peak.fetch_max(held, Ordering::SeqCst);
        Ok(())
    }

    /// Gives back `bytes` that were freed.
    pub fn give(&self, bytes: u64) {
        let _ = self
            .held
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |h| {
                Some(h.saturating_sub(bytes))
            });
    }

    /// Makes room in `v` for `more` items, taking the grown buffer's bytes first: while
    /// a vector grows, its old and new buffers are both alive.
    pub fn grow<T>(&self, v: &mut Vec<T>, more: usize) -> Result<(), CodecError> {
        if v.len() + more <= v.capacity() {
            return Ok(());
        }
        let old = v.capacity();
        let new = (2 * old).max(v.len() + more).max(1024);
        self.take(bytes_of::<T>(new))?;
        v.reserve_exact(new - v.len());
        self.give(bytes_of::<T>(old));
        // The allocator may round up; what is held is the buffer as it is.
        self.take_unchecked(bytes_of::<T>(v.capacity() - new));
        Ok(())
    }

    /// Gives back a vector's buffer as it is dropped.
    pub fn free<T>(&self, v: Vec<T>) {
        self.give(bytes_of::<T>(v.capacity()));
    }

    /// The most the layer held at once.
    pub fn peak(&self) -> u64 {
        self.peak.load(Ordering::SeqCst)
    }

    fn take_unchecked(&self, bytes: u64) {
        let held = self.held.fetch_add(bytes, Ordering::SeqCst) + bytes;
        self.peak.fetch_max(held, Ordering::SeqCst);
    }
}

/// The bytes of `n` items of `T`.
pub fn bytes_of<T>(n: usize) -> u64 {
    (n as u64).saturating_mul(std::mem::size_of::<T>() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn growth_is_taken_before_it_happens_and_refused_past_the_allowance() {
        let b = LayerBudget::new(100, 100 + 16 * 1024, "decoding 1x1".into());
        let mut v: Vec<i32> = Vec::new();
        b.grow(&mut v, 10).unwrap();
        assert_eq!(v.capacity(), 1024);
        assert_eq!(b.peak(), 4096);
        v.resize(1024, 0);
        // 2048 items (8 KiB) beside the old 4 KiB fit in 16 KiB.
        b.grow(&mut v, 1).unwrap();
        assert_eq!(b.peak(), 3 * 4096);
        v.resize(2048, 0);
        // 4096 items (16 KiB) beside the old 8 KiB do not.
        let e = b.grow(&mut v, 1).unwrap_err().to_string();
        assert!(e.contains("decoding 1x1 with its detail layer"), "{e}");
        assert!(e.contains("over the memory budget of 16.1 KiB"), "{e}");
        assert_eq!(v.capacity(), 2048, "nothing allocated when refused");
        b.free(v);
        assert_eq!(b.held.load(Ordering::SeqCst), 0);
    }
}
