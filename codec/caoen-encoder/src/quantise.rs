//! The encoder's side of the detail layer: transform the network's residual block by
//! block, quantise it and choose each block's coefficients by rate and distortion.
//!
//! Blocks are decided in coding order with the coder's own adaptive contexts: each
//! candidate (the dead-zone levels, each level moved a step where that pays, the same
//! with its last nonzero coefficients dropped, and the empty block) is priced by a
//! [`BlockPricer`] (the cost on a copy of the contexts, coding only what differs from
//! the candidates before it), and the one with the least `D + lambda R` is coded.

use rayon::prelude::*;

use caoen_decoder::detail::dct::{self, COEFFS, N, ZIGZAG};
use caoen_decoder::detail::field::ActivityField;
use caoen_decoder::detail::syntax::{
    self, BlockContext, BlockPricer, DetailContexts, GroupContext, Summary, GROUP_LEVELS,
};
use caoen_decoder::detail::weights::{self, FrequencyWeights};
use caoen_decoder::detail::{
    blocks, factor_context, group_start, luma_predicts, Detail, DetailPlane, Visit, Walk,
};
use caoen_decoder::entropy::{CostSink, SymbolSink};

/// Quantiser of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantiser {
    /// Step of every coefficient (of its weighted value, with frequency weights).
    pub step: f64,
    /// Dead zone: magnitudes round down unless their fraction exceeds `0.5 + deadzone`.
    pub deadzone: f64,
    /// Lagrange multiplier in squared steps per bit.
    pub lambda: f64,
    /// Search each coefficient's level (one step either way) by rate and distortion,
    /// not only the block's trailing coefficients.
    pub per_coefficient: bool,
}

/// Most trailing coefficients the search tries dropping: the photographs' curves are
/// the same to 0.02% with 2 as with 4, and to 0.1 point with 8
/// (`docs/codec-ablation.md`).
const TRIMS: usize = 2;

/// Level of coefficient `c` under `q`.
#[inline]
fn level(c: f64, q: Quantiser) -> i32 {
    // Truncation is the floor wherever the level is above zero, and unlike `floor` it
    // is an instruction, not a call, on baseline x86-64 (the search's inner loop).
    let m =
        ((c.abs() / q.step + 0.5 - q.deadzone) as i64).clamp(0, syntax::MAX_LEVEL as i64) as i32;
    m * if c < 0.0 { -1 } else { 1 }
}

/// Block `(bx, by)` of a `width x height` plane, pixels past the image edge repeating
/// the last row or column (so the edge does not look like a step to the transform).
fn gather(plane: &[f64], width: usize, height: usize, bx: usize, by: usize) -> [f64; COEFFS] {
    let mut b = [0.0; COEFFS];
    for y in 0..N {
        let py = (by * N + y).min(height - 1);
        for x in 0..N {
            let px = (bx * N + x).min(width - 1);
            b[y * N + x] = plane[py * width + px];
        }
    }
    b
}

/// The level-`g` group whose top-left block is `(bx, by)` (`8 2^g` pixels square,
/// row-major), edges repeated as [`gather`]'s.
fn gather_group(
    plane: &[f64],
    width: usize,
    height: usize,
    bx: usize,
    by: usize,
    g: usize,
) -> Vec<f64> {
    let n = N << g;
    (0..n * n)
        .map(|i| {
            let py = (by * N + i / n).min(height - 1);
            let px = (bx * N + i % n).min(width - 1);
            plane[py * width + px]
        })
        .collect()
}

/// Squared error of `levels` against the coefficients in steps, `x`; summed in one
/// fixed order, so every candidate's distortion is the same number wherever it is
/// computed.
fn distortion(x: &[f64; COEFFS], levels: &[i32; COEFFS]) -> f64 {
    x.iter()
        .zip(levels)
        .map(|(&x, &l)| (x - l as f64).powi(2))
        .sum()
}

/// The squared error (in steps) no levels can go below on coefficients `c`: each
/// coefficient's distance to the nearest whole step. Term by term no larger than
/// [`distortion`]'s and summed in the same order, so never above it in floating point.
fn unavoidable_error(c: &[f64; COEFFS], q: Quantiser) -> f64 {
    c.iter()
        .map(|&c| {
            // The distances to the whole steps either side, both exact in floating
            // point (from 2^52 up every float is whole).
            let x = (c / q.step).abs();
            if x < (1u64 << 52) as f64 {
                let below = x - (x as u64) as f64;
                below.min(1.0 - below).powi(2)
            } else {
                0.0
            }
        })
        .sum()
}

/// The most bits (1/256) a level of one moved to zero saves in the level search's
/// moves: the full search on the photographs at qualities 30 and 75 never took such a
/// move that saved more than 16 bits (it drops a sign and a token and can quieten the
/// neighbours' contexts), so moves whose added error needs more are not priced.
const MOST_SAVED_TO_ZERO: u64 = 19 * 256;

