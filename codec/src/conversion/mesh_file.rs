//! Reading polygon meshes: Wavefront OBJ (through `tobj`) and PLY, ASCII or binary
//! (through `ply-rs-bw`). Counts a PLY header declares are checked against the bytes
//! that follow it and against the memory budget before the parser allocates anything.

use std::path::Path;

use thiserror::Error;

use super::polygon_mesh::PolygonMesh;
use crate::geometry::vector::{cross, norm, sub};

/// The most vertices or triangles a mesh may have (2^31: indices stay in `u32`
/// arithmetic with room to spare).
pub const MAX_ELEMENTS: u64 = 1 << 31;

/// A mesh file that cannot be used, with the offending values.
#[derive(Debug, Error)]
pub enum MeshError {
    /// Reading the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The OBJ parser refused the file.
    #[error("{path}: not a valid OBJ file: {source}")]
    Obj {
        /// The file.
        path: String,
        /// What the parser said.
        #[source]
        source: tobj::LoadError,
    },
    /// The PLY parser refused the file.
    #[error("{path}: not a valid PLY file: {source}")]
    Ply {
        /// The file.
        path: String,
        /// What the parser said.
        #[source]
        source: ply_rs_bw::parser::ParseError,
    },
    /// A PLY header without its `end_header` line.
    #[error("{path}: not a valid PLY file: no end_header line")]
    NoEndHeader {
        /// The file.
        path: String,
    },
    /// A PLY header that is not UTF-8 text.
    #[error("{path}: not a valid PLY file: header is not text")]
    HeaderNotText {
        /// The file.
        path: String,
    },
    /// A PLY element whose count is not a number.
    #[error("{path}: not a valid PLY file: element {element}: count `{count}`")]
    BadCount {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The count as written.
        count: String,
    },
    /// A PLY file without a `vertex` element.
    #[error("{path}: not a valid PLY file: no `vertex` element")]
    NoVertices {
        /// The file.
        path: String,
    },
    /// A PLY vertex without one of its coordinates.
    #[error("{path}: not a valid PLY file: vertex {vertex} has no numeric `{axis}`")]
    NoCoordinate {
        /// The file.
        path: String,
        /// The vertex (from 0).
        vertex: usize,
        /// The missing property: `x`, `y` or `z`.
        axis: &'static str,
    },
    /// A PLY face without its list of vertex indices.
    #[error("{path}: not a valid PLY file: face {face} has no `vertex_indices` list")]
    NoIndexList {
        /// The file.
        path: String,
        /// The face (from 0).
        face: usize,
    },
    /// A PLY face whose vertex indices are not integers.
    #[error("{path}: not a valid PLY file: face {face}: vertex indices are not integers")]
    IndicesNotIntegers {
        /// The file.
        path: String,
        /// The face (from 0).
        face: usize,
    },
    /// The file's name does not say OBJ or PLY.
    #[error("{path}: unknown mesh format (expected a name ending in .obj or .ply)")]
    UnknownFormat {
        /// The file.
        path: String,
    },
    /// A face names a vertex that does not exist.
    #[error("{path}: face {face} uses vertex {index}, but the mesh has {vertices} vertices")]
    BadIndex {
        /// The file.
        path: String,
        /// The face's position in the file (from 0).
        face: usize,
        /// The vertex it names (from 0).
        index: i64,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{path}: vertex {vertex} has a non-finite coordinate {value}")]
    NonFinite {
        /// The file.
        path: String,
        /// The vertex (from 0).
        vertex: usize,
        /// The coordinate.
        value: f64,
    },
    /// No triangle with three distinct corners.
    #[error("{path}: the mesh has no triangles")]
    NoTriangles {
        /// The file.
        path: String,
    },
    /// Every vertex at one point: the mesh has no extent.
    #[error("{path}: all vertices are at one point")]
    SinglePoint {
        /// The file.
        path: String,
    },
    /// Every triangle has (next to) zero area: the mesh has no surface to convert.
    #[error("{path}: the mesh has no area: its {triangles} triangles are all degenerate (collinear corners)")]
    NoArea {
        /// The file.
        path: String,
        /// How many triangles it has.
        triangles: usize,
    },
    /// A PLY element declared with more than [`MAX_ELEMENTS`].
    #[error("{path}: element {element}: {declared} declared, over the limit of {max}")]
    TooManyElements {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The count its header declares.
        declared: u64,
        /// The limit.
        max: u64,
    },
    /// A PLY header declaring more elements than the bytes after it can hold.
    #[error(
        "{path}: element {element}: {declared} declared, more than the {body} bytes after \
         the header can hold"
    )]
    ShortBody {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The count its header declares.
        declared: u64,
        /// Bytes from the header's end to the file's end.
        body: u64,
    },
    /// The memory budget does not hold the mesh.
    #[error("{path}: {source}")]
    OverBudget {
        /// The file.
        path: String,
        /// The budget check.
        source: crate::budget::OverBudget,
    },
}

