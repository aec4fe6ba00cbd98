//! The detail layer: what the smooth key-point network leaves, transform-coded.
//!
//! The colour channels' residual after the network (coding space, coded size) is cut
//! into 8x8 blocks, each an orthonormal DCT ([`dct`]) quantised with one step per channel
//! kind (luma, chroma), scaled per block by the network's cell size ([`adaptive`]), and
//! coded by [`syntax`]. Under network cells of 16 pixels or more, a 2x2 group of blocks
//! can be *merged*: coded as the lowest 8x8 coefficients of one 16x16 DCT, and under
//! cells of 32 pixels or more a 4x4 group as those of one 32x32 DCT; the decoder turns
//! them into the group's blocks' coefficients ([`dct::part`]). A chroma block whose luma
//! block has AC levels may add a factor (in eighths) of the luma block's coefficients,
//! coded before its own: where colour edges follow brightness, chroma then codes the
//! difference ([`luma_predicts`]). The decoder adds the blocks' cosine
//! series to the network's colours at every sample position it evaluates, so the layer
//! follows the network to any output size or supersampling: the series is a function
//! defined everywhere in its block, not a table of pixels.

pub mod adaptive;
pub mod context_tables;
pub mod dct;
pub mod deblock;
pub mod field;
pub mod lapping;
pub mod syntax;
pub mod weights;

use adaptive::BlockSteps;
use dct::{COEFFS, N};
use deblock::{edge_basis, edge_weight, gate, Deblock};
use field::ActivityField;
use lapping::Lapping;
use weights::{FrequencyWeights, WeightTable};

use super::entropy::{AnsSink, AnsSource};
use super::keyset::Grid;
use super::varint;
use super::CodecError;
use syntax::{BlockContext, DetailContexts, FactorContext, GroupContext, Summary, GROUP_LEVELS};

/// Marks a block with no nonzero coefficient.
const ZERO: u32 = u32::MAX;

/// The blocks covering a `width x height` image: `(columns, rows)`.
pub fn blocks(width: u32, height: u32) -> (usize, usize) {
    ((width as usize).div_ceil(N), (height as usize).div_ceil(N))
}

/// The context of block `i` (`bx`, `by`) of a plane `cols` blocks wide, from its
/// cell-size class (`classes`, per block, [`adaptive::block_classes`]) and its left
/// and above neighbours' summaries (`summaries`, by block index, holds at least the
/// blocks before `i`): the one rule the reader and both writers share.
pub fn block_context(
    classes: &[u8],
    summaries: &[Summary],
    cols: usize,
    i: usize,
    kind: usize,
) -> BlockContext {
    let (bx, by) = (i % cols, i / cols);
    let left = if bx > 0 {
        summaries[i - 1]
    } else {
        Summary::default()
    };
    let above = if by > 0 {
        summaries[i - cols]
    } else {
        Summary::default()
    };
    BlockContext::new(kind, classes[i] as usize, left, above)
}

/// Whether block `i` of a `cols x rows` plane of `kind` starts a level-`g` group that
/// may merge (`g` 1: 2x2 blocks, one 16x16 transform; 2: 4x4 blocks, one 32x32): its
/// column and row are multiples of `2^g`, the group's blocks are all in the plane, and
/// it lies under a network cell at least the group's size (class `g` or more), which
/// then covers the group (cells are aligned to their size). Chroma's 2x2 groups may
/// merge under any cell: colour varies more smoothly than luma, so a 16x16 transform's
/// low frequencies often carry a chroma group where luma needs its blocks.
pub fn group_start(
    classes: &[u8],
    cols: usize,
    rows: usize,
    i: usize,
    g: usize,
    kind: usize,
) -> bool {
    let (bx, by, n) = (i % cols, i / cols, 1 << g);
    let class = if kind == 1 {
        classes[i].max(1)
    } else {
        classes[i]
    };
    bx % n == 0 && by % n == 0 && bx + n <= cols && by + n <= rows && class as usize >= g
}

/// A chroma block's coefficients with luma factor `a` (eighths): its own (none: all
/// zero) plus `a / 8` times its luma block's, the one rule of the scalar and grid paths.
fn plus_luma(own: Option<[f64; COEFFS]>, a: i32, luma: &[f64; COEFFS]) -> [f64; COEFFS] {
    let own = own.unwrap_or([0.0; COEFFS]);
    std::array::from_fn(|z| own[z] + a as f64 / 8.0 * luma[z])
}

