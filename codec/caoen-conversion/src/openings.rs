//! Openings for a converted mesh with holes. The closed fit spans each hole with a cap
//! of surface; a depth buffer of the mesh looks through the hole instead. The model
//! with openings is a thin shell of the fitted field (`shell` node) cut open over each
//! boundary loop: the loop's polygon, projected on the plane its area vector is normal
//! to, triangulated, each triangle a polygon patch with a large negative form factor
//! and a band across the plane just deep enough to hold the cap and the shell's inner
//! wall (`docs/conversion.md`). Patches, not set operations: the `perturb` node's index
//! visits only the patches near a point, so the cutters cost nothing elsewhere.

use serde_json::{json, Value};

use super::model::ImplicitField;
use super::polygon_mesh::PolygonMesh;
use caoen_geometry::vector::{cross, dot, sub, unit};

/// The shell's thickness in the unit cube (the fitted field is close to a signed
/// distance near its surface): thinner than a depth-buffer pixel at 256 px (0.0043),
/// so the wall seen edge-on through an opening covers no more than the rim does.
pub const SHELL_THICKNESS: f64 = 0.004;
/// Most corners of a loop's polygon: a loop with more is resampled along its length.
/// Each corner costs a triangle, one node, and the model file holds 10,000.
pub const MAX_CORNERS: usize = 64;
/// How far the cutter reaches beyond the cap and the loop on either side of the plane:
/// the inner wall (one thickness in) and a margin.
const SLAB_MARGIN: f64 = SHELL_THICKNESS + 0.006;
/// How far along the normal the cap is looked for, at least (unit cube).
const CAP_REACH: f64 = 0.05;
/// Triangles are grown by this much along their edges' normals, so neighbours overlap
/// rather than leave a wall along their shared edge.
pub const OVERLAP: f64 = 2e-4;
/// The form factor of a cutting patch: the largest a model file takes. The shell is
/// at most half its thickness (0.002), so `CUT_FACTOR Q^2` cuts through wherever the
/// patch's `Q` exceeds 4.5e-5: everywhere but a sliver along the polygon's outline.
pub const CUT_FACTOR: f64 = -1e6;
/// Triangles with an altitude below this are left out (the patch needs a convex
/// polygon to 1e-9 of its size; a resampled straight stretch of a loop gives slivers).
const MIN_ALTITUDE: f64 = 1e-6;

/// One opening: a triangulated polygon on a plane, extruded over `slab`.
#[derive(Debug, Clone, PartialEq)]
pub struct Opening {
    /// The loop's centroid.
    pub centre: [f64; 3],
    /// The unit normal of the loop's plane (its area vector's direction).
    pub normal: [f64; 3],
    /// The cutter's extent along the normal from the centre, `[lo, hi]`.
    pub slab: [f64; 2],
    /// The polygon's corners, on the plane, counter-clockwise about `normal`.
    pub corners: Vec<[f64; 3]>,
    /// The polygon's triangles, as corner indices, counter-clockwise about `normal`.
    pub triangles: Vec<[usize; 3]>,
    /// The number of mesh edges of the loop.
    pub loop_edges: usize,
}

impl Opening {
    /// Nodes the cutter takes in a model file: one patch a triangle.
    pub fn nodes(&self) -> usize {
        self.triangles.len()
    }

