//! Tiles: the independently coded rectangles of an image.
//!
//! The image is cut into square tiles of `side` pixels in raster order (the last row
//! and column clipped). Each tile's tree, key-point values and detail blocks are
//! entropy-coded on their own, with fresh contexts, so tiles are encoded and decoded in
//! parallel and the encoder holds one tile's working set per worker. The
//! reconstruction is not tiled: the key points of all tiles form one network and the
//! blocks one detail layer, evaluated as for an untiled image, so the colours across a
//! tile edge blend like those across any other root edge.

use super::quadtree::Cell;

/// Tile sides are multiples of this: of every root block size (at most `2^7`) and of
/// the detail layer's 8-pixel blocks, so no root or block straddles a tile edge.
pub const SIDE_UNIT: u32 = 128;
/// The encoder's tile side for images larger than [`SINGLE_TILE_MAX`].
pub const DEFAULT_SIDE: u32 = 512;
/// Images whose sides are at most this are coded as one tile: their whole working set
/// is small, and one set of adaptive contexts codes them in fewer bits.
pub const SINGLE_TILE_MAX: u32 = 1024;

/// A rectangle of the image: one tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileRect {
    /// Left edge in pixels.
    pub x0: u32,
    /// Top edge in pixels.
    pub y0: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// The tiles of a `width x height` image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tiling {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile side in pixels.
    pub side: u32,
}

impl Tiling {
    /// The encoder's tiling of a `width x height` image.
    pub fn choose(width: u32, height: u32) -> Tiling {
        let long = width.max(height).max(1);
        let side = if long <= SINGLE_TILE_MAX {
            long.next_multiple_of(SIDE_UNIT)
        } else {
            DEFAULT_SIDE
        };
        Tiling {
            width,
            height,
            side,
        }
    }

    /// Tiles per row.
    pub fn columns(&self) -> usize {
        self.width.div_ceil(self.side) as usize
    }

    /// Tile rows.
    pub fn rows(&self) -> usize {
        self.height.div_ceil(self.side) as usize
    }

    /// Number of tiles.
    pub fn count(&self) -> usize {
        self.columns() * self.rows()
    }

    /// Tile `i` in raster order.
    pub fn rect(&self, i: usize) -> TileRect {
        let cols = self.columns();
        let (x0, y0) = ((i % cols) as u32 * self.side, (i / cols) as u32 * self.side);
        TileRect {
            x0,
            y0,
            width: self.side.min(self.width - x0),
            height: self.side.min(self.height - y0),
        }
    }
}

impl TileRect {
    /// This rectangle with `margin` more pixels on every side, within a `width x
    /// height` image.
    pub fn grown(&self, margin: u32, width: u32, height: u32) -> TileRect {
        let (x0, y0) = (
            self.x0.saturating_sub(margin),
            self.y0.saturating_sub(margin),
        );
        TileRect {
            x0,
            y0,
            width: (self.x0 + self.width + margin).min(width) - x0,
            height: (self.y0 + self.height + margin).min(height) - y0,
        }
    }

    /// A cell of this tile's own tree in image coordinates.
    pub fn to_image(&self, c: Cell) -> Cell {
        Cell {
            x0: c.x0 + self.x0,
            y0: c.y0 + self.y0,
            log2: c.log2,
        }
    }
}

/// The permutation that puts cells gathered tile by tile (each tile's cells in its own
/// coding order, in image coordinates) into the image's coding order: root rows top to
/// bottom, roots left to right, each root's cells in Z order. For one tile it is the
/// identity. Evaluation relies on this order: the cells a band of rows needs are then
/// a few contiguous root rows.
pub fn image_order(cells: &[Cell], block_log2: u8) -> Vec<usize> {
    let mut order: Vec<usize> = (0..cells.len()).collect();
    // Stable: within one root the tile's Z order is kept.
    order.sort_by_key(|&i| (cells[i].y0 >> block_log2, cells[i].x0 >> block_log2));
    order
}

/// Cells gathered tile by tile and their values (one list per channel), put in the
/// image's coding order ([`image_order`]).
pub fn into_image_order<T: Copy>(
    cells: &[Cell],
    values: &[Vec<T>],
    block_log2: u8,
) -> (Vec<Cell>, Vec<Vec<T>>) {
    let order = image_order(cells, block_log2);
    (
        order.iter().map(|&i| cells[i]).collect(),
        permute(values, &order),
    )
}

/// `values` (one list per channel, one value per cell) permuted by `order`.
pub fn permute<T: Copy>(values: &[Vec<T>], order: &[usize]) -> Vec<Vec<T>> {
    values
        .iter()
        .map(|v| order.iter().map(|&i| v[i]).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadtree::TreeShape;

    #[test]
    fn small_images_are_one_tile_and_large_ones_are_cut() {
        let t = Tiling::choose(768, 512);
        assert_eq!((t.side, t.count()), (768, 1));
        assert_eq!(
            t.rect(0),
            TileRect {
                x0: 0,
                y0: 0,
                width: 768,
                height: 512
            }
        );
        let t = Tiling::choose(4032, 3024);
        assert_eq!((t.side, t.columns(), t.rows()), (512, 8, 6));
        assert_eq!(
            t.rect(7),
            TileRect {
                x0: 3584,
                y0: 0,
                width: 448,
                height: 512
            }
        );
        assert_eq!(
            t.rect(47),
            TileRect {
                x0: 3584,
                y0: 2560,
                width: 448,
                height: 464
            }
        );
        let area: u64 = (0..t.count())
            .map(|i| t.rect(i).width as u64 * t.rect(i).height as u64)
            .sum();
        assert_eq!(area, 4032 * 3024);
    }

    #[test]
    fn tiles_trees_reordered_are_the_image_tree() {
        // Splitting every cell touching a diagonal line gives a tree whose leaves cross
        // tile edges; the tiles' leaves, reordered, must be the whole image's walk.
        let (w, h) = (700u32, 300u32);
        let split = |c: &Cell| {
            let (x0, y0, s) = (c.x0 as i64, c.y0 as i64, c.size() as i64);
            (x0 - 2 * y0).abs() < 2 * s || (x0 + s - 2 * (y0 + s)).abs() < 2 * s
        };
        let shape = |w, h| TreeShape {
            width: w,
            height: h,
            block_log2: 5,
            min_log2: 2,
        };
        let whole = shape(w, h).walk(split);
        let tiling = Tiling {
            width: w,
            height: h,
            side: 256,
        };
        let mut gathered = Vec::new();
        for i in 0..tiling.count() {
            let r = tiling.rect(i);
            let leaves = shape(r.width, r.height).walk(|c| split(&r.to_image(*c)));
            gathered.extend(leaves.into_iter().map(|c| r.to_image(c)));
        }
        let order = image_order(&gathered, 5);
        let reordered: Vec<Cell> = order.iter().map(|&i| gathered[i]).collect();
        assert_eq!(reordered, whole);
    }
}