/// The first block of the level-`g` group of block `i` in a plane `cols` blocks wide.
fn group_of(cols: usize, i: usize, g: usize) -> usize {
    ((i / cols) >> g << g) * cols + ((i % cols) >> g << g)
}

/// What the coding order meets at a block ([`Walk::visit`]).
pub enum Visit {
    /// A block of a merged group after its first: nothing is coded.
    Covered,
    /// The first block of groups that may merge, by level less one: the merge bins
    /// from the largest group down to the first that is merged, then the block.
    Group([Option<GroupContext>; GROUP_LEVELS], BlockContext),
    /// Any other block.
    Block(BlockContext),
}

/// The coding order of one plane, the bookkeeping the reader and both writers share:
/// blocks in raster order, each one's context from its left and above neighbours'
/// summaries (a merged group's blocks all summarised by its one coded block), and the
/// merged groups so far.
pub struct Walk<'a> {
    classes: &'a [u8],
    cols: usize,
    rows: usize,
    kind: usize,
    summaries: Vec<Summary>,
    merged: Vec<u8>,
}

impl<'a> Walk<'a> {
    /// The walk over a `cols x rows` plane of `kind` with blocks of cell-size classes
    /// `classes`.
    pub fn new(classes: &'a [u8], cols: usize, rows: usize, kind: usize) -> Self {
        Walk {
            classes,
            cols,
            rows,
            kind,
            summaries: Vec::with_capacity(cols * rows),
            merged: vec![0; cols * rows],
        }
    }

    /// The next block in coding order; a covered block is done with it.
    pub fn visit(&mut self) -> Visit {
        let (i, cols) = (self.summaries.len(), self.cols);
        if self.merged[i] != 0 {
            self.summaries
                .push(self.summaries[group_of(cols, i, self.merged[i] as usize)]);
            return Visit::Covered;
        }
        let at = block_context(self.classes, &self.summaries, cols, i, self.kind);
        let (bx, by) = (i % cols, i / cols);
        let starts: [Option<GroupContext>; GROUP_LEVELS] = std::array::from_fn(|k| {
            let (g, n) = (k + 1, 2 << k);
            group_start(self.classes, cols, self.rows, i, g, self.kind).then(|| {
                let left = bx >= n && self.merged[i - n] as usize >= g;
                let above = by >= n && self.merged[i - n * cols] as usize >= g;
                GroupContext {
                    kind: self.kind,
                    level: g,
                    class: self.classes[i] as usize,
                    merged: usize::from(left) + usize::from(above),
                }
            })
        });
        if starts[0].is_none() {
            return Visit::Block(at);
        }
        Visit::Group(starts, at)
    }

    /// Marks the level-`g` group starting at the current block merged.
    pub fn merge(&mut self, g: usize) {
        let (i, cols) = (self.summaries.len(), self.cols);
        for y in 0..1 << g {
            for x in 0..1 << g {
                self.merged[i + y * cols + x] = g as u8;
            }
        }
    }

    /// The current block is coded with levels `q`.
    pub fn done(&mut self, q: &[i32; COEFFS]) {
        self.summaries.push(Summary::of(q));
    }

    /// The summaries so far, by block index.
    pub fn summaries(&self) -> &[Summary] {
        &self.summaries
    }

    /// Per block, the level of the merged group it is in (0 for none).
    pub fn into_merged(self) -> Vec<u8> {
        self.merged
    }
}

