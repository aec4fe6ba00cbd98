//! caoen: Cao En surfaces (a two-layer network mapping a sphere onto a freeform
//! surface), their renderers, and an image codec and texture tools built on them.
//!
//! The image codec's facade is at the crate root: [`encode`], [`decode`] and
//! [`inspect`] with their options, [`load`] and [`save`] for image files, and
//! [`register_image_hooks`] so that `image::open` reads `.cae` files.
//!
//! ```
//! use caoen::{decode, encode, load, save, DecodeOptions, EncodeOptions};
//! use std::path::Path;
//!
//! fn main() -> Result<(), Box<dyn std::error::Error>> {
//! #   let dir = std::env::temp_dir().join(format!("caoen-doctest-{}", std::process::id()));
//! #   std::fs::create_dir_all(&dir)?;
//! #   std::env::set_current_dir(&dir)?;
//! #   let ramp = (0..48 * 32 * 3).map(|i| (i % 97) as f32 / 96.0).collect();
//! #   let rgb = (caoen::ChannelLayout::Rgb, caoen::SampleFormat::U8);
//! #   save(&caoen::Raster::new(48, 32, rgb.0, rgb.1, ramp)?, Path::new("photo.png"))?;
//!     let image = load(Path::new("photo.png"))?;
//!     let options = EncodeOptions { quality: 80.0, ..EncodeOptions::default() };
//!     std::fs::write("photo.cae", encode(&image, &options)?)?;
//!     let decoded = decode(&std::fs::read("photo.cae")?, &DecodeOptions::default())?;
//!     save(&decoded, Path::new("decoded.png"))?;
//!     Ok(())
//! }
//! ```
//!
//! caoen is a workspace of one crate per layer, and this crate is its facade: each
//! layer is re-exported as a module. The image codec: [`codec`] (the format and decoder,
//! `caoen-decoder`, with the encoder, `caoen-encoder`), [`image_io`] (image files,
//! `caoen-io`), [`metrics`]; the shared ground: [`raster`], [`metadata`], [`budget`]
//! (`caoen-base`); the 3-D kit: [`geometry`], [`surface`] (with [`json`], the model
//! files' errors), [`frep`], [`render`], [`conversion`], [`texture`]. A program that only
//! decodes depends on `caoen-decoder` alone.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub use caoen_base::{budget, metadata, raster, rng};
pub use caoen_conversion as conversion;
pub use caoen_frep as frep;
pub use caoen_geometry as geometry;
pub use caoen_io as image_io;
pub use caoen_metrics as metrics;
pub use caoen_render as render;
pub use caoen_surface as surface;
pub use caoen_surface::json;
pub use caoen_texture as texture;

/// The image codec: the format and its decoder (`caoen-decoder`) and the encoder
/// (`caoen-encoder`) side by side.
pub mod codec {
    pub use caoen_decoder::*;
    pub use caoen_encoder::*;
}

pub use codec::bitstream::{Header, Parsed};
pub use codec::{
    decode, encode, encode_with_progress, inspect, CodecError as Error, DecodeOptions,
    EncodeOptions, EncodeStats, Limits, PixelSource, RateTarget, Region, Resampling, Scale,
};
pub use image_io::{load, register_image_hooks, save, CaeDecoder, ImageIoError};
pub use metadata::Metadata;
pub use raster::{ChannelLayout, Raster, SampleFormat};
