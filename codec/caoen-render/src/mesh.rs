//! Meshes for the mesh renderer: the triangle mesh and the tessellation of surfaces.

pub use caoen_geometry::mesh::{icosphere, Mesh};
pub use caoen_surface::tessellate::{sphere_uv, tessellate, NormalMode};
