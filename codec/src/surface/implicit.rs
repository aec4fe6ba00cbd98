//! The implicit form for convex solids (paper section 6, formula 17).
//!
//! A convex polyhedron around a centre `c` is `{x : (x - c) . w_i <= 1}` with
//! `w_i = t_i / |t_i|^2`, `t_i` the foot of the perpendicular from `c` to face `i`.
//! With one generator of all-ones weights, `f(x) = sum_i F(x . w_i)`; the solid is
//! `f <= s` for a level `s > 1`. On a face `F = 1`, inside every `F < 1` and tends to 0
//! as `q` grows, outside some `F > 1` grows without bound: larger `q` hugs the
//! polyhedron more tightly.

use super::blend::Blend;
use super::error::{check_finite, Result, SurfaceError};
use super::network::{KeyPoint, Network};

/// A half-space `normal . x <= offset`, `normal` of any non-zero length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Outward normal.
    pub normal: [f64; 3],
    /// Offset along the normal (in units of `|normal|`).
    pub offset: f64,
}

/// A convex solid in implicit form.
#[derive(Debug, Clone)]
pub struct ConvexSolid {
    network: Network,
    centre: [f64; 3],
    level: f64,
    feet: Vec<[f64; 3]>,
    bounding_radius: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl ConvexSolid {
    /// Builds the solid from the face feet `t_i` (relative to `centre`).
    pub fn from_face_feet(
        feet: &[[f64; 3]],
        centre: [f64; 3],
        blend: Blend,
        q: f64,
        level: f64,
    ) -> Result<Self> {
        if feet.is_empty() {
            return Err(SurfaceError::Empty);
        }
        check_finite(|| "centre".into(), &centre)?;
        if !(level > 1.0 && level.is_finite()) {
            return Err(SurfaceError::Parameter {
                what: "level s".into(),
                value: level,
                reason: "the inside test f <= s needs s > 1",
            });
        }
        let mut kps = Vec::with_capacity(feet.len());
        for (i, t) in feet.iter().enumerate() {
            check_finite(|| format!("face_feet[{i}]"), t)?;
            let t2 = dot(*t, *t);
            if t2.is_nan() || t2 <= 1e-24 {
                return Err(SurfaceError::Parameter {
                    what: format!("face_feet[{i}] length"),
                    value: t2.sqrt(),
                    reason: "the centre must lie strictly inside every face",
                });
            }
            kps.push(KeyPoint::new(
                t.iter().map(|v| v / t2).collect(),
                vec![1.0],
                blend,
                q,
            ));
        }
        let network = Network::new(3, 1, &kps, false)?;
        // f <= s forces x . w_i <= sigma for every i: the polyhedron scaled by sigma.
        let sigma = blend.level_set_s(level, q).max(1.0);
        let bounding_radius = circumradius(feet).ok_or_else(|| SurfaceError::Parameter {
            what: "face count".into(),
            value: feet.len() as f64,
            reason: "the planes do not enclose a bounded solid",
        })? * sigma;
        Ok(ConvexSolid {
            network,
            centre,
            level,
            feet: feet.to_vec(),
            bounding_radius,
        })
    }

    /// Builds the solid from half-spaces `normal . x <= offset`; `centre` must be inside.
    pub fn from_planes(
        planes: &[Plane],
        centre: [f64; 3],
        blend: Blend,
        q: f64,
        level: f64,
    ) -> Result<Self> {
        let mut feet = Vec::with_capacity(planes.len());
        for (i, pl) in planes.iter().enumerate() {
            let n2 = dot(pl.normal, pl.normal);
            let d = pl.offset - dot(pl.normal, centre);
            if n2.is_nan() || n2 <= 0.0 || d.is_nan() || d <= 0.0 {
                return Err(SurfaceError::Parameter {
                    what: format!("planes[{i}] distance from centre"),
                    value: d,
                    reason: "the centre must lie strictly inside every plane, normals non-zero",
                });
            }
            let s = d / n2;
            feet.push([pl.normal[0] * s, pl.normal[1] * s, pl.normal[2] * s]);
        }
        Self::from_face_feet(&feet, centre, blend, q, level)
    }

    /// `f(x) = sum_i F(w_i . (x - c))`.
    pub fn value(&self, x: [f64; 3]) -> f64 {
        let r = [
            x[0] - self.centre[0],
            x[1] - self.centre[1],
            x[2] - self.centre[2],
        ];
        // Non-finite x only arises from caller bugs; they read as outside.
        self.network.eval(&r).map(|y| y[0]).unwrap_or(f64::INFINITY)
    }

    /// `f(x)` and its gradient (exact, formula 12).
    pub fn value_and_gradient(&self, x: [f64; 3]) -> Result<(f64, [f64; 3])> {
        let r = [
            x[0] - self.centre[0],
            x[1] - self.centre[1],
            x[2] - self.centre[2],
        ];
        let (y, j) = self.network.eval_with_jacobian(&r)?;
        Ok((y[0], [j[0], j[1], j[2]]))
    }

    /// Whether `x` is inside (or on) the solid: `f(x) <= s`.
    pub fn contains(&self, x: [f64; 3]) -> bool {
        self.value(x) <= self.level
    }

    /// The level `s` of the surface `f = s`.
    pub fn level(&self) -> f64 {
        self.level
    }

    /// The centre the face feet are measured from.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// The face feet `t_i`.
    pub fn face_feet(&self) -> &[[f64; 3]] {
        &self.feet
    }

    /// Radius around the centre of a sphere that contains the whole solid.
    pub fn bounding_radius(&self) -> f64 {
        self.bounding_radius
    }

    /// The polyhedron's own extent along unit direction `d` from the centre
    /// (distance to its boundary), or infinity if unbounded that way.
    pub fn polyhedron_extent(&self, d: [f64; 3]) -> f64 {
        self.feet
            .iter()
            .filter_map(|t| {
                let t2 = dot(*t, *t);
                let c = dot(*t, d) / t2;
                (c > 0.0).then(|| 1.0 / c)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The underlying one-generator network.
    pub fn network(&self) -> &Network {
        &self.network
    }
}

/// Largest distance from the origin to a vertex of `{x : x . t_i <= |t_i|^2}`, or None
/// if the region is unbounded. Vertices are triple-plane intersections that satisfy
/// every constraint; the region is bounded iff every direction hits some face, checked
/// by the vertices covering the origin's surroundings (a bounded polytope has one).
fn circumradius(feet: &[[f64; 3]]) -> Option<f64> {
    let n = feet.len();
    if n < 4 {
        return None;
    }
    let rhs: Vec<f64> = feet.iter().map(|t| dot(*t, *t)).collect();
    let mut best: f64 = 0.0;
    let mut found = false;
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                let (ta, tb, tc) = (feet[a], feet[b], feet[c]);
                let bxc = [
                    tb[1] * tc[2] - tb[2] * tc[1],
                    tb[2] * tc[0] - tb[0] * tc[2],
                    tb[0] * tc[1] - tb[1] * tc[0],
                ];
                let det = dot(ta, bxc);
                if det.abs() < 1e-12 {
                    continue;
                }
                let cxa = [
                    tc[1] * ta[2] - tc[2] * ta[1],
                    tc[2] * ta[0] - tc[0] * ta[2],
                    tc[0] * ta[1] - tc[1] * ta[0],
                ];
                let axb = [
                    ta[1] * tb[2] - ta[2] * tb[1],
                    ta[2] * tb[0] - ta[0] * tb[2],
                    ta[0] * tb[1] - ta[1] * tb[0],
                ];
                let v: Vec<f64> = (0..3)
                    .map(|k| (rhs[a] * bxc[k] + rhs[b] * cxa[k] + rhs[c] * axb[k]) / det)
                    .collect();
                let v = [v[0], v[1], v[2]];
                if feet
                    .iter()
                    .zip(&rhs)
                    .all(|(t, r)| dot(*t, v) <= r * (1.0 + 1e-9))
                {
                    found = true;
                    best = best.max(dot(v, v).sqrt());
                }
            }
        }
    }
    // Unboundedness: some direction d with t_i . d <= 0 for all i. Sample the sphere
    // densely enough to catch any open cone of directions the vertices miss.
    let bounded = found
        && (0..2000).all(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / 2000.0;
            let r = (1.0 - z * z).sqrt();
            let phi = k as f64 * 2.399_963_229_728_653;
            let d = [r * phi.cos(), r * phi.sin(), z];
            feet.iter().any(|t| dot(*t, d) > 0.0)
        });
    bounded.then_some(best)
}
