//! The detail layer's coefficients as coded symbols (section `D`).
//!
//! Per channel, blocks in raster order. Where a 2x2 group of blocks lies under one
//! network cell of 16 pixels or more (a 4x4 group under one of 32 or more), its first
//! block starts with a *merge* bin: a merged group is one block of the lowest 8x8
//! coefficients of a 16x16 (32x32) transform, coded in place of the first block, and
//! its other blocks take no symbols ([`GroupContext`]). A block is a *coded* bin, then the position of
//! its last nonzero coefficient in zig-zag order (its class, then the bits below the
//! class's top one, each an adaptive bin), then its coefficients from that last one back
//! to the first. The first two take their context from the block's kind (luma or
//! chroma), the size of the network cell over it (its class, as for the adaptive
//! steps) and its neighbourhood: how far the left and above blocks' coefficients reach
//! ([`BlockContext::new`]). The signs of the first [`SIGNED`] scan positions are bins
//! in the context of the left and above blocks' signs at the same position, and their
//! magnitudes take the sizes of theirs as context: the network's smooth errors run on
//! across block edges, so neighbouring low frequencies share their signs and sizes
//! along the picture's structure. Coding backwards puts each coefficient's
//! higher-frequency neighbours before it, so their magnitudes are its context (the
//! scheme of AV1's level maps, simplified).

mod pricer;
#[cfg(test)]
mod tests;

pub use pricer::{BlockPricer, BlockRates};

use super::adaptive::CLASSES;
use super::context_tables::{ANCHORS, ANCHOR_STEPS, STATE_LEN};
use super::dct::{COEFFS, N, ZIGZAG};
use crate::entropy::{
    AnsSource, BinModel, Cdf, SymbolSink, Trained, CDF_FLOOR, CDF_ONE, MAX_RAW_BITS,
};
use crate::CodecError;

/// Magnitudes `0..LITERALS` are tokens of their own; token `LITERALS` escapes.
const LITERALS: usize = 16;
type TokenCdf = Cdf<4>;
/// Escape classes (bit length minus one of `m - LITERALS + 1`): 25 symbols, of which
/// levels up to [`MAX_LEVEL`] use 21.
type ClassCdf = Cdf<6>;
/// Classes of the last position: bit length of `last` (0..=6).
const LAST_CLASSES: usize = 7;
type LastCdf = Cdf<2>;
/// Frequency bands by scan position.
const BANDS: usize = 6;
/// Neighbourhood magnitude classes.
const MAG_CLASSES: usize = 5;
/// Block neighbourhood classes ([`BlockContext::neighbours`]).
pub const NEIGHBOURS: usize = 6;
/// Scan positions `0..SIGNED` code their signs as bins in the context of the left and
/// above blocks' signs at the same position ([`BlockContext::signs`]); the rest as raw bits.
pub const SIGNED: usize = 10;
/// Sign contexts of one position: the left and above blocks' signs there, `3 left + above`.
pub const SIGN_CONTEXTS: usize = 9;
/// Magnitude contexts of one position below [`SIGNED`]: how large the left and above
/// blocks' levels there are ([`BlockContext::levels`]).
pub const LEVELS: usize = 3;
/// Most bits below a last position's class bit.
const LAST_BITS: usize = LAST_CLASSES - 2;
/// Largest coefficient magnitude a file may hold.
pub const MAX_LEVEL: u32 = 1 << 20;
/// Most symbols one block can take (bins, tokens and raw bits): the decoder's bound.
/// The merge bins, the luma factor, the coded bin, the last position's class and bits, four per level (token, escape
/// class, two raw parts) and the signs outside a token (the first positions' bins and
/// the last level's).
pub const MAX_SYMBOLS_PER_BLOCK: u64 = 5 + SIGNED as u64 + LAST_BITS as u64 + COEFFS as u64 * 4;

/// The class of a block's last nonzero scan position `last`: its bit length.
fn last_class(last: usize) -> usize {
    if last == 0 {
        0
    } else {
        32 - (last as u32).leading_zeros() as usize
    }
}

