//! Ray tracing convex implicit solids (paper sections 6 and 7).
//!
//! Along a ray `o + t d` the implicit function is one-dimensional:
//! `f(t) = sum_i F_i(a_i + b_i t)` with `a_i = w_i . (o - c)`, `b_i = w_i . d`, so each
//! ray first reduces the solid to the pairs `(a_i, b_i)` and every later evaluation
//! costs one blending function per face, no 3-D arithmetic.
//!
//! Two methods find the crossings `f = s`:
//! - [`RayMethod::Paper`], the paper's: clip the ray to the bounding sphere, search
//!   the segment for an inside point by successive halving (midpoint, then quarter
//!   points, ...) until one is found or the spacing drops below a tolerance, then
//!   bisect between the inside point and each end for the two crossings.
//! - [`RayMethod::Fast`]: clip the ray to the polyhedron the solid is known to lie in
//!   (`x . w_i <= sigma`), then use that `f` is convex along the ray (every blending
//!   function here is convex and non-decreasing; power blends need `q >= 1`): the
//!   tangents at the ends of a bracket bound `f` from below, which either certifies a
//!   miss or proposes the next point (a 1-D cutting-plane search), and Newton's method
//!   from the outside converges monotonically onto each crossing because the tangent of
//!   a convex function never overshoots a root. Where convexity does not hold it falls
//!   back to the paper's method. Tests check it finds the paper's crossings.

// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{Blend, ConvexSolid};
use caoen_geometry::ray::Ray;
use caoen_geometry::vector::{dot, sub, unit};

/// How crossings are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RayMethod {
    /// Bounding sphere, halving search for an inside point, bisection (the paper's).
    Paper,
    /// Polyhedron clipping, convex cutting-plane search and monotone Newton steps.
    #[default]
    Fast,
}

/// Where a ray enters and leaves a solid: `t_in <= t_out` (line parameters; either may
/// be negative when the ray starts inside or beyond the solid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossings {
    /// Entry parameter.
    pub t_in: f64,
    /// Exit parameter.
    pub t_out: f64,
}

/// A convex solid prepared for ray tracing.
#[derive(Debug, Clone)]
pub struct ImplicitTracer {
    centre: [f64; 3],
    w: Vec<[f64; 3]>,
    q: Vec<f64>,
    blend: Vec<Blend>,
    level: f64,
    radius: f64,
    /// `x . w_i <= sigma` holds inside the solid (the polyhedron scaled by sigma).
    sigma: f64,
    convex: bool,
    /// Halving stops when the spacing of search points drops below this (world units).
    pub search_tolerance: f64,
    /// Bisection and Newton stop within this distance of a crossing (world units).
    pub root_tolerance: f64,
}

/// Upper bound on cutting-plane and Newton iterations (each converges in far fewer).
const MAX_ITER: usize = 100;
/// Finest subdivision of the paper's inside-point search; with the default tolerance of
/// a 256th of the bounding radius it stops at 512 parts.
const MAX_SEARCH_PARTS: u64 = 1 << 16;

impl ImplicitTracer {
    /// Prepares `solid`; tolerances default to `radius / 256` (inside-point search) and
    /// `radius * 1e-9` (crossings).
    pub fn new(solid: &ConvexSolid) -> Self {
        let net = solid.network();
        let w: Vec<[f64; 3]> = net
            .sources()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let q = net.sharpness().to_vec();
        let blend = net.blends().to_vec();
        let level = solid.level();
        let sigma = blend
            .iter()
            .zip(&q)
            .map(|(b, &q)| b.level_set_s(level, q))
            .fold(1.0f64, f64::max);
        let convex = blend
            .iter()
            .zip(&q)
            .all(|(b, &q)| *b != Blend::Power || q >= 1.0);
        let radius = solid.bounding_radius();
        ImplicitTracer {
            centre: solid.centre(),
            w,
            q,
            blend,
            level,
            radius,
            sigma,
            convex,
            search_tolerance: radius / 256.0,
            root_tolerance: radius * 1e-9,
        }
    }

    /// Radius of the bounding sphere around the centre.
    pub fn bounding_radius(&self) -> f64 {
        self.radius
    }

    /// The centre of the solid.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// `f(x)`, the same value as [`ConvexSolid::value`].
    pub fn value(&self, x: [f64; 3]) -> f64 {
        let r = sub(x, self.centre);
        self.w
            .iter()
            .zip(&self.q)
            .zip(&self.blend)
            .map(|((w, &q), b)| b.value(dot(*w, r), q))
            .sum()
    }

