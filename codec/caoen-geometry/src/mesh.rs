//! Triangle meshes: the type every mesher fills and every mesh consumer reads, the
//! subdivided icosahedron, and checks of closedness and area.

use super::vector::{cross, norm, normalise, sub};

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

impl Mesh {
    /// The bounding box `(lo, hi)` of the positions.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        super::vector::bounds(&self.positions)
    }

    /// The bytes the mesh's vectors hold (a domain point counted with its vector's
    /// header and the allocator's overhead), for reservations against the budget.
    pub fn heap_bytes(&self) -> u64 {
        let points: usize = self.domain_points.iter().map(|p| 40 + 8 * p.len()).sum();
        (24 * (self.positions.len() + self.normals.len())
            + points
            + 12 * self.triangles.len()
            + 48 * self.corner_uvs.len()) as u64
    }

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
        0.5 * norm(cross(sub(b, a), sub(c, a)))
    }
}
