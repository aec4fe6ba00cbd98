//! The image codec (paper section 9): an image as a Cao En network whose outputs are
//! `(x, y, colour)` points over a hypersphere domain. See `docs/format.md` for the
//! bitstream and the reconstruction, `docs/codec-ablation.md` for the model's choices
//! and what each measured.
//!
//! This facade is all most callers need: [`encode`], [`decode`], [`inspect`].

//! Beside the facade, the CLI's tools need three stages: [`bitstream`] (the container,
//! for `caoen info`), [`decoder`] (the decoded key points, for distortion and integer
//! output) and [`keypoint_map`]. The other stages are the codec's internals: public only
//! with the `internals` feature, for the fuzz targets and experiments.

pub mod bitstream;
pub mod decoder;
mod error;
pub mod keypoint_map;

/// Declares the internal stages: public with the `internals` feature, else crate-private.
macro_rules! stages {
    ($($(#[$doc:meta])* $name:ident;)*) => {
        $(
            $(#[$doc])*
            #[cfg(feature = "internals")]
            pub mod $name;
            $(#[$doc])*
            #[cfg(not(feature = "internals"))]
            #[allow(dead_code, unreachable_pub)]
            pub(crate) mod $name;
        )*
    };
}

stages! {
    /// Edge and per-scale detail maps that start the tree.
    analysis;
    /// Opponent colour transform and the HDR curve.
    colour;
    /// The transform-coded detail layer over the network's colours.
    detail;
    /// Quantisation and assembly of a file.
    encoder;
    /// Adaptive binary and multi-symbol models on the ANS coder; the bit counter.
    entropy;
    /// Ridge least squares by block conjugate gradients.
    fit;
    /// Pixels embedded on the sphere; sharpness for a footprint.
    geometry;
    /// Key-point sets: the network they stand for, and grid evaluation.
    keyset;
    /// Choosing the tree and fitting the colours.
    model;
    /// The adaptive quadtree.
    quadtree;
    /// Quality and effort mapping; the rate-target search.
    rate_control;
    /// Split flags and value residuals as coded symbols.
    syntax;
}

pub use error::{CodecError, Tag};

use crate::raster::Raster;

/// Encoder settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeOptions {
    /// Quality 0..=100 (higher: more key points, finer quantisation).
    pub quality: f32,
    /// Effort 1..=9: encoder time traded for quality at the same size.
    pub effort: u8,
    /// Rate target, overriding `quality` by search.
    pub target: Option<RateTarget>,
    /// Exact number of key points (luma), overriding the quality's choice.
    pub keypoints: Option<usize>,
}

/// A rate target for the encoder's search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RateTarget {
    /// Bits per pixel of the whole file.
    BitsPerPixel(f64),
    /// Total file size in bytes.
    Bytes(u64),
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            quality: 75.0,
            effort: 5,
            target: None,
            keypoints: None,
        }
    }
}

/// Decoder settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodeOptions {
    /// Output size; `None` decodes at the coded size.
    pub size: Option<(u32, u32)>,
    /// Forward-mapping supersampling `S` (S x S samples per output pixel, 1..=4);
    /// `None` uses the identity fast path where the file allows it.
    pub supersample: Option<u32>,
    /// Largest output the decoder will allocate, in pixels.
    pub max_pixels: u64,
}

/// Default decode limit on pixels (2^26).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 26;
/// Largest image side the format allows.
pub const MAX_SIDE: u32 = 16384;

impl Default for DecodeOptions {
    fn default() -> Self {
        DecodeOptions {
            size: None,
            supersample: None,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

/// Encodes `image` into a caoen file.
pub fn encode(image: &Raster, opts: &EncodeOptions) -> Result<Vec<u8>, CodecError> {
    encode_with_progress(image, opts, |_, _| {}).map(|(bytes, _)| bytes)
}

/// Encodes, reporting progress as `(done, total)` steps; also returns statistics.
pub fn encode_with_progress(
    image: &Raster,
    opts: &EncodeOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<(Vec<u8>, encoder::EncodeStats), CodecError> {
    if !(0.0..=100.0).contains(&opts.quality) {
        return Err(CodecError::Parameter {
            name: "quality",
            value: opts.quality.to_string(),
            reason: "0..=100",
        });
    }
    if !(1..=9).contains(&opts.effort) {
        return Err(CodecError::Parameter {
            name: "effort",
            value: opts.effort.to_string(),
            reason: "1..=9",
        });
    }
    if opts.keypoints == Some(0) {
        return Err(CodecError::Parameter {
            name: "keypoints",
            value: "0".into(),
            reason: "at least 1",
        });
    }
    let worst_quality = if opts.target.is_some() {
        100.0
    } else {
        opts.quality
    };
    let need = encode_memory(image.width(), image.height(), worst_quality);
    crate::budget::check(
        || {
            format!(
                "encoding {}x{} at quality {worst_quality}",
                image.width(),
                image.height()
            )
        },
        need,
    )?;
    let planes = encoder::prepare(image)?;
    let target = match opts.target {
        None => None,
        Some(RateTarget::BitsPerPixel(b)) if b.is_finite() && b > 0.0 => {
            Some(b * image.pixel_count() as f64 / 8.0)
        }
        Some(RateTarget::Bytes(n)) if n > 0 => Some(n as f64),
        Some(t) => {
            return Err(CodecError::Parameter {
                name: "target",
                value: format!("{t:?}"),
                reason: "must be positive",
            });
        }
    };
    let Some(target) = target else {
        let s = rate_control::settings(opts.quality, opts.effort, opts.keypoints)
            .adapted_to(image.format(), image.layout().has_alpha());
        return encoder::encode_with(image, &planes, &s, progress);
    };
    let steps = 6 + opts.effort as usize;
    let mut done = 0;
    let (q, _) = rate_control::search_quality(target, 0.02, steps, |q| {
        done += 1;
        progress(done, steps + 1);
        let s = rate_control::settings(q, opts.effort, opts.keypoints)
            .adapted_to(image.format(), image.layout().has_alpha());
        Ok(encoder::encode_with(image, &planes, &s, |_, _| {})?.0.len())
    })?;
    let s = rate_control::settings(q, opts.effort, opts.keypoints)
        .adapted_to(image.format(), image.layout().has_alpha());
    let out = encoder::encode_with(image, &planes, &s, |_, _| {})?;
    progress(steps + 1, steps + 1);
    Ok(out)
}

/// Estimated peak memory of encoding a `width x height` image at `quality`, in bytes.
///
/// The encoder holds the coding planes, the analysis maps and, per key-point set, the
/// fit's sparse design matrix and its transpose; the matrix grows with the number of
/// kernels over each pixel, which rises with quality. The per-pixel figures bound peak
/// RSS measured on noisy photo-like images (the densest trees): about 280 bytes per
/// pixel at quality 5, 360 at 75 and 510 at 100.
pub fn encode_memory(width: u32, height: u32, quality: f32) -> u64 {
    let q = f64::from(quality.clamp(0.0, 100.0)) / 100.0;
    let per_pixel = (300.0 + 240.0 * q * q).ceil() as u64;
    crate::budget::bytes(width.into(), height.into(), per_pixel).saturating_add(32 << 20)
}

/// Decodes a caoen file.
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    decoder::decode(bytes, opts)
}

/// Describes a caoen file without decoding it: the header and the sections, with every
/// container check [`decode`] makes. There is no pixel limit, since nothing is
/// allocated for the image.
pub fn inspect(bytes: &[u8]) -> Result<bitstream::Parsed<'_>, CodecError> {
    bitstream::parse(bytes, u64::MAX)
}
