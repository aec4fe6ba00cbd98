//! Batch evaluation: blocks of inputs in parallel (rayon), each block binned into
//! spatial cells that share one support query, and the cells' inputs evaluated by the
//! SIMD kernel where it applies.

use pulp::{Arch, Simd, WithSimd};
use rayon::prelude::*;

use super::kernel::Gathered;
use super::{Network, MAX_DIM};
use crate::error::{check_finite, Result, SurfaceError};

/// Inputs per parallel task in batch evaluation (fixed, so output never depends on threads).
const BATCH_BLOCK: usize = 16384;
/// Highest input dimension binned into cells; larger ones fall back to one query each.
const MAX_BIN_DIM: usize = 6;
/// Side of a binning cell as a fraction of the finest support radius: larger cells mean
/// fewer spatial queries but more candidates per input.
const CELL_FACTOR: f64 = 0.5;

impl Network {
    /// Evaluates a batch of inputs (`xs` is N x m row-major) in parallel; returns N x p.
    ///
    /// Consecutive inputs that lie close together share one spatial query, so batches
    /// ordered along the domain (grids, scanlines, tiles) are fastest. The result does
    /// not depend on the number of threads.
    ///
    /// For m = 3 with compact support the kernel runs in SIMD lanes (AVX2 + FMA, or
    /// plain scalar on CPUs without them, chosen at run time by `pulp`). Its sums are
    /// split across lanes and use fused multiply-adds where the CPU has them, so a batch
    /// result can differ from [`Self::eval`] (and between CPUs with and without AVX2) by
    /// rounding only; tests hold both to brute force within 1e-12. On one CPU the output
    /// bits are the same for any thread count.
    pub fn eval_batch(&self, xs: &[f64]) -> Result<Vec<f64>> {
        if !xs.len().is_multiple_of(self.m) {
            return Err(SurfaceError::Dimension {
                what: "batch of inputs (N x m)".into(),
                expected: (xs.len() / self.m + 1) * self.m,
                got: xs.len(),
            });
        }
        check_finite(|| "batch input".into(), xs)?;
        let (m, p) = (self.m, self.p);
        let count = xs.len() / m;
        let mut out = vec![0.0; count * p];
        out.par_chunks_mut(BATCH_BLOCK * p)
            .zip(xs.par_chunks(BATCH_BLOCK * m))
            .for_each_init(Scratch::default, |scratch, (ys, xs)| {
                Arch::new().dispatch(Block {
                    net: self,
                    xs,
                    ys,
                    scratch,
                })
            });
        Ok(out)
    }

    /// Evaluates one block sequentially: inputs are binned into spatial cells, each cell
    /// makes one spatial query, and its inputs are evaluated against those candidates.
    #[inline(always)]
    fn eval_block<S: Simd>(&self, simd: S, xs: &[f64], ys: &mut [f64], scratch: &mut Scratch) {
        let (m, p) = (self.m, self.p);
        let Scratch {
            bins,
            cand,
            gathered,
        } = scratch;
        let Some(index) = &self.index else {
            self.candidates(&[], 0.0, 0.0, cand);
            for (x, y) in xs.chunks_exact(m).zip(ys.chunks_exact_mut(p)) {
                self.accumulate(x, cand, y);
            }
            return;
        };
        bins.bin(xs, m, CELL_FACTOR * index.finest_radius);
        // With no global key point every candidate is compact: the SIMD kernel applies.
        let fast = m == 3 && self.global.is_empty();
        let mut centre = [0.0; MAX_DIM];
        let centre = &mut centre[..m];
        for group in bins.starts.windows(2) {
            let group = &bins.order[group[0] as usize..group[1] as usize];
            let (spread, max_norm2) = bounding_ball(xs, m, group, centre);
            self.candidates(centre, spread, max_norm2, cand);
            let members = group.iter().map(|&j| j as usize);
            if fast {
                gathered.load(simd, self, cand);
                gathered.eval_compact3(simd, self.normalised, xs, ys, members);
            } else {
                for j in members {
                    self.accumulate(&xs[j * m..(j + 1) * m], cand, &mut ys[j * p..(j + 1) * p]);
                }
            }
        }
    }
}