/// The same for a larger level moved a step towards zero, which changes its own token
/// or escape and, below 4, the neighbours' magnitude classes: never more than 12 bits
/// measured.
const MOST_SAVED: u64 = 14 * 256;

/// The moves the level search tries at coefficient `z` (level `l`, coefficient `x` in
/// steps) under multiplier `lambda`, in order: a step towards zero where the bits it
/// could save can pay for its added error, then a step away from zero where rounding
/// fell short by more than half a step.
fn moves(l: i32, x: f64, lambda: f64) -> [Option<i32>; 2] {
    let mut candidates = [None, None];
    let e = x.abs() - l.unsigned_abs() as f64;
    if l != 0 {
        let most = if l.abs() == 1 {
            MOST_SAVED_TO_ZERO
        } else {
            MOST_SAVED
        };
        if 2.0 * e + 1.0 <= lambda * most as f64 / 256.0 {
            candidates[0] = Some(l - l.signum());
        }
    }
    if e > 0.5 && l.unsigned_abs() < syntax::MAX_LEVEL {
        candidates[1] = Some(l + if x < 0.0 { -1 } else { 1 });
    }
    candidates
}

/// Chooses one block's levels by `D + lambda R` with the coder's contexts: the
/// dead-zone levels; with [`Quantiser::per_coefficient`], each coded coefficient from
/// the last back to the first moved one step towards zero, or away from it, when that
/// lowers the block's cost (the rate of a level depends on its neighbours' through the
/// contexts, so a level that rounds nearest can still cost more than it saves); then
/// up to [`TRIMS`] trailing coefficients dropped, and the empty block. The levels come
/// with their distortion and rate, so their cost needs no second pricing.
///
/// A moved candidate's distortion is first estimated from the current best's by the
/// one term that changed; only when that leaves the comparison within a margin far
/// above the rounding error is it summed in full, so the choices are those of summing
/// every candidate ([`reference::choose`] is tested equal). A candidate whose price
/// passes what would let it beat the best so far is not priced to the end.
fn choose(
    c: &[f64; COEFFS],
    q: Quantiser,
    ctx: &DetailContexts,
    at: syntax::BlockContext,
    pricer: &mut BlockPricer,
) -> Chosen {
    let levels: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
    let x: [f64; COEFFS] = std::array::from_fn(|z| c[z] / q.step);
    let mut rates = pricer.block(ctx, at);
    if levels.iter().all(|&l| l == 0) {
        return Chosen {
            levels,
            distortion: distortion(&x, &levels),
            rate: rates.rate(&levels, COEFFS),
        };
    }
    let cost = |d: f64, r: u64| d + q.lambda * r as f64 / 256.0;
    // The most bits (1/256) a candidate of squared error `d` can cost and still be
    // below `j`: two units and a relative 4e-9 above it, so that a candidate priced
    // past the limit is one the comparisons below would have rejected too.
    let limit = |j: f64, d: f64| -> u64 {
        if q.lambda <= 0.0 {
            return u64::MAX;
        }
        let room = j * (1.0 + 4e-9) / (1.0 - 4e-9) - d;
        if room < 0.0 {
            0
        } else {
            (room * 256.0 / q.lambda).floor().min(1e18) as u64 + 2
        }
    };
    let mut d = distortion(&x, &levels);
    let r = rates.rate(&levels, COEFFS);
    let mut best = (cost(d, r), levels);
    let mut best_dr = (d, r);
    if q.per_coefficient {
        for k in (0..COEFFS).rev() {
            let z = ZIGZAG[k] as usize;
            let l = best.1[z];
            for m in moves(l, x[z], q.lambda).into_iter().flatten() {
                let mut trial = best.1;
                trial[z] = m;
                let d_trial = d - (x[z] - l as f64).powi(2) + (x[z] - m as f64).powi(2);
                let Some(r) = rates.rate_within(&trial, k + 1, limit(best.0, d_trial)) else {
                    continue;
                };
                let estimate = cost(d_trial, r);
                let margin = 1e-9 * (best.0.abs() + estimate.abs());
                let better = if estimate < best.0 - margin {
                    true
                } else if estimate > best.0 + margin {
                    false
                } else {
                    cost(distortion(&x, &trial), r) < best.0
                };
                if better {
                    d = distortion(&x, &trial);
                    best = (cost(d, r), trial);
                    best_dr = (d, r);
                    break;
                }
            }
        }
    }
    let mut trimmed = best.1;
    // A candidate ending elsewhere shares no prefix with the last: priced in full,
    // kept if cheaper.
    let mut offer = |levels: [i32; COEFFS]| {
        let d = distortion(&x, &levels);
        if let Some(r) = rates.rate_within(&levels, COEFFS, limit(best.0, d)) {
            let j = cost(d, r);
            if j < best.0 {
                best = (j, levels);
                best_dr = (d, r);
            }
        }
    };
    let mut tries = 0;
    for k in (0..COEFFS).rev() {
        let z = ZIGZAG[k] as usize;
        if trimmed[z] == 0 {
            continue;
        }
        if tries == TRIMS {
            break;
        }
        tries += 1;
        trimmed[z] = 0;
        offer(trimmed);
    }
    // The loop stops at the empty block only when there were few enough.
    offer([0; COEFFS]);
    Chosen {
        levels: best.1,
        distortion: best_dr.0,
        rate: best_dr.1,
    }
}

