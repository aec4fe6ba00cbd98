//! The geometry every other layer builds on: 3-vectors, rays, affine maps, triangle
//! and polygon meshes with their files, winding numbers, and the polygonisation of
//! scalar fields with sharp creases. Of the rest of the library it imports only
//! `caoen-base`, for the memory budget mesh files are read within.

// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bounds;
pub mod crease;
pub mod decimate;
pub mod flat;
pub mod mesh;
pub mod mesh_file;
pub mod polygon_mesh;
pub mod polygonise;
pub mod printable;
pub mod ray;
pub mod transform;
pub mod untangle;
pub mod vector;
pub mod vertex_queue;
pub mod winding;
