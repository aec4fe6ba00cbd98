//! Entropy coding: adaptive models on constriction's ANS coder.
//!
//! Three kinds of symbol: binary decisions with an adaptive probability (16-bit fixed
//! point), tokens from an adaptive multi-symbol distribution (a 15-bit integer CDF, one
//! coder step per token instead of one per bin), and raw bits. All model updates are
//! integer, so decoding is platform-independent.
//!
//! The coder is constriction's asymmetric numeral system (`DefaultAnsCoder`: 64-bit
//! state, 32-bit words): its decoder needs no division per symbol, which made the range
//! coder's decoding latency-bound. ANS decodes in the reverse order of encoding, so the
//! encoder first runs the adaptive models forward, recording each symbol's interval, and
//! then encodes the intervals backwards. `model` holds the adaptive models, `coder` the ANS back end (the
//! models as constriction sees them, the sink that writes and the source that reads),
//! `cost` the back ends that price symbols without writing them.

mod coder;
mod cost;
mod model;

pub use coder::{AnsSink, AnsSource, SymbolSink, MAX_RAW_BITS};
pub use cost::{CostSink, OverlayCostSink};
pub use model::valid_cdf;
pub use model::{BinModel, Cdf, Trained, CDF_FLOOR, CDF_ONE};

#[cfg(test)]
mod tests {
    use super::coder::*;
    use super::model::*;
    use super::*;

    use caoen_base::rng::Lcg;

    /// A CDF table with the floor: every symbol equally likely.
    fn uniform<const W: usize>() -> Cdf<W> {
        let m = 4 * W;
        let f: Vec<u16> = (0..m)
            .map(|i| ((i as u32 + 1) * CDF_ONE as u32 / (m as u32 + 1)) as u16)
            .collect();
        Cdf::new(&f)
    }

    /// Every symbol at least the floor; the frequencies sum to the total.
    fn assert_valid<const W: usize>(m: &Cdf<W>) {
        let sum: u32 = (0..=4 * W).map(|s| m.frequency(s)).sum();
        assert_eq!(sum, CDF_ONE as u32, "total");
        for s in 0..=4 * W {
            assert!(m.frequency(s) >= CDF_FLOOR as u32, "{s}: {m:?}");
        }
    }

    /// The update by its per-entry definition.
    fn update_by_definition<const W: usize>(m: &Cdf<W>, s: usize) -> Vec<u32> {
        let n = m.seen as usize;
        let rate = 3 + [8, 32, 64, 256].iter().filter(|&&t| n >= t).count() as u32;
        let big_m = 4 * W;
        (0..big_m)
            .map(|i| {
                let f = m.entry(i);
                if i < s {
                    let lo = (i as u32 + 1) * CDF_FLOOR as u32;
                    f - ((f - lo) >> rate)
                } else {
                    let hi = CDF_ONE as u32 - (big_m - i) as u32 * CDF_FLOOR as u32;
                    f + ((hi - f) >> rate)
                }
            })
            .collect()
    }

    /// The symbol of `q` by scanning the intervals.
    fn locate_by_scan<const W: usize>(m: &Cdf<W>, q: u32) -> usize {
        (0..=4 * W)
            .find(|&s| {
                let (l, w) = m.interval(s);
                q >= l && q < l + w
            })
            .unwrap()
    }

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Sym {
        Bin(usize, bool),
        Token(usize, usize),
        Signed(usize, usize, bool),
        Class(usize),
        Raw(u32, u32),
    }

    /// A skewed mixed stream: bins on 4 contexts, 9-ary tokens on 3, 25-ary classes, raw
    /// bits of every width.
    fn stream(n: usize, seed: u64) -> Vec<Sym> {
        let mut r = Lcg::new(seed);
        (0..n)
            .map(|i| match i % 5 {
                0 => {
                    let c = (r.next_u31() % 4) as usize;
                    Sym::Bin(c, r.next_u31() % 97 < 10 + 20 * c as u32)
                }
                1 => {
                    let c = (r.next_u31() % 3) as usize;
                    // Geometric-ish, heavier for higher contexts.
                    let mut s = 0;
                    while s < 8 && r.next_u31() % 10 < 3 + 2 * c as u32 {
                        s += 1;
                    }
                    Sym::Token(c, s)
                }
                2 => Sym::Class((r.next_u31() % 25).min(r.next_u31() % 25) as usize),
                3 => {
                    let c = (r.next_u31() % 3) as usize;
                    let t = (r.next_u31() % 9).min(r.next_u31() % 9) as usize;
                    Sym::Signed(c, t, t > 0 && r.next_u31().is_multiple_of(2))
                }
                _ => {
                    let bits = 1 + r.next_u31() % MAX_RAW_BITS;
                    Sym::Raw(r.next_u31() & ((1 << bits) - 1), bits)
                }
            })
            .collect()
    }

    struct Models {
        bins: [BinModel; 4],
        tokens: [Cdf<2>; 3],
        classes: Cdf<6>,
    }

    impl Models {
        fn new() -> Self {
            Models {
                bins: [
                    BinModel::new(1),
                    BinModel::new(2),
                    BinModel::new(4),
                    BinModel::new(6),
                ],
                tokens: [uniform(); 3],
                classes: uniform(),
            }
        }
    }