/// A block's chosen levels with their squared error (in steps) and their rate (1/256
/// bits) on the contexts they were chosen on.
struct Chosen {
    levels: [i32; COEFFS],
    distortion: f64,
    rate: u64,
}

impl Chosen {
    /// `D + lambda R` with `extra` more bits (1/256) and `dropped` more squared error
    /// aside: the same number [`block_cost`] computes by pricing the levels again.
    fn cost(&self, q: Quantiser, extra: u64, dropped: f64) -> f64 {
        self.distortion + dropped + q.lambda * (self.rate + extra) as f64 / 256.0
    }
}

/// `D + lambda R` of coding coefficients `c` as `levels` at `at`, `extra` more bits
/// (1/256) and `dropped` more squared error (in steps) aside.
#[allow(clippy::too_many_arguments)]
fn block_cost(
    c: &[f64; COEFFS],
    levels: &[i32; COEFFS],
    q: Quantiser,
    ctx: &DetailContexts,
    at: BlockContext,
    pricer: &mut BlockPricer,
    extra: u64,
    dropped: f64,
) -> f64 {
    let x: [f64; COEFFS] = std::array::from_fn(|z| c[z] / q.step);
    let r = pricer.block(ctx, at).rate(levels, COEFFS) + extra;
    distortion(&x, levels) + dropped + q.lambda * r as f64 / 256.0
}

/// A group's transform: the lowest 8x8 coefficients and the energy of the rest.
type GroupTransform = ([f64; COEFFS], f64);

/// A group's choice: its `D + lambda R` (merge bins included), the level of the
/// merged group its first block starts (0: coded apart), and that block's levels.
type GroupChoice = (f64, usize, [i32; COEFFS]);

/// What a group's choice needs of the plane: the blocks' coefficients, the groups'
/// transforms (by block, for the group starts), the quantiser and the contexts.
#[derive(Clone, Copy)]
struct Plane<'a> {
    coeffs: &'a [[f64; COEFFS]],
    transforms: &'a [Option<[Option<GroupTransform>; GROUP_LEVELS]>],
    cols: usize,
    q: Quantiser,
    ctx: &'a DetailContexts,
}

