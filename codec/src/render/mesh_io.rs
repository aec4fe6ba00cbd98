//! Mesh files: Wavefront OBJ (with normals, texture coordinates and an optional
//! material library) and binary little-endian PLY.

use std::io::{self, Write};

use crate::geometry::mesh::Mesh;

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
