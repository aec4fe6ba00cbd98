//! caoen: Cao En surfaces (a two-layer network mapping a sphere onto a freeform
//! surface), their renderers, and an image codec and texture tools built on them.
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