impl Plane<'_> {
    /// The merged option of the level-`g` group at block `i`, searched when first
    /// asked for.
    fn merged(&self, i: usize, g: GroupContext, at: BlockContext) -> MergedOption<'_> {
        let (low, high) = self.transforms[i]
            .as_ref()
            .and_then(|t| t[g.level - 1].as_ref())
            .expect("a group start has its transforms");
        let dropped = high / (self.q.step * self.q.step);
        MergedOption {
            plane: self,
            low,
            dropped,
            bound: unavoidable_error(low, self.q) + dropped,
            g,
            at,
            found: None,
        }
    }

    /// Chooses between merging the 2x2 group at block `i` and coding its blocks apart,
    /// by `D + lambda R`. The first block is priced exactly; the other three on the
    /// contexts as they are, their neighbours' summaries from the candidates and from
    /// `left` (the lower left block's left neighbour, whose row is not coded yet: the
    /// first block's stands in) and `above` (the upper right block's).
    fn pair(
        &self,
        i: usize,
        g: GroupContext,
        at: BlockContext,
        (left, above): (Summary, Summary),
        pricer: &mut BlockPricer,
    ) -> GroupChoice {
        let (q, ctx, cols) = (self.q, self.ctx, self.cols);
        let blocks = [i, i + 1, i + cols, i + cols + 1].map(|k| &self.coeffs[k]);
        let first = choose(blocks[0], q, ctx, at, pricer);
        // The blocks coded later are priced without the level search: their contexts
        // are estimates anyway, and the search would double the group's time.
        let estimate = Quantiser {
            per_coefficient: false,
            ..q
        };
        let mut j_apart = first.cost(q, syntax::merge_cost(ctx, g, false), 0.0);
        let first = first.levels;
        let s0 = Summary::of(&first);
        let context = |l, a| BlockContext::new(at.kind, at.class, l, a);
        let mut others = [[0; COEFFS]; 3];
        let mut merged = self.merged(i, g, at);
        for k in 0..3 {
            if let Some((j_merged, m)) = merged.beats(j_apart, pricer) {
                return (j_merged, 1, m);
            }
            let at = match k {
                0 => context(s0, above),
                1 => context(left, s0),
                _ => context(Summary::of(&others[1]), Summary::of(&others[0])),
            };
            let other = choose(blocks[k + 1], estimate, ctx, at, pricer);
            j_apart += other.cost(q, 0, 0.0);
            others[k] = other.levels;
        }
        match merged.beats(j_apart, pricer) {
            Some((j_merged, m)) => (j_merged, 1, m),
            None => (j_apart, 0, first),
        }
    }

    /// Chooses for the groups starting at block `i` (`starts`, by level less one): the
    /// 4x4 group merged, or its four 2x2 groups each chosen by [`Plane::pair`] (the
    /// first exactly, the others on the contexts as they are, with the candidates'
    /// summaries as neighbours).
    fn choose(
        &self,
        i: usize,
        starts: [Option<GroupContext>; GROUP_LEVELS],
        at: BlockContext,
        summaries: &[Summary],
        pricer: &mut BlockPricer,
    ) -> GroupChoice {
        let cols = self.cols;
        let summary = |k: usize| summaries.get(k).copied().unwrap_or_default();
        let left = if i.is_multiple_of(cols) {
            Summary::default()
        } else {
            summary(i - 1)
        };
        let above = |k: usize| {
            if k >= cols {
                summary(k - cols)
            } else {
                Summary::default()
            }
        };
        let g1 = starts[0].expect("a 4x4 group start is a 2x2 one");
        let first = self.pair(i, g1, at, (left, above(i + 1)), pricer);
        let Some(g2) = starts[1] else {
            return first;
        };
        // The later 2x2 groups are estimates: priced without the level search.
        let estimates = Plane {
            q: Quantiser {
                per_coefficient: false,
                ..self.q
            },
            ..*self
        };
        let mut j_apart =
            first.0 + self.q.lambda * syntax::merge_cost(self.ctx, g2, false) as f64 / 256.0;
        let s0 = Summary::of(&first.2);
        let context = |l, a| BlockContext::new(at.kind, at.class, l, a);
        let mut subs = [s0; 3];
        let mut merged = [first.1 != 0, false, false, false];
        let mut whole = self.merged(i, g2, at);
        for k in 0..3 {
            if let Some((j_merged, m)) = whole.beats(j_apart, pricer) {
                return (j_merged, 2, m);
            }
            let j = [i + 2, i + 2 * cols, i + 2 * cols + 2][k];
            let (at, nb) = match k {
                0 => (context(s0, above(j)), (s0, above(j + 1))),
                1 => (context(left, s0), (left, s0)),
                _ => (context(subs[1], subs[0]), (subs[1], subs[0])),
            };
            let around = match k {
                0 => [merged[0], false],
                1 => [false, merged[0]],
                _ => [merged[2], merged[1]],
            };
            let g = GroupContext {
                merged: usize::from(around[0]) + usize::from(around[1]),
                ..g1
            };
            let sub = estimates.pair(j, g, at, nb, pricer);
            subs[k] = Summary::of(&sub.2);
            merged[k + 1] = sub.1 != 0;
            j_apart += sub.0;
        }
        match whole.beats(j_apart, pricer) {
            Some((j_merged, m)) => (j_merged, 2, m),
            None => (j_apart, first.1, first.2),
        }
    }
}

/// A group's merged option, its level search run only once the blocks coded apart
/// might cost more than it: coding apart costs at least what its blocks chosen so far
/// cost, so a search that could not beat that is skipped, and one that already beats
/// it ends the choice before the remaining blocks are searched. Either way the choice
/// is the one a full comparison makes.
struct MergedOption<'a> {
    plane: &'a Plane<'a>,
    low: &'a [f64; COEFFS],
    /// Squared error of the frequencies the group drops, in steps.
    dropped: f64,
    /// A cost the search cannot go below: the error no levels avoid (see
    /// [`unavoidable_error`]) and the dropped frequencies'.
    bound: f64,
    g: GroupContext,
    at: BlockContext,
    /// The search's cost (merge bin included) and levels, once run.
    found: Option<(f64, [i32; COEFFS])>,
}

impl MergedOption<'_> {
    /// The merged group's cost and levels if they cost less than `apart`, the cost of
    /// coding the group apart or a part of it.
    fn beats(&mut self, apart: f64, pricer: &mut BlockPricer) -> Option<(f64, [i32; COEFFS])> {
        if self.bound >= apart {
            return None;
        }
        let p = self.plane;
        let found = *self.found.get_or_insert_with(|| {
            let m = choose(self.low, p.q, p.ctx, self.at, pricer);
            (
                m.cost(p.q, syntax::merge_cost(p.ctx, self.g, true), self.dropped),
                m.levels,
            )
        });
        (found.0 < apart).then_some(found)
    }
}

