//! A polygon mesh as read from a file: positions and triangles, with what the
//! conversion needs of it (vertex normals, the unit-cube frame, topology counts).

use std::collections::HashMap;

use rayon::prelude::*;

use super::winding::{solid_angle_half, WindingTree};
use crate::vector::{cross, dot, sub, unit};

/// A triangle mesh: positions and counter-clockwise triangles (quads and polygons are
/// split into fans when read).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PolygonMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// A similarity `p -> (p - centre) * scale` that puts a mesh in the unit cube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitFrame {
    /// The centre of the mesh's bounding box.
    pub centre: [f64; 3],
    /// One over the longest side of the bounding box.
    pub scale: f64,
}

impl UnitFrame {
    /// A point of the mesh's space in the unit cube.
    pub fn to_unit(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| (p[k] - self.centre[k]) * self.scale)
    }
}

/// Edge and vertex counts: what tells a closed surface from an open one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topology {
    /// Vertices used by at least one triangle.
    pub vertices: usize,
    /// Distinct edges.
    pub edges: usize,
    /// Triangles.
    pub faces: usize,
    /// Edges with one triangle.
    pub boundary_edges: usize,
    /// Edges with more than two triangles.
    pub non_manifold_edges: usize,
}

impl Topology {
    /// V - E + F.
    pub fn euler_characteristic(&self) -> i64 {
        self.vertices as i64 - self.edges as i64 + self.faces as i64
    }

    /// Every edge has exactly two triangles.
    pub fn is_closed(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0
    }
}

/// How far a mesh is from enclosing a solid: its open boundary and what the winding
/// number says on either side of its surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Openness {
    /// Edges with one triangle.
    pub boundary_edges: usize,
    /// Edges with more than two triangles.
    pub non_manifold_edges: usize,
    /// The length of the boundary edges over the square root of the surface area: about
    /// 4 for a square sheet, 0 for a closed surface, about 1.4 for the Stanford bunny's
    /// holes at the base.
    pub boundary_ratio: f64,
    /// Of up to 256 spread vertices, the fraction where the winding number a short step
    /// behind the surface is over 0.75 and a step in front under 0.25: 1 where the mesh
    /// encloses a solid, near 0 on a sheet.
    pub enclosed_fraction: f64,
}

impl Openness {
    /// An open sheet rather than a solid with holes: a boundary longer than 2.5 times
    /// the square root of the area (a disc's is 3.5, a hemisphere's 2.5 to 3, the holes
    /// of a scan's base under 1.6), or inside and outside told apart at under 80% of the vertices probed.
    pub fn is_sheet(&self) -> bool {
        self.boundary_ratio > 2.5 || self.enclosed_fraction < 0.8
    }
}

impl PolygonMesh {
    /// The open boundary and the winding-number test of [`Openness`].
    pub fn openness(&self) -> Openness {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.triangles.len() * 2);
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let length: f64 = edges
            .iter()
            .filter(|(_, c)| **c == 1)
            .map(|((a, b), _)| {
                let d = sub(self.positions[*a as usize], self.positions[*b as usize]);
                dot(d, d).sqrt()
            })
            .fold(0.0, |a, b| a + b);
        let area = self.area();
        let tree = WindingTree::new(self);
        let n = self.outward_normals_by(&tree);
        let (lo, hi) = self.bounds();
        let step = 1e-3 * (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let stride = (self.positions.len() / 256).max(1);
        let probes: Vec<usize> = (0..self.positions.len())
            .step_by(stride)
            .filter(|&i| n[i] != [0.0; 3])
            .collect();
        let enclosed = probes
            .par_iter()
            .filter(|&&i| {
                let at = |s: f64| [0, 1, 2].map(|k| self.positions[i][k] + s * step * n[i][k]);
                tree.winding_number(at(-1.0)).abs() > 0.75
                    && tree.winding_number(at(1.0)).abs() < 0.25
            })
            .count();
        Openness {
            boundary_edges: edges.values().filter(|c| **c == 1).count(),
            non_manifold_edges: edges.values().filter(|c| **c > 2).count(),
            boundary_ratio: length / area.sqrt().max(1e-300),
            enclosed_fraction: enclosed as f64 / probes.len().max(1) as f64,
        }
    }

