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
        // Appended row by row: no zeroing pass over a table the size of the image.
        let stride = w + 1;
        let mut sums = Vec::with_capacity(stride * (h + 1));
        sums.resize(stride, 0.0);
        for y in 0..h {
            sums.push(0.0);
            let mut row = 0.0;
            for x in 0..w {
                row += plane[y * w + x];
                let above = sums[y * stride + x + 1];
                sums.push(above + row);
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
    /// Smallest scale held in `residual`, log2.
    first: usize,
    /// Per scale `log2 s` (`first..`): integral of the squared detail finer than `s`.
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
        Analysis {
            edges,
            ..Self::levels(planes, w, h, 0, max_log2)
        }
    }

    /// The predicted errors alone, for scales `2^min_log2..=2^max_log2`: what the
    /// encoder's tree asks of [`Analysis::predicted_error`] (the levels that may split),
    /// at a fraction of [`Analysis::new`]'s cost. `edges` is empty.
    pub fn levels(planes: &[Vec<f64>], w: usize, h: usize, min_log2: u8, max_log2: u8) -> Self {
        let integrals: Vec<Integral> = planes.iter().map(|p| Integral::new(p, w, h)).collect();
        let residual = (min_log2..=max_log2)
            .map(|l| {
                let s = 1usize << l;
                // Dividing by a power of two is multiplying by its reciprocal, bit for
                // bit: whole windows (all but the edges) take the multiply.
                let inv_area = 1.0 / (s * s) as f64;
                let mut energy = vec![0.0; w * h];
                let (before, after) = (s / 2, s - s / 2);
                for (plane, integral) in planes.iter().zip(&integrals) {
                    for y in 0..h {
                        let (y0, y1) = (y.saturating_sub(before), (y + after).min(h));
                        let row = &plane[y * w..(y + 1) * w];
                        let out = &mut energy[y * w..(y + 1) * w];
                        let clipped = |x: usize| {
                            let (x0, x1) = (x.saturating_sub(before), (x + after).min(w));
                            let area = (x1 - x0) * (y1 - y0);
                            let d = row[x] - integral.rect(x0, y0, x1, y1) / area as f64;
                            d * d
                        };
                        // Columns whose window lies whole inside the image, on rows
                        // whose window does too: four streams and a multiply, the same
                        // sum as `rect` term by term.
                        let (lo, hi) = (before, (w + 1).saturating_sub(after));
                        if y1 - y0 < s || lo >= hi {
                            for (x, e) in out.iter_mut().enumerate() {
                                *e += clipped(x);
                            }
                            continue;
                        }
                        let stride = w + 1;
                        let r0 = &integral.sums[y0 * stride..(y0 + 1) * stride];
                        let r1 = &integral.sums[y1 * stride..(y1 + 1) * stride];
                        let n = hi - lo;
                        let (a, b) = (&r1[lo + after..][..n], &r1[lo - before..][..n]);
                        let (c, d) = (&r0[lo + after..][..n], &r0[lo - before..][..n]);
                        for i in 0..n {
                            let mean = (a[i] - b[i] - c[i] + d[i]) * inv_area;
                            let e = row[lo + i] - mean;
                            out[lo + i] += e * e;
                        }
                        for x in (0..lo).chain(hi..w) {
                            out[x] += clipped(x);
                        }
                    }
                }
                Integral::new(&energy, w, h)
            })
            .collect();
        Analysis {
            w,
            h,
            edges: Vec::new(),
            first: min_log2 as usize,
            residual,
        }
    }

    /// Predicted squared error of one leaf of side `2^log2` over `[x0,x1) x [y0,y1)`;
    /// `log2` at least the smallest scale analysed.
    pub fn predicted_error(&self, log2: u8, x0: u32, y0: u32, x1: u32, y1: u32) -> f64 {
        let l = (log2 as usize).min(self.first + self.residual.len() - 1);
        self.residual[l - self.first].rect(
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
                for l in (self.first..self.first + self.residual.len()).rev() {
                    let r = 1usize << l;
                    let (x0, y0) = (x.saturating_sub(r / 2), y.saturating_sub(r / 2));
                    let (x1, y1) = ((x0 + r).min(self.w), (y0 + r).min(self.h));
                    let e = self.residual[l - self.first].rect(x0, y0, x1, y1)
                        / ((x1 - x0) * (y1 - y0)) as f64;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_levels_alone_predict_what_the_full_analysis_does() {
        let (w, h) = (45, 38);
        let planes: Vec<Vec<f64>> = (0..3)
            .map(|c| {
                (0..w * h)
                    .map(|i| ((i * (7 + c)) % 31) as f64 / 31.0 + ((i / w) as f64 * 0.2).sin())
                    .collect()
            })
            .collect();
        let full = Analysis::new(&planes, w, h, 5);
        // Every window's mean by plain division, against the reciprocal the fast loop
        // uses on whole windows.
        for l in 0..=5u8 {
            let s = 1usize << l;
            let mut energy = vec![0.0; w * h];
            for plane in &planes {
                let integral = Integral::new(plane, w, h);
                for y in 0..h {
                    let (y0, y1) = (y.saturating_sub(s / 2), (y + s - s / 2).min(h));
                    for x in 0..w {
                        let (x0, x1) = (x.saturating_sub(s / 2), (x + s - s / 2).min(w));
                        let mean = integral.rect(x0, y0, x1, y1) / ((x1 - x0) * (y1 - y0)) as f64;
                        let d = plane[y * w + x] - mean;
                        energy[y * w + x] += d * d;
                    }
                }
            }
            let want = Integral::new(&energy, w, h);
            assert!(
                want.sums
                    .iter()
                    .zip(&full.residual[l as usize].sums)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "level {l}"
            );
        }
        let lean = Analysis::levels(&planes, w, h, 2, 5);
        for log2 in 2..=7u8 {
            for (x0, y0, x1, y1) in [
                (0, 0, 32, 32),
                (8, 16, 16, 24),
                (32, 32, 64, 64),
                (40, 0, 45, 4),
            ] {
                assert_eq!(
                    full.predicted_error(log2, x0, y0, x1, y1).to_bits(),
                    lean.predicted_error(log2, x0, y0, x1, y1).to_bits(),
                    "log2 {log2} at ({x0},{y0})"
                );
            }
        }
    }
}