/// What a plane's blocks bring besides their residual, per block: the cell-size class
/// (a context) and, if the steps adapt, the step factor.
#[derive(Debug, Clone, Copy)]
pub struct PlaneBlocks<'a> {
    /// Cell-size classes.
    pub classes: &'a [u8],
    /// Step factors.
    pub factors: Option<&'a [f64]>,
    /// The steps' tilt with frequency.
    pub weights: Option<FrequencyWeights>,
}

/// The luma plane a chroma plane's blocks may add a factor of: its levels, its step,
/// and the chroma plane's index (0: C1).
#[derive(Debug, Clone, Copy)]
pub struct LumaReference<'a> {
    /// The coded luma plane.
    pub plane: &'a DetailPlane,
    /// Its step.
    pub step: f64,
    /// The chroma plane's index among the chroma planes.
    pub chroma: usize,
}

/// The luma factors a chroma block tries besides none: the least-squares fit of its
/// weighted coefficients `c` on the luma block's `l` (in eighths) and half of that.
fn factor_candidates(c: &[f64; COEFFS], l: &[f64; COEFFS]) -> [i32; 2] {
    let num: f64 = c.iter().zip(l).map(|(c, l)| c * l).sum();
    let den: f64 = l.iter().map(|l| l * l).sum();
    let limit = syntax::FACTOR_LIMIT as f64;
    let a = if den > 0.0 {
        (8.0 * num / den).round().clamp(-limit, limit) as i32
    } else {
        0
    };
    [a, a / 2]
}

/// Transforms, quantises and codes one residual plane (`kind` 0 luma, 1 chroma) into
/// `sink` with the stream's contexts; returns the coded levels. A chroma plane with a
/// luma reference gives blocks a luma factor where that pays.
#[allow(clippy::too_many_arguments)]
pub fn code_plane(
    residual: &[f64],
    (width, height): (u32, u32),
    q: Quantiser,
    kind: usize,
    blocks_of: PlaneBlocks,
    luma: Option<LumaReference>,
    ctx: &mut DetailContexts,
    sink: &mut impl SymbolSink,
) -> DetailPlane {
    let (cols, rows) = blocks(width, height);
    let (w, h) = (width as usize, height as usize);
    // Coefficients are quantised divided by their weights, so the levels and their
    // distortion are in weighted steps.
    let weights = blocks_of.weights.map_or(weights::FLAT, |wt| wt.table(kind));
    let weighted = |c: [f64; COEFFS], g: usize| -> [f64; COEFFS] {
        std::array::from_fn(|z| c[z] / weights[g][z])
    };
    let coeffs: Vec<[f64; COEFFS]> = (0..cols * rows)
        .into_par_iter()
        .map(|i| weighted(dct::forward(&gather(residual, w, h, i % cols, i / cols)), 0))
        .collect();
    let transforms: Vec<Option<[Option<GroupTransform>; GROUP_LEVELS]>> = (0..cols * rows)
        .into_par_iter()
        .map(|i| {
            group_start(blocks_of.classes, cols, rows, i, 1, kind).then(|| {
                std::array::from_fn(|k| {
                    let g = k + 1;
                    group_start(blocks_of.classes, cols, rows, i, g, kind).then(|| {
                        let (low, high) = dct::forward_group(
                            &gather_group(residual, w, h, i % cols, i / cols, g),
                            g,
                        );
                        (weighted(low, g), high)
                    })
                })
            })
        })
        .collect();
    let mut chosen = Vec::with_capacity(cols * rows);
    let mut walk = Walk::new(blocks_of.classes, cols, rows, kind);
    let mut pricer = BlockPricer::default();
    let luma_weights = blocks_of.weights.map_or(weights::FLAT, |wt| wt.table(0));
    let mut factors = vec![0i8; if luma.is_some() { cols * rows } else { 0 }];
    for (i, c) in coeffs.iter().enumerate() {
        let f = blocks_of.factors.map_or(1.0, |f| f[i]);
        let q = Quantiser {
            step: q.step * f,
            ..q
        };
        let mut merged = false;
        // A block chosen alone keeps its price for the luma factors' comparison.
        let (at, mut best, priced) = match walk.visit() {
            Visit::Covered => {
                chosen.push([0; COEFFS]);
                continue;
            }
            Visit::Group(starts, at) => {
                let plane = Plane {
                    coeffs: &coeffs,
                    transforms: &transforms,
                    cols,
                    q,
                    ctx,
                };
                let (_, level, best) = plane.choose(i, starts, at, walk.summaries(), &mut pricer);
                for (k, start) in starts.iter().enumerate().rev() {
                    if let Some(g) = start {
                        syntax::write_merge(ctx, *g, level == k + 1, sink);
                        if level == k + 1 {
                            walk.merge(level);
                            break;
                        }
                    }
                }
                merged = level != 0;
                (at, best, None)
            }
            Visit::Block(at) => {
                let chosen = choose(c, q, ctx, at, &mut pricer);
                (at, chosen.levels, Some(chosen))
            }
        };
        if let Some(l) = luma.filter(|l| !merged && luma_predicts(l.plane, i)) {
            // The luma block's dequantised coefficients in this plane's weighted units.
            let lc = l
                .plane
                .coefficients(i % cols, i / cols, l.step * f, &luma_weights)
                .expect("a predicting luma block is coded");
            let lw: [f64; COEFFS] = std::array::from_fn(|z| lc[z] / weights[0][z]);
            let fc = factor_context(&factors, cols, i, l.chroma);
            let none = syntax::factor_cost(ctx, fc, 0);
            let mut j_best = match &priced {
                Some(chosen) => chosen.cost(q, none, 0.0),
                None => block_cost(c, &best, q, ctx, at, &mut pricer, none, 0.0),
            };
            let mut a_best = 0;
            for a in factor_candidates(c, &lw).into_iter().filter(|&a| a != 0) {
                let x: [f64; COEFFS] = std::array::from_fn(|z| c[z] - a as f64 / 8.0 * lw[z]);
                let chosen = choose(&x, q, ctx, at, &mut pricer);
                let j = chosen.cost(q, syntax::factor_cost(ctx, fc, a), 0.0);
                if j < j_best {
                    (j_best, a_best, best) = (j, a, chosen.levels);
                }
            }
            syntax::write_factor(ctx, fc, a_best, sink);
            factors[i] = a_best as i8;
        }
        syntax::write_block(ctx, at, &best, sink);
        walk.done(&best);
        chosen.push(best);
    }
    let plane = DetailPlane::from_groups(cols, rows, chosen, walk.into_merged());
    if luma.is_some() {
        plane.with_factors(factors)
    } else {
        plane
    }
}