    /// Bounds of `f` over the box `lo..hi`: every blend is non-decreasing in its
    /// argument `w_i . (x - c)`, whose range over a box is exact.
    pub fn value_bounds(&self, lo: [f64; 3], hi: [f64; 3]) -> (f64, f64) {
        let (mut a, mut b) = (0.0, 0.0);
        for ((w, &q), bl) in self.w.iter().zip(&self.q).zip(&self.blend) {
            let (mut smin, mut smax) = (0.0, 0.0);
            for k in 0..3 {
                let (l, h) = (lo[k] - self.centre[k], hi[k] - self.centre[k]);
                smin += (w[k] * l).min(w[k] * h);
                smax += (w[k] * l).max(w[k] * h);
            }
            a += bl.value(smin, q);
            b += bl.value(smax, q);
        }
        (a, b)
    }

    /// The solid's terms `(w_i, q_i, blend_i)` of `f(x) = sum_i F_i(w_i . (x - c))`.
    pub fn terms(&self) -> impl Iterator<Item = ([f64; 3], f64, Blend)> + '_ {
        self.w
            .iter()
            .zip(&self.q)
            .zip(&self.blend)
            .map(|((w, q), b)| (*w, *q, *b))
    }

    /// The level `s` of the surface `f = s`.
    pub fn level(&self) -> f64 {
        self.level
    }

    /// `f(x)` and its gradient.
    pub fn value_gradient(&self, x: [f64; 3]) -> (f64, [f64; 3]) {
        let r = sub(x, self.centre);
        let (mut v, mut g) = (0.0, [0.0; 3]);
        for ((w, &q), b) in self.w.iter().zip(&self.q).zip(&self.blend) {
            let (f, d) = b.value_and_slope(dot(*w, r), q);
            v += f;
            for k in 0..3 {
                g[k] += d * w[k];
            }
        }
        (v, g)
    }

    /// The unit outward normal at `x` (the normalised gradient of `f`).
    pub fn normal(&self, x: [f64; 3]) -> [f64; 3] {
        let r = sub(x, self.centre);
        let mut g = [0.0; 3];
        for ((w, &q), b) in self.w.iter().zip(&self.q).zip(&self.blend) {
            let d = b.value_and_slope(dot(*w, r), q).1;
            for k in 0..3 {
                g[k] += d * w[k];
            }
        }
        unit(g)
    }

    /// Where `ray` crosses the surface, or None if it misses (rays whose inside chord
    /// is shorter than the search tolerance count as misses under the paper's method).
    pub fn crossings(
        &self,
        ray: &Ray,
        method: RayMethod,
        scratch: &mut Vec<[f64; 2]>,
    ) -> Option<Crossings> {
        let oc = sub(ray.origin, self.centre);
        scratch.clear();
        scratch.extend(self.w.iter().map(|w| [dot(*w, oc), dot(*w, ray.dir)]));
        let line = Line {
            ab: scratch,
            q: &self.q,
            blend: &self.blend,
            level: self.level,
        };
        match method {
            RayMethod::Fast if self.convex => self.fast(&line),
            _ => {
                // Bounding sphere: |oc + t d|^2 = R^2 with |d| = 1.
                let b = dot(oc, ray.dir);
                let disc = b * b - (dot(oc, oc) - self.radius * self.radius);
                if !(disc > 0.0) {
                    return None;
                }
                let h = disc.sqrt();
                self.paper(&line, -b - h, -b + h)
            }
        }
    }

    fn paper(&self, line: &Line, t0: f64, t1: f64) -> Option<Crossings> {
        let inside = line.find_inside(t0, t1, self.search_tolerance)?;
        let tol = self.root_tolerance;
        Some(Crossings {
            t_in: line.bisect(t0, inside, tol),
            t_out: line.bisect(t1, inside, tol),
        })
    }

    fn fast(&self, line: &Line) -> Option<Crossings> {
        // Clip to {x : x . w_i <= sigma}: a_i + b_i t <= sigma for every face.
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for &[a, b] in line.ab {
            if b.abs() < 1e-300 {
                if a > self.sigma {
                    return None;
                }
            } else {
                let t = (self.sigma - a) / b;
                if b > 0.0 {
                    hi = hi.min(t);
                } else {
                    lo = lo.max(t);
                }
            }
        }
        if !(lo < hi) || !lo.is_finite() || !hi.is_finite() {
            return None;
        }
        let inside = line.convex_inside(lo, hi, self.root_tolerance)?;
        let tol = self.root_tolerance;
        Some(Crossings {
            t_in: line.newton(lo, inside, tol),
            t_out: line.newton(hi, inside, tol),
        })
    }
}

/// The implicit function restricted to one ray.
struct Line<'a> {
    ab: &'a [[f64; 2]],
    q: &'a [f64],
    blend: &'a [Blend],
    level: f64,
}

