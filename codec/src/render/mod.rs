//! Renderers of Cao En surfaces (paper section 7): polygon meshes, and (to come) the
//! depth buffer, ray tracing of implicit solids with CSG, and shading.

pub mod mesh;
pub mod mesh_io;
