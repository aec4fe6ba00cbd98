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

/// Prices blocks exactly as [`write_block`] into a cost counter on a copy of the
/// contexts would, without copying them or writing. The models a block adapts more
/// than once (tokens and escape classes) live in two layers over the contexts: a
/// checkpoint, the state after coding a prefix of the block (its first symbols and its
/// highest coefficients), and the candidate's, on top of it; the others are read once
/// per block, straight from the contexts. A level search moves one coefficient at a
/// time from the highest down, so each candidate shares everything coded before that
/// coefficient with the last and codes only the rest. Each layer's entries are valid
/// where their stamp is the layer's generation, so forgetting a layer is one increment.
#[derive(Clone)]
pub struct BlockPricer {
    token: [[TokenCdf; TOKENS]; 2],
    token_stamp: [[u32; TOKENS]; 2],
    class: [[ClassCdf; 2]; 2],
    class_stamp: [[u32; 2]; 2],
    generation: [u32; 2],
    /// The checkpoint's last position; `None` when there is none.
    cp_last: Option<usize>,
    /// Scan positions `cp_todo..=last` are in the checkpoint.
    cp_todo: usize,
    /// Levels of the checkpoint (row-major; meaningful at the positions it holds).
    cp_levels: [i32; COEFFS],
    cp_map: MagnitudeMap,
    cp_cost: u64,
}

/// The checkpoint's layer and the candidate's.
const CHECKPOINT: usize = 0;
const CANDIDATE: usize = 1;

impl Default for BlockPricer {
    fn default() -> Self {
        let ctx = DetailContexts::default();
        BlockPricer {
            token: [ctx.token; 2],
            token_stamp: [[0; TOKENS]; 2],
            class: [ctx.class; 2],
            class_stamp: [[0; 2]; 2],
            generation: [1; 2],
            cp_last: None,
            cp_todo: 0,
            cp_levels: [0; COEFFS],
            cp_map: [0; PAD * PAD],
            cp_cost: 0,
        }
    }
}

impl BlockPricer {
    /// Prices blocks at `at` on `ctx`; `ctx` cannot change while the returned pricer
    /// lives, so nothing it remembers can go stale.
    pub fn block<'a>(&'a mut self, ctx: &'a DetailContexts, at: BlockContext) -> BlockRates<'a> {
        self.forget(CHECKPOINT);
        self.cp_last = None;
        BlockRates { p: self, ctx, at }
    }

    /// Invalidates every entry of `layer` (and the candidate's, which sits on the
    /// checkpoint).
    fn forget(&mut self, layer: usize) {
        for l in layer..2 {
            self.generation[l] = self.generation[l].wrapping_add(1);
            if self.generation[l] == 0 {
                self.token_stamp[l] = [0; TOKENS];
                self.class_stamp[l] = [0; 2];
                self.generation[l] = 1;
            }
        }
    }

    /// Model `i` of `layer`, brought in from the layer below (or the contexts) on first
    /// use.
    #[inline(always)]
    fn token(&mut self, ctx: &DetailContexts, layer: usize, i: usize) -> &mut TokenCdf {
        if self.token_stamp[layer][i] != self.generation[layer] {
            self.token[layer][i] = if layer == CANDIDATE
                && self.token_stamp[CHECKPOINT][i] == self.generation[CHECKPOINT]
            {
                self.token[CHECKPOINT][i]
            } else {
                ctx.token[i]
            };
            self.token_stamp[layer][i] = self.generation[layer];
        }
        &mut self.token[layer][i]
    }

    #[inline(always)]
    fn class(&mut self, ctx: &DetailContexts, layer: usize, kind: usize) -> &mut ClassCdf {
        if self.class_stamp[layer][kind] != self.generation[layer] {
            self.class[layer][kind] = if layer == CANDIDATE
                && self.class_stamp[CHECKPOINT][kind] == self.generation[CHECKPOINT]
            {
                self.class[CHECKPOINT][kind]
            } else {
                ctx.class[kind]
            };
            self.class_stamp[layer][kind] = self.generation[layer];
        }
        &mut self.class[layer][kind]
    }

