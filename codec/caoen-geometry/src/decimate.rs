//! Quadric-error decimation (Garland and Heckbert, 1997) of a closed mesh whose
//! vertices lie on a known surface: a grid mesh has as many triangles on a flat face as
//! on a curved one, and a slicer reads, stores and slices every one. Edges collapse
//! cheapest first, one end onto the other (a half-edge collapse, so every kept vertex
//! stays where the mesher put it, on the surface), each only if the mesh stays a
//! closed manifold (the link condition), no triangle flips or turns into a sliver, no
//! new triangle crosses another, and the new triangles stay within a distance of the
//! surface measured by the caller's distance estimate.

use std::collections::{HashMap, HashSet};

use super::mesh::Mesh;
use super::untangle::triangles_cross;
use super::vector::{cross, dot, norm, sub};
use super::vertex_queue::VertexQueue;

type V3 = [f64; 3];

/// A quadric `v^T A v + 2 b.v + c` as its ten coefficients.
#[derive(Debug, Clone, Copy, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    /// The squared distance to the plane through `p` with unit normal `n`, times `w`.
    fn plane(n: V3, p: V3, w: f64) -> Self {
        let d = -dot(n, p);
        let [a, b, c] = n;
        Quadric(
            [
                a * a,
                a * b,
                a * c,
                a * d,
                b * b,
                b * c,
                b * d,
                c * c,
                c * d,
                d * d,
            ]
            .map(|x| x * w),
        )
    }

    fn add(&mut self, o: &Quadric) {
        for (x, y) in self.0.iter_mut().zip(o.0) {
            *x += y;
        }
    }

    fn at(&self, [x, y, z]: V3) -> f64 {
        let q = &self.0;
        q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9]
    }
}

/// What [`decimate`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Decimated {
    /// Triangles before.
    pub before: usize,
    /// Edge collapses made.
    pub collapses: usize,
    /// The largest distance estimate at a checked point of a new triangle.
    pub deviation: f64,
}

/// The least twice-area over squared longest edge of a new triangle (0.5 for a grid's
/// right triangle), unless the triangles it replaces were worse: below it a collapse
/// makes a sliver and is refused.
const MIN_SHAPE: f64 = 2e-3;

/// The least cosine between a triangle's normal before and after a collapse: a larger
/// turn would fold the surface over itself or across an edge.
const MIN_TURN_COS: f64 = 0.5;

/// The weight of the pull of a vertex to its own place against its planes' (see
/// `decimate`): a collapse along a flat face costs this times the area times the
/// squared edge length.
const LENGTH_WEIGHT: f64 = 1e-4;

/// Below this shape (see [`MIN_SHAPE`]) a triangle's normal is not trusted.
const SLIVER: f64 = 1e-4;

fn normal(p: [V3; 3]) -> V3 {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

fn shape(p: [V3; 3]) -> f64 {
    let longest = norm(sub(p[1], p[0]))
        .max(norm(sub(p[2], p[1])))
        .max(norm(sub(p[0], p[2])));
    if longest > 0.0 {
        norm(normal(p)) / (longest * longest)
    } else {
        0.0
    }
}

/// Triangles by the grid cells their bounding boxes meet, for the crossing checks.
struct Grid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl Grid {
    fn span(&self, p: [V3; 3]) -> ([i64; 3], [i64; 3]) {
        let lo = [0, 1, 2].map(|k| (p[0][k].min(p[1][k]).min(p[2][k]) / self.cell).floor() as i64);
        let hi = [0, 1, 2].map(|k| (p[0][k].max(p[1][k]).max(p[2][k]) / self.cell).floor() as i64);
        (lo, hi)
    }

    fn insert(&mut self, t: u32, p: [V3; 3]) {
        let (lo, hi) = self.span(p);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    self.cells.entry([x, y, z]).or_default().push(t);
                }
            }
        }
    }

    /// Takes `t`, whose corners were `p`, out of its cells: lists of only the triangles
    /// there keep the crossing checks short as the triangles grow.
    fn remove(&mut self, t: u32, p: [V3; 3]) {
        let (lo, hi) = self.span(p);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(list) = self.cells.get_mut(&[x, y, z]) {
                        if let Some(i) = list.iter().position(|&o| o == t) {
                            list.swap_remove(i);
                        }
                    }
                }
            }
        }
    }

    /// Triangles listed in the cells `p`'s box meets, a triangle once per cell.
    fn near(&self, p: [V3; 3], out: &mut Vec<u32>) {
        let (lo, hi) = self.span(p);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(list) = self.cells.get(&[x, y, z]) {
                        out.extend_from_slice(list);
                    }
                }
            }
        }
    }
}

