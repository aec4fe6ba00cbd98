//! The coded syntax: quadtree split flags and key-point values on adaptive contexts
//! (see `docs/format.md`, "Tree syntax" and "Value syntax").

use super::entropy::{AnsSource, BinModel, Cdf, SymbolSink, MAX_RAW_BITS};
use super::quadtree::{Cell, TreeShape};
use super::CodecError;

/// Split-flag contexts: levels below the root (0..4) x split neighbours (0..=2).
const TREE_LEVELS: usize = 4;
/// Split flags adapt from rate 2^-1: a tree section is often only a few dozen flags.
const SPLIT_START: u8 = 1;

/// Adaptive contexts of the split flags.
#[derive(Clone)]
pub struct TreeContexts {
    split: [[BinModel; 3]; TREE_LEVELS],
}

impl Default for TreeContexts {
    fn default() -> Self {
        TreeContexts {
            split: [[BinModel::new(SPLIT_START); 3]; TREE_LEVELS],
        }
    }
}

/// Walks the tree in coding order; `flag(cell, (level, neighbours), model)` codes or
/// decodes the split flag of each node above the minimum size with its context's model.
/// Returns the leaves in coding order.
///
/// The context counts the same-size nodes left of and above a node that were split. In
/// Z order, every leaf coded before a node that covers the node's top row lies left of
/// it, and the last of them holds pixel `(x0-1, y0)`; the same-size left node was split
/// exactly when that leaf is smaller than the node (likewise above, by columns). So the
/// walk keeps only the size of the last leaf per pixel row and per pixel column.
fn walk_tree<E, F>(shape: &TreeShape, expected_leaves: usize, flag: F) -> Result<Vec<Cell>, E>
where
    F: FnMut(&Cell, (usize, usize), &mut BinModel) -> Result<bool, E>,
{
    let mut walk = TreeWalk {
        shape: *shape,
        ctx: TreeContexts::default(),
        // u16, not u8: byte fills become memset calls, whose stores the next context
        // load cannot forward from.
        // Padded to whole root blocks: a leaf then marks all its rows and columns
        // without clipping (entries past the image are never read).
        row: vec![u16::MAX; padded(shape.height, shape.block_log2)],
        col: vec![u16::MAX; padded(shape.width, shape.block_log2)],
        // Sized up front (growing by doubling costs copies and page faults), but no
        // further than a corrupt count could make expensive.
        leaves: Vec::with_capacity(expected_leaves.min(1 << 20)),
        flag,
    };
    for root in shape.roots() {
        walk.visit(root)?;
    }
    Ok(walk.leaves)
}

struct TreeWalk<F> {
    shape: TreeShape,
    ctx: TreeContexts,
    /// Size (log2) of the last leaf covering each pixel row, and column.
    row: Vec<u16>,
    col: Vec<u16>,
    leaves: Vec<Cell>,
    flag: F,
}

impl<F> TreeWalk<F> {
    fn visit<E>(&mut self, c: Cell) -> Result<(), E>
    where
        F: FnMut(&Cell, (usize, usize), &mut BinModel) -> Result<bool, E>,
    {
        let shape = self.shape;
        let (x0, y0, size) = (c.x0 as usize, c.y0 as usize, c.log2 as u16);
        if c.log2 > shape.min_log2 {
            let n = usize::from(x0 > 0 && self.row[y0] < size)
                + usize::from(y0 > 0 && self.col[x0] < size);
            let level = ((shape.block_log2 - c.log2) as usize).min(TREE_LEVELS - 1);
            if (self.flag)(&c, (level, n), &mut self.ctx.split[level][n])? {
                let [a, b, d, e] = c.children();
                if a.log2 == shape.min_log2 {
                    // Children without flags of their own: all leaves, of one size, so
                    // one mark over the node does for the four.
                    self.leaves.push(a);
                    if shape.inside(&b) {
                        self.leaves.push(b);
                    }
                    if shape.inside(&d) {
                        self.leaves.push(d);
                        if shape.inside(&e) {
                            self.leaves.push(e);
                        }
                    }
                    self.mark(&c, a.log2 as u16);
                } else {
                    self.visit(a)?;
                    if shape.inside(&b) {
                        self.visit(b)?;
                    }
                    if shape.inside(&d) {
                        self.visit(d)?;
                        if shape.inside(&e) {
                            self.visit(e)?;
                        }
                    }
                }
                return Ok(());
            }
        }
        self.leaf(c);
        Ok(())
    }

