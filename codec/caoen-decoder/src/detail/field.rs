//! The activity field of the adaptive steps: per square region of `2^r` pixels of a
//! tile an exponent `e` (`-LIMIT..=LIMIT`) that multiplies the steps of the region's
//! blocks by `2^(e/4)`, on top of their cell-size class's factor.
//!
//! The structural metrics and the eye weigh an error against the contrast around it:
//! busy regions mask errors, flat ones show them. The encoder sets the field from the
//! source's local variance (coarser steps where it is high, finer where it is low);
//! the decoder only reads it. It is coded at the start of a tile's luma detail stream.

use crate::entropy::{AnsSource, Cdf, SymbolSink};
use crate::CodecError;

use super::adaptive::CLASSES;
use super::dct::N;
use super::syntax::two_sided;
use super::DetailPlane;

/// Largest exponent magnitude: steps within a factor of two either way.
pub const LIMIT: i8 = 4;
/// Region sides a file may use, log2 pixels (a region holds whole 8x8 blocks).
pub const LOG2_RANGE: std::ops::RangeInclusive<u8> = 3..=7;
/// The factors `2^(e/4)` for `e = -LIMIT..=LIMIT`, as exact constants (the same on
/// every machine).
const FACTORS: [f64; 2 * LIMIT as usize + 1] = [
    0.5,
    0.594_603_557_501_360_5,
    std::f64::consts::FRAC_1_SQRT_2,
    0.840_896_415_253_714_5,
    1.0,
    1.189_207_115_002_721,
    std::f64::consts::SQRT_2,
    1.681_792_830_507_429,
    2.0,
];
/// Exponent models by the left and above regions' exponents: their sum, clamped to
/// `-LIMIT..=LIMIT`.
const NEIGHBOUR_CONTEXTS: usize = 2 * LIMIT as usize + 1;
/// Exponent models: by the cell-size class of the region's first block, then
/// [`NEIGHBOUR_CONTEXTS`].
const CONTEXTS: usize = CLASSES * NEIGHBOUR_CONTEXTS;
/// Nine symbols.
type ExponentCdf = Cdf<2>;

/// The exponent models as every field starts them.
fn fresh_models() -> [ExponentCdf; CONTEXTS] {
    [ExponentCdf::new(&two_sided(2 * LIMIT as usize, 0.5)); CONTEXTS]
}

/// The step factor of exponent `e`.
#[inline]
pub fn factor(e: i8) -> f64 {
    FACTORS[(e + LIMIT) as usize]
}

/// A tile's activity field: region side `2^log2` pixels, `cols x rows` regions in
/// raster order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ActivityField {
    /// Region side, log2 pixels (in [`LOG2_RANGE`]).
    pub log2: u8,
    /// Regions per row.
    pub cols: usize,
    /// Region rows.
    pub rows: usize,
    /// Exponents, raster order.
    pub exponents: Vec<i8>,
}

impl ActivityField {
    /// Regions of side `2^log2` over a `width x height` tile.
    pub fn regions(width: u32, height: u32, log2: u8) -> (usize, usize) {
        let side = 1u64 << log2;
        (
            (width as u64).div_ceil(side) as usize,
            (height as u64).div_ceil(side) as usize,
        )
    }

    /// Each 8x8 block's exponent, for `cols x rows` blocks in raster order: that of the
    /// region holding it.
    pub fn block_exponents(&self, cols: usize, rows: usize) -> Vec<i8> {
        (0..cols * rows)
            .map(|i| self.exponents[self.region_of(i % cols, i / cols)])
            .collect()
    }

    /// Blocks per region side, log2.
    fn block_shift(&self) -> u8 {
        self.log2 - N.trailing_zeros() as u8
    }

    /// The region holding block `(bx, by)`.
    fn region_of(&self, bx: usize, by: usize) -> usize {
        let shift = self.block_shift();
        (by >> shift) * self.cols + (bx >> shift)
    }

    /// Codes the exponents; `classes` are the tile's blocks' cell-size classes
    /// ([`super::adaptive::block_classes`]), `cols` blocks to a row.
    pub fn write(&self, classes: &[u8], cols: usize, sink: &mut impl SymbolSink) {
        let mut models = fresh_models();
        for (i, &e) in self.exponents.iter().enumerate() {
            let c = self.context(i, classes, cols);
            sink.symbol(&mut models[c], (e + LIMIT) as usize);
        }
    }

    /// Sets the exponent of every region no coded block takes its step from (`used`
    /// false) to the cheapest symbol under the models as they stand there: its blocks'
    /// levels are all 0 whatever the step, so only the field's bits depend on it.
    /// `classes` and `cols` as for [`Self::write`].
    pub fn settle(&mut self, used: &[bool], classes: &[u8], cols: usize) {
        let mut models = fresh_models();
        // Ties go to the exponent nearest 0.
        let order = [0i8, -1, 1, -2, 2, -3, 3, -4, 4];
        for (i, &used) in used.iter().enumerate().take(self.exponents.len()) {
            let c = self.context(i, classes, cols);
            if !used {
                let m = &models[c];
                self.exponents[i] = order
                    .into_iter()
                    .min_by_key(|&e| m.cost((e + LIMIT) as usize))
                    .expect("nine exponents");
            }
            models[c].update((self.exponents[i] + LIMIT) as usize);
        }
    }

