//! Faces that are flat and square to an axis made exactly flat. Vertices projected onto
//! a plane by Newton steps land within rounding of it (1e-17 of a unit, either side),
//! and a slicer's or Open3D's triangle-triangle test, run on such nearly coplanar
//! triangles, takes the rounding for a tilt and reports crossings between triangles of
//! one flat face that lie far apart.

use std::collections::HashMap;

type V3 = [f64; 3];

/// Snaps each patch of triangles flat to within `tolerance` and square to an axis
/// (their corners' coordinates along it within `tolerance` of each other) onto one
/// plane: the patch's median coordinate. Returns the vertices moved.
pub fn snap_flat_faces(pos: &mut [V3], tris: &[[u32; 3]], tolerance: f64) -> usize {
    let mut moved = 0;
    for axis in [0usize, 1, 2] {
        // Flat triangles, grouped by their vertices into patches (union-find).
        let mut parent: HashMap<u32, u32> = HashMap::new();
        fn root(parent: &mut HashMap<u32, u32>, v: u32) -> u32 {
            let mut r = v;
            while let Some(&p) = parent.get(&r) {
                if p == r {
                    break;
                }
                r = p;
            }
            // Path halving keeps later finds short.
            let mut x = v;
            while x != r {
                let next = parent[&x];
                parent.insert(x, r);
                x = next;
            }
            r
        }
        for t in tris {
            let c = t.map(|v| pos[v as usize][axis]);
            let lo = c[0].min(c[1]).min(c[2]);
            let hi = c[0].max(c[1]).max(c[2]);
            if !(hi - lo <= tolerance) {
                continue;
            }
            for &v in t {
                parent.entry(v).or_insert(v);
            }
            let r0 = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let r = root(&mut parent, v);
                if r != r0 {
                    // The smaller id as the root: the patches do not depend on the order.
                    let (a, b) = (r.min(r0), r.max(r0));
                    parent.insert(b, a);
                }
            }
        }
        let mut patches: HashMap<u32, Vec<u32>> = HashMap::new();
        let mut members: Vec<u32> = parent.keys().copied().collect();
        members.sort_unstable();
        for v in members {
            let r = root(&mut parent, v);
            patches.entry(r).or_default().push(v);
        }
        let mut roots: Vec<u32> = patches.keys().copied().collect();
        roots.sort_unstable();
        for r in roots {
            let vs = &patches[&r];
            // A patch of one triangle is a sliver square to the axis, not a face.
            if vs.len() < 4 {
                continue;
            }
            let mut c: Vec<f64> = vs.iter().map(|&v| pos[v as usize][axis]).collect();
            c.sort_by(f64::total_cmp);
            let plane = c[c.len() / 2];
            if c[c.len() - 1] - c[0] > tolerance {
                // Chained patches drift: only one plane is snapped to.
                continue;
            }
            for &v in vs {
                if pos[v as usize][axis] != plane {
                    pos[v as usize][axis] = plane;
                    moved += 1;
                }
            }
        }
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of squares at z = 0 with rounding noise becomes exactly flat; a tilted
    /// one does not move.
    #[test]
    fn noise_on_a_flat_face_goes() {
        let n = 6;
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let noise = ((i * 7 + j * 3) % 5) as f64 * 1e-15 - 2e-15;
                pos.push([i as f64 / n as f64, j as f64 / n as f64, 0.3 + noise]);
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let moved = snap_flat_faces(&mut pos, &tris, 1e-12);
        assert!(moved > 0);
        let z0 = pos[0][2];
        assert!(pos.iter().all(|p| p[2] == z0), "not flat");
        assert!((z0 - 0.3).abs() < 3e-15);
        let mut tilted: Vec<V3> = pos
            .iter()
            .map(|p| [p[0], p[1], 0.3 + 1e-3 * p[0]])
            .collect();
        let before = tilted.clone();
        assert_eq!(snap_flat_faces(&mut tilted, &tris, 1e-12), 0);
        assert_eq!(tilted, before);
    }
}