/// The inputs of a block grouped by the cubic binning cell they fall in: group `g` is
/// `order[starts[g]..starts[g + 1]]`, groups in order of first appearance, members
/// ascending (deterministic). Buffers are kept from block to block.
#[derive(Default)]
struct Bins {
    /// Cell key of each input.
    keys: Vec<u64>,
    /// Group of each input.
    group: Vec<u32>,
    /// Open-addressing hash table: cell key, group, and the `stamp` of the block that
    /// wrote the slot (older slots count as empty, so the table is never cleared).
    table: Vec<(u64, u32, u32)>,
    stamp: u32,
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl Bins {
    /// Bins the inputs `xs` (N x m) into cells of side `cell`.
    #[inline(always)]
    fn bin(&mut self, xs: &[f64], m: usize, cell: f64) {
        let count = xs.len() / m;
        self.order.clear();
        self.starts.clear();
        if m > MAX_BIN_DIM || cell.is_nan() || cell <= 0.0 {
            // One group per input.
            self.order.extend(0..count as u32);
            self.starts.extend(0..=count as u32);
            return;
        }
        let inv = 1.0 / cell;
        // Cell coordinates packed into one key below 2^63 (so `u64::MAX` is never a key),
        // `bits` per axis; coordinates beyond the range clamp into the edge cell, which
        // only widens that group's query (still exact). Truncating after the offset is
        // floor() up to rounding at cell borders, which only moves an input to the
        // neighbouring cell: grouping never affects exactness.
        let bits = 63 / m as u32;
        let half = (1u64 << (bits - 1)) as f64;
        let top = ((1u64 << bits) - 1) as f64;
        self.keys.clear();
        for x in xs.chunks_exact(m) {
            let mut key = 0u64;
            for v in x {
                key = (key << bits) | (v * inv + half).clamp(0.0, top) as i64 as u64;
            }
            self.keys.push(key);
        }
        let size = (2 * count).next_power_of_two().max(16);
        let shift = 64 - size.trailing_zeros();
        self.stamp = self.stamp.wrapping_add(1);
        if self.table.len() < size || self.stamp == 0 {
            self.table.clear();
            self.table.resize(size.max(self.table.len()), (0, 0, 0));
            self.stamp = 1;
        }
        let stamp = self.stamp;
        let table = &mut self.table[..size];
        self.group.clear();
        // Counts per group first, in `starts`.
        let mut last = (u64::MAX, 0u32);
        for &key in &self.keys {
            if key != last.0 {
                let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> shift) as usize;
                let g = loop {
                    let slot = &mut table[h];
                    if slot.2 != stamp {
                        *slot = (key, self.starts.len() as u32, stamp);
                        self.starts.push(0);
                        break slot.1;
                    }
                    if slot.0 == key {
                        break slot.1;
                    }
                    h = (h + 1) & (size - 1);
                };
                last = (key, g);
            }
            self.starts[last.1 as usize] += 1;
            self.group.push(last.1);
        }
        // Exclusive prefix sums, then scatter (members stay ascending).
        let mut sum = 0;
        for s in self.starts.iter_mut() {
            let c = *s;
            *s = sum;
            sum += c;
        }
        self.starts.push(sum);
        self.order.resize(count, 0);
        let mut next = self.starts.clone();
        for (j, &g) in self.group.iter().enumerate() {
            self.order[next[g as usize] as usize] = j as u32;
            next[g as usize] += 1;
        }
    }
}

/// Centre (written to `centre`), radius and largest squared norm of a group of inputs
/// (binning keys): the centre and half diagonal of their bounding box.
#[inline(always)]
fn bounding_ball(xs: &[f64], m: usize, group: &[u32], centre: &mut [f64]) -> (f64, f64) {
    let mut lo = [f64::INFINITY; MAX_DIM];
    let mut hi = [f64::NEG_INFINITY; MAX_DIM];
    let mut max_norm2 = 0.0f64;
    for &j in group {
        let j = j as usize;
        let x = &xs[j * m..(j + 1) * m];
        let mut n2 = 0.0;
        for (a, &v) in x.iter().enumerate() {
            lo[a] = lo[a].min(v);
            hi[a] = hi[a].max(v);
            n2 += v * v;
        }
        max_norm2 = max_norm2.max(n2);
    }
    let (mut spread2, mut size) = (0.0, 0.0f64);
    for a in 0..m {
        centre[a] = 0.5 * (lo[a] + hi[a]);
        let h = 0.5 * (hi[a] - lo[a]);
        spread2 += h * h;
        size = size.max(centre[a].abs());
    }
    // Pad for the rounding of the centre, so the query stays a superset.
    let spread = spread2.sqrt();
    (spread + 1e-12 * (spread + size) + 1e-15, max_norm2)
}

/// Per-thread scratch of batch evaluation, reused from block to block.
#[derive(Default)]
struct Scratch {
    bins: Bins,
    cand: Vec<u32>,
    gathered: Gathered,
}

/// One block of [`Network::eval_batch`], compiled for the SIMD level `pulp` picks.
struct Block<'a> {
    net: &'a Network,
    xs: &'a [f64],
    ys: &'a mut [f64],
    scratch: &'a mut Scratch,
}

impl WithSimd for Block<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        self.net.eval_block(simd, self.xs, self.ys, self.scratch);
    }
}

/// One block through `eval_block` at the given SIMD level.
#[cfg(test)]
pub(super) fn block_with<S: Simd>(simd: S, net: &Network, xs: &[f64]) -> Vec<f64> {
    let mut ys = vec![0.0; xs.len() / net.m * net.p];
    Block {
        net,
        xs,
        ys: &mut ys,
        scratch: &mut Scratch::default(),
    }
    .with_simd(simd);
    ys
}

#[cfg(test)]
mod tests {
    use super::super::test_rng::uniform;
    use super::*;

    /// Binning groups every input exactly once, members ascending, whatever the cell;
    /// one `Bins` reused across blocks of different sizes (its table is never cleared).
    #[test]
    fn bins_partition_the_block() {
        let mut st = 9;
        let mut bins = Bins::default();
        let xs: Vec<f64> = (0..3000).map(|_| 4.0 * uniform(&mut st) - 2.0).collect();
        for (m, cell) in [
            (3usize, 0.3),
            (3, 1e-9),
            (3, 1e9),
            (1, 0.01),
            (6, 0.5),
            (10, 0.5),
            (3, 0.0),
        ] {
            let xs = &xs[..xs.len() / m * m / (1 + m % 2)];
            bins.bin(xs, m, cell);
            let mut seen = vec![false; xs.len() / m];
            for g in bins.starts.windows(2) {
                let members = &bins.order[g[0] as usize..g[1] as usize];
                assert!(!members.is_empty() && members.windows(2).all(|w| w[0] < w[1]));
                members.iter().for_each(|&j| seen[j as usize] = true);
            }
            assert!(seen.iter().all(|s| *s) && bins.order.len() == seen.len());
            // Same cells, same groups, when the block is binned again.
            let before = (bins.starts.clone(), bins.order.clone());
            bins.bin(xs, m, cell);
            assert_eq!(before, (bins.starts.clone(), bins.order.clone()));
        }
    }
}
