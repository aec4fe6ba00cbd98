//! A set of key points over the image (the luma or the chroma set) and the fast path
//! that evaluates its normalised compact kernels at pixel positions.
//!
//! The canonical model is a core Cao En network (`caoen-surface`): sources on the sphere
//! ([`Frame::embed`]), [`Blend::Compact`], normalised, one weight and sharpness per key
//! point. The fast path reads the same parameters ([`KeySet::sources`],
//! [`KeySet::sharpness`], [`KeySet::weights`]) and evaluates exactly the same formula
//! per key point, but finds a pixel's key points through a grid of pixel buckets
//! instead of the network's k-d trees; the texture tools' tests check it against the
//! network.

mod grid;

use std::sync::OnceLock;

use crate::par::*;

pub use grid::{has_vector_unit, BandScratch, Grid, GridEval, Vectorisation};

use super::geometry::Frame;
use super::quadtree::Cell;
use caoen_base::Blend;

/// How a cell of side `s` becomes a key point: footprint `sigma = sigma_factor * s`,
/// weight `s^-weight_exponent`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelParams {
    /// Footprint per cell side; at least [`MIN_SIGMA_FACTOR`] so cells are covered.
    pub sigma_factor: f64,
    /// Finer key points outweigh coarser ones where they overlap.
    pub weight_exponent: f64,
}

/// Smallest footprint factor that still covers every pixel of a cell by its own key
/// point: the cell corner is `s/sqrt(2)` away, the support reaches `sqrt(6) sigma`.
pub const MIN_SIGMA_FACTOR: f64 = 0.3;

/// Side of the pixel buckets that index key points by their support rectangles.
const BUCKET: u32 = 2;
// `KeySet::pixel_weights` reads a bucket's candidates for two pixels of a row at once.
const _: () = assert!(BUCKET == 2);

/// Key points in coding order with everything evaluation needs.
#[derive(Debug, Clone)]
pub struct KeySet {
    frame: Frame,
    cells: Vec<Cell>,
    params: KernelParams,
    /// Key point centres in pixels.
    pub centres: Vec<(f64, f64)>,
    /// Footprints in pixels.
    pub sigma: Vec<f64>,
    /// Sphere points of the centres, made on first use: the splatting path works in
    /// the plane and does not need them.
    sources: OnceLock<Vec<[f64; 3]>>,
    q: Vec<f64>,
    weight: Vec<f64>,
    /// Built on first per-pixel use: the splatting path does not need it.
    buckets: OnceLock<Buckets>,
}

/// Key points indexed by the pixel buckets their support rectangles touch.
#[derive(Debug, Clone)]
struct Buckets {
    cols: u32,
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Normalised weights of every pixel (rows, row-major pixels) on the key points
/// (columns), in compressed sparse row form.
#[derive(Debug, Clone, Default)]
pub struct Weights {
    /// Row `p` spans `row_start[p]..row_start[p + 1]`.
    pub row_start: Vec<usize>,
    /// Key point index of each entry.
    pub col: Vec<u32>,
    /// Normalised weight of each entry.
    pub val: Vec<f64>,
}

impl KeySet {
    /// Key points at the centres of `cells` (clipped to the image).
    pub fn new(frame: Frame, cells: &[Cell], params: KernelParams) -> Self {
        let (w, h) = (frame.width, frame.height);
        // Weights depend on the cell size alone: one power per tree level.
        let weights: Vec<f64> = (0..32)
            .map(|l| 2f64.powi(l).powf(-params.weight_exponent))
            .collect();
        let sigma_factor = params.sigma_factor.max(MIN_SIGMA_FACTOR);
        // One parallel pass per field: each is cheap, but there can be a million cells.
        let mut centres = Vec::new();
        cells
            .par_iter()
            .map(|c| c.centre(w, h))
            .collect_into_vec(&mut centres);
        let mut sigma = Vec::new();
        cells
            .par_iter()
            .map(|c| sigma_factor * c.size() as f64)
            .collect_into_vec(&mut sigma);
        let mut q = Vec::new();
        centres
            .par_iter()
            .zip(&sigma)
            .map(|(&(x, y), &s)| frame.sharpness(x, y, s))
            .collect_into_vec(&mut q);
        let weight = cells.iter().map(|c| weights[c.log2 as usize]).collect();
        KeySet {
            frame,
            cells: cells.to_vec(),
            params,
            centres,
            sigma,
            sources: OnceLock::new(),
            q,
            weight,
            buckets: OnceLock::new(),
        }
    }

