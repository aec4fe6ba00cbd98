//! Self-intersections of a triangle mesh and their repair. Marching tetrahedra with
//! vertices interpolated along grid edges cuts each tetrahedron by a plane of the
//! piecewise-linear field, so its mesh never crosses itself; moving vertices onto the
//! true surface (and onto creases) can fold neighbouring triangles through each other
//! where the surface bends within a cell. The repair moves the vertices of crossing
//! triangles back towards where the grid put them, halving the way each round, so a
//! vertex leaves the surface only as far as the fold needs.

use rayon::prelude::*;

use super::vector::{cross, dot, sub};

type V3 = [f64; 3];

/// `(b - a) x (c - a) . (d - a)`: positive when `d` is on the side `abc` turns
/// counter-clockwise towards.
fn orient(a: V3, b: V3, c: V3, d: V3) -> f64 {
    dot(cross(sub(b, a), sub(c, a)), sub(d, a))
}

/// Whether segment `pq` passes through triangle `abc`. Touching does not count: a
/// crease's vertices lie on one line, and the triangles on either side of it touch
/// along that line without crossing. The crossing point is taken on the segment and tested
/// against the triangle's edges in its plane, so nearly coplanar triangles, whose
/// orientation signs are rounding noise, are not reported unless they overlap.
/// `sp` and `sq` are the orientations of `p` and `q` against the triangle.
fn crossing_inside(p: V3, q: V3, sp: f64, sq: f64, [a, b, c]: [V3; 3]) -> bool {
    if !((sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0)) {
        return false;
    }
    let s = sp / (sp - sq);
    let x = [0, 1, 2].map(|k| p[k] + s * (q[k] - p[k]));
    let n = cross(sub(b, a), sub(c, a));
    [(a, b), (b, c), (c, a)]
        .iter()
        .all(|&(u, v)| dot(cross(sub(v, u), sub(x, u)), n) > 0.0)
}

/// Whether two triangles cross: an edge of one meets the other (coplanar overlaps are
/// not counted; a closed surface's flat faces do not overlap). Each corner's side of
/// the other triangle's plane is found once: when all of one triangle's corners are on
/// one side, none of its edges can pass through the other, and most pairs end there.
pub fn triangles_cross(s: [V3; 3], t: [V3; 3]) -> bool {
    let edges_through = |s: [V3; 3], t: [V3; 3]| {
        let side = s.map(|p| orient(t[0], t[1], t[2], p));
        if (side.iter().all(|&x| x >= 0.0)) || side.iter().all(|&x| x <= 0.0) {
            return false;
        }
        (0..3).any(|k| crossing_inside(s[k], s[(k + 1) % 3], side[k], side[(k + 1) % 3], t))
    };
    edges_through(s, t) || edges_through(t, s)
}

/// The pairs of triangles with no vertex in common that cross (as Open3D's
/// `get_self_intersecting_triangles` counts them), each once, sorted.
pub fn crossing_pairs(pos: &[V3], tris: &[[u32; 3]]) -> Vec<(u32, u32)> {
    crossing_pairs_among(pos, tris, None)
}

