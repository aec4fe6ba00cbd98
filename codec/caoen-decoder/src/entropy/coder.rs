//! The ANS back end: the models as constriction's entropy models, the sink that records
//! symbols forward and encodes them backward, and the source that reads them.

use std::borrow::Borrow;
use std::convert::Infallible;
use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};
use constriction::stream::stack::DefaultAnsCoder;
use constriction::stream::{Decode, Encode};
use constriction::CoderError;

use super::model::*;
use crate::CodecError;

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
            return Err(CodecError::PayloadNotWords {
                bytes: bytes.len() as u64,
            });
        }
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        // Rejects a last word of zero, which no encoder writes.
        let dec =
            DefaultAnsCoder::from_compressed(words).map_err(|_| CodecError::PayloadMalformed)?;
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
            return Err(CodecError::PayloadOverrun);
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
