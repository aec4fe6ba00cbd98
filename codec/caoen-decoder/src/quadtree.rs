//! The adaptive quadtree whose leaves are the key points.
//!
//! The image is tiled by blocks of `2^block_log2` pixels in raster order; each block is
//! a quadtree down to cells of `2^min_log2` pixels. Nodes are visited depth first with
//! children in Z order (top-left, top-right, bottom-left, bottom-right); a node larger
//! than the minimum carries one split flag. Children lying wholly outside the image are
//! skipped (no flag, no leaf): the decoder knows the image size. Key point positions are
//! implied by the tree, so they cost no bits beyond the flags.

/// A square cell of the tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Cell {
    /// Left edge in pixels.
    pub x0: u32,
    /// Top edge in pixels.
    pub y0: u32,
    /// Side is `2^log2` pixels.
    pub log2: u8,
}

impl Cell {
    /// Side length in pixels.
    pub fn size(&self) -> u32 {
        1 << self.log2
    }

    /// The cell clipped to a `width x height` image: `(x0, y0, x1, y1)`, exclusive ends.
    pub fn clip(&self, width: u32, height: u32) -> (u32, u32, u32, u32) {
        let s = self.size();
        (
            self.x0,
            self.y0,
            (self.x0 + s).min(width),
            (self.y0 + s).min(height),
        )
    }

    /// Centre of the cell's part inside the image (where its key point sits).
    pub fn centre(&self, width: u32, height: u32) -> (f64, f64) {
        let (x0, y0, x1, y1) = self.clip(width, height);
        (0.5 * (x0 + x1) as f64, 0.5 * (y0 + y1) as f64)
    }

    /// The four children in Z order.
    pub fn children(&self) -> [Cell; 4] {
        let h = 1 << (self.log2 - 1);
        let l = self.log2 - 1;
        [
            Cell {
                x0: self.x0,
                y0: self.y0,
                log2: l,
            },
            Cell {
                x0: self.x0 + h,
                y0: self.y0,
                log2: l,
            },
            Cell {
                x0: self.x0,
                y0: self.y0 + h,
                log2: l,
            },
            Cell {
                x0: self.x0 + h,
                y0: self.y0 + h,
                log2: l,
            },
        ]
    }

    /// The parent cell.
    pub fn parent(&self) -> Cell {
        let l = self.log2 + 1;
        let mask = !((1u32 << l) - 1);
        Cell {
            x0: self.x0 & mask,
            y0: self.y0 & mask,
            log2: l,
        }
    }
}

/// Tree geometry shared by encoder and decoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TreeShape {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Root block side, log2.
    pub block_log2: u8,
    /// Smallest cell side, log2.
    pub min_log2: u8,
}

impl TreeShape {
    /// Root cells in raster order.
    pub fn roots(&self) -> impl Iterator<Item = Cell> + '_ {
        let b = 1u32 << self.block_log2;
        let (bw, bh) = (self.width.div_ceil(b), self.height.div_ceil(b));
        (0..bh).flat_map(move |j| {
            (0..bw).map(move |i| Cell {
                x0: i * b,
                y0: j * b,
                log2: self.block_log2,
            })
        })
    }

    /// Whether a cell overlaps the image.
    pub fn inside(&self, c: &Cell) -> bool {
        c.x0 < self.width && c.y0 < self.height
    }

    /// Walks the tree: `split(cell)` decides each flag (called only for cells above the
    /// minimum size, in coding order); returns the leaves in coding order.
    pub fn walk(&self, mut split: impl FnMut(&Cell) -> bool) -> Vec<Cell> {
        let mut leaves = Vec::new();
        let mut stack = Vec::new();
        for root in self.roots() {
            stack.push(root);
            while let Some(c) = stack.pop() {
                if c.log2 > self.min_log2 && split(&c) {
                    // Pushed in reverse so they pop in Z order.
                    for child in c.children().iter().rev().filter(|k| self.inside(k)) {
                        stack.push(*child);
                    }
                } else {
                    leaves.push(c);
                }
            }
        }
        leaves
    }

    /// Upper bound on the number of leaves (every cell at the minimum size).
    pub fn max_leaves(&self) -> u64 {
        let m = 1u64 << self.min_log2;
        (self.width as u64).div_ceil(m) * (self.height as u64).div_ceil(m)
    }

    /// Most split flags a tree can have: one per node above the smallest size that
    /// meets the image. Near the image's edges a node can have a single child, so the
    /// count is not bounded by a fixed multiple of the leaves.
    pub fn max_flags(&self) -> u64 {
        (self.min_log2 + 1..=self.block_log2)
            .map(|l| {
                let s = 1u64 << l;
                (self.width as u64).div_ceil(s) * (self.height as u64).div_ceil(s)
            })
            .sum()
    }
}

