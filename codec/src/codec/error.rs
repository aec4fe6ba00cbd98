//! Codec errors, sorted by who is at fault, carrying the offending values.

use thiserror::Error;

/// Why encoding or decoding failed.
#[derive(Debug, Error)]
pub enum CodecError {
    /// The input file is not a valid caoen stream (corrupt, truncated, wrong magic).
    #[error("invalid caoen file: {0}")]
    Format(String),
    /// The file is valid but uses something this decoder does not implement.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// A caller-supplied parameter is out of range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    Parameter {
        /// Which parameter.
        name: &'static str,
        /// Its value, formatted.
        value: String,
        /// The valid range.
        reason: &'static str,
    },
    /// Decoding would exceed a resource limit.
    #[error("limit exceeded: {what} is {value}, limit {limit}")]
    Limit {
        /// What was measured.
        what: &'static str,
        /// The measured value.
        value: u64,
        /// The limit.
        limit: u64,
    },
    /// The input image cannot be encoded (empty, non-finite samples).
    #[error("invalid image: {0}")]
    Image(#[from] crate::raster::RasterError),
    /// The surface core rejected the model.
    #[error("model: {0}")]
    Surface(#[from] crate::surface::SurfaceError),
}
