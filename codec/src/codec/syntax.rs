//! The coded syntax: quadtree split flags and key-point values, binarised onto
//! adaptive contexts (see `docs/format.md`, "Tree" and "Values").

use super::entropy::{BinModel, BinSink, RangeSource};
use super::quadtree::{Cell, TreeShape};
use super::CodecError;

/// Split-flag contexts: levels below the root (0..4) x split neighbours (0..=2).
const TREE_LEVELS: usize = 4;

/// Adaptive contexts of the split flags.
#[derive(Clone)]
pub struct TreeContexts {
    split: [[BinModel; 3]; TREE_LEVELS],
}

impl Default for TreeContexts {
    fn default() -> Self {
        TreeContexts {
            split: [[BinModel::default(); 3]; TREE_LEVELS],
        }
    }
}

/// Which nodes of each level were split, for the neighbour context.
struct SplitMap {
    levels: Vec<(u32, Vec<u8>)>,
    block_log2: u8,
}

impl SplitMap {
    fn new(shape: &TreeShape) -> Self {
        let levels = (0..=shape.block_log2)
            .map(|l| {
                let cols = shape.width.div_ceil(1 << l) + 1;
                let rows = shape.height.div_ceil(1 << l) + 1;
                (cols, vec![0u8; (cols * rows) as usize])
            })
            .collect();
        SplitMap {
            levels,
            block_log2: shape.block_log2,
        }
    }

    fn context(&self, c: &Cell) -> (usize, usize) {
        let (cols, map) = &self.levels[c.log2 as usize];
        let (i, j) = (c.x0 >> c.log2, c.y0 >> c.log2);
        let split_at = |i: u32, j: u32| map[(j * cols + i) as usize] == 2;
        let n = usize::from(i > 0 && split_at(i - 1, j)) + usize::from(j > 0 && split_at(i, j - 1));
        let level = ((self.block_log2 - c.log2) as usize).min(TREE_LEVELS - 1);
        (level, n)
    }

    fn record(&mut self, c: &Cell, split: bool) {
        let (cols, map) = &mut self.levels[c.log2 as usize];
        let (i, j) = (c.x0 >> c.log2, c.y0 >> c.log2);
        map[(j * *cols + i) as usize] = if split { 2 } else { 1 };
    }
}

/// Codes the split flags of the tree whose split nodes satisfy `is_split`; returns
/// the leaves in coding order.
pub fn write_tree(
    shape: &TreeShape,
    is_split: impl Fn(&Cell) -> bool,
    sink: &mut impl BinSink,
) -> Vec<Cell> {
    let mut ctx = TreeContexts::default();
    let mut map = SplitMap::new(shape);
    shape.walk(|c| {
        let split = is_split(c);
        let (l, n) = map.context(c);
        sink.bin(&mut ctx.split[l][n], split);
        map.record(c, split);
        split
    })
}

/// Decodes the split flags; returns the leaves in coding order.
pub fn read_tree(shape: &TreeShape, src: &mut RangeSource) -> Result<Vec<Cell>, CodecError> {
    let mut ctx = TreeContexts::default();
    let mut map = SplitMap::new(shape);
    let mut err = None;
    let leaves = shape.walk(|c| {
        if err.is_some() {
            return false;
        }
        let (l, n) = map.context(c);
        match src.bin(&mut ctx.split[l][n]) {
            Ok(split) => {
                map.record(c, split);
                split
            }
            Err(e) => {
                err = Some(e);
                false
            }
        }
    });
    match err {
        Some(e) => Err(e),
        None => Ok(leaves),
    }
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
    let mut col = vec![NONE; width as usize];
    // Per row: the last coded cell covering it, and the owner of the pixel just above
    // that cell's right column in this row.
    let mut row = vec![(NONE, NONE); height as usize];
    let mut out = vec![
        Neighbours {
            above: NONE,
            left: NONE,
            above_left: NONE,
        };
        cells.len()
    ];
    for (i, (c, nb)) in cells.iter().zip(out.iter_mut()).enumerate() {
        let i = i as u32;
        let (x0, y0) = (c.x0 as usize, c.y0 as usize);
        if x0 > 0 {
            (nb.left, nb.above_left) = (row[y0].0, row[y0].1);
        }
        // Single-pixel cells dominate at high rates: no clipping, no fill loops.
        if c.log2 == 0 {
            if y0 > 0 {
                nb.above = col[x0];
            }
            col[x0] = i;
            row[y0] = (i, nb.above);
            continue;
        }
        let (_, _, x1, y1) = c.clip(width, height);
        let (x1, y1) = (x1 as usize, y1 as usize);
        let above_right = if y0 > 0 {
            nb.above = col[(x0 + x1 - 1) / 2];
            col[x1 - 1]
        } else {
            NONE
        };
        if x0 > 0 {
            nb.left = row[(y0 + y1 - 1) / 2].0;
        }
        // Cells span at most 2^7 pixels: plain loops beat `fill`'s set-up.
        for o in &mut col[x0..x1] {
            *o = i;
        }
        row[y0] = (i, above_right);
        for o in &mut row[y0 + 1..y1] {
            *o = (i, i);
        }
    }
    out
}

/// Values beyond this magnitude are rejected by the decoder (no file needs them).
pub const MAX_VALUE: i64 = 1 << 24;
/// Unary magnitude bins before the Exp-Golomb escape.
const UNARY: usize = 14;
const SIZE_CLASSES: usize = 5;
const ACTIVITY: usize = 3;

/// Adaptive contexts of one channel's values.
#[derive(Clone)]
pub struct ValueContexts {
    zero: [[BinModel; ACTIVITY]; SIZE_CLASSES],
    sign: [BinModel; ACTIVITY],
    magnitude: [[BinModel; ACTIVITY]; UNARY],
}