/// The chroma key points: the luma leaves pruned one level. Wherever all existing
/// children of a node are leaves, the node replaces them; other leaves stay. Derived
/// from the luma tree alone, so it costs no bits.
pub fn pruned_one_level(shape: &TreeShape, leaves: &[Cell]) -> Vec<Cell> {
    // Depth-first coding order keeps a node's subtree contiguous, so a node whose
    // existing children are all leaves shows up as a run of exactly that many leaves
    // starting at its first child. Only a first child (both coordinates aligned to the
    // parent) can start one, and the leaves after it are its siblings exactly when they
    // have its size: a split sibling's first leaf is smaller. Integer tests per leaf
    // instead of constructing and comparing parents: the chroma thread waits on this.
    let mut out = Vec::with_capacity(leaves.len() / 2);
    let mut k = 0;
    while k < leaves.len() {
        let l = leaves[k];
        let h = 1u32 << l.log2;
        if l.log2 < shape.block_log2 && (l.x0 | l.y0) & h == 0 {
            let right = l.x0 + h < shape.width;
            let below = l.y0 + h < shape.height;
            let existing = 1 + usize::from(right) + usize::from(below) + usize::from(right & below);
            if let Some(run) = leaves.get(k + 1..k + existing) {
                if run.iter().all(|c| c.log2 == l.log2) {
                    out.push(l.parent());
                    k += existing;
                    continue;
                }
            }
        }
        out.push(l);
        k += 1;
    }
    out
}

/// A test tree over a `width x height` image: split flags from a seeded linear
/// congruential sequence, splitting where `split(draw)` holds.
/// The chroma cells for a luma tree.
pub fn chroma_cells(shape: &TreeShape, luma: &[Cell], pruned: bool) -> Vec<Cell> {
    if pruned {
        pruned_one_level(shape, luma)
    } else {
        luma.to_vec()
    }
}

/// A tree of `width x height` split where `split` says from a seeded sequence: test
/// material for the stages built on trees.
pub fn random_tree(
    width: u32,
    height: u32,
    seed: u32,
    split: impl Fn(u32) -> bool,
) -> (TreeShape, Vec<Cell>) {
    let shape = TreeShape {
        width,
        height,
        block_log2: 4,
        min_log2: 0,
    };
    let mut k = seed;
    let leaves = shape.walk(|_| {
        k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
        split(k >> 16)
    });
    (shape, leaves)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pruning by its definition: count each parent's leaf children.
    fn pruned_by_counting(shape: &TreeShape, leaves: &[Cell]) -> Vec<Cell> {
        use std::collections::{HashMap, HashSet};
        let mut leaf_children: HashMap<Cell, usize> = HashMap::new();
        for l in leaves.iter().filter(|l| l.log2 < shape.block_log2) {
            *leaf_children.entry(l.parent()).or_insert(0) += 1;
        }
        let mut out = Vec::new();
        let mut emitted = HashSet::new();
        for l in leaves {
            if l.log2 < shape.block_log2 {
                let p = l.parent();
                let existing = p.children().iter().filter(|k| shape.inside(k)).count();
                if leaf_children.get(&p) == Some(&existing) {
                    if emitted.insert(p) {
                        out.push(p);
                    }
                    continue;
                }
            }
            out.push(*l);
        }
        out
    }

    #[test]
    fn pruning_matches_its_definition() {
        for (w, h, seed) in [
            (37, 21, 1u32),
            (64, 64, 2),
            (5, 3, 3),
            (100, 17, 4),
            (1, 1, 5),
            (33, 47, 6),
            (129, 70, 7),
        ] {
            let (shape, leaves) = random_tree(w, h, seed, |d| d % 3 != 0);
            assert_eq!(
                pruned_one_level(&shape, &leaves),
                pruned_by_counting(&shape, &leaves),
                "{w}x{h}"
            );
            let (shape, leaves) = random_tree(w, h, seed, |d| d % 5 < 2);
            assert_eq!(
                pruned_one_level(&shape, &leaves),
                pruned_by_counting(&shape, &leaves),
                "{w}x{h}"
            );
        }
    }

    #[test]
    fn leaves_tile_the_image_exactly() {
        let (shape, leaves) = random_tree(37, 21, 0, |d| !d.is_multiple_of(3));
        let mut cover = vec![0u8; 37 * 21];
        for l in &leaves {
            let (x0, y0, x1, y1) = l.clip(37, 21);
            for y in y0..y1 {
                for x in x0..x1 {
                    cover[(y * 37 + x) as usize] += 1;
                }
            }
        }
        assert!(cover.iter().all(|&c| c == 1));
        let chroma = pruned_one_level(&shape, &leaves);
        let mut cover = vec![0u8; 37 * 21];
        for l in &chroma {
            let (x0, y0, x1, y1) = l.clip(37, 21);
            for y in y0..y1 {
                for x in x0..x1 {
                    cover[(y * 37 + x) as usize] += 1;
                }
            }
        }
        assert!(cover.iter().all(|&c| c == 1));
        assert!(chroma.len() < leaves.len());
    }
}