    /// The cutter as patches of a `perturb` node: per triangle a `polygon` patch on the
    /// slab's middle plane, as deep as half the slab, with the form factor
    /// [`CUT_FACTOR`]. Each triangle is grown by [`OVERLAP`] (scaled about its
    /// incentre, which moves every edge out by the same distance), so that along a
    /// shared edge, where one triangle's patch falls to zero, its neighbour's still
    /// cuts.
    pub fn patches(&self) -> Vec<Value> {
        let n = self.normal;
        let mid = 0.5 * (self.slab[0] + self.slab[1]);
        let depth = 0.5 * (self.slab[1] - self.slab[0]);
        self.triangles
            .iter()
            .map(|t| {
                let v = t.map(|i| {
                    let c = self.corners[i];
                    [0, 1, 2].map(|k| c[k] + mid * n[k])
                });
                let side = |i: usize| {
                    let d = sub(v[(i + 2) % 3], v[(i + 1) % 3]);
                    dot(d, d).sqrt()
                };
                let len = [side(0), side(1), side(2)];
                let perimeter = len[0] + len[1] + len[2];
                let incentre =
                    [0, 1, 2].map(|k| (0..3).map(|i| len[i] * v[i][k]).sum::<f64>() / perimeter);
                let area = 0.5 * dot(cross(sub(v[1], v[0]), sub(v[2], v[0])), n);
                let inradius = 2.0 * area / perimeter;
                // A sliver's sharp corner would move far: its edges move out by at most
                // half its inradius instead.
                let grow = 1.0 + (OVERLAP / inradius).min(0.5);
                let vertices =
                    v.map(|p| [0, 1, 2].map(|k| incentre[k] + grow * (p[k] - incentre[k])));
                json!({"polygon": {"vertices": vertices, "depth": depth}, "factor": CUT_FACTOR})
            })
            .collect()
    }
}

/// The openings for `loops` of the unit-cube mesh `unit` (its [`PolygonMesh::boundary_loops`]),
/// the caps looked for in `field`: the longest loops first, as many as `max_nodes`
/// nodes hold. Loops whose polygon has no area are left out.
pub fn openings(
    unit_mesh: &PolygonMesh,
    field: &dyn ImplicitField,
    loops: &[Vec<u32>],
    max_nodes: usize,
) -> Vec<Opening> {
    let mut order: Vec<usize> = (0..loops.len()).collect();
    let length = |l: &Vec<u32>| -> f64 {
        (0..l.len())
            .map(|k| {
                let d = sub(
                    unit_mesh.positions[l[k] as usize],
                    unit_mesh.positions[l[(k + 1) % l.len()] as usize],
                );
                dot(d, d).sqrt()
            })
            .sum()
    };
    order.sort_by(|&a, &b| length(&loops[b]).total_cmp(&length(&loops[a])));
    let mut out = Vec::new();
    let mut nodes = 0;
    for i in order {
        let Some(o) = opening(unit_mesh, field, &loops[i]) else {
            continue;
        };
        if nodes + o.nodes() > max_nodes {
            continue;
        }
        nodes += o.nodes();
        out.push(o);
    }
    out
}

