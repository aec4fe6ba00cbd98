//! MS-SSIM (Wang, Simoncelli, Bovik 2003): SSIM's contrast-structure term at five
//! dyadic scales and its luminance term at the coarsest, combined with the paper's
//! exponents.
//!
//! Each scale halves the previous one by averaging 2x2 blocks (an odd last row or
//! column is dropped), as the authors' `msssim.m` does with its 2x2 low-pass filter and
//! subsampling. Within a scale the statistics are those of [`super::ssim`] (11x11
//! Gaussian window, sigma 1.5, valid positions; smaller windows on images too small
//! for it). An image too small to halve again keeps its last scale for the remaining
//! exponents. Negative mean terms (anticorrelated images) count as 0.

use super::ssim::ssim_and_contrast_structure;
use super::{on_luma_planes, MetricError};
use caoen_base::raster::Raster;

/// The exponents of the five scales, finest first (Wang et al. 2003, table 1).
pub const MS_SSIM_WEIGHTS: [f64; 5] = [0.0448, 0.2856, 0.3001, 0.2363, 0.1333];

/// MS-SSIM of two rasters' luma planes (the plane of [`super::ssim`]), at most 1.
pub fn ms_ssim(reference: &Raster, test: &Raster) -> Result<f64, MetricError> {
    on_luma_planes(reference, test, ms_ssim_planes)
}

/// MS-SSIM of two planes of `width x height` samples on a [0, 1] scale.
///
/// Panics if a plane's length is not `width * height`: a caller bug.
pub fn ms_ssim_planes(a: &[f32], b: &[f32], width: u32, height: u32) -> f64 {
    let (mut w, mut h) = (width as usize, height as usize);
    assert!(
        a.len() == w * h && b.len() == w * h,
        "ms_ssim_planes: plane sizes do not match {w}x{h}"
    );
    let (mut a, mut b) = (a.to_vec(), b.to_vec());
    let last = MS_SSIM_WEIGHTS.len() - 1;
    let mut product = 1.0;
    for (scale, &weight) in MS_SSIM_WEIGHTS.iter().enumerate() {
        let (ssim, cs) = ssim_and_contrast_structure(&a, &b, w, h);
        let term = if scale == last { ssim } else { cs };
        product *= term.max(0.0).powf(weight);
        if scale < last && w >= 2 && h >= 2 {
            a = halve(&a, w, h);
            b = halve(&b, w, h);
            (w, h) = (w / 2, h / 2);
        }
    }
    product
}

/// The plane at half size: the mean of each 2x2 block.
fn halve(p: &[f32], w: usize, h: usize) -> Vec<f32> {
    let (hw, hh) = (w / 2, h / 2);
    let mut out = Vec::with_capacity(hw * hh);
    for y in 0..hh {
        let (r0, r1) = (&p[2 * y * w..], &p[(2 * y + 1) * w..]);
        for x in 0..hw {
            let s = f64::from(r0[2 * x])
                + f64::from(r0[2 * x + 1])
                + f64::from(r1[2 * x])
                + f64::from(r1[2 * x + 1]);
            out.push((s / 4.0) as f32);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SSIM_C1;

    fn texture(w: usize, h: usize) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                0.5 + 0.3 * (0.37 * x).sin() * (0.23 * y + 0.5 * (0.11 * x).cos()).cos()
            })
            .collect()
    }

    #[test]
    fn identical_planes_score_one() {
        let a = texture(200, 180);
        assert_eq!(ms_ssim_planes(&a, &a, 200, 180), 1.0);
    }

    #[test]
    fn flat_planes_give_the_luminance_term_of_the_coarsest_scale() {
        // Zero variance: every contrast-structure term is C2 / C2 = 1, and the
        // luminance term is the same at every position and scale.
        let (w, h) = (190, 177);
        let (a, b) = (vec![0.5f32; w * h], vec![0.6f32; w * h]);
        let (ma, mb) = (0.5f64, f64::from(0.6f32));
        let l = (2.0 * ma * mb + SSIM_C1) / (ma * ma + mb * mb + SSIM_C1);
        let want = l.powf(MS_SSIM_WEIGHTS[4]);
        let got = ms_ssim_planes(&a, &b, w as u32, h as u32);
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    }

    #[test]
    fn falls_as_noise_grows_and_tiny_images_are_defined() {
        let (w, h) = (256, 256);
        let a = texture(w, h);
        let noisy = |k: f32| -> Vec<f32> {
            a.iter()
                .enumerate()
                .map(|(i, v)| v + k * (((i * 7919) % 101) as f32 / 50.0 - 1.0))
                .collect()
        };
        let s1 = ms_ssim_planes(&a, &noisy(0.02), w as u32, h as u32);
        let s2 = ms_ssim_planes(&a, &noisy(0.08), w as u32, h as u32);
        assert!(1.0 > s1 && s1 > s2 && s2 > 0.0, "{s1} {s2}");
        let t = texture(5, 3);
        let v = ms_ssim_planes(&t, &[0.5; 15], 5, 3);
        assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{v}");
    }
}
