//! The detail layer: what the smooth key-point network leaves, transform-coded.
//!
//! The colour channels' residual after the network (coding space, coded size) is cut
//! into 8x8 blocks, each an orthonormal DCT ([`dct`]) quantised with one step per channel
//! kind (luma, chroma) and coded by [`syntax`]. The decoder adds the blocks' cosine
//! series to the network's colours at every sample position it evaluates, so the layer
//! follows the network to any output size or supersampling: the series is a function
//! defined everywhere in its block, not a table of pixels.

pub mod dct;
pub mod quantise;
pub mod syntax;

use dct::{COEFFS, N};

use super::entropy::AnsSource;
use super::keyset::Grid;
use super::CodecError;
use syntax::{BlockContext, DetailContexts};

/// Marks a block with no nonzero coefficient.
const ZERO: u32 = u32::MAX;

/// The blocks covering a `width x height` image: `(columns, rows)`.
pub fn blocks(width: u32, height: u32) -> (usize, usize) {
    (
        (width as usize).div_ceil(N),
        (height as usize).div_ceil(N),
    )
}

/// One channel's quantised coefficients.
#[derive(Debug, Clone, PartialEq)]
pub struct DetailPlane {
    /// Blocks per row.
    pub cols: usize,
    /// Block rows.
    pub rows: usize,
    /// Per block: its index in `levels`, or [`ZERO`].
    index: Vec<u32>,
    /// Row-major levels of the coded blocks.
    levels: Vec<[i32; COEFFS]>,
}

impl DetailPlane {
    /// A plane of `cols x rows` blocks from per-block levels (all-zero blocks dropped).
    pub fn from_blocks(cols: usize, rows: usize, blocks: Vec<[i32; COEFFS]>) -> Self {
        debug_assert_eq!(blocks.len(), cols * rows);
        let mut index = Vec::with_capacity(blocks.len());
        let mut levels = Vec::new();
        for b in blocks {
            if b.iter().all(|&v| v == 0) {
                index.push(ZERO);
            } else {
                index.push(levels.len() as u32);
                levels.push(b);
            }
        }
        DetailPlane {
            cols,
            rows,
            index,
            levels,
        }
    }

    /// The levels of block `(bx, by)`, if it has a nonzero one.
    pub fn block(&self, bx: usize, by: usize) -> Option<&[i32; COEFFS]> {
        let i = self.index[by * self.cols + bx];
        (i != ZERO).then(|| &self.levels[i as usize])
    }

    /// Number of blocks with a nonzero coefficient.
    pub fn coded_blocks(&self) -> usize {
        self.levels.len()
    }

    /// Reads a `cols x rows` plane.
    pub fn read(
        cols: usize,
        rows: usize,
        kind: usize,
        ctx: &mut DetailContexts,
        src: &mut AnsSource,
    ) -> Result<Self, CodecError> {
        let mut plane = DetailPlane {
            cols,
            rows,
            index: Vec::with_capacity(cols * rows),
            levels: Vec::new(),
        };
        let mut q = [0i32; COEFFS];
        for by in 0..rows {
            for bx in 0..cols {
                // The context reads only blocks already pushed (left and above).
                let at = {
                    let coded = |i: usize| usize::from(plane.index[i] != ZERO);
                    let mut n = 0;
                    if bx > 0 {
                        n += coded(by * cols + bx - 1);
                    }
                    if by > 0 {
                        n += coded((by - 1) * cols + bx);
                    }
                    BlockContext {
                        kind,
                        neighbours: n,
                    }
                };
                if syntax::read_block(ctx, at, &mut q, src)? {
                    plane.index.push(plane.levels.len() as u32);
                    plane.levels.push(q);
                } else {
                    plane.index.push(ZERO);
                }
            }
        }
        Ok(plane)
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
}

impl Detail {
    /// Reads the section of a `width x height` image with these steps (one per colour
    /// channel): a u32 byte count of the luma stream, the luma stream, the chroma stream.
    pub fn read(
        payload: &[u8],
        width: u32,
        height: u32,
        steps: Vec<f64>,
    ) -> Result<Self, CodecError> {
        let (cols, rows) = blocks(width, height);
        if payload.len() < 4 {
            return Err(CodecError::Truncated {
                what: "the detail section's stream length",
                offset: 0,
                need: 4,
                available: payload.len() as u64,
            });
        }
        let n = u32::from_le_bytes([payload[0], payload[1], payload[2], payload[3]]) as usize;
        if n > payload.len() - 4 {
            return Err(CodecError::Truncated {
                what: "the detail section's luma stream",
                offset: 4,
                need: n as u64,
                available: payload.len() as u64 - 4,
            });
        }
        let (luma, chroma) = payload[4..].split_at(n);
        let per_plane = syntax::MAX_SYMBOLS_PER_BLOCK * (cols * rows) as u64;
        let stream = |bytes: &[u8], kind: usize, planes: usize| -> Result<_, CodecError> {
            let mut src = AnsSource::new(bytes, per_plane * planes as u64)?;
            let mut ctx = DetailContexts::default();
            let planes = (0..planes)
                .map(|_| DetailPlane::read(cols, rows, kind, &mut ctx, &mut src))
                .collect::<Result<Vec<_>, _>>()?;
            if !src.finished_cleanly() {
                return Err(CodecError::Format(
                    "detail stream does not end where its syntax does".into(),
                ));
            }
            Ok(planes)
        };
        let (l, c) = rayon::join(
            || stream(luma, 0, 1),
            || stream(chroma, 1, steps.len() - 1),
        );
        let mut planes = l?;
        planes.extend(c?);
        Ok(Detail { planes, steps })
    }

