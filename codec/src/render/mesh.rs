//! Polygon meshes: tessellate the domain, map every vertex through the network.
//!
//! The sphere is tessellated as a subdivided icosahedron (no degenerate poles), the
//! torus as a regular wrapped grid. Vertices are shared, so meshes of closed domains
//! are watertight with consistent winding; texture coordinates are stored per
//! triangle corner so that the equirectangular seam does not break that sharing.

use rayon::prelude::*;

use crate::surface::normals::{exact_normal, NormalNetwork};
use crate::surface::{Domain, SurfaceError, SurfaceModel};

/// How vertex normals are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalMode {
    /// Exact normals from the Jacobian (formula 12).
    #[default]
    Exact,
    /// Normals interpolated by a second network from the exact key-point normals.
    Interpolated,
}

/// A triangle mesh with per-vertex normals and per-corner texture coordinates.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Unit vertex normals (zero where the surface is singular).
    pub normals: Vec<[f64; 3]>,
    /// Domain point of each vertex (the surface's parameterisation).
    pub domain_points: Vec<Vec<f64>>,
    /// Triangles as vertex indices, counter-clockwise seen from the normal side.
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinates `(u, v)` in [0, 1] for each corner of each triangle.
    pub corner_uvs: Vec<[[f64; 2]; 3]>,
}

/// The unit icosahedron subdivided `level` times (20 * 4^level triangles), outward CCW.
pub fn icosphere(level: u32) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<[f64; 3]> = [
        [-1., t, 0.],
        [1., t, 0.],
        [-1., -t, 0.],
        [1., -t, 0.],
        [0., -1., t],
        [0., 1., t],
        [0., -1., -t],
        [0., 1., -t],
        [t, 0., -1.],
        [t, 0., 1.],
        [-t, 0., -1.],
        [-t, 0., 1.],
    ]
    .iter()
    .map(|v| normalise(*v))
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<[f64; 3]>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (verts[a as usize], verts[b as usize]);
                verts.push(normalise([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                (verts.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut verts);
            let bc = midpoint(b, c, &mut verts);
            let ca = midpoint(c, a, &mut verts);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (verts, tris)
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
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

/// Tessellates `model`'s domain at `detail` (icosphere subdivisions for the sphere,
/// `8 * 2^detail` by `4 * 2^detail` cells for the torus) and maps it onto the surface.
pub fn tessellate(
    model: &SurfaceModel,
    detail: u32,
    normals: NormalMode,
) -> Result<Mesh, SurfaceError> {
    if detail > 9 {
        return Err(SurfaceError::Parameter {
            what: "mesh detail".into(),
            value: detail as f64,
            reason: "must be at most 9 (5 million triangles)",
        });
    }
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

impl Mesh {
    /// `V - E + F`, counting each undirected edge once.
    pub fn euler_characteristic(&self) -> i64 {
        let mut edges = std::collections::HashSet::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
            }
        }
        self.positions.len() as i64 - edges.len() as i64 + self.triangles.len() as i64
    }

    /// Whether every directed edge appears once and its reverse once: closed, manifold,
    /// consistently wound.
    pub fn is_closed_and_consistent(&self) -> bool {
        let mut directed = std::collections::HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0u32) += 1;
            }
        }
        directed
            .iter()
            .all(|(&(a, b), &c)| c == 1 && directed.get(&(b, a)) == Some(&1))
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f64 {
        let [a, b, c] = self.triangles[i].map(|k| self.positions[k as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
    }
}
