//! Adaptive steps of the detail layer: each block's step is its plane's step times a
//! factor chosen by the size of the network cell over the block, and, where the file
//! has an activity field ([`super::field`]), times its region's factor.
//!
//! The network splits its cells where the picture has detail, so the cell over a block
//! is a measure of local activity that the decoder has without a bit spent on it. Flat
//! regions (large cells), where the eye and the structural metrics notice small errors,
//! take a finer step; busy ones (small cells), which mask errors, a coarser one.
//! The same classes are contexts of the coefficient syntax ([`super::syntax`]), with
//! or without adaptive steps: blocks under large cells are coded less often.

use crate::quadtree::Cell;

use super::dct::N;
use super::field;

/// Classes of cell size: 8 pixels or smaller, 16, 32 or larger.
pub const CLASSES: usize = 3;
/// A stored factor byte `b` means `b / UNIT`.
pub const UNIT: f64 = 32.0;

/// The step factor of each class, as stored (`b / 32`, 1..=255), and the region size
/// of the activity field, if the tiles code one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AdaptiveSteps {
    /// Factor bytes by class: cells of 8 pixels or smaller, 16, 32 or larger.
    pub factors: [u8; CLASSES],
    /// The activity field's region side, log2 pixels ([`field::LOG2_RANGE`]); 0: no field.
    pub field_log2: u8,
}

impl AdaptiveSteps {
    /// The encoder's factors before they are scaled to the image ([`Self::normalised`];
    /// measured in `docs/codec-ablation.md`: 36 / 32 / 29 against 40 / 32 / 27, beside
    /// the post filters, gained 0.8 points of BD-rate by RGB PSNR below 0.3 bpp for 0.5
    /// by MS-SSIM).
    pub const DEFAULT: AdaptiveSteps = AdaptiveSteps {
        factors: [36, 32, 29],
        field_log2: 0,
    };

    /// Whether every factor is in range (a zero factor would erase its blocks) and the
    /// field's region side is none or one of [`field::LOG2_RANGE`].
    pub fn is_valid(&self) -> bool {
        self.factors.iter().all(|&f| f > 0)
            && (self.field_log2 == 0 || field::LOG2_RANGE.contains(&self.field_log2))
    }

    /// The activity field's region side, log2 pixels, if the tiles code one.
    pub fn field(&self) -> Option<u8> {
        (self.field_log2 != 0).then_some(self.field_log2)
    }

    /// The factor of a class.
    pub fn factor(&self, class: u8) -> f64 {
        self.factors[class as usize] as f64 / UNIT
    }

    /// The factors scaled so that their geometric mean over an image's blocks
    /// (`classes`, one per block) is one: the steps move between busy and flat blocks
    /// without moving the detail layer as a whole against the network, whose steps the
    /// quality sets (an image of flat regions only keeps the plain step).
    pub fn normalised(&self, classes: &[u8]) -> AdaptiveSteps {
        if classes.is_empty() {
            return *self;
        }
        let mut count = [0usize; CLASSES];
        for &c in classes {
            count[c as usize] += 1;
        }
        let log_sum: f64 = (0..CLASSES)
            .map(|c| count[c] as f64 * self.factor(c as u8).ln())
            .sum();
        let mean = (log_sum / classes.len() as f64).exp();
        AdaptiveSteps {
            factors: self
                .factors
                .map(|f| (f as f64 / mean).round().clamp(1.0, 255.0) as u8),
            ..*self
        }
    }
}

/// The class of a cell of side `2^log2`.
pub fn class_of(log2: u8) -> u8 {
    log2.saturating_sub(3).min(CLASSES as u8 - 1)
}

