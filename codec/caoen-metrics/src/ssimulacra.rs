//! SSIMULACRA2 (Cloudinary's perceptual metric) through the pure-Rust `ssimulacra2`
//! crate, for integer (sRGB display) images.

use ::ssimulacra2::{compute_frame_ssimulacra2, ColorPrimaries, Rgb, TransferCharacteristic};

use super::{check_pair, MetricError};
use caoen_base::raster::{Raster, SampleFormat};

/// Smallest side the metric accepts.
const MIN_SIDE: u32 = 8;

/// SSIMULACRA2 score (100 = identical, 90 visually lossless, 50 medium quality):
/// `None` for float (HDR) images and images smaller than 8x8, where it is undefined.
pub fn ssimulacra2(reference: &Raster, test: &Raster) -> Result<Option<f64>, MetricError> {
    check_pair(reference, test)?;
    if reference.format() == SampleFormat::F32
        || test.format() == SampleFormat::F32
        || reference.width() < MIN_SIDE
        || reference.height() < MIN_SIDE
    {
        return Ok(None);
    }
    let (Some(a), Some(b)) = (srgb_frame(reference), srgb_frame(test)) else {
        return Ok(None);
    };
    Ok(compute_frame_ssimulacra2(a, b).ok())
}

/// The colour channels as an sRGB frame (grey replicated), values clamped to [0, 1].
fn srgb_frame(r: &Raster) -> Option<Rgb> {
    let n = r.pixel_count();
    let planes: Vec<&[f32]> = if r.layout().colour_channels() == 1 {
        vec![r.plane(0); 3]
    } else {
        vec![r.plane(0), r.plane(1), r.plane(2)]
    };
    let data: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            [
                planes[0][i].clamp(0.0, 1.0),
                planes[1][i].clamp(0.0, 1.0),
                planes[2][i].clamp(0.0, 1.0),
            ]
        })
        .collect();
    Rgb::new(
        data,
        r.width() as usize,
        r.height() as usize,
        TransferCharacteristic::SRGB,
        ColorPrimaries::BT709,
    )
    .ok()
}
