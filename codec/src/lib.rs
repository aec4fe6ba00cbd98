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
//! The modules hold the rest: surfaces ([`surface`]), renderers ([`render`]), F-rep
//! modelling ([`frep`]), mesh conversion ([`conversion`]), texture tools ([`texture`]),
//! quality metrics ([`metrics`]). The codec's internal stages (analysis, entropy coding,
//! fitting, key sets, syntax) are private; the `internals` feature makes them public
//! modules of [`codec`], for the fuzz targets and design experiments.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod budget;
pub mod codec;
pub mod conversion;
pub mod frep;
pub mod geometry;
pub mod image_io;
pub mod json;
pub mod metadata;
pub mod metrics;
pub mod raster;
pub mod render;
pub mod surface;
pub mod texture;

pub use codec::bitstream::{Header, Parsed};
pub use codec::{
    decode, encode, encode_with_progress, inspect, CodecError as Error, DecodeOptions,
    EncodeOptions, EncodeStats, Limits, PixelSource, RateTarget, Resampling, Scale,
};
pub use image_io::{load, register_image_hooks, save, CaeDecoder, ImageIoError};
pub use metadata::Metadata;
pub use raster::{ChannelLayout, Raster, SampleFormat};
