//! The source at a smaller size, for coding an image there: the decoder draws the
//! continuous network at the image's own size. A separable Lanczos-3 filter stretched
//! by the scale, so it also band-limits what the smaller grid cannot hold.

use super::source::PixelSource;
use super::tiling::TileRect;
use caoen_base::raster::{Raster, SampleFormat};
use rayon::prelude::*;

/// Source rows read at once by the horizontal pass.
const STRIP_ROWS: u32 = 64;

/// A coded size relative to the image's: `tenths / 10` of each side, rounded up.
/// Tenths keep the sizes exact integers on every machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scale {
    /// The coded side over the image's, in tenths (1..=10).
    tenths: u32,
}

impl Scale {
    /// Half size per side.
    pub const HALF: Scale = Scale { tenths: 5 };

    /// `tenths / 10`, for `tenths` in 1..=10.
    pub const fn new(tenths: u32) -> Option<Scale> {
        if tenths >= 1 && tenths <= 10 {
            Some(Scale { tenths })
        } else {
            None
        }
    }

    /// `tenths / 10` of a constant in 1..=10.
    pub(crate) const fn of_tenths(tenths: u32) -> Scale {
        assert!(tenths >= 1 && tenths <= 10);
        Scale { tenths }
    }

    /// The coded side over the image's, in tenths.
    pub fn tenths(self) -> u32 {
        self.tenths
    }

    /// The coded side over the image's.
    pub fn factor(self) -> f64 {
        f64::from(self.tenths) / 10.0
    }

    /// The coded size of a `width x height` image (at least 1 x 1).
    pub fn coded_size(self, width: u32, height: u32) -> (u32, u32) {
        let side = |v: u32| (u64::from(v) * u64::from(self.tenths)).div_ceil(10).max(1) as u32;
        (side(width), side(height))
    }
}

/// Bytes [`downscale`] holds at its peak, beside its output: the horizontal pass's
/// planes, and one strip of the source.
pub fn downscale_memory(width: u32, height: u32, channels: usize, to: (u32, u32)) -> u64 {
    let c = channels as u64;
    let pass = u64::from(to.0) * u64::from(height) * c * 4;
    let strip = u64::from(width) * u64::from(STRIP_ROWS) * c * 4;
    let out = u64::from(to.0) * u64::from(to.1) * c * 4;
    pass + strip + out
}

/// Lanczos-3 at `x` (in output sample spacings).
fn lanczos3(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        return 1.0;
    }
    if x.abs() >= 3.0 {
        return 0.0;
    }
    let px = std::f64::consts::PI * x;
    3.0 * px.sin() * (px / 3.0).sin() / (px * px)
}

/// One output sample's filter along an axis: weights on the source samples from
/// `first`, summing to 1.
#[derive(Debug, Clone, PartialEq)]
struct Taps {
    first: usize,
    weights: Vec<f64>,
}

/// The filters mapping `src` samples onto `dst <= src`, with centres aligned as the
/// decoder aligns pixel centres (output `i` at source position `(i + 1/2) src/dst -
/// 1/2`) and the source's edge samples repeated past its ends.
fn taps(src: usize, dst: usize) -> Vec<Taps> {
    let scale = src as f64 / dst as f64;
    let support = 3.0 * scale;
    (0..dst)
        .map(|i| {
            let centre = (i as f64 + 0.5) * scale - 0.5;
            let lo = (centre - support).ceil() as isize;
            let hi = (centre + support).floor() as isize;
            let first = lo.clamp(0, src as isize - 1) as usize;
            let last = hi.clamp(0, src as isize - 1) as usize;
            let mut weights = vec![0.0; last - first + 1];
            for x in lo..=hi {
                let k = (x.clamp(0, src as isize - 1) as usize) - first;
                weights[k] += lanczos3((x as f64 - centre) / scale);
            }
            let sum: f64 = weights.iter().sum();
            weights.iter_mut().for_each(|w| *w /= sum);
            Taps { first, weights }
        })
        .collect()
}

