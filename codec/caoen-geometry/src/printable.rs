//! Meshes a slicer accepts: closed, manifold, consistently wound, without zero-area
//! triangles or stray specks, with every vertex inside the model's box. Marching
//! tetrahedra gives a closed mesh by construction; projecting vertices onto the
//! surface and onto creases can pull neighbours onto one point or one line (zero-area
//! triangles), and a field with thin spikes leaves pieces a cell across. Degenerate
//! triangles are removed by edge collapses that keep the mesh manifold (the link
//! condition), tiny pieces are dropped, and what remains is checked.

use std::collections::HashMap;

use super::mesh::Mesh;
use super::vector::{cross, dot, norm, sub};

/// What [`make_printable`] changed and found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Repair {
    /// Vertices moved back into the box.
    pub clamped: usize,
    /// Edge collapses that removed zero-area triangles.
    pub collapsed: usize,
    /// Zero-area triangles left (a collapse would have broken the manifold).
    pub degenerate_left: usize,
    /// Vertices moved off another vertex they coincided with (in 32-bit floats) without
    /// sharing an edge: two sheets touching at a point, which a reader that welds
    /// corners by position would join into a non-manifold vertex.
    pub separated: usize,
    /// Connected pieces dropped for being tiny against the largest.
    pub pieces_dropped: usize,
    /// Connected pieces kept.
    pub pieces: usize,
    /// Edges not shared by exactly two consistently wound triangles.
    pub bad_edges: usize,
    /// Enclosed volume of what is kept.
    pub volume: f64,
    /// Grid cells along the longest side of the mesh this came from (set by the mesher).
    pub cells: usize,
    /// Vertices moved back off the surface to undo a fold (set by the mesher).
    pub untangled: usize,
    /// Pairs of triangles without a common vertex that cross (set by the mesher).
    pub crossings: usize,
}

/// A triangle's height over its longest edge: zero for a cap or a needle.
pub fn min_height(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let twice_area = norm(cross(sub(b, a), sub(c, a)));
    let longest = norm(sub(b, a)).max(norm(sub(c, b))).max(norm(sub(a, c)));
    if longest > 0.0 {
        twice_area / longest
    } else {
        0.0
    }
}

/// Signed volume of a closed, outward-wound mesh (or of its part `tris`).
pub fn volume(positions: &[[f64; 3]], tris: &[[u32; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            dot(a, cross(b, c)) / 6.0
        })
        .sum()
}

/// Edges not used exactly once in each direction (one-sided, over-shared or wound
/// against a neighbour), counted once per undirected edge.
pub fn bad_edges(tris: &[[u32; 3]]) -> usize {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let mut bad = std::collections::HashSet::new();
    for (&(a, b), &c) in &directed {
        if c != 1 || directed.get(&(b, a)) != Some(&1) {
            bad.insert((a.min(b), a.max(b)));
        }
    }
    bad.len()
}

/// Cleans `mesh` for printing: vertices clamped into `[lo, hi]`, triangles thinner
/// than `tolerance` collapsed away, pieces smaller than `min_fraction` of the largest
/// piece's volume dropped, unused vertices removed.
pub fn make_printable(
    mesh: Mesh,
    lo: [f64; 3],
    hi: [f64; 3],
    tolerance: f64,
    min_fraction: f64,
) -> (Mesh, Repair) {
    let mut rep = Repair::default();
    let Mesh {
        mut positions,
        mut normals,
        triangles,
        ..
    } = mesh;
    for p in positions.iter_mut() {
        let q = [0, 1, 2].map(|k| p[k].clamp(lo[k], hi[k]));
        if q != *p {
            rep.clamped += 1;
            *p = q;
        }
    }
    let (tris, collapsed, left) = collapse_degenerate(&positions, triangles, tolerance);
    rep.collapsed = collapsed;
    rep.degenerate_left = left;
    if left > 0 {
        rep.degenerate_left = lift_apexes(&mut positions, &normals, &tris, tolerance);
    }
    rep.separated = separate_coincident(&mut positions, &tris);
    let pieces = components(&tris);
    let volumes: Vec<f64> = pieces.iter().map(|c| volume(&positions, c).abs()).collect();
    let largest = volumes.iter().cloned().fold(0.0, f64::max);
    let mut kept = Vec::with_capacity(tris.len());
    for (c, v) in pieces.iter().zip(&volumes) {
        if *v < min_fraction * largest || *v == 0.0 {
            rep.pieces_dropped += 1;
        } else {
            rep.pieces += 1;
            kept.extend_from_slice(c);
        }
    }
    // Unused vertices out, the rest renumbered in their first use order.
    let mut map = vec![u32::MAX; positions.len()];
    let (mut ps, mut ns) = (Vec::new(), Vec::new());
    for t in kept.iter_mut() {
        for v in t.iter_mut() {
            let i = *v as usize;
            if map[i] == u32::MAX {
                map[i] = ps.len() as u32;
                ps.push(positions[i]);
                ns.push(normals.get(i).copied().unwrap_or([0.0; 3]));
            }
            *v = map[i];
        }
    }
    positions = ps;
    normals = ns;
    rep.bad_edges = bad_edges(&kept);
    rep.volume = volume(&positions, &kept);
    (
        Mesh {
            positions,
            normals,
            domain_points: Vec::new(),
            triangles: kept,
            corner_uvs: Vec::new(),
        },
        rep,
    )
}

