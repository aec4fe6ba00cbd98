//! Texture tools on Cao En networks (paper section 9): image distortion by moving
//! control points ([`warp`]) and texture transfer between surfaces sharing a domain
//! ([`transfer`], with the solid textures of [`solid`] for its texture-space method).
//! See `docs/texture.md`.

pub mod projected;
pub mod solid;
pub mod transfer;
pub mod warp;
pub mod warp3d;

mod error;

pub use error::TextureError;