/// What a block tells its right and lower neighbours' contexts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// 0 when the block has no nonzero coefficient, else one more than the class of
    /// its last one (1..=7).
    pub reach: u8,
    /// The signs of its levels at scan positions `0..SIGNED`: 0 for zero, 1 positive,
    /// 2 negative.
    pub signs: [u8; SIGNED],
    /// The magnitudes of its levels at scan positions `0..SIGNED`, each counted up to 2.
    pub levels: [u8; SIGNED],
}

impl Summary {
    /// The summary of a block's levels (row-major).
    pub fn of(q: &[i32; COEFFS]) -> Summary {
        Summary {
            reach: (0..COEFFS)
                .rev()
                .find(|&k| q[ZIGZAG[k] as usize] != 0)
                .map_or(0, |last| 1 + last_class(last) as u8),
            signs: std::array::from_fn(|k| match q[ZIGZAG[k] as usize].signum() {
                0 => 0,
                1 => 1,
                _ => 2,
            }),
            levels: std::array::from_fn(|k| q[ZIGZAG[k] as usize].unsigned_abs().min(2) as u8),
        }
    }
}

fn band(k: usize) -> usize {
    match k {
        0 => 0,
        1..=2 => 1,
        3..=5 => 2,
        6..=14 => 3,
        15..=27 => 4,
        _ => 5,
    }
}

/// A geometric distribution of ratio `r` over `m + 1` symbols as cumulative entries
/// `F[1..=m]`, each step at least the floor.
fn geometric(m: usize, r: f64) -> Vec<u16> {
    let total = CDF_ONE as f64 - (m + 1) as f64 * CDF_FLOOR as f64;
    let norm: f64 = (0..=m).map(|i| r.powi(i as i32)).sum();
    let mut acc = 0.0;
    (0..m)
        .map(|i| {
            acc += r.powi(i as i32) / norm * total;
            (acc.floor() as u16) + (i as u16 + 1) * CDF_FLOOR
        })
        .collect()
}

/// A distribution falling by ratio `r` on both sides of the middle symbol, over `m +
/// 1` symbols (`m` even), as cumulative entries `F[1..=m]`, each step at least the
/// floor.
pub fn two_sided(m: usize, r: f64) -> Vec<u16> {
    let total = CDF_ONE as f64 - (m + 1) as f64 * CDF_FLOOR as f64;
    let p = |i: usize| r.powi((i as i32 - (m / 2) as i32).abs());
    let norm: f64 = (0..=m).map(p).sum();
    let mut acc = 0.0;
    (0..m)
        .map(|i| {
            acc += p(i) / norm * total;
            (acc.floor() as u16) + (i as u16 + 1) * CDF_FLOOR
        })
        .collect()
}

/// Largest magnitude of a chroma block's luma factor, in eighths.
pub const FACTOR_LIMIT: i32 = 16;
/// Factors `-FACTOR_LIMIT..=FACTOR_LIMIT`: 33 symbols.
type FactorCdf = Cdf<8>;
/// Factor contexts of a plane: how many of the left and above blocks have a factor.
pub const FACTOR_CONTEXTS: usize = 3;

/// The adaptive contexts of a detail section.
///
/// Fixed-size arrays, cheap to copy.
#[derive(Clone, PartialEq)]
pub struct DetailContexts {
    coded: [[[BinModel; NEIGHBOURS]; CLASSES]; 2],
    last: [[[LastCdf; NEIGHBOURS]; CLASSES]; 2],
    /// Signs of the first scan positions, by kind, position and the neighbours' signs
    /// there ([`BlockContext::signs`]).
    sign: [[[BinModel; SIGN_CONTEXTS]; SIGNED]; 2],
    /// Bits below a last position's class bit, by kind, class and bit (from the top).
    last_bits: [[[BinModel; LAST_BITS]; LAST_CLASSES]; 2],
    /// Level tokens ([`token_index`]).
    token: [TokenCdf; TOKENS],
    /// The last level's magnitude less one ([`first_index`]).
    first: [TokenCdf; 2 * BANDS * LEVELS],
    class: [ClassCdf; 2],
    /// Merge bins, by kind, slot ([`GroupContext::slot`]) and merged neighbour groups.
    merge: [[[BinModel; MERGE_CONTEXTS]; MERGE_SLOTS]; 2],
    /// Chroma blocks' luma factors, by chroma plane (C1, C2) and how many of the left
    /// and above blocks have one.
    factor: [[FactorCdf; FACTOR_CONTEXTS]; 2],
}

