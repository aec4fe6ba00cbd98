//! The memory budget: the most memory one operation may take for its working set.
//!
//! Every allocation that grows with the input (decoded images, coding planes, the
//! encoder's design matrix, rendered frames, textures) is estimated from declared sizes
//! — an image header, a caoen header, the requested output size — and checked here
//! before anything is allocated, so a small hostile file cannot demand gigabytes.
//!
//! The limit is one [`Limits`] per job, handed to every call of the job (the `caoen`
//! command line makes one per command from `--max-memory`). What a job keeps while it
//! works (the samples of every height map a model loads, each texture) is held as a
//! [`Reservation`]; every later check of the same job counts it, so one job's loads
//! together stay within one limit.

use std::io::Read;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use thiserror::Error;

/// The default budget, 2 GiB: what a laptop survives alongside everything else.
pub const DEFAULT_BUDGET: u64 = 2 << 30;

/// The words of every [`OverBudget`] message before the budget: a program that sets
/// the budget from its own option can find them to say how to raise it.
pub const OVER_BUDGET: &str = "over the memory budget of";

/// An operation would need more memory than the budget allows.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{what} needs about {}, {OVER_BUDGET} {}", human(*.need), human(*.budget))]
pub struct OverBudget {
    /// What would have been allocated.
    pub what: String,
    /// Its estimated size in bytes.
    pub need: u64,
    /// The budget in force, in bytes.
    pub budget: u64,
}

/// Memory a loaded asset keeps, counted by every check of its job until it is dropped.
#[derive(Debug, Default)]
pub struct Reservation {
    bytes: u64,
    /// The job's ledger (none for an empty reservation).
    ledger: Option<Arc<Ledger>>,
}

impl Reservation {
    /// The bytes reserved.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        if let Some(l) = &self.ledger {
            l.held.fetch_sub(self.bytes, Ordering::Relaxed);
        }
    }
}

/// Two reservations are alike whatever they hold: they are bookkeeping, not content.
impl PartialEq for Reservation {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// `a * b * c` bytes, saturating: an estimate that overflows is over any budget.
pub fn bytes(a: u64, b: u64, c: u64) -> u64 {
    a.saturating_mul(b).saturating_mul(c)
}

/// Reads all of `reader` within `budget` bytes.
fn read_within(
    mut reader: impl std::io::Read,
    len_hint: Option<u64>,
    budget: u64,
) -> std::io::Result<Vec<u8>> {
    let too_big = |what: &str, need: u64| {
        std::io::Error::other(OverBudget {
            what: what.into(),
            need,
            budget,
        })
    };
    if let Some(len) = len_hint.filter(|&l| l > budget) {
        return Err(too_big("reading the file", len));
    }
    let mut buf = Vec::new();
    // One byte past the budget tells a stream that is too long.
    (&mut reader)
        .take(budget.saturating_add(1))
        .read_to_end(&mut buf)?;
    if buf.len() as u64 > budget {
        return Err(too_big(
            "reading the input (it goes on past the budget)",
            buf.len() as u64,
        ));
    }
    Ok(buf)
}

/// A size that did not parse: the text given and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("`{text}`: {}", match self.unit() {
    Some(unit) => format!("unknown unit `{unit}` (use K, M, G or T)"),
    None => self.fault.to_string(),
})]
pub struct SizeError {
    /// The text given.
    pub text: String,
    /// What is wrong with it.
    pub fault: SizeFault,
}

/// What is wrong with a size's text.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum SizeFault {
    /// The number is missing or malformed.
    #[error("expected a size like 2G, 512M or 1000000")]
    Number,
    /// The unit after the number, from this byte of the text on, is not one of K, M, G
    /// or T.
    #[error("unknown unit (use K, M, G or T)")]
    Unit {
        /// Where the unit starts in the text.
        at: usize,
    },
    /// The size is below one byte or beyond what 64 bits hold.
    #[error("the budget must be at least one byte ({bytes} bytes given)")]
    Range {
        /// The size given, in bytes.
        bytes: f64,
    },
}