    #[inline]
    fn leaf(&mut self, c: Cell) {
        self.leaves.push(c);
        self.mark(&c, c.log2 as u16);
    }

    /// Records `size` as the last leaf size over the rows and columns of `c`.
    #[inline(always)]
    fn mark(&mut self, c: &Cell, size: u16) {
        fill_pow2(&mut self.row, c.y0 as usize, c.log2, size);
        fill_pow2(&mut self.col, c.x0 as usize, c.log2, size);
    }
}

/// `n` rounded up to whole blocks of `2^block_log2`.
fn padded(n: u32, block_log2: u8) -> usize {
    (n as usize).div_ceil(1 << block_log2) << block_log2
}

/// Sets the `2^log2` entries from `start`; the usual lengths are constants, so their
/// stores are a few straight-line moves instead of a loop.
#[inline(always)]
fn fill_pow2(v: &mut [u16], start: usize, log2: u8, value: u16) {
    match log2 {
        0 => v[start] = value,
        1 => v[start..start + 2].fill(value),
        2 => v[start..start + 4].fill(value),
        3 => v[start..start + 8].fill(value),
        4 => v[start..start + 16].fill(value),
        _ => v[start..start + (1 << log2)].fill(value),
    }
}

/// Codes the split flags of the tree whose split nodes satisfy `is_split`; returns
/// the leaves in coding order.
pub fn write_tree(
    shape: &TreeShape,
    is_split: impl Fn(&Cell) -> bool,
    sink: &mut impl SymbolSink,
) -> Vec<Cell> {
    let leaves = walk_tree(shape, 0, |c, _, m| {
        let split = is_split(c);
        sink.bin(m, split);
        Ok::<_, std::convert::Infallible>(split)
    });
    match leaves {
        Ok(leaves) => leaves,
        Err(never) => match never {},
    }
}

/// Decodes the split flags of a tree expected to have `expected_leaves` leaves (a
/// capacity hint); returns the leaves in coding order.
pub fn read_tree(
    shape: &TreeShape,
    expected_leaves: usize,
    src: &mut AnsSource,
) -> Result<Vec<Cell>, CodecError> {
    walk_tree(shape, expected_leaves, |_, _, m| src.bin(m))
}

/// Marks an absent neighbour.
const NONE: u32 = u32::MAX;

/// Causal neighbours of each key point (above, left, above-left), as key point indices
/// earlier in coding order: the prediction and context of its values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Neighbours {
    above: u32,
    left: u32,
    above_left: u32,
}

impl Neighbours {
    fn get(i: u32) -> Option<u32> {
        (i != NONE).then_some(i)
    }
}

/// Finds the causal neighbours of every cell (Z order makes all three precede it).
///
/// In Z order, any two cells that share a pixel column are coded top first, and any two
/// that share a pixel row left first. So, before cell `c` is coded, the last coded cell
/// covering column `x` of `c` is the one just above `c` there, and the last covering row
/// `y` of `c` the one just left of it: one owner per column and per row replaces a
/// per-pixel owner map. The above-left pixel `(x0-1, y0-1)` lies just above the left
/// neighbour's right column at row `y0`: it is that neighbour itself unless the
/// neighbour starts at row `y0`, and then it is the owner found above the neighbour's
/// top-right pixel when the neighbour was coded, which each row keeps beside its last
/// cell.
pub fn neighbours(cells: &[Cell], width: u32, height: u32) -> Vec<Neighbours> {
    let mut walk = NeighbourWalk::new(width, height);
    cells.iter().map(|c| walk.next(c)).collect()
}

/// [`neighbours`] one cell at a time, so a decoder can find them inside its value loop
/// (the bookkeeping then overlaps the entropy decoder's latency).
pub struct NeighbourWalk {
    width: u32,
    height: u32,
    /// Per column: the last coded cell covering it.
    col: Vec<u32>,
    /// Per row: the last coded cell covering it, and the owner of the pixel just above
    /// that cell's right column in this row.
    row: Vec<(u32, u32)>,
    /// Index of the next cell.
    next: u32,
}

