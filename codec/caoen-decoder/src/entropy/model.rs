//! The adaptive models: binary probabilities and integer CDFs, their updates and their
//! costs in 1/256 bits (integer, the same on every machine).

pub(super) const PRECISION: usize = 16;
pub(super) const ONE: u32 = 1 << PRECISION;
/// Adaptation rates of binary models stop speeding down here: each bin then moves
/// 1/2^6 of the way toward what it saw.
const MAX_RATE: u32 = 6;
/// Probabilities stay within [LIMIT, ONE - LIMIT] so every symbol stays codable.
pub(super) const LIMIT: u32 = 64;

/// An adaptive binary probability: `p0` = P(bit = 0) in units of 2^-16.
///
/// The adaptation rate starts fast and slows as the model sees bins (sections are
/// short, so the first few bins matter): after `n` bins the model moves
/// `2^-min(6, start - 1 + floor(log2(n + 2)))` of the way toward each new bin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BinModel {
    pub(super) p0: u16,
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
    pub(super) fn update(&mut self, bit: bool) {
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

/// A model whose probabilities can start from trained values: read as numbers for
/// training, and set from them (with a count of symbols as if seen, which sets how fast
/// the model then adapts).
pub trait Trained {
    /// Numbers of the probabilities: 1 for a binary model, `M` for a distribution.
    fn count(&self) -> usize;
    /// The probabilities: a binary model's P(0) in 2^-16, a distribution's entries
    /// `F[1..=M]` in 2^-15.
    fn probabilities(&self, out: &mut Vec<u16>);
    /// Symbols seen so far (saturating).
    fn seen(&self) -> u32;
    /// Starts from `p` ([`Trained::probabilities`]' form, valid: the caller checks) as
    /// if `seen` symbols had been coded.
    fn start_from(&mut self, p: &[u16], seen: u8);
}

impl Trained for BinModel {
    fn count(&self) -> usize {
        1
    }
    fn probabilities(&self, out: &mut Vec<u16>) {
        out.push(self.p0);
    }
    fn seen(&self) -> u32 {
        self.seen.into()
    }
    fn start_from(&mut self, p: &[u16], seen: u8) {
        self.p0 = p[0].clamp(LIMIT as u16, (ONE - LIMIT) as u16);
        self.seen = seen;
    }
}

impl<const W: usize> Trained for Cdf<W> {
    fn count(&self) -> usize {
        Self::M
    }
    fn probabilities(&self, out: &mut Vec<u16>) {
        out.extend((0..Self::M).map(|i| self.entry(i) as u16));
    }
    fn seen(&self) -> u32 {
        self.seen.into()
    }
    fn start_from(&mut self, p: &[u16], seen: u8) {
        debug_assert!(
            valid_cdf(p),
            "a distribution's entries keep the floor apart"
        );
        let mut w = [0u64; W];
        for (i, &f) in p.iter().enumerate().take(Self::M) {
            w[i / 4] |= (f as u64) << (16 * (i % 4));
        }
        self.w = w;
        self.seen = seen.into();
    }
}

/// Whether `f` holds a distribution's entries `F[1..=M]`: each at least [`CDF_FLOOR`]
/// above the one before (and `F[1]` above 0), the last at least the floor below
/// [`CDF_ONE`].
pub fn valid_cdf(f: &[u16]) -> bool {
    let mut prev = 0u32;
    for &x in f {
        if (x as u32) < prev + CDF_FLOOR as u32 {
            return false;
        }
        prev = x as u32;
    }
    prev + CDF_FLOOR as u32 <= CDF_ONE as u32
}

/// Precision of the multi-symbol models: probabilities in units of 2^-15.
pub(super) const CDF_PRECISION: usize = 15;
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
    pub(super) w: [u64; W],
    /// Symbols seen, saturating at the last rate step.
    pub(super) seen: u16,
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
    pub(super) const M: usize = 4 * W;
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
    pub(super) fn entry(&self, i: usize) -> u32 {
        (self.w[i / 4] >> (16 * (i % 4))) as u32 & 0xFFFF
    }

    /// The interval of symbol `s`: left cumulative frequency and width.
    #[inline]
    pub(super) fn interval(&self, s: usize) -> (u32, u32) {
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
    pub(super) fn locate(&self, quantile: u32) -> (usize, u32, u32) {
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

    /// Adapts the model to having coded `s`.
    #[inline]
    pub fn update(&mut self, s: usize) {
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
    pub(super) fn signed_interval(&self, t: usize, negative: bool) -> (u32, u32) {
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
pub(super) fn split_sign(t: usize, (left, width): (u32, u32), negative: bool) -> (u32, u32) {
    let half = width / 2;
    match (t, negative) {
        (0, _) => (left, width),
        (_, false) => (left, half),
        (_, true) => (left + half, width - half),
    }
}

/// `-log2(p / 2^16) * 256`, rounded, by the integer binary-logarithm algorithm
/// (repeated squaring of the mantissa), so rate estimates are the same on every machine.
pub(super) fn cost_of(p: u32) -> u32 {
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
pub(super) fn cost_table(p: u32) -> u32 {
    COST_TABLE[p as usize] as u32
}
