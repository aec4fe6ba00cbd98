//! Evaluation of a key set on a regular grid by splatting: each key point adds its
//! kernel to the grid points inside its support, row by row, instead of each grid point
//! searching for the key points that reach it.
//!
//! The kernel is the core's `Blend::Compact` in the form the stereographic embedding
//! gives it. With plane coordinates `u = (x - W/2) / S` (see [`Frame`]), the chord between
//! the sphere points of two pixel positions satisfies `1 - s = 2 d^2 / ((1 + r_c^2)(1 + r_p^2))`
//! for plane distance `d`, so `q (1 - s) / 3 = a_i * d_px^2 * g(p)` with a per-key-point
//! `a_i = 2 q_i / (3 S^2 (1 + r_c^2))` and a per-grid-point `g(p) = 1 / (1 + r_p^2)`. That
//! keeps the inner loop to a handful of multiply-adds over contiguous grid points, which
//! the compiler vectorises for the widest unit `pulp` finds at run time (AVX2, AVX-512 or
//! the baseline), and it avoids the dot product's cancellation `1 - s` near the centre. The per-pixel path ([`KeySet::kernels_at`]) stays as the reference; tests check
//! the two agree to rounding.
//!
//! Sums run over key points in coding order for every grid point, whatever the band
//! split, so the result does not depend on the thread count.

use rayon::prelude::*;

use super::{Frame, KeySet};

/// Grid rows evaluated together by one task.
const BAND: usize = 16;

/// Grid points a splat row handles per step. Rows are short (a 1-pixel key point's
/// support spans 3 pixels), so rather than a vector loop with a scalar tail, every row
/// is covered by whole steps of this many points; the points past the support's end
/// get the kernel's exact value there, zero, so the result is the same.
const LANES: usize = 8;

/// A regular grid of evaluation positions in coded-image pixel units:
/// `(x0 + i dx, y0 + j dy)` for `i < nx`, `j < ny`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// First column's x.
    pub x0: f64,
    /// Column spacing.
    pub dx: f64,
    /// Number of columns.
    pub nx: usize,
    /// First row's y.
    pub y0: f64,
    /// Row spacing.
    pub dy: f64,
    /// Number of rows.
    pub ny: usize,
}

impl Grid {
    /// The pixel centres of an `out_w x out_h` image stretched over the coded frame.
    pub fn pixel_centres(frame: &Frame, out_w: u32, out_h: u32) -> Grid {
        let (dx, dy) = (
            frame.width as f64 / out_w as f64,
            frame.height as f64 / out_h as f64,
        );
        Grid {
            x0: 0.5 * dx,
            dx,
            nx: out_w as usize,
            y0: 0.5 * dy,
            dy,
            ny: out_h as usize,
        }
    }

    /// Column `i`'s x.
    #[inline]
    pub fn x(&self, i: usize) -> f64 {
        self.x0 + i as f64 * self.dx
    }

    /// Row `j`'s y.
    #[inline]
    pub fn y(&self, j: usize) -> f64 {
        self.y0 + j as f64 * self.dy
    }

    /// Grid indices `lo..=hi` along one axis whose coordinate lies within `[c - r, c + r]`,
    /// or `None` when none does.
    fn span(c: f64, r: f64, origin: f64, step: f64, n: usize) -> Option<(usize, usize)> {
        // Clamped to the grid before rounding; ceil and floor by casts, which compile to
        // a few instructions where the library calls would not.
        let lo = ((c - r - origin) / step).clamp(0.0, n as f64);
        let hi = ((c + r - origin) / step).clamp(-1.0, n as f64 - 1.0);
        let (lo_t, hi_t) = (lo as i64, hi as i64);
        let lo = lo_t + i64::from((lo_t as f64) < lo);
        let hi = hi_t - i64::from((hi_t as f64) > hi);
        (lo <= hi).then_some((lo as usize, hi as usize))
    }
}

