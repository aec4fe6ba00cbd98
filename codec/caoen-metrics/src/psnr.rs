//! Mean squared error and PSNR.

/// Mean squared error of two equally long sample slices, summed in `f64` in order
/// (deterministic). Panics if the lengths differ, which is a caller bug: the public
/// raster metrics check sizes first.
pub fn mse(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len(), "mse of slices of different lengths");
    if a.is_empty() {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = f64::from(x) - f64::from(y);
            d * d
        })
        .sum();
    sum / a.len() as f64
}

/// PSNR in dB for a mean squared error and a peak value: `10 log10(peak^2 / mse)`,
/// `+inf` when `mse` is 0.
pub fn psnr_from_mse(mse: f64, peak: f64) -> f64 {
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / mse).log10()
    }
}
