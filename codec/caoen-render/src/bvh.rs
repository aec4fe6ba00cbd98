//! A bounding-volume hierarchy over a triangle mesh for ray queries: the geometry
//! secondary rays (shadows, reflection, refraction) meet where an object is drawn as a
//! mesh, and the first guess of a ray's crossing with a Cao En surface.

use caoen_geometry::bounds::Bounds;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::vector::{cross, dot, sub};

/// Triangles per leaf.
const LEAF: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: Bounds,
    /// Inner node: index of the second child (the first follows the node).
    /// Leaf: first index into `order`.
    a: u32,
    /// Leaf: triangle count; 0 marks an inner node.
    count: u32,
    /// Inner node: the axis it splits, for front-to-back traversal.
    axis: u8,
}

/// Where a ray meets a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter.
    pub t: f64,
    /// Triangle index.
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third corners.
    pub bary: [f64; 2],
}

/// Ray queries against a fixed triangle mesh.
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl TriangleBvh {
    /// Bytes the hierarchy of a mesh of `vertices` and `triangles` holds while it is
    /// built and after, an upper bound: its copies of the positions and triangles, at
    /// most two nodes and an order entry per triangle, and the build's centroids.
    pub fn bytes(vertices: usize, triangles: usize) -> u64 {
        let node = std::mem::size_of::<Node>() as u64;
        (vertices as u64)
            .saturating_mul(24)
            .saturating_add((triangles as u64).saturating_mul(12 + 2 * node + 4 + 24))
    }

    /// The hierarchy of `mesh`'s triangles (median splits along the longest axis of
    /// the centroids' box).
    pub fn new(mesh: &Mesh) -> Self {
        let mut bvh = TriangleBvh {
            positions: mesh.positions.clone(),
            triangles: mesh.triangles.clone(),
            nodes: Vec::with_capacity(2 * mesh.triangles.len() / LEAF + 1),
            order: (0..mesh.triangles.len() as u32).collect(),
        };
        let centroids: Vec<[f64; 3]> = bvh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| bvh.positions[i as usize]);
                [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
            })
            .collect();
        if !bvh.triangles.is_empty() {
            bvh.build(0, bvh.order.len(), &centroids);
        }
        bvh
    }

    fn build(&mut self, first: usize, count: usize, centroids: &[[f64; 3]]) -> usize {
        let (mut bounds, mut spread) = (Bounds::EMPTY, Bounds::EMPTY);
        for &t in &self.order[first..first + count] {
            for &v in &self.triangles[t as usize] {
                bounds.include(self.positions[v as usize]);
            }
            spread.include(centroids[t as usize]);
        }
        let at = self.nodes.len();
        self.nodes.push(Node {
            bounds,
            a: first as u32,
            count: count as u32,
            axis: 0,
        });
        if count <= LEAF {
            return at;
        }
        let axis = spread.longest_axis();
        let half = count / 2;
        self.order[first..first + count].select_nth_unstable_by(half, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        self.build(first, half, centroids);
        let second = self.build(first + half, count - half, centroids);
        self.nodes[at].a = second as u32;
        self.nodes[at].count = 0;
        self.nodes[at].axis = axis as u8;
        at
    }

    /// The nearest crossing with `t` in `(t_min, t_max)` of the ray `origin + t dir`.
    pub fn hit(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        t_min: f64,
        t_max: f64,
    ) -> Option<TriangleHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = dir.map(|d| 1.0 / d);
        let mut best: Option<TriangleHit> = None;
        let mut limit = t_max;
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if !node.bounds.meets_ray(origin, inv, t_min, limit) {
                continue;
            }
            if node.count > 0 {
                let first = node.a as usize;
                for &tri in &self.order[first..first + node.count as usize] {
                    if let Some((t, bary)) = self.triangle(tri, origin, dir) {
                        if t > t_min && t < limit {
                            limit = t;
                            best = Some(TriangleHit {
                                t,
                                triangle: tri,
                                bary,
                            });
                        }
                    }
                }
            } else if top + 2 <= stack.len() {
                let (near, far) = if dir[node.axis as usize] >= 0.0 {
                    (stack[top] + 1, node.a)
                } else {
                    (node.a, stack[top] + 1)
                };
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        best
    }

    /// Moeller-Trumbore crossing of the ray's line with triangle `tri`.
    fn triangle(&self, tri: u32, origin: [f64; 3], dir: [f64; 3]) -> Option<(f64, [f64; 2])> {
        let [a, b, c] = self.triangles[tri as usize].map(|i| self.positions[i as usize]);
        let (e1, e2) = (sub(b, a), sub(c, a));
        let p = cross(dir, e2);
        let det = dot(e1, p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = sub(origin, a);
        let u = dot(s, p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = cross(s, e1);
        let v = dot(dir, q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        Some((dot(e2, q) * inv, [u, v]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_nearest_face_of_an_icosphere() {
        let (positions, triangles) = caoen_geometry::mesh::icosphere(3);
        let mesh = Mesh {
            normals: positions.clone(),
            domain_points: Vec::new(),
            corner_uvs: Vec::new(),
            positions,
            triangles,
        };
        let bvh = TriangleBvh::new(&mesh);
        // From outside along each axis: the crossing lies between the inscribed and
        // circumscribed radius of the faceted sphere, and the brute-force nearest agrees.
        for dir in [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.6, 0.0, 0.8]] {
            let origin = dir.map(|d: f64| -3.0 * d);
            let h = bvh.hit(origin, dir, 0.0, f64::INFINITY).unwrap();
            let brute = (0..mesh.triangles.len() as u32)
                .filter_map(|t| bvh.triangle(t, origin, dir).map(|x| x.0))
                .filter(|t| *t > 0.0)
                .fold(f64::INFINITY, f64::min);
            assert_eq!(h.t, brute);
            assert!(h.t >= 2.0 && h.t < 2.05, "{}", h.t);
            // From the centre: one crossing, at about the radius.
            let h = bvh.hit([0.0; 3], dir, 0.0, f64::INFINITY).unwrap();
            assert!(h.t > 0.95 && h.t <= 1.0);
        }
    }
}
