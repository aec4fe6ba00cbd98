//! The inside of a closed triangle mesh as a field: the signed distance to the mesh,
//! positive inside. The nearest point comes from a bounding-volume hierarchy over the
//! triangles; the sign from the angle-weighted pseudo-normal of the nearest feature
//! (face, edge or vertex; Baerentzen and Aanaes), which is exact for a closed,
//! consistently oriented mesh. A distance function has Lipschitz constant 1, so its
//! bound over a box is the value at the centre plus or minus the half-diagonal.

use super::interval::{Aabb, Interval};
use caoen_geometry::bounds::Bounds;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::vector::{cross, dot, sub, unit};

/// Most triangles a mesh field may hold.
pub const MAX_TRIANGLES: usize = 2_000_000;

/// A node of the hierarchy: a box and either two children or a run of triangles.
#[derive(Debug, Clone, PartialEq)]
struct BvhNode {
    bounds: Bounds,
    /// Children's indices, or `(first, count)` of `order` for a leaf (`leaf` true).
    a: usize,
    b: usize,
    leaf: bool,
}

/// A closed, consistently oriented triangle mesh with what the signed distance needs.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshField {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Unit outward normal per triangle.
    face_normals: Vec<[f64; 3]>,
    /// Angle-weighted pseudo-normal per vertex.
    vertex_normals: Vec<[f64; 3]>,
    /// Per triangle and edge `k` (from corner `k` to `k + 1`): the sum of the two
    /// faces' normals.
    edge_normals: Vec<[[f64; 3]; 3]>,
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
    bounds: Aabb,
    /// The budget reservation of what the field holds, shared by its clones.
    _held: std::sync::Arc<caoen_base::budget::Reservation>,
}

/// The feature of a triangle the nearest point lies on.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Feature {
    Face,
    /// Edge from corner `k` to corner `k + 1`.
    Edge(usize),
    Vertex(usize),
}

/// The point of triangle `abc` nearest to `p`, and the feature it lies on (Ericson,
/// Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> ([f64; 3], Feature) {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return ([0, 1, 2].map(|k| a[k] + v * ab[k]), Feature::Edge(0));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return ([0, 1, 2].map(|k| a[k] + w * ac[k]), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (
            [0, 1, 2].map(|k| b[k] + w * (c[k] - b[k])),
            Feature::Edge(1),
        );
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (
        [0, 1, 2].map(|k| a[k] + ab[k] * v + ac[k] * w),
        Feature::Face,
    )
}

/// Why a mesh has no inside to measure.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshFieldError {
    /// No triangles, or more than the limit.
    #[error("{0} triangles: expected 1 to {MAX_TRIANGLES}")]
    TriangleCount(usize),
    /// An edge not used exactly once each way.
    #[error("the mesh is not closed and consistently oriented")]
    NotClosed,
    /// A vertex with an infinite or NaN coordinate.
    #[error("the mesh has non-finite vertices")]
    NonFinite,
    /// The memory budget does not hold the field.
    #[error("{0}")]
    OverBudget(#[from] caoen_base::budget::OverBudget),
}

/// Bytes a field holds per triangle, an upper bound: its corners, face normal, the
/// three edges' normals, at most one hierarchy node and its order entry.
const HELD_TRIANGLE_BYTES: u64 = 12 + 24 + 72 + std::mem::size_of::<BvhNode>() as u64 + 4;

/// Bytes per vertex: the position and the pseudo-normal.
const HELD_VERTEX_BYTES: u64 = 48;

/// Bytes per triangle of the building's hash maps of directed edges (three entries a
/// triangle, in tables of up to twice their entries, an old and a new table while one
/// grows).
const BUILD_TRIANGLE_BYTES: u64 = 160;