/// The detail layer of the colour channels' residuals (Y, or Y, C1, C2), one quantiser
/// per channel, its blocks of cell-size classes `classes` (and step factors, if the
/// steps adapt: the activity field's, if any, included), the steps' tilt with
/// frequency, if any, and its section payload (the activity field `field` coded first).
pub fn code_layer(
    residuals: &[Vec<f64>],
    size: (u32, u32),
    q: &[Quantiser],
    classes: &[u8],
    factors: Option<&[f64]>,
    weights: Option<FrequencyWeights>,
    field: Option<&ActivityField>,
) -> (Detail, Vec<u8>) {
    let blocks_of = PlaneBlocks {
        classes,
        factors,
        weights,
    };
    // The search prices symbols with each stream's contexts; the field's bits are
    // settled after it (regions without a coded block cost least), so the payload is
    // written from the chosen levels.
    let start = DetailContexts::for_step(q[0].step);
    let mut ctx = start.clone();
    let luma = code_plane(
        &residuals[0],
        size,
        q[0],
        0,
        blocks_of,
        None,
        &mut ctx,
        &mut CostSink::default(),
    );
    // Chroma follows luma: its blocks may add a factor of the coded luma blocks.
    let mut ctx = start;
    let chroma: Vec<DetailPlane> = (1..residuals.len())
        .map(|c| {
            let reference = LumaReference {
                plane: &luma,
                step: q[0].step,
                chroma: c - 1,
            };
            code_plane(
                &residuals[c],
                size,
                q[c],
                1,
                blocks_of,
                Some(reference),
                &mut ctx,
                &mut CostSink::default(),
            )
        })
        .collect();
    let planes: Vec<DetailPlane> = std::iter::once(luma).chain(chroma).collect();
    let field = field.map(|f| {
        let mut f = f.clone();
        f.settle(&f.used(&planes), classes, blocks(size.0, size.1).0);
        f
    });
    let detail = Detail {
        planes,
        steps: q.iter().map(|q| q.step).collect(),
        deblock: None,
        lapping: None,
        block_steps: None,
        weights,
        field,
    };
    let payload = detail.to_payload(classes);
    (detail, payload)
}

/// The plain search [`choose`] is tested equal to: every candidate re-coded whole into
/// an [`OverlayCostSink`](caoen_decoder::entropy::OverlayCostSink) and its distortion
/// summed in full.
#[cfg(test)]
mod reference {
    use super::*;
    use caoen_decoder::entropy::OverlayCostSink;

