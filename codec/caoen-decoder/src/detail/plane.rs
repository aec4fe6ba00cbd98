//! One channel's quantised blocks: their levels held compactly, gathered from tiles,
//! read from a stream, and dequantised per block.

use super::budget::{bytes_of, LayerBudget};
use super::dct::{self, COEFFS, N};
use super::syntax::{self, DetailContexts, FactorContext};
use super::weights::WeightTable;
use super::{group_of, Visit, Walk, ZERO};
use crate::entropy::AnsSource;
use crate::CodecError;

/// One channel's quantised coefficients.
#[derive(Debug, Clone, PartialEq)]
pub struct DetailPlane {
    /// Blocks per row.
    pub cols: usize,
    /// Block rows.
    pub rows: usize,
    /// Per block: its index in `spans`, or `ZERO` (none coded).
    pub index: Vec<u32>,
    /// Per coded block: where its levels start in `levels`, and its extent `(v1, u1)`:
    /// the rows and columns up to the last nonzero ones.
    pub spans: Vec<(u32, u8, u8)>,
    /// The coded blocks' levels, each block's `v1 x u1` corner row-major: most of a
    /// block's high frequencies are zero, so this holds a fraction of 64 per block.
    pub levels: Vec<i32>,
    /// Per block, the level of the merged group it is in, 0 for none (the group's
    /// first block holds its levels and the others none).
    pub merged: Vec<u8>,
    /// Per block of a chroma plane, its luma factor in eighths (0: none); empty for
    /// luma and for a plane without factors.
    pub factors: Vec<i8>,
}

/// Whether chroma block `i` may take a luma factor, given the luma plane: the luma
/// block is coded apart (not in a merged group) with a nonzero AC level, so its 8x8
/// coefficients are the chroma block's frame and carry some shape.
pub fn luma_predicts(luma: &DetailPlane, i: usize) -> bool {
    let k = luma.index[i];
    luma.merged[i] == 0 && k != ZERO && {
        let (_, v1, u1) = luma.spans[k as usize];
        v1 > 1 || u1 > 1
    }
}

/// The context of block `i`'s luma factor in chroma plane `plane` (0: C1), from the
/// factors of the blocks before it (`factors`, by block index).
pub fn factor_context(factors: &[i8], cols: usize, i: usize, plane: usize) -> FactorContext {
    let has = |k: usize| usize::from(factors[k] != 0);
    let left = if i.is_multiple_of(cols) {
        0
    } else {
        has(i - 1)
    };
    let above = if i >= cols { has(i - cols) } else { 0 };
    FactorContext {
        plane,
        neighbours: left + above,
    }
}

impl DetailPlane {
    /// A plane of `cols x rows` blocks from per-block levels (all-zero blocks dropped).
    pub fn from_blocks(cols: usize, rows: usize, blocks: Vec<[i32; COEFFS]>) -> Self {
        DetailPlane::from_groups(cols, rows, blocks, vec![0; cols * rows])
    }

    /// A plane from per-block levels and merged groups (`merged` per block, as
    /// [`Walk`] leaves it; a merged group's levels at its first block, zero at the
    /// others).
    pub fn from_groups(
        cols: usize,
        rows: usize,
        blocks: Vec<[i32; COEFFS]>,
        merged: Vec<u8>,
    ) -> Self {
        debug_assert_eq!(blocks.len(), cols * rows);
        debug_assert_eq!(merged.len(), cols * rows);
        let mut plane = DetailPlane::empty(cols, rows);
        for b in &blocks {
            plane.push(b);
        }
        plane.merged = merged;
        plane
    }

    /// The plane with chroma blocks' luma factors (eighths, per block).
    pub fn with_factors(mut self, factors: Vec<i8>) -> Self {
        debug_assert_eq!(factors.len(), self.cols * self.rows);
        self.factors = if factors.iter().any(|&a| a != 0) {
            factors
        } else {
            Vec::new()
        };
        self
    }