impl Default for DetailContexts {
    fn default() -> Self {
        let last = LastCdf::new(&geometric(8, 0.8));
        let token = std::array::from_fn(|i| {
            let mag = (i / LEVELS) % MAG_CLASSES;
            TokenCdf::new(&geometric(16, 0.2 + 0.15 * mag as f64))
        });
        DetailContexts {
            coded: [[[BinModel::new(2); NEIGHBOURS]; CLASSES]; 2],
            last: [[[last; NEIGHBOURS]; CLASSES]; 2],
            last_bits: [[[BinModel::new(4); LAST_BITS]; LAST_CLASSES]; 2],
            sign: [[[BinModel::new(4); SIGN_CONTEXTS]; SIGNED]; 2],
            first: [TokenCdf::new(&geometric(16, 0.4)); 2 * BANDS * LEVELS],
            token,
            class: [ClassCdf::new(&geometric(24, 0.7)); 2],
            merge: [[[BinModel::new(4); MERGE_CONTEXTS]; MERGE_SLOTS]; 2],
            factor: [[FactorCdf::new(&two_sided(2 * FACTOR_LIMIT as usize, 0.5)); FACTOR_CONTEXTS];
                2],
        }
    }
}

/// A model's probabilities ([`Trained::probabilities`]) and the symbols it has seen.
pub type ModelState = (Vec<u16>, u32);

/// Symbols a trained start counts as seen: distributions then adapt at `2^-4` and
/// binary models at `2^-min(6, start + 2)` (`docs/format.md`), fast enough to follow
/// the picture and slow enough to keep what the training knew.
pub const TRAINED_SEEN: u8 = 8;

impl DetailContexts {
    /// The contexts a stream starts from, for a file whose luma detail step is `step`:
    /// the trained probabilities ([`super::context_tables`]) at the two anchor steps
    /// around `step` mixed linearly (in 1/256), or the nearest anchor's outside them,
    /// each model as if it had seen [`TRAINED_SEEN`] symbols.
    pub fn for_step(step: f64) -> Self {
        let (a, b, w) = anchors(step);
        let (ta, tb) = (&ANCHORS[a], &ANCHORS[b]);
        let mut c = DetailContexts::default();
        let mut at = 0;
        let mut buf = [0u16; 32];
        c.each_model(&mut |m| {
            let n = m.count();
            for (k, p) in buf[..n].iter_mut().enumerate() {
                *p = ((ta[at + k] as u32 * (256 - w) + tb[at + k] as u32 * w) >> 8) as u16;
            }
            m.start_from(&buf[..n], TRAINED_SEEN);
            at += n;
        });
        debug_assert_eq!(at, STATE_LEN);
        c
    }

    /// Every model in the trained tables' order: the luma kind's (coded bins, last
    /// positions, signs, last-position bits, tokens, last levels, escape class, merge
    /// bins), the chroma kind's in the same order, then the chroma factors.
    fn each_model(&mut self, f: &mut dyn FnMut(&mut dyn Trained)) {
        for k in 0..2 {
            self.coded[k].iter_mut().flatten().for_each(|m| f(m));
            self.last[k].iter_mut().flatten().for_each(|m| f(m));
            self.sign[k].iter_mut().flatten().for_each(|m| f(m));
            self.last_bits[k].iter_mut().flatten().for_each(|m| f(m));
            let t = TOKENS / 2;
            self.token[k * t..(k + 1) * t].iter_mut().for_each(|m| f(m));
            let l = BANDS * LEVELS;
            self.first[k * l..(k + 1) * l].iter_mut().for_each(|m| f(m));
            f(&mut self.class[k]);
            self.merge[k].iter_mut().flatten().for_each(|m| f(m));
        }
        self.factor.iter_mut().flatten().for_each(|m| f(m));
    }

