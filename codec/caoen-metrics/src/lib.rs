//! Image quality metrics: MSE/PSNR over the colour channels, luma PSNR, SSIM and
//! SSIMULACRA2, comparing a reference raster with a test raster.
//!
//! # Conventions (what every number means)
//! - **Integer images** (8/16-bit, sRGB-encoded display values normalised to [0, 1]):
//!   errors are measured on the stored (gamma-encoded) values with peak 1.0, as every
//!   codec comparison does. A U8 and a U16 raster compare on the same scale.
//! - **HDR images** (either raster is [`SampleFormat::F32`]: linear radiance of any
//!   size): both rasters go through a fixed log encoding first,
//!   `e(v) = clamp((log2(max(v, 0) + 2^-14) + 14) / 32, 0, 1)`, which maps 32 stops,
//!   2^-14 (the smallest normal half float) to 2^18, onto [0, 1]; then peak 1.0.
//!   A log scale because a float codec's errors are relative (a 1% error in the sun
//!   and in the shadow cost the same), and a fixed one so numbers from different
//!   images and runs are comparable. 1 dB of log-PSNR is a fixed relative error.
//! - **RGB PSNR** (`psnr`): MSE pooled over all colour channels (alpha excluded; for
//!   grey images the grey channel), `10 log10(1 / MSE)`; `+inf` for identical images.
//! - **Y-PSNR** (`psnr_y`): integer images use BT.601 luma of the encoded values,
//!   `Y' = 0.299 R' + 0.587 G' + 0.114 B'` (JPEG's and WebP's YCbCr, so Y-PSNR is
//!   comparable with their tools); HDR images use BT.709 luminance of the linear
//!   values, `Y = 0.2126 R + 0.7152 G + 0.0722 B`, then the log encoding.
//! - **SSIM**: Wang et al. 2004 on the same luma plane, 11x11 Gaussian window
//!   (sigma 1.5), `K1 = 0.01`, `K2 = 0.03`, dynamic range 1, averaged over the
//!   valid window positions (no padding, no downsampling). See [`ssim`].
//! - **MS-SSIM** (`ms_ssim`): Wang et al. 2003 on the same luma plane, five dyadic
//!   scales of SSIM's window, the paper's exponents. See [`ms_ssim`].
//! - **SSIMULACRA2** (`ssimulacra2`): the `ssimulacra2` crate on the colour channels
//!   as sRGB (grey replicated to RGB); `None` for HDR images, which it is not defined
//!   for, and for images smaller than 8x8, which it rejects.
//!
//! All sums run sequentially in `f64`: the same inputs give the same bits on every run.

mod ms_ssim;
mod psnr;
mod ssim;
mod ssimulacra;

pub use ms_ssim::{ms_ssim, ms_ssim_planes, MS_SSIM_WEIGHTS};
pub use psnr::{mse, psnr_from_mse};
pub use ssim::{ssim, ssim_planes, SSIM_C1, SSIM_C2, SSIM_SIGMA, SSIM_WINDOW};
pub use ssimulacra::ssimulacra2;

use thiserror::Error;

use caoen_base::raster::{Raster, SampleFormat};

/// Why two rasters cannot be compared.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum MetricError {
    /// The images differ in size.
    #[error("images differ in size: {a_width}x{a_height} vs {b_width}x{b_height}")]
    Size {
        /// Reference width.
        a_width: u32,
        /// Reference height.
        a_height: u32,
        /// Test width.
        b_width: u32,
        /// Test height.
        b_height: u32,
    },
    /// The images differ in colour channel count (grey vs colour).
    #[error("images differ in colour channels: {a} vs {b}")]
    Channels {
        /// Reference colour channels.
        a: usize,
        /// Test colour channels.
        b: usize,
    },
}

/// Which value scale the metrics were computed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scale {
    /// Stored display values in [0, 1] (integer images).
    Display,
    /// The fixed log encoding of linear values (HDR images; see the module docs).
    LogHdr,
}

impl Scale {
    /// The scale two rasters are compared on: log if either is float.
    pub fn for_pair(a: &Raster, b: &Raster) -> Scale {
        if a.format() == SampleFormat::F32 || b.format() == SampleFormat::F32 {
            Scale::LogHdr
        } else {
            Scale::Display
        }
    }

    /// Stable lowercase name (`display`, `log-hdr`).
    pub fn name(self) -> &'static str {
        match self {
            Scale::Display => "display",
            Scale::LogHdr => "log-hdr",
        }
    }
}

/// Everything [`compare`] measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Scale the numbers are on.
    pub scale: Scale,
    /// Mean squared error pooled over the colour channels.
    pub mse: f64,
    /// RGB (all colour channels) PSNR in dB; `+inf` when identical.
    pub psnr: f64,
    /// Mean squared error of the luma plane.
    pub mse_y: f64,
    /// Luma PSNR in dB; `+inf` when identical.
    pub psnr_y: f64,
    /// SSIM of the luma plane, at most 1.
    pub ssim: f64,
    /// MS-SSIM of the luma plane, at most 1.
    pub ms_ssim: f64,
    /// SSIMULACRA2 score (100 = identical), when defined.
    pub ssimulacra2: Option<f64>,
    /// Alpha PSNR in dB, when both images have alpha.
    pub psnr_alpha: Option<f64>,
}