/// One channel's quantised coefficients.
#[derive(Debug, Clone, PartialEq)]
pub struct DetailPlane {
    /// Blocks per row.
    pub cols: usize,
    /// Block rows.
    pub rows: usize,
    /// Per block: its index in `spans`, or [`ZERO`].
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
    pub fn from_tiles(
        cols: usize,
        rows: usize,
        tiles: impl IntoIterator<Item = ((usize, usize), Option<DetailPlane>)>,
    ) -> Self {
        let mut index = vec![ZERO; cols * rows];
        let mut spans = Vec::new();
        let mut levels = Vec::new();
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
        }
        DetailPlane {
            cols,
            rows,
            index,
            spans,
            levels,
            merged,
            factors,
        }
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
    /// for the luma factors.
    pub fn read(
        cols: usize,
        rows: usize,
        classes: &[u8],
        kind: usize,
        luma: Option<(&DetailPlane, usize)>,
        ctx: &mut DetailContexts,
        src: &mut AnsSource,
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

/// The detail layer of an image: one plane per colour channel (Y, or Y, C1, C2) and
/// the quantiser steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Detail {
    /// Planes in channel order.
    pub planes: Vec<DetailPlane>,
    /// Step per plane.
    pub steps: Vec<f64>,
    /// Deblocking applied where the layer is evaluated ([`deblock`]), if any.
    pub deblock: Option<Deblock>,
    /// Lapping across the block edges ([`lapping`]), if any.
    pub lapping: Option<Lapping>,
    /// Each block's step factor ([`adaptive`]), if the steps adapt.
    pub block_steps: Option<BlockSteps>,
    /// The steps' tilt with frequency ([`weights`]), if any.
    pub weights: Option<FrequencyWeights>,
    /// The tile's activity field ([`field`]) as coded in its luma stream, if any (the
    /// decoder folds it into `block_steps`).
    pub field: Option<ActivityField>,
}

impl Detail {
    /// The section payload of these levels, coded as they are (the encoder's search
    /// writes its own), its blocks of cell-size classes `classes`: a u32 byte count of
    /// the luma stream, the luma stream (the activity field, if any, then plane 0), the
    /// chroma stream (planes 1 and 2).
    pub fn to_payload(&self, classes: &[u8]) -> Vec<u8> {
        let luma = self.planes.first();
        let stream = |planes: &[DetailPlane], kind: usize| {
            let mut sink = AnsSink::new();
            if let Some(f) = self.field.as_ref().filter(|_| kind == 0) {
                f.write(classes, luma.map_or(0, |l| l.cols), &mut sink);
            }
            let mut ctx = DetailContexts::for_step(self.steps[0]);
            const EMPTY: [i32; COEFFS] = [0; COEFFS];
            for (c, p) in planes.iter().enumerate() {
                let mut walk = Walk::new(classes, p.cols, p.rows, kind);
                let mut factors = vec![0i8; p.cols * p.rows];
                for i in 0..p.cols * p.rows {
                    let at = match walk.visit() {
                        Visit::Covered => continue,
                        Visit::Group(starts, at) => {
                            for (k, start) in starts.iter().enumerate().rev() {
                                if let Some(g) = start {
                                    let merged = p.merged[i] as usize == k + 1;
                                    syntax::write_merge(&mut ctx, *g, merged, &mut sink);
                                    if merged {
                                        walk.merge(k + 1);
                                        break;
                                    }
                                }
                            }
                            at
                        }
                        Visit::Block(at) => at,
                    };
                    if kind == 1 && p.merged[i] == 0 && luma.is_some_and(|l| luma_predicts(l, i)) {
                        factors[i] = p.factor(i) as i8;
                        syntax::write_factor(
                            &mut ctx,
                            factor_context(&factors, p.cols, i, c),
                            p.factor(i),
                            &mut sink,
                        );
                    }
                    let b = p.block(i % p.cols, i / p.cols).unwrap_or(EMPTY);
                    syntax::write_block(&mut ctx, at, &b, &mut sink);
                    walk.done(&b);
                }
            }
            sink.finish()
        };
        let split = self.planes.len().min(1);
        let luma = stream(&self.planes[..split], 0);
        let chroma = stream(&self.planes[split..], 1);
        let mut payload = Vec::with_capacity(5 + luma.len() + chroma.len());
        varint::push(&mut payload, luma.len() as u32);
        payload.extend(luma);
        payload.extend(chroma);
        payload
    }

    /// Reads the section of a `width x height` image with these steps (one per colour
    /// channel), its blocks of cell-size classes `classes` ([`adaptive::block_classes`])
    /// and, if the file has one, an activity field of regions of side `2^field_log2`: the
    /// luma stream's byte count (LEB128), the luma stream, the chroma stream.
    pub fn read(
        payload: &[u8],
        width: u32,
        height: u32,
        steps: Vec<f64>,
        classes: &[u8],
        field_log2: Option<u8>,
    ) -> Result<Self, CodecError> {
        Self::read_with_contexts(payload, width, height, steps, classes, field_log2).map(|(d, _)| d)
    }