/// One key point as the splat loop needs it.
#[derive(Debug, Clone, Copy)]
struct Splat {
    cx: f64,
    cy: f64,
    /// Grid columns within the radius.
    cols: (usize, usize),
    /// `2 q / (3 S^2 (1 + r_c^2))`: the kernel is `weight * (1 - a d^2 g)^3`.
    a: f32,
    weight: f32,
    rows: (usize, usize),
}

impl KeySet {
    fn splats(&self, grid: &Grid) -> Vec<Option<Splat>> {
        let inv_scale = 1.0 / self.frame.width.max(self.frame.height).max(1) as f64;
        (0..self.len())
            .into_par_iter()
            .map(|i| {
                let (cx, cy) = self.centres[i];
                let radius = self.frame.support_radius(cx, cy, self.sigma[i]);
                let cols = Grid::span(cx, radius, grid.x0, grid.dx, grid.nx)?;
                let rows = Grid::span(cy, radius, grid.y0, grid.dy, grid.ny)?;
                let (u, v) = self.frame.plane(cx, cy);
                let a = 2.0 * self.q[i] * inv_scale * inv_scale / (3.0 * (1.0 + u * u + v * v));
                Some(Splat {
                    cx,
                    cy,
                    cols,
                    a: a as f32,
                    weight: self.weight[i] as f32,
                    rows,
                })
            })
            .collect()
    }

    /// Evaluates `values` (planes with one value per key point) at every point of `grid`,
    /// normalised; a point no kernel reaches gets 0. Planes come back row-major.
    ///
    /// Kernels and sums are single precision (relative error ~1e-7, far below any output
    /// quantum): twice the lanes per vector of the double-precision reference.
    pub fn eval_grid(&self, values: &[Vec<f64>], grid: &Grid) -> Vec<Vec<f32>> {
        let (nx, ny) = (grid.nx, grid.ny);
        let mut planes = vec![vec![0.0f32; nx * ny]; values.len()];
        if nx == 0 || ny == 0 || values.is_empty() {
            return planes;
        }
        let splats = self.splats(grid);
        // Key points per band, in coding order (a counting sort over the bands each spans).
        let bands = ny.div_ceil(BAND);
        let mut start = vec![0usize; bands + 1];
        for s in splats.iter().flatten() {
            for b in s.rows.0 / BAND..=s.rows.1 / BAND {
                start[b + 1] += 1;
            }
        }
        for b in 0..bands {
            start[b + 1] += start[b];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[bands]];
        for (i, s) in splats.iter().enumerate() {
            if let Some(s) = s {
                for b in s.rows.0 / BAND..=s.rows.1 / BAND {
                    items[fill[b]] = i as u32;
                    fill[b] += 1;
                }
            }
        }
        // Rows are padded so a row's last step never leaves its buffer (the padding's
        // values are never read back).
        let stride = nx.next_multiple_of(LANES) + LANES;
        // Offsets from a row segment's first column, so positions stay exact in single
        // precision however wide the image: the segment's own offset from the key point
        // is formed in double precision.
        let xs: Vec<f32> = (0..stride).map(|k| (k as f64 * grid.dx) as f32).collect();
        let inv_scale = 1.0 / self.frame.width.max(self.frame.height).max(1) as f64;
        let plane_u2: Vec<f32> = (0..stride)
            .map(|i| {
                let u = (grid.x(i.min(nx - 1)) - 0.5 * self.frame.width as f64) * inv_scale;
                (u * u) as f32
            })
            .collect();
        let values_f32: Vec<Vec<f32>> = values
            .iter()
            .map(|v| v.iter().map(|&x| x as f32).collect())
            .collect();

        // Each band's rows of every plane, handed to one task.
        let mut chunks: Vec<Vec<&mut [f32]>> = (0..bands).map(|_| Vec::new()).collect();
        for plane in planes.iter_mut() {
            for (b, rows) in plane.chunks_mut(BAND * nx).enumerate() {
                chunks[b].push(rows);
            }
        }
        let arch = pulp::Arch::new();
        let ctx = Band {
            splats: &splats,
            grid,
            frame: &self.frame,
            xs: &xs,
            stride,
        };
        chunks.into_par_iter().enumerate().for_each_init(
            || (Vec::new(), Vec::new()),
            |(g, acc), (b, mut out)| {
                // Compiled for the widest vector unit the CPU has. No fused multiply-adds
                // are formed (Rust never contracts), so every unit gives the same bits.
                arch.dispatch(BandPass {
                    band: &ctx,
                    list: &items[start[b]..start[b + 1]],
                    values: &values_f32,
                    plane_u2: &plane_u2,
                    j0: b * BAND,
                    g,
                    acc,
                    out: &mut out,
                });
            },
        );
        planes
    }
}

