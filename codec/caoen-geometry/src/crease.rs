//! Sharp edges in meshes of set operations. A solid made by min/max of leaf fields has
//! creases where two leaves' surfaces meet (the rims of a CSG difference). Marching
//! tetrahedra places vertices on grid edges, so a crease comes out as a zigzag (the
//! saw-tooth rim) and shared vertex normals smear it. Here every vertex is moved onto
//! the surface of the leaf that is active at it, the vertices along a crease (those
//! with a neighbour on another leaf) onto the curve where the two leaves meet, and each
//! triangle takes its normals from the leaf active at its centre, with vertices split
//! between leaves, so the crease is sharp.

use std::collections::HashMap;

use rayon::prelude::*;

use super::mesh::Mesh;
use super::vector::{dot, norm, normalise, sub};

/// A field made of leaves by min and max: at every point its value is one leaf's.
pub trait Leaves: Sync {
    /// Leaf `i`'s field as it enters the combined one (negative inside) and its gradient.
    fn leaf(&self, i: usize, p: [f64; 3]) -> (f64, [f64; 3]);
    /// The leaf whose value the combined field takes at `p`.
    fn active(&self, p: [f64; 3]) -> usize;
}

/// Newton steps onto leaf `i`'s zero set; None if a step fails or leaves `reach`.
fn onto_leaf(l: &dyn Leaves, i: usize, p: [f64; 3], reach: f64) -> Option<[f64; 3]> {
    let mut q = p;
    for _ in 0..6 {
        let (f, g) = l.leaf(i, q);
        let n2 = dot(g, g);
        if !(n2 > 0.0 && f.is_finite()) {
            return None;
        }
        q = [0, 1, 2].map(|k| q[k] - f * g[k] / n2);
    }
    let d = norm(sub(q, p));
    (d <= reach).then_some(q)
}

/// Newton steps onto the curve where leaves `a` and `b` both vanish (the minimum-norm
/// step of the two linearised equations); None if they are parallel there or the
/// point leaves `reach`.
fn onto_crease(l: &dyn Leaves, a: usize, b: usize, p: [f64; 3], reach: f64) -> Option<[f64; 3]> {
    let mut q = p;
    for _ in 0..8 {
        let (fa, ga) = l.leaf(a, q);
        let (fb, gb) = l.leaf(b, q);
        let (aa, ab, bb) = (
            dot(ga, ga),
            ga[0] * gb[0] + ga[1] * gb[1] + ga[2] * gb[2],
            dot(gb, gb),
        );
        let det = aa * bb - ab * ab;
        if !(det > 1e-12 * aa * bb && fa.is_finite() && fb.is_finite()) {
            return None;
        }
        // delta = -J^T (J J^T)^-1 f.
        let la = (bb * fa - ab * fb) / det;
        let lb = (aa * fb - ab * fa) / det;
        q = [0, 1, 2].map(|k| q[k] - la * ga[k] - lb * gb[k]);
    }
    let d = norm(sub(q, p));
    (d <= reach).then_some(q)
}

/// The mesh with vertices on their leaves, crease vertices on the creases, and
/// per-leaf normals; `cell` is the grid spacing the mesh came from.
pub fn sharpen(mesh: Mesh, leaves: &dyn Leaves, cell: f64) -> Mesh {
    sharpen_with(mesh, leaves, cell, true)
}

/// As [`sharpen`]; with `split_leaves` false a vertex on a crease is not split between its
/// leaves (it keeps the normal of the first triangle that uses it), so a closed mesh
/// stays closed.
pub fn sharpen_with(mesh: Mesh, leaves: &dyn Leaves, cell: f64, split_leaves: bool) -> Mesh {
    let reach = 1.5 * cell;
    // 1. Every vertex onto its active leaf, unless that lands where another leaf is
    //    active: there the leaf's surface is not the solid's (a pattern's surface
    //    beyond the box it carves), and the vertex would leave the solid.
    let mut pos: Vec<[f64; 3]> = mesh
        .positions
        .par_iter()
        .map(|&p| {
            let i = leaves.active(p);
            onto_leaf(leaves, i, p, reach)
                .filter(|q| leaves.active(*q) == i)
                .unwrap_or(p)
        })
        .collect();
    let act: Vec<usize> = pos.par_iter().map(|&p| leaves.active(p)).collect();
    // 2. Vertices with a neighbour on another leaf: onto the crease of the two.
    let mut other: HashMap<u32, usize> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (i, j) = (t[k], t[(k + 1) % 3]);
            if act[i as usize] != act[j as usize] {
                other.entry(i).or_insert(act[j as usize]);
                other.entry(j).or_insert(act[i as usize]);
            }
        }
    }
    let mut snapped: Vec<(u32, [f64; 3])> = other
        .par_iter()
        .filter_map(|(&v, &b)| {
            let a = act[v as usize];
            onto_crease(leaves, a, b, pos[v as usize], reach).map(|q| (v, q))
        })
        .collect();
    snapped.sort_by_key(|s| s.0);
    for (v, q) in snapped {
        pos[v as usize] = q;
    }
    // 3. Each triangle's normals from the leaf active at its centre; a vertex shared by
    //    triangles of different leaves is split.
    let mut split: HashMap<(u32, usize), u32> = HashMap::new();
    let mut positions = Vec::with_capacity(pos.len());
    let mut normals = Vec::with_capacity(pos.len());
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        let c = [0, 1, 2]
            .map(|k| (pos[t[0] as usize][k] + pos[t[1] as usize][k] + pos[t[2] as usize][k]) / 3.0);
        let leaf = leaves.active(c);
        let key_leaf = if split_leaves { leaf } else { 0 };
        let tri = t.map(|v| {
            *split.entry((v, key_leaf)).or_insert_with(|| {
                let p = pos[v as usize];
                let (_, g) = leaves.leaf(leaf, p);
                positions.push(p);
                normals.push(normalise(g));
                (positions.len() - 1) as u32
            })
        });
        triangles.push(tri);
    }
    Mesh {
        positions,
        normals,
        domain_points: Vec::new(),
        triangles,
        corner_uvs: Vec::new(),
    }
}