    /// [`Detail::read`], with the luma and the chroma stream's contexts as each ends.
    pub fn read_with_contexts(
        payload: &[u8],
        width: u32,
        height: u32,
        steps: Vec<f64>,
        classes: &[u8],
        field_log2: Option<u8>,
    ) -> Result<(Self, [DetailContexts; 2]), CodecError> {
        let (cols, rows) = blocks(width, height);
        assert_eq!(classes.len(), cols * rows, "one class per block");
        let (n, used) = varint::read(payload, "the detail section's luma stream length", 0)?;
        let n = n as usize;
        if n > payload.len() - used {
            return Err(CodecError::Truncated {
                what: "the detail section's luma stream",
                offset: used as u64,
                need: n as u64,
                available: (payload.len() - used) as u64,
            });
        }
        let (luma, chroma) = payload[used..].split_at(n);
        let per_plane = syntax::MAX_SYMBOLS_PER_BLOCK * (cols * rows) as u64;
        let regions = field_log2.map_or(0, |l| {
            let (c, r) = ActivityField::regions(width, height, l);
            (c * r) as u64
        });
        let stream = |bytes: &[u8],
                      kind: usize,
                      planes: usize,
                      luma: Option<&DetailPlane>|
         -> Result<_, CodecError> {
            let field_symbols = if kind == 0 { regions } else { 0 };
            let mut src = AnsSource::new(bytes, per_plane * planes as u64 + field_symbols)?;
            let field = match field_log2.filter(|_| kind == 0) {
                Some(l) => Some(ActivityField::read(l, width, height, classes, &mut src)?),
                None => None,
            };
            let mut ctx = DetailContexts::for_step(steps[0]);
            let planes = (0..planes)
                .map(|c| {
                    DetailPlane::read(
                        cols,
                        rows,
                        classes,
                        kind,
                        luma.map(|l| (l, c)),
                        &mut ctx,
                        &mut src,
                    )
                })
                .collect::<Result<Vec<_>, _>>()?;
            if !src.finished_cleanly() {
                return Err(CodecError::PayloadLeftover {
                    stream: "detail stream",
                });
            }
            Ok((field, planes, ctx))
        };
        // Chroma reads after luma: which chroma blocks have a luma factor depends on
        // the luma blocks' levels.
        let (field, mut planes, luma_ctx) = stream(luma, 0, 1, None)?;
        let (_, c, chroma_ctx) = stream(chroma, 1, steps.len() - 1, planes.first())?;
        planes.extend(c);
        let detail = Detail {
            planes,
            steps,
            deblock: None,
            lapping: None,
            block_steps: None,
            weights: None,
            field,
        };
        Ok((detail, [luma_ctx, chroma_ctx]))
    }

    /// The layer at one position (coded pixels), one value per plane: the same
    /// function [`DetailEval`] sums on a grid, deblocking included, for callers that
    /// sample anywhere (warps), and the scalar reference its tests compare with.
    pub fn at(&self, x: f64, y: f64) -> Vec<f64> {
        let tables = weights::plane_tables(self.weights, self.planes.len());
        self.planes
            .iter()
            .zip(&self.steps)
            .enumerate()
            .map(|(pi, (p, &step))| {
                let (bx, tx) = locate(x, p.cols);
                let (by, ty) = locate(y, p.rows);
                let series = |bx: usize, by: usize, tx: f64, ty: f64| {
                    let Some(c) = self.block_coefficients(pi, bx, by, &tables) else {
                        return 0.0;
                    };
                    let (bu, bv) = (dct::basis_at(tx), dct::basis_at(ty));
                    let mut sum = 0.0;
                    for v in 0..N {
                        for u in 0..N {
                            sum += c[v * N + u] * bv[v] as f64 * bu[u] as f64;
                        }
                    }
                    sum
                };
                let mut value = match self.lapping {
                    // The post-filter along x, then along y: per axis the position's own
                    // block and, near an edge, the neighbour at the mirror position.
                    Some(l) => {
                        let terms = |p: f64, count: usize, own: usize, t: f64| match l.at(p, count)
                        {
                            Some((_, nb, w)) => {
                                [(own, t, 1.0 - w as f64), (nb, N as f64 - t, w as f64)]
                            }
                            None => [(own, t, 1.0), (own, t, 0.0)],
                        };
                        let mut sum = 0.0;
                        for (bx, tx, wx) in terms(x, p.cols, bx, tx) {
                            for (by, ty, wy) in terms(y, p.rows, by, ty) {
                                if wx * wy != 0.0 {
                                    sum += wx * wy * series(bx, by, tx, ty);
                                }
                            }
                        }
                        sum
                    }
                    None => series(bx, by, tx, ty),
                };
                if let Some(d) = self.deblock {
                    let (t, r) = (d.threshold(step), d.radius_px());
                    let edge = N as f64;
                    if let Some((e, w)) = edge_weight(x, p.cols, r) {
                        let step = series(e, by, 0.0, ty) - series(e - 1, by, edge, ty);
                        value += (w * gate(step as f32, t)) as f64;
                    }
                    if let Some((e, w)) = edge_weight(y, p.rows, r) {
                        let step = series(bx, e, tx, 0.0) - series(bx, e - 1, tx, edge);
                        value += (w * gate(step as f32, t)) as f64;
                    }
                }
                value
            })
            .collect()
    }

