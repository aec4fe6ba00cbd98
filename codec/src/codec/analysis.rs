//! Image analysis that steers where key points go: edge strength (gradient magnitude)
//! and local frequency content (energy left over after smoothing at each cell scale).
//!
//! A key point of cell side `s` represents roughly what survives a box blur of width
//! `s`; the energy of `Y - blur_s(Y)` summed over a cell is therefore the error a leaf
//! of that size is predicted to leave (the band energy above its Nyquist frequency).
//! The encoder splits cells whose predicted error exceeds its threshold before the
//! first fit, then corrects with the measured fitting error.

/// Summed-area table of a plane, `(w + 1) x (h + 1)`.
struct Integral {
    w: usize,
    sums: Vec<f64>,
}

impl Integral {
    fn new(plane: &[f64], w: usize, h: usize) -> Self {
        let mut sums = vec![0.0; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = 0.0;
            for x in 0..w {
                row += plane[y * w + x];
                sums[(y + 1) * (w + 1) + x + 1] = sums[y * (w + 1) + x + 1] + row;
            }
        }
        Integral { w, sums }
    }

    /// Sum over `[x0, x1) x [y0, y1)`.
    fn rect(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> f64 {
        let s = |x: usize, y: usize| self.sums[y * (self.w + 1) + x];
        s(x1, y1) - s(x0, y1) - s(x1, y0) + s(x0, y0)
    }
}

/// The analysis maps of one image.
pub struct Analysis {
    w: usize,
    h: usize,
    /// Gradient magnitude of luma (Sobel, per pixel).
    pub edges: Vec<f64>,
    /// Per scale `log2 s` (0..=max): integral of the squared detail finer than `s`.
    residual: Vec<Integral>,
}

impl Analysis {
    /// Analyses the colour planes (coding space) of a `w x h` image up to cells of
    /// `2^max_log2`.
    pub fn new(planes: &[Vec<f64>], w: usize, h: usize, max_log2: u8) -> Self {
        let luma = &planes[0];
        let at = |x: isize, y: isize| {
            luma[(y.clamp(0, h as isize - 1) as usize) * w + x.clamp(0, w as isize - 1) as usize]
        };
        let mut edges = vec![0.0; w * h];
        for y in 0..h as isize {
            for x in 0..w as isize {
                let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                    - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
                let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                    - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
                edges[y as usize * w + x as usize] = (gx * gx + gy * gy).sqrt() / 8.0;
            }
        }
        let integrals: Vec<Integral> = planes.iter().map(|p| Integral::new(p, w, h)).collect();
        let residual = (0..=max_log2)
            .map(|l| {
                let s = 1usize << l;
                let mut energy = vec![0.0; w * h];
                for (plane, integral) in planes.iter().zip(&integrals) {
                    for y in 0..h {
                        let (y0, y1) = (y.saturating_sub(s / 2), (y + s - s / 2).min(h));
                        for x in 0..w {
                            let (x0, x1) = (x.saturating_sub(s / 2), (x + s - s / 2).min(w));
                            let mean =
                                integral.rect(x0, y0, x1, y1) / ((x1 - x0) * (y1 - y0)) as f64;
                            let d = plane[y * w + x] - mean;
                            energy[y * w + x] += d * d;
                        }
                    }
                }
                Integral::new(&energy, w, h)
            })
            .collect();
        Analysis {
            w,
            h,
            edges,
            residual,
        }
    }

    /// Predicted squared error of one leaf of side `2^log2` over `[x0,x1) x [y0,y1)`.
    pub fn predicted_error(&self, log2: u8, x0: u32, y0: u32, x1: u32, y1: u32) -> f64 {
        let l = (log2 as usize).min(self.residual.len() - 1);
        self.residual[l].rect(
            x0 as usize,
            y0 as usize,
            (x1 as usize).min(self.w),
            (y1 as usize).min(self.h),
        )
    }

    /// Per-pixel target cell size (log2): the largest scale whose predicted per-pixel
    /// error stays below `per_pixel` (the local Nyquist spacing for that tolerance).
    pub fn target_log2(&self, per_pixel: f64) -> Vec<u8> {
        let mut out = vec![0u8; self.w * self.h];
        for y in 0..self.h {
            for x in 0..self.w {
                let mut best = 0u8;
                for l in (0..self.residual.len()).rev() {
                    let r = 1usize << l;
                    let (x0, y0) = (x.saturating_sub(r / 2), y.saturating_sub(r / 2));
                    let (x1, y1) = ((x0 + r).min(self.w), (y0 + r).min(self.h));
                    let e = self.residual[l].rect(x0, y0, x1, y1) / ((x1 - x0) * (y1 - y0)) as f64;
                    if e <= per_pixel {
                        best = l as u8;
                        break;
                    }
                }
                out[y * self.w + x] = best;
            }
        }
        out
    }
}
