//! Restoration: a small linear filter per colour plane, fitted by the encoder to bring
//! the decoded colours closest to the source's and applied by the decoder last, on the
//! coding planes before their conversion to output colours.
//!
//! A plane's filter is point-symmetric over a diamond of offsets `d` in coded pixels
//! (radius 3 for luma, 2 for chroma: the shapes of VVC's adaptive loop filter). With
//! taps `w`, the restored colour at `p` is
//!
//! `g(p) = f(p) + sum_d w_d (f(p + d) + f(p - d) - 2 f(p))`
//!
//! where `f` is the decoded plane, so a flat region passes unchanged whatever the taps.
//! At the coded size `f(p + d)` is a pixel's own colour (positions past the image
//! clamped to its edge). At any other size the offsets stay in coded pixels, and `f`
//! between output pixel centres is the bilinear interpolation of the output's samples,
//! so the filter follows the picture as the decode's scale changes. What the filter
//! corrects is what the network and the 8x8 blocks leave behind: quantisation noise
//! and ringing around edges, and edges softened by the network's blend.

pub mod fit;
pub mod syntax;

/// Tap precision: taps are integers in units of `2^-TAP_LOG2`.
pub const TAP_LOG2: u32 = 8;
/// Largest tap magnitude (just under 4).
pub const MAX_TAP: i32 = 1023;

/// One offset of each symmetric pair of the luma filter: the 7x7 diamond.
pub const LUMA_SHAPE: [(i32, i32); 12] = [
    (1, 0),
    (2, 0),
    (3, 0),
    (-2, 1),
    (-1, 1),
    (0, 1),
    (1, 1),
    (2, 1),
    (-1, 2),
    (0, 2),
    (1, 2),
    (0, 3),
];
/// One offset of each symmetric pair of the chroma filters: the 5x5 diamond.
pub const CHROMA_SHAPE: [(i32, i32); 6] = [(1, 0), (2, 0), (-1, 1), (0, 1), (1, 1), (0, 2)];
/// Largest offset along either axis.
pub const RADIUS: usize = 3;

/// The offsets of colour plane `c` (0 luma or grey, else chroma).
pub fn shape(c: usize) -> &'static [(i32, i32)] {
    if c == 0 {
        &LUMA_SHAPE
    } else {
        &CHROMA_SHAPE
    }
}

/// The filters of a file's colour planes (`None` leaves a plane alone).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Restoration {
    /// Per colour plane (Y, or Y, C1, C2): its taps in [`shape`]'s order.
    pub planes: Vec<Option<Vec<i32>>>,
}

impl Restoration {
    /// Whether any plane is filtered.
    pub fn any(&self) -> bool {
        self.planes.iter().any(Option::is_some)
    }

    /// Applies the filters to rows `rows` of `planes` (`w x h` samples each, output
    /// pixels `spacing` coded pixels apart), writing them into `out` (one slice per
    /// colour plane, `rows.len() * w` samples).
    pub fn apply_rows(
        &self,
        planes: &[&[f32]],
        (w, h): (usize, usize),
        spacing: (f64, f64),
        rows: std::ops::Range<usize>,
        out: &mut [&mut [f32]],
    ) {
        for (c, (plane, out)) in planes.iter().zip(out.iter_mut()).enumerate() {
            let src = &plane[rows.start * w..rows.end * w];
            match self.planes.get(c).and_then(Option::as_ref) {
                Some(taps) => filter_rows(plane, (w, h), spacing, shape(c), taps, rows.clone(), out),
                None => out.copy_from_slice(src),
            }
        }
    }

    /// Filters whole planes of `w x h` samples `spacing` coded pixels apart, in place.
    pub fn apply(&self, planes: &mut [Vec<f32>], (w, h): (usize, usize), spacing: (f64, f64)) {
        for c in 0..planes.len().min(self.planes.len()) {
            if let Some(taps) = &self.planes[c] {
                let mut out = vec![0.0f32; w * h];
                filter_rows(&planes[c], (w, h), spacing, shape(c), taps, 0..h, &mut out);
                planes[c] = out;
            }
        }
    }
}

/// Taps as weights.
fn weights(taps: &[i32]) -> Vec<f32> {
    taps.iter()
        .map(|&t| t as f32 / (1u32 << TAP_LOG2) as f32)
        .collect()
}

/// One plane's filter over rows `rows` into `out`.
fn filter_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    spacing: (f64, f64),
    shape: &[(i32, i32)],
    taps: &[i32],
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let wt = weights(taps);
    if spacing == (1.0, 1.0) {
        native_rows(plane, (w, h), shape, &wt, rows, out);
    } else {
        scaled_rows(plane, (w, h), spacing, shape, &wt, rows, out);
    }
}

