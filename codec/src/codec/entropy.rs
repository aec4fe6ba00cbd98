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
//! then encodes the intervals backwards. This module supplies the models (implementing
//! constriction's model traits) and a counting back end that prices symbols without
//! writing them.

use std::borrow::Borrow;
use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};
use constriction::stream::stack::DefaultAnsCoder;
use constriction::stream::{Decode, Encode};
use constriction::CoderError;
use std::convert::Infallible;

use super::CodecError;

const PRECISION: usize = 16;
const ONE: u32 = 1 << PRECISION;
/// Adaptation rates of binary models stop speeding down here: each bin then moves
/// 1/2^6 of the way toward what it saw.
const MAX_RATE: u32 = 6;
/// Probabilities stay within [LIMIT, ONE - LIMIT] so every symbol stays codable.
const LIMIT: u32 = 64;

/// An adaptive binary probability: `p0` = P(bit = 0) in units of 2^-16.
///
/// The adaptation rate starts fast and slows as the model sees bins (sections are
/// short, so the first few bins matter): after `n` bins the model moves
/// `2^-min(6, start - 1 + floor(log2(n + 2)))` of the way toward each new bin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BinModel {
    p0: u16,
    /// Bins seen, saturating (the rate stops changing long before 255).
    seen: u8,
    /// `start - 1` of the rate rule.
    base: u8,
}

impl BinModel {
    /// A model at P(0) = 1/2 whose first bins adapt at rate `2^-start`
    /// (`start` in 1..=6).
    pub const fn new(start: u8) -> Self {
        BinModel {
            p0: (ONE / 2) as u16,
            seen: 0,
            base: start - 1,
        }
    }

    #[inline]
    fn update(&mut self, bit: bool) {
        let rate = (self.base as u32 + 31 - (self.seen as u32 + 2).leading_zeros()).min(MAX_RATE);
        self.seen = self.seen.saturating_add(1);
        let p0 = self.p0 as u32;
        let p0 = if bit {
            p0 - (p0 >> rate)
        } else {
            p0 + ((ONE - p0) >> rate)
        };
        self.p0 = p0.clamp(LIMIT, ONE - LIMIT) as u16;
    }

    /// Cost of coding `bit` now, in 1/256 bits.
    #[inline]
    pub fn cost(&self, bit: bool) -> u32 {
        let p0 = self.p0 as u32;
        cost_table(if bit { ONE - p0 } else { p0 })
    }
}

/// Precision of the multi-symbol models: probabilities in units of 2^-15.
const CDF_PRECISION: usize = 15;
/// The total of every multi-symbol distribution.
pub const CDF_ONE: u16 = 1 << CDF_PRECISION;
/// Least frequency of any symbol of a multi-symbol model (probability 2^-13).
pub const CDF_FLOOR: u16 = 4;

/// An adaptive distribution over the `M + 1 = 4W + 1` symbols `0..=M` (AV1-style
/// integer CDF).
///
/// With `F[0] = 0`, `F[1..=M]` the stored entries and `F[M+1] = CDF_ONE`, symbol `s`
/// codes as `[F[s], F[s+1])`. After coding `s`, every stored entry `F[i+1]` moves
/// `1/2^rate` of the way toward its floor-respecting target: down to `(i+1) FLOOR` if
/// `i < s`, up to `ONE - (M-i) FLOOR` otherwise (rounding the move down), so every
/// symbol keeps at least [`CDF_FLOOR`] and the total stays exactly `CDF_ONE`. The rate
/// starts fast and slows as the model sees symbols: `3 + [n >= 8] + [n >= 32] +
/// [n >= 64] + [n >= 256]` after `n` symbols.
///
/// The entries are kept as 16-bit lanes, four to a `u64` word, and updated and searched
/// lane-parallel in plain integer arithmetic (no lane ever leaves its targets' range, so
/// no borrow or carry crosses lanes). That measured faster than per-entry code, which
/// the compiler vectorised into mixed scalar and vector work costing more than the
/// decoding itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cdf<const W: usize> {
    w: [u64; W],
    /// Symbols seen, saturating at the last rate step.
    seen: u16,
}