    /// Bytes per pixel the decoder holds for the layer at most (levels and their
    /// dequantised coefficients), for memory estimates.
    pub const BYTES_PER_PIXEL: u64 = 2 * 4 + 2;
}

/// The detail layer prepared for evaluation on one grid.
pub struct DetailEval {
    grid: Grid,
    /// Per plane: dequantised coefficients of the coded blocks, and the block index.
    planes: Vec<(Vec<[f32; COEFFS]>, Vec<u32>, usize)>,
    /// Per block column: the grid columns it covers and their basis values.
    columns: Vec<(usize, usize)>,
    basis_x: Vec<[f32; N]>,
    /// Per grid row: block row and basis values.
    rows: Vec<(usize, [f32; N])>,
}

/// Block index and in-block position of coordinate `p` (pixels), clamped to the
/// blocks: positions off the image belong to its edge blocks' series.
#[inline]
fn locate(p: f64, count: usize) -> (usize, f64) {
    let b = (p / N as f64).floor().clamp(0.0, count as f64 - 1.0) as usize;
    (b, p - (b * N) as f64)
}

impl DetailEval {
    /// Prepares `detail` for evaluation at the positions of `grid` (coded pixels).
    pub fn new(detail: &Detail, grid: &Grid) -> Self {
        let (cols, rows) = detail
            .planes
            .first()
            .map_or((1, 1), |p| (p.cols, p.rows));
        let mut columns = vec![(0usize, 0usize); cols];
        let mut basis_x = Vec::with_capacity(grid.nx);
        let mut last = None;
        for i in 0..grid.nx {
            let (b, t) = locate(grid.x(i), cols);
            basis_x.push(dct::basis_at(t));
            if last != Some(b) {
                columns[b].0 = i;
                last = Some(b);
            }
            columns[b].1 = i + 1;
        }
        let rows_basis = (0..grid.ny)
            .map(|j| {
                let (b, t) = locate(grid.y(j), rows);
                (b, dct::basis_at(t))
            })
            .collect();
        let planes = detail
            .planes
            .iter()
            .zip(&detail.steps)
            .map(|(p, &step)| {
                let coeffs = p
                    .levels
                    .iter()
                    .map(|l| std::array::from_fn(|i| (l[i] as f64 * step) as f32))
                    .collect();
                (coeffs, p.index.clone(), p.cols)
            })
            .collect();
        DetailEval {
            grid: *grid,
            planes,
            columns,
            basis_x,
            rows: rows_basis,
        }
    }

    /// Adds the layer to grid rows `j0..j0 + n`: `out[c]` holds plane `c`'s rows, `n`
    /// rows of the grid's width each.
    pub fn add_rows(&self, j0: usize, out: &mut [&mut [f32]]) {
        let nx = self.grid.nx;
        for ((coeffs, index, cols), plane) in self.planes.iter().zip(out.iter_mut()) {
            if coeffs.is_empty() {
                continue;
            }
            for (r, row) in plane.chunks_exact_mut(nx).enumerate() {
                let (by, bv) = self.rows[j0 + r];
                for bx in 0..*cols {
                    let i = index[by * cols + bx];
                    let (c0, c1) = self.columns[bx];
                    if i == ZERO || c0 >= c1 {
                        continue;
                    }
                    let c = &coeffs[i as usize];
                    // The block's row of the series at this y: g(u) = sum_v C[v][u] b_v(y).
                    let mut g = [0f32; N];
                    for (v, &b) in bv.iter().enumerate() {
                        for u in 0..N {
                            g[u] += c[v * N + u] * b;
                        }
                    }
                    for (o, bu) in row[c0..c1].iter_mut().zip(&self.basis_x[c0..c1]) {
                        let mut s = 0f32;
                        for u in 0..N {
                            s += g[u] * bu[u];
                        }
                        *o += s;
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