    /// The boundary loops: each a cycle of vertices joined by edges with one triangle,
    /// in the direction the triangles run along them. A vertex where two holes touch
    /// starts or continues more than one loop; a chain that does not close (through a
    /// non-manifold edge) is returned as far as it goes. Loops are in the order of the
    /// first triangle that has one of their edges.
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let mut count: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.triangles.len() * 2);
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let directed: Vec<(u32, u32)> = self
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .filter(|&(a, b)| count[&(a.min(b), a.max(b))] == 1)
            .collect();
        // Outgoing boundary edges per vertex, as indices into `directed`.
        let mut out: HashMap<u32, Vec<usize>> = HashMap::new();
        for (i, &(a, _)) in directed.iter().enumerate() {
            out.entry(a).or_default().push(i);
        }
        let mut used = vec![false; directed.len()];
        let mut loops = Vec::new();
        for start in 0..directed.len() {
            if used[start] {
                continue;
            }
            used[start] = true;
            let (first, mut at) = directed[start];
            let mut cycle = vec![first];
            while at != first {
                cycle.push(at);
                let Some(&e) = out.get(&at).and_then(|es| es.iter().find(|&&e| !used[e])) else {
                    break;
                };
                used[e] = true;
                at = directed[e].1;
            }
            loops.push(cycle);
        }
        loops
    }

    /// The bounding box `(lo, hi)` of the positions.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        crate::vector::bounds(&self.positions)
    }

    /// The frame that centres the bounding box and scales its longest side to 1.
    pub fn unit_frame(&self) -> UnitFrame {
        let (lo, hi) = self.bounds();
        let side = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        UnitFrame {
            centre: [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k])),
            scale: if side > 0.0 { 1.0 / side } else { 1.0 },
        }
    }

    /// The mesh mapped through `frame`.
    pub fn transformed(&self, frame: &UnitFrame) -> PolygonMesh {
        PolygonMesh {
            positions: self.positions.iter().map(|p| frame.to_unit(*p)).collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Unit vertex normals, each the angle-weighted mean of its triangles' normals (the
    /// weighting that does not depend on how a face is split into triangles).
    pub fn vertex_normals(&self) -> Vec<[f64; 3]> {
        let mut n = vec![[0.0; 3]; self.positions.len()];
        for t in &self.triangles {
            let p = t.map(|i| self.positions[i as usize]);
            let face = unit(cross(sub(p[1], p[0]), sub(p[2], p[0])));
            for k in 0..3 {
                let e1 = unit(sub(p[(k + 1) % 3], p[k]));
                let e2 = unit(sub(p[(k + 2) % 3], p[k]));
                let angle = dot(e1, e2).clamp(-1.0, 1.0).acos();
                let v = &mut n[t[k] as usize];
                for c in 0..3 {
                    v[c] += angle * face[c];
                }
            }
        }
        n.into_iter().map(unit).collect()
    }

    /// Vertex normals turned outward. Which way is out is voted by the winding number
    /// a short step behind a spread of vertices (inside, it is near 1): that works for
    /// open meshes too, where the signed volume says nothing.
    pub fn outward_normals(&self) -> Vec<[f64; 3]> {
        self.outward_normals_by(&WindingTree::new(self))
    }

    /// [`PolygonMesh::outward_normals`] with the mesh's winding tree already built.
    pub fn outward_normals_by(&self, tree: &WindingTree<'_>) -> Vec<[f64; 3]> {
        let n = self.vertex_normals();
        let (lo, hi) = self.bounds();
        let step = 1e-3 * (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let stride = (self.positions.len() / 64).max(1);
        let (mut inward, mut outward) = (0, 0);
        for i in (0..self.positions.len()).step_by(stride) {
            if n[i] == [0.0; 3] {
                continue;
            }
            let behind = [0, 1, 2].map(|k| self.positions[i][k] - step * n[i][k]);
            let w = tree.winding_number(behind).abs();
            if w > 0.5 {
                outward += 1;
            } else {
                inward += 1;
            }
        }
        if inward > outward {
            n.into_iter().map(|v| v.map(|x| -x)).collect()
        } else {
            n
        }
    }

    /// The generalised winding number at `q` (1 inside a closed mesh wound outward, -1
    /// wound inward, 0 outside; a fraction near holes): the triangles' solid angles
    /// over 4 pi (Van Oosterom and Strackee's formula).
    pub fn winding_number(&self, q: [f64; 3]) -> f64 {
        let sum: f64 = (0..self.triangles.len())
            .map(|t| 2.0 * solid_angle_half(self, t, q))
            .sum();
        sum / (4.0 * std::f64::consts::PI)
    }

    /// The surface area: the triangles' areas summed.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| 0.5 * dot(self.face_normal(t), self.face_normal(t)).sqrt())
            .sum()
    }

    /// Twice each triangle's area times its unit normal: the cross product of its edges.
    pub fn face_normal(&self, t: usize) -> [f64; 3] {
        let p = self.triangles[t].map(|i| self.positions[i as usize]);
        cross(sub(p[1], p[0]), sub(p[2], p[0]))
    }

    /// The signed volume (positive when the triangles wind outward).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| self.positions[i as usize]);
                dot(p[0], cross(p[1], p[2])) / 6.0
            })
            .sum()
    }

    /// Counts of vertices, edges, faces and edges with other than two faces.
    pub fn topology(&self) -> Topology {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.triangles.len() * 2);
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                used[a as usize] = true;
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        Topology {
            vertices: used.iter().filter(|u| **u).count(),
            edges: edges.len(),
            faces: self.triangles.len(),
            boundary_edges: edges.values().filter(|c| **c == 1).count(),
            non_manifold_edges: edges.values().filter(|c| **c > 2).count(),
        }
    }

    /// A box of half-sides `half` about the origin, turned by the rotation `r`
    /// (row-major), two triangles a face wound outward: the test solids with flat faces.
    pub fn cuboid(half: [f64; 3], r: [[f64; 3]; 3]) -> PolygonMesh {
        let turn = |p: [f64; 3]| r.map(|row| row[0] * p[0] + row[1] * p[1] + row[2] * p[2]);
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        PolygonMesh {
            positions: (0..8)
                .map(|i| turn([0, 1, 2].map(|k| if i >> k & 1 == 1 { half[k] } else { -half[k] })))
                .collect(),
            triangles: quads
                .iter()
                .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
                .collect(),
        }
    }

    /// The triangulated unit-radius icosphere subdivided `level` times, scaled by
    /// `radii` along the axes: the test solids whose conversion is one quadric.
    pub fn ellipsoid(radii: [f64; 3], level: u32) -> PolygonMesh {
        let (p, t) = crate::mesh::icosphere(level);
        PolygonMesh {
            positions: p
                .into_iter()
                .map(|v| [v[0] * radii[0], v[1] * radii[1], v[2] * radii[2]])
                .collect(),
            triangles: t,
        }
    }
}