    /// The cosine-series coefficients of block `(bx, by)` of plane `pi` (row-major),
    /// if any is nonzero: its levels times the step, the block's factor and the
    /// frequency weights (`tables`, per plane), a merged group's block its part of
    /// the group's, and a chroma block with a luma factor `a` that plus `a / 8` times
    /// the luma block's.
    pub fn block_coefficients(
        &self,
        pi: usize,
        bx: usize,
        by: usize,
        tables: &[WeightTable],
    ) -> Option<[f64; COEFFS]> {
        let p = &self.planes[pi];
        let i = by * p.cols + bx;
        let factor = |i: usize| self.block_steps.as_ref().map_or(1.0, |b| b.factor(i));
        let own = p.coefficients(
            bx,
            by,
            self.steps[pi] * factor(p.coded_block_of(i)),
            &tables[pi],
        );
        let a = p.factor(i);
        if a == 0 {
            return own;
        }
        let Some(luma) = self.planes[0].coefficients(bx, by, self.steps[0] * factor(i), &tables[0])
        else {
            return own;
        };
        Some(plus_luma(own, a, &luma))
    }

    /// Bytes per pixel the decoder holds for the layer at most (levels and their
    /// dequantised coefficients), for memory estimates.
    pub const BYTES_PER_PIXEL: u64 = 2 * 4 + 2;
}

/// One plane prepared for evaluation.
struct PlaneEval {
    /// Dequantised coefficients of the coded blocks, each block's `v1 x u1` corner up
    /// to its last nonzero row and column (row-major), one after the other: most
    /// blocks' high frequencies are zero, so a decoder holds a fraction of 64 values
    /// per block.
    coeffs: Vec<f32>,
    /// Per coded block: where its corner starts in `coeffs`, and `(v1, u1)`.
    extent: Vec<(u32, u8, u8)>,
    /// Per block: index into `extent`, or [`ZERO`].
    index: Vec<u32>,
    /// Blocks per row.
    cols: usize,
}

/// The detail layer prepared for evaluation on one grid.
pub struct DetailEval {
    grid: Grid,
    planes: Vec<PlaneEval>,
    /// Per block column: its first grid column, how many it covers, and where their
    /// basis values start in `basis_t`.
    columns: Vec<(usize, usize, usize)>,
    /// Per block column, the basis transposed: `basis_t[start + u n + k] = b_u` at the
    /// column's `k`-th grid column (`n` columns), so the sum over `u` runs along rows.
    basis_t: Vec<f32>,
    /// Per grid row: block row and basis values.
    rows: Vec<(usize, [f32; N])>,
    /// Grid columns near a vertical block edge: `(column, edge block column, weight)`.
    vcols: Vec<(usize, usize, f32)>,
    /// Per grid row near a horizontal block edge: `(edge block row, weight)`.
    hrows: Vec<Option<(usize, f32)>>,
    /// Per plane: the step below which a step across an edge is smoothed (none
    /// without deblocking).
    thresholds: Vec<f32>,
    /// Grid columns within a pixel of a vertical block edge, with lapping: `(column,
    /// own block column, neighbour block column, weight)`.
    lap_cols: Vec<(usize, usize, usize, f32)>,
    /// Per grid row within a pixel of a horizontal block edge, with lapping:
    /// `(neighbour block row, weight)`.
    lap_rows: Vec<Option<(usize, f32)>>,
}

/// Each plane's deblocking threshold, or none.
fn thresholds(detail: &Detail) -> Vec<f32> {
    match detail.deblock {
        Some(d) => detail.steps.iter().map(|&s| d.threshold(s)).collect(),
        None => Vec::new(),
    }
}

/// Block index and in-block position of coordinate `p` (pixels), clamped to the
/// blocks: positions off the image belong to its edge blocks' series.
#[inline]
fn locate(p: f64, count: usize) -> (usize, f64) {
    let b = (p / N as f64).floor().clamp(0.0, count as f64 - 1.0) as usize;
    (b, p - (b * N) as f64)
}

impl PlaneEval {
    /// One plane's coefficients (levels times `step`, the block's factor and the
    /// frequency weights) and their extents; a chroma plane's blocks with a luma factor
    /// add that times the luma block's coefficients (`luma`: the plane, its step and
    /// weights).
    fn new(
        p: &DetailPlane,
        step: f64,
        block_steps: Option<&BlockSteps>,
        weights: &WeightTable,
        luma: Option<(&DetailPlane, f64, &WeightTable)>,
    ) -> Self {
        let mut coeffs = vec![0.0f32; p.levels.len()];
        for (i, &k) in p.index.iter().enumerate() {
            if k != ZERO {
                let (at, v1, u1) = p.spans[k as usize];
                let s = step * block_steps.map_or(1.0, |b| b.factor(i));
                let (at, u1) = (at as usize, u1 as usize);
                for v in 0..v1 as usize {
                    let row = at + v * u1..at + v * u1 + u1;
                    for ((c, &q), w) in coeffs[row.clone()]
                        .iter_mut()
                        .zip(&p.levels[row])
                        .zip(&weights[0][v * N..])
                    {
                        *c = (q as f64 * s * w) as f32;
                    }
                }
            }
        }
        let mut eval = PlaneEval {
            coeffs,
            extent: p.spans.clone(),
            index: p.index.clone(),
            cols: p.cols,
        };
        // A merged group's blocks get their quadrants' coefficients, appended (its
        // first block's levels stay unused where they are).
        for i in (0..p.index.len()).filter(|&i| p.merged[i] != 0) {
            // The group is quantised with its first block's step.
            let s = step * block_steps.map_or(1.0, |b| b.factor(p.coded_block_of(i)));
            eval.replace(i, p.coefficients(i % p.cols, i / p.cols, s, weights));
        }
        // So do chroma blocks with a luma factor, their own series plus the factor
        // times luma's.
        if let Some((l, lstep, lw)) = luma {
            for i in (0..p.index.len()).filter(|&i| p.factor(i) != 0) {
                let f = block_steps.map_or(1.0, |b| b.factor(i));
                let (bx, by) = (i % p.cols, i / p.cols);
                let Some(l) = l.coefficients(bx, by, lstep * f, lw) else {
                    continue;
                };
                eval.replace(
                    i,
                    Some(plus_luma(
                        p.coefficients(bx, by, step * f, weights),
                        p.factor(i),
                        &l,
                    )),
                );
            }
        }
        eval
    }