impl NeighbourWalk {
    /// A walk over a `width x height` image's cells.
    pub fn new(width: u32, height: u32) -> Self {
        NeighbourWalk {
            width,
            height,
            col: vec![NONE; width as usize],
            row: vec![(NONE, NONE); height as usize],
            next: 0,
        }
    }

    /// The neighbours of `c`, the next cell in coding order.
    #[inline(always)]
    pub fn next(&mut self, c: &Cell) -> Neighbours {
        let i = self.next;
        self.next += 1;
        let (x0, y0) = (c.x0 as usize, c.y0 as usize);
        let mut nb = Neighbours {
            above: NONE,
            left: NONE,
            above_left: NONE,
        };
        if x0 > 0 {
            (nb.left, nb.above_left) = self.row[y0];
        }
        // Single-pixel cells dominate at high rates: no clipping, no fill loops.
        if c.log2 == 0 {
            if y0 > 0 {
                nb.above = self.col[x0];
            }
            self.col[x0] = i;
            self.row[y0] = (i, nb.above);
            return nb;
        }
        let (_, _, x1, y1) = c.clip(self.width, self.height);
        let (x1, y1) = (x1 as usize, y1 as usize);
        let above_right = if y0 > 0 {
            nb.above = self.col[(x0 + x1 - 1) / 2];
            self.col[x1 - 1]
        } else {
            NONE
        };
        if x0 > 0 {
            nb.left = self.row[(y0 + y1 - 1) / 2].0;
        }
        // Cells span at most 2^7 pixels: plain loops beat `fill`'s set-up.
        for o in &mut self.col[x0..x1] {
            *o = i;
        }
        self.row[y0] = (i, above_right);
        for o in &mut self.row[y0 + 1..y1] {
            *o = (i, i);
        }
        nb
    }
}

/// Values beyond this magnitude are rejected by the decoder (no file needs them).
pub const MAX_VALUE: i64 = 1 << 24;
/// Residual magnitudes `0..LITERALS` are tokens of their own; token `LITERALS` escapes.
const LITERALS: usize = 8;
const TOKENS: usize = LITERALS + 1;
/// A token model: its 8 boundaries fill two 64-bit words.
type TokenCdf = Cdf<2>;
/// Escape classes: the bit length minus one of `|r| - LITERALS + 1`, which is at most
/// `2^25 - 7` since values and predictions lie in `[-2^24, 2^24]`.
const CLASSES: usize = 25;
type ClassCdf = Cdf<6>;
const SIZE_CLASSES: usize = 5;
const ACTIVITY: usize = 3;

/// Initial token distributions per activity class: geometric, ratio 0.2, 0.4 and 0.6
/// (flat regions are mostly zeros), with the floor (`docs/format.md` lists them).
const TOKEN_INIT: [[u16; TOKENS - 1]; ACTIVITY] = [
    [26190, 31431, 32482, 32696, 32742, 32754, 32760, 32764],
    [19648, 27510, 30657, 31918, 32425, 32630, 32715, 32751],
    [13230, 21170, 25935, 28796, 30514, 31547, 32168, 32542],
];
/// Initial escape class distribution: geometric, ratio 0.7, with the floor.
const CLASS_INIT: [u16; CLASSES - 1] = [
    9806, 16671, 21478, 24844, 27201, 28853, 30010, 30821, 31390, 31789, 32070, 32268, 32408,
    32507, 32577, 32628, 32664, 32691, 32711, 32726, 32738, 32748, 32755, 32762,
];

/// Adaptive contexts of one channel's values.
#[derive(Clone)]
pub struct ValueContexts {
    token: [[TokenCdf; ACTIVITY]; SIZE_CLASSES],
    class: [ClassCdf; SIZE_CLASSES],
}

impl Default for ValueContexts {
    fn default() -> Self {
        let token = [
            Cdf::new(&TOKEN_INIT[0]),
            Cdf::new(&TOKEN_INIT[1]),
            Cdf::new(&TOKEN_INIT[2]),
        ];
        ValueContexts {
            token: [token; SIZE_CLASSES],
            class: [Cdf::new(&CLASS_INIT); SIZE_CLASSES],
        }
    }
}

