//! STL: binary and ASCII written from a triangle mesh, binary read back (corners with
//! the same coordinates joined).

use std::io::{self, Write};

use crate::mesh::Mesh;
use crate::vector::{cross, normalise, sub};

/// Writes `mesh` as binary STL: an 80-byte header, the triangle count, and per triangle
/// its unit normal (from the winding) and three corners as 32-bit floats.
pub fn write_stl(mesh: &Mesh, out: &mut impl Write) -> io::Result<()> {
    let count = u32::try_from(mesh.triangles.len())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "too many triangles for STL"))?;
    let mut header = [b' '; 80];
    let tag = b"caoen binary STL";
    header[..tag.len()].copy_from_slice(tag);
    let mut buf = Vec::with_capacity(84 + 50 * mesh.triangles.len());
    buf.extend_from_slice(&header);
    buf.extend_from_slice(&count.to_le_bytes());
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = normalise(cross(sub(b, a), sub(c, a)));
        for v in n.iter().chain(&a).chain(&b).chain(&c) {
            buf.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        buf.extend_from_slice(&0u16.to_le_bytes());
    }
    out.write_all(&buf)
}

/// Writes `mesh` as ASCII STL: `solid caoen`, per triangle its unit normal and three
/// corners, each number as the 32-bit float binary STL holds (shortest round-trip form).
pub fn write_stl_ascii(mesh: &Mesh, out: &mut impl Write) -> io::Result<()> {
    use std::fmt::Write as _;
    let mut text = String::with_capacity(64 + 260 * mesh.triangles.len());
    text.push_str("solid caoen\n");
    let v3 = |text: &mut String, v: [f64; 3]| {
        let [x, y, z] = v.map(|c| c as f32);
        let _ = write!(text, " {x:e} {y:e} {z:e}");
    };
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        text.push_str("  facet normal");
        v3(&mut text, normalise(cross(sub(b, a), sub(c, a))));
        text.push_str("\n    outer loop\n");
        for p in [a, b, c] {
            text.push_str("      vertex");
            v3(&mut text, p);
            text.push('\n');
        }
        text.push_str("    endloop\n  endfacet\n");
    }
    text.push_str("endsolid caoen\n");
    out.write_all(text.as_bytes())
}

/// Reads a binary STL: corners with the same 32-bit coordinates become one vertex
/// (normals from the triangles' windings, averaged). Errors on a short or inconsistent
/// file.
pub fn read_stl(bytes: &[u8]) -> io::Result<Mesh> {
    let bad = |m: &str| io::Error::new(io::ErrorKind::InvalidData, m.to_string());
    if bytes.len() < 84 {
        return Err(bad("shorter than the 84-byte STL header"));
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    if (bytes.len() - 84) / 50 != count || !(bytes.len() - 84).is_multiple_of(50) {
        return Err(bad("the triangle count does not match the file's length"));
    }
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut mesh = Mesh::default();
    for t in 0..count {
        let base = 84 + 50 * t + 12;
        let tri = [0, 1, 2].map(|k| {
            let p = [0, 1, 2].map(|d| f(base + 12 * k + 4 * d));
            *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                mesh.positions.push(p.map(f64::from));
                mesh.normals.push([0.0; 3]);
                (mesh.positions.len() - 1) as u32
            })
        });
        mesh.triangles.push(tri);
    }
    Ok(mesh)
}