    /// Cost of [`write_escape`] of `m`: the class and its raw bits.
    #[inline]
    fn escape(&mut self, ctx: &DetailContexts, layer: usize, kind: usize, m: u32) -> u64 {
        let v = m - LITERALS as u32 + 1;
        let c = 31 - v.leading_zeros();
        let model = self.class(ctx, layer, kind);
        let cost = model.cost(c as usize) as u64;
        model.update(c as usize);
        cost + 256 * c as u64
    }

    /// Cost of coefficient `k` (level `v`) of a block whose last is `last`, adapting
    /// `layer`'s models and `map` as [`write_block`] does.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn coefficient(
        &mut self,
        ctx: &DetailContexts,
        layer: usize,
        at: BlockContext,
        last: usize,
        k: usize,
        v: i32,
        map: &mut MagnitudeMap,
    ) -> u64 {
        let p = PADDED[k] as usize;
        let m = v.unsigned_abs();
        let b = band(k);
        let kind = at.kind;
        // The first models and the sign bins are used once per block, so they are
        // priced straight from the contexts.
        let sign =
            |ctx: &DetailContexts| ctx.sign[kind][k][at.signs[k] as usize].cost(v < 0) as u64;
        let mut cost;
        if k == last {
            let t = ((m - 1) as usize).min(LITERALS);
            cost = ctx.first[first_index(kind, b, at.level(k))].cost(t) as u64;
            cost += if k < SIGNED { sign(ctx) } else { 256 };
            if t == LITERALS {
                cost += self.escape(ctx, layer, kind, m - 1);
            }
        } else if k < SIGNED {
            let t = (m as usize).min(LITERALS);
            let model = self.token(
                ctx,
                layer,
                token_index(kind, b, mag_class(map, p), at.level(k)),
            );
            cost = model.cost(t) as u64;
            model.update(t);
            if t == LITERALS {
                cost += self.escape(ctx, layer, kind, m);
            }
            if m != 0 {
                cost += sign(ctx);
            }
        } else {
            let mc = mag_class(map, p);
            let t = (m as usize).min(LITERALS);
            let model = self.token(ctx, layer, token_index(kind, b, mc, 0));
            cost = model.signed_cost(t, v < 0) as u64;
            model.update(t);
            if t == LITERALS {
                cost += self.escape(ctx, layer, kind, m);
            }
        }
        map[p] = m.min(3) as u8;
        cost
    }
}

/// A [`BlockPricer`] on one block's contexts.
pub struct BlockRates<'a> {
    p: &'a mut BlockPricer,
    ctx: &'a DetailContexts,
    at: BlockContext,
}