/// The filter at the coded size: every offset is a whole pixel.
fn native_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    shape: &[(i32, i32)],
    wt: &[f32],
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut line = vec![0.0f32; w];
    for (j, y) in rows.clone().enumerate() {
        line.fill(0.0);
        let centre = &plane[y * w..(y + 1) * w];
        for (&(dx, dy), &k) in shape.iter().zip(wt) {
            let up = &plane[clamp(y as isize - dy as isize, h) * w..][..w];
            let down = &plane[clamp(y as isize + dy as isize, h) * w..][..w];
            let dxu = dx.unsigned_abs() as usize;
            // Columns `lo..hi` have both neighbours inside the row; the others clamp.
            let lo = dxu.min(w);
            let hi = w.saturating_sub(dxu).max(lo);
            for x in lo..hi {
                let (a, b) = if dx >= 0 {
                    (down[x + dxu], up[x - dxu])
                } else {
                    (down[x - dxu], up[x + dxu])
                };
                line[x] += k * (a + b - 2.0 * centre[x]);
            }
            for x in (0..lo).chain(hi..w) {
                let a = down[clamp(x as isize + dx as isize, w)];
                let b = up[clamp(x as isize - dx as isize, w)];
                line[x] += k * (a + b - 2.0 * centre[x]);
            }
        }
        let o = &mut out[j * w..(j + 1) * w];
        for x in 0..w {
            o[x] = centre[x] + line[x];
        }
    }
}

/// The filter at another size: offsets of `d / spacing` output pixels, sampled by
/// bilinear interpolation, positions clamped to the image.
fn scaled_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
    wt: &[f32],
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let at = |x: f64, y: f64| -> f32 {
        let x = x.clamp(0.0, (w - 1) as f64);
        let y = y.clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let top = plane[y0 * w + x0] * (1.0 - fx) + plane[y0 * w + x1] * fx;
        let bottom = plane[y1 * w + x0] * (1.0 - fx) + plane[y1 * w + x1] * fx;
        top * (1.0 - fy) + bottom * fy
    };
    // The offsets in output pixels, the same for every pixel.
    let offsets: Vec<(f64, f64)> = shape.iter().map(|&(dx, dy)| (dx as f64 / sx, dy as f64 / sy)).collect();
    for (j, y) in rows.enumerate() {
        for x in 0..w {
            let c = plane[y * w + x];
            let mut acc = 0.0f32;
            for (&(ox, oy), &k) in offsets.iter().zip(wt) {
                let (px, py) = (x as f64, y as f64);
                acc += k * (at(px + ox, py + oy) + at(px - ox, py - oy) - 2.0 * c);
            }
            out[j * w + x] = c + acc;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition, pixel by pixel.
    fn reference(plane: &[f32], (w, h): (usize, usize), c: usize, taps: &[i32]) -> Vec<f32> {
        let get = |x: isize, y: isize| plane[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize];
        let wt = weights(taps);
        let mut out = vec![0.0; w * h];
        for y in 0..h as isize {
            for x in 0..w as isize {
                let f = get(x, y);
                let mut acc = 0.0f32;
                for (&(dx, dy), &k) in shape(c).iter().zip(&wt) {
                    acc += k * (get(x + dx as isize, y + dy as isize) + get(x - dx as isize, y - dy as isize) - 2.0 * f);
                }
                out[y as usize * w + x as usize] = f + acc;
            }
        }
        out
    }

    fn noise(n: usize, seed: &mut u64) -> Vec<f32> {
        (0..n)
            .map(|_| {
                *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (*seed >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect()
    }

    #[test]
    fn the_native_filter_is_the_definition_at_every_pixel_and_size() {
        let mut seed = 7;
        for &(w, h) in &[(1, 1), (2, 5), (5, 2), (6, 7), (7, 6), (13, 9), (40, 3)] {
            let plane = noise(w * h, &mut seed);
            for c in [0, 1] {
                let taps: Vec<i32> = (0..shape(c).len()).map(|k| (k as i32 * 37 % 61) - 30).collect();
                let mut out = vec![0.0; w * h];
                filter_rows(&plane, (w, h), (1.0, 1.0), shape(c), &taps, 0..h, &mut out);
                assert_eq!(out, reference(&plane, (w, h), c, &taps), "{w}x{h} plane {c}");
                // A band of rows is the same rows of the whole.
                if h > 2 {
                    let mut band = vec![0.0; w];
                    filter_rows(&plane, (w, h), (1.0, 1.0), shape(c), &taps, 1..2, &mut band);
                    assert_eq!(band, out[w..2 * w]);
                }
            }
        }
    }

    #[test]
    fn scaled_sampling_at_unit_spacing_equals_the_native_filter() {
        let mut seed = 11;
        let (w, h) = (17, 11);
        let plane = noise(w * h, &mut seed);
        let taps: Vec<i32> = (0..12).map(|k| 20 - 3 * k).collect();
        let mut native = vec![0.0; w * h];
        native_rows(&plane, (w, h), &LUMA_SHAPE, &weights(&taps), 0..h, &mut native);
        let mut scaled = vec![0.0; w * h];
        scaled_rows(&plane, (w, h), (1.0, 1.0), &LUMA_SHAPE, &weights(&taps), 0..h, &mut scaled);
        for (a, b) in native.iter().zip(&scaled) {
            assert!((a - b).abs() < 1e-5, "{a} {b}");
        }
    }

    #[test]
    fn a_flat_plane_passes_unchanged_whatever_the_taps() {
        let (w, h) = (9, 8);
        let plane = vec![0.37f32; w * h];
        let r = Restoration {
            planes: vec![Some(vec![MAX_TAP; 12]), Some(vec![-MAX_TAP; 6]), None],
        };
        for spacing in [(1.0, 1.0), (0.5, 0.7), (3.0, 2.0)] {
            let mut planes = vec![plane.clone(); 3];
            r.apply(&mut planes, (w, h), spacing);
            for p in &planes {
                assert!(p.iter().all(|&v| (v - 0.37).abs() < 1e-5));
            }
        }
    }
}