    /// Each key point's source on the sphere, its cell's centre embedded.
    pub fn sources(&self) -> &[[f64; 3]] {
        self.sources.get_or_init(|| {
            self.centres
                .iter()
                .map(|&(x, y)| self.frame.embed(x, y))
                .collect()
        })
    }

    fn buckets(&self) -> &Buckets {
        self.buckets.get_or_init(|| self.build_buckets())
    }

    fn build_buckets(&self) -> Buckets {
        let (w, h) = (self.frame.width, self.frame.height);
        let (bc, br) = (w.div_ceil(BUCKET) as usize, h.div_ceil(BUCKET) as usize);
        let ranges: Vec<(usize, usize, usize, usize)> = self
            .centres
            .iter()
            .zip(&self.sigma)
            .map(|(&(x, y), &s)| {
                let r = self.frame.support_radius(x, y, s);
                let b = BUCKET as f64;
                let clamp =
                    |v: f64, hi: usize| (v / b).floor().clamp(0.0, hi as f64 - 1.0) as usize;
                (
                    clamp(x - r, bc),
                    clamp(y - r, br),
                    clamp(x + r, bc),
                    clamp(y + r, br),
                )
            })
            .collect();
        // Counting sort into buckets; items stay in key point order within each bucket.
        let mut count = vec![0u32; bc * br + 1];
        for &(x0, y0, x1, y1) in &ranges {
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    count[by * bc + bx + 1] += 1;
                }
            }
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; *count.last().unwrap_or(&0) as usize];
        for (i, &(x0, y0, x1, y1)) in ranges.iter().enumerate() {
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    let b = by * bc + bx;
                    items[fill[b] as usize] = i as u32;
                    fill[b] += 1;
                }
            }
        }
        Buckets {
            cols: bc as u32,
            start: count,
            items,
        }
    }

    /// Number of key points.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether there are no key points.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// The image frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Each key point's sharpness `q` (its kernel's, on the sphere).
    pub fn sharpness(&self) -> &[f64] {
        &self.q
    }

    /// Each key point's weight in the normalised sum.
    pub fn weights(&self) -> &[f64] {
        &self.weight
    }

    /// The kernel weights (unnormalised) at pixel position `(x, y)` into `out`; returns
    /// their sum. Identical per key point to the core's `Blend::Compact` evaluation.
    #[inline]
    pub fn kernels_at(&self, x: f64, y: f64, out: &mut Vec<(u32, f64)>) -> f64 {
        out.clear();
        let p = self.frame.embed(x, y);
        let (bx, by) = ((x / BUCKET as f64).floor(), (y / BUCKET as f64).floor());
        let (w, h) = (self.frame.width, self.frame.height);
        if !(bx >= 0.0
            && by >= 0.0
            && bx < w.div_ceil(BUCKET) as f64
            && by < h.div_ceil(BUCKET) as f64)
        {
            return self.kernels_brute(&p, out);
        }
        let buckets = self.buckets();
        let sources = self.sources();
        let b = by as usize * buckets.cols as usize + bx as usize;
        let mut sum = 0.0;
        for &i in &buckets.items[buckets.start[b] as usize..buckets.start[b + 1] as usize] {
            let k = self.kernel(sources, i as usize, &p);
            if k != 0.0 {
                sum += k;
                out.push((i, k));
            }
        }
        sum
    }

    #[inline]
    fn kernel(&self, sources: &[[f64; 3]], i: usize, p: &[f64; 3]) -> f64 {
        let w = &sources[i];
        let s = p[0] * w[0] + p[1] * w[1] + p[2] * w[2];
        self.weight[i] * Blend::Compact.value(s, self.q[i])
    }

    /// Positions outside the image (forward mapping, resampling) scan all key points.
    fn kernels_brute(&self, p: &[f64; 3], out: &mut Vec<(u32, f64)>) -> f64 {
        let sources = self.sources();
        let mut sum = 0.0;
        for i in 0..self.len() {
            let k = self.kernel(sources, i, p);
            if k != 0.0 {
                sum += k;
                out.push((i as u32, k));
            }
        }
        sum
    }

    /// Normalised weights of every pixel centre (the fit's design matrix).
    ///
    /// The same kernels, in the same order and with the same arithmetic, as
    /// [`KeySet::kernels_at`] per pixel (so the same bits), with each key point's
    /// parameters packed together and bands of rows written straight into their
    /// entries.
    pub fn pixel_weights(&self) -> Weights {
        /// Rows per parallel task.
        const BAND: usize = 16;
        let (w, h) = (self.frame.width as usize, self.frame.height as usize);
        let buckets = self.buckets();
        // Source point, sharpness and weight per key point: one cache line per candidate.
        let packed: Vec<[f64; 5]> = self
            .sources()
            .iter()
            .zip(&self.q)
            .zip(&self.weight)
            .map(|((s, &q), &wt)| [s[0], s[1], s[2], q, wt])
            .collect();
        let kernel = |p: &[f64; 3], c: &[f64; 5]| {
            let s = p[0] * c[0] + p[1] * c[1] + p[2] * c[2];
            c[4] * Blend::Compact.value(s, c[3])
        };
        let bands: Vec<(Vec<u32>, Vec<f64>, Vec<u32>)> = (0..h.div_ceil(BAND))
            .into_par_iter()
            .map(|band| {
                let rows = band * BAND..((band + 1) * BAND).min(h);
                let mut cols = Vec::with_capacity(rows.len() * w * 8);
                let mut vals = Vec::with_capacity(rows.len() * w * 8);
                let mut lens = Vec::with_capacity(rows.len() * w);
                // The second pixel of a bucket's pair, kept aside while the first's
                // entries are written.
                let (mut cols2, mut vals2) = (Vec::new(), Vec::new());
                for y in rows {
                    let by = y / BUCKET as usize;
                    // The two pixels of a bucket's row share its candidates: each
                    // candidate is read once for both.
                    for x in (0..w).step_by(BUCKET as usize) {
                        let pair = x + 1 < w;
                        let p = self.frame.embed(x as f64 + 0.5, y as f64 + 0.5);
                        let p2 = self.frame.embed(x as f64 + 1.5, y as f64 + 0.5);
                        let b = by * buckets.cols as usize + x / BUCKET as usize;
                        let items = &buckets.items
                            [buckets.start[b] as usize..buckets.start[b + 1] as usize];
                        let first = vals.len();
                        cols2.clear();
                        vals2.clear();
                        let (mut sum, mut sum2) = (0.0, 0.0);
                        for &i in items {
                            let c = &packed[i as usize];
                            let k = kernel(&p, c);
                            if k != 0.0 {
                                sum += k;
                                cols.push(i);
                                vals.push(k);
                            }
                            let k2 = kernel(&p2, c);
                            if k2 != 0.0 {
                                sum2 += k2;
                                cols2.push(i);
                                vals2.push(k2);
                            }
                        }
                        let inv = if sum > 0.0 { 1.0 / sum } else { 0.0 };
                        for v in &mut vals[first..] {
                            *v *= inv;
                        }
                        lens.push((vals.len() - first) as u32);
                        if pair {
                            let inv = if sum2 > 0.0 { 1.0 / sum2 } else { 0.0 };
                            cols.extend_from_slice(&cols2);
                            vals.extend(vals2.iter().map(|v| v * inv));
                            lens.push(vals2.len() as u32);
                        }
                    }
                }
                (cols, vals, lens)
            })
            .collect();
        let nnz: usize = bands.iter().map(|r| r.0.len()).sum();
        let mut out = Weights {
            row_start: Vec::with_capacity(w * h + 1),
            col: Vec::with_capacity(nnz),
            val: Vec::with_capacity(nnz),
        };
        out.row_start.push(0);
        let mut last = 0;
        for (cols, vals, lens) in bands {
            out.col.extend(cols);
            out.val.extend(vals);
            out.row_start.extend(lens.iter().map(|&l| {
                last += l as usize;
                last
            }));
        }
        out
    }

    /// [`KeySet::pixel_weights`] through [`KeySet::kernels_at`]: its reference.
    #[cfg(test)]
    fn pixel_weights_per_pixel(&self) -> Weights {
        let (w, h) = (self.frame.width as usize, self.frame.height as usize);
        let rows: Vec<(Vec<u32>, Vec<f64>, Vec<usize>)> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut cols = Vec::new();
                let mut vals = Vec::new();
                let mut lens = Vec::with_capacity(w);
                let mut buf = Vec::new();
                for x in 0..w {
                    let sum = self.kernels_at(x as f64 + 0.5, y as f64 + 0.5, &mut buf);
                    let inv = if sum > 0.0 { 1.0 / sum } else { 0.0 };
                    for &(i, k) in &buf {
                        cols.push(i);
                        vals.push(k * inv);
                    }
                    lens.push(buf.len());
                }
                (cols, vals, lens)
            })
            .collect();
        let nnz: usize = rows.iter().map(|r| r.0.len()).sum();
        let mut out = Weights {
            row_start: Vec::with_capacity(w * h + 1),
            col: Vec::with_capacity(nnz),
            val: Vec::with_capacity(nnz),
        };
        out.row_start.push(0);
        for (cols, vals, lens) in rows {
            out.col.extend(cols);
            out.val.extend(vals);
            for l in lens {
                let last = *out.row_start.last().expect("starts with 0");
                out.row_start.push(last + l);
            }
        }
        out
    }

    /// Evaluates `channels` planes (each n values, one per key point) at the pixel
    /// centres of a `out_w x out_h` grid covering the image (the identity fast path,
    /// resampled when the size differs from the coded one).
    pub fn render(&self, colours: &[Vec<f64>], out_w: u32, out_h: u32) -> Vec<Vec<f32>> {
        self.eval_grid(colours, &Grid::pixel_centres(&self.frame, out_w, out_h))
    }

    /// [`KeySet::render`] one pixel at a time through [`KeySet::kernels_at`]: the
    /// reference the splatting path is tested against.
    pub fn render_per_pixel(&self, colours: &[Vec<f64>], out_w: u32, out_h: u32) -> Vec<Vec<f64>> {
        let (sx, sy) = (
            self.frame.width as f64 / out_w as f64,
            self.frame.height as f64 / out_h as f64,
        );
        let nc = colours.len();
        let (ow, oh) = (out_w as usize, out_h as usize);
        let rows: Vec<Vec<f64>> = (0..oh)
            .into_par_iter()
            .map(|y| {
                let mut buf = Vec::new();
                let mut row = vec![0.0; nc * ow];
                for x in 0..ow {
                    let sum =
                        self.kernels_at((x as f64 + 0.5) * sx, (y as f64 + 0.5) * sy, &mut buf);
                    if sum > 0.0 {
                        let inv = 1.0 / sum;
                        for (c, plane) in colours.iter().enumerate() {
                            let v: f64 = buf.iter().map(|&(i, k)| k * plane[i as usize]).sum();
                            row[c * ow + x] = v * inv;
                        }
                    }
                }
                row
            })
            .collect();
        let mut planes = vec![vec![0.0; ow * oh]; nc];
        for (y, row) in rows.iter().enumerate() {
            for (c, plane) in planes.iter_mut().enumerate() {
                plane[y * ow..(y + 1) * ow].copy_from_slice(&row[c * ow..(c + 1) * ow]);
            }
        }
        planes
    }
}

