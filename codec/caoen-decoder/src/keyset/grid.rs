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

use crate::par::*;

use super::{Frame, KernelParams, KeySet, MIN_SIGMA_FACTOR};
use crate::geometry::SUPPORT_SIGMAS;
use crate::quadtree::Cell;

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
    /// or `None` when none does (`inv_step` is the reciprocal of the axis' spacing).
    #[inline]
    fn span(c: f64, r: f64, origin: f64, inv_step: f64, n: usize) -> Option<(usize, usize)> {
        let (lo, hi) = ((c - r - origin) * inv_step, (c + r - origin) * inv_step);
        // ceil and floor by casts, which compile to a few instructions where the library
        // calls would not; `as` saturates, so far-off positions stay harmless.
        let (lo_t, hi_t) = (lo as i64, hi as i64);
        let lo = (lo_t + i64::from((lo_t as f64) < lo)).max(0);
        let hi = (hi_t - i64::from((hi_t as f64) > hi)).min(n as i64 - 1);
        (lo <= hi).then_some((lo as usize, hi as usize))
    }
}

/// One key point as the splat loop needs it.
#[derive(Debug, Clone, Copy)]
struct Splat {
    cy: f64,
    /// First grid column of the support's bounding box.
    c0: u32,
    /// [`LANES`]-point steps that cover the box's columns.
    steps: u32,
    /// First and last grid row of the box.
    rows: (u32, u32),
    /// Column `c0`'s x offset from the key point.
    x0: f32,
    /// The cube root of the weight: the kernel is `(c - c a d^2 g)^3`.
    c: f32,
    /// `c a`, where `a = 2 q / (3 S^2 (1 + r_c^2))`: the kernel is
    /// `weight * (1 - a d^2 g)^3`.
    ca: f32,
    /// The key point's index (into the value planes).
    key: u32,
}

/// A key set and its values prepared for evaluation on one grid, band by band: two key
/// sets on the same grid (luma and chroma) can then be evaluated band by band side by
/// side and their results consumed while they are still in cache.
pub struct GridEval<'c> {
    grid: Grid,
    frame: Frame,
    builder: SplatBuilder,
    cells: &'c [Cell],
    /// Per band, the cells `lo..hi` from the first to the last whose splat reaches it.
    /// Coding order runs through the image in block rows, so a window is a few block
    /// rows of cells; a band pass builds their splats as it goes, and no splat is
    /// stored or sorted.
    windows: Vec<(u32, u32)>,
    /// Per cell, the first and last band its splat reaches (`[MAX, 0]` for none): a
    /// window's cells outside the band are skipped on a 4-byte load.
    cell_bands: Vec<[u16; 2]>,
    values: Vec<Vec<f32>>,
    /// Offsets of a row segment's points from its first column.
    xs: Vec<f32>,
    /// `u^2` of every (padded) column.
    plane_u2: Vec<f32>,
    /// Row length of the band buffers: padded so a row's last step never leaves it.
    stride: usize,
    arch: pulp::Arch,
}

/// Per-task buffers of [`GridEval::conformal`] and [`GridEval::eval_band`], reused
/// from band to band.
#[derive(Debug, Default)]
pub struct BandScratch {
    /// The conformal factors `g` of the band's grid points.
    g: Vec<f32>,
    /// The kernel sum and value accumulators of the band.
    acc: Vec<f32>,
    /// One key point's `a dx^2` per step of its row segment.
    ax2: Vec<[f32; LANES]>,
}

impl KeySet {
    /// Prepares `values` (planes with one value per key point) for evaluation on `grid`.
    pub fn grid_eval(&self, values: &[Vec<f64>], grid: &Grid) -> GridEval<'_> {
        GridEval::new(self.frame, &self.cells, self.params, grid).with_values(
            values
                .iter()
                .map(|v| v.iter().map(|&x| x as f32).collect())
                .collect(),
        )
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
        let eval = self.grid_eval(values, grid);
        // Each band's rows of every plane, handed to one task.
        let mut chunks: Vec<Vec<&mut [f32]>> = (0..eval.bands()).map(|_| Vec::new()).collect();
        for plane in planes.iter_mut() {
            for (b, rows) in plane.chunks_mut(BAND * nx).enumerate() {
                chunks[b].push(rows);
            }
        }
        chunks.into_par_iter().enumerate().for_each_init(
            BandScratch::default,
            |scratch, (b, mut out)| {
                eval.conformal(b, scratch);
                eval.eval_band(b, scratch, &mut out);
            },
        );
        planes
    }
}

