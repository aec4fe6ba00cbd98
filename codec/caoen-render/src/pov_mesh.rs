//! A Cao En surface as POV-Ray's `mesh2`: its tessellation one level finer than the
//! mesh `render::rays` starts its crossings from, each vertex with the network's exact
//! normal (so POV-Ray's smooth shading interpolates the normals caoen shades with),
//! and its texture on the domain as an `image_map` under `uv_mapping` with the
//! tessellation's per-corner texture coordinates (so the seam and the poles keep their
//! own corners).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use super::renderer::place_mesh;
use super::shading::Material;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::transform::Affine;
use caoen_surface::tessellate::{tessellate, NormalMode};
use caoen_surface::SurfaceModel;

/// The tessellation level of `detail` (a scene object's own, else caoen's default of
/// 5 for its ray hierarchy), one finer, from 6 up to the largest, 9.
pub fn export_detail(detail: Option<u32>) -> u32 {
    (detail.unwrap_or(5) + 1).clamp(6, 9)
}

/// Writes `model` placed by `place` as a `mesh2` with `material`'s pigment; the object's
/// finish and interior follow in `finish`. An error says what cannot be exported.
pub fn write_mesh2(
    out: &mut String,
    model: &SurfaceModel,
    (place, detail): (&Affine, Option<u32>),
    material: &Material,
    finish: &str,
    limits: &caoen_base::budget::Limits,
) -> Result<(), String> {
    let pigment = surface_pigment(material)?;
    let mut mesh = tessellate(model, export_detail(detail), NormalMode::Exact, limits)
        .map_err(|e| e.to_string())?;
    place_mesh(&mut mesh, place);
    let normals = exact_or_face_normals(&mesh);
    out.push_str("mesh2 {\n  vertex_vectors { ");
    let _ = write!(out, "{}", mesh.positions.len());
    for p in &mesh.positions {
        let _ = write!(out, ",\n    {}", v3f(*p));
    }
    let _ = write!(out, "\n  }}\n  normal_vectors {{ {}", normals.len());
    for n in &normals {
        let _ = write!(out, ",\n    {}", v3f(*n));
    }
    out.push_str("\n  }\n");
    // The corners' texture coordinates, each distinct one once, in first-seen order.
    let textured = material.texture.is_some() && mesh.corner_uvs.len() == mesh.triangles.len();
    let mut uv_index: Vec<[u32; 3]> = Vec::new();
    if textured {
        let mut seen: HashMap<[u32; 2], u32> = HashMap::new();
        let mut uvs: Vec<[f32; 2]> = Vec::new();
        for corners in &mesh.corner_uvs {
            uv_index.push(corners.map(|c| {
                // POV-Ray's v runs up the image, the domain's down.
                let uv = [c[0] as f32, (1.0 - c[1]) as f32];
                *seen.entry(uv.map(f32::to_bits)).or_insert_with(|| {
                    uvs.push(uv);
                    (uvs.len() - 1) as u32
                })
            }));
        }
        let _ = write!(out, "  uv_vectors {{ {}", uvs.len());
        for uv in &uvs {
            let _ = write!(out, ",\n    <{}, {}>", uv[0], uv[1]);
        }
        out.push_str("\n  }\n");
    }
    let _ = write!(out, "  face_indices {{ {}", mesh.triangles.len());
    for t in &mesh.triangles {
        let _ = write!(out, ",\n    <{}, {}, {}>", t[0], t[1], t[2]);
    }
    out.push_str("\n  }\n");
    if textured {
        let _ = write!(out, "  uv_indices {{ {}", uv_index.len());
        for t in &uv_index {
            let _ = write!(out, ",\n    <{}, {}, {}>", t[0], t[1], t[2]);
        }
        out.push_str("\n  }\n");
    }
    if material.transmit > 0.0 {
        // Refraction needs an inside: the sphere's and the torus's meshes are closed.
        out.push_str("  inside_vector <0, 0, 1>\n");
    }
    let _ = writeln!(
        out,
        "  {pigment}{}\n  {finish}\n}}",
        super::pov::normal(material)
    );
    Ok(())
}

