//! A mesh of several parts (a teapot's body, lid and spout): split into its connected
//! parts, each classified on its own, since the boundary ratio of the whole adds up the
//! parts' small openings over one area. A mesh whose parts each enclose a solid is
//! converted part by part and the parts united.

use std::collections::HashMap;

use rayon::prelude::*;
use serde_json::{json, Value};

use crate::fit::Conversion;
use crate::polygon_mesh::Openness;
use crate::settings::{run_fit, ConvertJob, Event};
use crate::{PolygonMesh, WindingTree};

/// Most parts a mesh is converted as; more, and the mesh is classified whole.
pub const MAX_PARTS: usize = 32;

/// Nodes each part adds around its fitted function in the model file (its transform,
/// the intersection with its supports and the support planes), with the union's.
const PART_WRAPPER_NODES: usize = 10;

/// The mesh's connected parts (triangles joined through shared vertices, or vertices
/// at the same position), most triangles first, each with its own vertices.
pub fn connected_parts(mesh: &PolygonMesh) -> Vec<PolygonMesh> {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    let join = |parent: &mut Vec<u32>, a: u32, b: u32| {
        let (ra, rb) = (root(parent, a), root(parent, b));
        if ra != rb {
            parent[ra.max(rb) as usize] = ra.min(rb);
        }
    };
    // Vertices written twice (a seam of texture coordinates) join their parts.
    let mut same: HashMap<[u64; 3], u32> = HashMap::with_capacity(n);
    for (i, p) in mesh.positions.iter().enumerate() {
        let first = *same.entry(p.map(f64::to_bits)).or_insert(i as u32);
        join(&mut parent, first, i as u32);
    }
    for t in &mesh.triangles {
        join(&mut parent, t[0], t[1]);
        join(&mut parent, t[0], t[2]);
    }
    let mut part_of: HashMap<u32, usize> = HashMap::new();
    let mut parts: Vec<PolygonMesh> = Vec::new();
    let mut local: Vec<(usize, u32)> = vec![(usize::MAX, 0); n];
    for t in &mesh.triangles {
        let r = root(&mut parent, t[0]);
        let next = parts.len();
        let k = *part_of.entry(r).or_insert(next);
        if k == parts.len() {
            parts.push(PolygonMesh::default());
        }
        let part = &mut parts[k];
        let tri = t.map(|v| {
            if local[v as usize].0 != k {
                local[v as usize] = (k, part.positions.len() as u32);
                part.positions.push(mesh.positions[v as usize]);
            }
            local[v as usize].1
        });
        part.triangles.push(tri);
    }
    parts.sort_by_key(|p| std::cmp::Reverse(p.triangles.len()));
    parts
}

/// The parts of a mesh that is an open sheet as a whole, with each part's openness,
/// when it has 2 to [`MAX_PARTS`] parts and none is a sheet by itself; otherwise the
/// number of parts and of those found to be sheets (0 when there are too many to
/// classify).
pub fn solid_parts(mesh: &PolygonMesh) -> Result<Vec<(PolygonMesh, Openness)>, (usize, usize)> {
    let parts = connected_parts(mesh);
    let n = parts.len();
    if n > MAX_PARTS {
        return Err((n, 0));
    }
    let classified: Vec<(PolygonMesh, Openness)> = parts
        .into_iter()
        .map(|p| {
            let open = p.openness();
            (p, open)
        })
        .collect();
    let sheets = classified.iter().filter(|p| p.1.is_sheet()).count();
    if n < 2 || sheets > 0 {
        return Err((n, sheets));
    }
    Ok(classified)
}