/// Reads an OBJ or PLY file (chosen by the extension), within the memory budget.
pub fn read(path: &Path) -> Result<PolygonMesh, MeshError> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let ply = match ext.as_deref() {
        Some("obj") => false,
        Some("ply") => true,
        _ => return Err(MeshError::UnknownFormat { path: name }),
    };
    let bytes = crate::budget::read(path).map_err(|source| MeshError::Io {
        path: name.clone(),
        source,
    })?;
    if ply {
        read_ply(&bytes, &name)
    } else {
        read_obj(&bytes, &name)
    }
}

/// Parses OBJ text; polygons become triangle fans, every object joins one mesh.
pub fn read_obj(bytes: &[u8], name: &str) -> Result<PolygonMesh, MeshError> {
    // tobj keeps positions, indices and its own bookkeeping: a few times the text.
    budget(name, bytes.len() as u64 * 6)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
        Err(tobj::LoadError::MaterialParseError)
    })
    .map_err(|source| MeshError::Obj {
        path: name.into(),
        source,
    })?;
    let mut mesh = PolygonMesh::default();
    let mut face = 0;
    for m in &models {
        let base = mesh.positions.len();
        let p = &m.mesh.positions;
        let count = p.len() / 3;
        for v in 0..count {
            mesh.positions.push([p[3 * v], p[3 * v + 1], p[3 * v + 2]]);
        }
        for t in m.mesh.indices.chunks_exact(3) {
            let mut tri = [0u32; 3];
            for k in 0..3 {
                if t[k] as usize >= count {
                    return Err(MeshError::BadIndex {
                        path: name.into(),
                        face,
                        index: i64::from(t[k]),
                        vertices: count,
                    });
                }
                tri[k] = (base + t[k] as usize) as u32;
            }
            mesh.triangles.push(tri);
            face += 1;
        }
    }
    finish(mesh, name)
}

