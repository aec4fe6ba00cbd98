//! The unsigned distance from a point to a mesh's triangles, through a bounding-volume
//! hierarchy (boxes, median splits, nearer child first): what thickening a sheet and
//! matching a model's parts to the mesh ask of it. Unlike the signed distance of the
//! F-rep mesh field, it needs no closed mesh.

use caoen_geometry::bounds::Bounds;
use caoen_geometry::vector::{dot, sub};

use crate::PolygonMesh;

/// A node of the hierarchy: a box and either two children or a run of triangles.
#[derive(Debug, Clone)]
struct Node {
    bounds: Bounds,
    /// Children's indices, or `(first, count)` of `order` for a leaf.
    a: u32,
    b: u32,
    leaf: bool,
}

/// A mesh's triangles arranged for distance queries.
#[derive(Debug, Clone)]
pub struct SurfaceDistance {
    corners: Vec<[[f64; 3]; 3]>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Bytes [`SurfaceDistance::new`] holds per triangle, an upper bound: the corners, the
/// order entry and at most one node (leaves hold up to four triangles).
pub const BYTES_PER_TRIANGLE: u64 = 72 + 4 + 64;

/// The point of triangle `abc` nearest to `p` (Ericson, Real-Time Collision Detection,
/// 5.1.5).
pub fn closest_on_triangle(p: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let at = |s: f64, t: f64| [0, 1, 2].map(|k| a[k] + s * ab[k] + t * ac[k]);
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return at(d1 / (d1 - d3), 0.0);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return at(0.0, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0, 1, 2].map(|k| b[k] + w * (c[k] - b[k]));
    }
    let denom = 1.0 / (va + vb + vc);
    at(vb * denom, vc * denom)
}

impl SurfaceDistance {
    /// The hierarchy over `mesh`'s triangles.
    pub fn new(mesh: &PolygonMesh) -> SurfaceDistance {
        let corners: Vec<[[f64; 3]; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| mesh.positions[v as usize]))
            .collect();
        let n = corners.len();
        let mut tree = SurfaceDistance {
            corners,
            nodes: Vec::with_capacity(n / 2 + 1),
            order: (0..n as u32).collect(),
        };
        if n > 0 {
            tree.build(0, n);
        }
        tree
    }

    fn build(&mut self, first: usize, count: usize) -> usize {
        let bounds = Bounds::of(
            self.order[first..first + count]
                .iter()
                .flat_map(|&i| self.corners[i as usize].iter()),
        );
        let at = self.nodes.len();
        self.nodes.push(Node {
            bounds,
            a: first as u32,
            b: count as u32,
            leaf: true,
        });
        if count <= 4 {
            return at;
        }
        let axis = bounds.longest_axis();
        let corners = &self.corners;
        let centre = |i: u32| corners[i as usize].iter().map(|c| c[axis]).sum::<f64>();
        let half = count / 2;
        self.order[first..first + count]
            .select_nth_unstable_by(half, |&x, &y| centre(x).total_cmp(&centre(y)));
        let left = self.build(first, half);
        let right = self.build(first + half, count - half);
        self.nodes[at] = Node {
            bounds,
            a: left as u32,
            b: right as u32,
            leaf: false,
        };
        at
    }

    /// The distance from `p` to the nearest triangle, and that triangle's nearest point
    /// (infinite and `p` for a mesh without triangles).
    pub fn nearest(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let mut best = (f64::INFINITY, p);
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if node.bounds.distance2(p) >= best.0 {
                continue;
            }
            if node.leaf {
                for &t in &self.order[node.a as usize..(node.a + node.b) as usize] {
                    let q = closest_on_triangle(p, self.corners[t as usize]);
                    let d = sub(p, q);
                    let d2 = dot(d, d);
                    if d2 < best.0 {
                        best = (d2, q);
                    }
                }
                continue;
            }
            let (l, r) = (&self.nodes[node.a as usize], &self.nodes[node.b as usize]);
            // The nearer child is popped first.
            if l.bounds.distance2(p) < r.bounds.distance2(p) {
                stack.extend([node.b, node.a]);
            } else {
                stack.extend([node.a, node.b]);
            }
        }
        (best.0.sqrt(), best.1)
    }

    /// The distance from `p` to the nearest triangle.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        self.nearest(p).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_distance_is_the_nearest_triangle_by_brute_force() {
        let mesh = PolygonMesh::ellipsoid([0.4, 0.3, 0.2], 2);
        let tree = SurfaceDistance::new(&mesh);
        for i in 0..200 {
            let f = i as f64;
            let p = [
                (f * 0.37).sin(),
                (f * 0.51).cos() * 0.7,
                (f * 0.13).sin() * 0.5,
            ];
            let brute = mesh
                .triangles
                .iter()
                .map(|t| {
                    let q = closest_on_triangle(p, t.map(|v| mesh.positions[v as usize]));
                    dot(sub(p, q), sub(p, q)).sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            assert!((tree.distance(p) - brute).abs() < 1e-12, "{p:?}");
        }
    }
}
