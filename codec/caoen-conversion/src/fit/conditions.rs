//! What the fit asks of the field: the surface samples (the fit's vertices and points
//! inside the triangles, denser on flat faces) and the conditions on them (values on
//! the surface and a step off it, a far grid, tangent derivatives at the vertices).

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::model::{Bump, ImplicitField, ImplicitModel};
use crate::polygon_mesh::PolygonMesh;
use crate::winding::WindingTree;
use caoen_geometry::vector::{dot, norm, sub};

/// One least-squares condition `F(p) = target`, weighted.
#[derive(Debug, Clone, Copy)]
pub(super) struct Condition {
    /// Where the condition holds.
    pub p: [f64; 3],
    /// The value (or derivative) asked for there.
    pub target: f64,
    /// Its weight in the least-squares sum.
    pub weight: f64,
    /// Zero for a value condition `F(p) = target`; otherwise a unit direction and the
    /// condition is on the derivative along it, `grad F(p) . dir = target`.
    pub dir: [f64; 3],
}

impl Condition {
    /// What the condition constrains, of a bump with unit factor.
    pub(super) fn of_bump(&self, b: &Bump) -> f64 {
        if self.dir == [0.0; 3] {
            b.kernel(self.p).0
        } else {
            dot(b.kernel(self.p).1, self.dir)
        }
    }

    /// What the condition constrains, of the model.
    pub(super) fn of_model(&self, m: &ImplicitModel) -> f64 {
        if self.dir == [0.0; 3] {
            m.value(self.p)
        } else {
            dot(m.value_gradient(self.p).1, self.dir)
        }
    }
}

/// The spacing of surface samples on large triangles (unit cube).
const SAMPLE_SPACING: f64 = 0.015;
/// The spacing on large triangles of a flat face (see [`flat_faces`]): where a face is
/// truly flat its triangles' normal is the surface's, and the conditions must hold the
/// field's zero set to the plane between distant vertices, which a wall seen edge-on
/// shows to the pixel.
const FLAT_SAMPLE_SPACING: f64 = 0.004;
/// Neighbours whose normals are closer than this (degrees) lie on one flat face...
const FLAT_DEG: f64 = 1.0;
/// ...and an edge sharper than this is a crease between faces.
const CREASE_DEG: f64 = 60.0;

/// Per triangle, whether it is large (longer than three [`FLAT_SAMPLE_SPACING`]) and
/// lies on a flat face: a neighbour across an edge is coplanar with it, and each other
/// one is coplanar too or meets it at a crease. A faceted smooth surface (a low-polygon model shaded smooth) has
/// neighbours at in-between angles: its face normals are not its surface's.
pub(super) fn flat_faces(mesh: &PolygonMesh, longest: impl Fn(usize) -> f64) -> Vec<bool> {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let large: Vec<usize> = (0..mesh.triangles.len())
        .filter(|&t| longest(t) > 3.0 * FLAT_SAMPLE_SPACING)
        .collect();
    let mut edges: std::collections::HashMap<(u32, u32), Vec<u32>> = Default::default();
    for &t in &large {
        let [a, b, c] = mesh.triangles[t];
        for e in [key(a, b), key(b, c), key(c, a)] {
            edges.insert(e, Vec::new());
        }
    }
    for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        for e in [key(a, b), key(b, c), key(c, a)] {
            if let Some(list) = edges.get_mut(&e) {
                list.push(t as u32);
            }
        }
    }
    let unit = |t: usize| {
        let n = mesh.face_normal(t);
        let l = norm(n).max(1e-300);
        n.map(|v| v / l)
    };
    let (flat, crease) = (FLAT_DEG.to_radians().cos(), CREASE_DEG.to_radians().cos());
    let mut out = vec![false; mesh.triangles.len()];
    for &t in &large {
        let n = unit(t);
        let [a, b, c] = mesh.triangles[t];
        let cosines: Vec<f64> = [key(a, b), key(b, c), key(c, a)]
            .iter()
            .flat_map(|e| edges[e].iter().filter(|&&o| o as usize != t))
            .map(|&o| dot(n, unit(o as usize)))
            .collect();
        out[t] =
            cosines.iter().any(|&c| c >= flat) && cosines.iter().all(|&c| c >= flat || c <= crease);
    }
    out
}
/// About the most points sampled inside triangles.
pub const MAX_SAMPLES: f64 = 400_000.0;