/// As [`crossing_pairs`], only pairs with a triangle of `near` (flagged by vertex).
fn crossing_pairs_among(pos: &[V3], tris: &[[u32; 3]], near: Option<&[bool]>) -> Vec<(u32, u32)> {
    if tris.is_empty() {
        return Vec::new();
    }
    let boxes: Vec<(V3, V3)> = tris
        .par_iter()
        .map(|t| {
            let p = t.map(|v| pos[v as usize]);
            let lo = [0, 1, 2].map(|k| p[0][k].min(p[1][k]).min(p[2][k]));
            let hi = [0, 1, 2].map(|k| p[0][k].max(p[1][k]).max(p[2][k]));
            (lo, hi)
        })
        .collect();
    // Grid cells twice the mean longest extent of a triangle: most triangles fall in a
    // few cells, and a cell holds a few dozen.
    let mean = boxes
        .iter()
        .map(|(lo, hi)| (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max))
        .sum::<f64>()
        / boxes.len() as f64;
    let cell = 2.0 * mean.max(1e-300);
    let origin = boxes.iter().fold([f64::INFINITY; 3], |o, (lo, _)| {
        [0, 1, 2].map(|k| o[k].min(lo[k]))
    });
    let key = |p: V3| [0, 1, 2].map(|k| ((p[k] - origin[k]) / cell).floor().max(0.0) as u64);
    let mut entries: Vec<([u64; 3], u32)> = Vec::new();
    for (i, (lo, hi)) in boxes.iter().enumerate() {
        let (a, b) = (key(*lo), key(*hi));
        // A triangle spanning very many cells (a sliver across the model) is rare;
        // it goes into every cell it spans all the same.
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    entries.push(([x, y, z], i as u32));
                }
            }
        }
    }
    entries.par_sort_unstable();
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut start = 0;
    for i in 1..=entries.len() {
        if i == entries.len() || entries[i].0 != entries[start].0 {
            groups.push((start, i));
            start = i;
        }
    }
    let flagged = |t: u32| near.is_none_or(|f| tris[t as usize].iter().any(|&v| f[v as usize]));
    let mut pairs: Vec<(u32, u32)> = groups
        .par_iter()
        .flat_map_iter(|&(s, e)| {
            let here = entries[s].0;
            let group = &entries[s..e];
            let mut found = Vec::new();
            for (x, &(_, i)) in group.iter().enumerate() {
                for &(_, j) in &group[x + 1..] {
                    let (ti, tj) = (tris[i as usize], tris[j as usize]);
                    if ti.iter().any(|v| tj.contains(v)) || !(flagged(i) || flagged(j)) {
                        continue;
                    }
                    let ((li, hi), (lj, hj)) = (boxes[i as usize], boxes[j as usize]);
                    if (0..3).any(|k| li[k] > hj[k] || lj[k] > hi[k]) {
                        continue;
                    }
                    // Counted in the cell of the boxes' overlap's low corner only.
                    if key([0, 1, 2].map(|k| li[k].max(lj[k]))) != here {
                        continue;
                    }
                    let (pi, pj) = (ti.map(|v| pos[v as usize]), tj.map(|v| pos[v as usize]));
                    if triangles_cross(pi, pj) {
                        found.push((i.min(j), i.max(j)));
                    }
                }
            }
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// What [`untangle`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Untangled {
    /// Crossing pairs found before the repair.
    pub crossings: usize,
    /// Vertices moved back towards their rest positions.
    pub moved: usize,
    /// Crossing pairs left after the repair.
    pub left: usize,
}

/// Rounds of halving before the vertices still crossing go all the way back.
const HALVINGS: usize = 6;

/// Removes crossings from a mesh whose vertices moved from `rest` (a placement without
/// crossings, same numbering) to `pos`: each round, the vertices of crossing
/// triangles and their neighbours come half the remaining way back towards `rest`;
/// after `HALVINGS` rounds they go back all the way.
pub fn untangle(pos: &mut [V3], rest: &[V3], tris: &[[u32; 3]]) -> Untangled {
    let target: Vec<V3> = pos.to_vec();
    let mut t = vec![1.0f64; pos.len()];
    let mut out = Untangled::default();
    let mut near: Option<Vec<bool>> = None;
    for round in 0..=HALVINGS + 2 {
        let pairs = crossing_pairs_among(pos, tris, near.as_deref());
        if round == 0 {
            out.crossings = pairs.len();
        }
        if pairs.is_empty() {
            break;
        }
        let mut hit = vec![false; pos.len()];
        for (a, b) in &pairs {
            for v in tris[*a as usize].iter().chain(&tris[*b as usize]) {
                hit[*v as usize] = true;
            }
        }
        // The one-ring too: a fold is a vertex with its neighbours, not a vertex alone.
        let mut grow = hit.clone();
        for tri in tris {
            if tri.iter().any(|&v| hit[v as usize]) {
                for &v in tri {
                    grow[v as usize] = true;
                }
            }
        }
        for (v, &g) in grow.iter().enumerate() {
            if !g {
                continue;
            }
            if t[v] == 1.0 {
                out.moved += 1;
            }
            t[v] = if round >= HALVINGS { 0.0 } else { 0.5 * t[v] };
            pos[v] = [0, 1, 2].map(|k| rest[v][k] + t[v] * (target[v][k] - rest[v][k]));
        }
        near = Some(grow);
    }
    out.left = crossing_pairs(pos, tris).len();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLAT: [V3; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn crossing_and_apart() {
        let through = [[0.2, 0.2, -1.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]];
        assert!(triangles_cross(FLAT, through));
        let beside = through.map(|p| [p[0] + 2.0, p[1], p[2]]);
        assert!(!triangles_cross(FLAT, beside));
        let above = FLAT.map(|p| [p[0], p[1], 0.5]);
        assert!(!triangles_cross(FLAT, above));
    }

    /// A vertex pushed through the opposite side of a thin slab is brought back.
    #[test]
    fn untangles_a_vertex_pushed_through() {
        // Two parallel triangles (top and bottom of a slab), not sharing vertices.
        let rest = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 0.1],
            [1.0, 0.0, 0.1],
            [0.0, 1.0, 0.1],
        ];
        let tris = [[0, 1, 2], [3, 5, 4]];
        assert!(crossing_pairs(&rest, &tris).is_empty());
        let mut pos = rest.clone();
        pos[3] = [0.2, 0.2, -0.5];
        assert_eq!(crossing_pairs(&pos, &tris), vec![(0, 1)]);
        let u = untangle(&mut pos, &rest, &tris);
        assert_eq!((u.crossings, u.left), (1, 0));
        assert!(crossing_pairs(&pos, &tris).is_empty());
    }
}
