//! Function-based modelling (F-rep): solids as the set where a real function of 3-D
//! space is non-negative, built from primitives by R-function set operations, blends,
//! offsets and transforms; rendered by interval ray casting and polygonisation, and
//! exported to POV-Ray (`docs/frep.md`).

pub mod assets;
pub mod convex_solid;
pub mod deform;
pub mod height_map;
pub mod interval;
pub mod mesh_field;
pub mod model_file;
pub mod node;
pub mod patch_index;
pub mod polygon_patch;
pub mod polygonise;
pub mod pov;
pub mod primitive;
pub mod raycast;
pub mod rfunction;

pub use interval::{Aabb, Interval};
pub use node::{Node, Patch, Support};
