//! Mesh files: reading polygon meshes from Wavefront OBJ (through `tobj`), PLY, ASCII or
//! binary, and OFF (both read here, strictly), and writing triangle meshes as OBJ (with
//! a material library), binary PLY, binary and ASCII STL, and 3MF with its unit. Counts
//! a PLY or OFF header declares are checked against the bytes that follow it and
//! against the memory budget before the parser allocates anything.

mod obj;
mod off;
mod ply;
mod stl;
mod threemf;
mod zip;

use std::path::Path;

use caoen_base::budget::Limits;
use std::path::PathBuf;

use thiserror::Error;

use super::polygon_mesh::PolygonMesh;

pub use obj::{read_obj, write_mtl, write_obj};
pub use off::read_off;
pub use ply::{read_ply, write_ply};
pub use stl::{read_stl, write_stl, write_stl_ascii};
pub use threemf::{three_mf_model, write_3mf, LengthUnit};

/// The most vertices or triangles a mesh may have (2^31: indices stay in `u32`
/// arithmetic with room to spare).
pub const MAX_ELEMENTS: u64 = 1 << 31;

/// A mesh file that cannot be used, with the offending values.
#[derive(Debug, Error)]
pub enum MeshError {
    /// Reading the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The OBJ parser refused the file.
    #[error("{}: not a valid OBJ file: {source}", path.display())]
    Obj {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        #[source]
        source: tobj::LoadError,
    },
    /// A PLY header line that is not understood.
    #[error("{}: not a valid PLY file: header line {line}: `{text}`", path.display())]
    BadHeaderLine {
        /// The file.
        path: PathBuf,
        /// The line (from 1).
        line: usize,
        /// The line as written (control characters replaced).
        text: String,
    },
    /// A PLY element ends before all its declared values are read.
    #[error("{}: not a valid PLY file: {element} {index} is cut short (property `{property}` missing)", path.display())]
    MissingValues {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// The first property without a value.
        property: String,
    },
    /// An ASCII PLY element line carries more numbers than its properties take.
    #[error("{}: not a valid PLY file: {element} {index} has {extra} more numbers than its properties take", path.display())]
    ExtraValues {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// How many numbers are left over.
        extra: usize,
    },
    /// A PLY value that is not a number of its declared type.
    #[error("{}: not a valid PLY file: {element} {index}: `{token}` is not a {ty}", path.display())]
    BadValue {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// The text found (control characters replaced).
        token: String,
        /// The declared type.
        ty: &'static str,
    },
    /// A PLY list whose length is negative or over what the file holds.
    #[error("{}: not a valid PLY file: {element} {index}: list length {length}", path.display())]
    BadListLength {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// The length as read.
        length: f64,
    },
    /// Data after the last element the header declares: the header lies about a count.
    #[error(
        "{}: not a valid PLY file: {bytes} bytes after the {declared} elements the \
         header declares (a count that is too small?)",
        path.display()
    )]
    TrailingData {
        /// The file.
        path: PathBuf,
        /// Bytes left over.
        bytes: u64,
        /// Elements declared, all kinds together.
        declared: u64,
    },
    /// A PLY header without its `end_header` line.
    #[error("{}: not a valid PLY file: no end_header line", path.display())]
    NoEndHeader {
        /// The file.
        path: PathBuf,
    },
    /// A PLY header that is not UTF-8 text.
    #[error("{}: not a valid PLY file: header is not text", path.display())]
    HeaderNotText {
        /// The file.
        path: PathBuf,
    },
    /// A PLY element whose count is not a number.
    #[error("{}: not a valid PLY file: element {element}: count `{count}`", path.display())]
    BadCount {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The count as written.
        count: String,
    },
    /// A PLY file without a `vertex` element.
    #[error("{}: not a valid PLY file: no `vertex` element", path.display())]
    NoVertices {
        /// The file.
        path: PathBuf,
    },
    /// A PLY vertex without one of its coordinates.
    #[error("{}: not a valid PLY file: vertex {vertex} has no numeric `{axis}`", path.display())]
    NoCoordinate {
        /// The file.
        path: PathBuf,
        /// The vertex (from 0).
        vertex: usize,
        /// The missing property: `x`, `y` or `z`.
        axis: &'static str,
    },
    /// A PLY face without its list of vertex indices.
    #[error("{}: not a valid PLY file: face {face} has no `vertex_indices` list", path.display())]
    NoIndexList {
        /// The file.
        path: PathBuf,
        /// The face (from 0).
        face: usize,
    },
    /// A PLY face whose vertex indices are not integers.
    #[error("{}: not a valid PLY file: face {face}: vertex indices are not integers", path.display())]
    IndicesNotIntegers {
        /// The file.
        path: PathBuf,
        /// The face (from 0).
        face: usize,
    },
    /// An OFF file that breaks the format: what is wrong, on which line.
    #[error("{}: not a valid OFF file: line {line}: {what}", path.display())]
    BadOff {
        /// The file.
        path: PathBuf,
        /// The line (from 1).
        line: usize,
        /// What is wrong there.
        what: String,
    },
    /// The file's name does not say OBJ, PLY or OFF.
    #[error("{}: unknown mesh format (expected a name ending in .obj, .ply or .off)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// A face names a vertex that does not exist.
    #[error("{}: face {face} uses vertex {index}, but the mesh has {vertices} vertices", path.display())]
    BadIndex {
        /// The file.
        path: PathBuf,
        /// The face's position in the file (from 0).
        face: usize,
        /// The vertex it names (from 0).
        index: i64,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{}: vertex {vertex} has a non-finite coordinate {value}", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The vertex (from 0).
        vertex: usize,
        /// The coordinate.
        value: f64,
    },
    /// No triangle with three distinct corners.
    #[error("{}: the mesh has no triangles", path.display())]
    NoTriangles {
        /// The file.
        path: PathBuf,
    },
    /// Every vertex at one point: the mesh has no extent.
    #[error("{}: all vertices are at one point", path.display())]
    SinglePoint {
        /// The file.
        path: PathBuf,
    },
    /// Every triangle has (next to) zero area: the mesh has no surface to convert.
    #[error("{}: the mesh has no area: its {triangles} triangles are all degenerate (collinear corners)", path.display())]
    NoArea {
        /// The file.
        path: PathBuf,
        /// How many triangles it has.
        triangles: usize,
    },
    /// A vertex too far from the origin for a converted model's frame.
    #[error(
        "{}: vertex {vertex} has coordinate {value:e}; a mesh to convert must lie \
         within +-{max:e} (scale it down first)",
        path.display()
    )]
    OutsideWorld {
        /// The file.
        path: PathBuf,
        /// The vertex (from 0).
        vertex: usize,
        /// The coordinate.
        value: f64,
        /// The largest coordinate magnitude allowed.
        max: f64,
    },
    /// A mesh whose box is too small for a converted model's frame.
    #[error(
        "{}: the mesh is {extent:e} across; a mesh to convert must be at least \
         {min:e} across (scale it up first)",
        path.display()
    )]
    TooSmall {
        /// The file.
        path: PathBuf,
        /// The longest side of its box.
        extent: f64,
        /// The smallest allowed.
        min: f64,
    },
    /// A PLY element declared with more than [`MAX_ELEMENTS`].
    #[error("{}: element {element}: {declared} declared, over the limit of {max}", path.display())]
    TooManyElements {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The count its header declares.
        declared: u64,
        /// The limit.
        max: u64,
    },
    /// A PLY header declaring more elements than the bytes after it can hold.
    #[error(
        "{}: element {element}: {declared} declared, more than the {body} bytes after \
         the header can hold",
        path.display()
    )]
    ShortBody {
        /// The file.
        path: PathBuf,
        /// The element's name.
        element: String,
        /// The count its header declares.
        declared: u64,
        /// Bytes from the header's end to the file's end.
        body: u64,
    },
    /// The memory budget does not hold the mesh.
    #[error("{}: {source}", path.display())]
    OverBudget {
        /// The file.
        path: PathBuf,
        /// The budget check.
        source: caoen_base::budget::OverBudget,
    },
}

