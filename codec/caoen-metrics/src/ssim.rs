//! SSIM (Wang, Bovik, Sheikh, Simoncelli 2004) with the paper's Gaussian window.
//!
//! Local statistics come from an 11x11 Gaussian window (sigma 1.5, weights summing
//! to 1); the SSIM map is evaluated at every position where the window fits inside
//! the image ("valid" filtering, as in the authors' `ssim_index.m`; equivalent to
//! scikit-image's `structural_similarity(gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=1)`) and averaged. There is no
//! downsampling step (the later `ssim.m` downsamples large images first).
//!
//! Images narrower or shorter than 11 pixels use, along that axis, the largest odd
//! window that fits, with the same sigma, renormalised: a 1x1 image compares its
//! single pixels.

use super::{on_luma_planes, MetricError};
use caoen_base::raster::Raster;

/// Window side in pixels.
pub const SSIM_WINDOW: usize = 11;
/// Gaussian sigma of the window, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
/// `(K1 L)^2` with `K1 = 0.01`, `L = 1`.
pub const SSIM_C1: f64 = 0.01 * 0.01;
/// `(K2 L)^2` with `K2 = 0.03`, `L = 1`.
pub const SSIM_C2: f64 = 0.03 * 0.03;

/// SSIM of two rasters' luma planes (see the module docs of [`crate`]).
pub fn ssim(reference: &Raster, test: &Raster) -> Result<f64, MetricError> {
    on_luma_planes(reference, test, ssim_planes)
}

/// Normalised 1-D Gaussian weights of odd length `len`.
fn gaussian(len: usize) -> Vec<f64> {
    let r = (len / 2) as f64;
    let w: Vec<f64> = (0..len)
        .map(|i| {
            let d = i as f64 - r;
            (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp()
        })
        .collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|v| v / s).collect()
}

/// Largest odd window length not above the standard one that fits in `n` pixels.
fn window_len(n: usize) -> usize {
    let len = SSIM_WINDOW.min(n);
    if len.is_multiple_of(2) {
        len - 1
    } else {
        len
    }
}

/// A `width x height` plane, row-major, of the sums over `kernel`'s weights `w_k` of
/// `w_k * at(x, y, k)`.
fn convolve(
    width: usize,
    height: usize,
    kernel: &[f64],
    at: impl Fn(usize, usize, usize) -> f64,
) -> Vec<f64> {
    let mut out = vec![0.0; width * height];
    for y in 0..height {
        for x in 0..width {
            out[y * width + x] = kernel
                .iter()
                .enumerate()
                .map(|(k, wk)| wk * at(x, y, k))
                .sum();
        }
    }
    out
}

/// Mean SSIM of two planes of `width x height` samples on a [0, 1] scale.
///
/// Panics if a plane's length is not `width * height`: a caller bug.
pub fn ssim_planes(a: &[f32], b: &[f32], width: u32, height: u32) -> f64 {
    ssim_and_contrast_structure(a, b, width as usize, height as usize).0
}

/// Mean SSIM and mean contrast-structure term `(2 cov + C2) / (var_a + var_b + C2)` of
/// two `w x h` planes (MS-SSIM uses the second at every scale but the coarsest).
pub(super) fn ssim_and_contrast_structure(a: &[f32], b: &[f32], w: usize, h: usize) -> (f64, f64) {
    assert!(
        a.len() == w * h && b.len() == w * h,
        "ssim_planes: plane sizes do not match {w}x{h}"
    );
    if w == 0 || h == 0 {
        return (1.0, 1.0);
    }
    let (kx, ky) = (gaussian(window_len(w)), gaussian(window_len(h)));
    let (ow, oh) = (w - kx.len() + 1, h - ky.len() + 1);

    // The five local moments, filtered separably: rows first, then columns.
    let products: [Box<dyn Fn(usize) -> f64>; 5] = [
        Box::new(|i| f64::from(a[i])),
        Box::new(|i| f64::from(b[i])),
        Box::new(|i| f64::from(a[i]) * f64::from(a[i])),
        Box::new(|i| f64::from(b[i]) * f64::from(b[i])),
        Box::new(|i| f64::from(a[i]) * f64::from(b[i])),
    ];
    let moments: Vec<Vec<f64>> = products
        .iter()
        .map(|f| {
            let rows = convolve(ow, h, &kx, |x, y, k| f(y * w + x + k));
            convolve(ow, oh, &ky, |x, y, k| rows[(y + k) * ow + x])
        })
        .collect();
    let (mx, my, xx, yy, xy) = (
        &moments[0],
        &moments[1],
        &moments[2],
        &moments[3],
        &moments[4],
    );
    let (mut total, mut total_cs) = (0.0, 0.0);
    for i in 0..ow * oh {
        let (ma, mb) = (mx[i], my[i]);
        let va = xx[i] - ma * ma;
        let vb = yy[i] - mb * mb;
        let cov = xy[i] - ma * mb;
        let cs = (2.0 * cov + SSIM_C2) / (va + vb + SSIM_C2);
        total += ((2.0 * ma * mb + SSIM_C1) * (2.0 * cov + SSIM_C2))
            / ((ma * ma + mb * mb + SSIM_C1) * (va + vb + SSIM_C2));
        total_cs += cs;
    }
    let n = (ow * oh) as f64;
    (total / n, total_cs / n)
}
