//! Lapping: an invertible filter across block edges that hides the blocks.
//!
//! A block transform leaves its quantisation error largest at the block's edges, and
//! two neighbours' errors differ there, so the decoded layer steps. The decoder's
//! post-filter moves each value within a pixel of an inner block edge towards the
//! value of the neighbouring block's series at the mirror position: `r + w(t) (r' -
//! r)`, `t` the distance to the edge. `w` is 1/2 at the edge (both sides meet: the
//! layer is continuous there), `w0` at the pixel centres next to it and 0 a pixel
//! away. The encoder applies the inverse to the residual's pixel pairs around every
//! edge before the transform, so without quantisation the two cancel: unlike
//! deblocking, lapping smooths the error, not the picture. The filter is separable
//! (along x, then along y; the two commute), and in a block `b_u(8 - t) = (-1)^u b_u(t)`,
//! so the mirror value is the neighbour's series with its odd rows or columns negated,
//! evaluated with the basis at the position itself.

use super::dct::N;

/// The lapping a file stores (one header byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lapping {
    /// The post-filter's weight at the pixel centres next to an edge, in 256ths
    /// (1..=127: below one half, so the filter is invertible).
    pub weight: u8,
}

impl Lapping {
    /// The encoder's setting (`docs/codec-ablation.md`).
    pub const DEFAULT: Lapping = Lapping { weight: 46 };

    /// Whether the weight is in its range.
    pub fn is_valid(self) -> bool {
        (1..=127).contains(&self.weight)
    }

    /// `w0`.
    fn w0(self) -> f64 {
        self.weight as f64 / 256.0
    }

    /// The weight at distance `t` (pixels) from an edge: 1/2 at the edge, `w0` at half
    /// a pixel, 0 from one pixel on, linear in between.
    pub fn weight_at(self, t: f64) -> f64 {
        let (t, w0) = (t.abs(), self.w0());
        if t >= 1.0 {
            0.0
        } else if t >= 0.5 {
            2.0 * w0 * (1.0 - t)
        } else {
            0.5 + (w0 - 0.5) * 2.0 * t
        }
    }

    /// The inner block edge within a pixel of coordinate `p` among `count` blocks:
    /// `(own block, neighbour block, weight)`, or none.
    pub fn at(self, p: f64, count: usize) -> Option<(usize, usize, f32)> {
        let e = (p / N as f64).round();
        if e < 1.0 || e >= count as f64 {
            return None;
        }
        let s = p - e * N as f64;
        let w = self.weight_at(s);
        if w <= 0.0 {
            return None;
        }
        let e = e as usize;
        Some(if s < 0.0 {
            (e - 1, e, w as f32)
        } else {
            (e, e - 1, w as f32)
        })
    }

