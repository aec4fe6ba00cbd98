//! Renderers of Cao En surfaces (paper section 7): polygon meshes, the depth buffer,
//! ray tracing of implicit solids with CSG, shading and textures, and scenes.

// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod camera;
pub mod crease;
pub mod csg;
pub mod depth_buffer;
pub mod error;
pub mod framebuffer;
pub mod mesh;
pub mod mesh_io;
pub mod polygonise;
pub mod raster;
pub mod raytrace;
pub mod renderer;
pub mod scene;
pub mod shading;
pub mod texture;
pub mod transform;
pub(crate) mod vec3;

pub use camera::{Camera, Projection, Ray};
pub use error::RenderError;
pub use framebuffer::{DepthMap, GBuffer, Hit, RgbImage};
pub use renderer::{render, Method, RenderOptions, Rendered};
pub use scene::Scene;