/// Most mesh vertices the fit works on. A denser mesh is fitted on a spread subset
/// (one vertex per cell of a grid sized to this count): its vertices are closer than
/// the smallest perturbation, so more of them add conditions, time and memory but no
/// detail the model can hold.
pub const MAX_FIT_VERTICES: usize = 200_000;

/// The vertices the fit works on: all of them, or on a mesh of more than `cap`, the
/// lowest-numbered vertex of each occupied cell of a grid coarsened until at most
/// `cap` cells are occupied (in index order, the same on every run).
pub fn spread_vertices(mesh: &PolygonMesh, cap: usize) -> Vec<u32> {
    let n = mesh.positions.len();
    if n <= cap {
        return (0..n as u32).collect();
    }
    let area = mesh.area();
    let (lo, hi) = mesh.bounds();
    let side = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // A surface of area A holds about A / h^2 cells of side h.
    let mut h = (area / cap as f64).sqrt().max(1e-9 * side);
    loop {
        let mut first: std::collections::HashMap<[i64; 3], u32> = Default::default();
        for (i, p) in mesh.positions.iter().enumerate() {
            let c = [0, 1, 2].map(|k| ((p[k] - lo[k]) / h).floor() as i64);
            first.entry(c).or_insert(i as u32);
        }
        if first.len() <= cap {
            let mut out: Vec<u32> = first.into_values().collect();
            out.sort_unstable();
            return out;
        }
        h *= 1.15;
    }
}

/// The surface samples: the fit's vertices (first, in the order of `fit_vertices`),
/// then points inside each triangle
/// (its centroid, or a barycentric grid at about [`SAMPLE_SPACING`] on a large one, or
/// [`FLAT_SAMPLE_SPACING`] on a flat face, so that a coarse mesh's flat faces hold the
/// surface too; on a mesh of more than [`MAX_SAMPLES`] triangles, the centroids of an
/// evenly strided subset, fewer when the vertices were thinned), with outward unit
/// normals.
pub(super) fn samples(
    mesh: &PolygonMesh,
    winding: &WindingTree<'_>,
    fit_vertices: &[u32],
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let all_normals = mesh.outward_normals_by(winding);
    let mut normals: Vec<[f64; 3]> = fit_vertices
        .iter()
        .map(|&i| all_normals[i as usize])
        .collect();
    // Face normals follow the winding; turn them the way the vertex normals went.
    let flip = all_normals
        .iter()
        .zip(mesh.vertex_normals())
        .any(|(a, b)| dot(*a, b) < 0.0);
    drop(all_normals);
    let longest = |t: usize| {
        let tri = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
        (0..3)
            .map(|k| norm(sub(tri[(k + 1) % 3], tri[k])))
            .fold(0.0, f64::max)
    };
    let flat = flat_faces(mesh, longest);
    // A flat face's triangles at the finer spacing, the others at the plain one; both
    // wider when the grid would pass MAX_SAMPLES points.
    let ratio = FLAT_SAMPLE_SPACING / SAMPLE_SPACING;
    let parts_at = |t: usize, h: f64| {
        let h = if flat[t] { h * ratio } else { h };
        (longest(t) / h).ceil().min(64.0)
    };
    let count = |h: f64| -> f64 {
        (0..mesh.triangles.len())
            .map(|t| (parts_at(t, h) - 1.0).max(1.0).powi(2) / 2.0)
            .sum()
    };
    let mut spacing = SAMPLE_SPACING;
    let widest = (0..mesh.triangles.len()).map(longest).fold(0.0, f64::max);
    while spacing * ratio < widest && count(spacing) > MAX_SAMPLES {
        spacing *= 1.25;
    }
    // On a mesh with more triangles than that, the vertices already sample the surface
    // densely: every k-th triangle gives its centroid. When the vertices were thinned,
    // the centroids fill only what is left of MAX_SAMPLES.
    let room = if fit_vertices.len() < mesh.positions.len() {
        MAX_SAMPLES - fit_vertices.len() as f64
    } else {
        MAX_SAMPLES
    };
    let stride = (mesh.triangles.len() as f64 / room).ceil().max(1.0) as usize;
    let mut pts: Vec<[f64; 3]> = fit_vertices
        .iter()
        .map(|&i| mesh.positions[i as usize])
        .collect();
    for t in (0..mesh.triangles.len()).step_by(stride) {
        let tri = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
        let n = mesh.face_normal(t);
        let l = norm(n).max(1e-300);
        let n = n.map(|v| if flip { -v / l } else { v / l });
        let parts = parts_at(t, spacing) as usize;
        if parts < 3 {
            pts.push([0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0));
            normals.push(n);
            continue;
        }
        for i in 1..parts {
            for j in 1..parts - i {
                let (a, b) = (i as f64 / parts as f64, j as f64 / parts as f64);
                let c = 1.0 - a - b;
                pts.push([0, 1, 2].map(|k| a * tri[0][k] + b * tri[1][k] + c * tri[2][k]));
                normals.push(n);
            }
        }
    }
    (pts, normals)
}