    /// Every model's probabilities and symbols seen, in the trained tables' order (the
    /// statistics the tables are trained from).
    pub fn models(&self) -> Vec<ModelState> {
        let mut c = self.clone();
        let mut out = Vec::new();
        c.each_model(&mut |m| {
            let mut p = Vec::with_capacity(m.count());
            m.probabilities(&mut p);
            out.push((p, m.seen()));
        });
        out
    }
}

/// The anchors around `step` (as the header stores it, in single precision) and the
/// second's weight in 1/256: plain arithmetic on the stored values, so every machine
/// picks the same.
fn anchors(step: f64) -> (usize, usize, u32) {
    let s = step as f32 as f64;
    let last = ANCHOR_STEPS.len() - 1;
    if s.is_nan() || s <= ANCHOR_STEPS[0] as f64 {
        return (0, 0, 0);
    }
    if s >= ANCHOR_STEPS[last] as f64 {
        return (last, last, 0);
    }
    let i = ANCHOR_STEPS
        .iter()
        .rposition(|&a| a as f64 <= s)
        .unwrap_or(0)
        .min(last - 1);
    let (lo, hi) = (ANCHOR_STEPS[i] as f64, ANCHOR_STEPS[i + 1] as f64);
    let w = ((s - lo) / (hi - lo) * 256.0).round().clamp(0.0, 256.0) as u32;
    (i, i + 1, w)
}

/// Token models: by kind, band, magnitude class and neighbour magnitude context.
const TOKENS: usize = 2 * BANDS * MAG_CLASSES * LEVELS;

/// The token model of a level of `kind` in band `b`, with magnitude class `mc` in its
/// block and neighbour magnitude context `lv` ([`BlockContext::level`]).
#[inline(always)]
fn token_index(kind: usize, b: usize, mc: usize, lv: usize) -> usize {
    ((kind * BANDS + b) * MAG_CLASSES + mc) * LEVELS + lv
}

/// The model of a block's last level, of `kind` in band `b`, with neighbour magnitude
/// context `lv`.
#[inline(always)]
fn first_index(kind: usize, b: usize, lv: usize) -> usize {
    (kind * BANDS + b) * LEVELS + lv
}

/// Side of the padded magnitude map: two spare rows and columns past the block, so
/// a coefficient's neighbours are plain offsets with no bounds tests.
const PAD: usize = N + 2;

/// The padded-map position of each scan position.
const PADDED: [u8; COEFFS] = {
    let mut p = [0u8; COEFFS];
    let mut k = 0;
    while k < COEFFS {
        let z = ZIGZAG[k] as usize;
        p[k] = ((z / N) * PAD + z % N) as u8;
        k += 1;
    }
    p
};

/// Magnitudes already coded in a block, each counted up to 3, on the padded map.
type MagnitudeMap = [u8; PAD * PAD];

/// Context of the coefficient at padded position `p` from the magnitudes already
/// coded in its block: the two next-frequency neighbours and three beyond.
#[inline(always)]
fn mag_class(map: &MagnitudeMap, p: usize) -> usize {
    let s = map[p + 1] + map[p + PAD] + map[p + PAD + 1] + map[p + 2] + map[p + 2 * PAD];
    (((s + 1) >> 1) as usize).min(MAG_CLASSES - 1)
}

fn write_escape(class: &mut ClassCdf, m: u32, sink: &mut impl SymbolSink) {
    let v = m - LITERALS as u32 + 1;
    let c = 31 - v.leading_zeros();
    sink.symbol(class, c as usize);
    let rest = v - (1 << c);
    if c > MAX_RAW_BITS {
        sink.raw(rest >> MAX_RAW_BITS, c - MAX_RAW_BITS);
    }
    if c > 0 {
        let low = c.min(MAX_RAW_BITS);
        sink.raw(rest & ((1 << low) - 1), low);
    }
}