/// The pigment of a surface: its domain texture by `uv_mapping` (white-based: a tint
/// has no `image_map` equivalent), a projected image map, or the plain colour.
fn surface_pigment(m: &Material) -> Result<String, String> {
    let Some((tex, _)) = &m.texture else {
        return Ok(super::pov::pigment(m));
    };
    if m.colour != [1.0; 3] {
        return Err(format!(
            "a texture tinted by `colour` {:?} has no POV-Ray image_map equivalent; leave `colour` out",
            m.colour
        ));
    }
    let Some(file) = tex.file() else {
        return Err("its texture was made in memory and has no file to name".into());
    };
    let name = file.display().to_string().replace('\\', "/");
    if name.contains('"') {
        return Err(format!("the texture file name {name} holds a `\"`"));
    }
    let transmit = if m.transmit > 0.0 {
        format!(" transmit all {}", m.transmit)
    } else {
        String::new()
    };
    Ok(format!(
        "pigment {{ uv_mapping image_map {{ {} \"{name}\" map_type 0 interpolate 2{transmit} }} }}",
        super::image_map::pov_format(Path::new(&name))
    ))
}

/// The mesh's normals, each vertex's exact one, or where that is undefined (a singular
/// point of the map) the mean of its triangles' normals, so POV-Ray reads no zero
/// vector.
fn exact_or_face_normals(mesh: &Mesh) -> Vec<[f64; 3]> {
    let len = |n: [f64; 3]| (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let good = |n: [f64; 3]| len(n).is_finite() && len(n) > 1e-12;
    if mesh.normals.iter().all(|n| good(*n)) {
        return mesh.normals.clone();
    }
    let mut sum = vec![[0.0f64; 3]; mesh.positions.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let (u, v) = (
            [0, 1, 2].map(|k| b[k] - a[k]),
            [0, 1, 2].map(|k| c[k] - a[k]),
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        for i in t {
            for k in 0..3 {
                sum[*i as usize][k] += n[k];
            }
        }
    }
    mesh.normals
        .iter()
        .zip(sum)
        .map(|(n, s)| {
            if good(*n) {
                *n
            } else if good(s) {
                s.map(|x| x / len(s))
            } else {
                [0.0, 0.0, 1.0]
            }
        })
        .collect()
}

/// A point or direction in POV-Ray's axes (caoen's y and z swapped) at single
/// precision: a tenth of a millionth of the object's size, far below a pixel, in half
/// the characters of the shortest double.
fn v3f(p: [f64; 3]) -> String {
    let f = |x: f64| if x.is_finite() { x as f32 } else { 0.0 };
    format!("<{}, {}, {}>", f(p[0]), f(p[2]), f(p[1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detail_is_finer_than_the_ray_mesh() {
        assert_eq!(export_detail(None), 6);
        assert_eq!(export_detail(Some(2)), 6);
        assert_eq!(export_detail(Some(6)), 7);
        assert_eq!(export_detail(Some(9)), 9);
    }

    #[test]
    fn mesh2_has_exact_normals_and_corner_uvs() {
        let model = caoen_surface::gallery::blob().unwrap();
        let limits = caoen_base::budget::Limits::default();
        let mut out = String::new();
        let m = Material::default();
        write_mesh2(
            &mut out,
            &model,
            (&Affine::IDENTITY, Some(0)),
            &m,
            "finish { }",
            &limits,
        )
        .unwrap();
        let (v, t) = caoen_surface::tessellate::mesh_size(&model.domain, 6);
        assert!(out.contains(&format!("vertex_vectors {{ {v},")));
        assert!(out.contains(&format!("normal_vectors {{ {v},")));
        assert!(out.contains(&format!("face_indices {{ {t},")));
        // Untextured: no texture coordinates.
        assert!(!out.contains("uv_vectors"));
        // The first normal is the network's exact one at the first vertex.
        let mesh = tessellate(&model, 6, NormalMode::Exact, &limits).unwrap();
        let first = out.split("normal_vectors").nth(1).unwrap();
        assert!(first.contains(&v3f(mesh.normals[0])), "{}", &first[..80]);
    }
}