/// What a key point's splat needs from its cell size alone, per tree level.
#[derive(Debug, Clone, Copy, Default)]
struct LevelKernel {
    /// `1 / (6 sigma^2)`: the kernel's `a` is `(1 + r_c^2)` times this.
    inv_6s2: f64,
    /// A radius the support never exceeds (pixels).
    radius: f64,
    /// The same radius as whole grid steps on a pixel-centre axis (see [`pixel_span`]).
    reach: PixelReach,
    /// The cube root of the key point weight.
    cbrt_weight: f64,
}

/// How many pixel centres a radius `r` reaches below and above a key point at `m / 2`,
/// indexed by the parity of `m`: a centre on a pixel edge (even) or on a pixel centre
/// (odd). Indexed rather than branched on: the parity changes with the cell size, so a
/// branch on it mispredicts.
#[derive(Debug, Clone, Copy, Default)]
struct PixelReach {
    below: [i64; 2],
    above: [i64; 2],
}

impl PixelReach {
    fn new(r: f64) -> Self {
        let odd = r.floor() as i64;
        PixelReach {
            below: [(r + 0.5).floor() as i64, odd],
            above: [(r - 0.5).floor() as i64, odd],
        }
    }
}

/// [`Grid::span`] in integers on an axis whose points are the pixel centres `i + 0.5`,
/// for a key point at `m / 2` (cell centres are whole or half pixels): points `i` with
/// `|i + 0.5 - m / 2| <= r`. Exact where the float version rounds, and a few
/// instructions where its saturating casts take a dozen.
#[inline]
fn pixel_span(m: i64, reach: &PixelReach, n: usize) -> Option<(usize, usize)> {
    let (k, parity) = (m >> 1, (m & 1) as usize);
    let (lo, hi) = (k - reach.below[parity], k + reach.above[parity]);
    let (lo, hi) = (lo.max(0), hi.min(n as i64 - 1));
    (lo <= hi).then_some((lo as usize, hi as usize))
}

/// What a band pass needs to turn a cell into its splat.
struct SplatBuilder {
    levels: [LevelKernel; 32],
    frame: Frame,
    grid: Grid,
    /// Reciprocal grid spacings.
    inv_d: (f64, f64),
    /// Whether each axis is the unit pixel-centre axis of [`pixel_span`].
    unit: (bool, bool),
}

impl SplatBuilder {
    /// The grid rows cell `c`'s splat reaches, if any.
    #[inline(always)]
    fn rows(&self, c: &Cell) -> Option<(usize, usize)> {
        let (y0, y1) = (c.y0, (c.y0 + c.size()).min(self.frame.height));
        let my = (y0 + y1) as i64;
        let level = &self.levels[c.log2 as usize & 31];
        let grid = &self.grid;
        if self.unit.1 {
            pixel_span(my, &level.reach, grid.ny)
        } else {
            Grid::span(
                0.5 * my as f64,
                level.radius,
                grid.y0,
                self.inv_d.1,
                grid.ny,
            )
        }
    }

    /// The splat of cell `c`, key point `key`, if it reaches grid rows `band.0..=band.1`.
    // Always: called per cell in the band loop, where a call returning the splat
    // through memory would cost more than building it.
    #[inline(always)]
    fn splat(&self, key: u32, c: &Cell, band: (usize, usize)) -> Option<Splat> {
        let rows = self.rows(c)?;
        if rows.1 < band.0 || rows.0 > band.1 {
            return None;
        }
        let (frame, grid) = (&self.frame, &self.grid);
        let (x0, y0, x1, y1) = c.clip(frame.width, frame.height);
        let (mx, my) = ((x0 + x1) as i64, (y0 + y1) as i64);
        let (cx, cy) = (0.5 * mx as f64, 0.5 * my as f64);
        let level = &self.levels[c.log2 as usize & 31];
        let cols = if self.unit.0 {
            pixel_span(mx, &level.reach, grid.nx)
        } else {
            Grid::span(cx, level.radius, grid.x0, self.inv_d.0, grid.nx)
        }?;
        let (u, v) = frame.plane(cx, cy);
        Some(Splat {
            cy,
            c0: cols.0 as u32,
            steps: ((cols.1 - cols.0) / LANES + 1) as u32,
            rows: (rows.0 as u32, rows.1 as u32),
            x0: (grid.x(cols.0) - cx) as f32,
            c: level.cbrt_weight as f32,
            ca: (level.cbrt_weight * (1.0 + u * u + v * v) * level.inv_6s2) as f32,
            key,
        })
    }
}