    /// Which regions some coded block of `planes` takes its step from (a merged group's
    /// blocks take their first block's).
    pub fn used(&self, planes: &[DetailPlane]) -> Vec<bool> {
        let mut used = vec![false; self.exponents.len()];
        for p in planes {
            for i in 0..p.cols * p.rows {
                if p.block(i % p.cols, i / p.cols).is_some() {
                    let j = p.coded_block_of(i);
                    used[self.region_of(j % p.cols, j / p.cols)] = true;
                }
            }
        }
        used
    }

    /// Reads the field of a `width x height` tile with regions of side `2^log2`, its
    /// blocks' cell-size classes `classes`.
    pub fn read(
        log2: u8,
        width: u32,
        height: u32,
        classes: &[u8],
        src: &mut AnsSource,
    ) -> Result<Self, CodecError> {
        let (cols, rows) = Self::regions(width, height, log2);
        let block_cols = (width as usize).div_ceil(N);
        let mut field = ActivityField {
            log2,
            cols,
            rows,
            exponents: Vec::with_capacity(cols * rows),
        };
        let mut models = fresh_models();
        for i in 0..cols * rows {
            let c = field.context(i, classes, block_cols);
            let s = src.symbol(&mut models[c])?;
            field.exponents.push(s as i8 - LIMIT);
        }
        Ok(field)
    }

    /// The model of region `i`: by the cell-size class of its first block (`classes`,
    /// `cols` blocks to a row) and the exponents of the regions left of it and above
    /// it (0 where there is none).
    fn context(&self, i: usize, classes: &[u8], cols: usize) -> usize {
        let shift = self.block_shift();
        let first = ((i / self.cols) << shift) * cols + ((i % self.cols) << shift);
        let (left, above) = neighbours(&self.exponents, self.cols, i);
        classes[first] as usize * NEIGHBOUR_CONTEXTS
            + ((left + above).clamp(-LIMIT, LIMIT) + LIMIT) as usize
    }
}

/// The exponents of the regions left of and above region `i` of a field `cols`
/// regions wide, 0 where there is none (the ones before `i` in raster order must be set).
fn neighbours(exponents: &[i8], cols: usize, i: usize) -> (i8, i8) {
    let left = if !i.is_multiple_of(cols) {
        exponents[i - 1]
    } else {
        0
    };
    let above = if i >= cols { exponents[i - cols] } else { 0 };
    (left, above)
}

/// How the encoder sets a field: region side, and steps going as `(variance +
/// floor)^strength` of the source's luma over each region, normalised to the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldSettings {
    /// Region side, log2 pixels (in [`LOG2_RANGE`]).
    pub log2: u8,
    /// The power of the variance the steps follow.
    pub strength: f64,
    /// The variance below which regions count as flat alike (in the coding plane's
    /// squared units).
    pub floor: f64,
    /// How far past the rounding boundary a region's exponent still takes its left
    /// and above neighbours' mean, in exponent units (0: plain rounding).
    pub hysteresis: f64,
}

impl FieldSettings {
    /// The tiles' fields from each tile's log activities ([`log_activity`], tiles in
    /// order, with their sizes): exponents against the mean over every region of the
    /// image, so the field moves steps between busy and flat regions without moving
    /// the image's steps as a whole.
    pub fn fields(&self, tiles: &[(Vec<f64>, (u32, u32))]) -> Vec<ActivityField> {
        let count: usize = tiles.iter().map(|(a, _)| a.len()).sum();
        let mean = tiles.iter().flat_map(|(a, _)| a).sum::<f64>() / count.max(1) as f64;
        tiles
            .iter()
            .map(|(a, (w, h))| {
                let (cols, rows) = ActivityField::regions(*w, *h, self.log2);
                let mut exponents = vec![0i8; a.len()];
                for (i, &a) in a.iter().enumerate() {
                    exponents[i] = exponent(
                        a,
                        mean,
                        self.strength,
                        neighbours(&exponents, cols, i),
                        self.hysteresis,
                    );
                }
                ActivityField {
                    log2: self.log2,
                    cols,
                    rows,
                    exponents,
                }
            })
            .collect()
    }
}

/// The encoder's measure of a region's activity: `ln(variance + c)` of a plane's
/// samples over each region of side `2^log2` of a `width x height` plane (row-major),
/// with `c` the contrast below which regions count as flat alike.
pub fn log_activity(plane: &[f64], width: usize, height: usize, log2: u8, c: f64) -> Vec<f64> {
    let side = 1usize << log2;
    let (cols, rows) = ActivityField::regions(width as u32, height as u32, log2);
    (0..cols * rows)
        .map(|i| {
            let (x0, y0) = ((i % cols) * side, (i / cols) * side);
            let (x1, y1) = ((x0 + side).min(width), (y0 + side).min(height));
            let (mut s1, mut s2) = (0.0, 0.0);
            for y in y0..y1 {
                for &v in &plane[y * width + x0..y * width + x1] {
                    s1 += v;
                    s2 += v * v;
                }
            }
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            let mean = s1 / n;
            ((s2 / n - mean * mean).max(0.0) + c).ln()
        })
        .collect()
}

