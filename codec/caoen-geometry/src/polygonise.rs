//! Polygonising a scalar field (negative inside) by marching tetrahedra: the mesh of
//! an implicit solid or a CSG expression, for the mesh renderer and for checking the
//! ray tracer's silhouettes.
//!
//! Each grid cube is split into six tetrahedra around its main diagonal; all cubes use
//! the same diagonal, so neighbouring cubes cut their shared faces identically and,
//! with vertices shared per grid edge, the mesh is watertight. Tetrahedra need no case
//! table: one or three inside corners give a triangle, two give a quad.

use std::collections::HashMap;

use rayon::prelude::*;

use super::mesh::Mesh;
use super::vector::{cross, dot, sub, unit};

/// The six tetrahedra of a cube (corner `k` at offset `(k & 1, k >> 1 & 1, k >> 2 & 1)`).
const TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// Polygonises `{x : field(x) < 0}` inside the box `[lo, hi]` with `cells` cubes along
/// the box's longest side. Normals come from the field's central differences; faces
/// wind counter-clockwise seen from outside. Texture coordinates are left empty.
pub fn polygonise(
    field: &(dyn Fn([f64; 3]) -> f64 + Sync),
    lo: [f64; 3],
    hi: [f64; 3],
    cells: usize,
) -> Mesh {
    polygonise_grid(field, lo, hi, cells, false).0
}

/// As [`polygonise`], with the grid's outer layer of points taken as outside, so the
/// mesh is closed even where the solid reaches the box (it is cut there); also returns
/// which vertices lie on such a cut (on a grid edge from an outer point that was
/// inside).
pub fn polygonise_closed(
    field: &(dyn Fn([f64; 3]) -> f64 + Sync),
    lo: [f64; 3],
    hi: [f64; 3],
    cells: usize,
) -> (Mesh, Vec<bool>) {
    polygonise_grid(field, lo, hi, cells, true)
}

fn polygonise_grid(
    field: &(dyn Fn([f64; 3]) -> f64 + Sync),
    lo: [f64; 3],
    hi: [f64; 3],
    cells: usize,
    closed: bool,
) -> (Mesh, Vec<bool>) {
    let ext = sub(hi, lo);
    let longest = ext.iter().cloned().fold(0.0f64, f64::max);
    if !(longest > 0.0) || cells == 0 {
        return (Mesh::default(), Vec::new());
    }
    let h = longest / cells as f64;
    let n = ext.map(|e| ((e / h).ceil() as usize).max(1));
    let (sx, sy) = (n[0] + 1, n[1] + 1);
    let corner = |i: usize, j: usize, k: usize| {
        [
            lo[0] + i as f64 * h,
            lo[1] + j as f64 * h,
            lo[2] + k as f64 * h,
        ]
    };
    // Field values at grid points, one z-slab per task.
    let mut values: Vec<f64> = (0..=n[2])
        .into_par_iter()
        .flat_map_iter(|k| (0..sy).flat_map(move |j| (0..sx).map(move |i| field(corner(i, j, k)))))
        .collect();
    let mut forced = vec![false; values.len()];
    if closed {
        for k in 0..=n[2] {
            for j in 0..sy {
                for i in 0..sx {
                    let outer = i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2];
                    let g = (k * sy + j) * sx + i;
                    // NaN counts as outside everywhere (`v < 0` is false). The mirrored
                    // value puts the cut about halfway along each edge, so cut vertices
                    // from one outer point do not coincide.
                    if outer && values[g] < 0.0 {
                        values[g] = -values[g];
                        forced[g] = true;
                    }
                }
            }
        }
    }
    let id = |i: usize, j: usize, k: usize| (k * sy + j) * sx + i;
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut edge_vertex: HashMap<(usize, usize), u32> = HashMap::new();
    let mut on_cut: Vec<bool> = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let ids: [usize; 8] =
                    std::array::from_fn(|c| id(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)));
                let vals = ids.map(|g| values[g]);
                let inside = vals.iter().filter(|v| **v < 0.0).count();
                if inside == 0 || inside == 8 {
                    continue;
                }
                for tet in TETS {
                    let g = tet.map(|c| ids[c]);
                    let v = tet.map(|c| vals[c]);
                    let (ins, outs): (Vec<usize>, Vec<usize>) = (0..4).partition(|&a| v[a] < 0.0);
                    if ins.is_empty() || outs.is_empty() {
                        continue;
                    }
                    let mut vertex = |a: usize, b: usize| -> u32 {
                        let key = (g[a].min(g[b]), g[a].max(g[b]));
                        *edge_vertex.entry(key).or_insert_with(|| {
                            let pa = grid_point(lo, h, g[a], sx, sy);
                            let pb = grid_point(lo, h, g[b], sx, sy);
                            let s = v[a] / (v[a] - v[b]);
                            on_cut.push(forced[g[a]] || forced[g[b]]);
                            positions.push([
                                pa[0] + s * (pb[0] - pa[0]),
                                pa[1] + s * (pb[1] - pa[1]),
                                pa[2] + s * (pb[2] - pa[2]),
                            ]);
                            (positions.len() - 1) as u32
                        })
                    };
                    let polygon: Vec<u32> = match (ins.len(), outs.len()) {
                        (1, 3) => outs.iter().map(|&o| vertex(ins[0], o)).collect(),
                        (3, 1) => ins.iter().map(|&i| vertex(i, outs[0])).collect(),
                        _ => vec![
                            vertex(ins[0], outs[0]),
                            vertex(ins[0], outs[1]),
                            vertex(ins[1], outs[1]),
                            vertex(ins[1], outs[0]),
                        ],
                    };
                    // Orient outwards: from the inside corners towards the outside ones.
                    let centroid = |set: &[usize]| {
                        let mut c = [0.0; 3];
                        for &a in set {
                            let p = grid_point(lo, h, g[a], sx, sy);
                            (0..3).for_each(|d| c[d] += p[d] / set.len() as f64);
                        }
                        c
                    };
                    let outward = sub(centroid(&outs), centroid(&ins));
                    let p = |v: u32| positions[v as usize];
                    for tri in [[0, 1, 2], [0, 2, 3]].iter().take(polygon.len() - 2) {
                        let mut t = tri.map(|a| polygon[a]);
                        let nrm = cross(sub(p(t[1]), p(t[0])), sub(p(t[2]), p(t[0])));
                        if dot(nrm, outward) < 0.0 {
                            t.swap(1, 2);
                        }
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            triangles.push(t);
                        }
                    }
                }
            }
        }
    }
    let e = 1e-3 * h;
    let normals = positions
        .par_iter()
        .map(|&x| {
            let d = |k: usize| {
                let (mut a, mut b) = (x, x);
                a[k] += e;
                b[k] -= e;
                field(a) - field(b)
            };
            unit([d(0), d(1), d(2)])
        })
        .collect();
    let mesh = Mesh {
        positions,
        normals,
        domain_points: Vec::new(),
        triangles,
        corner_uvs: Vec::new(),
    };
    (mesh, on_cut)
}

fn grid_point(lo: [f64; 3], h: f64, g: usize, sx: usize, sy: usize) -> [f64; 3] {
    let (i, j, k) = (g % sx, g / sx % sy, g / (sx * sy));
    [
        lo[0] + i as f64 * h,
        lo[1] + j as f64 * h,
        lo[2] + k as f64 * h,
    ]
}