    /// Block `i`'s coefficients become `c` (none: all zero), appended.
    fn replace(&mut self, i: usize, c: Option<[f64; COEFFS]>) {
        let Some(c) = c else {
            self.index[i] = ZERO;
            return;
        };
        let v1 = (0..N)
            .rev()
            .find(|&v| c[v * N..v * N + N].iter().any(|&x| x != 0.0))
            .map_or(0, |v| v + 1);
        let u1 = (0..N)
            .rev()
            .find(|&u| (0..N).any(|v| c[v * N + u] != 0.0))
            .map_or(0, |u| u + 1);
        if v1 == 0 {
            self.index[i] = ZERO;
            return;
        }
        self.index[i] = self.extent.len() as u32;
        self.extent
            .push((self.coeffs.len() as u32, v1 as u8, u1 as u8));
        for v in 0..v1 {
            self.coeffs
                .extend(c[v * N..v * N + u1].iter().map(|&x| x as f32));
        }
    }
}

impl DetailEval {
    /// Prepares `detail` for evaluation at the positions of `grid` (coded pixels).
    pub fn new(detail: &Detail, grid: &Grid) -> Self {
        let (cols, rows) = detail.planes.first().map_or((1, 1), |p| (p.cols, p.rows));
        let mut eval = DetailEval::geometry(cols, rows, grid, detail.deblock, detail.lapping);
        eval.thresholds = thresholds(detail);
        let tables = weights::plane_tables(detail.weights, detail.planes.len());
        eval.planes = detail
            .planes
            .iter()
            .enumerate()
            .map(|(pi, p)| {
                let luma = (pi > 0).then(|| (&detail.planes[0], detail.steps[0], &tables[0]));
                PlaneEval::new(
                    p,
                    detail.steps[pi],
                    detail.block_steps.as_ref(),
                    &tables[pi],
                    luma,
                )
            })
            .collect();
        eval
    }