impl BlockRates<'_> {
    /// The cost of `q` in 1/256 bits: what [`write_block`] would add to a
    /// [`CostSink`](crate::entropy::CostSink) on a copy of the contexts.
    ///
    /// `keep` is a hint: later candidates will share `q`'s levels at scan positions
    /// `keep..` (until its last changes), so those go into the checkpoint. A wrong
    /// hint costs time, never exactness: the checkpoint is rebuilt whenever `q`
    /// disagrees with it.
    pub fn rate(&mut self, q: &[i32; COEFFS], keep: usize) -> u64 {
        self.rate_within(q, keep, u64::MAX).expect("no limit")
    }

    /// [`BlockRates::rate`], or `None` as soon as the cost is known to exceed `limit`:
    /// a search that only wants candidates cheaper than its best stops pricing the
    /// others part way.
    pub fn rate_within(&mut self, q: &[i32; COEFFS], keep: usize, limit: u64) -> Option<u64> {
        let (ctx, at) = (self.ctx, self.at);
        let (kind, nb, cl) = (at.kind, at.neighbours, at.class);
        let p = &mut *self.p;
        let Some(last) = (0..COEFFS).rev().find(|&k| q[ZIGZAG[k] as usize] != 0) else {
            let cost = ctx.coded[kind][cl][nb].cost(false) as u64;
            return (cost <= limit).then_some(cost);
        };
        let held = p.cp_last == Some(last)
            && (p.cp_todo..=last).all(|k| {
                let z = ZIGZAG[k] as usize;
                q[z] == p.cp_levels[z]
            });
        if !held {
            p.forget(CHECKPOINT);
            let c = last_class(last);
            p.cp_cost = ctx.coded[kind][cl][nb].cost(true) as u64
                + ctx.last[kind][cl][nb].cost(c) as u64
                + ctx.last_bits[kind][c]
                    .iter()
                    .take(c.saturating_sub(1))
                    .enumerate()
                    .map(|(i, m)| m.cost((last >> (c - 2 - i)) & 1 == 1) as u64)
                    .sum::<u64>();
            p.cp_last = Some(last);
            p.cp_todo = last + 1;
            p.cp_map = [0; PAD * PAD];
        }
        if keep < p.cp_todo {
            let mut map = p.cp_map;
            for k in (keep..p.cp_todo).rev() {
                let z = ZIGZAG[k] as usize;
                p.cp_cost += p.coefficient(ctx, CHECKPOINT, at, last, k, q[z], &mut map);
                p.cp_levels[z] = q[z];
            }
            p.cp_map = map;
            p.cp_todo = keep;
        }
        p.forget(CANDIDATE);
        let mut map = p.cp_map;
        let mut cost = p.cp_cost;
        for k in (0..p.cp_todo).rev() {
            if cost > limit {
                return None;
            }
            cost += p.coefficient(ctx, CANDIDATE, at, last, k, q[ZIGZAG[k] as usize], &mut map);
        }
        (cost <= limit).then_some(cost)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entropy::{valid_cdf, AnsSink, CostSink, OverlayCostSink};

    /// Every anchor holds one valid start per model, in the models' order, and the
    /// anchors' steps rise.
    #[test]
    fn the_trained_tables_hold_a_valid_start_for_every_model() {
        let plain = DetailContexts::default().models();
        assert_eq!(plain.iter().map(|(p, _)| p.len()).sum::<usize>(), STATE_LEN);
        assert!(ANCHOR_STEPS.windows(2).all(|w| w[0] < w[1]));
        for table in ANCHORS.iter() {
            let mut at = 0;
            for (p, _) in &plain {
                let part = &table[at..at + p.len()];
                if p.len() == 1 {
                    assert!(
                        (64..=65536 - 64).contains(&(part[0] as u32)),
                        "a binary model's P(0) within its limits"
                    );
                } else {
                    assert!(valid_cdf(part), "a trained distribution keeps the floor");
                }
                at += p.len();
            }
        }
    }

    /// At an anchor's step the contexts start from that anchor's table; between two
    /// anchors from their mix, each entry between the two; past the ends from the
    /// nearest; and every model as if it had seen the trained count.
    #[test]
    fn contexts_start_from_the_anchors_mixed_by_the_step() {
        let flat = |c: &DetailContexts| -> Vec<u16> {
            c.models().into_iter().flat_map(|(p, _)| p).collect()
        };
        for (k, &s) in ANCHOR_STEPS.iter().enumerate() {
            assert_eq!(
                flat(&DetailContexts::for_step(s as f64)),
                ANCHORS[k].to_vec()
            );
        }
        let last = ANCHOR_STEPS.len() - 1;
        assert_eq!(flat(&DetailContexts::for_step(1e-6)), ANCHORS[0].to_vec());
        assert_eq!(
            flat(&DetailContexts::for_step(100.0)),
            ANCHORS[last].to_vec()
        );
        let (lo, hi) = (ANCHOR_STEPS[1] as f64, ANCHOR_STEPS[2] as f64);
        let mid = flat(&DetailContexts::for_step((lo + hi) / 2.0));
        for ((&m, &a), &b) in mid.iter().zip(&ANCHORS[1]).zip(&ANCHORS[2]) {
            assert_eq!(m as u32, (a as u32 + b as u32) / 2, "halfway is the mean");
        }
        assert!(DetailContexts::for_step(lo)
            .models()
            .iter()
            .all(|(_, seen)| *seen == TRAINED_SEEN as u32));
    }

    #[test]
    fn overlay_pricing_equals_pricing_a_copy_and_leaves_the_contexts_alone() {
        let mut ctx = DetailContexts::default();
        let mut overlay = OverlayCostSink::default();
        let mut sink = AnsSink::new();
        let mut seed = 12345u64;
        for i in 0..400 {
            let mut q = [0i32; COEFFS];
            // Sparse, mostly small levels with occasional escapes, as the quantiser makes.
            for (k, v) in q.iter_mut().enumerate() {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (seed >> 33) as u32;
                if r.is_multiple_of(2 + k as u32 / 4) {
                    let m = if r.is_multiple_of(97) {
                        (r >> 8) % 5000
                    } else {
                        (r >> 8) % 4
                    };
                    *v = if r & 1 == 1 { -(m as i32) } else { m as i32 };
                }
            }
            let at = BlockContext::varied(i);
            let mut copy = CostSink::default();
            write_block(&mut ctx.clone(), at, &q, &mut copy);
            let before = ctx.clone();
            overlay.reset();
            write_block(&mut ctx, at, &q, &mut overlay);
            assert!(ctx == before, "block {i}: pricing changed the contexts");
            assert_eq!(overlay.cost, copy.cost, "block {i}");
            write_block(&mut ctx, at, &q, &mut sink);
        }
    }

    #[test]
    fn the_block_pricer_equals_pricing_a_copy_within_limits_or_not() {
        let mut ctx = DetailContexts::default();
        let mut pricer = BlockPricer::default();
        let mut sink = AnsSink::new();
        let mut seed = 777u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        for i in 0..300 {
            let mut q = [0i32; COEFFS];
            for (k, v) in q.iter_mut().enumerate() {
                let r = next();
                if r.is_multiple_of(2 + k as u32 / 4) {
                    let m = if r.is_multiple_of(53) {
                        (r >> 8) % 5000
                    } else {
                        (r >> 8) % 4
                    };
                    *v = if r & 1 == 1 { -(m as i32) } else { m as i32 };
                }
            }
            let at = BlockContext::varied(i);
            // Candidates as the quantiser makes them (one level moved at a time, from
            // the highest position down, with good and bad hints), trims and the empty
            // block.
            let mut candidates = vec![(q, COEFFS)];
            let mut cur = q;
            for k in (0..COEFFS).rev() {
                let z = ZIGZAG[k] as usize;
                let r = next();
                if r.is_multiple_of(3) {
                    continue;
                }
                let mut trial = cur;
                trial[z] += [-1, 1, 20, -300][r as usize / 3 % 4];
                let keep = if r.is_multiple_of(7) {
                    next() as usize % (COEFFS + 1)
                } else {
                    k + 1
                };
                candidates.push((trial, keep));
                if r.is_multiple_of(2) {
                    cur = trial;
                }
            }
            let mut trimmed = cur;
            for k in (0..COEFFS)
                .rev()
                .filter(|&k| cur[ZIGZAG[k] as usize] != 0)
                .take(4)
            {
                trimmed[ZIGZAG[k] as usize] = 0;
                candidates.push((trimmed, COEFFS));
            }
            candidates.push(([0; COEFFS], COEFFS));
            let expected: Vec<u64> = candidates
                .iter()
                .map(|(c, _)| {
                    let mut copy = CostSink::default();
                    write_block(&mut ctx.clone(), at, c, &mut copy);
                    copy.cost
                })
                .collect();
            let mut rates = pricer.block(&ctx, at);
            for (j, ((c, keep), e)) in candidates.iter().zip(&expected).enumerate() {
                // A priced limit answers at its edge, and a call stopped part way
                // leaves nothing behind that changes the next price.
                match next() % 3 {
                    0 => assert_eq!(
                        rates.rate_within(c, *keep, e - 1),
                        None,
                        "block {i} candidate {j} over"
                    ),
                    1 => assert_eq!(
                        rates.rate_within(c, *keep, *e),
                        Some(*e),
                        "block {i} candidate {j} at"
                    ),
                    _ => {}
                }
                assert_eq!(rates.rate(c, *keep), *e, "block {i} candidate {j}");
            }
            write_block(&mut ctx, at, &cur, &mut sink);
        }
    }

    #[test]
    fn a_block_context_holds_its_neighbours_signs_and_sizes_at_the_low_positions() {
        let at = |k: usize| ZIGZAG[k] as usize;
        let mut left = [0i32; COEFFS];
        (left[0], left[at(1)], left[at(9)], left[at(10)]) = (-5, 1, -2, 7);
        let mut above = [0i32; COEFFS];
        (above[0], above[at(1)]) = (3, 2);
        let (l, a) = (Summary::of(&left), Summary::of(&above));
        assert_eq!(
            (l.reach, a.reach),
            (1 + 4, 1 + 1),
            "one more than the last's bit length"
        );
        assert_eq!(
            (l.signs[0], l.signs[1], l.signs[2], l.signs[9]),
            (2, 1, 0, 2)
        );
        assert_eq!(
            (l.levels[0], l.levels[1], l.levels[9]),
            (2, 1, 2),
            "sizes capped at 2"
        );
        let c = BlockContext::new(1, 2, l, a);
        assert_eq!((c.kind, c.class, c.neighbours), (1, 2, 4));
        assert_eq!(c.signs[0], 3 * 2 + 1, "left negative, above positive");
        assert_eq!(c.signs[1], 3 + 1);
        assert_eq!(c.signs[9], 3 * 2);
        assert_eq!(c.signs[2], 0);
        assert_eq!(
            (c.level(0), c.level(1), c.level(2), c.level(9)),
            (2, 2, 0, 1)
        );
        assert_eq!(
            c.level(10),
            0,
            "position 10 is past the contexts, whatever is there"
        );
        let none = BlockContext::new(0, 0, Summary::default(), Summary::default());
        assert_eq!(
            (none.neighbours, none.signs, none.levels),
            (0, [0; SIGNED], [0; SIGNED])
        );
    }

    #[test]
    fn initial_tables_are_valid_cdfs() {
        for (m, r) in [(8, 0.8), (16, 0.2), (16, 0.8), (24, 0.7)] {
            let f = geometric(m, r);
            assert_eq!(f.len(), m);
            assert!(f[0] >= CDF_FLOOR);
            for w in f.windows(2) {
                assert!(w[1] >= w[0] + CDF_FLOOR);
            }
            assert!(*f.last().unwrap() <= CDF_ONE - CDF_FLOOR);
        }
    }

    #[test]
    fn blocks_round_trip() {
        let mut blocks = vec![[0i32; COEFFS]; 6];
        blocks[1][0] = 3;
        blocks[2][63] = -1;
        blocks[2][5] = 40_000;
        blocks[3][ZIGZAG[1] as usize] = -17;
        blocks[3][ZIGZAG[2] as usize] = 1;
        for (i, v) in blocks[4].iter_mut().enumerate() {
            *v = (i as i32 % 7) - 3;
        }
        blocks[5][0] = -(MAX_LEVEL as i32);
        let mut ctx = DetailContexts::default();
        let mut sink = AnsSink::new();
        for (i, b) in blocks.iter().enumerate() {
            let at = BlockContext::varied(i);
            write_block(&mut ctx, at, b, &mut sink);
        }
        let bytes = sink.finish();
        let mut src = AnsSource::new(&bytes, 10_000).unwrap();
        let mut ctx = DetailContexts::default();
        for (i, b) in blocks.iter().enumerate() {
            let at = BlockContext::varied(i);
            let mut q = [0; COEFFS];
            let coded = read_block(&mut ctx, at, &mut q, &mut src).unwrap();
            assert_eq!(coded, b.iter().any(|&v| v != 0));
            assert_eq!(&q, b);
        }
        assert!(src.finished_cleanly());
    }
}
