//! The Cao En surface core: the network, its blending functions, domains, exact and
//! interpolated normals, projections, the implicit form for convex solids, morphing,
//! and the surface description file.

pub use caoen_base::blend;
pub mod domain;
pub mod error;
pub mod gallery;
pub mod implicit;
pub mod json;
pub mod model_file;
pub mod morph;
pub mod network;
pub mod normals;
pub mod projection;
mod support_index;
pub mod tessellate;
pub mod tracer;

pub use blend::Blend;
pub use domain::{Domain, ParamGrid};
pub use error::SurfaceError;
pub use implicit::{ConvexSolid, Plane};
pub use model_file::SurfaceModel;
pub use network::{KeyPoint, Network};