/// [`Cdf`]'s adaptation rate after `n` symbols, for `n` up to where it stops changing.
const CDF_RATES: [u8; 257] = {
    let mut r = [0; 257];
    let mut n = 0;
    while n < r.len() {
        r[n] = 3 + (n >= 8) as u8 + (n >= 32) as u8 + (n >= 64) as u8 + (n >= 256) as u8;
        n += 1;
    }
    r
};

/// One in every 16-bit lane.
const LANES: u64 = 0x0001_0001_0001_0001;
/// The top bit of every lane (entries stay below 2^15, so it is free as a guard).
const GUARDS: u64 = LANES << 15;

/// Per shift `r`: the lane bits that survive a shift right by `r` within their lane.
const KEEP: [u64; 16] = {
    let mut t = [0u64; 16];
    let mut r = 0;
    while r < 16 {
        t[r] = (0xFFFF >> r) * LANES;
        r += 1;
    }
    t
};

/// Per lane count `n`: all ones in the lanes below `n` (`n` in 0..=4).
const BELOW: [u64; 5] = [0, 0xFFFF, 0xFFFF_FFFF, 0xFFFF_FFFF_FFFF, u64::MAX];

/// The targets of [`Cdf`]'s update per entry, as lanes: `(i+1) FLOOR` below the coded
/// symbol, `ONE - (M-i) FLOOR` from it on.
const fn cdf_targets<const W: usize>() -> ([u64; W], [u64; W]) {
    let m = 4 * W;
    let mut lo = [0; W];
    let mut hi = [0; W];
    let mut i = 0;
    while i < m {
        let shift = 16 * (i % 4);
        lo[i / 4] |= (((i + 1) * CDF_FLOOR as usize) as u64) << shift;
        hi[i / 4] |= ((CDF_ONE as usize - (m - i) * CDF_FLOOR as usize) as u64) << shift;
        i += 1;
    }
    (lo, hi)
}

impl<const W: usize> Cdf<W> {
    /// Boundaries stored.
    const M: usize = 4 * W;
    const LO: [u64; W] = cdf_targets::<W>().0;
    const HI: [u64; W] = cdf_targets::<W>().1;

    /// A model starting at the cumulative frequencies `f` (`F[1..=M]`, checked by the
    /// tests of the tables that use it: increasing by at least the floor, the last at
    /// most `CDF_ONE - CDF_FLOOR`).
    pub const fn new(f: &[u16]) -> Self {
        assert!(W >= 1 && f.len() == 4 * W);
        let mut w = [0u64; W];
        let mut i = 0;
        while i < f.len() {
            w[i / 4] |= (f[i] as u64) << (16 * (i % 4));
            i += 1;
        }
        Cdf { w, seen: 0 }
    }

    /// Entry `F[i+1]`.
    #[inline]
    fn entry(&self, i: usize) -> u32 {
        (self.w[i / 4] >> (16 * (i % 4))) as u32 & 0xFFFF
    }

    /// The interval of symbol `s`: left cumulative frequency and width.
    #[inline]
    fn interval(&self, s: usize) -> (u32, u32) {
        let left = if s == 0 { 0 } else { self.entry(s - 1) };
        let right = if s == Self::M {
            CDF_ONE as u32
        } else {
            self.entry(s)
        };
        (left, right - left)
    }

    /// The symbol whose interval holds `quantile` (< `CDF_ONE`), with that interval's
    /// ends: the number of entries at or below `quantile`, counted lane-parallel without
    /// branches (a scan's exit branch mispredicts on about every other token).
    #[inline]
    fn locate(&self, quantile: u32) -> (usize, u32, u32) {
        let q1 = (quantile as u64 + 1) * LANES;
        let mut count = 0;
        for &w in &self.w {
            // Lanes at or below the quantile keep their guard bit clear in w - (q+1);
            // one bit each at the lane bottoms, summed into the top lane by a multiply.
            let below = (!((w | GUARDS) - q1) & GUARDS) >> 15;
            count += below.wrapping_mul(LANES) >> 48;
        }
        let s = count as usize;
        // The ends without branches: s is 0 for about half the tokens, a coin toss
        // for the predictor. `min` keeps the lane reads in bounds for the compiler.
        let left = self.entry(s.max(1) - 1) & 0u32.wrapping_sub(u32::from(s != 0));
        let right = if s >= Self::M {
            CDF_ONE as u32
        } else {
            self.entry(s.min(Self::M - 1))
        };
        (s, left, right)
    }