/// How a key point's quantiser step follows its cell size: with level steps, a cell
/// of side `2^l` under roots of side `2^root_log2` has `2^(root_log2 - l)` times the
/// channel's step (the header's step is the roots' step), so a value of `q` steps is
/// `q << shift` in root steps, the unit neighbours are predicted in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelSteps {
    /// Root block side, log2.
    pub root_log2: u8,
    /// Whether the step grows with smaller cells (else one step for all).
    pub on: bool,
}

impl LevelSteps {
    /// One step for every cell.
    pub const FLAT: LevelSteps = LevelSteps {
        root_log2: 0,
        on: false,
    };

    /// The cell's step in root steps, log2.
    #[inline]
    pub fn shift(&self, c: &Cell) -> u32 {
        if self.on {
            u32::from(self.root_log2.saturating_sub(c.log2))
        } else {
            0
        }
    }

    /// The cell's step for a channel whose roots have step `root_step`.
    #[inline]
    pub fn step(&self, c: &Cell, root_step: f64) -> f64 {
        root_step * (1u32 << self.shift(c)) as f64
    }

    /// Quantised values of `cells` times their steps: the values a decoder reads.
    pub fn dequantise(&self, cells: &[Cell], q: &[i64], root_step: f64) -> Vec<f64> {
        q.iter()
            .zip(cells)
            .map(|(&v, c)| v as f64 * self.step(c, root_step))
            .collect()
    }
}

/// `v / 2^k` rounded to nearest (halves up).
#[inline]
fn round_shift(v: i64, k: u32) -> i64 {
    if k == 0 {
        v
    } else {
        (v + (1 << (k - 1))) >> k
    }
}

/// Prediction and activity class of a key point of step shift `shift` from already
/// coded values in root steps (`scaled`): the prediction in the key point's own steps,
/// clamped to the value range.
#[inline]
pub fn predict(scaled: &[i64], nb: &Neighbours, previous: i64, shift: u32) -> (i64, usize) {
    let own = |v: i64| round_shift(v, shift).clamp(-MAX_VALUE, MAX_VALUE);
    // An above-left neighbour exists exactly when above and left do (the cell is off
    // the top and left borders): one test for the common case.
    if nb.above_left != NONE {
        let (a, l, al) = (
            scaled[nb.above as usize],
            scaled[nb.left as usize],
            scaled[nb.above_left as usize],
        );
        // LOCO-I's median edge detector, as the median of a, l and a + l - al
        // (min/max instead of branches: the comparisons are data, not patterns).
        let pred = a.min(l).max(a.max(l).min(a + l - al));
        let act = ((a - al).abs() + (l - al).abs()) >> shift;
        return (own(pred), usize::from(act > 0) + usize::from(act > 3));
    }
    match (Neighbours::get(nb.above), Neighbours::get(nb.left)) {
        (Some(v), _) | (None, Some(v)) => (own(scaled[v as usize]), 1),
        (None, None) => (own(previous), 2),
    }
}

fn size_class(c: &Cell) -> usize {
    (c.log2 as usize).min(SIZE_CLASSES - 1)
}

/// Codes one value's residual `r`: token `min(|r|, LITERALS)` in context (size,
/// activity) with the sign of a nonzero `r` in the same step (signs are near even:
/// modelling them saved 0.1% and cost a second coder step per value), and for
/// escapes the escape class in context size followed by the class's raw bits.
pub fn write_residual(
    ctx: &mut ValueContexts,
    size: usize,
    act: usize,
    r: i64,
    sink: &mut impl SymbolSink,
) {
    let mag = r.unsigned_abs();
    let token = (mag as usize).min(LITERALS);
    sink.signed_symbol(&mut ctx.token[size][act], token, r < 0);
    if token == LITERALS {
        let v = mag - LITERALS as u64 + 1;
        let class = 63 - v.leading_zeros();
        sink.symbol(&mut ctx.class[size], class as usize);
        // The class's bits below the leading one, high part first.
        let rest = v - (1 << class);
        if class > MAX_RAW_BITS {
            sink.raw((rest >> MAX_RAW_BITS) as u32, class - MAX_RAW_BITS);
        }
        if class > 0 {
            let low = class.min(MAX_RAW_BITS);
            sink.raw((rest & ((1 << low) - 1)) as u32, low);
        }
    }
}