/// Decimates the closed, consistently wound `mesh` by half-edge collapses while every
/// new triangle's centre and edge midpoints are within `max_distance` of the surface by
/// `distance` (an estimate of the distance to the surface, such as `|f| / |grad f|`).
/// Vertices flagged in `keep` are never removed. Normals follow their vertices.
pub fn decimate(
    mesh: Mesh,
    distance: &(dyn Fn(V3) -> f64 + Sync),
    max_distance: f64,
    keep: &[bool],
) -> (Mesh, Decimated) {
    let Mesh {
        positions: pos,
        normals,
        triangles,
        ..
    } = mesh;
    let mut out = Decimated {
        before: triangles.len(),
        ..Decimated::default()
    };
    let n = pos.len();
    let mut tris: Vec<Option<[u32; 3]>> = triangles.into_iter().map(Some).collect();
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut quadric = vec![Quadric::default(); n];
    let mut mean_edge = 0.0;
    for (i, t) in tris.iter().enumerate() {
        let t = t.expect("all present");
        let p = t.map(|v| pos[v as usize]);
        let nr = normal(p);
        let area2 = norm(nr);
        mean_edge += norm(sub(p[1], p[0]));
        let q = if area2 > 0.0 {
            Quadric::plane(nr.map(|x| x / area2), p[0], area2)
        } else {
            Quadric::default()
        };
        for &v in &t {
            around[v as usize].push(i as u32);
            quadric[v as usize].add(&q);
        }
    }
    // A faint pull of each vertex to its own place, weighted by its area: on a flat
    // face every collapse costs nothing by the planes, and this makes the shortest
    // edges go first, which keeps the triangles' shapes.
    let mut area = vec![0.0f64; n];
    for t in tris.iter().flatten() {
        let a = norm(normal(t.map(|v| pos[v as usize]))) / 6.0;
        for &v in t {
            area[v as usize] += a;
        }
    }
    for (v, q) in quadric.iter_mut().enumerate() {
        let e = LENGTH_WEIGHT * area[v];
        let [x, y, z] = pos[v];
        q.add(&Quadric([
            e,
            0.0,
            0.0,
            -e * x,
            e,
            0.0,
            -e * y,
            e,
            -e * z,
            e * (x * x + y * y + z * z),
        ]));
    }
    if tris.is_empty() {
        return (
            Mesh {
                positions: pos,
                normals,
                ..Mesh::default()
            },
            out,
        );
    }
    mean_edge /= tris.len() as f64;
    let mut grid = Grid {
        cell: 2.0 * mean_edge.max(1e-300),
        cells: HashMap::new(),
    };
    for (i, t) in tris.iter().enumerate() {
        let t = t.expect("all present");
        grid.insert(i as u32, t.map(|v| pos[v as usize]));
    }
    let mut alive = vec![true; n];
    let neighbours = |around: &[Vec<u32>], tris: &[Option<[u32; 3]>], v: u32| {
        let mut s: Vec<u32> = around[v as usize]
            .iter()
            .filter_map(|&t| tris[t as usize])
            .flat_map(|t| t.into_iter())
            .filter(|&w| w != v)
            .collect();
        s.sort_unstable();
        s.dedup();
        s
    };
    let free = |v: u32| !keep.get(v as usize).copied().unwrap_or(false);
    // The cheapest collapse of `v` not refused as things stand.
    let best = |around: &[Vec<u32>],
                tris: &[Option<[u32; 3]>],
                q: &[Quadric],
                refused: &HashSet<(u32, u32)>,
                refused_at: &[Vec<(u32, u32)>],
                v: u32| {
        let mut found: Option<(f64, u32)> = None;
        // A pair refused is listed at its ends: most vertices have none.
        let listed = &refused_at[v as usize];
        // Each neighbour is met twice or more; the ties by id keep the choice independent
        // of the order.
        for &t in &around[v as usize] {
            let Some(t) = tris[t as usize] else { continue };
            for w in t {
                if w == v || (!listed.is_empty() && refused.contains(&(v, w))) {
                    continue;
                }
                let mut s = q[v as usize];
                s.add(&q[w as usize]);
                let c = s.at(pos[w as usize]).max(0.0);
                if found.is_none_or(|(f, fw)| c < f || (c == f && w < fw)) {
                    found = Some((c, w));
                }
            }
        }
        found
    };
    // Candidates refused as things stood, listed at both their ends: a collapse nearby
    // may make them possible, and only then are they tried again.
    let mut refused: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    let mut refused_pairs: HashSet<(u32, u32)> = HashSet::new();
    // Each vertex's cheapest collapse, cheapest first (ties by vertex id, so the order
    // and the result depend on nothing but the mesh).
    let mut queue = VertexQueue::new(n);
    let mut onto = vec![0u32; n];
    macro_rules! enqueue {
        ($v:expr) => {{
            let v: u32 = $v;
            if free(v) {
                let found = best(&around, &tris, &quadric, &refused_pairs, &refused, v);
                if let Some((_, w)) = found {
                    onto[v as usize] = w;
                }
                queue.set(v, found.map(|(c, _)| c));
            }
        }};
    }
    for v in 0..n as u32 {
        enqueue!(v);
    }
    let mut near = Vec::new();
    let mut seen = vec![0u32; tris.len()];
    let mut check = 0u32;
    while let Some((_, a)) = queue.pop() {
        let b = onto[a as usize];
        if !alive[a as usize] {
            continue;
        }
        if !alive[b as usize] {
            enqueue!(a);
            continue;
        }
        macro_rules! refuse {
            () => {{
                if refused_pairs.insert((a, b)) {
                    refused[a as usize].push((a, b));
                    refused[b as usize].push((a, b));
                }
                enqueue!(a);
            }};
        }
        // The link condition: the ends' common neighbours are the edge's two apexes.
        let on_edge: Vec<u32> = around[a as usize]
            .iter()
            .copied()
            .filter(|&t| tris[t as usize].is_some_and(|s| s.contains(&b)))
            .collect();
        if on_edge.len() != 2 {
            refuse!();
            continue;
        }
        // The triangles that change, as they would be.
        let moved: Vec<(u32, [u32; 3])> = around[a as usize]
            .iter()
            .filter(|t| !on_edge.contains(t))
            .filter_map(|&t| tris[t as usize].map(|s| (t, s)))
            .map(|(t, s)| (t, s.map(|v| if v == a { b } else { v })))
            .collect();
        let ring_shape = moved
            .iter()
            .map(|&(t, _)| shape(tris[t as usize].expect("present").map(|v| pos[v as usize])))
            .fold(f64::INFINITY, f64::min);
        let ring_normal = moved.iter().fold([0.0; 3], |acc, &(t, _)| {
            let nr = normal(tris[t as usize].expect("present").map(|v| pos[v as usize]));
            [0, 1, 2].map(|k| acc[k] + nr[k])
        });
        // The shapes first: they are cheap, and most refusals are made by the distance.
        let shaped = moved.iter().all(|&(t, s)| {
            let old = tris[t as usize].expect("present").map(|v| pos[v as usize]);
            let new = s.map(|v| pos[v as usize]);
            let (n0, n1) = (normal(old), normal(new));
            let (l0, l1) = (norm(n0), norm(n1));
            if !(l1 > 0.0) || shape(new) < MIN_SHAPE.min(ring_shape) {
                return false;
            }
            // A sliver's normal is rounding noise: its ring's stands in for it.
            let (n0, l0) = if shape(old) < SLIVER {
                (ring_normal, norm(ring_normal))
            } else {
                (n0, l0)
            };
            !(l0 > 0.0 && dot(n0, n1) < MIN_TURN_COS * l0 * l1)
        });
        let mut worst = 0.0f64;
        let ok = shaped
            && moved.iter().all(|&(_, s)| {
                let new = s.map(|v| pos[v as usize]);
                let centre = [0, 1, 2].map(|k| (new[0][k] + new[1][k] + new[2][k]) / 3.0);
                let mid = |i: usize, j: usize| [0, 1, 2].map(|k| 0.5 * (new[i][k] + new[j][k]));
                [centre, mid(0, 1), mid(1, 2), mid(2, 0)].iter().all(|&p| {
                    let d = distance(p).abs();
                    worst = worst.max(d);
                    d <= max_distance
                })
            });
        if !ok {
            refuse!();
            continue;
        }
        let na = neighbours(&around, &tris, a);
        let nb = neighbours(&around, &tris, b);
        let common: Vec<u32> = na
            .iter()
            .filter(|v| nb.binary_search(v).is_ok())
            .copied()
            .collect();
        let mut apexes: Vec<u32> = on_edge
            .iter()
            .flat_map(|&t| tris[t as usize].expect("present"))
            .filter(|&v| v != a && v != b)
            .collect();
        apexes.sort_unstable();
        if common != apexes || apexes.len() != 2 || apexes[0] == apexes[1] {
            refuse!();
            continue;
        }
        // An apex left with two neighbours would leave two triangles back to back.
        if apexes
            .iter()
            .any(|&v| neighbours(&around, &tris, v).len() <= 3)
        {
            refuse!();
            continue;
        }
        // No new triangle may cross a triangle it shares no vertex with.
        let crosses = moved.iter().any(|&(t, s)| {
            let new = s.map(|v| pos[v as usize]);
            near.clear();
            grid.near(new, &mut near);
            check = check.wrapping_add(1);
            if check == 0 {
                seen.fill(0);
                check = 1;
            }
            near.iter().any(|&o| {
                // A triangle in several cells is checked once.
                if seen[o as usize] == check {
                    return false;
                }
                seen[o as usize] = check;
                if o == t || on_edge.contains(&o) {
                    return false;
                }
                let Some(mut other) = tris[o as usize] else {
                    return false;
                };
                // A triangle that changes too is checked as it will be.
                if let Some(&(_, m)) = moved.iter().find(|m| m.0 == o) {
                    other = m;
                }
                if other.iter().any(|v| s.contains(v)) {
                    return false;
                }
                triangles_cross(new, other.map(|v| pos[v as usize]))
            })
        });
        if crosses {
            refuse!();
            continue;
        }
        // Collapse.
        for &t in on_edge.iter().chain(moved.iter().map(|(t, _)| t)) {
            let old = tris[t as usize].expect("present");
            grid.remove(t, old.map(|v| pos[v as usize]));
        }
        for &t in &on_edge {
            tris[t as usize] = None;
        }
        for &(t, s) in &moved {
            tris[t as usize] = Some(s);
            around[b as usize].push(t);
            grid.insert(t, s.map(|v| pos[v as usize]));
        }
        around[a as usize].clear();
        around[b as usize].retain(|&t| tris[t as usize].is_some());
        for &v in &apexes {
            around[v as usize].retain(|&t| tris[t as usize].is_some());
        }
        alive[a as usize] = false;
        let qa = quadric[a as usize];
        quadric[b as usize].add(&qa);
        out.collapses += 1;
        out.deviation = out.deviation.max(worst);
        // The costs of the edges at `b` changed (its quadric grew), so its ring's best
        // collapses may have; those refused around the collapse are tried again.
        let mut again = neighbours(&around, &tris, b);
        again.push(b);
        for r in again.clone() {
            for (v, w) in std::mem::take(&mut refused[r as usize]) {
                if refused_pairs.remove(&(v, w)) {
                    again.push(v);
                }
            }
        }
        again.sort_unstable();
        again.dedup();
        for v in again {
            enqueue!(v);
        }
    }
    // Kept vertices renumbered in their first use order.
    let mut map = vec![u32::MAX; n];
    let (mut ps, mut ns, mut ts) = (Vec::new(), Vec::new(), Vec::new());
    for t in tris.into_iter().flatten() {
        ts.push(t.map(|v| {
            let i = v as usize;
            if map[i] == u32::MAX {
                map[i] = ps.len() as u32;
                ps.push(pos[i]);
                ns.push(normals.get(i).copied().unwrap_or([0.0; 3]));
            }
            map[i]
        }));
    }
    (
        Mesh {
            positions: ps,
            normals: ns,
            domain_points: Vec::new(),
            triangles: ts,
            corner_uvs: Vec::new(),
        },
        out,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::printable::bad_edges;

    /// A finely triangulated cube (each face an `n` x `n` grid of squares).
    fn cube(n: usize) -> Mesh {
        let mut pos = Vec::new();
        let mut index = HashMap::new();
        let mut tris = Vec::new();
        let mut id = |p: [i64; 3], pos: &mut Vec<V3>| {
            *index.entry(p).or_insert_with(|| {
                pos.push(p.map(|x| x as f64 / n as f64));
                (pos.len() - 1) as u32
            })
        };
        let n = n as i64;
        for axis in 0..3 {
            for side in [0, n] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                for i in 0..n {
                    for j in 0..n {
                        let at = |di: i64, dj: i64| {
                            let mut p = [0; 3];
                            p[axis] = side;
                            p[u] = i + di;
                            p[v] = j + dj;
                            p
                        };
                        let q = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|p| id(p, &mut pos));
                        // Outward: +axis faces wind u then v.
                        let (t1, t2) = if side == n {
                            ([q[0], q[1], q[2]], [q[0], q[2], q[3]])
                        } else {
                            ([q[0], q[2], q[1]], [q[0], q[3], q[2]])
                        };
                        tris.push(t1);
                        tris.push(t2);
                    }
                }
            }
        }
        Mesh {
            normals: vec![[0.0; 3]; pos.len()],
            positions: pos,
            triangles: tris,
            ..Mesh::default()
        }
    }

    /// A cube's faces become a few triangles each; it stays closed, with the same
    /// volume and corners.
    #[test]
    fn a_cube_becomes_a_few_triangles() {
        let m = cube(10);
        let before = crate::printable::volume(&m.positions, &m.triangles);
        assert!((before - 1.0).abs() < 1e-12);
        let box_distance = |p: V3| {
            (0..3)
                .map(|k| p[k].abs().min((p[k] - 1.0).abs()))
                .fold(f64::INFINITY, f64::min)
        };
        let (d, rep) = decimate(m, &box_distance, 1e-9, &[]);
        assert_eq!(bad_edges(&d.triangles), 0);
        assert!(d.triangles.len() <= 40, "{} triangles", d.triangles.len());
        assert!(rep.collapses > 0);
        let after = crate::printable::volume(&d.positions, &d.triangles);
        assert!((after - 1.0).abs() < 1e-9, "volume {after}");
        assert!(crate::untangle::crossing_pairs(&d.positions, &d.triangles).is_empty());
    }
}
