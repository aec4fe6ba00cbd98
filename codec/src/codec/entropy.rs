//! Entropy coding: adaptive binary models on constriction's range coder.
//!
//! Every syntax element is binarised; each bin has an adaptive probability (16-bit
//! fixed point, integer updates, so decoding is platform-independent). The range coder
//! itself is constriction's; this module only supplies the model (implementing its
//! model traits) and a counting back end that prices bits without writing them.

use std::borrow::Borrow;
use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};
use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

use super::CodecError;

const PRECISION: usize = 16;
const ONE: u32 = 1 << PRECISION;
/// Adaptation rate: each bin moves 1/2^RATE of the way toward what it saw.
const RATE: u32 = 5;
/// Probabilities stay within [LIMIT, ONE - LIMIT] so every symbol stays codable.
const LIMIT: u32 = 64;

/// An adaptive binary probability: `p0` = P(bit = 0) in units of 2^-16.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BinModel {
    p0: u32,
}

impl Default for BinModel {
    fn default() -> Self {
        BinModel { p0: ONE / 2 }
    }
}

impl BinModel {
    #[inline]
    fn update(&mut self, bit: bool) {
        if bit {
            self.p0 -= self.p0 >> RATE;
        } else {
            self.p0 += (ONE - self.p0) >> RATE;
        }
        self.p0 = self.p0.clamp(LIMIT, ONE - LIMIT);
    }

    /// Cost of coding `bit` now, in 1/256 bits.
    #[inline]
    pub fn cost(&self, bit: bool) -> u32 {
        let p = if bit { ONE - self.p0 } else { self.p0 };
        cost_of(p)
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

/// The fixed two-symbol distribution handed to the range coder.
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
        let p0 = self.0;
        if quantile < p0 {
            (false, 0, NonZeroU32::new(p0).expect("p0 >= LIMIT"))
        } else {
            (
                true,
                p0,
                NonZeroU32::new(ONE - p0).expect("p0 <= ONE - LIMIT"),
            )
        }
    }
}

/// Where binarised symbols go: a real encoder or a cost counter.
pub trait BinSink {
    /// Codes `bit` with the adaptive model `m` (and updates it).
    fn bin(&mut self, m: &mut BinModel, bit: bool);
    /// Codes `bit` with probability 1/2.
    fn bypass(&mut self, bit: bool);
}

/// Writes bins with constriction's range encoder.
#[derive(Default)]
pub struct RangeSink {
    enc: DefaultRangeEncoder,
}

impl RangeSink {
    /// An empty encoder.
    pub fn new() -> Self {
        RangeSink {
            enc: DefaultRangeEncoder::new(),
        }
    }

    /// Finishes and returns the bytes (little-endian 32-bit words).
    pub fn finish(self) -> Vec<u8> {
        let words = self.enc.into_compressed().expect("Vec backend cannot fail");
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

impl BinSink for RangeSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        self.enc
            .encode_symbol(bit, Bernoulli(m.p0))
            .expect("probabilities are valid");
        m.update(bit);
    }

    #[inline]
    fn bypass(&mut self, bit: bool) {
        self.enc
            .encode_symbol(bit, Bernoulli(ONE / 2))
            .expect("probabilities are valid");
    }
}

/// Counts the cost of bins (1/256 bits) without writing: the encoder's rate estimate.
#[derive(Debug, Default, Clone)]
pub struct CostSink {
    /// Accumulated cost in 1/256 bits.
    pub cost: u64,
}

impl BinSink for CostSink {
    #[inline]
    fn bin(&mut self, m: &mut BinModel, bit: bool) {
        self.cost += m.cost(bit) as u64;
        m.update(bit);
    }

    #[inline]
    fn bypass(&mut self, _bit: bool) {
        self.cost += 256;
    }
}

/// Reads bins back with constriction's range decoder.
pub struct RangeSource {
    dec: DefaultRangeDecoder,
    /// Bins read so far; bounded by the caller's syntax, checked against `max_bins`.
    bins: u64,
    max_bins: u64,
}

impl RangeSource {
    /// A decoder over `bytes` (a whole section payload), reading at most `max_bins` bins.
    pub fn new(bytes: &[u8], max_bins: u64) -> Result<Self, CodecError> {
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
        let dec = DefaultRangeDecoder::from_compressed(words)
            .map_err(|_| CodecError::Format("entropy-coded payload is malformed".into()))?;
        Ok(RangeSource {
            dec,
            bins: 0,
            max_bins,
        })
    }

    fn count(&mut self) -> Result<(), CodecError> {
        self.bins += 1;
        if self.bins > self.max_bins {
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
        let bit = self
            .dec
            .decode_symbol(Bernoulli(m.p0))
            .map_err(|_| CodecError::Format("entropy-coded payload is corrupt".into()))?;
        m.update(bit);
        Ok(bit)
    }

    /// Reads one equiprobable bin.
    #[inline]
    pub fn bypass(&mut self) -> Result<bool, CodecError> {
        self.count()?;
        self.dec
            .decode_symbol(Bernoulli(ONE / 2))
            .map_err(|_| CodecError::Format("entropy-coded payload is corrupt".into()))
    }

    /// Whether the decoder consumed exactly what the encoder wrote (the end-state check).
    pub fn finished_cleanly(&self) -> bool {
        self.dec.maybe_exhausted()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_round_trip_and_costs_track_the_real_size() {
        let mut models = [BinModel::default(); 4];
        let bits: Vec<(usize, bool)> = (0..20000u32)
            .map(|i| {
                (
                    (i % 4) as usize,
                    i.wrapping_mul(2654435761) % 97 < (10 + 20 * (i % 4)),
                )
            })
            .collect();
        let mut sink = RangeSink::new();
        let mut cost = CostSink::default();
        let mut cm = models;
        for &(c, b) in &bits {
            sink.bin(&mut models[c], b);
            cost.bin(&mut cm[c], b);
            sink.bypass(b);
            cost.bypass(b);
        }
        let bytes = sink.finish();
        let est = cost.cost as f64 / 256.0 / 8.0;
        assert!(
            (bytes.len() as f64 - est).abs() < 0.01 * est + 8.0,
            "real {} estimated {est}",
            bytes.len()
        );
        let mut src = RangeSource::new(&bytes, u64::MAX).unwrap();
        let mut models = [BinModel::default(); 4];
        for &(c, b) in &bits {
            assert_eq!(src.bin(&mut models[c]).unwrap(), b);
            assert_eq!(src.bypass().unwrap(), b);
        }
        assert!(src.finished_cleanly());
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