/// Reads one residual.
// Always: the value loops are the decoder's hot path, and a call per value costs.
#[inline(always)]
pub fn read_residual(
    ctx: &mut ValueContexts,
    size: usize,
    act: usize,
    src: &mut AnsSource,
) -> Result<i64, CodecError> {
    let (token, negative) = src.signed_symbol(&mut ctx.token[size][act])?;
    let mag = if token < LITERALS {
        token as i64
    } else {
        let class = src.symbol(&mut ctx.class[size])? as u32;
        let mut rest = 0u64;
        if class > MAX_RAW_BITS {
            rest = (src.raw(class - MAX_RAW_BITS)? as u64) << MAX_RAW_BITS;
        }
        if class > 0 {
            rest |= src.raw(class.min(MAX_RAW_BITS))? as u64;
        }
        // Below 2^25 + 2^25: no overflow; the caller's range check rejects the excess.
        ((1u64 << class) + rest) as i64 + LITERALS as i64 - 1
    };
    // Branch-free negation: the sign is a coin toss for the predictor.
    let flip = -i64::from(negative);
    Ok((mag ^ flip) - flip)
}

/// Codes the quantised values of one channel over a key-point set (each in its own
/// steps, as `levels` sets them).
pub fn write_values(
    cells: &[Cell],
    nbs: &[Neighbours],
    values: &[i64],
    levels: LevelSteps,
    sink: &mut impl SymbolSink,
) {
    let mut ctx = ValueContexts::default();
    let mut scaled = vec![0i64; values.len()];
    let mut previous = 0;
    for (i, c) in cells.iter().enumerate() {
        let shift = levels.shift(c);
        let (pred, act) = predict(&scaled, &nbs[i], previous, shift);
        write_residual(&mut ctx, size_class(c), act, values[i] - pred, sink);
        scaled[i] = values[i] << shift;
        previous = scaled[i];
    }
}

/// Reads the value of cell `c` (of step shift `shift`) from its prediction and
/// residual, range-checked.
// Always: the value loops are the decoder's hot path.
#[inline(always)]
fn read_value(
    ctx: &mut ValueContexts,
    c: &Cell,
    shift: u32,
    nb: &Neighbours,
    scaled: &[i64],
    previous: i64,
    src: &mut AnsSource,
) -> Result<i64, CodecError> {
    let (pred, act) = predict(scaled, nb, previous, shift);
    let v = pred + read_residual(ctx, size_class(c), act, src)?;
    if v.abs() > MAX_VALUE {
        return Err(CodecError::range(
            "key point value",
            v as f64,
            -MAX_VALUE as f64,
            MAX_VALUE as f64,
        ));
    }
    Ok(v)
}

/// Reads the quantised values of one channel (each in its own steps).
pub fn read_values(
    cells: &[Cell],
    nbs: &[Neighbours],
    levels: LevelSteps,
    src: &mut AnsSource,
) -> Result<Vec<i64>, CodecError> {
    let mut ctx = ValueContexts::default();
    let mut values = vec![0i64; cells.len()];
    let mut scaled = vec![0i64; cells.len()];
    let mut previous = 0;
    for (i, c) in cells.iter().enumerate() {
        let shift = levels.shift(c);
        let v = read_value(&mut ctx, c, shift, &nbs[i], &scaled, previous, src)?;
        values[i] = v;
        scaled[i] = v << shift;
        previous = scaled[i];
    }
    Ok(values)
}

/// Reads the quantised values of `channels` channels over `cells` of a
/// `width x height` image, finding the neighbours during the first channel.
pub fn read_channels(
    cells: &[Cell],
    width: u32,
    height: u32,
    channels: usize,
    levels: LevelSteps,
    src: &mut AnsSource,
) -> Result<Vec<Vec<i64>>, CodecError> {
    let mut out = Vec::with_capacity(channels);
    if channels == 0 {
        return Ok(out);
    }
    let mut walk = NeighbourWalk::new(width, height);
    let mut nbs = Vec::with_capacity(if channels > 1 { cells.len() } else { 0 });
    let mut ctx = ValueContexts::default();
    let mut values = vec![0i64; cells.len()];
    let mut scaled = vec![0i64; cells.len()];
    let mut previous = 0;
    for (i, c) in cells.iter().enumerate() {
        let nb = walk.next(c);
        if channels > 1 {
            nbs.push(nb);
        }
        let shift = levels.shift(c);
        let v = read_value(&mut ctx, c, shift, &nb, &scaled, previous, src)?;
        values[i] = v;
        scaled[i] = v << shift;
        previous = scaled[i];
    }
    out.push(values);
    for _ in 1..channels {
        out.push(read_values(cells, &nbs, levels, src)?);
    }
    Ok(out)
}

