//! The merged groups' choice: a 2x2 or 4x4 group's blocks coded apart against the
//! group coded as one larger transform's lowest frequencies, each option searched only
//! when it could win.

use super::{choose, unavoidable_error, Quantiser};
use caoen_decoder::detail::dct::COEFFS;
use caoen_decoder::detail::syntax::{
    self, BlockContext, BlockPricer, DetailContexts, GroupContext, Summary, GROUP_LEVELS,
};

/// A group's transform: the lowest 8x8 coefficients and the energy of the rest.
pub(super) type GroupTransform = ([f64; COEFFS], f64);

/// A group's choice: its `D + lambda R` (merge bins included), the level of the
/// merged group its first block starts (0: coded apart), and that block's levels.
pub(super) type GroupChoice = (f64, usize, [i32; COEFFS]);

/// What a group's choice needs of the plane: the blocks' coefficients, the groups'
/// transforms (by block, for the group starts), the quantiser and the contexts.
#[derive(Clone, Copy)]
pub(super) struct Plane<'a> {
    pub(super) coeffs: &'a [[f64; COEFFS]],
    pub(super) transforms: &'a [Option<[Option<GroupTransform>; GROUP_LEVELS]>],
    pub(super) cols: usize,
    pub(super) q: Quantiser,
    pub(super) ctx: &'a DetailContexts,
}

impl Plane<'_> {
    /// The merged option of the level-`g` group at block `i`, searched when first
    /// asked for.
    pub(super) fn merged(&self, i: usize, g: GroupContext, at: BlockContext) -> MergedOption<'_> {
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
    pub(super) fn choose(
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
pub(super) struct MergedOption<'a> {
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
    pub(super) found: Option<(f64, [i32; COEFFS])>,
}

impl MergedOption<'_> {
    /// The merged group's cost and levels if they cost less than `apart`, the cost of
    /// coding the group apart or a part of it.
    pub(super) fn beats(
        &mut self,
        apart: f64,
        pricer: &mut BlockPricer,
    ) -> Option<(f64, [i32; COEFFS])> {
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
