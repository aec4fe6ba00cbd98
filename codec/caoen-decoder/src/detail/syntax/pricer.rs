//! The encoder's exact block prices, from layers over the contexts instead of a copy
//! of them.

use super::{
    band, first_index, last_class, mag_class, token_index, BlockContext, ClassCdf, DetailContexts,
    MagnitudeMap, TokenCdf, LITERALS, PAD, PADDED, SIGNED, TOKENS,
};
#[cfg(doc)]
use super::{write_block, write_escape};
use crate::detail::dct::{COEFFS, ZIGZAG};

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