    /// Block `i`'s luma factor in eighths (0: none).
    pub fn factor(&self, i: usize) -> i32 {
        self.factors.get(i).map_or(0, |&a| a as i32)
    }

    fn empty(cols: usize, rows: usize) -> Self {
        DetailPlane {
            cols,
            rows,
            index: Vec::with_capacity(cols * rows),
            spans: Vec::new(),
            levels: Vec::new(),
            merged: Vec::new(),
            factors: Vec::new(),
        }
    }

    /// Appends the next block in raster order.
    fn push(&mut self, l: &[i32; COEFFS]) {
        let (mut v1, mut u1) = (0, 0);
        for (i, &q) in l.iter().enumerate() {
            if q != 0 {
                v1 = v1.max(i / N + 1);
                u1 = u1.max(i % N + 1);
            }
        }
        if v1 == 0 {
            self.index.push(ZERO);
            return;
        }
        self.index.push(self.spans.len() as u32);
        self.spans
            .push((self.levels.len() as u32, v1 as u8, u1 as u8));
        for v in 0..v1 {
            self.levels.extend_from_slice(&l[v * N..v * N + u1]);
        }
    }

    /// The plane of a whole image, `cols x rows` blocks, from its tiles' planes, each
    /// placed at its first block `(bx, by)`; a tile without a plane has no coded block.
    /// The whole plane's levels are taken from `budget` before they are gathered, and
    /// each tile's given back as it is dropped.
    pub fn from_tiles(
        cols: usize,
        rows: usize,
        tiles: Vec<((usize, usize), Option<DetailPlane>)>,
        budget: &LayerBudget,
    ) -> Result<Self, CodecError> {
        let planes = || tiles.iter().filter_map(|(_, p)| p.as_ref());
        let (n_levels, n_spans) =
            planes().fold((0, 0), |(l, s), p| (l + p.levels.len(), s + p.spans.len()));
        let whole = bytes_of::<i32>(n_levels) + bytes_of::<(u32, u8, u8)>(n_spans);
        budget.take(whole)?;
        let mut index = vec![ZERO; cols * rows];
        let mut spans = Vec::with_capacity(n_spans);
        let mut levels = Vec::with_capacity(n_levels);
        let mut merged = vec![0; cols * rows];
        let mut factors = Vec::new();
        for ((bx0, by0), plane) in tiles {
            let Some(p) = plane else { continue };
            if !p.factors.is_empty() && factors.is_empty() {
                factors = vec![0; cols * rows];
            }
            for by in 0..p.rows {
                for bx in 0..p.cols {
                    merged[(by0 + by) * cols + bx0 + bx] = p.merged[by * p.cols + bx];
                    if !p.factors.is_empty() {
                        factors[(by0 + by) * cols + bx0 + bx] = p.factors[by * p.cols + bx];
                    }
                    let i = p.index[by * p.cols + bx];
                    if i != ZERO {
                        let (at, v1, u1) = p.spans[i as usize];
                        let n = v1 as usize * u1 as usize;
                        index[(by0 + by) * cols + bx0 + bx] = spans.len() as u32;
                        spans.push((levels.len() as u32, v1, u1));
                        levels.extend_from_slice(&p.levels[at as usize..at as usize + n]);
                    }
                }
            }
            budget.free(p.levels);
            budget.free(p.spans);
        }
        Ok(DetailPlane {
            cols,
            rows,
            index,
            spans,
            levels,
            merged,
            factors,
        })
    }

    /// The levels of block `(bx, by)`, if it has a nonzero one (a merged group's are
    /// its first block's).
    pub fn block(&self, bx: usize, by: usize) -> Option<[i32; COEFFS]> {
        let i = self.index[by * self.cols + bx];
        (i != ZERO).then(|| {
            let (at, v1, u1) = self.spans[i as usize];
            let (v1, u1) = (v1 as usize, u1 as usize);
            let mut b = [0; COEFFS];
            for v in 0..v1 {
                let row = at as usize + v * u1;
                b[v * N..v * N + u1].copy_from_slice(&self.levels[row..row + u1]);
            }
            b
        })
    }