/// `planes` of two rasters' luma planes (on the pair's [`Scale`]), once the rasters are
/// checked comparable.
fn on_luma_planes(
    reference: &Raster,
    test: &Raster,
    planes: fn(&[f32], &[f32], u32, u32) -> f64,
) -> Result<f64, MetricError> {
    check_pair(reference, test)?;
    let scale = Scale::for_pair(reference, test);
    Ok(planes(
        &luma_plane(reference, scale),
        &luma_plane(test, scale),
        reference.width(),
        reference.height(),
    ))
}

/// Checks that two rasters can be compared.
fn check_pair(a: &Raster, b: &Raster) -> Result<(), MetricError> {
    if (a.width(), a.height()) != (b.width(), b.height()) {
        return Err(MetricError::Size {
            a_width: a.width(),
            a_height: a.height(),
            b_width: b.width(),
            b_height: b.height(),
        });
    }
    let (ca, cb) = (a.layout().colour_channels(), b.layout().colour_channels());
    if ca != cb {
        return Err(MetricError::Channels { a: ca, b: cb });
    }
    Ok(())
}

/// The fixed HDR log encoding (see the module docs).
pub fn log_encode(v: f32) -> f32 {
    const FLOOR: f32 = 1.0 / 16384.0; // 2^-14
    ((f64::from(v.max(0.0) + FLOOR).log2() as f32 + 14.0) / 32.0).clamp(0.0, 1.0)
}

/// The colour planes of a raster on the given scale, concatenated.
fn colour_planes(r: &Raster, scale: Scale) -> Vec<f32> {
    let n = r.pixel_count() * r.layout().colour_channels();
    let colour = &r.samples()[..n];
    match scale {
        Scale::Display => colour.to_vec(),
        Scale::LogHdr => colour.iter().map(|&v| log_encode(v)).collect(),
    }
}

/// The luma plane a raster's Y-PSNR and SSIM are computed on (see the module docs).
pub fn luma_plane(r: &Raster, scale: Scale) -> Vec<f32> {
    if r.layout().colour_channels() == 1 {
        let g = r.plane(0);
        return match scale {
            Scale::Display => g.to_vec(),
            Scale::LogHdr => g.iter().map(|&v| log_encode(v)).collect(),
        };
    }
    let (rr, gg, bb) = (r.plane(0), r.plane(1), r.plane(2));
    match scale {
        Scale::Display => (0..r.pixel_count())
            .map(|i| 0.299 * rr[i] + 0.587 * gg[i] + 0.114 * bb[i])
            .collect(),
        Scale::LogHdr => (0..r.pixel_count())
            .map(|i| log_encode(0.2126 * rr[i] + 0.7152 * gg[i] + 0.0722 * bb[i]))
            .collect(),
    }
}

/// RGB PSNR: MSE pooled over the colour channels (see the module docs).
pub fn psnr(reference: &Raster, test: &Raster) -> Result<f64, MetricError> {
    check_pair(reference, test)?;
    let scale = Scale::for_pair(reference, test);
    Ok(psnr_from_mse(
        mse(
            &colour_planes(reference, scale),
            &colour_planes(test, scale),
        ),
        1.0,
    ))
}

/// Luma PSNR (BT.601 luma for integer images, log BT.709 luminance for HDR).
pub fn psnr_y(reference: &Raster, test: &Raster) -> Result<f64, MetricError> {
    check_pair(reference, test)?;
    let scale = Scale::for_pair(reference, test);
    Ok(psnr_from_mse(
        mse(&luma_plane(reference, scale), &luma_plane(test, scale)),
        1.0,
    ))
}

/// All the metrics at once (sharing the converted planes).
pub fn compare(reference: &Raster, test: &Raster) -> Result<Comparison, MetricError> {
    check_pair(reference, test)?;
    let scale = Scale::for_pair(reference, test);
    let mse_rgb = mse(
        &colour_planes(reference, scale),
        &colour_planes(test, scale),
    );
    let (ya, yb) = (luma_plane(reference, scale), luma_plane(test, scale));
    let mse_y = mse(&ya, &yb);
    let ssim = ssim_planes(&ya, &yb, reference.width(), reference.height());
    let ms_ssim = ms_ssim_planes(&ya, &yb, reference.width(), reference.height());
    let psnr_alpha = (reference.layout().has_alpha() && test.layout().has_alpha()).then(|| {
        let (ca, cb) = (
            reference.layout().channels() - 1,
            test.layout().channels() - 1,
        );
        psnr_from_mse(mse(reference.plane(ca), test.plane(cb)), 1.0)
    });
    Ok(Comparison {
        scale,
        mse: mse_rgb,
        psnr: psnr_from_mse(mse_rgb, 1.0),
        mse_y,
        psnr_y: psnr_from_mse(mse_y, 1.0),
        ssim,
        ms_ssim,
        ssimulacra2: ssimulacra2(reference, test)?,
        psnr_alpha,
    })
}
