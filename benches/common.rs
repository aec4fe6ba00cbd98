//! What the criterion benches share.

use criterion::Criterion;

/// A bench's `main`: its own `summary` first, then its criterion `benches`, then
/// criterion's final summary.
pub fn main(summary: fn(), benches: fn()) {
    summary();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