/// The opening over one loop, if its polygon has an area.
fn opening(mesh: &PolygonMesh, field: &dyn ImplicitField, l: &[u32]) -> Option<Opening> {
    if l.len() < 3 {
        return None;
    }
    let pts: Vec<[f64; 3]> = l.iter().map(|&i| mesh.positions[i as usize]).collect();
    let m = pts.len() as f64;
    let centre = [0, 1, 2].map(|k| pts.iter().map(|p| p[k]).sum::<f64>() / m);
    // The area vector (Newell): the plane a bent loop projects onto with the most
    // area, so the projection folds least.
    let mut area = [0.0; 3];
    for k in 0..pts.len() {
        let c = cross(sub(pts[k], centre), sub(pts[(k + 1) % pts.len()], centre));
        area = [0, 1, 2].map(|a| area[a] + c[a]);
    }
    if dot(area, area).sqrt() < 1e-12 {
        return None;
    }
    let normal = unit(area);
    let corners_3d = resample(&pts, MAX_CORNERS);
    let corners: Vec<[f64; 3]> = corners_3d
        .iter()
        .map(|p| {
            let d = dot(sub(*p, centre), normal);
            [0, 1, 2].map(|k| p[k] - d * normal[k])
        })
        .collect();
    let triangles: Vec<[usize; 3]> = triangulate(&corners, normal)?
        .into_iter()
        .filter(|t| {
            let v = t.map(|i| corners[i]);
            let twice_area = dot(cross(sub(v[1], v[0]), sub(v[2], v[0])), normal);
            (0..3).all(|i| {
                let e = sub(v[(i + 1) % 3], v[i]);
                twice_area > MIN_ALTITUDE * dot(e, e).sqrt()
            })
        })
        .collect();
    if triangles.is_empty() {
        return None;
    }
    // The cutter spans the loop's own spread about the plane and the cap the field
    // puts over the hole, found along the normal through each triangle's centre.
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in &pts {
        let d = dot(sub(*p, centre), normal);
        lo = lo.min(d);
        hi = hi.max(d);
    }
    let radius = corners
        .iter()
        .map(|c| dot(sub(*c, centre), sub(*c, centre)).sqrt())
        .fold(0.0, f64::max);
    let reach = CAP_REACH.max(0.5 * radius);
    for t in &triangles {
        let c = [0, 1, 2].map(|k| (corners[t[0]][k] + corners[t[1]][k] + corners[t[2]][k]) / 3.0);
        if let Some(d) = nearest_crossing(field, c, normal, reach) {
            let d = d + dot(sub(c, centre), normal);
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    Some(Opening {
        centre,
        normal,
        slab: [lo - SLAB_MARGIN, hi + SLAB_MARGIN],
        corners,
        triangles,
        loop_edges: l.len(),
    })
}

/// `count` points spaced evenly along the closed polyline `pts` (all of them when it
/// has no more).
fn resample(pts: &[[f64; 3]], count: usize) -> Vec<[f64; 3]> {
    if pts.len() <= count {
        return pts.to_vec();
    }
    let seg: Vec<f64> = (0..pts.len())
        .map(|k| {
            let d = sub(pts[(k + 1) % pts.len()], pts[k]);
            dot(d, d).sqrt()
        })
        .collect();
    let total: f64 = seg.iter().sum();
    let mut out = Vec::with_capacity(count);
    let (mut k, mut before) = (0, 0.0);
    for j in 0..count {
        let s = total * j as f64 / count as f64;
        while k + 1 < pts.len() && before + seg[k] < s {
            before += seg[k];
            k += 1;
        }
        let t = if seg[k] > 0.0 {
            ((s - before) / seg[k]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        out.push([0, 1, 2].map(|c| a[c] + t * (b[c] - a[c])));
    }
    out
}

/// The signed distance along `dir` from `p` to the nearest zero of `field` within
/// `reach` either way, in steps of a fifth of the shell's thickness.
fn nearest_crossing(
    field: &dyn ImplicitField,
    p: [f64; 3],
    dir: [f64; 3],
    reach: f64,
) -> Option<f64> {
    let step = 0.2 * SHELL_THICKNESS;
    let at = |t: f64| field.value([0, 1, 2].map(|k| p[k] + t * dir[k]));
    let f0 = at(0.0);
    if f0 == 0.0 {
        return Some(0.0);
    }
    let (mut prev_up, mut prev_down) = (f0, f0);
    let mut t = step;
    while t <= reach {
        let (up, down) = (at(t), at(-t));
        if up.signum() != prev_up.signum() {
            return Some(t - 0.5 * step);
        }
        if down.signum() != prev_down.signum() {
            return Some(-t + 0.5 * step);
        }
        (prev_up, prev_down) = (up, down);
        t += step;
    }
    None
}

/// Ear clipping of the polygon `corners` (on a plane with unit normal `normal`): its
/// triangles, counter-clockwise about the normal. A polygon that folds over itself
/// (a bent loop's projection) still gives triangles: when no ear is left, the corner
/// with the most convex turn is cut off. None for a polygon without area.
fn triangulate(corners: &[[f64; 3]], normal: [f64; 3]) -> Option<Vec<[usize; 3]>> {
    let u = unit(if normal[0].abs() < 0.9 {
        cross(normal, [1.0, 0.0, 0.0])
    } else {
        cross(normal, [0.0, 1.0, 0.0])
    });
    let w = cross(normal, u);
    let p: Vec<[f64; 2]> = corners.iter().map(|c| [dot(*c, u), dot(*c, w)]).collect();
    let signed_area: f64 = (0..p.len())
        .map(|k| {
            let (a, b) = (p[k], p[(k + 1) % p.len()]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        * 0.5;
    if signed_area.abs() < 1e-10 {
        return None;
    }
    let mut ring: Vec<usize> = (0..p.len()).collect();
    // The triangles' corners run counter-clockwise in (u, w), which is counter-clockwise
    // about the normal (w = n x u).
    if signed_area < 0.0 {
        ring.reverse();
    }
    let turn = |a: usize, b: usize, c: usize| {
        (p[b][0] - p[a][0]) * (p[c][1] - p[a][1]) - (p[b][1] - p[a][1]) * (p[c][0] - p[a][0])
    };
    let mut out = Vec::new();
    while ring.len() > 3 {
        let n = ring.len();
        // Of the ears, the roundest (twice the area over the longest side squared):
        // slivers across the polygon would each reach most of it, and a point visits
        // every patch whose box holds it.
        let ear = (0..n)
            .filter(|&i| {
                let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
                turn(a, b, c) > 0.0
                    && ring.iter().all(|&q| {
                        q == a
                            || q == b
                            || q == c
                            || !(turn(a, b, q) >= 0.0
                                && turn(b, c, q) >= 0.0
                                && turn(c, a, q) >= 0.0)
                    })
            })
            .max_by(|&x, &y| {
                let round = |i: usize| {
                    let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
                    let side = |u: usize, v: usize| {
                        (p[u][0] - p[v][0]).powi(2) + (p[u][1] - p[v][1]).powi(2)
                    };
                    turn(a, b, c) / side(a, b).max(side(b, c)).max(side(c, a))
                };
                round(x).total_cmp(&round(y))
            });
        let i = ear.unwrap_or_else(|| {
            (0..n)
                .max_by(|&x, &y| {
                    let t = |i: usize| turn(ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
                    t(x).total_cmp(&t(y))
                })
                .expect("more than three corners")
        });
        let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
        if turn(a, b, c) > 0.0 {
            out.push([a, b, c]);
        }
        ring.remove(i);
    }
    if turn(ring[0], ring[1], ring[2]) > 0.0 {
        out.push([ring[0], ring[1], ring[2]]);
    }
    (!out.is_empty()).then_some(out)
}

/// The model with openings: `{"perturb": {"shell": fitted}, "patches": cutters}`
/// (the shell alone when there are none).
pub fn shell_with_openings(fitted: Value, openings: &[Opening], thickness: f64) -> Value {
    let shell = json!({"shell": fitted, "thickness": thickness});
    let patches: Vec<Value> = openings.iter().flat_map(Opening::patches).collect();
    if patches.is_empty() {
        return shell;
    }
    json!({"perturb": shell, "patches": patches, "power": 2})
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_frep::Node;

    #[test]
    fn a_conversion_opening_cuts_the_cap_of_a_holed_sphere_and_keeps_the_rest() {
        // A sphere missing its cap above z = 0.8; the field is the closed sphere.
        let ball = PolygonMesh::ellipsoid([0.4; 3], 4);
        let mut holed = ball.clone();
        holed
            .triangles
            .retain(|t| t.iter().any(|&i| ball.positions[i as usize][2] <= 0.32));
        let loops = holed.boundary_loops();
        assert_eq!(loops.len(), 1);
        let sphere = Node::Primitive(caoen_frep::primitive::Primitive::Sphere {
            centre: [0.0; 3],
            radius: 0.4,
        });
        let o = openings(&holed, &sphere, &loops, 10_000);
        assert_eq!(o.len(), 1);
        assert!(o[0].normal[2].abs() > 0.999, "{:?}", o[0].normal);
        assert!(o[0].triangles.len() == o[0].corners.len() - 2);
        let model = shell_with_openings(
            json!({"sphere": {"centre": [0.0, 0.0, 0.0], "radius": 0.4}}),
            &o,
            SHELL_THICKNESS,
        );
        let node = Node::from_json(
            &model,
            "model",
            std::path::Path::new("."),
            &caoen_base::budget::Limits::default(),
        )
        .unwrap();
        assert_eq!(node.count(), 3 + o[0].nodes());
        // Through the cap: no wall (outside everywhere along the axis up to the far
        // side's wall); beside the hole: the wall is there.
        for k in 0..=100 {
            let z = 0.25 + 0.2 * k as f64 / 100.0;
            assert!(node.value([0.0, 0.0, z]) < 0.0, "{z}");
        }
        // Across the whole cap, in the middle of the wall (sphere value r^2 - |p|^2:
        // the wall is 0.005 thick), shared triangle edges included.
        let rim = loops[0]
            .iter()
            .map(|&i| {
                let p = holed.positions[i as usize];
                (p[0] * p[0] + p[1] * p[1]).sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        for i in -40..=40 {
            for j in -40..=40 {
                let (x, y) = (0.95 * rim * i as f64 / 40.0, 0.95 * rim * j as f64 / 40.0);
                if x * x + y * y < (0.95 * rim).powi(2) {
                    let r = 0.4 - 0.0025;
                    let p = [x, y, (r * r - x * x - y * y).sqrt()];
                    assert!(node.value(p) < 0.0, "{p:?} {}", node.value(p));
                }
            }
        }
        assert!(node.value([0.0, 0.0, -0.4 + 0.5 * SHELL_THICKNESS]) > 0.0);
        let side = 0.4 - 0.5 * SHELL_THICKNESS;
        assert!(node.value([side, 0.0, 0.0]) > 0.0);
        // Just below the rim, outside the loop's polygon.
        assert!(node.value([(side * side - 0.09f64).sqrt(), 0.0, 0.3]) > 0.0);
        // Inside the wall's hollow.
        assert!(node.value([0.0, 0.0, 0.0]) < 0.0);
    }

    #[test]
    fn a_conversion_opening_triangulates_a_bent_outline() {
        // A C shape: not convex, so a fan from the centre would leave its polygon.
        let mut c = Vec::new();
        for k in 0..=12 {
            let a = 0.3 + 5.6 * k as f64 / 12.0;
            c.push([a.cos(), a.sin(), 0.0]);
        }
        for k in (0..=12).rev() {
            let a = 0.3 + 5.6 * k as f64 / 12.0;
            c.push([0.6 * a.cos(), 0.6 * a.sin(), 0.0]);
        }
        let t = triangulate(&c, [0.0, 0.0, 1.0]).unwrap();
        assert_eq!(t.len(), c.len() - 2);
        let area: f64 = t
            .iter()
            .map(|t| 0.5 * cross(sub(c[t[1]], c[t[0]]), sub(c[t[2]], c[t[0]]))[2])
            .sum();
        // The polygon's own area: the ring sector's chords (13 outer, 13 inner).
        let sector = |r: f64| 0.5 * r * r * 12.0 * (5.6f64 / 12.0).sin();
        assert!((area - (sector(1.0) - sector(0.6))).abs() < 1e-9, "{area}");
        // No triangle covers the gap of the C (around angle 0).
        for tri in &t {
            let cen = [0, 1].map(|k| (c[tri[0]][k] + c[tri[1]][k] + c[tri[2]][k]) / 3.0);
            let a = cen[1].atan2(cen[0]);
            assert!(a >= 0.29 || a <= 5.9 - std::f64::consts::TAU, "{cen:?}");
        }
    }
}
