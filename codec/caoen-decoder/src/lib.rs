//! The `.cae` format and its decoder: the container, the entropy-coded key points and
//! detail layer, and the reconstruction at any size (paper section 9: an image as a
//! Cao En network whose outputs are `(x, y, colour)` points over a hypersphere
//! domain). `docs/format.md` is the bitstream's specification.
//!
//! [`decode`] and [`inspect`] are all most callers need. The coding stages are public
//! modules because the encoder (`caoen-encoder`) and the texture tools build on them.
//! With the default `parallel` feature the decoder spreads its work over rayon's
//! threads; without it, it runs on the caller's thread and pulls in no thread pool
//! (the WebAssembly build). The output is the same either way.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bitstream;
pub mod colour;
pub mod decoder;
pub mod deringing;
pub mod detail;
pub mod entropy;
mod error;
pub mod geometry;
pub mod keyset;
mod par;
pub mod quadtree;
pub mod restoration;
pub mod syntax;
pub mod tiling;
pub mod varint;

pub use caoen_base::budget::Limits;
pub use colour::ColourBasis;
pub use error::{CodecError, Tag};
pub use quadtree::Cell;

use caoen_base::raster::Raster;

/// Decoder settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodeOptions {
    /// Output size; `None` decodes at the image's size (which a file coded at a
    /// smaller size records in its header).
    pub size: Option<(u32, u32)>,
    /// Forward-mapping supersampling `S` (S x S samples per output pixel, 1..=4);
    /// `None` uses the identity fast path where the file allows it.
    pub supersample: Option<u32>,
    /// Largest output the decoder will allocate, in pixels.
    pub max_pixels: u64,
    /// Memory limit of the call.
    pub limits: Limits,
    /// Decode only this rectangle of the image, drawn at `size` (by default its own
    /// size, rounded); `None` decodes the whole image.
    pub region: Option<Region>,
}

/// A rectangle `[x0, x1) x [y0, y1)` in the image's own pixel coordinates (the size
/// [`decode`] outputs by default), fractions allowed.
///
/// A region decoded at `k` times its size equals the same rectangle of the whole image
/// decoded at `k` times the image's size, where the rectangle's edges fall on that
/// decode's pixel edges (elsewhere it is the same continuous image sampled at other
/// centres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Left edge.
    pub x0: f64,
    /// Top edge.
    pub y0: f64,
    /// Right edge (exclusive).
    pub x1: f64,
    /// Bottom edge (exclusive).
    pub y1: f64,
}

/// Default decode limit on pixels (2^28, 16384 x 16384: the memory budget is the limit
/// that binds).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 28;
/// Largest image side the format allows.
pub const MAX_SIDE: u32 = 16384;

impl Default for DecodeOptions {
    fn default() -> Self {
        DecodeOptions {
            size: None,
            supersample: None,
            max_pixels: DEFAULT_MAX_PIXELS,
            limits: Limits::default(),
            region: None,
        }
    }
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