/// The longest edge of triangle `t`: `k` for the edge from corner `k` to `k + 1`.
fn longest_edge(pos: &[[f64; 3]], t: &[u32; 3]) -> usize {
    let len = |a: u32, b: u32| norm(sub(pos[a as usize], pos[b as usize]));
    (0..3)
        .max_by(|&a, &b| {
            len(t[a], t[(a + 1) % 3])
                .partial_cmp(&len(t[b], t[(b + 1) % 3]))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0)
}

/// The last resort for a zero-area triangle no collapse or flip can remove (its
/// neighbours fold onto the same line): its apex, the vertex opposite the longest
/// edge, moves four tolerances along its normal, off the line. Returns the degenerate
/// triangles left.
fn lift_apexes(pos: &mut [[f64; 3]], normals: &[[f64; 3]], tris: &[[u32; 3]], tol: f64) -> usize {
    let thin = |pos: &[[f64; 3]], t: &[u32; 3]| {
        min_height(pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]) < tol
    };
    for t in tris {
        if !thin(pos, t) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        let longest = longest_edge(pos, t);
        let apex = t[(longest + 2) % 3] as usize;
        let n = normals.get(apex).copied().unwrap_or([0.0; 3]);
        let l = norm(n);
        if l > 0.0 {
            pos[apex] = [0, 1, 2].map(|k| pos[apex][k] + 4.0 * tol * n[k] / l);
        }
    }
    tris.iter()
        .filter(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || thin(pos, t))
        .count()
}

/// Moves every vertex that has the 32-bit position of an earlier one a hundredth of the
/// way towards the centre of its neighbours (inside its own sheet, off the other);
/// returns how many moved.
fn separate_coincident(pos: &mut [[f64; 3]], tris: &[[u32; 3]]) -> usize {
    let mut ring: Vec<([f64; 3], u32)> = vec![([0.0; 3], 0); pos.len()];
    let mut used = vec![false; pos.len()];
    for t in tris {
        for k in 0..3 {
            used[t[k] as usize] = true;
            for j in 1..3 {
                let (v, w) = (t[k] as usize, t[(k + j) % 3] as usize);
                let q = pos[w];
                for (acc, x) in ring[v].0.iter_mut().zip(q) {
                    *acc += x;
                }
                ring[v].1 += 1;
            }
        }
    }
    let mut moved = 0;
    for _ in 0..4 {
        let mut seen: HashMap<[u32; 3], u32> = HashMap::new();
        let mut again = false;
        for v in 0..pos.len() {
            if !used[v] {
                continue;
            }
            let key = pos[v].map(|x| (x as f32).to_bits());
            if seen.insert(key, v as u32).is_some() && ring[v].1 > 0 {
                let n = f64::from(ring[v].1);
                let c = ring[v].0.map(|x| x / n);
                pos[v] = [0, 1, 2].map(|d| pos[v][d] + 0.01 * (c[d] - pos[v][d]));
                moved += 1;
                again = true;
            }
        }
        if !again {
            break;
        }
    }
    moved
}

/// The triangles in edge-connected pieces.
fn components(tris: &[[u32; 3]]) -> Vec<Vec<[u32; 3]>> {
    let mut parent: Vec<usize> = (0..tris.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut by_edge: HashMap<(u32, u32), usize> = HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            match by_edge.entry((a.min(b), a.max(b))) {
                std::collections::hash_map::Entry::Occupied(e) => {
                    let (x, y) = (find(&mut parent, i), find(&mut parent, *e.get()));
                    parent[x] = y;
                }
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(i);
                }
            }
        }
    }
    let mut index: HashMap<usize, usize> = HashMap::new();
    let mut out: Vec<Vec<[u32; 3]>> = Vec::new();
    for (i, t) in tris.iter().enumerate() {
        let r = find(&mut parent, i);
        let k = *index.entry(r).or_insert_with(|| {
            out.push(Vec::new());
            out.len() - 1
        });
        out[k].push(*t);
    }
    out
}