fn read_escape(class: &mut ClassCdf, src: &mut AnsSource) -> Result<u32, CodecError> {
    let c = src.symbol(class)? as u32;
    let mut rest = 0u64;
    if c > MAX_RAW_BITS {
        rest = (src.raw(c - MAX_RAW_BITS)? as u64) << MAX_RAW_BITS;
    }
    if c > 0 {
        rest |= src.raw(c.min(MAX_RAW_BITS))? as u64;
    }
    let m = (1u64 << c) + rest + LITERALS as u64 - 1;
    if m > MAX_LEVEL as u64 {
        return Err(CodecError::range(
            "detail coefficient",
            m as f64,
            0.0,
            MAX_LEVEL as f64,
        ));
    }
    Ok(m as u32)
}

/// Where a block sits among its coded neighbours: the context of its first symbols.
#[derive(Debug, Clone, Copy)]
pub struct BlockContext {
    /// 0 for luma, 1 for chroma.
    pub kind: usize,
    /// The block's cell-size class ([`adaptive::block_classes`](super::adaptive::block_classes)).
    pub class: usize,
    /// Neighbourhood class: 0 when neither the left nor the above block is coded, then
    /// rising with how far their coefficients reach ([`Summary::reach`]), up to
    /// `NEIGHBOURS - 1`.
    pub neighbours: usize,
    /// Per scan position below [`SIGNED`], the left and above blocks' signs there
    /// ([`Summary::signs`]), `3 left + above`: the context of this block's sign there.
    pub signs: [u8; SIGNED],
    /// Per scan position below [`SIGNED`], the left and above blocks' magnitudes there
    /// ([`Summary::levels`]): 0 when both are zero, 1 for a sum of 1 or 2, else 2.
    pub levels: [u8; SIGNED],
}

impl BlockContext {
    /// The context of a block from its left and above neighbours' summaries (the default
    /// where there is none), of `kind` (0 luma, 1 chroma) and cell-size class `class`.
    pub fn new(kind: usize, class: usize, left: Summary, above: Summary) -> BlockContext {
        let s = (left.reach + above.reach) as usize;
        BlockContext {
            kind,
            class,
            neighbours: if s == 0 {
                0
            } else {
                s.div_ceil(2).min(NEIGHBOURS - 1)
            },
            signs: std::array::from_fn(|k| 3 * left.signs[k] + above.signs[k]),
            levels: std::array::from_fn(|k| (left.levels[k] + above.levels[k]).div_ceil(2)),
        }
    }

    /// The neighbour magnitude context of scan position `k` (0 from [`SIGNED`] on).
    #[inline(always)]
    pub fn level(&self, k: usize) -> usize {
        if k < SIGNED {
            self.levels[k] as usize
        } else {
            0
        }
    }
}

impl BlockContext {
    /// The `i`-th of a sequence of contexts that runs through every value of each part,
    /// for tests that code blocks in all of them.
    pub fn varied(i: usize) -> BlockContext {
        BlockContext {
            kind: i % 2,
            class: i % CLASSES,
            neighbours: i % NEIGHBOURS,
            signs: std::array::from_fn(|k| ((i + k) % SIGN_CONTEXTS) as u8),
            levels: std::array::from_fn(|k| ((i + 2 * k) % LEVELS) as u8),
        }
    }
}

/// Group levels: a level-`g` group is `2^g x 2^g` blocks.
pub const GROUP_LEVELS: usize = 2;
/// Merge contexts of a group: how many of its left and above groups are merged.
pub const MERGE_CONTEXTS: usize = 3;
/// Merge models per kind: level-1 groups by class (0 for chroma only, 1, 2), then
/// level-2 groups.
const MERGE_SLOTS: usize = 4;

/// Where a group of blocks that may merge sits: the context of its merge bin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GroupContext {
    /// 0 for luma, 1 for chroma.
    pub kind: usize,
    /// 1 for a 2x2 group, 2 for a 4x4 group.
    pub level: usize,
    /// The cell-size class of its blocks: at least the level.
    pub class: usize,
    /// How many of the same-sized groups to its left and above are in merged groups
    /// of this level or larger (0..=2).
    pub merged: usize,
}