impl<'c> GridEval<'c> {
    /// Prepares the key points at the centres of `cells` (the [`KeySet`] of `frame`,
    /// `cells` and `params`) for evaluation on `grid`, straight from the cells (the
    /// decoder needs none of the key set's other fields); [`GridEval::with_values`]
    /// adds the values.
    pub fn new(frame: Frame, cells: &'c [Cell], params: KernelParams, grid: &Grid) -> Self {
        let (nx, ny) = (grid.nx, grid.ny);
        let inv_scale = frame.inv_scale();
        let sigma_factor = params.sigma_factor.max(MIN_SIGMA_FACTOR);
        let levels: [LevelKernel; 32] = std::array::from_fn(|l| {
            let sigma = sigma_factor * (1u64 << l) as f64;
            // Frame::support_radius without its square roots: with delta = 4 sigma / S,
            // sqrt((1 + r_p^2) / (1 + r_c^2)) <= 1 + delta / 2 + delta^2 / 2 because
            // 2 r_c / (1 + r_c^2) <= 1. A looser box only costs lanes: the kernel is
            // exactly zero outside its support.
            let delta = 4.0 * sigma * inv_scale;
            let radius =
                SUPPORT_SIGMAS * sigma * (1.0 + 0.5 * delta * (1.0 + delta)) * (1.0 + 1e-9) + 1e-9;
            LevelKernel {
                // Frame::sharpness's q = ((1 + r_c^2) S / (2 sigma))^2 makes the kernel's
                // 2 q / (3 S^2 (1 + r_c^2)) equal to (1 + r_c^2) times this.
                inv_6s2: 1.0 / (6.0 * sigma * sigma),
                radius,
                reach: PixelReach::new(radius),
                cbrt_weight: 2f64.powi(l as i32).powf(-params.weight_exponent).cbrt(),
            }
        });
        let builder = SplatBuilder {
            levels,
            frame,
            grid: *grid,
            inv_d: (1.0 / grid.dx, 1.0 / grid.dy),
            // Axes through the pixel centres at unit spacing (every decode at the coded
            // size) take the integer span.
            unit: (
                grid.dx == 1.0 && grid.x0 == 0.5,
                grid.dy == 1.0 && grid.y0 == 0.5,
            ),
        };
        // Windows and band ranges from one pass over the cells (a few instructions
        // each; serial).
        let bands = ny.div_ceil(BAND);
        assert!(
            bands <= 1 << 16,
            "{ny} grid rows: band numbers must fit 16 bits"
        );
        let mut windows = vec![(u32::MAX, 0u32); bands];
        let mut cell_bands = vec![[u16::MAX, 0]; if nx > 0 && ny > 0 { cells.len() } else { 0 }];
        for ((i, c), cb) in cells.iter().enumerate().zip(&mut cell_bands) {
            if let Some(rows) = builder.rows(c) {
                let (b0, b1) = (rows.0 / BAND, rows.1 / BAND);
                // At most 65536 rows (16384 supersampled 4 times): bands fit 16 bits.
                *cb = [b0 as u16, b1 as u16];
                for w in &mut windows[b0..=b1] {
                    // A predicted branch, not a min: the min's load would wait on the
                    // previous cell's store to the same window.
                    if w.1 == 0 {
                        w.0 = i as u32;
                    }
                    w.1 = i as u32 + 1;
                }
            }
        }
        let stride = nx.next_multiple_of(LANES) + LANES;
        // Offsets from a row segment's first column, so positions stay exact in single
        // precision however wide the image: the segment's own offset from the key point
        // is formed in double precision.
        let xs = (0..stride).map(|k| (k as f64 * grid.dx) as f32).collect();
        let plane_u2 = (0..stride)
            .map(|i| {
                let u = (grid.x(i.min(nx.max(1) - 1)) - frame.centre().0) * inv_scale;
                (u * u) as f32
            })
            .collect();
        GridEval {
            grid: *grid,
            frame,
            builder,
            cells,
            windows,
            cell_bands,
            values: Vec::new(),
            xs,
            plane_u2,
            stride,
            arch: pulp::Arch::new(),
        }
    }

