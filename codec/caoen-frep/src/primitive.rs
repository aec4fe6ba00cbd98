//! F-rep primitives: real functions of 3-D space, `f >= 0` inside, with analytic
//! gradients, interval extensions over boxes and bounding boxes. Each primitive sits at
//! a centre with its axis along z; a transform node turns and scales it.
//!
//! | primitive | `f(p)`, `q = p - centre` |
//! |---|---|
//! | sphere | `r^2 - |q|^2` |
//! | box | `min_k (h_k^2 - q_k^2)` (half sides `h`) |
//! | cylinder | `min(r^2 - q_x^2 - q_y^2, (l/2)^2 - q_z^2)` (length `l`) |
//! | cone | `min((r (1 - q_z / l))^2 - q_x^2 - q_y^2, q_z (l - q_z))` (base radius `r` at `q_z = 0`, apex at `l`) |
//! | torus | `r^2 - (sqrt(q_x^2 + q_y^2) - R)^2 - q_z^2` |
//! | half-space | `n . (point - p)` (outward unit normal `n`) |
//! | quadric | `a x^2 + b y^2 + c z^2 + d xy + e yz + f xz + g x + h y + i z + j` (no centre) |
//! | superellipsoid | `1 - ((|q_x/a|^(2/e2) + |q_y/b|^(2/e2))^(e2/e1) + |q_z/c|^(2/e1))` (Barr) |

use std::sync::Arc;

use super::interval::{Aabb, Interval};
use caoen_geometry::vector::sub;
use caoen_surface::tracer::ImplicitTracer;

/// A convex Cao En solid (the implicit form, formula 17) as an F-rep function:
/// `ln(s / f(p))`, positive inside `f < s`. The logarithm makes the function nearly
/// linear across the surface (the sum of exponentials grows exponentially outside).
#[derive(Debug, Clone)]
pub struct CaoEnSolid {
    tracer: Arc<ImplicitTracer>,
}

impl PartialEq for CaoEnSolid {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.tracer, &other.tracer)
    }
}

impl CaoEnSolid {
    /// Wraps a convex solid.
    pub fn new(solid: &caoen_surface::ConvexSolid) -> Self {
        CaoEnSolid {
            tracer: Arc::new(ImplicitTracer::new(solid)),
        }
    }

    /// The solid's implicit form.
    pub fn tracer(&self) -> &ImplicitTracer {
        &self.tracer
    }
}

/// Smallest `f` the logarithm sees (the power and compact blends reach 0 inside).
const TINY: f64 = 1e-300;