impl Weights {
    /// `A v` for `k` interleaved right-hand sides (`v[i * k + c]`), into `out[p * k + c]`.
    pub fn apply(&self, v: &[f64], k: usize, out: &mut [f64]) {
        // The encoder's conjugate gradients spend most of their time here: with `k` a
        // constant the channel loop unrolls and its bounds checks go. Same sums in the
        // same order as the general loop, so the same bits.
        match k {
            1 => self.apply_k::<1>(v, out),
            2 => self.apply_k::<2>(v, out),
            3 => self.apply_k::<3>(v, out),
            4 => self.apply_k::<4>(v, out),
            _ => self.apply_any(v, k, out),
        }
    }

    /// [`Weights::apply`] for `K` right-hand sides.
    fn apply_k<const K: usize>(&self, v: &[f64], out: &mut [f64]) {
        let (v, _) = v.as_chunks::<K>();
        out.par_chunks_mut(K * 1024)
            .enumerate()
            .for_each(|(chunk, o)| {
                let p0 = chunk * 1024;
                for (dp, op) in o.as_chunks_mut::<K>().0.iter_mut().enumerate() {
                    let p = p0 + dp;
                    let (s, e) = (self.row_start[p], self.row_start[p + 1]);
                    let mut acc = [0.0; K];
                    for (&i, &a) in self.col[s..e].iter().zip(&self.val[s..e]) {
                        let vi = &v[i as usize];
                        for c in 0..K {
                            acc[c] += a * vi[c];
                        }
                    }
                    *op = acc;
                }
            });
    }

