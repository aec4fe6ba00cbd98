//! Wavefront OBJ: read through `tobj` (positions and faces), written with normals,
//! texture coordinates and an optional material library.

use std::io::{self, Write};

use caoen_base::budget::Limits;

use super::{budget, finish, MeshError};
use crate::mesh::Mesh;
use crate::polygon_mesh::PolygonMesh;

/// Parses OBJ text; polygons become triangle fans, every object joins one mesh.
pub fn read_obj(bytes: &[u8], name: &str, limits: &Limits) -> Result<PolygonMesh, MeshError> {
    // tobj keeps positions, indices and its own bookkeeping: a few times the text; and
    // the text once more, cut to position indices.
    budget(name, bytes.len() as u64 * 7, limits)?;
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