/// The parts' triangles that lie on the surface of their union: without those whose
/// centre is inside another part (winding number over one half), which no view sees
/// and no point of the united model's surface is near.
pub fn visible(parts: &[(PolygonMesh, Openness)]) -> PolygonMesh {
    let trees: Vec<WindingTree<'_>> = parts.iter().map(|p| WindingTree::new(&p.0)).collect();
    let mut out = PolygonMesh::default();
    for (i, (part, _)) in parts.iter().enumerate() {
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&part.positions);
        let kept: Vec<[u32; 3]> = part
            .triangles
            .par_iter()
            .filter(|t| {
                let c = [0, 1, 2].map(|k| {
                    t.iter()
                        .map(|&v| part.positions[v as usize][k])
                        .sum::<f64>()
                        / 3.0
                });
                trees
                    .iter()
                    .enumerate()
                    .all(|(j, tree)| j == i || tree.winding_number(c).abs() <= 0.5)
            })
            .map(|t| t.map(|v| v + base))
            .collect();
        out.triangles.extend(kept);
    }
    out
}

/// Bytes the parts' own copies of a mesh's vertices and triangles take beside it, an
/// upper bound (vertices at the same position joined through a hash map while split).
pub fn parts_memory(mesh: &PolygonMesh) -> u64 {
    mesh.positions.len() as u64 * (24 + 16 + 48 + 32) + mesh.triangles.len() as u64 * 12
}

/// Fits each part with its share of `max_functions` and unites them: the union as the
/// model file `title` names, and the fits.
pub fn fit_parts(
    parts: &[(PolygonMesh, Openness)],
    job: &ConvertJob,
    max_functions: usize,
    title: &str,
    events: &mut dyn FnMut(Event<'_>),
) -> (Value, Vec<Conversion>) {
    let budget = max_functions.saturating_sub(parts.len() * PART_WRAPPER_NODES);
    let shares = shares(parts, budget.max(parts.len()));
    let mut models = Vec::with_capacity(parts.len());
    let mut fits = Vec::with_capacity(parts.len());
    for (i, ((part, open), share)) in parts.iter().zip(shares).enumerate() {
        events(Event::Note(&format!(
            "part {} of {}: {} triangles, {} boundary edges; {share} functions",
            i + 1,
            parts.len(),
            part.triangles.len(),
            open.boundary_edges
        )));
        let fit = run_fit(part, job, share, events);
        models.push(fit.model.to_frep_json(title, part.bounds())["model"].take());
        fits.push(fit);
    }
    let file = json!({
        "format": "caoen-frep/1",
        "name": title,
        "model": {"union": models, "a": 1},
        "material": {"colour": [0.85, 0.8, 0.72]},
    });
    (file, fits)
}

/// The functions of a budget of `budget` each part gets: a share by its vertices, at
/// least 1 (the base quadric); in all at most `budget` when it is at least the number
/// of parts.
pub fn shares(parts: &[(PolygonMesh, Openness)], budget: usize) -> Vec<usize> {
    let total: usize = parts.iter().map(|p| p.0.positions.len()).sum();
    parts
        .iter()
        .map(|p| (budget * p.0.positions.len() / total.max(1)).max(1))
        .collect::<Vec<_>>()
        .into_iter()
        .scan(budget, |left, s| {
            let s = s.min(*left).max(1);
            *left = left.saturating_sub(s);
            Some(s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_split_by_shared_vertices_and_positions() {
        let a = PolygonMesh::ellipsoid([0.3, 0.3, 0.3], 2);
        let mut mesh = a.clone();
        let n = a.positions.len() as u32;
        // A second ball with its own vertices, another beside it sharing positions with
        // the first only through duplicated vertices.
        mesh.positions
            .extend(a.positions.iter().map(|p| [p[0] + 1.0, p[1], p[2]]));
        mesh.triangles
            .extend(a.triangles.iter().map(|t| t.map(|v| v + n)));
        mesh.positions.extend(a.positions.iter().copied());
        mesh.triangles
            .extend(a.triangles[..10].iter().map(|t| t.map(|v| v + 2 * n)));
        let parts = connected_parts(&mesh);
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].triangles.len(), a.triangles.len() + 10);
        assert_eq!(parts[1].positions.len(), a.positions.len());
        assert!(parts[1].topology().is_closed());
    }
}
