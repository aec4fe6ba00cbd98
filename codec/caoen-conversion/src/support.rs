//! The planes a mesh lies behind: its bounding box and the flat faces of it that every
//! vertex lies behind (a CAD part's outer faces). The model is cut to them, which
//! costs nothing inside and puts those faces exactly where the mesh has them: a smooth
//! fit leaves a plane by a fraction of a pixel between its conditions, and a wall seen
//! edge-on shows that as whole rows of pixels seeing the wall's side.

use serde_json::{json, Value};

use super::polygon_mesh::PolygonMesh;

/// A flat region counts once it holds this fraction of the mesh's area: smaller faces
/// are few pixels in any view and each plane costs a node and an evaluation.
const MIN_AREA_FRACTION: f64 = 0.005;
/// Neighbouring triangles closer than this (degrees) lie on one flat region.
const FLAT_DEG: f64 = 1.0;
/// How far (unit cube) a region's vertices may leave its plane, and any vertex may lie
/// beyond it: the rounding of meshes written with single-precision coordinates, far
/// below a pixel of any depth buffer.
const TOLERANCE: f64 = 2e-5;
/// Most planes kept, the largest regions first.
const MAX_PLANES: usize = 32;
/// Margin of the box beyond the vertices (unit cube): keeps a flat mesh's box a solid.
const BOX_MARGIN: f64 = 1e-6;

/// A half-space `normal . (p - point) <= 0` (unit normal, pointing out of the solid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: [f64; 3],
    /// Outward unit normal.
    pub normal: [f64; 3],
}