/// What every band's pass reads.
struct Band<'a> {
    splats: &'a [Option<Splat>],
    grid: &'a Grid,
    frame: &'a Frame,
    xs: &'a [f32],
    stride: usize,
}

impl Band<'_> {
    /// Splats the key points `list` over the band starting at row `j0`; `acc` holds the
    /// kernel sum then the `NC` value planes, each `rows x nx`.
    #[inline(always)]
    fn splat<const NC: usize>(
        &self,
        list: &[u32],
        values: &[Vec<f32>],
        g: &[f32],
        j0: usize,
        acc: &mut [f32],
    ) {
        let grid = self.grid;
        let stride = self.stride;
        let plane = g.len();
        let rows = plane / stride;
        let (sum, rest) = acc.split_at_mut(plane);
        let mut chunks = rest.chunks_exact_mut(plane);
        let mut planes: [&mut [f32]; NC] =
            std::array::from_fn(|_| chunks.next().expect("NC planes follow the sum"));
        for &i in list {
            let Some(s) = self.splats[i as usize] else {
                continue;
            };
            let vals: [f32; NC] = std::array::from_fn(|c| values[c][i as usize]);
            let r0 = s.rows.0.max(j0);
            let r1 = s.rows.1.min(j0 + rows - 1);
            // Whole bounding-box rows: trimming each row to the disc's chord cost more
            // (a square root and two divisions per row) than the steps it saved.
            let (c0, steps) = (s.cols.0, (s.cols.1 - s.cols.0) / LANES + 1);
            let x0 = (grid.x(c0) - s.cx) as f32;
            for j in r0..r1 + 1 {
                let dy = grid.y(j) - s.cy;
                let off = (j - j0) * stride + c0;
                let range = off..off + steps * LANES;
                let mut it = planes.iter_mut();
                let rows_out: [&mut [f32]; NC] = std::array::from_fn(|_| match it.next() {
                    Some(p) => &mut p[range.clone()],
                    None => &mut [],
                });
                splat_row::<NC>(
                    &self.xs[..steps * LANES],
                    &g[range.clone()],
                    &mut sum[range],
                    rows_out,
                    Kernel {
                        x0,
                        a: s.a,
                        a_dy2: s.a * (dy * dy) as f32,
                        weight: s.weight,
                    },
                    vals,
                );
            }
        }
    }
}

/// Everything one band computes, as a `pulp` operation: the conformal factors, the
/// splats and the normalisation are all inlined into the target-feature function
/// `pulp` picks, which is what vectorises them.
struct BandPass<'a, 'o> {
    band: &'a Band<'a>,
    list: &'a [u32],
    values: &'a [Vec<f32>],
    plane_u2: &'a [f32],
    j0: usize,
    g: &'a mut Vec<f32>,
    acc: &'a mut Vec<f32>,
    out: &'a mut [&'o mut [f32]],
}