/// Removes triangles whose height is below `tol` by collapsing one of their vertices
/// onto a neighbour (the apex onto the nearer end of the longest edge, so the other
/// vertices keep their places), only where the two vertices' common neighbours are
/// exactly the two triangles' third vertices (the collapse keeps a closed manifold),
/// or else by flipping the longest edge. Returns the triangles, the collapses and flips
/// made and the degenerate triangles left.
fn collapse_degenerate(
    pos: &[[f64; 3]],
    tris: Vec<[u32; 3]>,
    tol: f64,
) -> (Vec<[u32; 3]>, usize, usize) {
    let mut tris: Vec<Option<[u32; 3]>> = tris.into_iter().map(Some).collect();
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); pos.len()];
    for (i, t) in tris.iter().enumerate() {
        for &v in t.as_ref().expect("all present") {
            around[v as usize].push(i);
        }
    }
    let degenerate = |t: &[u32; 3]| {
        t[0] == t[1]
            || t[1] == t[2]
            || t[0] == t[2]
            || min_height(pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]) < tol
    };
    let neighbours = |around: &Vec<Vec<usize>>, tris: &Vec<Option<[u32; 3]>>, v: u32| {
        let mut n: Vec<u32> = around[v as usize]
            .iter()
            .filter_map(|&i| tris[i])
            .flat_map(|t| t.into_iter())
            .filter(|&w| w != v)
            .collect();
        n.sort_unstable();
        n.dedup();
        n
    };
    let mut work: Vec<usize> = (0..tris.len()).collect();
    let mut collapses = 0;
    let mut guard = 0usize;
    while let Some(i) = work.pop() {
        guard += 1;
        if guard > 50 * tris.len() + 1000 {
            break;
        }
        let Some(t) = tris[i] else { continue };
        if !degenerate(&t) {
            continue;
        }
        // Candidate collapses (from, onto), the preferred one first.
        let longest = longest_edge(pos, &t);
        let len = |a: u32, b: u32| norm(sub(pos[a as usize], pos[b as usize]));
        let (u, w, apex) = (t[longest], t[(longest + 1) % 3], t[(longest + 2) % 3]);
        let (near, far) = if len(apex, u) <= len(apex, w) {
            (u, w)
        } else {
            (w, u)
        };
        let candidates = [
            (apex, near),
            (near, apex),
            (apex, far),
            (far, apex),
            (u, w),
            (w, u),
        ];
        let mut done = false;
        for (from, onto) in candidates {
            if from == onto {
                continue;
            }
            let nf = neighbours(&around, &tris, from);
            let no = neighbours(&around, &tris, onto);
            let common: Vec<u32> = nf
                .iter()
                .filter(|v| no.binary_search(v).is_ok())
                .copied()
                .collect();
            // The triangles on edge (from, onto) and their third vertices.
            let on_edge: Vec<usize> = around[from as usize]
                .iter()
                .copied()
                .filter(|&k| tris[k].is_some_and(|s| s.contains(&onto)))
                .collect();
            let mut thirds: Vec<u32> = on_edge
                .iter()
                .filter_map(|&k| tris[k])
                .flat_map(|s| s.into_iter())
                .filter(|&x| x != from && x != onto)
                .collect();
            thirds.sort_unstable();
            thirds.dedup();
            if on_edge.len() != 2 || common != thirds || thirds.len() != 2 {
                continue;
            }
            // Collapsing must not flip a surviving triangle around `from`.
            let flips = around[from as usize].iter().any(|&k| {
                let Some(s) = tris[k] else { return false };
                if s.contains(&onto) {
                    return false;
                }
                let before = s.map(|x| pos[x as usize]);
                let after = s.map(|x| pos[if x == from { onto } else { x } as usize]);
                let n0 = cross(sub(before[1], before[0]), sub(before[2], before[0]));
                let n1 = cross(sub(after[1], after[0]), sub(after[2], after[0]));
                dot(n0, n1) < 0.0
            });
            if flips {
                continue;
            }
            for k in on_edge {
                tris[k] = None;
            }
            let moved: Vec<usize> = std::mem::take(&mut around[from as usize]);
            for k in moved {
                if let Some(s) = tris[k].as_mut() {
                    for x in s.iter_mut() {
                        if *x == from {
                            *x = onto;
                        }
                    }
                    around[onto as usize].push(k);
                    work.push(k);
                }
            }
            around[onto as usize].retain(|&k| tris[k].is_some());
            collapses += 1;
            done = true;
            break;
        }
        if done {
            continue;
        }
        // No collapse keeps the manifold: flip the longest edge instead (the apex of a
        // cap lies on it), making (apex, x) the diagonal of the quad with the triangle
        // x beyond it, if that edge is not there already.
        let beyond: Vec<usize> = around[u as usize]
            .iter()
            .copied()
            .filter(|&k| k != i && tris[k].is_some_and(|s| s.contains(&w)))
            .collect();
        let [k] = beyond[..] else { continue };
        let other = tris[k].expect("present");
        let Some(&x) = other.iter().find(|&&v| v != u && v != w) else {
            continue;
        };
        let exists = around[apex as usize]
            .iter()
            .any(|&m| tris[m].is_some_and(|s| s.contains(&x)));
        if exists || x == apex {
            continue;
        }
        // t winds u -> w -> apex; the triangle beyond winds w -> u -> x.
        let (t1, t2) = ([u, x, apex], [x, w, apex]);
        if degenerate(&t1) || degenerate(&t2) {
            continue;
        }
        tris[i] = Some(t1);
        tris[k] = Some(t2);
        around[w as usize].retain(|&m| m != i);
        around[u as usize].retain(|&m| m != k);
        around[x as usize].push(i);
        around[apex as usize].push(k);
        work.push(i);
        work.push(k);
        collapses += 1;
    }
    let out: Vec<[u32; 3]> = tris.into_iter().flatten().collect();
    let left = out.iter().filter(|t| degenerate(t)).count();
    (out, collapses, left)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::icosphere;

    fn sphere() -> Mesh {
        let (positions, triangles) = icosphere(2);
        Mesh {
            normals: positions.clone(),
            positions,
            triangles,
            ..Mesh::default()
        }
    }

    /// A vertex moved onto its neighbour (two zero-area triangles) is collapsed away,
    /// and the mesh stays closed with the same volume.
    #[test]
    fn collapses_a_vertex_moved_onto_a_neighbour() {
        let mut m = sphere();
        let t = m.triangles[0];
        m.positions[t[0] as usize] = m.positions[t[1] as usize];
        let before = volume(&m.positions, &m.triangles);
        let (out, rep) = make_printable(m, [-2.0; 3], [2.0; 3], 1e-9, 1e-3);
        assert_eq!(rep.bad_edges, 0);
        assert_eq!(rep.degenerate_left, 0);
        assert!(rep.collapsed >= 1);
        assert_eq!(out.triangles.len(), 20 * 16 - 2);
        assert!((volume(&out.positions, &out.triangles) - before).abs() < 1e-12);
    }

    /// A speck beside the model is dropped; one the size of the model is kept.
    #[test]
    fn drops_specks_keeps_pieces() {
        let big = sphere();
        let mut m = big.clone();
        for (scale, shift) in [(1e-2, 3.0), (0.9, -3.0)] {
            let base = m.positions.len() as u32;
            m.positions.extend(
                big.positions
                    .iter()
                    .map(|p| [p[0] * scale + shift, p[1] * scale, p[2] * scale]),
            );
            m.normals.extend(big.normals.iter().copied());
            m.triangles
                .extend(big.triangles.iter().map(|t| t.map(|v| v + base)));
        }
        let (out, rep) = make_printable(m, [-5.0; 3], [5.0; 3], 1e-9, 1e-3);
        assert_eq!((rep.pieces, rep.pieces_dropped), (2, 1));
        assert_eq!(out.triangles.len(), 2 * big.triangles.len());
        assert_eq!(rep.bad_edges, 0);
    }

    #[test]
    fn clamps_into_the_box_and_counts_open_edges() {
        let mut m = sphere();
        m.triangles.pop();
        let (out, rep) = make_printable(m, [-0.5; 3], [0.5; 3], 1e-12, 0.0);
        assert!(rep.clamped > 0);
        assert!(out
            .positions
            .iter()
            .all(|p| p.iter().all(|v| v.abs() <= 0.5)));
        assert_eq!(rep.bad_edges, 3);
    }
}
