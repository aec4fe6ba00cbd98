//! Texture tools on Cao En networks (paper section 9): image distortion by moving
//! control points ([`warp`]) and texture transfer between surfaces sharing a domain
//! ([`transfer`], with the solid textures of [`solid`] for its texture-space method).
//! See `docs/texture.md`.

pub mod projected;
pub mod solid;
pub mod transfer;
pub mod warp;
pub mod warp3d;

use thiserror::Error;

/// Why a texture operation failed.
#[derive(Debug, Error)]
pub enum TextureError {
    /// Bad input or parameters.
    #[error("{0}")]
    Invalid(String),
    /// A network could not be built or evaluated.
    #[error(transparent)]
    Surface(#[from] crate::surface::SurfaceError),
    /// A raster could not be built.
    #[error(transparent)]
    Raster(#[from] crate::raster::RasterError),
}