    /// The same evaluator on the given instruction set: [`Vectorisation::Scalar`] forces
    /// the portable path the dispatched one must equal bit for bit.
    pub fn on(mut self, v: Vectorisation) -> Self {
        self.arch = match v {
            Vectorisation::Dispatched => pulp::Arch::new(),
            Vectorisation::Scalar => pulp::Arch::Scalar,
        };
        self
    }

    /// The same evaluator with the value planes to evaluate: one value per key point
    /// each, single precision (ample for any output quantum).
    pub fn with_values(mut self, values: Vec<Vec<f32>>) -> Self {
        assert!(
            values.iter().all(|v| v.len() == self.cells.len()),
            "one value per key point"
        );
        self.values = values;
        self
    }

    /// The grid this evaluator evaluates on.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Number of bands: the grid's rows in groups of [`GridEval::BAND`].
    pub fn bands(&self) -> usize {
        self.grid.ny.div_ceil(BAND)
    }

    /// Rows per band (the last band may have fewer).
    pub const BAND: usize = BAND;

    /// The conformal factors `g = 1 / (1 + r_p^2)` of band `b`'s grid points, into
    /// `scratch` (padded rows). They depend on the grid and frame alone, so key sets
    /// evaluated on the same grid can share them.
    pub fn conformal(&self, b: usize, scratch: &mut BandScratch) {
        self.arch.dispatch(Conformal {
            eval: self,
            b,
            g: &mut scratch.g,
        });
    }

    /// Evaluates band `b` into `out` (one slice per value plane, the band's rows of
    /// `nx` points each), normalised. `scratch` holds band `b`'s conformal factors from
    /// [`GridEval::conformal`] of this or another evaluator on the same grid.
    pub fn eval_band(&self, b: usize, scratch: &mut BandScratch, out: &mut [&mut [f32]]) {
        debug_assert_eq!(out.len(), self.values.len());
        let j0 = b * BAND;
        let rows = BAND.min(self.grid.ny - j0);
        assert_eq!(
            scratch.g.len(),
            rows * self.stride,
            "conformal factors of this band first"
        );
        // Compiled for the widest vector unit the CPU has. No fused multiply-adds are
        // formed (Rust never contracts), so every unit gives the same bits.
        self.arch.dispatch(BandPass {
            eval: self,
            window: self.windows[b],
            j0,
            rows,
            g: &scratch.g,
            acc: &mut scratch.acc,
            ax2: &mut scratch.ax2,
            out,
        });
    }