/// Per block of a `width x height` image (blocks of [`N`] pixels in raster order), the
/// class of the cell holding the block's centre pixel (the block's part inside the
/// image). `cells` are the luma leaves, which cover the image; a block no cell holds
/// keeps class 0.
pub fn block_classes(cells: &[Cell], width: u32, height: u32) -> Vec<u8> {
    let (cols, rows) = super::blocks(width, height);
    let centre = |b: usize, side: u32| ((b * N) as u32 + (N as u32 / 2)).min(side - 1);
    let mut classes = vec![0u8; cols * rows];
    for c in cells {
        let (x0, y0, x1, y1) = c.clip(width, height);
        if x0 >= x1 || y0 >= y1 {
            continue;
        }
        let class = class_of(c.log2);
        for by in y0 as usize / N..=(y1 as usize - 1) / N {
            let cy = centre(by, height);
            if !(y0..y1).contains(&cy) {
                continue;
            }
            for bx in x0 as usize / N..=(x1 as usize - 1) / N {
                if (x0..x1).contains(&centre(bx, width)) {
                    classes[by * cols + bx] = class;
                }
            }
        }
    }
    classes
}

/// The step factor of every block of a plane.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockSteps {
    /// The factors by class.
    pub steps: AdaptiveSteps,
    /// Per block, its class.
    pub classes: Vec<u8>,
    /// Per block, its activity field exponent (empty: no field).
    pub field: Vec<i8>,
}

impl BlockSteps {
    /// The factor of block `i` (raster order).
    #[inline]
    pub fn factor(&self, i: usize) -> f64 {
        let f = self.steps.factor(self.classes[i]);
        match self.field.get(i) {
            Some(&e) => f * field::factor(e),
            None => f,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_block_takes_the_class_of_the_cell_over_its_centre() {
        // A 40x24 image: a 32-pixel cell at the origin, then 8-pixel cells to its
        // right, 16- and 8-pixel cells below (the bottom row is cut by the image).
        let mut cells = vec![Cell {
            x0: 0,
            y0: 0,
            log2: 5,
        }];
        for y in (0..32).step_by(8) {
            cells.push(Cell {
                x0: 32,
                y0: y,
                log2: 3,
            });
        }
        let classes = block_classes(&cells, 40, 24);
        assert_eq!(classes.len(), 5 * 3);
        for by in 0..3 {
            assert_eq!(&classes[by * 5..by * 5 + 5], &[2, 2, 2, 2, 0]);
        }
        // The last block row of a 20-pixel-high image has its centre at row 19.
        let cells = [
            Cell {
                x0: 0,
                y0: 0,
                log2: 4,
            },
            Cell {
                x0: 0,
                y0: 16,
                log2: 3,
            },
        ];
        assert_eq!(block_classes(&cells, 16, 20), vec![1, 1, 1, 1, 0, 0]);
    }

    #[test]
    fn normalised_factors_keep_the_mean_step_of_the_image() {
        let s = AdaptiveSteps::DEFAULT;
        // Flat regions only: their blocks keep the plain step, the others scale alike.
        // 36 and 32 times 32/29, rounded.
        assert_eq!(s.normalised(&[2; 50]).factors, [40, 35, 32]);
        assert_eq!(s.normalised(&[]), s);
        for classes in [
            vec![0u8, 1, 2],
            vec![0; 7],
            vec![0, 0, 0, 2],
            vec![1, 2, 2, 2, 2, 0],
        ] {
            let n = s.normalised(&classes);
            let log_mean: f64 =
                classes.iter().map(|&c| n.factor(c).ln()).sum::<f64>() / classes.len() as f64;
            // Within the rounding of a byte (half of 1/32 of a factor near one).
            assert!(
                log_mean.abs() < 0.02,
                "{classes:?}: {:?} mean {log_mean}",
                n.factors
            );
            assert!(n.factors[0] > n.factors[1] && n.factors[1] > n.factors[2]);
        }
    }

    #[test]
    fn classes_follow_the_cell_size() {
        assert_eq!([0, 3, 4, 5, 7].map(class_of), [0, 0, 1, 2, 2]);
        let s = AdaptiveSteps::DEFAULT;
        assert!(s.is_valid());
        assert!(s.factor(0) > s.factor(1) && s.factor(1) > s.factor(2));
        assert!(!AdaptiveSteps {
            factors: [0, 32, 32],
            field_log2: 0
        }
        .is_valid());
        for (log2, valid) in [
            (0, true),
            (2, false),
            (3, true),
            (4, true),
            (7, true),
            (8, false),
        ] {
            assert_eq!(
                AdaptiveSteps {
                    field_log2: log2,
                    ..s
                }
                .is_valid(),
                valid,
                "{log2}"
            );
        }
    }
}
