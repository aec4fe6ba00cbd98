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
pub mod budget;
pub mod context_tables;
pub mod dct;
pub mod deblock;
mod eval;
pub mod field;
pub mod lapping;
mod plane;
pub mod syntax;
pub mod weights;

pub use eval::DetailEval;
pub use plane::{factor_context, luma_predicts, DetailPlane};

use adaptive::BlockSteps;
use budget::LayerBudget;
use dct::{COEFFS, N};
use deblock::Deblock;
use field::ActivityField;
use lapping::Lapping;
use weights::FrequencyWeights;

use super::entropy::{AnsSink, AnsSource};
use super::varint;
use super::CodecError;
use syntax::{BlockContext, DetailContexts, GroupContext, Summary, GROUP_LEVELS};

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
    /// luma stream's byte count (LEB128), the luma stream, the chroma stream. Returns
    /// the layer and the luma and the chroma stream's contexts as each ends.
    pub fn read(
        payload: &[u8],
        width: u32,
        height: u32,
        steps: Vec<f64>,
        classes: &[u8],
        field_log2: Option<u8>,
    ) -> Result<(Self, [DetailContexts; 2]), CodecError> {
        let unlimited = LayerBudget::unlimited();
        Detail::read_within(
            payload, width, height, steps, classes, field_log2, &unlimited,
        )
    }

    /// [`Detail::read`] with the planes' levels taken from `budget` as they grow.
    pub fn read_within(
        payload: &[u8],
        width: u32,
        height: u32,
        steps: Vec<f64>,
        classes: &[u8],
        field_log2: Option<u8>,
        budget: &LayerBudget,
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
                        (cols, rows),
                        classes,
                        kind,
                        luma.map(|l| (l, c)),
                        &mut ctx,
                        &mut src,
                        budget,
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

    /// Bytes per block and plane the decoder holds besides levels and coefficients
    /// (each block's index, group and factor, in a tile's plane, the image's and the
    /// evaluator's), for memory estimates made before the layer is read.
    pub const BYTES_PER_BLOCK: u64 = 3 * 4 + 2 * 2;
}