    #[inline]
    fn update(&mut self, s: usize) {
        let rate = CDF_RATES[self.seen as usize] as u32;
        self.seen = (self.seen + 1).min(CDF_RATES.len() as u16 - 1);
        let keep = KEEP[rate as usize];
        for (k, w) in self.w.iter_mut().enumerate() {
            let below = BELOW[s.saturating_sub(4 * k).min(4)];
            let down = ((*w - Self::LO[k]) >> rate) & keep & below;
            let up = ((Self::HI[k] - *w) >> rate) & keep & !below;
            *w = *w + up - down;
        }
    }

    /// Cost of coding `s` now, in 1/256 bits.
    #[inline]
    pub fn cost(&self, s: usize) -> u32 {
        // cost_of works in 2^-16 units.
        cost_table(self.interval(s).1 << (PRECISION - CDF_PRECISION))
    }

    /// The interval of token `t` with sign `negative` (see [`SymbolSink::signed_symbol`]).
    #[inline]
    fn signed_interval(&self, t: usize, negative: bool) -> (u32, u32) {
        split_sign(t, self.interval(t), negative)
    }

    /// Cost of coding token `t` with sign `negative` now, in 1/256 bits.
    #[inline]
    pub fn signed_cost(&self, t: usize, negative: bool) -> u32 {
        cost_table(self.signed_interval(t, negative).1 << (PRECISION - CDF_PRECISION))
    }

    /// The probability of `s` now, in units of 2^-15 (for tests).
    pub fn frequency(&self, s: usize) -> u32 {
        self.interval(s).1
    }
}

/// The part of token `t`'s interval `(left, width)` for the sign: the first
/// `floor(width / 2)` for positive, the rest for negative; token 0 has no sign.
#[inline]
fn split_sign(t: usize, (left, width): (u32, u32), negative: bool) -> (u32, u32) {
    let half = width / 2;
    match (t, negative) {
        (0, _) => (left, width),
        (_, false) => (left, half),
        (_, true) => (left + half, width - half),
    }
}

/// `-log2(p / 2^16) * 256`, rounded, by the integer binary-logarithm algorithm
/// (repeated squaring of the mantissa), so rate estimates are the same on every machine.
fn cost_of(p: u32) -> u32 {
    let e = 31 - p.leading_zeros(); // floor(log2 p)
                                    // Mantissa in [1, 2) as Q30.
    let mut m: u64 = ((p as u64) << 30) >> e;
    let mut frac = 0u32;
    for bit in (0..10).rev() {
        m = (m * m) >> 30;
        if m >= 2 << 30 {
            m >>= 1;
            frac |= 1 << bit;
        }
    }
    // log2 p in 1/1024 bits, then to 1/256 bits with rounding.
    let log2p = (e << 10) | frac;
    let cost = ((PRECISION as u32) << 10).saturating_sub(log2p);
    ((cost + 2) >> 2).max(1)
}

/// [`cost_of`] for every probability `1..=ONE`, looked up: the rate-distortion search
/// prices several candidates per block, and the squaring loop dominated its time.
static COST_TABLE: std::sync::LazyLock<Box<[u16]>> = std::sync::LazyLock::new(|| {
    (0..=ONE)
        .map(|p| if p == 0 { 0 } else { cost_of(p) as u16 })
        .collect()
});

/// [`cost_of`] through [`COST_TABLE`].
#[inline]
fn cost_table(p: u32) -> u32 {
    COST_TABLE[p as usize] as u32
}

/// The fixed two-symbol distribution handed to the coder.
#[derive(Debug, Clone, Copy)]
struct Bernoulli(u32);

impl EntropyModel<PRECISION> for Bernoulli {
    type Symbol = bool;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for Bernoulli {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl Borrow<bool>,
    ) -> Option<(u32, NonZeroU32)> {
        let p0 = self.0;
        if *symbol.borrow() {
            Some((p0, NonZeroU32::new(ONE - p0)?))
        } else {
            Some((0, NonZeroU32::new(p0)?))
        }
    }
}