    /// [`Weights::apply`] for any number of right-hand sides.
    fn apply_any(&self, v: &[f64], k: usize, out: &mut [f64]) {
        out.par_chunks_mut(k * 1024)
            .enumerate()
            .for_each(|(chunk, o)| {
                let p0 = chunk * 1024;
                for (dp, op) in o.chunks_exact_mut(k).enumerate() {
                    let p = p0 + dp;
                    op.fill(0.0);
                    for e in self.row_start[p]..self.row_start[p + 1] {
                        let (i, a) = (self.col[e] as usize, self.val[e]);
                        for c in 0..k {
                            op[c] += a * v[i * k + c];
                        }
                    }
                }
            });
    }

    /// `A^T u` for `K` interleaved channels into `out` (`n * K` values), adding in
    /// pixel order: each key point's sum in the order of its row of the transpose.
    pub fn scatter_t<const K: usize>(&self, u: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let (u, _) = u.as_chunks::<K>();
        let (out, _) = out.as_chunks_mut::<K>();
        for (p, up) in u.iter().enumerate().take(self.row_start.len() - 1) {
            let (s, e) = (self.row_start[p], self.row_start[p + 1]);
            for (&i, &a) in self.col[s..e].iter().zip(&self.val[s..e]) {
                let o = &mut out[i as usize];
                for c in 0..K {
                    o[c] += a * up[c];
                }
            }
        }
    }