impl pulp::WithSimd for BandPass<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let band = self.band;
        let (grid, frame, stride) = (band.grid, band.frame, band.stride);
        let nx = grid.nx;
        let rows = BAND.min(grid.ny - self.j0);
        let inv_scale = 1.0 / frame.width.max(frame.height).max(1) as f64;
        self.g.clear();
        for r in 0..rows {
            let v = (grid.y(self.j0 + r) - 0.5 * frame.height as f64) * inv_scale;
            let v2 = (v * v) as f32;
            self.g
                .extend(self.plane_u2.iter().map(|u2| 1.0 / (1.0 + u2 + v2)));
        }
        let plane = rows * stride;
        // Up to four planes share one pass; more take further passes.
        for (group, vals) in self.out.chunks_mut(4).zip(self.values.chunks(4)) {
            self.acc.clear();
            self.acc.resize((vals.len() + 1) * plane, 0.0f32);
            let (g, acc) = (&self.g[..], &mut self.acc[..]);
            match vals.len() {
                1 => band.splat::<1>(self.list, vals, g, self.j0, acc),
                2 => band.splat::<2>(self.list, vals, g, self.j0, acc),
                3 => band.splat::<3>(self.list, vals, g, self.j0, acc),
                _ => band.splat::<4>(self.list, vals, g, self.j0, acc),
            }
            let (sum, planes) = self.acc.split_at_mut(plane);
            for s in sum.iter_mut() {
                *s = if *s > 0.0 { 1.0 / *s } else { 0.0 };
            }
            for (o, a) in group.iter_mut().zip(planes.chunks_exact(plane)) {
                for ((o, a), inv) in o
                    .chunks_exact_mut(nx)
                    .zip(a.chunks_exact(stride))
                    .zip(sum.chunks_exact(stride))
                {
                    for ((o, &a), &inv) in o.iter_mut().zip(a).zip(inv) {
                        *o = a * inv;
                    }
                }
            }
        }
    }
}

/// One key point's kernel on one row: `weight (1 - g (a dx^2 + a_dy2))^3`, clamped at 0,
/// with `dx = x0 + k dx_grid` at the segment's `k`-th point.
#[derive(Debug, Clone, Copy)]
struct Kernel {
    /// The segment's first point's x offset from the key point.
    x0: f32,
    a: f32,
    a_dy2: f32,
    weight: f32,
}

/// The inner loop: one key point's kernel over one row segment, a whole number of
/// [`LANES`]-point steps long.
#[inline(always)]
fn splat_row<const NC: usize>(
    xs: &[f32],
    g: &[f32],
    sum: &mut [f32],
    acc: [&mut [f32]; NC],
    k: Kernel,
    vals: [f32; NC],
) {
    let (xs, _) = xs.as_chunks::<LANES>();
    let (g, _) = g.as_chunks::<LANES>();
    let (sum, _) = sum.as_chunks_mut::<LANES>();
    let steps = xs.len().min(g.len()).min(sum.len());
    // Every plane cut to the same length, so the loop below has no bounds checks.
    let acc: [&mut [[f32; LANES]]; NC] = acc.map(|a| &mut a.as_chunks_mut::<LANES>().0[..steps]);
    let (xs, g, sum) = (&xs[..steps], &g[..steps], &mut sum[..steps]);
    for s in 0..steps {
        let (x, g) = (&xs[s], &g[s]);
        let mut w = [0.0f32; LANES];
        for l in 0..LANES {
            let dx = x[l] + k.x0;
            let t = 1.0 - g[l] * (k.a * dx * dx + k.a_dy2);
            let t = if t > 0.0 { t } else { 0.0 };
            w[l] = k.weight * (t * t * t);
        }
        let out = &mut sum[s];
        for l in 0..LANES {
            out[l] += w[l];
        }
        for c in 0..NC {
            let out = &mut acc[c][s];
            for l in 0..LANES {
                out[l] += w[l] * vals[c];
            }
        }
    }
}