/// The bytes each value of a PLY scalar type takes in a binary file.
fn scalar_bytes(t: &str) -> Option<u64> {
    Some(match t {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

/// Checks the counts a PLY header declares against the bytes after it: each element
/// takes at least its scalars' bytes (binary) or two characters (ASCII), so a short
/// file cannot declare billions of elements.
fn check_ply_header(bytes: &[u8], name: &str) -> Result<(), MeshError> {
    let path = || name.to_string();
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or_else(|| MeshError::NoEndHeader { path: path() })?;
    let header = std::str::from_utf8(&bytes[..end])
        .map_err(|_| MeshError::HeaderNotText { path: path() })?;
    let body = (bytes.len() - end) as u64;
    let ascii = header.lines().any(|l| l.trim() == "format ascii 1.0");
    let mut elements: Vec<(String, u64, u64)> = Vec::new();
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["element", el, count] => {
                let n: u64 = count.parse().map_err(|_| MeshError::BadCount {
                    path: path(),
                    element: el.to_string(),
                    count: count.to_string(),
                })?;
                if n > MAX_ELEMENTS {
                    return Err(MeshError::TooManyElements {
                        path: path(),
                        element: el.to_string(),
                        declared: n,
                        max: MAX_ELEMENTS,
                    });
                }
                elements.push((el.to_string(), n, 0));
            }
            ["property", "list", count_type, _, _] => {
                if let Some(e) = elements.last_mut() {
                    e.2 += scalar_bytes(count_type).unwrap_or(1);
                }
            }
            ["property", t, _] => {
                if let Some(e) = elements.last_mut() {
                    e.2 += scalar_bytes(t).unwrap_or(1);
                }
            }
            _ => {}
        }
    }
    let mut need = 0u64;
    for (el, n, size) in &elements {
        let per = if ascii { 2 } else { (*size).max(1) };
        need = need.saturating_add(n.saturating_mul(per));
        if need > body {
            return Err(MeshError::ShortBody {
                path: path(),
                element: el.clone(),
                declared: *n,
                body,
            });
        }
    }
    // The parser keeps each element as a map of named properties (~100 bytes a value).
    let values: u64 = elements
        .iter()
        .map(|(_, n, size)| n.saturating_mul((*size).max(1)))
        .fold(0, u64::saturating_add);
    budget(name, values.saturating_mul(100))
}

fn budget(name: &str, need: u64) -> Result<(), MeshError> {
    crate::budget::check(|| "reading the mesh".to_string(), need).map_err(|source| {
        MeshError::OverBudget {
            path: name.into(),
            source,
        }
    })
}

/// Parses a PLY file: `vertex` elements with `x`, `y`, `z`, `face` elements with a
/// `vertex_indices` (or `vertex_index`) list; other properties are ignored.
pub fn read_ply(bytes: &[u8], name: &str) -> Result<PolygonMesh, MeshError> {
    use ply_rs_bw::ply::Property;
    check_ply_header(bytes, name)?;
    let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let ply = parser
        .read_ply(&mut std::io::Cursor::new(bytes))
        .map_err(|source| MeshError::Ply {
            path: name.into(),
            source,
        })?;
    let path = || name.to_string();
    let scalar = |p: &Property| -> Option<f64> {
        Some(match *p {
            Property::Char(v) => f64::from(v),
            Property::UChar(v) => f64::from(v),
            Property::Short(v) => f64::from(v),
            Property::UShort(v) => f64::from(v),
            Property::Int(v) => f64::from(v),
            Property::UInt(v) => f64::from(v),
            Property::Float(v) => f64::from(v),
            Property::Double(v) => v,
            _ => return None,
        })
    };
    let mut mesh = PolygonMesh::default();
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| MeshError::NoVertices { path: path() })?;
    for (i, v) in vertices.iter().enumerate() {
        let mut p = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
            p[k] = v
                .get(axis)
                .and_then(scalar)
                .ok_or_else(|| MeshError::NoCoordinate {
                    path: path(),
                    vertex: i,
                    axis,
                })?;
        }
        mesh.positions.push(p);
    }
    let count = mesh.positions.len();
    let faces = ply.payload.get("face").map(Vec::as_slice).unwrap_or(&[]);
    for (f, face) in faces.iter().enumerate() {
        let list = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
            .ok_or_else(|| MeshError::NoIndexList {
                path: path(),
                face: f,
            })?;
        let idx: Vec<i64> = match list {
            Property::ListChar(l) => l.iter().map(|&v| i64::from(v)).collect(),
            Property::ListUChar(l) => l.iter().map(|&v| i64::from(v)).collect(),
            Property::ListShort(l) => l.iter().map(|&v| i64::from(v)).collect(),
            Property::ListUShort(l) => l.iter().map(|&v| i64::from(v)).collect(),
            Property::ListInt(l) => l.iter().map(|&v| i64::from(v)).collect(),
            Property::ListUInt(l) => l.iter().map(|&v| i64::from(v)).collect(),
            _ => {
                return Err(MeshError::IndicesNotIntegers {
                    path: path(),
                    face: f,
                })
            }
        };
        if let Some(&bad) = idx.iter().find(|&&i| i < 0 || i as usize >= count) {
            return Err(MeshError::BadIndex {
                path: name.into(),
                face: f,
                index: bad,
                vertices: count,
            });
        }
        // A polygon becomes a fan around its first corner.
        for k in 1..idx.len().saturating_sub(1) {
            mesh.triangles
                .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
        }
    }
    finish(mesh, name)
}

/// Rejects non-finite coordinates and empty or degenerate meshes; drops triangles
/// with a repeated corner (they carry no surface).
fn finish(mut mesh: PolygonMesh, name: &str) -> Result<PolygonMesh, MeshError> {
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
    let area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            norm(cross(sub(b, a), sub(c, a))) / 2.0
        })
        .sum();
    if area <= 1e-12 * diagonal2 {
        return Err(MeshError::NoArea {
            path: name.into(),
            triangles: mesh.triangles.len(),
        });
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_quads_become_two_triangles_and_bad_input_is_refused() {
        let quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let m = read_obj(quad, "q.obj").unwrap();
        assert_eq!(m.triangles.len(), 2);
        assert!(matches!(
            read_obj(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n", "b.obj"),
            Err(MeshError::Obj { .. } | MeshError::BadIndex { .. })
        ));
        assert!(matches!(
            read_obj(b"v 0 0 nan\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", "n.obj"),
            Err(MeshError::NonFinite { vertex: 0, .. })
        ));
        assert!(matches!(
            read_obj(b"v 0 0 0\n", "e.obj"),
            Err(MeshError::NoTriangles { .. })
        ));
    }

    #[test]
    fn ply_ascii_and_binary_read_the_same_mesh() {
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float confidence\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n";
        let a = read_ply(ascii, "a.ply").unwrap();
        let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
            for v in p {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        bin.push(3);
        for i in [0i32, 1, 2] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let b = read_ply(&bin, "b.ply").unwrap();
        assert_eq!(a, b);
        assert_eq!(a.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn a_ply_header_cannot_declare_more_than_the_file_holds() {
        let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
        assert!(matches!(
            read_ply(huge, "h.ply"),
            Err(MeshError::TooManyElements {
                declared: 4_000_000_000,
                ..
            })
        ));
        let bad = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
        assert!(matches!(
            read_ply(bad, "i.ply"),
            Err(MeshError::BadIndex { index: 7, .. })
        ));
    }
}