/// Reads an OBJ, PLY or OFF file (chosen by the extension), within `limits`.
pub fn read(path: &Path, limits: &Limits) -> Result<PolygonMesh, MeshError> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let reader: fn(&[u8], &str, &Limits) -> Result<PolygonMesh, MeshError> = match ext.as_deref() {
        Some("obj") => read_obj,
        Some("ply") => read_ply,
        Some("off") => read_off,
        _ => return Err(MeshError::UnknownFormat { path: name.into() }),
    };
    let bytes = limits.read(path).map_err(|source| MeshError::Io {
        path: name.clone().into(),
        source,
    })?;
    reader(&bytes, &name, limits)
}

/// Checks `need` bytes for the mesh read from `name` against `limits`.
pub(super) fn budget(name: &str, need: u64, limits: &Limits) -> Result<(), MeshError> {
    limits
        .check(|| "reading the mesh".to_string(), need)
        .map_err(|source| MeshError::OverBudget {
            path: name.into(),
            source,
        })
}

/// Rejects non-finite coordinates and empty or degenerate meshes; drops triangles
/// with a repeated corner (they carry no surface).
pub(super) fn finish(mut mesh: PolygonMesh, name: &str) -> Result<PolygonMesh, MeshError> {
    for (i, p) in mesh.positions.iter().enumerate() {
        if let Some(&value) = p.iter().find(|v| !v.is_finite()) {
            return Err(MeshError::NonFinite {
                path: name.into(),
                vertex: i,
                value,
            });
        }
    }
    mesh.triangles
        .retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
    if mesh.triangles.is_empty() {
        return Err(MeshError::NoTriangles { path: name.into() });
    }
    let (lo, hi) = mesh.bounds();
    if (0..3).all(|k| hi[k] - lo[k] <= 0.0) {
        return Err(MeshError::SinglePoint { path: name.into() });
    }
    // Relative to the box: collinear corners leave only rounding-level areas.
    let diagonal2: f64 = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum();
    let area = mesh.area();
    if area <= 1e-12 * diagonal2 {
        return Err(MeshError::NoArea {
            path: name.into(),
            triangles: mesh.triangles.len(),
        });
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests;