impl SizeError {
    /// The unit the text gave, where that was the fault.
    pub fn unit(&self) -> Option<&str> {
        match self.fault {
            SizeFault::Unit { at } => self.text.get(at..).map(str::trim),
            _ => None,
        }
    }
}

/// Parses a size such as `2G`, `512M`, `1.5GiB` or `1000000` (bytes).
pub fn parse_size(s: &str) -> Result<u64, SizeError> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let error = |fault| SizeError {
        text: s.into(),
        fault,
    };
    let value: f64 = num.parse().map_err(|_| error(SizeFault::Number))?;
    let scale = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1u64,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => {
            let at = s.len() - s.trim_start().len() + split;
            return Err(error(SizeFault::Unit { at }));
        }
    };
    let b = value * scale as f64;
    if !(b.is_finite() && b >= 1.0 && b <= u64::MAX as f64) {
        return Err(error(SizeFault::Range { bytes: b }));
    }
    Ok(b as u64)
}

/// A byte count for messages: `1.3 GiB`, `512.0 MiB`, `900 bytes`.
pub fn human(b: u64) -> String {
    const UNITS: [(&str, u64); 4] = [
        ("TiB", 1 << 40),
        ("GiB", 1 << 30),
        ("MiB", 1 << 20),
        ("KiB", 1 << 10),
    ];
    UNITS.iter().find(|(_, u)| b >= *u).map_or_else(
        || format!("{b} bytes"),
        |(n, u)| format!("{:.1} {n}", b as f64 / *u as f64),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("2G"), Ok(2 << 30));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("1000"), Ok(1000));
        let fault = |s: &str| parse_size(s).unwrap_err().fault;
        assert_eq!(fault("-1G"), SizeFault::Number);
        assert_eq!(fault("0"), SizeFault::Range { bytes: 0.0 });
        assert!(matches!(fault("1e400"), SizeFault::Unit { .. }));
        assert_eq!(parse_size(" 2X").unwrap_err().unit(), Some("X"));
        assert_eq!(fault("NaN"), SizeFault::Number);
        assert_eq!(
            parse_size("2X").unwrap_err().to_string(),
            "`2X`: unknown unit `X` (use K, M, G or T)"
        );
    }

    #[test]
    fn a_jobs_reservations_count_in_its_checks_and_its_clones_only() {
        let limits = Limits::new(10_000);
        let other = limits.fresh();
        let r = limits.reserve(|| "a map".into(), 6_000).unwrap();
        assert_eq!(limits.held(), 6_000);
        assert_eq!(limits.clone().held(), 6_000, "clones share the ledger");
        assert_eq!(other.held(), 0, "a fresh job holds nothing");
        let e = limits.check(|| "more".into(), 5_000).unwrap_err();
        assert_eq!((e.need, e.budget), (11_000, 10_000));
        assert!(e.what.starts_with("more (with "), "{}", e.what);
        assert!(other.check(|| "more".into(), 5_000).is_ok());
        assert_eq!(limits.largest_checked(), 11_000);
        drop(r);
        assert_eq!(limits.held(), 0);
        assert!(limits.check(|| "more".into(), 5_000).is_ok());
        assert_eq!(limits, other, "alike by what they allow");
    }

    #[test]
    fn reads_stop_at_the_limit() {
        let limits = Limits::new(8);
        assert_eq!(limits.read_all(&b"12345678"[..], None).unwrap().len(), 8);
        assert!(limits.read_all(&b"123456789"[..], None).is_err());
        assert!(
            limits.read_all(&b""[..], Some(9)).is_err(),
            "a declared size is checked first"
        );
    }

    #[test]
    fn estimates_saturate_and_messages_name_both_sizes() {
        assert_eq!(bytes(u64::MAX, 2, 3), u64::MAX);
        assert_eq!(human(3 << 29), "1.5 GiB");
        assert_eq!(human(900), "900 bytes");
        let e = OverBudget {
            what: "decoding 16384x4096".into(),
            need: 3 << 30,
            budget: 2 << 30,
        };
        assert_eq!(
            e.to_string(),
            "decoding 16384x4096 needs about 3.0 GiB, over the memory budget of 2.0 GiB"
        );
    }
}

