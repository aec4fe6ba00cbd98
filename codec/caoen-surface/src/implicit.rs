//! The implicit form for convex solids (paper section 6, formula 17).
//!
//! A convex polyhedron around a centre `c` is `{x : (x - c) . w_i <= 1}` with
//! `w_i = t_i / |t_i|^2`, `t_i` the foot of the perpendicular from `c` to face `i`.
//! With one generator of all-ones weights, `f(x) = sum_i F(x . w_i)`; the solid is
//! `f <= s` for a level `s > 1`. On a face `F = 1`, inside every `F < 1` and tends to 0
//! as `q` grows, outside some `F > 1` grows without bound: larger `q` hugs the
//! polyhedron more tightly.

use super::blend::Blend;
use super::error::{check_finite, check_range, Result, SurfaceError};
use super::network::{KeyPoint, Network};
use caoen_geometry::vector::dot;

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
        check_range(
            || "face count".into(),
            feet.len() as f64,
            1.0,
            MAX_FACES as f64,
        )?;
        check_finite(|| "centre".into(), &centre)?;
        for (k, c) in centre.iter().enumerate() {
            check_range(|| format!("centre[{k}]"), *c, -WORLD_LIMIT, WORLD_LIMIT)?;
        }
        check_range(|| "level s".into(), level, f64::MIN_POSITIVE, MAX_LEVEL)?;
        if level <= 1.0 {
            return Err(SurfaceError::Parameter {
                what: "level s".into(),
                value: level,
                reason: "the inside test f <= s needs s > 1",
            });
        }
        let mut kps = Vec::with_capacity(feet.len());
        for (i, t) in feet.iter().enumerate() {
            check_finite(|| format!("face_feet[{i}]"), t)?;
            let len = dot(*t, *t).sqrt();
            if len.is_nan() || len <= MIN_FOOT {
                return Err(SurfaceError::Parameter {
                    what: format!("face_feet[{i}] length"),
                    value: len,
                    reason: "the centre must lie strictly inside every face, at least 1e-6 from it",
                });
            }
            check_range(
                || format!("face_feet[{i}] length"),
                len,
                MIN_FOOT,
                WORLD_LIMIT,
            )?;
            let t2 = len * len;
            kps.push(KeyPoint::new(
                t.iter().map(|v| v / t2).collect(),
                vec![1.0],
                blend,
                q,
            ));
        }
        let network = Network::new(3, 1, &kps, false)?;
        let circumradius = circumradius(feet).ok_or_else(|| SurfaceError::Parameter {
            what: "face count".into(),
            value: feet.len() as f64,
            reason: "the planes do not enclose a bounded solid",
        })?;
        let min_foot = feet
            .iter()
            .map(|t| dot(*t, *t).sqrt())
            .fold(f64::INFINITY, f64::min);
        let field = FieldRange {
            blend,
            level,
            faces: feet.len() as f64,
            reach: circumradius / min_foot,
        };
        let Some(sigma) = field.scale(q) else {
            return Err(field.sharpness_error(q));
        };
        let bounding_radius = circumradius * sigma;
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

/// Most faces a solid may have: the bounding-radius search visits every triple of faces.
pub const MAX_FACES: usize = 128;
/// Largest coordinate (centre, face distance) of a solid: squares and products of
/// coordinates stay far from overflow, and rays keep their precision.
pub const WORLD_LIMIT: f64 = 1e6;
/// Shortest distance from the centre to a face.
const MIN_FOOT: f64 = 1e-6;
/// Largest level `s`.
pub const MAX_LEVEL: f64 = 1e6;
/// Largest scale `sigma` of the bounding polyhedron over the polyhedron itself.
const MAX_SIGMA: f64 = 1e6;
/// Largest slope `F'` the field may reach inside its bounding sphere, so that sums
/// over faces, gradients and Newton steps stay finite.
const MAX_SLOPE: f64 = 1e250;

/// Where the field of one solid stays finite, as a function of its sharpness.
struct FieldRange {
    blend: Blend,
    level: f64,
    faces: f64,
    /// Largest `x . w_i` on the polyhedron's circumsphere, over `sigma`.
    reach: f64,
}

impl FieldRange {
    /// `sigma` for sharpness `q`, if every value and slope of the field inside the
    /// bounding sphere is finite (with headroom); None otherwise.
    fn scale(&self, q: f64) -> Option<f64> {
        if !(q.is_finite() && q > 0.0) {
            return None;
        }
        // f <= s forces x . w_i <= sigma for every i: the polyhedron scaled by sigma.
        let sigma = self.blend.level_set_s(self.level, q).max(1.0);
        if sigma.is_nan() || sigma > MAX_SIGMA {
            return None;
        }
        let (f, slope) = self.blend.value_and_slope(self.reach * sigma, q);
        (f.is_finite() && slope.abs() * self.faces <= MAX_SLOPE).then_some(sigma)
    }

    /// The error for a sharpness outside the range, naming the range where there is one.
    fn sharpness_error(&self, q: f64) -> SurfaceError {
        // The valid sharpnesses form one interval (sigma falls and the far slope grows
        // with q): find a point inside on a coarse grid, then each end by bisection.
        let ok = |lg: f64| self.scale(lg.exp2()).is_some();
        let Some(inside) = (-60..=60).map(|k| k as f64).find(|&lg| ok(lg)) else {
            return SurfaceError::Parameter {
                what: "level s".into(),
                value: self.level,
                reason: "no sharpness q gives this solid a finite field at this level",
            };
        };
        let edge = |mut good: f64, mut bad: f64| {
            for _ in 0..60 {
                let mid = 0.5 * (good + bad);
                if ok(mid) {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            good.exp2()
        };
        SurfaceError::OutOfRange {
            what: "q".into(),
            value: q,
            lo: edge(inside, -1100.0),
            hi: edge(inside, 1100.0),
        }
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
