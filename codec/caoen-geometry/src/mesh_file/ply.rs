//! PLY: a strict reader of its own (ASCII or binary; faces and triangle strips; the
//! body must hold exactly what the header declares), and the binary little-endian
//! writer.

use std::io::{self, Write};
use std::path::PathBuf;

use caoen_base::budget::Limits;

use super::{budget, finish, MeshError, MAX_ELEMENTS};
use crate::mesh::Mesh;
use crate::polygon_mesh::PolygonMesh;

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
    let path = || PathBuf::from(name);
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
            text: caoen_base::printable(line),
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
    limits: &Limits,
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
    budget(name, body.saturating_mul(12), limits)
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
pub fn read_ply(bytes: &[u8], name: &str, limits: &Limits) -> Result<PolygonMesh, MeshError> {
    let path = || PathBuf::from(name);
    let (format, elements, start) = ply_header(bytes, name)?;
    let body = &bytes[start..];
    check_ply_counts(
        &elements,
        format == PlyFormat::Ascii,
        body.len() as u64,
        name,
        limits,
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
                    token: caoen_base::printable(&t.chars().take(40).collect::<String>()),
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

/// Writes `mesh` as binary little-endian PLY: float positions, normals and per-vertex
/// texture coordinates (`s`, `t`; the first corner seen wins at a seam), int faces.
pub fn write_ply(mesh: &Mesh, out: &mut impl Write) -> io::Result<()> {
    let mut vertex_uv = vec![[0.0f64; 2]; mesh.positions.len()];
    let mut seen = vec![false; mesh.positions.len()];
    for (t, uvs) in mesh.triangles.iter().zip(&mesh.corner_uvs) {
        for k in 0..3 {
            let v = t[k] as usize;
            if !seen[v] {
                seen[v] = true;
                vertex_uv[v] = [uvs[k][0].rem_euclid(1.0), 1.0 - uvs[k][1].rem_euclid(1.0)];
            }
        }
    }
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment caoen surface mesh\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float s\nproperty float t\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    let mut buf = Vec::with_capacity(mesh.positions.len() * 32 + mesh.triangles.len() * 13);
    for ((p, n), uv) in mesh.positions.iter().zip(&mesh.normals).zip(&vertex_uv) {
        for v in p.iter().chain(n).chain(uv) {
            buf.extend_from_slice(&(*v as f32).to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        buf.push(3);
        for &i in t {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out.write_all(&buf)
}
