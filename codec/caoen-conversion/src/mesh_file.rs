//! Reading polygon meshes: Wavefront OBJ (through `tobj`), PLY, ASCII or binary, and
//! OFF (both read here, strictly). Counts a PLY or OFF header declares are checked
//! against the bytes that follow it and against the memory budget before the parser
//! allocates anything.

use std::path::Path;

use thiserror::Error;

use super::polygon_mesh::PolygonMesh;
use caoen_geometry::vector::{cross, norm, sub};

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
    /// A PLY header line that is not understood.
    #[error("{path}: not a valid PLY file: header line {line}: `{text}`")]
    BadHeaderLine {
        /// The file.
        path: String,
        /// The line (from 1).
        line: usize,
        /// The line as written (control characters replaced).
        text: String,
    },
    /// A PLY element ends before all its declared values are read.
    #[error("{path}: not a valid PLY file: {element} {index} is cut short (property `{property}` missing)")]
    MissingValues {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// The first property without a value.
        property: String,
    },
    /// An ASCII PLY element line carries more numbers than its properties take.
    #[error("{path}: not a valid PLY file: {element} {index} has {extra} more numbers than its properties take")]
    ExtraValues {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// How many numbers are left over.
        extra: usize,
    },
    /// A PLY value that is not a number of its declared type.
    #[error("{path}: not a valid PLY file: {element} {index}: `{token}` is not a {ty}")]
    BadValue {
        /// The file.
        path: String,
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
    #[error("{path}: not a valid PLY file: {element} {index}: list length {length}")]
    BadListLength {
        /// The file.
        path: String,
        /// The element's name.
        element: String,
        /// The element (from 0).
        index: u64,
        /// The length as read.
        length: f64,
    },
    /// Data after the last element the header declares: the header lies about a count.
    #[error(
        "{path}: not a valid PLY file: {bytes} bytes after the {declared} elements the \
         header declares (a count that is too small?)"
    )]
    TrailingData {
        /// The file.
        path: String,
        /// Bytes left over.
        bytes: u64,
        /// Elements declared, all kinds together.
        declared: u64,
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
    /// An OFF file that breaks the format: what is wrong, on which line.
    #[error("{path}: not a valid OFF file: line {line}: {what}")]
    BadOff {
        /// The file.
        path: String,
        /// The line (from 1).
        line: usize,
        /// What is wrong there.
        what: String,
    },
    /// The file's name does not say OBJ, PLY or OFF.
    #[error("{path}: unknown mesh format (expected a name ending in .obj, .ply or .off)")]
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
    /// A vertex too far from the origin for a converted model's frame.
    #[error(
        "{path}: vertex {vertex} has coordinate {value:e}; a mesh to convert must lie \
         within +-{max:e} (scale it down first)"
    )]
    OutsideWorld {
        /// The file.
        path: String,
        /// The vertex (from 0).
        vertex: usize,
        /// The coordinate.
        value: f64,
        /// The largest coordinate magnitude allowed.
        max: f64,
    },
    /// A mesh whose box is too small for a converted model's frame.
    #[error(
        "{path}: the mesh is {extent:e} across; a mesh to convert must be at least \
         {min:e} across (scale it up first)"
    )]
    TooSmall {
        /// The file.
        path: String,
        /// The longest side of its box.
        extent: f64,
        /// The smallest allowed.
        min: f64,
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
        source: caoen_base::budget::OverBudget,
    },
}

/// Reads an OBJ, PLY or OFF file (chosen by the extension), within the memory budget.
pub fn read(path: &Path) -> Result<PolygonMesh, MeshError> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let reader: fn(&[u8], &str) -> Result<PolygonMesh, MeshError> = match ext.as_deref() {
        Some("obj") => read_obj,
        Some("ply") => read_ply,
        Some("off") => read_off,
        _ => return Err(MeshError::UnknownFormat { path: name }),
    };
    let bytes = caoen_base::budget::read(path).map_err(|source| MeshError::Io {
        path: name.clone(),
        source,
    })?;
    reader(&bytes, &name)
}

