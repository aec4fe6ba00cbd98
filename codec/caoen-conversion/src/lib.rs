//! Polygon meshes into implicit surfaces (the polygon-to-implicit paper): a base
//! quadric plus local cubic perturbations fitted to the mesh, the deviation analysis
//! that measures the result against the mesh, and a radial-basis-function baseline
//! (`docs/conversion.md`).

mod choice;
pub mod components;
pub mod deviation;
pub mod distance;
pub mod fit;
pub mod job;
pub mod measure;
pub mod mesh_file;
pub mod model;
pub mod openings;
pub mod parts;
pub mod quadric;
pub mod rbf_baseline;
mod settings;
pub mod support;
pub mod thicken;

/// The mesh the conversion reads, with the geometry it asks of it.
pub use caoen_geometry::{polygon_mesh, winding};

pub use fit::{convert, Conversion, ConvertOptions, LevelReport};
pub use job::{convert_file, convert_mesh, ConvertError, ConvertJob, ConvertReport, Holes};
pub use measure::{measure, MeasureOptions, Measured};
pub use mesh_file::{read, MeshError};
pub use model::{Bump, ImplicitField, ImplicitModel, InUnitCube};
pub use polygon_mesh::{Openness, PolygonMesh, Topology, UnitFrame};
pub use winding::WindingTree;
