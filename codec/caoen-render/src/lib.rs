//! Renderers of Cao En surfaces (paper section 7): polygon meshes, the depth buffer,
//! ray tracing of implicit solids with CSG, shading and textures, and scenes.

// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bump;
pub mod bvh;
pub mod cae_texture;
pub mod camera;
pub mod csg;
pub mod depth_buffer;
pub mod error;
pub mod framebuffer;
pub mod image_map;
mod light_file;
pub mod lights;
pub mod mesh;
pub mod noise;
pub mod pattern;
pub mod pov;
pub mod pov_mesh;
pub mod raster;
pub mod rays;
pub mod renderer;
pub mod scene;
pub mod scene_file;
pub mod shading;
pub mod texture;
pub mod work;

pub use camera::{Camera, Projection, Ray};
/// Mesh files (OBJ with its material library, PLY, STL), read and written where the
/// meshes are defined.
pub use caoen_geometry::mesh_file as mesh_io;
/// Ray tracing of convex implicit solids (the tracer belongs to the solids).
pub use caoen_surface::tracer as raytrace;
pub use error::RenderError;
pub use framebuffer::{DepthMap, GBuffer, Hit, RgbImage};
pub use renderer::{render, Method, RenderOptions, Rendered};
pub use scene::Scene;
