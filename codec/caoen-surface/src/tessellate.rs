//! Polygon meshes of surfaces: tessellate the domain, map every vertex through the
//! network.
//!
//! The sphere is tessellated as a subdivided icosahedron (no degenerate poles), the
//! torus as a regular wrapped grid. Vertices are shared, so meshes of closed domains
//! are watertight with consistent winding; texture coordinates are stored per
//! triangle corner so that the equirectangular seam does not break that sharing.

use rayon::prelude::*;

use super::normals::{exact_normal, NormalNetwork};
use super::{Domain, SurfaceError, SurfaceModel};
use caoen_geometry::mesh::{icosphere, Mesh};

/// How vertex normals are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalMode {
    /// Exact normals from the Jacobian (formula 12).
    #[default]
    Exact,
    /// Normals interpolated by a second network from the exact key-point normals.
    Interpolated,
}

/// Equirectangular `(u, v)` of a unit-sphere point: `u = theta / 2pi`, `v = phi / pi`.
pub fn sphere_uv(x: &[f64]) -> [f64; 2] {
    use std::f64::consts::{PI, TAU};
    let theta = x[1].atan2(x[0]).rem_euclid(TAU);
    let phi = x[2].clamp(-1.0, 1.0).acos();
    [theta / TAU, phi / PI]
}

/// Corner texture coordinates of a sphere triangle, unwrapped across the seam and with
/// pole corners placed at their neighbours' mean longitude.
fn sphere_corner_uvs(pts: [&[f64]; 3]) -> [[f64; 2]; 3] {
    let mut uv = pts.map(sphere_uv);
    let at_pole = pts.map(|p| p[0].hypot(p[1]) < 1e-12);
    let reference = (0..3).find(|&k| !at_pole[k]).unwrap_or(0);
    for k in 0..3 {
        if !at_pole[k] {
            let d = uv[k][0] - uv[reference][0];
            if d > 0.5 {
                uv[k][0] -= 1.0;
            } else if d < -0.5 {
                uv[k][0] += 1.0;
            }
        }
    }
    let others: Vec<f64> = (0..3).filter(|&k| !at_pole[k]).map(|k| uv[k][0]).collect();
    for k in 0..3 {
        if at_pole[k] && !others.is_empty() {
            uv[k][0] = others.iter().sum::<f64>() / others.len() as f64;
        }
    }
    uv
}

/// Domain points, triangles and per-corner texture coordinates of a tessellation.
type DomainTriangulation = (Vec<Vec<f64>>, Vec<[u32; 3]>, Vec<[[f64; 2]; 3]>);

/// Vertices and triangles of the tessellation of `domain` at `detail`: for the sphere
/// an icosphere (`10 4^d + 2` vertices, `20 4^d` triangles), for the torus a wrapped
/// grid (`32 4^d` cells, two triangles each); none for other domains.
pub fn mesh_size(domain: &Domain, detail: u32) -> (u64, u64) {
    let n = 1u64 << (2 * detail.min(30));
    match domain {
        Domain::Sphere { dim: 3 } => (10 * n + 2, 20 * n),
        Domain::Torus => (32 * n, 64 * n),
        _ => (0, 0),
    }
}

/// Bytes per vertex while a tessellation is made, an upper bound: the domain point
/// (a vector of its own, with the allocator's overhead), its flat copy, the network's
/// output, the position and the normal, and the icosphere's vertex.
const MAKE_VERTEX_BYTES: u64 = 256;

/// Bytes per triangle while a tessellation is made: the corners (twice, with the
/// icosphere's list) and the corners' texture coordinates.
const MAKE_TRIANGLE_BYTES: u64 = 96;

/// Memory `tessellate` allocates for `domain` at `detail`, an upper bound checked
/// against the budget before it starts.
pub fn tessellation_bytes(domain: &Domain, detail: u32) -> u64 {
    let (v, t) = mesh_size(domain, detail);
    v.saturating_mul(MAKE_VERTEX_BYTES)
        .saturating_add(t.saturating_mul(MAKE_TRIANGLE_BYTES))
}

/// Tessellates `model`'s domain at `detail` (icosphere subdivisions for the sphere,
/// `8 * 2^detail` by `4 * 2^detail` cells for the torus) and maps it onto the surface,
/// within `limits`.
pub fn tessellate(
    model: &SurfaceModel,
    detail: u32,
    normals: NormalMode,
    limits: &caoen_base::budget::Limits,
) -> Result<Mesh, SurfaceError> {
    if detail > 9 {
        return Err(SurfaceError::Parameter {
            what: "mesh detail".into(),
            value: detail as f64,
            reason: "must be at most 9 (5 million triangles)",
        });
    }
    limits.check(
        || format!("a surface mesh at detail {detail}"),
        tessellation_bytes(&model.domain, detail),
    )?;
    let (domain_points, triangles, corner_uvs): DomainTriangulation = match model.domain {
        Domain::Sphere { dim: 3 } => {
            let (v, t) = icosphere(detail);
            let pts: Vec<Vec<f64>> = v.iter().map(|p| p.to_vec()).collect();
            let uvs = t
                .iter()
                .map(|tri| sphere_corner_uvs(tri.map(|i| pts[i as usize].as_slice())))
                .collect();
            (pts, t, uvs)
        }
        Domain::Torus => {
            let cols = 8usize << detail;
            let rows = 4usize << detail;
            let grid = model.domain.grid(cols, rows)?;
            let tris = grid.wrapped_triangles()?;
            let uvs = tris
                .iter()
                .map(|tri| {
                    // Unwrap the corners that wrapped around to index 0.
                    let ij = tri.map(|i| ((i as usize % cols) as f64, (i as usize / cols) as f64));
                    let (i0, j0) = ij[0];
                    ij.map(|(i, j)| {
                        let i = if i < i0 { i + cols as f64 } else { i };
                        let j = if j < j0 { j + rows as f64 } else { j };
                        [i / cols as f64, j / rows as f64]
                    })
                })
                .collect();
            let pts = grid.points.chunks_exact(4).map(|p| p.to_vec()).collect();
            (pts, tris, uvs)
        }
        other => {
            return Err(SurfaceError::Parameter {
                what: format!("domain {other:?}"),
                value: other.param_dim() as f64,
                reason: "meshes exist for the sphere S^2 and the torus",
            })
        }
    };
    if model.network.output_dim() != 3 {
        return Err(SurfaceError::Parameter {
            what: "shape dimension p".into(),
            value: model.network.output_dim() as f64,
            reason: "a mesh needs 3-D shape vectors",
        });
    }
    let flat: Vec<f64> = domain_points.iter().flatten().copied().collect();
    let positions: Vec<[f64; 3]> = model
        .network
        .eval_batch(&flat)?
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let normals: Vec<[f64; 3]> = match normals {
        NormalMode::Exact => domain_points
            .par_iter()
            .map(|x| exact_normal(&model.network, &model.domain, x))
            .collect::<Result<_, _>>()?,
        NormalMode::Interpolated => {
            let nn = NormalNetwork::new(&model.network, &model.domain)?;
            domain_points
                .par_iter()
                .map(|x| nn.normal(x))
                .collect::<Result<_, _>>()?
        }
    };
    Ok(Mesh {
        positions,
        normals,
        domain_points,
        triangles,
        corner_uvs,
    })
}
