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
    polygonise_grid(field, lo, hi, cells, false, &|_| true)
        .expect("admitted")
        .0
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
    polygonise_closed_admitted(field, lo, hi, cells, &|_| true).expect("admitted")
}

/// The size of a mesh before it is built: its vertices and triangles, exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshSize {
    /// Grid points sampled (the field's values held while the mesh is built).
    pub grid_points: usize,
    /// Vertices: one per grid or tetrahedron edge whose ends differ in sign.
    pub vertices: usize,
    /// Triangles, before any that fold to zero area are dropped.
    pub triangles: usize,
}

/// As [`polygonise_closed`], asking `admit` before the mesh is built, once the field
/// has been sampled and the mesh's size counted: `None` if it says no. A mesh follows
/// the surface's area, which only the samples tell, so a memory budget can be checked
/// here and not before.
pub fn polygonise_closed_admitted(
    field: &(dyn Fn([f64; 3]) -> f64 + Sync),
    lo: [f64; 3],
    hi: [f64; 3],
    cells: usize,
    admit: &dyn Fn(MeshSize) -> bool,
) -> Option<(Mesh, Vec<bool>)> {
    polygonise_grid(field, lo, hi, cells, true, admit)
}

/// Grid points of the grid [`polygonise`] samples for the box `[lo, hi]` at `cells`
/// cubes along its longest side: a flat model's grid is flat.
pub fn grid_points(lo: [f64; 3], hi: [f64; 3], cells: usize) -> u64 {
    let ext = sub(hi, lo);
    let longest = ext.iter().cloned().fold(0.0f64, f64::max);
    if !(longest > 0.0) || cells == 0 {
        return 0;
    }
    let h = longest / cells as f64;
    ext.iter()
        .map(|&e| ((e / h).ceil() as u64).max(1) + 1)
        .product()
}

/// The vertices and triangles marching tetrahedra makes from `values` on an `n`-cube
/// grid (x fastest): every edge of the cubes' tetrahedra whose ends differ in sign is
/// a vertex, every tetrahedron with one or three corners inside a triangle and with two
/// a quad.
fn count_mesh(values: &[f64], n: [usize; 3]) -> (usize, usize) {
    let (sx, sy) = (n[0] + 1, n[1] + 1);
    let inside = |i: usize, j: usize, k: usize| values[(k * sy + j) * sx + i] < 0.0;
    (0..=n[2])
        .into_par_iter()
        .map(|k| {
            let (mut vertices, mut triangles) = (0usize, 0usize);
            for j in 0..sy {
                for i in 0..sx {
                    let here = inside(i, j, k);
                    // The edges from this point in the positive directions: the cube
                    // edges and the face and main diagonals the tetrahedra share.
                    for d in [
                        [1, 0, 0],
                        [0, 1, 0],
                        [0, 0, 1],
                        [1, 1, 0],
                        [1, 0, 1],
                        [0, 1, 1],
                        [1, 1, 1],
                    ] {
                        let (a, b, c) = (i + d[0], j + d[1], k + d[2]);
                        if a <= n[0] && b <= n[1] && c <= n[2] && inside(a, b, c) != here {
                            vertices += 1;
                        }
                    }
                    if i == n[0] || j == n[1] || k == n[2] {
                        continue;
                    }
                    for tet in TETS {
                        let ins = tet
                            .iter()
                            .filter(|&&c| inside(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)))
                            .count();
                        triangles += match ins {
                            1 | 3 => 1,
                            2 => 2,
                            _ => 0,
                        };
                    }
                }
            }
            (vertices, triangles)
        })
        .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1))
}

fn polygonise_grid(
    field: &(dyn Fn([f64; 3]) -> f64 + Sync),
    lo: [f64; 3],
    hi: [f64; 3],
    cells: usize,
    closed: bool,
    admit: &dyn Fn(MeshSize) -> bool,
) -> Option<(Mesh, Vec<bool>)> {
    let ext = sub(hi, lo);
    let longest = ext.iter().cloned().fold(0.0f64, f64::max);
    if !(longest > 0.0) || cells == 0 {
        return Some((Mesh::default(), Vec::new()));
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
    let (vertices, triangles) = count_mesh(&values, n);
    if !admit(MeshSize {
        grid_points: values.len(),
        vertices,
        triangles,
    }) {
        return None;
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
    Some((mesh, on_cut))
}

fn grid_point(lo: [f64; 3], h: f64, g: usize, sx: usize, sy: usize) -> [f64; 3] {
    let (i, j, k) = (g % sx, g / sx % sy, g / (sx * sy));
    [
        lo[0] + i as f64 * h,
        lo[1] + j as f64 * h,
        lo[2] + k as f64 * h,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The count a budget is checked against is the mesh that is then built: every
    /// vertex, and every triangle but those that fold to zero area.
    #[test]
    fn the_counted_size_is_the_built_size() {
        for (cells, r) in [(7, 0.6), (24, 0.83), (40, 0.5)] {
            let ball = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + 0.5 * p[2] * p[2]).sqrt() - r;
            let seen = std::cell::Cell::new(None);
            let (m, _) =
                polygonise_closed_admitted(&ball, [-1.0; 3], [1.0, 0.9, 1.0], cells, &|s| {
                    seen.set(Some(s));
                    true
                })
                .expect("admitted");
            let s = seen.get().expect("asked");
            assert_eq!(s.vertices, m.positions.len());
            assert!(s.triangles >= m.triangles.len());
            assert!(s.triangles <= m.triangles.len() + m.triangles.len() / 50);
            assert_eq!(
                s.grid_points as u64,
                grid_points([-1.0; 3], [1.0, 0.9, 1.0], cells)
            );
            let refused = polygonise_closed_admitted(&ball, [-1.0; 3], [1.0; 3], cells, &|_| false);
            assert!(refused.is_none());
        }
    }
}
