//! Mesh files as the conversion reads them: the readers (and writers) of
//! `caoen_geometry::mesh_file`, and the frame a mesh to convert must fit.

pub use caoen_geometry::mesh_file::*;

use super::polygon_mesh::PolygonMesh;

/// Largest coordinate magnitude of a mesh to convert. The model file holds `scale`
/// (the mesh's longest side) up to 1e6 and `translate` up to 1e6 (the world limit):
/// within +-4e5 both hold, with room for the box around the mesh and for rounding.
pub const MAX_CONVERT_COORDINATE: f64 = 4e5;

/// Smallest longest side of a mesh to convert (the model file's smallest `scale` is
/// 1e-6; the factor of ten leaves room for rounding).
pub const MIN_CONVERT_EXTENT: f64 = 1e-5;

/// Checks that `mesh` fits the frame a converted model file can describe (see
/// [`MAX_CONVERT_COORDINATE`], [`MIN_CONVERT_EXTENT`]), so the model convert writes
/// reads back.
pub fn check_convertible(mesh: &PolygonMesh, name: &str) -> Result<(), MeshError> {
    for (vertex, p) in mesh.positions.iter().enumerate() {
        if let Some(&value) = p
            .iter()
            .find(|v| v.is_nan() || v.abs() > MAX_CONVERT_COORDINATE)
        {
            return Err(MeshError::OutsideWorld {
                path: name.into(),
                vertex,
                value,
                max: MAX_CONVERT_COORDINATE,
            });
        }
    }
    let (lo, hi) = mesh.bounds();
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if extent < MIN_CONVERT_EXTENT {
        return Err(MeshError::TooSmall {
            path: name.into(),
            extent,
            min: MIN_CONVERT_EXTENT,
        });
    }
    Ok(())
}