    /// Applies the encoder's pre-filter (the inverse of the decoder's post-filter at
    /// pixel centres) to a `width x height` plane whose first pixel is image pixel
    /// `origin`, for the inner block edges of an image `image` pixels wide and high.
    /// Pixels whose partner across an edge lies outside the plane are left as they
    /// are: the caller gives a tile a pixel of margin and keeps only its inside.
    pub fn prefilter(
        self,
        plane: &mut [f64],
        (width, height): (usize, usize),
        origin: (u32, u32),
        image: (u32, u32),
    ) {
        // Pixel pair (a, b) -> mean + (a - b)/2 / (1 - 2 w0) on each side.
        let gain = 1.0 / (1.0 - 2.0 * self.w0());
        let edges = |o: u32, n: usize, size: u32| {
            let (o, size) = (o as usize, size as usize);
            (1..size.div_ceil(N))
                .map(|e| e * N)
                .filter(move |&e| e > o && e < o + n)
                .map(move |e| e - o)
        };
        let pair = |a: &mut f64, b: &mut f64| {
            let (m, d) = ((*a + *b) * 0.5, (*a - *b) * 0.5 * gain);
            (*a, *b) = (m + d, m - d);
        };
        for e in edges(origin.1, height, image.1) {
            let (top, bottom) = plane.split_at_mut(e * width);
            for (a, b) in top[(e - 1) * width..].iter_mut().zip(&mut bottom[..width]) {
                pair(a, b);
            }
        }
        let columns: Vec<usize> = edges(origin.0, width, image.0).collect();
        for row in plane.chunks_exact_mut(width) {
            for &e in &columns {
                let (left, right) = row.split_at_mut(e);
                pair(&mut left[e - 1], &mut right[0]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_weight_meets_at_the_edge_and_ends_a_pixel_away() {
        let l = Lapping { weight: 40 };
        assert!((l.weight_at(0.0) - 0.5).abs() < 1e-12);
        assert!((l.weight_at(0.5) - 40.0 / 256.0).abs() < 1e-12);
        assert!((l.weight_at(-0.5) - 40.0 / 256.0).abs() < 1e-12);
        assert_eq!(l.weight_at(1.0), 0.0);
        // Continuous: no jump anywhere along the ramp.
        for i in 0..200 {
            let t = i as f64 / 100.0;
            assert!((l.weight_at(t) - l.weight_at(t + 1e-6)).abs() < 1e-5, "{t}");
        }
        assert_eq!(l.at(15.5, 4), Some((1, 2, (40.0 / 256.0) as f32)));
        assert_eq!(l.at(16.5, 4), Some((2, 1, (40.0 / 256.0) as f32)));
        assert_eq!(l.at(17.0, 4), None);
        assert_eq!(l.at(7.5, 1), None, "no edge at the image's border");
        assert_eq!(l.at(0.2, 4), None);
    }

    #[test]
    fn the_prefilter_is_undone_by_the_post_filter_at_pixel_centres() {
        let l = Lapping::DEFAULT;
        let (w, h) = (19usize, 11usize);
        let x: Vec<f64> = (0..w * h)
            .map(|i| ((i * 37 % 101) as f64 * 0.13).sin())
            .collect();
        let mut pre = x.clone();
        l.prefilter(&mut pre, (w, h), (0, 0), (w as u32, h as u32));
        assert_ne!(pre, x);
        // Post-filter: along x then along y, each pixel towards its mirror partner.
        let post = |p: &[f64]| {
            let mut a = p.to_vec();
            for j in 0..h {
                for i in 0..w {
                    if let Some((_, _, wt)) = l.at(i as f64 + 0.5, w.div_ceil(N)) {
                        let m = if (i + 1) % N == 0 { i + 1 } else { i - 1 };
                        a[j * w + i] = p[j * w + i] + wt as f64 * (p[j * w + m] - p[j * w + i]);
                    }
                }
            }
            let b = a.clone();
            for j in 0..h {
                if let Some((_, _, wt)) = l.at(j as f64 + 0.5, h.div_ceil(N)) {
                    let m = if (j + 1) % N == 0 { j + 1 } else { j - 1 };
                    for i in 0..w {
                        a[j * w + i] = b[j * w + i] + wt as f64 * (b[m * w + i] - b[j * w + i]);
                    }
                }
            }
            a
        };
        let back = post(&pre);
        for (a, b) in back.iter().zip(&x) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn a_tile_with_a_margin_prefilters_as_the_whole_plane_does() {
        let l = Lapping::DEFAULT;
        let (w, h) = (40usize, 24usize);
        let x: Vec<f64> = (0..w * h)
            .map(|i| ((i * 53 % 97) as f64 * 0.21).cos())
            .collect();
        let mut whole = x.clone();
        l.prefilter(&mut whole, (w, h), (0, 0), (w as u32, h as u32));
        // The tile x 16..32, y 8..24 with a pixel of margin where the image goes on.
        let (x0, x1, y0, y1) = (15usize, 33usize, 7usize, 24usize);
        let mut tile: Vec<f64> = (y0..y1)
            .flat_map(|j| x[j * w + x0..j * w + x1].to_vec())
            .collect();
        l.prefilter(
            &mut tile,
            (x1 - x0, y1 - y0),
            (x0 as u32, y0 as u32),
            (w as u32, h as u32),
        );
        for j in 8..24 {
            for i in 16..32 {
                assert_eq!(
                    tile[(j - y0) * (x1 - x0) + i - x0],
                    whole[j * w + i],
                    "({i}, {j})"
                );
            }
        }
    }
}