    /// Splats the key points of `window` over the band starting at row `j0`; `acc`
    /// holds the kernel sum then the `NC` value planes, each `rows x stride`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn splat<const NC: usize>(
        &self,
        (lo, hi): (u32, u32),
        values: &[Vec<f32>],
        g: &[f32],
        j0: usize,
        rows: usize,
        acc: &mut [f32],
        ax2: &mut Vec<[f32; LANES]>,
    ) {
        let grid = &self.grid;
        let stride = self.stride;
        let plane = rows * stride;
        let (sum, rest) = acc.split_at_mut(plane);
        let mut chunks = rest.chunks_exact_mut(plane);
        let mut planes: [&mut [f32]; NC] =
            std::array::from_fn(|_| chunks.next().expect("NC planes follow the sum"));
        let (xs, _) = self.xs.as_chunks::<LANES>();
        let band = (j0, j0 + rows - 1);
        let b = (j0 / BAND) as u16;
        let range = lo as usize..hi as usize;
        let (cells, bands) = (
            self.cells.get(range.clone()).unwrap_or(&[]),
            self.cell_bands.get(range).unwrap_or(&[]),
        );
        for ((k, c), &[b0, b1]) in (lo..hi).zip(cells).zip(bands) {
            if b < b0 || b > b1 {
                continue;
            }
            let Some(s) = self.builder.splat(k, c, band) else {
                continue;
            };
            let s = &s;
            let vals: [f32; NC] = std::array::from_fn(|c| values[c][s.key as usize]);
            let r0 = (s.rows.0 as usize).max(j0);
            let r1 = (s.rows.1 as usize).min(j0 + rows - 1);
            // Whole bounding-box rows: trimming each row to the disc's chord cost more
            // (a square root and two divisions per row) than the steps it saved.
            let steps = s.steps as usize;
            let n = steps * LANES;
            let row0 = (r0 - j0) * stride + s.c0 as usize;
            let mut dy = grid.y(r0) - s.cy;
            if steps == 1 {
                // Most key points at high rates (one- and two-pixel cells) span one step:
                // their x part stays in registers and a row is one step, without the
                // slicing a row of several steps needs.
                let ax2 = xs[0].map(|x| {
                    let dx = x + s.x0;
                    s.ca * dx * dx
                });
                let mut off = row0;
                for _ in r0..=r1 {
                    let kern = Kernel {
                        c: s.c,
                        ay2: s.ca * (dy * dy) as f32,
                    };
                    let w = kern.step(&ax2, lanes(g, off));
                    add_step(lanes_mut(sum, off), &w, None);
                    for (p, &v) in planes.iter_mut().zip(&vals) {
                        add_step(lanes_mut(p, off), &w, Some(v));
                    }
                    off += stride;
                    dy += grid.dy;
                }
                continue;
            }
            // The x part of the kernel is the same on every row of the key point.
            if ax2.len() < steps {
                ax2.resize(steps, [0.0; LANES]);
            }
            let (ax2, xs) = (&mut ax2[..steps], &xs[..steps]);
            let (x0, ca) = (s.x0, s.ca);
            for (o, x) in ax2.iter_mut().zip(xs) {
                *o = x.map(|x| {
                    let dx = x + x0;
                    ca * dx * dx
                });
            }
            for r in 0..=r1 - r0 {
                let kern = Kernel {
                    c: s.c,
                    ay2: s.ca * (dy * dy) as f32,
                };
                let off = row0 + r * stride;
                let range = off..off + n;
                let mut it = planes.iter_mut();
                let out: [&mut [[f32; LANES]]; NC] = std::array::from_fn(|_| match it.next() {
                    Some(p) => p[range.clone()].as_chunks_mut().0,
                    None => &mut [],
                });
                splat_row::<NC>(
                    ax2,
                    g[range.clone()].as_chunks().0,
                    sum[range].as_chunks_mut().0,
                    out,
                    kern,
                    vals,
                );
                dy += grid.dy;
            }
        }
    }
}

/// Which instructions the band pass runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Vectorisation {
    /// The widest vector unit the CPU has (AVX-512, AVX2 or scalar), found at run time.
    Dispatched,
    /// Plain scalar code, whatever the CPU: the reference.
    Scalar,
}

/// Whether this CPU runs the band pass on a vector unit (else the dispatched path is the
/// scalar one).
pub fn has_vector_unit() -> bool {
    !matches!(pulp::Arch::new(), pulp::Arch::Scalar)
}

/// The conformal factors of one band, as a `pulp` operation (so the division
/// vectorises).
struct Conformal<'a, 'c> {
    eval: &'a GridEval<'c>,
    b: usize,
    g: &'a mut Vec<f32>,
}

impl pulp::WithSimd for Conformal<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let e = self.eval;
        let (grid, frame) = (&e.grid, &e.frame);
        let j0 = self.b * BAND;
        let rows = BAND.min(grid.ny - j0);
        let inv_scale = frame.inv_scale();
        self.g.clear();
        for r in 0..rows {
            let v = (grid.y(j0 + r) - frame.centre().1) * inv_scale;
            let v2 = (v * v) as f32;
            self.g
                .extend(e.plane_u2.iter().map(|u2| 1.0 / (1.0 + u2 + v2)));
        }
    }
}

/// One band's splats and normalisation, as a `pulp` operation: everything is inlined
/// into the target-feature function `pulp` picks, which is what vectorises it.
struct BandPass<'a, 'c, 'o> {
    eval: &'a GridEval<'c>,
    window: (u32, u32),
    j0: usize,
    rows: usize,
    g: &'a [f32],
    acc: &'a mut Vec<f32>,
    ax2: &'a mut Vec<[f32; LANES]>,
    out: &'a mut [&'o mut [f32]],
}