impl Default for ValueContexts {
    fn default() -> Self {
        ValueContexts {
            zero: [[BinModel::default(); ACTIVITY]; SIZE_CLASSES],
            sign: [BinModel::default(); ACTIVITY],
            magnitude: [[BinModel::default(); ACTIVITY]; UNARY],
        }
    }
}

/// Prediction and activity class of key point `i` from already coded values.
#[inline]
pub fn predict(values: &[i64], nb: &Neighbours, previous: i64) -> (i64, usize) {
    let get = |i: u32| Neighbours::get(i).map(|i| values[i as usize]);
    match (get(nb.above), get(nb.left), get(nb.above_left)) {
        (Some(a), Some(l), Some(al)) => {
            // LOCO-I's median edge detector.
            let pred = if al >= a.max(l) {
                a.min(l)
            } else if al <= a.min(l) {
                a.max(l)
            } else {
                a + l - al
            };
            let act = (a - al).abs() + (l - al).abs();
            (
                pred,
                if act == 0 {
                    0
                } else if act <= 3 {
                    1
                } else {
                    2
                },
            )
        }
        (Some(v), _, _) | (None, Some(v), _) => (v, 1),
        (None, None, _) => (previous, 2),
    }
}

fn size_class(c: &Cell) -> usize {
    (c.log2 as usize).min(SIZE_CLASSES - 1)
}

/// Codes one value's residual `r`.
pub fn write_residual(
    ctx: &mut ValueContexts,
    size: usize,
    act: usize,
    r: i64,
    sink: &mut impl BinSink,
) {
    sink.bin(&mut ctx.zero[size][act], r != 0);
    if r == 0 {
        return;
    }
    sink.bin(&mut ctx.sign[act], r < 0);
    let m = r.unsigned_abs() - 1;
    for k in 0..UNARY {
        let more = m > k as u64;
        sink.bin(&mut ctx.magnitude[k][act], more);
        if !more {
            return;
        }
    }
    // Exp-Golomb order 0 of the remainder, bypass-coded.
    let v = m - UNARY as u64 + 1;
    let bits = 63 - v.leading_zeros();
    for _ in 0..bits {
        sink.bypass(false);
    }
    for b in (0..=bits).rev() {
        sink.bypass((v >> b) & 1 == 1);
    }
}

/// Reads one residual.
pub fn read_residual(
    ctx: &mut ValueContexts,
    size: usize,
    act: usize,
    src: &mut RangeSource,
) -> Result<i64, CodecError> {
    if !src.bin(&mut ctx.zero[size][act])? {
        return Ok(0);
    }
    let negative = src.bin(&mut ctx.sign[act])?;
    let mut m = 0u64;
    let mut escaped = true;
    for k in 0..UNARY {
        if src.bin(&mut ctx.magnitude[k][act])? {
            m = k as u64 + 1;
        } else {
            m = k as u64;
            escaped = false;
            break;
        }
    }
    if escaped {
        let mut bits = 0;
        while !src.bypass()? {
            bits += 1;
            if bits > 40 {
                return Err(CodecError::Format("value escape code too long".into()));
            }
        }
        let mut v = 1u64;
        for _ in 0..bits {
            v = (v << 1) | u64::from(src.bypass()?);
        }
        m = v - 1 + UNARY as u64;
    }
    let mag = m as i64 + 1;
    if mag > 2 * MAX_VALUE {
        return Err(CodecError::Format(format!(
            "value residual {mag} out of range"
        )));
    }
    Ok(if negative { -mag } else { mag })
}

/// Codes the quantised values of one channel over a key-point set.
pub fn write_values(cells: &[Cell], nbs: &[Neighbours], values: &[i64], sink: &mut impl BinSink) {
    let mut ctx = ValueContexts::default();
    let mut previous = 0;
    for (i, c) in cells.iter().enumerate() {
        let (pred, act) = predict(values, &nbs[i], previous);
        write_residual(&mut ctx, size_class(c), act, values[i] - pred, sink);
        previous = values[i];
    }
}

/// Reads the quantised values of one channel.
pub fn read_values(
    cells: &[Cell],
    nbs: &[Neighbours],
    src: &mut RangeSource,
) -> Result<Vec<i64>, CodecError> {
    let mut ctx = ValueContexts::default();
    let mut values = vec![0i64; cells.len()];
    let mut previous = 0;
    for (i, c) in cells.iter().enumerate() {
        let (pred, act) = predict(&values, &nbs[i], previous);
        let v = pred + read_residual(&mut ctx, size_class(c), act, src)?;
        if v.abs() > MAX_VALUE {
            return Err(CodecError::Format(format!(
                "key point value {v} out of range"
            )));
        }
        values[i] = v;
        previous = v;
    }
    Ok(values)
}

/// Most bins one value can take (zero, sign, unary, escape prefix and suffix).
pub const MAX_BINS_PER_VALUE: u64 = 3 + UNARY as u64 + 2 * 41;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::quadtree::{pruned_one_level, random_tree};

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
        for (w, h, seed, num) in [
            (37, 21, 1u32, 2u32),
            (64, 64, 2, 1),
            (5, 3, 3, 2),
            (100, 17, 4, 3),
            (1, 1, 5, 2),
            (129, 70, 6, 2),
            (48, 80, 7, 4),
        ] {
            // Splitting with probability num/5: sparse to dense trees.
            let (shape, leaves) = random_tree(w, h, seed, |d| d % 5 < num);
            for cells in [leaves.clone(), pruned_one_level(&shape, &leaves)] {
                let fast = neighbours(&cells, w, h);
                let slow = neighbours_by_owner_map(&cells, w, h);
                assert_eq!(fast, slow, "{w}x{h} seed {seed}");
            }
        }
    }
}