/// Builds the conditions. `pts`/`normals` are the surface samples; the first
/// `vertices` of them are mesh vertices; `winding` tells the far grid's sides.
pub(super) fn conditions(
    winding: &WindingTree<'_>,
    pts: &[[f64; 3]],
    normals: &[[f64; 3]],
    vertices: usize,
    step: f64,
) -> Vec<Condition> {
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(pts).expect("the mesh has points");
    let nearest = |q: [f64; 3]| -> (f64, usize) {
        let n = tree
            .query(&q)
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        (n.distance.sqrt(), n.item as usize)
    };
    let mut out: Vec<Condition> = pts
        .iter()
        .map(|&p| Condition {
            p,
            target: 0.0,
            weight: 1.0,
            dir: [0.0; 3],
        })
        .collect();
    // Off-surface pairs at the vertices, at several distances so that the sign of
    // the field is pinned from the surface out to the far grid. The smallest step
    // halves until nothing else on the surface is nearer than the vertex (thin parts
    // and creases); a larger one that fails that test is left out.
    let pairs: Vec<Vec<Condition>> = (0..pts.len())
        .into_par_iter()
        .map(|i| {
            let mut list = Vec::new();
            for side in [1.0, -1.0] {
                let offset = |d: f64| [0, 1, 2].map(|k| pts[i][k] + side * d * normals[i][k]);
                let mut d = step;
                for _ in 0..4 {
                    if nearest(offset(d)).0 >= 0.99 * d {
                        list.push(Condition {
                            p: offset(d),
                            target: -side * d,
                            weight: 1.0,
                            dir: [0.0; 3],
                        });
                        break;
                    }
                    d *= 0.5;
                }
                for d in [0.03, 0.07] {
                    if i < vertices && d > step && nearest(offset(d)).0 >= 0.99 * d {
                        list.push(Condition {
                            p: offset(d),
                            target: -side * d,
                            weight: 0.5,
                            dir: [0.0; 3],
                        });
                    }
                }
            }
            list
        })
        .collect();
    out.extend(pairs.into_iter().flatten());
    // Far points: a grid over the cube, with the side from the winding number.
    let n = 14;
    let grid: Vec<[f64; 3]> = (0..n * n * n)
        .map(|i| {
            [i % n, (i / n) % n, i / (n * n)].map(|c| -0.6 + 1.2 * (c as f64 + 0.5) / n as f64)
        })
        .collect();
    let far: Vec<Option<Condition>> = grid
        .par_iter()
        .map(|&q| {
            let (d, _) = nearest(q);
            if d < 4.0 * step {
                return None;
            }
            let inside = winding.winding_number(q).abs() > 0.5;
            let dist = d.min(0.15);
            Some(Condition {
                p: q,
                target: if inside { dist } else { -dist },
                weight: 0.3,
                dir: [0.0; 3],
            })
        })
        .collect();
    out.extend(far.into_iter().flatten());
    out
}

/// Tangent conditions at the vertices: the derivative of `F` along two directions
/// across the vertex normal is 0, so the gradient follows the normal (the mean
/// normal angle) where a coarse mesh's facets would tilt it.
pub(super) fn tangent_conditions(
    pts: &[[f64; 3]],
    normals: &[[f64; 3]],
    weight: f64,
) -> Vec<Condition> {
    let mut out = Vec::with_capacity(2 * pts.len());
    for (p, n) in pts.iter().zip(normals) {
        if *n == [0.0; 3] {
            continue;
        }
        // Any vector not along n, crossed with it, and n crossed with that.
        let a = if n[0].abs() < 0.6 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let t1 = caoen_geometry::vector::unit(caoen_geometry::vector::cross(*n, a));
        let t2 = caoen_geometry::vector::cross(*n, t1);
        for t in [t1, t2] {
            out.push(Condition {
                p: *p,
                target: 0.0,
                weight,
                dir: t,
            });
        }
    }
    out
}
