//! What every layer of caoen shares and needs no heavy dependency for: images as planar
//! rasters ([`raster`]), the metadata that travels with them ([`metadata`]), memory
//! limits checked before allocating ([`budget`]) and the blending functions of the
//! Cao En network's first layer ([`blend`]), which the surfaces and the image codec
//! both evaluate.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod blend;
pub mod budget;
pub mod metadata;
pub mod raster;
pub mod rng;

pub use blend::Blend;
pub use budget::{Limits, OverBudget};
pub use metadata::Metadata;
pub use raster::{ChannelLayout, Raster, SampleFormat};

/// `text` with control characters escaped (`\n`, `\u{1b}`): names and values taken
/// from a file go into one-line messages, and must not drive the terminal.
pub fn printable(text: &str) -> String {
    if !text.chars().any(char::is_control) {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}
