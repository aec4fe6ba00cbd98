//! The geometry every other layer builds on: 3-vectors, rays, affine maps, triangle
//! meshes, and the polygonisation of scalar fields with sharp creases. It imports
//! nothing from the rest of the library.

// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod crease;
pub mod mesh;
pub mod polygonise;
pub mod printable;
pub mod ray;
pub mod transform;
pub mod vector;
