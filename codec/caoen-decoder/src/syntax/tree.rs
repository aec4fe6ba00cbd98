//! The quadtree's split flags, each in the context of its level and of how many of its
//! same-size neighbours left and above were split.

use crate::entropy::{AnsSource, BinModel, SymbolSink};
use crate::quadtree::{Cell, TreeShape};
use crate::CodecError;

/// Split-flag contexts: levels below the root (0..4) x split neighbours (0..=2).
pub(super) const TREE_LEVELS: usize = 4;
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
pub(super) fn walk_tree<E, F>(
    shape: &TreeShape,
    expected_leaves: usize,
    flag: F,
) -> Result<Vec<Cell>, E>
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