    /// [`DetailEval::new`] taking the layer, each plane's levels freed as soon as its
    /// coefficients are made: the decoder's peak holds one plane's levels, not all.
    pub fn from_layer(detail: Detail, grid: &Grid) -> Self {
        let (cols, rows) = detail.planes.first().map_or((1, 1), |p| (p.cols, p.rows));
        let mut eval = DetailEval::geometry(cols, rows, grid, detail.deblock, detail.lapping);
        eval.thresholds = thresholds(&detail);
        let tables = weights::plane_tables(detail.weights, detail.planes.len());
        let mut planes = detail.planes.into_iter();
        let Some(luma) = planes.next() else {
            return eval;
        };
        let (steps, block_steps) = (detail.steps, detail.block_steps.as_ref());
        eval.planes.push(PlaneEval::new(
            &luma,
            steps[0],
            block_steps,
            &tables[0],
            None,
        ));
        // Chroma's luma factors need the luma levels: those are freed last.
        for (pi, p) in planes.enumerate().map(|(k, p)| (k + 1, p)) {
            let l = Some((&luma, steps[0], &tables[0]));
            eval.planes
                .push(PlaneEval::new(&p, steps[pi], block_steps, &tables[pi], l));
        }
        eval
    }

    /// The evaluation geometry of `cols x rows` blocks on `grid`, without planes.
    fn geometry(
        cols: usize,
        rows: usize,
        grid: &Grid,
        deblock: Option<Deblock>,
        lapping: Option<Lapping>,
    ) -> Self {
        // Grid positions increase, so each block column covers a contiguous run.
        let mut columns = vec![(0usize, 0usize, 0usize); cols];
        let mut per_column: Vec<Vec<[f32; N]>> = vec![Vec::new(); cols];
        for i in 0..grid.nx {
            let (b, t) = locate(grid.x(i), cols);
            if per_column[b].is_empty() {
                columns[b].0 = i;
            }
            per_column[b].push(dct::basis_at(t));
        }
        let mut basis_t = Vec::with_capacity(grid.nx * N);
        for (c, basis) in columns.iter_mut().zip(&per_column) {
            c.1 = basis.len();
            c.2 = basis_t.len();
            for u in 0..N {
                basis_t.extend(basis.iter().map(|b| b[u]));
            }
        }
        let rows_basis = (0..grid.ny)
            .map(|j| {
                let (b, t) = locate(grid.y(j), rows);
                (b, dct::basis_at(t))
            })
            .collect();
        let r = deblock.map_or(0.0, Deblock::radius_px);
        let vcols = (0..grid.nx)
            .filter_map(|i| edge_weight(grid.x(i), cols, r).map(|(e, w)| (i, e, w)))
            .collect();
        let hrows = (0..grid.ny)
            .map(|j| edge_weight(grid.y(j), rows, r))
            .collect();
        let (lap_cols, lap_rows) = match lapping {
            Some(l) => (
                (0..grid.nx)
                    .filter_map(|i| l.at(grid.x(i), cols).map(|(own, nb, w)| (i, own, nb, w)))
                    .collect(),
                (0..grid.ny)
                    .map(|j| l.at(grid.y(j), rows).map(|(_, nb, w)| (nb, w)))
                    .collect(),
            ),
            None => (Vec::new(), vec![None; grid.ny]),
        };
        DetailEval {
            grid: *grid,
            planes: Vec::new(),
            columns,
            basis_t,
            rows: rows_basis,
            vcols,
            hrows,
            thresholds: Vec::new(),
            lap_cols,
            lap_rows,
        }
    }