    fn write(syms: &[Sym], sink: &mut impl SymbolSink) {
        let mut m = Models::new();
        for &s in syms {
            match s {
                Sym::Bin(c, b) => sink.bin(&mut m.bins[c], b),
                Sym::Token(c, t) => sink.symbol(&mut m.tokens[c], t),
                Sym::Signed(c, t, neg) => sink.signed_symbol(&mut m.tokens[c], t, neg),
                Sym::Class(t) => sink.symbol(&mut m.classes, t),
                Sym::Raw(v, bits) => sink.raw(v, bits),
            }
        }
    }

    #[test]
    fn symbols_round_trip_and_costs_track_the_real_size() {
        for seed in 0..4 {
            let syms = stream(40000, seed);
            let mut sink = AnsSink::new();
            write(&syms, &mut sink);
            let mut cost = CostSink::default();
            write(&syms, &mut cost);
            let bytes = sink.finish();
            let est = cost.cost as f64 / 256.0 / 8.0;
            assert!(
                (bytes.len() as f64 - est).abs() < 0.005 * est + 8.0,
                "real {} estimated {est}",
                bytes.len()
            );
            let mut src = AnsSource::new(&bytes, syms.len() as u64).unwrap();
            let mut m = Models::new();
            for &s in &syms {
                let got = match s {
                    Sym::Bin(c, _) => Sym::Bin(c, src.bin(&mut m.bins[c]).unwrap()),
                    Sym::Token(c, _) => Sym::Token(c, src.symbol(&mut m.tokens[c]).unwrap()),
                    Sym::Signed(c, _, _) => {
                        let (t, neg) = src.signed_symbol(&mut m.tokens[c]).unwrap();
                        Sym::Signed(c, t, neg)
                    }
                    Sym::Class(_) => Sym::Class(src.symbol(&mut m.classes).unwrap()),
                    Sym::Raw(_, bits) => Sym::Raw(src.raw(bits).unwrap(), bits),
                };
                assert_eq!(got, s);
            }
            assert!(src.finished_cleanly());
            // One symbol more than the syntax allows is an error, not a hang.
            assert!(src.raw(1).is_err());
        }
    }

    #[test]
    fn adaptive_cdfs_keep_their_total_and_floor_under_any_updates() {
        fn hammer<const W: usize>(seed: u64) {
            let n = 4 * W + 1;
            let mut r = Lcg::new(seed);
            let mut m = uniform::<W>();
            // Long runs of one symbol (the worst case for the others' floors), then
            // alternations between the extremes, then noise.
            for s in [0, n - 1, n / 2, 0] {
                for _ in 0..5000 {
                    m.update(s);
                    assert_valid(&m);
                }
                // The favoured symbol takes almost everything: a shift update stalls
                // within 2^7 of its target, so the rest keep at most that over the floor.
                let rest = (n as u32 - 1) * (128 + CDF_FLOOR as u32);
                assert!(m.frequency(s) >= CDF_ONE as u32 - rest, "{m:?}");
            }
            for i in 0..20000 {
                m.update(if i % 2 == 0 { 0 } else { n - 1 });
                assert_valid(&m);
            }
            for _ in 0..20000 {
                let s = r.next_u31() as usize % n;
                let want = update_by_definition(&m, s);
                m.update(s);
                assert_valid(&m);
                assert_eq!((0..n - 1).map(|i| m.entry(i)).collect::<Vec<_>>(), want);
                let q = r.next_u31() % CDF_ONE as u32;
                let (t, left, right) = m.locate(q);
                assert_eq!(t, locate_by_scan(&m, q));
                assert_eq!((left, right - left), m.interval(t));
            }
        }
        hammer::<1>(1);
        hammer::<2>(2);
        hammer::<4>(3);
        hammer::<6>(4);
    }

    #[test]
    fn binary_models_stay_codable_under_any_updates() {
        for start in 1..=6 {
            let mut m = BinModel::new(start);
            for (n, bit) in [(3000, true), (3000, false), (100, true)] {
                for _ in 0..n {
                    m.update(bit);
                    assert!((LIMIT..=ONE - LIMIT).contains(&(m.p0 as u32)));
                }
            }
        }
        // Fast at first, 2^-6 per bin in the long run.
        let mut m = BinModel::new(1);
        m.update(true);
        assert_eq!(m.p0, 16384);
        let mut m = BinModel::new(1);
        for _ in 0..300 {
            m.update(false);
        }
        m.p0 = 32768;
        m.update(true);
        assert_eq!(m.p0, 32768 - 512);
    }

    #[test]
    fn cost_lookup_equals_the_logarithm_algorithm() {
        for p in 1..=ONE {
            assert_eq!(cost_table(p), cost_of(p), "p {p}");
        }
    }

    #[test]
    fn cost_table_matches_log2() {
        for p in [LIMIT, 100, 1000, 32768, 50000, ONE - LIMIT] {
            let want = -((p as f64) / ONE as f64).log2() * 256.0;
            assert!(
                (cost_of(p) as f64 - want).abs() < 0.01 * 256.0,
                "{p}: {} vs {want}",
                cost_of(p)
            );
        }
    }
}