impl pulp::WithSimd for BandPass<'_, '_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let e = self.eval;
        let (nx, stride) = (e.grid.nx, e.stride);
        let plane = self.rows * stride;
        // Up to four planes share one pass; more take further passes.
        for (group, vals) in self.out.chunks_mut(4).zip(e.values.chunks(4)) {
            self.acc.clear();
            self.acc.resize((vals.len() + 1) * plane, 0.0f32);
            let (g, acc, ax2) = (self.g, &mut self.acc[..], &mut *self.ax2);
            let (j0, rows, window) = (self.j0, self.rows, self.window);
            match vals.len() {
                1 => e.splat::<1>(window, vals, g, j0, rows, acc, ax2),
                2 => e.splat::<2>(window, vals, g, j0, rows, acc, ax2),
                3 => e.splat::<3>(window, vals, g, j0, rows, acc, ax2),
                _ => e.splat::<4>(window, vals, g, j0, rows, acc, ax2),
            }
            let (sum, planes) = self.acc.split_at_mut(plane);
            for s in sum.iter_mut() {
                // A sum so small (extreme weight exponents) that its reciprocal
                // overflows single precision counts as no kernel at all.
                let r = 1.0 / *s;
                *s = if *s > 0.0 && r.is_finite() { r } else { 0.0 };
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

/// One key point's kernel on one row: `(c - g (ax2 + ay2))^3`, clamped at 0, where
/// `c^3` is the key point's weight and `ax2`, `ay2` its `c a dx^2`, `c a dy^2`. Folding
/// the weight into the cube saves a multiply per point: `c^3 (1 - g a d^2)^3`.
#[derive(Debug, Clone, Copy)]
struct Kernel {
    c: f32,
    ay2: f32,
}

/// The inner loop: one key point's kernel over one row segment of whole
/// [`LANES`]-point steps.
#[inline(always)]
fn splat_row<const NC: usize>(
    ax2: &[[f32; LANES]],
    g: &[[f32; LANES]],
    sum: &mut [[f32; LANES]],
    acc: [&mut [[f32; LANES]]; NC],
    k: Kernel,
    vals: [f32; NC],
) {
    let steps = ax2.len().min(g.len()).min(sum.len());
    // Every slice cut to the same length, so the loop below has no bounds checks.
    let acc: [&mut [[f32; LANES]]; NC] = acc.map(|a| &mut a[..steps]);
    let (ax2, g, sum) = (&ax2[..steps], &g[..steps], &mut sum[..steps]);
    for s in 0..steps {
        let w = k.step(&ax2[s], &g[s]);
        add_step(&mut sum[s], &w, None);
        for c in 0..NC {
            add_step(&mut acc[c][s], &w, Some(vals[c]));
        }
    }
}

impl Kernel {
    /// The kernel at one step of points, from their `c a dx^2` and conformal factors.
    #[inline(always)]
    fn step(self, ax2: &[f32; LANES], g: &[f32; LANES]) -> [f32; LANES] {
        let mut w = [0.0f32; LANES];
        for l in 0..LANES {
            let t = self.c - g[l] * (ax2[l] + self.ay2);
            let t = if t > 0.0 { t } else { 0.0 };
            w[l] = t * t * t;
        }
        w
    }
}

/// Adds the kernel `w` (times `value`, if any) to one step of an accumulator.
#[inline(always)]
fn add_step(out: &mut [f32; LANES], w: &[f32; LANES], value: Option<f32>) {
    for l in 0..LANES {
        out[l] += match value {
            Some(v) => w[l] * v,
            None => w[l],
        };
    }
}

/// The step of points starting at `off`.
#[inline(always)]
fn lanes(s: &[f32], off: usize) -> &[f32; LANES] {
    s[off..off + LANES].try_into().expect("LANES points")
}

/// The step of points starting at `off`, mutably.
#[inline(always)]
fn lanes_mut(s: &mut [f32], off: usize) -> &mut [f32; LANES] {
    (&mut s[off..off + LANES]).try_into().expect("LANES points")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_pixel_span_is_the_set_of_centres_within_reach() {
        let mut rng = caoen_base::rng::Lcg::new(12345);
        let mut next = || rng.next_u31() as f64 / (1u64 << 31) as f64;
        for _ in 0..20000 {
            let n = 1 + (next() * 40.0) as usize;
            let m = (next() * 2.0 * n as f64) as i64;
            let r = next() * 25.0;
            let c = 0.5 * m as f64;
            let want: Vec<usize> = (0..n)
                .filter(|&i| (i as f64 + 0.5 - c).abs() <= r)
                .collect();
            let want = want.first().map(|&lo| (lo, *want.last().unwrap()));
            assert_eq!(
                pixel_span(m, &PixelReach::new(r), n),
                want,
                "m {m} r {r} n {n}"
            );
            assert_eq!(
                Grid::span(c, r, 0.5, 1.0, n),
                want,
                "float span, m {m} r {r} n {n}"
            );
        }
    }
}