impl Line<'_> {
    /// `f(t) - s`.
    #[inline]
    fn g(&self, t: f64) -> f64 {
        let mut f = 0.0;
        for ((ab, &q), b) in self.ab.iter().zip(self.q).zip(self.blend) {
            f += b.value(ab[0] + ab[1] * t, q);
        }
        f - self.level
    }

    /// `(f(t) - s, f'(t))`.
    #[inline]
    fn g_and_slope(&self, t: f64) -> (f64, f64) {
        let (mut f, mut d) = (0.0, 0.0);
        for ((ab, &q), b) in self.ab.iter().zip(self.q).zip(self.blend) {
            let (v, s) = b.value_and_slope(ab[0] + ab[1] * t, q);
            f += v;
            d += s * ab[1];
        }
        (f - self.level, d)
    }

    /// The paper's search: midpoint, then the two quarter points, then the four eighth
    /// points, ... until a point with `f <= s` or a spacing below `tol`.
    fn find_inside(&self, t0: f64, t1: f64, tol: f64) -> Option<f64> {
        let len = t1 - t0;
        let mut parts = 2u64;
        loop {
            let h = len / parts as f64;
            for j in (1..parts).step_by(2) {
                let t = t0 + h * j as f64;
                if self.g(t) <= 0.0 {
                    return Some(t);
                }
            }
            // `!(h >= tol)` also ends a search whose bracket or tolerance is NaN.
            if !(h >= tol) || parts >= MAX_SEARCH_PARTS {
                return None;
            }
            parts *= 2;
        }
    }

    /// Bisection between `outside` (g > 0) and `inside` (g <= 0) down to `tol`.
    fn bisect(&self, mut outside: f64, mut inside: f64, tol: f64) -> f64 {
        // Each step halves the bracket: 2100 steps take any finite f64 bracket to one ulp.
        for _ in 0..2100 {
            if !((outside - inside).abs() > tol) {
                break;
            }
            let mid = 0.5 * (outside + inside);
            if mid == outside || mid == inside {
                break;
            }
            if self.g(mid) <= 0.0 {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        0.5 * (outside + inside)
    }

    /// A point of `[lo, hi]` with `g <= 0`, or None when convexity proves there is none
    /// (or the bracket shrinks below `tol` without finding one).
    fn convex_inside(&self, mut lo: f64, mut hi: f64, tol: f64) -> Option<f64> {
        let (mut glo, mut dlo) = self.g_and_slope(lo);
        if glo <= 0.0 {
            return Some(lo);
        }
        let (mut ghi, mut dhi) = self.g_and_slope(hi);
        if ghi <= 0.0 {
            return Some(hi);
        }
        for _ in 0..MAX_ITER {
            // The minimum lies at an end if f is monotone over the bracket; both ends are
            // outside, so then the ray misses.
            if dlo >= 0.0 || dhi <= 0.0 || hi - lo < tol {
                return None;
            }
            // The tangents at both ends meet below f (convexity): a lower bound.
            let t = (ghi - glo + dlo * lo - dhi * hi) / (dlo - dhi);
            let bound = glo + dlo * (t - lo);
            if bound > 0.0 {
                return None;
            }
            // Stay clear of the ends so the bracket always shrinks by a fair fraction.
            let margin = 0.05 * (hi - lo);
            // max/min rather than clamp: a NaN from overflowing slopes must end the
            // search, not panic.
            let t = t.max(lo + margin).min(hi - margin);
            if !t.is_finite() {
                return None;
            }
            let (g, d) = self.g_and_slope(t);
            if g <= 0.0 {
                return Some(t);
            }
            if d < 0.0 {
                (lo, glo, dlo) = (t, g, d);
            } else {
                (hi, ghi, dhi) = (t, g, d);
            }
        }
        None
    }

    /// The crossing between `outside` (g > 0) and `inside` (g <= 0): Newton steps from
    /// the outside, which for a convex f approach the root monotonically; bisection
    /// guards the rare step that leaves the bracket through rounding.
    fn newton(&self, outside: f64, inside: f64, tol: f64) -> f64 {
        let (mut a, mut b) = (outside, inside);
        let mut t = a;
        for _ in 0..MAX_ITER {
            let (g, d) = self.g_and_slope(t);
            if g <= 0.0 {
                b = t;
            } else {
                a = t;
            }
            let mut next = if d != 0.0 { t - g / d } else { f64::NAN };
            let (lo, hi) = (a.min(b), a.max(b));
            if !(next >= lo && next <= hi) {
                next = 0.5 * (a + b);
            }
            let step = (next - t).abs();
            t = next;
            if step <= tol || (a - b).abs() <= tol {
                break;
            }
        }
        t
    }
}

/// Intersects `ray` with the sphere `(centre, radius)`: the analytic baseline the
/// benchmark compares the implicit tracer with. Returns the line parameters.
pub fn ray_sphere(ray: &Ray, centre: [f64; 3], radius: f64) -> Option<Crossings> {
    let oc = sub(ray.origin, centre);
    let b = dot(oc, ray.dir);
    let disc = b * b - (dot(oc, oc) - radius * radius);
    if !(disc >= 0.0) {
        return None;
    }
    let h = disc.sqrt();
    Some(Crossings {
        t_in: -b - h,
        t_out: -b + h,
    })
}