/// Most symbols one value can take (signed token, escape class, two raw-bit chunks).
pub const MAX_SYMBOLS_PER_VALUE: u64 = 4;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entropy::{AnsSink, CostSink, CDF_FLOOR, CDF_ONE};
    use crate::quadtree::{pruned_one_level, random_tree};

    /// The split-flag contexts by their definition: per level, a map of which visited
    /// nodes were split.
    fn tree_contexts_by_split_maps(
        shape: &TreeShape,
        leaves: &[Cell],
    ) -> Vec<(Cell, (usize, usize))> {
        let leaf_set: std::collections::HashSet<Cell> = leaves.iter().copied().collect();
        let mut maps: Vec<(u32, Vec<u8>)> = (0..=shape.block_log2)
            .map(|l| {
                let cols = shape.width.div_ceil(1 << l) + 1;
                let rows = shape.height.div_ceil(1 << l) + 1;
                (cols, vec![0u8; (cols * rows) as usize])
            })
            .collect();
        let mut out = Vec::new();
        shape.walk(|c| {
            let (cols, map) = &mut maps[c.log2 as usize];
            let (i, j) = (c.x0 >> c.log2, c.y0 >> c.log2);
            let split_at = |i: u32, j: u32| map[(j * *cols + i) as usize] == 2;
            let n =
                usize::from(i > 0 && split_at(i - 1, j)) + usize::from(j > 0 && split_at(i, j - 1));
            let level = ((shape.block_log2 - c.log2) as usize).min(TREE_LEVELS - 1);
            out.push((*c, (level, n)));
            let split = !leaf_set.contains(c);
            map[(j * *cols + i) as usize] = if split { 2 } else { 1 };
            split
        });
        out
    }

    /// Random trees from sparse to dense (splitting where a draw is below `num` of 5),
    /// over odd, degenerate and whole-block sizes: `(width, height, shape, leaves)`.
    fn test_trees() -> impl Iterator<Item = (u32, u32, TreeShape, Vec<Cell>)> {
        [
            (37, 21, 1u32, 2u32),
            (64, 64, 2, 1),
            (64, 64, 2, 3),
            (5, 3, 3, 2),
            (100, 17, 4, 3),
            (1, 1, 5, 2),
            (129, 70, 6, 2),
            (48, 80, 7, 4),
        ]
        .into_iter()
        .map(|(w, h, seed, num)| {
            let (shape, leaves) = random_tree(w, h, seed, |d| d % 5 < num);
            (w, h, shape, leaves)
        })
    }

    #[test]
    fn tree_contexts_match_the_split_maps() {
        for (w, h, shape, leaves) in test_trees() {
            let leaf_set: std::collections::HashSet<Cell> = leaves.iter().copied().collect();
            let mut got = Vec::new();
            let walked = walk_tree(&shape, 0, |c, ctx, _| {
                got.push((*c, ctx));
                Ok::<_, ()>(!leaf_set.contains(c))
            })
            .unwrap();
            assert_eq!(walked, leaves);
            assert_eq!(got, tree_contexts_by_split_maps(&shape, &leaves), "{w}x{h}");
            let mut sink = AnsSink::new();
            assert_eq!(
                write_tree(&shape, |c| !leaf_set.contains(c), &mut sink),
                leaves
            );
            let bytes = sink.finish();
            let mut src = AnsSource::new(&bytes, got.len() as u64).unwrap();
            assert_eq!(read_tree(&shape, 1, &mut src).unwrap(), leaves);
            assert!(src.finished_cleanly());
        }
    }

    #[test]
    fn corrupt_payloads_give_errors_or_bounded_results() {
        let (shape, cells) = random_tree(61, 37, 9, |d| d % 5 < 3);
        let nbs = neighbours(&cells, 61, 37);
        let mut k = 7u32;
        for words in [0usize, 1, 2, 3, 5, 17, 200] {
            for _ in 0..20 {
                let bytes: Vec<u8> = (0..words * 4)
                    .map(|_| {
                        k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
                        (k >> 16) as u8
                    })
                    .collect();
                let budget = MAX_SYMBOLS_PER_VALUE * cells.len() as u64;
                for on in [false, true] {
                    let levels = LevelSteps {
                        root_log2: shape.block_log2,
                        on,
                    };
                    if let Ok(mut src) = AnsSource::new(&bytes, budget) {
                        if let Ok(values) = read_values(&cells, &nbs, levels, &mut src) {
                            assert!(values.iter().all(|v| v.abs() <= MAX_VALUE));
                        }
                    }
                }
                if let Ok(mut src) = AnsSource::new(&bytes, 10_000) {
                    if let Ok(leaves) = read_tree(&shape, 0, &mut src) {
                        assert!(leaves.len() as u64 <= shape.max_leaves());
                    }
                }
            }
        }
        // A payload ending in a zero word is not one any encoder writes.
        assert!(AnsSource::new(&[1, 0, 0, 0, 0, 0, 0, 0], 10).is_err());
        assert!(AnsSource::new(&[1, 2, 3], 10).is_err());
    }

    #[test]
    fn initial_tables_respect_the_floor_and_total() {
        let check = |f: &[u16]| {
            let mut left = 0;
            for &v in f.iter().chain([&CDF_ONE]) {
                assert!(v >= left + CDF_FLOOR, "{f:?}");
                left = v;
            }
        };
        TOKEN_INIT.iter().for_each(|t| check(t));
        check(&CLASS_INIT);
    }

    /// Values over a random tree: a smooth ramp with noise, some large jumps (escapes
    /// of every class), and the extremes of the value range.
    fn test_values(n: usize, seed: u32) -> Vec<i64> {
        let mut k = seed;
        let mut next = || {
            k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
            k >> 8
        };
        (0..n)
            .map(|i| match next() % 50 {
                0 => MAX_VALUE,
                1 => -MAX_VALUE,
                2 => (next() as i64 % (2 * MAX_VALUE + 1)) - MAX_VALUE,
                3..=8 => (i as i64 / 7) + (next() % 600) as i64 - 300,
                _ => (i as i64 / 7) + (next() % 5) as i64 - 2,
            })
            .collect()
    }

    #[test]
    fn values_round_trip_and_costs_track_the_real_size() {
        for on in [false, true] {
            for (w, h, seed) in [(61u32, 37u32, 1u32), (128, 96, 2), (3, 200, 3)] {
                let (shape, cells) = random_tree(w, h, seed, |d| d % 5 < 3);
                let levels = LevelSteps {
                    root_log2: shape.block_log2,
                    on,
                };
                assert_eq!(
                    on,
                    cells.iter().any(|c| levels.shift(c) > 0),
                    "the tree has small cells"
                );
                let nbs = neighbours(&cells, w, h);
                let channels = [
                    test_values(cells.len(), seed),
                    test_values(cells.len(), !seed),
                ];
                let mut sink = AnsSink::new();
                let mut cost = CostSink::default();
                for v in &channels {
                    write_values(&cells, &nbs, v, levels, &mut sink);
                    write_values(&cells, &nbs, v, levels, &mut cost);
                }
                let bytes = sink.finish();
                let est = cost.cost as f64 / 2048.0;
                assert!(
                    (bytes.len() as f64 - est).abs() < 0.005 * est + 8.0,
                    "real {} estimated {est}",
                    bytes.len()
                );
                let max = MAX_SYMBOLS_PER_VALUE * cells.len() as u64 * 2;
                let mut src = AnsSource::new(&bytes, max).unwrap();
                for v in &channels {
                    assert_eq!(&read_values(&cells, &nbs, levels, &mut src).unwrap(), v);
                }
                assert!(src.finished_cleanly());
                let mut src = AnsSource::new(&bytes, max).unwrap();
                assert_eq!(
                    read_channels(&cells, w, h, 2, levels, &mut src).unwrap(),
                    channels
                );
                assert!(src.finished_cleanly());
            }
        }
    }

    #[test]
    fn level_steps_predict_in_root_steps_rounded_to_the_cell_s_own() {
        let levels = LevelSteps {
            root_log2: 5,
            on: true,
        };
        let cell = |log2| Cell { x0: 0, y0: 0, log2 };
        assert_eq!([5, 4, 3, 0].map(|l| levels.shift(&cell(l))), [0, 1, 2, 5]);
        assert_eq!(levels.step(&cell(3), 0.25), 1.0);
        assert_eq!(LevelSteps::FLAT.shift(&cell(0)), 0);
        // One neighbour above, 5 root steps: a cell of twice the root step predicts
        // 2.5 rounded up, one of four times 1.25 rounded to 1; -5 gives -2 and -1.
        let above = Neighbours {
            above: 0,
            left: NONE,
            above_left: NONE,
        };
        assert_eq!(predict(&[5], &above, 0, 1), (3, 1));
        assert_eq!(predict(&[5], &above, 0, 2), (1, 1));
        assert_eq!(predict(&[-5], &above, 0, 1), (-2, 1));
        assert_eq!(predict(&[-5], &above, 0, 2), (-1, 1));
        // The median edge detector runs in root steps, the activity is in the cell's.
        let all = Neighbours {
            above: 0,
            left: 1,
            above_left: 2,
        };
        assert_eq!(predict(&[40, 8, 0], &all, 0, 2), (10, 2));
        assert_eq!(predict(&[4, 0, 0], &all, 0, 2), (1, 1));
        assert_eq!(predict(&[3, 0, 0], &all, 0, 2), (1, 0));
        // A prediction beyond the range in the cell's steps is clamped to it.
        assert_eq!(predict(&[MAX_VALUE << 3], &above, 0, 0).0, MAX_VALUE);
    }

    #[test]
    fn every_residual_magnitude_class_round_trips() {
        let mut rs: Vec<i64> = vec![0, 1, -1, 7, -7, 8, -8, 9, 22, -23];
        for b in 0..=25 {
            for d in [-1i64, 0, 1] {
                let m = (1i64 << b) + d + LITERALS as i64 - 1;
                if m > 0 && m <= 2 * MAX_VALUE {
                    rs.extend([m, -m]);
                }
            }
        }
        rs.push(2 * MAX_VALUE);
        let mut ctx = ValueContexts::default();
        let mut sink = AnsSink::new();
        for (i, &r) in rs.iter().enumerate() {
            write_residual(&mut ctx, i % SIZE_CLASSES, i % ACTIVITY, r, &mut sink);
        }
        let bytes = sink.finish();
        let mut src = AnsSource::new(&bytes, MAX_SYMBOLS_PER_VALUE * rs.len() as u64).unwrap();
        let mut ctx = ValueContexts::default();
        for (i, &r) in rs.iter().enumerate() {
            assert_eq!(
                read_residual(&mut ctx, i % SIZE_CLASSES, i % ACTIVITY, &mut src).unwrap(),
                r
            );
        }
        assert!(src.finished_cleanly());
    }

    /// The neighbours by their definition: the owners of three pixels in a full
    /// per-pixel owner map.
    fn neighbours_by_owner_map(cells: &[Cell], width: u32, height: u32) -> Vec<Neighbours> {
        let w = width as usize;
        let mut owner = vec![NONE; w * height as usize];
        for (i, c) in cells.iter().enumerate() {
            let (x0, y0, x1, y1) = c.clip(width, height);
            for y in y0 as usize..y1 as usize {
                owner[y * w + x0 as usize..y * w + x1 as usize].fill(i as u32);
            }
        }
        let at = |x: u32, y: u32| owner[y as usize * w + x as usize];
        cells
            .iter()
            .map(|c| {
                let (x0, y0, x1, y1) = c.clip(width, height);
                let (cx, cy) = ((x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2);
                Neighbours {
                    above: if y0 > 0 { at(cx, y0 - 1) } else { NONE },
                    left: if x0 > 0 { at(x0 - 1, cy) } else { NONE },
                    above_left: if x0 > 0 && y0 > 0 {
                        at(x0 - 1, y0 - 1)
                    } else {
                        NONE
                    },
                }
            })
            .collect()
    }

    #[test]
    fn neighbours_match_the_owner_map() {
        for (w, h, shape, leaves) in test_trees() {
            for cells in [leaves.clone(), pruned_one_level(&shape, &leaves)] {
                let fast = neighbours(&cells, w, h);
                let slow = neighbours_by_owner_map(&cells, w, h);
                assert_eq!(fast, slow, "{w}x{h}, {} cells", cells.len());
            }
        }
    }
}