impl DecoderModel<PRECISION> for Bernoulli {
    #[inline]
    fn quantile_function(&self, quantile: u32) -> (bool, u32, NonZeroU32) {
        // Without branches: split flags are hard to predict, and a mispredicted
        // branch costs more than the masks.
        let p0 = self.0;
        let bit = quantile >= p0;
        let mask = 0u32.wrapping_sub(u32::from(bit));
        let left = p0 & mask;
        let p = p0.wrapping_add(ONE.wrapping_sub(2 * p0) & mask);
        (
            bit,
            left,
            NonZeroU32::new(p).expect("LIMIT <= p0 <= ONE - LIMIT"),
        )
    }
}

/// A multi-symbol model as handed to the coder.
#[derive(Clone, Copy)]
struct CdfModel<'a, const W: usize>(&'a Cdf<W>);

impl<const W: usize> EntropyModel<CDF_PRECISION> for CdfModel<'_, W> {
    type Symbol = usize;
    type Probability = u32;
}

impl<const W: usize> EncoderModel<CDF_PRECISION> for CdfModel<'_, W> {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl Borrow<usize>,
    ) -> Option<(u32, NonZeroU32)> {
        let s = *symbol.borrow();
        if s > Cdf::<W>::M {
            return None;
        }
        let (left, p) = self.0.interval(s);
        Some((left, NonZeroU32::new(p)?))
    }
}

impl<const W: usize> DecoderModel<CDF_PRECISION> for CdfModel<'_, W> {
    #[inline]
    fn quantile_function(&self, quantile: u32) -> (usize, u32, NonZeroU32) {
        let (s, left, right) = self.0.locate(quantile);
        (
            s,
            left,
            NonZeroU32::new(right - left).expect("every symbol keeps the floor"),
        )
    }
}

/// A token model whose nonzero tokens carry an equiprobable sign in the same step.
#[derive(Clone, Copy)]
struct SignedCdfModel<'a, const W: usize>(&'a Cdf<W>);

impl<const W: usize> EntropyModel<CDF_PRECISION> for SignedCdfModel<'_, W> {
    type Symbol = (usize, bool);
    type Probability = u32;
}

impl<const W: usize> EncoderModel<CDF_PRECISION> for SignedCdfModel<'_, W> {
    #[inline]
    fn left_cumulative_and_probability(
        &self,
        symbol: impl Borrow<(usize, bool)>,
    ) -> Option<(u32, NonZeroU32)> {
        let (t, negative) = *symbol.borrow();
        if t > Cdf::<W>::M {
            return None;
        }
        let (left, p) = self.0.signed_interval(t, negative);
        Some((left, NonZeroU32::new(p)?))
    }
}

impl<const W: usize> DecoderModel<CDF_PRECISION> for SignedCdfModel<'_, W> {
    #[inline]
    fn quantile_function(&self, quantile: u32) -> ((usize, bool), u32, NonZeroU32) {
        let (t, left, right) = self.0.locate(quantile);
        let (width, half) = (right - left, (right - left) / 2);
        // split_sign without branches: the sign is a coin toss for the predictor.
        let nonzero = u32::from(t != 0);
        let negative = nonzero & u32::from(quantile - left >= half);
        let (neg_mask, pos_mask) = (
            0u32.wrapping_sub(negative),
            0u32.wrapping_sub(nonzero ^ negative),
        );
        let left = left + (half & neg_mask);
        let p = width - (half & neg_mask) - ((width - half) & pos_mask);
        let negative = negative != 0;
        (
            (t, negative),
            left,
            // Widths are at least the floor (4), so halves are at least 2.
            NonZeroU32::new(p).expect("every symbol keeps the floor"),
        )
    }
}

/// `bits` (1..=16) equiprobable bits as one symbol: the value `v < 2^bits` codes as
/// `[v, v + 1) * 2^(16 - bits)`.
#[derive(Clone, Copy)]
struct RawBits(u32);