/// The exponent of a region of log activity `a` when the image's mean is `mean` and the
/// steps go as `(variance + c)^strength`: in quarter octaves, clamped, and the mean of
/// its coded `(left, above)` neighbours where that is within `0.5 + hysteresis` (the
/// coder's contexts make that value cheap).
pub fn exponent(a: f64, mean: f64, strength: f64, (left, above): (i8, i8), hysteresis: f64) -> i8 {
    let x =
        (4.0 * strength * (a - mean) / std::f64::consts::LN_2).clamp(-(LIMIT as f64), LIMIT as f64);
    let near = ((left as f64 + above as f64) / 2.0).round();
    if (x - near).abs() < 0.5 + hysteresis {
        near as i8
    } else {
        x.round() as i8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entropy::AnsSink;

    #[test]
    fn the_factors_are_quarter_octaves() {
        for e in -LIMIT..=LIMIT {
            let want = 2f64.powf(e as f64 / 4.0);
            assert!(
                (factor(e) - want).abs() < 1e-15,
                "{e}: {} against {want}",
                factor(e)
            );
        }
    }

    #[test]
    fn fields_read_back_as_written() {
        let mut rng = caoen_base::rng::Lcg::new(7);
        for (w, h, log2) in [(768, 512, 4), (100, 37, 3), (129, 300, 5), (8, 8, 7)] {
            let (cols, rows) = ActivityField::regions(w, h, log2);
            let exponents = (0..cols * rows)
                .map(|_| (rng.next_u31() % 9) as i8 - LIMIT)
                .collect();
            let field = ActivityField {
                log2,
                cols,
                rows,
                exponents,
            };
            let block_cols = (w as usize).div_ceil(N);
            let classes: Vec<u8> = (0..block_cols * (h as usize).div_ceil(N))
                .map(|i| (i % 7 % 3) as u8)
                .collect();
            let mut sink = AnsSink::new();
            field.write(&classes, block_cols, &mut sink);
            let bytes = sink.finish();
            let mut src = AnsSource::new(&bytes, (cols * rows) as u64).unwrap();
            let back = ActivityField::read(log2, w, h, &classes, &mut src).unwrap();
            assert!(src.finished_cleanly());
            assert_eq!(back, field, "{w}x{h}, 2^{log2}");
        }
    }

    #[test]
    fn blocks_take_their_regions_exponent() {
        let field = ActivityField {
            log2: 4,
            cols: 2,
            rows: 2,
            exponents: vec![-1, 2, 3, -4],
        };
        // A 24x24 tile: 3x3 blocks, the last row and column in the second regions.
        assert_eq!(
            field.block_exponents(3, 3),
            vec![-1, -1, 2, -1, -1, 2, 3, 3, -4]
        );
    }

    #[test]
    fn busy_regions_take_coarser_steps_than_flat_ones() {
        // Left half flat grey, right half a checkerboard of amplitude 0.2.
        let (w, h) = (32, 16);
        let plane: Vec<f64> = (0..w * h)
            .map(|i| {
                if i % w < 16 {
                    0.5
                } else {
                    0.5 + 0.2 * if (i % w + i / w) % 2 == 0 { 1.0 } else { -1.0 }
                }
            })
            .collect();
        let a = log_activity(&plane, w, h, 4, 0.0009);
        assert!((a[0] - 0.0009f64.ln()).abs() < 1e-12, "flat: {}", a[0]);
        assert!(
            (a[1] - (0.04f64 + 0.0009).ln()).abs() < 1e-12,
            "busy: {}",
            a[1]
        );
        let mean = (a[0] + a[1]) / 2.0;
        // ln(0.0409 / 0.0009) / 2 = 1.91; times 0.15 strength, 4 / ln 2: 1.65 -> 2.
        assert_eq!(exponent(a[0], mean, 0.15, (0, 0), 0.0), -2);
        assert_eq!(exponent(a[1], mean, 0.15, (0, 0), 0.0), 2);
        assert_eq!(exponent(a[1], mean, 1.0, (0, 0), 0.0), LIMIT);
        // 1.65 is within 0.5 + 0.25 of the neighbours' mean 1 (from 0 and 2), not of 0.
        assert_eq!(exponent(a[1], mean, 0.15, (0, 2), 0.25), 1);
        assert_eq!(exponent(a[1], mean, 0.15, (0, 0), 0.25), 2);
        // A plain rounding where the neighbours' mean is the nearest anyway.
        assert_eq!(exponent(a[0], mean, 0.15, (-2, -2), 0.25), -2);
    }
}
