//! Meshes of F-rep solids: marching tetrahedra over the model's box, then every vertex
//! moved onto the surface by Newton steps along the gradient (linear interpolation on
//! a cell edge only approximates the crossing), with normals from the exact gradient.

use super::interval::Aabb;
use super::node::Node;
use crate::render::mesh::Mesh;
use crate::render::polygonise::polygonise;

/// Newton steps per vertex: each roughly squares the relative error of a smooth field.
const PROJECTION_STEPS: u32 = 4;

/// The mesh of `node`'s boundary within `bounds`, `cells` cells along the longest side.
pub fn mesh(node: &Node, bounds: &Aabb, cells: usize) -> Mesh {
    // One cell of margin so the surface never touches the grid's faces.
    let pad = bounds.longest() / cells.max(1) as f64;
    let b = bounds.padded(pad);
    // polygonise puts the inside where the field is negative.
    let mut m = polygonise(&|p| -node.value(p), b.lo, b.hi, cells);
    let limit = pad;
    for (p, n) in m.positions.iter_mut().zip(m.normals.iter_mut()) {
        let start = *p;
        for _ in 0..PROJECTION_STEPS {
            let (f, g) = node.value_gradient(*p);
            let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if g2.is_nan() || g2 <= 0.0 || !f.is_finite() {
                break;
            }
            let q = [0, 1, 2].map(|k| p[k] - f * g[k] / g2);
            // A step that leaves the vertex's cell would jump to another sheet of the
            // surface (near a sharp edge or a thin part): keep the last good point.
            let moved = (0..3)
                .map(|k| (q[k] - start[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if moved.is_nan() || moved > limit {
                break;
            }
            *p = q;
        }
        let (_, g) = node.value_gradient(*p);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if len > 0.0 {
            // Outward: f decreases outwards.
            *n = g.map(|v| -v / len);
        }
    }
    m
}