    /// Number of blocks with a nonzero coefficient (a merged group counts once).
    pub fn coded_blocks(&self) -> usize {
        self.spans.len()
    }

    /// Number of merged groups.
    pub fn merged_groups(&self) -> usize {
        (0..self.merged.len())
            .filter(|&i| self.merged[i] != 0 && self.coded_block_of(i) == i)
            .count()
    }

    /// The block whose levels block `i` evaluates: the first of its merged group, or
    /// itself. Its step factor is the group's.
    pub fn coded_block_of(&self, i: usize) -> usize {
        group_of(self.cols, i, self.merged[i] as usize)
    }

    /// The cosine-series coefficients of block `(bx, by)` (row-major) with its levels'
    /// step `step` and frequency weights `weights`, if any level is nonzero: its levels
    /// times the step and their weights, or for a block of a merged group its part of
    /// the group's ([`dct::part`]).
    pub fn coefficients(
        &self,
        bx: usize,
        by: usize,
        step: f64,
        weights: &WeightTable,
    ) -> Option<[f64; COEFFS]> {
        let i = by * self.cols + bx;
        let g = self.merged[i] as usize;
        let first = self.coded_block_of(i);
        let l = self.block(first % self.cols, first / self.cols)?;
        let c: [f64; COEFFS] = std::array::from_fn(|z| l[z] as f64 * step * weights[g][z]);
        if g == 0 {
            return Some(c);
        }
        let n = 1 << g;
        Some(dct::part(&c, g, bx % n, by % n))
    }

    /// Reads a `cols x rows` plane whose blocks have cell-size classes `classes`; a
    /// chroma plane with its luma plane and its index among the chroma planes (0: C1),
    /// for the luma factors. Its levels are taken from `budget` before they grow.
    pub fn read(
        (cols, rows): (usize, usize),
        classes: &[u8],
        kind: usize,
        luma: Option<(&DetailPlane, usize)>,
        ctx: &mut DetailContexts,
        src: &mut AnsSource,
        budget: &LayerBudget,
    ) -> Result<Self, CodecError> {
        let mut plane = DetailPlane::empty(cols, rows);
        let mut factors = vec![0i8; if luma.is_some() { cols * rows } else { 0 }];
        let mut q = [0i32; COEFFS];
        let mut walk = Walk::new(classes, cols, rows, kind);
        for i in 0..cols * rows {
            let mut merged = false;
            let at = match walk.visit() {
                Visit::Covered => {
                    plane.index.push(ZERO);
                    continue;
                }
                Visit::Group(starts, at) => {
                    for (k, start) in starts.iter().enumerate().rev() {
                        if let Some(g) = start {
                            if syntax::read_merge(ctx, *g, src)? {
                                walk.merge(k + 1);
                                merged = true;
                                break;
                            }
                        }
                    }
                    at
                }
                Visit::Block(at) => at,
            };
            if let Some((_, c)) = luma.filter(|&(l, _)| !merged && luma_predicts(l, i)) {
                factors[i] =
                    syntax::read_factor(ctx, factor_context(&factors, cols, i, c), src)? as i8;
            }
            let coded = syntax::read_block(ctx, at, &mut q, src)?;
            walk.done(&q);
            if coded {
                // A coded block has a nonzero level (the syntax codes its last one).
                budget.grow(&mut plane.levels, COEFFS)?;
                budget.grow(&mut plane.spans, 1)?;
                plane.push(&q);
            } else {
                plane.index.push(ZERO);
            }
        }
        plane.merged = walk.into_merged();
        Ok(if luma.is_some() {
            plane.with_factors(factors)
        } else {
            plane
        })
    }
}
