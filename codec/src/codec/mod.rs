//! The image codec (paper section 9): an image as a Cao En network whose outputs are
//! `(x, y, colour)` points over a hypersphere domain. See `docs/format.md` for the
//! bitstream and `shared/design/codec.md` for the model.
//!
//! This facade is all most callers need: [`encode`], [`decode`], [`inspect`].

pub mod analysis;
pub mod colour;
pub mod entropy;
mod error;
pub mod fit;
pub mod geometry;
pub mod keyset;
pub mod model;
pub mod quadtree;

pub use error::CodecError;

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
    let _ = (image, opts);
    Err(CodecError::Unsupported(
        "the encoder is being built (issue 5)".into(),
    ))
}

/// Decodes a caoen file.
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    let _ = (bytes, opts);
    Err(CodecError::Unsupported(
        "the decoder is being built (issue 5)".into(),
    ))
}