    /// The level search of [`choose`] with any pricing.
    pub fn search_levels(
        x: &[f64; COEFFS],
        lambda: f64,
        start: (f64, [i32; COEFFS]),
        price: &mut impl FnMut(&[i32; COEFFS]) -> f64,
    ) -> (f64, [i32; COEFFS]) {
        let (mut best, mut levels) = start;
        for k in (0..COEFFS).rev() {
            let z = ZIGZAG[k] as usize;
            for m in moves(levels[z], x[z], lambda).into_iter().flatten() {
                let mut trial = levels;
                trial[z] = m;
                let j = price(&trial);
                if j < best {
                    (best, levels) = (j, trial);
                    break;
                }
            }
        }
        (best, levels)
    }

    pub fn choose(
        c: &[f64; COEFFS],
        q: Quantiser,
        ctx: &mut DetailContexts,
        at: syntax::BlockContext,
        cost: &mut OverlayCostSink,
    ) -> [i32; COEFFS] {
        let levels: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
        if levels.iter().all(|&l| l == 0) {
            return levels;
        }
        let x: [f64; COEFFS] = std::array::from_fn(|z| c[z] / q.step);
        let mut price = |l: &[i32; COEFFS]| {
            cost.reset();
            syntax::write_block(ctx, at, l, cost);
            distortion(&x, l) + q.lambda * cost.cost as f64 / 256.0
        };
        let mut best = (price(&levels), levels);
        if q.per_coefficient {
            best = search_levels(&x, q.lambda, best, &mut price);
        }
        let mut trimmed = best.1;
        let mut tries = 0;
        for k in (0..COEFFS).rev() {
            let z = ZIGZAG[k] as usize;
            if trimmed[z] == 0 {
                continue;
            }
            if tries == TRIMS {
                break;
            }
            tries += 1;
            trimmed[z] = 0;
            let j = price(&trimmed);
            if j < best.0 {
                best = (j, trimmed);
            }
        }
        let empty = [0; COEFFS];
        let j = price(&empty);
        if j < best.0 {
            best = (j, empty);
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_decoder::entropy::OverlayCostSink;

    /// Coefficients falling off with frequency, as a photograph's residual does.
    fn residual_block(seed: &mut u64, scale: f64) -> [f64; COEFFS] {
        std::array::from_fn(|i| {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (*seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            u * scale / (1.0 + (i / N + i % N) as f64)
        })
    }

    /// A step towards zero adds `2e + 1` squared steps (`e` the coefficient's distance
    /// past its level): offered while the bits it may save can pay for that, at 19 bits
    /// from a level of one and 14 from larger ones; a step away only past half a step.
    #[test]
    fn the_search_offers_the_moves_that_can_pay() {
        let lambda = 0.05;
        // From one to zero, 19 bits pay for 0.95 squared steps: e up to -0.025.
        assert_eq!(moves(1, 0.97, lambda), [Some(0), None]);
        assert_eq!(moves(-1, -0.97, lambda), [Some(0), None]);
        assert_eq!(moves(1, 0.98, lambda), [None, None]);
        // From three, 14 bits pay for 0.7 squared steps: e up to -0.15.
        assert_eq!(moves(3, 2.84, lambda), [Some(2), None]);
        assert_eq!(moves(-3, -2.86, lambda), [None, None]);
        // Away from zero past half a step, whatever the multiplier.
        assert_eq!(moves(0, -0.6, lambda), [None, Some(-1)]);
        assert_eq!(moves(2, 2.55, 0.0), [None, Some(3)]);
        assert_eq!(moves(2, 2.55, lambda), [None, Some(3)]);
        assert_eq!(moves(1, 1.51, 1.0), [Some(0), Some(2)]);
        assert_eq!(moves(0, 0.4, lambda), [None, None]);
    }

    #[test]
    fn the_level_search_only_takes_cheaper_blocks_one_step_from_rounding() {
        let q = Quantiser {
            step: 1.0,
            deadzone: 0.2,
            lambda: 0.12,
            per_coefficient: true,
        };
        let mut ctx = DetailContexts::default();
        let mut cost = OverlayCostSink::default();
        let at = caoen_decoder::detail::syntax::BlockContext {
            kind: 0,
            class: 1,
            neighbours: 1,
            signs: [4, 2, 0, 8, 1, 5, 0, 3, 7, 6],
            levels: [0, 1, 2, 0, 1, 2, 2, 1, 0, 0],
        };
        let mut seed = 99u64;
        let mut moved = 0;
        for _ in 0..300 {
            let c = residual_block(&mut seed, 12.0);
            let start: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
            let mut price = |l: &[i32; COEFFS]| {
                cost.reset();
                syntax::write_block(&mut ctx, at, l, &mut cost);
                distortion(&c, l) + q.lambda * cost.cost as f64 / 256.0
            };
            let j0 = price(&start);
            let (j, levels) = reference::search_levels(&c, q.lambda, (j0, start), &mut price);
            assert!(j <= j0);
            assert_eq!(j, price(&levels), "the cost returned is the levels' cost");
            for k in 0..COEFFS {
                let nearest = c[k].round() as i32;
                assert!(
                    (levels[k] - nearest).abs() <= 1,
                    "{} from {}",
                    levels[k],
                    c[k]
                );
            }
            moved += usize::from(levels != start);
            syntax::write_block(
                &mut ctx,
                at,
                &levels,
                &mut caoen_decoder::entropy::AnsSink::new(),
            );
        }
        assert!(
            moved > 30,
            "the search changes some blocks ({moved} of 300)"
        );
    }

    /// A merged option asked with rising costs apart (as a group's blocks are added)
    /// answers as a full search compared with each would.
    #[test]
    fn a_merged_option_answers_as_its_full_search_would() {
        let mut seed = 31u64;
        let ctx = DetailContexts::default();
        let mut pricer = BlockPricer::default();
        let (mut searched, mut skipped) = (0, 0);
        for i in 0..400 {
            let q = Quantiser {
                step: [1.0, 0.4, 2.5][i % 3],
                deadzone: 0.2,
                lambda: 0.09,
                per_coefficient: i % 2 == 0,
            };
            let low = residual_block(&mut seed, if i % 4 == 0 { 40.0 } else { 6.0 });
            let high = (i % 7) as f64 * 0.8;
            let transforms = [Some([Some((low, high)), None])];
            let plane = Plane {
                coeffs: &[],
                transforms: &transforms,
                cols: 1,
                q,
                ctx: &ctx,
            };
            let g = GroupContext {
                kind: 0,
                level: 1,
                class: 1,
                merged: i % 3,
            };
            let at = syntax::BlockContext {
                kind: 0,
                ..syntax::BlockContext::varied(i)
            };
            let full = choose(&low, q, &ctx, at, &mut pricer);
            let j_full = full.cost(
                q,
                syntax::merge_cost(&ctx, g, true),
                high / (q.step * q.step),
            );
            let mut option = plane.merged(0, g, at);
            for f in [0.1, 0.5, 0.9, 1.0, 1.1, 2.0] {
                let apart = j_full * f;
                let expected = (j_full < apart).then_some((j_full, full.levels));
                assert_eq!(
                    option.beats(apart, &mut pricer),
                    expected,
                    "group {i} at {f}"
                );
                // Answered by the bound alone, without a search.
                skipped += usize::from(option.found.is_none());
            }
            searched += usize::from(option.found.is_some());
        }
        assert!(
            searched > 100 && skipped > 10,
            "searched {searched}, skipped {skipped}"
        );
    }

    #[test]
    fn choices_equal_the_reference_search() {
        let mut seed = 2024u64;
        for per_coefficient in [true, false] {
            let mut changed = 0;
            for (kind, step, lambda, scale) in [
                (0, 1.0, 0.09, 12.0),
                (1, 0.37, 0.09, 3.0),
                (0, 0.05, 0.2, 200.0),
                (1, 2.5, 0.03, 4.0),
            ] {
                let q = Quantiser {
                    step,
                    deadzone: 0.2,
                    lambda,
                    per_coefficient,
                };
                let mut ctx = DetailContexts::default();
                let mut cost = OverlayCostSink::default();
                let mut pricer = BlockPricer::default();
                for i in 0..400 {
                    let c = residual_block(&mut seed, scale * if i % 5 == 0 { 8.0 } else { 1.0 });
                    let at = syntax::BlockContext {
                        kind,
                        ..syntax::BlockContext::varied(i)
                    };
                    let expected = reference::choose(&c, q, &mut ctx, at, &mut cost);
                    let chosen = choose(&c, q, &ctx, at, &mut pricer);
                    assert_eq!(chosen.levels, expected, "block {i}");
                    // The kept distortion and rate give the cost of pricing the levels
                    // again, to the bit, with or without extra bits and dropped error.
                    for (extra, dropped) in [(0, 0.0), (300, 0.0), (77, 1.25)] {
                        let again =
                            block_cost(&c, &expected, q, &ctx, at, &mut pricer, extra, dropped);
                        assert_eq!(
                            chosen.cost(q, extra, dropped).to_bits(),
                            again.to_bits(),
                            "block {i}"
                        );
                    }
                    // What a merged group's search is skipped by stays below its cost.
                    for (extra, dropped) in [(0, 0.0), (0, 3.5)] {
                        assert!(
                            unavoidable_error(&c, q) + dropped <= chosen.cost(q, extra, dropped),
                            "block {i}"
                        );
                    }
                    let rounded: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
                    changed += usize::from(expected != rounded);
                    syntax::write_block(
                        &mut ctx,
                        at,
                        &expected,
                        &mut caoen_decoder::entropy::AnsSink::new(),
                    );
                }
            }
            assert!(changed > 100, "the search has choices to make ({changed})");
        }
    }
}