/// Parses an OFF file: the keyword `OFF`, the counts `vertices faces edges` (on the
/// keyword's line or the next), one line `x y z` per vertex, one line `n i_1 ... i_n`
/// per face (polygons become fans; three or four colour numbers may follow the
/// indices). `#` starts a comment. The counts are checked against the bytes that
/// follow and against the budget before anything is allocated; a line with too few or
/// too many numbers, a face naming a missing vertex and anything after the last face
/// are refused.
pub fn read_off(bytes: &[u8], name: &str) -> Result<PolygonMesh, MeshError> {
    let bad = |line: usize, what: String| MeshError::BadOff {
        path: name.into(),
        line,
        what,
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count()
            + 1;
        bad(line, "not text".into())
    })?;
    // Lines with their numbers (from 1), comments and blank lines left out.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("")))
        .filter(|(_, l)| !l.trim().is_empty());
    let (first, head) = lines.next().ok_or_else(|| bad(1, "no `OFF` line".into()))?;
    let mut words = head.split_whitespace();
    if words.next() != Some("OFF") {
        return Err(bad(
            first,
            format!(
                "`{}`: expected `OFF`",
                caoen_surface::json::printable(head.trim())
            ),
        ));
    }
    let mut counts: Vec<&str> = words.collect();
    let mut counts_line = first;
    if counts.is_empty() {
        let (l, c) = lines.next().ok_or_else(|| bad(first, "no counts".into()))?;
        counts = c.split_whitespace().collect();
        counts_line = l;
    }
    let [v, f, _e] = counts[..] else {
        return Err(bad(
            counts_line,
            format!("{} numbers; expected vertices, faces, edges", counts.len()),
        ));
    };
    let count = |t: &str, what: &str| -> Result<u64, MeshError> {
        let n: u64 = t.parse().map_err(|_| {
            bad(
                counts_line,
                format!("{what} count `{}`", caoen_surface::json::printable(t)),
            )
        })?;
        if n > MAX_ELEMENTS {
            return Err(MeshError::TooManyElements {
                path: name.into(),
                element: what.into(),
                declared: n,
                max: MAX_ELEMENTS,
            });
        }
        Ok(n)
    };
    let (vertices, faces) = (count(v, "vertex")?, count(f, "face")?);
    // A vertex line takes at least 6 bytes (`0 0 0\n`), a face line 8 (`3 0 1 2\n`
    // less one separator); the mesh made is at most 24 bytes a vertex and 12 a
    // triangle, with fans of a polygon as many triangles as its line has numbers.
    let body = bytes.len() as u64;
    for (element, declared, need) in [
        ("vertex", vertices, vertices.saturating_mul(6)),
        (
            "face",
            faces,
            vertices
                .saturating_mul(6)
                .saturating_add(faces.saturating_mul(7)),
        ),
    ] {
        if need > body {
            return Err(MeshError::ShortBody {
                path: name.into(),
                element: element.into(),
                declared,
                body,
            });
        }
    }
    budget(name, vertices * 24 + body * 12)?;
    let mut mesh = PolygonMesh {
        positions: Vec::with_capacity(vertices as usize),
        triangles: Vec::with_capacity(faces as usize),
    };
    let mut last = counts_line;
    for index in 0..vertices {
        let (l, line) = lines.next().ok_or_else(|| {
            bad(
                last + 1,
                format!("vertex {index} missing ({vertices} declared)"),
            )
        })?;
        last = l;
        let nums: Vec<&str> = line.split_whitespace().collect();
        if nums.len() != 3 {
            return Err(bad(
                l,
                format!("vertex {index} has {} numbers; expected 3", nums.len()),
            ));
        }
        let mut p = [0.0; 3];
        for (k, t) in nums.iter().enumerate() {
            p[k] = t.parse().map_err(|_| {
                bad(
                    l,
                    format!(
                        "vertex {index}: `{}` is not a number",
                        caoen_surface::json::printable(t)
                    ),
                )
            })?;
        }
        mesh.positions.push(p);
    }
    for face in 0..faces as usize {
        let (l, line) = lines
            .next()
            .ok_or_else(|| bad(last + 1, format!("face {face} missing ({faces} declared)")))?;
        last = l;
        let nums: Vec<&str> = line.split_whitespace().collect();
        let n: usize = nums
            .first()
            .and_then(|t| t.parse().ok())
            .filter(|n| (3..=nums.len() - 1).contains(n))
            .ok_or_else(|| {
                bad(
                    l,
                    format!(
                        "face {face}: `{}` is not a polygon of 3 or more listed vertices",
                        caoen_surface::json::printable(line.trim())
                    ),
                )
            })?;
        let colour = nums.len() - 1 - n;
        if ![0, 3, 4].contains(&colour) {
            return Err(bad(l, format!("face {face} has {colour} numbers after its {n} indices; expected none or a colour of 3 or 4")));
        }
        let mut idx = Vec::with_capacity(n);
        for t in &nums[1..=n] {
            let i: i64 = t.parse().map_err(|_| {
                bad(
                    l,
                    format!(
                        "face {face}: `{}` is not a vertex index",
                        caoen_surface::json::printable(t)
                    ),
                )
            })?;
            if i < 0 || i as u64 >= vertices {
                return Err(MeshError::BadIndex {
                    path: name.into(),
                    face,
                    index: i,
                    vertices: vertices as usize,
                });
            }
            idx.push(i as u32);
        }
        for k in 1..n - 1 {
            mesh.triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    if let Some((l, _)) = lines.next() {
        return Err(bad(
            l,
            format!(
                "data after the {faces} faces the header declares (a count that is too small?)"
            ),
        ));
    }
    finish(mesh, name)
}

/// Parses OBJ text; polygons become triangle fans, every object joins one mesh.
pub fn read_obj(bytes: &[u8], name: &str) -> Result<PolygonMesh, MeshError> {
    // tobj keeps positions, indices and its own bookkeeping: a few times the text; and
    // the text once more, cut to position indices.
    budget(name, bytes.len() as u64 * 7)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let text = position_indices_only(bytes);
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(text), &opts, |_| {
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

/// The OBJ text with every face corner cut to its position index (`7/3/2` becomes `7`):
/// caoen reads neither texture coordinates nor normals, and tobj's arithmetic on their
/// indices overflows on huge ones.
fn position_indices_only(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    let mut cut = false;
    for &b in bytes {
        if b.is_ascii_whitespace() {
            cut = false;
        } else if b == b'/' {
            cut = true;
        }
        if !cut {
            out.push(b);
        }
    }
    out
}

/// A PLY scalar type: its name in messages and its size in a binary file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(t: &str) -> Option<Scalar> {
        Some(match t {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn bytes(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// One binary value; `big` for big-endian files.
    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("sized by the caller");
                if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(get!(i16, 2)),
            Scalar::U16 => f64::from(get!(u16, 2)),
            Scalar::I32 => f64::from(get!(i32, 4)),
            Scalar::U32 => f64::from(get!(u32, 4)),
            Scalar::F32 => f64::from(get!(f32, 4)),
            Scalar::F64 => get!(f64, 8),
        }
    }

    /// One ASCII value, `None` when the token is not of this type.
    fn parse_token(self, t: &str) -> Option<f64> {
        if self.is_integer() {
            let v: i64 = t.parse().ok()?;
            let (lo, hi) = match self {
                Scalar::I8 => (i64::from(i8::MIN), i64::from(i8::MAX)),
                Scalar::U8 => (0, i64::from(u8::MAX)),
                Scalar::I16 => (i64::from(i16::MIN), i64::from(i16::MAX)),
                Scalar::U16 => (0, i64::from(u16::MAX)),
                Scalar::I32 => (i64::from(i32::MIN), i64::from(i32::MAX)),
                _ => (0, i64::from(u32::MAX)),
            };
            (lo..=hi).contains(&v).then_some(v as f64)
        } else {
            t.parse().ok()
        }
    }
}

/// A property of a PLY element: a scalar, or a list (count type, item type).
#[derive(Debug, Clone)]
struct PlyProperty {
    name: String,
    count: Option<Scalar>,
    item: Scalar,
}

/// A PLY element as its header declares it.
#[derive(Debug, Clone)]
struct PlyElement {
    name: String,
    count: u64,
    properties: Vec<PlyProperty>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PlyFormat {
    Ascii,
    Little,
    Big,
}

/// Parses a PLY header; returns the format, the elements and the offset of the body.
fn ply_header(bytes: &[u8], name: &str) -> Result<(PlyFormat, Vec<PlyElement>, usize), MeshError> {
    let path = || name.to_string();
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or_else(|| MeshError::NoEndHeader { path: path() })?;
    // The body starts after the line break that ends `end_header` (LF or CR LF).
    let mut body = end + 10;
    if bytes.get(body) == Some(&b'\r') {
        body += 1;
    }
    if bytes.get(body) == Some(&b'\n') {
        body += 1;
    }
    let header = std::str::from_utf8(&bytes[..end])
        .map_err(|_| MeshError::HeaderNotText { path: path() })?;
    let mut format = None;
    let mut elements: Vec<PlyElement> = Vec::new();
    for (i, line) in header.lines().enumerate() {
        let bad = || MeshError::BadHeaderLine {
            path: path(),
            line: i + 1,
            text: caoen_surface::json::printable(line),
        };
        let w: Vec<&str> = line.split_whitespace().collect();
        // Names and counts from the header reach the messages: no control characters
        // (comments are not read).
        if !matches!(w.first(), Some(&"comment" | &"obj_info"))
            && line.chars().any(|c| c.is_control() && !c.is_whitespace())
        {
            return Err(bad());
        }
        match w.as_slice() {
            ["ply"] | [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, "1.0"] => {
                format = Some(match *f {
                    "ascii" => PlyFormat::Ascii,
                    "binary_little_endian" => PlyFormat::Little,
                    "binary_big_endian" => PlyFormat::Big,
                    _ => return Err(bad()),
                })
            }
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
                elements.push(PlyElement {
                    name: el.to_string(),
                    count: n,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count_type, item_type, prop] => {
                let (Some(c), Some(t), Some(e)) = (
                    Scalar::parse(count_type),
                    Scalar::parse(item_type),
                    elements.last_mut(),
                ) else {
                    return Err(bad());
                };
                if !c.is_integer() {
                    return Err(bad());
                }
                e.properties.push(PlyProperty {
                    name: prop.to_string(),
                    count: Some(c),
                    item: t,
                });
            }
            ["property", t, prop] => {
                let (Some(t), Some(e)) = (Scalar::parse(t), elements.last_mut()) else {
                    return Err(bad());
                };
                e.properties.push(PlyProperty {
                    name: prop.to_string(),
                    count: None,
                    item: t,
                });
            }
            _ => return Err(bad()),
        }
    }
    let Some(format) = format else {
        return Err(MeshError::BadHeaderLine {
            path: path(),
            line: 2,
            text: "(no `format` line)".into(),
        });
    };
    Ok((format, elements, body.min(bytes.len())))
}

/// Checks the counts a PLY header declares against the bytes after it (each element
/// takes at least its scalars' bytes, or two characters in ASCII, so a short file
/// cannot declare billions of elements) and the mesh it can make against the budget.
fn check_ply_counts(
    elements: &[PlyElement],
    ascii: bool,
    body: u64,
    name: &str,
) -> Result<(), MeshError> {
    let mut need = 0u64;
    for el in elements {
        let size: u64 = el
            .properties
            .iter()
            .map(|p| p.count.unwrap_or(p.item).bytes() as u64)
            .sum();
        let per = if ascii { 2 } else { size.max(1) };
        need = need.saturating_add(el.count.saturating_mul(per));
        if need > body {
            return Err(MeshError::ShortBody {
                path: name.into(),
                element: el.name.clone(),
                declared: el.count,
                body,
            });
        }
    }
    // The mesh made from the body: a vertex is 24 bytes from at least 3 body bytes, a
    // triangle 12 bytes from at least one (a one-byte index in a strip), so at most 12
    // bytes a body byte, plus the tables of the elements kept.
    budget(name, body.saturating_mul(12))
}

fn budget(name: &str, need: u64) -> Result<(), MeshError> {
    caoen_base::budget::check(|| "reading the mesh".to_string(), need).map_err(|source| {
        MeshError::OverBudget {
            path: name.into(),
            source,
        }
    })
}

/// Where a PLY element's values go.
enum Sink {
    Vertex { x: usize, y: usize, z: usize },
    Faces { list: usize },
    Strips { list: usize },
    Skip,
}

/// Parses a PLY file: `vertex` elements with `x`, `y`, `z`, `face` elements with a
/// `vertex_indices` (or `vertex_index`) list (polygons become fans), `tristrips`
/// elements with a `vertex_indices` list (triangle strips, -1 restarts a strip); other
/// elements and properties are read and ignored. The file must hold exactly what its
/// header declares: a short element, extra numbers on an ASCII line or data after the
/// last element are refused.
pub fn read_ply(bytes: &[u8], name: &str) -> Result<PolygonMesh, MeshError> {
    let path = || name.to_string();
    let (format, elements, start) = ply_header(bytes, name)?;
    let body = &bytes[start..];
    check_ply_counts(
        &elements,
        format == PlyFormat::Ascii,
        body.len() as u64,
        name,
    )?;
    let mut mesh = PolygonMesh::default();
    // Faces are checked against the vertex count once every element is read (a file
    // may declare faces first).
    let mut faces: Vec<(u64, Vec<i64>)> = Vec::new();
    let mut strips: Vec<(u64, Vec<i64>)> = Vec::new();
    let mut reader = PlyReader {
        body,
        pos: 0,
        format,
        name,
    };
    let mut saw_vertices = false;
    for el in &elements {
        let find = |names: &[&str]| {
            el.properties
                .iter()
                .position(|p| names.contains(&p.name.as_str()))
        };
        let sink = match el.name.as_str() {
            "vertex" => {
                saw_vertices = true;
                let axis = |a: &'static str| {
                    find(&[a])
                        .filter(|&i| el.properties[i].count.is_none())
                        .ok_or(MeshError::NoCoordinate {
                            path: path(),
                            vertex: 0,
                            axis: a,
                        })
                };
                if el.count == 0 {
                    Sink::Skip
                } else {
                    Sink::Vertex {
                        x: axis("x")?,
                        y: axis("y")?,
                        z: axis("z")?,
                    }
                }
            }
            "face" | "tristrips" => {
                let list = find(&["vertex_indices", "vertex_index"]);
                let list = match list {
                    Some(i) if el.properties[i].count.is_some() => i,
                    _ if el.count == 0 => usize::MAX,
                    _ => {
                        return Err(MeshError::NoIndexList {
                            path: path(),
                            face: 0,
                        })
                    }
                };
                if !el.properties.get(list).is_none_or(|p| p.item.is_integer()) {
                    return Err(MeshError::IndicesNotIntegers {
                        path: path(),
                        face: 0,
                    });
                }
                if el.name == "face" {
                    Sink::Faces { list }
                } else {
                    Sink::Strips { list }
                }
            }
            _ => Sink::Skip,
        };
        let mut values: Vec<Vec<f64>> = vec![Vec::new(); el.properties.len()];
        for index in 0..el.count {
            reader.element(el, index, &mut values)?;
            match sink {
                Sink::Vertex { x, y, z } => {
                    mesh.positions
                        .push([values[x][0], values[y][0], values[z][0]]);
                }
                Sink::Faces { list } => {
                    faces.push((index, values[list].iter().map(|&v| v as i64).collect()));
                }
                Sink::Strips { list } => {
                    strips.push((index, values[list].iter().map(|&v| v as i64).collect()));
                }
                Sink::Skip => {}
            }
        }
    }
    reader.finish(elements.iter().map(|e| e.count).sum())?;
    if !saw_vertices {
        return Err(MeshError::NoVertices { path: path() });
    }
    let count = mesh.positions.len();
    let check = |face: u64, i: i64| {
        if i < 0 || i as usize >= count {
            Err(MeshError::BadIndex {
                path: path(),
                face: face as usize,
                index: i,
                vertices: count,
            })
        } else {
            Ok(i as u32)
        }
    };
    for (f, idx) in &faces {
        for &i in idx {
            check(*f, i)?;
        }
        // A polygon becomes a fan around its first corner.
        for k in 1..idx.len().saturating_sub(1) {
            mesh.triangles
                .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
        }
    }
    for (f, idx) in &strips {
        // Each run between -1 markers is a strip; every other triangle is turned
        // around so all keep the first one's winding.
        for run in idx.split(|&i| i == -1) {
            for &i in run {
                check(*f, i)?;
            }
            for k in 0..run.len().saturating_sub(2) {
                let (a, b, c) = (run[k] as u32, run[k + 1] as u32, run[k + 2] as u32);
                mesh.triangles
                    .push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
            }
        }
    }
    finish(mesh, name)
}

/// Reads a PLY body element by element.
struct PlyReader<'a> {
    body: &'a [u8],
    pos: usize,
    format: PlyFormat,
    name: &'a str,
}

impl PlyReader<'_> {
    /// Reads element `index` of `el` into `values` (one list per property).
    fn element(
        &mut self,
        el: &PlyElement,
        index: u64,
        values: &mut [Vec<f64>],
    ) -> Result<(), MeshError> {
        if self.format == PlyFormat::Ascii {
            return self.ascii_element(el, index, values);
        }
        let big = self.format == PlyFormat::Big;
        for (p, out) in el.properties.iter().zip(values.iter_mut()) {
            out.clear();
            let missing = || MeshError::MissingValues {
                path: self.name.into(),
                element: el.name.clone(),
                index,
                property: p.name.clone(),
            };
            let n = match p.count {
                None => 1,
                Some(c) => {
                    let b = self
                        .body
                        .get(self.pos..self.pos + c.bytes())
                        .ok_or_else(missing)?;
                    self.pos += c.bytes();
                    let n = c.read(b, big);
                    self.list_length(el, index, n, p.item.bytes())?
                }
            };
            let size = p.item.bytes();
            let b = self
                .body
                .get(self.pos..self.pos + n * size)
                .ok_or_else(missing)?;
            self.pos += n * size;
            out.extend(b.chunks_exact(size).map(|v| p.item.read(v, big)));
        }
        Ok(())
    }

    /// A list length as read, checked against the bytes left (at least `min` each).
    fn list_length(
        &self,
        el: &PlyElement,
        index: u64,
        n: f64,
        min: usize,
    ) -> Result<usize, MeshError> {
        let left = (self.body.len() - self.pos) as f64;
        if !(n >= 0.0 && n * min as f64 <= left) {
            return Err(MeshError::BadListLength {
                path: self.name.into(),
                element: el.name.clone(),
                index,
                length: n,
            });
        }
        Ok(n as usize)
    }

    /// One ASCII element: one line, every number used.
    fn ascii_element(
        &mut self,
        el: &PlyElement,
        index: u64,
        values: &mut [Vec<f64>],
    ) -> Result<(), MeshError> {
        // Blank lines between elements carry nothing.
        let line = loop {
            let rest = &self.body[self.pos..];
            let len = rest
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |n| n + 1);
            let line = &rest[..len];
            self.pos += len;
            if len == 0 || !line.iter().all(u8::is_ascii_whitespace) {
                break line;
            }
        };
        let line = String::from_utf8_lossy(line);
        let mut tokens = line.split_ascii_whitespace();
        for (p, out) in el.properties.iter().zip(values.iter_mut()) {
            out.clear();
            let mut next = |ty: Scalar| -> Result<f64, MeshError> {
                let t = tokens.next().ok_or_else(|| MeshError::MissingValues {
                    path: self.name.into(),
                    element: el.name.clone(),
                    index,
                    property: p.name.clone(),
                })?;
                ty.parse_token(t).ok_or_else(|| MeshError::BadValue {
                    path: self.name.into(),
                    element: el.name.clone(),
                    index,
                    token: caoen_surface::json::printable(&t.chars().take(40).collect::<String>()),
                    ty: ty.name(),
                })
            };
            let n = match p.count {
                None => 1,
                Some(c) => {
                    let n = next(c)?;
                    // Each item takes at least two characters of what is left.
                    let left = (self.body.len() - self.pos + line.len()) as f64;
                    if !(n >= 0.0 && 2.0 * n <= left) {
                        return Err(MeshError::BadListLength {
                            path: self.name.into(),
                            element: el.name.clone(),
                            index,
                            length: n,
                        });
                    }
                    n as usize
                }
            };
            for _ in 0..n {
                let v = next(p.item)?;
                out.push(v);
            }
        }
        let extra = tokens.count();
        if extra > 0 {
            return Err(MeshError::ExtraValues {
                path: self.name.into(),
                element: el.name.clone(),
                index,
                extra,
            });
        }
        Ok(())
    }

    /// Refuses anything after the last element (whitespace only in ASCII).
    fn finish(&self, declared: u64) -> Result<(), MeshError> {
        let rest = &self.body[self.pos..];
        let left = if self.format == PlyFormat::Ascii {
            rest.iter().filter(|b| !b.is_ascii_whitespace()).count()
        } else {
            rest.len()
        };
        if left > 0 {
            return Err(MeshError::TrailingData {
                path: self.name.into(),
                bytes: rest.len() as u64,
                declared,
            });
        }
        Ok(())
    }
}

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
    fn off_polygons_become_fans_and_bad_lines_are_refused() {
        let quad = b"OFF # a square\n4 1 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n4 0 1 2 3 255 0 0\n";
        let m = read_off(quad, "q.off").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let same_line = read_off(b"OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "s.off").unwrap();
        assert_eq!(same_line.triangles.len(), 1);
        for (text, words) in [
            (
                &b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0 7\n3 0 1 2\n"[..],
                "line 5: vertex 2 has 4 numbers",
            ),
            (
                b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 5\n",
                "1 numbers after its 3 indices",
            ),
            (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "not a polygon"),
            (
                b"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                "face 1 missing",
            ),
            (
                b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 x\n3 0 1 2\n",
                "`x` is not a number",
            ),
            (
                b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
                "uses vertex -1",
            ),
            (b"COFF\n3 1 0\n", "expected `OFF`"),
            (b"OFF\n3 1\n", "2 numbers"),
            (b"OFF\n9999999999 1 0\n", "over the limit"),
        ] {
            let e = read_off(text, "b.off").unwrap_err().to_string();
            assert!(e.contains(words), "{e}");
        }
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
    fn ply_bodies_hold_exactly_what_the_header_declares() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let extra = format!("{head}0 0 0 9\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(
            read_ply(extra.as_bytes(), "e.ply"),
            Err(MeshError::ExtraValues {
                index: 0,
                extra: 1,
                ..
            })
        ));
        let more = format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1 0\n");
        assert!(matches!(
            read_ply(more.as_bytes(), "m.ply"),
            Err(MeshError::TrailingData { declared: 4, .. })
        ));
        let short = format!("{head}0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(
            read_ply(short.as_bytes(), "s.ply"),
            Err(MeshError::MissingValues { index: 1, .. })
        ));
        let word = format!("{head}0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n");
        assert!(matches!(
            read_ply(word.as_bytes(), "w.ply"),
            Err(MeshError::BadValue { index: 1, .. })
        ));
    }

    #[test]
    fn binary_triangle_strips_restart_at_minus_one_and_keep_the_winding() {
        let mut bin = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n".to_vec();
        for p in [[0.0f64, 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]] {
            for v in p {
                bin.extend_from_slice(&v.to_be_bytes());
            }
        }
        let strip = [1i32, 0, 2, 3, -1, 3, 0, 1, -1, 1, 2, 3];
        bin.extend_from_slice(&(strip.len() as i32).to_be_bytes());
        for i in strip {
            bin.extend_from_slice(&i.to_be_bytes());
        }
        let m = read_ply(&bin, "t.ply").unwrap();
        assert_eq!(
            m.triangles,
            vec![[1, 0, 2], [2, 0, 3], [3, 0, 1], [1, 2, 3]]
        );
        assert!(m.topology().is_closed());
        // One byte too many is a header that lies.
        bin.push(0);
        assert!(matches!(
            read_ply(&bin, "t.ply"),
            Err(MeshError::TrailingData { bytes: 1, .. })
        ));
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