impl MeshField {
    /// The field of `mesh`, which must be closed with every edge used once each way
    /// (outward-facing triangles, anticlockwise seen from outside).
    pub fn new(mesh: &Mesh, limits: &caoen_base::budget::Limits) -> Result<Self, MeshFieldError> {
        let n = mesh.triangles.len();
        if n == 0 || n > MAX_TRIANGLES {
            return Err(MeshFieldError::TriangleCount(n));
        }
        let held = limits.reserve(
            || format!("the field of a {n}-triangle mesh"),
            HELD_VERTEX_BYTES * mesh.positions.len() as u64 + HELD_TRIANGLE_BYTES * n as u64,
        )?;
        limits.check(
            || format!("building the field of a {n}-triangle mesh"),
            BUILD_TRIANGLE_BYTES * n as u64,
        )?;
        if !mesh.is_closed_and_consistent() {
            return Err(MeshFieldError::NotClosed);
        }
        let positions = mesh.positions.clone();
        if positions.iter().flatten().any(|v| !v.is_finite()) {
            return Err(MeshFieldError::NonFinite);
        }
        let mut triangles = mesh.triangles.clone();
        // Outward winding: a positive enclosed volume (a surface's tessellation may run
        // either way round).
        let volume: f64 = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| positions[v as usize]);
                dot(a, cross(b, c))
            })
            .sum();
        if volume < 0.0 {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        let corner = |t: &[u32; 3], k: usize| positions[t[k] as usize];
        let face_normals: Vec<[f64; 3]> = triangles
            .iter()
            .map(|t| {
                unit(cross(
                    sub(corner(t, 1), corner(t, 0)),
                    sub(corner(t, 2), corner(t, 0)),
                ))
            })
            .collect();
        let mut vertex_normals = vec![[0.0; 3]; positions.len()];
        for (t, nf) in triangles.iter().zip(&face_normals) {
            for k in 0..3 {
                let (p, q, r) = (corner(t, k), corner(t, (k + 1) % 3), corner(t, (k + 2) % 3));
                let (u, v) = (unit(sub(q, p)), unit(sub(r, p)));
                let angle = dot(u, v).clamp(-1.0, 1.0).acos();
                let vn = &mut vertex_normals[t[k] as usize];
                for j in 0..3 {
                    vn[j] += angle * nf[j];
                }
            }
        }
        let mut by_edge = std::collections::HashMap::with_capacity(3 * n);
        for (i, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                by_edge.insert((t[k], t[(k + 1) % 3]), i);
            }
        }
        let edge_normals = triangles
            .iter()
            .zip(&face_normals)
            .map(|(t, nf)| {
                [0, 1, 2].map(|k| {
                    let twin = by_edge[&(t[(k + 1) % 3], t[k])];
                    let other = face_normals[twin];
                    [0, 1, 2].map(|j| nf[j] + other[j])
                })
            })
            .collect();
        let mut field = MeshField {
            bounds: Aabb::new([0.0; 3], [0.0; 3]),
            positions,
            triangles,
            face_normals,
            vertex_normals,
            edge_normals,
            nodes: Vec::new(),
            order: (0..n as u32).collect(),
            _held: std::sync::Arc::new(held),
        };
        field.build(0, n);
        let root = &field.nodes[0];
        field.bounds = Aabb::new(root.bounds.lo, root.bounds.hi);
        Ok(field)
    }

    /// Builds the node over `order[first..first + count]`, returning its index.
    fn build(&mut self, first: usize, count: usize) -> usize {
        let corners = self.order[first..first + count]
            .iter()
            .flat_map(|&i| self.triangles[i as usize])
            .map(|v| &self.positions[v as usize]);
        let bounds = Bounds::of(corners);
        let at = self.nodes.len();
        self.nodes.push(BvhNode {
            bounds,
            a: first,
            b: count,
            leaf: true,
        });
        if count <= 4 {
            return at;
        }
        // Median split along the box's longest axis, by triangle centres.
        let axis = bounds.longest_axis();
        let centre = |m: &MeshField, i: u32| {
            let t = m.triangles[i as usize];
            t.iter()
                .map(|&v| m.positions[v as usize][axis])
                .sum::<f64>()
        };
        let mut run: Vec<u32> = self.order[first..first + count].to_vec();
        run.sort_by(|&x, &y| centre(self, x).total_cmp(&centre(self, y)));
        self.order[first..first + count].copy_from_slice(&run);
        let half = count / 2;
        let left = self.build(first, half);
        let right = self.build(first + half, count - half);
        self.nodes[at] = BvhNode {
            bounds,
            a: left,
            b: right,
            leaf: false,
        };
        at
    }

    /// The nearest point of the mesh to `p`: (squared distance, point, triangle, feature).
    fn nearest(&self, p: [f64; 3]) -> (f64, [f64; 3], usize, Feature) {
        let mut best = (f64::INFINITY, p, 0, Feature::Face);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i];
            if node.bounds.distance2(p) >= best.0 {
                continue;
            }
            if node.leaf {
                for &t in &self.order[node.a..node.a + node.b] {
                    let tri = self.triangles[t as usize];
                    let [a, b, c] = tri.map(|v| self.positions[v as usize]);
                    let (q, f) = closest_on_triangle(p, a, b, c);
                    let d2 = dot(sub(p, q), sub(p, q));
                    if d2 < best.0 {
                        best = (d2, q, t as usize, f);
                    }
                }
                continue;
            }
            let (l, r) = (&self.nodes[node.a], &self.nodes[node.b]);
            let (dl, dr) = (l.bounds.distance2(p), r.bounds.distance2(p));
            // The nearer child is popped first.
            if dl < dr {
                stack.push(node.b);
                stack.push(node.a);
            } else {
                stack.push(node.a);
                stack.push(node.b);
            }
        }
        best
    }

    /// The signed distance (positive inside) and its gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (d2, q, t, feature) = self.nearest(p);
        let normal = match feature {
            Feature::Face => self.face_normals[t],
            Feature::Edge(k) => self.edge_normals[t][k],
            Feature::Vertex(k) => self.vertex_normals[self.triangles[t][k] as usize],
        };
        let d = d2.sqrt();
        let away = sub(p, q);
        let outside = dot(away, normal) > 0.0;
        // The unit vector from the nearest point outwards: the face's normal where the
        // nearest point is inside a face (the same vector, without the rounding of a
        // tiny difference); near an edge or a vertex, closer than rounding can resolve
        // (ray hits land there), the feature's pseudo-normal.
        let out = if feature == Feature::Face || d <= 1e-9 * self.bounds.longest() {
            unit(normal)
        } else {
            let g = away.map(|v| v / d);
            if outside {
                g
            } else {
                g.map(|v| -v)
            }
        };
        let g = out.map(|v| -v);
        if outside {
            (-d, g)
        } else {
            (d, g)
        }
    }

    /// Bounds of the field over a box (Lipschitz 1 about the centre).
    pub fn interval(&self, b: &Aabb) -> Interval {
        let (c, r) = (b.centre(), b.half_diagonal());
        let (v, _) = self.value_gradient(c);
        Interval::new(v - r, v + r)
    }

    /// The mesh's box, which holds the solid.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// How many triangles the field is made of.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
}