/// One primitive.
#[derive(Debug, Clone, PartialEq)]
pub enum Primitive {
    /// A ball.
    Sphere {
        /// Centre.
        centre: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// An axis-aligned box (sharp edges).
    Box {
        /// Centre.
        centre: [f64; 3],
        /// Half the side along each axis.
        half: [f64; 3],
    },
    /// A capped cylinder around the z axis.
    Cylinder {
        /// Centre.
        centre: [f64; 3],
        /// Radius.
        radius: f64,
        /// Length along z.
        length: f64,
    },
    /// A cone along +z: base disc at the centre, apex `length` above it.
    Cone {
        /// Centre of the base.
        centre: [f64; 3],
        /// Base radius.
        radius: f64,
        /// Height.
        length: f64,
    },
    /// A torus around the z axis.
    Torus {
        /// Centre.
        centre: [f64; 3],
        /// Distance from the centre to the tube's centre line.
        major: f64,
        /// Tube radius.
        minor: f64,
    },
    /// Everything behind a plane.
    HalfSpace {
        /// A point of the plane.
        point: [f64; 3],
        /// Outward unit normal.
        normal: [f64; 3],
    },
    /// A general quadric `a x^2 + b y^2 + c z^2 + d xy + e yz + f xz + g x + h y + i z + j`.
    Quadric {
        /// `[a, b, c, d, e, f, g, h, i, j]`.
        coefficients: [f64; 10],
    },
    /// A convex Cao En solid.
    CaoEn(CaoEnSolid),
    /// Barr's superellipsoid.
    Superellipsoid {
        /// Centre.
        centre: [f64; 3],
        /// Semi-axes.
        radii: [f64; 3],
        /// North-south exponent `e1` and east-west exponent `e2` (1, 1: an ellipsoid).
        exponents: [f64; 2],
    },
}

/// `|x|^e` and its derivative, finite at 0 for `e < 1` (clamped slope).
fn abs_pow(x: f64, e: f64) -> (f64, f64) {
    let a = x.abs();
    if a == 0.0 {
        return (0.0, 0.0);
    }
    let v = a.powf(e);
    (v, e * v / a * x.signum())
}

/// Value and gradient of `min(f1, f2)` (the first on ties).
fn min2(a: (f64, [f64; 3]), b: (f64, [f64; 3])) -> (f64, [f64; 3]) {
    if b.0 < a.0 {
        b
    } else {
        a
    }
}

impl Primitive {
    /// Value and gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self {
            Primitive::Sphere { centre, radius } => {
                let q = sub(p, *centre);
                (
                    radius * radius - (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]),
                    q.map(|v| -2.0 * v),
                )
            }
            Primitive::Box { centre, half } => {
                let q = sub(p, *centre);
                let mut best = (f64::INFINITY, [0.0; 3]);
                for k in 0..3 {
                    let mut g = [0.0; 3];
                    g[k] = -2.0 * q[k];
                    best = min2(best, (half[k] * half[k] - q[k] * q[k], g));
                }
                best
            }
            Primitive::Cylinder {
                centre,
                radius,
                length,
            } => {
                let q = sub(p, *centre);
                let h = 0.5 * length;
                min2(
                    (
                        radius * radius - q[0] * q[0] - q[1] * q[1],
                        [-2.0 * q[0], -2.0 * q[1], 0.0],
                    ),
                    (h * h - q[2] * q[2], [0.0, 0.0, -2.0 * q[2]]),
                )
            }
            Primitive::Cone {
                centre,
                radius,
                length,
            } => {
                let q = sub(p, *centre);
                let s = radius * (1.0 - q[2] / length);
                min2(
                    (
                        s * s - q[0] * q[0] - q[1] * q[1],
                        [-2.0 * q[0], -2.0 * q[1], -2.0 * s * radius / length],
                    ),
                    (q[2] * (length - q[2]), [0.0, 0.0, length - 2.0 * q[2]]),
                )
            }
            Primitive::Torus {
                centre,
                major,
                minor,
            } => {
                let q = sub(p, *centre);
                let rho = q[0].hypot(q[1]);
                let d = rho - major;
                let v = minor * minor - d * d - q[2] * q[2];
                // On the axis every direction is as good; the gradient's xy part is 0.
                let k = if rho > 0.0 { -2.0 * d / rho } else { 0.0 };
                (v, [k * q[0], k * q[1], -2.0 * q[2]])
            }
            Primitive::HalfSpace { point, normal } => {
                let q = sub(*point, p);
                (
                    normal[0] * q[0] + normal[1] * q[1] + normal[2] * q[2],
                    normal.map(|v| -v),
                )
            }
            Primitive::Quadric { coefficients: c } => {
                let [x, y, z] = p;
                (
                    c[0] * x * x
                        + c[1] * y * y
                        + c[2] * z * z
                        + c[3] * x * y
                        + c[4] * y * z
                        + c[5] * x * z
                        + c[6] * x
                        + c[7] * y
                        + c[8] * z
                        + c[9],
                    [
                        2.0 * c[0] * x + c[3] * y + c[5] * z + c[6],
                        2.0 * c[1] * y + c[3] * x + c[4] * z + c[7],
                        2.0 * c[2] * z + c[4] * y + c[5] * x + c[8],
                    ],
                )
            }
            Primitive::CaoEn(c) => {
                let (f, g) = c.tracer.value_gradient(p);
                let f = f.max(TINY);
                ((c.tracer.level() / f).ln(), g.map(|v| -v / f))
            }
            Primitive::Superellipsoid {
                centre,
                radii,
                exponents: [e1, e2],
            } => {
                let q = sub(p, *centre);
                let (px, dx) = abs_pow(q[0] / radii[0], 2.0 / e2);
                let (py, dy) = abs_pow(q[1] / radii[1], 2.0 / e2);
                let (pz, dz) = abs_pow(q[2] / radii[2], 2.0 / e1);
                let s = px + py;
                let (w, dw) = abs_pow(s, e2 / e1);
                (
                    1.0 - (w + pz),
                    [-dw * dx / radii[0], -dw * dy / radii[1], -dz / radii[2]],
                )
            }
        }
    }

    /// The range of the function over a box.
    pub fn interval(&self, b: &Aabb) -> Interval {
        let [x, y, z] = b.axes();
        let shift = |c: &[f64; 3]| {
            [
                x - Interval::point(c[0]),
                y - Interval::point(c[1]),
                z - Interval::point(c[2]),
            ]
        };
        let k = Interval::point;
        match self {
            Primitive::Sphere { centre, radius } => {
                let q = shift(centre);
                k(radius * radius) - (q[0].sqr() + q[1].sqr() + q[2].sqr())
            }
            Primitive::Box { centre, half } => {
                let q = shift(centre);
                (0..3)
                    .map(|i| k(half[i] * half[i]) - q[i].sqr())
                    .reduce(Interval::min)
                    .expect("three axes")
            }
            Primitive::Cylinder {
                centre,
                radius,
                length,
            } => {
                let q = shift(centre);
                let h = 0.5 * length;
                (k(radius * radius) - q[0].sqr() - q[1].sqr()).min(k(h * h) - q[2].sqr())
            }
            Primitive::Cone {
                centre,
                radius,
                length,
            } => {
                let q = shift(centre);
                let s = k(*radius) - q[2].scale(radius / length);
                (s.sqr() - q[0].sqr() - q[1].sqr()).min(q[2] * (k(*length) - q[2]))
            }
            Primitive::Torus {
                centre,
                major,
                minor,
            } => {
                let q = shift(centre);
                let rho = (q[0].sqr() + q[1].sqr()).sqrt();
                k(minor * minor) - (rho - k(*major)).sqr() - q[2].sqr()
            }
            Primitive::HalfSpace { point, normal } => {
                let q = shift(point);
                -(q[0].scale(normal[0]) + q[1].scale(normal[1]) + q[2].scale(normal[2]))
            }
            Primitive::Quadric { coefficients: c } => {
                // Each axis's a t^2 + b t as a (t + b / 2a)^2 - b^2 / 4a: exact over
                // the axis's interval (the plain sum of the two terms treats the same
                // t as two independent ones), so a quadric without cross terms, such
                // as a ball patch, is bounded exactly.
                let axis = |t: Interval, a: f64, b: f64| -> Interval {
                    if a == 0.0 {
                        return t.scale(b);
                    }
                    let s = b / (2.0 * a);
                    let exact = (t + k(s)).sqr().scale(a) - k(a * s * s);
                    // Rounding of the rearranged form, kept outside the bound.
                    let pad = 1e-12 * (exact.lo.abs().max(exact.hi.abs()) + (a * s * s).abs());
                    Interval::new(exact.lo - pad, exact.hi + pad)
                };
                axis(x, c[0], c[6])
                    + axis(y, c[1], c[7])
                    + axis(z, c[2], c[8])
                    + (x * y).scale(c[3])
                    + (y * z).scale(c[4])
                    + (x * z).scale(c[5])
                    + k(c[9])
            }
            Primitive::CaoEn(c) => {
                let (lo, hi) = c.tracer.value_bounds(b.lo, b.hi);
                let l = c.tracer.level();
                // ln(s / f) decreases in f.
                Interval::new((l / hi.max(TINY)).ln(), (l / lo.max(TINY)).ln())
            }
            Primitive::Superellipsoid {
                centre,
                radii,
                exponents: [e1, e2],
            } => {
                let q = shift(centre);
                let px = q[0].scale(1.0 / radii[0]).abs_pow(2.0 / e2);
                let py = q[1].scale(1.0 / radii[1]).abs_pow(2.0 / e2);
                let pz = q[2].scale(1.0 / radii[2]).abs_pow(2.0 / e1);
                k(1.0) - ((px + py).abs_pow(e2 / e1) + pz)
            }
        }
    }

    /// A box holding the whole solid, or None if it is unbounded.
    pub fn bounds(&self) -> Option<Aabb> {
        let around =
            |c: [f64; 3], h: [f64; 3]| Some(Aabb::new(sub(c, h), [0, 1, 2].map(|k| c[k] + h[k])));
        match self {
            Primitive::Sphere { centre, radius } => around(*centre, [*radius; 3]),
            Primitive::Box { centre, half } => around(*centre, *half),
            Primitive::Cylinder {
                centre,
                radius,
                length,
            } => around(*centre, [*radius, *radius, 0.5 * length]),
            Primitive::Cone {
                centre,
                radius,
                length,
            } => Some(Aabb::new(
                [centre[0] - radius, centre[1] - radius, centre[2]],
                [centre[0] + radius, centre[1] + radius, centre[2] + length],
            )),
            Primitive::Torus {
                centre,
                major,
                minor,
            } => around(*centre, [major + minor, major + minor, *minor]),
            Primitive::HalfSpace { .. } | Primitive::Quadric { .. } => None,
            Primitive::Superellipsoid { centre, radii, .. } => around(*centre, *radii),
            Primitive::CaoEn(c) => around(c.tracer.centre(), [c.tracer.bounding_radius(); 3]),
        }
    }
}