    /// `A^T A v` for `K` interleaved channels into `out` (`n * K` values): per pixel,
    /// its value summed as [`Weights::apply`] does, then scattered as
    /// [`Weights::scatter_t`] does.
    pub fn gram<const K: usize>(&self, v: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let (v, _) = v.as_chunks::<K>();
        let (out, _) = out.as_chunks_mut::<K>();
        for p in 0..self.row_start.len() - 1 {
            let (s, e) = (self.row_start[p], self.row_start[p + 1]);
            let (cols, vals) = (&self.col[s..e], &self.val[s..e]);
            let mut acc = [0.0; K];
            for (&i, &a) in cols.iter().zip(vals) {
                let vi = &v[i as usize];
                for c in 0..K {
                    acc[c] += a * vi[c];
                }
            }
            for (&i, &a) in cols.iter().zip(vals) {
                let o = &mut out[i as usize];
                for c in 0..K {
                    o[c] += a * acc[c];
                }
            }
        }
    }

    /// The transpose in CSR form (rows = key points), for `A^T u`.
    pub fn transpose(&self, n: usize) -> Weights {
        let mut count = vec![0usize; n + 1];
        for &c in &self.col {
            count[c as usize + 1] += 1;
        }
        for i in 1..=n {
            count[i] += count[i - 1];
        }
        let mut fill = count.clone();
        let mut col = vec![0u32; self.col.len()];
        let mut val = vec![0.0; self.val.len()];
        for p in 0..self.row_start.len() - 1 {
            for e in self.row_start[p]..self.row_start[p + 1] {
                let i = self.col[e] as usize;
                col[fill[i]] = p as u32;
                val[fill[i]] = self.val[e];
                fill[i] += 1;
            }
        }
        Weights {
            row_start: count,
            col,
            val,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadtree::random_tree;

    fn random_keyset(w: u32, h: u32, seed: u32, sigma_factor: f64) -> KeySet {
        let (_, cells) = random_tree(w, h, seed, |d| d.is_multiple_of(2));
        KeySet::new(
            Frame::new(w, h),
            &cells,
            KernelParams {
                sigma_factor,
                weight_exponent: 1.0,
            },
        )
    }

    /// The normalised value at `(x, y)` through the per-pixel kernels.
    fn reference_at(ks: &KeySet, values: &[f64], x: f64, y: f64) -> f64 {
        let mut buf = Vec::new();
        let sum = ks.kernels_at(x, y, &mut buf);
        if sum > 0.0 {
            buf.iter()
                .map(|&(i, k)| k * values[i as usize])
                .sum::<f64>()
                / sum
        } else {
            0.0
        }
    }

    #[test]
    fn splatting_equals_the_per_pixel_path_on_any_grid() {
        // Single precision: values of magnitude ~1 agree to a few 1e-7.
        const TOL: f64 = 2e-6;
        for (w, h, seed, sigma) in [
            (53, 37, 7, 0.4),
            (1, 1, 1, 0.3),
            (1, 9, 2, 0.5),
            (9, 1, 3, 0.5),
            (8, 8, 4, 0.3),
            (17, 5, 5, 0.7),
            (130, 70, 6, 0.5),
        ] {
            let ks = random_keyset(w, h, seed, sigma);
            let frame = *ks.frame();
            let values: Vec<Vec<f64>> = (0..5)
                .map(|c| {
                    (0..ks.len())
                        .map(|i| ((i * (c + 3)) as f64 * 0.37).sin() * (c + 1) as f64)
                        .collect()
                })
                .collect();
            let lattice = |s: usize| Grid {
                x0: 0.5 - (s / 2) as f64 / s as f64,
                dx: 1.0 / s as f64,
                nx: w as usize * s,
                y0: 0.5 - (s / 2) as f64 / s as f64,
                dy: 1.0 / s as f64,
                ny: h as usize * s,
            };
            let grids = [
                Grid::pixel_centres(&frame, w, h),
                Grid::pixel_centres(&frame, 2 * w + 1, h.div_ceil(2)),
                Grid::pixel_centres(&frame, w.div_ceil(3), 3 * h),
                lattice(2),
                lattice(3),
            ];
            for grid in grids {
                // 1 to 5 planes: every specialised width and a second pass.
                for nc in 1..=5 {
                    let got = ks.eval_grid(&values[..nc], &grid);
                    for j in 0..grid.ny {
                        for i in 0..grid.nx {
                            for (c, plane) in got.iter().enumerate() {
                                let want = reference_at(&ks, &values[c], grid.x(i), grid.y(j));
                                let have = plane[j * grid.nx + i] as f64;
                                assert!(
                                    (have - want).abs() <= TOL * (c + 1) as f64,
                                    "{w}x{h} {grid:?} plane {c} at ({i},{j}): {have} vs {want}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn pixel_weights_equal_the_per_pixel_kernels_bit_for_bit() {
        for (w, h, seed, sigma) in [
            (53, 37, 7, 0.4),
            (1, 1, 1, 0.3),
            (17, 40, 5, 0.7),
            (130, 70, 6, 0.5),
        ] {
            let ks = random_keyset(w, h, seed, sigma);
            let (fast, slow) = (ks.pixel_weights(), ks.pixel_weights_per_pixel());
            assert_eq!(fast.row_start, slow.row_start, "{w}x{h}");
            assert_eq!(fast.col, slow.col, "{w}x{h}");
            assert!(
                fast.val
                    .iter()
                    .zip(&slow.val)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{w}x{h}"
            );
        }
    }

    #[test]
    fn weights_apply_equals_its_definition_for_any_number_of_right_hand_sides() {
        let ks = random_keyset(37, 29, 5, 0.6);
        let a = ks.pixel_weights();
        let (pixels, n) = (a.row_start.len() - 1, ks.cells.len());
        for k in 1..=6 {
            let v: Vec<f64> = (0..n * k)
                .map(|i| ((i * 7919) % 101) as f64 - 50.5)
                .collect();
            let mut got = vec![f64::NAN; pixels * k];
            a.apply(&v, k, &mut got);
            // The definition, summed in entry order as the fast paths promise.
            for p in 0..pixels {
                for c in 0..k {
                    let mut want = 0.0;
                    for e in a.row_start[p]..a.row_start[p + 1] {
                        want += a.val[e] * v[a.col[e] as usize * k + c];
                    }
                    assert_eq!(got[p * k + c].to_bits(), want.to_bits(), "k {k} pixel {p}");
                }
            }
        }
    }
}