/// The memory limit of one job, checked before allocating, and what the job holds.
///
/// Every allocation that grows with the input is estimated from declared sizes and
/// checked with [`Limits::check`] before it is made. What a job keeps while it works
/// (every height map and texture a model or scene loads) is held as a
/// [`Reservation`] from [`Limits::reserve`], and every later check counts it, so one
/// job's loads together stay within one limit. Clones share what is held: hand the
/// same `Limits` (or a clone) to every call of one job.
#[derive(Debug, Clone)]
pub struct Limits {
    /// The most memory the job may allocate, in bytes (its input, already held by
    /// the caller, not counted).
    pub max_memory: u64,
    ledger: Arc<Ledger>,
}

/// What a job's calls hold and the largest need they checked.
#[derive(Debug, Default)]
struct Ledger {
    held: AtomicU64,
    largest: AtomicU64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits::new(DEFAULT_BUDGET)
    }
}

/// Two limits are alike when they allow the same: what they hold is bookkeeping.
impl PartialEq for Limits {
    fn eq(&self, other: &Self) -> bool {
        self.max_memory == other.max_memory
    }
}

impl Eq for Limits {}

impl Limits {
    /// A limit of `max_memory` bytes, holding nothing yet.
    pub fn new(max_memory: u64) -> Self {
        Limits {
            max_memory,
            ledger: Arc::default(),
        }
    }

    /// The same limit for a new job, sharing nothing held with this one.
    pub fn fresh(&self) -> Self {
        Limits::new(self.max_memory)
    }

    /// Checks an estimated need, on top of what the job's reservations hold, against
    /// the limit; `what` is only formatted on failure.
    pub fn check(&self, what: impl FnOnce() -> String, need: u64) -> Result<(), OverBudget> {
        let held = self.held();
        let total = need.saturating_add(held);
        self.ledger.largest.fetch_max(total, Ordering::Relaxed);
        if total <= self.max_memory {
            Ok(())
        } else {
            Err(OverBudget {
                what: if held == 0 {
                    what()
                } else {
                    format!("{} (with {} already loaded)", what(), human(held))
                },
                need: total,
                budget: self.max_memory,
            })
        }
    }

    /// Checks `need` like [`Limits::check`] and, when it fits, holds it until the
    /// reservation is dropped.
    pub fn reserve(
        &self,
        what: impl FnOnce() -> String,
        need: u64,
    ) -> Result<Reservation, OverBudget> {
        self.check(what, need)?;
        self.ledger.held.fetch_add(need, Ordering::Relaxed);
        Ok(Reservation {
            bytes: need,
            ledger: Some(self.ledger.clone()),
        })
    }

    /// Bytes held by live reservations: what the job's loads so far keep.
    pub fn held(&self) -> u64 {
        self.ledger.held.load(Ordering::Relaxed)
    }

    /// The largest need checked so far (with what was held at the time): the job's
    /// estimate of its peak, which a measured peak is compared with.
    pub fn largest_checked(&self) -> u64 {
        self.ledger.largest.load(Ordering::Relaxed)
    }

    /// Reads all of `reader` (`len_hint`: its size where known), refusing input larger
    /// than the limit before reading it: a file's bytes are held in memory, so they
    /// count like any allocation.
    pub fn read_all(&self, reader: impl Read, len_hint: Option<u64>) -> std::io::Result<Vec<u8>> {
        read_within(reader, len_hint, self.max_memory)
    }

    /// [`Limits::read_all`] of the file at `path`.
    pub fn read(&self, path: &std::path::Path) -> std::io::Result<Vec<u8>> {
        let file = std::fs::File::open(path)?;
        let len = file
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .map(|m| m.len());
        self.read_all(file, len)
    }

    /// [`Limits::read`] as UTF-8 text.
    pub fn read_to_string(&self, path: &std::path::Path) -> std::io::Result<String> {
        String::from_utf8(self.read(path)?)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
    }
}
