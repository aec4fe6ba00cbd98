//! Mesh files: Wavefront OBJ (with normals, texture coordinates and an optional
//! material library), binary little-endian PLY and binary STL.

use std::io::{self, Write};

use caoen_geometry::mesh::Mesh;

/// Writes `mesh` as OBJ. With `material = Some((mtl_file, name))` the OBJ references the
/// material library and uses the named material.
pub fn write_obj(
    mesh: &Mesh,
    out: &mut impl Write,
    material: Option<(&str, &str)>,
) -> io::Result<()> {
    writeln!(
        out,
        "# caoen surface mesh: {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    if let Some((lib, _)) = material {
        writeln!(out, "mtllib {lib}")?;
    }
    for p in &mesh.positions {
        writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for n in &mesh.normals {
        writeln!(out, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    for uvs in &mesh.corner_uvs {
        for uv in uvs {
            // OBJ's v axis points up the image; ours points down it.
            writeln!(out, "vt {} {}", uv[0], 1.0 - uv[1])?;
        }
    }
    if let Some((_, name)) = material {
        writeln!(out, "usemtl {name}")?;
    }
    if mesh.corner_uvs.is_empty() {
        // No texture coordinates: faces name positions and normals only.
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| v + 1);
            writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        return Ok(());
    }
    for (i, t) in mesh.triangles.iter().enumerate() {
        let vt = 3 * i + 1;
        writeln!(
            out,
            "f {}/{}/{} {}/{}/{} {}/{}/{}",
            t[0] + 1,
            vt,
            t[0] + 1,
            t[1] + 1,
            vt + 1,
            t[1] + 1,
            t[2] + 1,
            vt + 2,
            t[2] + 1
        )?;
    }
    Ok(())
}

/// Writes a material library with one diffuse-textured material.
pub fn write_mtl(out: &mut impl Write, name: &str, texture_file: &str) -> io::Result<()> {
    writeln!(
        out,
        "newmtl {name}\nKa 0.1 0.1 0.1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\nmap_Kd {texture_file}"
    )
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
        let n = caoen_geometry::vector::cross(
            caoen_geometry::vector::sub(b, a),
            caoen_geometry::vector::sub(c, a),
        );
        let len = caoen_geometry::vector::norm(n);
        let n = if len > 0.0 {
            n.map(|v| v / len)
        } else {
            [0.0; 3]
        };
        for v in n.iter().chain(&a).chain(&b).chain(&c) {
            buf.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        buf.extend_from_slice(&0u16.to_le_bytes());
    }
    out.write_all(&buf)
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