impl PolygonMesh {
    /// A UV sphere of `radius` about the origin with `n` (at least 2) bands, wound
    /// outward.
    pub fn uv_sphere(n: usize, radius: f64) -> PolygonMesh {
        let mut positions = vec![[0.0, 0.0, radius], [0.0, 0.0, -radius]];
        for i in 1..n {
            let th = std::f64::consts::PI * i as f64 / n as f64;
            for j in 0..2 * n {
                let ph = std::f64::consts::PI * j as f64 / n as f64;
                positions.push([
                    radius * th.sin() * ph.cos(),
                    radius * th.sin() * ph.sin(),
                    radius * th.cos(),
                ]);
            }
        }
        let ring = |i: usize, j: usize| (2 + (i - 1) * 2 * n + j % (2 * n)) as u32;
        let mut triangles = Vec::new();
        for j in 0..2 * n {
            triangles.push([0, ring(1, j), ring(1, j + 1)]);
            triangles.push([1, ring(n - 1, j + 1), ring(n - 1, j)]);
            for i in 1..n - 1 {
                triangles.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
                triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
            }
        }
        PolygonMesh {
            positions,
            triangles,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_icosphere_is_closed_with_euler_characteristic_two() {
        let m = PolygonMesh::ellipsoid([1.0, 2.0, 3.0], 2);
        let t = m.topology();
        assert!(t.is_closed());
        assert_eq!(t.euler_characteristic(), 2);
        // Outward winding: positive volume, close to the ellipsoid's 4/3 pi abc.
        let v = m.signed_volume();
        assert!(v > 0.9 * 8.0 * std::f64::consts::PI && v < 8.0 * std::f64::consts::PI);
        // Vertex normals of a sphere point along the position.
        let s = PolygonMesh::ellipsoid([1.0; 3], 3);
        for (p, n) in s.positions.iter().zip(s.vertex_normals()) {
            assert!(dot(*p, n) > 0.999, "{p:?} {n:?}");
        }
    }

    #[test]
    fn a_sheet_is_told_from_a_solid_with_a_hole() {
        let ball = PolygonMesh::ellipsoid([1.0, 0.8, 0.6], 3);
        let o = ball.openness();
        assert_eq!((o.boundary_edges, o.non_manifold_edges), (0, 0));
        assert!(
            o.boundary_ratio == 0.0 && o.enclosed_fraction > 0.99,
            "{o:?}"
        );
        assert!(!o.is_sheet());
        // A few triangles gone: a hole, still a solid.
        let mut holed = ball.clone();
        holed.triangles.drain(0..6);
        let o = holed.openness();
        assert!(o.boundary_edges > 0 && !o.is_sheet(), "{o:?}");
        // Half the ball: a bowl, open on purpose.
        let mut bowl = ball.clone();
        bowl.triangles
            .retain(|t| t.iter().all(|&i| ball.positions[i as usize][2] > -0.05));
        assert!(bowl.openness().is_sheet(), "{:?}", bowl.openness());
        // A flat square sheet of zero thickness.
        let n = 10;
        let sheet = PolygonMesh {
            positions: (0..=n)
                .flat_map(|i| (0..=n).map(move |j| [i as f64, j as f64, 0.0]))
                .collect(),
            triangles: (0..n)
                .flat_map(|i| {
                    (0..n).flat_map(move |j| {
                        let v = |a: u32, b: u32| a * (n + 1) + b;
                        [
                            [v(i, j), v(i + 1, j), v(i + 1, j + 1)],
                            [v(i, j), v(i + 1, j + 1), v(i, j + 1)],
                        ]
                    })
                })
                .collect(),
        };
        let o = sheet.openness();
        assert_eq!(o.boundary_edges, 4 * n as usize);
        assert!((o.boundary_ratio - 4.0).abs() < 1e-9, "{o:?}");
        assert!(o.is_sheet());
    }

    #[test]
    fn the_boundary_loops_of_a_conversion_mesh_with_two_holes_are_its_two_rims() {
        let ball = PolygonMesh::ellipsoid([1.0; 3], 3);
        assert!(ball.boundary_loops().is_empty());
        let mut holed = ball.clone();
        // A cap off the top and a smaller one off the bottom.
        holed.triangles.retain(|t| {
            let z = t.map(|i| ball.positions[i as usize][2]);
            !(z.iter().all(|&z| z > 0.7) || z.iter().all(|&z| z < -0.85))
        });
        let loops = holed.boundary_loops();
        assert_eq!(loops.len(), 2, "{loops:?}");
        let boundary = holed.topology().boundary_edges;
        assert_eq!(loops.iter().map(Vec::len).sum::<usize>(), boundary);
        for l in &loops {
            // Each loop is a cycle of distinct vertices on one rim.
            let mut sorted = l.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), l.len());
            let z: Vec<f64> = l.iter().map(|&i| ball.positions[i as usize][2]).collect();
            let top = z[0] > 0.0;
            for (k, &zk) in z.iter().enumerate() {
                assert_eq!(zk > 0.0, top);
                // The rim's vertices belong to a removed triangle.
                assert!(if top { zk > 0.7 } else { zk < -0.85 }, "{zk}");
                // Consecutive vertices share a triangle edge with one triangle.
                let (a, b) = (l[k], l[(k + 1) % l.len()]);
                let n = holed
                    .triangles
                    .iter()
                    .filter(|t| t.contains(&a) && t.contains(&b))
                    .count();
                assert_eq!(n, 1, "{a} {b}");
            }
        }
    }

    #[test]
    fn the_unit_frame_puts_the_longest_side_at_one() {
        let m = PolygonMesh::ellipsoid([2.0, 1.0, 0.5], 1)
            .transformed(&PolygonMesh::ellipsoid([2.0, 1.0, 0.5], 1).unit_frame());
        let (lo, hi) = m.bounds();
        assert!((hi[0] - lo[0] - 1.0).abs() < 1e-12);
        assert!((hi[0] + lo[0]).abs() < 1e-12);
    }
}