impl EntropyModel<PRECISION> for RawBits {
    type Symbol = u32;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for RawBits {
    #[inline]
    fn left_cumulative_and_probability(&self, v: impl Borrow<u32>) -> Option<(u32, NonZeroU32)> {
        let shift = PRECISION as u32 - self.0;
        let v = *v.borrow();
        (v >> self.0 == 0).then(|| (v << shift, NonZeroU32::new(1 << shift).expect("nonzero")))
    }
}

impl DecoderModel<PRECISION> for RawBits {
    #[inline]
    fn quantile_function(&self, quantile: u32) -> (u32, u32, NonZeroU32) {
        let shift = PRECISION as u32 - self.0;
        let v = quantile >> shift;
        (v, v << shift, NonZeroU32::new(1 << shift).expect("nonzero"))
    }
}

/// Most raw bits one symbol carries.
pub const MAX_RAW_BITS: u32 = 16;

/// Where symbols go: a real encoder or a cost counter.
pub trait SymbolSink {
    /// Codes `bit` with the adaptive model `m` (and updates it).
    fn bin(&mut self, m: &mut BinModel, bit: bool);
    /// Codes symbol `s` with the adaptive model `m` (and updates it).
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize);
    /// Codes token `t` with the adaptive model `m` (and updates it); a nonzero token
    /// also carries the equiprobable `negative` in the same coder step: its
    /// interval splits into a positive first part of half its width (rounded down) and
    /// a negative rest.
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool);
    /// Codes the low `bits` (1..=16) bits of `v`, all equiprobable.
    fn raw(&mut self, v: u32, bits: u32);
}

/// One symbol's interval as recorded by [`AnsSink`], replayed backwards.
#[derive(Clone, Copy)]
struct Interval {
    left: u32,
    probability: u32,
    /// The model's precision: [`CDF_PRECISION`] (tokens) or [`PRECISION`] (the rest).
    cdf: bool,
}

/// A fixed interval as an encoder model (for the backward replay).
#[derive(Clone, Copy)]
struct Fixed(u32, NonZeroU32);

impl<const P: usize> EntropyModel<P> for Fixed {
    type Symbol = ();
    type Probability = u32;
}

impl<const P: usize> EncoderModel<P> for Fixed {
    #[inline]
    fn left_cumulative_and_probability(&self, _: impl Borrow<()>) -> Option<(u32, NonZeroU32)> {
        Some((self.0, self.1))
    }
}

/// Writes symbols with constriction's ANS coder (recorded forward, encoded backward).
#[derive(Default)]
pub struct AnsSink {
    intervals: Vec<Interval>,
}

impl AnsSink {
    /// An empty encoder.
    pub fn new() -> Self {
        AnsSink::default()
    }

    #[inline]
    fn push(&mut self, (left, probability): (u32, u32), cdf: bool) {
        self.intervals.push(Interval {
            left,
            probability,
            cdf,
        });
    }

    /// Finishes and returns the bytes (little-endian 32-bit words).
    pub fn finish(self) -> Vec<u8> {
        let mut ans = DefaultAnsCoder::new();
        for i in self.intervals.iter().rev() {
            let model = Fixed(
                i.left,
                NonZeroU32::new(i.probability).expect("models keep every probability nonzero"),
            );
            let r = if i.cdf {
                Encode::<CDF_PRECISION>::encode_symbol(&mut ans, (), model)
            } else {
                Encode::<PRECISION>::encode_symbol(&mut ans, (), model)
            };
            r.expect("Vec backend cannot fail");
        }
        let words = ans.into_compressed().expect("Vec backend cannot fail");
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

impl SymbolSink for AnsSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        let p0 = m.p0 as u32;
        self.push(if bit { (p0, ONE - p0) } else { (0, p0) }, false);
        m.update(bit);
    }

    #[inline]
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize) {
        assert!(s <= Cdf::<W>::M, "symbol within the alphabet");
        self.push(m.interval(s), true);
        m.update(s);
    }

    #[inline]
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool) {
        assert!(t <= Cdf::<W>::M, "symbol within the alphabet");
        self.push(m.signed_interval(t, negative), true);
        m.update(t);
    }

    #[inline]
    fn raw(&mut self, v: u32, bits: u32) {
        assert!((1..=MAX_RAW_BITS).contains(&bits) && v >> bits == 0);
        let shift = PRECISION as u32 - bits;
        self.push((v << shift, 1 << shift), false);
    }
}

