//! Meshes for the mesh renderer: the triangle mesh and the tessellation of surfaces.

pub use crate::geometry::mesh::{icosphere, Mesh};
pub use crate::surface::tessellate::{sphere_uv, tessellate, NormalMode};
