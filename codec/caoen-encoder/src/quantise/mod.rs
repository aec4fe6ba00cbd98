//! The encoder's side of the detail layer: transform the network's residual block by
//! block, quantise it and choose each block's coefficients by rate and distortion.
//!
//! Blocks are decided in coding order with the coder's own adaptive contexts: each
//! candidate (the dead-zone levels, each level moved a step where that pays, the same
//! with its last nonzero coefficients dropped, and the empty block) is priced by a
//! [`BlockPricer`] (the cost on a copy of the contexts, coding only what differs from
//! the candidates before it), and the one with the least `D + lambda R` is coded.

mod groups;
#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use caoen_decoder::detail::dct::{self, COEFFS, N, ZIGZAG};
use caoen_decoder::detail::field::ActivityField;
use caoen_decoder::detail::syntax::{
    self, BlockContext, BlockPricer, DetailContexts, GROUP_LEVELS,
};
use caoen_decoder::detail::weights::{self, FrequencyWeights};
use caoen_decoder::detail::{
    blocks, factor_context, group_start, luma_predicts, Detail, DetailPlane, Visit, Walk,
};
use caoen_decoder::entropy::{CostSink, SymbolSink};
use groups::{GroupTransform, Plane};

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
    let searched = best.1;
    // A candidate ending elsewhere shares no prefix with the last: priced in full,
    // kept if cheaper.
    let offer = |levels: [i32; COEFFS]| {
        let d = distortion(&x, &levels);
        if let Some(r) = rates.rate_within(&levels, COEFFS, limit(best.0, d)) {
            let j = cost(d, r);
            if j < best.0 {
                best = (j, levels);
                best_dr = (d, r);
            }
        }
    };
    tail_trims(searched, offer);
    Chosen {
        levels: best.1,
        distortion: best_dr.0,
        rate: best_dr.1,
    }
}

/// Offers `levels` with its last nonzero levels (in zigzag order) dropped one more at a
/// time, up to [`TRIMS`] of them, then the empty block: an end of block moved earlier
/// often saves more rate than the dropped levels cost.
fn tail_trims(levels: [i32; COEFFS], mut offer: impl FnMut([i32; COEFFS])) {
    let mut trimmed = levels;
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