impl GroupContext {
    /// The merge model's slot: a 2x2 group's class (0 only for chroma), or 3 for a
    /// 4x4 group.
    fn slot(&self) -> usize {
        if self.level == 1 {
            self.class
        } else {
            3
        }
    }
}

/// Codes whether a group is merged.
pub fn write_merge(
    ctx: &mut DetailContexts,
    g: GroupContext,
    merged: bool,
    sink: &mut impl SymbolSink,
) {
    sink.bin(&mut ctx.merge[g.kind][g.slot()][g.merged], merged);
}

/// Reads whether a group is merged.
pub fn read_merge(
    ctx: &mut DetailContexts,
    g: GroupContext,
    src: &mut AnsSource,
) -> Result<bool, CodecError> {
    src.bin(&mut ctx.merge[g.kind][g.slot()][g.merged])
}

/// The cost of [`write_merge`] in 1/256 bits, on the contexts as they are.
pub fn merge_cost(ctx: &DetailContexts, g: GroupContext, merged: bool) -> u64 {
    ctx.merge[g.kind][g.slot()][g.merged].cost(merged) as u64
}

/// Where a chroma block's luma factor is coded: its chroma plane (0 for C1, 1 for C2)
/// and how many of its left and above blocks have a nonzero factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FactorContext {
    /// 0 for C1, 1 for C2.
    pub plane: usize,
    /// Left and above blocks with a factor (0..=2).
    pub neighbours: usize,
}

/// Codes a chroma block's luma factor `a` (eighths, `|a| <= FACTOR_LIMIT`).
pub fn write_factor(
    ctx: &mut DetailContexts,
    f: FactorContext,
    a: i32,
    sink: &mut impl SymbolSink,
) {
    sink.symbol(
        &mut ctx.factor[f.plane][f.neighbours],
        (a + FACTOR_LIMIT) as usize,
    );
}

/// Reads a chroma block's luma factor.
pub fn read_factor(
    ctx: &mut DetailContexts,
    f: FactorContext,
    src: &mut AnsSource,
) -> Result<i32, CodecError> {
    Ok(src.symbol(&mut ctx.factor[f.plane][f.neighbours])? as i32 - FACTOR_LIMIT)
}

/// The cost of [`write_factor`] in 1/256 bits, on the contexts as they are.
pub fn factor_cost(ctx: &DetailContexts, f: FactorContext, a: i32) -> u64 {
    ctx.factor[f.plane][f.neighbours].cost((a + FACTOR_LIMIT) as usize) as u64
}

/// Codes one block's quantised coefficients (row-major levels).
pub fn write_block(
    ctx: &mut DetailContexts,
    at: BlockContext,
    q: &[i32; COEFFS],
    sink: &mut impl SymbolSink,
) {
    let (kind, nb, cl) = (at.kind, at.neighbours, at.class);
    let last = (0..COEFFS).rev().find(|&k| q[ZIGZAG[k] as usize] != 0);
    sink.bin(&mut ctx.coded[kind][cl][nb], last.is_some());
    let Some(last) = last else { return };
    let c = last_class(last);
    sink.symbol(&mut ctx.last[kind][cl][nb], c);
    for (i, model) in ctx.last_bits[kind][c]
        .iter_mut()
        .take(c.saturating_sub(1))
        .enumerate()
    {
        sink.bin(model, (last >> (c - 2 - i)) & 1 == 1);
    }
    let mut map: MagnitudeMap = [0; PAD * PAD];
    for k in (0..=last).rev() {
        let z = ZIGZAG[k] as usize;
        let p = PADDED[k] as usize;
        let v = q[z];
        let m = v.unsigned_abs();
        let b = band(k);
        if k == last {
            // Known nonzero: code m - 1 and the sign.
            let t = ((m - 1) as usize).min(LITERALS);
            sink.symbol(&mut ctx.first[first_index(kind, b, at.level(k))], t);
            if t == LITERALS {
                write_escape(&mut ctx.class[kind], m - 1, sink);
            }
            if k < SIGNED {
                sink.bin(&mut ctx.sign[kind][k][at.signs[k] as usize], v < 0);
            } else {
                sink.raw(u32::from(v < 0), 1);
            }
        } else if k < SIGNED {
            // The sign has a context of its own, after the magnitude.
            let t = (m as usize).min(LITERALS);
            sink.symbol(
                &mut ctx.token[token_index(kind, b, mag_class(&map, p), at.level(k))],
                t,
            );
            if t == LITERALS {
                write_escape(&mut ctx.class[kind], m, sink);
            }
            if m != 0 {
                sink.bin(&mut ctx.sign[kind][k][at.signs[k] as usize], v < 0);
            }
        } else {
            let mc = mag_class(&map, p);
            let t = (m as usize).min(LITERALS);
            sink.signed_symbol(&mut ctx.token[token_index(kind, b, mc, 0)], t, v < 0);
            if t == LITERALS {
                write_escape(&mut ctx.class[kind], m, sink);
            }
        }
        map[p] = m.min(3) as u8;
    }
}