    /// Adds the layer to grid rows `j0..j0 + n`: `out[c]` holds plane `c`'s rows, `n`
    /// rows of the grid's width each.
    pub fn add_rows(&self, j0: usize, out: &mut [&mut [f32]]) {
        let nx = self.grid.nx;
        for (pi, (p, plane)) in self.planes.iter().zip(out.iter_mut()).enumerate() {
            if p.extent.is_empty() {
                continue;
            }
            let t = self.thresholds.get(pi).copied().unwrap_or(0.0);
            let mut el = vec![0f32; p.cols];
            let mut er = vec![0f32; p.cols];
            let mut delta = vec![0f32; nx];
            let lapped = !self.lap_cols.is_empty();
            // Per block column, the row of its (lapped) series at this y.
            let mut gs = vec![[0f32; N]; if lapped { p.cols } else { 0 }];
            let corner = |i: u32| {
                let (at, v1, u1) = p.extent[i as usize];
                let (v1, u1) = (v1 as usize, u1 as usize);
                (&p.coeffs[at as usize..at as usize + v1 * u1], v1, u1)
            };
            for (r, row) in plane.chunks_exact_mut(nx).enumerate() {
                let (by, bv) = self.rows[j0 + r];
                let lap_row = self.lap_rows[j0 + r];
                el.fill(0.0);
                er.fill(0.0);
                for bx in 0..p.cols {
                    let i = p.index[by * p.cols + bx];
                    let (c0, n, start) = self.columns[bx];
                    // The block's row of the series at this y: g(u) = sum_v C[v][u] b_v(y).
                    let mut g = [0f32; N];
                    let mut width = 0;
                    if i != ZERO {
                        let (c, v1, u1) = corner(i);
                        for v in 0..v1 {
                            let b = bv[v];
                            for u in 0..u1 {
                                g[u] += c[v * u1 + u] * b;
                            }
                        }
                        if t > 0.0 {
                            // The row's values at the block's left and right edges.
                            for (u, &gu) in g.iter().enumerate().take(u1) {
                                el[bx] += gu * edge_basis(u, false);
                                er[bx] += gu * edge_basis(u, true);
                            }
                        }
                        width = u1;
                    }
                    if let Some((nb, w)) = lap_row {
                        // Towards the series of the block across the edge at the mirror
                        // position: its rows with odd v negated, at this y.
                        for gu in g.iter_mut().take(width) {
                            *gu *= 1.0 - w;
                        }
                        let k = p.index[nb * p.cols + bx];
                        if k != ZERO {
                            let (c, v1, u1) = corner(k);
                            for v in 0..v1 {
                                let b = if v % 2 == 1 { -w * bv[v] } else { w * bv[v] };
                                for u in 0..u1 {
                                    g[u] += c[v * u1 + u] * b;
                                }
                            }
                            width = width.max(u1);
                        }
                    }
                    if lapped {
                        gs[bx] = g;
                    }
                    if width == 0 || n == 0 {
                        continue;
                    }
                    let out = &mut row[c0..c0 + n];
                    for (u, &gu) in g.iter().enumerate().take(width) {
                        let basis = &self.basis_t[start + u * n..start + (u + 1) * n];
                        for (o, &b) in out.iter_mut().zip(basis) {
                            *o += gu * b;
                        }
                    }
                }
                for &(i, own, nb, w) in &self.lap_cols {
                    // Towards the neighbour's row at the mirror position: its odd
                    // columns negated, with this column's basis.
                    let (c0, n, start) = self.columns[own];
                    let (a, b) = (&gs[own], &gs[nb]);
                    let mut d = 0.0;
                    for u in 0..N {
                        let m = if u % 2 == 1 { -b[u] } else { b[u] };
                        d += (m - a[u]) * self.basis_t[start + u * n + i - c0];
                    }
                    row[i] += w * d;
                }
                if t <= 0.0 {
                    continue;
                }
                for &(i, e, w) in &self.vcols {
                    row[i] += w * gate(el[e] - er[e - 1], t);
                }
                if let Some((e, w)) = self.hrows[j0 + r] {
                    delta.fill(0.0);
                    for bx in 0..p.cols {
                        let (c0, n, start) = self.columns[bx];
                        if n == 0 {
                            continue;
                        }
                        let mut h = [0f32; N];
                        let below = p.index[e * p.cols + bx];
                        let above = p.index[(e - 1) * p.cols + bx];
                        if below == ZERO && above == ZERO {
                            continue;
                        }
                        // The step's series along x: the block below at its top edge
                        // minus the block above at its bottom edge.
                        for (idx, above) in [(below, false), (above, true)] {
                            if idx == ZERO {
                                continue;
                            }
                            let (at, v1, u1) = p.extent[idx as usize];
                            let (v1, u1) = (v1 as usize, u1 as usize);
                            let c = &p.coeffs[at as usize..at as usize + v1 * u1];
                            for v in 0..v1 {
                                let b = edge_basis(v, above);
                                let b = if above { -b } else { b };
                                for u in 0..u1 {
                                    h[u] += c[v * u1 + u] * b;
                                }
                            }
                        }
                        let out = &mut delta[c0..c0 + n];
                        for (u, &hu) in h.iter().enumerate() {
                            if hu == 0.0 {
                                continue;
                            }
                            let basis = &self.basis_t[start + u * n..start + (u + 1) * n];
                            for (o, &b) in out.iter_mut().zip(basis) {
                                *o += hu * b;
                            }
                        }
                    }
                    for (o, &d) in row.iter_mut().zip(&delta) {
                        *o += w * gate(d, t);
                    }
                }
            }
        }
    }
    /// The layer on the whole grid, one plane per channel (for the forward path).
    pub fn eval(&self) -> Vec<Vec<f32>> {
        let n = self.grid.nx * self.grid.ny;
        let mut planes = vec![vec![0f32; n]; self.planes.len()];
        {
            let mut out: Vec<&mut [f32]> = planes.iter_mut().map(|p| p.as_mut_slice()).collect();
            self.add_rows(0, &mut out);
        }
        planes
    }
}