/// Counts the cost of symbols (1/256 bits) without writing: the encoder's rate estimate.
#[derive(Debug, Default, Clone)]
pub struct CostSink {
    /// Accumulated cost in 1/256 bits.
    pub cost: u64,
}

impl SymbolSink for CostSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        self.cost += m.cost(bit) as u64;
        m.update(bit);
    }

    #[inline]
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize) {
        self.cost += m.cost(s) as u64;
        m.update(s);
    }

    #[inline]
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool) {
        self.cost += m.signed_cost(t, negative) as u64;
        m.update(t);
    }

    #[inline]
    fn raw(&mut self, _v: u32, bits: u32) {
        self.cost += 256 * bits as u64;
    }
}

/// A [`CostSink`] that leaves the models it is handed untouched: their adapted states
/// live in a small overlay keyed by the model's address, so pricing a candidate needs
/// no copy of every context, only of those it touches. Costs equal [`CostSink`]'s on a
/// copy of the models.
#[derive(Debug, Default, Clone)]
pub struct OverlayCostSink {
    /// Accumulated cost in 1/256 bits.
    pub cost: u64,
    bins: Vec<(usize, BinModel)>,
    /// Address, entries (the first `W` of them used) and count seen.
    cdfs: Vec<(usize, [u64; OVERLAY_W], u16)>,
}

/// Widest [`Cdf`] the overlay holds.
const OVERLAY_W: usize = 8;

impl OverlayCostSink {
    /// Forgets the cost and every adapted state, for the next candidate.
    pub fn reset(&mut self) {
        self.cost = 0;
        self.bins.clear();
        self.cdfs.clear();
    }

    /// Prices `s` on the overlay's state of `m` and adapts that state.
    #[inline]
    fn price<const W: usize>(&mut self, m: &Cdf<W>, s: usize, cost: impl Fn(&Cdf<W>) -> u32) {
        const { assert!(W <= OVERLAY_W) };
        let key = m as *const Cdf<W> as usize;
        match self.cdfs.iter_mut().find(|e| e.0 == key) {
            Some(e) => {
                let mut local = Cdf::<W> {
                    w: std::array::from_fn(|i| e.1[i]),
                    seen: e.2,
                };
                self.cost += cost(&local) as u64;
                local.update(s);
                e.1[..W].copy_from_slice(&local.w);
                e.2 = local.seen;
            }
            None => {
                let mut local = *m;
                self.cost += cost(&local) as u64;
                local.update(s);
                let mut w = [0; OVERLAY_W];
                w[..W].copy_from_slice(&local.w);
                self.cdfs.push((key, w, local.seen));
            }
        }
    }
}

impl SymbolSink for OverlayCostSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        let key = m as *const BinModel as usize;
        let e = match self.bins.iter().position(|e| e.0 == key) {
            Some(i) => &mut self.bins[i].1,
            None => {
                self.bins.push((key, *m));
                &mut self.bins.last_mut().expect("just pushed").1
            }
        };
        self.cost += e.cost(bit) as u64;
        e.update(bit);
    }

    #[inline]
    fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>, s: usize) {
        self.price(m, s, |c| c.cost(s));
    }

    #[inline]
    fn signed_symbol<const W: usize>(&mut self, m: &mut Cdf<W>, t: usize, negative: bool) {
        self.price(m, t, |c| c.signed_cost(t, negative));
    }

    #[inline]
    fn raw(&mut self, _v: u32, bits: u32) {
        self.cost += 256 * bits as u64;
    }
}

/// ANS decoding cannot fail: any state decodes to some symbol (a corrupt stream shows
/// as syntax out of range, a symbol budget overrun, or a wrong end state).
#[inline]
fn infallible<T>(r: Result<T, CoderError<Infallible, Infallible>>) -> T {
    match r {
        Ok(t) => t,
        Err(CoderError::Frontend(never) | CoderError::Backend(never)) => match never {},
    }
}

/// Reads symbols back with constriction's ANS decoder.
pub struct AnsSource {
    dec: DefaultAnsCoder,
    /// Symbols read so far; bounded by the caller's syntax, checked against
    /// `max_symbols` so no corrupt stream can make a caller loop long.
    symbols: u64,
    max_symbols: u64,
}

