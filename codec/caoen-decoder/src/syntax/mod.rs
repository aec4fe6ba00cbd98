//! The coded syntax: quadtree split flags and key-point values on adaptive contexts
//! (see `docs/format.md`, "Tree syntax" and "Value syntax").

#[cfg(test)]
mod tests;
mod tree;

pub use tree::{read_tree, write_tree, TreeContexts};

use super::entropy::{AnsSource, Cdf, SymbolSink, MAX_RAW_BITS};
use super::quadtree::Cell;
use super::CodecError;

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