/// Reads one block's coefficients into `q` (row-major levels); returns whether it is
/// coded (any coefficient nonzero).
pub fn read_block(
    ctx: &mut DetailContexts,
    at: BlockContext,
    q: &mut [i32; COEFFS],
    src: &mut AnsSource,
) -> Result<bool, CodecError> {
    let (kind, nb, cl) = (at.kind, at.neighbours, at.class);
    *q = [0; COEFFS];
    if !src.bin(&mut ctx.coded[kind][cl][nb])? {
        return Ok(false);
    }
    let c = src.symbol(&mut ctx.last[kind][cl][nb])?;
    if c >= LAST_CLASSES {
        return Err(CodecError::range(
            "detail last-position class",
            c as f64,
            0.0,
            (LAST_CLASSES - 1) as f64,
        ));
    }
    let mut last = usize::from(c > 0);
    for model in ctx.last_bits[kind][c].iter_mut().take(c.saturating_sub(1)) {
        last = 2 * last + usize::from(src.bin(model)?);
    }
    let mut map: MagnitudeMap = [0; PAD * PAD];
    for k in (0..=last).rev() {
        let z = ZIGZAG[k] as usize;
        let p = PADDED[k] as usize;
        let b = band(k);
        let (m, negative) = if k == last {
            let t = src.symbol(&mut ctx.first[first_index(kind, b, at.level(k))])?;
            let m = if t == LITERALS {
                read_escape(&mut ctx.class[kind], src)?
            } else {
                t as u32
            } + 1;
            let negative = if k < SIGNED {
                src.bin(&mut ctx.sign[kind][k][at.signs[k] as usize])?
            } else {
                src.raw(1)? == 1
            };
            (m, negative)
        } else if k < SIGNED {
            let t =
                src.symbol(&mut ctx.token[token_index(kind, b, mag_class(&map, p), at.level(k))])?;
            let m = if t == LITERALS {
                read_escape(&mut ctx.class[kind], src)?
            } else {
                t as u32
            };
            (
                m,
                m != 0 && src.bin(&mut ctx.sign[kind][k][at.signs[k] as usize])?,
            )
        } else {
            let mc = mag_class(&map, p);
            let (t, negative) = src.signed_symbol(&mut ctx.token[token_index(kind, b, mc, 0)])?;
            let m = if t == LITERALS {
                read_escape(&mut ctx.class[kind], src)?
            } else {
                t as u32
            };
            (m, negative)
        };
        if m > MAX_LEVEL {
            return Err(CodecError::range(
                "detail coefficient",
                m as f64,
                0.0,
                MAX_LEVEL as f64,
            ));
        }
        map[p] = m.min(3) as u8;
        q[z] = if negative { -(m as i32) } else { m as i32 };
    }
    Ok(true)
}