impl AnsSource {
    /// A decoder over `bytes` (a whole section payload), reading at most `max_symbols`
    /// symbols.
    pub fn new(bytes: &[u8], max_symbols: u64) -> Result<Self, CodecError> {
        if !bytes.len().is_multiple_of(4) {
            return Err(CodecError::Format(format!(
                "entropy-coded payload of {} bytes is not whole words",
                bytes.len()
            )));
        }
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        // Rejects a last word of zero, which no encoder writes.
        let dec = DefaultAnsCoder::from_compressed(words)
            .map_err(|_| CodecError::Format("entropy-coded payload is malformed".into()))?;
        Ok(AnsSource {
            dec,
            symbols: 0,
            max_symbols,
        })
    }

    #[inline]
    fn count(&mut self) -> Result<(), CodecError> {
        self.symbols += 1;
        if self.symbols > self.max_symbols {
            return Err(CodecError::Format(
                "entropy-coded payload runs past its syntax".into(),
            ));
        }
        Ok(())
    }

    /// Reads one bin with the adaptive model `m`.
    #[inline]
    pub fn bin(&mut self, m: &mut BinModel) -> Result<bool, CodecError> {
        self.count()?;
        let bit = infallible(self.dec.decode_symbol(Bernoulli(m.p0 as u32)));
        m.update(bit);
        Ok(bit)
    }

    /// Reads one symbol with the adaptive model `m`.
    #[inline]
    pub fn symbol<const W: usize>(&mut self, m: &mut Cdf<W>) -> Result<usize, CodecError> {
        self.count()?;
        let s = infallible(self.dec.decode_symbol(CdfModel(m)));
        m.update(s);
        Ok(s)
    }

    /// Reads a token and its sign (see [`SymbolSink::signed_symbol`]) with the
    /// adaptive model `m`.
    #[inline]
    pub fn signed_symbol<const W: usize>(
        &mut self,
        m: &mut Cdf<W>,
    ) -> Result<(usize, bool), CodecError> {
        self.count()?;
        let (t, negative) = infallible(self.dec.decode_symbol(SignedCdfModel(m)));
        m.update(t);
        Ok((t, negative))
    }

    /// Reads `bits` (1..=16) raw bits.
    #[inline]
    pub fn raw(&mut self, bits: u32) -> Result<u32, CodecError> {
        debug_assert!((1..=MAX_RAW_BITS).contains(&bits));
        self.count()?;
        Ok(infallible(self.dec.decode_symbol(RawBits(bits))))
    }

    /// Whether the decoder consumed exactly what the encoder wrote: every word read and
    /// the state back at the encoder's initial zero (the end-state check).
    pub fn finished_cleanly(&self) -> bool {
        self.dec.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded linear congruential sequence (no test depends on a random crate).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> u32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) as u32
        }
    }

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
        let mut r = Lcg(seed);
        (0..n)
            .map(|i| match i % 5 {
                0 => {
                    let c = (r.next() % 4) as usize;
                    Sym::Bin(c, r.next() % 97 < 10 + 20 * c as u32)
                }
                1 => {
                    let c = (r.next() % 3) as usize;
                    // Geometric-ish, heavier for higher contexts.
                    let mut s = 0;
                    while s < 8 && r.next() % 10 < 3 + 2 * c as u32 {
                        s += 1;
                    }
                    Sym::Token(c, s)
                }
                2 => Sym::Class((r.next() % 25).min(r.next() % 25) as usize),
                3 => {
                    let c = (r.next() % 3) as usize;
                    let t = (r.next() % 9).min(r.next() % 9) as usize;
                    Sym::Signed(c, t, t > 0 && r.next().is_multiple_of(2))
                }
                _ => {
                    let bits = 1 + r.next() % MAX_RAW_BITS;
                    Sym::Raw(r.next() & ((1 << bits) - 1), bits)
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
            let mut r = Lcg(seed);
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
                let s = r.next() as usize % n;
                let want = update_by_definition(&m, s);
                m.update(s);
                assert_valid(&m);
                assert_eq!((0..n - 1).map(|i| m.entry(i)).collect::<Vec<_>>(), want);
                let q = r.next() % CDF_ONE as u32;
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