/// `image` at `to` (at most its size per side), of the same layout and format. Samples
/// of integer formats stay in [0, 1] and float ones non-negative, as sources are.
pub fn downscale(image: &(impl PixelSource + ?Sized), to: (u32, u32)) -> Raster {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let (tw, th) = (to.0 as usize, to.1 as usize);
    let channels = image.layout().channels();
    let across = taps(w, tw);
    let down = taps(h, th);
    // Horizontal pass, strip by strip of the source: channel-major planes tw x h.
    let mut pass = vec![0f32; tw * h * channels];
    for y0 in (0..h).step_by(STRIP_ROWS as usize) {
        let rows = (h - y0).min(STRIP_ROWS as usize);
        let strip = image.region(TileRect {
            x0: 0,
            y0: y0 as u32,
            width: w as u32,
            height: rows as u32,
        });
        let samples = strip.samples();
        for c in 0..channels {
            let plane = &samples[c * w * rows..(c + 1) * w * rows];
            let out = &mut pass[c * tw * h + y0 * tw..c * tw * h + (y0 + rows) * tw];
            out.par_chunks_mut(tw).enumerate().for_each(|(r, row)| {
                let src = &plane[r * w..(r + 1) * w];
                for (o, t) in row.iter_mut().zip(&across) {
                    let s = &src[t.first..t.first + t.weights.len()];
                    *o = s
                        .iter()
                        .zip(&t.weights)
                        .map(|(&v, &k)| f64::from(v) * k)
                        .sum::<f64>() as f32;
                }
            });
        }
    }
    let (lo, hi) = match image.format() {
        SampleFormat::F32 => (0.0, f32::MAX),
        SampleFormat::U8 | SampleFormat::U16 => (0.0, 1.0),
    };
    let mut out = vec![0f32; tw * th * channels];
    for c in 0..channels {
        let plane = &pass[c * tw * h..(c + 1) * tw * h];
        out[c * tw * th..(c + 1) * tw * th]
            .par_chunks_mut(tw)
            .zip(&down)
            .for_each(|(row, t)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let v: f64 = t
                        .weights
                        .iter()
                        .enumerate()
                        .map(|(k, &wk)| f64::from(plane[(t.first + k) * tw + x]) * wk)
                        .sum();
                    *o = (v as f32).clamp(lo, hi);
                }
            });
    }
    Raster::from_finite(to.0, to.1, image.layout(), image.format(), out)
        .expect("the sizes are the target's")
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_base::raster::ChannelLayout;

    #[test]
    fn filters_sum_to_one_and_stay_inside_the_source() {
        for (src, dst) in [(768, 384), (7, 4), (5, 1), (1023, 512), (3, 3)] {
            for t in taps(src, dst) {
                assert!((t.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                assert!(t.first + t.weights.len() <= src);
            }
        }
    }

    #[test]
    fn a_constant_stays_constant_and_a_ramp_a_ramp() {
        let (w, h) = (37, 20);
        let mut s = vec![0.25f32; w * h];
        s.extend((0..w * h).map(|i| (i % w) as f32 / w as f32));
        let img = Raster::new(
            w as u32,
            h as u32,
            ChannelLayout::GreyAlpha,
            SampleFormat::U8,
            s,
        )
        .unwrap();
        let (tw, th) = Scale::HALF.coded_size(w as u32, h as u32);
        let d = downscale(&img, (tw, th));
        assert_eq!((d.width(), d.height()), (19, 10));
        assert!(d.plane(0).iter().all(|&v| (v - 0.25).abs() < 1e-6));
        // Away from the edges, output x sits at source position 2x + 1/2 (37/19 apart).
        let scale = w as f64 / tw as f64;
        for x in 3..tw as usize - 3 {
            let want = ((x as f64 + 0.5) * scale - 0.5) / w as f64;
            assert!(
                (f64::from(d.plane(1)[5 * tw as usize + x]) - want).abs() < 1e-3,
                "x {x}"
            );
        }
    }

    #[test]
    fn strips_do_not_show_in_the_output() {
        // Taller than a strip, with rows that differ: the result must equal the
        // separable filter applied to the whole image at once.
        let (w, h) = (9usize, 150usize);
        let s: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 101) as f32 / 100.0)
            .collect();
        let img = Raster::new(
            w as u32,
            h as u32,
            ChannelLayout::Grey,
            SampleFormat::U16,
            s.clone(),
        )
        .unwrap();
        let d = downscale(&img, (4, 61));
        let (a, b) = (taps(w, 4), taps(h, 61));
        for y in 0..61 {
            for x in 0..4 {
                let mut v = 0.0;
                for (j, wy) in b[y].weights.iter().enumerate() {
                    for (i, wx) in a[x].weights.iter().enumerate() {
                        v += wy * wx * f64::from(s[(b[y].first + j) * w + a[x].first + i]);
                    }
                }
                let got = f64::from(d.plane(0)[y * 4 + x]);
                assert!(
                    (got - v.clamp(0.0, 1.0)).abs() < 1e-5,
                    "({x}, {y}): {got} against {v}"
                );
            }
        }
    }
}