/// Where a model is cut: the mesh's bounding box and its supporting flat faces, in the
/// coordinates of the mesh they were found on.
#[derive(Debug, Clone, PartialEq)]
pub struct Supports {
    /// The box's low corner.
    pub lo: [f64; 3],
    /// The box's high corner.
    pub hi: [f64; 3],
    /// Planes of flat faces every vertex lies behind, beyond the box's own.
    pub planes: Vec<Plane>,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Supports {
    /// The supports of `mesh`.
    pub fn of(mesh: &PolygonMesh) -> Supports {
        let (lo, hi) = mesh.bounds();
        Supports {
            planes: supporting_planes(mesh),
            ..Supports::of_box(lo, hi)
        }
    }

    /// The box from `lo` to `hi` alone.
    pub fn of_box(lo: [f64; 3], hi: [f64; 3]) -> Supports {
        Supports {
            lo: lo.map(|v| v - BOX_MARGIN),
            hi: hi.map(|v| v + BOX_MARGIN),
            planes: Vec::new(),
        }
    }

    /// `min(v, the box's and the planes' fields)` with the gradient of the least: the
    /// value of the model cut to the supports, as the written model's intersection
    /// (an R-conjunction, twice the least of its operands) has it, halved.
    pub fn cut(&self, p: [f64; 3], (mut v, mut g): (f64, [f64; 3])) -> (f64, [f64; 3]) {
        for k in 0..3 {
            let (c, h) = (
                0.5 * (self.lo[k] + self.hi[k]),
                0.5 * (self.hi[k] - self.lo[k]),
            );
            let q = p[k] - c;
            let b = h * h - q * q;
            if b < v {
                v = b;
                g = [0.0; 3];
                g[k] = -2.0 * q;
            }
        }
        for s in &self.planes {
            let d = dot(s.normal, [0, 1, 2].map(|k| s.point[k] - p[k]));
            if d < v {
                v = d;
                g = s.normal.map(|x| -x);
            }
        }
        (v, g)
    }

    /// The model file's nodes of the box and the planes (F-rep `box` and
    /// `half_space`), in the same coordinates.
    pub fn json_nodes(&self) -> Vec<Value> {
        let centre = [0, 1, 2].map(|k| 0.5 * (self.lo[k] + self.hi[k]));
        let size = [0, 1, 2].map(|k| self.hi[k] - self.lo[k]);
        std::iter::once(json!({"box": {"centre": centre, "size": size}}))
            .chain(
                self.planes
                    .iter()
                    .map(|s| json!({"half_space": {"point": s.point, "normal": s.normal}})),
            )
            .collect()
    }
}

/// The planes of the flat regions (edge-connected triangles within [`FLAT_DEG`] of
/// each other, flat within [`TOLERANCE`], at least [`MIN_AREA_FRACTION`] of the area)
/// that every vertex lies behind, the largest first, without the box's own faces.
fn supporting_planes(mesh: &PolygonMesh) -> Vec<Plane> {
    let n = mesh.triangles.len();
    let normals: Vec<([f64; 3], f64)> = (0..n)
        .map(|t| {
            let f = mesh.face_normal(t);
            let l = dot(f, f).sqrt();
            (if l > 0.0 { f.map(|v| v / l) } else { [0.0; 3] }, 0.5 * l)
        })
        .collect();
    // Union-find over the edges between nearly parallel triangles.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let mut first: std::collections::HashMap<(u32, u32), u32> = Default::default();
    let flat = FLAT_DEG.to_radians().cos();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (tri[e], tri[(e + 1) % 3]);
            match first.entry((a.min(b), a.max(b))) {
                std::collections::hash_map::Entry::Vacant(v) => {
                    v.insert(t as u32);
                }
                std::collections::hash_map::Entry::Occupied(o) => {
                    let u = *o.get();
                    if dot(normals[t].0, normals[u as usize].0).abs() >= flat {
                        let (ra, rb) = (root(&mut parent, t as u32), root(&mut parent, u));
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
            }
        }
    }
    drop(first);
    let total: f64 = normals.iter().map(|x| x.1).sum();
    // Per region (indexed by its root): area, area-weighted normal sum, first triangle.
    // A smooth mesh is one region per triangle, so only the large ones list theirs.
    let roots: Vec<u32> = (0..n as u32).map(|t| root(&mut parent, t)).collect();
    drop(parent);
    let mut sums = vec![(0.0f64, [0.0f64; 3]); n];
    for (t, &(normal, area)) in normals.iter().enumerate() {
        let entry = &mut sums[roots[t] as usize];
        // A fin folded flat joins antiparallel triangles: the region's first decides.
        let s = if entry.0 == 0.0 || dot(entry.1, normal) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        entry.0 += area;
        for (sum, v) in entry.1.iter_mut().zip(normal) {
            *sum += s * area * v;
        }
    }
    let mut large: Vec<(f64, [f64; 3], Vec<u32>)> = Vec::new();
    let mut slot = vec![u32::MAX; n];
    for (t, &r) in roots.iter().enumerate() {
        let (area, sum) = sums[r as usize];
        if area < MIN_AREA_FRACTION * total {
            continue;
        }
        if slot[r as usize] == u32::MAX {
            slot[r as usize] = large.len() as u32;
            large.push((area, sum, Vec::new()));
        }
        large[slot[r as usize] as usize].2.push(t as u32);
    }
    large.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.2[0].cmp(&b.2[0])));
    let mut planes: Vec<Plane> = Vec::new();
    for (_, sum, tris) in large {
        let l = dot(sum, sum).sqrt();
        if l <= 0.0 {
            continue;
        }
        let mut normal = sum.map(|v| v / l);
        let region = |normal: [f64; 3]| {
            tris.iter()
                .flat_map(|&t| mesh.triangles[t as usize])
                .map(|i| dot(normal, mesh.positions[i as usize]))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| {
                    (a.min(d), b.max(d))
                })
        };
        let (rlo, rhi) = region(normal);
        if rhi - rlo > TOLERANCE {
            continue;
        }
        let (alo, ahi) = mesh
            .positions
            .iter()
            .map(|p| dot(normal, *p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| {
                (a.min(d), b.max(d))
            });
        // The whole mesh lies behind the region on one side or the other.
        let offset = if ahi <= rhi + TOLERANCE {
            ahi
        } else if alo >= rlo - TOLERANCE {
            normal = normal.map(|v| -v);
            -alo
        } else {
            continue;
        };
        // The box already holds a plane along an axis.
        if normal.iter().any(|v| v.abs() > 1.0 - 1e-12) {
            continue;
        }
        if planes.iter().any(|p| dot(p.normal, normal) > 1.0 - 1e-9) {
            continue;
        }
        planes.push(Plane {
            point: normal.map(|v| v * offset),
            normal,
        });
        if planes.len() == MAX_PLANES {
            break;
        }
    }
    planes
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's 12 triangles, rotated by `r` (row-major) about its centre.
    fn cube(r: [[f64; 3]; 3]) -> PolygonMesh {
        PolygonMesh::cuboid([0.5; 3], r)
    }

    fn rotation(a: f64) -> [[f64; 3]; 3] {
        let (s, c) = a.sin_cos();
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    }

    #[test]
    fn a_rotated_cube_is_cut_to_its_faces_and_an_upright_one_to_its_box() {
        assert!(Supports::of(&cube(rotation(0.0))).planes.is_empty());
        let mesh = cube(rotation(0.3));
        let s = Supports::of(&mesh);
        // The four faces the rotation turned off the axes; the two it kept are the box's.
        assert_eq!(s.planes.len(), 4, "{:?}", s.planes);
        for p in &s.planes {
            assert!(p.normal[2].abs() < 1e-12);
            // The face's own distance from the centre, and every corner behind it.
            assert!((dot(p.normal, p.point) - 0.5).abs() < 1e-12);
            for v in &mesh.positions {
                assert!(dot(p.normal, [0, 1, 2].map(|k| v[k] - p.point[k])) <= 1e-12);
            }
        }
        // Cutting a large ball to the supports leaves exactly the cube.
        let ball = |p: [f64; 3]| (1.0 - dot(p, p), p.map(|v| -2.0 * v));
        for (p, inside) in [
            ([0.0; 3], true),
            ([0.49, 0.0, 0.0], true),
            ([0.0, 0.0, 0.51], false),
        ] {
            let q = [0, 1, 2].map(|j| dot(rotation(0.3)[j], p));
            assert_eq!(s.cut(q, ball(q)).0 > 0.0, inside, "{p:?}");
        }
        let corner = [0, 1, 2].map(|j| dot(rotation(0.3)[j], [0.45, 0.0, 0.0]));
        let (v, g) = s.cut(corner, ball(corner));
        assert!((v - 0.05).abs() < 1e-9, "{v}");
        let out = [0, 1, 2].map(|j| rotation(0.3)[j][0]);
        assert!(
            g.iter().zip(out).all(|(a, b)| (a + b).abs() < 1e-9),
            "{g:?}"
        );
    }

    #[test]
    fn no_plane_cuts_the_mesh_and_small_facets_give_none() {
        // A finely faceted ellipsoid: every facet supports it, none is large enough.
        let sphere = PolygonMesh::ellipsoid([0.5, 0.4, 0.3], 3);
        assert!(Supports::of(&sphere).planes.is_empty());
        // A corner pushed in: the triangles at it tilt, and a plane through them would
        // cut the mesh; the kept planes (the two rotated faces away from it) do not.
        let mut dented = cube(rotation(0.3));
        dented.positions[7] = dented.positions[7].map(|v| 0.6 * v);
        let s = Supports::of(&dented);
        assert_eq!(s.planes.len(), 2, "{:?}", s.planes);
        for p in &s.planes {
            for v in &dented.positions {
                assert!(dot(p.normal, [0, 1, 2].map(|k| v[k] - p.point[k])) <= TOLERANCE);
            }
        }
    }

    #[test]
    fn the_json_nodes_are_the_box_and_the_half_spaces() {
        let s = Supports::of(&cube(rotation(0.3)));
        let nodes = s.json_nodes();
        assert_eq!(nodes.len(), 5);
        assert!(nodes[0]["box"]["size"][2].as_f64().unwrap() - 1.0 < 1e-5);
        assert!(nodes[1..]
            .iter()
            .all(|n| n["half_space"]["normal"].is_array()));
    }
}
